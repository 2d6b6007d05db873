"""Compiled kernels of the point-to-mesh distance (:mod:`shellrepair.mesh.distance`, Numba).

* :func:`centroids`, :func:`nearest_triangle_distances`: the order test's
  centroid query and distances (:func:`shellrepair.mesh.distance.point_mesh_distance`;
  the latter each point's closest candidate triangle, on scalars).

Each gives what its NumPy version gives, to the bit (tests/test_selftest_speed.py).
How the kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["centroids", "nearest_triangle_distances"]

from shellrepair import compiled

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _centroids(V, F):
    m = F.shape[0]
    C = np.empty((m, 3))
    for f in range(m):
        a, b, c = F[f, 0], F[f, 1], F[f, 2]
        for k in range(3):
            C[f, k] = (V[a, k] + V[b, k] + V[c, k]) / 3.0
    return C


def centroids(V, F):
    """Triangle centroids, ``V[F].mean(axis=1)`` (NumPy's sums and division)
    without the (m,3,3) corner array.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64

    Returns
    -------
    C : (m,3) float64
    """
    return _centroids(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64))


@njit(cache=True, nogil=True)
def _segment_distance(p0, p1, p2, s0, s1, s2, e0, e1, e2):
    # the closest point of segment S-E to P and its distance: distance._closest_on_triangles' edge step
    D0, D1, D2 = e0 - s0, e1 - s1, e2 - s2
    t = ((p0 - s0) * D0 + (p1 - s1) * D1 + (p2 - s2) * D2) / max(D0 * D0 + D1 * D1 + D2 * D2, 1e-300)
    if t < 0.0:
        t = 0.0
    elif t > 1.0:
        t = 1.0
    y0, y1, y2 = s0 + t * D0, s1 + t * D1, s2 + t * D2
    f0, f1, f2 = p0 - y0, p1 - y1, p2 - y2
    return np.sqrt(f0 * f0 + f1 * f1 + f2 * f2), y0, y1, y2


@njit(cache=True, nogil=True)
def _point_triangle(p0, p1, p2, a0, a1, a2, b0, b1, b2, c0, c1, c2):
    # distance._closest_on_triangles on scalars (no array views): the same operations in the same order
    ab0, ab1, ab2 = b0 - a0, b1 - a1, b2 - a2
    ac0, ac1, ac2 = c0 - a0, c1 - a1, c2 - a2
    ap0, ap1, ap2 = p0 - a0, p1 - a1, p2 - a2
    d00 = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
    d01 = ab0 * ac0 + ab1 * ac1 + ab2 * ac2
    d11 = ac0 * ac0 + ac1 * ac1 + ac2 * ac2
    d20 = ap0 * ab0 + ap1 * ab1 + ap2 * ab2
    d21 = ap0 * ac0 + ap1 * ac1 + ap2 * ac2
    den = d00 * d11 - d01 * d01
    ok = den > 1e-30 * max(d00 * d11, 1e-300)
    inv = 1.0 / den if ok else 0.0
    v = (d11 * d20 - d01 * d21) * inv
    w = (d00 * d21 - d01 * d20) * inv
    x0 = a0 + v * ab0 + w * ac0
    x1 = a1 + v * ab1 + w * ac1
    x2 = a2 + v * ab2 + w * ac2
    if ok and v >= 0 and w >= 0 and v + w <= 1:
        e0, e1, e2 = p0 - x0, p1 - x1, p2 - x2
        return np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    best = np.inf
    dy, y0, y1, y2 = _segment_distance(p0, p1, p2, a0, a1, a2, b0, b1, b2)
    if dy < best:
        best, x0, x1, x2 = dy, y0, y1, y2
    dy, y0, y1, y2 = _segment_distance(p0, p1, p2, b0, b1, b2, c0, c1, c2)
    if dy < best:
        best, x0, x1, x2 = dy, y0, y1, y2
    dy, y0, y1, y2 = _segment_distance(p0, p1, p2, c0, c1, c2, a0, a1, a2)
    if dy < best:
        best, x0, x1, x2 = dy, y0, y1, y2
    e0, e1, e2 = p0 - x0, p1 - x1, p2 - x2
    return np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)


@njit(cache=True, nogil=True)
def _nearest_triangle_distances(Q, V, F, idx):
    p, kk = idx.shape
    d = np.empty(p)
    for i in range(p):
        q0, q1, q2 = Q[i, 0], Q[i, 1], Q[i, 2]
        m = 0.0
        for j in range(kk):
            f = idx[i, j]
            a, b, c = F[f, 0], F[f, 1], F[f, 2]
            x = _point_triangle(q0, q1, q2, V[a, 0], V[a, 1], V[a, 2], V[b, 0], V[b, 1], V[b, 2],
                                V[c, 0], V[c, 1], V[c, 2])
            if j == 0 or np.isnan(m):
                m = x if j == 0 else m
            elif np.isnan(x) or x < m:
                m = x
        d[i] = m
    return d


def nearest_triangle_distances(Q, V, F, idx):
    """For each point ``Q[i]``, its distance to the nearest of the triangles
    ``V[F[idx[i]]]``, read from ``V`` and ``F`` (no (m,3,3) corner array)
    with the point-triangle step on scalars: the operations of
    :func:`shellrepair.mesh.distance._closest_on_triangles` and the norm after it,
    in their order, so the same numbers to the bit.

    Parameters
    ----------
    Q : (p,3) float64
    V : (n,3) float64
    F : (m,3) int64
    idx : (p,kk) int64
        Candidate triangles (rows of ``F``) of each point.

    Returns
    -------
    d : (p,) float64
    """
    return _nearest_triangle_distances(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(V, np.float64),
                                       np.ascontiguousarray(F, np.int64), np.ascontiguousarray(idx, np.int64))
