"""Kubelka-Munk two-flux reflectance of corrosion layers (eqs 4-7).

Parameters: absorption ``K`` and scattering ``S`` (1/um, >= 0), thickness
``X`` (um, >= 0, ``inf`` allowed), background reflectance ``Rg`` in [0, 1].
Every limit is finite: X -> 0 gives Rg, X -> inf or huge S X gives R_inf,
K -> 0 the conservative layer, S -> 0 pure absorption, K = S = 0 an empty
layer (see :func:`km_reflectance`).

References
----------
.. [1] P. Kubelka and F. Munk, "Ein Beitrag zur Optik der Farbanstriche",
   Z. techn. Physik 12, 593-601, 1931.
.. [2] Yamamoto, Shiba, Okada (the source paper), eqs 4-7.
"""

from __future__ import annotations

import numpy as np

from shellrepair.appearance.reflectance.dispatch import elementwise, kernels

__all__ = ["km_r_inf", "km_reflectance", "km_layers", "km_mix", "km_to_transport"]

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
    K_ = kernels("km")
    if K_ is not None:
        return elementwise(K_.km_r_inf, (K, S))
    return _km_r_inf_np(K, S)


def _km_r_inf_np(K, S):
    """NumPy version of :func:`km_r_inf` (the test oracle of the compiled kernel)."""
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
    K_ = kernels("km")
    if K_ is not None:
        return elementwise(K_.km_reflectance, (K, S, X, Rg))
    return _km_reflectance_np(K, S, X, Rg)


def _km_reflectance_np(K, S, X, Rg):
    """NumPy version of :func:`km_reflectance` (the test oracle of the compiled kernel)."""
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
