"""Local triangle–triangle intersection tests for new patches.

What counts as crossing
-----------------------
Two triangles *cross* when their relative interiors meet: some point lies
inside both (for a zero-area triangle, inside the segment it covers). So

* triangles that share a vertex or an edge, or only touch at a point or
  along a segment of their boundaries, are in contact, not crossing;
* two triangles in one plane cross when they overlap in area (a patch
  lying on top of a scan face, two faces folded flat onto each other over
  a shared edge) and do not when they only touch along an edge or at a
  point;
* corners are compared by position, not by vertex id: two vertices at the
  same position (a seam that was not welded) are contact too.

Every decision is a sign of an exact orientation predicate
(:mod:`shellrepair.mesh.predicates`: a float filter with Shewchuk's error bound,
exact integer arithmetic for the few rows it cannot decide), so there is
no tolerance: the answer is the one for the float64 positions given.

How: a pair is apart when all corners of one triangle lie strictly on one
side of the other's plane (most candidate pairs). Otherwise, if both
triangles straddle each other's plane, each cuts a segment out of the line
where the two planes meet, and they cross when those two open segments
overlap (two more orient3d signs, after Guigue & Devillers 2003). Pairs in
one plane are judged in it: projected along the axis of a non-zero normal
component, their interiors overlap unless one of the six edge lines
separates them (orient2d).

With the compiled kernels on, the same tests run pair by pair in one
call (:func:`shellrepair.mesh.intersect_kernels.cross_status`) for the pairs whose
signs the float filters certify (nearly all of a scan's); pairs in one
plane, with a zero-area triangle, or with a sign only exact arithmetic
settles go to the NumPy tests above, so every answer is theirs.

Candidate pairs for a patch come from the scan faces near its box
(:class:`NearFaces`: vertices bucketed in xy columns, vertex-to-face
lists), so a check costs about its own size, not the scan's;
:class:`TriangleIndex` (a k-d tree over every triangle) is the plain
whole-mesh index it is tested against. :func:`crossing_pairs` finds the
crossing pairs within one set of triangles (a patch against itself,
:func:`self_intersections` of a whole mesh).

References
----------
P. Guigue, O. Devillers, "Fast and robust triangle-triangle overlap test
using orientation predicates", Journal of Graphics Tools 8(1), 2003.
J. R. Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast
Robust Geometric Predicates", 1997.
"""

from __future__ import annotations

import itertools

import numpy as np

from shellrepair import compiled
from shellrepair.lazyscipy import cKDTree
from shellrepair.mesh import fastmesh, intersect_kernels, topology_kernels
from shellrepair.mesh.geometry import bounding_spheres, bounds, concat_ranges, cross, plane_frame, triangle_boxes, uniq
from shellrepair.mesh.predicates import EPS, O3D_BOUND, TINY, orient2d, orient3d
from shellrepair.mesh.topology import vertex_faces

__all__ = ["TriangleIndex", "NearFaces", "pair_intersections", "crossing_pairs", "self_intersections",
           "patch_vs_index_many",
           "embeds_by_projection", "ball_pairs", "triangles_cross"]

#: Largest loop whose projected outline :func:`embeds_by_projection` tests
#: for simplicity (O(k²) segment pairs).
PROJECTION_MAX_LOOP = 600
#: Smallest projected area, relative to the largest, counted as positive.
PROJECTION_AREA_TOL = 1e-9


#: Error bound factor of the plane-side filter in :func:`_plane_signs`: the
#: value −n·(p − t0), n = (t1 − t0) × (t2 − t0), is a sum of six products of
#: three rounded differences; each reaches the sum through at most 8
#: roundings (3 differences, a product and a difference in n, a product
#: and two sums in the dot), so its error is below γ₈ = 8ε/(1 − 8ε) times
#: the same sum taken in absolute values (the permanent). 10ε covers that
#: and the rounding of the permanent itself.
SIDE_BOUND = 10.0 * EPS


@np.errstate(over="ignore", invalid="ignore")
def _plane_signs(T, P, known=None):
    """Exact side of each point ``P[:, i]`` of the plane of triangle T.

    The sign is that of ``orient3d(T0, T1, T2, P_i)``. T's normal is
    formed once per pair and dotted with each point (a cheaper form than
    three full determinants); rows its error bound (``SIDE_BOUND``) cannot
    decide go to the exact predicate.

    Parameters
    ----------
    T, P : (p,3,3) float64
    known : (p,3) bool, optional
        Points known to be at a corner of T (shared vertex ids): 0 without
        arithmetic.

    Returns
    -------
    s : (p,3) int8
    """
    t0 = T[:, 0]
    e1 = T[:, 1] - t0
    e2 = T[:, 2] - t0
    n = cross(e1, e2)
    m = np.empty_like(n)
    m[:, 0] = np.abs(e1[:, 1] * e2[:, 2]) + np.abs(e1[:, 2] * e2[:, 1])
    m[:, 1] = np.abs(e1[:, 2] * e2[:, 0]) + np.abs(e1[:, 0] * e2[:, 2])
    m[:, 2] = np.abs(e1[:, 0] * e2[:, 1]) + np.abs(e1[:, 1] * e2[:, 0])
    s = np.empty(P.shape[:2], np.int8)
    for i in range(3):
        w = P[:, i] - t0
        det = n[:, 0] * w[:, 0] + n[:, 1] * w[:, 1] + n[:, 2] * w[:, 2]
        perm = m[:, 0] * np.abs(w[:, 0]) + m[:, 1] * np.abs(w[:, 1]) + m[:, 2] * np.abs(w[:, 2])
        s[:, i] = -np.sign(det)
        unsure = ~(np.abs(det) > SIDE_BOUND * perm) | ~(perm >= TINY) | ~np.isfinite(perm)
        if known is not None:
            s[known[:, i], i] = 0
            unsure &= ~known[:, i]
        u = np.flatnonzero(unsure)
        if u.size:
            s[u, i] = orient3d(T[u, 0], T[u, 1], T[u, 2], P[u, i])
    return s


def _rotate(T, first):
    """Triangles with corner ``first`` (p,) moved to the front, turning
    sense kept."""
    r = np.arange(len(T))
    return np.stack([T[r, first], T[r, (first + 1) % 3], T[r, (first + 2) % 3]], axis=1)


def _alone(s):
    """Index of the corner alone on its side (the one whose non-zero sign
    the other two do not share), for triangles straddling a plane."""
    pos = s > 0
    return np.where(pos.sum(axis=1) == 1, np.argmax(pos, axis=1), np.argmax(s < 0, axis=1))


def _straddling_cross(A, B, sa, sb):
    """Pairs that each straddle the other's plane: do the two open
    segments the triangles cut out of the planes' common line overlap?

    Guigue–Devillers: turn each triangle so its lone corner comes first,
    swap the other's last two corners so the lone corner lies on the
    positive side of it, and compare the segments' ends by two orient3d
    signs (strictly, for open segments).
    """
    ia, ib = _alone(sa), _alone(sb)
    r = np.arange(len(A))
    sa0, sb0 = sa[r, ia], sb[r, ib]
    A = _rotate(A, ia)
    B = _rotate(B, ib)
    # flip B (swap its last two corners) where A's lone corner is below it,
    # and A where B's lone corner is below A
    fb = sa0 < 0
    B[fb] = B[fb][:, [0, 2, 1]]
    fa = sb0 < 0
    A[fa] = A[fa][:, [0, 2, 1]]
    p1, q1, r1 = A[:, 0], A[:, 1], A[:, 2]
    p2, q2, r2 = B[:, 0], B[:, 1], B[:, 2]
    return (orient3d(p1, q1, p2, q2) < 0) & (orient3d(p1, r1, r2, p2) < 0)


def _drop_axis(T):
    """For each non-degenerate triangle, an axis along which it projects
    with non-zero area (the largest normal component first), and the sign
    of that projected area."""
    n = cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    order = np.argsort(-np.abs(n), axis=1)
    axis = order[:, 0].copy()
    sign = np.zeros(len(T), np.int8)
    todo = np.arange(len(T))
    for k in range(3):
        if todo.size == 0:
            break
        ax = order[todo, k]
        s = _proj_orient(T[todo], ax)
        done = s != 0
        axis[todo[done]] = ax[done]
        sign[todo[done]] = s[done]
        todo = todo[~done]
    return axis, sign


_KEEP = np.array([[1, 2], [2, 0], [0, 1]])   # coordinates kept when dropping axis 0, 1, 2


def _project(P, axis):
    """(p,k,3) points to (p,k,2), dropping coordinate ``axis`` (p,): exact.
    The kept coordinates follow in cyclic order (y z, z x, x y), so the
    projection turns as the triangle does seen from the positive axis."""
    return np.take_along_axis(P, _KEEP[axis][:, None, :], axis=2)


def _proj_orient(T, axis):
    Q = _project(T, axis)
    return orient2d(Q[:, 0], Q[:, 1], Q[:, 2])


def _coplanar_cross(A, B, axis):
    """Pairs in one plane: do their interiors overlap? Projected along
    ``axis`` (exact), each turned counter-clockwise; separated when all
    corners of one lie on the closed outer side of an edge line of the
    other."""
    PA, PB = _project(A, axis), _project(B, axis)
    for P in (PA, PB):
        s = orient2d(P[:, 0], P[:, 1], P[:, 2])
        P[s < 0] = P[s < 0][:, [0, 2, 1]]
    sep = np.zeros(len(A), bool)
    for P, Q in ((PA, PB), (PB, PA)):
        for i in range(3):
            j = (i + 1) % 3
            out = np.ones(len(A), bool)
            for c in range(3):
                out &= orient2d(P[:, i], P[:, j], Q[:, c]) <= 0
            sep |= out
    return ~sep


def _folded(A, B, shared):
    """Coplanar non-degenerate pairs sharing exactly one edge: folded onto
    each other (third corners on the same side of the edge, in the plane)?"""
    r = np.arange(len(A))
    ia = np.argmin(shared.any(axis=2), axis=1)      # A's corner off the edge
    ib = np.argmin(shared.any(axis=1), axis=1)
    T = _rotate(A, ia)                              # (a_off, e0, e1)
    axis, _ = _drop_axis(T)
    P = _project(np.concatenate([T, B[r, ib][:, None]], axis=1), axis)
    sa = orient2d(P[:, 1], P[:, 2], P[:, 0])
    sb = orient2d(P[:, 1], P[:, 2], P[:, 3])
    return sa == sb


def _segment_of(T):
    """The two extreme corners of zero-area triangles (their segment)."""
    d = np.stack([np.sum((T[:, 1] - T[:, 2]) ** 2, axis=1), np.sum((T[:, 2] - T[:, 0]) ** 2, axis=1),
                  np.sum((T[:, 0] - T[:, 1]) ** 2, axis=1)], axis=1)
    k = np.argmax(d, axis=1)          # the corner opposite the longest side is between the others
    r = np.arange(len(T))
    return T[r, (k + 1) % 3], T[r, (k + 2) % 3]


def _segment_cross(p, q, B, s_p, s_q, axis):
    """Open segments p–q against the interiors of non-degenerate triangles B.

    ``s_p, s_q``: sides of p and q of B's plane; ``axis``: B's projection axis.
    """
    hit = np.zeros(len(B), bool)
    if len(B) == 0:
        return hit
    # through the plane: the crossing point inside B, strictly
    through = (s_p * s_q) < 0
    t = np.flatnonzero(through)
    if t.size:
        o = [orient3d(p[t], q[t], B[t, i], B[t, (i + 1) % 3]) for i in range(3)]
        hit[t] = ((o[0] > 0) & (o[1] > 0) & (o[2] > 0)) | ((o[0] < 0) & (o[1] < 0) & (o[2] < 0))
    # in the plane: separated by an edge line of B or by the segment's own line
    f = np.flatnonzero((s_p == 0) & (s_q == 0) & ~(p == q).all(axis=1))
    if f.size:
        PB = _project(B[f], axis[f])
        S = _project(np.stack([p[f], q[f]], axis=1), axis[f])
        s = orient2d(PB[:, 0], PB[:, 1], PB[:, 2])
        PB[s < 0] = PB[s < 0][:, [0, 2, 1]]
        sep = np.zeros(f.size, bool)
        for i in range(3):
            j = (i + 1) % 3
            sep |= (orient2d(PB[:, i], PB[:, j], S[:, 0]) <= 0) & (orient2d(PB[:, i], PB[:, j], S[:, 1]) <= 0)
        o = np.stack([orient2d(S[:, 0], S[:, 1], PB[:, c]) for c in range(3)], axis=1)
        sep |= (o >= 0).all(axis=1) | (o <= 0).all(axis=1)
        hit[f] = ~sep
    return hit


def _segments_cross(p1, q1, p2, q2):
    """Do the open segments p1–q1 and p2–q2 meet (crossing in one point, or
    overlapping along one line)? Zero-length segments never do."""
    hit = np.zeros(len(p1), bool)
    ok = ~(p1 == q1).all(axis=1) & ~(p2 == q2).all(axis=1)
    f = np.flatnonzero(ok)
    f = f[orient3d(p1[f], q1[f], p2[f], q2[f]) == 0]       # in one plane
    if f.size == 0:
        return hit
    a, b, c, d = p1[f], q1[f], p2[f], q2[f]
    col_c, col_d = _collinear(a, b, c), _collinear(a, b, d)
    line = col_c & col_d
    # in a plane: a proper crossing, seen in a projection that keeps the plane
    i = np.flatnonzero(~line)
    if i.size:
        T = np.stack([a[i], b[i], np.where(col_c[i, None], d[i], c[i])], axis=1)
        axis, _ = _drop_axis(T)
        P = _project(np.stack([a[i], b[i], c[i], d[i]], axis=1), axis)
        o1, o2 = orient2d(P[:, 0], P[:, 1], P[:, 2]), orient2d(P[:, 0], P[:, 1], P[:, 3])
        o3, o4 = orient2d(P[:, 2], P[:, 3], P[:, 0]), orient2d(P[:, 2], P[:, 3], P[:, 1])
        hit[f[i]] = (o1 * o2 < 0) & (o3 * o4 < 0)
    # on one line: an overlap of positive length
    i = np.flatnonzero(line)
    if i.size:
        ta, tb, tc, td = _line_coordinate(a[i], b[i], c[i], d[i])
        lo1, hi1 = np.minimum(ta, tb), np.maximum(ta, tb)
        lo2, hi2 = np.minimum(tc, td), np.maximum(tc, td)
        hit[f[i]] = np.maximum(lo1, lo2) < np.minimum(hi1, hi2)
    return hit


def _collinear(a, b, c):
    return (orient2d(a[:, [1, 2]], b[:, [1, 2]], c[:, [1, 2]]) == 0) \
        & (orient2d(a[:, [2, 0]], b[:, [2, 0]], c[:, [2, 0]]) == 0) \
        & (orient2d(a[:, [0, 1]], b[:, [0, 1]], c[:, [0, 1]]) == 0)


def _line_coordinate(a, b, c, d):
    """Positions of collinear points along their line, by the coordinate
    in which a and b differ most (exact: comparisons only)."""
    ax = np.argmax(np.abs(b - a), axis=1)
    r = np.arange(len(a))
    return a[r, ax], b[r, ax], c[r, ax], d[r, ax]


def _degenerate(T):
    """Zero-area triangles (collinear or coincident corners), exactly."""
    return _collinear(T[:, 0], T[:, 1], T[:, 2])


def triangles_cross(A, B, shared=None):
    """Which triangle pairs cross: their relative interiors meet.

    Exact for the float64 positions given (see the module docstring for
    what counts as contact). Vertex ids play no part in the answer.

    Parameters
    ----------
    A, B : (p,3,3) float64
    shared : (p,3,3) bool, optional
        ``shared[:, i, j]``: corner i of A is corner j of B (same vertex id,
        hence same position). Only saves arithmetic.

    Returns
    -------
    hit : (p,) bool
    """
    A = np.asarray(A, np.float64)
    B = np.asarray(B, np.float64)
    p = len(A)
    hit = np.zeros(p, bool)
    if p == 0:
        return hit
    sb = _plane_signs(A, B, None if shared is None else shared.any(axis=1))
    # B must straddle A's plane or lie in it; otherwise it meets the plane
    # (and A) at most in a corner or an edge
    straddle_b = (sb > 0).any(axis=1) & (sb < 0).any(axis=1)
    flat_b = (sb == 0).all(axis=1)
    near = np.flatnonzero(straddle_b | flat_b)
    if near.size == 0:
        return hit
    A, B, sb = A[near], B[near], sb[near]
    sa = _plane_signs(B, A, None if shared is None else shared[near].any(axis=2))
    straddle_a = (sa > 0).any(axis=1) & (sa < 0).any(axis=1)
    flat = flat_b[near] | (sa == 0).all(axis=1)     # one plane, or a zero-area triangle
    # the general case: each straddles the other's plane
    g = np.flatnonzero(~flat & straddle_a & straddle_b[near])
    if g.size:
        hit[near[g]] = _straddling_cross(A[g], B[g], sa[g], sb[g])
    f = np.flatnonzero(flat)
    if f.size:
        hit[near[f]] = _flat_cross(A[f], B[f], None if shared is None else shared[near[f]])
    return hit


def _flat_cross(A, B, shared=None):
    """Pairs with one triangle's corners all on the other's plane: both in
    one plane, or a zero-area triangle among them. ``shared`` as in
    :func:`triangles_cross`: coplanar pairs sharing an edge cross when
    their third corners lie on one side of it (one sign each)."""
    out = np.zeros(len(A), bool)
    da, db = _degenerate(A), _degenerate(B)
    both = ~da & ~db
    if shared is not None:
        edge = both & (shared.sum(axis=(1, 2)) == 2)
        e = np.flatnonzero(edge)
        if e.size:
            out[e] = _folded(A[e], B[e], shared[e])
        both &= ~edge
    i = np.flatnonzero(both)
    if i.size:
        axis, _ = _drop_axis(A[i])
        out[i] = _coplanar_cross(A[i], B[i], axis)
    for D, T, dD, dT in ((A, B, da, db), (B, A, db, da)):
        i = np.flatnonzero(dD & ~dT)
        if i.size:
            p, q = _segment_of(D[i])
            T_ = T[i]
            s = _plane_signs(T_, np.stack([p, q, q], axis=1))
            axis, _ = _drop_axis(T_)
            out[i] = _segment_cross(p, q, T_, s[:, 0], s[:, 1], axis)
    i = np.flatnonzero(da & db)
    if i.size:
        p1, q1 = _segment_of(A[i])
        p2, q2 = _segment_of(B[i])
        out[i] = _segments_cross(p1, q1, p2, q2)
    return out


def pair_intersections(A, Aid, B, Bid):
    """Which triangle pairs cross (see :func:`triangles_cross`).

    Parameters
    ----------
    A, B : (p,3,3) float64
        Corner positions of the two triangles of each pair.
    Aid, Bid : (p,3) int64
        Corner vertex ids. Equal ids must mean equal positions; the test
        itself compares positions (so vertices at one position with
        different ids are contact too); the same face twice crosses
        itself (its interior overlaps).

    Returns
    -------
    hit : (p,) bool
    """
    Aid = np.asarray(Aid)
    Bid = np.asarray(Bid)
    if compiled.ENABLED and len(A) and np.isfinite(A).all() and np.isfinite(B).all():
        r = np.arange(len(A))
        return _pairs_cross(A, Aid, r, B, Bid, r)
    return triangles_cross(A, B, Aid[:, :, None] == Bid[:, None, :])


def _pairs_cross(A, Aid, ai, B, Bid, bj):
    """:func:`pair_intersections` of the pairs (A[ai], B[bj]) (finite
    corners, kernels on): the compiled filters decide most pairs
    (:func:`shellrepair.mesh.intersect_kernels.cross_status`), the exact NumPy tests the
    rest (pairs in one plane, zero-area triangles, signs the filters
    cannot certify); the same answers as :func:`triangles_cross`."""
    st = intersect_kernels.cross_status(A, Aid, ai, B, Bid, bj, SIDE_BOUND, O3D_BOUND, TINY)
    hit = st == intersect_kernels.CROSS
    u = np.flatnonzero(st == intersect_kernels.UNDECIDED)
    for s in range(0, len(u), 200_000):
        a, b = ai[u[s:s + 200_000]], bj[u[s:s + 200_000]]
        hit[u[s:s + 200_000]] = pair_intersections_numpy(A[a], Aid[a], B[b], Bid[b])
    return hit


def pair_intersections_numpy(A, Aid, B, Bid):
    """:func:`pair_intersections` in NumPy (the compiled filters' oracle)."""
    Aid = np.asarray(Aid)
    Bid = np.asarray(Bid)
    return triangles_cross(A, B, Aid[:, :, None] == Bid[:, None, :])


class TriangleIndex:
    """A k-d tree over the centroids of every triangle of a mesh.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    origin : (3,) float64, optional
        Subtracted from coordinates (large offsets).
    """

    def __init__(self, V, F, origin=None):
        self.V = np.asarray(V, np.float64)
        self.F = np.asarray(F, np.int64)
        self.origin = np.zeros(3) if origin is None else np.asarray(origin, np.float64)
        c, r = bounding_spheres(self.V[self.F] - self.origin)
        self.centroids = c
        self.radius = r
        # a few huge triangles should not blow every query up: the query
        # radius covers triangles up to r_cut; larger ones are tested apart
        med = float(np.median(r)) if len(r) else 0.0
        self.r_cut = min(float(r.max(initial=0.0)), 4 * med)
        self.big = np.flatnonzero(r > self.r_cut)
        self.tree = cKDTree(c)
        self._boxes = None

    def faces_near(self, lo, hi):
        """Faces whose bounding boxes meet the box ``[lo, hi]`` (absolute
        coordinates), sorted: with this, :func:`patch_vs_index` takes the
        compiled pairs and tests (:func:`shellrepair.mesh.intersect_kernels.patch_pairs`),
        which find the same crossings as the sphere pairs (the tests are
        exact either way). The box is grown by a relative 1e-9 so that the
        caller's shift by ``origin`` and back cannot drop a face by rounding
        (a superset: the pairs are boxed again in the kernel).
        """
        if self._boxes is None:
            T = self.V[self.F]
            self._boxes = (T.min(axis=1), T.max(axis=1))
        flo, fhi = self._boxes
        lo = np.asarray(lo, np.float64)
        hi = np.asarray(hi, np.float64)
        slack = 1e-9 * (np.abs(lo) + np.abs(hi) + (hi - lo))
        return np.flatnonzero(np.all((flo <= hi + slack) & (fhi >= lo - slack), axis=1))

    def candidate_pairs(self, C, R):
        """Pairs (query i, face j) whose bounding spheres may meet.

        Parameters
        ----------
        C : (t,3) float64
            Query centres, in the index's shifted frame.
        R : (t,) float64
            Query radii.

        Returns
        -------
        ai, bi : (p,) int64
        """
        ai, bi = ball_pairs(self.tree, C, R + self.r_cut)
        if self.big.size:
            a2, b2 = _sphere_pairs(C, R, self.centroids[self.big], self.radius[self.big])
            ai, bi = np.concatenate([ai, a2]), np.concatenate([bi, self.big[b2]])
            key = uniq(ai * len(self.F) + bi)  # sort-based: np.unique hashes int64 keys slowly (numpy 2.4)
            ai, bi = key // len(self.F), key % len(self.F)
        return ai, bi


class NearFaces:
    """The faces near a query, found without indexing the whole mesh.

    Vertices are bucketed once in columns of a grid in x and y (one sort
    by column); a query box takes the columns it spans, keeps the vertices
    inside it, and the faces using them (vertex-to-face lists). A face that
    meets the box has every vertex within its longest edge of it, so the
    box is grown by the longest edge first; the few triangles much longer than the rest are
    kept apart and tested against every query, so that they do not grow
    every box (so a scan with very many such triangles makes every query
    pay for them). Building costs two sorts; a query costs the columns its
    box spans, so the check of a small hole in a large scan stays small.

    Kept rather than a SciPy ``cKDTree`` of the vertices (a ball around the
    grown box, then the box: the same faces), measured by ``python
    eval/bench_libs.py grid --repeat 3`` on a 1.3M-face sphere, 200 boxes
    of 10-80 edges: the grid is built in 75 ms (compiled counting sorts)
    against the tree's 865 ms, and answers the 200 queries in 804 ms against
    1953 ms (the edge lengths and vertex-face lists, 2.1 s in all, are
    needed either way).

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    origin : (3,) float64, optional
        Queries come in coordinates minus ``origin``.
    vf : (order, start), or a callable returning it, optional
        Vertex-to-face lists: ``order`` sorts ``F.ravel()`` by vertex,
        ``start[v]:start[v+1]`` are vertex v's entries (built if not given;
        a callable is called last, when the rest is built: lists being
        built on another thread).
    topo : EdgeTopology, optional
        The mesh's edges (:func:`shellrepair.mesh.topology.edge_topology`): edge
        lengths are then measured once per edge, not once per face corner.
    """

    #: Triangles whose longest edge exceeds this many times the median are "big".
    BIG = 8.0
    #: Query triangles × near faces up to which pairs are found by brute force.
    BRUTE = 50000

    def __init__(self, V, F, origin=None, vf=None, topo=None):
        self.V = np.asarray(V, np.float64)
        self.F = np.asarray(F, np.int64)
        self.origin = np.zeros(3) if origin is None else np.asarray(origin, np.float64)
        V, F = self.V, self.F
        if topo is not None and len(topo.edges):
            E = topo.edges
            if fastmesh.enabled(len(F)):
                L2 = fastmesh.edge_sq_lengths(V, E)
            else:
                L2 = np.empty(len(E))   # squared, per edge; in chunks that stay in cache
                for s in range(0, len(E), 1 << 16):
                    d = V[E[s:s + (1 << 16), 0]] - V[E[s:s + (1 << 16), 1]]
                    L2[s:s + (1 << 16)] = np.einsum("ij,ij->i", d, d)
            med = float(np.median(L2[:: max(1, len(L2) // 300_000)]))
            big_e = np.flatnonzero(L2 > self.BIG ** 2 * med) if med > 0 else np.zeros(0, np.int64)
            self.big = np.zeros(0, np.int64)
            if big_e.size:   # the faces of the (few) big edges, from the half-edges grouped by edge
                start = np.cumsum(topo.edge_count) - topo.edge_count
                self.big = np.unique(topo.he_order[concat_ranges(start[big_e], topo.edge_count[big_e])] // 3)
                L2[big_e] = 0.0
            self.grow = float(np.sqrt(L2.max(initial=0.0)))  # bounds every other face
        else:
            longest = np.zeros(len(F))  # squared, per face
            for a, b in ((0, 1), (1, 2), (2, 0)):
                d = V[F[:, a]] - V[F[:, b]]
                np.maximum(longest, np.einsum("ij,ij->i", d, d), out=longest)
            med = float(np.median(longest[:: max(1, len(F) // 100_000)])) if len(F) else 0.0
            big = longest > self.BIG ** 2 * med if med > 0 else np.zeros(len(F), bool)
            self.big = np.flatnonzero(big)
            self.grow = float(np.sqrt(longest[~big].max(initial=0.0)))
            del longest
        if compiled.ENABLED and len(V) and np.isfinite(V[:, :2]).all():   # the same grid by two counting sorts
            self.lo2, self.h, self.vorder, self.vkey, self.ny = intersect_kernels.grid_sort(V, grow=self.grow)
            self.vf_order, self.vf_start = (topology_kernels.vertex_faces(F, len(V)) if vf is None
                                            else vf() if callable(vf) else vf)
            return
        # column by column: a reduction over axis 0 of the (n,2) view runs two values at a time
        lo = np.array([V[:, 0].min(), V[:, 1].min()]) if len(V) else np.zeros(2)
        span = float(max(V[:, 0].max() - lo[0], V[:, 1].max() - lo[1])) if len(V) else 0.0
        # columns of about four longest edges, at most ~4096 a side
        self.h = max(4 * self.grow, span / 4096, 1e-300)
        self.lo2 = lo
        ij = np.floor((V[:, :2] - lo) / self.h).astype(np.int64)
        self.ny = int(ij[:, 1].max(initial=0)) + 1
        key = ij[:, 0] * self.ny + ij[:, 1]
        del ij
        if len(V) < 2 ** 32 and int(key.max(initial=0)) < 2 ** 31:
            # one sort of (column, vertex) packed in a word: by column, by vertex within
            # (order within a column is immaterial: faces_near sorts its result)
            key <<= 32
            key |= np.arange(len(V))
            key.sort()
            self.vorder = key & 0xFFFFFFFF
            key >>= 32
            self.vkey = key
        else:
            self.vorder = np.argsort(key)
            self.vkey = key[self.vorder]
        del key
        self.vf_order, self.vf_start = vertex_faces(F, len(V)) if vf is None else vf() if callable(vf) else vf

    def faces_near(self, lo, hi):
        """Faces that may meet the box ``[lo, hi]`` (absolute coordinates)."""
        lo = np.asarray(lo, np.float64) - self.grow
        hi = np.asarray(hi, np.float64) + self.grow
        if compiled.ENABLED and self.vf_order.dtype == np.int64 and np.isfinite(lo).all() and np.isfinite(hi).all():
            if getattr(self, "_fmark", None) is None:
                self._fmark = np.zeros(len(self.F), bool)   # scratch, left all False
            return intersect_kernels.faces_in_box(self, lo, hi, self._fmark)
        c0 = np.maximum(np.floor((lo[:2] - self.lo2) / self.h), 0).astype(np.int64)
        c1 = np.floor((hi[:2] - self.lo2) / self.h).astype(np.int64)
        c1[1] = min(c1[1], self.ny - 1)
        if np.any(c1 < c0):
            vs = np.zeros(0, np.int64)
        else:
            rows = np.arange(c0[0], c1[0] + 1)
            a = np.searchsorted(self.vkey, rows * self.ny + c0[1], side="left")
            b = np.searchsorted(self.vkey, rows * self.ny + c1[1], side="right")
            vs = self.vorder[concat_ranges(a, b - a)]
            P = self.V[vs]
            vs = vs[np.all((P >= lo) & (P <= hi), axis=1)]
        s = self.vf_start[vs]
        faces = self.vf_order[concat_ranges(s, self.vf_start[vs + 1] - s)] // 3
        return np.unique(np.concatenate([faces, self.big]))

    def candidate_pairs(self, C, R):
        """Pairs (query i, face j) whose bounding spheres meet.

        Parameters
        ----------
        C : (t,3) float64
            Query centres, minus ``origin``.
        R : (t,) float64
            Query radii.

        Returns
        -------
        ai, bi : (p,) int64
        """
        C = np.asarray(C, np.float64)
        R = np.asarray(R, np.float64)
        none = np.zeros(0, np.int64)
        if len(C) == 0 or len(self.F) == 0:
            return none, none
        lo = (C - R[:, None]).min(axis=0) + self.origin
        hi = (C + R[:, None]).max(axis=0) + self.origin
        f = self.faces_near(lo, hi)
        if f.size == 0:
            return none, none
        c, r = bounding_spheres(self.V[self.F[f]] - self.origin)
        if len(C) * len(f) <= self.BRUTE:
            ai, bj = _sphere_pairs(C, R, c, r)
            return ai, f[bj]
        # a k-d tree over the faces of ordinary size; the few much larger
        # ones (a scan's flat base, say) would widen every query: all pairs
        r_cut = min(float(r.max()), 4 * float(np.median(r)))
        small = np.flatnonzero(r <= r_cut)
        large = np.flatnonzero(r > r_cut)
        ai, bj = ball_pairs(cKDTree(c[small]), C, R + r_cut)
        bj = small[bj]
        keep = np.sum((C[ai] - c[bj]) ** 2, axis=1) <= (R[ai] + r[bj]) ** 2
        ai, bj = ai[keep], bj[keep]
        if large.size:
            a2, b2 = _sphere_pairs(C, R, c[large], r[large], self.BRUTE)
            ai, bj = np.concatenate([ai, a2]), np.concatenate([bj, large[b2]])
        return ai, f[bj]


def ball_pairs(tree, X, radius):
    """Pairs (i, j): point j of the k-d ``tree`` lies within ``radius[i]`` of ``X[i]``.

    Returns
    -------
    ai, bj : (p,) int64
    """
    lists = tree.query_ball_point(X, radius, return_sorted=False)
    cnt = np.fromiter((len(x) for x in lists), np.int64, len(lists))
    ai = np.repeat(np.arange(len(X)), cnt)
    bj = np.fromiter(itertools.chain.from_iterable(lists), np.int64, int(cnt.sum()))  # C-level walk
    return ai, bj


def _sphere_pairs(C, R, c, r, budget=4_000_000):
    """All pairs (i, j) of spheres (C[i], R[i]) and (c[j], r[j]) that meet, by
    products of at most ``budget`` entries (|C − c|² expanded; its round-off is
    covered by a slack, a superset of pairs being fine as they are tested
    exactly after)."""
    nC, nc = np.einsum("ij,ij->i", C, C), np.einsum("ij,ij->i", c, c)
    step = max(1, budget // max(len(c), 1))
    ai, bj = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for s in range(0, len(C), step):
        e = slice(s, s + step)
        d2 = nC[e, None] + nc[None, :] - 2.0 * (C[e] @ c.T)
        reach = (R[e, None] + r[None, :]) ** 2 + 1e-9 * (nC[e, None] + nc[None, :])
        a, b = np.nonzero(d2 <= reach)
        ai.append(a.astype(np.int64) + s)
        bj.append(b.astype(np.int64))
    return np.concatenate(ai), np.concatenate(bj)


def patch_vs_index(Pt, Pid, index, return_faces=False, return_pairs=False):
    """Count patch triangles crossing the indexed triangles.

    Parameters
    ----------
    Pt : (t,3,3) float64
        Patch triangle corners (absolute coordinates).
    Pid : (t,3) int64
        Corner ids in the index's numbering (new vertices: ids no indexed
        face uses, e.g. negative).
    index : TriangleIndex
    return_faces : bool
        Return the crossing patch triangles instead of the count.
    return_pairs : bool
        Return the crossing pairs (patch triangle, indexed face) instead.

    Returns
    -------
    n_hits : int, or (h,) int64 patch triangle indices, or (h,2) int64 pairs
    """
    none = np.zeros((0, 2), np.int64) if return_pairs else np.zeros(0, np.int64) if return_faces else 0
    if len(Pt) == 0 or len(index.F) == 0:
        return none
    Q = Pt - index.origin
    if compiled.ENABLED and hasattr(index, "faces_near") and np.isfinite(Q).all():
        # the near faces' boxes against the patch's (intersect_kernels.patch_pairs): a
        # superset of the crossing pairs, as the sphere pairs below are, and
        # their tests where the compiled filters decide
        lo, hi = bounds(Q.reshape(-1, 3))
        f = index.faces_near(lo + index.origin, hi + index.origin)
        Pid = np.asarray(Pid, np.int64)
        ai, bj, st = intersect_kernels.patch_pairs(Q, Pid, f, index.V, index.F, index.origin, SIDE_BOUND, O3D_BOUND, TINY)
        hit = st == intersect_kernels.CROSS
        u = np.flatnonzero(st == intersect_kernels.UNDECIDED)
        if u.size:   # in one plane, or signs the filters cannot certify: the exact tests
            a, b = ai[u], f[bj[u]]
            hit[u] = pair_intersections_numpy(Q[a], Pid[a], index.V[index.F[b]] - index.origin, index.F[b])
        if return_pairs:
            return np.column_stack([ai[hit], f[bj[hit]]])
        return uniq(ai[hit]) if return_faces else int(hit.sum())
    else:
        ai, bi = index.candidate_pairs(*bounding_spheres(Q))
        if ai.size == 0:
            return none
        T = index.V[index.F[bi]] - index.origin
        # bounding-box filter before the exact tests
        amin, amax = Q[ai].min(axis=1), Q[ai].max(axis=1)
        bmin, bmax = T.min(axis=1), T.max(axis=1)
        keep = np.all((amin <= bmax) & (bmin <= amax), axis=1)
        ai, bi, T = ai[keep], bi[keep], T[keep]
    if ai.size == 0:
        return none
    hit = np.zeros(len(ai), bool)
    for s in range(0, len(ai), 200_000):
        sl = slice(s, s + 200_000)
        hit[sl] = pair_intersections(Q[ai[sl]], Pid[ai[sl]], T[sl], index.F[bi[sl]])
    if return_pairs:
        return np.column_stack([ai[hit], bi[hit]])
    return np.unique(ai[hit]) if return_faces else int(hit.sum())


def patch_vs_index_many(items, index):
    """:func:`patch_vs_index` with ``return_faces=True`` for several patches,
    each on its own (its own box, its own pairs): the tests are exact per
    pair, so each patch gets what its own call gives.

    Parameters
    ----------
    items : list of ((t,3,3) float64, (t,3) int64)
        Each patch's triangle corners and corner ids, as ``Pt, Pid``.
    index : TriangleIndex or NearFaces

    Returns
    -------
    bad : list of (h,) int64
        Per patch, its triangles that cross the indexed ones.
    """
    return [patch_vs_index(Pt, Pid, index, return_faces=True) for Pt, Pid in items]


def crossing_pairs(C, ids):
    """Pairs of triangles of one set that cross each other.

    Candidates are pairs whose bounding spheres meet (a k-d tree over the
    centroids; triangles far larger than the median are paired apart so
    they do not widen every query), then pairs whose boxes overlap; those
    get the exact tests of :func:`pair_intersections`.

    Parameters
    ----------
    C : (t,3,3) float64
        Triangle corners (subtract a nearby origin first for large offsets).
    ids : (t,3) int64
        Corner vertex ids (equal ids: a shared vertex, touching allowed).

    Returns
    -------
    pairs : (h,2) int64
        Crossing pairs, each as ``i < j``.
    """
    C = np.asarray(C, np.float64)
    ids = np.asarray(ids, np.int64)
    none = np.zeros((0, 2), np.int64)
    if len(C) < 2:
        return none
    if compiled.ENABLED and len(C) <= KERNEL_PAIRS_MAX and np.isfinite(C).all():
        # overlapping boxes (intersect_kernels.box_pairs): a superset of the crossing
        # pairs, as the sphere pairs below are; the exact tests decide
        i, j = intersect_kernels.box_pairs(*triangle_boxes(C))
        hit = _pairs_cross(C, ids, i, C, ids, j)
        return np.column_stack([i[hit], j[hit]])
    else:
        P = _sphere_box_pairs(C)
    if len(P) == 0:
        return none
    hit = np.zeros(len(P), bool)
    for s in range(0, len(P), 200_000):
        a, b = P[s:s + 200_000, 0], P[s:s + 200_000, 1]
        hit[s:s + 200_000] = pair_intersections(C[a], ids[a], C[b], ids[b])
    return P[hit]


#: Largest triangle set whose candidate pairs :func:`crossing_pairs` finds
#: with the compiled box grid (the k-d tree above it: whole meshes).
KERNEL_PAIRS_MAX = 200_000


def _sphere_box_pairs(C):
    """Pairs i < j of C whose bounding spheres meet and boxes overlap."""
    none = np.zeros((0, 2), np.int64)
    c, r = bounding_spheres(C)
    r_cut = min(float(np.percentile(r, 99)), 4 * float(np.median(r)))  # the largest 1 % are paired apart
    tree = cKDTree(c)
    P = tree.query_pairs(2 * r_cut, output_type="ndarray").astype(np.int64)
    big = np.flatnonzero(r > r_cut)
    if big.size:
        i, j = ball_pairs(tree, c[big], r[big] + float(r.max()))
        i = big[i]
        m = i != j
        key = uniq(np.concatenate([P[:, 0] * len(C) + P[:, 1],
                               np.minimum(i[m], j[m]) * len(C) + np.maximum(i[m], j[m])]))
        P = np.column_stack([key // len(C), key % len(C)])
    if len(P) == 0:
        return none
    i, j = P[:, 0], P[:, 1]
    near = np.sum((c[i] - c[j]) ** 2, axis=1) <= (r[i] + r[j]) ** 2 * (1 + 1e-9)
    lo, hi = C.min(axis=1), C.max(axis=1)
    near &= np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
    return P[near]


def self_intersections(V, F):
    """Number of intersecting pairs among the triangles of one mesh."""
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if len(F) < 2:
        return 0
    return len(crossing_pairs(V[F] - V.mean(axis=0), F))


def outline_is_simple(Q):
    """Is the closed 2-D polygon ``Q`` (k,2) simple (no two non-adjacent
    edges meet, not even touching)? Pair by pair in a compiled loop
    (:func:`shellrepair.mesh.intersect_kernels.outline_simple`) when the kernels are on,
    else all pairs at once (:func:`outline_is_simple_reference`); the same
    tests in the same arithmetic, so the same answer.

    Parameters
    ----------
    Q : (k,2) float64

    Returns
    -------
    bool
    """
    Q = np.asarray(Q, np.float64)
    if not compiled.ENABLED or len(Q) < 3 or not np.isfinite(Q).all():
        return outline_is_simple_reference(Q)
    span = float(np.ptp(Q, axis=0).max()) or 1.0
    return intersect_kernels.outline_simple(Q, 1e-12 * span * span)


def outline_is_simple_reference(Q):
    """:func:`outline_is_simple` by NumPy over all edge pairs (the fallback,
    and the oracle of :func:`shellrepair.mesh.intersect_kernels.outline_simple`);
    parameters and returns as :func:`outline_is_simple`."""
    k = len(Q)
    if k < 3:
        return False
    A, B = Q, np.roll(Q, -1, axis=0)
    i, j = np.triu_indices(k, 2)
    keep = ~((i == 0) & (j == k - 1))  # edges k−1 and 0 are adjacent
    i, j = i[keep], j[keep]
    if i.size == 0:
        return True
    span = float(np.ptp(Q, axis=0).max()) or 1.0
    eps = 1e-12 * span * span

    def orient(p, q, r):
        return (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])

    a, b, c, d = A[i], B[i], A[j], B[j]
    o1, o2 = orient(a, b, c), orient(a, b, d)
    o3, o4 = orient(c, d, a), orient(c, d, b)
    # separated when both ends of one edge lie strictly on one side of the other
    apart = ((o1 > eps) & (o2 > eps)) | ((o1 < -eps) & (o2 < -eps)) \
        | ((o3 > eps) & (o4 > eps)) | ((o3 < -eps) & (o4 < -eps))
    # collinear-ish pairs: separated when their boxes do not overlap
    lo1, hi1 = np.minimum(a, b), np.maximum(a, b)
    lo2, hi2 = np.minimum(c, d), np.maximum(c, d)
    boxes_apart = np.any((hi1 < lo2) | (hi2 < lo1), axis=1)
    return bool(np.all(apart | boxes_apart))


def embeds_by_projection(P, T, n_loop, axis=None):
    """A cheap proof that a disc-shaped patch does not cross itself.

    The patch's loop (its first ``n_loop`` vertices, in order) is projected
    on the plane normal to ``axis``; if that outline is a simple polygon and
    every patch triangle keeps a positive area there (the same turning
    sense as the outline), the projection maps the patch one-to-one onto
    the polygon: an orientation-preserving piecewise-linear map of a disc
    covers each point as often as its boundary winds around it, once
    inside a simple outline. Two patch triangles that met in space would
    overlap in the projection, so none do. When the test fails the patch
    may still be fine; check it pair by pair.

    Parameters
    ----------
    P : (p,3) float64
        Patch vertices, loop first.
    T : (t,3) int64
        Patch triangles, a disc whose boundary is the loop.
    n_loop : int
    axis : (3,) float64, optional
        Default: the loop's vector-area direction.

    Returns
    -------
    ok : bool
        True only when the certificate holds.
    """
    P = np.asarray(P, np.float64)
    T = np.asarray(T, np.int64)
    k = int(n_loop)
    if k < 3 or k > PROJECTION_MAX_LOOP or len(T) == 0 or not np.isfinite(P).all():
        return False
    C = P - P[:k].mean(axis=0)
    if axis is None:
        axis = 0.5 * cross(C[:k], np.concatenate([C[1:k], C[:1]])).sum(axis=0)   # np.roll by -1
    axis = np.asarray(axis, np.float64)
    if not np.linalg.norm(axis) > 0:
        return False
    u, v = plane_frame(axis)
    Q = np.column_stack([C @ u, C @ v])
    q = Q[:k]
    qn = np.concatenate([q[1:], q[:1]])                  # np.roll by -1
    outline = 0.5 * float(np.sum(q[:, 0] * qn[:, 1] - qn[:, 0] * q[:, 1]))
    if outline == 0.0:
        return False
    if compiled.ENABLED and np.isfinite(Q).all():
        return intersect_kernels.projection_embeds(Q, T, k, np.sign(outline), PROJECTION_AREA_TOL)
    e1, e2 = Q[T[:, 1]] - Q[T[:, 0]], Q[T[:, 2]] - Q[T[:, 0]]
    areas = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) * np.sign(outline)
    # the patch must turn the other way round from its loop: loop edges appear
    # reversed in the patch triangles, so the two signs are opposite
    areas = -areas
    if not (areas > PROJECTION_AREA_TOL * np.abs(areas).max()).all():
        return False
    return outline_is_simple(q)
