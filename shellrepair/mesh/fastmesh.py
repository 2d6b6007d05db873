"""Compiled kernels of the whole-mesh steps (Numba).

Each kernel here is one linear pass (or a few) over the faces, in place of
NumPy code that sorts or builds a sparse matrix: the half-edge topology by
counting sorts on each edge's lower vertex, pieces by union-find, face
areas and signed volumes in one loop each (the vertex-face lists are
:func:`shellrepair.mesh.topology_kernels.vertex_faces`'s, loaded on their own). They give
exactly what their NumPy versions in :mod:`shellrepair.mesh.topology` and
:mod:`shellrepair.mesh.clean` give (those stay as the reference, and as the
path taken when Numba is missing; ``tests/test_scale_structures.py``
compares the two).

Numba is imported, and the kernels compiled or loaded from their cache
(``cache=True``: machine code kept beside this file in ``__pycache__``),
on first use only, and only for meshes of at least ``MIN_FACES`` faces
(:func:`enabled`): loading them costs about half a second once per
process, more than they save on a small mesh. :func:`warm_up` compiles
them all (``make setup`` calls it), so that no user run waits on the
compiler. Kernels release the GIL (``nogil``): from ``HALVES_MIN_ROWS``
rows, with two cores or more, the edge topology, face areas and edge
lengths run in two halves on two threads, with the same results.

They run where :data:`shellrepair.compiled.ENABLED` is set (the one switch:
``SHELLREPAIR_NO_NUMBA=1`` turns them off) and Numba can be imported
(these kernels have no ahead-of-time build).
"""

from __future__ import annotations

import os
import threading
from types import SimpleNamespace

import numpy as np

from shellrepair import compiled
from shellrepair.mesh import halves

#: Faces from which the whole-mesh steps use the kernels. Below it they
#: save less than the half second that loading them costs once per process
#: (measured on the 1M-face scale case: edge topology, orientation, areas
#: and vertex-face lists 0.71-0.78 s CPU with NumPy, 0.22-0.29 s compiled;
#: :func:`preload` overlaps the loading with the reading of the file).
MIN_FACES = 400_000

__all__ = ["MIN_FACES", "enabled", "preload", "edge_topology_arrays", "edge_topology_steps", "edge_ids", "face_pieces_labels",
           "face_areas", "normal_moments", "edge_sq_lengths", "triple_hash", "vertex_faces", "piece_signed_volumes", "warm_up"]

#: Runs of slots shorter than this are sorted by insertion (a vertex's
#: edges: about six on a scan); longer ones by np.sort.
_INSERTION_MAX = 24
#: Bits of a half-edge (or corner) id in a packed word.
_HE_BITS = 32
#: Where the higher vertex starts in the edge kernel's packed (higher
#: vertex, half-edge, direction) word.
_KEY_SHIFT = _HE_BITS + 1
#: Lower vertices per bucket, as a power of two: a bucket's entries (about
#: six per vertex, 8 bytes each) stay within the core's cache.
_BUCKET_SHIFT = 12

_K = None
_LOCK = threading.Lock()


def _usable():
    """Whether the kernels can run: :data:`shellrepair.compiled.ENABLED`
    (read at call time) and Numba there."""
    return compiled.ENABLED and compiled.numba_found()


def enabled(n_faces):
    """True when a whole-mesh step on ``n_faces`` faces should use the kernels:
    from ``MIN_FACES`` faces, or on any mesh once they are loaded (their
    loading is then paid already; they give the same arrays)."""
    return _usable() and (n_faces >= MIN_FACES or _K is not None)


def _kernels():
    """The compiled kernels (Numba imported and the kernels compiled or
    loaded from the cache on the first call)."""
    global _K
    if _K is not None:
        return _K
    with _LOCK:   # one thread loads them (see preload); the others wait for it
        if _K is not None:
            return _K
        import numba

        jit = numba.njit(cache=True, nogil=True)
        _K = SimpleNamespace(edge_ids=jit(_edge_ids_kernel), pieces=jit(_pieces_kernel),
                             areas=jit(_areas_kernel), edge_sq=jit(_edge_sq_kernel), volumes=jit(_volumes_kernel),
                             triple_hash=jit(_triple_hash_kernel), moments=jit(_moments_kernel),
                             edge_count=jit(_edge_count_kernel), edge_scatter=jit(_edge_scatter_kernel),
                             edge_bucket=jit(_edge_bucket_kernel), edge_list=jit(_edge_list_kernel),
                             single=jit(_single_kernel))
    return _K


# --------------------------------------------------------------------------
# half-edge topology
# --------------------------------------------------------------------------
# the steps of edge_topology_arrays, each run on two halves (on two threads
# for a large mesh): faces for steps 1-2, buckets (and their vertices) for 3-4
def _edge_count_kernel(F, f0, f1, n, shift, bcount):
    # step 1 over faces [f0, f1): half-edges per bucket (bcount[k + 1])
    for f in range(f0, f1):
        for c in range(3):
            u = F[f, c]
            if u < 0 or u >= n:
                raise ValueError("a face refers to a vertex outside [0, n_vertices)")
            v = F[f, c + 1] if c < 2 else F[f, 0]
            bcount[((u if u < v else v) >> shift) + 1] += 1


def _edge_scatter_kernel(F, f0, f1, shift, bpos, key, lowv):
    # step 2 over faces [f0, f1), from each bucket's position bpos (advanced)
    low = (np.int64(1) << shift) - 1
    for f in range(f0, f1):
        for c in range(3):
            u = F[f, c]
            v = F[f, c + 1] if c < 2 else F[f, 0]
            if u < v:
                a, b = u, v
            else:
                a, b = v, u
            k = a >> shift
            p = bpos[k]
            bpos[k] = p + 1
            key[p] = (b << _KEY_SHIFT) | ((3 * f + c) << 1) | (1 if u > v else 0)
            lowv[p] = a & low


def _edge_bucket_kernel(key, lowv, bstart, k0, k1, n, shift, vstart):
    # step 3 for buckets [k0, k1), in place: each bucket's entries of key
    # filed by lower vertex within the bucket's own range (through a copy
    # of the bucket, in cache); returns their edges
    low = (np.int64(1) << shift) - 1
    cnt = np.zeros((np.int64(1) << shift) + 1, np.int64)
    big = 0
    for k in range(k0, k1):
        big = max(big, bstart[k + 1] - bstart[k])
    tmp = np.empty(big, np.int64)
    slot = key
    n_edges = 0
    for k in range(k0, k1):
        s0 = bstart[k]
        s1 = bstart[k + 1]
        a0 = k << shift
        na = min(n - a0, low + 1)
        cnt[:na + 1] = 0
        for i in range(s0, s1):
            cnt[lowv[i] + 1] += 1
        cnt[0] = s0
        for j in range(na):
            cnt[j + 1] += cnt[j]
        for j in range(na):
            vstart[a0 + j] = cnt[j]
        for i in range(s0, s1):
            tmp[i - s0] = key[i]
        for i in range(s0, s1):
            j = lowv[i]
            slot[cnt[j]] = tmp[i - s0]
            cnt[j] += 1
        for j in range(na):
            s = vstart[a0 + j]
            e = cnt[j]
            if e - s > _INSERTION_MAX:
                slot[s:e] = np.sort(slot[s:e])
            else:
                for i in range(s + 1, e):
                    x = slot[i]
                    q = i - 1
                    while q >= s and slot[q] > x:
                        slot[q + 1] = slot[q]
                        q -= 1
                    slot[q + 1] = x
            prev = -1
            for i in range(s, e):
                b = slot[i] >> _KEY_SHIFT
                if b != prev:
                    n_edges += 1
                    prev = b
    return n_edges


def _edge_list_kernel(slot, vstart, a0, a1, e0, edges, count):
    # step 4 for vertices [a0, a1), their edges numbered from e0 (an edge's
    # half-edges are all in its lower vertex's run); returns the edges with
    # one face and whether every two-face edge has them opposite
    mask = (np.int64(1) << _HE_BITS) - 1
    ei = e0 - 1
    n_single = 0
    consistent = True
    first_dir = 0
    same_dir = False
    for a in range(a0, a1):
        prev = -1
        for i in range(vstart[a], vstart[a + 1]):
            b = slot[i] >> _KEY_SHIFT
            d = slot[i] & 1
            if b != prev:
                if ei >= e0:
                    if count[ei] == 1:
                        n_single += 1
                    elif count[ei] == 2 and same_dir:
                        consistent = False
                ei += 1
                edges[ei, 0] = a
                edges[ei, 1] = b
                prev = b
                first_dir = d
            elif count[ei] == 1:
                same_dir = d == first_dir
            count[ei] += 1
            slot[i] = (slot[i] >> 1) & mask
    if ei >= e0:
        if count[ei] == 1:
            n_single += 1
        elif count[ei] == 2 and same_dir:
            consistent = False
    return n_single, consistent


def _single_kernel(slot, count, n_single):
    single = np.empty(n_single, np.int64)
    j = 0
    i = 0
    for e in range(count.size):
        if count[e] == 1:
            single[j] = slot[i]
            j += 1
        i += count[e]
    single.sort()
    return single


def edge_topology_steps(F, n, shift, two=False):
    """The half-edge topology's arrays (see :func:`edge_topology_arrays`) in
    four steps, each in two halves: on two threads with ``two`` (the same
    arrays either way).

    Parameters
    ----------
    F : (m,3) int64, C-contiguous
    n : int
        Vertex count.
    shift : int
        Vertices are filed in buckets of ``2**shift`` consecutive ids.
    two : bool
        Run each step's halves on two threads.

    Returns
    -------
    he_order, edges, edge_count, boundary_he, consistent
        As :func:`edge_topology_arrays`.

    Raises
    ------
    ValueError
        When a vertex id is outside ``0 .. n-1``.
    """
    run = halves.both if two else halves.in_turn
    K = _kernels()
    m = len(F)
    m3 = 3 * m
    nb = (n >> shift) + 1
    h = m // 2
    c0 = np.zeros(nb + 1, np.int64)
    c1 = np.zeros(nb + 1, np.int64)
    run(K.edge_count, (F, h, m, n, shift, c1), (F, 0, h, n, shift, c0))
    bstart = np.cumsum(c0 + c1)
    key = np.empty(m3, np.int64)
    lowv = np.empty(m3, np.int32)
    # the first half's half-edges first in each bucket, then the second's: as one pass files them
    run(K.edge_scatter, (F, h, m, shift, bstart[:nb] + c0[1:], key, lowv),
        (F, 0, h, shift, bstart[:nb].copy(), key, lowv))
    del c0, c1
    vstart = np.empty(n + 1, np.int64)
    kh = nb // 2
    # the buckets sorted in place: key becomes the slots (each bucket keeps its range)
    e_hi, e_lo = run(K.edge_bucket, (key, lowv, bstart, kh, nb, n, shift, vstart),
                     (key, lowv, bstart, 0, kh, n, shift, vstart))
    slot = key
    del key, lowv
    vstart[n] = m3
    edges = np.empty((e_lo + e_hi, 2), np.int64)
    count = np.zeros(e_lo + e_hi, np.int64)
    ah = min(kh << shift, n)
    (s_hi, ok_hi), (s_lo, ok_lo) = run(K.edge_list, (slot, vstart, ah, n, e_lo, edges, count),
                                       (slot, vstart, 0, ah, 0, edges, count))
    single = K.single(slot, count, s_lo + s_hi)
    return slot, edges, count, single, ok_lo and ok_hi


def _edge_ids_kernel(he_order, edge_count):
    out = np.empty(he_order.size, np.int64)
    i = 0
    for e in range(edge_count.size):
        for _ in range(edge_count[e]):
            out[he_order[i]] = e
            i += 1
    return out


def edge_topology_arrays(F, n):
    """The arrays of :class:`shellrepair.mesh.topology.EdgeTopology`, by counting sorts.

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
    edges : (e,2) int64
        Sorted by ``(edges[:,0], edges[:,1])``, ``edges[:,0] < edges[:,1]``.
    edge_count : (e,) int64
    boundary_he : (b,) int64
        Sorted.
    consistent : bool
        No edge with two faces has both half-edges in one direction (no
        face needs a flip to agree with its neighbours).
    Or None when the ids do not fit the packing (``n >= 2**30`` or
    ``3m >= 2**32``): use the NumPy version then.

    Notes
    -----
    Every half-edge ``u -> v`` is filed under its lower vertex
    ``min(u, v)`` in two steps that each stay in cache: first into buckets
    of ``2**12`` lower vertices (a few thousand write streams), then, bucket
    by bucket, by the lower vertex itself (in place: the bucket copied to
    scratch in cache, filed back into its own range); each vertex's few entries are
    then sorted by ``(max(u, v), half-edge)`` packed in one 64-bit word
    (with the half-edge's direction in the lowest bit).
    O(m) work, no global sort, no random access outside a bucket. From
    ``HALVES_MIN_ROWS`` faces, with two cores, each step runs on two
    threads: the faces in halves for the filing (the second half's entries
    after the first's in each bucket, as one pass files them), the buckets
    in halves for the sorting and the edge list (an edge's half-edges are
    all under its lower vertex). The arrays are the same either way.
    """
    F = np.ascontiguousarray(F, np.int64)
    n = int(n)
    if n >= 2 ** (63 - _KEY_SHIFT) or 3 * len(F) >= 2 ** _HE_BITS:
        return None
    shift = max(1, min(_BUCKET_SHIFT, max(n - 1, 1).bit_length()))
    return edge_topology_steps(F, n, shift, two=_two_threads(len(F)))


def edge_ids(he_order, edge_count):
    """``edge_of_he``: the edge of each half-edge, (3m,) int64, from the
    grouping :func:`edge_topology_arrays` gives."""
    return _kernels().edge_ids(np.ascontiguousarray(he_order, np.int64), np.ascontiguousarray(edge_count, np.int64))


# --------------------------------------------------------------------------
# pieces
# --------------------------------------------------------------------------
def _pieces_kernel(he_order, edge_count, tails, parent, manifold_only, check):
    m = parent.size
    for f in range(m):
        parent[f] = f
    differ = False
    s = 0
    for e in range(edge_count.size):
        c = edge_count[e]
        if c == 2 or (c > 2 and not manifold_only):
            for i in range(s, s + c - 1):
                ra = he_order[i] // 3
                while parent[ra] != ra:
                    parent[ra] = parent[parent[ra]]   # path halving
                    ra = parent[ra]
                rb = he_order[i + 1] // 3
                while parent[rb] != rb:
                    parent[rb] = parent[parent[rb]]
                    rb = parent[rb]
                # the lower root wins: a root is its piece's lowest face
                if ra < rb:
                    parent[rb] = ra
                elif rb < ra:
                    parent[ra] = rb
            if check and c == 2 and tails[he_order[s]] == tails[he_order[s + 1]]:
                differ = True
        s += c
    label = np.empty(m, np.int64)
    n_pieces = 0
    for f in range(m):
        r = parent[f]          # a lower face, labelled already: its root is final
        while parent[r] != r:
            r = parent[r]
        parent[f] = r
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
        :func:`shellrepair.mesh.clean.orient_faces`); else across every shared
        edge (:func:`shellrepair.mesh.topology.face_pieces`).

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
    # 32-bit parents where face ids fit: half the memory the random accesses roam
    parent = np.empty(int(m), np.int32 if m < 2 ** 31 else np.int64)
    known = getattr(topo, "consistent", None)   # found by the edge kernel: no per-edge lookups
    n, label, first, differ = _kernels().pieces(topo.he_order, topo.edge_count, tails, parent, bool(manifold_only),
                                                known is None)
    return int(n), label, first, bool(differ) if known is None else not known


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


#: Rows from which :func:`_in_halves` runs a row-wise kernel on two threads.
HALVES_MIN_ROWS = 1_000_000


def _two_threads(rows):
    """Whether a step over ``rows`` rows runs in halves on two threads:
    from ``HALVES_MIN_ROWS`` rows, with two cores or more."""
    return rows >= HALVES_MIN_ROWS and (os.cpu_count() or 1) >= 2


def _in_halves(kernel, V, R, out):
    """``kernel(V, R, out)`` for a kernel whose output row i depends only on
    row i of ``R``: where :func:`_two_threads`, the two halves of the rows
    on two threads (the kernels release the GIL); the same values either
    way."""
    if not _two_threads(len(R)):
        kernel(V, R, out)
        return
    h = len(R) // 2
    halves.both(kernel, (V, R[h:], out[h:]), (V, R[:h], out[:h]))


def face_areas(V, F):
    """Triangle areas, (m,) float64: ``0.5 |(b - a) × (c - a)|``, bit for bit
    as :func:`shellrepair.mesh.topology.face_areas` computes them."""
    out = np.empty(len(F))
    _in_halves(_kernels().areas, np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64), out)
    return out


def _moments_kernel(V, F, row, thresh, a, M):
    for f in range(F.shape[0]):
        p = row[f]
        if p < 0:
            continue
        h = (np.uint64(f) * np.uint64(2654435761)) & np.uint64(0xFFFFFFFF)
        if not np.float64(h) < thresh[p]:
            continue
        i = F[f, 0]
        j = F[f, 1]
        k = F[f, 2]
        ux = V[j, 0] - V[i, 0]
        uy = V[j, 1] - V[i, 1]
        uz = V[j, 2] - V[i, 2]
        wx = V[k, 0] - V[i, 0]
        wy = V[k, 1] - V[i, 1]
        wz = V[k, 2] - V[i, 2]
        n0 = uy * wz - uz * wy
        n1 = uz * wx - ux * wz
        n2 = ux * wy - uy * wx
        a[p, 0] += n0
        a[p, 1] += n1
        a[p, 2] += n2
        ln = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if ln > 0:
            w = 1.0 / ln
            M[p, 0, 0] += n0 * n0 * w
            M[p, 0, 1] += n0 * n1 * w
            M[p, 0, 2] += n0 * n2 * w
            M[p, 1, 1] += n1 * n1 * w
            M[p, 1, 2] += n1 * n2 * w
            M[p, 2, 2] += n2 * n2 * w


def normal_moments(V, F, row, thresh, k):
    """Per group of faces, the sum ``a`` of the face normals ``n = (b − a) ×
    (c − a)`` and ``M = Σ n nᵀ / |n|``, over the faces ``f`` with
    ``row[f] >= 0`` (their group) whose hash ``(f · 2654435761) mod 2³²``
    is below ``thresh[row[f]]`` (``inf``: every face); in one pass, without
    the per-face arrays. Sums in face order, so not bit for bit NumPy's
    (what uses them allows for round-off).

    Returns
    -------
    a : (k,3) float64
    M : (k,3,3) float64, symmetric
    """
    a = np.zeros((k, 3))
    M = np.zeros((k, 3, 3))
    _kernels().moments(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64),
                       np.ascontiguousarray(row, np.int64), np.ascontiguousarray(thresh, np.float64), a, M)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        M[:, j, i] = M[:, i, j]
    return a, M


def _edge_sq_kernel(V, E, out):
    for e in range(E.shape[0]):
        a = E[e, 0]
        b = E[e, 1]
        dx = V[a, 0] - V[b, 0]
        dy = V[a, 1] - V[b, 1]
        dz = V[a, 2] - V[b, 2]
        out[e] = (dx * dx + dz * dz) + dy * dy     # einsum("ij,ij->i")'s order, as in _areas_kernel


def edge_sq_lengths(V, E):
    """Squared lengths of the edges ``E`` (k,2), (k,) float64: one pass, no
    (k,3) temporaries; the sums of ``einsum("ij,ij->i", d, d)`` here."""
    out = np.empty(len(E))
    _in_halves(_kernels().edge_sq, np.ascontiguousarray(V, np.float64), np.ascontiguousarray(E, np.int64), out)
    return out


def _triple_hash_kernel(F, out):
    for f in range(F.shape[0]):
        x = F[f, 0]
        y = F[f, 1]
        z = F[f, 2]
        a = min(min(x, y), z)
        c = max(max(x, y), z)
        b = x + y + z - a - c
        h = np.uint64(a) * np.uint64(0x9E3779B97F4A7C15)
        h ^= np.uint64(b) * np.uint64(0xC2B2AE3D27D4EB4F)
        h ^= np.uint64(c) * np.uint64(0x165667B19E3779F9)
        out[f] = h ^ (h >> np.uint64(29))


def triple_hash(F):
    """The 64-bit hash of each row's vertex set that
    :func:`shellrepair.mesh.clean.triple_hash_reference` computes, (m,) uint64, in one pass."""
    out = np.empty(len(F), np.uint64)
    _kernels().triple_hash(np.ascontiguousarray(F, np.int64), out)
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
        # dot(a, cross(b, c)) / 6 as clean.signed_volumes writes it
        det = (ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)) / 6.0
        vol[p] += -det if flip[f] else det
    return vol


def piece_signed_volumes(V, F, flip, piece, n_pieces):
    """Signed volume of each piece with ``flip`` applied, about the mean of
    its face centroids; the sums of :func:`shellrepair.mesh.clean.signed_volumes`
    in the same order (one pass for the centroids, one for the volumes)."""
    return _kernels().volumes(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64),
                               np.ascontiguousarray(flip, np.bool_), np.ascontiguousarray(piece, np.int64),
                               int(n_pieces))


# --------------------------------------------------------------------------
# vertex -> faces
# --------------------------------------------------------------------------
def vertex_faces(F, n):
    """:func:`shellrepair.mesh.topology.vertex_faces`: ``(order, start)``, by
    :func:`shellrepair.mesh.topology_kernels.vertex_faces` (the one compiled version;
    loaded on its own, not with this module's kernels)."""
    from shellrepair.mesh import topology_kernels

    return topology_kernels.vertex_faces(F, n)


def preload(n_faces):
    """Start loading the kernels in a background thread when a mesh of
    ``n_faces`` faces will use them (:func:`enabled`), so that importing
    Numba and reading the cached machine code overlap the reading of the
    file (NumPy's work there runs without the GIL). Returns at once."""
    if enabled(n_faces) and _K is None:
        threading.Thread(target=warm_up, name="shellrepair-kernels", daemon=True).start()


def warm_up():
    """Compile (or load from the cache) every kernel on a two-triangle mesh;
    False when the kernels are off or Numba is missing."""
    if not _usable():
        return False
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    F = np.array([[0, 1, 2], [2, 1, 3]], np.int64)
    order, edges, count, _, _ = edge_topology_arrays(F, 4)
    edge_topology_steps(F, 4, 1, two=True)
    edge_ids(order, count)
    face_pieces_labels(SimpleNamespace(he_order=order, edge_count=count), F, 2, manifold_only=True)
    face_areas(V, F)
    edge_sq_lengths(V, edges)
    triple_hash(F)
    piece_signed_volumes(V, F, np.zeros(2, bool), np.zeros(2, np.int64), 1)
    normal_moments(V, F, np.zeros(2, np.int64), np.full(1, np.inf), 1)
    vertex_faces(F, 4)
    return True
