"""Which patch continues this scan best, asked of the scan at the hole's own size.

:func:`probe_errors` cuts test holes of the hole's own size (its own
outline; where that fits nowhere, a disc as wide as the hole across its
narrow axis, :func:`outline_narrow_axis`, then a disc of the hole's area,
:func:`hole_radius`) into intact scan next to the hole,
fills each with every candidate fairing order exactly as a hole is
filled (triangulate, refine, fair: :func:`_refined`
and :func:`shellrepair.fill.fair.fair_patch_orders`), and measures each fill
against the scan that was cut away: the RMS distance of the removed
vertices to the filled surface. Each candidate's errors on the probes
are combined by their geometric mean (each probe weighs alike,
:class:`Pooled`); the candidate with the lowest wins (:func:`shellrepair.fill.selftest.choose_order`).

Why at the hole's own size: the orders differ most deep inside a hole, and
how much depends on the hole's size against the surface's curvature and
relief. A band a few rings wide next to the rim (the earlier test) sees
only the first rings, where every order is close to the scan; a small
hole's verdict says nothing of a large one's.

A real rim is often rougher than intact scan (a scanner's ragged fringe
at the edge of what it saw), and a higher order carries that noise on into
the hole. So each test hole's rim is given the real rim's roughness
(:func:`shellrepair.fill.roughness.rim_roughness`, the offsets along the normal that the real rim has
beyond the test rim's own, drawn from a fixed seed): on a sphere with a
clean rim order 3 wins; with the rim moved by noise of 0.5 % of the radius
order 2 does, and the choice follows (tests/test_repair.py).

Where the scan stands across the hole (:func:`shellrepair.fill.creases.walled`:
walls around it, as on a CAD part whose face the views missed up to its
creases), a test hole stops at creases (:mod:`shellrepair.fill.creases`), so
that it too is met by walls standing across it.

A probe is placed where the disc and a margin of ``MARGIN_EDGES`` rim
edges (at least ``MARGIN_FACES`` of the rim faces' longest edges) around
it are intact scan: no boundary edge (of a hole or of the
scan's border) inside, and the disc one piece of surface (a thin part
whose far side comes within the radius is not a disc). Candidates are the
scan vertices in shells around the hole, from just outside its rim
outwards (``SHELLS``); up to ``PROBES`` of them are taken, each as far as
possible from those already taken (the same ones for the same scan). A
test hole too small for a vertex of its own fills alike at every order and
does not count. Where fewer than ``MIN_PROBES`` probes fit at the hole's
size and at half of it (the hole is as large as the intact scan around
it), the scan cannot tell, and the caller falls back to a documented
default.
"""

from __future__ import annotations

import weakref

import numpy as np

from shellrepair import compiled
from shellrepair.fill import probe_kernels
from shellrepair.fill.creases import CREASE_DEGREES, crease_cut, walled
from shellrepair.fill.roughness import rim_roughness, roughen
from shellrepair.mesh.geometry import cross, mean_edge
from shellrepair.mesh.topology import boundary_half_edges, half_edge_ends

__all__ = ["hole_radius", "probe_errors", "inside_polygon", "inside_polygon_reference", "mean_edge",
           "Pooled", "PROBES"]

#: Test holes per real hole.
PROBES = 3
#: Intact scan kept around a test hole, in rim edges (the fairing reads 3 rings).
MARGIN_EDGES = 5.0
#: ... and at least this many times the mean longest edge of the scan
#: faces at the rim: a placement is refused where the faces within its
#: reach leave an edge closer than half the margin to its centre, so a
#: margin under two faces' size refuses every placement (a rim of short
#: edges between long faces: a disc cut across a torus's coarse grid,
#: rim edges 0.0104, its faces' longest 0.031).
MARGIN_FACES = 3.0
#: Shells searched for probe centres: distance from the hole's rim, in units
#: of the probe's radius (inner, outer), tried in turn until ``PROBES`` fit.
SHELLS = ((1.2, 2.5), (2.5, 5.0), (5.0, 10.0))
#: Probe radii tried, in units of the hole's (:func:`hole_radius`): the
#: hole's own size first; half of it only where fewer than ``MIN_PROBES``
#: probes of that size fit. A quarter is not tried: a test hole of a
#: sixteenth of the hole's area does not say how each order carries the rim
#: across the hole. Per-hole screens (eval/results/order-test/rim-density/) found
#: the test's verdicts at a quarter of the size worse than order 2 alone on
#: design and development seeds alike. Where the quarter goes, a verdict
#: from one test hole is not taken either (``MIN_PROBES``): an armadillo's
#: 876-edge occlusion that one test hole of half its size gave order 3
#: left the case at 3.14 per mille against 1.02 at order 2.
SCALES = (1.0, 0.5)
#: Test holes a scale needs before its verdict is taken (one alone is not
#: repeated evidence: a single disc of the hole's area laid over a fat
#: torus's tube, or over an armadillo's relief, ranked the orders the
#: other way round from the real hole, where the next scale's 3 test holes
#: ranked them as the real hole does; see :func:`probe_errors`). Where no
#: scale reaches it, the scan cannot tell (no errors).
MIN_PROBES = 2
#: Corners of the disc tried where no test hole of the hole's outline fits
#: (an outline too long for the intact scan around it, such as a slit's).
DISC_POINTS = 32
#: Candidate centres checked per shell (spread evenly over the shell's vertices).
CENTRES_PER_SHELL = 24
#: Seed of the offsets that give a test hole's rim the real rim's roughness
#: (:func:`shellrepair.fill.roughness.roughen`): the same offsets for the same scan.
ROUGHNESS_SEED = 0
#: Cotangent rounds of the test's fairing (the fill itself uses
#: ``fair.COTAN_ROUNDS``); fewer make the test cheaper.
TEST_ROUNDS = 2
#: A test hole that refined at the rim's density would have more than this
#: many new vertices is refined at ``TEST_COARSEN`` times the rim's edge
#: length instead (about ``TEST_COARSEN²`` times fewer unknowns).
TEST_MAX_UNKNOWNS = 1000
TEST_COARSEN = 2.0


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
    loop or chain of ``T``, so :func:`_probe` refuses the placement either
    way; answered by one sort of the edges instead of walking the loops
    (measured on eval's seed 503915309, case 4: 1786 of 3633 placements end
    there, 6.9 of 13.5 s before)."""
    E = half_edge_ends(T, boundary_half_edges(T, n))
    return bool(len(E) and (np.minimum(dist[E[:, 0]], dist[E[:, 1]]) < limit).any())


class _NearEdges:
    """The edges of the faces near a hole, sorted once for every placement
    of :func:`_probe` (which before sorted each placement's region again).

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
#: Near scans kept per scan (:func:`_near`): a scan's holes and scales
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
        :func:`_probe` call cost 0.2 ms on a scan with a thousand holes);
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


def _near(ctx, near_f):
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
    """:func:`_probe`'s region in NumPy (the kernels off, or near faces that
    are not a plain surface): the faces within ``R`` of ``p`` from the
    centroids' tree, those joined to the vertex's faces, the open-edge
    verdict where the near scan's edges are sorted (else :func:`_probe`
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
    # is near); what the walk of :func:`_probe` finds, for less work: most placements end here
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


def _faces_within(V, F, faces, c, reach):
    """The faces of ``faces`` with a corner within ``reach`` of ``c`` (in their order)."""
    if compiled.ENABLED:
        return probe_kernels.faces_within(V, F, faces, c, reach)
    T = V[F[faces]]
    return faces[(((T - c) ** 2).sum(axis=2) <= reach * reach).any(axis=1)]


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


def _probe(V, F, near, p_id, shape, margin, crease=None):
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
    # the region's own rim: closed loops, none of their vertices closer than ``limit``
    src = rim_tails(Tl, len(g))
    if src is None or (len(src) and dl[src].min() < limit):
        return None
    on_edge = np.zeros(len(g), bool)
    on_edge[src] = True
    inside = inside_polygon(Vg @ a, Vg @ b, outline) & (dl <= r_out)
    disc = inside[Tl].all(axis=1)
    seed = np.flatnonzero(disc & (Tl == pl).any(axis=1))
    if seed.size == 0:
        return None
    # a test hole removes the vertices whose faces it all takes, and it
    # takes only faces within the outline: where no vertex has all its
    # faces there, it removes none (nothing to measure against), known
    # before the region's pieces and loops are walked
    enclosed = np.zeros(len(g), bool)
    enclosed[Tl[disc]] = True
    enclosed[Tl[~disc]] = False
    if not enclosed.any():
        return None
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


class Pooled:
    """Each candidate's error over the test holes (or bands): the
    geometric mean of each test's own RMS distance of the removed scan to
    the candidate's fill.

    Each test weighs alike, whatever its number of removed vertices: pooled
    over all removed vertices, as before, a test hole on finer scan
    outweighed the others (on a fat torus, one holding 4188 of the removed
    vertices, where order 3 lies 2x further than order 2, outweighed two
    where it is 5-8x truer), and one on a crease outweighed several on
    smooth scan. On the development seeds the regret went 1.1039 -> 1.0811,
    1.0072 -> 1.0118, 1.0764 -> 1.0668 (eval/results/order-test/rim-density/).
    """

    def __init__(self, candidates):
        self.candidates = tuple(candidates)
        self.logs = dict.fromkeys(self.candidates, 0.0)     # the sum over tests of log RMS
        self.tests = 0

    def add(self, distances):
        """One test: ``distances`` yields (candidate, (p,) distances) for
        every candidate, lazily; the first with a non-finite distance drops
        the whole test (the candidates after it are not built). Returns
        whether the test counted."""
        dd, n = {}, 0
        for o, e in distances:
            if not np.isfinite(e).all():
                return False
            dd[o] = float((e * e).sum())
            n = len(e)
        for o in self.candidates:
            self.logs[o] += 0.5 * np.log(max(dd[o] / max(n, 1), 1e-300))
        self.tests += 1
        return True

    def rms(self, keep=lambda o: True):
        """{candidate: geometric mean over the tests of their RMS} of those
        ``keep`` admits; empty before any test."""
        if not self.tests:
            return {}
        return {o: float(np.exp(self.logs[o] / self.tests)) for o in self.candidates if keep(o)}


class _RimDistance:
    """The distance of scan vertices near a hole to its rim (nearest rim
    vertex), measured only where a shell asks: a vertex farther than
    ``hi * r + h`` from the rim's centroid plus the rim's reach from it
    is farther than that from every rim vertex, so it is not measured for
    a shell ending at ``hi``. Each measured distance is the tree's answer
    for that vertex, whichever others are measured with it, so it is kept
    for the hole's other shells, scales and outlines (on an armadillo's 257
    holes the same vertices were measured again for each: 1.2 s of 8.5)."""

    def __init__(self, V, loop, c, rim_r):
        from scipy.spatial import cKDTree

        self.V, self.c, self.rim_r = V, c, rim_r
        self.tree = cKDTree(V[loop])
        self.ids = np.zeros(0, np.int64)         # measured vertices, ascending
        self.dist = np.zeros(0)                  # and their distances

    def of(self, verts, limit):
        """Distances of ``verts`` (ascending ids), measured at least for
        every one within ``limit`` of the rim (NaN for some beyond it)."""
        bound = self.rim_r + limit + 1e-9 * (abs(self.rim_r) + abs(limit)) + 1e-300
        if compiled.ENABLED:
            need = probe_kernels.within_distance(self.V, verts, self.c, bound)
        else:
            D = self.V[verts] - self.c
            need = np.flatnonzero(np.sqrt((D * D).sum(axis=1)) <= bound)    # within bound of the rim's centroid
        out = np.full(len(verts), np.nan)
        if need.size == 0:
            return out
        i = np.minimum(np.searchsorted(self.ids, verts[need]), max(len(self.ids) - 1, 0))
        known = self.ids[i] == verts[need] if len(self.ids) else np.zeros(need.size, bool)
        out[need[known]] = self.dist[i[known]]
        todo = need[~known]
        if todo.size:
            d = self.tree.query(self.V[verts[todo]])[0]
            out[todo] = d
            ids = np.concatenate([self.ids, verts[todo]])
            order = np.argsort(ids, kind="stable")
            self.ids, self.dist = ids[order], np.concatenate([self.dist, d])[order]
        return out


class _Rings:
    """The faces within some rings of a hole's rim, for each shell, scale
    and outline of its test: one walk (:meth:`ScanContext.ring_walk`)
    answers every ring count up to its own, so the rim is walked again only
    for more rings than any asked before (on a scan with a thousand holes,
    a walk for each shell, scale and outline cost 0.5 s)."""

    def __init__(self, ctx, loop):
        self.ctx, self.loop = ctx, loop
        self.walked = 0                  # rings of the walk kept
        self.found = self.off = None

    def faces(self, rings):
        """The faces of :meth:`ScanContext.ring_faces` of the rim and
        ``rings`` rings, in the walk's order (not sorted: the caller sorts
        what it keeps of them, a quarter or less at 10M faces, where
        sorting them all took 1.4 s of the order test's 22)."""
        rings = max(1, int(rings))
        if rings > self.walked:
            got = self.ctx.ring_walk(self.loop, rings)
            if got is None:                  # the kernels off: the NumPy walk
                return self.ctx.ring_faces(self.loop, rings)
            (self.found, self.off), self.walked = got, rings
        return self.found[:self.off[rings]]


def _longest_edges(V, T):
    """Mean over the faces ``T`` (f,3) of each one's longest edge (0 without faces)."""
    if len(T) == 0:
        return 0.0
    P = V[T]
    e = np.stack([((P[:, 1] - P[:, 0]) ** 2).sum(axis=1), ((P[:, 2] - P[:, 1]) ** 2).sum(axis=1),
                  ((P[:, 0] - P[:, 2]) ** 2).sum(axis=1)], axis=1)
    return float(np.sqrt(e.max(axis=1)).mean())


def _centres(rim_dist, verts, r, h, lo, hi):
    """Candidate probe centres in the shell ``lo..hi`` (units of ``r``)
    beyond the rim: scan vertices, an even spread over them.
    ``verts``: the vertices near the hole (ascending); ``rim_dist``: their
    distances to its rim (:class:`_RimDistance`)."""
    dist = rim_dist.of(verts, hi * r + h)
    sel = verts[(dist >= lo * r + h) & (dist <= hi * r + h)]
    if sel.size == 0:
        return sel
    if sel.size > CENTRES_PER_SHELL:
        sel = sel[np.round(np.linspace(0, sel.size - 1, CENTRES_PER_SHELL)).astype(np.int64)]
    return sel


def probe_errors(ctx, loop, candidates, max_probes=None):
    """RMS error of each candidate order on test holes of this hole's size.

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
    loop : (k,) int64
    candidates : sequence of int
        Fairing orders.
    max_probes : int, optional
        Default :data:`PROBES`.

    Returns
    -------
    errors : dict of int -> float
        RMS distance (scan units) of the removed scan to each candidate's
        fill, the geometric mean over the probes of each one's RMS
        (:class:`Pooled`); empty when no probe fits.
    probes : int
        How many test holes were filled.
    scale : float
        Their radius over the hole's (:data:`SCALES`; 0 when none fit).
    """

    V = ctx.V
    loop = np.asarray(loop, np.int64)
    r0 = hole_radius(V, loop)
    outline, e1, _, n0 = hole_outline(V, loop)
    t = np.linspace(0.0, 2.0 * np.pi, DISC_POINTS, endpoint=False)
    unit = np.column_stack([np.cos(t), np.sin(t)])
    # where the outline fits nowhere: first a disc as wide as the hole is
    # across its narrow axis (how far its middle lies from its rim, which is
    # what sets how far each order carries the rim on: a strip 2.1 x 0.45
    # under a torus's tube, whose disc of equal area, radius 0.5, wrapped
    # round the tube of radius 0.3 in every test hole and ranked order 2
    # first, 1.46 per mille where order 3 gives 0.13), then a disc of its area
    narrow = unit * min(r0, outline_narrow_axis(outline))
    disc = unit * r0
    # an outline that does not hold its own centre holds no face around a
    # probe's centre vertex either (that face has the vertex as a corner):
    # every placement would be refused, so it is not tried
    own = [outline] if inside_polygon(np.zeros(1), np.zeros(1), outline)[0] else []
    # the real rim's roughness, given to each test hole's rim (a ragged rim
    # is noise a higher order carries on into the hole)
    ring = ctx.F[ctx.ring_faces(loop, 1)]
    rough = rim_roughness(V, ring, loop)
    # the margin a placement needs where the scan's faces are longer than the rim's edges
    faces_margin = MARGIN_FACES * _longest_edges(V, ring)
    # the near vertices' distances to the rim, kept for every scale and outline
    c = V[loop].mean(axis=0)
    rim = _RimDistance(V, loop, c, float(np.sqrt(((V[loop] - c) ** 2).sum(axis=1)).max()))
    rings = _Rings(ctx, loop)
    crease = float(np.cos(np.radians(CREASE_DEGREES))) if walled(ctx, loop) else None
    # a hole as wide across its narrow axis as its area's disc: the narrow
    # disc is that disc, whose search would run twice to the same answer
    narrow_too = [] if np.array_equal(narrow, disc) else [narrow]
    for f in SCALES:          # the largest scale at which MIN_PROBES test holes fit
        small = False
        for shape in own + (narrow_too if f == 1.0 else []) + [disc]:   # the outline, the narrow disc, the disc of its area
            errors, n, alike = _probe_errors(ctx, loop, candidates, max_probes, f * r0, (f * shape, e1, n0), rough,
                                             rim, rings, faces_margin, crease)
            if n >= min(MIN_PROBES, PROBES if max_probes is None else int(max_probes)):
                return errors, n, f
            small = alike > 0 and not n
        if small:             # the disc of its area fits, too small for a vertex: smaller ones are too
            break
    return {}, 0, 0.0


def _probe_errors(ctx, loop, candidates, max_probes, r, shape, rough, rim, rings, faces_margin, crease=None):
    from shellrepair.errors import MeshError
    from shellrepair.fill.fair import fair_patch_orders
    from shellrepair.fill.patch import PatchError
    from shellrepair.mesh.distance import point_mesh_distance
    from shellrepair.mesh.index import ScanContext
    from shellrepair.mesh.io import Mesh

    max_probes = PROBES if max_probes is None else int(max_probes)
    V = ctx.V
    h = mean_edge(V, loop)
    r = max(r, float(np.sqrt((shape[0] ** 2).sum(axis=1).max())))   # the outline's reach from its centre
    if not np.isfinite(r) or r <= 0 or h <= 0:
        return {}, 0, 0
    margin = max(MARGIN_EDGES * h, faces_margin)
    c, rim_r = rim.c, rim.rim_r            # the rim's centroid and reach, measured once for the hole
    pool = Pooled(candidates)
    taken = []
    alike = 0                  # test holes with no vertex of their own
    for lo, hi in SHELLS:
        if pool.tests + alike >= max_probes:
            break
        # the scan near the hole, as far as this shell's test holes and their
        # margins reach: faces within as many rings of the rim as reach it at
        # half the rim's edge length, then those with a corner within reach
        # (a scan finer than that further out only loses far probes: a probe
        # whose surroundings are cut short fails its check). Walked shell by
        # shell, the outer shells only where the inner ones did not give the
        # test holes: a shell's candidates and test holes lie within its own
        # reach, so they are the ones the outermost shell's region gives
        # wherever the shorter ring walk reaches every face within that reach
        # (31 of 32 development cases gave the same bytes; on a rocker arm's
        # thin parts one test hole moved, RMS 20.11186 -> 20.11188 per
        # mille); at 10M faces the outermost region cost 1.4-1.8 s a hole,
        # most holes fit their test holes in the first shell.
        reach = rim_r + hi * r + r + margin + 2 * h
        near_f = rings.faces(int(np.ceil(2.0 * reach / h)))
        near_f = np.sort(_faces_within(V, ctx.F, near_f, c, reach))     # (a filter: sorting after it is the same)
        near = _near(ctx, near_f)
        cands = _centres(rim, near.verts, r, h, lo, hi)
        ends = near.ends(cands, shape, margin)
        # farthest first from what is taken (the first: the shell's first candidate)
        left = list(cands)
        while left and pool.tests + alike < max_probes:
            if taken:
                P = V[np.asarray(left)]
                dmin = np.min(np.sqrt(((P[:, None, :] - V[np.asarray(taken)][None]) ** 2).sum(axis=2)), axis=1)
                j = int(np.argmax(dmin))
                if dmin[j] < r:      # overlapping an earlier probe: nothing new
                    break
            else:
                j = 0
            pid = int(left.pop(j))
            if ends is not None and ends[pid]:
                continue         # (the compiled walk of its region ended it: _probe would say None)
            got = _probe(V, ctx.F, near, pid, shape, margin, crease)
            if got is None:
                continue
            Vl, Fl, ploop, Q = got
            Vl = roughen(Vl, Fl, ploop, rough, ROUGHNESS_SEED + len(taken), edge=h)
            origin = Vl.mean(axis=0)
            try:
                lctx = ScanContext(Mesh(V=Vl - origin, F=Fl))
                P0, T, _ = _refined(lctx, ploop, max(candidates))
            except (MeshError, PatchError, ValueError, IndexError):
                continue
            X0, Fs, nf, _, scale, org = P0
            if len(X0) == nf:
                # no vertex of its own: every order fills it alike, so it says
                # nothing of the order (counted, it made ties that order 2 took)
                alike += 1
                taken.append(pid)
                continue
            faired = [Xu for Xu, _ in fair_patch_orders(X0, Fs, nf, tuple(candidates), rounds=TEST_ROUNDS,
                                                         operator=False)]
            faired = as_filled(candidates, faired)
            Tp = Fs[len(Fs) - len(T):]
            if pool.add((o, point_mesh_distance(Q - origin, org + scale * np.vstack([X0[:nf], Xu]), Tp))
                        for o, Xu in zip(candidates, faired)):
                taken.append(pid)
    return pool.rms(), pool.tests, alike


def as_filled(candidates, faired):
    """Each candidate's patch as the fill would make it: order 3 only where
    it converges, that is where it departs from order 2 no more than order
    1 does (:func:`shellrepair.fill.hole._departs`, which keeps order 2 on a
    real hole otherwise), else order 2's patch in its place.

    A test hole where order 3 balloons would otherwise weigh against order
    3 everywhere, though the fill never keeps such a patch: on a torus of
    r/R 0.7 (case 2 of seed 114979771) one of two test holes beside a
    199-edge disc had order 3 sixteen times further from the scan than
    order 2, and the disc got order 2 (3.18 per mille) where order 3 gives
    0.44.

    Parameters
    ----------
    candidates : sequence of int
    faired : list of (u,3) float64
        Each candidate's new vertices, in ``candidates``' order.

    Returns
    -------
    filled : list of (u,3) float64
    """
    at = {o: i for i, o in enumerate(candidates)}
    if not all(o in at for o in (1, 2, 3)):
        return faired
    P1, P2, P3 = (faired[at[o]] for o in (1, 2, 3))
    d12 = float(np.sqrt(((P1 - P2) ** 2).sum(axis=1).mean()))
    d23 = float(np.sqrt(((P3 - P2) ** 2).sum(axis=1).mean()))
    if d23 <= d12:
        return faired
    out = list(faired)
    out[at[3]] = P2
    return out


def _refined(ctx, loop, rings):
    """The test hole triangulated and refined as :func:`~shellrepair.fill.patch.build_patch`
    does, in the hole's local frame, with ``rings`` rings of scan around it;
    at ``TEST_COARSEN`` times the rim's edge length when the rim's density
    would give more than ``TEST_MAX_UNKNOWNS`` new vertices.

    Returns ((X, Fs, nf, g, scale, origin), T, c): the submesh positions
    (fixed scan vertices first), its faces (the patch's last), the number
    of fixed vertices, their ids in ``ctx``, the frame, the patch
    triangles, and the refinement's edge length in rim edges (1 or
    ``TEST_COARSEN``).
    """
    from shellrepair.fill.refine import refine_patch, split_chords
    from shellrepair.fill.triangulate import triangulate_loop
    from shellrepair.mesh.index import local_frame, rim_data, submesh

    k = len(loop)
    sigma, edge_normals, forbidden = rim_data(ctx, loop)
    origin, scale, Pl = local_frame(ctx, loop, sigma)
    T = triangulate_loop(Pl, edge_normals, forbidden)
    # new vertices at the rim's density: ~ the area over an equilateral
    # triangle's, halved (a mesh has about half as many vertices as faces)
    e = Pl[T]
    area = 0.5 * np.linalg.norm(cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]), axis=1).sum()
    s2 = float(np.mean(sigma / scale)) ** 2
    c = TEST_COARSEN if area / (np.sqrt(3.0) / 4.0 * s2) / 2.0 > TEST_MAX_UNKNOWNS else 1.0
    Pl, T = refine_patch(Pl, T, c * sigma / scale, k, forbidden)
    Pl, T = split_chords(Pl, T, c * sigma / scale, k, forbidden)    # as a faired fill's
    g, Fs, nf, _ = submesh(ctx, loop, Pl, T, rings=rings)
    X = np.vstack([(ctx.V[g] - origin) / scale, Pl[k:]])
    return (X, Fs, nf, g, scale, origin), T, c
