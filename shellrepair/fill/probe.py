"""Which patch continues this scan best, asked of the scan at the hole's own size.

:func:`probe_errors` cuts test holes of the hole's own size (its own
outline; where that fits nowhere, a disc as wide as the hole across its
narrow axis, :func:`~shellrepair.fill.placement.outline_narrow_axis`, then a disc of the hole's area,
:func:`~shellrepair.fill.placement.hole_radius`) into intact scan next to the hole
(:func:`shellrepair.fill.placement.cut_test_hole`),
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

A real rim is often noisier than intact scan (a scanner's ragged fringe
at the edge of what it saw), and a higher order carries that noise on into
the hole. So each test hole's rim is given the real rim's noise
(:func:`shellrepair.fill.roughness.rim_noise`: the normal offsets' changes
from one rim vertex to the next, where the surface's curvature term
cancels; what the real rim has beyond the test rim's own, drawn from a
fixed seed): on a sphere with a clean rim order 3 wins; with the rim moved
by noise of 0.5 % of the radius order 2 does, and the choice follows
(tests/test_repair.py). The noise is given only where the real rim is
clearly the noisier (:data:`shellrepair.fill.roughness.SIGNIFICANCE`: two
clean rims differ by their grids' jags alone). Until 2026-12-07 the rims
were compared by their roughness (the offsets themselves), which holds
the curvature term too: a real rim on more curved scan than its test
holes had the difference given to them as noise, which weighs against
order 3 (5 discs on a fat torus, case 8 of seed 162639851: order 2 on
every disc, 4.95 per mille, where order 3 gives 0.577).
eval/results/order-test/probe-noise/ has the screens on development
seeds; BENCHMARKS.md ("The order test") the seeds drawn after the change.

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
possible from those already taken (the same ones for the same scan);
the third only where the first two rank the candidates differently
(:meth:`Pooled.settled`: two that agree are a majority the third could
not outvote). A test hole too small for a vertex of its own fills alike
at every order and does not count. Where fewer than ``MIN_PROBES`` probes fit at the hole's
size and at half of it (the hole is as large as the intact scan around
it), the scan cannot tell, and the caller falls back to a documented
default.
"""

from __future__ import annotations

import numpy as np

from shellrepair import compiled
from shellrepair.fill import probe_kernels
from shellrepair.fill.creases import CREASE_DEGREES, walled
from shellrepair.fill.placement import (cut_test_hole, hole_outline, hole_radius, inside_polygon,
                                        near_scan, outline_narrow_axis)
from shellrepair.fill.roughness import add_noise, rim_noise
from shellrepair.mesh.geometry import cross, mean_edge

__all__ = ["probe_errors", "hole_radius", "Pooled", "as_filled", "PROBES", "FLAT"]

#: The candidate of the rim's triangulation with no new vertex (also
#: :data:`shellrepair.fill.selftest.FLAT`, read from here): measured on each
#: test hole's triangulation before refinement, as the fill's flat
#: triangulation is made.
FLAT = "flat"

#: Test holes per real hole, at most: a third is cut only where the first
#: two disagree (:meth:`Pooled.settled`). Per-hole screens of seven seeds
#: (eval/results/order-test/hole-screens/, 280 holes with three test
#: holes): stopping at two that agree stopped on 149 of them, and moved the
#: per-hole regret 1.1920 -> 1.1926 on the design seeds, 1.1545 -> 1.1459
#: on the development seeds.
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
#: Candidate centres whose placement walks are asked for at once (:class:`_Ends`).
ENDS_BATCH = 8
#: Seed of the offsets that give a test hole's rim the real rim's noise
#: (:func:`shellrepair.fill.roughness.add_noise`): the same offsets for the same scan.
ROUGHNESS_SEED = 0
#: Cotangent rounds of the test's fairing (the fill itself uses
#: ``fair.COTAN_ROUNDS``); fewer make the test cheaper.
TEST_ROUNDS = 2
#: A test hole that refined at the rim's density would have more than this
#: many new vertices is refined at ``TEST_COARSEN`` times the rim's edge
#: length instead (about ``TEST_COARSEN²`` times fewer unknowns).
TEST_MAX_UNKNOWNS = 1000
TEST_COARSEN = 2.0


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
        self.firsts = []          # each test's own best candidate

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
        low = min(dd[o] for o in self.candidates)
        tops = [o for o in self.candidates if dd[o] == low]
        self.firsts.append(tops[0] if len(tops) == 1 else None)     # (a tie: no candidate first)
        return True

    def settled(self, planned):
        """Whether the tests so far decide a test of ``planned`` tests:
        they all rank the same candidate first (alone: a test with a tie
        at its lowest error ranks none first) and are a majority of
        ``planned`` (two of three), so the tests left could not outvote
        them. The pooled errors then rank that candidate first too (each
        test's log RMS is lowest for it, so their sum is)."""
        return (self.tests > planned // 2 and self.tests < planned
                and len(set(self.firsts)) == 1 and self.firsts[0] is not None)

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


class _Ends:
    """Which candidate centres the compiled walk ends (an open edge near,
    :meth:`~shellrepair.fill.placement._Near.ends`), asked in batches of
    ``ENDS_BATCH`` in the order the centres are tried: a large hole's test
    takes two or three of a shell's centres, and walking every one of its
    (up to ``CENTRES_PER_SHELL``) large regions up front cost 32 ms of a
    cut base's 0.18 s test; a small hole's refuses most of them, and one
    call each cost more in dispatch than the walk. The same verdicts either
    way, so the same test holes."""

    def __init__(self, near, shape, margin):
        self.near, self.shape, self.margin = near, shape, margin
        self.known = {}

    def ended(self, pid, upcoming):
        """Whether the walk ends centre ``pid``; ``upcoming``: the centres
        to be tried after it, in order (the rest of the batch)."""
        if pid not in self.known:
            batch = [pid] + [c for c in upcoming if c not in self.known][:ENDS_BATCH - 1]
            got = self.near.ends(np.asarray(batch, np.int64), self.shape, self.margin)
            if got is None:                 # the walk is not compiled: cut_test_hole decides
                return False
            self.known.update(got)
        return self.known[pid]


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
    # the real rim's noise, given to each test hole's rim (a ragged rim
    # is noise a higher order carries on into the hole)
    ring = ctx.F[ctx.ring_faces(loop, 1)]
    noise = rim_noise(V, ring, loop)
    # the margin a placement needs where the scan's faces are longer than the rim's edges
    faces_margin = MARGIN_FACES * _longest_edges(V, ring)
    # the near vertices' distances to the rim, kept for every scale and outline
    c = V[loop].mean(axis=0)
    rim = _RimDistance(V, loop, c, float(np.sqrt(((V[loop] - c) ** 2).sum(axis=1)).max()))
    crease = float(np.cos(np.radians(CREASE_DEGREES))) if walled(ctx, loop) else None
    # a hole as wide across its narrow axis as its area's disc: the narrow
    # disc is that disc, whose search would run twice to the same answer
    narrow_too = [] if np.array_equal(narrow, disc) else [narrow]
    for f in SCALES:          # the largest scale at which MIN_PROBES test holes fit
        small = False
        for shape in own + (narrow_too if f == 1.0 else []) + [disc]:   # the outline, the narrow disc, the disc of its area
            errors, n, alike = _probe_errors(ctx, loop, candidates, max_probes, f * r0, (f * shape, e1, n0), noise,
                                             rim, faces_margin, crease)
            if n >= min(MIN_PROBES, PROBES if max_probes is None else int(max_probes)):
                return errors, n, f
            small = alike > 0 and not n
        if small:             # the disc of its area fits, too small for a vertex: smaller ones are too
            break
    return {}, 0, 0.0


def _probe_errors(ctx, loop, candidates, max_probes, r, shape, noise, rim, faces_margin, crease=None):
    from shellrepair.errors import MeshError
    from shellrepair.fill.fair import fair_patch_orders
    from shellrepair.fill.patch import PatchError
    from shellrepair.mesh.distance import point_mesh_distance
    from shellrepair.mesh.index import ScanContext
    from shellrepair.mesh.io import Mesh

    max_probes = PROBES if max_probes is None else int(max_probes)
    orders = tuple(o for o in candidates if o != FLAT)
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
        if pool.tests + alike >= max_probes or pool.settled(max_probes):
            break
        # the scan near the hole, as far as this shell's test holes and their
        # margins reach: faces with a corner within reach, walked from the
        # rim without leaving that reach (ScanContext.faces_near), within as
        # many rings as reach it at half the rim's edge length (a scan finer
        # than that further out only loses far probes: a probe whose
        # surroundings are cut short fails its check). The walk used to run
        # every ring first and keep those within reach after: at 10M faces
        # it touched four times the faces it kept. Walked shell by
        # shell, the outer shells only where the inner ones did not give the
        # test holes: a shell's candidates and test holes lie within its own
        # reach, so they are the ones the outermost shell's region gives
        # wherever the shorter ring walk reaches every face within that reach
        # (31 of 32 development cases gave the same bytes; on a rocker arm's
        # thin parts one test hole moved, RMS 20.11186 -> 20.11188 per
        # mille); at 10M faces the outermost region cost 1.4-1.8 s a hole,
        # most holes fit their test holes in the first shell.
        reach = rim_r + hi * r + r + margin + 2 * h
        near = near_scan(ctx, ctx.faces_near(loop, int(np.ceil(2.0 * reach / h)), c, reach))
        cands = _centres(rim, near.verts, r, h, lo, hi)
        ends = _Ends(near, shape, margin)
        # farthest first from what is taken (the first: the shell's first candidate)
        left = list(cands)
        while left and pool.tests + alike < max_probes and not pool.settled(max_probes):
            if taken:
                P = V[np.asarray(left)]
                dmin = np.min(np.sqrt(((P[:, None, :] - V[np.asarray(taken)][None]) ** 2).sum(axis=2)), axis=1)
                j = int(np.argmax(dmin))
                if dmin[j] < r:      # overlapping an earlier probe: nothing new
                    break
            else:
                j = 0
            pid = int(left.pop(j))
            if ends.ended(pid, left):
                continue         # (the compiled walk of its region ended it: cut_test_hole would say None)
            got = cut_test_hole(V, ctx.F, near, pid, shape, margin, crease)
            if got is None:
                continue
            Vl, Fl, ploop, Q = got
            Vl = add_noise(Vl, Fl, ploop, noise, ROUGHNESS_SEED + len(taken), count=len(loop))
            origin = Vl.mean(axis=0)
            try:
                lctx = ScanContext(Mesh(V=Vl - origin, F=Fl))
                P0, T, _, flat_T = _refined(lctx, ploop, max(orders), flat=FLAT in candidates)
            except (MeshError, PatchError, ValueError, IndexError):
                continue
            X0, Fs, nf, _, scale, org = P0
            if len(X0) == nf:
                # no vertex of its own: every order fills it alike, so it says
                # nothing of the order (counted, it made ties that order 2 took)
                alike += 1
                taken.append(pid)
                continue
            faired = [Xu for Xu, _ in fair_patch_orders(X0, Fs, nf, orders, rounds=TEST_ROUNDS,
                                                         operator=False)]
            faired = as_filled(orders, faired)
            Tp = Fs[len(Fs) - len(T):]

            def distances():
                for o, Xu in zip(orders, faired):
                    yield o, point_mesh_distance(Q - origin, org + scale * np.vstack([X0[:nf], Xu]), Tp)
                if FLAT in candidates:
                    yield FLAT, point_mesh_distance(Q - origin, org + scale * X0[:nf], flat_T)

            if pool.add(distances()):
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


def _refined(ctx, loop, rings, flat=False):
    """The test hole triangulated and refined as :func:`~shellrepair.fill.patch.build_patch`
    does, in the hole's local frame, with ``rings`` rings of scan around it;
    at ``TEST_COARSEN`` times the rim's edge length when the rim's density
    would give more than ``TEST_MAX_UNKNOWNS`` new vertices.

    Returns ((X, Fs, nf, g, scale, origin), T, c, flat): the submesh
    positions (fixed scan vertices first), its faces (the patch's last),
    the number of fixed vertices, their ids in ``ctx``, the frame, the
    patch triangles, the refinement's edge length in rim edges (1 or
    ``TEST_COARSEN``), and, with ``flat``, the rim's minimum-weight
    triangulation in the submesh's ids, as the fill's flat candidate
    makes it (``build_patch(..., minimal=True)``; else None).
    """
    from shellrepair.fill.refine import refine_patch, split_chords
    from shellrepair.fill.triangulate import triangulate_loop
    from shellrepair.mesh.index import local_frame, rim_data, submesh

    k = len(loop)
    sigma, edge_normals, forbidden = rim_data(ctx, loop)
    origin, scale, Pl = local_frame(ctx, loop, sigma)
    T = triangulate_loop(Pl, edge_normals, forbidden)
    T0 = triangulate_loop(Pl, edge_normals, forbidden, fast=False) if flat else None
    # new vertices at the rim's density: ~ the area over an equilateral
    # triangle's, halved (a mesh has about half as many vertices as faces)
    e = Pl[T]
    area = 0.5 * np.linalg.norm(cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]), axis=1).sum()
    s2 = float(np.mean(sigma / scale)) ** 2
    c = TEST_COARSEN if area / (np.sqrt(3.0) / 4.0 * s2) / 2.0 > TEST_MAX_UNKNOWNS else 1.0
    Pl, T = refine_patch(Pl, T, c * sigma / scale, k, forbidden)
    Pl, T = split_chords(Pl, T, c * sigma / scale, k, forbidden)    # as a faired fill's
    g, Fs, nf, loc = submesh(ctx, loop, Pl, T, rings=rings)
    X = np.vstack([(ctx.V[g] - origin) / scale, Pl[k:]])
    return (X, Fs, nf, g, scale, origin), T, c, (np.asarray(loc, np.int64)[T0] if flat else None)
