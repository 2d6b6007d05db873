"""Compiled kernels of the rho_dt table reads (Numba): :mod:`.albedo` (eq 3).

:func:`diffuse_transmittance` (the trilinear read of ``albedo._stencil`` /
``albedo._trilinear``), :func:`mean_transmittance` and
:func:`internal_reflectance` (the bilinear read of the node means, shifted
to the query's critical angle for eta < 1).  The index and weight helpers
(``rho_index``, ``rho_combine``, ``mean_index``, ``mean_combine``) are
inlined into :mod:`.layered_kernels` too.  How they are made fast:
:mod:`.common_kernels`; their NumPy versions: :mod:`.reference`.
"""

from __future__ import annotations

import math

import numpy as np

from shellrepair.appearance.reflectance._constants import M_MIN, _TINY
from shellrepair.appearance.reflectance.common_kernels import BLOCK, _at, _clip, _ftz_enter, _ftz_exit, _inline, _slp, jit, vlog


# --------------------------------------------------------------------------
# rho_dt table reads (eq 3): albedo._stencil / _trilinear, mean_transmittance
# --------------------------------------------------------------------------


@_inline
def _axis(x, x0, dx, n):
    f = _clip((x - x0) / dx, 0.0, n - 1.0)
    i = min(np.int64(f), n - 2)
    return i, f - i


@_inline
def _kappa_1(eta):
    e2 = eta * eta - 1.0
    s = np.float64(e2 > 0.0) - np.float64(e2 < 0.0)  # np.sign, without a branch
    return s * math.sqrt(abs(e2))


@_inline
def _next_to_one_1(kap_c, lo, up, wk):
    """albedo._next_to_one with the cell's nodes lo = Kp[k], up = Kp[min(k + 1, Nk - 1)]."""
    wk = 0.0 if ((kap_c < 0.0) & (up == 0.0)) else wk
    wk = 1.0 if ((kap_c > 0.0) & (lo == 0.0)) else wk
    wk = 1.0 if ((kap_c == 0.0) & (up == 0.0)) else wk
    return 0.0 if ((kap_c == 0.0) & (lo == 0.0)) else wk


@_inline
def _edge_aligned_1(x, c_query, c_node):
    lo = x * c_node / max(c_query, _TINY)
    hi = c_node + (x - c_query) * (1.0 - c_node) / max(1.0 - c_query, _TINY)
    return lo if x < c_query else hi


@_inline
def _node(dk0, k0, k):
    """Kp[k] formed as the grid was (albedo._grid: dk * arange(-k0, Nk)), bit for bit.

    Arithmetic instead of a load: LLVM does not vectorise a loop with a
    gather, and the index part of a table read is most of its arithmetic.
    """
    return dk0 * np.float64(k - k0)


@_inline
def _slice_cell(dk0, k0, U0, dU, NU, x, kap_c, k):
    """Cell (iu, wu) in u of kappa slice k, read at the cosine aligned to its critical angle."""
    kn = _node(dk0, k0, k)
    tir = (kap_c < 0.0) & (kn < 0.0)
    xe = _edge_aligned_1(x, -min(kap_c, 0.0), -min(kn, 0.0))
    xk = xe if tir else x
    return _axis(math.sqrt(xk), U0, dU, NU)


@_inline
def rho_index(x, m, eta, K_first, K_step, K_last, NK, dk0, k0, U0, dU, NU, L0, dL, NL):
    """The trilinear read of albedo._stencil as two base indices and four weights.

    Returns ``(i0, i1, wu0, wu1, wj, wk)``: node (iu, j, k) of slice k at
    flat index i0 and (iu', j, k + 1) at i1, the weights along u in each
    slice, along log m and along kappa.
    """
    x = _clip(x, 0.0, 1.0)
    lm = vlog(max(m, M_MIN))
    kap = _kappa_1(max(eta, _TINY))
    j, wj = _axis(lm, L0, dL, NL)
    k, wk = _axis(kap, K_first, K_step, NK)  # kappa axis as _stencil forms it: Kp[0], Kp[1] - Kp[0]
    kap_c = _clip(kap, K_first, K_last)
    wk = _next_to_one_1(kap_c, _node(dk0, k0, k), _node(dk0, k0, min(k + 1, NK - 1)), wk)
    iu0, wu0 = _slice_cell(dk0, k0, U0, dU, NU, x, kap_c, k)
    iu1, wu1 = _slice_cell(dk0, k0, U0, dU, NU, x, kap_c, k + 1)
    return (iu0 * NL + j) * NK + k, (iu1 * NL + j) * NK + k + 1, wu0, wu1, wj, wk


@_inline
def rho_combine(vals, NL, NK, i0, i1, wu0, wu1, wj, wk):
    """The 8 terms of the read, summed in NumPy's pairwise order (albedo._trilinear)."""
    sj = NK  # next m node
    su = NL * NK  # next u node
    a0 = 1.0 - wu0
    c0 = 1.0 - wu1
    ak0 = 1.0 - wk
    aj0 = 1.0 - wj
    t0 = a0 * aj0 * ak0 * vals[i0]
    t1 = a0 * wj * ak0 * vals[i0 + sj]
    t2 = wu0 * aj0 * ak0 * vals[i0 + su]
    t3 = wu0 * wj * ak0 * vals[i0 + su + sj]
    t4 = c0 * aj0 * wk * vals[i1]
    t5 = c0 * wj * wk * vals[i1 + sj]
    t6 = wu1 * aj0 * wk * vals[i1 + su]
    t7 = wu1 * wj * wk * vals[i1 + su + sj]
    return ((t0 + t1) + (t2 + t3)) + ((t4 + t5) + (t6 + t7))


@jit
def diffuse_transmittance(lo, hi, c, m, eta, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, out):
    """Per block: indices and weights (arithmetic, vectorised), then the 8 reads per point."""
    ix = np.empty((2, BLOCK), dtype=np.int64)
    wt = np.empty((4, BLOCK))
    NK = Kp.shape[0]
    K_first, K_step, K_last = Kp[0], Kp[1] - Kp[0], Kp[NK - 1]
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        cb = _slp(c, b0, b0 + bn)
        mb = _slp(m, b0, b0 + bn)
        eb = _slp(eta, b0, b0 + bn)
        for t in range(bn):
            i0, i1, wu0, wu1, wj, wk = rho_index(_at(cb, t), _at(mb, t), _at(eb, t), K_first, K_step, K_last, NK,
                                                 dk0, k0, U0, dU, NU, L0, dL, NL)
            ix[0, t] = i0
            ix[1, t] = i1
            wt[0, t] = wu0
            wt[1, t] = wu1
            wt[2, t] = wj
            wt[3, t] = wk
        for t in range(bn):
            r = rho_combine(vals, NL, NK, ix[0, t], ix[1, t], wt[0, t], wt[1, t], wt[2, t], wt[3, t])
            out[b0 + t] = _clip(r, 0.0, 1.0)
    _ftz_exit(old)


@_inline
def mean_index(m, eta, K_first, K_step, K_last, NK, dk0, k0, L0, dL, NL):
    """Cell and weights of albedo.mean_transmittance's bilinear read: (j, k, wj, wk, cq, kap_c)."""
    j, wj = _axis(vlog(max(m, M_MIN)), L0, dL, NL)
    kap = _kappa_1(max(eta, _TINY))
    k, wk = _axis(kap, K_first, K_step, NK)
    kap_c = _clip(kap, K_first, K_last)
    wk = _next_to_one_1(kap_c, _node(dk0, k0, k), _node(dk0, k0, min(k + 1, NK - 1)), wk)
    return j, k, wj, wk, -min(kap_c, 0.0), kap_c


@_inline
def mean_combine(j, k, wj, wk, cq, kap_c, dk0, k0, M, P, Q0, Q1):
    """The four node means (shifted to the query's critical angle for eta < 1), in NumPy's sum order."""
    if not kap_c < 0.0:  # eta >= 1: no slice is read shifted, the plain bilinear read of the means
        ak0 = 1.0 - wk
        aj0 = 1.0 - wj
        out = aj0 * ak0 * M[j, k]
        out = out + wj * ak0 * M[j + 1, k]
        out = out + aj0 * wk * M[j, k + 1]
        out = out + wj * wk * M[j + 1, k + 1]
        return _clip(out, 0.0, 1.0)
    out = 0.0
    for dk in range(2):
        ak = 1.0 - wk if dk == 0 else wk
        kk = k + dk
        kn = _node(dk0, k0, kk)
        cn = -min(kn, 0.0)
        tir = (kap_c < 0.0) & (kn < 0.0)
        cns = cn if tir else 1.0
        cqs = cq if tir else 1.0
        r = (1.0 - cqs) / max(1.0 - cns, _TINY)
        for dj in range(2):
            aj = 1.0 - wj if dj == 0 else wj
            jj = j + dj
            ratio = cqs / cns
            p, q0, q1, mv = P[jj, kk], Q0[jj, kk], Q1[jj, kk], M[jj, kk]
            shifted = ratio * ratio * p + 2.0 * r * cqs * q0 + 2.0 * r * r * (q1 - cns * q0)
            v = shifted if tir else mv
            out = out + aj * ak * v
    return _clip(out, 0.0, 1.0)


@_inline
def _mean_block(m, eta, b0, bn, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, ix, wt, res):
    """albedo.mean_transmittance of points b0 .. b0 + bn - 1 into res[:bn]: indices (vectorised), then the reads."""
    NK = Kp.shape[0]
    K_first, K_step, K_last = Kp[0], Kp[1] - Kp[0], Kp[NK - 1]
    mb = _slp(m, b0, b0 + bn)
    eb = _slp(eta, b0, b0 + bn)
    for t in range(bn):
        j, k, wj, wk, cq, kap_c = mean_index(_at(mb, t), _at(eb, t), K_first, K_step, K_last, NK, dk0, k0,
                                             L0, dL, NL)
        ix[0, t] = j
        ix[1, t] = k
        wt[0, t] = wj
        wt[1, t] = wk
        wt[2, t] = cq
        wt[3, t] = kap_c
    for t in range(bn):
        res[t] = mean_combine(ix[0, t], ix[1, t], wt[0, t], wt[1, t], wt[2, t], wt[3, t], dk0, k0, M, P, Q0, Q1)


@jit
def mean_transmittance(lo, hi, m, eta, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, out):
    ix = np.empty((2, BLOCK), dtype=np.int64)
    wt = np.empty((4, BLOCK))
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        _mean_block(m, eta, b0, bn, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, ix, wt, out[b0:b0 + bn])
    _ftz_exit(old)


@jit
def internal_reflectance(lo, hi, m, eta, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi, out):
    ix = np.empty((2, BLOCK), dtype=np.int64)
    wt = np.empty((4, BLOCK))
    res = np.empty(BLOCK)
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        _mean_block(m, eta, b0, bn, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, ix, wt, res)
        eb = _slp(eta, b0, b0 + bn)
        for t in range(bn):
            e = _clip(_at(eb, t), e_lo, e_hi)
            out[b0 + t] = _clip(1.0 - res[t] / (e * e), 0.0, 1.0 - 1e-9)
    _ftz_exit(old)


#: The kernels of this module, by name (for warm_up's count and the tests).
KERNELS = ("diffuse_transmittance", "mean_transmittance", "internal_reflectance")
