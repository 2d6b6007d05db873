"""Reflectance model for aged gilt bronze (Yamamoto, Shiba & Okada, section 4).

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
live in this module, not in the tests; each is named below.

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

import dataclasses
import functools
import hashlib
import os
import tempfile
import threading

import numpy as np

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

# --------------------------------------------------------------------------
# Named constants
# --------------------------------------------------------------------------

#: Smallest Beckmann roughness (RMS slope, dimensionless).  ``m -> 0`` is a
#: mirror whose D is a Dirac delta; below this value m is clamped.  At
#: m = 1e-3 the lobe is ~0.06 degrees wide, far below a pixel of any render
#: this package makes.
M_MIN = 1e-3

#: Cosines at or below this (dimensionless) count as "on the horizon": the
#: BRDF and the Beckmann D return 0 there instead of evaluating
#: exp(-tan^2/m^2) / cos^4, whose cos^4 underflows.
COS_EPS = 1e-12

#: Floor for denominators that are mathematically positive.
_TINY = np.finfo(np.float64).tiny

#: Domain of the precomputed rho_dt table (roughness m, relative index eta).
#: eta < 1 (the layer optically thinner than the medium above it) is
#: covered too: light arriving outside the critical cone is totally
#: reflected, and the table holds that consistently with the Fresnel term.
RHO_DT_M_RANGE = (0.005, 1.5)
RHO_DT_ETA_RANGE = (0.3, 3.0)

#: Floor (dimensionless) of the cosines n.i and n.o in the denominator
#: 4 (n.i)(n.o) of eq 8: cos(89.5 deg).  Without it a mirror pair of
#: directions both grazing the horizon gives f ~ D / (4 cos^2), 1e6-1e10
#: for the presets' roughness.  Flooring a denominator can only lower f, so
#: the directional albedo stays below its unfloored value (<= 1) and
#: ``f (n.i) <= F D(n.h) / (4 max(n.o, MU_FLOOR)) <= 1 / (4 pi m^2 MU_FLOOR)``.
MU_FLOOR = float(np.cos(np.radians(89.5)))

#: Stated bound on |table - reference quadrature| for incidence up to 89 deg
#: over RHO_DT_M_RANGE x RHO_DT_ETA_RANGE (checked in tests/test_shading.py
#: and measured in eval/bench_shading.py).
RHO_DT_MAX_ERROR = 1e-3


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
    D = beckmann_D(nh, m)  # eq 13 (normalised)
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
    DG4, oh, _ = _microfacet_geometry(wi, wo, n, m)
    return DG4 * fresnel_dielectric(oh, eta)  # eq 8


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
    DG4, oh, _ = _microfacet_geometry(wi, wo, n, m)
    F = fresnel_conductor(oh[..., None], n_metal, k_metal)
    return DG4[..., None] * F


# --------------------------------------------------------------------------
# Directional albedo and rho_dt (eq 3)
# --------------------------------------------------------------------------


def _gauss_legendre01(n):
    x, w = np.polynomial.legendre.leggauss(int(n))
    return 0.5 * (x + 1.0), 0.5 * w


def _albedo_geometry(cos_o, m, n_t, n_phi):
    """Quadrature nodes for the specular albedo at given (cos_o, m).

    ``cos_o`` and ``m`` are 1-D arrays of equal length P.  Returns
    ``(weight, o_dot_h)`` of shape (P, n_phi * n_t) such that
    ``albedo(eta) = sum(weight * F(o_dot_h, eta), axis=-1)``.

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
    The integral of eq 3; ``rho_dt = 1 - A``.  See ``_albedo_geometry`` for
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
        w, oh = _albedo_geometry(c[sl], mm[sl], n_t, n_phi)
        out[sl] = np.sum(w * fresnel_dielectric(oh, ee[sl, None]), axis=-1)
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


def _rule_albedo(cos_theta, m, eta):
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
    The rule every table node holds: ``_albedo_geometry`` at
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
    Fg = fresnel_dielectric(cg[:, None], eta[None, :])  # (Nc, K)
    out = np.empty((c.size, eta.size), dtype=np.float64)
    step = 64
    for s0 in range(0, c.size, step):
        sl = slice(s0, s0 + step)
        w, oh = _albedo_geometry(c[sl], mm[sl], n_t, n_phi)
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
    interpolant is compared with the rule (:func:`_rule_albedo`) at check
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
    at_nodes = 1.0 - _rule_albedo(cos_n, m_n, eta_chk)  # (Nu * Nm, K)
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
    blocks = [(cos_c, m_c, eta_chk, 1.0 - _rule_albedo(cos_c, m_c, eta_chk)),
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
        blocks.append((cs, ms, np.array([e]), 1.0 - _rule_albedo(cs, ms, np.array([e]))))
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
    safety = np.broadcast_to(np.where(kappa < 0.0, _ENVELOPE_SAFETY_TIR, 1.0), vals.shape).ravel()
    for _ in range(200):
        over = (w * flat[idx]).sum(axis=-1) - ref
        pos = over > 0.0
        if not np.any(pos):
            break
        touch = w[pos] > 0.0
        delta = np.zeros(flat.size)
        np.maximum.at(delta, idx[pos][touch], np.broadcast_to(over[pos][:, None], touch.shape)[touch])
        flat = np.clip(flat - safety * delta, 0.0, 1.0)
    vals = flat.reshape(vals.shape)
    return RhoDtTable(u, log_m, kappa, vals)


def _cache_path():
    base = os.environ.get("SHELLREPAIR_CACHE_DIR")
    if not base:
        base = os.path.join(
            os.environ.get("XDG_CACHE_HOME", os.path.join(os.path.expanduser("~"), ".cache")),
            "shellrepair",
        )
    key = repr((_TABLE_VERSION, _ENVELOPE_SAFETY_TIR, _TABLE_N_U, _TABLE_N_M, _TABLE_N_KAPPA, _TABLE_QUAD,
                RHO_DT_M_RANGE, RHO_DT_ETA_RANGE)).encode()
    return os.path.join(base, "rho_dt_%s.npz" % hashlib.sha1(key).hexdigest()[:12])


_TABLE = None
_TABLE_LOCK = threading.Lock()


def rho_dt_table():
    """The rho_dt table, built on first use and cached.

    Returns
    -------
    table : RhoDtTable

    Notes
    -----
    Built by the quadrature rule of :func:`_rule_albedo` at every node and
    at ~10^7 check points for the lower envelope (35-150 s on two busy
    cores, once per machine and table version) and stored as ``.npz`` under ``$SHELLREPAIR_CACHE_DIR``
    or ``~/.cache/shellrepair``; an unwritable cache directory only costs
    the rebuild.  A corrupt cache file is ignored and rebuilt.
    """
    global _TABLE
    with _TABLE_LOCK:
        if _TABLE is not None:
            return _TABLE
        path = _cache_path()
        table = None
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
                os.makedirs(os.path.dirname(path), exist_ok=True)
                fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), suffix=".npz")
                with os.fdopen(fd, "wb") as fh:
                    np.savez(fh, u=table.u, log_m=table.log_m, kappa=table.kappa,
                             values=table.values)
                os.replace(tmp, path)
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
    m, eta = np.broadcast_arrays(np.asarray(m, dtype=np.float64), np.asarray(eta, dtype=np.float64))
    e = np.clip(eta, RHO_DT_ETA_RANGE[0], RHO_DT_ETA_RANGE[1])
    return np.clip(1.0 - mean_transmittance(m, eta) / (e * e), 0.0, 1.0 - 1e-9)


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
    ci = np.asarray(cos_i, dtype=np.float64)
    co = np.asarray(cos_o, dtype=np.float64)
    above = (ci > COS_EPS) & (co > COS_EPS)
    t_i = diffuse_transmittance(ci, m, eta)  # eq 3 at wi
    t_o = diffuse_transmittance(co, m, eta)  # eq 3 at wo
    rho_bar = mean_transmittance(m, eta)
    r_i = internal_reflectance(m, eta)
    R = np.asarray(R_km, dtype=np.float64)
    # eq 2, local form; (1 - r_i) / rho_bar = 1 / eta^2 where reciprocity holds
    scale = np.where(above, t_i * t_o * (1.0 - r_i) / (np.pi * np.maximum(rho_bar, _TINY)), 0.0)
    return scale[..., None] * R / (1.0 - r_i[..., None] * R)  # internal reflections


# --------------------------------------------------------------------------
# Kubelka-Munk (eqs 4-7)
# --------------------------------------------------------------------------


def _km_core(K, S):
    """Return (beta, T, R_inf, delta) without dividing by S.

    beta = sqrt(K (K + 2S)), T = S + K + beta, R_inf = S / T, delta = 1 - R_inf
    = (K + beta) / T.  T = 0 only when K = S = 0 (an empty layer).
    """
    beta = np.sqrt(K * (K + 2.0 * S))
    T = S + K + beta
    Ts = np.where(T > 0.0, T, 1.0)
    R_inf = np.where(T > 0.0, S / Ts, 0.0)
    delta = np.where(T > 0.0, (K + beta) / Ts, 1.0)
    return beta, T, R_inf, delta


def km_r_inf(K, S):
    """Kubelka-Munk reflectance of an infinitely thick layer (eq 6).

    Parameters
    ----------
    K, S : (...) float arrays
        Absorption and scattering coefficients (same unit, >= 0).

    Returns
    -------
    R_inf : (...) float64 array in [0, 1]
        1 for K = 0 < S (conservative), 0 for S = 0 (nothing scatters back).

    Notes
    -----
    Eq 6: ``R_inf = 1 + K/S - sqrt((K/S)^2 + 2 K/S)``.  Because
    ``(1 + a)^2 - (a^2 + 2a) = 1`` this equals ``1 / (1 + a + sqrt(a^2+2a))``
    = ``S / (S + K + sqrt(K (K + 2S)))``, which has no cancellation at
    large K/S and no division by S.

    References
    ----------
    Kubelka & Munk 1931; source paper eq 6.

    Examples
    --------
    >>> float(km_r_inf(0.0, 1.0)), float(km_r_inf(1.0, 0.0))
    (1.0, 0.0)
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    return _km_core(K, S)[2]


def _phi1(z):
    """(1 - exp(-z)) / z, equal to 1 at z = 0, accurate for small z."""
    zs = np.where(z > 1e-8, z, 1.0)
    return np.where(z > 1e-8, -np.expm1(-zs) / zs, 1.0 - 0.5 * z)


def km_reflectance(K, S, X, Rg):
    """Kubelka-Munk reflectance of a layer of thickness X over a background.

    Parameters
    ----------
    K, S : (...) float arrays
        Absorption and scattering coefficients (1/um), >= 0.
    X : (...) float array
        Layer thickness (um), >= 0; ``np.inf`` allowed.
    Rg : (...) float array
        Diffuse reflectance of what lies under the layer, in [0, 1].

    Returns
    -------
    R : (...) float64 array in [0, 1]

    Notes
    -----
    Paper eq 5, with ``e = exp(-S X (1/R_inf - R_inf)) = exp(-2 beta X)``,
    ``beta = sqrt(K (K + 2S))``, is algebraically::

        R = [R_inf (1 - e) - Rg (R_inf^2 - e)] / [1 - e R_inf^2 - Rg R_inf (1 - e)]

    Written with ``delta = 1 - R_inf`` and ``q = (1 - e) / delta`` this is::

        R = [Rg (1 + R_inf) + q (R_inf - Rg)] / [(1 + R_inf) + R_inf q (R_inf - Rg)]

    where ``q = X T (1 + R_inf) (1 - exp(-z))/z``, ``z = 2 beta X``,
    ``T = S + K + beta``.  This form is exact and finite in every limit:

    - X -> 0: q -> 0, R = Rg.
    - X -> inf or S X in the thousands: q -> 1/delta, R = R_inf.
    - K -> 0 (conservative): delta -> 0, q -> 2 S X, giving
      ``R = (Rg + S X (1 - Rg)) / (1 + S X (1 - Rg))``.
    - S -> 0 (pure absorption): R_inf -> 0, R = Rg exp(-2 K X).
    - K = S = 0: the layer is empty, R = Rg.

    References
    ----------
    Kubelka & Munk 1931; source paper eqs 5-6.

    Examples
    --------
    >>> round(float(km_reflectance(0.0, 1.0, 1.0, 0.0)), 12)   # SX / (1 + SX)
    0.5
    """
    K, S, X, Rg = np.broadcast_arrays(
        np.asarray(K, dtype=np.float64),
        np.asarray(S, dtype=np.float64),
        np.asarray(X, dtype=np.float64),
        np.asarray(Rg, dtype=np.float64),
    )
    Rg = np.clip(Rg, 0.0, 1.0)
    beta, T, Ri, delta = _km_core(K, S)
    with np.errstate(over="ignore", invalid="ignore"):
        Xf = np.where(np.isfinite(X), X, 0.0)
        z = 2.0 * beta * Xf
        y = Xf * T * (1.0 + Ri)  # = z / delta, but finite at delta = 0
        q = np.where(delta > 1e-8, -np.expm1(-z) / np.maximum(delta, 1e-300), y * _phi1(z))
        d = Ri - Rg
        num = Rg * (1.0 + Ri) + q * d
        den = (1.0 + Ri) + Ri * q * d
        R = num / den
        # q overflowed (S X beyond ~1e300 with K = 0): R -> R_inf
        R = np.where(np.isfinite(q) & np.isfinite(R), R, Ri)
    R = np.where(X == 0.0, Rg, R)  # no layer: exactly the background
    R = np.where(np.isinf(X), Ri, R)  # infinitely thick: eq 6
    R = np.where(T > 0.0, R, Rg)  # empty layer
    return np.clip(R, 0.0, 1.0)


def km_layers(layers, Rg):
    """Reflectance of a stack of Kubelka-Munk layers.

    Parameters
    ----------
    layers : sequence of (K, S, X) tuples
        Listed from the substrate up (first tuple lies on the background);
        each entry broadcasts like :func:`km_reflectance`'s arguments.
    Rg : (...) float array
        Reflectance of the substrate under the first layer.

    Returns
    -------
    R : (...) float64 array in [0, 1]

    Notes
    -----
    In the two-flux theory the only thing a layer needs to know about what
    lies below is its diffuse reflectance, so the stack is evaluated bottom
    up, each layer's R becoming the next layer's Rg (eq 5 applied
    recursively).  Splitting a layer into two layers of X/2 gives the same
    result.

    Examples
    --------
    >>> one = km_layers([(0.1, 1.0, 2.0)], 0.3)
    >>> two = km_layers([(0.1, 1.0, 1.0), (0.1, 1.0, 1.0)], 0.3)
    >>> bool(np.isclose(one, two, rtol=0, atol=1e-14))
    True
    """
    R = np.asarray(Rg, dtype=np.float64)
    for K, S, X in layers:
        R = km_reflectance(K, S, X, R)
    return R


def km_mix(K, S, m):
    """Coefficients of a mixture of colourants (eq 7).

    Parameters
    ----------
    K, S : (P, ...) float arrays
        Absorption and scattering coefficients of the P components along
        axis 0 (further axes, e.g. colour channels, broadcast).
    m : (P,) float array
        Non-negative proportions; need not sum to 1.

    Returns
    -------
    (K_mix, S_mix) : tuple of (...) float64 arrays

    Raises
    ------
    ValueError
        If m has a negative entry, sums to zero, or its length differs from
        the number of components.

    Notes
    -----
    Eq 7: ``K = sum m_i K_i / sum m_i``, ``S = sum m_i S_i / sum m_i``.

    Examples
    --------
    >>> km_mix([1.0, 3.0], [2.0, 2.0], [1.0, 1.0])
    (np.float64(2.0), np.float64(2.0))
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    m = np.asarray(m, dtype=np.float64)
    if m.ndim != 1 or m.shape[0] != K.shape[0] or m.shape[0] != S.shape[0]:
        raise ValueError(
            "km_mix: proportions m of shape %s do not match K %s and S %s along axis 0"
            % (m.shape, K.shape, S.shape)
        )
    if np.any(m < 0.0) or not np.sum(m) > 0.0:
        raise ValueError("km_mix: proportions must be >= 0 with a positive sum, got %s" % m)
    w = (m / np.sum(m)).reshape((-1,) + (1,) * (K.ndim - 1))
    return np.sum(w * K, axis=0), np.sum(w * S, axis=0)


# --------------------------------------------------------------------------
# Dipole diffusion (Jensen et al. 2001)
# --------------------------------------------------------------------------


def _dipole_A(eta):
    """Boundary mismatch A = (1 + F_dr)/(1 - F_dr), F_dr by Jensen et al.'s fit."""
    eta = np.asarray(eta, dtype=np.float64)
    # Diffuse Fresnel reflectance fit (Jensen et al. 2001; Egan & Hilgeman)
    F_dr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
    return (1.0 + F_dr) / (1.0 - F_dr)


def dipole_rd(alpha_prime, eta):
    """Total diffuse reflectance of the dipole model.

    Parameters
    ----------
    alpha_prime : (...) float array
        Reduced albedo ``sigma_s' / (sigma_s' + sigma_a)`` in [0, 1].
    eta : (...) float array
        Relative refractive index of the medium (> 0).

    Returns
    -------
    Rd : (...) float64 array in [0, 1]

    Notes
    -----
    Jensen et al. 2001, integrating the dipole profile over the plane::

        Rd = alpha'/2 (1 + exp(-4/3 A sqrt(3 (1 - alpha')))) exp(-sqrt(3 (1 - alpha')))
        A  = (1 + F_dr) / (1 - F_dr)
        F_dr = -1.440/eta^2 + 0.710/eta + 0.668 + 0.0636 eta

    Examples
    --------
    >>> float(dipole_rd(0.0, 1.3))
    0.0
    """
    a = np.clip(np.asarray(alpha_prime, dtype=np.float64), 0.0, 1.0)
    A = _dipole_A(eta)
    s = np.sqrt(3.0 * (1.0 - a))
    return 0.5 * a * (1.0 + np.exp(-(4.0 / 3.0) * A * s)) * np.exp(-s)


def dipole_tail_fraction(r, sigma_a, sigma_s_prime, eta):
    """Fraction of the dipole's diffuse reflectance leaving beyond radius r.

    Parameters
    ----------
    r : (...) float array
        Distance from the point of entry (same length unit as 1/sigma).
    sigma_a, sigma_s_prime : (...) float arrays
        Absorption and reduced scattering coefficients (1/length), > 0.
    eta : (...) float array
        Relative refractive index.

    Returns
    -------
    P : (...) float64 array in [0, 1]
        ``int_r^inf Rd(r') 2 pi r' dr' / Rd``.

    Notes
    -----
    Each pole of Jensen et al.'s profile
    ``Rd(r) = alpha'/(4 pi) sum_j z_j (1 + s d_j) exp(-s d_j) / d_j^3``,
    with ``d_j = sqrt(r^2 + z_j^2)``, s = sigma_tr, integrates in closed
    form: ``int_r^inf z (1 + s d) e^{-s d} / d^3 2 pi r' dr' = 2 pi z e^{-s d(r)} / d(r)``.
    Used by :func:`shellrepair.materials.choose_model` as the error of
    treating transport as local within a pixel footprint.
    """
    sa = np.maximum(np.asarray(sigma_a, dtype=np.float64), _TINY)
    ss = np.maximum(np.asarray(sigma_s_prime, dtype=np.float64), 0.0)
    r = np.maximum(np.asarray(r, dtype=np.float64), 0.0)
    st = sa + ss  # sigma_t'
    s_tr = np.sqrt(3.0 * sa * st)
    zr = 1.0 / st
    zv = zr * (1.0 + 4.0 / 3.0 * _dipole_A(eta))
    dr = np.sqrt(r * r + zr * zr)
    dv = np.sqrt(r * r + zv * zv)
    tail = zr * np.exp(-s_tr * dr) / dr + zv * np.exp(-s_tr * dv) / dv
    total = np.exp(-s_tr * zr) + np.exp(-s_tr * zv)
    return np.clip(tail / np.maximum(total, _TINY), 0.0, 1.0)


def dipole_profile(r, sigma_a, sigma_s_prime, eta):
    """Radial diffuse reflectance profile R_d(r) of the dipole model.

    Parameters
    ----------
    r : (...) float array
        Distance from the point of entry (length unit of 1/sigma).
    sigma_a, sigma_s_prime : (...) float arrays
        Absorption and reduced scattering coefficients (1/length), > 0.
    eta : (...) float array
        Relative refractive index.

    Returns
    -------
    Rd : (...) float64 array
        Exitance per unit area per unit incident flux (1/length^2);
        ``int Rd(r) 2 pi r dr = dipole_rd(alpha', eta)``.

    Notes
    -----
    Jensen et al. 2001::

        Rd(r) = alpha'/(4 pi) [z_r (1 + s d_r) e^{-s d_r} / d_r^3
                               + z_v (1 + s d_v) e^{-s d_v} / d_v^3]

    with s = sigma_tr = sqrt(3 sigma_a sigma_t'), z_r = 1/sigma_t',
    z_v = z_r (1 + 4A/3), d = sqrt(r^2 + z^2).
    """
    sa = np.maximum(np.asarray(sigma_a, dtype=np.float64), _TINY)
    ss = np.maximum(np.asarray(sigma_s_prime, dtype=np.float64), 0.0)
    r = np.maximum(np.asarray(r, dtype=np.float64), 0.0)
    st = sa + ss
    alpha = ss / st
    s_tr = np.sqrt(3.0 * sa * st)
    zr = 1.0 / st
    zv = zr * (1.0 + 4.0 / 3.0 * _dipole_A(eta))
    dr = np.sqrt(r * r + zr * zr)
    dv = np.sqrt(r * r + zv * zv)
    pole_r = zr * (1.0 + s_tr * dr) * np.exp(-s_tr * dr) / dr**3  # real source
    pole_v = zv * (1.0 + s_tr * dv) * np.exp(-s_tr * dv) / dv**3  # virtual source
    return alpha / (4.0 * np.pi) * (pole_r + pole_v)


def km_to_transport(K, S):
    """Transport coefficients matching Kubelka-Munk K and S (diffusion limit).

    Parameters
    ----------
    K, S : (...) float arrays
        Kubelka-Munk coefficients (1/length).

    Returns
    -------
    (sigma_a, sigma_s_prime) : tuple of (...) float64 arrays

    Notes
    -----
    The usual diffusion-limit correspondence ``K = 2 sigma_a`` and
    ``S = (3/4) sigma_s'`` (van Gemert & Star, Lasers Life Sci. 1, 1987).
    It is an approximation; it is used only to estimate the diffusion
    length for the model choice, never for colours.
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    return 0.5 * K, (4.0 / 3.0) * S


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
    wi = np.asarray(wi, dtype=np.float64)
    wo = np.asarray(wo, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    spec = torrance_sparrow(wi, wo, n, m, eta)  # eq 8
    diff = layered_diffuse(_dot(n, wi), _dot(n, wo), m, eta, R_km)  # eq 2 + Saunderson
    return spec[..., None] + diff
