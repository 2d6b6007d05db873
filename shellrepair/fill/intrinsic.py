"""The cotangent Laplacian of a patch's intrinsic Delaunay triangulation.

Scan rims are full of slivers: triangles with an angle near 0 or π. Their
cotangents are huge or negative, and the Voronoi areas of their corners
tiny, so the ordinary cotangent Laplacian and mass of a submesh that holds
them make a poor fairing operator there. The surface itself is fine; only
its triangulation is bad. This module keeps the surface and changes the
triangulation *intrinsically*: edges are flipped on the surface (each new
edge a straight line across the two triangles it joins, its length found
by laying the pair flat) until every interior edge is Delaunay (its two
opposite angles sum to at most π). The cotangent weights of its interior
edges are never negative, and its triangles are as round as the vertices
allow (Bobenko & Springborn; Fisher et al.). Vertex positions and the
surface stay those of the mesh; only the operator changes: the weights,
and the lumped mass (a third of each intrinsic triangle's area at each
corner, the same total area as the mesh).

Positions are used once, for the edge lengths; everything after works on
lengths. Boundary edges are not flipped. Flips go in rounds of edges that
share no triangle, the worst edges first, until none is left.

References
----------
A. I. Bobenko, B. A. Springborn, "A discrete Laplace–Beltrami operator for
simplicial surfaces", Discrete Comput. Geom. 38 (2007). M. Fisher,
B. Springborn, P. Schröder, A. I. Bobenko, "An algorithm for the
construction of intrinsic Delaunay triangulations with applications to
digital geometry processing", Computing 81 (2007). N. Sharp, K. Crane,
"A Laplacian for nonmanifold triangle meshes", SGP 2020.
"""

from __future__ import annotations

import numpy as np

from shellrepair import compiled
from shellrepair.fill import intrinsic_kernels
from shellrepair.fill.refine import independent_flips
from shellrepair.lazyscipy import sparse as sp
from shellrepair.mesh.topology import edge_topology, manifold_pairs

__all__ = ["intrinsic_delaunay", "intrinsic_laplacian", "laplacian_arrays", "flip_to_delaunay", "flip_to_delaunay_reference",
           "cotangents", "twins", "triangle_areas"]

#: An edge flips when its opposite cotangents sum below ``-FLIP_TOL``.
FLIP_TOL = 1e-12
#: Flip rounds at most (each flips every edge it can); the triangulation
#: reached is used even if edges are left (any triangulation is valid).
MAX_ROUNDS = 100

_NXT = np.array([1, 2, 0])


def triangle_areas(L):
    """Areas of triangles from their side lengths (t,3), by Kahan's stable
    form of Heron's formula (sides sorted, parenthesised as written)."""
    s = -np.sort(-np.asarray(L, np.float64), axis=1)   # a >= b >= c
    a, b, c = s[:, 0], s[:, 1], s[:, 2]
    q = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c))
    return 0.25 * np.sqrt(np.maximum(q, 0.0))


def cotangents(L):
    """Cotangent of the angle facing each side, and the triangles' areas.

    Parameters
    ----------
    L : (t,3) float64
        ``L[f,i]``: length of the side from corner i to corner (i+1)%3.

    Returns
    -------
    cot : (t,3) float64
        Cotangent of the angle facing each side.
    A : (t,) float64
        The areas (:func:`triangle_areas`).
    """
    A = triangle_areas(L)
    b, c = L[:, [1, 2, 0]], L[:, [2, 0, 1]]
    return (b * b + c * c - L * L) / (4.0 * np.maximum(A, 1e-300))[:, None], A


def twins(T, n):
    """Twin of each half-edge (slot ``3f+i`` runs ``T[f,i] -> T[f,i+1]``), or
    −1: boundary edges, and vertex pairs with more than two half-edges
    (which are then not flipped).

    Parameters
    ----------
    T : (t,3) int64
        Triangles.
    n : int
        Vertex count.

    Returns
    -------
    twin : (3t,) int64
    """
    h1, h2 = manifold_pairs(edge_topology(T, n))
    twin = np.full(3 * len(T), -1, np.int64)
    twin[h1] = h2
    twin[h2] = h1
    return twin


def intrinsic_delaunay(X, F, max_rounds=MAX_ROUNDS):
    """Flip the edges of a triangle mesh on its surface until it is Delaunay.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
        A manifold (with boundary) triangle mesh.

    Returns
    -------
    T : (m,3) int64
        The intrinsic triangles (same vertices, same count).
    L : (m,3) float64
        ``L[f,i]``: length of the side from ``T[f,i]`` to ``T[f,(i+1)%3]``.
    settled : bool
        Every interior edge is Delaunay (False if ``max_rounds`` ran out).
    """
    T, L, settled, _ = flip_to_delaunay(X, F, max_rounds)
    return T, L, settled


def flip_to_delaunay(X, F, max_rounds=MAX_ROUNDS):
    """:func:`intrinsic_delaunay`, plus the cotangents and areas of the result
    (from its last round) when settled, else None. Compiled
    (:func:`shellrepair.fill.intrinsic_kernels.intrinsic_flips`, the same bits) when Numba
    is there, else :func:`flip_to_delaunay_reference`.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    max_rounds : int

    Returns
    -------
    T, L, settled
        As :func:`intrinsic_delaunay`.
    known : (cot (m,3), A (m,)) or None
        :func:`cotangents` of the result when settled.
    """
    if not compiled.ENABLED:
        return flip_to_delaunay_reference(X, F, max_rounds)
    X = np.asarray(X, np.float64)
    T = np.array(F, np.int64)
    P = X[T]
    L = np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2)
    settled, cot, A = intrinsic_kernels.intrinsic_flips(T, L, len(X), max_rounds, FLIP_TOL)
    return T, L, settled, ((cot, A) if settled else None)


def flip_to_delaunay_reference(X, F, max_rounds=MAX_ROUNDS):
    """:func:`flip_to_delaunay` in NumPy: rounds of vectorised flips (the
    compiled kernel's test oracle, and the fallback when kernels are off).
    Parameters and returns as :func:`flip_to_delaunay`."""
    X = np.asarray(X, np.float64)
    T = np.array(F, np.int64)
    P = X[T]
    L = np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2)
    n, t = len(X), len(T)
    for _ in range(int(max_rounds)):
        twin = twins(T, n)
        h1 = np.flatnonzero(twin > np.arange(3 * t))   # each interior edge once
        cot, A = cotangents(L)
        f1, i1 = h1 // 3, h1 % 3
        h2 = twin[h1]
        f2, i2 = h2 // 3, h2 % 3
        s = cot[f1, i1] + cot[f2, i2]                   # the two angles facing the edge
        c, d = T[f1, _NXT[_NXT[i1]]], T[f2, _NXT[_NXT[i2]]]
        bad = np.flatnonzero((s < -FLIP_TOL) & (c != d) & np.isfinite(s))
        if bad.size == 0:
            return T, L, True, (cot, A)
        k = independent_flips(bad, f1[bad], f2[bad], -s[bad], bad, t)
        F1, F2, I1, I2 = f1[k], f2[k], i1[k], i2[k]
        a, b, C, D = T[F1, I1], T[F1, _NXT[I1]], c[k], d[k]
        lab, lbc, lca = L[F1, I1], L[F1, _NXT[I1]], L[F1, _NXT[_NXT[I1]]]
        lad, ldb = L[F2, _NXT[I2]], L[F2, _NXT[_NXT[I2]]]
        # lay (a, b, c) and (b, a, d) flat, a at the origin, b on +x, c above, d below
        cx = (lab * lab + lca * lca - lbc * lbc) / (2.0 * lab)
        cy = np.sqrt(np.maximum(lca * lca - cx * cx, 0.0))
        dx = (lab * lab + lad * lad - ldb * ldb) / (2.0 * lab)
        dy = -np.sqrt(np.maximum(lad * lad - dx * dx, 0.0))
        lcd = np.hypot(cx - dx, cy - dy)
        # (a, b, c), (b, a, d) -> (c, a, d), (d, b, c)
        T[F1] = np.column_stack([C, a, D])
        L[F1] = np.column_stack([lca, lad, lcd])
        T[F2] = np.column_stack([D, b, C])
        L[F2] = np.column_stack([ldb, lbc, lcd])
    return T, L, False, None


def intrinsic_laplacian(X, F):
    """Cotangent Laplacian and lumped mass of the intrinsic Delaunay triangulation.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64

    Returns
    -------
    K : (n,n) CSC float64
        ``K = D − W``, ``W_ij`` the sum of ½ cot of the angles facing the
        intrinsic edges between i and j (never negative inside the mesh),
        positive semidefinite.
    M : (n,) float64
        A third of the area of every intrinsic triangle at each of its
        corners (the same total area as the mesh).
    """
    n = len(X)
    T, L, _, known = flip_to_delaunay(X, F)
    cot, A = cotangents(L) if known is None else known
    w = 0.5 * cot.ravel()
    i, j = T.ravel(), T[:, [1, 2, 0]].ravel()
    # each side's weight w: −w at (i, j) and (j, i), +w at (i, i) and (j, j); duplicates summed
    K = sp.csc_matrix((np.concatenate([-w, -w, w, w]),
                       (np.concatenate([i, j, i, j]), np.concatenate([j, i, i, j]))), shape=(n, n))
    M = np.bincount(T.ravel(), np.repeat(A / 3.0, 3), n)
    return K, M


def laplacian_arrays(X, F):
    """:func:`intrinsic_laplacian` for the fairing rounds: K as compiled CSR
    arrays (:func:`shellrepair.fill.intrinsic_kernels.laplacian_rows`: columns unsorted,
    a spare zero on the diagonal; K is symmetric, so they are its CSC too),
    without SciPy's conversion and sort. Needs the kernels.

    Returns
    -------
    K : (ptr, col, val)
    M : (n,) float64
    """
    n = len(X)
    T, L, _, known = flip_to_delaunay(X, F)
    cot, A = cotangents(L) if known is None else known
    ptr, col, val = intrinsic_kernels.laplacian_rows(T, 0.5 * cot, n, False)
    M = np.bincount(T.ravel(), np.repeat(A / 3.0, 3), n)
    return (ptr, col, val), M
