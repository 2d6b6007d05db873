"""Dipole diffusion (Jensen et al. 2001): how far light travels under the surface.

Used to judge whether the local form of eq 2 is adequate at a pixel
footprint (:func:`shellrepair.appearance.shader.choose_model`), never for colours.
Coefficients are absorption ``sigma_a`` and reduced scattering
``sigma_s'`` (1/length, > 0) and the relative index ``eta`` (> 0).

References
----------
.. [1] H. W. Jensen, S. R. Marschner, M. Levoy, P. Hanrahan, "A Practical
   Model for Subsurface Light Transport", SIGGRAPH 2001.
.. [2] C. Donner and H. W. Jensen, "Light Diffusion in Multi-Layered
   Translucent Materials", SIGGRAPH 2005.
"""

from __future__ import annotations

import numpy as np

from shellrepair.appearance.reflectance.dispatch import elementwise, kernels
from shellrepair.appearance.reflectance.microfacet import _TINY

__all__ = ["dipole_rd", "dipole_tail_fraction", "dipole_profile"]

# --------------------------------------------------------------------------
# Dipole diffusion (Jensen et al. 2001)
# --------------------------------------------------------------------------


def dipole_A(eta):
    """Boundary mismatch A = (1 + F_dr)/(1 - F_dr), F_dr by Jensen et al.'s fit.

    Parameters
    ----------
    eta : (...) float array
        Relative refractive index of the boundary (> 0).

    Returns
    -------
    A : (...) float64 array
        Greater than 1 for eta > 1 (internal reflection at a denser
        medium's boundary); used by :func:`dipole_rd` and the profile.
    """
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
    K = kernels("dipole")
    if K is not None:
        return elementwise(K.dipole_rd, (alpha_prime, eta))
    return _dipole_rd_np(alpha_prime, eta)


def _dipole_rd_np(alpha_prime, eta):
    """NumPy version of :func:`dipole_rd` (the test oracle of the compiled kernel)."""
    a = np.clip(np.asarray(alpha_prime, dtype=np.float64), 0.0, 1.0)
    A = dipole_A(eta)
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
    Used by :func:`shellrepair.appearance.shader.choose_model` as the error of
    treating transport as local within a pixel footprint.
    """
    K = kernels("dipole")
    if K is not None:
        return elementwise(K.dipole_tail_fraction, (r, sigma_a, sigma_s_prime, eta))
    return _dipole_tail_fraction_np(r, sigma_a, sigma_s_prime, eta)


def _dipole_tail_fraction_np(r, sigma_a, sigma_s_prime, eta):
    """NumPy version of :func:`dipole_tail_fraction` (the test oracle of the compiled kernel)."""
    sa = np.maximum(np.asarray(sigma_a, dtype=np.float64), _TINY)
    ss = np.maximum(np.asarray(sigma_s_prime, dtype=np.float64), 0.0)
    r = np.maximum(np.asarray(r, dtype=np.float64), 0.0)
    st = sa + ss  # sigma_t'
    s_tr = np.sqrt(3.0 * sa * st)
    zr = 1.0 / st
    zv = zr * (1.0 + 4.0 / 3.0 * dipole_A(eta))
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
    K = kernels("dipole")
    if K is not None:
        return elementwise(K.dipole_profile, (r, sigma_a, sigma_s_prime, eta))
    return _dipole_profile_np(r, sigma_a, sigma_s_prime, eta)


def _dipole_profile_np(r, sigma_a, sigma_s_prime, eta):
    """NumPy version of :func:`dipole_profile` (the test oracle of the compiled kernel)."""
    sa = np.maximum(np.asarray(sigma_a, dtype=np.float64), _TINY)
    ss = np.maximum(np.asarray(sigma_s_prime, dtype=np.float64), 0.0)
    r = np.maximum(np.asarray(r, dtype=np.float64), 0.0)
    st = sa + ss
    alpha = ss / st
    s_tr = np.sqrt(3.0 * sa * st)
    zr = 1.0 / st
    zv = zr * (1.0 + 4.0 / 3.0 * dipole_A(eta))
    dr = np.sqrt(r * r + zr * zr)
    dv = np.sqrt(r * r + zv * zv)
    pole_r = zr * (1.0 + s_tr * dr) * np.exp(-s_tr * dr) / dr**3  # real source
    pole_v = zv * (1.0 + s_tr * dv) * np.exp(-s_tr * dv) / dv**3  # virtual source
    return alpha / (4.0 * np.pi) * (pole_r + pole_v)
