"""Compiled helpers that several kernel modules share (Numba).

* ``_ring_collect``: one ring of faces around a vertex front
  (:mod:`shellrepair.mesh.index_kernels`' ring walk and
  :mod:`shellrepair.mesh.intersect_kernels`' box query);
* ``_in_sorted``: membership in a sorted key array (the relaxation's and
  the triangulation's forbidden edges);
* :func:`max_sq_distance`: a loop's diameter, squared
  (:func:`shellrepair.holes.loops._diameter`, which uses it once this module is
  loaded: every fill loads it).

How the kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["max_sq_distance"]

from shellrepair import compiled

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _ring_collect(front, nfr, vf_order, vf_start, fmark, found, nf):
    # One ring's new faces appended to found (room checked by the caller).
    for i in range(nfr):
        v = front[i]
        for p in range(vf_start[v], vf_start[v + 1]):
            f = vf_order[p] // 3
            if not fmark[f]:
                fmark[f] = True
                found[nf] = f
                nf += 1
    return nf


@njit(cache=True, nogil=True)
def _in_sorted(keys, x):
    if keys.size == 0:
        return False
    p = min(np.searchsorted(keys, x), keys.size - 1)
    return keys[p] == x


# --------------------------------------------------------------------------
# a loop's diameter (shellrepair.holes.loops)
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _max_sq_distance(Q):
    best = 0.0
    k = Q.shape[0]
    for i in range(k):
        for j in range(k):
            dx = Q[i, 0] - Q[j, 0]
            dy = Q[i, 1] - Q[j, 1]
            dz = Q[i, 2] - Q[j, 2]
            d = (dx * dx + dy * dy) + dz * dz   # NumPy's sum over the last axis, in its order
            if d > best:
                best = d
    return best


def max_sq_distance(Q):
    """Largest squared distance between two rows of ``Q`` (k,3) float64, 0.0
    when there are none; bit for bit ``((Q[:, None] - Q[None]) ** 2).sum(axis=2).max()``
    (:func:`shellrepair.holes.loops._diameter`'s NumPy form) without its (k,k,3)
    temporary. A NaN coordinate is skipped here where NumPy's max would
    return NaN: callers pass finite rows."""
    return float(_max_sq_distance(np.ascontiguousarray(Q, np.float64)))
