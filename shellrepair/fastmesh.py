"""Compiled kernels of the whole-mesh steps (Numba).

Each kernel here is one linear pass (or a few) over the faces, in place of
NumPy code that sorts or builds a sparse matrix: the half-edge topology by
a counting sort on the lower vertex of each edge, pieces by union-find,
face areas and signed volumes in one fused loop. They give exactly what
their NumPy versions in :mod:`shellrepair.topology` and
:mod:`shellrepair.clean` give (those stay as the reference and as the
fallback when Numba is missing; ``tests/test_scale_structures.py``
compares the two).

Kernels are compiled with ``cache=True`` (the machine code is kept beside
this file in ``__pycache__``) and release the GIL (``nogil``).
:func:`warm_up` compiles them all on a tiny mesh, for ``make setup``.

``AVAILABLE`` is False when Numba cannot be imported; callers then take
their NumPy path. Setting the environment variable
``SHELLREPAIR_NO_NUMBA=1`` forces that path (for tests and comparisons).
"""

from __future__ import annotations

import os

import numpy as np

try:  # pragma: no cover - depends on the environment
    if os.environ.get("SHELLREPAIR_NO_NUMBA"):
        raise ImportError("SHELLREPAIR_NO_NUMBA is set")
    import numba
except ImportError:  # pragma: no cover
    numba = None

#: True when the compiled kernels can be used.
AVAILABLE = numba is not None

__all__ = ["AVAILABLE", "edge_topology_arrays", "face_pieces_labels", "face_areas", "vertex_faces",
           "piece_signed_volumes", "warm_up"]

#: Runs of slots shorter than this are sorted by insertion (a vertex's
#: edges: about six on a scan); longer ones by a merge sort.
_INSERTION_MAX = 24


def _njit(f):
    if numba is None:
        return None
    return numba.njit(cache=True, nogil=True)(f)


# --------------------------------------------------------------------------
# half-edge topology
# --------------------------------------------------------------------------
def _edge_kernel(F, n, other):
    m = F.shape[0]
    m3 = 3 * m
    # counting sort of the half-edges by their edge's lower vertex
    start = np.zeros(n + 1, np.int64)
    for f in range(m):
        for c in range(3):
            u = F[f, c]
            if u < 0 or u >= n:
                raise ValueError("a face refers to a vertex outside [0, n_vertices)")
            v = F[f, c + 1] if c < 2 else F[f, 0]
            start[(u if u < v else v) + 1] += 1
    for i in range(n):
        start[i + 1] += start[i]
    pos = start[:n].copy()
    order = np.empty(m3, np.int64)
    for f in range(m):
        for c in range(3):
            u = F[f, c]
            v = F[f, c + 1] if c < 2 else F[f, 0]
            if u < v:
                a, b = u, v
            else:
                a, b = v, u
            p = pos[a]
            pos[a] = p + 1
            order[p] = 3 * f + c
            other[p] = b
    # within each lower vertex: by the higher vertex, stably (half-edge order)
    n_edges = 0
    n_single = 0
    for a in range(n):
        s = start[a]
        e = start[a + 1]
        k = e - s
        if k > _INSERTION_MAX:
            perm = np.argsort(other[s:e], kind="mergesort")
            ob = other[s:e][perm]
            oh = order[s:e][perm]
            other[s:e] = ob
            order[s:e] = oh
        elif k > 1:
            for i in range(s + 1, e):
                bv = other[i]
                hv = order[i]
                j = i - 1
                while j >= s and other[j] > bv:
                    other[j + 1] = other[j]
                    order[j + 1] = order[j]
                    j -= 1
                other[j + 1] = bv
                order[j + 1] = hv
        run = 0
        for i in range(s, e):
            if i == s or other[i] != other[i - 1]:
                if run == 1:
                    n_single += 1
                n_edges += 1
                run = 0
            run += 1
        if run == 1:
            n_single += 1
    edges = np.empty((n_edges, 2), np.int64)
    count = np.zeros(n_edges, np.int64)
    edge_of_he = np.empty(m3, np.int64)
    single = np.empty(n_single, np.int64)
    ei = -1
    si = 0
    for a in range(n):
        for i in range(start[a], start[a + 1]):
            if i == start[a] or other[i] != other[i - 1]:
                if ei >= 0 and count[ei] == 1:
                    single[si] = order[i - 1]
                    si += 1
                ei += 1
                edges[ei, 0] = a
                edges[ei, 1] = other[i]
            count[ei] += 1
            edge_of_he[order[i]] = ei
    if ei >= 0 and count[ei] == 1:
        single[si] = order[m3 - 1]
        si += 1
    single.sort()
    return order, edge_of_he, edges, count, single


_edge_kernel_jit = _njit(_edge_kernel)


def edge_topology_arrays(F, n):
    """The arrays of :class:`shellrepair.topology.EdgeTopology`, by a counting sort.

    Parameters
    ----------
    F : (m,3) int64 array
        Vertex ids in ``[0, n)``.
    n : int
        Number of vertices.

    Returns
    -------
    he_order : (3m,) int64
        Half-edge ids grouped by undirected edge in edge order; within an
        edge, in increasing half-edge id.
    edge_of_he : (3m,) int64
    edges : (e,2) int64
        Sorted by ``(edges[:,0], edges[:,1])``, ``edges[:,0] < edges[:,1]``.
    edge_count : (e,) int64
    boundary_he : (b,) int64
        Sorted.

    Notes
    -----
    Every half-edge ``u -> v`` is filed under ``min(u, v)`` (one counting
    pass and one scatter), then each vertex's few entries are sorted by
    ``max(u, v)``: O(m) work and no global sort. The higher vertex of
    each entry is kept in 32 bits when ids fit.
    """
    F = np.ascontiguousarray(F, np.int64)
    n = int(n)
    other = np.empty(3 * len(F), np.int32 if n < 2 ** 31 else np.int64)
    return _edge_kernel_jit(F, n, other)


# --------------------------------------------------------------------------
# pieces
# --------------------------------------------------------------------------
def _find(parent, x):
    while parent[x] != x:
        parent[x] = parent[parent[x]]   # path halving
        x = parent[x]
    return x


_find_jit = _njit(_find)


def _pieces_kernel(he_order, edge_count, tails, m, manifold_only):
    parent = np.arange(m)
    differ = False
    s = 0
    for e in range(edge_count.size):
        c = edge_count[e]
        if c == 2 or (c > 2 and not manifold_only):
            for i in range(s, s + c - 1):
                ra = _find_jit(parent, he_order[i] // 3)
                rb = _find_jit(parent, he_order[i + 1] // 3)
                # the lower root wins: a root is its piece's lowest face
                if ra < rb:
                    parent[rb] = ra
                elif rb < ra:
                    parent[ra] = rb
            if c == 2 and tails[he_order[s]] == tails[he_order[s + 1]]:
                differ = True
        s += c
    label = np.empty(m, np.int64)
    n_pieces = 0
    for f in range(m):
        r = _find_jit(parent, f)
        if r == f:
            label[f] = n_pieces
            n_pieces += 1
        else:
            label[f] = label[r]
    first = np.empty(n_pieces, np.int64)
    k = 0
    for f in range(m):
        if label[f] == k:
            first[k] = f
            k += 1
    return n_pieces, label, first, differ


_pieces_kernel_jit = _njit(_pieces_kernel)


def face_pieces_labels(topo, F, m, *, manifold_only):
    """Faces joined across shared edges, labelled as SciPy's
    ``connected_components`` labels them.

    Parameters
    ----------
    topo : EdgeTopology
        With ``he_order``.
    F : (m,3) int64 array
        The faces ``topo`` was built on.
    m : int
        Number of faces.
    manifold_only : bool
        Join only across edges with exactly two faces (the pieces of
        :func:`shellrepair.clean.orient_faces`); else across every shared
        edge (:func:`shellrepair.topology.face_pieces`).

    Returns
    -------
    n_pieces : int
    label : (m,) int64
        Pieces numbered in the order of their lowest face (SciPy's order).
    first : (n_pieces,) int64
        The lowest face of each piece.
    differ : bool
        True when some edge with two faces is used in the same direction by
        both (a flip is needed).
    """
    tails = np.ascontiguousarray(F, np.int64).reshape(-1)
    n, label, first, differ = _pieces_kernel_jit(topo.he_order, topo.edge_count, tails, int(m), bool(manifold_only))
    return int(n), label, first, bool(differ)


# --------------------------------------------------------------------------
# per-face geometry
# --------------------------------------------------------------------------
def _areas_kernel(V, F, out):
    for f in range(F.shape[0]):
        a = F[f, 0]
        b = F[f, 1]
        c = F[f, 2]
        ux = V[b, 0] - V[a, 0]
        uy = V[b, 1] - V[a, 1]
        uz = V[b, 2] - V[a, 2]
        wx = V[c, 0] - V[a, 0]
        wy = V[c, 1] - V[a, 1]
        wz = V[c, 2] - V[a, 2]
        # geometry.cross(u, w), term by term in the same order
        cx = uy * wz - uz * wy
        cy = uz * wx - ux * wz
        cz = ux * wy - uy * wx
        # summed as NumPy's einsum("ij,ij->i") sums three terms on x86-64
        out[f] = 0.5 * np.sqrt((cx * cx + cz * cz) + cy * cy)


_areas_kernel_jit = _njit(_areas_kernel)


def face_areas(V, F):
    """Triangle areas, (m,) float64: ``0.5 |(b - a) × (c - a)|``, bit for bit
    as :func:`shellrepair.topology.face_areas` computes them."""
    out = np.empty(len(F))
    _areas_kernel_jit(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64), out)
    return out


def _volumes_kernel(V, F, flip, piece, n_pieces):
    m = F.shape[0]
    cnt = np.zeros(n_pieces, np.int64)
    cen = np.zeros((n_pieces, 3))
    for f in range(m):
        p = piece[f]
        cnt[p] += 1
        for j in range(3):
            cen[p, j] += (V[F[f, 0], j] + V[F[f, 1], j] + V[F[f, 2], j]) / 3.0
    for p in range(n_pieces):
        d = cnt[p] if cnt[p] > 0 else 1
        for j in range(3):
            cen[p, j] /= d
    vol = np.zeros(n_pieces)
    for f in range(m):
        p = piece[f]
        ax = V[F[f, 0], 0] - cen[p, 0]
        ay = V[F[f, 0], 1] - cen[p, 1]
        az = V[F[f, 0], 2] - cen[p, 2]
        bx = V[F[f, 1], 0] - cen[p, 0]
        by = V[F[f, 1], 1] - cen[p, 1]
        bz = V[F[f, 1], 2] - cen[p, 2]
        cx = V[F[f, 2], 0] - cen[p, 0]
        cy = V[F[f, 2], 1] - cen[p, 1]
        cz = V[F[f, 2], 2] - cen[p, 2]
        # dot(a, cross(b, c)) / 6 as clean._signed_volumes writes it
        det = (ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)) / 6.0
        vol[p] += -det if flip[f] else det
    return vol


_volumes_kernel_jit = _njit(_volumes_kernel)


def piece_signed_volumes(V, F, flip, piece, n_pieces):
    """Signed volume of each piece with ``flip`` applied, about the mean of
    its face centroids; the sums of :func:`shellrepair.clean._signed_volumes`
    in the same order (one pass for the centroids, one for the volumes)."""
    return _volumes_kernel_jit(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64),
                               np.ascontiguousarray(flip, np.bool_), np.ascontiguousarray(piece, np.int64),
                               int(n_pieces))


# --------------------------------------------------------------------------
# vertex -> faces
# --------------------------------------------------------------------------
def _vertex_faces_kernel(flat, n):
    start = np.zeros(n + 1, np.int64)
    for i in range(flat.size):
        start[flat[i] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    pos = start[:n].copy()
    order = np.empty(flat.size, np.int64)
    for i in range(flat.size):
        v = flat[i]
        order[pos[v]] = i
        pos[v] += 1
    return order, start


_vertex_faces_kernel_jit = _njit(_vertex_faces_kernel)


def vertex_faces(F, n):
    """:func:`shellrepair.topology.vertex_faces` by one counting sort."""
    return _vertex_faces_kernel_jit(np.ascontiguousarray(F, np.int64).reshape(-1), int(n))


def warm_up():
    """Compile (or load from the cache) every kernel on a two-triangle mesh."""
    if not AVAILABLE:
        return False
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    F = np.array([[0, 1, 2], [2, 1, 3]], np.int64)
    from .topology import edge_topology

    topo = edge_topology(F, 4)
    face_pieces_labels(topo, F, 2, manifold_only=True)
    face_areas(V, F)
    piece_signed_volumes(V, F, np.zeros(2, bool), np.zeros(2, np.int64), 1)
    vertex_faces(F, 4)
    return True
