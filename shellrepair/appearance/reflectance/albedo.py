"""Directional albedo of the microfacet lobe and the rho_dt table (eq 3).

Light that crosses the rough interface into the corrosion layers is what
the specular lobe does not reflect: the diffuse transmittance
``rho_dt(o) = 1 - int f_r(o, i) (n.i) dw_i`` (source paper eq 3).  The
integral is computed by a Gauss rule over half vectors
(:func:`specular_albedo`), tabulated on a grid in
``(sqrt(cos theta), log m, sign(eta - 1) sqrt(|eta^2 - 1|))``
(:func:`rho_dt_table`, shipped with the package) and read by
trilinear interpolation (:func:`diffuse_transmittance`).  The table is a
lower envelope of its rule, so the layered model never reflects more than
it receives.  Its hemispherical mean gives the interface's internal
reflectance (:func:`mean_transmittance`, :func:`internal_reflectance`).

Valid ranges: m in :data:`RHO_DT_M_RANGE`, eta in :data:`RHO_DT_ETA_RANGE`
(inputs outside are clamped); stated accuracy :data:`RHO_DT_MAX_ERROR`.

References
----------
.. [1] Yamamoto, Shiba, Okada (the source paper), eq 3.
.. [2] R. L. Cook and K. E. Torrance, ACM TOG 1(1), 1982.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import os
import threading

import numpy as np

from shellrepair.appearance.reflectance.dispatch import elementwise, kernels
from shellrepair.appearance.reflectance.microfacet import _TINY, COS_EPS, M_MIN, _fresnel_dielectric_np

__all__ = [
    "RHO_DT_M_RANGE",
    "RHO_DT_ETA_RANGE",
    "RHO_DT_MAX_ERROR",
    "specular_albedo",
    "RhoDtTable",
    "u_mean_weights",
    "rho_dt_table",
    "diffuse_transmittance",
    "mean_transmittance",
    "internal_reflectance",
]

#: Domain of the precomputed rho_dt table (roughness m, relative index eta).
#: eta < 1 (the layer optically thinner than the medium above it) is
#: covered too: light arriving outside the critical cone is totally
#: reflected, and the table holds that consistently with the Fresnel term.
RHO_DT_M_RANGE = (0.005, 1.5)
RHO_DT_ETA_RANGE = (0.3, 3.0)

#: Stated bound on |table - reference quadrature| for incidence up to 89 deg
#: over RHO_DT_M_RANGE x RHO_DT_ETA_RANGE (checked in tests/test_shading.py
#: and measured in eval/bench_shading.py).
RHO_DT_MAX_ERROR = 1e-3

# --------------------------------------------------------------------------
# Directional albedo and rho_dt (eq 3)
# --------------------------------------------------------------------------


def _gauss_legendre01(n):
    x, w = np.polynomial.legendre.leggauss(int(n))
    return 0.5 * (x + 1.0), 0.5 * w


def albedo_geometry(cos_o, m, n_t, n_phi):
    """Quadrature nodes for the specular albedo at given (cos_o, m).

    The rule behind :func:`specular_albedo` and the rho_dt table
    (:func:`rule_albedo`); with F = 1 its weights sum to the lobe's
    albedo without Fresnel (at most 1: the white furnace).

    Parameters
    ----------
    cos_o, m : (P,) float arrays
        Cosine of the view direction and Beckmann roughness, pairwise.
    n_t, n_phi : int
        Gauss-Legendre nodes along the slope and the azimuth.

    Returns
    -------
    weight, o_dot_h : (P, n_phi * n_t) float64 arrays
        ``albedo(eta) = sum(weight * F(o_dot_h, eta), axis=-1)``.

    Notes
    -----
    The integral ``int f_r (n.i) dw_i`` is rewritten over half vectors
    (dw_i = 4 (o.h) dw_h) and the Beckmann slope density is mapped to the
    unit square: ``tan^2 theta_h = -m^2 log(1 - t)``, so that
    ``D (n.h) dw_h = dt dphi / (2 pi)``.  For each phi the t-range is cut
    exactly where the reflected direction crosses the horizon:
    ``n.i = a sin 2x + b cos 2x`` with x = theta_h, a = sin(theta_o) cos(phi),
    b = cos(theta_o), which is > 0 iff ``x < (pi - atan2(b, a)) / 2``.
    Gauss-Legendre in t on [0, t*] and in phi on [0, pi] (the integrand is
    even in phi) then converge quickly; only G's min() kink remains.
    """
    cos_o = np.clip(np.asarray(cos_o, dtype=np.float64), 0.0, 1.0)[:, None, None]
    m = np.maximum(np.asarray(m, dtype=np.float64), M_MIN)[:, None, None]
    sin_o = np.sqrt(1.0 - cos_o * cos_o)
    # Azimuth: near grazing incidence the horizon cut x_cut(phi) swings from
    # ~pi/2 to ~0 within |phi - pi/2| ~ cos(theta_o); grade the panels
    # geometrically towards phi = pi/2 (down to 0.5 cos theta_o).
    n_side = _PHI_GRADING
    n_pan = 2 * (n_side + 1)
    q = max(4, int(n_phi) // n_pan)
    s_min = np.maximum(0.5 * cos_o[:, 0, 0], 1e-4)
    frac = np.arange(n_side + 1) / n_side
    a = (0.5 * np.pi) ** (1.0 - frac)[None, :] * s_min[:, None] ** frac[None, :]
    left = np.concatenate([0.5 * np.pi - a, np.full((a.shape[0], 1), 0.5 * np.pi)], axis=1)
    right = np.pi - left[:, ::-1]
    edges_phi = np.concatenate([left, right[:, 1:]], axis=1)  # (P, n_pan + 1)
    uphi, wphi = _gauss_legendre01(q)
    lo_phi = edges_phi[:, :-1, None]
    w_phi = (edges_phi[:, 1:] - edges_phi[:, :-1])[:, :, None]
    phi = (lo_phi + uphi[None, None, :] * w_phi).reshape(a.shape[0], -1, 1)
    wphi = (wphi[None, None, :] * w_phi).reshape(phi.shape)
    ut, wt = _gauss_legendre01(n_t)
    ut = ut[None, None, :]
    wt = wt[None, None, :]
    cphi = np.cos(phi)
    sphi = np.sin(phi)
    psi = np.arctan2(cos_o, sin_o * cphi)
    x_cut = 0.5 * (np.pi - psi)  # horizon cut in theta_h: n.i = 0
    # G's min() switches branch where o.h = 2 (n.h)(n.o)  (theta_h = psi)
    # and where n.i = n.o (theta_h = pi/2 - psi); split there too.
    x1 = np.clip(psi, 0.0, x_cut)
    x2 = np.clip(0.5 * np.pi - psi, 0.0, x_cut)
    edges_x = np.sort(np.stack([np.zeros_like(x_cut), np.minimum(x1, x2),
                                np.maximum(x1, x2), x_cut], axis=0), axis=0)
    tan_e = np.tan(edges_x)
    # work with tau = 1 - t = exp(-tan^2/m^2) so that t -> 1 keeps its digits
    edges_tau = np.exp(-(tan_e * tan_e) / (m * m))[..., 0]  # (4, P, n_phi)
    hi = edges_tau[:-1, ..., None]  # (3, P, n_phi, 1), tau decreases with x
    width = (edges_tau[:-1] - edges_tau[1:])[..., None]
    tau = hi - ut * width  # (3, P, n_phi, n_t)
    wt = wt * width
    tau = np.moveaxis(tau, 0, -2).reshape(tau.shape[1], tau.shape[2], -1)
    wt = np.moveaxis(wt, 0, -2).reshape(tau.shape)
    tan2 = -(m * m) * np.log(np.maximum(tau, 1e-300))
    cos_h = 1.0 / np.sqrt(1.0 + tan2)
    sin_h = np.sqrt(tan2) * cos_h
    hx = sin_h * cphi
    hy = sin_h * sphi  # noqa: F841  (o has no y component)
    oh = sin_o * hx + cos_o * cos_h
    oh = np.maximum(oh, COS_EPS)
    no = np.maximum(cos_o, COS_EPS)
    ni = 2.0 * oh * cos_h - cos_o
    ni = np.maximum(ni, 0.0)
    # G / (n.o) = min(1/no, 2 nh / oh, 2 nh ni / (oh no))     (eq 11 / n.o)
    g_over_no = np.minimum(1.0 / no, 2.0 * cos_h / oh * np.minimum(1.0, ni / no))
    # f_r (n.i) dw_i = D G F / (4 ni no) ni 4 oh dw_h = F G oh / (nh no) D nh dw_h
    integrand_geo = g_over_no * oh / cos_h
    # measure: D nh dw_h = dt dphi / (2 pi); phi over [0, pi] counted twice.
    weight = integrand_geo * (2.0 / (2.0 * np.pi)) * wphi * wt
    P = weight.shape[0]
    return weight.reshape(P, -1), np.broadcast_to(oh, weight.shape).reshape(P, -1)


def specular_albedo(cos_theta, m, eta, *, n_t=64, n_phi=64):
    """Directional albedo of the Torrance-Sparrow lobe, by quadrature.

    Parameters
    ----------
    cos_theta : (...) float array
        Cosine of the outgoing (or, by reciprocity, incident) direction.
    m : (...) float array
        Beckmann RMS slope.
    eta : (...) float array
        Relative refractive index.
    n_t, n_phi : int, optional
        Gauss-Legendre orders in the mapped slope radius and azimuth.  The
        defaults reach ~1e-5 over the table range; the reference in the
        tests uses more.

    Returns
    -------
    A : (...) float64 array
        ``int_{2pi} f_r(o, i) (n.i) dw_i`` (dimensionless, <= 1).

    Notes
    -----
    The integral of eq 3; ``rho_dt = 1 - A``.  See ``albedo_geometry`` for
    the change of variables that makes a tensor Gauss rule accurate even at
    m = 0.005 and 90 degree incidence.
    """
    cos_theta, m, eta = np.broadcast_arrays(
        np.asarray(cos_theta, dtype=np.float64),
        np.asarray(m, dtype=np.float64),
        np.asarray(eta, dtype=np.float64),
    )
    shape = cos_theta.shape
    c = cos_theta.ravel()
    mm = m.ravel()
    ee = eta.ravel()
    out = np.empty(c.shape, dtype=np.float64)
    step = max(1, 2_000_000 // (n_t * n_phi))
    for s in range(0, c.size, step):
        sl = slice(s, s + step)
        w, oh = albedo_geometry(c[sl], mm[sl], n_t, n_phi)
        out[sl] = np.sum(w * _fresnel_dielectric_np(oh, ee[sl, None]), axis=-1)
    return out.reshape(shape)


# --- the rho_dt table -------------------------------------------------------

#: Grid of the table.  Axes are chosen so that trilinear interpolation is
#: accurate where rho_dt bends sharply (measured, docs/shading.md):
#: u = sqrt(cos theta) (fine near grazing, where F rises steeply), log m,
#: and the signed kappa = sign(eta - 1) sqrt(|eta^2 - 1|) (the g of eq 12 at
#: grazing for eta > 1, minus the critical cosine for eta < 1; fine near
#: eta = 1).  _TABLE_N_KAPPA nodes span eta in [1, 3]; the same spacing
#: continues below 0 down to eta = RHO_DT_ETA_RANGE[0].
_TABLE_N_U = 129
_TABLE_N_M = 49
_TABLE_N_KAPPA = 81
_TABLE_QUAD = (24, 40)  # (n_t, n_phi) per node
_TABLE_N_C = 1025  # nodes in o.h for the Fresnel factor
_TABLE_VERSION = 6
#: eta < 1 nodes are lowered by this multiple of a check point's overshoot
#: (eta >= 1: once).  There the rule samples the kink of F at total
#: internal reflection with Gauss nodes that move with (theta, m), so it is
#: not smooth between check points (its own error is up to ~1e-2 at
#: m >= 1, tests/test_shading.py); with a factor 1 random points exceeded
#: the rule by up to 1.5e-4, with 2 by none.
_ENVELOPE_SAFETY_TIR = 2.0
#: Geometric azimuth panels on each side of phi = pi/2 in the quadrature.
_PHI_GRADING = 4


def u_mean_weights(u):
    """Weights of the exact cosine-weighted mean of a piecewise-linear function of u.

    Parameters
    ----------
    u : (N,) float array
        Increasing nodes on [0, 1] (u = sqrt(cos theta)).

    Returns
    -------
    W : (N,) float64 array
        ``4 int_0^1 g(u) u^3 du = sum_i W_i g(u_i)`` exactly for every g
        linear between the nodes (and sum W = 1 when u spans [0, 1]).
    """
    u = np.asarray(u, dtype=np.float64)
    a, b = u[:-1], u[1:]
    h = b - a
    I0 = b ** 4 - a ** 4  # int 4 u^3
    I1 = 0.8 * (b ** 5 - a ** 5)  # int 4 u^4
    W = np.zeros(u.size)
    W[:-1] += (b * I0 - I1) / h
    W[1:] += (I1 - a * I0) / h
    return W


@dataclasses.dataclass(frozen=True)
class RhoDtTable:
    """Precomputed rho_dt on a regular grid.

    Attributes
    ----------
    u : (Nu,) float64 array
        ``sqrt(cos theta)`` nodes, uniform on [0, 1].
    log_m : (Nm,) float64 array
        Natural log of the roughness nodes, uniform.
    kappa : (Nk,) float64 array
        Signed ``sign(eta - 1) sqrt(|eta^2 - 1|)`` nodes, uniform, with a
        node at 0 (eta = 1).
    values : (Nu, Nm, Nk) float64 array
        ``1 - specular_albedo`` at the nodes.
    """

    u: np.ndarray
    log_m: np.ndarray
    kappa: np.ndarray
    values: np.ndarray

    def __call__(self, cos_theta, m, eta):
        """Trilinear interpolation; inputs clamped to the grid."""
        return _trilinear(self, cos_theta, m, eta)

    @functools.cached_property
    def mean_values(self):
        """``(Nm, Nk)`` cosine-weighted hemispherical mean of rho_dt.

        ``rho_bar = 2 int_0^1 rho_dt(mu) mu dmu = 4 int_0^1 rho_dt(u) u^3 du``
        (mu = u^2), integrated exactly for the piecewise-linear-in-u
        interpolant (:func:`u_mean_weights`), so that it is the mean of
        what :func:`diffuse_transmittance` returns.
        """
        return np.tensordot(u_mean_weights(self.u), self.values, axes=(0, 0))

    @functools.cached_property
    def tir_moments(self):
        """``(3, Nm, Nk)`` moments of each eta < 1 slice about its critical cosine.

        With c = the slice's critical cosine and y = cos theta:
        ``P = 2 int_0^c rho y dy``, ``Q0 = int_c^1 rho dy``,
        ``Q1 = int_c^1 rho y dy`` (zero for eta >= 1 slices).  They give the
        exact mean of a slice read at the cosines shifted to another
        critical angle (:func:`mean_transmittance`).  Computed exactly by
        3-point Gauss on every u cell, split at sqrt(c) (the integrand is a
        polynomial of degree <= 4 in u there).
        """
        U = self.u
        out = np.zeros((3,) + self.values.shape[1:])
        g, gw = _gauss_legendre01(3)
        for k in np.flatnonzero(self.kappa < 0.0):
            c = -self.kappa[k]
            br = np.union1d(U, [np.sqrt(c)])
            a, b = br[:-1], br[1:]
            uq = (a[:, None] + (b - a)[:, None] * g[None, :]).ravel()
            wq = ((b - a)[:, None] * gw[None, :]).ravel()
            T = np.stack([np.interp(uq, U, self.values[:, j, k]) for j in range(self.values.shape[1])],
                         axis=1)  # (Q, Nm)
            below = uq < np.sqrt(c)
            # y = u^2, dy = 2 u du
            out[0, :, k] = (wq * below * 4.0 * uq ** 3) @ T
            out[1, :, k] = (wq * ~below * 2.0 * uq) @ T
            out[2, :, k] = (wq * ~below * 2.0 * uq ** 3) @ T
        return out

    @functools.cached_property
    def kernel_args(self):
        """The table as the compiled kernels read it, or None if its kappa axis is not the grid's.

        ``(values (Nu*Nm*Nk,), kappa, dk, k0, u0, du, Nu, log_m0, dlog_m,
        Nm, mean_values, P, Q0, Q1)``, C-contiguous float64, with the axis
        origins and steps formed exactly as :func:`_stencil` forms them.
        ``kappa[k] == dk * (k - k0)`` bit for bit (checked), which the
        kernels use instead of reading kappa.
        """
        U, L, Kp = self.u, self.log_m, self.kappa
        f = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
        zero = np.flatnonzero(Kp == 0.0)
        if zero.size != 1 or zero[0] + 1 >= Kp.size:
            return None
        k0 = int(zero[0])
        dk = float(Kp[k0 + 1])  # = dk * 1, exactly
        if not np.array_equal(dk * np.arange(-k0, Kp.size - k0), Kp):
            return None
        P, Q0, Q1 = self.tir_moments
        return (f(self.values).reshape(-1), f(Kp), dk, k0, float(U[0]), float(U[1] - U[0]), int(U.size),
                float(L[0]), float(L[1] - L[0]), int(L.size), f(self.mean_values), f(P), f(Q0), f(Q1))

    def slice_eta(self, eta):
        """2-D table ``(Nu, Nm)`` for one fixed eta (linear in kappa)."""
        kap = float(_kappa(float(eta)))
        k, w = _axis_index(np.float64(kap), self.kappa[0], self.kappa[1] - self.kappa[0],
                           self.kappa.size)
        return (1.0 - w) * self.values[:, :, k] + w * self.values[:, :, k + 1]


def _kappa(eta):
    """Signed table coordinate of eta: sign(eta - 1) sqrt(|eta^2 - 1|)."""
    e2 = np.asarray(eta, dtype=np.float64) ** 2 - 1.0
    return np.sign(e2) * np.sqrt(np.abs(e2))


def _eta_of_kappa(kappa):
    return np.sqrt(1.0 + kappa * np.abs(kappa))


def _grid():
    u = np.linspace(0.0, 1.0, _TABLE_N_U)
    log_m = np.linspace(np.log(RHO_DT_M_RANGE[0]), np.log(RHO_DT_M_RANGE[1]), _TABLE_N_M)
    dk = _kappa(RHO_DT_ETA_RANGE[1]) / (_TABLE_N_KAPPA - 1)
    n_neg = int(np.ceil(-_kappa(RHO_DT_ETA_RANGE[0]) / dk - 1e-9))
    kappa = dk * np.arange(-n_neg, _TABLE_N_KAPPA)
    return u, log_m, kappa


def rule_albedo(cos_theta, m, eta):
    """Specular albedo by the table's own quadrature rule.

    Parameters
    ----------
    cos_theta, m : (P,) float arrays
        Pairs of incidence cosine and roughness.
    eta : (K,) float array
        Relative indices, all applied to every pair.

    Returns
    -------
    A : (P, K) float64 array

    Notes
    -----
    The rule every table node holds: ``albedo_geometry`` at
    ``_TABLE_QUAD`` Gauss points, its weights deposited on ``_TABLE_N_C``
    nodes in o.h (linear hats), where F is tabulated for every eta at once.
    The white-furnace bound of the layered model (``f_TS + f_d`` reflects
    at most 1) is exact against this rule; the rule's own distance to the
    converged integral is measured in tests/test_shading.py.
    """
    c = np.asarray(cos_theta, dtype=np.float64).ravel()
    mm = np.asarray(m, dtype=np.float64).ravel()
    eta = np.atleast_1d(np.asarray(eta, dtype=np.float64))
    n_t, n_phi = _TABLE_QUAD
    cg = np.linspace(0.0, 1.0, _TABLE_N_C)
    Fg = _fresnel_dielectric_np(cg[:, None], eta[None, :])  # (Nc, K)
    out = np.empty((c.size, eta.size), dtype=np.float64)
    step = 64
    for s0 in range(0, c.size, step):
        sl = slice(s0, s0 + step)
        w, oh = albedo_geometry(c[sl], mm[sl], n_t, n_phi)
        # the lobe with F = 1 reflects at most 1 (single scattering, V-cavity
        # G); the rule's excess over 1 is quadrature error (<= 2e-9 measured
        # at m ~ 0.02) and is scaled away
        w = w / np.maximum(w.sum(axis=1, keepdims=True), 1.0)
        n = w.shape[0]
        f = np.clip(oh, 0.0, 1.0) * (_TABLE_N_C - 1)
        j = np.minimum(f.astype(np.intp), _TABLE_N_C - 2)
        a = f - j
        idx = np.arange(n)[:, None] * _TABLE_N_C + j
        Wg = np.bincount(idx.ravel(), (w * (1.0 - a)).ravel(), minlength=n * _TABLE_N_C)
        Wg += np.bincount((idx + 1).ravel(), (w * a).ravel(), minlength=n * _TABLE_N_C)
        out[sl] = Wg.reshape(n, _TABLE_N_C) @ Fg
    return out


def _build_table():
    """Nodes by the quadrature rule, then lowered into a lower envelope.

    Trilinear interpolation overshoots where rho_dt is convex (near
    grazing) and across the step at the critical angle (eta < 1), and
    there the layered model would reflect more than it receives.  So the
    interpolant is compared with the rule (:func:`rule_albedo`) at check
    points between the nodes: cell midpoints in u and in log m, midpoints
    and quarter points in kappa (also at the (u, m) nodes), and for
    eta < 1 around the critical angle, where rho_dt steps over ~m radians
    (from 3 m inside to 6 m past it).  Every node a check point leans on
    (positive weight) is lowered by that point's overshoot, repeated until
    no check point overshoots (nodes are clipped at 0, so one pass may
    not do).  For a locally quadratic function the cell midpoints are
    where linear interpolation errs most, so between check points the
    interpolant stays below the rule too; this is measured, not proved,
    on random points in tests/test_shading.py.
    """
    u, log_m, kappa = _grid()
    eta = _eta_of_kappa(kappa)
    mm = np.exp(log_m)
    Nu, Nm, Nk = u.size, mm.size, kappa.size
    cos_n = np.repeat(u * u, Nm)
    m_n = np.tile(mm, Nu)
    # check etas: kappa midpoints and quarter points (F is batched: cheap)
    kap_mid = 0.5 * (kappa[1:] + kappa[:-1])
    eta_mid = _eta_of_kappa(kap_mid)
    dk = kappa[1] - kappa[0]
    kap_q = np.concatenate([kappa[:-1] + 0.25 * dk, kappa[:-1] + 0.75 * dk])
    eta_chk = np.concatenate([eta, eta_mid, _eta_of_kappa(kap_q)])
    at_nodes = 1.0 - rule_albedo(cos_n, m_n, eta_chk)  # (Nu * Nm, K)
    vals = at_nodes[:, :Nk].reshape(Nu, Nm, Nk).copy()
    raw = RhoDtTable(u, log_m, kappa, vals)
    # check points: (cos, m) pairs x eta values
    um = 0.5 * (u[1:] + u[:-1])
    m_mid = np.exp(0.5 * (log_m[1:] + log_m[:-1]))
    pairs = [(np.repeat(um * um, Nm), np.tile(mm, um.size)),            # u midpoints
             (np.repeat(u * u, Nm - 1), np.tile(m_mid, Nu)),            # m midpoints
             (np.repeat(um * um, Nm - 1), np.tile(m_mid, um.size))]     # both
    cos_c = np.concatenate([p[0] for p in pairs])
    m_c = np.concatenate([p[1] for p in pairs])
    # blocks of check points: (cos (P,), m (P,), eta (K,), reference (P, K))
    blocks = [(cos_c, m_c, eta_chk, 1.0 - rule_albedo(cos_c, m_c, eta_chk)),
              (cos_n, m_n, eta_chk[Nk:], at_nodes[:, Nk:])]  # node pairs, off-node etas
    # eta < 1: the step at the critical angle, smoothed over ~m radians
    # (Beckmann tail exp(-(d/m)^2)): from 3 m inside it to 6 m past it,
    # on node slices at node roughnesses and midpoint slices at midpoints
    offsets = np.array([-3.0, -1.5, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0])
    for e, m_s in [(e, mm) for e in eta[eta < 1.0]] + [(e, m_mid) for e in eta_mid[eta_mid < 1.0]]:
        th_c = np.arcsin(e)
        th = th_c + offsets[:, None] * m_s[None, :]
        cs = np.cos(np.clip(th, 0.0, 0.5 * np.pi)).ravel()
        ms = np.tile(m_s, len(offsets))
        blocks.append((cs, ms, np.array([e]), 1.0 - rule_albedo(cs, ms, np.array([e]))))
    # the points where the interpolant overshoots the rule
    flat = vals.ravel().copy()
    bad_idx, bad_w, bad_ref = [], [], []
    for cs, ms, es, ref in blocks:
        rows = max(1, (1 << 19) // es.size)
        for s0 in range(0, cs.size, rows):
            sl = slice(s0, s0 + rows)
            shape = ref[sl].shape
            idx, w = _stencil(raw, np.broadcast_to(cs[sl, None], shape), np.broadcast_to(ms[sl, None], shape),
                              np.broadcast_to(es[None, :], shape))
            over = (w * flat[idx]).sum(axis=-1) - ref[sl]
            pos = over > 0.0
            bad_idx.append(idx[pos])
            bad_w.append(w[pos])
            bad_ref.append(ref[sl][pos])
    idx, w, ref = np.concatenate(bad_idx), np.concatenate(bad_w), np.concatenate(bad_ref)
    # lower every node a bad point leans on by that point's overshoot, and
    # again until none is left (a node clipped at 0 cannot take its share,
    # so one pass is not enough); lowering only lowers the interpolant, so
    # points that were fine stay fine
    # (the weights are >= 0, so a point's interpolant, rounding included,
    # never rises as nodes are lowered: each pass checks only the points
    # that overshot in the pass before)
    safety = np.broadcast_to(np.where(kappa < 0.0, _ENVELOPE_SAFETY_TIR, 1.0), vals.shape).ravel()
    for _ in range(200):
        over = (w * flat[idx]).sum(axis=-1) - ref
        pos = over > 0.0
        if not np.any(pos):
            break
        idx, w, ref, over = idx[pos], w[pos], ref[pos], over[pos]
        touch = w > 0.0
        delta = np.zeros(flat.size)
        np.maximum.at(delta, idx[touch], np.broadcast_to(over[:, None], touch.shape)[touch])
        flat = np.clip(flat - safety * delta, 0.0, 1.0)
    vals = flat.reshape(vals.shape)
    return RhoDtTable(u, log_m, kappa, vals)


def _table_key():
    """The parameters the table is a function of, as text (the cache's and the shipped file's key)."""
    return repr((_TABLE_VERSION, _ENVELOPE_SAFETY_TIR, _TABLE_N_U, _TABLE_N_M, _TABLE_N_KAPPA, _TABLE_QUAD,
                 RHO_DT_M_RANGE, RHO_DT_ETA_RANGE))


def _cache_path():
    base = os.environ.get("SHELLREPAIR_CACHE_DIR")
    if not base:
        base = os.path.join(
            os.environ.get("XDG_CACHE_HOME", os.path.join(os.path.expanduser("~"), ".cache")),
            "shellrepair",
        )
    return os.path.join(base, "rho_dt_%s.npz" % hashlib.sha1(_table_key().encode()).hexdigest()[:12])


#: The table shipped with the package (package data; made by
#: ``python -m shellrepair.appearance.reflectance.table``, checked by tests/test_rho_dt_file.py).
SHIPPED_TABLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "rho_dt_table.npz")
#: The shipped values are stored as multiples of 2**-SHIPPED_BITS, rounded
#: down (so the table stays a lower envelope of its rule), as second
#: differences along the u axis (small integers that deflate to ~0.8 MB
#: instead of 4.6 MB for the float64 values).
SHIPPED_BITS = 20


def encode_table(table):
    """The shipped file's arrays for a table.

    Parameters
    ----------
    table : RhoDtTable

    Returns
    -------
    arrays : dict
        ``key`` (:func:`_table_key`), ``bits`` and ``d2``: the values
        times ``2**bits`` rounded down, differenced twice along u
        ``(Nu, Nm, Nk) int32``.
    """
    q = np.floor(np.asarray(table.values, np.float64) * 2.0 ** SHIPPED_BITS).astype(np.int64)
    d2 = np.diff(np.diff(q, axis=0, prepend=0), axis=0, prepend=0)
    return {"key": np.array(_table_key()), "bits": np.array(SHIPPED_BITS), "d2": d2.astype(np.int32)}


def decode_table(arrays):
    """The table from the shipped file's arrays (:func:`encode_table`), or
    None where they were made for other parameters or are not a table.

    Parameters
    ----------
    arrays : mapping
        ``key``, ``bits`` and ``d2`` as :func:`encode_table` gives them.

    Returns
    -------
    table : RhoDtTable or None
        Values exact multiples of ``2**-bits`` in [0, 1].
    """
    u, log_m, kappa = _grid()
    d2 = np.asarray(arrays["d2"])
    if str(arrays["key"]) != _table_key() or d2.shape != (u.size, log_m.size, kappa.size):
        return None
    q = np.cumsum(np.cumsum(d2.astype(np.int64), axis=0), axis=0)
    values = q / 2.0 ** int(arrays["bits"])
    if values.min() < 0.0 or values.max() > 1.0:
        return None
    return RhoDtTable(u, log_m, kappa, values)


def _shipped():
    """The shipped table, or None (no file, a damaged one, or one for other parameters)."""
    try:
        with np.load(SHIPPED_TABLE) as z:
            return decode_table(z)
    except (OSError, KeyError, ValueError, EOFError):
        return None


_TABLE = None
_TABLE_LOCK = threading.Lock()


def rho_dt_table():
    """The rho_dt table: the one shipped with the package, read once.

    Returns
    -------
    table : RhoDtTable

    Notes
    -----
    The table is a function of fixed parameters, built by the quadrature
    rule of :func:`rule_albedo` at every node and at ~10^7 check points
    for the lower envelope (:func:`_build_table`: 40 s of CPU, 90 s on two
    busy cores), so it ships with the package (:data:`SHIPPED_TABLE`,
    ~0.8 MB; read in milliseconds; its values are the built ones rounded
    down to multiples of ``2**-SHIPPED_BITS``, about 1e-6).  Where that
    file is missing, damaged or was made for other parameters (a changed
    ``_TABLE_*`` constant before ``python -m shellrepair.appearance.reflectance.table``
    made it again), the table is built on first use and cached as ``.npz``
    under ``$SHELLREPAIR_CACHE_DIR`` or ``~/.cache/shellrepair``; an
    unwritable cache directory only costs the rebuild, and a corrupt cache
    file is ignored and rebuilt.
    """
    global _TABLE
    with _TABLE_LOCK:
        if _TABLE is not None:
            return _TABLE
        table = _shipped()
        if table is not None:
            _TABLE = table
            return table
        path = _cache_path()
        try:
            with np.load(path) as z:
                cand = RhoDtTable(z["u"], z["log_m"], z["kappa"], z["values"])
            ref = _grid()
            if (cand.values.shape == (ref[0].size, ref[1].size, ref[2].size)
                    and np.all(np.isfinite(cand.values))
                    and np.allclose(cand.log_m, ref[1]) and np.allclose(cand.kappa, ref[2])):
                table = cand
        except (OSError, KeyError, ValueError):
            table = None
        if table is None:
            table = _build_table()
            try:
                import io

                from shellrepair.files import atomic_write

                os.makedirs(os.path.dirname(path), exist_ok=True)
                buf = io.BytesIO()
                np.savez(buf, u=table.u, log_m=table.log_m, kappa=table.kappa, values=table.values)
                atomic_write(path, buf.getvalue(), os_errors=True)
            except OSError:
                pass
        _TABLE = table
        return table


def _axis_index(x, x0, dx, n):
    """Cell index and weight for a uniform axis, clamped to the grid."""
    f = np.clip((x - x0) / dx, 0.0, n - 1.0)
    i = np.minimum(f.astype(np.intp), n - 2)
    return i, f - i


def _edge_aligned_cos(x, c_query, c_node):
    """Move cos theta = x from a critical cosine c_query to c_node.

    For eta < 1 rho_dt falls steeply at the critical angle (cos = c =
    sqrt(1 - eta^2), total internal reflection beyond it).  Two table
    slices in eta have their edges at different angles, so blending them at
    the same angle would give two half steps.  Instead each slice is read at
    the angle that lies in the same relative position to its own edge:
    piecewise linear in x with 0 -> 0, c_query -> c_node, 1 -> 1.
    """
    below = x < c_query
    lo = x * c_node / np.maximum(c_query, _TINY)
    hi = c_node + (x - c_query) * (1.0 - c_node) / np.maximum(1.0 - c_query, _TINY)
    return np.where(below, lo, hi)


def _next_to_one(kap_c, Kp, k, wk):
    """Weight of the upper kappa node, with the two cells next to eta = 1 read one-sided.

    The Fresnel factor of eta = 1 + e jumps to 1 within ~sqrt(2 e) of the
    horizon, and for eta = 1 - e light cannot enter there at all; the
    eta = 1 slice (no reflection) cannot express either, and blending with
    it put up to all the light back in at grazing.  In the cells
    (eta_-1, 1) and (1, eta_1) the slice farther from 1 is read alone (for
    eta < 1 shifted to the query's critical angle).  F grows with |eta - 1|
    at every angle, so this errs on the side of reflecting more at the
    interface and transmitting less.  eta = 1 itself reads its own slice.
    """
    up = Kp[np.minimum(k + 1, Kp.size - 1)]
    wk = np.where((kap_c < 0.0) & (up == 0.0), 0.0, wk)
    wk = np.where((kap_c > 0.0) & (Kp[k] == 0.0), 1.0, wk)
    wk = np.where((kap_c == 0.0) & (up == 0.0), 1.0, wk)
    return np.where((kap_c == 0.0) & (Kp[k] == 0.0), 0.0, wk)


def _stencil(table, cos_theta, m, eta):
    """Flat node indices and weights of the trilinear read, ``(..., 8)`` each.

    Inputs are clamped to the grid.  For eta < 1 each of the two kappa
    slices is read at the cosine in the same position relative to its own
    critical angle (:func:`_edge_aligned_cos`).
    """
    cos_theta, m, eta = np.broadcast_arrays(
        np.asarray(cos_theta, dtype=np.float64),
        np.asarray(m, dtype=np.float64),
        np.asarray(eta, dtype=np.float64),
    )
    x = np.clip(cos_theta, 0.0, 1.0)
    lm = np.log(np.maximum(m, M_MIN))
    kap = _kappa(np.maximum(eta, _TINY))
    U, L, Kp = table.u, table.log_m, table.kappa
    j, wj = _axis_index(lm, L[0], L[1] - L[0], L.size)
    k, wk = _axis_index(kap, Kp[0], Kp[1] - Kp[0], Kp.size)
    kap_c = np.clip(kap, Kp[0], Kp[-1])
    wk = _next_to_one(kap_c, Kp, k, wk)
    Nm, Nk = L.size, Kp.size
    idx, wts = [], []
    for dk, ak in ((0, 1.0 - wk), (1, wk)):
        kn = Kp[k + dk]
        tir = (kap_c < 0.0) & (kn < 0.0)
        xk = np.where(tir, _edge_aligned_cos(x, -np.minimum(kap_c, 0.0), -np.minimum(kn, 0.0)), x)
        i, wi = _axis_index(np.sqrt(xk), U[0], U[1] - U[0], U.size)
        for di, ai in ((0, 1.0 - wi), (1, wi)):
            for dj, aj in ((0, 1.0 - wj), (1, wj)):
                idx.append(((i + di) * Nm + (j + dj)) * Nk + (k + dk))
                wts.append(ai * aj * ak)
    return np.stack(idx, axis=-1), np.stack(wts, axis=-1)


def _trilinear(table, cos_theta, m, eta):
    idx, w = _stencil(table, cos_theta, m, eta)
    return np.asarray((w * table.values.ravel()[idx]).sum(axis=-1), dtype=np.float64)


def diffuse_transmittance(cos_theta, m, eta):
    """Diffuse transmittance rho_dt of the rough interface (eq 3).

    Parameters
    ----------
    cos_theta : (...) float array
        Cosine of the direction with the normal, clamped to [0, 1].
    m : (...) float array
        Beckmann RMS slope; clamped to :data:`RHO_DT_M_RANGE`.
    eta : (...) float array
        Relative refractive index; clamped to :data:`RHO_DT_ETA_RANGE`.

    Returns
    -------
    rho_dt : (...) float64 array in [0, 1]

    Notes
    -----
    Paper eq 3 with the normalised Beckmann D::

        rho_dt(o) = 1 - int_{2 pi} f_r(o, i) (n.i) dw_i

    Read by trilinear interpolation in (sqrt(cos theta), log m,
    sign(eta - 1) sqrt(|eta^2 - 1|)) from a table of
    Gauss-quadrature values (:func:`rho_dt_table`).  Stated accuracy:
    within :data:`RHO_DT_MAX_ERROR` (1e-3) of the reference quadrature for
    m in [0.02, 1], eta in [1.1, 2.5] and incidence up to 89 degrees
    (measured maximum in docs/shading.md); between 89 and 90 degrees the
    table is still finite and monotone but not held to that bound.  For
    eta < 1 (total internal reflection outside the critical cone) the same
    table is used; its measured error there is in docs/shading.md.

    Energy: the table is a lower envelope of its quadrature rule
    (``_build_table``): at every check point between the nodes the value
    read is at most ``1 - A`` with A the lobe's albedo by the same rule,
    so ``f_TS + f_d`` (:func:`layered_diffuse`) reflects at most what it
    receives.  The price is a lower rho_dt where the interpolant used to
    overshoot: <= 2.1e-4 for the aged-bronze preset (eta = 1.75), up to
    2.7e-3 elsewhere for eta >= 1, and for eta < 1 with m < ~0.05 most of
    the table cell that holds the critical-angle step (up to 0.46 at one
    angle, 2.9e-3 on average).

    Examples
    --------
    >>> float(diffuse_transmittance(0.5, 0.3, 1.0))   # index-matched: no reflection
    1.0
    """
    K = kernels("albedo")
    a = rho_dt_table().kernel_args if K is not None else None
    if a is not None:
        return elementwise(K.diffuse_transmittance, (cos_theta, m, eta), a[:10])
    return _diffuse_transmittance_np(cos_theta, m, eta)


def _diffuse_transmittance_np(cos_theta, m, eta):
    """NumPy version of :func:`diffuse_transmittance` (the test oracle of the compiled kernel)."""
    return np.clip(rho_dt_table()(cos_theta, m, eta), 0.0, 1.0)


def mean_transmittance(m, eta):
    """Cosine-weighted hemispherical mean of rho_dt (diffuse light entering).

    Parameters
    ----------
    m : (...) float array
        Beckmann RMS slope; clamped to :data:`RHO_DT_M_RANGE`.
    eta : (...) float array
        Relative refractive index; clamped to :data:`RHO_DT_ETA_RANGE`.

    Returns
    -------
    rho_bar : (...) float64 array in [0, 1]
        ``2 int_0^1 rho_dt(mu) mu dmu``: the fraction of uniformly diffuse
        light from above that crosses the interface (1 - the external
        diffuse reflectance r_e).

    Notes
    -----
    The exact cosine-weighted mean of what :func:`diffuse_transmittance`
    returns at (m, eta): bilinear in (log m, signed kappa) over node means
    (:attr:`RhoDtTable.mean_values`); for eta < 1 each slice's mean is taken
    at the cosines that read it, shifted to its own critical angle
    (:attr:`RhoDtTable.tir_moments`).  So the diffuse term of
    :func:`layered_diffuse` integrated over incidence returns exactly
    ``rho_dt(o) R (1 - r_i) / (1 - r_i R) <= rho_dt(o)``.
    """
    K = kernels("albedo")
    a = rho_dt_table().kernel_args if K is not None else None
    if a is not None:
        return elementwise(K.mean_transmittance, (m, eta), a[1:4] + a[7:])
    return _mean_transmittance_np(m, eta)


def _mean_transmittance_np(m, eta):
    """NumPy version of :func:`mean_transmittance` (the test oracle of the compiled kernel)."""
    table = rho_dt_table()
    m, eta = np.broadcast_arrays(np.asarray(m, dtype=np.float64), np.asarray(eta, dtype=np.float64))
    L, Kp = table.log_m, table.kappa
    j, wj = _axis_index(np.log(np.maximum(m, M_MIN)), L[0], L[1] - L[0], L.size)
    kap = _kappa(np.maximum(eta, _TINY))
    k, wk = _axis_index(kap, Kp[0], Kp[1] - Kp[0], Kp.size)
    kap_c = np.clip(kap, Kp[0], Kp[-1])
    wk = _next_to_one(kap_c, Kp, k, wk)
    cq = -np.minimum(kap_c, 0.0)  # the query's critical cosine (0 for eta >= 1)
    M = table.mean_values
    P, Q0, Q1 = table.tir_moments
    out = 0.0
    for dk, ak in ((0, 1.0 - wk), (1, wk)):
        kk = k + dk
        cn = -np.minimum(Kp[kk], 0.0)
        tir = (kap_c < 0.0) & (Kp[kk] < 0.0)
        # the slice read at x -> its own critical position (_edge_aligned_cos):
        # below the edge x = y cq/cn, above x = cq + (y - cn) r
        cns = np.where(tir, cn, 1.0)
        cqs = np.where(tir, cq, 1.0)
        r = (1.0 - cqs) / np.maximum(1.0 - cns, _TINY)
        for dj, aj in ((0, 1.0 - wj), (1, wj)):
            jj = j + dj
            shifted = ((cqs / cns) ** 2 * P[jj, kk] + 2.0 * r * cqs * Q0[jj, kk]
                       + 2.0 * r * r * (Q1[jj, kk] - cns * Q0[jj, kk]))
            out = out + aj * ak * np.where(tir, shifted, M[jj, kk])
    return np.clip(out, 0.0, 1.0)


def internal_reflectance(m, eta):
    """Diffuse reflectance r_i of the interface seen from inside the layer.

    Parameters
    ----------
    m, eta : (...) float arrays
        As :func:`mean_transmittance`.

    Returns
    -------
    r_i : (...) float64 array in [0, 1)

    Notes
    -----
    Diffuse (Lambertian) light going up inside a layer of index eta leaves
    with probability ``1 - r_i``.  Reciprocity of the interface (the
    radiance of transmitted light scales by eta^2) ties it to the outside
    transmittance: ``1 - r_i = rho_bar / eta^2`` (e.g. Kelemen &
    Szirmay-Kalos 2001; Weidlich & Wilkie 2007).  For a smooth interface
    at eta = 1.5 this gives r_i ~ 0.60, the classical value.  Clamped to
    [0, 1 - 1e-9] so that ``1 / (1 - r_i R)`` stays finite.
    """
    K = kernels("albedo")
    a = rho_dt_table().kernel_args if K is not None else None
    if a is not None:
        return elementwise(K.internal_reflectance, (m, eta), a[1:4] + a[7:] + RHO_DT_ETA_RANGE)
    return _internal_reflectance_np(m, eta)


def _internal_reflectance_np(m, eta):
    """NumPy version of :func:`internal_reflectance` (the test oracle of the compiled kernel)."""
    m, eta = np.broadcast_arrays(np.asarray(m, dtype=np.float64), np.asarray(eta, dtype=np.float64))
    e = np.clip(eta, RHO_DT_ETA_RANGE[0], RHO_DT_ETA_RANGE[1])
    return np.clip(1.0 - _mean_transmittance_np(m, eta) / (e * e), 0.0, 1.0 - 1e-9)
