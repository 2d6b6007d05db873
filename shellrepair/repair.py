"""Fill every hole of a scan with a faired shell patch and merge it.

Per hole (a loop classed ``hole`` by :mod:`shellrepair.holes.loops`), touching
only the patch and a few rings of scan around it:

1. triangulate the loop (:mod:`~shellrepair.fill.triangulate`);
2. refine it to the density of the rim (:mod:`~shellrepair.fill.refine`);
3. fair it, Δᵏx = 0 with the scan around it fixed
   (:mod:`~shellrepair.fill.fair`), optionally smooth it (Taubin, non-shrinking);
   a planar opening that the scan meets edge-on (a base, a sole; on a CAD
   part, any exactly planar outline with a crease along its rim) gets a
   flat cap instead, bent only where rim faces slant across it;
4. check it (:mod:`~shellrepair.mesh.intersect`): no patch triangle may cross the
   scan, itself or an earlier patch, and no patch may create an edge the
   mesh has. A patch that crosses is rebuilt: chords near the crossing are
   re-routed, vertices near it are held on the flat triangulation, then the
   harmonic patch and the checked flat triangulation are tried. A planar
   opening whose own region the scan crosses away from its rim stops at
   once: every flat triangulation covers that region. If nothing works
   the hole stays open and the report says why.

Two loops facing each other across a missing band are first offered a tube
(:mod:`~shellrepair.fill.bridge`); the tube or the two caps are kept by their
curvature-variation energy. Two planar loops met edge-on on one plane, one
inside the other, are one flat face with a hole
(:func:`~shellrepair.fill.band_fill.flat_face_with_hole`).

Then every accepted patch is appended: original vertices keep their index
and exact values, new vertices and faces come after them and are flagged
``filled``; vertex colours (and other vertex properties) are interpolated
harmonically from the rim. Holes are filled in runs of ``BATCH``
consecutive holes, one run at a time or by ``jobs`` processes; within a run
the first attempt's rim data, triangulation and refinement are done for all
its holes at once (the refinement as one disjoint union, with the same
result as hole by hole). Where the runs are filled in this process (one
run, or a daemonic process) and ``jobs`` is more than one, a second thread
runs the ``order="auto"`` holes' order tests, and the order-3 patches they
ask for, beside the fills (:class:`~shellrepair.fill.beside.HelperThread`; that
work reads only the scan and the run's first-attempt work). The checks
between patches and the merge run afterwards in hole order, so the output
does not depend on ``jobs``.

Whole-mesh structures (edges, vertex-to-face lists, the faces near a box)
are built once, vectorised; a patch is checked against the scan faces near
its own box only (:class:`~shellrepair.mesh.intersect.NearFaces`), and against
itself by a projection certificate where one holds
(:func:`~shellrepair.mesh.intersect.embeds_by_projection`), pair by pair
otherwise.

``method="seed"`` is the paper's simple shape model for comparison: close
each hole with the same triangulation, smooth a duplicate of the whole
mesh ``smooth`` times (10 by default) with the umbrella operator, and take
the filled region's vertices from the smoothed duplicate.

The steps live in their own modules: :mod:`~shellrepair.fill.patch` (one
patch), :mod:`~shellrepair.fill.hole` (attempts, checks, retries, bands),
:mod:`~shellrepair.fill.bridge` (finding bands), :mod:`~shellrepair.fill.merge`
(appending the patches); this module runs them over a scan and writes the
report.

References
----------
P. Liepa, "Filling Holes in Meshes", SGP 2003. M. Botsch, L. Kobbelt, "An
intuitive framework for real-time freeform modeling", SIGGRAPH 2004.
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple, Optional

import numpy as np

# Every fill triangulates its loop with Qhull's Delaunay and measures with
# k-d trees (scipy.spatial, 0.3-0.5 s to import, scipy.sparse with it): loaded
# with this module, before a repair's clock starts, not by its first hole.
# The modules below name SciPy through shellrepair.lazyscipy, so reading a
# scan (shellrepair.mesh.io) does not load it.
import scipy.spatial  # noqa: F401

from shellrepair import blas
from shellrepair.errors import MeshError
# the order test of order="auto" (the default), which the fill imports on its
# first hole: loaded with this module, before a repair's clock starts
from shellrepair.fill import probe, selftest  # noqa: F401
from shellrepair.fill.band_fill import _fill_pair
from shellrepair.fill.bands import Bands, find_bands
from shellrepair.fill.beside import HelperThread
from shellrepair.fill.checks import CLASHES, MERGED_CHECK, NO_PATCH_PASSES, Outcome
from shellrepair.fill.hole import SEED_SMOOTH_PASSES, _seed_patches, fill_hole
from shellrepair.fill.merge import Accepted, _merge, crossings_after_merge
from shellrepair.fill.pants import PantsUnit, expand, pants_unit
from shellrepair.fill.patch import BATCH, BandUnit, HoleUnit, Patch, build_patch
from shellrepair.fill.runs import _worker, run_chunk, worker_context
from shellrepair.holes.loops import detect_holes
from shellrepair.holes.pinched import split_pinched
from shellrepair.mesh import distance  # the order test's distances, loaded with it
from shellrepair.mesh.clean import describe_open_chains
from shellrepair.mesh.convert import MeshLike, as_mesh
from shellrepair.mesh.index import ScanContext
from shellrepair.mesh.io import Mesh, check_references, manifold_mesh
from shellrepair.mesh.topology import edge_count_delta, edge_topology
from shellrepair.mesh.units import in_scan_units
from shellrepair.options import RepairOptions
from shellrepair.progress import ProgressArg, as_callback
from shellrepair.report.table import table1_dict

__all__ = ["repair_mesh", "build_patch", "Patch", "SEED_SMOOTH_PASSES"]


def repair_mesh(mesh: MeshLike, options: Optional[RepairOptions] = None, *, progress: ProgressArg = None,
                **changes: Any) -> tuple[Mesh, dict]:
    """Fill the holes of a mesh.

    Parameters
    ----------
    mesh : Mesh, (V, F), open3d or trimesh mesh, or path
        See :func:`shellrepair.mesh.convert.as_mesh`.
    options : RepairOptions, optional
        How holes are found and filled (:class:`shellrepair.options.RepairOptions`:
        ``order``, ``smooth``, ``max_hole``, ``fill_borders``, ``method``,
        ``jobs``, ``bridge``, ``closed``); default: the defaults.
    progress : callable, optional
        Called as ``progress(label, done, total)`` (the protocol of
        :mod:`shellrepair.progress`): ``"finding holes"`` 0..2, then
        ``"filling holes"`` once per hole or band filled. Default None:
        nothing. ``True`` draws the terminal bar, as before.
    **changes
        Any option by name, applied over ``options``
        (``repair_mesh(mesh, order="auto", jobs=2)``).

    Returns
    -------
    repaired : Mesh
        Original vertices first and unchanged; new vertices and faces
        flagged in ``vertex_filled`` / ``face_filled``.
    report : dict
        Table 1 fields (see :func:`shellrepair.report.table.table1_dict`) plus
        per-hole details.

    Raises
    ------
    MeshError
        An option out of range, or a face that refers to a vertex outside
        ``V`` or to a vertex with a NaN or infinite coordinate (one line,
        as :func:`shellrepair.mesh.io.read_mesh` says it; a vertex no face uses
        may be non-finite, and is given back as it was).
    """
    with blas.one_thread():     # the fill's many small products: one BLAS thread (shellrepair.blas)
        return _repair_mesh(mesh, options, progress=progress, **changes)


def _repair_mesh(mesh: MeshLike, options: Optional[RepairOptions] = None, *, progress: ProgressArg = None,
                 **changes: Any) -> tuple[Mesh, dict]:
    """:func:`repair_mesh`'s work, with whatever BLAS thread count the caller
    set (:func:`repair_mesh` sets one)."""
    opts = RepairOptions.make(options, **changes)  # checked once, messages name the option
    legacy_bar = progress is True
    progress = as_callback(progress)
    order, smooth, max_hole, fill_borders = opts.order, opts.smooth, opts.max_hole, opts.fill_borders
    method, jobs, bridge, closed = opts.method, opts.jobs, opts.bridge, opts.closed
    base = opts.base
    order_for = opts.order_for
    mesh = as_mesh(mesh)  # a (V, F) pair, an open3d or trimesh mesh, or a path
    t0 = time.perf_counter()
    _progress(progress, 0, 2, "finding holes")  # whole-mesh work before the per-hole bar
    index_built = None
    ex = None
    if jobs > 1:
        # with cores to spare: the region the crossing checks read is built
        # beside making the mesh manifold and detecting holes, the context
        # (the kernels loaded) beside the detection, then the near-face
        # index beside the order test and the band search (compiled loops
        # that release the GIL)
        from concurrent.futures import ThreadPoolExecutor

        ex = ThreadPoolExecutor(2)
    try:
        known = _kept(mesh).get       # built by read_mesh
        topo = known("topology")
        early = None    # an _Early: the region and lists started before the mesh is final
        if not getattr(mesh, "fixes", None):
            # not prepared by read_mesh: checked as it checks (a face on a vertex
            # outside V or with a NaN coordinate: MeshError), the same topology by
            # position, made manifold (not re-oriented)
            F0 = np.asarray(mesh.F, np.int64)
            check_references(np.asarray(mesh.V, np.float64), F0)
            if topo is None:
                topo = edge_topology(F0, len(mesh.V))
            early = _early_region(ex, mesh.V, F0, topo)
            mesh = manifold_mesh(_as_mesh(mesh), orient=False, topo=topo)
            known = _kept(mesh).get
            topo = known("topology")
        V = np.asarray(mesh.V, np.float64)
        F = np.asarray(mesh.F, np.int64)
        # a vertex no face uses may be NaN or infinite (read_mesh keeps it, noted): the
        # whole-mesh work sees a finite stand-in, the output gets the vertex back as it was
        stand_in = np.zeros(len(V), bool) if np.isfinite(V).all() else ~np.isfinite(V).all(axis=1)
        if stand_in.any():
            V = V.copy()
            V[stand_in] = V[F[0, 0]]
        if topo is None:
            topo = edge_topology(F, len(V))
        if early is not None and not early.holds(V, F, topo):
            early.drop()        # the mesh changed on its way (made manifold): its region is built as usual
            early = None
        elif early is None:
            early = _early_region(ex, V, F, topo)       # (read_mesh's mesh: final already)
        _progress(progress, 1, 2, "finding holes")

        def context():
            c = ScanContext(Mesh(V=V, F=F, vertex_colors=mesh.vertex_colors, vertex_props=mesh.vertex_props),
                            topo=topo, base=base)
            if early is not None:
                c.take_region(early.region, early.V, early.F, early.topo, vf=early.vf)
            return c

        max_size, size_label, unit_note = in_scan_units(opts.max_hole_size, opts.unit, V)

        def detect():
            return detect_holes(V, F, max_hole=max_hole, fill_borders=fill_borders, closed=closed, topo=topo,
                                pieces=known("pieces"), areas=known("face_areas"), measure=False,
                                max_size=max_size, size_label=size_label)

        if ex is not None:
            later = ex.submit(context)
            scan = detect()
            ctx = later.result()
            index_built = ctx.index_in_background(ex)
        else:
            scan = detect()
            ctx = context()
    finally:
        if ex is not None:
            ex.shutdown(wait=False)
    _progress(progress, 2, 2, "finding holes")
    _fill_requested(opts, scan)
    splits = []
    if method == "fair":
        # two hole loops sharing vertices: a band pinched there, filled as its parts
        scan, splits = split_pinched(V, F, topo, scan, pieces=known("pieces"))
    holes = scan.holes
    _check_requested(opts, holes)
    asked_open = set(opts.leave_open)
    flat_caps = set(opts.cap_flat)
    all_holes, holes = holes, [h for h in holes if h.id not in asked_open]
    ctx.know_loops(scan.loops)
    results = {}
    bands = find_bands(ctx, scan) if bridge != "never" and method == "fair" else Bands([], [])
    # each pair's mutual flag, for a pair the fill tries again (tube_crossed_caps)
    flags = {frozenset((b.A.id, b.B.id)): b.mutual
             for b in bands.pairs + [x for t in bands.triples for x in t[3]]}
    # a loop left open or capped flat by request joins no band; its partner is filled alone
    alone = asked_open | flat_caps
    pairs = [b for b in bands.pairs if not {b.A.id, b.B.id} & alone]
    triples = [t for t in bands.triples if not {L.id for L in t[:3]} & alone]
    paired = {L.id for b in pairs for L in (b.A, b.B)}
    paired |= {L.id for t in triples for L in t[:3]}

    asked_order = {**order_for, **{i: 1 for i in flat_caps}}   # a flat cap: the harmonic patch

    def order_of(*loops):     # the order asked for one of these loops, else the scan's
        return next((asked_order[L.id] for L in loops if L.id in asked_order), order)

    def joining_order(o):            # a tube or a pants has new vertices: "flat" joins loops at order 1
        return 1 if o == "flat" else o

    units = [BandUnit(b.A, b.B, joining_order(order_of(b.A, b.B)), smooth, bridge, b.mutual) for b in pairs]
    units += [pants_unit(A, B, C, fb, joining_order(order_of(A, B, C)), smooth, bridge) for A, B, C, fb in triples]
    units += [HoleUnit(h.id, h.vertices, order_of(h), smooth) for h in holes if h.id not in paired]
    units.sort(key=lambda u: u.first_id)
    if index_built is not None:
        index_built.result()   # the fills read it (and a failure to build it surfaces here)
    if method == "seed":
        patches = _seed_patches(ctx, holes, smooth or SEED_SMOOTH_PASSES, results)
        unit_out = [([Outcome(patches.get(h.id), results.get(h.id, ""), 0.0, [])], None) for h in holes]
        units = [HoleUnit(h.id, h.vertices, order, smooth) for h in holes]
    else:
        # fixed runs of units, whatever ``jobs`` is, so the output is too
        chunks = [units[i:i + BATCH] for i in range(0, len(units), BATCH)]
        unit_out = []
        # a daemonic process (a worker of a multiprocessing pool) may not
        # start processes: its runs are filled here, with the helper thread
        # (multiprocessing imported only where a pool may start: one run needs none)
        if jobs > 1 and len(chunks) > 1 and not _daemonic():
            import multiprocessing as mp

            _ = ctx.index  # built before forking, so workers share it
            with worker_context(ctx), mp.get_context("fork").Pool(min(jobs, len(chunks))) as pool:
                for out in pool.imap(_worker, chunks, chunksize=1):
                    unit_out.extend(out)
                    _progress(progress, len(unit_out), len(units))
        else:
            done = [0]

            def tick():  # the bar moves hole by hole
                done[0] += 1
                _progress(progress, done[0], len(units))

            # a spare core runs the order="auto" holes' order tests and order-3 patches beside the fills
            with _beside(jobs > 1 and "auto" in {u.order for u in units}) as pool:
                for chunk in chunks:
                    unit_out.extend(run_chunk(ctx, chunk, tick, pool=pool))
    if legacy_bar:  # progress=True: the terminal bar this call drew ends its line
        from shellrepair.progress import end_line

        end_line(progress)

    # sequential merge: patches against each other, in hole order
    units, unit_out = expand(units, unit_out)     # a pants unit: its parts, one per loop
    # the loops a tube or a pants joins; a band filled by caps (its tube
    # failed or cost more) and a pants that fell back to a band and a cap
    # leave holes like any other, refilled below where a patch crossed another's
    paired = {L.id for u, (_, record) in zip(units, unit_out) if isinstance(u, (BandUnit, PantsUnit))
              and (record is None or record.get("chosen") != "caps")
              for L in ((u.A, u.B, u.C) if isinstance(u, PantsUnit) else (u.A, u.B))}
    acc = Accepted()
    rows = {}
    bridges = []
    for u, (outs, record) in zip(units, unit_out):
        loops = ([u.A, u.B] if isinstance(u, BandUnit) else [u.A, u.B, u.C] if isinstance(u, PantsUnit)
                 else [scan.loops[u.hole_id]])
        tube_rejected = None
        tube_ok, tube_patch = False, None
        for L, out in zip(loops, outs):
            patch = out.patch
            row = {"id": L.id, "edges": L.edges, "status": "failed", "reason": out.reason,
                   "failure": out.failure or NO_PATCH_PASSES, "new_vertices": 0, "new_faces": 0,
                   "seconds": round(out.seconds, 4), "option": None}
            if patch is not None:
                patch, conflict, swapped = acc.place(ctx, patch)
                _note_swap(rows, swapped)
                if patch is None:
                    row.update(reason=conflict, failure=CLASHES)
                    if acc.crossed is not None:
                        row["crosses_hole"] = acc.crossed
                    if record is not None and record.get("chosen") == "tube":
                        tube_rejected = conflict
                else:
                    tube_ok, tube_patch = True, patch
                    row.update(status="filled", reason=patch.option, new_vertices=int(len(patch.P)),
                               new_faces=int(len(patch.T)), option=patch.option, **_kind(patch))
                    if patch.choice is not None:
                        row["choice"] = patch.choice.as_dict()
            elif record is not None and record.get("chosen") == "tube":
                if tube_ok:
                    row.update(status="filled", option=record.get("shape", "tube"), new_vertices=0, new_faces=0,
                               **_kind(tube_patch))
                elif tube_rejected:
                    row.update(reason=tube_rejected, failure=CLASHES)
            if L.kind == "hole":
                rows[L.id] = row
        if record is not None:
            bridges.append(record)
    if method == "fair" and bridge != "never":
        tube_crossed_caps(ctx, scan, paired, rows, acc, joining_order(order), smooth, bridge, bridges, flags)
    _refill_crossed(ctx, mesh, V, F, holes, paired, rows, acc, order, smooth, method, asked_order)
    # the merged output checked once more, as a whole: a patch that crosses the scan, itself or another
    # patch (none should: each was checked when built and when accepted) is left open and says so
    accepted = [it[0] for it in acc.items]
    crossed = crossings_after_merge(ctx, accepted)
    for k, why in sorted(crossed.items()):
        for hid, row in rows.items():
            if row["status"] == "filled" and np.isin(scan.loops[hid].vertices, accepted[k].loop).all():
                row.update(status="failed", new_vertices=0, new_faces=0, option=None, failure=MERGED_CHECK,
                           reason=f"left open: the check of the merged output found its patch crossing {why}")
    accepted = [p for k, p in enumerate(accepted) if k not in crossed]
    asked_fill = set(opts.fill)
    for h in all_holes:
        if h.id in asked_open:
            rows[h.id] = {"id": h.id, "edges": h.edges, "status": "skipped",
                          "reason": "left open by request", "new_vertices": 0, "new_faces": 0,
                          "seconds": 0.0, "option": None, "requested": "left open"}
            continue
        if h.id not in rows:
            continue
        asked = [f"order {order_for[h.id]}"] if h.id in order_for else []
        if h.id in flat_caps:
            asked.append("flat cap")
            if rows[h.id]["status"] == "filled":
                rows[h.id]["option"] = rows[h.id]["reason"] = \
                    f"flat cap by request: {rows[h.id]['option']} (harmonic; flat where the rim is planar)"
        if h.id in asked_fill:
            asked.append("fill")
        if asked:
            rows[h.id]["requested"] = ", ".join(asked)
    rows = [rows[h.id] for h in all_holes if h.id in rows]
    for row in rows:       # why a hole stays open, as data: on failed rows only
        if row["status"] != "failed":
            row.pop("failure", None)
    repaired = _merge(mesh, V, F, accepted)
    if stand_in.any():
        repaired.V[:len(V)][stand_in] = np.asarray(mesh.V, np.float64)[stand_in]
    # check the result: boundary and non-manifold edges left, counted on the
    # edges the appended faces touch (the rest of the mesh did not change)
    delta = edge_count_delta(topo, repaired.F[len(F):], len(repaired.V), n_before=len(V))
    n_new_v, n_new_f = len(repaired.V) - len(V), len(repaired.F) - len(F)
    joins = getattr(mesh, "joins", None)
    joined = 0 if joins is None else len(joins)
    report = table1_dict(len(all_holes), rows, path=mesh.path, seconds=time.perf_counter() - t0,
                         method=method, order=order, borders=len(scan.borders), open_chains=scan.open_chains,
                         extra={**{k: int(v) for k, v in mesh.fixes.items()},
                                "border_edges_after": int(sum(b.edges for b in scan.borders)),
                                # as the files have them: the reader's copies at points where
                                # pieces meet are joined again when written (Mesh.joins)
                                "vertices_before": int(len(V)) - joined, "faces_before": int(len(F)),
                                "vertices_after": int(len(repaired.V)) - joined, "faces_after": int(len(repaired.F)),
                                "open_chain_list": describe_open_chains(F, scan.open_chains, len(V), topo),
                                "boundary_edges_before": int(topo.n_boundary_edges),
                                "boundary_edges_after": int(topo.n_boundary_edges + delta["boundary_edges"]),
                                "nonmanifold_edges_before": int(mesh.fixes.get("nonmanifold_edges_found",
                                                                               topo.nonmanifold_edges.shape[0])),
                                "nonmanifold_edges_after": int(topo.nonmanifold_edges.shape[0]
                                                               + delta["nonmanifold_edges"]),
                                "smooth": smooth, "jobs": jobs, "bridge": bridge, "base": base,
                                **({"max_hole_size": size_label, "unit": unit_note} if max_size is not None else {}),
                                "closed": {None: "auto", True: "yes", False: "no"}[closed],
                                "bridges": bridges,
                                "pinched_bands": [{"loops": [int(a), int(b)], "parts": [int(i) for i in ids]}
                                                  for a, b, ids in splits],
                                "euler_before": int(scan.euler),
                                "euler_after": int(scan.euler + n_new_v - delta["edges"] + n_new_f),
                                "border_loops": [{"id": b.id, "edges": b.edges, "reason": b.reason}
                                                 for b in scan.borders]})
    return repaired, report


def _daemonic():
    """Whether this process is a daemonic one (a worker of a multiprocessing pool)."""
    import multiprocessing as mp

    return mp.current_process().daemon


def _beside(use):
    """A helper thread for work beside the fills (:class:`~shellrepair.fill.beside.HelperThread`,
    a context manager), or a ``None`` stand-in when ``use`` is false."""
    import contextlib

    return HelperThread() if use else contextlib.nullcontext()


def _kind(patch):
    """A filled row's typed account of its patch: ``kind`` (one of
    :data:`shellrepair.fill.patch.KINDS`) and the fairing ``order`` (None
    where it was not faired)."""
    return {"kind": patch.kind, "order": None if patch.order is None else int(patch.order)}


def _note_swap(rows, swapped):
    """An earlier hole's row, when the merge put its order-2 fill in place of its order-3 one."""
    if swapped is not None and swapped.hole_id in rows:
        rows[swapped.hole_id].update(reason=swapped.option, option=swapped.option,
                                     new_vertices=int(len(swapped.P)), new_faces=int(len(swapped.T)),
                                     **_kind(swapped))


def tube_crossed_caps(ctx, scan, paired, rows, acc, order, smooth, mode, bridges, flags=None):
    """Two single holes whose caps cross each other cannot both be capped:
    the region missing between them is a band their continuation arcs did
    not pair (on a fat torus's inner side half of each loop's arcs land on
    the other loop and half on itself, no majority). Each such pair, in
    hole order, is filled as a band (:func:`shellrepair.fill.band_fill._fill_pair`:
    its caps, which cross, then the tube); a tube that passes its checks
    and crosses no other accepted patch takes the place of the earlier
    hole's cap. ``rows``, ``bridges`` and ``paired`` (the two loops) are
    updated in place; a pair left as it was goes on to
    :func:`_refill_crossed`.

    Parameters
    ----------
    ctx : ScanContext
    scan : HoleScan
    paired : set of int
        The loops filled as part of a band or pants (gets the pairs joined here).
    rows : dict
        Report row per hole id (their ``reason`` says which patch a failed
        cap crossed).
    acc : Accepted
        The patches accepted so far (:class:`shellrepair.fill.merge.Accepted`).
    order, smooth, mode
        As for :func:`shellrepair.fill.band_fill._fill_pair`.
    bridges : list of dict
        The report's band records (gets one per pair tried).
    flags : dict, optional
        ``mutual`` per pair of loop ids, from the band search.

    Returns
    -------
    None
    """
    for hid in sorted(rows):
        row = rows[hid]
        other = row.get("crosses_hole")
        if row["status"] != "failed" or other is None or hid in paired:
            continue
        if other in paired or other not in rows or rows[other]["status"] != "filled":
            continue
        A, B = scan.loops[other], scan.loops[hid]
        j = next((k for k, it in enumerate(acc.items) if it[0].hole_id == other), None)
        if j is None or A.kind != "hole" or np.intersect1d(A.vertices, B.vertices).size:
            continue
        outs, record = _fill_pair(ctx, A, B, order, smooth, mode,
                                  (flags or {}).get(frozenset((A.id, B.id)), False))
        row["seconds"] = round(row["seconds"] + outs[0].seconds, 4)
        tube = outs[0].patch if record.get("chosen") == "tube" else None
        why, corners = acc.conflict(ctx, tube, skip=j) if tube is not None else ("", None)
        if why is not None:
            continue
        acc.exchange(j, tube, *corners)
        record["reason"] = f"the two holes' caps cross each other; {record['reason']}"
        bridges.append(record)
        paired.update((other, hid))
        rows[other].update(status="filled", reason=tube.option, option=tube.option,
                           new_vertices=int(len(tube.P)), new_faces=int(len(tube.T)), **_kind(tube))
        row.update(status="filled", reason=outs[1].reason, option=record.get("shape", "tube"), new_vertices=0,
                   new_faces=0, **_kind(tube))
        row.pop("crosses_hole", None)


def _fill_requested(opts, scan):
    """The loops ``opts.fill`` names become holes (changed in place, their
    reason saying what they were classed). One error, before any work, for
    an id the scan has no loop for, or for a loop a plan acted on
    (``opts.expect``) that this scan's loop of that id does not match in
    edges or centre."""
    ids = {L.id for L in scan.loops}
    for i, (edges, center) in sorted(opts.expect.items()):
        L = scan.loops[i] if i in ids else None
        far = L is not None and center is not None and not (
            len(center) == 3 and np.allclose(L.center, center, rtol=1e-8, atol=1e-6 * max(L.diameter, 1e-300)))
        if L is None or (edges is not None and edges != L.edges) or far:
            seen = "has no such loop" if L is None else f"has loop {i} with {L.edges} edges around {L.center}"
            raise MeshError(f"the plan acts on loop {i} ({edges} edges around {center}), but this scan {seen}: "
                            "the plan was made for another scan or other detection options")
    unknown = sorted(set(opts.fill) - ids)
    if unknown:
        raise MeshError(f"no loop with id {', '.join(map(str, unknown))} in this scan (its loops: "
                        f"{', '.join(map(str, sorted(ids))) or 'none'}; `shellrepair holes` lists them)")
    for L in scan.loops:
        if L.id in opts.fill and L.kind != "hole":
            L.reclass("hole", f"filled by request (classed {L.kind}: {L.reason})")


def _check_requested(opts, holes):
    """Every hole id a request names (``leave_open``, ``order_for``,
    ``cap_flat``) is one of the scan's holes; else one error naming them,
    before any work."""
    ids = {h.id for h in holes}
    unknown = sorted((set(opts.leave_open) | set(opts.order_for) | set(opts.cap_flat)) - ids)
    if unknown:
        raise MeshError(f"no hole with id {', '.join(map(str, unknown))} in this scan (its holes: "
                        f"{', '.join(map(str, sorted(ids))) or 'none'}; `shellrepair holes` lists them)")


def _refill_crossed(ctx, mesh, V, F, holes, paired, rows, acc, order, smooth, method, order_for=None):
    """Fill again each single hole refused because its patch crosses an
    earlier hole's: on the scan with every accepted patch appended, so the
    new fill's checks keep it off them (one round, in hole order, each at
    its requested order where ``order_for`` has one; the row is updated in
    place). Where that fails too and the crossed patch is an order-3 patch
    of ``order="auto"`` with an order-2 fill of its hole (``Patch.fallback``),
    the hole is filled once more around the patches with that order-2 fill
    in its place, which is kept only if this fill is (:func:`_refill_beside_fallback`)."""
    order_for = order_for or {}
    again = [h for h in holes if method == "fair" and h.id not in paired and h.id in rows
             and rows[h.id]["status"] == "failed"
             and rows[h.id].get("crosses_hole") is not None]
    if not again:
        return
    ctx2 = _grown_context(mesh, V, F, acc)
    for h in again:
        row = rows[h.id]
        out = fill_hole(ctx2, h.id, np.asarray(h.vertices, np.int64), order_for.get(h.id, order), smooth)
        patch, reason, failure = out.patch, out.reason, out.failure or NO_PATCH_PASSES
        row["seconds"] = round(row["seconds"] + out.seconds, 4)
        if patch is not None:
            patch, reason, swapped = acc.place(ctx, patch)
            _note_swap(rows, swapped)
            failure = CLASHES
        if patch is None:
            patch, why = _refill_beside_fallback(ctx, mesh, V, F, h, row, rows, acc, order_for.get(h.id, order),
                                                 smooth)
            if patch is not None:
                option = (f"{patch.option} (filled again around the patches accepted before it, hole "
                          f"{row['crosses_hole']}'s order-2 fill in place of its order-3 patch: the first crossed both)")
                row.update(status="filled", reason=option, option=option, new_vertices=int(len(patch.P)),
                           new_faces=int(len(patch.T)), **_kind(patch))
                row.pop("crosses_hole", None)
                if patch.choice is not None:
                    row["choice"] = patch.choice.as_dict()
                continue
            row.update(reason=f"{row['reason']}; filled again around the accepted patches: {reason}{why}",
                       failure=failure)
            continue
        option = f"{patch.option} (filled again around the patches accepted before it: the first crossed one)"
        row.update(status="filled", reason=option, option=option, new_vertices=int(len(patch.P)),
                   new_faces=int(len(patch.T)), **_kind(patch))
        row.pop("crosses_hole", None)
        if patch.choice is not None:
            row["choice"] = patch.choice.as_dict()


def _grown_context(mesh, V, F, acc):
    """A context of the scan with every patch ``acc`` holds appended (the
    scan a refill's checks keep its patch off)."""
    grown = _merge(mesh, V, F, [it[0] for it in acc.items])
    return ScanContext(Mesh(V=grown.V, F=grown.F, vertex_colors=grown.vertex_colors, vertex_props=grown.vertex_props))


def _refill_beside_fallback(ctx, mesh, V, F, h, row, rows, acc, order, smooth):
    """The last try of :func:`_refill_crossed` for hole ``h``: the accepted
    patch its fill crosses (``row["crosses_hole"]``), where that is an
    order-3 patch chosen by ``order="auto"``, gives way to its hole's
    order-2 fill (``Patch.fallback``, checked when it was built) if that
    fits with the other accepted patches; ``h`` is filled on the scan with
    the accepted patches so changed appended, and the exchange is kept
    only if that fill is accepted. Closing both holes comes before the
    higher order of one: on a fat torus seen by five views near its
    equator (case 10 of seed 318614305) a 552-edge hole stayed open
    beside a neighbour's order-3 cap, where the neighbour's order-2 cap
    leaves it room.

    Returns
    -------
    patch : Patch or None
        ``h``'s accepted patch (``acc`` and the crossed hole's row then
        hold the order-2 fill), or None (``acc`` unchanged).
    why : str
        Why it was not tried or failed ('' when it was not tried), to
        append to the row's reason.
    """
    j = next((k for k, it in enumerate(acc.items) if it[0].hole_id == row.get("crosses_hole")), None)
    alt = None if j is None else acc.items[j][0].fallback
    if alt is None:
        return None, ""
    why, corners = acc.conflict(ctx, alt, skip=j)
    if why is not None:
        return None, f"; hole {row['crosses_hole']}'s order-2 fill in its place: {why}"
    old = acc.items[j]
    acc.replace(j, alt, *corners)
    ctx3 = _grown_context(mesh, V, F, acc)
    out = fill_hole(ctx3, h.id, np.asarray(h.vertices, np.int64), order, smooth)
    row["seconds"] = round(row["seconds"] + out.seconds, 4)
    patch, why = out.patch, out.reason
    if patch is not None:
        why, corners = acc.conflict(ctx, patch)
        if why is None:
            acc.add(patch, *corners)
            _note_swap(rows, alt)
            return patch, ""
    acc.restore(j, old)
    return None, f"; around hole {row['crosses_hole']}'s order-2 fill in place of its order-3 patch: {why}"


def _kept(mesh):
    """{name: value} of the whole-mesh data :func:`read_mesh` kept for the
    mesh's current arrays (:meth:`Mesh.cached`, one check for all)."""
    if not hasattr(mesh, "cached"):
        return {}
    names = ("topology", "pieces", "face_areas")
    return {n: v for n, v in zip(names, mesh.cached(*names)) if v is not None}


def _progress(report, i, n, label="filling holes"):
    """Report ``i`` of ``n`` to the progress callback ``report`` (None: nothing)."""
    if report is not None:
        report(label, i, n)


class _Early(NamedTuple):
    """The region around the boundary loops of a mesh and, where there is
    none, its whole-mesh vertex-face lists, on their way from an executor
    (:func:`shellrepair.mesh.index.early_lists`) for the context that will hold
    these very arrays (:meth:`shellrepair.mesh.index.ScanContext.take_region`)."""

    V: np.ndarray
    F: np.ndarray
    topo: Any
    region: Any     # concurrent.futures.Future
    vf: Any         # concurrent.futures.Future
    drop: Any       # callable: neither is wanted any more

    def holds(self, V, F, topo):
        """Whether these are the arrays and topology it was started on (the very objects)."""
        return self.V is V and self.F is F and self.topo is topo


def _early_region(ex, V, F, topo):
    """An :class:`_Early` started on the executor ``ex``; None without an
    executor, or when ``V`` is not float64 (the context's would be a copy)."""
    if ex is None or topo is None or not isinstance(V, np.ndarray) or V.dtype != np.float64:
        return None
    from shellrepair.mesh import index as context

    return _Early(V, F, topo, *context.early_lists(ex, V, F, topo))


def _as_mesh(mesh):
    """A :class:`Mesh` with the fields of ``mesh`` (any object with ``V`` and ``F``)."""
    if isinstance(mesh, Mesh):
        return mesh
    return Mesh(V=np.asarray(mesh.V, np.float64), F=np.asarray(mesh.F, np.int64),
                vertex_colors=getattr(mesh, "vertex_colors", None), vertex_props=dict(getattr(mesh, "vertex_props", {})),
                vertex_dtype=getattr(mesh, "vertex_dtype", "f8"), path=getattr(mesh, "path", None),
                vertex_filled=getattr(mesh, "vertex_filled", None), face_filled=getattr(mesh, "face_filled", None),
                notes=list(getattr(mesh, "notes", [])), comments=list(getattr(mesh, "comments", [])),
                texture=getattr(mesh, "texture", None))
