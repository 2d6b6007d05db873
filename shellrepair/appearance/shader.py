"""The aged-metal shader: the full BRDF, its fast evaluation and the model choice.

:func:`shade_reference` composes the material model term by term from
:mod:`shellrepair.appearance.reflectance` (the specification); :class:`MaterialShader`
evaluates the same thing quickly from per-material lookup tables;
:func:`choose_model` picks the simplest adequate model (specular only, the
local layered form, or the dipole) at a pixel footprint.  The model itself
is described in :mod:`shellrepair.appearance.materials`::

    f = (1 - c) [g f_TS,gold + (1 - g) f_TS,bronze]
        + c [f_TS,patina + rho_dt(i) rho_dt(o) R_eff(c, d) / pi]

References
----------
.. [1] Yamamoto, Shiba, Okada, "A Reflection Model for Representation of
   Gilt Bronze Statues with Aging Degradation", section 4.
.. [2] H. W. Jensen et al., "A Practical Model for Subsurface Light
   Transport", SIGGRAPH 2001 (the dipole used by :func:`choose_model`).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from shellrepair.appearance import reflectance as sh
from shellrepair.appearance.materials import get_material, layer_thicknesses, substrate_reflectance, surface_params
from shellrepair.appearance.reflectance import albedo as _albedo
from shellrepair.appearance.reflectance import dispatch

__all__ = ["shade_reference", "MaterialShader", "ModelChoice", "choose_model", "model_switch_footprint_um", "warm_up"]


def _km_of_coverage(c, mat, crust=0.0):
    c = np.asarray(c, dtype=np.float64)
    Rg = substrate_reflectance(mat)
    X = layer_thicknesses(c, mat)
    layers = [[np.asarray(L[0].K), np.asarray(L[0].S), x[..., None]] for L, x in zip(mat.layers, X)]
    if mat.crust is not None:
        # eq 7: the dark deposit mixed into the outermost layer
        p = (np.clip(np.asarray(crust, dtype=np.float64), 0.0, 1.0) * mat.crust[1])[..., None]
        top = layers[-1]
        top[0] = (1.0 - p) * top[0] + p * np.asarray(mat.crust[0].K)
        top[1] = (1.0 - p) * top[1] + p * np.asarray(mat.crust[0].S)
    return sh.km_layers([tuple(L) for L in layers], Rg)


def shade_reference(wi, wo, n, coverage, material, gild=1.0, crust=0.0):
    """The full aged-metal BRDF, composed term by term from :mod:`shading`.

    Parameters
    ----------
    wi, wo, n : (..., 3) float arrays
        Unit light direction, view direction and normal.
    coverage : (...) float array in [0, 1]
    material : Material or str
    gild : (...) float array in [0, 1], optional
        Fraction of the uncorroded area where the exposed metal (gold leaf)
        remains; the rest shows the substrate (bronze).  1 by default.
    crust : (...) float array in [0, 1], optional
        Dark deposit on the patina (sheltered from rain), as a fraction of
        the material's largest proportion (eq 7 mixing).  0 by default.

    Returns
    -------
    f : (..., 3) float64 array
        BRDF per RGB channel (1/sr).

    Notes
    -----
    See the module docstring; this is the specification that
    :class:`MaterialShader` reproduces quickly.
    """
    mat = get_material(material)
    c = np.clip(np.asarray(coverage, dtype=np.float64), 0.0, 1.0)
    g = np.clip(np.asarray(gild, dtype=np.float64), 0.0, 1.0)
    m, _ = surface_params(c, mat)
    gold = sh.torrance_sparrow_conductor(wi, wo, n, m, np.asarray(mat.exposed.n),
                                         np.asarray(mat.exposed.k))
    bare = sh.torrance_sparrow_conductor(wi, wo, n, m, np.asarray(mat.substrate.n),
                                         np.asarray(mat.substrate.k))
    metal = g[..., None] * gold + (1.0 - g)[..., None] * bare
    if not mat.corrodes:
        return metal
    R_km = _km_of_coverage(c, mat, crust)
    rust = sh.local_brdf(wi, wo, n, m, mat.eta_top, R_km)
    return (1.0 - c)[..., None] * metal + c[..., None] * rust


class MaterialShader:
    """Precomputed, fast evaluation of :func:`shade_reference`.

    Parameters
    ----------
    material : Material or str
    n_lut : int, optional
        Nodes of the 1-D lookup tables (Fresnel in o.h, R_KM in c).

    Notes
    -----
    For one material every nonlinear factor except the Beckmann exponent is
    a function of one or two bounded scalars, so it is tabulated once:

    - conductor (gold, bronze) and dielectric Fresnel as functions of o.h
      (1-D),
    - R_eff = R_KM (1 - r_i) / (rho_bar (1 - r_i R_KM)) as a function of the
      coverage c (1-D; m and X follow from c),
    - rho_dt as a function of (sqrt(cos theta), c) (2-D), sliced from the
      shared rho_dt table at this material's eta.

    Evaluation works on chunks of :attr:`chunk` points so the temporaries
    stay in cache.  Agreement with :func:`shade_reference` is tested and
    measured in eval/bench_shading.py.
    """

    chunk = 32768

    def __init__(self, material, *, n_lut=2049):
        self.material = mat = get_material(material)
        self.n_lut = int(n_lut)
        x = np.linspace(0.0, 1.0, self.n_lut)
        self._F_metal = sh.fresnel_conductor(x[:, None], np.asarray(mat.exposed.n),
                                             np.asarray(mat.exposed.k))  # (L, 3)
        self._dF_metal = np.diff(self._F_metal, axis=0, append=self._F_metal[-1:])
        self._F_bare = sh.fresnel_conductor(x[:, None], np.asarray(mat.substrate.n),
                                            np.asarray(mat.substrate.k))  # (L, 3)
        self._dF_bare = np.diff(self._F_bare, axis=0, append=self._F_bare[-1:])
        self.corrodes = mat.corrodes
        if self.corrodes:
            self._F_top = sh.fresnel_dielectric(x, mat.eta_top)
            self._dF_top = np.diff(self._F_top, append=self._F_top[-1])
            # R_eff on a (c, crust) grid; c nodes 1/1024 apart (the layer
            # schedule's kinks at c = 0.25 and 0.3 fall on or next to nodes)
            self._nrc = 1025
            self._nrd = 65 if mat.crust is not None else 2
            xc = np.linspace(0.0, 1.0, self._nrc)[:, None]
            xd = np.linspace(0.0, 1.0, self._nrd)[None, :]
            R = _km_of_coverage(xc, mat, xd)  # (Nc, Nd, 3)
            m_x, _ = surface_params(xc, mat)
            r_i = sh.internal_reflectance(m_x, mat.eta_top)[..., None]
            rbar_x = sh.mean_transmittance(m_x, mat.eta_top)[..., None]
            # internal reflection at the interface folded in (layered_diffuse)
            Reff = R * (1.0 - r_i) / (np.maximum(rbar_x, 1e-300) * (1.0 - r_i * R))
            self._R_eff = Reff
            self._R4 = np.ascontiguousarray(np.concatenate(
                [Reff[:-1, :-1], Reff[:-1, 1:], Reff[1:, :-1], Reff[1:, 1:]], axis=-1
            ).reshape(-1, 12))
            table = sh.rho_dt_table()
            sl = table.slice_eta(mat.eta_top)  # (Nu, Nm)
            self._nc = 257
            cn = np.linspace(0.0, 1.0, self._nc)
            m_c, _ = surface_params(cn, mat)
            lm = np.log(np.maximum(m_c, sh.M_MIN))
            L = table.log_m
            j, w = _albedo._axis_index(lm, L[0], L[1] - L[0], L.size)
            self._rho_tab = (1.0 - w)[None, :] * sl[:, j] + w[None, :] * sl[:, j + 1]  # (Nu, Nc)
            self._nu = table.u.size
            # bilinear cells packed as (cell, 4 corners): one gather per lookup
            R4 = np.stack([self._rho_tab[:-1, :-1], self._rho_tab[:-1, 1:],
                           self._rho_tab[1:, :-1], self._rho_tab[1:, 1:]], axis=-1)
            self._rho4 = np.ascontiguousarray(R4.reshape(-1, 4))
            # rho_bar(c) = 2 int_0^1 rho_dt(mu) mu dmu, mu = u^2 -> 4 int rho u^3 du
            uu = table.u
            self._rho_bar = sh.u_mean_weights(uu) @ self._rho_tab  # exact for the interpolant
        self._m0 = mat.m_exposed
        self._dm = mat.m_rust - mat.m_exposed
        # value and forward difference side by side: one gather per lookup
        Ft = self._F_top if self.corrodes else np.zeros(self.n_lut)
        dFt = self._dF_top if self.corrodes else np.zeros(self.n_lut)
        self._Fpack = np.ascontiguousarray(
            np.concatenate([self._F_metal, self._F_bare, Ft[:, None],
                            self._dF_metal, self._dF_bare, dFt[:, None]], axis=1))

    def _R_of(self, c, d):
        """Bilinear R_eff(c, crust), one gather of the 4 corners."""
        fc = c * (self._nrc - 1)
        i = np.minimum(fc.astype(np.intp), self._nrc - 2)
        a = (fc - i)[:, None]
        fd = np.clip(d, 0.0, 1.0) * (self._nrd - 1)
        j = np.minimum(fd.astype(np.intp), self._nrd - 2)
        b = (fd - j)[:, None]
        g = np.take(self._R4, i * (self._nrd - 1) + j, axis=0)
        r0 = g[:, 0:3] + b * (g[:, 3:6] - g[:, 0:3])
        r1 = g[:, 6:9] + b * (g[:, 9:12] - g[:, 6:9])
        return r0 + a * (r1 - r0)

    def _lut(self, T, dT, x):
        f = x * (self.n_lut - 1)
        i = f.astype(np.intp)
        np.minimum(i, self.n_lut - 1, out=i)
        w = f - i
        if T.ndim == 2:
            return T[i] + w[:, None] * dT[i]
        return T[i] + w * dT[i]

    def _packed(self, P, x, half):
        """Linear interpolation in a (L, 2 half) [values | differences] table."""
        f = x * (self.n_lut - 1)
        i = f.astype(np.intp)
        np.minimum(i, self.n_lut - 1, out=i)
        w = (f - i)[:, None]
        g = np.take(P, i, axis=0)
        return g[:, :half] + w * g[:, half:]

    def _rho(self, u, c):
        fu = u * (self._nu - 1)
        i = np.minimum(fu.astype(np.intp), self._nu - 2)
        a = fu - i
        fc = c * (self._nc - 1)
        j = np.minimum(fc.astype(np.intp), self._nc - 2)
        b = fc - j
        g = np.take(self._rho4, i * (self._nc - 1) + j, axis=0)
        r0 = g[:, 0] + b * (g[:, 1] - g[:, 0])
        r1 = g[:, 2] + b * (g[:, 3] - g[:, 2])
        return r0 + a * (r1 - r0)

    def __call__(self, wi, wo, n, coverage, gild=1.0, crust=0.0, *, parts=False):
        """Evaluate the BRDF.

        Parameters
        ----------
        wi, wo, n : (..., 3) float arrays (broadcasting)
        coverage : (...) float array in [0, 1]
        gild, crust : (...) float arrays in [0, 1], optional
            Gilding fraction of the uncorroded area and dark crust on the
            patina (see :func:`shade_reference`).
        parts : bool, optional
            Return the specular and diffuse parts separately.

        Returns
        -------
        f : (..., 3) float64 array
            Or ``(f_spec, f_diffuse)`` when ``parts`` is true.
        """
        K = dispatch.kernels("shader")
        if K is None:
            return self.evaluate_numpy(wi, wo, n, coverage, gild, crust, parts=parts)
        wi, wo, n, c, g, dd = dispatch.as_float(wi, wo, n, coverage, gild, crust)
        shape = np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1], n.shape[:-1], c.shape, g.shape,
                                    dd.shape)
        P = int(np.prod(shape))
        spec = np.empty((P, 3), dtype=np.float64)
        diff = np.empty((P, 3), dtype=np.float64) if parts else spec
        if P:
            vec = [dispatch.per_point_rows(a, shape, P) for a in (wi, wo, n)]
            par = [dispatch.per_point(a, shape, P) for a in (c, g, dd)]
            dispatch.run(K.material_shader, P, *vec, *par, *self._kernel_tables, spec, diff, not parts)
        if parts:
            return spec.reshape(shape + (3,)), diff.reshape(shape + (3,))
        return spec.reshape(shape + (3,))

    def evaluate_numpy(self, wi, wo, n, coverage, gild=1.0, crust=0.0, *, parts=False):
        """The NumPy version of :meth:`__call__`: the oracle of its compiled kernel.

        The path :meth:`__call__` takes when the kernels are off
        (``SHELLREPAIR_NO_NUMBA=1``; Numba missing), so it then returns
        these arrays bit for bit; with the kernels on the two agree within
        ``1e-11`` relative (tests/test_reflectance_kernels.py).  Evaluates
        chunks of :attr:`chunk` points.  Parameters and returns as
        :meth:`__call__`.
        """
        wi, wo, n = (np.asarray(a, dtype=np.float64) for a in (wi, wo, n))
        c = np.asarray(coverage, dtype=np.float64)
        g = np.asarray(gild, dtype=np.float64)
        dd = np.asarray(crust, dtype=np.float64)
        shape = np.broadcast_shapes(wi.shape[:-1], wo.shape[:-1], n.shape[:-1], c.shape, g.shape,
                                    dd.shape)
        P = int(np.prod(shape))
        wi = np.broadcast_to(wi, shape + (3,)).reshape(P, 3)
        wo = np.broadcast_to(wo, shape + (3,)).reshape(P, 3)
        n = np.broadcast_to(n, shape + (3,)).reshape(P, 3)
        c = np.broadcast_to(c, shape).reshape(P)
        g = np.broadcast_to(g, shape).reshape(P)
        dd = np.broadcast_to(dd, shape).reshape(P)
        spec = np.empty((P, 3), dtype=np.float64)
        diff = np.zeros((P, 3), dtype=np.float64) if parts else None
        for s in range(0, P, self.chunk):
            sl = slice(s, s + self.chunk)
            fs, fd = self._eval(wi[sl], wo[sl], n[sl], c[sl], g[sl], dd[sl])
            if parts:
                spec[sl] = fs
                if fd is not None:
                    diff[sl] = fd
            else:
                spec[sl] = fs if fd is None else fs + fd
        if parts:
            return spec.reshape(shape + (3,)), diff.reshape(shape + (3,))
        return spec.reshape(shape + (3,))

    @functools.cached_property
    def _kernel_tables(self):
        """The lookup tables as ``shader_kernels.material_shader`` takes them."""
        if self.corrodes:
            rho4, nu, nc, R4, nrc, nrd = self._rho4, self._nu, self._nc, self._R4, self._nrc, self._nrd
        else:  # never read
            rho4, nu, nc, R4, nrc, nrd = np.zeros((1, 4)), 2, 2, np.zeros((1, 12)), 2, 2
        return (float(self._m0), float(self._dm), int(self.n_lut), np.ascontiguousarray(self._Fpack),
                bool(self.corrodes), np.ascontiguousarray(rho4), int(nu), int(nc), np.ascontiguousarray(R4),
                int(nrc), int(nrd))

    def ambient(self, cos_o, coverage, gild=1.0, crust=0.0):
        """Reflectance weights under a distant environment.

        Parameters
        ----------
        cos_o : (P,) float array
            Cosine of the view direction with the normal.
        coverage : (P,) float array
        gild, crust : (P,) float arrays or floats, optional

        Returns
        -------
        (w_spec, w_diffuse) : tuple of (P,3) float64 arrays
            Multiply w_spec by the environment radiance in the mirror
            direction and w_diffuse by the radiance around the normal.

        Notes
        -----
        The dielectric lobe's directional albedo is exactly
        ``1 - rho_dt(o)``; the diffuse albedo under uniform light is
        ``rho_dt(o) R_eff rho_bar`` with ``rho_bar = 2 int rho_dt(mu) mu dmu``
        (= ``rho_dt(o) R_KM (1 - r_i) / (1 - r_i R_KM)``).
        The conductor lobe is approximated by F(n.o) (roughness ignored).
        """
        no = np.clip(np.asarray(cos_o, dtype=np.float64), 0.0, 1.0)
        c = np.clip(np.asarray(coverage, dtype=np.float64), 0.0, 1.0)
        g = np.clip(np.asarray(gild, dtype=np.float64), 0.0, 1.0)
        g = np.broadcast_to(g, no.shape)[:, None]
        Fm = (g * self._lut(self._F_metal, self._dF_metal, no)
              + (1.0 - g) * self._lut(self._F_bare, self._dF_bare, no))
        if not self.corrodes:
            return Fm, np.zeros_like(Fm)
        rho_o = self._rho(np.sqrt(no), c)
        rbar = np.interp(c, np.linspace(0.0, 1.0, self._nc), self._rho_bar)
        R = self._R_of(c, np.broadcast_to(np.asarray(crust, dtype=np.float64), c.shape))
        w_spec = (1.0 - c)[:, None] * Fm + (c * (1.0 - rho_o))[:, None]
        w_diff = (c * rho_o * rbar)[:, None] * R
        return w_spec, w_diff

    def _eval(self, wi, wo, n, c, gild, crust):
        # For unit wi, wo: |wi + wo|^2 = 2 (1 + wi.wo), o.h = sqrt((1 + wi.wo) / 2)
        # and n.h = (n.i + n.o) / |wi + wo|: three dot products, no h array.
        c = np.clip(c, 0.0, 1.0)
        ni = np.einsum("ij,ij->i", n, wi)
        no = np.einsum("ij,ij->i", n, wo)
        io = np.einsum("ij,ij->i", wi, wo)
        hl2 = np.maximum(2.0 + 2.0 * io, 0.0)
        valid = (ni > sh.COS_EPS) & (no > sh.COS_EPS) & (hl2 > sh.COS_EPS * sh.COS_EPS)
        nis = np.where(valid, ni, 1.0)
        nos = np.where(valid, no, 1.0)
        inv_hl = 1.0 / np.sqrt(np.where(valid, hl2, 1.0))
        nh = np.minimum((nis + nos) * inv_hl, 1.0)
        nfi = np.maximum(nis, sh.MU_FLOOR)  # grazing guard of eq 8's denominator
        nfo = np.maximum(nos, sh.MU_FLOOR)
        oh = np.minimum(0.5 * np.where(valid, hl2, 1.0) * inv_hl, 1.0)
        m = np.maximum(self._m0 + self._dm * c, sh.M_MIN)
        inv_m2 = 1.0 / (m * m)
        # Beckmann D (eq 13, normalised)
        nh2 = nh * nh
        D = np.exp((nh2 - 1.0) / nh2 * inv_m2) * inv_m2 / (np.pi * nh2 * nh2)
        # G / (4 ni no)  (eq 11 over the denominator of eq 8)
        g = np.minimum(1.0 / (nfi * nfo), 2.0 * nh / (np.maximum(oh, sh.COS_EPS) * np.maximum(nfi, nfo)))
        DG4 = np.where(valid, 0.25 * D * g, 0.0)
        Fmt = self._packed(self._Fpack, oh, 7)  # gold (3), bronze (3) and dielectric (1) Fresnel
        gl = np.clip(gild, 0.0, 1.0)[:, None]
        Fmetal = gl * Fmt[:, :3] + (1.0 - gl) * Fmt[:, 3:6]
        if not self.corrodes:
            return DG4[:, None] * Fmetal, None
        spec = DG4[:, None] * ((1.0 - c)[:, None] * Fmetal + (c * Fmt[:, 6])[:, None])
        fc = c * (self._nc - 1)
        j = np.minimum(fc.astype(np.intp), self._nc - 2)
        b = fc - j
        rho = self._rho_cj(np.sqrt(nis), j, b) * self._rho_cj(np.sqrt(nos), j, b)
        diff = np.where(valid, c * rho * (1.0 / np.pi), 0.0)
        R = self._R_of(c, crust)
        return spec, diff[:, None] * R

    def _rho_cj(self, u, j, b):
        """Bilinear rho_dt lookup with the coverage cell (j, b) precomputed."""
        fu = u * (self._nu - 1)
        i = np.minimum(fu.astype(np.intp), self._nu - 2)
        a = fu - i
        g = np.take(self._rho4, i * (self._nc - 1) + j, axis=0)
        r0 = g[:, 0] + b * (g[:, 1] - g[:, 0])
        r1 = g[:, 2] + b * (g[:, 3] - g[:, 2])
        return r0 + a * (r1 - r0)


# --------------------------------------------------------------------------
# Model choice
# --------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class ModelChoice:
    """The simplest adequate reflectance model for a footprint.

    Attributes
    ----------
    model : str
        ``"specular"`` (opaque conductor, Torrance-Sparrow only),
        ``"local"`` (f_spec + rho_dt R_KM rho_dt / pi) or ``"dipole"``
        (the diffuse term spread by the dipole profile).
    error_estimate : float
        For ``local``: the fraction of the diffusely re-emitted light that
        leaves the surface farther than half a footprint from where it
        entered (what the local form puts in the wrong pixel).  For
        ``dipole``: the same fraction, i.e. the error the local form would
        have made.  0 for ``specular``.
    diffusion_length_um : float
        ``1 / sigma_tr`` of the corrosion stack (largest over channels).
    footprint_um : float
    reason : str
    """

    model: str
    error_estimate: float
    diffusion_length_um: float
    footprint_um: float
    reason: str


def choose_model(footprint_um, material, *, coverage=1.0, tol=0.01):
    """Pick the simplest model adequate at a pixel footprint.

    Parameters
    ----------
    footprint_um : float
        Width of one pixel on the surface, in micrometres.
    material : Material or str
    coverage : float, optional
        Rust coverage at which to judge (the worst case, 1, by default).
    tol : float, optional
        Largest acceptable fraction of misplaced diffuse light.

    Returns
    -------
    ModelChoice

    Notes
    -----
    The corrosion stack's K, S are mixed by thickness (eq 7) and mapped to
    sigma_a, sigma_s' (:func:`shellrepair.appearance.reflectance.km_to_transport`); the
    dipole profile's radial integral (:func:`shellrepair.appearance.reflectance.dipole_tail_fraction`)
    gives the fraction of light exiting beyond half the footprint.  If it
    is at most ``tol`` the local form of eq 2 is adequate.

    Examples
    --------
    >>> choose_model(500.0, "aged-bronze").model   # 0.5 mm pixels
    'local'
    >>> choose_model(500.0, "gilt").model
    'specular'
    """
    mat = get_material(material)
    fp = float(footprint_um)
    if not mat.corrodes or coverage <= 0.0:
        return ModelChoice("specular", 0.0, 0.0, fp,
                           "opaque conductor: no light enters, Torrance-Sparrow alone is exact")
    Ks = np.array([L[0].K for L in mat.layers], dtype=np.float64)
    Ss = np.array([L[0].S for L in mat.layers], dtype=np.float64)
    X = np.array(layer_thicknesses(coverage, mat), dtype=np.float64)
    K, S = sh.km_mix(Ks, Ss, X)  # eq 7, weighted by thickness
    sa, ssp = sh.km_to_transport(K, S)
    s_tr = np.sqrt(3.0 * sa * (sa + ssp))
    ell = float(np.max(1.0 / np.maximum(s_tr, 1e-300)))
    err = float(np.max(sh.dipole_tail_fraction(0.5 * fp, sa, ssp, mat.eta_top)))
    if err <= tol:
        return ModelChoice("local", err, ell, fp,
                           "diffusion length %.3g um << footprint %.3g um: local form, "
                           "%.2g of diffuse light leaves its pixel" % (ell, fp, err))
    return ModelChoice("dipole", err, ell, fp,
                       "diffusion length %.3g um visible at footprint %.3g um: the local form "
                       "would misplace %.2g of the diffuse light" % (ell, fp, err))


def model_switch_footprint_um(material, *, coverage=1.0, tol=0.01):
    """Pixel footprint (um) below which :func:`choose_model` picks the dipole.

    Parameters
    ----------
    material : Material or str
        A corroding material.
    coverage, tol : float, optional
        As in :func:`choose_model`.

    Returns
    -------
    footprint_um : float
        The footprint at which the misplaced fraction equals ``tol``
        (bisection in log footprint to a relative 1e-6); ``0.0`` for a
        material that does not corrode (never the dipole).

    Notes
    -----
    The misplaced fraction decreases monotonically with the footprint (the
    dipole profile's tail beyond half a pixel), so the switch is one point.
    docs/shading.md quotes the value this prints.
    """
    mat = get_material(material)
    if not mat.corrodes or coverage <= 0.0:
        return 0.0
    lo, hi = 1e-3, 1e6
    for _ in range(80):
        mid = np.sqrt(lo * hi)
        if choose_model(mid, mat, coverage=coverage, tol=tol).model == "local":
            hi = mid
        else:
            lo = mid
        if hi / lo < 1.0 + 1e-6:
            break
    return float(hi)


def warm_up():
    """Compile the shading kernels now (or load them from Numba's cache).

    Calls every public function of :mod:`shellrepair.appearance.reflectance`, and
    :class:`MaterialShader` and :func:`shade_reference` for each preset, with
    small inputs in the layouts the library uses (arrays of points, one
    light direction for all points, one roughness or index for all), so
    that each kernel specialisation is compiled once and cached on disk.
    ``make setup`` runs it, so no later run waits for the JIT.

    Returns
    -------
    n : int
        Number of compiled specialisations (0 when the kernels are off:
        ``SHELLREPAIR_NO_NUMBA=1`` or Numba missing).
    """
    from shellrepair.appearance.reflectance import (
        beckmann_D,
        diffuse_transmittance,
        dipole_profile,
        dipole_rd,
        dipole_tail_fraction,
        fresnel_conductor,
        fresnel_dielectric,
        internal_reflectance,
        km_r_inf,
        km_reflectance,
        layered_diffuse,
        local_brdf,
        mean_transmittance,
        torrance_sparrow,
        torrance_sparrow_conductor,
        v_cavity_G,
    )

    if dispatch.kernels("shader") is None:
        return 0

    rng = np.random.default_rng(0)
    P = 8
    d = rng.normal(size=(3, P, 3)) * [0.3, 0.3, 1.0]
    wi, wo, n = d / np.linalg.norm(d, axis=-1, keepdims=True)
    c, m, eta, R = rng.uniform(0.1, 0.9, P), rng.uniform(0.05, 1.0, P), rng.uniform(1.1, 2.0, P), rng.uniform(0, 1, P)
    R3 = rng.uniform(0, 1, (P, 3))
    nk = (np.array([0.2, 1.0, 1.2]), np.array([3.7, 2.6, 2.4]))
    for e in (eta, 1.75):  # per point, and one index for all points
        beckmann_D(c, m), fresnel_dielectric(c, e), diffuse_transmittance(c, m, e)
        mean_transmittance(m, e), internal_reflectance(m, e), layered_diffuse(c, c, m, e, R3)
        torrance_sparrow(wi, wo, n, m, e), local_brdf(wi, wo, n, m, e, R3), dipole_rd(R, e)
        dipole_tail_fraction(c, m, R, e), dipole_profile(c, m, R, e)
    v_cavity_G(c, c, c, c), fresnel_conductor(c, m, eta), fresnel_conductor(c[:, None], *nk)
    torrance_sparrow_conductor(wi, wo, n, m, *nk), km_r_inf(c, m)
    km_reflectance(c, m, eta, R), km_reflectance(c[:, None], m[:, None], eta[:, None], R3)
    km_reflectance(c[:, None], m[:, None], eta[:, None], nk[0])
    dipole_tail_fraction(1.0, c, m, 1.75), dipole_profile(c, 0.1, 0.2, 1.75)
    for name in ("aged-bronze", "gilt", "bronze"):
        f = MaterialShader(name)
        f(wi, wo, n, c, c, c), f(wi[0], wo, n, c, c, c, parts=True)  # per point; one light (the renderer)
        f(wi, wo, n, c), f(wi[0], wo, n, c)  # default gilding and crust
        shade_reference(wi, wo, n, c, name, c, c), choose_model(100.0, name)
    modules = [dispatch.kernels(name) for name in dispatch.KERNEL_MODULES]
    return sum(len(getattr(K, k).signatures) for K in modules for k in K.KERNELS)
