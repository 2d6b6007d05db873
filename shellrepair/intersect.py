"""Local triangle–triangle intersection tests for new patches.

Two triangles that share no vertex intersect when an edge of one crosses
the other. Triangles that share one vertex (a patch triangle at the rim and
a scan face at the same loop vertex) intersect beyond it only where the
edge opposite the shared vertex of one crosses the other. Triangles that
share an edge intersect only when folded flat onto each other. Touching at
shared vertices and edges is not an intersection. Coplanar overlaps without
a fold are not detected (they do not arise from faired patches).

Candidate pairs come from a k-d tree of triangle centroids, so a check
costs O(t log m) for a patch of t triangles.
"""

from __future__ import annotations

import numpy as np

from .geometry import cross
from scipy.spatial import cKDTree

__all__ = ["TriangleIndex", "pair_intersections", "self_intersections"]

#: Barycentric / segment-parameter tolerance: hits this close to an edge or
#: endpoint count as touching, not crossing.
TOUCH_TOL = 1e-7
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
    """A k-d tree over triangle centroids for candidate-pair queries.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    origin : (3,) float64, optional
        Subtracted from coordinates (large offsets).
    region : list of (lo (3,), hi (3,)) boxes, optional
        Index only the faces near these boxes (the holes): queries whose
        reach leaves the covered cells fall back to a tree over all faces,
        built on first need. Without it every face is indexed.
    """

    #: Cells a box may cover at most; a region needing more indexes everything.
    MAX_CELLS = 200_000

    def __init__(self, V, F, origin=None, region=None):
        self.V = np.asarray(V, np.float64)
        self.F = np.asarray(F, np.int64)
        self.origin = np.zeros(3) if origin is None else np.asarray(origin, np.float64)
        self._full = None
        self.cells = None
        if not (region and self._build_region(region)):
            self._index_all()
            self.ids = None
            self.tree = self._full
            self.cells = None

    def _index_all(self):
        """Centroids, radii and a tree over every face (also the fallback)."""
        T = self.V[self.F] - self.origin
        c = T.mean(axis=1)
        r = np.sqrt(np.max(np.sum((T - c[:, None, :]) ** 2, axis=2), axis=1))
        self.centroids = c
        self.radius = r
        # a few huge triangles should not blow every query up: the query
        # radius covers triangles up to r_cut; larger ones are tested apart
        med = float(np.median(r)) if len(r) else 0.0
        r_cut = float(r.max(initial=0.0))
        if r_cut > 4 * med:
            r_cut = 4 * med
        if self.cells is None:
            self.r_cut = r_cut
        self.big = np.flatnonzero(r > self.r_cut)
        self._full = cKDTree(c)

    def _cell_keys(self, lo, hi):
        """Keys of the grid cells a box overlaps (None when too many)."""
        a = np.floor((lo - self.origin - self.grid0) / self.h).astype(np.int64)
        b = np.floor((hi - self.origin - self.grid0) / self.h).astype(np.int64)
        a, b = np.maximum(a, 0), np.minimum(b, self.dims - 1)
        if np.any(b < a):
            return np.zeros(0, np.int64)
        size = np.prod(b - a + 1)
        if size > self.MAX_CELLS:
            return None
        g = np.meshgrid(*[np.arange(a[k], b[k] + 1) for k in range(3)], indexing="ij")
        return (g[0].ravel() * self.dims[1] + g[1].ravel()) * self.dims[2] + g[2].ravel()

    def _build_region(self, region):
        """Index only the faces with a vertex in the cells around ``region``.

        Every face is then at most ``r_cut`` (the longest edge of the mesh)
        from its own vertices, so a face that can touch a query box grown by
        ``2 r_cut`` has a vertex in the cells that box covers. Returns False
        (index everything) where the mesh has a few very long edges or the
        grid would be too large.
        """
        V, F = self.V, self.F
        longest = np.zeros(len(F))
        for a, b in ((0, 1), (1, 2), (2, 0)):
            np.maximum(longest, np.linalg.norm(V[F[:, a]] - V[F[:, b]], axis=1), out=longest)
        med = float(np.median(longest[:: max(1, len(F) // 100_000)])) if len(F) else 0.0
        lmax = float(longest.max(initial=0.0))
        if lmax > 8 * med:  # a few huge triangles: the plain index handles them apart
            return False
        self.r_cut = lmax
        ext = np.array([np.max(hi - lo) for lo, hi in region])
        self.h = max(float(np.median(ext)) / 4, 2 * self.r_cut, 1e-300)
        P = V - self.origin
        self.grid0 = P.min(axis=0) - self.h
        self.dims = np.floor((P.max(axis=0) + self.h - self.grid0) / self.h).astype(np.int64) + 2
        if np.prod(self.dims.astype(float)) > 2.0 ** 62:
            return False
        keys = []
        for lo, hi in region:
            k = self._cell_keys(lo - 2 * self.r_cut, hi + 2 * self.r_cut)
            if k is None:
                return False
            keys.append(k)
        cells = np.unique(np.concatenate(keys)) if keys else np.zeros(0, np.int64)
        q = np.floor((P - self.grid0) / self.h).astype(np.int64)
        vk = (q[:, 0] * self.dims[1] + q[:, 1]) * self.dims[2] + q[:, 2]
        vmark = np.isin(vk, cells)
        self.ids = np.flatnonzero(vmark[F].any(axis=1))
        T = V[F[self.ids]] - self.origin
        c = T.mean(axis=1)
        self.centroids_local = c
        self.big = np.zeros(0, np.int64)
        self.cells = cells
        self.tree = cKDTree(c) if self.ids.size else None
        return True

    def _covers(self, C, R):
        if self.cells is None:
            return True
        lo = (C - R[:, None]).min(axis=0) - 2 * self.r_cut + self.origin
        hi = (C + R[:, None]).max(axis=0) + 2 * self.r_cut + self.origin
        k = self._cell_keys(lo, hi)
        if k is None:
            return False
        pos = np.minimum(np.searchsorted(self.cells, k), len(self.cells) - 1)  # cells: sorted, unique
        return bool(len(self.cells) and (self.cells[pos] == k).all())

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
        if self._covers(C, R):
            tree, ids = self.tree, self.ids
        else:  # the query leaves the indexed region: use every face
            if self._full is None:
                self._index_all()
            tree, ids = self._full, None
        if tree is None:
            lists = [[] for _ in range(len(C))]
        else:
            lists = tree.query_ball_point(C, R + self.r_cut, return_sorted=False)
        cnt = np.fromiter((len(x) for x in lists), np.int64, len(lists))
        ai = np.repeat(np.arange(len(C)), cnt)
        bi = np.fromiter((j for x in lists for j in x), np.int64, int(cnt.sum()))
        if ids is not None:
            bi = ids[bi]
        if self.big.size and ids is None:
            cb, rb = self.centroids[self.big], self.radius[self.big]
            step = max(1, 4_000_000 // self.big.size)
            extra_a, extra_b = [ai], [bi]
            for s in range(0, len(C), step):
                d = np.linalg.norm(C[s:s + step, None, :] - cb[None], axis=2)
                a2, b2 = np.nonzero(d <= R[s:s + step, None] + rb[None])
                extra_a.append(a2 + s)
                extra_b.append(self.big[b2])
            ai, bi = np.concatenate(extra_a), np.concatenate(extra_b)
        return ai, bi


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
    c = Q.mean(axis=1)
    r = np.linalg.norm(Q - c[:, None, :], axis=2).max(axis=1)
    ai, bi = index.candidate_pairs(c, r)
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


def self_intersections(V, F):
    """Number of intersecting pairs among the triangles of one mesh."""
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if len(F) < 2:
        return 0
    index = TriangleIndex(V, F, origin=V.mean(axis=0))
    Q = V[F] - index.origin
    ai, bi = index.candidate_pairs(index.centroids, index.radius)
    m = ai != bi
    pairs = np.unique(np.column_stack([np.minimum(ai[m], bi[m]), np.maximum(ai[m], bi[m])]), axis=0)
    ai, bi = pairs[:, 0], pairs[:, 1]
    amin, amax = Q[ai].min(axis=1), Q[ai].max(axis=1)
    bmin, bmax = Q[bi].min(axis=1), Q[bi].max(axis=1)
    keep = np.all((amin <= bmax) & (bmin <= amax), axis=1)
    ai, bi = ai[keep], bi[keep]
    hits = 0
    for s in range(0, len(ai), 200_000):
        sl = slice(s, s + 200_000)
        hits += int(pair_intersections(Q[ai[sl]], F[ai[sl]], Q[bi[sl]], F[bi[sl]]).sum())
    return hits
