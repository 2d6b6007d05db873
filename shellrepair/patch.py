"""One hole's shell patch: triangulate, refine, fair (steps 1-3 of the fill).

:func:`build_patch` turns one boundary loop into a :class:`Patch`: the loop
triangulated (:mod:`~shellrepair.triangulate`), refined to the rim's density
(:mod:`~shellrepair.refine`) and faired with the scan's rings around it held
fixed (:mod:`~shellrepair.fair`), or a flat cap where the scan meets a planar
opening edge-on (:func:`_meets_edge_on`). :class:`_Context` holds the
whole-mesh structures the per-hole work reads (edges, vertex-to-face lists,
the faces near a box), built once, or on a large scan with few holes only
those of a region around them (:class:`_Region`); :func:`_prefill` does a run of holes'
first attempts at once.

The retries, the checks and the choice among attempts are in
:mod:`~shellrepair.fill`; the merge into the scan in :mod:`~shellrepair.merge`;
the orchestration in :mod:`~shellrepair.repair`.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import kernels
from .errors import MeshError
from .geometry import concat_ranges, cross, uniq
from .fair import (fair_patch, harmonic_interpolate, patch_energies, taubin_smooth, uniform_laplacian)
from .intersect import NearFaces, patch_vs_index
from .refine import refine_patch, refine_patches
from .topology import vertex_faces
from .triangulate import triangulate_loop


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
    A: object              # shellrepair.holes.Loop
    B: object
    order: object
    smooth: int
    mode: str              # the ``bridge`` option: "auto" or "always"

    @property
    def first_id(self):
        return self.A.id


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
    choice : shellrepair.selftest.OrderTest or None
        What the order test measured when ``order="auto"`` chose this
        patch's order (None for a forced order or an untested kind).
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
    fallback: object = None   # order 3 chosen by "auto": the hole's checked order-2 patch (same rim edges)
    choice: object = None     # the OrderTest behind an "auto" order

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
        self._vf = None   # vertex-to-face lists, built on first use (vf_order, vf_start)
        self._vmark = np.zeros(self.n, bool)      # scratch marks for ring_faces, left all False
        self._fmark = np.zeros(len(self.F), bool)
        self._vpos = None                         # scratch vertex positions (vpos()), made on first use
        self.planarity = {}  # loop id -> planarity measured by detect_holes
        self.axes = {}       # loop id -> (loop vertices, best-fit plane axis) measured by detect_holes
        self.base = "auto"   # RepairOptions.base: how a scan's planar opening met edge-on is filled
        self.topo = None     # the mesh's EdgeTopology, when the caller has it
        self._index = None
        self._full_index = None
        self._region = None  # _Region near the boundary loops; False: none (whole-mesh structures)
        # the region and the index are built once, by whichever thread asks
        # first (the others wait); the whole-mesh lists may be on their way
        # from another thread (a future, see whole_index)
        self._build_lock = threading.RLock()
        self._vf_future = None
        self._region_future = None   # the region on its way from another thread (take_region)
        self._early_vf = None        # and the whole-mesh lists, where there is no region
        # loop bytes -> {triangle key: 0/1}: the scan test's answers (_scan_allowed),
        # shared with a helper thread's copy of this context
        self.allowed_answers = {}
        self.pre = {}  # hole id -> _Pre: first-attempt work done for a batch of holes
        self.beside = None  # fill._Beside: a helper thread's work beside a batch's fills

    @property
    def vf_order(self):
        return self.vf[0]

    @property
    def vf_start(self):
        return self.vf[1]

    @property
    def vf(self):
        """Vertex-to-face lists ``(order, start)`` of the whole mesh, built once on first use."""
        if self._vf is None:
            fut = self._vf_future
            self._vf = (fut.result() if fut is not None
                        else (kernels.vertex_faces if kernels.ENABLED else vertex_faces)(self.F, self.n))
        return self._vf

    @property
    def index(self):
        """The near-face index of the crossing checks: :class:`_LocalIndex`
        over the region (:meth:`region`) when there is one, else the
        whole-mesh :class:`~shellrepair.intersect.NearFaces`."""
        return self.build_index()

    def _once(self, name, build):
        """The attribute ``name``, set to ``build()`` by the first thread
        to find it None (the others wait for it, under ``_build_lock``)."""
        got = getattr(self, name)
        if got is None:
            with self._build_lock:
                got = getattr(self, name)
                if got is None:
                    got = build()
                    setattr(self, name, got)
        return got

    def build_index(self):
        """:attr:`index`, built once, by the first thread to ask (the others wait)."""
        def build():
            reg = self.region()
            return _LocalIndex(self, reg) if reg is not None else self.whole_index()

        return self._once("_index", build)

    def index_in_background(self, ex):
        """Start building :attr:`index` on the executor ``ex`` (two workers
        or more) and return its future once :attr:`vf` is arranged: the
        whole-mesh vertex-face lists, where the index needs them, are built
        on a worker of their own beside the index's grid. Meanwhile the
        caller may use :attr:`vf` and :meth:`region` (waiting for the lists
        only); :attr:`index` waits for the index."""
        arranged = threading.Event()

        def build():
            try:
                if self.region() is None and self._vf is None and self._vf_future is None and kernels.ENABLED:
                    early = self._early_vf     # (started with the region: take_region)
                    self._vf_future = early if early is not None else ex.submit(kernels.vertex_faces, self.F, self.n)
            finally:
                arranged.set()
            return self.build_index()

        done = ex.submit(build)
        arranged.wait()
        return done

    def whole_index(self):
        """The whole-mesh :class:`~shellrepair.intersect.NearFaces`, built once
        (its vertex-face lists are :attr:`vf`, asked for last)."""
        return self._once("_full_index", lambda: NearFaces(self.V, self.F, origin=self.V.mean(axis=0),
                                                            vf=lambda: self.vf, topo=self.topo))

    def region(self):
        """The :class:`_Region` around the boundary loops, or None (a mesh
        too small, too many loops, or no edge topology: whole-mesh lists)."""
        def build():
            fut = self._region_future
            return (fut.result() if fut is not None else _build_region(self)) or False

        return self._once("_region", build) or None

    def take_region(self, future, V, F, topo, vf=None):
        """Use the region a ``future`` is building (:func:`region_of` of
        ``V``, ``F``, ``topo``, started before this context was made) when
        those are this context's arrays and topology, the very objects: the
        region :meth:`region` would build. ``vf``: a future of the
        whole-mesh vertex-face lists of ``F`` (:attr:`vf`), started with
        the region for when it is None (:func:`early_lists`). Returns
        whether they were taken."""
        ok = future is not None and V is self.V and F is self.F and topo is self.topo and self._region is None
        if ok:
            self._region_future = future
            self._early_vf = vf
        return ok

    def _local_lists(self, verts):
        """The region's vertex-face lists when they are complete at every
        vertex of ``verts`` and the whole-mesh ones are not built; else None."""
        if self._vf is not None:
            return None
        reg = self.region()
        return reg if reg is not None and reg.covered[verts].all() else None

    def vpos(self):
        """Scratch of one int64 per vertex, all -1 (made on first use); a
        user sets the entries it needs and sets them back to -1."""
        if self._vpos is None:
            self._vpos = np.full(self.n, -1, np.int64)
        return self._vpos

    def pre_for(self, hole_id, loop):
        """The batch's first-attempt work for this hole and loop, or None."""
        pre = self.pre.get(hole_id)
        return pre if pre is not None and np.array_equal(pre.loop, loop) else None

    def faces_of(self, verts):
        """Faces with a corner in ``verts`` (sorted): the compiled walk's
        first ring (:func:`shellrepair.kernels.ring_faces`) when the kernels
        are there, over the same vertex-face lists as :meth:`_faces_of_numpy`."""
        if not kernels.ENABLED:
            return self._faces_of_numpy(verts)
        verts = np.asarray(verts, np.int64)
        reg = self._local_lists(verts)
        order, start = (reg.vf_order, reg.vf_start) if reg is not None else self.vf
        F = self.F if self.F.flags.c_contiguous and self.F.dtype == np.int64 else np.ascontiguousarray(self.F, np.int64)
        return kernels.ring_faces(verts, 1, order, start, F, self._vmark, self._fmark)

    def _faces_of_numpy(self, verts):
        """:meth:`faces_of` in NumPy (its test oracle; the NumPy ring walk's
        step, which holds the scratch marks :meth:`faces_of` would use)."""
        verts = np.asarray(verts, np.int64)
        reg = self._local_lists(verts)
        order, start = (reg.vf_order, reg.vf_start) if reg is not None else self.vf
        s = start[verts]
        return uniq(order[concat_ranges(s, start[verts + 1] - s)] // 3)

    def ring_faces(self, verts, rings):
        """Faces within ``rings`` rings of ``verts`` (sorted)."""
        if kernels.ENABLED:
            F = self.F if self.F.flags.c_contiguous and self.F.dtype == np.int64 else np.ascontiguousarray(self.F, np.int64)
            verts = np.asarray(verts, np.int64)
            reg = self._local_lists(verts)
            if reg is not None:
                got = kernels.ring_faces(verts, rings, reg.vf_order, reg.vf_start, F, self._vmark, self._fmark)
                if reg.covered[F[got]].all():   # every list the walk read was complete
                    return got
            return kernels.ring_faces(verts, rings, self.vf_order, self.vf_start, F, self._vmark, self._fmark)
        return self._ring_faces_numpy(verts, rings)

    def _ring_faces_numpy(self, verts, rings):
        """:meth:`ring_faces` in NumPy (the compiled walk's test oracle)."""
        vm, fm = self._vmark, self._fmark
        front = uniq(verts)
        vm[front] = True
        marked_v, found = [front], []
        try:
            for _ in range(max(1, int(rings))):
                f = self._faces_of_numpy(front)
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


#: The fill reads a local region (:class:`_Region`: the faces near the mesh's
#: boundary loops) instead of whole-mesh vertex-face lists and near-face
#: grid on a mesh of at least this many faces ...
LOCAL_MIN_FACES = 400_000
#: ... with at most this many boundary loops ...
LOCAL_MAX_LOOPS = kernels.MAX_BOXES
#: ... and boundary edges in all ...
LOCAL_MAX_EDGES = 20_000
#: ... when the region holds at most this share of the faces.
LOCAL_MAX_SHARE = 0.5
#: A loop's region: its bounding box grown by this many times its diagonal
#: (where a faired patch bulges beyond it, its check reads the whole-mesh
#: index) ...
LOCAL_GROW = 0.25
#: ... and by this many of its longest edges (the rings around a small loop).
LOCAL_RING_EDGES = 12


class _Region:
    """The faces whose bounding boxes meet some box around the boundary
    loops, and their vertex-to-face lists.

    Every face at a vertex inside a box has that vertex in its bounding box,
    so the lists are complete at those vertices (``covered``); a query that
    reads any other vertex's list goes to the whole-mesh lists instead. The
    lists have the whole-mesh layout (``start`` over all vertices, entries
    ``3f + corner`` in ascending order), so a complete list is the
    whole-mesh list itself.
    """

    def __init__(self, F, n, lo, hi, found):
        self.lo, self.hi = lo, hi
        self.faces, self.fmin, self.fmax, self.covered = found
        o, self.vf_start = kernels.vertex_faces(F[self.faces], n)
        self.vf_order = 3 * self.faces[o // 3] + o % 3


def _build_region(ctx):
    """:class:`_Region` around the boundary loops of ``ctx.topo``, or None."""
    return region_of(ctx.V, ctx.F, ctx.topo)


def early_lists(ex, V, F, topo):
    """Start, on the executor ``ex`` (two workers or more), the region
    around the boundary loops of ``topo`` (:func:`region_of`) and, where
    there is none, the whole-mesh vertex-face lists of ``F``: the lists the
    per-hole work reads (:meth:`_Context.take_region` takes both futures).

    Returns
    -------
    region, vf : concurrent.futures.Future
        ``vf``'s result is None where the region is not (the lists are
        then not built).
    drop : callable
        Call it when neither is wanted any more: what has not begun is
        cancelled, the lists are not started.
    """
    region = ex.submit(region_of, V, F, topo)
    dropped = threading.Event()

    def lists():
        if region.result() is not None or dropped.is_set() or not kernels.ENABLED:
            return None
        return kernels.vertex_faces(F, len(V))

    vf = ex.submit(lists)

    def drop():
        dropped.set()
        region.cancel()
        vf.cancel()

    return region, vf, drop


def region_of(V, F, topo):
    """:class:`_Region` around the boundary loops of ``topo`` (the edge
    topology of ``F``), or None (a mesh too small, too many loops, no
    topology or no kernels: the whole-mesh lists serve instead).

    A :class:`_Context` over the same ``V``, ``F`` and ``topo`` builds this
    region; :meth:`_Context.take_region` accepts one built beforehand.
    """
    if not kernels.ENABLED or topo is None or len(F) < LOCAL_MIN_FACES:
        return None
    bh = topo.boundary_he
    if bh.size == 0 or bh.size > LOCAL_MAX_EDGES:
        return None
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    E = topo.ends(bh)
    vs, inv = np.unique(E, return_inverse=True)
    inv = inv.reshape(-1, 2)
    nc, lab = connected_components(coo_matrix((np.ones(len(E)), (inv[:, 0], inv[:, 1])), shape=(len(vs), len(vs))),
                                   directed=False)
    P = V[vs]
    if nc > LOCAL_MAX_LOOPS or not np.isfinite(P).all():
        return None
    lo = np.full((nc, 3), np.inf)
    hi = np.full((nc, 3), -np.inf)
    np.minimum.at(lo, lab, P)
    np.maximum.at(hi, lab, P)
    longest = np.zeros(nc)
    np.maximum.at(longest, lab[inv[:, 0]], np.linalg.norm(P[inv[:, 0]] - P[inv[:, 1]], axis=1))
    g = LOCAL_GROW * np.linalg.norm(hi - lo, axis=1) + LOCAL_RING_EDGES * longest
    lo -= g[:, None]
    hi += g[:, None]
    found = kernels.faces_in_boxes(V, F, lo, hi)
    return _Region(F, len(V), lo, hi, found) if found[0].size <= LOCAL_MAX_SHARE * len(F) else None


class _LocalIndex:
    """What the crossing checks read of a near-face index
    (:func:`shellrepair.intersect.patch_vs_index`: ``faces_near``, ``V``,
    ``F``, ``origin``), from a :class:`_Region`: the faces whose bounding
    boxes meet a query box inside one of the region's boxes (a superset of
    the faces that meet it, as the whole-mesh index gives; the exact tests
    decide). Any other query, and anything else, goes to the whole-mesh
    index, built then."""

    def __init__(self, ctx, region):
        self._ctx = ctx
        self._reg = region
        self.V, self.F = ctx.V, ctx.F
        self.origin = ctx.V.mean(axis=0)

    def faces_near(self, lo, hi):
        """Faces that may meet the box ``[lo, hi]`` (absolute coordinates), sorted."""
        lo = np.asarray(lo, np.float64)
        hi = np.asarray(hi, np.float64)
        r = self._reg
        if np.isfinite(lo).all() and np.isfinite(hi).all() and np.all((r.lo <= lo) & (hi <= r.hi), axis=1).any():
            return r.faces[kernels.boxes_meeting(r.fmin, r.fmax, lo, hi)]
        return self._ctx.whole_index().faces_near(lo, hi)

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self._ctx.whole_index(), name)


def _rim_data(ctx, loop):
    """Scale σ per loop vertex, scan normals across loop edges, forbidden chords."""
    if not kernels.ENABLED:
        return _rim_data_numpy(ctx, loop)
    reg = ctx._local_lists(loop)          # the lists ctx.faces_of reads
    order, start = (reg.vf_order, reg.vf_start) if reg is not None else ctx.vf
    sig_sum, sig_cnt, edge_normals, forb = kernels.rim_walk(loop, order, start, ctx.F, ctx.V)
    forbidden = set(zip(forb[:, 0].tolist(), forb[:, 1].tolist()))
    return _rim_sigma(ctx, loop, sig_sum, sig_cnt), edge_normals, forbidden


def _rim_faces(ctx, loop):
    """The sides (3m,2), side lengths and unit normals of the faces at the loop."""
    T = ctx.F[ctx.faces_of(loop)]
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    ln = np.linalg.norm(ctx.V[E[:, 0]] - ctx.V[E[:, 1]], axis=1)
    nrm = np.cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
    nl = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.divide(nrm, nl, out=np.zeros_like(nrm), where=nl > 0)
    return E, ln, nrm


def _rim_sigma(ctx, loop, sig_sum, sig_cnt):
    if kernels.ENABLED:
        return kernels.rim_sigma(ctx.V, loop, sig_sum, sig_cnt)
    return _rim_sigma_numpy(ctx, loop, sig_sum, sig_cnt)


def _rim_sigma_numpy(ctx, loop, sig_sum, sig_cnt):
    """:func:`_rim_sigma` in NumPy (the compiled one's test oracle)."""
    sigma = sig_sum / np.maximum(sig_cnt, 1)
    loop_len = np.linalg.norm(ctx.V[np.concatenate([loop[1:], loop[:1]])] - ctx.V[loop], axis=1)   # np.roll by -1
    return np.where(sig_cnt > 0, sigma, loop_len)


def _rim_data_numpy(ctx, loop):
    """:func:`_rim_data` in Python (the compiled walk's test oracle)."""
    k = len(loop)
    pos = {int(v): i for i, v in enumerate(loop)}
    E, ln, nrm = _rim_faces(ctx, loop)
    sig_sum = np.zeros(k)
    sig_cnt = np.zeros(k)
    edge_normals = np.zeros((k, 3))
    forbidden = set()
    m = len(nrm)
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
    return _rim_sigma(ctx, loop, sig_sum, sig_cnt), edge_normals, forbidden


def _submesh(ctx, loop, Pl, T, rings):
    """Local submesh: scan faces within ``rings`` of the loop, plus the patch.

    Returns X (fixed scan vertices first, then new), Fs, g (global ids of
    the fixed vertices)."""
    k = len(loop)
    rf = ctx.ring_faces(loop, rings)
    if kernels.ENABLED:
        g, Fs, loc_loop, ok = kernels.submesh(rf, ctx.F, loop, T, ctx.vpos())
        if ok:
            return g, Fs, len(g), loc_loop
    return _submesh_numpy(ctx, loop, T, rf)


def _submesh_numpy(ctx, loop, T, rf):
    """:func:`_submesh` in NumPy from its ring faces ``rf`` (the compiled
    numbering's test oracle)."""
    k = len(loop)
    Fg = ctx.F[rf]
    g = uniq(Fg)
    Fr = np.searchsorted(g, Fg)
    loc_loop = np.searchsorted(g, loop)       # every loop vertex is on a ring face
    if len(g) == 0 or not np.array_equal(g[np.minimum(loc_loop, len(g) - 1)], loop):
        remap = {int(v): i for i, v in enumerate(g.tolist())}
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
    frame: tuple | None = None      # _local_frame(ctx, loop, rim sigma)
    first: object = None            # the first attempt, built and checked (fill._first_attempts)


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
        rim = _rim_data(ctx, loop)
        pre = _Pre(loop=loop, rim=rim)
        ctx.pre[hole_id] = pre
        if order != 1:
            pre.edge_on = _meets_edge_on(ctx, loop, hole_id)
        sigma, edge_normals, forbidden = rim
        pre.frame = _local_frame(ctx, loop, sigma)
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
                energy=False, pinned=None, scan_aware=False, max_vertices=None):
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
    max_vertices : int, optional
        Raise :class:`PatchError` when refinement makes more new vertices
        than this (a work budget), before the costly fairing.

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
    if pre is not None and pre.frame is not None:     # the batch's frame of this loop and rim
        origin, scale, Pl = pre.frame[0], pre.frame[1], pre.frame[2].copy()
    else:
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
    if max_vertices is not None and q > max_vertices:
        # a work bound (shellrepair.fill._Budget): stop before fairing
        raise PatchError(f"refined patch has {q} new vertices, over the work budget left ({int(max_vertices)})")
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


def _scan_allowed(ctx, loop):
    """``allowed(T)`` for :func:`triangulate_loop`: True for the triangles
    (loop positions) that cross no scan face.

    A triangle's answer depends on its corners only (each is tested against
    the scan on its own), so the answers are kept on ``ctx`` per loop: the
    retries of one hole (re-routed chords, sub-loops, the mender) ask about
    the same triangles many times (on a 699-edge hole, 13104 asked, 1611
    different).
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


def _corners(ctx, patch):
    """A patch's triangle corners (t,3,3) and ids (t,3): the scan vertex,
    or ``-(1 + j)`` for new vertex j."""
    if kernels.ENABLED:
        return kernels.patch_corners(ctx.V, patch.loop, patch.P, patch.T)
    return _corners_numpy(ctx, patch)


def _corners_numpy(ctx, patch):
    """:func:`_corners` in NumPy (the compiled one's test oracle)."""
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
#: continues them into a dome. On a scan it gets a flat cap only where the
#: walls turn into the opening's plane along most of its rim
#: (:func:`_turns_into_opening`): a base the scan reached the edge of, not
#: a cut through walls that run on.
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
    """Is the loop a planar opening whose surrounding walls stand across its
    plane, to be capped flat? On a scan, by ``ctx.base``
    (:class:`shellrepair.options.RepairOptions`): ``"flat"`` every such
    opening, ``"faired"`` none, ``"auto"`` where the walls turn into it
    (:func:`_turns_into_opening`); a CAD face's outline always."""
    return edge_on_verdict(ctx, loop, hole_id)[0]


def edge_on_verdict(ctx, loop, hole_id=None):
    """:func:`_meets_edge_on` and, when False, why (for the report of a
    ``--base flat`` that does not apply): ``(bool, str)``."""
    from .holes import loop_stats

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
    n = _face_cross(ctx, ctx.ring_faces(loop, EDGE_ON_RINGS))
    a = 0.5 * np.linalg.norm(n, axis=1)
    if a.sum() <= 0:
        return False, "no face of area beside it"
    cosines = np.abs(n @ st["axis"]) / np.maximum(2 * a, 1e-300)
    c = float(np.sum(a * cosines) / a.sum())
    if c > EDGE_ON_COS:
        return False, (f"the scan beside it does not stand across its plane (mean |cos| of its faces' "
                       f"normals to the plane's {c:.2f}, over {EDGE_ON_COS})")
    # the user's word on what the opening is (RepairOptions.base), else the rule
    if ctx.base == "flat":
        return True, ""
    if ctx.base == "auto" and _turns_into_opening(ctx, loop):
        return True, ""
    return False, "faired by request" if ctx.base == "faired" else "the scan does not turn into its plane"


def _face_cross(ctx, faces):
    """``cross(e1, e2)`` of the scan faces ``faces`` (twice their area-weighted normals)."""
    if kernels.ENABLED:
        return kernels.face_cross(faces, ctx.F, ctx.V)
    T = ctx.F[faces]
    return cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])


def _turns_into_opening(ctx, loop):
    """Does the scan turn into the opening's plane along most of its rim?

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
    """
    return 2 * rim_turning(ctx, loop) > len(loop)


def rim_turning(ctx, loop):
    """How many of the loop's vertices have first-ring faces that face out
    through the opening (:func:`_turns_into_opening`'s count; 0 for a loop
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
