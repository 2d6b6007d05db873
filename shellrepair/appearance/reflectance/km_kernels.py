"""Compiled kernels of the Kubelka-Munk layers (Numba): :mod:`.km` (eqs 4-7).

:func:`km_r_inf` and :func:`km_reflectance`, one pass over the points each.
How they are made fast: :mod:`.common_kernels`; their NumPy versions:
:mod:`.reference`.
"""

from __future__ import annotations

import math

from shellrepair.appearance.reflectance.common_kernels import _at, _clip, _ftz_enter, _ftz_exit, _inline, _slp, jit, vexpm1


# --------------------------------------------------------------------------
# Kubelka-Munk (eqs 4-7)
# --------------------------------------------------------------------------


@_inline
def km_core_1(K, S):
    beta = math.sqrt(K * (K + 2.0 * S))
    T = S + K + beta
    pos = T > 0.0
    Ts = T if pos else 1.0
    R_inf = S / Ts if pos else 0.0
    delta = (K + beta) / Ts if pos else 1.0
    return beta, T, R_inf, delta


@_inline
def km_reflectance_1(K, S, X, Rg):
    Rg = _clip(Rg, 0.0, 1.0)
    beta, T, Ri, delta = km_core_1(K, S)
    finite_X = math.isfinite(X)
    Xf = X if finite_X else 0.0
    z = 2.0 * beta * Xf
    y = Xf * T * (1.0 + Ri)  # = z / delta, finite at delta = 0
    e1 = -vexpm1(-z)  # 1 - exp(-z)
    # q = e1 / delta, or y phi1(z) with phi1 = e1 / z (km._phi1) near delta = 0:
    # one division serves both branches (same operations as the oracle's)
    big_d = delta > 1e-8
    big_z = z > 1e-8
    qd = e1 / (max(delta, 1e-300) if big_d else (z if big_z else 1.0))
    q = qd if big_d else (y * qd if big_z else y * (1.0 - 0.5 * z))
    d = Ri - Rg
    num = Rg * (1.0 + Ri) + q * d
    den = (1.0 + Ri) + Ri * q * d
    R = num / den
    R = R if (math.isfinite(q) & math.isfinite(R)) else Ri  # q overflowed: R -> R_inf
    R = Rg if X == 0.0 else R  # no layer
    R = Ri if math.isinf(X) else R  # infinitely thick: eq 6
    R = R if T > 0.0 else Rg  # empty layer
    return _clip(R, 0.0, 1.0)


@jit
def km_r_inf(lo, hi, K, S, out):
    K = _slp(K, lo, hi)
    S = _slp(S, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        _, _, Ri, _ = km_core_1(_at(K, i), _at(S, i))
        out[i] = Ri
    _ftz_exit(old)


@jit
def km_reflectance(lo, hi, K, S, X, Rg, out):
    K = _slp(K, lo, hi)
    S = _slp(S, lo, hi)
    X = _slp(X, lo, hi)
    Rg = _slp(Rg, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        out[i] = km_reflectance_1(_at(K, i), _at(S, i), _at(X, i), _at(Rg, i))
    _ftz_exit(old)


#: The kernels of this module, by name (for warm_up's count and the tests).
KERNELS = ("km_r_inf", "km_reflectance")
