"""The scan as the fill reads it: a read-only index built once per scan.

:class:`ScanContext` holds the whole-mesh structures the per-hole work
reads (edges, vertex-to-face lists, the faces near a box), built once, or on
a large scan with few holes only those of a region around them
(:class:`_Region`, :data:`LOCAL_MIN_FACES`). The queries every fill stage
makes of the scan around one loop live here too: :func:`rim_data` (scale,
normals across the rim, forbidden chords), :func:`submesh` (the scan's
rings around a loop, plus a patch) and :func:`local_frame`.

Nothing here imports a fill stage: :mod:`~shellrepair.holes.loops`,
:mod:`~shellrepair.fill.patch`, :mod:`~shellrepair.fill.probe` and the rest read it,
so the fill's modules import one way (tests/test_layout.py).
"""

from __future__ import annotations

import threading

import numpy as np

from shellrepair import compiled
from shellrepair.mesh import index_kernels as context_kernels
from shellrepair.mesh import topology_kernels
from shellrepair.mesh.geometry import concat_ranges, uniq
from shellrepair.mesh.intersect import NearFaces
from shellrepair.mesh.topology import vertex_faces


class ScanContext:
    """Whole-mesh structures built once; per-hole work only reads them.

    Parameters
    ----------
    mesh : Mesh
    topo : EdgeTopology, optional
        The mesh's, when the caller has it.
    base : str
        ``RepairOptions.base``: how a scan's planar opening met edge-on is
        filled ("auto", "flat", "faired").

    Other modules change it only through its methods: :meth:`know_loops`
    (what hole detection measured), :meth:`take_region`, and a run of
    holes' scratch (:meth:`start_run`, :meth:`keep_first`,
    :meth:`end_run`).
    """

    def __init__(self, mesh, topo=None, base="auto"):
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
        self.base = base     # RepairOptions.base: how a scan's planar opening met edge-on is filled
        self.topo = topo     # the mesh's EdgeTopology, when the caller has it
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
        # loop bytes -> {triangle key: 0/1}: the scan test's answers (scan_allowed),
        # shared with a helper thread's copy of this context
        self.allowed_answers = {}
        self.pre = {}  # hole id -> _Pre: first-attempt work done for a batch of holes
        self.beside = None  # beside.Beside: a helper thread's work beside a batch's fills

    def know_loops(self, loops):
        """Keep what hole detection measured of each loop (planarity, its
        plane's axis), so the fill does not measure it again."""
        self.planarity = {L.id: L.planarity for L in loops}
        self.axes = {L.id: (L.vertices, L.axis) for L in loops if L.axis is not None}

    def start_run(self, beside):
        """A run of holes starts: ``beside`` the helper thread's work beside
        it (``beside.Beside``, or None)."""
        self.beside = beside

    def keep_first(self, hole_id, pre):
        """A hole's first-attempt work, done in a batch (``patch._Pre``)."""
        self.pre[hole_id] = pre

    def end_run(self):
        """The run is over: its first-attempt work and helper are dropped."""
        self.pre = {}
        if self.beside is not None:
            self.beside.cancel()
        self.beside = None

    def for_helper(self):
        """A copy for a helper thread: the same whole-mesh structures (the
        region around the loops built here first, so the two threads share
        it) and the same batch's first-attempt work, its own scratch marks
        and positions, no helper of its own."""
        import copy

        self.region()
        h = copy.copy(self)
        h._vmark = np.zeros(self.n, bool)
        h._fmark = np.zeros(len(self.F), bool)
        h._vpos = None
        h.beside = None
        return h

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
                        else (topology_kernels.vertex_faces if compiled.ENABLED else vertex_faces)(self.F, self.n))
        return self._vf

    @property
    def index(self):
        """The near-face index of the crossing checks: :class:`LocalIndex`
        over the region (:meth:`region`) when there is one, else the
        whole-mesh :class:`~shellrepair.mesh.intersect.NearFaces`."""
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
            return LocalIndex(self, reg) if reg is not None else self.whole_index()

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
                if self.region() is None and self._vf is None and self._vf_future is None and compiled.ENABLED:
                    early = self._early_vf     # (started with the region: take_region)
                    self._vf_future = early if early is not None else ex.submit(topology_kernels.vertex_faces, self.F, self.n)
            finally:
                arranged.set()
            return self.build_index()

        done = ex.submit(build)
        arranged.wait()
        return done

    def whole_index(self):
        """The whole-mesh :class:`~shellrepair.mesh.intersect.NearFaces`, built once
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
        first ring (:func:`shellrepair.mesh.index_kernels.ring_faces`) when the kernels
        are there, over the same vertex-face lists as :meth:`_faces_of_numpy`."""
        if not compiled.ENABLED:
            return self._faces_of_numpy(verts)
        verts = np.asarray(verts, np.int64)
        reg = self._local_lists(verts)
        order, start = (reg.vf_order, reg.vf_start) if reg is not None else self.vf
        F = self.F if self.F.flags.c_contiguous and self.F.dtype == np.int64 else np.ascontiguousarray(self.F, np.int64)
        return context_kernels.ring_faces(verts, 1, order, start, F, self._vmark, self._fmark)

    def _faces_of_numpy(self, verts):
        """:meth:`faces_of` in NumPy (its test oracle; the NumPy ring walk's
        step, which holds the scratch marks :meth:`faces_of` would use)."""
        verts = np.asarray(verts, np.int64)
        reg = self._local_lists(verts)
        order, start = (reg.vf_order, reg.vf_start) if reg is not None else self.vf
        s = start[verts]
        return uniq(order[concat_ranges(s, start[verts + 1] - s)] // 3)

    def ring_faces(self, verts, rings):
        """Faces within ``rings`` rings of ``verts`` (sorted): the compiled
        walk's faces (:meth:`ring_walk`) sorted, or the NumPy walk."""
        if compiled.ENABLED:
            return np.sort(self.ring_walk(verts, rings)[0])
        return self._ring_faces_numpy(verts, rings)

    def ring_walk(self, verts, rings):
        """The walk of :meth:`ring_faces` with each ring's end: ``(faces in
        walk order, off)``, ``np.sort(faces[:off[r]])`` being
        ``ring_faces(verts, r)`` for every ``1 <= r <= rings``
        (:func:`shellrepair.mesh.index_kernels.ring_walk`); None with the
        kernels off."""
        if not compiled.ENABLED:
            return None
        return self._walk(verts, lambda v, order, start, F: context_kernels.ring_walk(
            v, rings, order, start, F, self._vmark, self._fmark), faces=lambda got: got[0])

    def _walk(self, verts, walk, faces=lambda got: got):
        """``walk(verts, vf_order, vf_start, F)`` over the region's
        vertex-face lists where they are complete at ``verts``, kept where
        they were complete at every vertex of the faces it found
        (``faces(result)``), else over the whole mesh's lists."""
        F = self.F if self.F.flags.c_contiguous and self.F.dtype == np.int64 else np.ascontiguousarray(self.F, np.int64)
        verts = np.asarray(verts, np.int64)
        reg = self._local_lists(verts)
        if reg is not None:
            got = walk(verts, reg.vf_order, reg.vf_start, F)
            if reg.covered[F[faces(got)]].all():   # every list the walk read was complete
                return got
        return walk(verts, self.vf_order, self.vf_start, F)

    def faces_near(self, verts, rings, c, reach):
        """The faces within ``rings`` rings of ``verts`` that the walk
        reaches without leaving ``reach`` of ``c``: a face is kept, and its
        vertices walked on from, only where one of its corners lies within
        ``reach`` of ``c`` (sorted;
        :func:`shellrepair.mesh.index_kernels.ring_walk_within`, or
        :meth:`_faces_near_numpy` with the kernels off).

        Parameters
        ----------
        verts : (k,) int64
        rings : int
        c : (3,) float64
        reach : float

        Returns
        -------
        faces : (f,) int64
        """
        if not compiled.ENABLED:
            return self._faces_near_numpy(verts, rings, c, reach)
        return self._walk(verts, lambda v, order, start, F: context_kernels.ring_walk_within(
            v, rings, order, start, F, self.V, c, reach, self._vmark, self._fmark))

    def _faces_near_numpy(self, verts, rings, c, reach):
        """:meth:`faces_near` in NumPy (the compiled walk's test oracle)."""
        c = np.asarray(c, np.float64)
        r2 = float(reach) * float(reach)

        def within(f):
            D = self.V[self.F[f]] - c
            D *= D
            return f[((D[..., 0] + D[..., 1] + D[..., 2]) <= r2).any(axis=1)]

        return self._ring_faces_numpy(verts, rings, within)

    def _ring_faces_numpy(self, verts, rings, keep=None):
        """:meth:`ring_faces` in NumPy (the compiled walk's test oracle);
        ``keep``: the faces of a ring kept and walked on from (all of them
        by default; :meth:`_faces_near_numpy`'s reach)."""
        vm, fm = self._vmark, self._fmark
        front = uniq(np.asarray(verts, np.int64))
        vm[front] = True
        marked_v, seen, found = [front], [], []
        try:
            for _ in range(max(1, int(rings))):
                f = self._faces_of_numpy(front)
                f = f[~fm[f]]
                fm[f] = True
                seen.append(f)
                if keep is not None:
                    f = keep(f)
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
            for a in seen:
                fm[a] = False
        return np.sort(np.concatenate(found)) if found else np.zeros(0, np.int64)


#: The fill reads a local region (:class:`_Region`: the faces near the mesh's
#: boundary loops) instead of whole-mesh vertex-face lists and near-face
#: grid on a mesh of at least this many faces ...
LOCAL_MIN_FACES = 400_000
#: ... with at most this many boundary loops ...
LOCAL_MAX_LOOPS = context_kernels.MAX_BOXES
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
        o, self.vf_start = topology_kernels.vertex_faces(F[self.faces], n)
        self.vf_order = 3 * self.faces[o // 3] + o % 3


def _build_region(ctx):
    """:class:`_Region` around the boundary loops of ``ctx.topo``, or None."""
    return region_of(ctx.V, ctx.F, ctx.topo)


def early_lists(ex, V, F, topo):
    """Start, on the executor ``ex`` (two workers or more), the region
    around the boundary loops of ``topo`` (:func:`region_of`) and, where
    there is none, the whole-mesh vertex-face lists of ``F``: the lists the
    per-hole work reads (:meth:`ScanContext.take_region` takes both futures).

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
        if region.result() is not None or dropped.is_set() or not compiled.ENABLED:
            return None
        return topology_kernels.vertex_faces(F, len(V))

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

    A :class:`ScanContext` over the same ``V``, ``F`` and ``topo`` builds this
    region; :meth:`ScanContext.take_region` accepts one built beforehand.
    """
    if not compiled.ENABLED or topo is None or len(F) < LOCAL_MIN_FACES:
        return None
    bh = topo.boundary_he
    if bh.size == 0 or bh.size > LOCAL_MAX_EDGES:
        return None
    from shellrepair.mesh.components import connected_components

    E = topo.ends(bh)
    vs, inv = np.unique(E, return_inverse=True)
    inv = inv.reshape(-1, 2)
    nc, lab = connected_components(len(vs), inv[:, 0], inv[:, 1])
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
    found = context_kernels.faces_in_boxes(V, F, lo, hi)
    return _Region(F, len(V), lo, hi, found) if found[0].size <= LOCAL_MAX_SHARE * len(F) else None


class LocalIndex:
    """What the crossing checks read of a near-face index
    (:func:`shellrepair.mesh.intersect.patch_vs_index`: ``faces_near``, ``V``,
    ``F``, ``origin``), from a :class:`_Region`: the faces whose bounding
    boxes meet a query box inside one of the region's boxes (a superset of
    the faces that meet it, as the whole-mesh index gives; the exact tests
    decide). Any other query, and anything else, goes to the whole-mesh
    index, built then.

    Parameters
    ----------
    ctx : ScanContext
        The scan whose whole-mesh index answers what the region cannot.
    region : _Region
        The boxes around the holes, with the faces meeting each
        (:meth:`ScanContext.region`).
    """

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
            return r.faces[context_kernels.boxes_meeting(r.fmin, r.fmax, lo, hi)]
        return self._ctx.whole_index().faces_near(lo, hi)

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self._ctx.whole_index(), name)


def rim_data(ctx, loop):
    """Scale σ per loop vertex, scan normals across loop edges, forbidden chords."""
    if not compiled.ENABLED:
        return rim_data_numpy(ctx, loop)
    reg = ctx._local_lists(loop)          # the lists ctx.faces_of reads
    order, start = (reg.vf_order, reg.vf_start) if reg is not None else ctx.vf
    sig_sum, sig_cnt, edge_normals, forb = context_kernels.rim_walk(loop, order, start, ctx.F, ctx.V)
    forbidden = set(zip(forb[:, 0].tolist(), forb[:, 1].tolist()))
    return rim_sigma(ctx, loop, sig_sum, sig_cnt), edge_normals, forbidden


def _rim_faces(ctx, loop):
    """The sides (3m,2), side lengths and unit normals of the faces at the loop."""
    T = ctx.F[ctx.faces_of(loop)]
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    ln = np.linalg.norm(ctx.V[E[:, 0]] - ctx.V[E[:, 1]], axis=1)
    nrm = np.cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
    nl = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.divide(nrm, nl, out=np.zeros_like(nrm), where=nl > 0)
    return E, ln, nrm


def rim_sigma(ctx, loop, sig_sum, sig_cnt):
    """The scale σ per loop vertex: the mean length of the scan edges at it,
    or the loop edge from it where it has none (compiled:
    :func:`shellrepair.mesh.index_kernels.rim_sigma`, else :func:`rim_sigma_reference`).

    Parameters
    ----------
    ctx : ScanContext
    loop : (k,) int64
    sig_sum, sig_cnt : (k,) float64
        The summed lengths of the scan edges at each loop vertex, and their count.

    Returns
    -------
    (k,) float64
    """
    if compiled.ENABLED:
        return context_kernels.rim_sigma(ctx.V, loop, sig_sum, sig_cnt)
    return rim_sigma_reference(ctx, loop, sig_sum, sig_cnt)


def rim_sigma_reference(ctx, loop, sig_sum, sig_cnt):
    """:func:`rim_sigma` in NumPy (the fallback when kernels are off, and the
    compiled one's test oracle); parameters and returns as :func:`rim_sigma`."""
    sigma = sig_sum / np.maximum(sig_cnt, 1)
    loop_len = np.linalg.norm(ctx.V[np.concatenate([loop[1:], loop[:1]])] - ctx.V[loop], axis=1)   # np.roll by -1
    return np.where(sig_cnt > 0, sigma, loop_len)


def rim_data_numpy(ctx, loop):
    """:func:`rim_data` in Python (the compiled walk's test oracle)."""
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
    return rim_sigma(ctx, loop, sig_sum, sig_cnt), edge_normals, forbidden


def submesh(ctx, loop, Pl, T, rings):
    """Local submesh: scan faces within ``rings`` of the loop, plus the patch.

    Returns X (fixed scan vertices first, then new), Fs, g (global ids of
    the fixed vertices)."""
    k = len(loop)
    rf = ctx.ring_faces(loop, rings)
    if compiled.ENABLED:
        g, Fs, loc_loop, ok = context_kernels.submesh(rf, ctx.F, loop, T, ctx.vpos())
        if ok:
            return g, Fs, len(g), loc_loop
    return submesh_reference(ctx, loop, T, rf)


def submesh_reference(ctx, loop, T, rf):
    """:func:`submesh` in NumPy from its ring faces ``rf`` (the fallback, and
    the oracle of :func:`shellrepair.mesh.index_kernels.submesh`'s numbering).

    Parameters
    ----------
    ctx : ScanContext
    loop : (k,) int64
    T : (t,3) int64
        The patch's triangles (ids below k: loop positions; from k: new vertices).
    rf : (r,) int64
        The scan faces of the submesh (:meth:`ScanContext.ring_faces`).

    Returns
    -------
    g : (n,) int64
        Global ids of the fixed (scan) vertices, sorted.
    Fs : (r+t,3) int64
        The ring faces then the patch's, in local ids (fixed vertices first, then new).
    nf : int
        ``len(g)``.
    loc_loop : (k,) int64
        Each loop vertex's local id.
    """
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


def local_frame(ctx, loop, sigma):
    """Origin, scale and scaled loop positions of a hole's local frame:
    centred on the loop, in units of its mean rim edge."""
    P = ctx.V[loop]
    origin = P.mean(axis=0)
    scale = float(np.mean(sigma))
    if not np.isfinite(scale) or scale <= 0:
        scale = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0))) or 1.0
    return origin, scale, (P - origin) / scale
