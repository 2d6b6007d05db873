"""Choose a hole's fairing order by a test on the scan around it (``order="auto"``).

Which fairing order continues a scan best depends on the surface: order 3
(curvature continuous) extrapolates smooth and finely relieved surfaces
best, order 2 (thin plate) is safer where the rim carries noise or sharp
sculpted detail that order 3 would carry on into the hole. Instead of a
constant chosen on a benchmark, :func:`choose_order` asks the scan itself:

0. Order 3 needs a curvature to continue: where an edge within the three
   rings of scan it reads around the rim bends by more than
   ``SMOOTH_BEND_DEG`` (:func:`rim_bend`: a CAD crease, sculpted detail
   finer than the sampling, a scanner's noise) the hole keeps order 2,
   untested. On such rims the band test is not representative (its larger
   hole reads other rings; on stress cases of real scans and CAD parts it
   chose order 3 where order 2 was truer), and order 2 is the safer
   continuation. Smooth, finely sampled rims (edges bending a few degrees)
   go on to the test.
1. Remove a band of ``w`` rings of known scan around the hole
   (:func:`probe_band`): together with the hole it is a larger hole, whose
   rim is the band's outer edge.
2. Fill that larger hole with each candidate order exactly as a hole is
   filled (:func:`shellrepair.patch.build_patch`: triangulate, refine,
   fair), on a local copy of the scan around it.
3. Measure each fill against the band it replaced: the RMS distance of the
   band's vertices (the scan that was removed, the hole's own rim included)
   to the filled surface (:func:`point_mesh_distance`).
4. The order with the lowest error fills the real hole, a higher order
   only where its error is lower by more than the scan's resolution
   (:func:`sagitta`: a scan sampled at edge length h with faces bending by
   θ per edge lies θh/8 from the smooth surface it samples, and the test's
   fills are no truer than that; on a finely sampled smooth scan both
   errors are below it, and the orders cannot be told apart), and if the
   real fills
   agree with the test (:func:`agrees`): were both candidates as close to
   the true surface as the test found, their new vertices within the
   band's width of the rim (the depth from a rim the test measured at)
   would lie within the sum of their two errors of each other. Where they
   lie further apart, the test did not represent this hole (a rim the band
   does not share, such as slivers or a jagged rim) and the lower order is
   kept. Deeper inside a hole much larger than the band, both fills' errors
   grow with the hole's size and the two part further whichever is the
   better, so the gap there is not compared (on the 510-edge hole of
   eval/bench_fill.py, order 3 lies 0.0139 ‰ from the true surface and
   order 2 0.251 ‰, 0.8 ‰ apart in all, far more than the test's errors).

The band is ``w = clip(round(BAND_FRACTION * k / 2π), BAND_MIN, BAND_MAX)``
rings wide for a rim of ``k`` edges (``k / 2π`` is the hole's radius in rim
edges): the test hole is about twice the real one across, so its centre
lies on known scan next to the real hole, where the candidates differ most.
A test hole that would have more than ``TEST_MAX_UNKNOWNS`` new vertices
is refined at ``TEST_COARSEN`` times the rim's edge length (the test only
ranks two orders; its resolution floor grows with the square of the edge
length). Small holes (fewer than ``SMALL_EDGES`` rim edges) are many on a
scan and cheap to fill, so they are not tested one by one: the test runs
on at most ``SMALL_SAMPLE`` of them, spread evenly over their ids, and its
verdict (errors in units of each test hole's rim edge, summed) holds for
all of them (:func:`scan_verdict`). Larger holes do the same per size
class (each doubling of the rim's edges) when a class has more than
``SMALL_SAMPLE`` holes: a scan with hundreds of holes pays for a few
dozen tests, not hundreds. Holes with fewer than ``MIN_EDGES`` rim edges
are never tested (a patch of a few triangles, where the orders differ by
less than the scan's own noise). A hole whose band is not a clean annulus
(it meets another hole or a border, or wraps around a thin part) takes
the scan's verdict on its small holes when there is one, else
``DEFAULT_ORDER``.

Cost (measured with the floor, the size classes and the coarse test: the
10M-face case of ``eval/bench_scale.py``, 200 smooth holes, 19 tests and
no order-3 fill, ~1.1x the CPU of order 2; before, 200 tests and 105
order-3 fills, ~3x): a rim that is not smooth costs one walk over its three rings (on
real scans and CAD parts nearly every hole; measured +4 % CPU on a
568-hole ray-cast bust). A tested hole costs one local copy of the scan
(``w + MARGIN_RINGS`` rings around the hole) and one fill per candidate
of a hole about twice as large, then the real fill at both orders when
the test asks for 3: up to ~5x the order-2 fill of a large hole on a
smooth surface; per-hole and local, never whole-mesh. The fairing reads ``order`` rings of the scan around the rim
(every scan vertex is held fixed, so rings further out do not change the
solve); the band width is what sets how far from the hole the test looks.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from . import kernels
from .fair import fair_patch_orders
from .geometry import uniq

__all__ = ["choose_order", "scan_verdict", "agrees", "near_rim", "probe_band", "point_mesh_distance", "rim_bend",
           "OrderTest"]

#: Candidate orders of the probe test (:mod:`shellrepair.probe`; ties go
#: to ``DEFAULT_ORDER``, then the lower order).
CANDIDATES = (1, 2, 3)
#: Candidate orders of the band test (``CRITERION = "band"``; ties go to the first).
BAND_CANDIDATES = (2, 3)
#: The order of holes that are not tested.
DEFAULT_ORDER = 2
#: Holes with fewer rim edges are not tested.
MIN_EDGES = 8
#: Holes with fewer rim edges share one verdict per scan ...
SMALL_EDGES = 24
#: ... from the test on at most this many of them.
SMALL_SAMPLE = 8
#: Band width as a fraction of the hole's radius in rim edges, and its bounds in rings.
BAND_FRACTION = 0.5
BAND_MIN = 2
BAND_MAX = 6
#: Rings of scan kept around the test hole (the fairing reads up to 3).
MARGIN_RINGS = 4
#: Cotangent rounds of the test's fairing (the fill itself uses
#: ``fair.COTAN_ROUNDS``); fewer make the test cheaper.
TEST_ROUNDS = 2
#: A test hole that refined at the rim's density would have more than this
#: many new vertices is refined at ``TEST_COARSEN`` times the rim's edge
#: length instead (about ``TEST_COARSEN²`` times fewer unknowns).
TEST_MAX_UNKNOWNS = 1000
TEST_COARSEN = 2.0
#: How a hole's order is chosen: "band" (the band test) or "probe"
#: (test holes of the hole's own size, :mod:`shellrepair.probe`).
CRITERION = "band"
#: The sagitta floor (:func:`sagitta`) is scaled by this before it decides.
FLOOR_SCALE = 1.0
#: Triangles nearest (by centroid) to each measured point searched for its closest point.
NEAREST_TRIANGLES = 8
#: Order 3 is tested only on a smooth rim: no edge within ``max(CANDIDATES)``
#: rings of it bends by more than this many degrees (:func:`rim_bend`).
SMOOTH_BEND_DEG = 30.0


@dataclass
class OrderTest:
    """What :func:`choose_order` found for one hole.

    Attributes
    ----------
    order : int
        The chosen order.
    errors : dict of int -> float
        RMS distance of the band's vertices to each candidate's fill, in the
        scan's units (empty when the hole was not tested).
    rings : int
        Band width in rings (0 when not tested).
    why : str
        Why the hole was not tested, or ''.
    shared : int
        For a scan's verdict on its small holes: how many were tested.
    floor : float
        The smallest difference of the two errors the test resolves
        (:func:`sagitta`, in the errors' units).
    """

    order: int
    errors: dict = field(default_factory=dict)
    rings: int = 0
    why: str = ""
    shared: int = 0
    floor: float = 0.0

    def describe(self):
        """One line for the report."""
        if not self.errors:
            return f"auto: order {self.order}, {self.why}"
        errs = ", ".join(f"order {o} {e:.3g}" for o, e in sorted(self.errors.items()))
        if self.floor > 0 and self.order == min(self.errors) and min(self.errors.values()) < self.errors[self.order]:
            errs += f" (within the scan's resolution {self.floor:.3g} of each other)"
        if self.shared:
            return (f"auto: order {self.order}, the scan's verdict on its holes of this size (the band test on "
                    f"{self.shared}; errors here {errs})" + (f"; {self.why}" if self.why else ""))
        if not self.rings:     # the test holes of the hole's size (CRITERION "probe")
            return f"auto: order {self.order}, by {self.why}, RMS {errs}"
        return f"auto: order {self.order}, self-test on a {self.rings}-ring band of scan: {errs}"


def rim_bend(ctx, loop, rings=max(BAND_CANDIDATES)):
    """The largest bend between two adjacent faces within ``rings`` rings of a rim.

    Order 3 continues the curvature it reads on the rings of scan around
    the rim. That reading is a sample of a curvature field only where the
    surface is resolved by its sampling, adjacent faces turning by a small
    fraction of a radian (a smooth surface sampled at edge length h bends
    by about h / R per edge for a radius of curvature R). An edge bending by
    tens of degrees is a crease of a CAD part, sculpted detail finer than
    the sampling or a scanner's noise: its curvature is a spike that order
    3 would carry into the hole, and the band test, whose larger hole reads
    other rings, does not see it.

    Parameters
    ----------
    ctx : shellrepair.patch._Context
    loop : (k,) int64
    rings : int

    Returns
    -------
    bend : float
        Degrees between the normals of the two faces of an interior edge,
        the largest over the faces within ``rings`` rings of the loop
        (faces without area left out; 0 when no edge has two such faces).
    """
    T = ctx.F[ctx.ring_faces(np.asarray(loop, np.int64), rings)]
    return _largest_bend(_edge_bends(ctx.V, T)[0])


def _largest_bend(c):
    """:func:`rim_bend` from the bends' cosines."""
    if c.size == 0:
        return 0.0
    m = float(c.min())
    # np.clip on the scalar costs microseconds: the same clip (NaN stays NaN), in Python
    return float(np.degrees(np.arccos(m if m != m else (-1.0 if m < -1.0 else (1.0 if m > 1.0 else m)))))


def _edge_bends(V, T):
    """Cosines of the bend between the two faces of each interior edge of
    ``T`` (faces without area left out), and the edges' lengths."""
    from .topology import face_normals

    if len(T) < 2:
        return np.zeros(0), np.zeros(0)
    if kernels.ENABLED:    # the same numbers, the normals, sort and lengths compiled
        N, a, b, h = kernels.edge_bend_pairs(V, T)
        return np.einsum("ij,ij->i", N[a], N[b]), h
    N = face_normals(V, T)
    ln = np.linalg.norm(N, axis=1)
    ok = ln > 0
    N = np.divide(N, ln[:, None], out=np.zeros_like(N), where=ok[:, None])
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    E.sort(axis=1)
    fid = np.tile(np.arange(len(T)), 3)
    o = np.lexsort((E[:, 1], E[:, 0]))
    Es, fs = E[o], fid[o]
    pair = np.flatnonzero(np.all(Es[1:] == Es[:-1], axis=1))   # an interior edge: its two faces
    a, b = fs[pair], fs[pair + 1]
    keep = ok[a] & ok[b]
    c = np.einsum("ij,ij->i", N[a[keep]], N[b[keep]])
    e = Es[pair[keep]]
    return c, np.linalg.norm(V[e[:, 1]] - V[e[:, 0]], axis=1)


def sagitta(V, T):
    """How far a triangle mesh at this density lies from the smooth surface it samples.

    A chord of length h on a curve of curvature κ lies κh²/8 from the arc.
    The normals of the two faces of an edge of length h turn by θ ≈ κ
    times their centroids' spacing (h/√3 for equilateral faces), so θh/8
    is about κh²/(8√3): a lower bound on how far the mesh lies from the
    surface (0.58 of the chord's sag). Two fills of a hole at the scan's
    density cannot be told apart by the scan closer than this: the test's
    two errors must differ by more than it.

    Parameters
    ----------
    V : (n,3) float64
    T : (m,3) int64
        The scan's faces the test reads (the band).

    Returns
    -------
    s : float
        The RMS of θh/8 over the interior edges of ``T`` (0 when none).
    """
    return _sagitta_of(*_edge_bends(V, np.asarray(T, np.int64)))


def _sagitta_of(c, h):
    """:func:`sagitta` from :func:`_edge_bends`' cosines and lengths."""
    if c.size == 0:
        return 0.0
    theta = np.arccos(np.clip(c, -1.0, 1.0))
    return float(np.sqrt(np.mean((theta * h / 8.0) ** 2)))


def band_rings(k):
    """Band width in rings for a rim of ``k`` edges."""
    return int(np.clip(round(BAND_FRACTION * k / (2 * np.pi)), BAND_MIN, BAND_MAX))


def probe_band(ctx, loop, rings):
    """The band of ``rings`` rings of scan around a hole, as a larger hole.

    Parameters
    ----------
    ctx : shellrepair.patch._Context
    loop : (k,) int64
        The hole's loop (global vertex ids).
    rings : int

    Returns
    -------
    probe : tuple or None
        ``(V, F, probe_loop, known)`` of a local copy of the scan with the
        band removed: positions (local), faces, the larger hole's loop
        (local ids, boundary half-edge order) and the band's vertices not
        on that loop (local ids: the known surface the fill should meet).
        None when the band is not an annulus between the hole's loop and
        one other simple loop (it touches another boundary, wraps around a
        thin part or reaches the end of the scan).
    """
    got = _probe_band(ctx, loop, rings)
    return None if got is None else got[:4]


def _probe_band(ctx, loop, rings, walk=None):
    """:func:`probe_band`, with the band's faces (ids in ``ctx``) last.

    ``walk``: :func:`_ring_walk` of the loop over at least ``rings +
    MARGIN_RINGS`` rings, when the caller has it (compiled kernels only)."""
    from .topology import edge_topology

    loop = np.asarray(loop, np.int64)
    parts = _band_parts(ctx, loop, rings, walk)
    if parts is None:
        return None
    g, Fb, Fk, band, loc_loop, nvb = parts
    n = len(g)
    # the band must be an annulus: two boundary loops, one of them the hole's
    topo = edge_topology(Fb, n)        # (euler_characteristic's and boundary_loops', built once)
    if nvb - topo.edges.shape[0] + Fb.shape[0] != 0:
        return None
    bl, chains = _boundary_loops(Fb, n, topo)
    if len(bl) != 2 or chains:
        return None
    same = [set(b.tolist()) == set(loc_loop.tolist()) for b in bl]
    if sum(same) != 1:
        return None
    outer = set(bl[same.index(False)].tolist())
    # the same loop as a hole of the kept scan (its half-edge order)
    kl, _ = _boundary_loops(Fk, n)
    probe = [b for b in kl if set(b.tolist()) == outer]
    if len(probe) != 1:
        return None
    ploop = probe[0].astype(np.int64)
    keep = np.zeros(n, bool)           # np.setdiff1d(uniq(Fb), ploop), by marks
    keep[Fb] = True
    keep[ploop] = False
    return ctx.V[g], Fk, ploop, np.flatnonzero(keep), band


def _boundary_loops(F, n, topo=None):
    """:func:`shellrepair.holes.boundary_loops` of ``F``; where the boundary
    is simple (no pinch, no open chain), its cycles walked in one compiled
    pass (:func:`shellrepair.kernels.boundary_cycles`: the same loops)."""
    from .holes import boundary_loops
    from .topology import edge_topology

    if kernels.ENABLED:
        topo = edge_topology(F, n) if topo is None else topo
        ok, verts, off = kernels.boundary_cycles(F, n, topo.boundary_he)
        if ok:
            return [verts[off[i]:off[i + 1]] for i in range(len(off) - 1)], []
    return boundary_loops(F, n, topo=topo)


def _band_parts(ctx, loop, rings, walk=None):
    """The band of ``rings`` rings around ``loop`` and the region of
    ``MARGIN_RINGS`` more: ``(g, Fb, Fk, band, loc_loop, nvb)`` as
    :func:`shellrepair.kernels.band_split` gives them, or None when the
    band is empty or is the whole region."""
    if not kernels.ENABLED:
        return _band_parts_numpy(ctx, loop, rings)
    faces, off = _ring_walk(ctx, loop, rings + MARGIN_RINGS) if walk is None else walk
    nb, nr = int(off[rings]), int(off[rings + MARGIN_RINGS])
    if nb == 0 or nb == nr:
        return None
    return kernels.band_split(faces, nb, nr, _faces(ctx), loop, ctx.vpos())


def _band_parts_numpy(ctx, loop, rings):
    """:func:`_band_parts` in NumPy (the compiled split's test oracle)."""
    band = ctx.ring_faces(loop, rings)
    region = ctx.ring_faces(loop, rings + MARGIN_RINGS)
    if band.size == 0 or band.size == region.size:
        return None
    g = uniq(ctx.F[region])
    Fl = np.searchsorted(g, ctx.F[region])
    inband = np.isin(region, band)
    Fb, Fk = Fl[inband], Fl[~inband]
    return g, Fb, Fk, band, np.searchsorted(g, loop), uniq(Fb).size


def _faces(ctx):
    """``ctx.F`` as the kernels take it (C-contiguous int64)."""
    F = ctx.F
    return F if F.flags.c_contiguous and F.dtype == np.int64 else np.ascontiguousarray(F, np.int64)


def _ring_walk(ctx, loop, rings):
    """:func:`shellrepair.kernels.ring_walk` of ``loop`` in ``ctx``, on the
    vertex-face lists :meth:`~shellrepair.patch._Context.ring_faces` reads
    (the region's where they are complete, else the whole mesh's)."""
    F = _faces(ctx)
    reg = ctx._local_lists(loop)
    if reg is not None:
        got = kernels.ring_walk(loop, rings, reg.vf_order, reg.vf_start, F, ctx._vmark, ctx._fmark)
        if reg.covered[F[got[0]]].all():   # every list the walk read was complete
            return got
    return kernels.ring_walk(loop, rings, ctx.vf_order, ctx.vf_start, F, ctx._vmark, ctx._fmark)


def point_mesh_distance(Q, V, F, nearest=NEAREST_TRIANGLES):
    """Distance of points to a small triangle mesh.

    Each point is measured against the ``nearest`` triangles whose centroids
    are closest to it (exact point-triangle distance), which is the true
    distance for a patch of triangles of even size like a refined fill.

    Parameters
    ----------
    Q : (p,3) float64
    V : (n,3) float64
    F : (m,3) int64

    Returns
    -------
    d : (p,) float64
    """
    Q = np.asarray(Q, np.float64)
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if len(Q) == 0 or len(F) == 0:
        return np.full(len(Q), np.inf)
    kk = min(int(nearest), len(F))
    if kernels.ENABLED:    # the same operations, compiled
        _, idx = cKDTree(kernels.centroids(V, F)).query(Q, k=kk)
        return kernels.nearest_triangle_distances(Q, V, F, np.asarray(idx).reshape(len(Q), kk))
    T = V[F]
    _, idx = cKDTree(T.mean(axis=1)).query(Q, k=kk)
    idx = np.asarray(idx).reshape(len(Q), kk)
    P = np.repeat(Q, kk, axis=0)
    Tn = T[idx.ravel()]
    E = P - _closest_on_triangles(P, Tn[:, 0], Tn[:, 1], Tn[:, 2])
    d = np.sqrt(_dot3(E, E))
    return d.reshape(len(Q), kk).min(axis=1)


def _dot3(a, b):
    """Row-wise dot products of (n,3) arrays, summed left to right (as the
    compiled :func:`shellrepair.kernels.nearest_triangle_distances` does; einsum's
    order depends on the CPU's vector width)."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _closest_on_triangles(P, A, B, C):
    """Closest point of triangle ABC to P, row by row.

    The point is written as A + v (B − A) + w (C − A); the barycentric
    coordinates of P's projection are clamped to the triangle, checking the
    three edges where the projection falls outside (degenerate triangles
    reduce to their longest edge's segment).
    """
    AB, AC = B - A, C - A
    AP = P - A
    d00 = _dot3(AB, AB)
    d01 = _dot3(AB, AC)
    d11 = _dot3(AC, AC)
    d20 = _dot3(AP, AB)
    d21 = _dot3(AP, AC)
    den = d00 * d11 - d01 * d01
    ok = den > 1e-30 * np.maximum(d00 * d11, 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, den, 1.0), 0.0)
    v = (d11 * d20 - d01 * d21) * inv
    w = (d00 * d21 - d01 * d20) * inv
    inside = ok & (v >= 0) & (w >= 0) & (v + w <= 1)
    X = A + v[:, None] * AB + w[:, None] * AC
    best = np.where(inside, np.sqrt(_dot3(P - X, P - X)), np.inf)
    out = X.copy()
    for S, E in ((A, B), (B, C), (C, A)):   # the edges, for points projecting outside
        D = E - S
        t = np.clip(_dot3(P - S, D) / np.maximum(_dot3(D, D), 1e-300), 0.0, 1.0)
        Y = S + t[:, None] * D
        dy = np.sqrt(_dot3(P - Y, P - Y))
        take = ~inside & (dy < best)
        out[take] = Y[take]
        best = np.where(take, dy, best)
    return out


def _mean_edge(V, loop):
    """The mean edge length of a loop."""
    if kernels.ENABLED and len(loop) and V.dtype == np.float64 and V.flags.c_contiguous:   # (else a copy of V)
        return kernels.loop_mean_edge(V, loop)
    return _mean_edge_numpy(V, loop)


def _mean_edge_numpy(V, loop):
    """:func:`_mean_edge` in NumPy (the compiled one's test oracle)."""
    loop = np.asarray(loop)
    nxt = np.empty_like(loop)     # np.roll(loop, -1), without its checks
    nxt[:-1] = loop[1:]
    nxt[-1:] = loop[:1]
    return float(np.mean(np.linalg.norm(V[nxt] - V[loop], axis=1)))


def size_class(k):
    """The size class of a rim of ``k`` edges: 0 below ``SMALL_EDGES``, then
    one class per doubling (``SMALL_EDGES`` to ``2 SMALL_EDGES`` is 1, ...)."""
    if k < SMALL_EDGES:
        return 0
    return 1 + int(np.floor(np.log2(k / SMALL_EDGES)))


def scan_verdict(ctx, holes, candidates=None, run=None):
    """One order for each class of a scan's many holes, from the test on a few of them.

    The small holes (``MIN_EDGES <= edges < SMALL_EDGES``) always share one
    verdict. Larger holes share one per size class (:func:`size_class`)
    when the class has more than ``SMALL_SAMPLE`` holes: the test runs on
    ``SMALL_SAMPLE`` of them, spread evenly over their ids, and its verdict
    holds for every hole of the class (``ctx.auto_shared``); classes with
    fewer holes test each one.

    Parameters
    ----------
    ctx : shellrepair.patch._Context
    holes : sequence of shellrepair.holes.Loop
        The holes to fill.
    candidates : sequence of int
    run : callable, optional
        ``run(f, items)``: ``[f(ctx, *item) for item in items]``, in order
        (on several threads, each with its own context:
        :func:`shellrepair.fill.on_two_threads`). Default: here, in turn.
        Each test's result does not depend on where it ran, and the
        verdicts add them up in the same order: the same verdicts.

    Returns
    -------
    verdict : OrderTest or None
        The small holes' verdict: errors in units of the test hole's mean
        rim edge (averaged over the tests); None when no small hole could
        be tested. Set it as ``ctx.auto_small`` for :func:`choose_order` to
        use. The larger classes' verdicts are set as ``ctx.auto_shared``
        (class -> OrderTest) here.
    """
    if candidates is None:
        candidates = CANDIDATES if CRITERION == "probe" else BAND_CANDIDATES
    candidates = tuple(candidates)
    groups = {}
    for h in holes:
        if h.edges >= MIN_EDGES:
            groups.setdefault(size_class(h.edges), []).append(h)
    classes = [(c, _sample(group)) for c, group in sorted(groups.items()) if c == 0 or len(group) > SMALL_SAMPLE]
    items = [(h.id, h.vertices, candidates) for _, picked in classes for h in picked]
    if run is None:
        tests = [_relative_test(ctx, *item) for item in items]
    else:
        tests = run(_relative_test, items)
    shared = {}
    at = 0
    for c, picked in classes:
        v = _class_verdict(tests[at:at + len(picked)], candidates)
        at += len(picked)
        if v is not None:
            shared[c] = v
    ctx.auto_shared = {c: v for c, v in shared.items() if c > 0}
    return shared.get(0)


def _sample(group):
    """At most ``SMALL_SAMPLE`` holes of ``group``, spread evenly over it."""
    pick = np.unique(np.round(np.linspace(0, len(group) - 1, min(SMALL_SAMPLE, len(group)))).astype(int))
    return [group[i] for i in pick]


def _relative_test(ctx, hole_id, loop, candidates):
    """:func:`choose_order` with errors in units of the test hole's rim edge."""
    return choose_order(ctx, hole_id, loop, candidates, relative=True)


def _class_verdict(tests, candidates):
    """One verdict from the tests on a class's sample (:func:`_sample`):
    errors and floors in units of each test hole's rim edge, summed in the
    sample's order; None when no test gave every candidate's error."""
    total = dict.fromkeys(candidates, 0.0)
    floor = 0.0
    n, rings = 0, 0
    for t in tests:
        if len(t.errors) == len(candidates):
            for o in candidates:
                total[o] += t.errors[o]
            floor += t.floor
            n += 1
            rings = max(rings, t.rings)
    if n == 0:
        return None
    best = _best(total, floor, candidates)
    return OrderTest(int(best), errors={o: total[o] / n for o in candidates}, rings=rings, shared=n,
                     floor=floor / n)


def _best(errors, floor, candidates):
    """The candidate with the lowest error; a higher order only where it
    beats every lower one by more than ``floor``."""
    best = candidates[0] if candidates[0] in errors else min(errors)
    for o in candidates:
        if o in errors and o != best and errors[o] + (floor if o > best else -floor) < errors[best]:
            best = o
    return best


def _scaled(verdict, V, loop, why=""):
    """A shared verdict with its errors in this rim's units."""
    scale = _mean_edge(V, loop)
    return OrderTest(verdict.order, errors={o: e * scale for o, e in verdict.errors.items()},
                     rings=verdict.rings, shared=verdict.shared, floor=verdict.floor * scale, why=why)


def choose_order(ctx, hole_id, loop, candidates=None, relative=False, shared=True, rings=None):
    """Pick the fairing order for one hole by the band test (module docstring).

    Parameters
    ----------
    ctx : shellrepair.patch._Context
    hole_id : int
    loop : (k,) int64
    candidates : sequence of int
    relative : bool
        Errors in units of the test hole's mean rim edge (for
        :func:`scan_verdict`); implies ``shared=False``.
    shared : bool
        A hole takes the scan's verdict on its size class
        (``ctx.auto_small``, ``ctx.auto_shared``) when there is one.
    rings : int, optional
        Band width (default :func:`band_rings` of the rim's edges).

    Returns
    -------
    test : OrderTest
    """
    from .errors import MeshError
    from .io import Mesh
    from .patch import PatchError, _Context

    loop = np.asarray(loop, np.int64)
    k = len(loop)
    if CRITERION == "probe":
        return _probe_test(ctx, loop, CANDIDATES if candidates is None else tuple(candidates), relative)
    candidates = BAND_CANDIDATES if candidates is None else tuple(candidates)
    bends = _edge_bends(ctx.V, ctx.F[ctx.ring_faces(loop, max(candidates))])   # rim_bend's, kept for sagitta
    bend = _largest_bend(bends[0])
    if bend > SMOOTH_BEND_DEG:     # no smooth curvature to continue: order 2, untested
        return OrderTest(DEFAULT_ORDER, why=f"an edge within {max(candidates)} rings of the rim bends {bend:.0f}°, "
                                            f"over {SMOOTH_BEND_DEG:g}° (a crease, fine detail or noise)")
    verdict = getattr(ctx, "auto_small", None)
    if shared and not relative:
        mine = verdict if k < SMALL_EDGES else getattr(ctx, "auto_shared", {}).get(size_class(k))
        if mine is not None:
            return _scaled(mine, ctx.V, loop)
    if k < MIN_EDGES:
        return OrderTest(DEFAULT_ORDER, why=f"{k} rim edges, not tested")
    rings = band_rings(k) if rings is None else int(rings)
    probe = None
    # one walk gives the band and region of every width tried (each a prefix of the widest)
    walk = _ring_walk(ctx, loop, rings + MARGIN_RINGS) if kernels.ENABLED and rings >= BAND_MIN else None
    while probe is None and rings >= BAND_MIN:
        probe = _probe_band(ctx, loop, rings, walk)
        if probe is None:
            rings -= 2 if rings > BAND_MIN + 1 else 1
    if probe is None:
        if verdict is not None and shared and not relative:   # the scan's verdict, scaled to this rim
            return _scaled(verdict, ctx.V, loop, why="no clean band of scan around the hole")
        return OrderTest(DEFAULT_ORDER, why="no clean band of scan around the hole")
    Vl, Fl, ploop, known, band = probe
    origin = Vl.mean(axis=0)        # a local frame: scans far from the origin keep their digits
    lctx = _Context(Mesh(V=Vl - origin, F=Fl))
    Q = Vl[known] - origin
    errors = {}
    try:    # one triangulation and refinement, faired at each candidate order
        P0, T, coarse = _refined(lctx, ploop, max(candidates))
    except (MeshError, PatchError):
        return OrderTest(DEFAULT_ORDER, rings=rings, why="the band could not be triangulated")
    # the scan resolves the surface to its sagitta; a fill refined c times
    # coarser than the scan, to c² of it
    # (the band's faces are rim_bend's when the band is max(candidates) rings wide)
    floor = (_sagitta_of(*bends) if rings == max(candidates) else sagitta(ctx.V, ctx.F[band])) * coarse ** 2
    floor *= FLOOR_SCALE
    X0, Fs, nf, g, scale, org = P0
    faired = fair_patch_orders(X0, Fs, nf, candidates, rounds=TEST_ROUNDS, operator=False)   # their common work done once
    for o, (Xu, _) in zip(candidates, faired):
        X = org + scale * np.vstack([X0[:nf], Xu])
        Tp = Fs[len(Fs) - len(T):]
        d = point_mesh_distance(Q, X, Tp)
        if np.isfinite(d).all():
            errors[o] = float(np.sqrt(np.mean(d * d)))
    if not errors:
        return OrderTest(DEFAULT_ORDER, rings=rings, why="no candidate filled the band")
    if relative:
        unit = _mean_edge(Vl, ploop)
        errors = {o: e / unit for o, e in errors.items()}
        floor /= unit
    best = _best(errors, floor, candidates)
    return OrderTest(int(best), errors=errors, rings=rings, floor=floor)


def _probe_test(ctx, loop, candidates, relative):
    """:func:`choose_order` by test holes of the hole's own size (:mod:`shellrepair.probe`)."""
    from .probe import probe_errors

    k = len(loop)
    if k < MIN_EDGES:
        return OrderTest(DEFAULT_ORDER, why=f"{k} rim edges, not tested")
    errors, n, scale = probe_errors(ctx, loop, candidates)
    if not errors:
        return OrderTest(DEFAULT_ORDER, why="no intact scan of the hole's size around it: the scan cannot tell")
    why = f"{n} test holes of its size" if scale == 1.0 else f"{n} test holes of {scale:g} its radius"
    if relative:
        unit = _mean_edge(ctx.V, loop)
        errors = {o: e / unit for o, e in errors.items()}
    # ties (a test hole too small for new vertices fills alike at every
    # order) go to the default order, then to the lower one
    best = min(candidates, key=lambda o: (errors[o], o != DEFAULT_ORDER, o))
    return OrderTest(int(best), errors=errors, rings=0, why=why)


def _refined(ctx, loop, rings):
    """The test hole triangulated and refined as :func:`~shellrepair.patch.build_patch`
    does, in the hole's local frame, with ``rings`` rings of scan around it;
    at ``TEST_COARSEN`` times the rim's edge length when the rim's density
    would give more than ``TEST_MAX_UNKNOWNS`` new vertices.

    Returns ((X, Fs, nf, g, scale, origin), T, c): the submesh positions
    (fixed scan vertices first), its faces (the patch's last), the number
    of fixed vertices, their ids in ``ctx``, the frame, the patch
    triangles, and the refinement's edge length in rim edges (1 or
    ``TEST_COARSEN``).
    """
    from .patch import _local_frame, _rim_data, _submesh
    from .refine import refine_patch
    from .triangulate import triangulate_loop

    k = len(loop)
    sigma, edge_normals, forbidden = _rim_data(ctx, loop)
    origin, scale, Pl = _local_frame(ctx, loop, sigma)
    T = triangulate_loop(Pl, edge_normals, forbidden)
    # new vertices at the rim's density: ~ the area over an equilateral
    # triangle's, halved (a mesh has about half as many vertices as faces)
    e = Pl[T]
    area = 0.5 * np.linalg.norm(np.cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]), axis=1).sum()
    s2 = float(np.mean(sigma / scale)) ** 2
    c = TEST_COARSEN if area / (np.sqrt(3.0) / 4.0 * s2) / 2.0 > TEST_MAX_UNKNOWNS else 1.0
    Pl, T = refine_patch(Pl, T, c * sigma / scale, k, forbidden)
    g, Fs, nf, _ = _submesh(ctx, loop, Pl, T, rings=rings)
    X = np.vstack([(ctx.V[g] - origin) / scale, Pl[k:]])
    return (X, Fs, nf, g, scale, origin), T, c


def agrees(test, V, low, high):
    """Do the real fills at two orders agree with the test's errors?

    Parameters
    ----------
    test : OrderTest
    V : (n,3) float64
        The scan's positions (the patches' loops index it).
    low, high : shellrepair.patch.Patch
        The hole filled at the lower and the higher order.

    Returns
    -------
    ok : bool
        True when the RMS distance to ``low``'s surface of ``high``'s new
        vertices within ``test.rings`` rings of the rim (:func:`near_rim`;
        all of them in a patch no deeper than that) is at most the sum of
        the two orders' test errors: the test measured its errors on a band
        that many rings wide next to a rim, and deeper inside a large hole
        both fills' errors grow with its size (module docstring).
    gap : float
        That distance.
    """
    if not test.errors or low.order not in test.errors or high.order not in test.errors:
        return False, float("nan")
    P = high.P[near_rim(len(high.loop), high.T, len(high.P), max(int(test.rings), 1))]
    d = point_mesh_distance(P, np.vstack([V[low.loop], low.P]), low.T)
    gap = float(np.sqrt(np.mean(d * d))) if len(d) else 0.0
    return gap <= test.errors[low.order] + test.errors[high.order], gap


def near_rim(k, T, n_new, rings):
    """The new vertices of a patch within ``rings`` rings of its rim.

    Parameters
    ----------
    k : int
        Rim vertices (ids ``0..k-1`` in ``T``).
    T : (m,3) int64
        The patch's triangles (new vertices ``k..k+n_new-1``).
    n_new : int
    rings : int

    Returns
    -------
    idx : (p,) int64
        Ids among the new vertices (0-based), increasing; a vertex is one
        ring further than the nearest vertex it shares a triangle with.
    """
    T = np.asarray(T, np.int64)
    depth = np.full(k + n_new, -1, np.int64)
    depth[:k] = 0
    for r in range(1, int(rings) + 1):
        touched = T[(depth[T] == r - 1).any(axis=1)].ravel()
        touched = touched[depth[touched] < 0]
        if touched.size == 0:
            break
        depth[touched] = r
    return np.flatnonzero(depth[k:] > 0)
