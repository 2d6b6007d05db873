"""Compiled kernels of the order test's placements (:mod:`shellrepair.fill.probe`, Numba).

A test hole is placed around a scan vertex only where the scan within the
test hole's reach is intact: the faces within that reach joined to the
vertex's faces have no open edge close to it (else a hole or the scan's
border is near). Most placements tried end there (1722 of 2245 on eight
cases of eval's seed 408096311), and in NumPy each cost a centroid tree
query, a sort of the region's edges and a component labelling, a few
milliseconds of dispatch whatever the region's size.

* :func:`near_adjacency`: the faces near a hole, once for all their
  placements: each face's neighbour across each edge and each vertex's
  faces;
* :func:`placement`: one placement's region walked from the vertex's faces
  across shared edges, only as far as faces lie within reach, stopping at
  the first open edge close to the vertex;
* :func:`component_within`: the faces of a subset joined to some of them
  across shared edges;
* :func:`inside_polygon`: the even-odd test of points against an outline
  (:func:`shellrepair.fill.placement.inside_polygon_reference`, whose (points ×
  outline edges) arrays cost 1.3 ms a call on eval's cases).

Each gives what :func:`shellrepair.fill.placement.cut_test_hole`'s NumPy steps give
(the same faces, the same verdict; tests/test_selftest.py). How the
kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["near_adjacency", "placement", "placement_statuses", "component_within", "inside_polygon",
           "within_distance"]

from shellrepair import compiled

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _near_adjacency(lc, nv):
    m = lc.shape[0]
    cnt = np.zeros(nv + 1, np.int64)
    for f in range(m):
        for c in range(3):
            cnt[lc[f, c] + 1] += 1
    start = np.cumsum(cnt)
    fill = start[:-1].copy()
    pos = np.empty(3 * m, np.int64)
    for f in range(m):                 # faces in ascending order: each vertex's list ascending
        for c in range(3):
            v = lc[f, c]
            pos[fill[v]] = f
            fill[v] += 1
    across = np.full((m, 3), m, np.int64)
    ok = True
    for f in range(m):
        a0, a1, a2 = lc[f, 0], lc[f, 1], lc[f, 2]
        if a0 == a1 or a1 == a2 or a2 == a0:
            ok = False                 # a degenerate face: not a plain surface
            break
        for j in range(3):
            a = lc[f, j]
            b = lc[f, (j + 1) % 3]
            found = 0
            for i in range(start[a], start[a + 1]):
                g = pos[i]
                if g != f and (lc[g, 0] == b or lc[g, 1] == b or lc[g, 2] == b):
                    across[f, j] = g
                    found += 1
            if found > 1:
                ok = False             # an edge of three faces or more
        if not ok:
            break
    return start, pos, across, ok


def near_adjacency(lc, nv):
    """The near faces' adjacency, for :func:`placement`.

    Parameters
    ----------
    lc : (m,3) int64
        The near faces' corners, numbered 0..nv-1.
    nv : int

    Returns
    -------
    start : (nv+1,) int64
    pos : (3m,) int64
        The faces of vertex ``v`` are ``pos[start[v]:start[v+1]]``, ascending.
    across : (m,3) int64
        The face across edge ``(corner j, corner j+1)`` of each face, ``m``
        where there is none.
    ok : bool
        False where a face is degenerate or an edge has three faces or more
        (``across`` is then not complete: the caller takes the NumPy path).
    """
    return _near_adjacency(np.ascontiguousarray(lc, np.int64), int(nv))


@njit(cache=True, nogil=True)
def _dist(V, v, p):
    dx = V[v, 0] - p[0]
    dy = V[v, 1] - p[1]
    dz = V[v, 2] - p[2]
    return np.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, nogil=True)
def _within(V, corners, f, p, R):
    return _dist(V, corners[f, 0], p) <= R and _dist(V, corners[f, 1], p) <= R and _dist(V, corners[f, 2], p) <= R


@njit(cache=True, nogil=True)
def _walk(V, corners, across, start, pos, lp, p, R, limit, state, queue, seeds, touched):
    # the walk of one placement over ``state`` (all 0 on entry); every face
    # whose state it sets is listed in ``touched`` for the caller to reset.
    # Returns (status, faces in queue, seeds, touched).
    m = corners.shape[0]
    ns = 0
    qn = 0
    nt = 0
    for i in range(start[lp], start[lp + 1]):
        f = pos[i]
        if _within(V, corners, f, p, R):
            state[f] = 1
            touched[nt] = f
            nt += 1
            queue[qn] = f
            qn += 1
            seeds[ns] = f
            ns += 1
    if ns == 0:
        return 1, 0, 0, nt
    head = 0
    while head < qn:
        f = queue[head]
        head += 1
        for j in range(3):
            g = across[f, j]
            opened = g == m
            if not opened:
                st = state[g]
                if st == 0:
                    touched[nt] = g
                    nt += 1
                    if _within(V, corners, g, p, R):
                        state[g] = 1
                        queue[qn] = g
                        qn += 1
                    else:
                        state[g] = 2
                        opened = True
                elif st == 2:
                    opened = True
            if opened:
                da = _dist(V, corners[f, j], p)
                db = _dist(V, corners[f, (j + 1) % 3], p)
                if min(da, db) < limit:
                    return 2, 0, ns, nt
    return 0, qn, ns, nt


@njit(cache=True, nogil=True)
def _placement(V, corners, across, start, pos, lp, p, R, limit):
    m = corners.shape[0]
    state = np.zeros(m, np.int8)       # 0 not seen, 1 in the component, 2 beyond reach
    queue = np.empty(m, np.int64)
    seeds = np.empty(start[lp + 1] - start[lp], np.int64)
    touched = np.empty(m, np.int64)
    status, qn, ns, _ = _walk(V, corners, across, start, pos, lp, p, R, limit, state, queue, seeds, touched)
    if status == 0:
        return 0, np.sort(queue[:qn]), seeds[:ns]
    return status, queue[:0], seeds[:ns]


@njit(cache=True, nogil=True)
def _placement_statuses(V, corners, across, start, pos, lps, vids, R, limit):
    m = corners.shape[0]
    state = np.zeros(m, np.int8)
    queue = np.empty(m, np.int64)
    touched = np.empty(m, np.int64)
    most = 0
    for lp in lps:
        most = max(most, start[lp + 1] - start[lp])
    seeds = np.empty(most, np.int64)
    out = np.empty(lps.size, np.int8)
    for i in range(lps.size):
        status, _, _, nt = _walk(V, corners, across, start, pos, lps[i], V[vids[i]], R, limit, state, queue,
                                 seeds, touched)
        out[i] = status
        for t in range(nt):
            state[touched[t]] = 0
    return out


def placement(V, corners, across, start, pos, lp, p, R, limit):
    """One placement's region: the near faces with every corner within
    ``R`` of ``p`` joined to the faces of vertex ``lp`` across shared edges.

    Parameters
    ----------
    V : (n,3) float64
    corners : (m,3) int64
        The near faces' corners (ids into ``V``).
    across, start, pos
        :func:`near_adjacency` of those faces.
    lp : int
        The placement's vertex, in the numbering of :func:`near_adjacency`.
    p : (3,) float64
        Its position.
    R, limit : float

    Returns
    -------
    status : int
        0: the region; 1: no face of the vertex within reach; 2: an edge
        of the region with one face in it has a corner closer than
        ``limit`` to ``p`` (the walk stops there).
    region : (r,) int64
        The region's faces (positions in ``corners``), ascending (status 0).
    seeds : (s,) int64
        The vertex's faces within reach, ascending (statuses 0 and 2).
    """
    return _placement(V, corners, across, start, pos, int(lp), np.ascontiguousarray(p, np.float64), float(R),
                      float(limit))


def placement_statuses(V, corners, across, start, pos, lps, vids, R, limit):
    """:func:`placement`'s status for many vertices at once, one walk each
    over the same scratch (reset after each walk, not allocated again):
    most placements end at an open edge near their vertex, and one call
    each cost more in dispatch and in clearing a near region's worth of
    scratch than the walk itself.

    Parameters
    ----------
    V, corners, across, start, pos, R, limit
        As for :func:`placement`.
    lps : (s,) int64
        The placements' vertices, in the numbering of :func:`near_adjacency`.
    vids : (s,) int64
        The same vertices' ids into ``V`` (their positions are ``V[vids]``).

    Returns
    -------
    status : (s,) int8
        :func:`placement`'s status of each, the same to the bit.
    """
    return _placement_statuses(V, corners, across, start, pos, np.ascontiguousarray(lps, np.int64),
                               np.ascontiguousarray(vids, np.int64), float(R), float(limit))


@njit(cache=True, nogil=True)
def _within_distance(V, verts, c, bound):
    keep = np.empty(verts.size, np.int64)
    k = 0
    for i in range(verts.size):
        if _dist(V, verts[i], c) <= bound:
            keep[k] = i
            k += 1
    return keep[:k]


def within_distance(V, verts, c, bound):
    """Indices into ``verts`` of the vertices within ``bound`` of ``c``:
    NumPy's ``np.flatnonzero(np.sqrt(((V[verts] - c) ** 2).sum(axis=1)) <=
    bound)`` to the bit.

    Parameters
    ----------
    V : (n,3) float64
    verts : (k,) int64
    c : (3,) float64
    bound : float

    Returns
    -------
    (j,) int64
    """
    return _within_distance(V, np.ascontiguousarray(verts, np.int64), np.ascontiguousarray(c, np.float64),
                            float(bound))


@njit(cache=True, nogil=True)
def _component_within(across, faces, seeds):
    m = across.shape[0]
    state = np.zeros(m, np.int8)       # 1 in the subset, 2 reached
    for f in faces:
        state[f] = 1
    queue = np.empty(faces.size, np.int64)
    qn = 0
    for i in seeds:
        f = faces[i]
        if state[f] == 1:
            state[f] = 2
            queue[qn] = f
            qn += 1
    head = 0
    while head < qn:
        f = queue[head]
        head += 1
        for j in range(3):
            g = across[f, j]
            if g < m and state[g] == 1:
                state[g] = 2
                queue[qn] = g
                qn += 1
    keep = np.empty(qn, np.int64)
    k = 0
    for i in range(faces.size):        # the subset's order
        if state[faces[i]] == 2:
            keep[k] = i
            k += 1
    return keep


def component_within(across, faces, seeds):
    """The faces of ``faces`` joined to ``faces[seeds]`` across edges shared within ``faces``.

    Parameters
    ----------
    across : (m,3) int64
        :func:`near_adjacency`'s neighbours.
    faces : (k,) int64
        A subset of the faces, distinct.
    seeds : (s,) int64
        Indices into ``faces`` of some of them.

    Returns
    -------
    keep : (c,) int64
        Indices into ``faces`` of the joined ones, ascending.
    """
    return _component_within(across, np.ascontiguousarray(faces, np.int64), np.ascontiguousarray(seeds, np.int64))


@njit(cache=True, nogil=True)
def _inside_polygon(x, y, poly):
    k = poly.shape[0]
    out = np.zeros(x.size, np.bool_)
    for i in range(x.size):
        c = 0
        for j in range(k):
            ax, ay = poly[j, 0], poly[j, 1]
            bx, by = poly[(j + 1) % k, 0], poly[(j + 1) % k, 1]
            if (ay > y[i]) != (by > y[i]):
                if x[i] < ax + (y[i] - ay) * (bx - ax) / (by - ay):
                    c += 1
        out[i] = c % 2 == 1
    return out


def inside_polygon(x, y, poly):
    """Even-odd test of points against a closed polygon, with the
    operations of :func:`shellrepair.fill.placement.inside_polygon_reference`
    in the same order (the same answer to the bit).

    Parameters
    ----------
    x, y : (p,) float64
    poly : (k,2) float64

    Returns
    -------
    inside : (p,) bool
    """
    return _inside_polygon(np.ascontiguousarray(x, np.float64).ravel(), np.ascontiguousarray(y, np.float64).ravel(),
                           np.ascontiguousarray(poly, np.float64))
