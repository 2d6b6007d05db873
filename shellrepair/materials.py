"""Material presets, the rust-coverage map and the aged-metal shader.

A gilt-bronze statue after centuries (source paper, 4.4; Dorsey & Hanrahan
1996) is bronze partly covered by corrosion layers -- cuprite (Cu2O) next to
the metal, then green basic copper salts -- with remnants of gold leaf where
the corrosion has not reached.  Per vertex a *rust coverage* c in [0, 1]
says how much of the surface is corroded and a *gilding* fraction g in
[0, 1] how much of the uncorroded rest still carries gold leaf (the rest is
bare, worn bronze).  c drives

- the Beckmann roughness ``m = m_exposed + (m_rust - m_exposed) c``
  (source paper 4.3: the spread of rust is used as the roughness), and
- the thickness of each corrosion layer, which grows in the order the
  corrosion forms (source paper 4.4; Dorsey & Hanrahan 1996): cuprite next
  to the metal first (``X = X_max clip(c / c_full)``), the green basic
  salts on top of it later (``X = X_max clip((c - c_start) / (1 - c_start))``),
  so a thin patina shows cuprite red-brown and a thick one green,

and the BRDF is the area-weighted mix of the exposed metals (Torrance-Sparrow
with conductor Fresnel) and the corroded part (Torrance-Sparrow with
dielectric Fresnel over the Kubelka-Munk stack on bronze, with the
interface's internal reflection, :func:`shellrepair.shading.layered_diffuse`)::

    f = (1 - c) [g f_TS,gold + (1 - g) f_TS,bronze]
        + c [f_TS,patina + rho_dt(i) rho_dt(o) R_eff(c, d) / pi]
    R_eff = R_KM (1 - r_i) / (rho_bar (1 - r_i R_KM))

where a dark crust d in [0, 1] (soot and sulphates where rain does not wash
the patina) is mixed into the outermost layer by eq 7.  c, g and d per
vertex come from the scan's colours or from :mod:`shellrepair.aging`.

Colour is three channels at the wavelengths :data:`RGB_WAVELENGTHS_NM`.

References
----------
.. [1] P. B. Johnson and R. W. Christy, "Optical Constants of the Noble
   Metals", Phys. Rev. B 6, 4370-4379, 1972 (Au and Cu n, k).
.. [2] J. Dorsey and P. Hanrahan, "Modeling and Rendering of Metallic
   Patinas", SIGGRAPH 1996.
.. [3] J. W. Anthony et al., Handbook of Mineralogy, Mineralogical Society
   of America (refractive indices of malachite and brochantite).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import shading as sh

__all__ = [
    "RGB_WAVELENGTHS_NM",
    "Conductor",
    "KMLayer",
    "Material",
    "GOLD_LEAF",
    "BRONZE",
    "CUPRITE",
    "GREEN_PATINA",
    "DARK_CRUST",
    "MATERIALS",
    "get_material",
    "layer_thicknesses",
    "rust_coverage_from_colors",
    "rust_coverage_from_occlusion",
    "rust_coverage",
    "surface_params",
    "substrate_reflectance",
    "shade_reference",
    "MaterialShader",
    "ModelChoice",
    "choose_model",
    "model_switch_footprint_um",
]

#: Wavelengths (nm) of the R, G, B channels: rows of Johnson & Christy's
#: table, so no interpolation of the published constants is needed.
RGB_WAVELENGTHS_NM = (659.5, 548.6, 450.9)


@dataclasses.dataclass(frozen=True)
class Conductor:
    """A metal: complex refractive index ``n + i k`` per RGB channel."""

    name: str
    n: tuple
    k: tuple
    source: str


@dataclasses.dataclass(frozen=True)
class KMLayer:
    """A Kubelka-Munk layer: K and S per RGB channel in 1/um."""

    name: str
    K: tuple
    S: tuple
    eta: float
    illustrative: bool
    source: str


@dataclasses.dataclass(frozen=True)
class Material:
    """An aged-metal preset.

    Attributes
    ----------
    name : str
    exposed : Conductor
        Metal seen where there is no rust and the gilding holds (gold leaf,
        or bronze for an ungilded statue).
    substrate : Conductor
        Metal under the corrosion layers, and where the gilding is worn off.
    layers : tuple of (KMLayer, X_max, c_start, c_full)
        Corrosion layers from the metal up: thickness (um) at full growth
        and the coverage range over which it grows linearly from 0 to
        X_max (:func:`layer_thicknesses`).  Empty for an uncorroded metal.
    m_exposed, m_rust : float
        Beckmann RMS slope at coverage 0 and 1.
    eta_top : float
        Refractive index of the outermost corrosion layer (the rough
        dielectric interface).
    crust : (KMLayer, float) or None
        A dark deposit mixed into the outermost layer (eq 7) in proportion
        ``crust x p_max`` where the surface is sheltered from washing rain,
        with its largest proportion p_max.
    """

    name: str
    exposed: Conductor
    substrate: Conductor
    layers: tuple
    m_exposed: float
    m_rust: float
    eta_top: float
    crust: tuple = None

    @property
    def corrodes(self):
        return len(self.layers) > 0


GOLD_LEAF = Conductor(
    "gold leaf",
    n=(0.14, 0.43, 1.38),
    k=(3.697, 2.455, 1.914),
    source="Johnson & Christy 1972, Au at 659.5, 548.6, 450.9 nm",
)

#: No standard optical-constant table exists for tin bronze; copper's is the
#: closest published one.  A ~10 % Sn bronze is somewhat less red than this.
BRONZE = Conductor(
    "bronze (copper constants)",
    n=(0.22, 1.02, 1.24),
    k=(3.747, 2.577, 2.397),
    source="Johnson & Christy 1972, Cu at 659.5, 548.6, 450.9 nm (stand-in for Cu-Sn bronze)",
)

#: Cuprite, Cu2O, the red oxide next to the metal.  No published
#: Kubelka-Munk K, S exist for it: the values are ILLUSTRATIVE, chosen only
#: to follow its ~2.1 eV band gap (weak absorption in red, strong in green
#: and blue) and so that 4 um of it on copper, under the eta = 1.75
#: interface, looks red-brown (diffuse albedo ~ (0.27, 0.03, 0.013), sRGB
#: ~ (141, 48, 30); docs/shading.md).  Its index (n ~ 2.85, Handbook of
#: Mineralogy) is not used for an interface because it lies under the green
#: patina.
CUPRITE = KMLayer(
    "cuprite",
    K=(0.08, 1.2, 3.0),
    S=(0.3, 0.3, 0.3),
    eta=2.85,
    illustrative=True,
    source="illustrative K, S (no published values); n from Handbook of Mineralogy",
)

#: Green patina of basic copper salts (brochantite / malachite).  No
#: published K, S: the values are ILLUSTRATIVE (absorb red, scatter
#: weakly), chosen so that a thick layer, seen through the eta = 1.75
#: interface with its internal reflection, has the diffuse albedo
#: ~ (0.07, 0.30, 0.20) (sRGB ~ (75, 150, 125)) of a verdigris patina rather
#: than a pastel mint; K/S = (1.4, 0.11, 0.27).  eta = 1.75 lies within the
#: principal indices of brochantite (1.73-1.80) and malachite (1.66-1.91),
#: Handbook of Mineralogy.
GREEN_PATINA = KMLayer(
    "green patina",
    K=(0.2, 0.022, 0.045),
    S=(0.1, 0.1, 0.1),
    eta=1.75,
    illustrative=True,
    source="illustrative K, S (no published values); eta from Handbook of Mineralogy",
)

#: Dark crust on sheltered outdoor bronze: soot and sulphate deposits that
#: rain does not wash away (Graedel 1987; Scott 2002).  ILLUSTRATIVE K, S: a
#: black, weakly scattering pigment, mixed into the green layer by eq 7.
DARK_CRUST = KMLayer(
    "dark crust",
    K=(1.5, 1.5, 1.5),
    S=(0.1, 0.1, 0.1),
    eta=1.75,
    illustrative=True,
    source="illustrative K, S (a black deposit); dark crusts on sheltered bronze: Graedel 1987, Scott 2002",
)

MATERIALS = {
    "aged-bronze": Material(
        "aged-bronze",
        exposed=GOLD_LEAF,
        substrate=BRONZE,
        # cuprite forms first (full 4 um at c = 0.3), the green salts grow
        # on it from c = 0.25 to 40 um at c = 1
        layers=((CUPRITE, 4.0, 0.0, 0.3), (GREEN_PATINA, 40.0, 0.25, 1.0)),
        m_exposed=0.15,
        m_rust=0.45,
        eta_top=GREEN_PATINA.eta,
        crust=(DARK_CRUST, 0.06),
    ),
    "gilt": Material("gilt", GOLD_LEAF, BRONZE, (), 0.12, 0.12, GREEN_PATINA.eta),
    "bronze": Material("bronze", BRONZE, BRONZE, (), 0.2, 0.2, GREEN_PATINA.eta),
}


def layer_thicknesses(coverage, material):
    """Thickness of each corrosion layer at a rust coverage.

    Parameters
    ----------
    coverage : (...) float array in [0, 1]
    material : Material or str

    Returns
    -------
    X : list of (...) float64 arrays
        Thickness (um) of each layer, from the metal up:
        ``X_max clip((c - c_start) / (c_full - c_start), 0, 1)``.
    """
    mat = get_material(material)
    c = np.clip(np.asarray(coverage, dtype=np.float64), 0.0, 1.0)
    return [xmax * np.clip((c - c0) / (c1 - c0), 0.0, 1.0) for _, xmax, c0, c1 in mat.layers]


def get_material(name):
    """Look up a preset by name.

    Parameters
    ----------
    name : str or Material
        One of ``MATERIALS`` (``aged-bronze``, ``gilt``, ``bronze``), or a
        :class:`Material`, returned as is.

    Returns
    -------
    Material

    Raises
    ------
    ValueError
        For an unknown name; the message lists the known ones.
    """
    if isinstance(name, Material):
        return name
    try:
        return MATERIALS[name]
    except (KeyError, TypeError):
        raise ValueError(
            "unknown material %r; choose one of %s" % (name, ", ".join(sorted(MATERIALS)))
        ) from None


# --------------------------------------------------------------------------
# Rust coverage
# --------------------------------------------------------------------------

#: Hue (degrees) at which a colour starts / stops reading as green patina.
_PATINA_HUE = (75.0, 105.0, 200.0, 250.0)
#: Saturation at which the hue is fully trusted (greys carry no rust cue).
_SAT_FULL = 0.25
#: Median saturation below which vertex colours are treated as uninformative.
_SAT_UNINFORMATIVE = 0.05


def _smoothstep(a, b, x):
    t = np.clip((x - a) / (b - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _hue_sat(rgb):
    rgb = np.asarray(rgb, dtype=np.float64)
    mx = rgb.max(axis=-1)
    mn = rgb.min(axis=-1)
    d = mx - mn
    sat = np.where(mx > 0.0, d / np.where(mx > 0.0, mx, 1.0), 0.0)
    ds = np.where(d > 0.0, d, 1.0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    h = np.where(mx == r, ((g - b) / ds) % 6.0, np.where(mx == g, (b - r) / ds + 2.0, (r - g) / ds + 4.0))
    return np.where(d > 0.0, 60.0 * h, 0.0), sat


def rust_coverage_from_colors(vertex_colors):
    """Rust coverage from scanned vertex colours.

    Parameters
    ----------
    vertex_colors : (n,3) numpy uint8 array (or floats in [0, 1])

    Returns
    -------
    c : (n,) float64 array in [0, 1]

    Notes
    -----
    A heuristic, not a measurement: green-blue hues (about 90-230 degrees)
    read as green patina (c -> 1), red-yellow hues (gold leaf, bronze) as
    exposed metal (c -> 0); the hue is trusted in proportion to the
    saturation (full at 0.25) and unsaturated colours give 0.5.
    """
    col = np.asarray(vertex_colors)
    if col.ndim != 2 or col.shape[1] != 3:
        raise ValueError("vertex_colors must be (n,3), got shape %s" % (col.shape,))
    rgb = col.astype(np.float64) / 255.0 if col.dtype == np.uint8 else col.astype(np.float64)
    hue, sat = _hue_sat(np.clip(rgb, 0.0, 1.0))
    a0, a1, b0, b1 = _PATINA_HUE
    green = _smoothstep(a0, a1, hue) * (1.0 - _smoothstep(b0, b1, hue))
    w = np.clip(sat / _SAT_FULL, 0.0, 1.0)
    return w * green + (1.0 - w) * 0.5


def _fibonacci_sphere(n):
    i = np.arange(n, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def vertex_normals(V, F):
    """Area-weighted unit vertex normals.

    Parameters
    ----------
    V : (n,3) numpy float array
    F : (m,3) numpy int array

    Returns
    -------
    N : (n,3) float64 array; (0, 0, 1) at isolated or degenerate vertices.
    """
    from .topology import face_normals

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fn = face_normals(V, F)
    N = np.empty_like(V)
    idx = F.ravel()
    for k in range(3):  # bincount is much faster than np.add.at
        N[:, k] = np.bincount(idx, np.repeat(fn[:, k], 3), minlength=len(V))
    ln = np.linalg.norm(N, axis=1)
    ok = ln > 0.0
    N[ok] /= ln[ok, None]
    N[~ok] = (0.0, 0.0, 1.0)
    return N


def rust_coverage_from_occlusion(V, F, *, n_dirs=16, radius=0.1, base=0.2, gain=1.6, subset=None, normals=None,
                                 scene=None):
    """Rust coverage from an ambient-occlusion estimate.

    Parameters
    ----------
    V : (n,3) numpy float array
    F : (m,3) numpy int array
    n_dirs : int, optional
        Ray directions on a fixed Fibonacci sphere (deterministic); those in
        each vertex's upper hemisphere are used.
    radius : float, optional
        Rays longer than ``radius`` x bounding-box diagonal count as open sky.
    base, gain : float, optional
        ``c = clip(base + gain * occlusion, 0, 1)``.
    subset : (k,) int array or None, optional
        Only these vertices are estimated (e.g. those a render can see);
        the others get ``base``.
    normals : (n,3) float array or None, optional
        :func:`vertex_normals` of the mesh, when the caller has them.
    scene : open3d.t.geometry.RaycastingScene or None, optional
        A scene holding exactly this mesh, when the caller has built one
        (building it is a large part of the time on big meshes).

    Returns
    -------
    c : (n,) float64 array in [0, 1]

    Notes
    -----
    A heuristic in the spirit of Dorsey & Hanrahan's exposure maps:
    recesses keep moisture and dirt and corrode first, exposed convex parts
    keep their gilding.  Occlusion is the cosine-weighted fraction of
    directions whose ray hits the mesh within the radius.
    """
    import open3d as o3d

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    N = vertex_normals(V, F) if normals is None else np.asarray(normals, np.float64)
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if len(V) else 1.0
    diag = diag if diag > 0.0 else 1.0
    if scene is None:
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    dirs = _fibonacci_sphere(int(n_dirs))
    idx = np.arange(len(V)) if subset is None else np.unique(np.asarray(subset, dtype=np.int64))
    out = np.full(len(V), float(np.clip(base, 0.0, 1.0)))
    N = N[idx]
    occ = np.zeros(len(idx))
    wsum = np.zeros(len(idx))
    origin = V[idx] + (1e-4 * diag) * N
    for d in dirs:
        w = N @ d
        up = w > 0.05
        if not np.any(up):
            continue
        rays = np.concatenate([origin[up], np.broadcast_to(d, (int(up.sum()), 3))], axis=1)
        t = scene.cast_rays(o3d.core.Tensor(rays.astype(np.float32)))["t_hit"].numpy()
        hit = t < radius * diag
        occ[up] += w[up] * hit
        wsum[up] += w[up]
    occlusion = occ / np.maximum(wsum, 1e-12)
    out[idx] = np.clip(base + gain * occlusion, 0.0, 1.0)
    return out


def rust_coverage(V, F, vertex_colors=None, *, subset=None, normals=None, scene=None,
                  colors_only=False):
    """Per-vertex rust coverage: from colours when informative, else occlusion.

    Parameters
    ----------
    V : (n,3) numpy float array
    F : (m,3) numpy int array
    vertex_colors : (n,3) numpy uint8 array or None
    subset : (k,) int array or None
        Vertices that need the occlusion estimate (see
        :func:`rust_coverage_from_occlusion`).
    normals : (n,3) float array or None
        :func:`vertex_normals`, when the caller has them.
    scene : open3d RaycastingScene or None
        See :func:`rust_coverage_from_occlusion`.

    Returns
    -------
    c : (n,) float64 array in [0, 1]
    source : str
        ``"colors"`` or ``"occlusion"`` (colours that are nearly grey, median
        saturation below 0.05, carry no rust cue and are ignored).
    colors_only : bool
        Return ``(None, None)`` instead of estimating occlusion when the
        colours carry no cue (the renderer then uses
        :func:`shellrepair.aging.aging_maps`).
    """
    if vertex_colors is not None:
        col = np.asarray(vertex_colors)
        rgb = col.astype(np.float64) / 255.0 if col.dtype == np.uint8 else col.astype(np.float64)
        _, sat = _hue_sat(np.clip(rgb, 0.0, 1.0))
        if len(sat) and np.median(sat) >= _SAT_UNINFORMATIVE:
            return rust_coverage_from_colors(col), "colors"
    if colors_only:
        return None, None
    return rust_coverage_from_occlusion(V, F, subset=subset, normals=normals, scene=scene), "occlusion"


# --------------------------------------------------------------------------
# The full model: reference composition and the fast shader
# --------------------------------------------------------------------------


def surface_params(coverage, material):
    """Roughness and layer thicknesses driven by the rust coverage.

    Parameters
    ----------
    coverage : (...) float array in [0, 1]
    material : Material or str

    Returns
    -------
    m : (...) float64 array
        ``m_exposed + (m_rust - m_exposed) c``.
    X : list of (...) float64 arrays
        Thickness (um) of each corrosion layer (:func:`layer_thicknesses`).
    """
    mat = get_material(material)
    c = np.clip(np.asarray(coverage, dtype=np.float64), 0.0, 1.0)
    m = mat.m_exposed + (mat.m_rust - mat.m_exposed) * c
    return m, layer_thicknesses(c, mat)


def substrate_reflectance(material):
    """Diffuse reflectance of the metal under the corrosion layers.

    Returns
    -------
    Rg : (3,) float64 array

    Notes
    -----
    Approximated by the conductor's normal-incidence Fresnel reflectance
    seen from inside the top layer (index relative to ``eta_top``); for
    gold and copper its hemispherical average differs by a few percent.
    """
    mat = get_material(material)
    n = np.asarray(mat.substrate.n) / mat.eta_top
    k = np.asarray(mat.substrate.k) / mat.eta_top
    return sh.fresnel_conductor(1.0, n, k)


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
            j, w = sh._axis_index(lm, L[0], L[1] - L[0], L.size)
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
    sigma_a, sigma_s' (:func:`shellrepair.shading.km_to_transport`); the
    dipole profile's radial integral (:func:`shellrepair.shading.dipole_tail_fraction`)
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
