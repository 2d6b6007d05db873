"""The local layered BRDF: rough dielectric interface over a Kubelka-Munk stack.

Eq 2 of the source paper with the distance-dependent R_d collapsed to a
point (R_d -> R_KM), plus the specular lobe of eq 8 and the light the
interface reflects back down (a Saunderson-type correction)::

    f(wi, wo) = f_spec(wi, wo) + rho_dt(wi) R_KM rho_dt(wo) (1 - r_i) / (pi rho_bar (1 - r_i R_KM))

Built from :mod:`.microfacet` (f_spec) and :mod:`.albedo` (rho_dt,
rho_bar, r_i); R_KM comes from :mod:`.km`.

References
----------
.. [1] Yamamoto, Shiba, Okada (the source paper), eqs 2-3, 8.
.. [2] J. L. Saunderson, "Calculation of the Color of Pigmented Plastics",
   JOSA 32, 1942.
"""

from __future__ import annotations

import numpy as np

from shellrepair.appearance.reflectance.albedo import (
    RHO_DT_ETA_RANGE,
    _diffuse_transmittance_np,
    _internal_reflectance_np,
    _mean_transmittance_np,
    rho_dt_table,
)
from shellrepair.appearance.reflectance.dispatch import directional, kernels, with_rows
from shellrepair.appearance.reflectance.microfacet import _TINY, COS_EPS, _dot, _torrance_sparrow_np

__all__ = ["layered_diffuse", "local_brdf"]


def layered_diffuse(cos_i, cos_o, m, eta, R_km):
    """Diffuse BRDF of a Kubelka-Munk stack under a rough dielectric interface.

    Parameters
    ----------
    cos_i, cos_o : (...) float arrays
        Cosines of the light and view directions with the normal; 0 at or
        below the horizon (<= :data:`COS_EPS`).
    m, eta : (...) float arrays
        Roughness and relative index of the interface.
    R_km : (..., C) float array
        Diffuse reflectance of the stack below the interface, per channel.

    Returns
    -------
    f_d : (..., C) float64 array
        BRDF (1/sr).

    Notes
    -----
    Eq 2 in its local form (R_d -> R_KM at a point) with the light that the
    interface reflects back down counted (a Saunderson-type correction,
    Saunderson 1942)::

        f_d = rho_dt(i) rho_dt(o) R / (pi eta^2 (1 - r_i R))

    Light enters with probability rho_dt(i) (eq 3), is reflected diffusely
    by the stack (R), leaves with probability 1 - r_i = rho_bar / eta^2
    (:func:`internal_reflectance`) or goes back down for another round
    (the geometric series 1 / (1 - r_i R)); by reciprocity the leaving light
    is distributed as rho_dt(o) cos(o), normalised by pi rho_bar.  It is
    evaluated as ``rho_dt(i) rho_dt(o) R (1 - r_i) / (pi rho_bar (1 - r_i R))``,
    equal to the form above where ``1 - r_i = rho_bar / eta^2`` and, where
    the single-scattering lobe makes rho_bar / eta^2 exceed 1 (rough
    interfaces with eta < 1, r_i clamped to 0), still never creating
    energy.  rho_bar is the exact mean of the rho_dt read
    (:func:`mean_transmittance`), so with R = 1 the diffuse term returns
    exactly rho_dt(o), and rho_dt(o) <= 1 - A_spec(o) (the table is a lower
    envelope, :func:`diffuse_transmittance`): the directional albedo of
    ``f_TS + f_d`` is at most 1 (white furnace, tests/test_shading.py), and
    with eta = 1 it is Lambert's R / pi.  Without the correction a white stack under an
    eta = 1.75 interface reflects only rho_bar ~ 0.9 of what enters.
    """
    K = kernels("layered")
    a = rho_dt_table().kernel_args if K is not None else None
    if a is not None:
        return with_rows(K.layered_diffuse, (cos_i, cos_o, m, eta), R_km, a + RHO_DT_ETA_RANGE)
    return _layered_diffuse_np(cos_i, cos_o, m, eta, R_km)


def _layered_diffuse_np(cos_i, cos_o, m, eta, R_km):
    """NumPy version of :func:`layered_diffuse` (the test oracle of the compiled kernel)."""
    ci = np.asarray(cos_i, dtype=np.float64)
    co = np.asarray(cos_o, dtype=np.float64)
    above = (ci > COS_EPS) & (co > COS_EPS)
    t_i = _diffuse_transmittance_np(ci, m, eta)  # eq 3 at wi
    t_o = _diffuse_transmittance_np(co, m, eta)  # eq 3 at wo
    rho_bar = _mean_transmittance_np(m, eta)
    r_i = _internal_reflectance_np(m, eta)
    R = np.asarray(R_km, dtype=np.float64)
    # eq 2, local form; (1 - r_i) / rho_bar = 1 / eta^2 where reciprocity holds
    scale = np.where(above, t_i * t_o * (1.0 - r_i) / (np.pi * np.maximum(rho_bar, _TINY)), 0.0)
    return scale[..., None] * R / (1.0 - r_i[..., None] * R)  # internal reflections

# --------------------------------------------------------------------------
# The local layered BRDF (eq 2 with R_d -> R_KM)
# --------------------------------------------------------------------------


def local_brdf(wi, wo, n, m, eta, R_km):
    """Rough dielectric interface over a Kubelka-Munk diffuse stack.

    Parameters
    ----------
    wi, wo, n : (..., 3) float arrays
        Unit light direction, view direction and normal.
    m : (...) float array
        Beckmann RMS slope of the top interface.
    eta : (...) float array
        Relative index of the top layer.
    R_km : (..., C) float array
        Kubelka-Munk reflectance of the layer stack per channel (eq 5, or
        :func:`km_layers`).

    Returns
    -------
    f : (..., C) float64 array
        BRDF (1/sr).

    Notes
    -----
    Eq 2 with the distance-dependent R_d(|x_i - x_o|) collapsed to a point
    (R_d -> R_KM delta(x_i - x_o), as the paper does in 4.2), plus the
    specular reflection of eq 8, with the interface's internal reflection
    (:func:`layered_diffuse`)::

        f = f_TS(i, o) + rho_dt(i) rho_dt(o) R_KM / (pi eta^2 (1 - r_i R_KM))

    Energy: with rho_dt = 1 - A_spec the directional albedo is
    ``A + (1 - A) R_eff <= 1`` where ``R_eff = R (1 - r_i) / (1 - r_i R) <= 1``
    (= 1 for a white stack).
    """
    K = kernels("layered")
    a = rho_dt_table().kernel_args if K is not None else None
    if a is not None:
        f = directional(K.local_brdf, (wi, wo, n), (m, eta), rows=R_km, extra=a + RHO_DT_ETA_RANGE)
        if f is not None:
            return f
    return _local_brdf_np(wi, wo, n, m, eta, R_km)


def _local_brdf_np(wi, wo, n, m, eta, R_km):
    """NumPy version of :func:`local_brdf` (the test oracle of the compiled kernel)."""
    wi = np.asarray(wi, dtype=np.float64)
    wo = np.asarray(wo, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    spec = _torrance_sparrow_np(wi, wo, n, m, eta)  # eq 8
    diff = _layered_diffuse_np(_dot(n, wi), _dot(n, wo), m, eta, R_km)  # eq 2 + Saunderson
    return spec[..., None] + diff
