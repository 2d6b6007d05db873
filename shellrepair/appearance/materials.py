"""Material presets: metals, corrosion layers and how coverage drives them.

The rust-coverage map lives in :mod:`shellrepair.appearance.coverage` (its names
re-exported here) and the shader that reads these presets
(:func:`~shellrepair.appearance.shader.shade_reference`,
:class:`~shellrepair.appearance.shader.MaterialShader`,
:func:`~shellrepair.appearance.shader.choose_model`) in :mod:`shellrepair.appearance.shader`,
which imports this module and is never imported by it.

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
interface's internal reflection, :func:`shellrepair.appearance.reflectance.layered_diffuse`)::

    f = (1 - c) [g f_TS,gold + (1 - g) f_TS,bronze]
        + c [f_TS,patina + rho_dt(i) rho_dt(o) R_eff(c, d) / pi]
    R_eff = R_KM (1 - r_i) / (rho_bar (1 - r_i R_KM))

where a dark crust d in [0, 1] (soot and sulphates where rain does not wash
the patina) is mixed into the outermost layer by eq 7.  c, g and d per
vertex come from the scan's colours or from :mod:`shellrepair.appearance.aging`.

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

from shellrepair.appearance.reflectance.microfacet import fresnel_conductor

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
    return fresnel_conductor(1.0, n, k)


# the rust-coverage map (imports nothing from here, so eagerly)
from shellrepair.appearance.coverage import (
    rust_coverage,
    rust_coverage_from_colors,
    rust_coverage_from_occlusion,
    vertex_normals,
)

