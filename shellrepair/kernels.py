"""Compiled kernels for the per-hole work (Numba, cached on disk).

Each kernel does what a NumPy (or plain Python) function of the package
does, with the same floating-point operations in the same order, so its
result is the same to the bit; that function stays as the test oracle
(``tests/test_kernels.py`` asserts equality on seeded random and degenerate
inputs). The kernels exist because the per-hole work is many small steps:
in NumPy each costs a few microseconds of dispatch whatever its size, and
loops of rounds (edge flips) pay it hundreds of times a hole.

* :func:`vertex_faces`: vertex-to-face lists by two cache-sized counting
  sorts (:func:`shellrepair.topology.vertex_faces`; also the whole-mesh
  version :mod:`shellrepair.fastmesh` gives);
* :func:`faces_in_boxes`: the faces whose bounding boxes meet some boxes
  (the region of :class:`shellrepair.context._Region`), one pass over the
  vertices and one over the faces;
* :func:`ring_faces`: the faces within some rings of a vertex set
  (:meth:`shellrepair.context.ScanContext.ring_faces`);
* :func:`submesh`: a hole's submesh in local numbering
  (:func:`shellrepair.context.submesh`); :func:`patch_corners`,
  :func:`rim_sigma`: a patch's triangle corners and its rim scale
  (:func:`shellrepair.patch._corners`, :func:`shellrepair.context._rim_sigma`);
* :func:`inside_outline`, :func:`loop_cover`: the inside test and the cover
  test of :func:`shellrepair.triangulate._delaunay_in_projection`;
* :func:`grid_sort`, :func:`faces_in_box`: the vertex grid of
  :class:`shellrepair.intersect.NearFaces` and its box query;
* :func:`box_pairs`: candidate triangle pairs for the crossing tests
  (a superset of the crossing pairs, like the bounding-sphere pairs of
  :mod:`shellrepair.intersect` it replaces, so the tests' results are
  the same);
* :func:`separated`: pairs a certified plane test rules out before the
  exact crossing tests;
* :func:`cross_status`: the crossing test of triangle pairs where its float
  filters decide (:func:`shellrepair.intersect.triangles_cross`), the rest
  left to it, and :func:`patch_pairs`: a patch's candidate pairs with the
  scan and their tests in one call;
* :func:`projection_embeds`: the projected area and outline tests of
  :func:`shellrepair.intersect.embeds_by_projection`;
* :func:`intrinsic_flips`: intrinsic Delaunay edge flips in rounds, with the
  cotangents and areas of the result
  (:func:`shellrepair.intrinsic._flip_to_delaunay`);
* :func:`relax`: a patch's Delaunay edge flips
  (:func:`shellrepair.refine._relax`), the angles still NumPy's, and
  :func:`relax_round_parts`: one round's angle parts and fold tests;
* :func:`rim_edges`: a loop's rim scale and scan normals from the faces
  around it (:func:`shellrepair.context.rim_data`);
* :func:`fair_small`: a small patch's whole fairing
  (:func:`shellrepair.fair.fair_patch`), the solves dense: equal to
  round-off, not to the bit (the one kernel with a tolerance, stated there);
* :func:`energy_blocks`: the unknown and fixed blocks of a large patch's
  fairing energy (:func:`shellrepair.fair._energy` and its slices), equal
  to round-off (the sums in another order; tests/test_fair.py);
* :func:`folds`: the patch triangles folded onto a neighbour
  (:func:`shellrepair.fill._folds`);
* :func:`rim_walk`: :func:`rim_edges` with the faces around the loop found
  and measured in the same pass (:func:`shellrepair.context.rim_data`);
* :func:`face_cross`: faces' cross products, gathered and computed in one
  pass (:func:`shellrepair.patch._meets_edge_on`);
* :func:`ring_sums`: the sums over the two rings around a loop's vertices
  (:func:`shellrepair.bridge._ring_sums`, the continuation arcs), and
  :func:`block_ids`, :func:`corner_normal_sums`: the arcs' local vertex
  numbers and vertex normal sums;
* :func:`arc_landings`: where each continuation arc lands first, arc by
  arc, sample by sample, in a k-d tree of the rim vertices
  (:func:`shellrepair.bridge._landings_numpy`, which asks SciPy's
  ``cKDTree`` run by run);
* :func:`angle_parts`, :func:`unfolded`: the products and sums of the
  relaxation's opposite angles (the arctan2 left to NumPy) and its fold
  test (:func:`shellrepair.refine._angle`, :func:`shellrepair.refine._unfolded`);
* :func:`split_test`: the refinement's split test (:func:`shellrepair.refine._refine`);
* :func:`ring_walk`: the rings around a loop in one walk, each ring's end
  recorded (:func:`ring_faces`); :func:`centroids`,
  :func:`nearest_triangle_distances`: the order test's centroid query and
  distances (:func:`shellrepair.distance.point_mesh_distance`; the latter
  each point's closest candidate triangle, on scalars);
* :func:`centred_area`, :func:`outline_cross`, :func:`cover_free`: a
  loop's centred positions and vector area, and the projected Delaunay
  triangulation's inside, normal and cover tests with the forbidden edges
  (:func:`shellrepair.triangulate.triangulate_loop`,
  :func:`shellrepair.triangulate._delaunay_in_projection`);
* :func:`tet_faces`, :func:`loop_edges_present`: the triangles of a
  tetrahedralization and the loop edges among them
  (:func:`shellrepair.triangulate.delaunay_faces`,
  :func:`shellrepair.triangulate._with_loop_edges`);
* :func:`restricted_prepare`, :func:`restricted_search`: the candidate
  triangles' edges and normals and the minimum-weight search over them by
  interval length (:func:`shellrepair.triangulate.restricted_dp`).

Each kernel is marked :func:`shellrepair.compiled.kernel`: ``make setup``
compiles them ahead of time (``python -m shellrepair.aot build``) for the
argument types of ``shellrepair/aot_types.json``, so that a run loads them
in milliseconds and never imports Numba; a call with other types goes to
Numba's JIT (cached on disk, ``cache=True``, under ``__pycache__`` beside
this file), with the same bits. :func:`shellrepair.warmup.warm_up` compiles every kernel with
the JIT on tiny inputs (the build's way where the ahead-of-time build
fails, and what ``python -m shellrepair.aot record`` watches to list the
types). When neither is there (``SHELLREPAIR_NO_NUMBA=1`` forces that
too), ``ENABLED`` is False and callers use the NumPy versions.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["ENABLED", "vertex_faces", "faces_in_boxes", "ring_faces", "submesh", "inside_outline", "loop_cover", "patch_corners", "rim_sigma", "faces_in_box", "grid_sort", "box_pairs", "separated", "cross_status", "patch_pairs", "projection_embeds", "intrinsic_flips", "rim_edges", "relax", "fair_small", "relax_round_parts", "energy_blocks", "boxes_meeting", "max_sq_distance", "outline_simple", "folds", "rim_walk", "face_cross", "ring_sums", "block_ids", "corner_normal_sums", "arc_landings", "angle_parts", "unfolded", "split_test", "centred_area", "outline_cross", "cover_free", "tet_faces", "loop_edges_present", "restricted_prepare", "restricted_search", "liepa_tables", "chord_rows", "ring_walk", "centroids", "nearest_triangle_distances"]

from . import compiled
from .geometry import vertex_faces_scipy
from .halves import both, in_turn

#: Whether the kernels run (compiled ahead of time, or by Numba's JIT):
#: :func:`shellrepair.compiled.available`; when False, the NumPy versions run instead.
ENABLED = compiled.available()
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
    """Vertex-to-face lists (as :func:`shellrepair.topology.vertex_faces`),
    by two cache-sized counting sorts (buckets of vertices, then each
    vertex): the one compiled version, which :mod:`shellrepair.fastmesh`
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
    if not ENABLED or flat.size >= 2 ** _VF_BITS:   # corner ids must fit the packing
        if flat.size and (flat.min() < 0 or flat.max() >= n):
            raise ValueError(f"face indices must lie in [0, {n}), got {flat.min()}..{flat.max()}")
        return vertex_faces_scipy(F, n)
    shift = max(1, min(_VF_BUCKET_SHIFT, max(n - 1, 1).bit_length()))
    return _vertex_faces(flat, n, shift, two=flat.size >= VF_HALVES_MIN and (os.cpu_count() or 1) >= 2)


@njit(cache=True, nogil=True)
def _faces_in_boxes(V, F, lo, hi):
    n = V.shape[0]
    m = F.shape[0]
    nb = lo.shape[0]
    # per vertex, 6 bits a box: below / above it on x, y, z (NaN: none set)
    code = np.zeros(n, np.uint64)
    inside = np.zeros(n, np.bool_)
    for v in range(n):
        c = np.uint64(0)
        for k in range(nb):
            for d in range(3):
                x = V[v, d]
                if x < lo[k, d]:
                    c |= np.uint64(1) << np.uint64(6 * k + d)
                elif x > hi[k, d]:
                    c |= np.uint64(1) << np.uint64(6 * k + 3 + d)
            if (c >> np.uint64(6 * k)) & np.uint64(63) == 0 and V[v, 0] == V[v, 0] and V[v, 1] == V[v, 1] \
                    and V[v, 2] == V[v, 2]:
                inside[v] = True
        code[v] = c
    # a face misses box k when its three corners share a side of it
    keep = np.zeros(m, np.bool_)
    cnt = 0
    for f in range(m):
        c = code[F[f, 0]] & code[F[f, 1]] & code[F[f, 2]]
        for k in range(nb):
            if (c >> np.uint64(6 * k)) & np.uint64(63) == 0:
                keep[f] = True
                cnt += 1
                break
    out = np.empty(cnt, np.int64)
    fmin = np.empty((cnt, 3))
    fmax = np.empty((cnt, 3))
    j = 0
    for f in range(m):
        if keep[f]:
            out[j] = f
            for d in range(3):
                x0, x1, x2 = V[F[f, 0], d], V[F[f, 1], d], V[F[f, 2], d]
                fmin[j, d] = min(x0, min(x1, x2))
                fmax[j, d] = max(x0, max(x1, x2))
            j += 1
    return out, fmin, fmax, inside


#: Boxes :func:`faces_in_boxes` takes at most (6 bits each in a 64-bit word).
MAX_BOXES = 10


def faces_in_boxes(V, F, lo, hi):
    """Faces whose bounding box meets at least one of the boxes ``[lo[k], hi[k]]``
    (closed): one pass over the vertices (which side of each box they lie
    on, in a word) and one over the faces. A face with a NaN coordinate
    counts as meeting.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    lo, hi : (b,3) float64, b <= MAX_BOXES

    Returns
    -------
    faces : (r,) int64, ascending
    fmin, fmax : (r,3) float64
        Their bounding boxes.
    inside : (n,) bool
        The vertices inside some box (finite).
    """
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    lo, hi = c(np.reshape(lo, (-1, 3))), c(np.reshape(hi, (-1, 3)))
    if len(lo) > MAX_BOXES:
        raise ValueError(f"at most {MAX_BOXES} boxes, got {len(lo)}")
    return _faces_in_boxes(c(V), np.ascontiguousarray(F, np.int64), lo, hi)


@njit(cache=True, nogil=True)
def _grow(a, size):
    if size < a.size:
        return a
    b = np.empty(2 * a.size + 16, a.dtype)
    b[:a.size] = a
    return b


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
def _ring_expand(found, f0, nf, F, vmark, marked, nm, front):
    # The new vertices of faces found[f0:nf]: marked and the next front.
    nfr = 0
    for j in range(f0, nf):
        fj = found[j]
        for c in range(3):
            w = F[fj, c]
            if not vmark[w]:
                vmark[w] = True
                marked[nm] = w
                nm += 1
                front[nfr] = w
                nfr += 1
    return nm, nfr


@njit(cache=True, nogil=True)
def _room(a, size):
    # a, or a larger copy when it holds fewer than size entries (the loops
    # that fill the buffers take them as arguments and never reassign
    # them, so they compile to plain loads and stores).
    if size <= a.size:
        return a
    b = np.empty(max(2 * a.size, size), a.dtype)
    b[:a.size] = a
    return b


@njit(cache=True, nogil=True)
def _ring_faces(verts, rings, vf_order, vf_start, F, vmark, fmark):
    faces, _ = _ring_walk(verts, rings, vf_order, vf_start, F, vmark, fmark)   # walk order ...
    faces.sort()                                                                 # ... sorted
    return faces


def ring_faces(verts, rings, vf_order, vf_start, F, vmark, fmark):
    """Faces within ``rings`` rings of ``verts``, sorted (as
    :meth:`shellrepair.context.ScanContext.ring_faces`).

    Parameters
    ----------
    verts : (k,) int64
    rings : int
        At least one ring is taken.
    vf_order, vf_start : int64 arrays
        Vertex-to-face lists (:func:`vertex_faces`).
    F : (m,3) int64
    vmark : (n,) bool, fmark : (m,) bool
        Scratch marks, all False; left all False.

    Returns
    -------
    faces : (r,) int64
    """
    return _ring_faces(np.ascontiguousarray(verts, np.int64), int(rings), vf_order, vf_start, F, vmark, fmark)


@njit(cache=True, nogil=True)
def _number_vertices(faces, F, vpos):
    # The distinct vertices of the faces ``faces``, sorted, each numbered
    # by its place among them in vpos (which holds -1 for every vertex before).
    m = faces.size
    seen = np.empty(3 * m, np.int64)
    ng = 0
    for i in range(m):
        for c in range(3):
            w = F[faces[i], c]
            if vpos[w] < 0:
                vpos[w] = 0
                seen[ng] = w
                ng += 1
    g = np.sort(seen[:ng])
    for i in range(ng):
        vpos[g[i]] = i
    return g


@njit(cache=True, nogil=True)
def _submesh(faces, F, loop, T, vpos):
    m = faces.size
    g = _number_vertices(faces, F, vpos)
    ng = g.size
    k = loop.size
    loc = np.empty(k, np.int64)
    ok = True
    for i in range(k):
        loc[i] = vpos[loop[i]]
        if loc[i] < 0:
            ok = False
    Fs = np.empty((m + T.shape[0], 3), np.int64)
    if ok:
        for i in range(m):
            for c in range(3):
                Fs[i, c] = vpos[F[faces[i], c]]
        for i in range(T.shape[0]):
            for c in range(3):
                t = T[i, c]
                Fs[m + i, c] = loc[t] if t < k else ng + t - k
    for i in range(ng):
        vpos[g[i]] = -1
    return g, Fs, loc, ok


def submesh(faces, F, loop, T, vpos):
    """The local numbering of a hole's submesh (as
    :func:`shellrepair.context.submesh`): the scan faces ``faces`` and the
    patch ``T`` over the loop's positions and new vertices.

    Parameters
    ----------
    faces : (m,) int64
        Scan faces (:func:`ring_faces`).
    F : (f,3) int64
    loop : (k,) int64
        Global loop vertices, each on one of ``faces``.
    T : (t,3) int64
        Patch triangles: index i < k is ``loop[i]``, index k + j new vertex j.
    vpos : (n,) int64
        Scratch, all -1 (one entry per scan vertex); left all -1.

    Returns
    -------
    g : (nf,) int64
        The faces' vertices, sorted (local index i is ``g[i]``).
    Fs : (m + t,3) int64
        The faces in local indices, then the patch with new vertex j at
        ``nf + j``.
    loc_loop : (k,) int64
        The loop's local indices.
    ok : bool
        False when some loop vertex is on none of ``faces`` (``Fs`` and
        ``loc_loop`` are then not set).
    """
    return _submesh(np.ascontiguousarray(faces, np.int64), np.ascontiguousarray(F, np.int64), np.ascontiguousarray(loop, np.int64),
                    np.ascontiguousarray(T, np.int64), vpos)


@njit(cache=True, nogil=True)
def _outline_label(X, Y, x, y):
    # Where (x, y) lies against the closed outline (X, Y): 0 outside, 1
    # inside, 2 at a corner (within 1e-12), 3 on a side; the crossing
    # counts of the rays to the right and to the left of the point, with
    # the coordinates taken relative to it.
    k = X.size
    right = 0
    left = 0
    xb = X[k - 1] - x
    yb = Y[k - 1] - y
    for i in range(k):
        xa = X[i] - x
        ya = Y[i] - y
        if -1e-12 < xa < 1e-12 and -1e-12 < ya < 1e-12:
            return 2
        if (ya > 0) != (yb > 0):
            if (xa * yb - xb * ya) / (yb - ya) > 0:
                right += 1
        if (ya < 0) != (yb < 0):
            if (xa * yb - xb * ya) / (yb - ya) < 0:
                left += 1
        xb = xa
        yb = ya
    if (right & 1) != (left & 1):
        return 3
    return 1 if right & 1 else 0


@njit(cache=True, nogil=True)
def _inside_outline(Q, S):
    X = Q[:, 0].copy()
    Y = Q[:, 1].copy()
    keep = np.empty(S.shape[0], np.int64)
    n = 0
    for t in range(S.shape[0]):
        a, b, c = S[t, 0], S[t, 1], S[t, 2]
        x = (Q[a, 0] + Q[b, 0] + Q[c, 0]) / 3.0
        y = (Q[a, 1] + Q[b, 1] + Q[c, 1]) / 3.0
        if _outline_label(X, Y, x, y) != 0:
            keep[n] = t
            n += 1
    out = np.empty((n, 3), np.int64)
    for i in range(n):
        for c in range(3):
            out[i, c] = S[keep[i], c]
    return out


def inside_outline(Q, S):
    """The triangles of ``S`` whose centroid is inside the outline ``Q``,
    on its sides or at its corners (as
    :func:`shellrepair.triangulate._delaunay_in_projection`'s test by
    ``skimage.measure.points_in_poly``: a crossing count, corners within
    1e-12).

    Parameters
    ----------
    Q : (k,2) float64
        The outline's corners in order (closed implicitly).
    S : (t,3) int64
        Triangles over ``Q``'s rows.

    Returns
    -------
    S_in : (r,3) int64
        The rows of ``S`` kept, in order.
    """
    return _inside_outline(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(S, np.int64))


@njit(cache=True, nogil=True)
def _loop_cover(S, n, k):
    t = S.shape[0]
    out = np.empty((t, 3), np.int64)
    mx = abs(n[0])
    for i in range(t):
        a = abs(n[i])
        if a > mx or np.isnan(a):
            if not np.isnan(mx):
                mx = a
    lim = 1e-12 * mx
    seen = np.zeros(k, np.bool_)
    ok = True
    for i in range(t):
        if abs(n[i]) <= lim:
            ok = False
        if n[i] < 0:
            out[i, 0], out[i, 1], out[i, 2] = S[i, 0], S[i, 2], S[i, 1]
        else:
            out[i, 0], out[i, 1], out[i, 2] = S[i, 0], S[i, 1], S[i, 2]
        for c in range(3):
            x = out[i, c]
            y = out[i, (c + 1) % 3]
            if x == (y + 1) % k:
                seen[y] = True
    if ok:
        for j in range(k):
            if not seen[j]:
                ok = False
                break
    return out, ok


def loop_cover(S, n, k):
    """Orient the triangles ``S`` by the signs of ``n`` and test that they
    triangulate the loop of ``k`` positions (as
    :func:`shellrepair.triangulate._delaunay_in_projection`).

    Parameters
    ----------
    S : (t,3) int64
    n : (t,) float64
        Each triangle's normal along the viewing axis (unnormalised).
    k : int

    Returns
    -------
    S_oriented : (t,3) int64
        ``S``, the rows with negative ``n`` turned (corners 0, 2, 1).
    ok : bool
        Every ``|n|`` above 1e-12 of the largest, and every loop edge
        ``(i, i+1)`` the reversed half-edge ``i+1 -> i`` of some triangle.
    """
    return _loop_cover(np.ascontiguousarray(S, np.int64), np.ascontiguousarray(n, np.float64), int(k))


@njit(cache=True, nogil=True)
def _patch_corners(V, loop, P, T):
    k = loop.size
    t = T.shape[0]
    C = np.empty((t, 3, 3))
    ids = np.empty((t, 3), np.int64)
    for i in range(t):
        for c in range(3):
            j = T[i, c]
            if j < k:
                v = loop[j]
                ids[i, c] = v
                for d in range(3):
                    C[i, c, d] = V[v, d]
            else:
                ids[i, c] = k - 1 - j
                for d in range(3):
                    C[i, c, d] = P[j - k, d]
    return C, ids


def patch_corners(V, loop, P, T):
    """A patch's triangle corners and their ids (as
    :func:`shellrepair.patch._corners`).

    Parameters
    ----------
    V : (n,3) float64
    loop : (k,) int64
    P : (q,3) float64
        The patch's new vertices.
    T : (t,3) int64
        Index i < k is ``loop[i]``, index k + j is ``P[j]``.

    Returns
    -------
    C : (t,3,3) float64
    ids : (t,3) int64
        The scan vertex, or ``-(1 + j)`` for new vertex j.
    """
    c = lambda x, d: np.ascontiguousarray(x, d)  # noqa: E731
    return _patch_corners(c(V, np.float64), c(loop, np.int64), c(P, np.float64).reshape(-1, 3), c(T, np.int64))


@njit(cache=True, nogil=True)
def _rim_sigma(V, loop, sig_sum, sig_cnt):
    k = loop.size
    out = np.empty(k)
    for i in range(k):
        if sig_cnt[i] > 0:
            out[i] = sig_sum[i] / max(sig_cnt[i], 1.0)
        else:
            a, b = loop[i], loop[(i + 1) % k]
            d0 = V[b, 0] - V[a, 0]
            d1 = V[b, 1] - V[a, 1]
            d2 = V[b, 2] - V[a, 2]
            out[i] = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    return out


def rim_sigma(V, loop, sig_sum, sig_cnt):
    """Per loop vertex, the mean length of the scan edges at it, or the
    length of its loop edge where it has none (as
    :func:`shellrepair.context._rim_sigma`).

    Parameters
    ----------
    V : (n,3) float64
    loop : (k,) int64
    sig_sum, sig_cnt : (k,) float64
        Sums and counts of the edge lengths (:func:`rim_walk`).

    Returns
    -------
    sigma : (k,) float64
    """
    c = lambda x, d: np.ascontiguousarray(x, d)  # noqa: E731
    return _rim_sigma(c(V, np.float64), c(loop, np.int64), c(sig_sum, np.float64), c(sig_cnt, np.float64))


@njit(cache=True, nogil=True)
def _faces_in_box(vkey, vorder, V, vf_order, vf_start, big, lo2, h, ny, lo, hi, fmark):
    c00 = max(np.floor((lo[0] - lo2[0]) / h), 0.0)
    c01 = max(np.floor((lo[1] - lo2[1]) / h), 0.0)
    c10 = np.floor((hi[0] - lo2[0]) / h)
    c11 = min(np.floor((hi[1] - lo2[1]) / h), ny - 1.0)
    # the vertices in the box, then their faces: arrays sized in advance (an
    # array grown inside the loops costs reference counts at every step)
    nrow = int(c10) - int(c00) + 1 if not (c10 < c00 or c11 < c01) else 0
    ra = np.empty(max(nrow, 0), np.int64)
    rb = np.empty(max(nrow, 0), np.int64)
    total = 0
    for r in range(nrow):
        row = int(c00) + r
        ra[r] = np.searchsorted(vkey, row * ny + int(c01), side="left")
        rb[r] = np.searchsorted(vkey, row * ny + int(c11), side="right")
        total += rb[r] - ra[r]
    inbox = np.empty(total, np.int64)
    nv = 0
    bound = big.size
    for r in range(nrow):
        for p in range(ra[r], rb[r]):
            v = vorder[p]
            if (lo[0] <= V[v, 0] <= hi[0] and lo[1] <= V[v, 1] <= hi[1]
                    and lo[2] <= V[v, 2] <= hi[2]):
                inbox[nv] = v
                nv += 1
                bound += vf_start[v + 1] - vf_start[v]
    found = np.empty(bound, np.int64)
    nf = _ring_collect(inbox, nv, vf_order, vf_start, fmark, found, 0)   # the box's vertices' faces
    for f in big:
        if not fmark[f]:
            fmark[f] = True
            found[nf] = f
            nf += 1
    for j in range(nf):
        fmark[found[j]] = False
    return np.sort(found[:nf])


def faces_in_box(index, lo, hi, fmark):
    """:meth:`shellrepair.intersect.NearFaces.faces_near`'s walk, compiled.

    Parameters
    ----------
    index : NearFaces
    lo, hi : (3,) float64
        The box, already grown by ``index.grow``.
    fmark : (m,) bool
        Scratch marks, all False; left all False.

    Returns
    -------
    faces : (r,) int64
        Sorted, distinct: the faces of the vertices in the box, and the big faces.
    """
    return _faces_in_box(index.vkey, index.vorder, index.V, index.vf_order, index.vf_start,
                         np.ascontiguousarray(index.big, np.int64), np.asarray(index.lo2, np.float64),
                         float(index.h), int(index.ny), np.asarray(lo, np.float64), np.asarray(hi, np.float64), fmark)


@njit(cache=True, nogil=True)
def _xy_bounds(V):
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    for v in range(V.shape[0]):
        for c in range(2):
            x = V[v, c]
            if x < lo[c]:
                lo[c] = x
            if x > hi[c]:
                hi[c] = x
    return lo, hi


@njit(cache=True, nogil=True)
def _grid_sort(V, lo, h):
    n = V.shape[0]
    ix = np.empty(n, np.int64)
    iy = np.empty(n, np.int64)
    nx = 1
    ny = 1
    for v in range(n):
        ix[v] = np.int64(np.floor((V[v, 0] - lo[0]) / h))
        iy[v] = np.int64(np.floor((V[v, 1] - lo[1]) / h))
        nx = max(nx, ix[v] + 1)
        ny = max(ny, iy[v] + 1)
    # least significant digit first: by row, then (stably) by column
    tmp = np.empty(n, np.int64)
    order = np.empty(n, np.int64)
    count = np.zeros(ny + 1, np.int64)
    for v in range(n):
        count[iy[v] + 1] += 1
    for b in range(ny):
        count[b + 1] += count[b]
    for v in range(n):
        tmp[count[iy[v]]] = v
        count[iy[v]] += 1
    count = np.zeros(nx + 1, np.int64)
    for v in range(n):
        count[ix[v] + 1] += 1
    for b in range(nx):
        count[b + 1] += count[b]
    for p in range(n):
        v = tmp[p]
        order[count[ix[v]]] = v
        count[ix[v]] += 1
    key = np.empty(n, np.int64)
    for p in range(n):
        v = order[p]
        key[p] = ix[v] * ny + iy[v]
    return order, key, ny


def grid_sort(V, h=None, grow=0.0):
    """The vertex grid of :class:`shellrepair.intersect.NearFaces`, by two
    counting sorts instead of one comparison sort.

    Parameters
    ----------
    V : (n,3) float64, n >= 1, x and y finite (else ValueError)
    grow : float
        The index's longest ordinary edge: columns are
        ``h = max(4 grow, span / 4096, 1e-300)`` wide, ``span`` the larger
        side of V's bounding box in x and y.

    Returns
    -------
    lo : (2,) float64
        Corner of the grid (V's smallest x and y).
    h : float
    order : (n,) int64
        Vertices sorted by column key (within a key, by vertex id).
    key : (n,) int64
        Their keys ``i * ny + j``, ascending.
    ny : int
    """
    V = np.asarray(V, np.float64)
    lo, hi = _xy_bounds(V)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all() and np.isfinite(V[:, :2]).all()):
        raise ValueError("grid_sort needs finite x and y")
    span = float(np.max(hi - lo))
    h = max(4 * grow, span / 4096, 1e-300)
    order, key, ny = _grid_sort(V, lo, h)
    return lo, h, order, key, int(ny)


# --------------------------------------------------------------------------
# candidate pairs for the crossing tests
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _box_pairs(Amin, Amax, Bmin, Bmax, self_pairs):
    na, nb = Amin.shape[0], Bmin.shape[0]
    ai = np.empty(0, np.int64)
    if na == 0 or nb == 0:
        return ai, ai.copy()
    lo = np.empty(3)
    hi = np.empty(3)
    ext = 0.0
    for c in range(3):
        lo[c] = Bmin[0, c]
        hi[c] = Bmax[0, c]
    for j in range(nb):
        e = 0.0
        for c in range(3):
            lo[c] = min(lo[c], Bmin[j, c])
            hi[c] = max(hi[c], Bmax[j, c])
            e = max(e, Bmax[j, c] - Bmin[j, c])
        ext += e
    # a grid over B's boxes: cells about twice B's mean extent, at most 64 a side
    h = 2.0 * ext / nb
    dims = np.ones(3, np.int64)
    cell = np.empty(3)
    for c in range(3):
        span = hi[c] - lo[c]
        k = 1
        if h > 0 and span > 0:
            k = min(64, max(1, int(span / h)))
        dims[c] = k
        cell[c] = span / k if span > 0 else 1.0
    ncell = dims[0] * dims[1] * dims[2]
    rng = np.empty((nb, 6), np.int64)
    count = np.zeros(ncell + 1, np.int64)
    for j in range(nb):
        for c in range(3):
            i0 = int((Bmin[j, c] - lo[c]) / cell[c])
            i1 = int((Bmax[j, c] - lo[c]) / cell[c])
            rng[j, c] = min(max(i0, 0), dims[c] - 1)
            rng[j, 3 + c] = min(max(i1, 0), dims[c] - 1)
        for x in range(rng[j, 0], rng[j, 3] + 1):
            for y in range(rng[j, 1], rng[j, 4] + 1):
                for z in range(rng[j, 2], rng[j, 5] + 1):
                    count[(x * dims[1] + y) * dims[2] + z + 1] += 1
    for q in range(ncell):
        count[q + 1] += count[q]
    fill = count[:-1].copy()
    items = np.empty(count[ncell], np.int64)
    for j in range(nb):
        for x in range(rng[j, 0], rng[j, 3] + 1):
            for y in range(rng[j, 1], rng[j, 4] + 1):
                for z in range(rng[j, 2], rng[j, 5] + 1):
                    q = (x * dims[1] + y) * dims[2] + z
                    items[fill[q]] = j
                    fill[q] += 1
    stamp = np.full(nb, -1, np.int64)
    out_a = np.empty(16, np.int64)
    out_b = np.empty(16, np.int64)
    npair = 0
    r = np.empty(6, np.int64)
    buf = np.empty(nb, np.int64)   # one query's pairs: the outputs grow once a query, not inside its loops
    for i in range(na):
        skip = False
        for c in range(3):
            if Amax[i, c] < lo[c] or Amin[i, c] > hi[c]:
                skip = True
        if skip:
            continue
        for c in range(3):
            r[c] = min(max(int((Amin[i, c] - lo[c]) / cell[c]), 0), dims[c] - 1)
            r[3 + c] = min(max(int((Amax[i, c] - lo[c]) / cell[c]), 0), dims[c] - 1)
        m = 0
        for x in range(r[0], r[3] + 1):
            for y in range(r[1], r[4] + 1):
                for z in range(r[2], r[5] + 1):
                    q = (x * dims[1] + y) * dims[2] + z
                    for p in range(count[q], count[q + 1]):
                        j = items[p]
                        if stamp[j] == i or (self_pairs and j <= i):
                            continue
                        stamp[j] = i
                        if (Amin[i, 0] <= Bmax[j, 0] and Bmin[j, 0] <= Amax[i, 0]
                                and Amin[i, 1] <= Bmax[j, 1] and Bmin[j, 1] <= Amax[i, 1]
                                and Amin[i, 2] <= Bmax[j, 2] and Bmin[j, 2] <= Amax[i, 2]):
                            buf[m] = j
                            m += 1
        while out_a.size < npair + m:
            out_a = _grow(out_a, out_a.size)
            out_b = _grow(out_b, out_b.size)
        for t in range(m):
            out_a[npair + t] = i
            out_b[npair + t] = buf[t]
        npair += m
    return out_a[:npair], out_b[:npair]


def box_pairs(Amin, Amax, Bmin=None, Bmax=None):
    """Pairs (i, j) of boxes of A and of B that overlap (closed, on every axis).

    Parameters
    ----------
    Amin, Amax : (a,3) float64
        Box corners, finite.
    Bmin, Bmax : (b,3) float64, optional
        Without them, pairs within A with ``i < j``.

    Returns
    -------
    ai, bj : (p,) int64
        Sorted by ``i``, then in an order fixed by the input.

    Notes
    -----
    B's boxes are bucketed in a uniform grid (cells about twice their mean
    extent, at most 64 a side); each A box is tested against the boxes in
    the cells it covers. Every overlapping pair is reported once; the
    crossing tests then decide exactly, so this set replaces any other
    superset of the crossing pairs (bounding spheres, say) without
    changing a result.
    """
    self_pairs = Bmin is None
    if self_pairs:
        Bmin, Bmax = Amin, Amax
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    return _box_pairs(c(Amin), c(Amax), c(Bmin), c(Bmax), self_pairs)


@njit(cache=True, nogil=True)
def _strict_side(T, P, side_bound, tiny):
    """+1 / -1 when all three points P are certainly on one side of T's
    plane (intersect._plane_signs' error bound), else 0."""
    e1x, e1y, e1z = T[1, 0] - T[0, 0], T[1, 1] - T[0, 1], T[1, 2] - T[0, 2]
    e2x, e2y, e2z = T[2, 0] - T[0, 0], T[2, 1] - T[0, 1], T[2, 2] - T[0, 2]
    n0, n1, n2 = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    m0 = abs(e1y * e2z) + abs(e1z * e2y)
    m1 = abs(e1z * e2x) + abs(e1x * e2z)
    m2 = abs(e1x * e2y) + abs(e1y * e2x)
    side = 0
    for i in range(3):
        w0, w1, w2 = P[i, 0] - T[0, 0], P[i, 1] - T[0, 1], P[i, 2] - T[0, 2]
        det = n0 * w0 + n1 * w1 + n2 * w2
        perm = m0 * abs(w0) + m1 * abs(w1) + m2 * abs(w2)
        if not (abs(det) > side_bound * perm and perm >= tiny and np.isfinite(perm)):
            return 0
        s = 1 if det > 0 else -1
        if i == 0:
            side = s
        elif s != side:
            return 0
    return side


@njit(cache=True, nogil=True)
def _separated(A, Aid, ai, B, Bid, bj, side_bound, tiny):
    out = np.zeros(ai.size, np.bool_)
    for q in range(ai.size):
        i, j = ai[q], bj[q]
        common = False
        for x in range(3):
            for y in range(3):
                if Aid[i, x] == Bid[j, y]:
                    common = True
        if common:
            continue
        if _strict_side(A[i], B[j], side_bound, tiny) != 0 or _strict_side(B[j], A[i], side_bound, tiny) != 0:
            out[q] = True
    return out


def separated(A, Aid, ai, B, Bid, bj, side_bound, tiny):
    """Pairs (A[ai], B[bj]) that certainly cannot cross: one triangle's
    corners all strictly on one side of the other's plane, as the
    error-bounded plane test of :func:`shellrepair.intersect._plane_signs`
    certifies it (pairs sharing a vertex id are never claimed). The crossing
    test answers False for every such pair, so it need not see them.

    Parameters
    ----------
    A, B : (a,3,3), (b,3,3) float64
    Aid, Bid : (a,3), (b,3) int64
    ai, bj : (p,) int64
    side_bound, tiny : float
        The filter's error factor and smallest trusted permanent.

    Returns
    -------
    sep : (p,) bool
    """
    c = np.ascontiguousarray
    return _separated(c(A, np.float64), c(Aid, np.int64), c(ai, np.int64), c(B, np.float64), c(Bid, np.int64),
                      c(bj, np.int64), float(side_bound), float(tiny))


#: :func:`cross_status` codes: the pair does not cross, crosses, or was not
#: decided by the float filters (the caller's exact NumPy test decides).
APART, CROSS, UNDECIDED = 0, 1, 2


@njit(cache=True, nogil=True)
def _o3d(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, o3d_bound, tiny):
    """:func:`shellrepair.predicates.orient3d` of one row where its float
    filter (or its exact-zero shortcuts) decides, else 2: the same
    products, sums and bound."""
    adx, bdx, cdx = ax - dx, bx - dx, cx - dx
    ady, bdy, cdy = ay - dy, by - dy, cy - dy
    adz, bdz, cdz = az - dz, bz - dz, cz - dz
    bdxcdy, cdxbdy = bdx * cdy, cdx * bdy
    cdxady, adxcdy = cdx * ady, adx * cdy
    adxbdy, bdxady = adx * bdy, bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    perm = (abs(adz) * (abs(bdxcdy) + abs(cdxbdy))
            + abs(bdz) * (abs(cdxady) + abs(adxcdy))
            + abs(cdz) * (abs(adxbdy) + abs(bdxady)))
    if abs(det) > o3d_bound * perm and perm >= tiny and np.isfinite(perm):
        return 1 if det > 0 else -1
    # exactly zero without arithmetic: two equal points, or the four in one axis-aligned plane
    if ((ax == bx and ay == by and az == bz) or (ax == cx and ay == cy and az == cz)
            or (ax == dx and ay == dy and az == dz) or (bx == cx and by == cy and bz == cz)
            or (bx == dx and by == dy and bz == dz) or (cx == dx and cy == dy and cz == dz)
            or (ax == bx and ax == cx and ax == dx) or (ay == by and ay == cy and ay == dy)
            or (az == bz and az == cz and az == dz)):
        return 0
    return 2


@njit(cache=True, nogil=True)
def _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2, px, py, pz,
          side_bound, o3d_bound, tiny):
    """The side of p of the plane through t0, t1, t2 (normal n, its
    permanent factors m): intersect._plane_signs of one point, 2 where the
    filters cannot decide."""
    w0, w1, w2 = px - t0x, py - t0y, pz - t0z
    det = n0 * w0 + n1 * w1 + n2 * w2
    perm = m0 * abs(w0) + m1 * abs(w1) + m2 * abs(w2)
    if abs(det) > side_bound * perm and perm >= tiny and np.isfinite(perm):
        return -1 if det > 0 else 1
    return _o3d(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, px, py, pz, o3d_bound, tiny)


@njit(cache=True, nogil=True)
def _side_signs(TT, t, PP, p, known, side_bound, o3d_bound, tiny):
    """:func:`shellrepair.intersect._plane_signs` of one pair: the sides of
    the corners of ``PP[p]`` of the plane of ``TT[t]`` (2 where the filters
    cannot decide; 0 for corners whose bit is set in ``known``)."""
    t0x, t0y, t0z = TT[t, 0, 0], TT[t, 0, 1], TT[t, 0, 2]
    t1x, t1y, t1z = TT[t, 1, 0], TT[t, 1, 1], TT[t, 1, 2]
    t2x, t2y, t2z = TT[t, 2, 0], TT[t, 2, 1], TT[t, 2, 2]
    e1x, e1y, e1z = t1x - t0x, t1y - t0y, t1z - t0z
    e2x, e2y, e2z = t2x - t0x, t2y - t0y, t2z - t0z
    n0, n1, n2 = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    m0 = abs(e1y * e2z) + abs(e1z * e2y)
    m1 = abs(e1z * e2x) + abs(e1x * e2z)
    m2 = abs(e1x * e2y) + abs(e1y * e2x)
    s0 = s1 = s2 = 0
    if not known & 1:
        s0 = _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2,
                   PP[p, 0, 0], PP[p, 0, 1], PP[p, 0, 2], side_bound, o3d_bound, tiny)
    if not known & 2:
        s1 = _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2,
                   PP[p, 1, 0], PP[p, 1, 1], PP[p, 1, 2], side_bound, o3d_bound, tiny)
    if not known & 4:
        s2 = _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2,
                   PP[p, 2, 0], PP[p, 2, 1], PP[p, 2, 2], side_bound, o3d_bound, tiny)
    return s0, s1, s2


@njit(cache=True, nogil=True)
def _alone_corner(s0, s1, s2):
    """intersect._alone of one sign row: the corner alone on its side (the
    first positive one when one is positive, else the first negative one)."""
    if (s0 > 0) + (s1 > 0) + (s2 > 0) == 1:
        return 0 if s0 > 0 else 1 if s1 > 0 else 2
    return 0 if s0 < 0 else 1 if s1 < 0 else 2


@njit(cache=True, nogil=True)
def _cross_one(A, Aid, i, B, Bid, j, side_bound, o3d_bound, tiny):
    """One pair of :func:`_cross_status`, ``A[i]`` and ``B[j]``."""
    ka = 0       # bit x: corner x of A is a corner of B (the same id)
    kb = 0
    for x in range(3):
        for y in range(3):
            if Aid[i, x] == Bid[j, y]:
                ka |= 1 << x
                kb |= 1 << y
    b0, b1, b2 = _side_signs(A, i, B, j, kb, side_bound, o3d_bound, tiny)
    if b0 == 2 or b1 == 2 or b2 == 2:
        return UNDECIDED
    if b0 == 0 and b1 == 0 and b2 == 0:
        return UNDECIDED                           # in one plane: the NumPy test
    if not ((b0 > 0 or b1 > 0 or b2 > 0) and (b0 < 0 or b1 < 0 or b2 < 0)):
        return APART
    a0, a1, a2 = _side_signs(B, j, A, i, ka, side_bound, o3d_bound, tiny)
    if a0 == 2 or a1 == 2 or a2 == 2:
        return UNDECIDED
    if a0 == 0 and a1 == 0 and a2 == 0:
        return UNDECIDED
    if not ((a0 > 0 or a1 > 0 or a2 > 0) and (a0 < 0 or a1 < 0 or a2 < 0)):
        return APART
    # both straddle: intersect._straddling_cross (Guigue-Devillers)
    ra, rb = _alone_corner(a0, a1, a2), _alone_corner(b0, b1, b2)
    pa, qa, xa = ra, (ra + 1) % 3, (ra + 2) % 3
    pb, qb, xb = rb, (rb + 1) % 3, (rb + 2) % 3
    if (a0, a1, a2)[ra] < 0:
        qb, xb = xb, qb
    if (b0, b1, b2)[rb] < 0:
        qa, xa = xa, qa
    s1 = _o3d(A[i, pa, 0], A[i, pa, 1], A[i, pa, 2], A[i, qa, 0], A[i, qa, 1], A[i, qa, 2],
              B[j, pb, 0], B[j, pb, 1], B[j, pb, 2], B[j, qb, 0], B[j, qb, 1], B[j, qb, 2], o3d_bound, tiny)
    if s1 != 2 and s1 >= 0:
        return APART
    s2 = _o3d(A[i, pa, 0], A[i, pa, 1], A[i, pa, 2], A[i, xa, 0], A[i, xa, 1], A[i, xa, 2],
              B[j, xb, 0], B[j, xb, 1], B[j, xb, 2], B[j, pb, 0], B[j, pb, 1], B[j, pb, 2], o3d_bound, tiny)
    if s2 != 2 and s2 >= 0:
        return APART
    if s1 == 2 or s2 == 2:
        return UNDECIDED
    return CROSS


@njit(cache=True, nogil=True)
def _cross_status(A, Aid, ai, B, Bid, bj, side_bound, o3d_bound, tiny):
    out = np.empty(ai.size, np.int8)
    for q in range(ai.size):
        out[q] = _cross_one(A, Aid, ai[q], B, Bid, bj[q], side_bound, o3d_bound, tiny)
    return out


def cross_status(A, Aid, ai, B, Bid, bj, side_bound, o3d_bound, tiny):
    """Do the triangle pairs (A[ai], B[bj]) cross? The tests of
    :func:`shellrepair.intersect.triangles_cross` (ids equal: corners known
    to be shared) for the pairs its float filters decide: the plane sides,
    then, for pairs that straddle each other's plane, the two orient3d
    signs of the segment overlap, each by the filter and the exact-zero
    shortcuts of :func:`shellrepair.predicates.orient3d`. Every decided
    answer is the exact one; pairs that need exact arithmetic or lie in
    one plane (or have a zero-area triangle) are left ``UNDECIDED`` for
    the NumPy test.

    Parameters
    ----------
    A, B : (a,3,3), (b,3,3) float64
    Aid, Bid : (a,3), (b,3) int64
    ai, bj : (p,) int64
    side_bound, o3d_bound, tiny : float
        The plane filter's and orient3d's error factors, the smallest trusted permanent.

    Returns
    -------
    status : (p,) int8
        ``APART``, ``CROSS`` or ``UNDECIDED`` per pair.
    """
    c = np.ascontiguousarray
    return _cross_status(c(A, np.float64), c(Aid, np.int64), c(ai, np.int64), c(B, np.float64),
                         c(Bid, np.int64), c(bj, np.int64), float(side_bound), float(o3d_bound), float(tiny))


@njit(cache=True, nogil=True)
def _min3(a, b, c):
    """np.min of three values (NaN propagates)."""
    m = a
    if b < m or b != b:
        m = b
    if m == m and (c < m or c != c):
        m = c
    return m


@njit(cache=True, nogil=True)
def _max3(a, b, c):
    """np.max of three values (NaN propagates)."""
    m = a
    if b > m or b != b:
        m = b
    if m == m and (c > m or c != c):
        m = c
    return m


@njit(cache=True, nogil=True)
def _boxes(T):
    lo = np.empty((T.shape[0], 3))
    hi = np.empty((T.shape[0], 3))
    for t in range(T.shape[0]):
        for c in range(3):
            lo[t, c] = _min3(T[t, 0, c], T[t, 1, c], T[t, 2, c])
            hi[t, c] = _max3(T[t, 0, c], T[t, 1, c], T[t, 2, c])
    return lo, hi


#: Patch triangles × faces up to which :func:`patch_pairs` compares all
#: boxes (above: :func:`box_pairs`' grid); the same pairs either way.
PAIRS_BRUTE = 8192


@njit(cache=True, nogil=True)
def _patch_pairs(Q, Qid, f, V, F, origin, side_bound, o3d_bound, tiny):
    nf = f.size
    T = np.empty((nf, 3, 3))
    Tid = np.empty((nf, 3), np.int64)
    for j in range(nf):
        for k in range(3):
            v = F[f[j], k]
            Tid[j, k] = v
            for c in range(3):
                T[j, k, c] = V[v, c] - origin[c]
    qlo, qhi = _boxes(Q)
    tlo, thi = _boxes(T)
    if Q.shape[0] * nf <= PAIRS_BRUTE:
        ai = np.empty(Q.shape[0] * nf, np.int64)     # (no growing in the loop: that costs
        bj = np.empty(Q.shape[0] * nf, np.int64)     # reference counts at every step)
        n = 0
        for i in range(Q.shape[0]):
            for j in range(nf):
                if (qlo[i, 0] <= thi[j, 0] and tlo[j, 0] <= qhi[i, 0] and qlo[i, 1] <= thi[j, 1]
                        and tlo[j, 1] <= qhi[i, 1] and qlo[i, 2] <= thi[j, 2] and tlo[j, 2] <= qhi[i, 2]):
                    ai[n] = i
                    bj[n] = j
                    n += 1
        ai, bj = ai[:n], bj[:n]
    else:
        ai, bj = _box_pairs(qlo, qhi, tlo, thi, False)
    st = _cross_status(Q, Qid, ai, T, Tid, bj, side_bound, o3d_bound, tiny)
    return ai, bj, st


def patch_pairs(Q, Qid, f, V, F, origin, side_bound, o3d_bound, tiny):
    """:func:`cross_status` of a patch against some faces of a mesh, their
    candidate pairs found here: the faces' corners minus ``origin``, both
    sides' boxes, the overlapping pairs (:func:`box_pairs`), then the
    tests (:func:`shellrepair.intersect.patch_vs_index`'s steps in one call).

    Parameters
    ----------
    Q : (t,3,3) float64
        Patch triangle corners minus ``origin``, finite.
    Qid : (t,3) int64
        Their corner ids in the mesh's numbering (new vertices: ids no face uses).
    f : (r,) int64
        The faces to test.
    V : (n,3) float64
    F : (m,3) int64
    origin : (3,) float64
    side_bound, o3d_bound, tiny : float
        As for :func:`cross_status`.

    Returns
    -------
    ai, bj : (p,) int64
        The pairs (patch triangle, index into ``f``) whose boxes overlap, sorted by ``ai``.
    status : (p,) int8
    """
    c = np.ascontiguousarray
    return _patch_pairs(c(Q, np.float64), c(Qid, np.int64), c(f, np.int64), c(V, np.float64), c(F, np.int64),
                        c(origin, np.float64), float(side_bound), float(o3d_bound), float(tiny))


@njit(cache=True, nogil=True)
def _projection_embeds(Q, T, k, sgn, area_tol):
    t = T.shape[0]
    areas = np.empty(t)
    amax = 0.0
    for r in range(t):
        a, b, c = T[r, 0], T[r, 1], T[r, 2]
        e1x, e1y = Q[b, 0] - Q[a, 0], Q[b, 1] - Q[a, 1]
        e2x, e2y = Q[c, 0] - Q[a, 0], Q[c, 1] - Q[a, 1]
        ar = -(0.5 * (e1x * e2y - e1y * e2x) * sgn)
        if ar != ar:
            return False                  # NaN: NumPy's max and comparisons fail too
        areas[r] = ar
        amax = max(amax, abs(ar))
    for r in range(t):
        if not areas[r] > area_tol * amax:
            return False
    lo0 = hi0 = Q[0, 0]
    lo1 = hi1 = Q[0, 1]
    for i in range(1, k):
        lo0, hi0 = min(lo0, Q[i, 0]), max(hi0, Q[i, 0])
        lo1, hi1 = min(lo1, Q[i, 1]), max(hi1, Q[i, 1])
    span = max(hi0 - lo0, hi1 - lo1)
    if span == 0.0:
        span = 1.0
    return _outline_simple(Q[:k], 1e-12 * span * span)


def projection_embeds(Q, T, k, sgn, area_tol):
    """The tail of :func:`shellrepair.intersect.embeds_by_projection` in one
    call: every projected patch triangle turns against the loop with an
    area above ``area_tol`` times the largest, and the loop's outline (the
    first ``k`` rows of ``Q``) is simple (:func:`outline_simple`, with
    :func:`shellrepair.intersect._outline_is_simple`'s tolerance); the same
    products, comparisons and tolerance, so the same answer.

    Parameters
    ----------
    Q : (n,2) float64
        Projected patch vertices, loop first, finite.
    T : (t,3) int64
        Patch triangles, t >= 1.
    k : int
        Loop length, >= 3.
    sgn : float
        Sign of the loop's projected area (+1.0 or -1.0).
    area_tol : float

    Returns
    -------
    ok : bool
    """
    return bool(_projection_embeds(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(T, np.int64),
                                   int(k), float(sgn), float(area_tol)))


# --------------------------------------------------------------------------
# intrinsic Delaunay flips
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _cot_area(L, cot, A):
    """:func:`shellrepair.intrinsic._cotangents` into ``cot``, ``A``."""
    for f in range(L.shape[0]):
        x, y, z = L[f, 0], L[f, 1], L[f, 2]
        # sides sorted a >= b >= c (the values, as np.sort gives them)
        if x < y:
            x, y = y, x
        if y < z:
            y, z = z, y
        if x < y:
            x, y = y, x
        a, b, c = x, y, z
        q = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c))
        area = 0.25 * np.sqrt(max(q, 0.0))
        A[f] = area
        den = 4.0 * max(area, 1e-300)
        for i in range(3):
            lb = L[f, (i + 1) % 3]
            lc = L[f, (i + 2) % 3]
            li = L[f, i]
            cot[f, i] = (lb * lb + lc * lc - li * li) / den


@njit(cache=True, nogil=True)
def _manifold_twins(T, n, twin, start, slot):
    """Twin half-edges of the edges with exactly two half-edges, else −1
    (:func:`shellrepair.intrinsic._twins`): half-edges bucketed by their
    smaller vertex (a counting sort), then paired inside each bucket."""
    m3 = 3 * T.shape[0]
    start[:] = 0
    for f in range(T.shape[0]):
        for i in range(3):
            start[min(T[f, i], T[f, (i + 1) % 3]) + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    hi = np.empty(m3, np.int64)         # bucketed: the larger vertex of each half-edge
    for f in range(T.shape[0]):
        for i in range(3):
            a, b = T[f, i], T[f, (i + 1) % 3]
            v = min(a, b)
            slot[fill[v]] = 3 * f + i
            hi[fill[v]] = max(a, b)
            fill[v] += 1
    twin[:m3] = -1
    for v in range(n):
        s, e = start[v], start[v + 1]
        for p in range(s, e):
            w = hi[p]
            other = -1
            count = 0
            for q in range(s, e):
                if hi[q] == w:
                    count += 1
                    if q != p:
                        other = slot[q]
            if count == 2:
                twin[slot[p]] = other


@njit(cache=True, nogil=True)
def _flips(T, L, n, max_rounds, flip_tol):
    t = T.shape[0]
    twin = np.empty(3 * t, np.int64)
    start = np.empty(n + 1, np.int64)
    slot = np.empty(3 * t, np.int64)
    cot = np.empty((t, 3))
    A = np.empty(t)
    best = np.empty(t)
    taken = np.zeros(t, np.bool_)
    seen = np.zeros(t, np.bool_)
    second = np.zeros(t, np.bool_)
    cand = np.empty(3 * t, np.int64)
    exc = np.empty(3 * t)
    for _ in range(max_rounds):
        _manifold_twins(T, n, twin, start, slot)
        _cot_area(L, cot, A)
        # bad edges, each once (its smaller half-edge), in half-edge order
        nb = 0
        for h in range(3 * t):
            h2 = twin[h]
            if h2 <= h:
                continue
            f1, i1 = h // 3, h % 3
            f2, i2 = h2 // 3, h2 % 3
            s = cot[f1, i1] + cot[f2, i2]
            c, d = T[f1, (i1 + 2) % 3], T[f2, (i2 + 2) % 3]
            if s < -flip_tol and c != d and np.isfinite(s):
                cand[nb] = h
                exc[nb] = -s
                nb += 1
        if nb == 0:
            return True, cot, A
        # refine._independent_flips: each the worst edge of both its faces;
        # of ties the first keeps a face
        for j in range(nb):
            h = cand[j]
            best[h // 3] = -np.inf
            best[twin[h] // 3] = -np.inf
        for j in range(nb):
            h = cand[j]
            g1, g2 = h // 3, twin[h] // 3
            if exc[j] > best[g1]:
                best[g1] = exc[j]
            if exc[j] > best[g2]:
                best[g2] = exc[j]
        keep = np.zeros(nb, np.bool_)
        for j in range(nb):
            h = cand[j]
            g1, g2 = h // 3, twin[h] // 3
            if best[g1] == exc[j] and best[g2] == exc[j] and not seen[g1]:
                seen[g1] = True
                keep[j] = True
        for j in range(nb):
            if keep[j]:
                taken[cand[j] // 3] = True
        for j in range(nb):
            if keep[j]:
                g1, g2 = cand[j] // 3, twin[cand[j]] // 3
                if taken[g2] and g2 != g1:
                    keep[j] = False
        for j in range(nb):        # a second face kept by the first only
            if keep[j]:
                g2 = twin[cand[j]] // 3
                if second[g2]:
                    keep[j] = False
                else:
                    second[g2] = True
        k = 0
        for j in range(nb):
            h = cand[j]
            seen[h // 3] = False
            taken[h // 3] = False
            second[twin[h] // 3] = False
            if keep[j]:
                cand[k] = h
                k += 1
        # every new row from the old triangulation first, then the writes
        # (f1 rows, then f2 rows), as the vectorised assignment does
        rows = np.empty((k, 4, 3), np.int64)
        lens = np.empty((k, 2, 3))
        for j in range(k):
            h = cand[j]
            h2 = twin[h]
            F1, I1, F2, I2 = h // 3, h % 3, h2 // 3, h2 % 3
            a, b = T[F1, I1], T[F1, (I1 + 1) % 3]
            C, D = T[F1, (I1 + 2) % 3], T[F2, (I2 + 2) % 3]
            lab, lbc, lca = L[F1, I1], L[F1, (I1 + 1) % 3], L[F1, (I1 + 2) % 3]
            lad, ldb = L[F2, (I2 + 1) % 3], L[F2, (I2 + 2) % 3]
            # lay (a, b, c) and (b, a, d) flat: a at the origin, b on +x
            cx = (lab * lab + lca * lca - lbc * lbc) / (2.0 * lab)
            cy = np.sqrt(max(lca * lca - cx * cx, 0.0))
            dx = (lab * lab + lad * lad - ldb * ldb) / (2.0 * lab)
            dy = -np.sqrt(max(lad * lad - dx * dx, 0.0))
            lcd = np.hypot(cx - dx, cy - dy)
            rows[j, 0, 0], rows[j, 0, 1], rows[j, 0, 2] = C, a, D
            rows[j, 1, 0], rows[j, 1, 1], rows[j, 1, 2] = D, b, C
            rows[j, 2, 0], rows[j, 2, 1] = F1, F2
            lens[j, 0, 0], lens[j, 0, 1], lens[j, 0, 2] = lca, lad, lcd
            lens[j, 1, 0], lens[j, 1, 1], lens[j, 1, 2] = ldb, lbc, lcd
        for j in range(k):
            F1 = rows[j, 2, 0]
            for i in range(3):
                T[F1, i] = rows[j, 0, i]
                L[F1, i] = lens[j, 0, i]
        for j in range(k):
            F2 = rows[j, 2, 1]
            for i in range(3):
                T[F2, i] = rows[j, 1, i]
                L[F2, i] = lens[j, 1, i]
    return False, cot, A


def intrinsic_flips(T, L, n, max_rounds, flip_tol):
    """Intrinsic Delaunay flips in rounds (as :func:`shellrepair.intrinsic._flip_to_delaunay`).

    Parameters
    ----------
    T : (m,3) int64
        Triangles; flipped in place.
    L : (m,3) float64
        ``L[f,i]``: length of side ``T[f,i] -> T[f,(i+1)%3]``; updated in place.
    n : int
        Vertex count.
    max_rounds : int
    flip_tol : float
        An edge flips when its opposite cotangents sum below ``-flip_tol``.

    Returns
    -------
    settled : bool
    cot : (m,3) float64, A : (m,) float64
        Cotangents and areas of the final triangulation (meaningful when settled).
    """
    return _flips(T, L, int(n), int(max_rounds), float(flip_tol))


# --------------------------------------------------------------------------
# a loop's rim data
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _rim_edges(k, ia_all, ib_all, ln, nrm):
    sig_sum = np.zeros(k)
    sig_cnt = np.zeros(k)
    edge_normals = np.zeros((k, 3))
    forb = np.empty((ia_all.size, 2), np.int64)
    nf = 0
    m = nrm.shape[0]
    for r in range(ia_all.size):
        ia, ib = ia_all[r], ib_all[r]
        L = ln[r]
        if ia >= 0:
            sig_sum[ia] += L
            sig_cnt[ia] += 1
        if ib >= 0:
            sig_sum[ib] += L
            sig_cnt[ib] += 1
        if ia >= 0 and ib >= 0:
            if ib == (ia + 1) % k:
                for j in range(3):
                    edge_normals[ia, j] = nrm[r % m, j]
            elif ia != (ib + 1) % k:
                forb[nf, 0] = min(ia, ib)
                forb[nf, 1] = max(ia, ib)
                nf += 1
    return sig_sum, sig_cnt, edge_normals, forb[:nf]


def rim_edges(loop, E, ln, nrm):
    """The edge walk of :func:`shellrepair.context.rim_data`.

    Parameters
    ----------
    loop : (k,) int64
        Loop vertices (a vertex listed twice counts at its last position).
    E : (3m,2) int64
        The sides of the m faces around the loop: ``T[:, [0,1]]``, then
        ``[1,2]``, then ``[2,0]``.
    ln : (3m,) float64
        Side lengths.
    nrm : (m,3) float64
        Unit face normals.

    Returns
    -------
    sig_sum, sig_cnt : (k,) float64
        Sum and count of scan edge lengths at each loop vertex.
    edge_normals : (k,3) float64
        Normal of the scan face across loop edge i (the last seen).
    forbidden : (f,2) int64
        Loop-position pairs the scan joins by an edge other than a loop
        edge, as (smaller, larger), with repeats.
    """
    loop = np.asarray(loop, np.int64)
    k = loop.size
    # loop position of each side's ends (-1: not on the loop); the last of repeats
    order = np.argsort(loop, kind="stable")
    sl = loop[order]
    p = np.searchsorted(sl, E, side="right") - 1
    pc = np.maximum(p, 0)
    where = np.where((p >= 0) & (sl[pc] == E), order[pc], -1)
    return _rim_edges(k, np.ascontiguousarray(where[:, 0]), np.ascontiguousarray(where[:, 1]),
                      np.ascontiguousarray(ln, np.float64), np.ascontiguousarray(nrm, np.float64))


# --------------------------------------------------------------------------
# Delaunay relaxation of a patch (refine._relax): the bookkeeping compiled,
# the angles left to NumPy (its arctan2 is not libm's to the last bit)
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _relax_gather(T, twin, active, n):
    m = active.size
    h1 = active.copy()
    h2 = np.empty(m, np.int64)
    kab = np.empty(m, np.int64)
    for j in range(m):
        h = h1[j]
        h2[j] = twin[h]
        a, b = T[h // 3, h % 3], T[h // 3, (h % 3 + 1) % 3]
        kab[j] = min(a, b) * n + max(a, b)
    srt = np.argsort(kab, kind="mergesort")       # stable: edge-key order, as a full pass lists them
    out = np.empty((m, 8), np.int64)              # h1, h2, a, b, c, d, f1, f2
    for j in range(m):
        h, g = h1[srt[j]], h2[srt[j]]
        f1, i1, f2, i2 = h // 3, h % 3, g // 3, g % 3
        out[j, 0], out[j, 1] = h, g
        out[j, 2], out[j, 3], out[j, 4] = T[f1, i1], T[f1, (i1 + 1) % 3], T[f1, (i1 + 2) % 3]
        out[j, 5] = T[f2, (i2 + 2) % 3]
        out[j, 6], out[j, 7] = f1, f2
    return out


@njit(cache=True, nogil=True)
def _in_sorted(keys, x):
    if keys.size == 0:
        return False
    p = min(np.searchsorted(keys, x), keys.size - 1)
    return keys[p] == x


@njit(cache=True, nogil=True)
def _relax_apply(T, twin, changed, is_loop, forb, edge_keys, ck_keys, ck_vals, g, excess, unfolded, flip_eps, n):
    """One round of refine._relax after its angles: returns (status, active);
    status 0: flipped, go on; 1: settled; 2: faces shared by two flips of
    the round (a tie NumPy's vectorised writes resolve by order: the caller
    redoes the whole relaxation in NumPy). ``ck_keys`` (sorted) and
    ``ck_vals``: edges flips made (True) or removed (False); returned
    updated."""
    m = g.shape[0]
    nt = T.shape[0]
    none = np.empty(0, np.int64)
    geo = np.empty(m, np.int64)
    ng = 0
    for j in range(m):
        if excess[j] > flip_eps and g[j, 4] != g[j, 5]:
            geo[ng] = j
            ng += 1
    if ng == 0:
        return 1, none, ck_keys, ck_vals
    cand = np.empty(ng, np.int64)
    ncd = np.zeros(m, np.int64)
    nc = 0
    for q in range(ng):
        j = geo[q]
        c, d = g[j, 4], g[j, 5]
        key = min(c, d) * n + max(c, d)
        exists = _in_sorted(edge_keys, key)
        if ck_keys.size:
            p = min(np.searchsorted(ck_keys, key), ck_keys.size - 1)
            if ck_keys[p] == key:
                exists = ck_vals[p]
        ok = not exists
        if forb.size and is_loop[c] and is_loop[d] and _in_sorted(forb, key):
            ok = False
        if ok and unfolded[j]:
            cand[nc] = j
            ncd[j] = key
            nc += 1
    if nc == 0:
        return 1, none, ck_keys, ck_vals
    # refine._independent_flips
    best = np.empty(nt)
    for q in range(nc):
        j = cand[q]
        best[g[j, 6]] = -np.inf
        best[g[j, 7]] = -np.inf
    for q in range(nc):
        j = cand[q]
        best[g[j, 6]] = max(best[g[j, 6]], excess[j])
        best[g[j, 7]] = max(best[g[j, 7]], excess[j])
    seen = np.zeros(nt, np.bool_)
    taken = np.zeros(nt, np.bool_)
    keep = np.zeros(nc, np.bool_)
    for q in range(nc):
        j = cand[q]
        g1, g2 = g[j, 6], g[j, 7]
        if best[g1] == excess[j] and best[g2] == excess[j] and not seen[g1]:
            seen[g1] = True
            keep[q] = True
            taken[g1] = True
    kept = np.empty(nc, np.int64)
    nk = 0
    for q in range(nc):
        j = cand[q]
        if keep[q] and (not taken[g[j, 7]] or g[j, 7] == g[j, 6]):
            kept[nk] = j
            nk += 1
    if nk == 0:
        return 1, none, ck_keys, ck_vals
    # of flips making the same new edge the first; in new-edge order
    keys = np.empty(nk, np.int64)
    for q in range(nk):
        keys[q] = ncd[kept[q]]
    by = np.argsort(keys, kind="mergesort")
    flips = np.empty(nk, np.int64)
    nf = 0
    for q in range(nk):
        if q == 0 or keys[by[q]] != keys[by[q - 1]]:
            flips[nf] = kept[by[q]]
            nf += 1
    flips = flips[:nf]
    if nf == 0:
        return 1, none, ck_keys, ck_vals
    used = np.zeros(nt, np.bool_)
    for q in range(nf):
        j = flips[q]
        for f in (g[j, 6], g[j, 7]):
            if used[f]:
                return 2, none, ck_keys, ck_vals
            used[f] = True
    # flip: f1 = (a,b,c) -> (c,a,d), f2 = (b,a,d) -> (d,b,c); outer half-edges move slots
    slot_new = np.full(3 * nt, -1, np.int64)
    old = np.empty((4, nf), np.int64)
    new = np.empty((4, nf), np.int64)
    for q in range(nf):
        j = flips[q]
        h1, h2 = g[j, 0], g[j, 1]
        F1, I1, F2, I2 = h1 // 3, h1 % 3, h2 // 3, h2 % 3
        old[0, q], old[1, q] = 3 * F1 + (I1 + 2) % 3, 3 * F2 + (I2 + 1) % 3
        old[2, q], old[3, q] = 3 * F2 + (I2 + 2) % 3, 3 * F1 + (I1 + 1) % 3
        new[0, q], new[1, q], new[2, q], new[3, q] = 3 * F1, 3 * F1 + 1, 3 * F2, 3 * F2 + 1
    outer = np.empty((4, nf), np.int64)
    for r in range(4):
        for q in range(nf):
            outer[r, q] = twin[old[r, q]]
            slot_new[old[r, q]] = new[r, q]
    for q in range(nf):
        j = flips[q]
        F1, F2 = g[j, 6], g[j, 7]
        A, B, C, D = g[j, 2], g[j, 3], g[j, 4], g[j, 5]
        T[F1, 0], T[F1, 1], T[F1, 2] = C, A, D
        T[F2, 0], T[F2, 1], T[F2, 2] = D, B, C
        changed[F1] = True
        changed[F2] = True
        twin[3 * F1 + 2] = 3 * F2 + 2
        twin[3 * F2 + 2] = 3 * F1 + 2
    for r in range(4):
        for q in range(nf):
            o = outer[r, q]
            if o >= 0:
                ro = slot_new[o] if slot_new[o] >= 0 else o
                twin[new[r, q]] = ro
            else:
                twin[new[r, q]] = -1
    for r in range(4):
        for q in range(nf):
            o = outer[r, q]
            if o >= 0:
                ro = slot_new[o] if slot_new[o] >= 0 else o
                twin[ro] = new[r, q]
    # the made edges (True), then the removed ones (False): the last write of a key counts
    uk = np.empty(2 * nf, np.int64)
    uv = np.empty(2 * nf, np.bool_)
    for q in range(nf):
        j = flips[q]
        uk[q], uv[q] = ncd[j], True
        A, B = g[j, 2], g[j, 3]
        uk[nf + q], uv[nf + q] = min(A, B) * n + max(A, B), False
    by = np.argsort(uk, kind="mergesort")
    nk2 = ck_keys.size + 2 * nf
    mk = np.empty(nk2, np.int64)
    mv = np.empty(nk2, np.bool_)
    p, t = 0, 0
    for q in range(2 * nf):
        if q + 1 < 2 * nf and uk[by[q + 1]] == uk[by[q]]:
            continue                       # a later write of the same key follows
        key, val = uk[by[q]], uv[by[q]]
        while p < ck_keys.size and ck_keys[p] < key:
            mk[t], mv[t] = ck_keys[p], ck_vals[p]
            p += 1
            t += 1
        if p < ck_keys.size and ck_keys[p] == key:
            p += 1
        mk[t], mv[t] = key, val
        t += 1
    while p < ck_keys.size:
        mk[t], mv[t] = ck_keys[p], ck_vals[p]
        p += 1
        t += 1
    ck_keys, ck_vals = mk[:t], mv[:t]
    # next round: the edges of the changed faces and the unflipped candidates
    flipped = np.zeros(m, np.bool_)
    for q in range(nf):
        flipped[flips[q]] = True
    nxt = np.empty(ng + 6 * nf, np.int64)
    k = 0
    for q in range(ng):
        j = geo[q]
        if flipped[j]:
            continue
        h = g[j, 0]
        if used[h // 3]:
            continue
        nxt[k] = min(h, twin[h])
        k += 1
    for q in range(nf):
        j = flips[q]
        for f in (g[j, 6], g[j, 7]):
            for i in range(3):
                h = 3 * f + i
                if twin[h] >= 0:
                    nxt[k] = min(h, twin[h])
                    k += 1
    return 0, np.unique(nxt[:k]), ck_keys, ck_vals


@njit(cache=True, nogil=True)
def _pair_half_edges(T, n):
    """The half-edge pairing of :func:`shellrepair.refine._relax_numpy`
    (``key = min·n + max`` per half-edge ``3f+c``, its stable argsort, twins
    of neighbours in it), by a counting sort on the lower vertex and an
    insertion sort on the higher one within it (the same order).

    Returns the sorted keys, the twins (−1: none) and ``order[pair]``."""
    m = 3 * T.shape[0]
    lo = np.empty(m, np.int64)
    hi = np.empty(m, np.int64)
    for f in range(T.shape[0]):
        for c in range(3):
            a = T[f, c]
            b = T[f, (c + 1) % 3]
            lo[3 * f + c] = min(a, b)
            hi[3 * f + c] = max(a, b)
    start = np.zeros(n + 1, np.int64)
    for h in range(m):
        start[lo[h] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    order = np.empty(m, np.int64)
    fill = start[:n].copy()
    for h in range(m):          # stable: by id within a lower vertex
        order[fill[lo[h]]] = h
        fill[lo[h]] += 1
    for v in range(n):          # stable insertion sort by the higher vertex
        for i in range(start[v] + 1, start[v + 1]):
            h = order[i]
            j = i - 1
            while j >= start[v] and hi[order[j]] > hi[h]:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = h
    ks = np.empty(m, np.int64)
    for i in range(m):
        h = order[i]
        ks[i] = lo[h] * n + hi[h]
    twin = np.full(m, -1, np.int64)
    npair = 0
    for i in range(m - 1):
        if ks[i + 1] == ks[i]:
            npair += 1
    active = np.empty(npair, np.int64)
    k = 0
    for i in range(m - 1):      # in the order of NumPy's two fancy assignments
        if ks[i + 1] == ks[i]:
            twin[order[i]] = order[i + 1]
            active[k] = order[i]
            k += 1
    for i in range(m - 1):
        if ks[i + 1] == ks[i]:
            twin[order[i + 1]] = order[i]
    return ks, twin, active


def relax(P, T, is_loop, forb, max_rounds, dirty, angle, unfolded, flip_eps):
    """:func:`shellrepair.refine._relax` with its bookkeeping compiled.

    The same rounds, choices and results; the opposite angles and the fold
    test stay NumPy's own (``angle``, ``unfolded``: refine's functions),
    so every decision sees the same numbers. ``angle`` None: both from
    :func:`relax_round_parts` (refine's compiled angle parts and fold
    test, one pass a round) and NumPy's arctan2.

    Returns
    -------
    T, changed, settled : as ``_relax``; or None when two flips of a round
        share a face (a tie between equal excesses), for the caller to
        redo in NumPy.
    """
    n = len(P)
    nt = len(T)
    changed = np.zeros(nt, bool)
    if nt < 2:
        return T, changed, True
    T = np.array(T, np.int64)
    if angle is None:
        P = np.ascontiguousarray(P, np.float64)
    forb = np.sort(forb[:, 0] * n + forb[:, 1]) if len(forb) else np.zeros(0, np.int64)
    ks, twin, active = _pair_half_edges(T, n)
    if dirty is not None:
        active = active[dirty[active // 3] | dirty[twin[active] // 3]]
    ck_keys, ck_vals = np.zeros(0, np.int64), np.zeros(0, np.bool_)
    is_loop = np.ascontiguousarray(is_loop, np.bool_)
    settled = False
    for _ in range(max_rounds):
        if active.size == 0:
            settled = True
            break
        g = _relax_gather(T, twin, np.ascontiguousarray(active, np.int64), n)
        if angle is None:     # the compiled parts of both (refine's own numbers), NumPy's arctan2
            cr1, dt1, cr2, dt2, unf = _relax_round_parts(P, g)
            excess = np.arctan2(cr1, dt1) + np.arctan2(cr2, dt2) - np.pi
        else:
            pa, pb, pc, pd = P[g[:, 2]], P[g[:, 3]], P[g[:, 4]], P[g[:, 5]]
            excess = angle(pa - pc, pb - pc) + angle(pa - pd, pb - pd) - np.pi
            unf = np.ascontiguousarray(unfolded(pa, pb, pc, pd), np.bool_)
        status, active, ck_keys, ck_vals = _relax_apply(T, twin, changed, is_loop, forb, ks, ck_keys, ck_vals, g,
                                                        np.ascontiguousarray(excess), unf, float(flip_eps), n)
        if status == 2:
            return None
        if status == 1:
            settled = True
            break
    return T, changed, settled


# --------------------------------------------------------------------------
# fairing of a small patch (dense normal equations)
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _laplacian_rows(T, W, n, binary):
    """K = D − A as CSR rows (diagonal included, unsorted columns).

    ``binary``: A is the 0/1 adjacency of the edges of ``T`` (the uniform
    Laplacian of :func:`shellrepair.fair.uniform_laplacian`); else
    ``A_ij`` sums ``W[f,s]`` over the sides s of T joining i and j (the
    cotangent Laplacian of :func:`shellrepair.intrinsic.intrinsic_laplacian`
    with W = ½ cot)."""
    m = T.shape[0]
    cnt = np.ones(n + 1, np.int64)      # the diagonal, plus two entries a side
    cnt[n] = 0
    for f in range(m):
        for s in range(3):
            cnt[T[f, s]] += 1
            cnt[T[f, (s + 1) % 3]] += 1
    ptr = np.zeros(n + 1, np.int64)
    for v in range(n):
        ptr[v + 1] = ptr[v] + cnt[v]
    col = np.empty(ptr[n], np.int64)
    val = np.zeros(ptr[n])
    fill = ptr[:-1].copy()
    where = np.full(n, -1, np.int64)    # column -> slot in the row being built
    # rows built one vertex at a time from its half-edges: bucket them first
    hs = np.zeros(n + 1, np.int64)
    for f in range(m):
        for s in range(3):
            hs[T[f, s] + 1] += 1
            hs[T[f, (s + 1) % 3] + 1] += 1
    for v in range(n):
        hs[v + 1] += hs[v]
    hf = hs[:-1].copy()
    other = np.empty(hs[n], np.int64)
    wt = np.empty(hs[n])
    for f in range(m):
        for s in range(3):
            a, b = T[f, s], T[f, (s + 1) % 3]
            w = 1.0 if binary else W[f, s]
            other[hf[a]] = b
            wt[hf[a]] = w
            hf[a] += 1
            other[hf[b]] = a
            wt[hf[b]] = w
            hf[b] += 1
    for v in range(n):
        d = fill[v]
        col[d] = v
        fill[v] += 1
        diag = 0.0
        for p in range(hs[v], hs[v + 1]):
            j = other[p]
            if j == v:
                continue
            q = where[j]
            if q < 0:
                q = fill[v]
                fill[v] += 1
                col[q] = j
                where[j] = q
                val[q] = -wt[p] if not binary else -1.0
            elif not binary:
                val[q] -= wt[p]
        for q in range(d + 1, fill[v]):
            diag -= val[q]
            where[col[q]] = -1
        val[d] = diag
        ptr_end = fill[v]
        for q in range(ptr_end, ptr[v + 1]):
            col[q] = v                  # unused slots: zeros on the diagonal
            val[q] = 0.0
    return ptr, col, val


@njit(cache=True, nogil=True)
def _matvec(ptr, col, val, x):
    y = np.zeros_like(x)
    for v in range(ptr.size - 1):
        for q in range(ptr[v], ptr[v + 1]):
            for c in range(x.shape[1]):
                y[v, c] += val[q] * x[col[q], c]
    return y


@njit(cache=True, nogil=True)
def _cholesky_solve(Q, B):
    """Solve Q x = B (Q symmetric positive definite) by Cholesky; ok False
    when a pivot is not positive.

    The factor's entries are those of the textbook row-by-row Cholesky
    (``L[i, j] = (Q[i, j] − Σ_k L[i, k] L[j, k]) / L[j, j]``, the sum taken
    for k = 0, 1, ... in turn; tests/test_kernels.py holds a Python
    version to the bit), computed a column at a time: column j of L, kept
    as row j of ``Lt``, is Q's row j less each earlier column k scaled by
    L[j, k], k ascending. Every entry sees the same operations in the same
    order, but the inner loop runs over independent entries, which the
    compiler vectorises (the row-by-row form's inner loop is one chain of
    dependent subtractions): ~2-3x faster at 150-400 unknowns. The forward
    substitution likewise subtracts column by column (each entry's terms in
    the same order), the backward one row by row.
    """
    n = Q.shape[0]
    Lt = np.zeros((n, n))     # Lt[k, i] = L[i, k]
    s = np.empty(n)
    for j in range(n):
        m = n - j
        sj = s[j:]            # (loops from 0 over views: the compiler then vectorises them)
        for i in range(m):
            sj[i] = Q[j + i, j]
        for k in range(j):
            row = Lt[k, j:]
            c = row[0]
            for i in range(m):
                sj[i] = sj[i] - row[i] * c
        if not sj[0] > 0.0:
            return B, False
        d = np.sqrt(sj[0])
        out = Lt[j, j:]
        out[0] = d
        for i in range(1, m):
            out[i] = sj[i] / d
    X = B.copy()
    x = np.empty(n)
    for c in range(B.shape[1]):
        for i in range(n):
            x[i] = B[i, c]
        for k in range(n):    # forward: x[i] −= L[i, k] x[k], k ascending, then / L[i, i]
            xk = x[k] / Lt[k, k]
            x[k] = xk
            row = Lt[k, k + 1:]
            xr = x[k + 1:]
            for i in range(n - k - 1):
                xr[i] = xr[i] - row[i] * xk
        for i in range(n - 1, -1, -1):
            t = x[i]
            row = Lt[i]
            for k in range(i + 1, n):
                t -= row[k] * x[k]
            x[i] = t / row[i]
        for i in range(n):
            X[i, c] = x[i]
    return X, True


@njit(cache=True, nogil=True)
def _fair_round(ptr, col, val, D, order, X, fixed, unk_pos, unk):
    """Minimise xᵀQx, Q = K (D K)^(order−1), over the unknown rows of X."""
    n = X.shape[0]
    nu = unk.size
    Xf = X.copy()
    for i in range(nu):
        Xf[unk[i]] = 0.0
    y = _matvec(ptr, col, val, Xf)
    for _ in range(order - 1):
        for v in range(n):
            y[v] *= D[v]
        y = _matvec(ptr, col, val, y)
    B = np.empty((nu, 3))
    for i in range(nu):
        B[i] = -y[unk[i]]
    # Q restricted to the unknowns: G = K[:, u] (n x nu), then (order − 1)
    # times G <- K D G, and Quu = K[u, :] D G (order 1: Quu = G[u])
    G = np.zeros((n, nu))
    for v in range(n):
        for q in range(ptr[v], ptr[v + 1]):
            p = unk_pos[col[q]]
            if p >= 0:
                G[v, p] += val[q]
    for _ in range(order - 2):
        H = np.zeros((n, nu))
        for v in range(n):
            for q in range(ptr[v], ptr[v + 1]):
                w = val[q] * D[col[q]]
                j = col[q]
                for p in range(nu):
                    H[v, p] += w * G[j, p]
        G = H
    Q = np.zeros((nu, nu))
    if order == 1:
        for i in range(nu):
            Q[i] = G[unk[i]]
    else:
        for v in range(n):
            for q in range(ptr[v], ptr[v + 1]):
                j = col[q]                    # K[v, j] = K[j, v]: row j of K[u, :]
                p = unk_pos[j]
                if p >= 0:
                    w = val[q] * D[v]
                    for r in range(nu):
                        Q[p, r] += w * G[v, r]
    for i in range(nu):                       # symmetric in exact arithmetic
        for j in range(i):
            a = 0.5 * (Q[i, j] + Q[j, i])
            Q[i, j] = a
            Q[j, i] = a
    return _cholesky_solve(Q, B)


@njit(cache=True, nogil=True)
def _fair_small(X, F, fixed, order, rounds, degenerate_area, flip_tol, flip_rounds, uniform_max_order):
    n = X.shape[0]
    m = F.shape[0]
    unk_pos = np.full(n, -1, np.int64)
    nu = 0
    for v in range(n):
        if not fixed[v]:
            unk_pos[v] = nu
            nu += 1
    unk = np.empty(nu, np.int64)
    for v in range(n):
        if unk_pos[v] >= 0:
            unk[unk_pos[v]] = v
    X = X.copy()
    ones = np.ones(n)
    ptr, col, val = _laplacian_rows(F, np.zeros((0, 3)), n, True)
    # the solves read K without its spare zero slots (_drop_spare_diagonal:
    # each added a zero product, so no sum changes; half the entries)
    pc, cc, vc = _drop_spare_diagonal(ptr, col, val)
    Xu, ok = _fair_round(pc, cc, vc, ones, min(order, uniform_max_order), X, fixed, unk_pos, unk)
    if not ok:
        return X, False, ptr, col, val
    for i in range(nu):
        X[unk[i]] = Xu[i]
    for _ in range(rounds):
        finite = True
        amin = np.inf
        for v in range(n):
            for c in range(3):
                if not np.isfinite(X[v, c]):
                    finite = False
        for f in range(m):
            a, b, c = F[f, 0], F[f, 1], F[f, 2]
            ux, uy, uz = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
            vx, vy, vz = X[c, 0] - X[a, 0], X[c, 1] - X[a, 1], X[c, 2] - X[a, 2]
            cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            ar = 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)
            if ar < amin:
                amin = ar
        if not finite or not amin > degenerate_area:
            break
        T = F.copy()
        L = np.empty((m, 3))
        for f in range(m):
            for s in range(3):
                a, b = T[f, s], T[f, (s + 1) % 3]
                dx, dy, dz = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
                L[f, s] = np.sqrt(dx * dx + dy * dy + dz * dz)
        settled, cot, A = _flips(T, L, n, flip_rounds, flip_tol)
        if not settled:
            _cot_area(L, cot, A)
        W = 0.5 * cot
        M = np.zeros(n)
        for f in range(m):
            for s in range(3):
                M[T[f, s]] += A[f] / 3.0
        ptr2, col2, val2 = _laplacian_rows(T, W, n, False)
        if not (np.isfinite(val2).all() and np.isfinite(M).all()):
            break
        floor = degenerate_area + 1e-3 * np.median(M)
        D = 1.0 / np.maximum(M, floor)
        pc, cc, vc = _drop_spare_diagonal(ptr2, col2, val2)
        Xn, ok = _fair_round(pc, cc, vc, D, order, X, fixed, unk_pos, unk)
        if not ok or not np.isfinite(Xn).all():
            break
        for i in range(nu):
            X[unk[i]] = Xn[i]
        ptr, col, val = ptr2, col2, val2
    return X, True, ptr, col, val


def fair_small(X, F, fixed, order, rounds, degenerate_area, flip_tol, flip_rounds, uniform_max_order=2):
    """:func:`shellrepair.fair.fair_patch` for a small patch, compiled.

    The same rounds (a uniform-weight solve of order min(order,
    ``uniform_max_order``), then cotangent rounds on the
    intrinsic Delaunay triangulation, the same stopping tests), with the
    normal equations of the unknowns assembled dense and solved by a
    Cholesky factorisation instead of libigl's sparse one: equal to
    ``fair_patch`` to round-off (tests/test_kernels.py bounds the
    difference), for patches of up to a few hundred unknowns.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    fixed : (n,) bool
        Rows held (the scan's, and pinned new vertices).
    order : {1, 2, 3}
    rounds : int
    degenerate_area, flip_tol : float
    flip_rounds : int
        As in :mod:`shellrepair.fair` and :mod:`shellrepair.intrinsic`.
    uniform_max_order : int
        ``fair.UNIFORM_MAX_ORDER``.

    Returns
    -------
    X2 : (n,3) float64
    ok : bool
        False when the first solve's matrix is not positive definite
        (then use the sparse path).
    ptr, col, val : CSR arrays
        The order-1 operator of the last round used (``fair_patch``'s K;
        unused slots hold zeros on the diagonal).
    """
    return _fair_small(np.ascontiguousarray(X, np.float64), np.ascontiguousarray(F, np.int64),
                       np.ascontiguousarray(fixed, np.bool_), int(order), int(rounds), float(degenerate_area),
                       float(flip_tol), int(flip_rounds), int(uniform_max_order))


@njit(cache=True, nogil=True)
def _angle_part(a0, a1, a2, b0, b1, b2, q0, q1, q2):
    """:func:`_angle_parts` of (a − q, b − q), one row: its operations."""
    u0, u1, u2 = a0 - q0, a1 - q1, a2 - q2
    v0, v1, v2 = b0 - q0, b1 - q1, b2 - q2
    c0 = u1 * v2 - u2 * v1
    c1 = u2 * v0 - u0 * v2
    c2 = u0 * v1 - u1 * v0
    # the dot product from 0.0, as np.sum's reduction starts: +0.0 where every product is −0.0
    return np.sqrt(c0 * c0 + c1 * c1 + c2 * c2), 0.0 + u0 * v0 + u1 * v1 + u2 * v2


@njit(cache=True, nogil=True)
def _relax_round_parts(P, g):
    m = g.shape[0]
    cr1, dt1 = np.empty(m), np.empty(m)
    cr2, dt2 = np.empty(m), np.empty(m)
    pa, pb = np.empty((m, 3)), np.empty((m, 3))
    pc, pd = np.empty((m, 3)), np.empty((m, 3))
    for r in range(m):
        for i in range(3):
            pa[r, i], pb[r, i] = P[g[r, 2], i], P[g[r, 3], i]
            pc[r, i], pd[r, i] = P[g[r, 4], i], P[g[r, 5], i]
        cr1[r], dt1[r] = _angle_part(pa[r, 0], pa[r, 1], pa[r, 2], pb[r, 0], pb[r, 1], pb[r, 2],
                                     pc[r, 0], pc[r, 1], pc[r, 2])
        cr2[r], dt2[r] = _angle_part(pa[r, 0], pa[r, 1], pa[r, 2], pb[r, 0], pb[r, 1], pb[r, 2],
                                     pd[r, 0], pd[r, 1], pd[r, 2])
    return cr1, dt1, cr2, dt2, _unfolded(pa, pb, pc, pd)


def relax_round_parts(P, g):
    """One relaxation round's numbers for the candidate edges of
    :func:`_relax_gather` (rows of ``g``: h1, h2, a, b, c, d, f1, f2):
    :func:`angle_parts` of the angles at c and at d facing edge a-b
    (``(a − c, b − c)``, ``(a − d, b − d)``) and :func:`unfolded` of the
    flip, in one pass with the same operations (the arctan2 stays NumPy's).

    Returns
    -------
    cr1, dt1, cr2, dt2 : (m,) float64
    unf : (m,) bool
    """
    return _relax_round_parts(np.ascontiguousarray(P, np.float64), np.ascontiguousarray(g, np.int64))


# --------------------------------------------------------------------------
# fairing of large patches: the energy's blocks, assembled directly
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _times_dk(ptr, col, val, D, acc, lst, cnt, acc2, mark2, lst2):
    """Sparse row r (``acc`` at columns ``lst[:cnt]``) times D K, K
    symmetric, into ``acc2`` / ``lst2`` (``acc2`` zero and ``mark2`` clear
    on entry); returns the new column count."""
    cnt2 = 0
    for t in range(cnt):
        w = lst[t]
        sw = acc[w] * D[w]
        for q in range(ptr[w], ptr[w + 1]):
            j = col[q]
            lst2[cnt2] = j            # listed once: the count moves on only for a new column
            cnt2 += 1 - np.int64(mark2[j])
            mark2[j] = 1
            acc2[j] += sw * val[q]
    return cnt2


@njit(cache=True, nogil=True)
def _energy_rows(ptr, col, val, D, order, unk, pos, is_fixed):
    """Rows ``unk`` of Q = K (D K)^(order−1), split by column into the
    unknowns' block (columns ``pos`` of unknowns) and the fixed block
    (columns ``pos`` of fixed vertices); each row's columns sorted.

    Row by row (Gustavson): the row of K, then (order − 1) times r ← (r D) K,
    in scattered accumulators, one per level, that hold zeros between rows
    (each row clears the entries it used): an entry's sum starts from 0.0
    and adds its terms in the order the row's expansion meets them. A row's
    columns are listed without branches (marks) and sorted by rank (each
    column's count of smaller ones; the columns are distinct; a row of more
    than 64 by a sort): ~1.3x the
    speed of first-touch stamps and an insertion sort, the same arrays."""
    n = ptr.size - 1
    nu = unk.size
    acc1, acc2, acc3 = np.zeros(n), np.zeros(n), np.zeros(n)
    # marks of one byte and column lists of four (a fairing submesh has far
    # fewer than 2^31 vertices): with the three accumulators they stay
    # within a core's L2 on a ~13k-vertex submesh (order 3, 11,847
    # unknowns: 27 -> 24 ms)
    m1, m2, m3 = np.zeros(n, np.uint8), np.zeros(n, np.uint8), np.zeros(n, np.uint8)
    l1, l2, l3 = np.empty(n + 1, np.int32), np.empty(n + 1, np.int32), np.empty(n + 1, np.int32)
    srt = np.empty(n, np.int64)
    # a row of Q reads ``order`` rings: 7, 19, 37 columns around a vertex of
    # valence six (1 + 3 order (order + 1)); room for a few more, so that an
    # order-3 system is not copied to larger arrays twice on the way
    cap_u = max((4 + 3 * order * (order + 1)) * nu, 16)
    cap_f = max(4 * nu, 16)
    u_ptr = np.zeros(nu + 1, np.int64)
    u_col = np.empty(cap_u, np.int64)
    u_val = np.empty(cap_u)
    f_ptr = np.zeros(nu + 1, np.int64)
    f_col = np.empty(cap_f, np.int64)
    f_val = np.empty(cap_f)
    nuu = 0
    nuf = 0
    for i in range(nu):
        v = unk[i]
        cnt1 = 0
        for q in range(ptr[v], ptr[v + 1]):           # level 1: row v of K
            j = col[q]
            l1[cnt1] = j
            cnt1 += 1 - np.int64(m1[j])
            m1[j] = 1
            acc1[j] += val[q]
        cnt, cnt2 = cnt1, 0
        acc, lst = acc1, l1
        if order >= 2:
            cnt2 = _times_dk(ptr, col, val, D, acc1, l1, cnt1, acc2, m2, l2)
            cnt, acc, lst = cnt2, acc2, l2
        if order >= 3:
            cnt = _times_dk(ptr, col, val, D, acc2, l2, cnt2, acc3, m3, l3)
            acc, lst = acc3, l3
        if cnt <= 64:
            for t in range(cnt):                       # the columns sorted, by rank
                j = lst[t]
                r = 0
                for u in range(cnt):
                    r += lst[u] < j
                srt[r] = j
        else:                                          # (a long row: rank sorting grows as its square)
            srt[:cnt] = np.sort(lst[:cnt])
        if nuu + cnt > cap_u:
            cap_u = 2 * (nuu + cnt)
            u_col = np.concatenate((u_col[:nuu], np.empty(cap_u - nuu, np.int64)))
            u_val = np.concatenate((u_val[:nuu], np.empty(cap_u - nuu)))
        if nuf + cnt > cap_f:
            cap_f = 2 * (nuf + cnt)
            f_col = np.concatenate((f_col[:nuf], np.empty(cap_f - nuf, np.int64)))
            f_val = np.concatenate((f_val[:nuf], np.empty(cap_f - nuf)))
        for t in range(cnt):
            j = srt[t]
            if is_fixed[j]:
                f_col[nuf] = pos[j]
                f_val[nuf] = acc[j]
                nuf += 1
            else:
                u_col[nuu] = pos[j]
                u_val[nuu] = acc[j]
                nuu += 1
        u_ptr[i + 1] = nuu
        f_ptr[i + 1] = nuf
        for t in range(cnt1):                          # clear what the row used
            j = l1[t]
            acc1[j] = 0.0
            m1[j] = 0
        if order >= 2:
            for t in range(cnt2):
                j = l2[t]
                acc2[j] = 0.0
                m2[j] = 0
        if order >= 3:
            for t in range(cnt):
                j = l3[t]
                acc3[j] = 0.0
                m3[j] = 0
    return u_ptr, u_col[:nuu].copy(), u_val[:nuu].copy(), f_ptr, f_col[:nuf].copy(), f_val[:nuf].copy()


@njit(cache=True, nogil=True)
def _symmetrise(ptr, col, val):
    """Q ← (Q + Qᵀ) / 2 in place, for sorted rows of a structurally
    symmetric matrix: both entries get the same value, to the bit.

    Row i's entries (i, j), j > i, meet their mirrors (j, i) in row j in
    increasing i, so each row j keeps a cursor that only moves forward to
    the first column not below i: one pass over the entries (a binary
    search per entry found the same slot)."""
    n = ptr.size - 1
    cur = ptr[:-1].copy()
    for i in range(n):
        for q in range(ptr[i], ptr[i + 1]):
            j = col[q]
            if j <= i:
                continue
            c = cur[j]
            end = ptr[j + 1]
            while c < end and col[c] < i:
                c += 1
            cur[j] = c
            if c < end and col[c] == i:
                m = 0.5 * (val[q] + val[c])
                val[q] = m
                val[c] = m
    return val


@njit(cache=True, nogil=True)
def _drop_spare_diagonal(ptr, col, val):
    """The rows without the spare zero slots :func:`_laplacian_rows` leaves
    on the diagonal (a zero entry of column i in row i after the row's
    first): about half of a cotangent Laplacian's entries, each adding a
    zero product in :func:`_energy_rows` (so dropping them changes no sum)."""
    n = ptr.size - 1
    keep = np.zeros(ptr[n], np.bool_)
    p2 = np.zeros(n + 1, np.int64)
    for i in range(n):
        seen = False
        for q in range(ptr[i], ptr[i + 1]):
            if col[q] == i:
                if seen and val[q] == 0.0:
                    continue
                seen = True
            keep[q] = True
            p2[i + 1] += 1
    for i in range(n):
        p2[i + 1] += p2[i]
    c2 = np.empty(p2[n], np.int64)
    v2 = np.empty(p2[n])
    t = 0
    for q in range(ptr[n]):
        if keep[q]:
            c2[t] = col[q]
            v2[t] = val[q]
            t += 1
    return p2, c2, v2


def energy_blocks(ptr, col, val, D, order, unknown, fixed):
    """The blocks of the fairing energy Q = K (D K)^(order−1) that a solve
    with the rows ``fixed`` given needs, assembled in one pass per row
    (:func:`shellrepair.fair._energy` and slicing, without the sparse
    products, sorts and transposes; equal to round-off, the sums taken in
    another order).

    Parameters
    ----------
    ptr, col, val : CSR (or CSC) arrays of K (n,n), symmetric
    D : (n,) float64
        The diagonal between the factors (M⁻¹; ones for unit masses).
    order : {1, 2, 3}
    unknown, fixed : int64 arrays partitioning range(n)

    Returns
    -------
    uu : (ptr, col, val)
        Q[unknown][:, unknown], rows sorted, symmetric to the bit (the same
        arrays are its CSC).
    uf : (ptr, col, val)
        Q[unknown][:, fixed] as CSR.
    """
    unknown = np.ascontiguousarray(unknown, np.int64)
    fixed = np.ascontiguousarray(fixed, np.int64)
    n = ptr.size - 1
    pos = np.empty(n, np.int64)
    pos[unknown] = np.arange(unknown.size)
    pos[fixed] = np.arange(fixed.size)
    is_fixed = np.zeros(n, np.bool_)
    is_fixed[fixed] = True
    ptr, col, val = _drop_spare_diagonal(np.ascontiguousarray(ptr, np.int64), np.ascontiguousarray(col, np.int64),
                                         np.ascontiguousarray(val, np.float64))
    up, uc, uv, fp, fc, fv = _energy_rows(ptr, col, val, np.ascontiguousarray(D, np.float64), int(order), unknown, pos,
                                          is_fixed)
    uv = _symmetrise(up, uc, uv)
    return (up, uc, uv), (fp, fc, fv)

# --------------------------------------------------------------------------
# the local region's near-face query
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _boxes_meeting(bmin, bmax, lo, hi, out):
    for i in range(bmin.shape[0]):
        out[i] = (bmin[i, 0] <= hi[0] and bmin[i, 1] <= hi[1] and bmin[i, 2] <= hi[2]
                  and bmax[i, 0] >= lo[0] and bmax[i, 1] >= lo[1] and bmax[i, 2] >= lo[2])
    return out


def boxes_meeting(bmin, bmax, lo, hi):
    """(m,) bool: which boxes ``[bmin[i], bmax[i]]`` (m,3) meet the box
    ``[lo, hi]``; ``np.all((bmin <= hi) & (bmax >= lo), axis=1)`` in one
    pass, without its six (m,3) temporaries."""
    out = np.empty(len(bmin), np.bool_)
    return _boxes_meeting(np.ascontiguousarray(bmin, np.float64), np.ascontiguousarray(bmax, np.float64),
                          np.ascontiguousarray(lo, np.float64), np.ascontiguousarray(hi, np.float64), out)


# --------------------------------------------------------------------------
# per loop: its diameter, whether its projected outline is simple
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
    (:func:`shellrepair.holes._diameter`'s NumPy form) without its (k,k,3)
    temporary. A NaN coordinate is skipped here where NumPy's max would
    return NaN: callers pass finite rows."""
    return float(_max_sq_distance(np.ascontiguousarray(Q, np.float64)))


@njit(cache=True, nogil=True)
def _orient2(px, py, qx, qy, rx, ry):
    return (qx - px) * (ry - py) - (qy - py) * (rx - px)


@njit(cache=True, nogil=True)
def _outline_simple(Q, eps):
    k = Q.shape[0]
    for i in range(k):
        ax, ay = Q[i, 0], Q[i, 1]
        i1 = i + 1 if i + 1 < k else 0
        bx, by = Q[i1, 0], Q[i1, 1]
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue    # edges k-1 and 0 are adjacent
            cx, cy = Q[j, 0], Q[j, 1]
            j1 = j + 1 if j + 1 < k else 0
            dx, dy = Q[j1, 0], Q[j1, 1]
            o1 = _orient2(ax, ay, bx, by, cx, cy)
            o2 = _orient2(ax, ay, bx, by, dx, dy)
            o3 = _orient2(cx, cy, dx, dy, ax, ay)
            o4 = _orient2(cx, cy, dx, dy, bx, by)
            if (o1 > eps and o2 > eps) or (o1 < -eps and o2 < -eps) \
                    or (o3 > eps and o4 > eps) or (o3 < -eps and o4 < -eps):
                continue
            if (max(ax, bx) < min(cx, dx) or max(cx, dx) < min(ax, bx)
                    or max(ay, by) < min(cy, dy) or max(cy, dy) < min(ay, by)):
                continue
            return False
    return True


def outline_simple(Q, eps):
    """:func:`shellrepair.intersect._outline_is_simple`'s pair test on every
    pair of non-adjacent edges of the closed polygon ``Q`` (k,2), k >= 3,
    with its tolerance ``eps``: the same orientations, in the same
    arithmetic, so the same answer; it stops at the first pair that meets."""
    return bool(_outline_simple(np.ascontiguousarray(Q, np.float64), float(eps)))


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
    """:func:`shellrepair.fill._folds`' test, compiled: the patch triangles
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


@njit(cache=True, nogil=True)
def _rim_walk(loop, vf_order, vf_start, F, V):
    # the faces at the loop's vertices, sorted and unique (Context.faces_of)
    total = 0
    for v in loop:
        total += vf_start[v + 1] - vf_start[v]
    fs = np.empty(total, np.int64)
    q = 0
    for v in loop:
        for p in range(vf_start[v], vf_start[v + 1]):
            fs[q] = vf_order[p] // 3
            q += 1
    fs = np.sort(fs)
    m = 0
    for i in range(total):
        if i == 0 or fs[i] != fs[i - 1]:
            fs[m] = fs[i]
            m += 1
    # sides T[:, [0,1]], then [1,2], then [2,0]; their lengths; unit normals
    ia = np.empty(3 * m, np.int64)
    ib = np.empty(3 * m, np.int64)
    ln = np.empty(3 * m)
    nrm = np.empty((m, 3))
    order = np.argsort(loop, kind="mergesort")
    sl = loop[order]
    for c in range(3):
        for r in range(m):
            a, b = F[fs[r], c], F[fs[r], (c + 1) % 3]
            d0, d1, d2 = V[a, 0] - V[b, 0], V[a, 1] - V[b, 1], V[a, 2] - V[b, 2]
            ln[c * m + r] = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            j = np.searchsorted(sl, a, side="right") - 1
            ia[c * m + r] = order[j] if j >= 0 and sl[j] == a else -1
            j = np.searchsorted(sl, b, side="right") - 1
            ib[c * m + r] = order[j] if j >= 0 and sl[j] == b else -1
    for r in range(m):
        f = fs[r]
        x0, x1, x2 = V[F[f, 0], 0], V[F[f, 0], 1], V[F[f, 0], 2]
        a0, a1, a2 = V[F[f, 1], 0] - x0, V[F[f, 1], 1] - x1, V[F[f, 1], 2] - x2
        b0, b1, b2 = V[F[f, 2], 0] - x0, V[F[f, 2], 1] - x1, V[F[f, 2], 2] - x2
        n0, n1, n2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
        nl = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if nl > 0:
            nrm[r, 0], nrm[r, 1], nrm[r, 2] = n0 / nl, n1 / nl, n2 / nl
        else:
            nrm[r, 0], nrm[r, 1], nrm[r, 2] = 0.0, 0.0, 0.0
    return _rim_edges(loop.size, ia, ib, ln, nrm)


def rim_walk(loop, vf_order, vf_start, F, V):
    """:func:`rim_edges` from the loop alone: the faces at its vertices
    (``vf_order``, ``vf_start``: complete lists there), their sides, side
    lengths and unit normals as :func:`shellrepair.context._rim_faces` makes
    them, then the edge walk; the same four arrays."""
    return _rim_walk(np.ascontiguousarray(loop, np.int64), vf_order, vf_start,
                     np.ascontiguousarray(F, np.int64), np.ascontiguousarray(V, np.float64))


@njit(cache=True, nogil=True)
def _face_cross(faces, F, V):
    n = np.empty((faces.size, 3))
    for r in range(faces.size):
        f = faces[r]
        x0, x1, x2 = V[F[f, 0], 0], V[F[f, 0], 1], V[F[f, 0], 2]
        a0, a1, a2 = V[F[f, 1], 0] - x0, V[F[f, 1], 1] - x1, V[F[f, 1], 2] - x2
        b0, b1, b2 = V[F[f, 2], 0] - x0, V[F[f, 2], 1] - x1, V[F[f, 2], 2] - x2
        n[r, 0] = a1 * b2 - a2 * b1
        n[r, 1] = a2 * b0 - a0 * b2
        n[r, 2] = a0 * b1 - a1 * b0
    return n


def face_cross(faces, F, V):
    """``cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])`` of the
    faces ``T = F[faces]`` (:func:`shellrepair.geometry.cross`), in one pass.

    Parameters
    ----------
    faces : (m,) int64
    F : (f,3) int64
    V : (n,3) float64

    Returns
    -------
    n : (m,3) float64
        Twice the area-weighted face normals.
    """
    return _face_cross(np.ascontiguousarray(faces, np.int64), np.ascontiguousarray(F, np.int64),
                       np.ascontiguousarray(V, np.float64))


@njit(cache=True, nogil=True)
def _ring_sums(E, li, level, X, Nv):
    nv = level.size
    # each vertex's neighbours (unsorted, with repeats); the rows read
    # below (levels 0 and 1) sorted in place, repeats skipped when read
    start = np.zeros(nv + 1, np.int64)
    for r in range(E.shape[0]):
        start[E[r, 0] + 1] += 1
        start[E[r, 1] + 1] += 1
    for v in range(nv):
        start[v + 1] += start[v]
    nb = np.empty(start[nv], np.int64)
    fill = start[:nv].copy()
    for r in range(E.shape[0]):
        a, b = E[r, 0], E[r, 1]
        nb[fill[a]] = b
        fill[a] += 1
        nb[fill[b]] = a
        fill[b] += 1
    for v in range(nv):
        if level[v] <= 1:
            for i in range(start[v] + 1, start[v + 1]):       # insertion sort: a few entries
                x = nb[i]
                j = i - 1
                while j >= start[v] and nb[j] > x:
                    nb[j + 1] = nb[j]
                    j -= 1
                nb[j + 1] = x
    p = li.size
    s1 = np.zeros((p, 3))
    n1 = np.zeros((p, 3))
    c1 = np.zeros(p)
    s2 = np.zeros((p, 3))
    n2 = np.zeros((p, 3))
    c2 = np.zeros(p)
    mark = np.zeros(nv, np.bool_)
    got = np.empty(nv, np.int64)
    for i in range(p):
        v = li[i]
        ng = 0
        for jj in range(start[v], start[v + 1]):
            w = nb[jj]
            if level[w] != 1 or (jj > start[v] and nb[jj - 1] == w):
                continue
            c1[i] += 1.0
            for k in range(3):
                s1[i, k] += X[w, k]
                n1[i, k] += Nv[w, k]
            for tt in range(start[w], start[w + 1]):
                x = nb[tt]
                if level[x] == 2 and not mark[x]:
                    mark[x] = True
                    got[ng] = x
                    ng += 1
        two = np.sort(got[:ng])
        for x in two:
            mark[x] = False
            c2[i] += 1.0
            for k in range(3):
                s2[i, k] += X[x, k]
                n2[i, k] += Nv[x, k]
    return s1, c1, n1, s2, c2, n2


def ring_sums(E, li, level, X, Nv):
    """:func:`shellrepair.bridge._ring_sums` compiled: per rim vertex the
    sums over its level-1 neighbours and over their level-2 neighbours, in
    ascending vertex order from zero, as the sparse products add them.

    Parameters
    ----------
    E : (k,2) int64
        Edges (repeats and both directions allowed).
    li : (p,) int64
        Rim vertices.
    level : (nv,) int64
    X, Nv : (nv,3) float64

    Returns
    -------
    s1, c1, n1, s2, c2, n2
        As :func:`shellrepair.bridge._ring_sums`.
    """
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    i = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    return _ring_sums(i(E).reshape(-1, 2), i(li), i(level), c(X), c(Nv))


@njit(cache=True, nogil=True)
def _block_ids(Fcat, fcount, loopcat, sizes, n, vpos):
    if vpos.size:
        return _block_ids_marked(Fcat, fcount, loopcat, sizes, n, vpos)
    nb = fcount.size
    ukey = np.empty(3 * Fcat.shape[0] + loopcat.size, np.int64)
    L = np.empty(Fcat.shape, np.int64)
    li = np.empty(loopcat.size, np.int64)
    nu = 0
    f0 = 0
    p0 = 0
    for blk in range(nb):
        f1, p1 = f0 + fcount[blk], p0 + sizes[blk]
        vs = np.empty(3 * (f1 - f0) + (p1 - p0), np.int64)
        q = 0
        for f in range(f0, f1):
            for c in range(3):
                vs[q] = Fcat[f, c]
                q += 1
        for i in range(p0, p1):
            vs[q] = loopcat[i]
            q += 1
        vs = np.sort(vs)
        m = 0
        for i in range(vs.size):
            if i == 0 or vs[i] != vs[i - 1]:
                vs[m] = vs[i]
                m += 1
        vs = vs[:m]
        base = np.int64(blk) * n
        for i in range(m):
            ukey[nu + i] = base + vs[i]
        for f in range(f0, f1):
            for c in range(3):
                L[f, c] = nu + np.searchsorted(vs, Fcat[f, c])
        for i in range(p0, p1):
            li[i] = nu + np.searchsorted(vs, loopcat[i])
        nu += m
        f0, p0 = f1, p1
    return ukey[:nu], L, li


@njit(cache=True, nogil=True)
def _block_ids_marked(Fcat, fcount, loopcat, sizes, n, vpos):
    # _block_ids with a vertex-position scratch (all -1, left so): each
    # block's distinct vertices marked and sorted, then read off.
    nb = fcount.size
    ukey = np.empty(3 * Fcat.shape[0] + loopcat.size, np.int64)
    L = np.empty(Fcat.shape, np.int64)
    li = np.empty(loopcat.size, np.int64)
    seen = np.empty(max(1, 3 * Fcat.shape[0] + loopcat.size), np.int64)
    nu = 0
    f0 = 0
    p0 = 0
    for blk in range(nb):
        f1, p1 = f0 + fcount[blk], p0 + sizes[blk]
        m = 0
        for f in range(f0, f1):
            for c in range(3):
                w = Fcat[f, c]
                if vpos[w] < 0:
                    vpos[w] = 0
                    seen[m] = w
                    m += 1
        for i in range(p0, p1):
            w = loopcat[i]
            if vpos[w] < 0:
                vpos[w] = 0
                seen[m] = w
                m += 1
        vs = np.sort(seen[:m])
        base = np.int64(blk) * n
        for i in range(m):
            ukey[nu + i] = base + vs[i]
            vpos[vs[i]] = nu + i
        for f in range(f0, f1):
            for c in range(3):
                L[f, c] = vpos[Fcat[f, c]]
        for i in range(p0, p1):
            li[i] = vpos[loopcat[i]]
        for i in range(m):
            vpos[vs[i]] = -1
        nu += m
        f0, p0 = f1, p1
    return ukey[:nu], L, li


#: :func:`block_ids` marks vertices in a scratch of one entry per mesh vertex
#: when the mesh has at most this many vertices per face corner and loop
#: vertex given (the scratch then costs less than sorting each block's
#: corners); else it sorts them. The results are the same.
BLOCK_SCRATCH_RATIO = 8


def block_ids(Fcat, fcount, loopcat, sizes, n, scratch=None):
    """Local vertex numbers of several blocks of faces and loops
    (:func:`shellrepair.bridge._continuation_arcs_many`): the keys
    ``block * n + vertex`` of every block's vertices, sorted and unique
    (``np.unique``), and each face corner's and loop vertex's position
    among them (``np.searchsorted``); block by block, without sorting all
    keys at once.

    Parameters
    ----------
    Fcat : (r,3) int64
        The blocks' faces, block after block.
    fcount : (b,) int64
        Faces per block.
    loopcat : (p,) int64
        The blocks' loop vertices, block after block.
    sizes : (b,) int64
        Loop vertices per block.
    n : int
        Number of vertices of the mesh.
    scratch : bool, optional
        Number the vertices through a scratch of ``n`` entries (True) or by
        sorting each block's corners (False); by default the scratch when
        ``n`` is at most ``BLOCK_SCRATCH_RATIO`` times the entries given.

    Returns
    -------
    ukey : (nv,) int64
    L : (r,3) int64
    li : (p,) int64
    """
    i = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    Fcat, loopcat = i(Fcat).reshape(-1, 3), i(loopcat)
    if scratch is None:
        scratch = n <= BLOCK_SCRATCH_RATIO * (Fcat.size + loopcat.size)
    vpos = np.full(int(n) if scratch else 0, -1, np.int64)
    return _block_ids(Fcat, i(fcount), loopcat, i(sizes), np.int64(n), vpos)


@njit(cache=True, nogil=True)
def _corner_normal_sums(L, Fcat, V, nv):
    m = Fcat.shape[0]
    Nf = _face_cross(np.arange(m), Fcat, V)
    acc = np.zeros((nv, 3))
    for c in range(3):
        for f in range(m):
            for k in range(3):
                acc[L[f, c], k] += Nf[f, k]
    return acc


def corner_normal_sums(L, Fcat, V, nv):
    """``np.add.at(acc, L[:, c], np.cross(e1, e2))`` for c = 0, 1, 2 in
    turn (``e1, e2`` the sides of the faces ``Fcat`` from corner 0): the
    area-weighted normal sums at local vertices, the same additions in the
    same order.

    Returns
    -------
    acc : (nv,3) float64
    """
    return _corner_normal_sums(np.ascontiguousarray(L, np.int64), np.ascontiguousarray(Fcat, np.int64),
                               np.ascontiguousarray(V, np.float64), int(nv))


#: Points per leaf of :func:`arc_landings`' k-d tree of rim vertices.
_KD_LEAF = 8


@njit(cache=True, nogil=True)
def _kd_select(order, P, ax, a, z, k):
    # Wirth's selection: order[a:z] rearranged in place so that the points
    # before position k lie at most, and those after at least, at order[k]
    # along axis ax
    lo, hi = a, z - 1
    while lo < hi:
        x = P[order[k], ax]
        i, j = lo, hi
        while i <= j:
            while P[order[i], ax] < x:
                i += 1
            while x < P[order[j], ax]:
                j -= 1
            if i <= j:
                order[i], order[j] = order[j], order[i]
                i += 1
                j -= 1
        if j < k:
            lo = i
        if k < i:
            hi = j


@njit(cache=True, nogil=True)
def _kd_build(P):
    # a k-d tree by index medians along the widest axis: node b covers
    # order[lo[b]:hi[b]]; an inner node's left child holds the points at
    # most split[b] along axis[b], its right child those at least it
    n = P.shape[0]
    cap = n + 2      # a split node has more than _KD_LEAF points: leaves hold 4 or more
    lo = np.empty(cap, np.int64)
    hi = np.empty(cap, np.int64)
    axis = np.full(cap, -1, np.int64)
    split = np.zeros(cap)
    left = np.full(cap, -1, np.int64)
    order = np.arange(n)
    lo[0], hi[0] = 0, n
    nb = 1
    todo = np.empty(cap, np.int64)
    todo[0] = 0
    nt = 1
    while nt:
        nt -= 1
        b = todo[nt]
        a, z = lo[b], hi[b]
        if z - a <= _KD_LEAF:
            continue
        best, ax = -1.0, 0
        for k in range(3):
            mn, mx = np.inf, -np.inf
            for i in range(a, z):
                x = P[order[i], k]
                mn = min(mn, x)
                mx = max(mx, x)
            if mx - mn > best:
                best, ax = mx - mn, k
        mid = a + (z - a) // 2
        _kd_select(order, P, ax, a, z, mid)
        axis[b] = ax
        split[b] = P[order[mid], ax]
        left[b] = nb
        lo[nb], hi[nb] = a, mid
        lo[nb + 1], hi[nb + 1] = mid, z
        todo[nt] = nb
        todo[nt + 1] = nb + 1
        nt += 2
        nb += 2
    return order, lo[:nb], hi[:nb], axis[:nb], split[:nb], left[:nb]


@njit(cache=True, nogil=True)
def _sinc(x):
    # np.sinc of one value: sin(y) / y, y = pi x (eps where y is 0)
    y = np.pi * x
    if y == 0.0:
        y = 2.220446049250313e-16
    return np.sin(y) / y


@njit(cache=True, nogil=True)
def _arc_key(j, r, owner, place, arow, krow, irow, skip):
    # what a landing on rim vertex j decides for arc r: its loop, and
    # whether it is the arc's own start (2 * loop + 1) or not (2 * loop)
    w = owner[j]
    if w == arow[r]:
        g = abs(place[j] - irow[r])
        if min(g, krow[r] - g) <= skip:
            return 2 * w + 1
    return 2 * w


#: Ties :func:`arc_landings` keeps per sample; more sends it to NumPy.
_MAX_TIES = 16


@njit(cache=True, nogil=True)
def _arc_landings(U, T, N, kap, s0, length, frac, slack, ent, nent, P, owner, place, edge, arow, krow, irow, skip,
                  rank, landed, r0):
    m = U.shape[0]
    J = frac.size
    # every operand finite, else the NumPy version decides (NaN bounds)
    for r in range(m):
        for k in range(3):
            if not (np.isfinite(U[r, k]) and np.isfinite(T[r, k]) and np.isfinite(N[r, k])):
                return 2, r0
        if not (np.isfinite(kap[r]) and np.isfinite(s0[r]) and np.isfinite(length[r])):
            return 2, r0
    for i in range(P.shape[0]):
        for k in range(3):
            if not np.isfinite(P[i, k]):
                return 2, r0
    emax = -np.inf
    for i in range(edge.size):
        if not np.isfinite(edge[i]):
            return 2, r0
        emax = max(emax, edge[i])
    # per loop the largest slack of its arcs' samples, plus the largest edge
    bound = np.full(nent, -np.inf)
    for r in range(m):
        h = length[r] / J
        for c in range(J):
            s = s0[r] + length[r] * frac[c]
            bound[ent[r]] = max(bound[ent[r]], h + slack * (s - s0[r]))
    for e in range(nent):
        bound[e] += emax
    order, lo, hi, axis, split, left = _kd_build(P)
    Q = np.empty((P.shape[0], 3))      # the points in leaf order
    for i in range(P.shape[0]):
        for k in range(3):
            Q[i, k] = P[order[i], k]
    stack = np.empty(256, np.int64)
    side = np.empty((256, 3))      # per queued node, the sample's distance to its box along each axis
    bmin = np.full(3, np.inf)
    bmax = np.full(3, -np.inf)
    for i in range(P.shape[0]):
        for k in range(3):
            bmin[k] = min(bmin[k], P[i, k])
            bmax[k] = max(bmax[k], P[i, k])
    x = np.empty(3)
    ties = np.empty(_MAX_TIES, np.int64)
    for r in range(r0, m):
        rb = bound[ent[r]]
        h = length[r] / J
        for c in range(J):
            s = s0[r] + length[r] * frac[c]
            # only a vertex within the sample's slack plus the largest edge
            # can be a landing (a margin over that radius: a wider search
            # only costs time)
            tol = h + slack * (s - s0[r])
            rc = min(rb, (tol + emax) * (1.0 + 1e-9))
            rb2 = rc * rc
            ks = kap[r] * s
            a = s * _sinc(ks / np.pi)
            sc = _sinc(ks / (2 * np.pi))
            bq = 0.5 * kap[r] * (s * s) * (sc * sc)
            for k in range(3):
                x[k] = U[r, k] + a * T[r, k] + bq * N[r, k]
            # the rim vertices nearest the sample and nearer than the bound
            # (cKDTree's squared distance, summed in its order); a box's
            # squared distance, summed in that order from per-axis
            # distances that round no higher than a point's, is no more
            # than any of its points'
            best = np.inf
            nt = 0
            stack[0] = 0
            for k in range(3):
                side[0, k] = max(0.0, bmin[k] - x[k], x[k] - bmax[k])
            ns = 1
            while ns:
                ns -= 1
                b = stack[ns]
                lb = side[ns, 0] * side[ns, 0] + side[ns, 1] * side[ns, 1] + side[ns, 2] * side[ns, 2]
                if lb > best or lb > rb2:
                    continue
                if axis[b] < 0:
                    for i in range(lo[b], hi[b]):
                        d0 = Q[i, 0] - x[0]
                        d1 = Q[i, 1] - x[1]
                        d2 = Q[i, 2] - x[2]
                        dd = d0 * d0 + d1 * d1 + d2 * d2
                        if dd > rb2 or dd > best:
                            continue
                        if dd < best:
                            best = dd
                            nt = 0
                        if nt == _MAX_TIES:
                            return 1, r
                        ties[nt] = order[i]
                        nt += 1
                    continue
                ax = axis[b]
                diff = x[ax] - split[b]
                if diff < 0:
                    near, far, gap = left[b], left[b] + 1, split[b] - x[ax]
                else:
                    near, far, gap = left[b] + 1, left[b], diff
                for k in range(3):
                    side[ns + 1, k] = side[ns, k]
                side[ns, ax] = max(side[ns, ax], gap)
                stack[ns] = far
                stack[ns + 1] = near
                ns += 2
            if nt == 0:
                continue
            d = np.sqrt(best)
            if not d < rb:
                continue
            bj = ties[0]
            if nt > 1:
                # cKDTree keeps one of the vertices at the same distance:
                # of points at one place, the first in its leaf order
                # (rank); vertices that decide alike need no choice
                key = _arc_key(bj, r, owner, place, arow, krow, irow, skip)
                alike = True
                same = True
                for t in range(1, nt):
                    j = ties[t]
                    alike &= _arc_key(j, r, owner, place, arow, krow, irow, skip) == key
                    same &= P[j, 0] == P[bj, 0] and P[j, 1] == P[bj, 1] and P[j, 2] == P[bj, 2]
                if not alike:
                    if not same:
                        return 1, r
                    if rank.size == 0:
                        return 3, r
                    for t in range(1, nt):
                        if rank[ties[t]] < rank[bj]:
                            bj = ties[t]
            who = owner[bj]
            if not d <= tol + edge[who]:
                continue
            if _arc_key(bj, r, owner, place, arow, krow, irow, skip) & 1:
                continue
            landed[r] = who
            break
    return 0, m


def arc_landings(U, T, N, kap, s0, length, n_samples, slack, ent, nent, P, owner, place, edge, arow, krow, irow,
                 skip, rank_of=None):
    """The loop each continuation arc lands on first
    (:func:`shellrepair.bridge.loop_sights`' walk along the arcs, the
    NumPy version :func:`shellrepair.bridge._landings_numpy` its oracle),
    arc by arc and sample by sample, each sample looked up in a k-d tree
    of the rim vertices.

    A sample lands on its nearest rim vertex (the squared distance summed
    as SciPy's ``cKDTree`` sums it) when that vertex is nearer than its
    loop's bound and within the sample's slack plus the target's mean
    edge, and is not the arc's own start. Of several vertices at the same
    distance that would decide differently, ``cKDTree`` keeps the first in
    its own leaf order: for vertices at one place (a vertex shared by
    touching loops) that order is read from a ``cKDTree`` of ``P``, built
    by ``rank_of(P)`` when first needed; vertices at different places at
    the same distance that decide differently give status 1.

    Parameters
    ----------
    U, T, N : (m,3) float64
        The arcs' base points, unit tangents and normals.
    kap, s0, length : (m,) float64
        Curvatures, base-to-rim lengths and lengths followed.
    n_samples : int
        Samples per arc, at ``s0 + length * (1..n_samples) / n_samples``.
    slack : float
        Lateral slack per unit of arc length.
    ent : (m,) int64
        Each arc's followed loop (0..nent-1): the loop's bound is the
        largest slack of its arcs' samples plus the largest ``edge``.
    nent : int
    P : (p,3) float64
        Rim vertices of every loop, loop after loop.
    owner, place : (p,) int64
        Each rim vertex's loop and position along it.
    edge : (L,) float64
        Loops' mean edge lengths.
    arow, krow, irow : (m,) int64
        Each arc's loop, that loop's vertex count and the arc's vertex.
    skip : int
        Rim vertices this many steps from the arc's own are its start.
    rank_of : callable, optional
        ``rank_of(P)`` -> (p,) int64, each vertex's position in the leaf
        order of ``cKDTree(P)``; without it such ties give status 1.

    Returns
    -------
    landed : (m,) int64
        The loop each arc lands on first, -1 for none.
    status : int
        0; 1 where a tie the kernel cannot decide was met, 2 where an
        operand is not finite (``landed`` is then unusable).
    """
    f = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    i = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    frac = np.arange(1, int(n_samples) + 1) / int(n_samples)
    args = (f(U).reshape(-1, 3), f(T).reshape(-1, 3), f(N).reshape(-1, 3), f(kap), f(s0), f(length), frac,
            float(slack), i(ent), int(nent), f(P).reshape(-1, 3), i(owner), i(place), f(edge), i(arow), i(krow),
            i(irow), int(skip))
    landed = np.full(len(args[0]), -1, np.int64)
    status, r = _arc_landings(*args, np.zeros(0, np.int64), landed, 0)
    if status == 3:
        if rank_of is None:
            return landed, 1
        status, r = _arc_landings(*args, i(rank_of(args[10])), landed, r)
    return landed, status


@njit(cache=True, nogil=True)
def _angle_parts(u, v):
    m = u.shape[0]
    cr = np.empty(m)
    dt = np.empty(m)
    for r in range(m):
        c0 = u[r, 1] * v[r, 2] - u[r, 2] * v[r, 1]
        c1 = u[r, 2] * v[r, 0] - u[r, 0] * v[r, 2]
        c2 = u[r, 0] * v[r, 1] - u[r, 1] * v[r, 0]
        cr[r] = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        dt[r] = 0.0 + u[r, 0] * v[r, 0] + u[r, 1] * v[r, 1] + u[r, 2] * v[r, 2]   # from 0.0, as np.sum
    return cr, dt


def angle_parts(u, v):
    """The two arguments of :func:`shellrepair.refine._angle`'s arctan2:
    ``|u × v|`` and ``u · v`` per row, as its NumPy products and sums
    give them (the arctan2 stays NumPy's).

    Parameters
    ----------
    u, v : (m,3) float64

    Returns
    -------
    cr, dot : (m,) float64
    """
    return _angle_parts(np.ascontiguousarray(u, np.float64), np.ascontiguousarray(v, np.float64))


@njit(cache=True, nogil=True)
def _cross_row(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, nogil=True)
def _unfolded(pa, pb, pc, pd):
    m = pa.shape[0]
    out = np.empty(m, np.bool_)
    for r in range(m):
        a0, a1, a2 = pa[r, 0], pa[r, 1], pa[r, 2]
        b0, b1, b2 = pb[r, 0], pb[r, 1], pb[r, 2]
        c0, c1, c2 = pc[r, 0], pc[r, 1], pc[r, 2]
        d0, d1, d2 = pd[r, 0], pd[r, 1], pd[r, 2]
        x0, x1, x2 = _cross_row(b0 - a0, b1 - a1, b2 - a2, c0 - a0, c1 - a1, c2 - a2)
        y0, y1, y2 = _cross_row(a0 - b0, a1 - b1, a2 - b2, d0 - b0, d1 - b1, d2 - b2)
        n0, n1, n2 = x0 + y0, x1 + y1, x2 + y2
        m0, m1, m2 = _cross_row(a0 - c0, a1 - c1, a2 - c2, d0 - c0, d1 - c1, d2 - c2)
        k0, k1, k2 = _cross_row(b0 - d0, b1 - d1, b2 - d2, c0 - d0, c1 - d1, c2 - d2)
        out[r] = (m0 * n0 + m1 * n1 + m2 * n2 > 0) and (k0 * n0 + k1 * n1 + k2 * n2 > 0)
    return out


def unfolded(pa, pb, pc, pd):
    """:func:`shellrepair.refine._unfolded` compiled: would flipping edge
    a-b of triangles (a,b,c), (b,a,d) to c-d keep both new triangles
    facing the way the old pair faced? The same products and sums.

    Parameters
    ----------
    pa, pb, pc, pd : (m,3) float64

    Returns
    -------
    ok : (m,) bool
    """
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    return _unfolded(c(pa), c(pb), c(pc), c(pd))


@njit(cache=True, nogil=True)
def _split_test(P, Tr, s, alpha):
    r = Tr.shape[0]
    C = np.empty((r, 3))
    sc = np.empty(r)
    split = np.empty(r, np.bool_)
    for i in range(r):
        a, b, c = Tr[i, 0], Tr[i, 1], Tr[i, 2]
        for k in range(3):
            C[i, k] = (P[a, k] + P[b, k] + P[c, k]) / 3.0
        sc[i] = (s[a] + s[b] + s[c]) / 3.0
        ok = True
        for v in (a, b, c):
            e0, e1, e2 = C[i, 0] - P[v, 0], C[i, 1] - P[v, 1], C[i, 2] - P[v, 2]
            d = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2) * alpha
            if not (d > sc[i] and d > s[v]):
                ok = False
        split[i] = ok
    return C, sc, split


def split_test(P, Tr, s, alpha):
    """The refinement's split test (:func:`shellrepair.refine._refine`):
    each triangle's centroid ``C`` and mean scale ``sc``, and whether
    ``alpha`` times the centroid's distance to every corner exceeds both
    ``sc`` and the corner's scale; NumPy's means and norms, the same sums.

    Parameters
    ----------
    P : (n,3) float64
    Tr : (r,3) int64
    s : (n,) float64
    alpha : float

    Returns
    -------
    C : (r,3) float64, sc : (r,) float64, split : (r,) bool
    """
    return _split_test(np.ascontiguousarray(P, np.float64), np.ascontiguousarray(Tr, np.int64),
                       np.ascontiguousarray(s, np.float64), float(alpha))


@njit(cache=True, nogil=True)
def _nan_max(x, y):
    # np.maximum of two floats: the first where it is NaN or not smaller (NaN propagates)
    return x if (x >= y or x != x) else y


@njit(cache=True, nogil=True)
def _clip_unit(d):
    # np.clip(d, -1.0, 1.0): NaN stays NaN
    if d < -1.0:
        return -1.0
    if d > 1.0:
        return 1.0
    return d


@njit(cache=True, nogil=True)
def _sorts_before(x, y):
    # x strictly before y in NumPy's sort order of floats (NaN last)
    return x < y or (y != y and x == x)


@njit(cache=True, nogil=True)
def _centred_area(P):
    k = P.shape[0]
    m0 = m1 = m2 = 0.0
    for i in range(k):
        m0 += P[i, 0]
        m1 += P[i, 1]
        m2 += P[i, 2]
    m0, m1, m2 = m0 / k, m1 / k, m2 / k
    C = np.empty((k, 3))
    for i in range(k):
        C[i, 0], C[i, 1], C[i, 2] = P[i, 0] - m0, P[i, 1] - m1, P[i, 2] - m2
    s0 = s1 = s2 = 0.0
    for i in range(k):
        j = i + 1 if i + 1 < k else 0
        s0 += C[i, 1] * C[j, 2] - C[i, 2] * C[j, 1]
        s1 += C[i, 2] * C[j, 0] - C[i, 0] * C[j, 2]
        s2 += C[i, 0] * C[j, 1] - C[i, 1] * C[j, 0]
    va = np.empty(3)
    va[0], va[1], va[2] = -0.5 * s0, -0.5 * s1, -0.5 * s2
    return C, va


def centred_area(P):
    """The loop ``P`` about its mean and minus its vector area, as
    :func:`shellrepair.triangulate.triangulate_loop` computes them
    (``C = P - P.mean(axis=0)``, ``-0.5 * cross(C, C rolled by -1).sum(axis=0)``):
    NumPy sums a C-ordered array's columns row after row from 0.0, and so
    does this.

    Parameters
    ----------
    P : (k,3) float64, C-ordered (the caller's NumPy would sum an
        F-ordered one pairwise)

    Returns
    -------
    C : (k,3) float64
    va : (3,) float64
    """
    return _centred_area(np.ascontiguousarray(P, np.float64))


@njit(cache=True, nogil=True)
def _outline_cross(Q, S, P):
    S = _inside_outline(Q, S)
    raw = np.empty((S.shape[0], 3))
    for t in range(S.shape[0]):
        i0, i1, i2 = S[t, 0], S[t, 1], S[t, 2]
        a0, a1, a2 = P[i1, 0] - P[i0, 0], P[i1, 1] - P[i0, 1], P[i1, 2] - P[i0, 2]
        b0, b1, b2 = P[i2, 0] - P[i0, 0], P[i2, 1] - P[i0, 1], P[i2, 2] - P[i0, 2]
        raw[t, 0] = a1 * b2 - a2 * b1
        raw[t, 1] = a2 * b0 - a0 * b2
        raw[t, 2] = a0 * b1 - a1 * b0
    return S, raw


def outline_cross(Q, S, P):
    """:func:`inside_outline` and the kept triangles' cross products
    ``(P[b] - P[a]) × (P[c] - P[a])`` (the normal test of
    :func:`shellrepair.triangulate._delaunay_in_projection`, before its
    product with the axis, which stays NumPy's).

    Parameters
    ----------
    Q : (k,2) float64
    S : (t,3) int64
    P : (k,3) float64

    Returns
    -------
    S_in : (r,3) int64
    raw : (r,3) float64
    """
    return _outline_cross(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(S, np.int64),
                          np.ascontiguousarray(P, np.float64))


@njit(cache=True, nogil=True)
def _cover_free(S, n, k, fk):
    out, ok = _loop_cover(S, n, k)
    if not ok:
        return out, 1
    if fk.size:
        for t in range(out.shape[0]):
            for c in range(3):
                x, y = out[t, c], out[t, (c + 1) % 3]
                if _in_sorted(fk, min(x, y) * k + max(x, y)):
                    return out, 2
    return out, 0


def cover_free(S, n, k, fk):
    """:func:`loop_cover`, then whether an edge of the triangles joins a
    forbidden pair (:func:`shellrepair.triangulate._none_forbidden`).

    Parameters
    ----------
    S : (t,3) int64
    n : (t,) float64
    k : int
    fk : (f,) int64
        Sorted keys ``x·k + y`` of the forbidden pairs ``0 <= x < y < k``.

    Returns
    -------
    S_oriented : (t,3) int64
    status : int
        0 a cover without a forbidden edge; 1 not a cover; 2 a cover
        using a forbidden edge.
    """
    out, status = _cover_free(np.ascontiguousarray(S, np.int64), np.ascontiguousarray(n, np.float64), int(k),
                              np.ascontiguousarray(fk, np.int64))
    return out, int(status)


@njit(cache=True, nogil=True)
def _tet_faces(S, n):
    t = S.shape[0]
    first = np.empty(4 * t, np.int64)       # each face's smallest corner
    rest = np.empty(4 * t, np.int64)        # and b·n + c of the other two
    v = np.empty(4, np.int64)
    for i in range(t):
        for c in range(4):              # the corners sorted (insertion)
            x = S[i, c]
            j = c
            while j > 0 and v[j - 1] > x:
                v[j] = v[j - 1]
                j -= 1
            v[j] = x
        first[4 * i], rest[4 * i] = v[0], v[1] * n + v[2]
        first[4 * i + 1], rest[4 * i + 1] = v[0], v[1] * n + v[3]
        first[4 * i + 2], rest[4 * i + 2] = v[0], v[2] * n + v[3]
        first[4 * i + 3], rest[4 * i + 3] = v[1], v[2] * n + v[3]
    # the keys (a·n + b)·n + c in order: by a (counting sort), then by b·n + c
    start = np.zeros(n + 1, np.int64)
    for i in range(4 * t):
        start[first[i] + 1] += 1
    for a in range(n):
        start[a + 1] += start[a]
    fill = start[:n].copy()
    srt = np.empty(4 * t, np.int64)
    for i in range(4 * t):
        srt[fill[first[i]]] = rest[i]
        fill[first[i]] += 1
    m = 0
    D = np.empty((4 * t, 3), np.int64)
    for a in range(n):
        seg = srt[start[a]:start[a + 1]]
        if seg.size > 16:
            seg.sort()
        else:
            for p in range(1, seg.size):
                x = seg[p]
                j = p
                while j > 0 and seg[j - 1] > x:
                    seg[j] = seg[j - 1]
                    j -= 1
                seg[j] = x
        for p in range(seg.size):
            if p == 0 or seg[p] != seg[p - 1]:
                D[m, 0], D[m, 1], D[m, 2] = a, seg[p] // n, seg[p] % n
                m += 1
    return D[:m].copy()


def tet_faces(S, n):
    """The triangles of tetrahedra ``S`` over ``n`` points, each once,
    corners ascending, ordered by their key ``(a·n + b)·n + c``
    (:func:`shellrepair.triangulate.delaunay_faces`'s sort, faces and
    ``np.unique``).

    Parameters
    ----------
    S : (t,4) int
        Corners in ``[0, n)``.
    n : int

    Returns
    -------
    D : (f,3) int64
    """
    return _tet_faces(np.ascontiguousarray(S, np.int64), int(n))


@njit(cache=True, nogil=True)
def _loop_edges_present(D, k):
    seen = np.zeros(k, np.bool_)
    for i in range(D.shape[0]):
        a, b, c = D[i, 0], D[i, 1], D[i, 2]
        for p, q in ((a, b), (b, c), (a, c)):
            if p < 0 or p >= k or q < 0 or q >= k:
                return seen, False
            if q == p + 1:
                seen[p] = True
            if p == 0 and q == k - 1:
                seen[k - 1] = True
    return seen, True


def loop_edges_present(D, k):
    """Which loop edges ``(i, i+1)`` (and ``(0, k-1)`` last) are an edge
    ``(a, b)``, ``(b, c)`` or ``(a, c)`` of some row of ``D``
    (:func:`shellrepair.triangulate._with_loop_edges`'s ``np.isin``).

    Parameters
    ----------
    D : (t,3) int64
    k : int

    Returns
    -------
    seen : (k,) bool
    ok : bool
        False when a corner is outside ``[0, k)`` (``seen`` is then not
        complete: its keys could alias, the caller's NumPy decides).
    """
    return _loop_edges_present(np.ascontiguousarray(D, np.int64), int(k))


@njit(cache=True, nogil=True)
def _forbidden_chord(p, q, k, fk):
    # (p, q) is a chord (not a loop edge) and forbidden (restricted_dp's np.isin)
    return q - p > 1 and not (p == 0 and q == k - 1) and _in_sorted(fk, p * k + q)


@njit(cache=True, nogil=True)
def _restricted_prepare(P, cand, fk):
    k = P.shape[0]
    m0 = cand.shape[0]
    keep = np.empty(m0, np.int64)
    m = 0
    for r in range(m0):
        x, y, z = cand[r, 0], cand[r, 1], cand[r, 2]
        if not (x < y and y < z):
            continue
        if fk.size and (_forbidden_chord(x, y, k, fk) or _forbidden_chord(y, z, k, fk)
                        or _forbidden_chord(x, z, k, fk)):
            continue
        if x < 0 or z >= k:     # an index NumPy would wrap or reject: the caller's NumPy decides
            e = np.empty(0, np.int64)
            return e, e, e, e, e, e, 0, e, -1, np.empty((0, 3)), np.empty((0, 3)), np.empty(0, np.bool_), \
                np.empty(0), 1
        keep[m] = r
        m += 1
    a = np.empty(m, np.int64)
    b = np.empty(m, np.int64)
    c = np.empty(m, np.int64)
    for q in range(m):
        a[q], b[q], c[q] = cand[keep[q], 0], cand[keep[q], 1], cand[keep[q], 2]
    # edge ids: the loop edges (i, i+1), the interval (0, k-1), the candidates'
    # (a, b), (b, c), (a, c); bucketed by first corner, each (i, j) one id
    ne_all = k + 3 * m
    ei = np.empty(ne_all, np.int64)
    ej = np.empty(ne_all, np.int64)
    for i in range(k - 1):
        ei[i], ej[i] = i, i + 1
    ei[k - 1], ej[k - 1] = 0, k - 1
    for q in range(m):
        s = k + 3 * q
        ei[s], ej[s] = a[q], b[q]
        ei[s + 1], ej[s + 1] = b[q], c[q]
        ei[s + 2], ej[s + 2] = a[q], c[q]
    start = np.zeros(k + 1, np.int64)
    for s in range(ne_all):
        start[ei[s] + 1] += 1
    for i in range(k):
        start[i + 1] += start[i]
    fill = start[:k].copy()
    rows = np.empty(ne_all, np.int64)
    for s in range(ne_all):
        rows[fill[ei[s]]] = s
        fill[ei[s]] += 1
    stamp = np.full(k, -1, np.int64)
    idof = np.empty(k, np.int64)
    eid = np.empty(ne_all, np.int64)
    ne = 0
    for i in range(k):
        for p in range(start[i], start[i + 1]):
            s = rows[p]
            j = ej[s]
            if stamp[j] != i:
                stamp[j] = i
                idof[j] = ne
                ne += 1
            eid[s] = idof[j]
    base = eid[:k - 1].copy()
    top = eid[k - 1]
    el = np.empty(m, np.int64)
    er = np.empty(m, np.int64)
    et = np.empty(m, np.int64)
    for q in range(m):
        s = k + 3 * q
        el[q], er[q], et[q] = eid[s], eid[s + 1], eid[s + 2]
    # triangle (a, c, b): raw normal cross(P[c] - P[a], P[b] - P[a]), unit normal, area
    raw = np.empty((m, 3))
    n = np.empty((m, 3))
    nz = np.empty(m, np.bool_)
    area = np.empty(m)
    for q in range(m):
        ia, ib, ic = a[q], b[q], c[q]
        u0, u1, u2 = P[ic, 0] - P[ia, 0], P[ic, 1] - P[ia, 1], P[ic, 2] - P[ia, 2]
        v0, v1, v2 = P[ib, 0] - P[ia, 0], P[ib, 1] - P[ia, 1], P[ib, 2] - P[ia, 2]
        r0 = u1 * v2 - u2 * v1
        r1 = u2 * v0 - u0 * v2
        r2 = u0 * v1 - u1 * v0
        raw[q, 0], raw[q, 1], raw[q, 2] = r0, r1, r2
        ln = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        nz[q] = ln > 0
        d = ln if ln > 0 else 1.0
        n[q, 0], n[q, 1], n[q, 2] = r0 / d, r1 / d, r2 / d
        area[q] = 0.5 * ln
    return a, b, c, el, er, et, ne, base, top, raw, n, nz, area, 0


def restricted_prepare(P, cand, fk):
    """The candidates of :func:`shellrepair.triangulate.restricted_dp` and
    their edges and geometry (its NumPy setup, the same products): the
    candidates kept (``a < b < c``, no chord in ``fk``), their edges
    ``(a, b)``, ``(b, c)``, ``(a, c)`` as ids (any numbering, one id per
    edge: the search reads them only as names), and each triangle
    ``(a, c, b)``'s cross product, unit normal and area.

    Parameters
    ----------
    P : (k,3) float64
    cand : (t,3) int64
    fk : (f,) int64
        Sorted keys ``x·k + y`` of the forbidden pairs.

    Returns
    -------
    a, b, c, el, er, et : (m,) int64
    ne : int
        Number of edge ids.
    base : (k-1,) int64
        The loop edges' ids.
    top : int
        The id of the interval ``(0, k-1)``.
    raw, n : (m,3) float64, nz : (m,) bool, area : (m,) float64
    status : int
        0; 1 when a kept candidate has a corner outside ``[0, k)`` (nothing
        else returned then).
    """
    out = _restricted_prepare(np.ascontiguousarray(P, np.float64), np.ascontiguousarray(cand, np.int64),
                              np.ascontiguousarray(fk, np.int64))
    return out[:6] + (int(out[6]), out[7], int(out[8])) + out[9:13] + (int(out[13]),)


@njit(cache=True, nogil=True)
def _restricted_search(k, a, b, c, el, er, et, ne, base, edge_normals, n, nz, area, bad0, top, tie):
    m = b.shape[0]
    inf = np.inf
    WA = np.full(ne, inf)
    WS = np.full(ne, inf)
    N = np.zeros((ne, 3))
    HN = np.zeros(ne, np.bool_)
    sel = np.full(ne, -1, np.int64)        # each solved interval's candidate
    best = np.full(ne, inf)                # the least finite worst cost among its candidates
    sws = np.full(ne, inf)                 # the chosen candidate's area (inf where past the tie)
    for i in range(k - 1):
        e = base[i]
        WA[e] = 0.0
        WS[e] = 0.0
        x, y, z = edge_normals[i, 0], edge_normals[i, 1], edge_normals[i, 2]
        N[e, 0] = x
        N[e, 1] = y
        N[e, 2] = z
        HN[e] = abs(x) + abs(y) + abs(z) > 0
    r0, r1, r2 = edge_normals[k - 1, 0], edge_normals[k - 1, 1], edge_normals[k - 1, 2]
    has_close = abs(r0) + abs(r1) + abs(r2) > 0
    rim_zero = r0 == 0 and r1 == 0 and r2 == 0
    # candidates by length c - a, stable (np.argsort(L, kind="stable") and its groups)
    start = np.zeros(k + 1, np.int64)
    for i in range(m):
        start[c[i] - a[i] + 1] += 1
    for s in range(k):
        start[s + 1] += start[s]
    fill = start[:k].copy()
    order = np.empty(m, np.int64)
    for i in range(m):
        s = c[i] - a[i]
        order[fill[s]] = i
        fill[s] += 1
    wa = np.empty(m)
    ws = np.empty(m)
    for length in range(2, k):
        q0, q1 = start[length], start[length + 1]
        # worst cost and area of each candidate, on the shorter intervals el, er
        for q in range(q0, q1):
            i = order[q]
            l, r, t = el[i], er[i], et[i]
            n0, n1, n2 = n[i, 0], n[i, 1], n[i, 2]
            d1 = _clip_unit(n0 * N[l, 0] + n1 * N[l, 1] + n2 * N[l, 2])
            d2 = _clip_unit(n0 * N[r, 0] + n1 * N[r, 1] + n2 * N[r, 2])
            a1 = ((1.0 - d1) if nz[i] else 2.0) if HN[l] else 0.0
            a2 = ((1.0 - d2) if nz[i] else 2.0) if HN[r] else 0.0
            w = _nan_max(_nan_max(a1, a2), _nan_max(WA[l], WA[r]))
            if has_close and t == top:      # the closing edge's scan face (triangulate._angle)
                if (n0 == 0 and n1 == 0 and n2 == 0) or rim_zero:
                    g = 2.0
                else:
                    g = 1.0 - _clip_unit(n0 * r0 + n1 * r1 + n2 * r2)
                w = _nan_max(w, g)
            if bad0[i]:
                w = inf
            wa[q] = w
            ws[q] = area[i] + WS[l] + WS[r]
            if np.isfinite(w) and w < best[t]:
                best[t] = w
        # per interval: the least area within ANGLE_TIE of the best cost, the first of equals
        for q in range(q0, q1):
            w = wa[q]
            if not np.isfinite(w):
                continue
            i = order[q]
            t = et[i]
            s = ws[q] if w <= best[t] + tie else inf
            if sel[t] < 0 or _sorts_before(s, sws[t]):
                sel[t] = i
                sws[t] = s
        for q in range(q0, q1):
            i = order[q]
            t = et[i]
            if sel[t] == i:
                WA[t] = wa[q]
                WS[t] = sws[t]
                N[t, 0] = n[i, 0]
                N[t, 1] = n[i, 1]
                N[t, 2] = n[i, 2]
                HN[t] = nz[i]
    T = np.empty((max(k - 2, 0), 3), np.int64)
    if not np.isfinite(WA[top]):
        return T[:0], 1, 0, k - 1
    # the triangles, depth first as restricted_dp's stack pops them
    stack = np.empty((2 * k + 2, 3), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, k - 1, top
    sp = 1
    nt = 0
    while sp > 0:
        sp -= 1
        i, j, e = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        if j - i < 2:
            continue
        s = sel[e]
        if s < 0 or nt >= T.shape[0]:
            return T[:nt], 2, i, j
        mm = b[s]
        T[nt, 0], T[nt, 1], T[nt, 2] = i, j, mm
        nt += 1
        stack[sp, 0], stack[sp, 1], stack[sp, 2] = i, mm, el[s]
        stack[sp + 1, 0], stack[sp + 1, 1], stack[sp + 1, 2] = mm, j, er[s]
        sp += 2
    return T[:nt], 0, 0, 0


def restricted_search(k, a, b, c, el, er, et, ne, base, edge_normals, n, nz, area, bad0, top, tie):
    """The group loop and the read-back of
    :func:`shellrepair.triangulate.restricted_dp` (its NumPy form
    :func:`shellrepair.triangulate._restricted_dp_numpy`): intervals by
    increasing length, each closed by the candidate of least worst
    dihedral cost, the least area among costs within ``tie`` of it (the
    first of equal areas, as ``np.lexsort`` orders them), with the same
    products, clips and maxima.

    Parameters
    ----------
    k : int
        Loop length.
    a, b, c : (m,) int64
        The candidates' sorted corners.
    el, er, et : (m,) int64
        Their edges ``(a, b)``, ``(b, c)``, ``(a, c)`` as ids into the ``ne``
        edge keys.
    ne : int
    base : (k-1,) int64
        The ids of the loop edges ``(i, i+1)``.
    edge_normals : (k,3) float64
        Rim normals (zero rows unknown).
    n : (m,3) float64, nz : (m,) bool, area : (m,) float64, bad0 : (m,) bool
        The candidates' unit normals, whether they are not degenerate, their
        areas, and whether they face against the axis.
    top : int
        The id of the interval ``(0, k-1)``.
    tie : float
        ``ANGLE_TIE``.

    Returns
    -------
    T : (k-2,3) int64
        Triangles ``(i, j, apex)`` in the read-back's order (fewer on failure).
    status : int
        0; 1 when no triangulation uses only the candidates; 2 when the
        interval ``(i, j)`` has no apex.
    i, j : int
    """
    ci = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    cf = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    cb = lambda x: np.ascontiguousarray(x, np.bool_)  # noqa: E731
    T, status, i, j = _restricted_search(int(k), ci(a), ci(b), ci(c), ci(el), ci(er), ci(et), int(ne), ci(base),
                                         cf(edge_normals), cf(n), cb(nz), cf(area), cb(bad0), int(top), float(tie))
    return T, int(status), int(i), int(j)


@njit(cache=True, nogil=True)
def _liepa_tables(Q, rim, has_rim, forb, axis, use_axis, tie):
    k = Q.shape[0]
    inf = np.inf
    Qx = np.ascontiguousarray(Q[:, 0])
    Qy = np.ascontiguousarray(Q[:, 1])
    Qz = np.ascontiguousarray(Q[:, 2])
    # the tables by interval (i, j), and a copy by (j, i): the apex loop
    # reads edge (i, m) from a row and edge (m, j) from a row of the copy;
    # the normals as three planes, so that both loops over the apexes read
    # (and the first one vectorises) along rows
    WA = np.full((k, k), inf)
    WS = np.full((k, k), inf)
    WAc = np.full((k, k), inf)
    WSc = np.full((k, k), inf)
    Nx, Ny, Nz = np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k))
    Ncx, Ncy, Ncz = np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k))
    HN = np.zeros((k, k), np.bool_)
    HNc = np.zeros((k, k), np.bool_)
    forbc = np.ascontiguousarray(forb.T)
    O = np.full((k, k), -1, np.int64)
    for i in range(k - 1):
        WA[i, i + 1] = 0.0
        WS[i, i + 1] = 0.0
        WAc[i + 1, i] = 0.0
        WSc[i + 1, i] = 0.0
        if has_rim[i]:
            Nx[i, i + 1], Ny[i, i + 1], Nz[i, i + 1] = rim[i, 0], rim[i, 1], rim[i, 2]
            Ncx[i + 1, i], Ncy[i + 1, i], Ncz[i + 1, i] = rim[i, 0], rim[i, 1], rim[i, 2]
        h = has_rim[i] and (rim[i, 0] != 0 or rim[i, 1] != 0 or rim[i, 2] != 0)
        HN[i, i + 1] = h
        HNc[i + 1, i] = h
    c0, c1, c2 = rim[k - 1, 0], rim[k - 1, 1], rim[k - 1, 2]
    close_zero = (abs(c0) + abs(c1)) + abs(c2) == 0
    ax0, ax1, ax2 = axis[0], axis[1], axis[2]
    wa = np.empty(k)
    ws = np.empty(k)
    n0s, n1s, n2s = np.empty(k), np.empty(k), np.empty(k)
    ar = np.empty(k)
    axd = np.empty(k)
    nzs = np.empty(k, np.bool_)
    for L in range(2, k):
        for i in range(k - L):
            j = i + L
            n = L - 1
            q0, q1, q2 = Qx[i], Qy[i], Qz[i]
            a0, a1, a2 = Qx[j] - q0, Qy[j] - q1, Qz[j] - q2
            fij = forb[i, j]
            # each apex m = i + 1 + t: the triangle (i, j, m)'s unit normal and area
            for t in range(n):
                m = i + 1 + t
                b0, b1, b2 = Qx[m] - q0, Qy[m] - q1, Qz[m] - q2
                r0 = a1 * b2 - a2 * b1            # geometry.cross(Q[j] - Q[i], Q[m] - Q[i])
                r1 = a2 * b0 - a0 * b2
                r2 = a0 * b1 - a1 * b0
                ln = np.sqrt((r0 * r0 + r1 * r1) + r2 * r2)
                nz = ln > 0
                d = ln if nz else 1.0
                n0s[t], n1s[t], n2s[t] = r0 / d, r1 / d, r2 / d
                ar[t] = 0.5 * ln
                nzs[t] = nz
                axd[t] = (r0 * ax0 + r1 * ax1) + r2 * ax2
            # its worst dihedral cost and total area (selects: np.clip, np.maximum with NaN first)
            for t in range(n):
                m = i + 1 + t
                n0, n1, n2 = n0s[t], n1s[t], n2s[t]
                nz = nzs[t]
                d1 = (n0 * Nx[i, m] + n1 * Ny[i, m]) + n2 * Nz[i, m]
                d1 = -1.0 if d1 < -1.0 else (1.0 if d1 > 1.0 else d1)
                d2 = (n0 * Ncx[j, m] + n1 * Ncy[j, m]) + n2 * Ncz[j, m]
                d2 = -1.0 if d2 < -1.0 else (1.0 if d2 > 1.0 else d2)
                e1 = ((1.0 - d1) if nz else 2.0) if HN[i, m] else 0.0
                e2 = ((1.0 - d2) if nz else 2.0) if HNc[j, m] else 0.0
                x = e1 if ((e1 >= e2) | (e1 != e1)) else e2
                u, v = WA[i, m], WAc[j, m]
                y = u if ((u >= v) | (u != u)) else v
                w = x if ((x >= y) | (x != x)) else y
                bad = forb[i, m] | forbc[j, m] | fij | (use_axis & (axd[t] <= 0))
                wa[t] = inf if bad else w
                ws[t] = (ar[t] + WS[i, m]) + WSc[j, m]
            if L == k - 1 and has_rim[k - 1]:    # the closing edge's scan face (triangulate._angle)
                for t in range(n):
                    if wa[t] == inf:
                        continue
                    n0, n1, n2 = n0s[t], n1s[t], n2s[t]
                    if close_zero or (abs(n0) + abs(n1)) + abs(n2) == 0:
                        g = 2.0
                    else:
                        g = 1.0 - _clip_unit((n0 * c0 + n1 * c1) + n2 * c2)
                    wa[t] = _nan_max(wa[t], g)
            # np.min (NaN wins), then np.argmin of the areas within tie of it (first of equals, a NaN first)
            best = wa[0]
            for t in range(1, n):
                if best != best:
                    break
                x = wa[t]
                if x < best or x != x:
                    best = x
            lim = best + tie
            sel = 0
            cur = ws[0] if wa[0] <= lim else inf
            for t in range(1, n):
                if cur != cur:
                    break
                x = ws[t] if wa[t] <= lim else inf
                if x < cur or x != x:
                    cur = x
                    sel = t
            WA[i, j] = wa[sel]
            WAc[j, i] = wa[sel]
            WS[i, j] = cur
            WSc[j, i] = cur
            O[i, j] = i + 1 + sel
            Nx[i, j], Ny[i, j], Nz[i, j] = n0s[sel], n1s[sel], n2s[sel]
            Ncx[j, i], Ncy[j, i], Ncz[j, i] = n0s[sel], n1s[sel], n2s[sel]
            HN[i, j] = nzs[sel]
            HNc[j, i] = nzs[sel]
    return O, WA[0, k - 1]


def liepa_tables(Q, rim, has_rim, forb, axis, tie):
    """The tables of :func:`shellrepair.triangulate._dp` (Liepa's O(k³)
    dynamic program), with its products, clips, maxima and first-of-equals
    choices, one interval at a time.

    Parameters
    ----------
    Q : (k,3) float64
        The sub-loop's positions.
    rim : (k,3) float64, has_rim : (k,) bool
        The scan face's normal across sub-loop edge ``(i, i+1)`` (``(k-1,
        0)`` last) and whether there is one.
    forb : (k,k) bool
        Forbidden chords ``(i, j)``, ``i < j``.
    axis : (3,) float64 or None
        Every triangle must face along it (``cross · axis > 0``).
    tie : float
        ``ANGLE_TIE``.

    Returns
    -------
    O : (k,k) int64
        The apex closing each interval ``(i, j)``.
    worst : float
        The whole loop's worst dihedral cost (inf: no triangulation).
    """
    use = axis is not None
    ax = np.ascontiguousarray(axis if use else np.zeros(3), np.float64).reshape(3)
    O, worst = _liepa_tables(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(rim, np.float64),
                             np.ascontiguousarray(has_rim, np.bool_), np.ascontiguousarray(forb, np.bool_), ax,
                             use, float(tie))
    return O, float(worst)


@njit(cache=True, nogil=True)
def _chord_rows(Q, q, fk):
    k = Q.shape[0]
    best = np.inf
    bi, bj, ties = -1, -1, 0
    for i in range(k - q):
        x, y, z = Q[i, 0], Q[i, 1], Q[i, 2]
        dmin = np.inf
        jmin, count = -1, 0
        for j in range(i + q, min(k, i + k - q + 1)):
            if fk.size and _in_sorted(fk, i * k + j):
                continue
            dx, dy, dz = Q[j, 0] - x, Q[j, 1] - y, Q[j, 2] - z
            d = np.sqrt((dx * dx + dy * dy) + dz * dz)     # np.linalg.norm(..., axis=1)
            if d < dmin:
                dmin, jmin, count = d, j, 1
            elif d == dmin:
                count += 1
        if jmin >= 0 and dmin < best:
            best, bi, bj, ties = dmin, i, jmin, count
    return bi, bj, ties


def chord_rows(Q, q, fk):
    """The row-by-row search of :func:`shellrepair.triangulate._best_chord_rows`:
    the row ``i`` whose nearest allowed partner ``j`` (``i + q <= j <=
    min(k - 1, i + k - q)``) is nearest overall, the first such row.

    Parameters
    ----------
    Q : (k,3) float64
        The sub-loop's positions.
    q : int
    fk : (f,) int64
        Sorted keys ``u·k + v`` (``u < v``) of the forbidden position pairs.

    Returns
    -------
    i, j : int
        ``i = -1`` when no row has an allowed partner; ``j`` the first of
        the row's nearest partners.
    ties : int
        How many partners of row ``i`` are that near (more than one: the
        row's pick is NumPy's argsort's, the caller's to make).
    """
    i, j, t = _chord_rows(np.ascontiguousarray(Q, np.float64), int(q), np.ascontiguousarray(fk, np.int64))
    return int(i), int(j), int(t)


# --------------------------------------------------------------------------
# the order test (shellrepair.selftest): its band's rings and split, the
# distances of points to their nearest triangles
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _ring_walk(verts, rings, vf_order, vf_start, F, vmark, fmark):
    # _ring_faces' walk, its faces kept in walk order with each ring's end
    marked = np.empty(max(verts.size, 16), np.int64)
    nm = 0
    front = np.empty(max(verts.size, 16), np.int64)
    nfr = 0
    for v in verts:
        if not vmark[v]:
            vmark[v] = True
            marked[nm] = v
            nm += 1
            front[nfr] = v
            nfr += 1
    R = max(1, rings)
    off = np.zeros(R + 1, np.int64)
    found = np.empty(max(64, 8 * verts.size), np.int64)
    nf = 0
    for r in range(R):
        need = nf
        for i in range(nfr):
            need += vf_start[front[i] + 1] - vf_start[front[i]]
        found = _room(found, need)
        f0 = nf
        nf = _ring_collect(front, nfr, vf_order, vf_start, fmark, found, nf)
        off[r + 1:] = nf
        marked = _room(marked, nm + 3 * (nf - f0))
        front = _room(front, 3 * (nf - f0))
        nm, nfr = _ring_expand(found, f0, nf, F, vmark, marked, nm, front)
        if nfr == 0:
            break
    for i in range(nm):
        vmark[marked[i]] = False
    for j in range(nf):
        fmark[found[j]] = False
    return found[:nf].copy(), off


def ring_walk(verts, rings, vf_order, vf_start, F, vmark, fmark):
    """:func:`ring_faces`' walk with every ring count up to ``rings`` in it:
    the faces in the order the walk finds them, ring by ring, and each
    ring's end, so that ``np.sort(faces[:off[r]])`` is ``ring_faces(verts,
    r, ...)`` for each ``1 <= r <= rings``.

    Parameters
    ----------
    verts, rings, vf_order, vf_start, F, vmark, fmark
        As in :func:`ring_faces`.

    Returns
    -------
    faces : (f,) int64
        In walk order.
    off : (max(rings, 1) + 1,) int64
        ``off[r]``: how many of ``faces`` lie within ``r`` rings (``off[0] = 0``).
    """
    return _ring_walk(np.ascontiguousarray(verts, np.int64), int(rings), vf_order, vf_start, F, vmark, fmark)


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
    :func:`shellrepair.distance._closest_on_triangles` and the norm after it,
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
