"""Local triangle–triangle intersection tests for new patches.

Two triangles that share no vertex intersect when an edge of one crosses
the other. Triangles that share one vertex (a patch triangle at the rim and
a scan face at the same loop vertex) intersect beyond it only where the
edge opposite the shared vertex of one crosses the other. Triangles that
share an edge intersect only when folded flat onto each other. Touching at
shared vertices and edges is not an intersection. Coplanar overlaps without
a fold are not detected (they do not arise from faired patches).

Candidate pairs for a patch come from the scan faces near its box
(:class:`NearFaces`: vertices bucketed in xy columns, vertex-to-face
lists), so a check costs about its own size, not the scan's;
:class:`TriangleIndex` (a k-d tree over every triangle) is the plain
whole-mesh index it is tested against. :func:`crossing_pairs` finds the
crossing pairs within one set of triangles (a patch against itself,
:func:`self_intersections` of a whole mesh). Before the exact edge tests,
pairs with one triangle wholly on one side of the other's plane are set
aside (most candidate pairs are).
"""

from __future__ import annotations

import numpy as np

from .geometry import bounding_spheres, concat_ranges, cross, dot, plane_frame
from .topology import vertex_faces
from scipy.spatial import cKDTree

__all__ = ["TriangleIndex", "NearFaces", "pair_intersections", "crossing_pairs", "self_intersections",
           "embeds_by_projection", "ball_pairs"]

#: Barycentric / segment-parameter tolerance: hits this close to an edge or
#: endpoint count as touching, not crossing.
TOUCH_TOL = 1e-7
#: Largest loop whose projected outline :func:`embeds_by_projection` tests
#: for simplicity (O(k²) segment pairs).
PROJECTION_MAX_LOOP = 600
#: Smallest projected area, relative to the largest, counted as positive.
PROJECTION_AREA_TOL = 1e-9
#: Normals of two triangles sharing an edge with a dot product below
#: ``-1 + FOLD_TOL`` are folded onto each other.
FOLD_TOL = 1e-6


def _seg_tri(p0, p1, a, b, c, tol=TOUCH_TOL):
    """Does segment p0–p1 cross the interior of triangle abc (vectorised)?"""
    d = p1 - p0
    e1 = b - a
    e2 = c - a
    h = cross(d, e2)
    det = np.sum(e1 * h, axis=-1)
    scale = np.linalg.norm(d, axis=-1) * np.linalg.norm(e1, axis=-1) * np.linalg.norm(e2, axis=-1)
    ok = np.abs(det) > 1e-12 * np.maximum(scale, 1e-300)
    f = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p0 - a
    u = f * np.sum(s * h, axis=-1)
    q = cross(s, e1)
    v = f * np.sum(d * q, axis=-1)
    t = f * np.sum(e2 * q, axis=-1)
    return ok & (u > tol) & (v > tol) & (u + v < 1 - tol) & (t > tol) & (t < 1 - tol)


#: Corners closer to the other triangle's plane than this, relative to the
#: plane normal's length times the corner's distance from the plane's
#: anchor, count as on the plane (:func:`_one_side`).
SIDE_TOL = 1e-10


def _one_side(A, B, skip):
    """Do the corners of B (other than the ``skip`` ones) lie strictly on one
    side of A's plane?

    Such a pair cannot intersect: no edge of B reaches A's plane, and A lies
    in a plane that B meets at most in a shared corner. The margin
    (``SIDE_TOL``) is far above the round-off of the signed distances, so
    a pair on one side here is one the exact tests reject too.

    Parameters
    ----------
    A, B : (p,3,3) float64
    skip : (p,3) bool
        Corners of B shared with A (on A's plane by construction).

    Returns
    -------
    apart : (p,) bool
    """
    n = cross(A[:, 1] - A[:, 0], A[:, 2] - A[:, 0])
    r = B - A[:, :1]
    d = dot(r, n[:, None, :])
    tol = SIDE_TOL * np.sqrt(dot(n, n))[:, None] * np.sqrt(dot(r, r))
    pos = (d > tol) | skip
    neg = (d < -tol) | skip
    return pos.all(axis=1) | neg.all(axis=1)


def pair_intersections(A, Aid, B, Bid):
    """Which triangle pairs intersect.

    Parameters
    ----------
    A, B : (p,3,3) float64
        Corner positions of the two triangles of each pair.
    Aid, Bid : (p,3) int64
        Corner vertex ids (equal ids mean a shared vertex).

    Returns
    -------
    hit : (p,) bool
    """
    p = len(A)
    hit = np.zeros(p, bool)
    if p == 0:
        return hit
    eq = Aid[:, :, None] == Bid[:, None, :]
    sa = eq.any(axis=2)  # corner of A shared
    sb = eq.any(axis=1)
    ns = sa.sum(axis=1)
    # pairs sharing at most a corner with one triangle wholly on one side
    # of the other's plane cannot meet (most candidate pairs): skip them
    near = np.flatnonzero(ns <= 1)
    if near.size:
        apart = _one_side(A[near], B[near], sb[near]) | _one_side(B[near], A[near], sa[near])
        ns = ns.copy()
        ns[near[apart]] = -1
    # no shared vertex: all six edge/triangle tests
    z = np.flatnonzero(ns == 0)
    if z.size:
        a, b = A[z], B[z]
        h = np.zeros(z.size, bool)
        for i in range(3):
            j = (i + 1) % 3
            h |= _seg_tri(a[:, i], a[:, j], b[:, 0], b[:, 1], b[:, 2])
            h |= _seg_tri(b[:, i], b[:, j], a[:, 0], a[:, 1], a[:, 2])
        hit[z] = h
    # one shared vertex: the opposite edges
    o = np.flatnonzero(ns == 1)
    if o.size:
        ia = np.argmax(sa[o], axis=1)
        ib = np.argmax(sb[o], axis=1)
        r = np.arange(o.size)
        a, b = A[o], B[o]
        a1, a2 = a[r, (ia + 1) % 3], a[r, (ia + 2) % 3]
        b1, b2 = b[r, (ib + 1) % 3], b[r, (ib + 2) % 3]
        hit[o] = (_seg_tri(a1, a2, b[:, 0], b[:, 1], b[:, 2])
                  | _seg_tri(b1, b2, a[:, 0], a[:, 1], a[:, 2]))
    # a shared edge: folded onto each other
    t = np.flatnonzero(ns == 2)
    if t.size:
        na = cross(A[t, 1] - A[t, 0], A[t, 2] - A[t, 0])
        nb = cross(B[t, 1] - B[t, 0], B[t, 2] - B[t, 0])
        den = np.linalg.norm(na, axis=1) * np.linalg.norm(nb, axis=1)
        cos = np.sum(na * nb, axis=1) / np.maximum(den, 1e-300)
        hit[t] = (cos < -1 + FOLD_TOL) | (den == 0)
    hit[ns == 3] = True  # the same triangle twice
    return hit


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
            key = np.unique(ai * len(self.F) + bi)
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

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    origin : (3,) float64, optional
        Queries come in coordinates minus ``origin``.
    vf : (order, start), optional
        Vertex-to-face lists: ``order`` sorts ``F.ravel()`` by vertex,
        ``start[v]:start[v+1]`` are vertex v's entries (built if not given).
    topo : EdgeTopology, optional
        The mesh's edges (:func:`shellrepair.topology.edge_topology`): edge
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
            L2 = np.empty(len(E))   # squared, per edge; in chunks that stay in cache
            for s in range(0, len(E), 1 << 16):
                d = V[E[s:s + (1 << 16), 0]] - V[E[s:s + (1 << 16), 1]]
                L2[s:s + (1 << 16)] = np.einsum("ij,ij->i", d, d)
            med = float(np.median(L2[:: max(1, len(L2) // 300_000)]))
            big_edge = L2 > self.BIG ** 2 * med if med > 0 else np.zeros(len(L2), bool)
            self.big = np.unique(np.flatnonzero(big_edge[topo.edge_of_he]) // 3)
            self.grow = float(np.sqrt(L2[~big_edge].max(initial=0.0)))  # bounds every other face
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
        lo = V[:, :2].min(axis=0) if len(V) else np.zeros(2)
        span = float(np.ptp(V[:, :2], axis=0).max()) if len(V) else 0.0
        # columns of about four longest edges, at most ~4096 a side
        self.h = max(4 * self.grow, span / 4096, 1e-300)
        self.lo2 = lo
        ij = np.floor((V[:, :2] - lo) / self.h).astype(np.int64)
        self.ny = int(ij[:, 1].max(initial=0)) + 1
        key = ij[:, 0] * self.ny + ij[:, 1]
        self.vorder = np.argsort(key)  # order within a column is immaterial: faces_near sorts its result
        self.vkey = key[self.vorder]
        del ij, key
        self.vf_order, self.vf_start = vertex_faces(F, len(V)) if vf is None else vf

    def faces_near(self, lo, hi):
        """Faces that may meet the box ``[lo, hi]`` (absolute coordinates)."""
        lo = np.asarray(lo, np.float64) - self.grow
        hi = np.asarray(hi, np.float64) + self.grow
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
    bj = np.fromiter((j for x in lists for j in x), np.int64, int(cnt.sum()))
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


def patch_vs_index(Pt, Pid, index, return_faces=False):
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

    Returns
    -------
    n_hits : int, or (h,) int64 patch triangle indices
    """
    none = np.zeros(0, np.int64) if return_faces else 0
    if len(Pt) == 0 or len(index.F) == 0:
        return none
    Q = Pt - index.origin
    ai, bi = index.candidate_pairs(*bounding_spheres(Q))
    if ai.size == 0:
        return none
    T = index.V[index.F[bi]] - index.origin
    # bounding-box filter before the exact tests
    amin, amax = Q[ai].min(axis=1), Q[ai].max(axis=1)
    bmin, bmax = T.min(axis=1), T.max(axis=1)
    keep = np.all((amin <= bmax) & (bmin <= amax), axis=1)
    ai, bi, T = ai[keep], bi[keep], T[keep]
    hit = np.zeros(len(ai), bool)
    for s in range(0, len(ai), 200_000):
        sl = slice(s, s + 200_000)
        hit[sl] = pair_intersections(Q[ai[sl]], Pid[ai[sl]], T[sl], index.F[bi[sl]])
    return np.unique(ai[hit]) if return_faces else int(hit.sum())


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
    c, r = bounding_spheres(C)
    r_cut = min(float(r.max()), 4 * float(np.median(r)))
    tree = cKDTree(c)
    P = tree.query_pairs(2 * r_cut, output_type="ndarray").astype(np.int64)
    big = np.flatnonzero(r > r_cut)
    if big.size:
        i, j = ball_pairs(tree, c[big], r[big] + float(r.max()))
        i = big[i]
        m = i != j
        key = np.unique(np.concatenate([P[:, 0] * len(C) + P[:, 1],
                                        np.minimum(i[m], j[m]) * len(C) + np.maximum(i[m], j[m])]))
        P = np.column_stack([key // len(C), key % len(C)])
    if len(P) == 0:
        return none
    i, j = P[:, 0], P[:, 1]
    near = np.sum((c[i] - c[j]) ** 2, axis=1) <= (r[i] + r[j]) ** 2 * (1 + 1e-9)
    lo, hi = C.min(axis=1), C.max(axis=1)
    near &= np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
    P = P[near]
    hit = np.zeros(len(P), bool)
    for s in range(0, len(P), 200_000):
        a, b = P[s:s + 200_000, 0], P[s:s + 200_000, 1]
        hit[s:s + 200_000] = pair_intersections(C[a], ids[a], C[b], ids[b])
    return P[hit]


def self_intersections(V, F):
    """Number of intersecting pairs among the triangles of one mesh."""
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if len(F) < 2:
        return 0
    return len(crossing_pairs(V[F] - V.mean(axis=0), F))


def _outline_is_simple(Q):
    """Is the closed 2-D polygon ``Q`` (k,2) simple (no two non-adjacent
    edges meet, not even touching)?"""
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
        axis = 0.5 * cross(C[:k], np.roll(C[:k], -1, axis=0)).sum(axis=0)
    axis = np.asarray(axis, np.float64)
    if not np.linalg.norm(axis) > 0:
        return False
    u, v = plane_frame(axis)
    Q = np.column_stack([C @ u, C @ v])
    q = Q[:k]
    outline = 0.5 * float(np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1]))
    if outline == 0.0:
        return False
    e1, e2 = Q[T[:, 1]] - Q[T[:, 0]], Q[T[:, 2]] - Q[T[:, 0]]
    areas = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) * np.sign(outline)
    # the patch must turn the other way round from its loop: loop edges appear
    # reversed in the patch triangles, so the two signs are opposite
    areas = -areas
    if not (areas > PROJECTION_AREA_TOL * np.abs(areas).max()).all():
        return False
    return _outline_is_simple(q)
