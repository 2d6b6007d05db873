"""Compiled vertex-to-face lists (Numba): :func:`vertex_faces`.

The lists of :func:`shellrepair.mesh.topology.vertex_faces` by two cache-sized
counting sorts (buckets of vertices, then each vertex), the same arrays as
:func:`shellrepair.mesh.geometry.vertex_faces_scipy`; the scan's index
(:mod:`shellrepair.mesh.index`), the near-face grid of
:mod:`shellrepair.mesh.intersect` and the whole-mesh steps of
:mod:`shellrepair.mesh.fastmesh` use it. How the kernels are compiled and
switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["vertex_faces"]

from shellrepair import compiled
from shellrepair.mesh.geometry import vertex_faces_scipy
from shellrepair.mesh.halves import both, in_turn

njit = compiled.kernel


# --------------------------------------------------------------------------
# whole mesh: vertex-to-face lists
# --------------------------------------------------------------------------
#: Bits of a corner id in the vertex-face sort's packed (vertex in bucket, corner) word.
_VF_BITS = 32
#: Vertices per bucket of the vertex-face sort, as a power of two: a
#: bucket's corners (about six per vertex, 8 bytes each) stay in cache.
_VF_BUCKET_SHIFT = 12


@njit(cache=True, nogil=True)
def _vf_count(flat, i0, i1, n, shift, bcount):
    # 1. corners [i0, i1) per bucket of 2**shift vertices (bcount[k + 1])
    for i in range(i0, i1):
        v = flat[i]
        if v < 0 or v >= n:
            raise ValueError("a face refers to a vertex outside [0, n_vertices)")
        bcount[(v >> shift) + 1] += 1


@njit(cache=True, nogil=True)
def _vf_scatter(flat, i0, i1, shift, bpos, tmp):
    # 2. corners [i0, i1) into their buckets, in corner order, from bpos (advanced)
    low = (np.int64(1) << shift) - 1
    for i in range(i0, i1):
        v = flat[i]
        k = v >> shift
        tmp[bpos[k]] = ((v & low) << _VF_BITS) | i
        bpos[k] += 1


@njit(cache=True, nogil=True)
def _vf_buckets(tmp, bstart, k0, k1, n, shift, order, start):
    # 3. buckets [k0, k1), each by its vertex (a counting sort within the bucket, stable)
    low = (np.int64(1) << shift) - 1
    cnt = np.zeros((np.int64(1) << shift) + 1, np.int64)
    mask = (np.int64(1) << _VF_BITS) - 1
    for k in range(k0, k1):
        s0 = bstart[k]
        s1 = bstart[k + 1]
        a0 = k << shift
        na = min(n - a0, low + 1)
        if na <= 0:
            break
        cnt[:na + 1] = 0
        for i in range(s0, s1):
            cnt[(tmp[i] >> _VF_BITS) + 1] += 1
        cnt[0] = s0
        for j in range(na):
            cnt[j + 1] += cnt[j]
            start[a0 + j] = cnt[j]
        for i in range(s0, s1):
            j = tmp[i] >> _VF_BITS
            order[cnt[j]] = tmp[i] & mask
            cnt[j] += 1


#: Corners from which :func:`vertex_faces` runs each of its steps in two
#: halves on two threads (with two cores or more): the same lists.
VF_HALVES_MIN = 3_000_000


def _vertex_faces(flat, n, shift, two=False):
    """The lists in three steps, each in two halves (corners for the first
    two, buckets for the third): on two threads with ``two``, the same
    arrays either way (the second half's corners after the first's in each
    bucket, as one pass files them)."""
    run = both if two else in_turn
    m3 = flat.size
    h = m3 // 2
    nb = (n >> shift) + 1
    c0 = np.zeros(nb + 1, np.int64)
    c1 = np.zeros(nb + 1, np.int64)
    run(_vf_count, (flat, h, m3, n, shift, c1), (flat, 0, h, n, shift, c0))
    bstart = np.cumsum(c0 + c1)
    tmp = np.empty(m3, np.int64)
    run(_vf_scatter, (flat, h, m3, shift, bstart[:nb] + c0[1:], tmp), (flat, 0, h, shift, bstart[:nb].copy(), tmp))
    del c0, c1
    order = np.empty(m3, np.int64)
    start = np.empty(n + 1, np.int64)
    kh = nb // 2
    run(_vf_buckets, (tmp, bstart, kh, nb, n, shift, order, start), (tmp, bstart, 0, kh, n, shift, order, start))
    start[n] = m3
    return order, start


def vertex_faces(F, n_vertices):
    """Vertex-to-face lists (as :func:`shellrepair.mesh.topology.vertex_faces`),
    by two cache-sized counting sorts (buckets of vertices, then each
    vertex): the one compiled version, which :mod:`shellrepair.mesh.fastmesh`
    uses too (compiled or loaded on its first call, alone).

    Parameters
    ----------
    F : (m,3) int64
    n_vertices : int

    Returns
    -------
    order : (3m,) int64
        Positions in ``F.ravel()`` grouped by vertex, in order within a
        vertex; ``order // 3`` are the faces.
    start : (n+1,) int64

    Raises
    ------
    ValueError
        A face refers to a vertex outside ``[0, n_vertices)``.
    """
    n = int(n_vertices)
    flat = np.ascontiguousarray(np.asarray(F, np.int64).reshape(-1))
    if not compiled.ENABLED or flat.size >= 2 ** _VF_BITS:   # corner ids must fit the packing
        if flat.size and (flat.min() < 0 or flat.max() >= n):
            raise ValueError(f"face indices must lie in [0, {n}), got {flat.min()}..{flat.max()}")
        return vertex_faces_scipy(F, n)
    shift = max(1, min(_VF_BUCKET_SHIFT, max(n - 1, 1).bit_length()))
    return _vertex_faces(flat, n, shift, two=flat.size >= VF_HALVES_MIN and (os.cpu_count() or 1) >= 2)
