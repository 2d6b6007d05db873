"""Triangulate a hole's boundary loop.

Every layer minimises Liepa's weight: the triangulation whose worst dihedral
angle (between neighbouring new triangles, and between a new triangle and
the scan's face across a loop edge) is smallest, ties broken by the
smallest total area. The layers, each tried where the one before has no
answer:

1. the Delaunay triangulation of the loop projected along its axis, where it
   triangulates the loop exactly (O(k log k));
2. the minimum-weight triangulation among the triangles of the 3D Delaunay
   tetrahedralization of the loop's vertices (Zou, Ju & Carr 2013; the
   search space of CGAL's ``triangulate_hole``), loop edges the
   tetrahedralization lacks completed with every apex: O(t) for t
   candidate triangles, so loops of thousands of edges are searched whole.
   Faces of one tetrahedralization meet only at shared edges and corners,
   so this answer never crosses itself. An ``allowed`` test (the scan's
   faces) is asked about each answer's triangles; rejected ones leave the
   search space and the search runs again (``LAZY_ROUNDS``);
3. Liepa's full O(k³) dynamic program, for loops up to ``DP_MAX`` edges
   (compiled, :func:`shellrepair.fill.triangulate_kernels.liepa_tables`; its NumPy oracle
   is vectorised over all splits of one interval length at a time);
4. longer loops are cut by a short chord between vertices far apart along
   the loop (the nearest pair at least a quarter of the loop apart), and
   each piece goes through layers 2–4 on its own vertices.

No triangulation creates an edge the mesh already has: chords between loop
vertices that are already joined by a mesh edge are forbidden.

References
----------
P. Liepa, "Filling Holes in Meshes", Eurographics Symposium on Geometry
Processing, 2003. M. Zou, T. Ju, N. Carr, "An algorithm for triangulating
multiple 3D polygons", Eurographics Symposium on Geometry Processing, 2013.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict

import numpy as np

from shellrepair import compiled
from shellrepair.errors import MeshError
from shellrepair.fill import triangulate_kernels
from shellrepair.mesh.geometry import cross, dot, plane_frame, points_in_polygon

__all__ = ["triangulate_loop", "restricted_dp", "restricted_dp_reference", "delaunay_faces", "delaunay_faces_uncached",
           "delaunay_in_projection", "loop_cover_reference", "with_loop_edges", "best_chord", "best_chord_rows", "liepa_dp",
           "dp_tables_reference", "vector_length", "DP_MAX", "RESTRICTED_MAX", "DELAUNAY_KEPT", "DELAUNAY_CACHE"]

#: Largest loop triangulated by one dynamic program.
DP_MAX = 200
#: Longest (sub-)loop searched over its Delaunay tetrahedralization's triangles.
RESTRICTED_MAX = 2000
#: A tetrahedralization with more triangles than this per loop vertex (points
#: along a smooth space curve can make it nearly quadratic) is not searched.
FACES_PER_VERTEX = 40
#: Rounds of the restricted search that drop the triangles ``allowed`` rejects.
LAZY_ROUNDS = 16
#: Tolerance when comparing worst dihedral costs (1 − cos of the angle) before areas.
ANGLE_TIE = 1e-12


def _normals(A, B, C):
    n = cross(B - A, C - A)
    ln = np.linalg.norm(n, axis=-1, keepdims=True)
    return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0), 0.5 * ln[..., 0]


def _angle(n1, n2):
    """Dihedral cost between unit normals: 1 − cos, monotone in the angle
    (0 for a flat continuation, 2 for a fold); 2 where either is zero."""
    d = n1[..., 0] * n2[..., 0] + n1[..., 1] * n2[..., 1] + n1[..., 2] * n2[..., 2]
    bad = (np.abs(n1).sum(axis=-1) == 0) | (np.abs(n2).sum(axis=-1) == 0)
    return np.where(bad, 2.0, 1.0 - np.clip(d, -1.0, 1.0))


def triangulate_loop(P, edge_normals=None, forbidden=None, axis="auto", fast=True, allowed=None):
    """Triangulate a closed loop of points.

    The layers, each tried where the one before finds nothing:

    1. (``fast``) the Delaunay triangulation of the loop projected along
       ``axis``, where it triangulates the loop exactly;
    2. Liepa's minimum-weight triangulation searched over the triangles of
       the 3D Delaunay tetrahedralization of the loop's vertices
       (:func:`delaunay_faces`, :func:`restricted_dp`; loops up to
       ``RESTRICTED_MAX`` edges). Such triangles meet only at shared edges
       and corners, so this triangulation never crosses itself;
    3. the full O(k³) search (:func:`liepa_dp`), loops up to ``DP_MAX`` edges;
    4. longer loops are cut by a short chord into two pieces, each
       triangulated by layers 2–4 on its own vertices.

    Parameters
    ----------
    P : (k,3) float64
        Loop positions, in boundary half-edge order (the scan's faces lie to
        the left).
    edge_normals : (k,3) float64, optional
        Unit normal of the scan's face across loop edge ``(i, i+1)``, for the
        dihedral term at the rim. Zero rows mean unknown.
    forbidden : set of (int, int), optional
        Pairs ``(i, j)``, ``i < j``, of loop positions that must not be joined
        (the mesh already has that edge).
    axis : (3,) float64, "auto" or None
        Viewing direction for the embedding constraint: when given, the
        triangulation is first sought among those whose every triangle faces
        along ``axis`` (positive area when projected on the plane normal to
        it). Where the loop's projection is a simple polygon such a
        triangulation exists and cannot cross itself. ``"auto"`` uses the
        loop's own axis (minus its vector area, the way the patch faces);
        None skips the constrained search. If no constrained triangulation
        exists, the unconstrained one is returned.
    fast : bool
        First try the Delaunay triangulation of the loop projected along the
        axis, accepted only when it triangulates the loop exactly (every loop
        edge, k − 2 triangles, all facing along the axis, no forbidden
        chord). The refinement and fairing that follow decide the shape, so
        the O(k log k) triangulation serves where it is valid; the dynamic
        programs handle the rest.
    allowed : callable, optional
        ``allowed(T) -> (t,) bool`` for candidate triangles ``T`` (t,3) of
        loop positions: False for triangles that must not be used (they
        cross the scan). The projection and the restricted search use only
        allowed triangles; the full search and the chord cuts ignore it.

    Returns
    -------
    T : (k-2,3) int64
        Triangles as indices into ``P``, oriented so that each loop edge
        ``(i, i+1)`` appears reversed (consistent with the scan).

    Raises
    ------
    MeshError
        If every triangulation would create an existing edge.
    """
    P = np.asarray(P, np.float64)
    k = len(P)
    if k < 3:
        raise MeshError(f"a loop needs at least 3 vertices, got {k}")
    if edge_normals is None:
        edge_normals = np.zeros((k, 3))
    forbidden = set() if forbidden is None else set(forbidden)
    idx = np.arange(k)
    edge_normals = np.asarray(edge_normals, np.float64)
    C = None
    if isinstance(axis, str):
        if compiled.ENABLED and P.flags.c_contiguous:   # (NumPy sums an F-ordered P's columns pairwise)
            C, va = triangulate_kernels.centred_area(P)
        else:
            C = P - P.mean(axis=0)
            va = -0.5 * cross(C, np.concatenate([C[1:], C[:1]])).sum(axis=0)   # np.roll by -1
        ln = vector_length(va)
        axis = va / ln if ln > 0 else None
    if axis is not None:
        axis = np.asarray(axis, np.float64)
    if axis is not None and fast:
        T = delaunay_in_projection(P, axis, forbidden, C)
        if T is not None and (allowed is None or np.asarray(allowed(T), bool).all()):
            return T
    return _triangulate(P, idx, edge_normals, forbidden, axis, allowed)


def vector_length(x):
    """``np.linalg.norm(x)`` of a vector: for a float64 one its own steps
    (``sqrt(x.dot(x))``, the same dot product) without its Python
    overhead.

    Parameters
    ----------
    x : (d,) array

    Returns
    -------
    float
        The same value as ``np.linalg.norm(x)``, to the bit.
    """
    if x.dtype == np.float64 and x.ndim == 1:
        return math.sqrt(x.dot(x))
    return np.linalg.norm(x)


def delaunay_in_projection(P, axis, forbidden, C=None):
    """The Delaunay triangulation of the loop projected along ``axis``, when
    it is a triangulation of the loop: every loop edge present, k − 2
    triangles inside the outline, all facing along ``axis``, no forbidden
    chord. None otherwise (non-convex outlines whose edges are not Delaunay,
    outlines that overlap themselves).

    Parameters
    ----------
    P : (k,3) float64
        The loop.
    axis : (3,) float64
        The direction to project along (any length).
    forbidden : set of (int, int)
        Chords (loop positions, smaller first) no triangle may have.
    C : (k,3) float64, optional
        ``P - P.mean(axis=0)``, when the caller has it.

    Returns
    -------
    T : (k-2,3) int64 or None
        Compiled checks when the kernels are on, else
        :func:`loop_cover_reference`'s; the same triangles.
    """
    from scipy.spatial import Delaunay, QhullError

    k = len(P)
    a = axis / vector_length(axis)
    u, v = plane_frame(a)
    if C is None:
        plain = compiled.ENABLED and P.dtype == np.float64 and P.flags.c_contiguous
        C = triangulate_kernels.centred_area(P)[0] if plain else P - P.mean(axis=0)
    Q = np.column_stack([C @ u, C @ v])
    try:
        tri = Delaunay(Q)
    except (QhullError, ValueError):
        return None
    S = tri.simplices.astype(np.int64)
    if len(S) < k - 2 or tri.coplanar.size:
        return None
    if compiled.ENABLED and P.dtype == np.float64:
        S, raw = triangulate_kernels.outline_cross(Q, S, P)
        if len(S) != k - 2:
            return None
        S, status = triangulate_kernels.cover_free(S, raw @ a, k, _forbidden_keys(forbidden, k))
        return S if status == 0 else None
    return _loop_cover_numpy(P, Q, S, a, k, forbidden)


def _forbidden_keys(forbidden, k):
    """Sorted keys ``x·k + y`` of the pairs ``0 <= x < y < k`` of
    ``forbidden`` (the only ones a triangle's edge can be)."""
    if not forbidden:
        return _NO_KEYS
    return np.unique(np.array([x * k + y for x, y in forbidden if 0 <= x < y < k], np.int64))


_NO_KEYS = np.zeros(0, np.int64)


def _loop_cover_numpy(P, Q, S, a, k, forbidden):
    """The checks of :func:`delaunay_in_projection` on its Delaunay
    triangles ``S`` in NumPy (the compiled checks' test oracle): ``S``
    kept inside the outline and oriented, or None."""
    # keep triangles whose centroid is inside the outline (even-odd rule)
    inside = points_in_polygon(Q[S].mean(axis=1), Q)
    S = S[inside]
    if len(S) != k - 2:
        return None
    # orient each along the axis (our convention: normal along the axis)
    n = cross(P[S[:, 1]] - P[S[:, 0]], P[S[:, 2]] - P[S[:, 0]]) @ a
    S, ok = loop_cover_reference(S, n, k)
    return _none_forbidden(S, forbidden) if ok else None


def loop_cover_reference(S, n, k):
    """``S`` turned to face along ``n``'s signs, and whether it covers the
    loop: no triangle flat (``|n|`` at most 1e-12 of the largest), every
    loop edge present (NumPy: the fallback, and
    :func:`shellrepair.fill.triangulate_kernels.loop_cover`'s oracle).

    Parameters
    ----------
    S : (t,3) int64
        Triangles of loop positions.
    n : (t,) float64
        Each triangle's normal along the projection axis.
    k : int
        Loop length.

    Returns
    -------
    S : (t,3) int64
    covers : bool
    """
    S = np.where((n < 0)[:, None], S[:, [0, 2, 1]], S)
    n = np.abs(n)
    if (n <= 1e-12 * np.max(n)).any():
        return S, False
    # every loop edge exactly once, reversed (i+1 -> i): the half-edges
    # (i+1 mod k) -> i cover every i
    he = np.concatenate([S[:, [0, 1]], S[:, [1, 2]], S[:, [2, 0]]])
    seen = np.zeros(k, bool)
    seen[he[he[:, 0] == (he[:, 1] + 1) % k, 1]] = True
    return S, bool(seen.all())


def _none_forbidden(S, forbidden):
    """``S``, or None when one of its edges joins a forbidden pair."""
    if forbidden:
        he = np.concatenate([S[:, [0, 1]], S[:, [1, 2]], S[:, [2, 0]]])
        und = {(int(min(x, y)), int(max(x, y))) for x, y in he.tolist()}
        if und & set(forbidden):
            return None
    return S


def _triangulate(P, idx, edge_normals, forbidden, axis, allowed=None):
    """Triangulate the sub-loop ``idx`` (global positions into P): the
    restricted search, the full search, or a chord cut and both pieces."""
    k = len(idx)
    if 4 <= k <= RESTRICTED_MAX:
        T = _restricted(P, idx, edge_normals, forbidden, axis, allowed)
        if T is not None:
            return T
    if k <= DP_MAX:
        if axis is not None:
            try:
                return liepa_dp(P, idx, edge_normals, forbidden, axis)
            except MeshError:
                pass
        return liepa_dp(P, idx, edge_normals, forbidden, None)
    i, j = best_chord(P, idx, forbidden)
    a = idx[i:j + 1]                          # closes with chord idx[j] -> idx[i]
    b = np.concatenate([idx[j:], idx[:i + 1]])  # closes with chord idx[i] -> idx[j]
    Ta = _triangulate(P, a, edge_normals, forbidden, axis, allowed)
    Tb = _triangulate(P, b, edge_normals, forbidden, axis, allowed)
    return np.vstack([Ta, Tb])


def _restricted(P, idx, edge_normals, forbidden, axis, allowed):
    """Layer 2 on the sub-loop ``idx``: the minimum-weight triangulation
    among its Delaunay faces (allowed ones only), facing along ``axis``
    first; None where there is none."""
    k = len(idx)
    Q = P[idx]
    D = delaunay_faces(Q)
    if D is None or len(D) > FACES_PER_VERTEX * k:
        return None
    D = with_loop_edges(D, k)
    # rim normals of the sub-loop's edges that are loop edges; forbidden pairs in local positions
    nxt = np.roll(idx, -1)
    rim_ok = (idx + 1) % len(P) == nxt
    en = np.where(rim_ok[:, None], edge_normals[idx], 0.0)
    pos = {int(g): t for t, g in enumerate(idx)}
    forb = set()
    for x, y in forbidden:
        if x in pos and y in pos:
            forb.add((min(pos[x], pos[y]), max(pos[x], pos[y])))
    n = np.int64(k)
    key = (D[:, 0] * n + D[:, 1]) * n + D[:, 2]    # sorted: D is
    verdict = np.zeros(len(D), np.int8)           # allowed(): 0 not asked yet, 1 yes, -1 no
    keep = np.ones(len(D), bool)
    for ax in ((axis, None) if axis is not None else (None,)):
        # ``allowed`` is asked lazily: only about the triangles of each answer;
        # the ones it rejects leave the search space and the search runs again
        for _ in range(LAZY_ROUNDS):
            try:
                T = restricted_dp(Q, D[keep], en, forb, ax)
            except MeshError:
                break
            if allowed is None:
                return idx[T]
            S = np.sort(T, axis=1)
            at = np.searchsorted(key, (S[:, 0] * n + S[:, 1]) * n + S[:, 2])
            ask = at[verdict[at] == 0]
            if ask.size:
                verdict[ask] = np.where(np.asarray(allowed(idx[D[ask]]), bool), 1, -1)
            if (verdict[at] > 0).all():
                return idx[T]
            keep[at[verdict[at] < 0]] = False
    return None


def with_loop_edges(D, k):
    """Candidates ``D`` plus, for each loop edge no candidate has (the
    tetrahedralization need not contain the loop's edges), the triangles on
    it with every other apex; only those may then cross other candidates.

    Parameters
    ----------
    D : (t,3) int64
        Candidate triangles of loop positions, corners sorted ascending
        (:func:`delaunay_faces`).
    k : int
        Loop length.

    Returns
    -------
    (u,3) int64
        ``D`` itself when it has every loop edge, else the union, sorted by key.
    """
    n = np.int64(k)
    seen, ok = triangulate_kernels.loop_edges_present(D, k) if compiled.ENABLED else (None, False)
    if ok:
        miss = np.flatnonzero(~seen)
    else:
        E = np.concatenate([D[:, 0] * n + D[:, 1], D[:, 1] * n + D[:, 2], D[:, 0] * n + D[:, 2]])
        i = np.arange(k - 1)
        want = np.concatenate([i * n + i + 1, [k - 1]])
        miss = np.flatnonzero(~np.isin(want, E))
    if miss.size == 0:
        return D
    extra = []
    for e in miss.tolist():
        a, b = (e, e + 1) if e < k - 1 else (0, k - 1)
        m = np.setdiff1d(np.arange(k), [a, b])
        extra.append(np.sort(np.column_stack([np.full(m.size, a), np.full(m.size, b), m]), axis=1))
    A = np.concatenate([D] + extra)
    key = np.unique((A[:, 0] * n + A[:, 1]) * n + A[:, 2])
    return np.column_stack([key // (n * n), (key // n) % n, key % n])


#: Sub-loops shorter than this are searched row by row (:func:`best_chord_rows`).
CHORD_ROWS_MAX = 256


def best_chord(P, idx, forbidden):
    """Shortest chord between loop positions at least k/4 apart either way.

    The answer of the row-by-row search (:func:`best_chord_rows`, O(k²)),
    in O(k^1.5 log k): the positions are cut into blocks of about √k; a row
    ``i``'s allowed partners (``i + q .. i + k − q``) are whole blocks, each
    searched by a k-d tree (blocks holding a forbidden partner of the row
    by brute force), and at most two part-blocks at the window's ends, by
    brute force. The row nearest overall, the first of equals, gets its
    partner as the row-by-row search picks it. Compiled
    (:func:`shellrepair.fill.triangulate_kernels.chord_rows`) when the kernels
    are on, the loop at most ``CHORD_KERNEL_MAX`` long and its ids distinct.

    Parameters
    ----------
    P : (n,3) float64
    idx : (k,) int64
        The sub-loop's vertices.
    forbidden : set of (int, int)
        Vertex pairs (smaller first) no chord may join.

    Returns
    -------
    i, j : int
        The chord's positions in ``idx``, ``i < j``.

    Raises
    ------
    MeshError
        When every far enough pair is forbidden.
    """
    from scipy.spatial import cKDTree

    k = len(idx)
    if compiled.ENABLED and k <= CHORD_KERNEL_MAX and len(np.unique(idx)) == k:
        return _best_chord_compiled(P, idx, forbidden)
    if k < CHORD_ROWS_MAX:
        return best_chord_rows(P, idx, forbidden)
    Q = P[idx]
    q = max(3, k // 4)
    rows = k - q
    I = np.arange(rows)
    lo = I + q                                   # each row's window lo .. hi
    hi = np.minimum(k - 1, I + k - q)
    b = max(8, int(np.sqrt(k)))
    first = -(-lo // b) * b                      # the first whole block's start
    last = (hi + 1) // b * b - 1                 # the last whole block's end
    whole = last >= first + b - 1
    # forbidden partners, as (row, position) keys in this sub-loop's numbering
    fk = _position_keys(idx, forbidden)
    near = np.full(rows, np.inf)
    # the part-blocks at both ends of each window (all of it without a whole block)
    o = np.arange(2 * b)
    L = lo[:, None] + o[None, :]
    okL = (L <= hi[:, None]) & ((L < first[:, None]) | ~whole[:, None])
    R = hi[:, None] - o[None, :b]
    okR = (R >= lo[:, None]) & (R > last[:, None])
    for Pm, ok in ((L, okL), (R, okR)):
        Pm = np.where(ok, Pm, 0)
        if fk.size:
            ok &= ~np.isin(I[:, None] * k + Pm, fk)
        D = np.linalg.norm(Q[Pm] - Q[I, None, :], axis=2)
        near = np.minimum(near, np.where(ok, D, np.inf).min(axis=1))
    # whole blocks: rows whose window holds block [s, e]
    fr, fp = fk // k, fk % k
    for s in range(0, k - b + 1, b):
        e = s + b - 1
        r0, r1 = max(0, e - k + q), min(rows - 1, s - q)
        if r1 < r0:
            continue
        rr = np.arange(r0, r1 + 1)
        rr = rr[(first[rr] <= s) & (last[rr] >= e)]
        if rr.size == 0:
            continue
        brute = np.unique(fr[(fp >= s) & (fp <= e)])
        tree_rows = np.setdiff1d(rr, brute)
        if tree_rows.size:
            _, jj = cKDTree(Q[s:e + 1]).query(Q[tree_rows])
            j = s + jj
            near[tree_rows] = np.minimum(near[tree_rows], np.linalg.norm(Q[j] - Q[tree_rows], axis=1))
        for i in np.intersect1d(rr, brute).tolist():
            j = np.arange(s, e + 1)
            d = np.linalg.norm(Q[j] - Q[i], axis=1)
            d[np.isin(i * k + j, fk)] = np.inf
            near[i] = min(near[i], d.min())
    i = int(np.argmin(near))
    if not np.isfinite(near[i]):
        raise MeshError(_NO_CHORD)
    return i, _pick_in_row(Q, idx, i, q, forbidden)


_NO_CHORD = "no chord splits this loop without duplicating an existing edge"


def _position_keys(idx, forbidden):
    """The forbidden pairs among the sub-loop ``idx``'s vertices, as sorted
    keys ``u·k + v`` of their positions ``u < v`` (:func:`_forbidden_keys`
    for a sub-loop whose ids are not its positions)."""
    k = len(idx)
    pos = {int(g): t for t, g in enumerate(idx.tolist())}
    fk = []
    for x, y in forbidden:
        if x in pos and y in pos:
            u, v = sorted((pos[x], pos[y]))
            fk.append(u * k + v)
    return np.unique(np.asarray(fk, np.int64))


def _pick_in_row(Q, idx, i, q, forbidden):
    """Row ``i``'s partner as the row-by-row search picks it: the first
    allowed one in NumPy's argsort of the distances (which orders equally
    near partners)."""
    k = len(idx)
    j = np.arange(i + q, min(k, i + k - q + 1))
    d = np.linalg.norm(Q[j] - Q[i], axis=1)
    for t in np.argsort(d):
        u, v = sorted((int(idx[i]), int(idx[j[t]])))
        if (u, v) not in forbidden:
            return int(j[t])
    raise MeshError(_NO_CHORD)


#: Longest sub-loop whose chord is searched row by row in compiled code
#: (O(k²) distances: 2·10⁷ at this length, a few tens of ms).
CHORD_KERNEL_MAX = 6000


def _best_chord_compiled(P, idx, forbidden):
    """:func:`best_chord_rows` by :func:`shellrepair.fill.triangulate_kernels.chord_rows`;
    where the chosen row has several equally near partners, its pick is
    made as the row-by-row search makes it (NumPy's argsort order)."""
    k = len(idx)
    Q = P[idx]
    q = max(3, k // 4)
    fk = _position_keys(idx, forbidden)
    i, j, ties = triangulate_kernels.chord_rows(Q, q, fk)
    if i < 0:
        raise MeshError(_NO_CHORD)
    return i, (_pick_in_row(Q, idx, i, q, forbidden) if ties > 1 else j)


def best_chord_rows(P, idx, forbidden):
    """:func:`best_chord` row by row, O(k²): used for short sub-loops, and
    the oracle of the block search and of
    :func:`shellrepair.fill.triangulate_kernels.chord_rows`. Parameters, returns
    and errors as :func:`best_chord`."""
    k = len(idx)
    Q = P[idx]
    q = max(3, k // 4)
    best = (np.inf, -1, -1)
    for i in range(0, k - q):
        j = np.arange(i + q, min(k, i + k - q + 1))
        if j.size == 0:
            continue
        d = np.linalg.norm(Q[j] - Q[i], axis=1)
        for t in np.argsort(d):
            a, b = sorted((int(idx[i]), int(idx[j[t]])))
            if (a, b) not in forbidden:
                if d[t] < best[0]:
                    best = (float(d[t]), i, int(j[t]))
                break
    if best[1] < 0:
        raise MeshError(_NO_CHORD)
    return best[1], best[2]


def liepa_dp(P, idx, edge_normals, forbidden, axis=None):
    """Liepa's O(k³) dynamic program on the sub-loop ``idx``: the
    triangulation whose worst dihedral angle (then area) is least (tables
    compiled by :func:`shellrepair.fill.triangulate_kernels.liepa_tables` when the
    kernels are on, else :func:`dp_tables_reference`; the same triangles).

    Parameters
    ----------
    P : (n,3) float64
    idx : (k,) int64
        The sub-loop's vertices, in order.
    edge_normals : (n,3) float64
        The scan face's normal across each loop edge ``(i, i+1)``.
    forbidden : set of (int, int)
        Vertex pairs (smaller first) no triangle side may join.
    axis : (3,) float64, optional
        Every triangle must face along it.

    Returns
    -------
    T : (k-2,3) int64

    Raises
    ------
    MeshError
        When no triangulation avoids the forbidden chords (or faces along ``axis``).
    """
    k = len(idx)
    if k == 3:
        T = np.array([[idx[0], idx[2], idx[1]]], np.int64)
        if _uses_forbidden(T, forbidden):
            raise MeshError("the only triangle of this loop duplicates an existing edge")
        if axis is not None and np.dot(cross(P[T[0, 1]] - P[T[0, 0]], P[T[0, 2]] - P[T[0, 0]]), axis) <= 0:
            raise MeshError("the triangle faces against the loop's axis")
        return T
    Q = P[idx]
    # rim normals: across sub-loop edge (i, i+1) is the scan face of global edge (idx[i], idx[i]+1)
    glob_next = (idx + 1) % len(P)
    rim = np.zeros((k, 3))
    has_rim = np.zeros(k, bool)
    nxt = np.roll(idx, -1)
    rim_ok = glob_next == nxt
    rim[rim_ok] = edge_normals[idx[rim_ok]]
    has_rim[rim_ok] = True
    # forbidden chords in local positions
    forb = np.zeros((k, k), bool)
    if forbidden:
        pos = {int(g): t for t, g in enumerate(idx)}
        for a, b in forbidden:
            if a in pos and b in pos:
                ia, ib = sorted((pos[a], pos[b]))
                if ib - ia > 1 and not (ia == 0 and ib == k - 1):
                    forb[ia, ib] = True
    if compiled.ENABLED:
        O, worst = triangulate_kernels.liepa_tables(Q, rim, has_rim, forb, axis, ANGLE_TIE)
    else:
        O, worst = dp_tables_reference(Q, rim, has_rim, forb, axis)
    if not np.isfinite(worst):
        if axis is not None:
            raise MeshError("no triangulation of this loop faces along its axis")
        raise MeshError("every triangulation of this loop duplicates an existing edge")
    tris = []
    stack = [(0, k - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        mm = int(O[a, b])
        tris.append((idx[a], idx[b], idx[mm]))
        stack.append((a, mm))
        stack.append((mm, b))
    return np.array(tris, np.int64)


def dp_tables_reference(Q, rim, has_rim, forb, axis):
    """The tables of :func:`liepa_dp`, vectorised over all splits of one interval
    length at a time (the compiled :func:`shellrepair.fill.triangulate_kernels.liepa_tables`'
    test oracle, and the fallback when the kernels are off).

    Parameters
    ----------
    Q : (k,3) float64
        The sub-loop's positions.
    rim : (k,3) float64
        The scan normal across each sub-loop edge ``(i, i+1)`` where ``has_rim``.
    has_rim : (k,) bool
    forb : (k,k) bool
        Forbidden chords, ``forb[i, j]`` for ``i < j``.
    axis : (3,) float64 or None

    Returns
    -------
    O : (k,k) int64
        The apex closing each interval ``(i, j)``.
    worst : float
        The whole loop's worst dihedral cost (inf: no triangulation).
    """
    k = len(Q)
    axis = None if axis is None else np.asarray(axis, np.float64)
    WA = np.full((k, k), np.inf)   # worst dihedral angle of the best triangulation of (i..j)
    WS = np.full((k, k), np.inf)   # its area
    O = np.full((k, k), -1, np.int64)
    N = np.zeros((k, k, 3))        # normal of the triangle on chord (i, j)
    HN = np.zeros((k, k), bool)    # N[i, j] is a real normal (not zero)
    for i in range(k - 1):
        WA[i, i + 1] = 0.0
        WS[i, i + 1] = 0.0
        N[i, i + 1] = rim[i] if has_rim[i] else 0.0
        HN[i, i + 1] = bool(has_rim[i] and np.any(rim[i] != 0))
    for L in range(2, k):
        r = k - L
        i = np.arange(r)
        j = i + L
        # chord (i, j) closed by apex m = i + t, t = 1 .. L-1: the tables
        # on edges (i, m) and (m, j) are read as strided views (_left, _right)
        Qi = Q[:r, None, :]
        Qm = np.lib.stride_tricks.as_strided(Q[1:], shape=(r, L - 1, 3), strides=(Q.strides[0],) + Q.strides,
                                             writeable=False)                       # Q[i + t]
        raw = cross(Q[L:, None, :] - Qi, Qm - Qi)          # triangle (i, j, m), unnormalised normal
        ln = np.sqrt(dot(raw, raw))
        nz = ln > 0
        n = raw / np.where(nz, ln, 1.0)[..., None]
        area = 0.5 * ln
        # dihedral cost (1 - cos) with the triangles (or rim faces) on edges (i, m) and (m, j);
        # 2 (a fold) for a degenerate candidate, 0 where there is no neighbour yet
        a1 = np.where(_left(HN, r, L), np.where(nz, 1.0 - np.clip(dot(n, _left(N, r, L)), -1.0, 1.0), 2.0), 0.0)
        a2 = np.where(_right(HN, r, L), np.where(nz, 1.0 - np.clip(dot(n, _right(N, r, L)), -1.0, 1.0), 2.0), 0.0)
        wa = np.maximum(np.maximum(a1, a2), np.maximum(_left(WA, r, L), _right(WA, r, L)))
        if L == k - 1 and has_rim[k - 1]:  # the closing edge (k-1 -> 0) has a scan face across it
            wa = np.maximum(wa, _angle(n, np.broadcast_to(rim[k - 1], n.shape)))
        ws = area + _left(WS, r, L) + _right(WS, r, L)
        bad = _left(forb, r, L) | _right(forb, r, L) | np.diagonal(forb, L)[:, None]
        if axis is not None:  # embedding constraint: every triangle faces along the axis
            bad |= dot(raw, axis) <= 0
        wa = np.where(bad, np.inf, wa)
        best_a = wa.min(axis=1, keepdims=True)
        ws_masked = np.where(wa <= best_a + ANGLE_TIE, ws, np.inf)
        t = np.argmin(ws_masked, axis=1)
        WA[i, j] = wa[i, t]
        WS[i, j] = ws_masked[i, t]
        O[i, j] = i + 1 + t
        N[i, j] = n[i, t]
        HN[i, j] = nz[i, t]
    return O, WA[0, k - 1]


def _left(X, r, L):
    """``X[i, i + t]`` for i < r, 1 <= t < L, as a view of the (k,k,...) table X."""
    s0, s1 = X.strides[:2]
    return np.lib.stride_tricks.as_strided(X[0, 1:], shape=(r, L - 1) + X.shape[2:],
                                           strides=(s0 + s1, s1) + X.strides[2:], writeable=False)


def _right(X, r, L):
    """``X[i + t, i + L]`` for i < r, 1 <= t < L, as a view of the (k,k,...) table X."""
    s0, s1 = X.strides[:2]
    return np.lib.stride_tricks.as_strided(X[1, L:], shape=(r, L - 1) + X.shape[2:],
                                           strides=(s0 + s1, s0) + X.strides[2:], writeable=False)


def _uses_forbidden(T, forbidden):
    for t in T:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            if (min(a, b), max(a, b)) in forbidden:
                return True
    return False


#: Tetrahedralizations kept (:func:`delaunay_faces`): a hole's retries
#: triangulate the same sub-loops again (74 calls, 34 different point sets
#: on one 699-edge hole).
DELAUNAY_KEPT = 32
#: The kept answers of :func:`delaunay_faces`, by point set, oldest first.
DELAUNAY_CACHE = OrderedDict()
_DELAUNAY_LOCK = threading.Lock()


def delaunay_faces(P):
    """Triangles of the 3D Delaunay tetrahedralization of the points ``P``.

    Parameters
    ----------
    P : (k,3) float64

    Returns
    -------
    D : (t,3) int64 or None
        Each face once, corners sorted ascending; None when the points span
        less than a volume even after joggling (Qhull ``QJ``) or a point was
        merged with another (duplicates), so the faces cannot serve as the
        search space of every loop vertex. The answers for the last
        ``DELAUNAY_KEPT`` point sets are kept, and a copy given again.
    """
    P = np.asarray(P)
    key = (P.dtype.str, P.shape, P.tobytes())
    with _DELAUNAY_LOCK:
        D = DELAUNAY_CACHE.get(key, DELAUNAY_CACHE)
        if D is not DELAUNAY_CACHE:
            DELAUNAY_CACHE.move_to_end(key)
    if D is DELAUNAY_CACHE:      # not kept
        D = delaunay_faces_uncached(P)
        with _DELAUNAY_LOCK:
            DELAUNAY_CACHE[key] = D
            while len(DELAUNAY_CACHE) > DELAUNAY_KEPT:
                DELAUNAY_CACHE.popitem(last=False)
    # a copy: the caller may change it, and the kernels it goes to take
    # writeable arrays (a read-only one is another signature to compile)
    return None if D is None else D.copy()


def delaunay_faces_uncached(P):
    """:func:`delaunay_faces`, computed (neither looked up nor kept).
    Parameters and returns as :func:`delaunay_faces`."""
    from scipy.spatial import Delaunay, QhullError

    if len(P) < 4:
        return None
    C = P - P.mean(axis=0)
    tri = None
    for opts in ("Qbb Qc Qz Q12", "QJ"):
        try:
            tri = Delaunay(C, qhull_options=opts)
        except (QhullError, ValueError):
            continue
        if tri.coplanar.size == 0:
            break
        tri = None
    if tri is None:
        return None
    if compiled.ENABLED:
        return triangulate_kernels.tet_faces(tri.simplices, len(P))
    S = np.sort(tri.simplices.astype(np.int64), axis=1)
    D = np.concatenate([S[:, [0, 1, 2]], S[:, [0, 1, 3]], S[:, [0, 2, 3]], S[:, [1, 2, 3]]])
    n = np.int64(len(P))
    key = np.unique((D[:, 0] * n + D[:, 1]) * n + D[:, 2])
    return np.column_stack([key // (n * n), (key // n) % n, key % n])


def restricted_dp(P, cand, edge_normals, forbidden, axis=None):
    """Liepa's minimum-weight triangulation searched over the triangles
    ``cand`` only (Zou, Ju & Carr 2013; CGAL's ``triangulate_hole``).

    A triangle ``(a, b, c)``, a < b < c, closes the interval ``(a, c)`` of
    the loop with apex ``b`` on the best triangulations of ``(a, b)`` and
    ``(b, c)``; intervals are solved by increasing length, so every
    candidate is looked at once: O(t) for t candidates instead of O(k³).

    Parameters
    ----------
    P : (k,3) float64
    cand : (t,3) int64
        Candidate triangles, corners sorted ascending.
    edge_normals, forbidden, axis
        As for :func:`triangulate_loop`.

    Returns
    -------
    T : (k-2,3) int64

    Raises
    ------
    MeshError
        If no triangulation of the loop uses only candidate triangles.
    """
    if compiled.ENABLED:
        T = _restricted_dp_compiled(P, cand, edge_normals, forbidden, axis)
        if T is not None:
            return T
    return restricted_dp_reference(P, cand, edge_normals, forbidden, axis)


def _restricted_dp_compiled(P, cand, edge_normals, forbidden, axis):
    """:func:`restricted_dp` by :func:`shellrepair.fill.triangulate_kernels.restricted_prepare`
    and :func:`shellrepair.fill.triangulate_kernels.restricted_search` (the axis test stays
    NumPy's product); None where the inputs are not plain (float
    positions, one rim normal per loop edge, corners inside the loop), for
    the NumPy version to handle."""
    P = np.asarray(P)
    k = len(P)
    en = np.asarray(edge_normals, np.float64)
    if k < 3 or P.dtype != np.float64 or P.shape != (k, 3) or en.shape != (k, 3):
        return None
    cand = np.asarray(cand, np.int64).reshape(-1, 3)
    fk = np.unique(np.array([x * k + y for x, y in forbidden], np.int64)) if forbidden else np.zeros(0, np.int64)
    a, b, c, el, er, et, ne, base, top, raw, n, nz, area, status = triangulate_kernels.restricted_prepare(P, cand, fk)
    if status:
        return None
    bad0 = np.zeros(len(a), bool) if axis is None else raw @ axis <= 0
    T, status, i, j = triangulate_kernels.restricted_search(k, a, b, c, el, er, et, ne, base, en, n, nz, area, bad0, top,
                                                ANGLE_TIE)
    if status == 1:
        raise MeshError(_NO_RESTRICTED)
    if status == 2:
        raise MeshError(f"restricted search: interval ({i}, {j}) has no apex")
    return T


_NO_RESTRICTED = "no triangulation of this loop uses only triangles of its Delaunay tetrahedralization"


def restricted_dp_reference(P, cand, edge_normals, forbidden, axis=None):
    """:func:`restricted_dp` in NumPy, the interval lengths in groups: the
    fallback, and the compiled search's test oracle. Parameters, returns
    and errors as :func:`restricted_dp`."""
    k = len(P)
    cand = np.asarray(cand, np.int64).reshape(-1, 3)
    a, b, c = cand[:, 0], cand[:, 1], cand[:, 2]
    ok = (a < b) & (b < c)
    if forbidden:
        fk = np.array([x * k + y for x, y in forbidden], np.int64)
        for p, q in ((a, b), (b, c), (a, c)):
            chord = (q - p > 1) & ~((p == 0) & (q == k - 1))
            ok &= ~(chord & np.isin(p * k + q, fk))
    a, b, c = a[ok], b[ok], c[ok]
    # edge ids: the loop edges (i, i+1) first, then every candidate's edges
    keys = np.unique(np.concatenate([np.arange(k - 1) * k + np.arange(1, k), [k - 1], a * k + b, b * k + c, a * k + c]))
    el, er, et = (np.searchsorted(keys, x) for x in (a * k + b, b * k + c, a * k + c))
    ne = len(keys)
    WA = np.full(ne, np.inf)
    WS = np.full(ne, np.inf)
    N = np.zeros((ne, 3))
    HN = np.zeros(ne, bool)
    apex = np.full(ne, -1, np.int64)
    base = np.searchsorted(keys, np.arange(k - 1) * k + np.arange(1, k))
    WA[base] = 0.0
    WS[base] = 0.0
    # rim normals: the scan face across loop edge (i, i+1)
    N[base] = edge_normals[:k - 1]
    HN[base] = np.abs(edge_normals[:k - 1]).sum(axis=1) > 0
    raw = cross(P[c] - P[a], P[b] - P[a])           # triangle (a, c, b), the patch's orientation
    ln = np.sqrt(dot(raw, raw))
    nz = ln > 0
    n = raw / np.where(nz, ln, 1.0)[:, None]
    area = 0.5 * ln
    bad0 = np.zeros(len(a), bool) if axis is None else raw @ axis <= 0
    top = int(np.searchsorted(keys, k - 1))        # the interval (0, k-1): its rim edge closes the loop
    rim_close = edge_normals[k - 1]
    has_close = bool(np.abs(rim_close).sum() > 0)
    L = c - a
    order = np.argsort(L, kind="stable")
    cuts = np.flatnonzero(np.diff(L[order])) + 1
    for grp in np.split(order, cuts):
        l, r, t = el[grp], er[grp], et[grp]
        ng = n[grp]
        zg = nz[grp]
        d1 = np.clip(dot(ng, N[l]), -1.0, 1.0)
        d2 = np.clip(dot(ng, N[r]), -1.0, 1.0)
        a1 = np.where(HN[l], np.where(zg, 1.0 - d1, 2.0), 0.0)
        a2 = np.where(HN[r], np.where(zg, 1.0 - d2, 2.0), 0.0)
        wa = np.maximum(np.maximum(a1, a2), np.maximum(WA[l], WA[r]))
        if has_close and t.size and t[0] == top:  # the interval (0, k-1) is the longest: alone in its group
            wa = np.maximum(wa, _angle(ng, np.broadcast_to(rim_close, ng.shape)))
        wa = np.where(bad0[grp], np.inf, wa)
        ws = area[grp] + WS[l] + WS[r]
        fin = np.isfinite(wa)
        if not fin.any():
            continue
        grp, t, wa, ws = grp[fin], t[fin], wa[fin], ws[fin]
        best = np.full(ne, np.inf)
        np.minimum.at(best, t, wa)
        ws = np.where(wa <= best[t] + ANGLE_TIE, ws, np.inf)
        o = np.lexsort((ws, t))
        first = o[np.r_[True, t[o][1:] != t[o][:-1]]]
        tt = t[first]
        WA[tt] = wa[first]
        WS[tt] = ws[first]
        apex[tt] = b[grp[first]]
        N[tt] = n[grp[first]]
        HN[tt] = nz[grp[first]]
    if not np.isfinite(WA[top]):
        raise MeshError(_NO_RESTRICTED)
    tris = []
    stack = [(0, k - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        m = int(apex[np.searchsorted(keys, i * k + j)])
        if not i < m < j:  # cannot happen: every solved interval has its apex
            raise MeshError(f"restricted search: interval ({i}, {j}) has no apex")
        tris.append((i, j, m))
        stack.append((i, m))
        stack.append((m, j))
    return np.array(tris, np.int64)


