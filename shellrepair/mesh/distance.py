"""Distance of points to a small triangle mesh: how far a fill lies from
the scan it stands in for.

:func:`point_mesh_distance` measures the order test's refills against the
scan cut away (:mod:`~shellrepair.fill.probe`) and eval's patches against the
truth; compiled (:func:`shellrepair.mesh.distance_kernels.nearest_triangle_distances`)
with this NumPy version as its oracle, the same operations in the same
order. The candidate triangles come from SciPy's ``cKDTree`` of their
centroids; only the point-triangle step is ours.

Why not libigl's ``point_mesh_squared_distance`` (an AABB tree, exact)?
Measured by ``python eval/bench_libs.py distance`` on the order test's own
calls (every call of a repair with ``order="auto"``, fastest of 5, warm)::

    scan                        calls  points   ours ms  igl ms  distances that differ (largest relative)
    bumpy sphere, 6 holes          54     552       5.2     1.5    409 (7.8e-13)
    fine sphere, 1 large hole       9   18594      97.6    60.5   7347 (3.3e-04)
    bunny                          45    4536      12.3    11.9   1821 (3.5e-03)

libigl is exact and as fast or faster, and on these three scans the orders
chosen and the meshes written are the same to the byte; but its distances
differ from ours in the last bits everywhere and by up to 0.35 % where
the eight nearest centroids miss the nearest triangle, so every report's
``choice.test_rms`` (written in full) changes, and a near tie between two
orders could go the other way. And importing libigl costs a fresh
process 0.69-0.73 s (``python -X importtime -c "import igl"``, three runs,
2026-12-06, this 2-core machine while busy), more than a whole small
repair's ``seconds``: every ``--order auto`` run would pay it (issue 38).
Ours stays for both reasons.
"""

from __future__ import annotations

import numpy as np

from shellrepair import compiled
from shellrepair.lazyscipy import cKDTree
from shellrepair.mesh import distance_kernels

__all__ = ["point_mesh_distance", "nearest_triangle_distances_reference"]

#: Triangles nearest (by centroid) to each measured point searched for its closest point.
NEAREST_TRIANGLES = 8


def point_mesh_distance(Q, V, F, nearest=NEAREST_TRIANGLES):
    """Distance of points to a small triangle mesh.

    Each point is measured against the ``nearest`` triangles whose centroids
    are closest to it (exact point-triangle distance), which is the true
    distance for a patch of triangles of even size like a refined fill.

    Parameters
    ----------
    Q : (p,3) float64
    V : (n,3) float64
    F : (m,3) int64

    Returns
    -------
    d : (p,) float64
    """
    Q = np.asarray(Q, np.float64)
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if len(Q) == 0 or len(F) == 0:
        return np.full(len(Q), np.inf)
    kk = min(int(nearest), len(F))
    if compiled.ENABLED:    # the same operations, compiled
        _, idx = cKDTree(distance_kernels.centroids(V, F)).query(Q, k=kk)
        return distance_kernels.nearest_triangle_distances(Q, V, F, np.asarray(idx).reshape(len(Q), kk))
    T = V[F]
    _, idx = cKDTree(T.mean(axis=1)).query(Q, k=kk)
    idx = np.asarray(idx).reshape(len(Q), kk)
    P = np.repeat(Q, kk, axis=0)
    Tn = T[idx.ravel()]
    E = P - _closest_on_triangles(P, Tn[:, 0], Tn[:, 1], Tn[:, 2])
    d = np.sqrt(_dot3(E, E))
    return d.reshape(len(Q), kk).min(axis=1)


def nearest_triangle_distances_reference(Q, V, F, idx):
    """Distance of each point to the nearest of its candidate triangles, in
    NumPy: :func:`point_mesh_distance`'s step after the candidates are
    found, and the reference
    :func:`shellrepair.mesh.distance_kernels.nearest_triangle_distances` (the
    compiled step) is held to.

    Parameters
    ----------
    Q : (p,3) float64
    V : (n,3) float64
    F : (m,3) int64
    idx : (p,k) int64
        Per point, its candidate triangles (rows of ``F``).

    Returns
    -------
    d : (p,) float64
    """
    kk = idx.shape[1]
    P = np.repeat(Q, kk, axis=0)
    T = V[F][idx.ravel()]
    E = P - _closest_on_triangles(P, T[:, 0], T[:, 1], T[:, 2])
    return np.sqrt(_dot3(E, E)).reshape(len(Q), kk).min(axis=1)


def _dot3(a, b):
    """Row-wise dot products of (n,3) arrays, summed left to right (as the
    compiled :func:`shellrepair.mesh.distance_kernels.nearest_triangle_distances` does; einsum's
    order depends on the CPU's vector width)."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _closest_on_triangles(P, A, B, C):
    """Closest point of triangle ABC to P, row by row.

    The point is written as A + v (B − A) + w (C − A); the barycentric
    coordinates of P's projection are clamped to the triangle, checking the
    three edges where the projection falls outside (degenerate triangles
    reduce to their longest edge's segment).
    """
    AB, AC = B - A, C - A
    AP = P - A
    d00 = _dot3(AB, AB)
    d01 = _dot3(AB, AC)
    d11 = _dot3(AC, AC)
    d20 = _dot3(AP, AB)
    d21 = _dot3(AP, AC)
    den = d00 * d11 - d01 * d01
    ok = den > 1e-30 * np.maximum(d00 * d11, 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, den, 1.0), 0.0)
    v = (d11 * d20 - d01 * d21) * inv
    w = (d00 * d21 - d01 * d20) * inv
    inside = ok & (v >= 0) & (w >= 0) & (v + w <= 1)
    X = A + v[:, None] * AB + w[:, None] * AC
    best = np.where(inside, np.sqrt(_dot3(P - X, P - X)), np.inf)
    out = X.copy()
    for S, E in ((A, B), (B, C), (C, A)):   # the edges, for points projecting outside
        D = E - S
        t = np.clip(_dot3(P - S, D) / np.maximum(_dot3(D, D), 1e-300), 0.0, 1.0)
        Y = S + t[:, None] * D
        dy = np.sqrt(_dot3(P - Y, P - Y))
        take = ~inside & (dy < best)
        out[take] = Y[take]
        best = np.where(take, dy, best)
    return out
