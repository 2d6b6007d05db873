"""Fill every hole of a scan with a faired shell patch and merge it.

Per hole (a loop classed ``hole`` by :mod:`shellrepair.holes`), touching
only the patch and a few rings of scan around it:

1. triangulate the loop (:mod:`~shellrepair.triangulate`);
2. refine it to the density of the rim (:mod:`~shellrepair.refine`);
3. fair it, Δᵏx = 0 with the scan around it fixed
   (:mod:`~shellrepair.fair`), optionally smooth it (Taubin, non-shrinking);
   a planar opening that the scan meets edge-on (a base, a sole; on a CAD
   part, any exactly planar outline with a crease along its rim) gets a
   flat cap instead, bent only where rim faces slant across it;
4. check it (:mod:`~shellrepair.intersect`): no patch triangle may cross the
   scan, itself or an earlier patch, and no patch may create an edge the
   mesh has. A patch that crosses is rebuilt: chords near the crossing are
   re-routed, vertices near it are held on the flat triangulation, then the
   harmonic patch and the checked flat triangulation are tried. A planar
   opening whose own region the scan crosses away from its rim stops at
   once: every flat triangulation covers that region. If nothing works
   the hole stays open and the report says why.

Two loops facing each other across a missing band are first offered a tube
(:mod:`~shellrepair.bridge`); the tube or the two caps are kept by their
curvature-variation energy.

Then every accepted patch is appended: original vertices keep their index
and exact values, new vertices and faces come after them and are flagged
``filled``; vertex colours (and other vertex properties) are interpolated
harmonically from the rim. Holes are filled in runs of ``BATCH``
consecutive holes, one run at a time or by ``jobs`` processes; within a run
the first attempt's rim data, triangulation and refinement are done for all
its holes at once (the refinement as one disjoint union, with the same
result as hole by hole). The checks between patches and the merge run
afterwards in hole order, so the output does not depend on ``jobs``.

Whole-mesh structures (edges, vertex-to-face lists, the faces near a box)
are built once, vectorised; a patch is checked against the scan faces near
its own box only (:class:`~shellrepair.intersect.NearFaces`), and against
itself by a projection certificate where one holds
(:func:`~shellrepair.intersect.embeds_by_projection`), pair by pair
otherwise.

``method="seed"`` is the paper's simple shape model for comparison: close
each hole with the same triangulation, smooth a duplicate of the whole
mesh ``smooth`` times (10 by default) with the umbrella operator, and take
the filled region's vertices from the smoothed duplicate.

References
----------
P. Liepa, "Filling Holes in Meshes", SGP 2003. M. Botsch, L. Kobbelt, "An
intuitive framework for real-time freeform modeling", SIGGRAPH 2004.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .clean import describe_open_chains
from .errors import MeshError
from .geometry import bounding_spheres, concat_ranges, cross, uniq
from .fair import (curvature_variation_energy, fair_patch, harmonic_interpolate, taubin_smooth,
                   thin_plate_energy, umbrella_smooth, uniform_laplacian)
from .holes import detect_holes
from .intersect import NearFaces, ball_pairs, crossing_pairs, embeds_by_projection, pair_intersections, patch_vs_index
from .io import Mesh, manifold_mesh
from .refine import refine_patch, refine_patches
from .report import table1_dict
from .topology import edge_count_delta, edge_topology, vertex_faces
from .triangulate import triangulate_loop

__all__ = ["repair_mesh", "build_patch", "Patch", "SEED_SMOOTH_PASSES"]

#: Smoothing passes of the paper's seed method when ``smooth`` is not given.
SEED_SMOOTH_PASSES = 10


class PatchError(Exception):
    """A patch option that cannot be used; the message is the reason."""


@dataclass
class Patch:
    """A hole's shell patch, before merging.

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
        Which option was accepted.
    disc : bool
        The triangles form one disc bounded by ``loop`` (k − 2 triangles
        before refinement); False for a tube between two loops.
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

    def global_faces(self, base):
        """Faces with new vertex j at index ``base + j``."""
        k = len(self.loop)
        G = np.where(self.T < k, self.loop[np.minimum(self.T, k - 1)], base + self.T - k)
        return G.astype(np.int64)


class _Context:
    """Whole-mesh structures built once; per-hole work only reads them."""

    def __init__(self, mesh):
        self.V = mesh.V
        self.F = mesh.F
        self.n = len(mesh.V)
        self.colors = mesh.vertex_colors
        self.props = {k: v for k, v in mesh.vertex_props.items()
                      if np.asarray(v).ndim == 1 and np.issubdtype(np.asarray(v).dtype, np.number)}
        self.vf_order, self.vf_start = vertex_faces(self.F, self.n)
        self._vmark = np.zeros(self.n, bool)      # scratch marks for ring_faces, left all False
        self._fmark = np.zeros(len(self.F), bool)
        self.planarity = {}  # loop id -> planarity measured by detect_holes
        self.topo = None     # the mesh's EdgeTopology, when the caller has it
        self._index = None
        self.pre = {}  # hole id -> _Pre: first-attempt work done for a batch of holes

    @property
    def index(self):
        if self._index is None:
            self._index = NearFaces(self.V, self.F, origin=self.V.mean(axis=0), vf=(self.vf_order, self.vf_start),
                                    topo=self.topo)
        return self._index

    def pre_for(self, hole_id, loop):
        """The batch's first-attempt work for this hole and loop, or None."""
        pre = self.pre.get(hole_id)
        return pre if pre is not None and np.array_equal(pre.loop, loop) else None

    def faces_of(self, verts):
        verts = np.asarray(verts, np.int64)
        s = self.vf_start[verts]
        return uniq(self.vf_order[concat_ranges(s, self.vf_start[verts + 1] - s)] // 3)

    def ring_faces(self, verts, rings):
        """Faces within ``rings`` rings of ``verts`` (sorted)."""
        vm, fm = self._vmark, self._fmark
        front = uniq(verts)
        vm[front] = True
        marked_v, found = [front], []
        try:
            for _ in range(max(1, int(rings))):
                f = self.faces_of(front)
                f = f[~fm[f]]
                fm[f] = True
                found.append(f)
                vs = uniq(self.F[f])
                front = vs[~vm[vs]]
                vm[front] = True
                marked_v.append(front)
                if front.size == 0:
                    break
        finally:
            for a in marked_v:
                vm[a] = False
            for a in found:
                fm[a] = False
        return np.sort(np.concatenate(found)) if found else np.zeros(0, np.int64)


def _rim_data(ctx, loop):
    """Scale σ per loop vertex, scan normals across loop edges, forbidden chords."""
    k = len(loop)
    pos = {int(v): i for i, v in enumerate(loop)}
    f1 = ctx.faces_of(loop)
    T = ctx.F[f1]
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    ln = np.linalg.norm(ctx.V[E[:, 0]] - ctx.V[E[:, 1]], axis=1)
    sig_sum = np.zeros(k)
    sig_cnt = np.zeros(k)
    edge_normals = np.zeros((k, 3))
    forbidden = set()
    nrm = np.cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
    nl = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.divide(nrm, nl, out=np.zeros_like(nrm), where=nl > 0)
    m = len(T)
    for r, ((a, b), L) in enumerate(zip(E.tolist(), ln.tolist())):
        ia, ib = pos.get(a), pos.get(b)
        if ia is not None:
            sig_sum[ia] += L
            sig_cnt[ia] += 1
        if ib is not None:
            sig_sum[ib] += L
            sig_cnt[ib] += 1
        if ia is not None and ib is not None:
            if ib == (ia + 1) % k:
                edge_normals[ia] = nrm[r % m]
            elif ia != (ib + 1) % k:
                forbidden.add((min(ia, ib), max(ia, ib)))
    sigma = sig_sum / np.maximum(sig_cnt, 1)
    loop_len = np.linalg.norm(ctx.V[np.roll(loop, -1)] - ctx.V[loop], axis=1)
    sigma = np.where(sig_cnt > 0, sigma, loop_len)
    return sigma, edge_normals, forbidden


def _submesh(ctx, loop, Pl, T, rings):
    """Local submesh: scan faces within ``rings`` of the loop, plus the patch.

    Returns X (fixed scan vertices first, then new), Fs, g (global ids of
    the fixed vertices)."""
    k = len(loop)
    rf = ctx.ring_faces(loop, rings)
    g = uniq(ctx.F[rf])
    remap = {int(v): i for i, v in enumerate(g.tolist())}
    Fr = np.searchsorted(g, ctx.F[rf])
    loc_loop = np.array([remap[int(v)] for v in loop], np.int64)
    nf = len(g)
    Tp = np.where(T < k, loc_loop[np.minimum(T, k - 1)], nf + T - k)
    return g, np.vstack([Fr, Tp]).astype(np.int64), nf, loc_loop


def _local_frame(ctx, loop, sigma):
    """Origin, scale and scaled loop positions of a hole's local frame:
    centred on the loop, in units of its mean rim edge."""
    P = ctx.V[loop]
    origin = P.mean(axis=0)
    scale = float(np.mean(sigma))
    if not np.isfinite(scale) or scale <= 0:
        scale = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0))) or 1.0
    return origin, scale, (P - origin) / scale


@dataclass
class _Pre:
    """A hole's first attempt up to refinement, done in a batch."""

    loop: np.ndarray
    rim: tuple
    T0: np.ndarray | None = None
    refined: tuple | None = None
    edge_on: bool | None = None     # _meets_edge_on, when the unit's order asked for it


#: Holes whose first triangulation is refined together (see ``refine_patches``).
BATCH = 24
#: Loops longer than this are refined on their own.
BATCH_MAX_LOOP = 400


def _prefill(ctx, units):
    """Rim data, triangulation and refinement of the single holes among
    ``units``, the refinement as one batch (results identical to doing it
    hole by hole); stored in ``ctx.pre`` for :func:`build_patch`."""
    items, ids = [], []
    for kind, args in units:
        if kind != "one":
            continue
        hole_id, loop, order = args[0], np.asarray(args[1], np.int64), args[2]
        rim = _rim_data(ctx, loop)
        pre = _Pre(loop=loop, rim=rim)
        ctx.pre[hole_id] = pre
        if order != 1:
            pre.edge_on = _meets_edge_on(ctx, loop, hole_id)
        sigma, edge_normals, forbidden = rim
        _, scale, Pl = _local_frame(ctx, loop, sigma)
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
                energy=False, pinned=None, scan_aware=False):
    """Build one hole's patch (no checks against the scan).

    Parameters
    ----------
    ctx : _Context
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
        hole (:func:`_scan_allowed`).

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
    sigma, edge_normals, forbidden = pre.rim if pre is not None else _rim_data(ctx, loop)
    origin, scale, Pl = _local_frame(ctx, loop, sigma)
    forbidden = forbidden | set(avoid)
    fresh = pre is not None and not avoid and not scan_aware  # the batch's first attempt applies
    if initial is not None:
        if isinstance(initial, tuple):  # a first tube with vertices inside (bridge.guide_tube)
            P_in, initial = initial
            Pl = np.vstack([Pl, (np.asarray(P_in, np.float64) - origin) / scale])
        T = np.asarray(initial, np.int64)
    elif fresh and pre.T0 is not None:
        T = pre.T0
    else:
        try:
            T = triangulate_loop(Pl, edge_normals, forbidden,
                                 allowed=_scan_allowed(ctx, loop) if scan_aware else None)
        except MeshError as exc:
            raise PatchError(str(exc)) from None
    T0 = T
    if refine:
        if fresh and pre.refined is not None and np.array_equal(T, pre.T0):
            Pl, T = pre.refined
        else:
            Pl, T = refine_patch(Pl, T, sigma / scale, k, forbidden)
    q = len(Pl) - k
    colors = None
    props = {}
    new_local = Pl[k:]
    patch_energy = None
    if q > 0 and (fair or smooth or ctx.colors is not None or ctx.props):
        g, Fs, nf, loc_loop = _submesh(ctx, loop, Pl, T, rings=max(order, 1))
        X = np.vstack([(ctx.V[g] - origin) / scale, Pl[k:]])
        K = None
        if fair:
            Xu, K = fair_patch(X, Fs, nf, order=order, pinned=pinned)
            X[nf:] = Xu
            if energy:
                # vertices with complete neighbourhoods: patch, loop and ring 1
                ring1 = np.searchsorted(g, np.unique(ctx.F[ctx.faces_of(loop)]))
                S = np.unique(np.concatenate([ring1, np.arange(nf, len(X))]))
                patch_energy = (thin_plate_energy(X, Fs, np.concatenate([loc_loop, np.arange(nf, len(X))])),
                                curvature_variation_energy(X, Fs, S) / scale ** 2)
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


def _scan_allowed(ctx, loop):
    """``allowed(T)`` for :func:`triangulate_loop`: True for the triangles
    (loop positions) that cross no scan face."""
    loop = np.asarray(loop, np.int64)

    def allowed(T):
        T = np.asarray(T, np.int64)
        ok = np.ones(len(T), bool)
        if len(T):
            ok[patch_vs_index(ctx.V[loop[T]], loop[T], ctx.index, return_faces=True)] = False
        return ok

    return allowed


def _corners(ctx, patch):
    k = len(patch.loop)
    allp = np.vstack([ctx.V[patch.loop], patch.P])
    ids = np.where(patch.T < k, patch.loop[np.minimum(patch.T, k - 1)], -(1 + patch.T - k))
    return allp[patch.T], ids.astype(np.int64)


def _check_patch(ctx, patch):
    """Why the patch cannot be used (or None), and the patch triangles at fault."""
    C, ids = _corners(ctx, patch)
    if not np.isfinite(C).all():
        return "non-finite patch positions", np.zeros(0, np.int64)
    bad = patch_vs_index(C, ids, ctx.index, return_faces=True)
    if bad.size:
        return f"patch would cross the scan ({bad.size} triangles)", bad
    # the patch against itself: a disc that projects one-to-one cannot
    # cross itself; otherwise test its triangles pair by pair
    if len(C) > 1 and not (patch.disc and embeds_by_projection(
            np.vstack([ctx.V[patch.loop], patch.P]), patch.T, len(patch.loop))):
        pairs = crossing_pairs(C - ctx.index.origin, ids)
        if len(pairs):
            return f"patch would cross itself ({len(pairs)} triangle pairs)", np.unique(pairs.ravel())
    return None, np.zeros(0, np.int64)


def _chords_near(ctx, patch, bad):
    """Chords of the unrefined triangulation nearest to the faulty triangles."""
    k = len(patch.loop)
    C, _ = _corners(ctx, patch)
    P0 = ctx.V[patch.loop]
    c0 = P0[patch.T0].mean(axis=1)
    near = np.unique(cKDTree(c0).query(C[bad].mean(axis=1))[1])
    out = set()
    for t in patch.T0[near]:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            a, b = int(min(a, b)), int(max(a, b))
            if b - a > 1 and not (a == 0 and b == k - 1):
                out.add((a, b))
    return out


#: A loop at most this planar (RMS distance to its plane over its diameter;
#: float32 round-off of a flat CAD face is ~1e-7) whose flat triangulation
#: covers its outline one-to-one is a plane region: every flat
#: triangulation covers the same region, so scan faces crossing it away
#: from the loop cross them all, and re-routing chords is futile.
BLOCKED_PLANARITY = 1e-6


def _blocked_in_plane(ctx, hole_id, flat, bad):
    """How many scan faces cross a planar opening's region away from its
    loop (so that every flat triangulation crosses them), or 0 when that
    cannot be shown (the loop is not planar, its outline not simple, or
    every crossing face touches the loop, where another chord may help)."""
    from .holes import loop_stats

    loop = flat.loop
    if not flat.disc or len(flat.P) or bad.size == 0:
        return 0
    planarity = ctx.planarity.get(hole_id)
    if planarity is None:
        planarity = loop_stats(ctx.V, loop)["planarity"]
    if planarity > BLOCKED_PLANARITY or not embeds_by_projection(ctx.V[loop], flat.T, len(loop)):
        return 0
    C, ids = _corners(ctx, flat)
    pairs = patch_vs_index(C[bad], ids[bad], ctx.index, return_pairs=True)
    faces = np.unique(pairs[:, 1])
    touching = np.isin(ctx.F[faces], loop).any(axis=1)
    return int(faces.size) if faces.size and not touching.any() else 0


#: Rounds of re-triangulation when the flat triangulation crosses the scan.
FLAT_RETRIES = 12
#: Rounds of re-triangulation when the faired patch crosses the scan.
FAIRED_RETRIES = 3
#: Rounds of growing the region held on the flat triangulation around a crossing.
PIN_ROUNDS = 3
#: Time budget of one hole, seconds: no new attempt starts after
#: ``HOLE_SECONDS + HOLE_SECONDS_PER_EDGE * edges``.
HOLE_SECONDS = 3.0
HOLE_SECONDS_PER_EDGE = 0.004


#: How each option is named in the report.
OPTION_NAMES = {"faired": "faired order {order}", "harmonic": "harmonic (order 1)",
                "flat cap": "flat cap: a planar opening the scan meets edge-on (order 1)"}
#: A loop at most this planar (RMS distance to its plane over its diameter) ...
EDGE_ON_PLANARITY = 0.02
#: ... whose surrounding faces (``EDGE_ON_RINGS`` rings) have normals with a
#: mean |cos| to its axis of at most this is an opening the scan meets
#: edge-on: a statue's base, a foot's sole, the cut of a bust or a pipe's
#: end. The walls stand across the opening's plane; a faired patch would
#: continue them into a dome, while the surface they bound is flat.
EDGE_ON_COS = 0.35
EDGE_ON_RINGS = 6


#: A loop planar to this (RMS over diameter; round-off of float32 CAD
#: coordinates is ~1e-7, scans are far from it) is a CAD face's outline,
#: judged by its first ring of faces alone (the first with any area, past
#: zero-area faces an exporter left on the rim): edge-on as soon as one of
#: them stands across its plane (a crease along part of the rim). On a coarse
#: CAD part six rings reach far beyond the rim, and large faces there
#: outvote it either way: the plate around a pocket hides the pocket's
#: walls, a capsule's long walls make the ring at its dome's pole look
#: edge-on.
EDGE_ON_CAD_PLANARITY = 1e-6


def _meets_edge_on(ctx, loop, hole_id=None):
    """Is the loop a planar opening whose surrounding walls stand across its plane?"""
    from .holes import loop_stats

    if ctx.planarity.get(hole_id, 0.0) > EDGE_ON_PLANARITY:  # measured already: not planar
        return False
    st = loop_stats(ctx.V, loop)
    if st["planarity"] > EDGE_ON_PLANARITY:
        return False
    if st["planarity"] <= EDGE_ON_CAD_PLANARITY:
        for rings in range(1, EDGE_ON_RINGS + 1):   # past rings of zero-area faces only
            T = ctx.F[ctx.ring_faces(loop, rings)]
            n = cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
            ln = np.linalg.norm(n, axis=1)
            if np.any(ln > 0):
                return bool(np.any((ln > 0) & (np.abs(n @ st["axis"]) <= EDGE_ON_COS * ln)))
        return False
    T = ctx.F[ctx.ring_faces(loop, EDGE_ON_RINGS)]
    n = cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
    a = 0.5 * np.linalg.norm(n, axis=1)
    if a.sum() <= 0:
        return False
    cosines = np.abs(n @ st["axis"]) / np.maximum(2 * a, 1e-300)
    return float(np.sum(a * cosines) / a.sum()) <= EDGE_ON_COS


def _roll_rim(ctx, hole_id, loop, T0, patch, bad, smooth):
    """A flat cap that crosses slanting rim faces: let the cap bend (order
    2) only near the crossing, the rest held flat; grow that region up to
    ``PIN_ROUNDS`` times."""
    free = None
    n_new = len(patch.P)
    for _ in range(PIN_ROUNDS):
        free = _pin_region(patch, bad, free)
        pinned = np.setdiff1d(np.arange(n_new), free)
        try:
            p = build_patch(ctx, hole_id, loop, order=2, smooth=smooth, initial=T0, pinned=pinned)
        except PatchError:
            return None
        why, b2 = _check_patch(ctx, p)
        if why is None:
            p.option = (f"flat cap: a planar opening the scan meets edge-on, bent (order 2) along "
                        f"{len(free)} vertices where rim faces slant across it")
            return p
        if len(p.T) == len(patch.T):
            bad = np.union1d(bad, b2)
    return None


def _pin_region(patch, bad, pinned):
    """New vertices of the faulty triangles and two rings around them
    (grown by two more rings each call), 0-based among the new vertices."""
    k = len(patch.loop)
    T = patch.T
    mark = np.zeros(k + len(patch.P), bool)
    if pinned is not None:
        mark[k + np.asarray(pinned)] = True
    mark[T[bad].ravel()] = True
    for _ in range(2):
        mark[T[mark[T].any(axis=1)].ravel()] = True
    return np.flatnonzero(mark[k:])


#: ``order="auto"``: order 3 is kept where it moves the order-2 patch by at
#: most this fraction of the hole's diameter (RMS). Where curvature
#: extrapolates stably (smooth and finely relieved surfaces) the two agree
#: closely and order 3 is the better guess; where order 3 departs far from
#: order 2 (jagged rims, large holes in complex shapes) it is extrapolating
#: noise. Chosen on the benchmark suite (see BENCHMARKS.md).
AUTO_TAU = 0.035


def _fill_one(ctx, hole_id, loop, order, smooth, energy=False):
    """Fill one hole; ``order="auto"`` picks 2 or 3 (see ``AUTO_TAU``)."""
    if order != "auto":
        return _fill_one_order(ctx, hole_id, loop, order, smooth, energy)
    t0 = time.perf_counter()
    patch, reason, secs, reasons = _fill_one_order(ctx, hole_id, loop, 2, smooth, energy)
    if patch is None or patch.order != 2 or len(patch.P) == 0 or "held" in patch.option:
        return patch, reason, time.perf_counter() - t0, reasons
    diameter = float(np.linalg.norm(ctx.V[loop].max(axis=0) - ctx.V[loop].min(axis=0)))
    try:
        p3 = build_patch(ctx, hole_id, loop, order=3, smooth=smooth, initial=patch.T0, energy=energy)
    except PatchError:
        return patch, reason, time.perf_counter() - t0, reasons
    if len(p3.P) == len(patch.P):
        rel = float(np.sqrt(np.mean(np.sum((p3.P - patch.P) ** 2, axis=1)))) / max(diameter, 1e-300)
        if rel <= AUTO_TAU and _check_patch(ctx, p3)[0] is None:
            p3.option = patch.option.replace("order 2", "order 3") + f" (auto: {100 * rel:.1f}% of the diameter from order 2)"
            return p3, reason, time.perf_counter() - t0, reasons
        patch.option += f" (auto: order 3 would move it {100 * rel:.1f}% of the diameter)"
    return patch, reason, time.perf_counter() - t0, reasons


def _fill_one_order(ctx, hole_id, loop, order, smooth, energy=False):
    """Fill one hole, trying the options in turn.

    0. Triangulate, refine and fair; done if the patch crosses nothing.
    1. Otherwise check the flat triangulation against the
       scan; where it crosses (a peninsula of scan next to the rim),
       triangulate again with only triangles that cross no scan face
       (``scan_aware``: the search over the loop's Delaunay triangles drops
       each triangle the scan rejects); if that still crosses, forbid the
       chords near the crossing and triangulate again.
    2. Refine and fair that triangulation (order ``order``, then harmonic);
       if the faired patch crosses the scan, re-route the chords near the
       crossing and go back to 1 (at most ``FAIRED_RETRIES`` times).
    3. Otherwise keep the checked flat triangulation, if there is one.

    No new round starts after ``HOLE_SECONDS + HOLE_SECONDS_PER_EDGE * k``
    seconds; the hole then keeps the checked flat triangulation or fails
    saying so.

    Returns (patch or None, reason, seconds, reasons tried).
    """
    t0 = time.perf_counter()
    reasons = []
    avoid = set()
    flat_ok = None
    options = [("faired", order)] + ([("harmonic", 1)] if order != 1 else [])
    pre = ctx.pre_for(hole_id, loop)
    edge_on = pre.edge_on if pre is not None and pre.edge_on is not None \
        else (order != 1 and _meets_edge_on(ctx, loop, hole_id))
    if order != 1 and edge_on:
        options = [("flat cap", 1)] + options
    faired_rounds = 0
    first = True
    scan_aware = False
    budget = HOLE_SECONDS + HOLE_SECONDS_PER_EDGE * len(loop)
    for _ in range(FLAT_RETRIES + FAIRED_RETRIES + 2):
        if time.perf_counter() - t0 > budget:
            reasons.append(f"gave up after {time.perf_counter() - t0:.1f} s (budget {budget:.1f} s for "
                           f"{len(loop)} edges), {len(avoid)} chords re-routed")
            break
        try:
            flat = build_patch(ctx, hole_id, loop, order=1, smooth=0, refine=False, fair=False, avoid=avoid,
                               scan_aware=scan_aware)
        except PatchError as exc:
            if avoid:
                reasons.append(f"no triangulation avoids crossing the scan ({len(avoid)} chords re-routed)")
            else:
                reasons.append(f"triangulation: {exc}")
            break
        if first:  # the common case: the first option on the first triangulation is fine
            first = False
            name0, order0 = options[0]
            try:
                patch = build_patch(ctx, hole_id, loop, order=order0, smooth=smooth, initial=flat.T0,
                                    energy=energy)
                why0, bad0 = _check_patch(ctx, patch)
                if why0 is None:
                    patch.option = OPTION_NAMES[name0].format(order=order0)
                    return patch, "", time.perf_counter() - t0, reasons
                if name0 == "flat cap" and bad0.size:
                    rolled = _roll_rim(ctx, hole_id, loop, flat.T0, patch, bad0, smooth)
                    if rolled is not None:
                        return rolled, "", time.perf_counter() - t0, reasons
                    reasons.append(f"flat cap: {why0}")
            except PatchError:
                pass
        why, bad = _check_patch(ctx, flat)
        if why is not None and not scan_aware:
            scan_aware = True  # again, with only triangles that cross no scan face
            continue
        if why is not None:
            blocked = _blocked_in_plane(ctx, hole_id, flat, bad)
            if blocked:
                reasons.append(f"flat: {why}; {blocked} scan faces cross the opening's own plane inside it, "
                               f"so no flat triangulation avoids them")
                break
            more = _chords_near(ctx, flat, bad) - avoid if bad.size else set()
            if not more:
                reasons.append(f"flat: {why}")
                break
            avoid |= more
            continue
        flat_ok = flat
        retry = False
        for name, o in options:
            try:
                patch = build_patch(ctx, hole_id, loop, order=o, smooth=smooth, initial=flat.T0, avoid=avoid,
                                    energy=energy)
            except PatchError as exc:
                reasons.append(f"{name}: {exc}")
                continue
            why, bad = _check_patch(ctx, patch)
            pinned = None
            for _grow in range(PIN_ROUNDS if why is not None and bad.size else 0):
                # hold the new vertices around the crossing on the flat triangulation
                pinned = _pin_region(patch, bad, pinned)
                try:
                    pp = build_patch(ctx, hole_id, loop, order=o, smooth=smooth, initial=flat.T0, avoid=avoid,
                                     energy=energy, pinned=pinned)
                except PatchError:
                    break
                w2, b2 = _check_patch(ctx, pp)
                if w2 is None:
                    patch, why = pp, None
                    break
                bad = np.union1d(bad, b2) if len(pp.T) == len(patch.T) else bad
            if why is None:
                patch.option = OPTION_NAMES[name].format(order=o)
                if avoid:
                    patch.option += f", {len(avoid)} chords re-routed"
                if pinned is not None:
                    patch.option += f", {len(pinned)} vertices held on the flat triangulation"
                return patch, "", time.perf_counter() - t0, reasons
            more = _chords_near(ctx, patch, bad) - avoid if bad.size else set()
            if name == "faired" and more and faired_rounds < FAIRED_RETRIES:
                faired_rounds += 1
                avoid |= more
                retry = True
                break
            reasons.append(f"{name}: {why}")
        if not retry:
            break
    else:
        reasons.append(f"the triangulation still crosses the scan after re-routing {len(avoid)} chords")
    if flat_ok is not None:
        flat_ok.option = "flat triangulation" + (f", {len(avoid)} chords re-routed" if avoid else "")
        return flat_ok, "", time.perf_counter() - t0, reasons
    return None, "; ".join(reasons), time.perf_counter() - t0, reasons


#: Which energy decides tube against caps: 0 thin plate ∫(2H)², 1 curvature
#: variation ∫|∇(2Hn)|². The thin-plate energy of a thin torus's inner band is
#: higher than that of two flat caps, so it picks caps where the band is
#: missing; the curvature variation measures how well each option continues
#: the surrounding surface's curvature and picks the tube (tested on tori of
#: tube radius 0.2–0.5 and cut angles 70–150°).
ENERGY = 1


def _fill_pair(ctx, A, B, order, smooth, mode):
    """A missing region bounded by loops A and B: a tube, or a cap on each.

    The tube starts from :func:`~shellrepair.bridge.guide_tube` (rings
    along both loops' continuation arcs; the plain zip of the two loops if
    that fails), is refined and faired like a cap with both loops' rings
    fixed, and is checked against the scan and itself; the faired tube and
    the tube held on the arcs are both tried and the valid one with the
    lower energy (``ENERGY``) is kept. Only for loops that see each other
    both ways are crossings retried (vertices held around them). The caps
    are checked against the scan and against each other. When each loop's
    arcs land on the other the valid tube is kept without building caps;
    otherwise an option that fails its checks loses, and if both pass the
    lower energy wins. While a valid tube is in hand each cap gets one
    attempt (no re-routing): a cap that crosses something there is not
    needed.

    Returns (outcomes, record): outcomes as for :func:`_fill_one` per loop
    (the tube patch is given with A, B refers to it), record for the report.
    """
    from .bridge import MAX_REACH, continuation_arcs, guide_tube, tube_triangles

    t0 = time.perf_counter()
    loop = np.concatenate([A.vertices, B.vertices])
    order = 2 if order == "auto" else order
    PA, PB = ctx.V[A.vertices], ctx.V[B.vertices]
    arcs = [continuation_arcs(ctx.V, ctx.F[ctx.ring_faces(L.vertices, 3)], L.vertices) for L in (A, B)]
    try:
        sigma = _rim_data(ctx, loop)[0]      # the rim's edge length, as refinement reads it
        Pg, Tg = guide_tube(PA, PB, *arcs, spacing=float(np.mean(sigma)),
                            reach=MAX_REACH * max(A.diameter, B.diameter))
    except (ValueError, IndexError, FloatingPointError):   # degenerate rims: the plain zip below
        Pg, Tg = np.zeros((0, 3)), None
    mutual = frozenset((A.id, B.id)) in getattr(ctx, "bands_mutual", set())
    tube, why_tube = None, ""
    # edges the scan has between the two loops' vertices (other than the
    # loops' own edges): a tube that made one again would be non-manifold
    Fl = ctx.F[ctx.faces_of(loop)]
    scan_edges = {tuple(e) for e in _edges_of(Fl).tolist()}
    own = {tuple(sorted(e)) for L in (A, B) for e in zip(L.vertices.tolist(), np.roll(L.vertices, -1).tolist())}
    scan_edges -= own

    def attempt(first, init, o, fair=True, pinned=None):
        """(the patch if it passes its checks, the faulty triangles, the patch built)"""
        nonlocal why_tube
        try:
            p = build_patch(ctx, A.id, loop, order=o, smooth=smooth if fair else 0, initial=init,
                            energy=fair, fair=fair, pinned=pinned)
        except PatchError as exc:
            why_tube = str(exc)
            return None, np.zeros(0, np.int64), None
        why, bad = _check_patch(ctx, p)
        if why is None and any(e in scan_edges for e in _scan_edges(p)):
            why = "the tube would repeat an edge of the scan"
        if why is None:
            how = f"faired order {o}" if fair else "refined, not faired"
            if pinned is not None:
                how += f", {len(pinned)} vertices held on the first tube"
            p.option = f"tube to loop {B.id} ({first}), {how}"
            return p, bad, p
        why_tube = f"{first}: {why}"
        return None, bad, p

    def caps_crossing(caps):
        """Why the two caps cannot both be used, or ''."""
        why = "; ".join(f"cap of loop {L.id}: {c[1] or 'failed'}" for L, c in zip((A, B), caps) if c[0] is None)
        if not why:
            acc = _Accepted()
            acc.add(caps[0][0], *_corners(ctx, caps[0][0]))
            if acc.conflict(ctx, caps[1][0])[0]:
                why = "the two caps cross each other"
        return why

    # loops that see each other one way only (an island and its surround, or
    # a loop whose arcs happen to reach a neighbour): the caps first; while
    # they stand, the tube gets one attempt, for the energy comparison
    caps = None
    lean = False
    if not mutual and mode != "always":
        caps = [_fill_one(ctx, L.id, L.vertices, order, smooth, energy=True) for L in (A, B)]
        lean = not caps_crossing(caps)
    if len(Pg) and np.isfinite(Pg).all():
        first, init = "along the continuation arcs", (Pg, Tg)
        faired, bad, built = attempt(first, init, order)
        # the first tube itself (refined, every vertex held): the arcs carry
        # the scan's curvature across the gap, which fairing can flatten;
        # the fairer of the two valid options is kept
        held = None
        q = len(built.P) if built is not None and not lean else 0
        if q:
            held, hbad, hp = attempt(first, init, order, pinned=np.arange(q))
            free = None
            for _ in range(PIN_ROUNDS if mutual and faired is None and held is None and hbad.size and hp is not None
                           else 0):
                # a fold of the arcs (at a jag of a rim): fair only around it
                free = _pin_region(hp, hbad, free)
                held, b2, _ = attempt(first, init, order, pinned=np.setdiff1d(np.arange(q), free))
                if held is not None:
                    break
                hbad = np.union1d(hbad, b2) if b2.size else hbad
            if held is not None:
                held.option = f"tube to loop {B.id} ({first}), refined, held on the arcs" + (
                    f" except {len(free)} vertices faired (order {order}) around a fold" if free is not None else "")
        valid = [p for p in (faired, held) if p is not None]
        if valid:
            tube = min(valid, key=lambda p: p.energy[ENERGY] if p.energy is not None else np.inf)
        elif mutual and bad.size and built is not None:
            # hold the vertices near the crossing on the arcs (as for a cap)
            pinned = None
            for _ in range(PIN_ROUNDS):
                pinned = _pin_region(built, bad, pinned)
                tube, b2, _ = attempt(first, init, order, pinned=pinned)
                if tube is not None:
                    break
                bad = np.union1d(bad, b2) if b2.size else bad
    if tube is None and not lean:
        tube, _, _ = attempt("zipped", tube_triangles(PA, PB), order)
    seen_both_ways = tube is not None and mutual and mode != "always"
    if caps is None and not seen_both_ways:   # (seen both ways: the tube continues the surface)
        if tube is not None:    # one attempt per cap
            caps = []
            for L in (A, B):
                t1 = time.perf_counter()
                try:
                    c = build_patch(ctx, L.id, L.vertices, order=order, smooth=smooth, energy=True)
                    why, _ = _check_patch(ctx, c)
                except PatchError as exc:
                    c, why = None, str(exc)
                if why is not None:
                    c = None
                else:
                    c.option = OPTION_NAMES["faired"].format(order=order)
                caps.append((c, why or "", time.perf_counter() - t1, []))
        else:
            caps = [_fill_one(ctx, L.id, L.vertices, order, smooth, energy=True) for L in (A, B)]
    if caps is None:
        secs = time.perf_counter() - t0
        e_tube = tube.energy[ENERGY] if tube.energy is not None else None
        record = {"loops": [int(A.id), int(B.id)], "kinds": [A.kind, B.kind],
                  "tube_energy": None if e_tube is None else round(float(e_tube), 6), "caps_energy": None,
                  "chosen": "tube", "reason": "each loop's continuation arcs land on the other"}
        tube.hole_id = A.id
        return [(tube, "", secs, []), (None, f"bridged with loop {A.id} by a tube", secs, [])], record
    why_caps = caps_crossing(caps)
    e_tube = tube.energy[ENERGY] if tube is not None and tube.energy is not None else np.inf
    caps_ok = not why_caps
    e_caps = sum(c[0].energy[ENERGY] if c[0] is not None and c[0].energy is not None else np.inf
                 for c in caps) if caps_ok else np.inf
    record = {"loops": [int(A.id), int(B.id)], "kinds": [A.kind, B.kind],
              "tube_energy": None if not np.isfinite(e_tube) else round(float(e_tube), 6),
              "caps_energy": None if not np.isfinite(e_caps) else round(float(e_caps), 6)}
    use_tube = tube is not None and (mode == "always" or not caps_ok or e_tube < e_caps)
    secs = time.perf_counter() - t0
    if use_tube:
        record["chosen"] = "tube"
        record["reason"] = ("--bridge always" if mode == "always" else
                            f"caps failed: {why_caps}" if not caps_ok else
                            f"tube energy {e_tube:.4g} < caps energy {e_caps:.4g}")
        tube.hole_id = A.id
        return [(tube, "", secs, []), (None, f"bridged with loop {A.id} by a tube", secs, [])], record
    record["chosen"] = "caps"
    if tube is None:
        record["reason"] = f"tube failed: {why_tube}"
    elif not np.isfinite(e_tube):
        record["reason"] = "no faired tube energy to compare (tube without interior vertices)"
    else:
        record["reason"] = f"caps energy {e_caps:.4g} <= tube energy {e_tube:.4g}"
    out = []
    for L, c in zip((A, B), caps):
        if L.kind != "hole":
            out.append((None, "border", secs, []))
        else:
            out.append(c)
    return out, record


_WORKER_CTX = None


def _run_unit(ctx, unit):
    kind, args = unit
    if kind == "one":
        return [_fill_one(ctx, *args)], None
    return _fill_pair(ctx, *args)


def _run_chunk(ctx, chunk, on_unit=None):
    """Fill a run of consecutive units (their first attempts batched);
    ``on_unit()`` is called after each."""
    try:
        _prefill(ctx, chunk)
        out = []
        for u in chunk:
            out.append(_run_unit(ctx, u))
            if on_unit is not None:
                on_unit()
        return out
    finally:
        ctx.pre = {}


def _worker(chunk):
    return _run_chunk(_WORKER_CTX, chunk)


def _find_bands(ctx, scan):
    """Pairs of ``hole`` loops whose continuation arcs land on each other.

    Only loops classed ``hole`` are paired (a border is never bridged);
    borders still stop arcs. Only loops with another loop within reach of
    their arcs (``MAX_REACH`` diameters) have their arcs followed. Loops
    that share a vertex are never paired. Sets ``ctx.bands_mutual``.
    """
    from .bridge import MAX_REACH, band_pairs, loop_sights

    loops = scan.loops
    hole = np.array([L.kind == "hole" for L in loops], bool)
    if hole.sum() < 2:
        return []
    ids = np.flatnonzero(hole)
    centres = np.array([ctx.V[loops[i].vertices].mean(axis=0) for i in ids])
    radius = np.array([0.5 * loops[i].diameter for i in ids])
    reach = radius + MAX_REACH * 2 * radius
    tree = cKDTree(centres)
    cand = []
    for a, i in enumerate(ids):     # holes with another hole within reach of their arcs
        near = np.asarray(tree.query_ball_point(centres[a], reach[a] + radius.max()), np.int64)
        near = near[(near != a) & (np.linalg.norm(centres[near] - centres[a], axis=1) <= reach[a] + radius[near])]
        if near.size:
            cand.append(int(i))
    if not cand:
        return []
    sights = loop_sights(ctx.V, loops, lambda lp: ctx.F[ctx.ring_faces(lp, 3)], candidates=cand)
    # loops that touch (share a vertex, e.g. the pinched pieces of a slit)
    # are one opening split at a pinch, not the two ends of a band
    for a, (counts, m) in sights.items():
        for b in np.flatnonzero(counts):
            if b != a and np.intersect1d(loops[a].vertices, loops[b].vertices).size:
                counts[b] = 0
    pairs = band_pairs(sights, hole)
    # pairs whose loops each send most of their arcs to the other: read by _fill_pair
    ctx.bands_mutual = {frozenset((loops[i].id, loops[j].id)) for i, j, _, mutual in pairs if mutual}
    return [(loops[i], loops[j], sc) for i, j, sc, _ in pairs]


def _edges_of(T):
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    return np.sort(E, axis=1)


def repair_mesh(mesh, options=None, *, progress=False, **changes):
    """Fill the holes of a mesh.

    Parameters
    ----------
    mesh : Mesh, (V, F), open3d or trimesh mesh, or path
        See :func:`shellrepair.convert.as_mesh`.
    options : RepairOptions, optional
        How holes are found and filled (:class:`shellrepair.options.RepairOptions`:
        ``order``, ``smooth``, ``max_hole``, ``fill_borders``, ``method``,
        ``jobs``, ``bridge``, ``closed``); default: the defaults.
    progress : bool
        Print progress to stderr.
    **changes
        Any option by name, applied over ``options``
        (``repair_mesh(mesh, order="auto", jobs=2)``).

    Returns
    -------
    repaired : Mesh
        Original vertices first and unchanged; new vertices and faces
        flagged in ``vertex_filled`` / ``face_filled``.
    report : dict
        Table 1 fields (see :func:`shellrepair.report.table1_dict`) plus
        per-hole details.
    """
    from .convert import as_mesh

    from .options import RepairOptions

    opts = RepairOptions.make(options, **changes)  # checked once, messages name the option
    order, smooth, max_hole, fill_borders = opts.order, opts.smooth, opts.max_hole, opts.fill_borders
    method, jobs, bridge, closed = opts.method, opts.jobs, opts.bridge, opts.closed
    mesh = as_mesh(mesh)  # a (V, F) pair, an open3d or trimesh mesh, or a path
    t0 = time.perf_counter()
    _progress(progress, 0, 2, "finding holes")  # whole-mesh work before the per-hole bar
    known = mesh.cached if hasattr(mesh, "cached") else lambda name: None   # built by read_mesh
    topo = known("topology")
    if not getattr(mesh, "fixes", None):
        # not prepared by read_mesh: the same topology by position, made manifold (not re-oriented)
        if topo is None:
            topo = edge_topology(np.asarray(mesh.F, np.int64), len(mesh.V))
        mesh = manifold_mesh(_as_mesh(mesh), orient=False, topo=topo)
        known = mesh.cached
        topo = known("topology")
    V = np.asarray(mesh.V, np.float64)
    F = np.asarray(mesh.F, np.int64)
    # a vertex no face uses may be NaN or infinite (read_mesh keeps it, noted): the
    # whole-mesh work sees a finite stand-in, the output gets the vertex back as it was
    stand_in = ~np.isfinite(V).all(axis=1)
    if stand_in.any():
        V = V.copy()
        V[stand_in] = V[F[0, 0]]
    if topo is None:
        topo = edge_topology(F, len(V))
    _progress(progress, 1, 2, "finding holes")

    def context(index):
        c = _Context(Mesh(V=V, F=F, vertex_colors=mesh.vertex_colors, vertex_props=mesh.vertex_props))
        c.topo = topo
        if index:
            _ = c.index
        return c

    def detect():
        return detect_holes(V, F, max_hole=max_hole, fill_borders=fill_borders, closed=closed, topo=topo,
                            pieces=known("pieces"), areas=known("face_areas"))

    if jobs > 1:
        # with cores to spare, the near-face index is built beside hole
        # detection (both are NumPy work that mostly runs without the GIL)
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(1) as ex:
            later = ex.submit(context, True)
            scan = detect()
            ctx = later.result()
    else:
        scan = detect()
        ctx = context(False)
    _progress(progress, 2, 2, "finding holes")
    holes = scan.holes
    ctx.planarity = {L.id: L.planarity for L in scan.loops}
    results = {}
    pairs = []
    if bridge != "never" and method == "fair":
        pairs = _find_bands(ctx, scan)
    paired = {L.id for A, B, _ in pairs for L in (A, B)}
    units = [("pair", (A, B, order, smooth, bridge)) for A, B, _ in pairs]
    units += [("one", (h.id, h.vertices, order, smooth)) for h in holes if h.id not in paired]
    units.sort(key=lambda u: u[1][0].id if u[0] == "pair" else u[1][0])
    if method == "seed":
        patches = _seed_patches(ctx, holes, smooth or SEED_SMOOTH_PASSES, results)
        unit_out = [([(patches.get(h.id), results.get(h.id, ""), 0.0, [])], None) for h in holes]
        units = [("one", (h.id, h.vertices, order, smooth)) for h in holes]
    else:
        # fixed runs of units, whatever ``jobs`` is, so the output is too
        chunks = [units[i:i + BATCH] for i in range(0, len(units), BATCH)]
        unit_out = []
        if jobs > 1 and len(chunks) > 1:
            global _WORKER_CTX
            _ = ctx.index  # built before forking (above), so workers share it
            _WORKER_CTX = ctx
            import multiprocessing as mp
            with mp.get_context("fork").Pool(min(jobs, len(chunks))) as pool:
                for out in pool.imap(_worker, chunks, chunksize=1):
                    unit_out.extend(out)
                    _progress(progress, len(unit_out), len(units))
            _WORKER_CTX = None
        else:
            done = [0]

            def tick():  # the bar moves hole by hole
                done[0] += 1
                _progress(progress, done[0], len(units))

            for chunk in chunks:
                unit_out.extend(_run_chunk(ctx, chunk, tick))
    if progress:  # end the bars' line (if they drew one)
        from .progress import end_line

        end_line()

    # sequential merge: patches against each other, in hole order
    acc = _Accepted()
    rows = {}
    bridges = []
    for u, (outs, record) in zip(units, unit_out):
        loops = [u[1][0], u[1][1]] if u[0] == "pair" else [scan.loops[u[1][0]]]
        tube_rejected = None
        tube_ok = False
        for L, (patch, reason, secs, _) in zip(loops, outs):
            row = {"id": L.id, "edges": L.edges, "status": "failed", "reason": reason,
                   "new_vertices": 0, "new_faces": 0, "seconds": round(secs, 4), "option": None}
            if patch is not None:
                conflict, corners = acc.conflict(ctx, patch)
                if conflict:
                    row["reason"] = conflict
                    if record is not None and record.get("chosen") == "tube":
                        tube_rejected = conflict
                else:
                    acc.add(patch, *corners)
                    tube_ok = True
                    row.update(status="filled", reason=patch.option, new_vertices=int(len(patch.P)),
                               new_faces=int(len(patch.T)), option=patch.option)
            elif record is not None and record.get("chosen") == "tube":
                if tube_ok:
                    row.update(status="filled", option="tube", new_vertices=0, new_faces=0)
                else:
                    row["reason"] = tube_rejected or row["reason"]
            if L.kind == "hole":
                rows[L.id] = row
        if record is not None:
            bridges.append(record)
    rows = [rows[h.id] for h in holes if h.id in rows]
    accepted = [it[0] for it in acc.items]
    repaired = _merge(mesh, V, F, accepted)
    if stand_in.any():
        repaired.V[:len(V)][stand_in] = np.asarray(mesh.V, np.float64)[stand_in]
    # check the result: boundary and non-manifold edges left, counted on the
    # edges the appended faces touch (the rest of the mesh did not change)
    delta = edge_count_delta(topo, repaired.F[len(F):], len(repaired.V))
    n_new_v, n_new_f = len(repaired.V) - len(V), len(repaired.F) - len(F)
    report = table1_dict(len(holes), rows, path=mesh.path, seconds=time.perf_counter() - t0,
                         method=method, order=order, borders=len(scan.borders), open_chains=scan.open_chains,
                         extra={**{k: int(v) for k, v in mesh.fixes.items()},
                                "border_edges_after": int(sum(b.edges for b in scan.borders)),
                                "vertices_before": int(len(V)), "faces_before": int(len(F)),
                                "vertices_after": int(len(repaired.V)), "faces_after": int(len(repaired.F)),
                                "open_chain_list": describe_open_chains(F, scan.open_chains, len(V), topo),
                                "boundary_edges_before": int(topo.n_boundary_edges),
                                "boundary_edges_after": int(topo.n_boundary_edges + delta["boundary_edges"]),
                                "nonmanifold_edges_before": int(mesh.fixes.get("nonmanifold_edges_found",
                                                                               topo.nonmanifold_edges.shape[0])),
                                "nonmanifold_edges_after": int(topo.nonmanifold_edges.shape[0]
                                                               + delta["nonmanifold_edges"]),
                                "smooth": smooth, "jobs": jobs, "bridge": bridge,
                                "closed": {None: "auto", True: "yes", False: "no"}[closed],
                                "bridges": bridges,
                                "euler_before": int(scan.euler),
                                "euler_after": int(scan.euler + n_new_v - delta["edges"] + n_new_f),
                                "border_loops": [{"id": b.id, "edges": b.edges, "reason": b.reason}
                                                 for b in scan.borders]})
    return repaired, report


def _progress(on, i, n, label="filling holes"):
    if on:  # a throttled bar on stderr when it is a terminal (shellrepair.progress)
        from .progress import step

        step(label, i, n)


def _scan_edges(patch):
    """Edges the patch creates between scan vertices, as (a, b) with a < b."""
    k = len(patch.loop)
    E = _edges_of(np.where(patch.T < k, patch.loop[np.minimum(patch.T, k - 1)], -1))
    return [tuple(e) for e in E[(E >= 0).all(axis=1)].tolist()]


class _Accepted:
    """Patches accepted so far, with their corners and boxes cached."""

    def __init__(self):
        self.items = []
        self.lo = np.zeros((0, 3))
        self.hi = np.zeros((0, 3))
        self.edges = set()

    def add(self, patch, C, ids):
        oid = np.where(ids < 0, ids - 10 ** 12 * (len(self.items) + 1), ids)  # new vertices differ per patch
        c, r = bounding_spheres(C)
        self.items.append((patch, C, oid, c, r))
        P = C.reshape(-1, 3)
        self.lo = np.vstack([self.lo, P.min(axis=0)])
        self.hi = np.vstack([self.hi, P.max(axis=0)])
        self.edges.update(_scan_edges(patch))

    def conflict(self, ctx, patch):
        """Why the patch clashes with an accepted one, or None."""
        if any(e in self.edges for e in _scan_edges(patch)):
            return "an earlier patch already created an edge this patch needs", None
        C, ids = _corners(ctx, patch)
        if self.items:
            P = C.reshape(-1, 3)
            lo, hi = P.min(axis=0), P.max(axis=0)
            near = np.flatnonzero(np.all((self.lo <= hi) & (lo <= self.hi), axis=1))
            c1, r1 = bounding_spheres(C)
            for j in near:
                other, D, oid, c2, r2 = self.items[j]
                ai, bi = ball_pairs(cKDTree(c2), c1, r1 + r2.max())
                if ai.size and pair_intersections(C[ai], ids[ai], D[bi], oid[bi]).any():
                    return f"patch would cross the patch of hole {other.hole_id}", None
        return None, (C, ids)


def _merge(mesh, V, F, patches):
    """Append patches; originals unchanged, additions flagged."""
    n = len(V)
    newP, newF, newC = [], [], []
    props = {k: [] for k in mesh.vertex_props}
    base = n
    for p in patches:
        newP.append(p.P)
        newF.append(p.global_faces(base))
        if mesh.vertex_colors is not None:
            newC.append(p.colors if p.colors is not None else
                        np.zeros((len(p.P), mesh.vertex_colors.shape[1]), np.uint8))
        for name in props:
            arr = np.asarray(mesh.vertex_props[name])
            props[name].append(p.props.get(name, np.zeros(len(p.P), arr.dtype)))
        base += len(p.P)
    q = base - n
    V2 = np.vstack([V] + newP) if newP else V.copy()
    F2 = np.vstack([F] + newF) if newF else F.copy()
    out = Mesh(V=V2, F=F2.astype(np.int64, copy=False), vertex_dtype=mesh.vertex_dtype, path=mesh.path,
               notes=list(mesh.notes), F_out=getattr(mesh, "F_out", None), fixes=dict(getattr(mesh, "fixes", {})),
               comments=list(getattr(mesh, "comments", [])))
    if mesh.vertex_colors is not None:
        out.vertex_colors = np.vstack([mesh.vertex_colors] + newC).astype(np.uint8)
    out.vertex_props = {k: np.concatenate([np.asarray(mesh.vertex_props[k])] + v) for k, v in props.items()}
    vf = np.zeros(n + q, bool)
    vf[n:] = True
    if mesh.vertex_filled is not None:
        vf[:n] = mesh.vertex_filled
    ff = np.zeros(len(F2), bool)
    ff[len(F):] = True
    if mesh.face_filled is not None:
        ff[:len(F)] = mesh.face_filled
    out.vertex_filled, out.face_filled = vf, ff
    return out


def _as_mesh(mesh):
    """A :class:`Mesh` with the fields of ``mesh`` (any object with ``V`` and ``F``)."""
    if isinstance(mesh, Mesh):
        return mesh
    return Mesh(V=np.asarray(mesh.V, np.float64), F=np.asarray(mesh.F, np.int64),
                vertex_colors=getattr(mesh, "vertex_colors", None), vertex_props=dict(getattr(mesh, "vertex_props", {})),
                vertex_dtype=getattr(mesh, "vertex_dtype", "f8"), path=getattr(mesh, "path", None),
                vertex_filled=getattr(mesh, "vertex_filled", None), face_filled=getattr(mesh, "face_filled", None),
                notes=list(getattr(mesh, "notes", [])), comments=list(getattr(mesh, "comments", [])))


def _seed_patches(ctx, holes, passes, results):
    """The paper's method: close, smooth a duplicate of the whole mesh, take the filled region."""
    built = []
    for h in holes:
        try:
            p = build_patch(ctx, h.id, h.vertices, order=1, smooth=0, refine=True, fair=False)
            built.append(p)
        except PatchError as exc:
            results[h.id] = f"seed: {exc}"
    n = ctx.n
    newP = [p.P for p in built]
    base = n
    Fs = [ctx.F]
    for p in built:
        Fs.append(p.global_faces(base))
        base += len(p.P)
    X = np.vstack([ctx.V] + newP) if newP else ctx.V.copy()
    Fall = np.vstack(Fs)
    if base > n:
        origin = ctx.V.mean(axis=0)
        X = umbrella_smooth(X - origin, Fall, passes, (0.5,)) + origin  # the whole duplicate
    out = {}
    base = n
    for p in built:
        p.P = X[base:base + len(p.P)]
        base += len(p.P)
        why, _ = _check_patch(ctx, p)
        if why is None:
            p.option = f"seed, {passes} smoothing passes"
            out[p.hole_id] = p
        else:
            results[p.hole_id] = f"seed: {why}"
    return out
