"""One test hole cut into intact scan: where the order test may place it, and what it removes.

The order test (:mod:`shellrepair.fill.probe`) asks the scan beside a hole
how each candidate fills a hole like it. This module cuts one such test
hole (:func:`cut_test_hole`): the hole's outline (:func:`hole_outline`, or a
disc, :func:`hole_radius`, :func:`outline_narrow_axis`) laid on the scan's
tangent plane at a scan vertex, the faces within it taken away, with a
margin of intact scan around it. A placement is refused where the scan
there is not intact (an open edge of another hole or of the scan's border
within the margin), not one piece of surface (a thin part's far side
within the outline), or where the cut would leave anything but one rim
(:func:`rim_tails` for the region's own rim). Where the scan stands across
the hole, the test hole stops at creases
(:func:`shellrepair.fill.creases.crease_cut`).

The walk of a placement's region is compiled
(:func:`shellrepair.fill.probe_kernels.placement`) over the adjacency of the
faces near the hole (:func:`near_scan`, kept with the scan for its other
holes); the NumPy steps are kept as its fallback and oracle.
"""

from __future__ import annotations

import weakref

import numpy as np

from shellrepair import compiled
from shellrepair.fill import probe_kernels
from shellrepair.fill.creases import crease_cut
from shellrepair.mesh.geometry import cross
from shellrepair.mesh.topology import boundary_half_edges, half_edge_ends

__all__ = ["hole_radius", "hole_outline", "outline_narrow_axis", "inside_polygon", "inside_polygon_reference",
           "rim_tails", "near_scan", "cut_test_hole", "EDGES_AFTER", "COMPILED_WALK"]


def hole_radius(V, loop):
    """Radius of the disc of the hole's area: the rim projected on its
    best-fit plane, its polygon area A, ``sqrt(A / pi)``; at most the rim's
    largest distance from its centroid.

    Parameters
    ----------
    V : (n,3) float64
    loop : (k,) int64

    Returns
    -------
    r : float
    """
    P = np.asarray(V, np.float64)[np.asarray(loop, np.int64)]
    c = P.mean(axis=0)
    Q = P - c
    _, _, vt = np.linalg.svd(Q, full_matrices=False)
    x, y = Q @ vt[0], Q @ vt[1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    rmax = float(np.sqrt((Q * Q).sum(axis=1).max()))
    return min(float(np.sqrt(area / np.pi)), rmax)


def hole_outline(V, loop):
    """The hole's rim in its best-fit plane: (outline (k,2) about the rim's
    centroid, in-plane axes e1, e2 (3,), normal (3,))."""
    P = np.asarray(V, np.float64)[np.asarray(loop, np.int64)]
    Q = P - P.mean(axis=0)
    _, _, vt = np.linalg.svd(Q, full_matrices=False)
    return np.column_stack([Q @ vt[0], Q @ vt[1]]), vt[0], vt[1], vt[2]


def outline_narrow_axis(poly):
    """The half width of a closed polygon (k,2) across its narrow axis:
    twice the square root of the smaller eigenvalue of its area's second
    moments about its centroid (the minor semi-axis of the ellipse with the
    same moments; a disc's radius for a disc)."""
    x, y = np.asarray(poly, np.float64).T
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    A = cr.sum() / 2.0
    if abs(A) <= 0:
        return 0.0
    cx = ((x + xn) * cr).sum() / (6.0 * A)
    cy = ((y + yn) * cr).sum() / (6.0 * A)
    sxx = ((x * x + x * xn + xn * xn) * cr).sum() / (12.0 * A) - cx * cx
    syy = ((y * y + y * yn + yn * yn) * cr).sum() / (12.0 * A) - cy * cy
    sxy = ((x * yn + 2 * x * y + 2 * xn * yn + xn * y) * cr).sum() / (24.0 * A) - cx * cy
    lam = np.linalg.eigvalsh(np.array([[sxx, sxy], [sxy, syy]]))[0]
    return float(2.0 * np.sqrt(max(lam, 0.0)))


def inside_polygon(x, y, poly):
    """Even-odd test of points (x, y) against a closed polygon (k,2):
    compiled (:func:`shellrepair.fill.probe_kernels.inside_polygon`) where
    the kernels are on, else :func:`inside_polygon_reference` (the same
    answer)."""
    if compiled.ENABLED:
        return probe_kernels.inside_polygon(x, y, poly)
    return inside_polygon_reference(x, y, poly)


def inside_polygon_reference(x, y, poly):
    """:func:`inside_polygon` in NumPy (the compiled kernel's test oracle)."""
    x = np.asarray(x, np.float64)[:, None]
    y = np.asarray(y, np.float64)[:, None]
    ax, ay = poly[:, 0][None], poly[:, 1][None]
    bx, by = np.roll(poly[:, 0], -1)[None], np.roll(poly[:, 1], -1)[None]
    straddle = (ay > y) != (by > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = ax + (y - ay) * (bx - ax) / (by - ay)
    return (straddle & (x < xc)).sum(axis=1) % 2 == 1


def _component(F, seed_faces):
    """Faces of ``F`` connected to ``seed_faces`` through shared edges (local ids)."""
    from shellrepair.mesh.components import connected_components

    m = len(F)
    if m == 0:
        return np.zeros(0, np.int64)
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    fid = np.tile(np.arange(m), 3)
    key = E[:, 0] * (int(F.max()) + 1) + E[:, 1]
    order = np.argsort(key)        # (any order of equal keys: the same edges, so the same components)
    ks = key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    a, b = fid[order[same]], fid[order[same + 1]]
    _, lab = connected_components(m, a, b)
    keep = np.zeros(int(lab.max()) + 1, bool)
    keep[lab[seed_faces]] = True
    return np.flatnonzero(keep[lab])


def _frame(P, e1, n0):
    """In-plane axes (a, b) of the tangent plane at a vertex, from its
    faces' corners ``P`` (f,3,3) relative to it: the normal of those faces
    summed, ``a`` the hole's axis ``e1`` turned into the plane, ``b`` on the
    side that keeps the outline's turn (``n0``); None without a normal."""
    nrm = cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]).sum(axis=0)
    ln = float(np.linalg.norm(nrm))
    if ln <= 0:
        return None
    nrm /= ln
    a = e1 - (e1 @ nrm) * nrm
    if np.linalg.norm(a) < 1e-6:      # the hole's axis along this normal: any in-plane axis
        a = cross(nrm, np.array([1.0, 0.0, 0.0] if abs(nrm[0]) < 0.9 else [0.0, 1.0, 0.0]))
    a /= np.linalg.norm(a)
    b = cross(nrm, a)
    if n0 @ nrm < 0:                   # the outline's turn kept: its normal on the surface's side
        b = -b
    return a, b


def _open_edge_within(T, n, dist, limit):
    """Whether an edge used by one face of ``T`` only has a corner closer
    than ``limit`` (``dist`` per vertex). Such an edge lies on a boundary
    loop or chain of ``T``, so :func:`cut_test_hole` refuses the placement either
    way; answered by one sort of the edges instead of walking the loops
    (measured on eval's seed 503915309, case 4: 1786 of 3633 placements end
    there, 6.9 of 13.5 s before)."""
    E = half_edge_ends(T, boundary_half_edges(T, n))
    return bool(len(E) and (np.minimum(dist[E[:, 0]], dist[E[:, 1]]) < limit).any())


class _NearEdges:
    """The edges of the faces near a hole, sorted once for every placement
    of :func:`cut_test_hole` (which before sorted each placement's region again).

    ``eid`` (m,3): each near face's edges, as ids into ``ends`` (e,2), the
    edges' corners (global vertex ids); the faces of edge ``i`` are
    ``faces[start[i]:start[i + 1]]`` (positions in ``near_f``).
    """

    def __init__(self, F, near_f, n):
        Fn = np.asarray(F[near_f], np.int64)
        m = len(Fn)
        E = np.sort(np.stack([Fn[:, [0, 1]], Fn[:, [1, 2]], Fn[:, [2, 0]]], axis=1), axis=2)
        key = (E[..., 0] * np.int64(n) + E[..., 1]).ravel()
        order = np.argsort(key)
        ks = key[order]
        new = np.ones(len(ks), bool)
        new[1:] = ks[1:] != ks[:-1]
        inv = np.empty(len(ks), np.int64)
        inv[order] = np.cumsum(new) - 1
        uk = ks[new]
        self.eid = inv.reshape(m, 3)
        self.ends = np.column_stack([uk // n, uk % n])
        self.faces = order // 3
        self.start = np.append(np.flatnonzero(new), len(ks))
        self.m = m
        self.n_edges = len(uk)
        # where every edge has one or two faces: the face across each edge
        # of each face (``m`` where none), for a cheaper gather
        many = np.diff(self.start)
        self.across = None
        if m and many.max() <= 2:
            other = np.full(len(ks), m, np.int64)
            two = np.flatnonzero(many == 2)
            a, b = self.start[two], self.start[two] + 1
            other[order[a]] = self.faces[b]
            other[order[b]] = self.faces[a]
            self.across = other.reshape(m, 3)

    def component(self, pos, seed):
        """Of the near faces at positions ``pos`` (sorted), those joined to
        ``pos[seed]`` through edges shared within ``pos``: their indices
        into ``pos`` (sorted), as :func:`_component` finds them."""
        from shellrepair.mesh.components import connected_components

        k = len(pos)
        loc = np.full(self.m + 1, -1, np.int64)
        loc[pos] = np.arange(k)
        if self.across is not None:
            src = np.repeat(np.arange(k, dtype=np.int64), 3)
            dst = loc[self.across[pos]].ravel()
            ok = dst > src          # each pair once (and no face outside ``pos``)
            _, lab = connected_components(k, src[ok], dst[ok])
            keep = np.zeros(int(lab.max()) + 1, bool)
            keep[lab[seed]] = True
            return np.flatnonzero(keep[lab])
        e = self.eid[pos].ravel()
        lo = self.start[e]
        cnt = self.start[e + 1] - lo
        src = np.repeat(np.arange(k, dtype=np.int64), 3)
        src = np.repeat(src, cnt)
        first = np.repeat(lo - np.concatenate([[0], np.cumsum(cnt)[:-1]]), cnt)
        dst = loc[self.faces[first + np.arange(len(src))]]
        ok = dst > src          # each pair once (the other way and a face with itself left out)
        _, lab = connected_components(k, src[ok], dst[ok])
        keep = np.zeros(int(lab.max()) + 1, bool)
        keep[lab[seed]] = True
        return np.flatnonzero(keep[lab])

    def open_edge_within(self, V, pos, p, limit):
        """:func:`_open_edge_within` of the near faces at ``pos``, the
        distances measured from ``p``: the same answer from the edges
        sorted once."""
        e = self.eid[pos].ravel()
        once = np.bincount(e, minlength=self.n_edges)[e] == 1
        if not once.any():
            return False
        ends = self.ends[e[once]]
        D = V[ends.ravel()] - p
        d = np.sqrt((D * D).sum(axis=1)).reshape(-1, 2)
        return bool((np.minimum(d[:, 0], d[:, 1]) < limit).any())


#: The near scan's edges are sorted once for all placements
#: (:class:`_NearEdges`) when the placements' regions have added up to this
#: many times its faces; before, each placement sorts its own region's
#: (the same answers either way; only the cost differs).
EDGES_AFTER = 0.5
#: Placements walked by the compiled kernel (:mod:`shellrepair.fill.probe_kernels`)
#: where the kernels are on; False: by the NumPy steps (the centroid tree,
#: the edge sort and labelling), the same test holes to the bit, slower
#: (on an armadillo with 257 holes, 4.5 s of placements against 1.1 s).
COMPILED_WALK = True
#: Near scans kept per scan (:func:`near_scan`): a scan's holes and scales
#: often reach the same faces (on a small object, all of them).
NEAR_KEPT = 2
_NEAR_CACHE = weakref.WeakKeyDictionary()


class _Near:
    """The faces near a hole (``faces``, positions into the scan's ``F``;
    ``corners``, their rows of ``F``), the vertices they use, their
    adjacency for the compiled placement walk (:meth:`adjacency`), and for
    the NumPy steps their centroids' tree and their edges
    (:class:`_NearEdges`, sorted once enough placements need them)."""

    def __init__(self, V, F, near_f, vpos=None):
        self.V, self.F, self.faces = V, F, near_f
        self.vpos = vpos                           # the scan's vertex scratch (ScanContext.vpos()), or None
        self.corners = np.ascontiguousarray(F[near_f], np.int64)     # (m,3) vertex ids
        mark = np.zeros(len(V), bool)
        mark[self.corners] = True
        self.verts = np.flatnonzero(mark)          # np.unique's, without its sort
        self._tree = None
        self._adjacency = None
        self.edges = None
        self.sorted_faces = 0

    @property
    def tree(self):
        """A tree of the faces' centroids (the NumPy placement's region query)."""
        if self._tree is None:
            from scipy.spatial import cKDTree

            self._tree = cKDTree(self.V[self.corners].mean(axis=1))
        return self._tree

    def adjacency(self):
        """(start, pos, across) of :func:`shellrepair.fill.probe_kernels.near_adjacency`
        over :attr:`verts`' numbering, for the compiled placement; None with
        the kernels off, or where the faces are not a plain surface (a
        degenerate face, an edge of three faces): the NumPy placement then."""
        if self._adjacency is None:
            self._adjacency = False
            if compiled.ENABLED and COMPILED_WALK:
                if self.vpos is not None:       # each corner's place in verts, by the scan's scratch
                    vp = self.vpos
                    vp[self.verts] = np.arange(len(self.verts))
                    lc = vp[self.corners]
                    vp[self.verts] = -1
                else:
                    lc = np.searchsorted(self.verts, self.corners)
                start, pos, across, ok = probe_kernels.near_adjacency(lc, len(self.verts))
                if ok:
                    self._adjacency = (start, pos, across)
        return self._adjacency or None

    def ends(self, pids, shape, margin):
        """{vertex id: whether the compiled walk ends its placement} for the
        candidate centres ``pids`` (:func:`probe_kernels.placement_statuses`,
        one call for all: most end at an open edge near them, and each
        :func:`cut_test_hole` call cost 0.2 ms on a scan with a thousand holes);
        None where the walk is not compiled (:meth:`adjacency`)."""
        adj = self.adjacency()
        if adj is None or len(pids) == 0:
            return None
        start, fpos, across = adj
        _, R, limit = _reaches(shape[0], margin)
        pids = np.asarray(pids, np.int64)
        status = probe_kernels.placement_statuses(self.V, self.corners, across, start, fpos,
                                                  np.searchsorted(self.verts, pids), pids, R, limit)
        return dict(zip(pids.tolist(), (status != 0).tolist()))

    def edges_for_placement(self, k):
        """The edges sorted once, for a placement whose region has ``k``
        faces: None (the placement sorts its own region's) until the
        placements have sorted ``EDGES_AFTER`` times as many faces as
        the near scan has."""
        if self.edges is None:
            self.sorted_faces += k
            if self.sorted_faces < EDGES_AFTER * len(self.faces):
                return None
            self.edges = _NearEdges(self.F, self.faces, len(self.V))
        return self.edges


def near_scan(ctx, near_f):
    """:class:`_Near` of ``near_f`` in ``ctx``, kept with the scan for its
    other holes and scales (the same faces give the same tree and edges)."""
    kept = _NEAR_CACHE.setdefault(ctx, [])
    for nr in kept:
        if nr.V is ctx.V and nr.F is ctx.F and np.array_equal(nr.faces, near_f):
            return nr
    # (the scratch array, not the context: what the cache keeps must not
    # keep the context, its weak key, alive)
    nr = _Near(ctx.V, ctx.F, near_f, ctx.vpos())
    kept.insert(0, nr)
    del kept[NEAR_KEPT:]
    return nr


def _own_frame(V, p, T, outline, r_out, e1, n0):
    """The tangent frame at the vertex at ``p`` (:func:`_frame`) from its
    faces' corners ``T`` (f,3), or None where it has none or no face of it
    lies inside the outline laid there (an outline narrower than the scan's
    faces: no test hole, known before the region's pieces and loops are
    walked)."""
    P0 = V[T] - p
    frame = _frame(P0, e1, n0)
    if frame is None:
        return None
    a, b = frame
    own = inside_polygon((P0 @ a).ravel(), (P0 @ b).ravel(), outline).reshape(-1, 3) \
        & (np.sqrt((P0 * P0).sum(axis=2)) <= r_out)
    return frame if own.all(axis=1).any() else None


def _region(V, near, p_id, p, R, limit, outline, r_out, e1, n0):
    """:func:`cut_test_hole`'s region in NumPy (the kernels off, or near faces that
    are not a plain surface): the faces within ``R`` of ``p`` from the
    centroids' tree, those joined to the vertex's faces, the open-edge
    verdict where the near scan's edges are sorted (else :func:`cut_test_hole`
    gives it). Returns (positions in ``near``, their corners, the frame,
    the sorted edges or None) or None where no test hole fits."""
    # a face with every corner within R has its centroid within R: the
    # centroids' tree gives the few faces to test, in near's order
    sub = np.sort(np.asarray(near.tree.query_ball_point(p, R), np.int64))
    D = V[near.corners[sub]] - p
    D *= D                     # each corner's distance, its squares summed in order (x, y, z)
    dv = np.sqrt(D[..., 0] + D[..., 1] + D[..., 2])
    pos = sub[(dv[:, 0] <= R) & (dv[:, 1] <= R) & (dv[:, 2] <= R)]
    if pos.size == 0:
        return None
    T = near.corners[pos]
    seed = np.flatnonzero((T[:, 0] == p_id) | (T[:, 1] == p_id) | (T[:, 2] == p_id))
    if seed.size == 0:
        return None
    frame = _own_frame(V, p, T[seed], outline, r_out, e1, n0)
    if frame is None:
        return None
    # the region's own boundary: only at its outer edge (else a hole or border
    # is near); what the walk of :func:`cut_test_hole` finds, for less work: most placements end here
    edges = near.edges_for_placement(len(pos))
    if edges is not None:          # the near scan's edges, sorted once
        comp = edges.component(pos, seed)
        if edges.open_edge_within(V, pos[comp], p, limit):
            return None
    else:                          # the region's edges sorted here (the same answers)
        comp = _component(T, seed)
    return pos[comp], T[comp], frame, edges


def _reaches(outline, margin):
    """A test hole's reaches from its centre: (the outline's, the region's
    ``R`` with its margin, the ``limit`` within which an open edge refuses
    the placement)."""
    r_out = float(np.sqrt((outline * outline).sum(axis=1).max()))
    R = r_out + margin
    return r_out, R, R - margin * 0.5


def rim_tails(T, n):
    """The tails of the boundary half-edges of faces ``T`` (vertex ids below
    ``n``), or None where they do not all close into loops: the vertices of
    :func:`~shellrepair.holes.loops.boundary_loops`' loops and its verdict
    on chains, without walking them (the half-edges close into loops
    exactly where every vertex has as many leaving as arriving;
    ``tests/test_selftest.py`` checks both against the walk).

    Parameters
    ----------
    T : (m,3) int64
    n : int

    Returns
    -------
    tails : (b,) int64 or None
    """
    src, dst = half_edge_ends(T, boundary_half_edges(T, n)).T
    if not np.array_equal(np.bincount(src, minlength=n), np.bincount(dst, minlength=n)):
        return None
    return src


def cut_test_hole(V, F, near, p_id, shape, margin, crease=None):
    """A test hole of the hole's shape around scan vertex ``p_id``, with
    ``margin`` of intact scan around it; None where the scan is not intact
    and one piece of surface there.

    ``near``: :class:`_Near` (the faces near the hole, their adjacency;
    for the NumPy steps their centroids' tree and edges).
    ``shape``: (outline (k,2), e1, normal) of the hole, scaled: the outline
    is laid on the scan's tangent plane at the vertex, its first axis
    ``e1`` turned into that plane (the hole's orientation kept).
    ``crease``: None, or the cosine below which an edge is a crease: the
    test hole is then the faces joined to the one at its centre across
    edges that are not creases (:data:`shellrepair.fill.creases.CREASE_DEGREES`),
    with the relief they enclose (:func:`shellrepair.fill.creases.crease_cut`).

    Returns (Vl, Fl, ploop, Q): local positions, the local scan with the
    test hole cut, the test hole's loop (local ids) and the removed
    vertices' positions.
    """
    from shellrepair.holes.loops import boundary_loops

    outline, e1, n0 = shape
    p = V[p_id]
    r_out, R, limit = _reaches(outline, margin)
    adj = near.adjacency()
    edges = None
    if adj is not None:
        # the region walked from the vertex's faces, compiled: the faces
        # within R joined to them across shared edges, the walk stopped at
        # an open edge closer than limit (a hole or border near); the same
        # faces and verdict as the NumPy steps below (tests/test_selftest.py)
        start, fpos, across = adj
        status, cpos, spos = probe_kernels.placement(V, near.corners, across, start, fpos,
                                                     int(np.searchsorted(near.verts, p_id)), p, R, limit)
        if status != 0:
            return None
        frame = _own_frame(V, p, near.corners[spos], outline, r_out, e1, n0)
        if frame is None:
            return None
        T = near.corners[cpos]
        open_checked = True
    else:
        got = _region(V, near, p_id, p, R, limit, outline, r_out, e1, n0)
        if got is None:
            return None
        cpos, T, frame, edges = got
        open_checked = edges is not None
    a, b = frame
    g, Tl = np.unique(T, return_inverse=True)
    Tl = Tl.reshape(-1, 3).astype(np.int64)
    Vg = V[g] - p
    dl = np.sqrt((Vg * Vg).sum(axis=1))
    pl = int(np.searchsorted(g, p_id))
    if not open_checked and _open_edge_within(Tl, len(g), dl, limit):
        return None
    inside = inside_polygon(Vg @ a, Vg @ b, outline) & (dl <= r_out)
    disc = inside[Tl].all(axis=1)
    seed = np.flatnonzero(disc & (Tl == pl).any(axis=1))
    if seed.size == 0:
        return None
    # a test hole removes the vertices whose faces it all takes, and it
    # takes only faces within the outline: where no vertex has all its
    # faces there, it removes none (nothing to measure against), known
    # before the region's rim, pieces and loops are walked (on a star's
    # small holes most placements end here: 229 of 340 on case 15 of seed
    # 865890797)
    enclosed = np.zeros(len(g), bool)
    enclosed[Tl[disc]] = True
    enclosed[Tl[~disc]] = False
    if not enclosed.any():
        return None
    # the region's own rim: closed loops, none of their vertices closer than ``limit``
    src = rim_tails(Tl, len(g))
    if src is None or (len(src) and dl[src].min() < limit):
        return None
    on_edge = np.zeros(len(g), bool)
    on_edge[src] = True
    dfaces = np.flatnonzero(disc)
    dseed = np.flatnonzero((Tl[dfaces] == pl).any(axis=1))
    if adj is not None:
        keep_d = probe_kernels.component_within(adj[2], cpos[dfaces], dseed)
    elif edges is not None:
        keep_d = edges.component(cpos[dfaces], dseed)
    else:
        keep_d = _component(Tl[dfaces], dseed)
    cut = np.zeros(len(Tl), bool)
    cut[dfaces[keep_d]] = True
    if (disc & ~cut).any():
        return None          # faces of another sheet within the outline: not one piece of surface there
    if crease is not None:
        # stopped at creases: the part beyond one stays scan, the crease its
        # rim; relief that the rest encloses is cut with it
        kept = dfaces[keep_d]
        sub = crease_cut(Vg, Tl[kept], int(np.searchsorted(keep_d, dseed[0])), crease)
        if len(sub) < len(kept):
            cut = np.zeros(len(Tl), bool)
            cut[kept[sub]] = True
    Fk = Tl[~cut]
    lk, ck = boundary_loops(Fk, len(g))
    if ck:
        return None
    inner_loops = [L for L in lk if not on_edge[L].any()]
    if len(inner_loops) != 1:
        return None
    ploop = np.asarray(inner_loops[0], np.int64)
    used = np.zeros(len(g), bool)
    used[Fk] = True
    removed = np.unique(Tl[cut])
    removed = removed[~used[removed]]
    if removed.size == 0 or len(ploop) < 3:
        return None
    # keep only the vertices the kept faces use (the removed ones are measured against)
    ids = np.flatnonzero(used)
    remap = np.full(len(g), -1, np.int64)
    remap[ids] = np.arange(ids.size)
    Vl = V[g]
    return Vl[ids], remap[Fk], remap[ploop], Vl[removed]
