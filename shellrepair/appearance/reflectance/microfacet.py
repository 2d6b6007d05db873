"""Microfacet terms of the rough interface: Beckmann D, V-cavity G, Fresnel F.

The Torrance-Sparrow BRDF of the source paper (eqs 8-13) for a rough
dielectric (the corrosion layer's surface) and, with the conductor Fresnel
term, for exposed metal (gold leaf, bronze)::

    f_r(i, o) = D(h) G(i, o) F(i.h) / (4 (n.i)(n.o))

Parameters, defaults and valid ranges
-------------------------------------
- directions ``(..., 3)`` unit vectors that broadcast against each other;
  all arithmetic is float64.
- Beckmann roughness ``m`` (RMS slope) > 0; below :data:`M_MIN` it is clamped.
- dielectric relative index ``eta`` > 0 (``eta < 1``: total internal
  reflection past the critical angle); conductor index ``n + i k`` with
  ``n > 0, k >= 0``.

Numerical guards: cosines <= :data:`COS_EPS` are on the horizon (D and f
are 0 there); the cosines of eq 8's denominator are floored at
:data:`MU_FLOOR`; denominators that are mathematically positive are floored
at ``_TINY``.

References
----------
.. [1] Yamamoto, Shiba, Okada, "A Reflection Model for Representation of
   Gilt Bronze Statues with Aging Degradation" (the source paper), eqs 8-13.
.. [2] R. L. Cook and K. E. Torrance, "A Reflectance Model for Computer
   Graphics", ACM TOG 1(1), 1982.
"""

from __future__ import annotations

import numpy as np

# the guards, documented in their module and shared with the compiled kernels
from shellrepair.appearance.reflectance._constants import _TINY, COS_EPS, M_MIN, MU_FLOOR
from shellrepair.appearance.reflectance.dispatch import directional, elementwise, kernels

__all__ = [
    "M_MIN",
    "COS_EPS",
    "MU_FLOOR",
    "beckmann_D",
    "v_cavity_G",
    "fresnel_dielectric",
    "fresnel_conductor",
    "torrance_sparrow",
    "torrance_sparrow_conductor",
]


def _dot(a, b):
    """Dot product over the last axis, broadcasting ``(..., 3)`` arrays."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]

# --------------------------------------------------------------------------
# Microfacet terms (eqs 8-13)
# --------------------------------------------------------------------------


def beckmann_D(cos_theta_h, m):
    """Beckmann microfacet distribution, normalised over projected area.

    Parameters
    ----------
    cos_theta_h : (...) float array
        Cosine between the microfacet normal h and the macro normal n.
        Clamped to [0, 1]; values <= :data:`COS_EPS` give 0.
    m : (...) float array
        RMS slope (the paper's S_rough), clamped below at :data:`M_MIN`.

    Returns
    -------
    D : (...) float64 array
        Distribution value (1/sr), satisfying
        ``integral D(h) (n.h) dw_h = 1`` over the hemisphere.

    Notes
    -----
    Paper eq 13 is ``D = exp(-(tan d / m)^2) / (m^2 cos^4 d)``.  It leaves
    out the factor 1/pi, so its projected area integrates to pi, not 1;
    used in eq 3 the specular albedo then exceeds 1 at grazing angles and
    rho_dt goes negative.  This implementation uses the normalised form
    (Cook & Torrance 1982)::

        D = exp(-tan^2(theta_h) / m^2) / (pi m^2 cos^4(theta_h))

    tan^2 is formed as (1 - c^2)/c^2, and D is set to 0 for
    c <= COS_EPS, where exp underflows to 0 and c^4 to 0.

    References
    ----------
    Cook & Torrance 1982; source paper eq 13.

    Examples
    --------
    >>> round(float(beckmann_D(1.0, 0.5)), 6)   # 1 / (pi m^2)
    1.27324
    """
    K = kernels("microfacet")
    if K is not None:
        return elementwise(K.beckmann_D, (cos_theta_h, m))
    return _beckmann_D_np(cos_theta_h, m)


def _beckmann_D_np(cos_theta_h, m):
    """NumPy version of :func:`beckmann_D` (the test oracle of the compiled kernel)."""
    c = np.clip(np.asarray(cos_theta_h, dtype=np.float64), 0.0, 1.0)
    m = np.maximum(np.asarray(m, dtype=np.float64), M_MIN)
    ok = c > COS_EPS
    cs = np.where(ok, c, 1.0)
    c2 = cs * cs
    m2 = m * m
    tan2 = (1.0 - c2) / c2  # tan^2(theta_h)
    D = np.exp(-tan2 / m2) / (np.pi * m2 * c2 * c2)  # eq 13 with the 1/pi
    return np.where(ok, D, 0.0)


def v_cavity_G(n_dot_h, n_dot_i, n_dot_o, o_dot_h):
    """V-cavity geometric attenuation (masking and shadowing).

    Parameters
    ----------
    n_dot_h, n_dot_i, n_dot_o : (...) float arrays
        Cosines of the half vector, incident and outgoing directions with the
        macro normal; clamped to [0, 1].
    o_dot_h : (...) float array
        Cosine between the outgoing direction and the half vector (equal to
        i.h).  Where it is <= 0 the facet is back-facing and G = 0.

    Returns
    -------
    G : (...) float64 array in [0, 1]

    Notes
    -----
    Paper eqs 9-11 (Cook & Torrance 1982)::

        G1 = 2 (n.h)(n.o) / (o.h)            (eq 9, masking)
        G2 = 2 (n.h)(n.i) / (o.h)            (eq 10, shadowing)
        G  = min(1, G1, G2)                  (eq 11)

    G is symmetric in i and o, so the BRDF stays reciprocal.

    Examples
    --------
    >>> float(v_cavity_G(1.0, 1.0, 1.0, 1.0))
    1.0
    """
    K = kernels("microfacet")
    if K is not None:
        return elementwise(K.v_cavity_G, (n_dot_h, n_dot_i, n_dot_o, o_dot_h))
    return _v_cavity_G_np(n_dot_h, n_dot_i, n_dot_o, o_dot_h)


def _v_cavity_G_np(n_dot_h, n_dot_i, n_dot_o, o_dot_h):
    """NumPy version of :func:`v_cavity_G` (the test oracle of the compiled kernel)."""
    nh = np.clip(np.asarray(n_dot_h, dtype=np.float64), 0.0, 1.0)
    ni = np.clip(np.asarray(n_dot_i, dtype=np.float64), 0.0, 1.0)
    no = np.clip(np.asarray(n_dot_o, dtype=np.float64), 0.0, 1.0)
    oh = np.asarray(o_dot_h, dtype=np.float64)
    front = oh > 0.0
    ohs = np.where(front, oh, 1.0)
    g1 = 2.0 * nh * no / ohs  # eq 9
    g2 = 2.0 * nh * ni / ohs  # eq 10
    G = np.minimum(1.0, np.minimum(g1, g2))  # eq 11
    return np.where(front, G, 0.0)


def fresnel_dielectric(cos_i, eta):
    """Unpolarised Fresnel reflectance of a dielectric interface.

    Parameters
    ----------
    cos_i : (...) float array
        Cosine of the angle of incidence (on the microfacet, c = i.h).  Its
        absolute value is used, clamped to [0, 1].
    eta : (...) float array
        Relative refractive index (transmitted / incident side), > 0.

    Returns
    -------
    F : (...) float64 array in [0, 1]
        1 past the critical angle (eta < 1, total internal reflection).

    Notes
    -----
    Paper eq 12 (Cook & Torrance 1982)::

        g = sqrt(eta^2 + c^2 - 1)
        F = 1/2 (g-c)^2/(g+c)^2 (1 + (c(g+c)-1)^2 / (c(g-c)+1)^2)

    ``eta^2 + c^2 - 1 < 0`` means total internal reflection, F = 1.

    Examples
    --------
    >>> round(float(fresnel_dielectric(1.0, 1.5)), 6)   # ((n-1)/(n+1))^2
    0.04
    """
    K = kernels("microfacet")
    if K is not None:
        return elementwise(K.fresnel_dielectric, (cos_i, eta))
    return _fresnel_dielectric_np(cos_i, eta)


def _fresnel_dielectric_np(cos_i, eta):
    """NumPy version of :func:`fresnel_dielectric` (the test oracle of the compiled kernel)."""
    c = np.clip(np.abs(np.asarray(cos_i, dtype=np.float64)), 0.0, 1.0)
    eta = np.asarray(eta, dtype=np.float64)
    g2 = eta * eta + c * c - 1.0
    tir = g2 < 0.0
    g = np.sqrt(np.where(tir, 0.0, g2))
    a = (g - c) / np.maximum(g + c, _TINY)
    b = (c * (g + c) - 1.0) / np.maximum(c * (g - c) + 1.0, _TINY)
    F = 0.5 * a * a * (1.0 + b * b)  # eq 12
    return np.where(tir, 1.0, np.clip(F, 0.0, 1.0))


def fresnel_conductor(cos_i, n, k):
    """Exact unpolarised Fresnel reflectance of a conductor ``n + i k``.

    Parameters
    ----------
    cos_i : (...) float array
        Cosine of the angle of incidence; absolute value, clamped to [0, 1].
    n, k : (...) float arrays
        Real and imaginary parts of the complex refractive index relative
        to the incident medium (n > 0, k >= 0).  With k = 0 this equals
        :func:`fresnel_dielectric`.

    Returns
    -------
    F : (...) float64 array in [0, 1]

    Notes
    -----
    With c = cos i, s^2 = 1 - c^2 and ``a^2 + b^2 = |(n + ik)^2 - s^2|``,
    ``a = sqrt((|(n+ik)^2 - s^2| + n^2 - k^2 - s^2) / 2)`` (the real part of
    the complex cosine of refraction times n + ik), the s- and p-polarised
    reflectances are (Born & Wolf, ch. 14; Cook & Torrance 1982)::

        Rs = (a^2 + b^2 - 2 a c + c^2) / (a^2 + b^2 + 2 a c + c^2)
        Rp = Rs (c^2 (a^2+b^2) - 2 a c s^2 + s^4)
                / (c^2 (a^2+b^2) + 2 a c s^2 + s^4)
        F  = (Rs + Rp) / 2

    The Rp form is multiplied through by c^2 so it stays finite at grazing
    incidence (c = 0 gives Rs = Rp = 1).

    References
    ----------
    M. Born and E. Wolf, Principles of Optics, ch. 14 (metals).

    Examples
    --------
    >>> round(float(fresnel_conductor(1.0, 0.43, 2.455)), 4)  # gold, 549 nm
    0.7869
    """
    K = kernels("microfacet")
    if K is not None:
        return elementwise(K.fresnel_conductor, (cos_i, n, k))
    return _fresnel_conductor_np(cos_i, n, k)


def _fresnel_conductor_np(cos_i, n, k):
    """NumPy version of :func:`fresnel_conductor` (the test oracle of the compiled kernel)."""
    c = np.clip(np.abs(np.asarray(cos_i, dtype=np.float64)), 0.0, 1.0)
    n = np.asarray(n, dtype=np.float64)
    k = np.asarray(k, dtype=np.float64)
    c2 = c * c
    s2 = 1.0 - c2
    t = n * n - k * k - s2
    a2b2 = np.sqrt(t * t + 4.0 * n * n * k * k)  # |(n+ik)^2 - s^2|
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t), 0.0))
    rs_num = a2b2 - 2.0 * a * c + c2
    rs_den = a2b2 + 2.0 * a * c + c2
    Rs = rs_num / np.maximum(rs_den, _TINY)
    p1 = c2 * a2b2 + s2 * s2
    p2 = 2.0 * a * c * s2
    Rp = Rs * (p1 - p2) / np.maximum(p1 + p2, _TINY)
    return np.clip(0.5 * (Rs + Rp), 0.0, 1.0)


def _microfacet_geometry(wi, wo, n, m):
    """Shared D G / (4 ni no) factor and the Fresnel cosine o.h.

    Returns ``(DG4, oh, valid)`` where ``DG4 = D G / (4 (n.i)(n.o))`` formed
    stably as ``D/4 * min(1/(ni no), 2nh/(oh ni), 2nh/(oh no))`` and zero
    below the horizon.
    """
    wi = np.asarray(wi, dtype=np.float64)
    wo = np.asarray(wo, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    ni = _dot(n, wi)
    no = _dot(n, wo)
    hv = wi + wo
    hlen = np.sqrt(_dot(hv, hv))
    valid = (ni > COS_EPS) & (no > COS_EPS) & (hlen > COS_EPS)
    hv = hv / np.where(valid, hlen, 1.0)[..., None]
    nh = np.clip(_dot(n, hv), 0.0, 1.0)
    oh = np.clip(_dot(wo, hv), 0.0, 1.0)
    # grazing guard: the cosines of eq 8's denominator are floored at MU_FLOOR
    nis = np.maximum(np.where(valid, ni, 1.0), MU_FLOOR)
    nos = np.maximum(np.where(valid, no, 1.0), MU_FLOOR)
    ohs = np.maximum(oh, COS_EPS)
    # G / (ni no) with G = min(1, 2 nh no / oh, 2 nh ni / oh)   (eq 11)
    g_over = np.minimum(1.0 / (nis * nos), 2.0 * nh / (ohs * np.maximum(nis, nos)))
    D = _beckmann_D_np(nh, m)  # eq 13 (normalised)
    DG4 = np.where(valid, 0.25 * D * g_over, 0.0)  # eq 8 without F
    return DG4, oh, valid


def torrance_sparrow(wi, wo, n, m, eta):
    """Torrance-Sparrow BRDF of a rough dielectric interface (eq 8).

    Parameters
    ----------
    wi, wo : (..., 3) float arrays
        Unit directions towards the light and towards the viewer.
    n : (..., 3) float array
        Unit macro-surface normal.
    m : (...) float array
        Beckmann RMS slope (clamped at :data:`M_MIN`).
    eta : (...) float array
        Relative refractive index of the interface.

    Returns
    -------
    f : (...) float64 array
        BRDF value (1/sr); 0 where either direction is at or below the
        horizon (cosine <= :data:`COS_EPS`), finite at grazing angles.

    Notes
    -----
    Paper eq 8::

        f_r = D(h) G(i, o) F(i.h) / (4 (n.i)(n.o))

    with h = (i + o)/|i + o|, D eq 13 (normalised, see :func:`beckmann_D`),
    G eq 11, F eq 12.  ``G / ((n.i)(n.o))`` is evaluated as
    ``min(1/(ni no), 2 nh/(oh max(ni, no)))`` which is the same quantity
    with no 0/0 as a direction grazes.  Symmetric in wi and wo.

    Grazing guard: in that denominator n.i and n.o are floored at
    :data:`MU_FLOOR` (cos 89.5 deg), which bounds
    ``f (n.i) <= 1 / (4 pi m^2 MU_FLOOR)`` and can only lower the albedo.

    References
    ----------
    Cook & Torrance 1982; source paper eqs 8-13.
    """
    K = kernels("microfacet")
    if K is not None:
        f = directional(K.torrance_sparrow, (wi, wo, n), (m, eta))
        if f is not None:
            return f
    return _torrance_sparrow_np(wi, wo, n, m, eta)


def _torrance_sparrow_np(wi, wo, n, m, eta):
    """NumPy version of :func:`torrance_sparrow` (the test oracle of the compiled kernel)."""
    DG4, oh, _ = _microfacet_geometry(wi, wo, n, m)
    return DG4 * _fresnel_dielectric_np(oh, eta)  # eq 8


def torrance_sparrow_conductor(wi, wo, n, m, n_metal, k_metal):
    """Torrance-Sparrow BRDF with the conductor Fresnel term, per channel.

    Parameters
    ----------
    wi, wo, n : (..., 3) float arrays
        Unit directions (light, viewer) and unit normal.
    m : (...) float array
        Beckmann RMS slope.
    n_metal, k_metal : (C,) float arrays
        Complex refractive index per colour channel.

    Returns
    -------
    f : (..., C) float64 array
        BRDF per channel (1/sr), 0 below the horizon.

    Notes
    -----
    Eq 8 with F replaced by :func:`fresnel_conductor` (gold leaf, bronze).
    """
    K = kernels("microfacet")
    nm, km = np.asarray(n_metal, dtype=np.float64), np.asarray(k_metal, dtype=np.float64)
    if K is not None and nm.ndim <= 1 and nm.shape == km.shape:
        nm, km = np.ascontiguousarray(nm.reshape(-1)), np.ascontiguousarray(km.reshape(-1))
        f = directional(K.torrance_sparrow_conductor, (wi, wo, n), (m,), extra=(nm, km), C=nm.size)
        if f is not None:
            return f
    return _torrance_sparrow_conductor_np(wi, wo, n, m, n_metal, k_metal)


def _torrance_sparrow_conductor_np(wi, wo, n, m, n_metal, k_metal):
    """NumPy version of :func:`torrance_sparrow_conductor` (the test oracle of the compiled kernel)."""
    DG4, oh, _ = _microfacet_geometry(wi, wo, n, m)
    F = _fresnel_conductor_np(oh[..., None], n_metal, k_metal)
    return DG4[..., None] * F
