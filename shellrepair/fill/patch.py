"""One hole's shell patch: triangulate, refine, fair (steps 1-3 of the fill).

:func:`build_patch` turns one boundary loop into a :class:`Patch`: the loop
triangulated (:mod:`~shellrepair.fill.triangulate`), refined to the rim's density
(:mod:`~shellrepair.fill.refine`) and faired with the scan's rings around it held
fixed (:mod:`~shellrepair.fill.fair`), or a flat cap where the scan meets a planar
opening edge-on (:func:`_meets_edge_on`). It reads the scan through
:class:`~shellrepair.mesh.index.ScanContext`; :func:`_prefill` does a run of
holes' first attempts at once.

The retries, the checks and the choice among attempts are in
:mod:`~shellrepair.fill.hole`; the merge into the scan in :mod:`~shellrepair.fill.merge`;
the orchestration in :mod:`~shellrepair.repair`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from shellrepair import compiled
from shellrepair.errors import MeshError
from shellrepair.fill import patch_kernels
from shellrepair.fill.fair import fair_patch, harmonic_interpolate, patch_energies, taubin_smooth, uniform_laplacian
from shellrepair.fill.refine import refine_patch, refine_patches, split_chords
from shellrepair.fill.triangulate import triangulate_loop
from shellrepair.mesh.geometry import cross
from shellrepair.mesh.index import local_frame, rim_data, submesh
from shellrepair.mesh.intersect import patch_vs_index


class HoleUnit(NamedTuple):
    """One hole filled on its own (a unit of the fill's work)."""
    hole_id: int
    loop: np.ndarray
    order: object          # 1, 2, 3 or "auto"
    smooth: int

    @property
    def first_id(self):
        """The hole id the units are ordered by."""
        return self.hole_id


class BandUnit(NamedTuple):
    """Two ``hole`` loops bounding one missing band: a tube or two caps."""
    A: object              # shellrepair.holes.loops.Loop
    B: object
    order: object
    smooth: int
    mode: str              # the ``bridge`` option: "auto" or "always"
    mutual: bool = False   # each loop sends most of its arcs to the other (shellrepair.fill.bands.Band)

    @property
    def first_id(self):
        return self.A.id


class PatchError(Exception):
    """A patch option that cannot be used; the message is the reason."""


class OverBudget(PatchError):
    """A refined patch with more new vertices than the work budget left
    (``build_patch``'s ``max_vertices``): a larger attempt of the same
    opening would be over it too."""


#: What made a patch (:attr:`Patch.kind`): a faired surface at its order;
#: the harmonic one (the last faired option); a flat cap on a planar
#: opening the scan meets edge-on; the flat triangulation; the paper's
#: smoothed seed; Steiner points of the last layer; a tube between two
#: loops, a pants joining three, a flat face with a hole in it.
KINDS = ("faired", "harmonic", "flat cap", "flat", "seed", "steiner", "tube", "pants", "flat face")


@dataclass(frozen=True)
class Patch:
    """A hole's shell patch, before merging.

    Frozen: a stage that adds to a patch (its report sentence, the order
    test behind it, the order-2 patch to fall back on) makes a new one with
    :meth:`with_`, so no module changes a patch another module made.

    Attributes
    ----------
    hole_id : int
    loop : (k,) int64
        Global loop vertex indices.
    P : (q,3) float64
        New vertex positions.
    T : (t,3) int64
        Triangles: index i < k is ``loop[i]``, index k + j is new vertex j.
    T0 : (k-2,3) int64
        The loop's triangulation before refinement (loop positions).
    colors : (q,c) uint8 or None
    props : dict of name -> (q,) array
    option : str
        Which option was accepted, as a sentence for the report (nothing
        reads it back: decisions read ``kind`` and the counts below).
    kind : str
        What made the patch, one of :data:`KINDS` ("" for a patch no fill
        option has named yet).
    choice : shellrepair.fill.selftest.OrderTest or None
        What the order test measured when ``order="auto"`` chose this
        patch's order (None for a forced order or an untested kind).
    disc : bool
        The triangles form one disc bounded by ``loop`` (k − 2 triangles
        before refinement); False for a tube between two loops.
    rerouted : int
        Chords of the first triangulation re-routed to avoid the scan.
    pinned : int
        New vertices held on the flat triangulation where the faired
        surface crossed the scan.
    mended : int
        Regions the last layer (:mod:`shellrepair.fill.mend`) re-triangulated.
    """

    hole_id: int
    loop: np.ndarray
    P: np.ndarray
    T: np.ndarray
    colors: np.ndarray | None = None
    props: dict = field(default_factory=dict)
    option: str = ""
    T0: np.ndarray | None = None
    energy: tuple | None = None
    order: int | None = None
    disc: bool = False
    fallback: object = None   # order 3 chosen by "auto": the hole's checked order-2 patch (same rim edges)
    choice: object = None     # the OrderTest behind an "auto" order
    kind: str = ""
    rerouted: int = 0
    pinned: int = 0
    mended: int = 0

    @property
    def plain(self):
        """The option as first built: no chord re-routed, no vertex held,
        nothing mended."""
        return not (self.rerouted or self.pinned or self.mended)

    def with_(self, **changes):
        """A copy of this patch with ``changes`` (field name -> value); the
        arrays are shared, not copied."""
        return replace(self, **changes)

    def global_faces(self, base):
        """Faces with new vertex j at index ``base + j``."""
        k = len(self.loop)
        G = np.where(self.T < k, self.loop[np.minimum(self.T, k - 1)], base + self.T - k)
        return G.astype(np.int64)


@dataclass
class _Pre:
    """A hole's first attempt up to refinement, done in a batch."""

    loop: np.ndarray
    rim: tuple
    T0: np.ndarray | None = None
    refined: tuple | None = None
    edge_on: bool | None = None     # _meets_edge_on, when the unit's order asked for it
    frame: tuple | None = None      # local_frame(ctx, loop, rim sigma)
    first: object = None            # the first attempt, built and checked (fill_runs.first_attempts)

    def keep_first(self, first):
        """Keep the first attempt, built and checked in a batch (:func:`shellrepair.fill.runs.first_attempts`)."""
        self.first = first

    def refined_once(self, make):
        """The refined triangulation: ``make()`` the first time it is asked for, kept after."""
        if self.refined is None:
            self.refined = make()
        return self.refined


#: Holes whose first triangulation is refined together (see ``refine_patches``).
BATCH = 24
#: Loops longer than this are refined on their own.
BATCH_MAX_LOOP = 400


def _prefill(ctx, units):
    """Rim data, triangulation and refinement of the single holes among
    ``units``, the refinement as one batch (results identical to doing it
    hole by hole); stored in ``ctx.pre`` for :func:`build_patch`."""
    items, ids = [], []
    for unit in units:
        if not isinstance(unit, HoleUnit):
            continue
        hole_id, loop, order = unit.hole_id, np.asarray(unit.loop, np.int64), unit.order
        rim = rim_data(ctx, loop)
        pre = _Pre(loop=loop, rim=rim)
        ctx.keep_first(hole_id, pre)
        if order != 1:
            pre.edge_on = _meets_edge_on(ctx, loop, hole_id)
        sigma, edge_normals, forbidden = rim
        pre.frame = local_frame(ctx, loop, sigma)
        _, scale, Pl = pre.frame
        try:
            pre.T0 = triangulate_loop(Pl, edge_normals, forbidden)
        except MeshError:
            continue  # build_patch meets the same error and reports it
        if len(loop) <= BATCH_MAX_LOOP:
            items.append((Pl, pre.T0, sigma / scale, len(loop), forbidden))
            ids.append(hole_id)
    for hole_id, refined in zip(ids, refine_patches(items)):
        ctx.pre[hole_id].refined = refined


def build_patch(ctx, hole_id, loop, order=2, smooth=0, refine=True, fair=True, avoid=(), initial=None,
                energy=False, pinned=None, scan_aware=False, max_vertices=None, chords=False, minimal=False):
    """Build one hole's patch (no checks against the scan).

    Parameters
    ----------
    ctx : ScanContext
    hole_id : int
    loop : (k,) int64
    order : {1, 2, 3}
    smooth : int
        Taubin passes after fairing.
    refine, fair : bool
    avoid : set of (int, int)
        More loop-position pairs the triangulation must not join (chords
        whose triangles crossed the scan in an earlier attempt).
    initial : (t,3) int64 or ((q,3) float64, (t,3) int64), optional
        A first triangulation over the loop positions to use instead of
        triangulating ``loop`` (a tube between two loops given as one
        concatenated ``loop``); with positions, a first mesh whose vertex
        ``k + j`` is ``P[j]``.
    energy : bool
        Also measure the faired patch's energies (``patch.energy``: thin
        plate, curvature variation).
    pinned : array of int, optional
        New vertices (0-based among the new ones) kept where refinement put
        them, on the flat triangulation, instead of being faired.
    scan_aware : bool
        Triangulate with only triangles that cross no scan face near the
        hole (:func:`scan_allowed`).
    max_vertices : int, optional
        Raise :class:`PatchError` when refinement makes more new vertices
        than this (a work budget), before the costly fairing.
    chords : bool
        After refinement, split the long chords of a faired (order 2 or 3)
        disc patch (:func:`~shellrepair.fill.refine.split_chords`): the
        faired option of a hole's fill; not a flat cap, an order-1 patch or
        a tube.
    minimal : bool
        Triangulate by Liepa's minimum-weight search alone
        (:func:`~shellrepair.fill.triangulate.triangulate_loop` with
        ``fast=False``), not the Delaunay triangulation of the loop's
        projection: the flat candidate, where the triangulation is the
        patch and so decides its shape.

    Returns
    -------
    patch : Patch

    Raises
    ------
    PatchError
    """
    loop = np.asarray(loop, np.int64)
    k = len(loop)
    pre = ctx.pre_for(hole_id, loop)
    sigma, edge_normals, forbidden = pre.rim if pre is not None else rim_data(ctx, loop)
    if pre is not None and pre.frame is not None:     # the batch's frame of this loop and rim
        origin, scale, Pl = pre.frame[0], pre.frame[1], pre.frame[2].copy()
    else:
        origin, scale, Pl = local_frame(ctx, loop, sigma)
    forbidden = forbidden | set(avoid)
    fresh = pre is not None and not avoid and not scan_aware and not minimal  # the batch's first attempt applies
    if initial is not None:
        if isinstance(initial, tuple):  # a first tube with vertices inside (tube.guide_tube)
            P_in, initial = initial
            Pl = np.vstack([Pl, (np.asarray(P_in, np.float64) - origin) / scale])
        T = np.asarray(initial, np.int64)
    elif fresh and pre.T0 is not None:
        T = pre.T0
    else:
        try:
            T = triangulate_loop(Pl, edge_normals, forbidden, fast=not minimal,
                                 allowed=scan_allowed(ctx, loop) if scan_aware else None)
        except MeshError as exc:
            raise PatchError(str(exc)) from None
    T0 = T
    if refine:
        if fresh and pre.refined is not None and np.array_equal(T, pre.T0):
            Pl, T = pre.refined
        else:
            Pl, T = refine_patch(Pl, T, sigma / scale, k, forbidden)
        if chords and fair and order >= 2 and len(T0) == k - 2:
            Pl, T = split_chords(Pl, T, sigma / scale, k, forbidden)
    q = len(Pl) - k
    if max_vertices is not None and q > max_vertices:
        # a work bound (shellrepair.fill.checks.WorkBudget): stop before fairing
        raise OverBudget(f"refined patch has {q} new vertices, over the work budget left ({int(max_vertices)})")
    colors = None
    props = {}
    new_local = Pl[k:]
    patch_energy = None
    if q > 0 and (fair or smooth or ctx.colors is not None or ctx.props):
        g, Fs, nf, loc_loop = submesh(ctx, loop, Pl, T, rings=max(order, 1))
        X = np.vstack([(ctx.V[g] - origin) / scale, Pl[k:]])
        K = None
        if fair:
            Xu, K = fair_patch(X, Fs, nf, order=order, pinned=pinned)
            X[nf:] = Xu
            if energy:
                # vertices with complete neighbourhoods: patch, loop and ring 1
                ring1 = np.searchsorted(g, np.unique(ctx.F[ctx.faces_of(loop)]))
                S = np.unique(np.concatenate([ring1, np.arange(nf, len(X))]))
                E, C = patch_energies(X, Fs, np.concatenate([loc_loop, np.arange(nf, len(X))]), S)
                patch_energy = (E, C / scale ** 2)
        if smooth:
            Xs = taubin_smooth(X, Fs, nf, smooth)
            if pinned is not None and len(pinned):
                Xs[pinned] = X[nf:][pinned]
            X[nf:] = Xs
        new_local = X[nf:]
        if ctx.colors is not None or ctx.props:
            if K is None:
                K = uniform_laplacian(Fs, len(X))
            if ctx.colors is not None:
                c = harmonic_interpolate(K, ctx.colors[g].astype(np.float64), nf)
                colors = np.clip(np.round(c), 0, 255).astype(np.uint8)
            for name, arr in ctx.props.items():
                vals = harmonic_interpolate(K, np.asarray(arr, np.float64)[g][:, None], nf)[:, 0]
                props[name] = vals.astype(np.asarray(arr).dtype) if np.issubdtype(np.asarray(arr).dtype, np.floating) \
                    else np.round(vals).astype(np.asarray(arr).dtype)
    if not np.isfinite(new_local).all():
        raise PatchError("the fairing solve did not converge (non-finite positions)")
    Pn = origin + scale * new_local
    return Patch(hole_id=hole_id, loop=loop, P=Pn, T=T, colors=colors, props=props, T0=T0, disc=len(T0) == k - 2,
                 energy=patch_energy, order=order if fair else None)


def scan_allowed(ctx, loop):
    """``allowed(T)`` for :func:`triangulate_loop`: True for the triangles
    (loop positions) that cross no scan face.

    A triangle's answer depends on its corners only (each is tested against
    the scan on its own), so the answers are kept on ``ctx`` per loop: the
    retries of one hole (re-routed chords, sub-loops, the mender) ask about
    the same triangles many times (on a 699-edge hole, 13104 asked, 1611
    different).

    Parameters
    ----------
    ctx : ScanContext
        The scan; its ``allowed_answers`` keeps the answers.
    loop : (k,) int64
        The rim's vertex indices.

    Returns
    -------
    allowed : callable
        ``allowed(T)`` for triangles ``T`` (t,3) of loop positions: (t,)
        bool, True where the triangle crosses no scan face.
    """
    loop = np.asarray(loop, np.int64)
    k = np.int64(len(loop))
    known = ctx.allowed_answers.setdefault(loop.tobytes(), {})

    def allowed(T):
        T = np.asarray(T, np.int64).reshape(-1, 3)
        if not len(T):
            return np.ones(0, bool)
        S = np.sort(T, axis=1)
        keys = ((S[:, 0] * k + S[:, 1]) * k + S[:, 2]).tolist()
        got = np.fromiter((known.get(x, 2) for x in keys), np.int8, len(keys))
        ask = np.flatnonzero(got == 2)
        if ask.size:
            Ta = T[ask]
            ok = np.ones(ask.size, np.int8)
            ok[patch_vs_index(ctx.V[loop[Ta]], loop[Ta], ctx.index, return_faces=True)] = 0
            got[ask] = ok
            known.update(zip((keys[i] for i in ask.tolist()), ok.tolist()))
        return got.astype(bool)

    return allowed


def corners(ctx, patch):
    """A patch's triangle corners and their ids (compiled:
    :func:`shellrepair.fill.patch_kernels.patch_corners`, else :func:`corners_reference`).

    Parameters
    ----------
    ctx : ScanContext
    patch : Patch

    Returns
    -------
    C : (t,3,3) float64
        Each triangle's corners.
    ids : (t,3) int64
        The scan vertex at each corner, or ``-(1 + j)`` for new vertex j.
    """
    if compiled.ENABLED:
        return patch_kernels.patch_corners(ctx.V, patch.loop, patch.P, patch.T)
    return corners_reference(ctx, patch)


def corners_reference(ctx, patch):
    """:func:`corners` in NumPy (the fallback when kernels are off, and the
    oracle of :func:`shellrepair.fill.patch_kernels.patch_corners`); parameters
    and returns as :func:`corners`."""
    k = len(patch.loop)
    allp = np.vstack([ctx.V[patch.loop], patch.P])
    ids = np.where(patch.T < k, patch.loop[np.minimum(patch.T, k - 1)], -(1 + patch.T - k))
    return allp[patch.T], ids.astype(np.int64)



#: A loop at most this planar (RMS distance to its plane over its diameter) ...
EDGE_ON_PLANARITY = 0.02
#: ... whose surrounding faces (``EDGE_ON_RINGS`` rings) have normals with a
#: mean |cos| to its axis of at most this is an opening the scan meets
#: edge-on: a statue's base, a foot's sole, the cut of a bust or a pipe's
#: end. The walls stand across the opening's plane; a faired patch
#: continues them into a dome. On a scan it gets a flat cap only with
#: ``--base flat`` (the user knows the object's base is there). Until
#: 2026-12-06 it was also capped where the walls turn into the opening's
#: plane along most of its rim (:func:`turns_into_opening`); measured
#: against always fairing, that rule lost: 17.1 against 14.8 per mille
#: (geometric means, the 18 plane-cut cases it was asked about,
#: eval/results/base_rule-48611-58231-66107.md), and on development seeds
#: 731, 733, 735 and 920328247 (64 stress cases) always fairing was closer
#: to the truth on all 8 cases where the two differed (a dumbbell's
#: occlusion 43.9 against 1.46, bases 17.2 against 12.1, 13.5 against 9.7).
EDGE_ON_COS = 0.35
EDGE_ON_RINGS = 6


#: A loop planar to this (RMS over diameter) is a CAD face's outline,
#: judged by its first ring of faces alone (the first with any area, past
#: zero-area faces an exporter left on the rim): edge-on as soon as one of
#: them stands across its plane (a crease along part of the rim). On a coarse
#: CAD part six rings reach far beyond the rim, and large faces there
#: outvote it either way: the plate around a pocket hides the pocket's
#: walls, a capsule's long walls make the ring at its dome's pole look
#: edge-on.
#:
#: The value is measured, not a round-off bound. Float32 round-off of an
#: exact plane is ~1e-7, and the limit was 1e-6 until 2026-12-07; but a CAD
#: part as distributed is planar only to its file's digits: the fandisk's
#: flat faces, cut by the stress suite's occlusion, give outlines of 1.0e-5
#: to 1.3e-5 (six design seeds: 731, 733, 270074373, 569393493, 541225744,
#: 922665491, 665 loops of 8 or more edges), where every other loop, scan or
#: smooth shape, is 1.26e-3 or more. 1e-4 lies in the middle of that gap (on
#: a log scale). Under 1e-6 one such outline, met edge-on by the walls
#: around it, was faired into a dome: 16.1 per mille from the truth where
#: the flat cap gives 0.28 (541225744-06). Validated on seeds drawn after
#: (865890797, 943514874, 638981991, 730980852, 472178172, 582058423,
#: 917107603, 625692123, 345931864, 438057884): fandisk outlines 9.9e-6 to
#: 3.3e-5, every other loop 3.0e-4 or more (the lowest a scanner-occluded
#: star's arm, the next 1.6e-3). A scan's rim carries the scanner's noise
#: and lies orders of magnitude above either (tests/test_base_cap.py).
EDGE_ON_CAD_PLANARITY = 1e-4


def _meets_edge_on(ctx, loop, hole_id=None):
    """Is the loop a planar opening whose surrounding walls stand across its
    plane, to be capped flat? On a scan, by ``ctx.base``
    (:class:`shellrepair.options.RepairOptions`): ``"flat"`` every such
    opening, ``"faired"`` and ``"auto"`` none (``EDGE_ON_COS`` says why);
    a CAD face's outline always."""
    return edge_on_verdict(ctx, loop, hole_id)[0]


def edge_on_verdict(ctx, loop, hole_id=None):
    """:func:`_meets_edge_on` and, when False, why (for the report of a
    ``--base flat`` that does not apply): ``(bool, str)``."""
    from shellrepair.holes.loops import loop_stats

    def planar_limit(p):
        return False, f"its rim is not planar (RMS {p:.3g} of its size off its plane, over {EDGE_ON_PLANARITY})"

    if ctx.planarity.get(hole_id, 0.0) > EDGE_ON_PLANARITY:  # measured already: not planar
        return planar_limit(ctx.planarity[hole_id])
    known = ctx.axes.get(hole_id)
    if known is not None and hole_id in ctx.planarity and np.array_equal(known[0], loop):
        st = {"planarity": ctx.planarity[hole_id], "axis": known[1]}   # measured already, on this loop
    else:
        st = loop_stats(ctx.V, loop)
    if st["planarity"] > EDGE_ON_PLANARITY:
        return planar_limit(st["planarity"])
    if st["planarity"] <= EDGE_ON_CAD_PLANARITY:
        for rings in range(1, EDGE_ON_RINGS + 1):   # past rings of zero-area faces only
            T = ctx.F[ctx.ring_faces(loop, rings)]
            n = cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
            ln = np.linalg.norm(n, axis=1)
            if np.any(ln > 0):
                hit = bool(np.any((ln > 0) & (np.abs(n @ st["axis"]) <= EDGE_ON_COS * ln)))
                return hit, "" if hit else "no face beside it stands across its plane"
        return False, "no face of area beside it"
    c = walls_cos(ctx, loop, st["axis"])
    if c is None:
        return False, "no face of area beside it"
    if c > EDGE_ON_COS:
        return False, (f"the scan beside it does not stand across its plane (mean |cos| of its faces' "
                       f"normals to the plane's {c:.2f}, over {EDGE_ON_COS})")
    # the user's word on what the opening is (RepairOptions.base): a scan's
    # opening is capped flat only when the user says its base is there
    if ctx.base == "flat":
        return True, ""
    return False, "faired by request" if ctx.base == "faired" else "a scan's opening is faired unless --base flat"


def walls_cos(ctx, loop, axis):
    """How far the scan around a loop stands across it: the area-weighted
    mean |cos| of the normals of the faces of ``EDGE_ON_RINGS`` rings around
    it to ``axis`` (its plane's normal); None where those faces have no area.
    At most ``EDGE_ON_COS``: the walls stand across the opening.

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
    loop : (k,) int64
    axis : (3,) float64
        Unit normal.

    Returns
    -------
    c : float or None
    """
    n = _face_cross(ctx, ctx.ring_faces(loop, EDGE_ON_RINGS))
    a = 0.5 * np.linalg.norm(n, axis=1)
    if a.sum() <= 0:
        return None
    cosines = np.abs(n @ axis) / np.maximum(2 * a, 1e-300)
    return float(np.sum(a * cosines) / a.sum())


def _face_cross(ctx, faces):
    """``cross(e1, e2)`` of the scan faces ``faces`` (twice their area-weighted normals)."""
    if compiled.ENABLED:
        return patch_kernels.face_cross(faces, ctx.F, ctx.V)
    T = ctx.F[faces]
    return cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])


def turns_into_opening(ctx, loop):
    """Does the scan turn into the opening's plane along most of its rim?
    (The statistic of the rule that capped such openings flat until it
    was measured to lose, ``EDGE_ON_COS``; kept for eval/base_rule.py.)

    Walls standing across a planar opening either end there (a statue's
    real base: the scan's last faces bend into the base, along a fillet or
    a chamfer of its edge, so they already face out through the opening)
    or run on beyond it (a cut through the object: the last faces face
    away from the opening, or straight across it). The test is per rim
    vertex: the area-weighted mean of its first-ring faces' normals against
    the opening's normal, which the loop's own orientation gives (Newell's
    formula; the scan's faces run the other way round the rim). The
    opening is a base, to be capped flat, when more than half of its rim
    vertices turn into it; otherwise the faired fill continues the walls.

    Parameters
    ----------
    ctx : ScanContext
    loop : (k,) int64
        The opening's rim vertices, in the loop's order.

    Returns
    -------
    bool
        True: a base, to be capped flat.
    """
    return 2 * rim_turning(ctx, loop) > len(loop)


def rim_turning(ctx, loop):
    """How many of the loop's vertices have first-ring faces that face out
    through the opening (:func:`turns_into_opening`'s count; 0 for a loop
    with no orientation, such as one folded onto itself)."""
    P = ctx.V[loop]
    Q = np.roll(P, -1, axis=0)
    axis = np.array([np.sum((P[:, 1] - Q[:, 1]) * (P[:, 2] + Q[:, 2])),
                     np.sum((P[:, 2] - Q[:, 2]) * (P[:, 0] + Q[:, 0])),
                     np.sum((P[:, 0] - Q[:, 0]) * (P[:, 1] + Q[:, 1]))])
    length = float(np.linalg.norm(axis))
    if not np.isfinite(length) or length == 0:
        return 0
    axis /= length
    T = ctx.F[ctx.faces_of(loop)]
    n = cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
    pos = ctx.vpos()       # loop positions by vertex, O(k) (a fresh array of n per hole was O(n))
    pos[loop] = np.arange(len(loop))
    num = np.zeros(len(loop))
    den = np.zeros(len(loop))
    try:
        for j in range(3):
            at = pos[T[:, j]]
            on = at >= 0
            np.add.at(num, at[on], (n @ axis)[on])
            np.add.at(den, at[on], np.linalg.norm(n, axis=1)[on])
    finally:
        pos[loop] = -1
    turning = num < 0   # facing out through the opening (its normal points into the object)
    return int(np.count_nonzero(turning & (den > 0)))
