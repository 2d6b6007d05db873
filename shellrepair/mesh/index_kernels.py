"""Compiled kernels of the scan's index around a hole (:mod:`shellrepair.mesh.index`, Numba).

* :func:`faces_in_boxes`: the faces whose bounding boxes meet some boxes
  (the region of :class:`shellrepair.mesh.index._Region`), one pass over the
  vertices and one over the faces; :func:`boxes_meeting`: the region's
  near-face query;
* :func:`ring_faces`: the faces within some rings of a vertex set
  (:meth:`shellrepair.mesh.index.ScanContext.ring_faces`), and
  :func:`ring_walk`: the rings in one walk, each ring's end recorded (the
  order test's band); :func:`ring_walk_within`: the rings walked only
  within a reach of a point (the order test's region);
* :func:`submesh`: a hole's submesh in local numbering
  (:func:`shellrepair.mesh.index.submesh`); :func:`rim_sigma`: a patch's rim
  scale (:func:`shellrepair.mesh.index.rim_sigma`);
* :func:`rim_edges`: a loop's rim scale and scan normals from the faces
  around it (:func:`shellrepair.mesh.index.rim_data`), and :func:`rim_walk`:
  the same with the faces around the loop found and measured in one pass.

Each gives what its NumPy version gives, to the bit (tests/test_kernels.py,
tests/test_region.py). How the kernels are compiled and switched off:
:mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["faces_in_boxes", "ring_faces", "submesh", "rim_sigma", "rim_edges", "boxes_meeting", "rim_walk", "ring_walk",
           "ring_walk_within"]

from shellrepair import compiled
from shellrepair.mesh.common_kernels import _ring_collect

njit = compiled.kernel


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
def _first_front(verts, vmark):
    # A walk's first front: the distinct vertices of verts, marked; returns
    # (marked, front, count), both lists holding the same vertices.
    marked = np.empty(max(verts.size, 16), np.int64)
    front = np.empty(max(verts.size, 16), np.int64)
    n = 0
    for v in verts:
        if not vmark[v]:
            vmark[v] = True
            marked[n] = v
            front[n] = v
            n += 1
    return marked, front, n


@njit(cache=True, nogil=True)
def _front_faces(front, nfr, vf_start):
    # How many face entries the vertex-face lists of the front hold (the room a ring needs).
    need = 0
    for i in range(nfr):
        need += vf_start[front[i] + 1] - vf_start[front[i]]
    return need


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
    :meth:`shellrepair.mesh.index.ScanContext.ring_faces`).

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
    :func:`shellrepair.mesh.index.submesh`): the scan faces ``faces`` and the
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
    :func:`shellrepair.mesh.index.rim_sigma`).

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
    """The edge walk of :func:`shellrepair.mesh.index.rim_data`.

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
    lengths and unit normals as :func:`shellrepair.mesh.index._rim_faces` makes
    them, then the edge walk; the same four arrays."""
    return _rim_walk(np.ascontiguousarray(loop, np.int64), vf_order, vf_start,
                     np.ascontiguousarray(F, np.int64), np.ascontiguousarray(V, np.float64))


# --------------------------------------------------------------------------
# the rings around a loop in one walk (ring_faces, the order test's band)
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _ring_walk(verts, rings, vf_order, vf_start, F, vmark, fmark):
    # _ring_faces' walk, its faces kept in walk order with each ring's end
    marked, front, nm = _first_front(verts, vmark)
    nfr = nm
    R = max(1, rings)
    off = np.zeros(R + 1, np.int64)
    found = np.empty(max(64, 8 * verts.size), np.int64)
    nf = 0
    for r in range(R):
        found = _room(found, nf + _front_faces(front, nfr, vf_start))
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


# --------------------------------------------------------------------------
# the scan within reach of a hole, walked only within that reach (the order test's region)
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _ring_walk_within(verts, rings, vf_order, vf_start, F, V, c, reach2, vmark, fmark):
    # _ring_walk's rings, a face kept (and walked on from) only where a
    # corner lies within reach of c; the others marked, listed to be reset
    marked, front, nm = _first_front(verts, vmark)
    nfr = nm
    found = np.empty(max(64, 8 * verts.size), np.int64)
    nf = 0
    beyond = np.empty(64, np.int64)
    nb = 0
    for r in range(max(1, rings)):
        need = _front_faces(front, nfr, vf_start)
        found = _room(found, nf + need)
        beyond = _room(beyond, nb + need)
        f0 = nf
        for i in range(nfr):
            v = front[i]
            for p in range(vf_start[v], vf_start[v + 1]):
                f = vf_order[p] // 3
                if fmark[f]:
                    continue
                fmark[f] = True
                near = False
                for j in range(3):
                    w = F[f, j]
                    dx = V[w, 0] - c[0]
                    dy = V[w, 1] - c[1]
                    dz = V[w, 2] - c[2]
                    if dx * dx + dy * dy + dz * dz <= reach2:
                        near = True
                        break
                if near:
                    found[nf] = f
                    nf += 1
                else:
                    beyond[nb] = f
                    nb += 1
        marked = _room(marked, nm + 3 * (nf - f0))
        front = _room(front, 3 * (nf - f0))
        nm, nfr = _ring_expand(found, f0, nf, F, vmark, marked, nm, front)
        if nfr == 0:
            break
    for i in range(nm):
        vmark[marked[i]] = False
    for j in range(nf):
        fmark[found[j]] = False
    for j in range(nb):
        fmark[beyond[j]] = False
    out = found[:nf].copy()
    out.sort()
    return out


def ring_walk_within(verts, rings, vf_order, vf_start, F, V, c, reach, vmark, fmark):
    """The faces near ``verts`` within ``reach`` of ``c``, walked only within
    that reach: :func:`ring_walk`'s rings (at most ``rings``), each face
    kept, and its vertices walked on from, only where one of its corners
    lies within ``reach`` of ``c``. A face within reach that the walk
    reaches only through faces beyond it is not kept (the ring walk with
    the faces beyond reach dropped after it, which this walk replaced in
    the order test, kept it); on a scan of 10M faces that walk touched four
    times the faces it kept.

    Parameters
    ----------
    verts : (k,) int64
    rings : int
    vf_order, vf_start : int64 arrays
        Vertex-face lists complete at every vertex the walk reaches.
    F : (m,3) int64
    V : (n,3) float64
    c : (3,) float64
    reach : float
    vmark, fmark : bool arrays
        Scratch marks (all False; left all False).

    Returns
    -------
    faces : (f,) int64
        Sorted.
    """
    return _ring_walk_within(np.ascontiguousarray(verts, np.int64), int(rings), vf_order, vf_start, F,
                             np.ascontiguousarray(V, np.float64), np.ascontiguousarray(c, np.float64),
                             float(reach) * float(reach), vmark, fmark)
