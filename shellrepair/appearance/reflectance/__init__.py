"""Reflectance model for aged gilt bronze (Yamamoto, Shiba & Okada, section 4).

One module per model:

- :mod:`.microfacet`: Beckmann D, V-cavity G, Fresnel F, Torrance-Sparrow (eqs 8-13);
- :mod:`.albedo`: the lobe's directional albedo and the rho_dt table (eq 3);
- :mod:`.km`: Kubelka-Munk layers (eqs 4-7);
- :mod:`.dipole`: dipole diffusion (Jensen et al. 2001), for the model choice;
- :mod:`.layered`: the local layered BRDF that joins them (eq 2).

Each model's per-point functions run compiled kernels (Numba) when they
are on: ``<model>_kernels`` beside each module (:mod:`.microfacet_kernels`,
...; :mod:`.shader_kernels` for :class:`shellrepair.appearance.shader.MaterialShader`;
:mod:`.common_kernels` for what they share), reached through
:mod:`.dispatch`.  Their NumPy versions, the path with the kernels off
(``SHELLREPAIR_NO_NUMBA=1``) and the kernels' test oracles, are gathered in
:mod:`.reference`.


The surface of a gilt-bronze statue after centuries is a rough interface
(Torrance-Sparrow microfacets, paper eqs 8-13) over a stack of corrosion
layers (cuprite, green basic copper salts) on bronze, whose diffuse
reflectance follows Kubelka-Munk theory (eqs 4-7).  Light that enters the
layers is attenuated on the way in and out by the rough interface's
diffuse transmittance rho_dt (eq 3), which gives the local form of the
diffusion BSSRDF of eq 2::

    f(wi, wo) = f_spec(wi, wo) + rho_dt(wi) R_KM rho_dt(wo) / pi

Parameters of every function, defaults and valid ranges
--------------------------------------------------------
- directions ``(..., 3)`` unit vectors that broadcast against each other;
  all arithmetic is float64.
- Beckmann roughness ``m``: RMS microfacet slope, > 0; values below
  :data:`M_MIN` are clamped to it (a smooth surface is a delta that no
  array can hold).
- relative refractive index ``eta`` of a dielectric, > 0 (``eta < 1`` gives
  total internal reflection past the critical angle).
- conductor index ``n + i k`` with ``n > 0, k >= 0``.
- Kubelka-Munk absorption ``K`` and scattering ``S`` (1/um), thickness
  ``X`` (um), background reflectance ``Rg`` in [0, 1].

Numerical guards (grazing cosines, K -> 0, S -> 0, S X -> inf, m -> 0)
live in the modules, not in the tests; each is named where it is applied.

References
----------
.. [1] Yamamoto, Shiba, Okada, "A Reflection Model for Representation of
   Gilt Bronze Statues with Aging Degradation" (the source paper), eqs 1-13.
.. [2] R. L. Cook and K. E. Torrance, "A Reflectance Model for Computer
   Graphics", ACM TOG 1(1), 1982 (Beckmann D, V-cavity G, Fresnel).
.. [3] P. Kubelka and F. Munk, "Ein Beitrag zur Optik der Farbanstriche",
   Z. techn. Physik 12, 593-601, 1931.
.. [4] H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A Practical
   Model for Subsurface Light Transport", SIGGRAPH 2001.
.. [5] C. Donner and H. W. Jensen, "Light Diffusion in Multi-Layered
   Translucent Materials", SIGGRAPH 2005.
"""

from __future__ import annotations

from shellrepair.appearance.reflectance import albedo, dipole, km, layered, microfacet
from shellrepair.appearance.reflectance.albedo import (
    RHO_DT_ETA_RANGE,
    RHO_DT_M_RANGE,
    RHO_DT_MAX_ERROR,
    RhoDtTable,
    diffuse_transmittance,
    internal_reflectance,
    mean_transmittance,
    rho_dt_table,
    specular_albedo,
    u_mean_weights,
)
from shellrepair.appearance.reflectance.dipole import dipole_profile, dipole_rd, dipole_tail_fraction
from shellrepair.appearance.reflectance.km import km_layers, km_mix, km_r_inf, km_reflectance, km_to_transport
from shellrepair.appearance.reflectance.layered import layered_diffuse, local_brdf
from shellrepair.appearance.reflectance.microfacet import (
    COS_EPS,
    M_MIN,
    MU_FLOOR,
    beckmann_D,
    fresnel_conductor,
    fresnel_dielectric,
    torrance_sparrow,
    torrance_sparrow_conductor,
    v_cavity_G,
)

__all__ = [
    "M_MIN",
    "COS_EPS",
    "MU_FLOOR",
    "RHO_DT_M_RANGE",
    "RHO_DT_ETA_RANGE",
    "RHO_DT_MAX_ERROR",
    "beckmann_D",
    "v_cavity_G",
    "fresnel_dielectric",
    "fresnel_conductor",
    "torrance_sparrow",
    "torrance_sparrow_conductor",
    "specular_albedo",
    "diffuse_transmittance",
    "mean_transmittance",
    "internal_reflectance",
    "layered_diffuse",
    "RhoDtTable",
    "u_mean_weights",
    "rho_dt_table",
    "km_r_inf",
    "km_reflectance",
    "km_layers",
    "km_mix",
    "dipole_rd",
    "dipole_tail_fraction",
    "dipole_profile",
    "km_to_transport",
    "local_brdf",
]
