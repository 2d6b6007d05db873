"""Compiled kernel of the fill's fold check (:mod:`shellrepair.fill.checks`, Numba).

* :func:`folds`: the patch triangles folded onto a neighbour
  (:func:`shellrepair.fill.hole._folds`, the same answer; tests/test_kernels.py).

How the kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["folds"]

from shellrepair import compiled

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _folds(C, ids, Cs, Fr, cos_max):
    nc, ns = C.shape[0], Cs.shape[0]
    nh = 3 * (nc + ns)
    lo = np.empty(nh, np.int64)
    hi = np.empty(nh, np.int64)
    for r in range(nc + ns):
        for j in range(3):
            a = ids[r, j] if r < nc else Fr[r - nc, j]
            b = ids[r, (j + 1) % 3] if r < nc else Fr[r - nc, (j + 1) % 3]
            lo[3 * r + j] = min(a, b)
            hi[3 * r + j] = max(a, b)
    out = np.empty(0, np.int64)
    if nh == 0:
        return out
    base = lo.min()
    span = hi.max() - base + 1
    order = np.argsort((lo - base) * span + (hi - base), kind="mergesort")   # lexsort((hi, lo)): stable
    hit = np.zeros(nc, np.bool_)
    for q in range(nh - 1):
        x, y = order[q], order[q + 1]
        if lo[x] != lo[y] or hi[x] != hi[y]:
            continue
        rx, ry = x // 3, y // 3
        if rx >= nc and ry >= nc:                          # two scan faces
            continue
        jx, jy = x % 3, y % 3
        P = C[rx, jx] if rx < nc else Cs[rx - nc, jx]
        Q = C[rx, (jx + 1) % 3] if rx < nc else Cs[rx - nc, (jx + 1) % 3]
        R = C[rx, (jx + 2) % 3] if rx < nc else Cs[rx - nc, (jx + 2) % 3]
        Ry = C[ry, (jy + 2) % 3] if ry < nc else Cs[ry - nc, (jy + 2) % 3]
        e0, e1, e2 = Q[0] - P[0], Q[1] - P[1], Q[2] - P[2]
        ln = max(np.sqrt(e0 * e0 + e1 * e1 + e2 * e2), 1e-300)
        e0, e1, e2 = e0 / ln, e1 / ln, e2 / ln
        u0, u1, u2 = R[0] - P[0], R[1] - P[1], R[2] - P[2]
        w0, w1, w2 = Ry[0] - P[0], Ry[1] - P[1], Ry[2] - P[2]
        du = u0 * e0 + u1 * e1 + u2 * e2
        dw = w0 * e0 + w1 * e1 + w2 * e2
        u0, u1, u2 = u0 - du * e0, u1 - du * e1, u2 - du * e2
        w0, w1, w2 = w0 - dw * e0, w1 - dw * e1, w2 - dw * e2
        den = np.sqrt(u0 * u0 + u1 * u1 + u2 * u2) * np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        if u0 * w0 + u1 * w1 + u2 * w2 > cos_max * den and den > 0:
            if rx < nc:
                hit[rx] = True
            if ry < nc:
                hit[ry] = True
    return np.flatnonzero(hit)


def folds(C, ids, Cs, Fr, cos_max):
    """:func:`shellrepair.fill.hole._folds`' test, compiled: the patch triangles
    (corners ``C``, corner ids ``ids``) folded onto a neighbour across an
    edge, a patch triangle or a scan face (corners ``Cs``, vertex ids
    ``Fr``).

    Parameters
    ----------
    C : (t,3,3) float64
    ids : (t,3) int64
    Cs : (r,3,3) float64
    Fr : (r,3) int64
    cos_max : float
        A pair folds when the cosine of the angle between its far corners,
        seen along the edge, exceeds this.

    Returns
    -------
    bad : (h,) int64
        Sorted patch triangle indices.
    """
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    i = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    return _folds(c(C).reshape(-1, 3, 3), i(ids).reshape(-1, 3), c(Cs).reshape(-1, 3, 3), i(Fr).reshape(-1, 3),
                  float(cos_max))
