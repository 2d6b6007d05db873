"""One fill function per tool, all with the same signature.

``fill(V, F) -> (V_out, F_out, info)``

* ``V (n,3) float64``, ``F (m,3) int64``: the perforated mesh.
* ``V_out, F_out``: what the tool returned, as arrays.
* ``info``: a dict with ``seconds`` (the tool's fill call(s) only; building
  the tool's mesh structure from arrays and back is ``convert_seconds``)
  and anything the tool reported.

A tool that is not installed raises :class:`ToolMissing` when called; any
other exception is that tool failing on that case. The benchmark runs each
call in a child process (:mod:`eval.worker`), so a crash or a hang is
recorded too.

Every tool is asked to fill *every* hole (the ground truths are closed, so
every boundary loop is a hole):

===================  ========================================================
tool                 call
===================  ========================================================
ours-o1/o2/o3        ``shellrepair.repair.repair_mesh(mesh, order=k)``, its compiled
                     kernels loaded before the call is timed (as a peer's
                     import loads its native library)
ours-auto            ``repair_mesh(mesh, order="auto")`` (1, 2 or 3 per hole by test holes of its size, shellrepair.fill.selftest)
ours-cli             the command line's default (``shellrepair repair``, ``make repair``): ``order="auto"``
                     and ``jobs`` the cores there are (a helper thread runs the band tests and the
                     order-3 patches beside the fill; the same output as ``ours-auto``). In the
                     benchmarks' daemonic workers a scan of more than 24 holes is filled in one
                     process with the helper, where the command line would use processes
ours-seed            ``repair_mesh(mesh, method="seed")`` (the paper's method)
pymeshlab            ``MeshSet.meshing_close_holes(maxholesize=<all boundary
                     edges + 1>)``, other parameters at their defaults
open3d               ``t.geometry.TriangleMesh.fill_holes(hole_size=10*diag)``
meshlib-fillHole     ``mrmeshpy.fillHole(mesh, e)`` for every hole
                     (``findHoleRepresentiveEdges``), default parameters
meshlib-nicely       ``mrmeshpy.fillHoleNicely(mesh, e, settings)`` with
                     subdivision to the mesh's mean edge length and curvature
                     smoothing (``smoothCurvature=True``, the default)
cgal                 ``Polygon_mesh_processing.triangulate_refine_and_fair_hole``
                     on a ``Polyhedron_3``, one border halfedge per hole,
                     default density and fairing continuity
pymeshfix            ``MeshFix(V, F).fill_holes(0, refine=True)`` (fill all
                     boundaries; not the full ``repair()``, which would also
                     remove and move original faces)
poisson              pymeshlab's screened Poisson surface of the scan, kept
                     where it covers the holes (:func:`poisson_trimmed`)
===================  ========================================================
"""

from __future__ import annotations

import os
import time

import numpy as np

__all__ = ["ToolMissing", "TOOLS", "PEERS", "OURS", "REFERENCE", "tool_available", "run_tool"]


class ToolMissing(RuntimeError):
    """The tool's Python package is not installed."""


def _import(name):
    import importlib

    try:
        return importlib.import_module(name)
    except ImportError as exc:  # includes a broken shared library
        raise ToolMissing(f"{name} is not installed ({exc})") from None


def _mean_edge(V, F):
    return float(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean())


# --------------------------------------------------------------------------
# ours
# --------------------------------------------------------------------------
def _ours(V, F, **kw):
    try:
        from shellrepair.repair import repair_mesh
    except ImportError as exc:
        raise ToolMissing(f"shellrepair.repair is not available ({exc})") from None
    from shellrepair.mesh.io import Mesh

    _load_kernels()
    mesh = Mesh(V=np.array(V, np.float64), F=np.array(F, np.int64))
    t0 = time.perf_counter()
    repaired, report = repair_mesh(mesh, **kw)
    dt = time.perf_counter() - t0
    ff = getattr(repaired, "face_filled", None)
    info = {"seconds": dt, "convert_seconds": 0.0,
            "reported_holes_before": report.get("holes_before"),
            "reported_holes_after": report.get("holes_after"),
            "reported_rate": report.get("interpolation_rate"),
            "face_filled": None if ff is None else int(np.count_nonzero(ff)),
            "statuses": _count_statuses(report.get("holes", [])),
            # holes where order="auto" found no intact scan of the hole's size to test on
            "untold": sum("the scan cannot tell" in (h.get("option") or "") for h in report.get("holes", [])),
            "reported_holes": len(report.get("holes", []))}
    return np.asarray(repaired.V, np.float64), np.asarray(repaired.F, np.int64), info


def _load_kernels():
    """Load our compiled kernels (Numba, from the on-disk cache that ``make
    setup`` fills) before the timed call, as importing a peer loads its
    native library before its call is timed. Once loaded, the whole-mesh
    steps use them on meshes of any size (:func:`shellrepair.mesh.fastmesh.enabled`).
    A user's first run pays the loading once per process; bench_scale's
    first and second ``make repair`` show that cost."""
    from shellrepair import warmup
    from shellrepair.fill import cholesky
    from shellrepair.mesh import fastmesh

    warmup.warm_up()
    cholesky.warm_up()
    fastmesh.warm_up()


def _count_statuses(holes):
    out = {}
    for h in holes:
        key = h.get("status", "?")
        if key != "filled":
            key = f"{key}: {h.get('reason', '')}"[:80]
        out[key] = out.get(key, 0) + 1
    return out


def ours_o1(V, F):
    return _ours(V, F, order=1)


def ours_o2(V, F):
    return _ours(V, F, order=2)


def ours_o3(V, F):
    return _ours(V, F, order=3)


def ours_flat(V, F):
    return _ours(V, F, order="flat")


def ours_auto(V, F):
    return _ours(V, F, order="auto")


def ours_cli(V, F):
    from shellrepair.batch import default_jobs

    return _ours(V, F, order="auto", jobs=default_jobs())


def ours_seed(V, F):
    return _ours(V, F, method="seed")


# --------------------------------------------------------------------------
# peers
# --------------------------------------------------------------------------
def pymeshlab_close_holes(V, F):
    ml = _import("pymeshlab")
    from shellrepair.mesh.topology import edge_topology

    t0 = time.perf_counter()
    ms = ml.MeshSet()
    ms.add_mesh(ml.Mesh(vertex_matrix=np.asarray(V, np.float64), face_matrix=np.asarray(F, np.int32)))
    conv = time.perf_counter() - t0
    maxhole = int(edge_topology(F, len(V)).n_boundary_edges) + 1
    t0 = time.perf_counter()
    ms.meshing_close_holes(maxholesize=maxhole)
    dt = time.perf_counter() - t0
    m = ms.current_mesh()
    return (np.asarray(m.vertex_matrix(), np.float64), np.asarray(m.face_matrix(), np.int64),
            {"seconds": dt, "convert_seconds": conv, "maxholesize": maxhole})


def open3d_fill_holes(V, F):
    o3d = _import("open3d")
    t0 = time.perf_counter()
    mesh = o3d.t.geometry.TriangleMesh()
    mesh.vertex.positions = o3d.core.Tensor(np.ascontiguousarray(V, np.float64))
    mesh.triangle.indices = o3d.core.Tensor(np.ascontiguousarray(F, np.int64))
    conv = time.perf_counter() - t0
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    t0 = time.perf_counter()
    out = mesh.fill_holes(hole_size=10.0 * diag)
    dt = time.perf_counter() - t0
    return (out.vertex.positions.numpy().astype(np.float64), out.triangle.indices.numpy().astype(np.int64),
            {"seconds": dt, "convert_seconds": conv, "hole_size": 10.0 * diag})


def _meshlib_mesh(V, F):
    mm = _import("meshlib.mrmeshpy")
    mn = _import("meshlib.mrmeshnumpy")
    mesh = mn.meshFromFacesVerts(np.ascontiguousarray(F, np.int32), np.ascontiguousarray(V, np.float64))
    return mm, mn, mesh


def _meshlib_out(mn, mesh):
    Vo = np.asarray(mn.getNumpyVerts(mesh), np.float64)
    Fo = np.asarray(mn.getNumpyFaces(mesh.topology), np.int64)
    return Vo, Fo


def meshlib_fill_hole(V, F):
    t0 = time.perf_counter()
    mm, mn, mesh = _meshlib_mesh(V, F)
    conv = time.perf_counter() - t0
    t0 = time.perf_counter()
    edges = list(mesh.topology.findHoleRepresentiveEdges())
    params = mm.FillHoleParams()
    for e in edges:
        mm.fillHole(mesh, e, params)
    dt = time.perf_counter() - t0
    t0 = time.perf_counter()
    Vo, Fo = _meshlib_out(mn, mesh)
    return Vo, Fo, {"seconds": dt, "convert_seconds": conv + time.perf_counter() - t0, "holes": len(edges)}


def meshlib_fill_hole_nicely(V, F):
    t0 = time.perf_counter()
    mm, mn, mesh = _meshlib_mesh(V, F)
    conv = time.perf_counter() - t0
    edge = _mean_edge(V, F)
    t0 = time.perf_counter()
    edges = list(mesh.topology.findHoleRepresentiveEdges())
    settings = mm.FillHoleNicelySettings()
    settings.triangulateOnly = False
    settings.smoothCurvature = True
    settings.subdivideSettings.maxEdgeLen = edge
    settings.subdivideSettings.maxEdgeSplits = 1_000_000
    for e in edges:
        mm.fillHoleNicely(mesh, e, settings)
    dt = time.perf_counter() - t0
    t0 = time.perf_counter()
    Vo, Fo = _meshlib_out(mn, mesh)
    return Vo, Fo, {"seconds": dt, "convert_seconds": conv + time.perf_counter() - t0, "holes": len(edges),
                    "maxEdgeLen": edge}


def _off_text(V, F):
    """OFF text of a mesh (exact: Python's shortest round-trip floats)."""
    vs = "\n".join(f"{x!r} {y!r} {z!r}" for x, y, z in np.asarray(V, np.float64).tolist())
    fs = "\n".join(f"3 {a} {b} {c}" for a, b, c in np.asarray(F, np.int64).tolist())
    return f"OFF\n{len(V)} {len(F)} 0\n{vs}\n{fs}\n"


def _read_off_numbers(path):
    """A triangle OFF file as written by CGAL: (V, F)."""
    with open(path) as fh:
        head = fh.readline().split()
        if head == ["OFF"] or not head:
            head = fh.readline().split()
        else:
            head = head[1:]
        nv, nf = int(head[0]), int(head[1])
        nums = np.array(fh.read().split(), np.float64)
    Vo = nums[:3 * nv].reshape(nv, 3)
    Fo = nums[3 * nv:3 * nv + 4 * nf].reshape(nf, 4)
    if nf and not np.all(Fo[:, 0] == 3):
        raise ValueError("CGAL wrote non-triangle faces")
    return Vo, Fo[:, 1:].astype(np.int64)


def cgal_refine_fair(V, F):
    _import("CGAL")
    import tempfile

    PMP = _import("CGAL.CGAL_Polygon_mesh_processing")
    Polyhedron_3 = _import("CGAL.CGAL_Polyhedron_3").Polyhedron_3
    # in and out through OFF files, read and written by CGAL's C++ code: the
    # fastest path its Python bindings offer (building Point_3 objects one
    # by one from Python took 9-10 s for a 1M-face mesh against about 5 s)
    with tempfile.TemporaryDirectory(prefix="cgal_") as tmp:
        src, dst = os.path.join(tmp, "in.off"), os.path.join(tmp, "out.off")
        t0 = time.perf_counter()
        with open(src, "w") as fh:
            fh.write(_off_text(V, F))
        P = Polyhedron_3(src)
        if P.size_of_facets() != len(F):
            raise RuntimeError(f"CGAL read {P.size_of_facets()} of {len(F)} faces")
        for i, v in enumerate(P.vertices()):
            v.set_id(i)
        # one border halfedge per hole, found by walking each loop once
        P.normalize_border()  # border halfedges last: border_halfedges() visits only them
        starts, seen = [], set()
        for h in P.border_halfedges():
            if not h.is_border():
                h = h.opposite()
            if not h.is_border():
                continue
            key = (h.opposite().vertex().id(), h.vertex().id())
            if key in seen:
                continue
            starts.append(h)
            g = h
            for _ in range(len(V) + 1):
                seen.add((g.opposite().vertex().id(), g.vertex().id()))
                g = g.next()
                if (g.opposite().vertex().id(), g.vertex().id()) == key:
                    break
        conv = time.perf_counter() - t0
        t0 = time.perf_counter()
        n_faces = 0
        created = []
        for h in starts:
            fo, vo = [], []
            PMP.triangulate_refine_and_fair_hole(P, h, fo, vo)
            n_faces += len(fo)
            created.extend(vo)
        dt = time.perf_counter() - t0
        t0 = time.perf_counter()
        # CGAL writes 6 significant digits: take the faces from its file, the
        # positions exactly: the input's (CGAL leaves them) and the new
        # vertices' from their handles, which come in the file's order
        P.write_to_file(dst)
        Voff, Fo = _read_off_numbers(dst)
        new = np.array([(q.x(), q.y(), q.z()) for q in (v.point() for v in created)], np.float64).reshape(-1, 3)
        Vo = np.vstack([np.asarray(V, np.float64), new])
        tol = 1e-4 * max(float(np.abs(Vo).max(initial=0.0)), 1e-300)  # 6 digits: relative 5e-5
        if Voff.shape != Vo.shape or np.abs(Voff - Vo).max(initial=0.0) > tol:
            Vo = np.array([(q.x(), q.y(), q.z()) for q in (v.point() for v in P.vertices())], np.float64)
        conv += time.perf_counter() - t0
    return Vo, Fo, {"seconds": dt, "convert_seconds": conv, "holes": len(starts), "patch_faces": n_faces}


def pymeshfix_fill_holes(V, F):
    pmf = _import("pymeshfix")
    t0 = time.perf_counter()
    mf = pmf.MeshFix(np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int32))
    conv = time.perf_counter() - t0
    t0 = time.perf_counter()
    n = mf.fill_holes(0, True)
    dt = time.perf_counter() - t0
    return (np.asarray(mf.points, np.float64), np.asarray(mf.faces, np.int64),
            {"seconds": dt, "convert_seconds": conv, "holes_filled": int(n) if n is not None else None})


#: Octree depth of the screened Poisson reconstruction (``poisson``): a
#: grid of 2**10 cells along the largest side, about the edge length of
#: eval's 20k-100k-face scans.
POISSON_DEPTH = 10


def poisson_trimmed(V, F):
    """Screened Poisson reconstruction kept where it covers the holes.

    The route many scan teams take: pymeshlab's screened Poisson surface
    of the scan (vertex normals from its faces, ``depth=POISSON_DEPTH``,
    other parameters at their defaults). Its surface does not meet the
    scan's rims, so it is sampled on a fill that does: our order-2 fill
    (``repair_mesh(order=2)``: a cap per hole, a tube per missing band),
    whose new vertices are moved to the nearest point of the Poisson surface
    (open3d's closest-point query). The scan and its rims are not moved;
    what covers a hole is the Poisson surface at the fill's vertices (the
    order-2 fill starts them near the right sheet of it: MeshLib's flat
    triangulation put them on the wrong one across large holes and bands).
    ``seconds`` is the reconstruction, the fill and the projection.
    """
    ml = _import("pymeshlab")
    o3d = _import("open3d")
    from eval.metrics import closest_point_on_triangles
    from shellrepair.mesh.core import Mesh
    from shellrepair.repair import repair_mesh

    t0 = time.perf_counter()
    ms = ml.MeshSet()
    ms.add_mesh(ml.Mesh(vertex_matrix=np.asarray(V, np.float64), face_matrix=np.asarray(F, np.int32)))
    conv = time.perf_counter() - t0
    t0 = time.perf_counter()
    ms.compute_normal_per_vertex()
    ms.generate_surface_reconstruction_screened_poisson(depth=POISSON_DEPTH)
    pm = ms.current_mesh()
    Vp, Fp = np.asarray(pm.vertex_matrix(), np.float64), np.asarray(pm.face_matrix(), np.int64)
    out, rep = repair_mesh(Mesh(V=np.asarray(V, np.float64), F=np.asarray(F, np.int64)), order=2)
    Vo, Fo = np.array(out.V, np.float64), np.asarray(out.F, np.int64)
    new = np.arange(len(V), len(Vo))
    if new.size and len(Fp):
        c = Vp.mean(axis=0)
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor((Vp - c).astype(np.float32)), o3d.core.Tensor(Fp.astype(np.uint32)))
        tri = scene.compute_closest_points(o3d.core.Tensor((Vo[new] - c).astype(np.float32)))["primitive_ids"]
        T = Vp[Fp[tri.numpy().astype(np.int64)]]
        Vo[new] = closest_point_on_triangles(Vo[new], T[:, 0], T[:, 1], T[:, 2])
    dt = time.perf_counter() - t0
    return Vo, Fo, {"seconds": dt, "convert_seconds": conv, "poisson_faces": int(len(Fp)), "depth": POISSON_DEPTH}


#: Tool name -> fill function, in the order of the tables.
OURS = {"ours-o1": ours_o1, "ours-o2": ours_o2, "ours-o3": ours_o3, "ours-flat": ours_flat, "ours-auto": ours_auto,
        "ours-cli": ours_cli, "ours-seed": ours_seed}
PEERS = {
    "pymeshlab": pymeshlab_close_holes,
    "open3d": open3d_fill_holes,
    "meshlib-fillHole": meshlib_fill_hole,
    "meshlib-nicely": meshlib_fill_hole_nicely,
    "cgal": cgal_refine_fair,
    "pymeshfix": pymeshfix_fill_holes,
    "poisson": poisson_trimmed,
}
TOOLS = {**OURS, **PEERS}
#: Ours at its default order: the reference of the ratio columns.
REFERENCE = "ours-auto"  # the default call (order chosen per hole)

_PACKAGES = {"pymeshlab": "pymeshlab", "open3d": "open3d", "meshlib-fillHole": "meshlib.mrmeshpy",
             "meshlib-nicely": "meshlib.mrmeshpy", "cgal": "CGAL.CGAL_Polygon_mesh_processing",
             "pymeshfix": "pymeshfix", "poisson": "pymeshlab"}


def tool_available(name):
    """(available, reason) without running the tool."""
    import importlib.util

    if name in OURS:
        ok = importlib.util.find_spec("shellrepair.repair") is not None
        return ok, "" if ok else "shellrepair.repair not found"
    pkg = _PACKAGES[name]
    try:
        ok = importlib.util.find_spec(pkg) is not None
    except ModuleNotFoundError:
        ok = False
    return ok, "" if ok else f"{pkg.split('.')[0]} is not installed"


def run_tool(name, V, F):
    """Run one tool's fill on arrays (in this process)."""
    if name not in TOOLS:
        raise ValueError(f"unknown tool '{name}' (known: {', '.join(TOOLS)})")
    return TOOLS[name](np.asarray(V, np.float64), np.asarray(F, np.int64))
