"""Our own small structures against the libraries that do the same job.

Run ``.venv/bin/python eval/bench_libs.py [polygon|distance|grid|readers ...]``
(all four when none is named). Each section prints its numbers (the
fastest of ``--repeat`` runs, in one warm process) and whether the answers
are the same; the docstrings of the functions measured quote them.

* ``polygon``: :func:`shellrepair.mesh.geometry.points_in_polygon` (NumPy) against
  scikit-image's ``points_in_poly`` (Cython), which the fill used before:
  random outlines, and the outlines and samples hole detection tests
  (:func:`shellrepair.holes.loops._inside_fractions`) on single-view scans.
* ``distance``: :func:`shellrepair.mesh.distance.point_mesh_distance` (SciPy's
  cKDTree of centroids, then the exact distance to the 8 nearest
  triangles) against libigl's ``point_mesh_squared_distance`` (an AABB
  tree, exact), on the order test's own queries.
* ``grid``: :class:`shellrepair.mesh.intersect.NearFaces` (vertices in xy
  columns) against a SciPy cKDTree of the vertices, for the crossing
  checks' box queries on a 1.3M-face mesh.
* ``readers``: our OBJ / OFF / STL readers (:mod:`shellrepair.mesh.formats`)
  against meshio and Open3D on a ~1M-face file of each format, and what
  each keeps.

Asserts nothing; needs the bench/test extras (scikit-image, meshio).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def best_of(fn, repeat):
    """The fastest of ``repeat`` runs of ``fn()`` in seconds, and its last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


# --------------------------------------------------------------------------
# polygon
# --------------------------------------------------------------------------
def star(k, rng):
    """A random star-shaped outline of ``k`` corners around the origin."""
    a = np.sort(rng.uniform(0, 2 * np.pi, k))
    r = rng.uniform(0.5, 1.0, k)
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def polygon(repeat):
    from skimage.measure import points_in_poly

    from eval import shapes
    from shellrepair.holes import loops as holes
    from shellrepair.mesh.geometry import points_in_polygon

    rng = np.random.default_rng(0)
    print("polygon: random star outlines, uniform points in [-1,1]^2 plus every corner and side midpoint")
    print(f"{'corners':>8} {'points':>7} {'ours ms':>9} {'skimage ms':>11} {'ratio':>6}  same")
    for k in (24, 200, 2000):
        for p in (1000, 20000):
            Q = star(k, rng)
            P = np.vstack([rng.uniform(-1, 1, (p, 2)), Q, 0.5 * (Q + np.roll(Q, 1, axis=0))])
            t_ours, a = best_of(lambda: points_in_polygon(P, Q), repeat)
            t_sk, b = best_of(lambda: points_in_poly(P, Q), repeat)
            print(f"{k:>8} {p:>7} {1e3 * t_ours:>9.2f} {1e3 * t_sk:>11.2f} {t_ours / t_sk:>6.1f}  "
                  f"{bool(np.array_equal(a, b))}")
    # the fill's own use: hole detection's inside fractions on single-view scans
    from shellrepair.holes.loops import detect_holes

    scans = [shapes.range_scan(*shapes.bumpy_sphere(5, amplitude=0.05, frequency=5)),
             shapes.range_scan(*shapes.torus(nu=160, nv=60), view=(0.1, -1.0, 0.9))]
    from shellrepair.mesh.io import read_mesh

    bunny = read_mesh(ROOT / "data" / "bunny_zipper.ply")
    scans.append((bunny.V, bunny.F))
    for name, impl in (("ours", points_in_polygon), ("skimage", points_in_poly)):
        spent = [0.0]

        def timed(*a, impl=impl):
            t = time.perf_counter()
            out = impl(*a)
            spent[0] += time.perf_counter() - t
            return out

        holes.points_in_polygon = timed
        try:
            fr = []
            for s in scans:
                V, F = s[0], s[1]
                fr.append([L.inside_fraction for L in detect_holes(V, F, closed=False).loops])
        finally:
            holes.points_in_polygon = points_in_polygon
        if name == "ours":
            ours_fr, ours_t = fr, spent[0]
        else:
            sk_fr, sk_t = fr, spent[0]
    n = sum(len(f) for f in ours_fr)
    print(f"hole detection on 3 single-view scans ({n} loops): points-in-polygon time ours {1e3 * ours_t:.1f} ms, "
          f"skimage {1e3 * sk_t:.1f} ms; inside fractions the same to the bit: {ours_fr == sk_fr}")


def _distance_cases():
    """Scans whose holes the order test measures: (name, mesh)."""
    from eval import shapes
    from shellrepair.mesh.io import Mesh, read_mesh

    out = []
    V, F = shapes.bumpy_sphere(4, amplitude=0.03, frequency=6)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=6, radius=0.2, seed=3)
    out.append(("bumpy sphere, 6 holes", Mesh(V=V2, F=F2)))
    V, F = shapes.icosphere(6)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[int(np.argmax(V[:, 2]))], radius=0.5)
    out.append(("fine sphere, 1 large hole", Mesh(V=V2, F=F2)))
    out.append(("bunny", read_mesh(ROOT / "data" / "bunny_zipper.ply")))
    return out


def distance(repeat):
    import igl

    from shellrepair.mesh import distance as dist
    from shellrepair.mesh.io import mesh_bytes
    from shellrepair.repair import repair_mesh

    ours = dist.point_mesh_distance

    def exact(Q, V, F):
        Q, V, F = (np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(V, np.float64),
                   np.ascontiguousarray(F, np.int64))
        if len(Q) == 0 or len(F) == 0:
            return np.full(len(Q), np.inf)
        return np.sqrt(igl.point_mesh_squared_distance(Q, V, F)[0])

    print("distance: point_mesh_distance (cKDTree + 8 nearest triangles, compiled) against "
          "igl.point_mesh_squared_distance (AABB, exact), on the order test's calls")
    for name, mesh in _distance_cases():
        calls = []

        def record(Q, V, F, *a):
            calls.append((np.array(Q), np.array(V), np.array(F)))
            return ours(Q, V, F, *a)

        dist.point_mesh_distance = record
        try:
            base, rep = repair_mesh(mesh, order="auto", jobs=1)
        finally:
            dist.point_mesh_distance = ours
        if not calls:
            print(f"  {name}: no order test")
            continue
        t_ours = sum(best_of(lambda c=c: ours(*c), repeat)[0] for c in calls)
        t_igl = sum(best_of(lambda c=c: exact(*c), repeat)[0] for c in calls)
        worst, differ = 0.0, 0
        for c in calls:
            a, b = ours(*c), exact(*c)
            differ += int(np.count_nonzero(a != b))
            worst = max(worst, float(np.max(np.abs(a - b) / np.maximum(b, 1e-300))))
        dist.point_mesh_distance = exact
        try:
            other, rep2 = repair_mesh(mesh, order="auto", jobs=1)
        finally:
            dist.point_mesh_distance = ours
        same = mesh_bytes("a.ply", base) == mesh_bytes("a.ply", other)
        orders = [h["choice"].get("order") for h in rep["holes"]] == [h["choice"].get("order") for h in rep2["holes"]]
        rms = [h["choice"].get("test_rms") for h in rep["holes"]] == [h["choice"].get("test_rms") for h in rep2["holes"]]
        n = sum(len(c[0]) for c in calls)
        print(f"  {name}: {len(calls)} calls, {n} points; ours {1e3 * t_ours:.1f} ms, igl {1e3 * t_igl:.1f} ms; "
              f"{differ} distances differ (largest relative {worst:.2e}); same orders chosen: {orders}; "
              f"same mesh bytes: {same}; same report (test RMS per order): {rms}")


def grid(repeat):
    from scipy.spatial import cKDTree

    from eval import shapes
    from shellrepair.mesh import fastmesh
    from shellrepair.mesh.geometry import concat_ranges
    from shellrepair.mesh.intersect import NearFaces

    fastmesh.warm_up()
    V, F = shapes.icosphere(8)   # 1.3M faces
    V = V + 1e-4 * np.random.default_rng(0).standard_normal(V.shape)
    t_grid, nf = best_of(lambda: NearFaces(V, F), repeat)
    t_tree, tree = best_of(lambda: cKDTree(V), repeat)
    from shellrepair.mesh import intersect_kernels

    t_sort, _ = best_of(lambda: intersect_kernels.grid_sort(V, grow=nf.grow), repeat)
    rng = np.random.default_rng(1)
    h = float(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean())
    boxes = []
    for c in V[rng.choice(len(V), 200, replace=False)]:
        half = h * rng.uniform(5, 40)
        boxes.append((c - half, c + half))

    def by_grid():
        return [nf.faces_near(lo, hi) for lo, hi in boxes]

    def by_tree():   # the same set: vertices in the grown box (a ball around it, then the box), their faces
        out = []
        for lo, hi in boxes:
            lo, hi = lo - nf.grow, hi + nf.grow
            vs = np.asarray(tree.query_ball_point(0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))), np.int64)
            vs = vs[np.all((V[vs] >= lo) & (V[vs] <= hi), axis=1)]
            s = nf.vf_start[vs]
            f = nf.vf_order[concat_ranges(s, nf.vf_start[vs + 1] - s)] // 3
            out.append(np.unique(np.concatenate([f, nf.big])))
        return out

    q_grid, a = best_of(by_grid, repeat)
    q_tree, b = best_of(by_tree, repeat)
    same = all(np.array_equal(x, y) for x, y in zip(a, b))
    print(f"grid: intersect.NearFaces (xy columns, compiled counting sorts) against a cKDTree of the vertices, "
          f"{len(F)} faces, 200 boxes of 10-80 edges")
    print(f"  build: the whole index {1e3 * t_grid:.0f} ms (edge lengths and vertex-face lists, which both need, "
          f"included), its grid {1e3 * t_sort:.0f} ms against cKDTree {1e3 * t_tree:.0f} ms; 200 queries: grid {1e3 * q_grid:.1f} ms, cKDTree {1e3 * q_tree:.1f} ms; "
          f"same faces: {same}")


def _reader_files(folder):
    """A 1.3M-face sphere as OBJ (vertex colours, texture coordinates, a
    comment, two groups and materials), COFF (vertex colours, a comment)
    and binary STL; returns {format: path}."""
    from eval import shapes

    V, F = shapes.icosphere(8)
    V = V + 1e-4 * np.random.default_rng(0).standard_normal(V.shape)
    C = (np.abs(V) * 255).astype(np.uint8)
    uv = np.round(V[:, :2] * 0.5 + 0.5, 6)
    half = len(F) // 2
    fmt_v = lambda rows: "".join(f"v {x:.9g} {y:.9g} {z:.9g} {r / 255:.6g} {g / 255:.6g} {b / 255:.6g}\n"
                                 for (x, y, z), (r, g, b) in rows)
    lines = ["# a 1.3M-face sphere, coloured and textured\n", "mtllib sphere.mtl\n", fmt_v(zip(V.tolist(), C.tolist())),
             "".join(f"vt {u:.6g} {w:.6g}\n" for u, w in uv.tolist())]
    for name, rows in (("front", F[:half]), ("back", F[half:])):
        lines.append(f"g {name}\nusemtl {name}\n")
        lines.append("".join(f"f {a}/{a} {b}/{b} {c}/{c}\n" for a, b, c in (rows + 1).tolist()))
    out = {"obj": folder / "sphere.obj", "off": folder / "sphere.off", "stl": folder / "sphere.stl"}
    out["obj"].write_text("".join(lines))
    off = ["COFF\n# a 1.3M-face sphere, coloured\n", f"{len(V)} {len(F)} 0\n",
           "".join(f"{x:.9g} {y:.9g} {z:.9g} {r} {g} {b} 255\n" for (x, y, z), (r, g, b) in zip(V.tolist(), C.tolist())),
           "".join(f"3 {a} {b} {c}\n" for a, b, c in F.tolist())]
    out["off"].write_text("".join(off))
    out["off (plain)"] = folder / "plain.off"   # what meshio reads: OFF without colours
    out["off (plain)"].write_text("".join(["OFF\n", off[1], "".join(f"{x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in V.tolist()),
                                           off[3]]))
    rec = np.zeros(len(F), [("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = V[F]
    out["stl"].write_bytes(b"\0" * 80 + np.uint32(len(F)).tobytes() + rec.tobytes())
    return out, len(F)


def readers(repeat):
    import tempfile

    import meshio
    import open3d as o3d

    from shellrepair.mesh.formats.obj import read_obj
    from shellrepair.mesh.formats.off import read_off
    from shellrepair.mesh.formats.stl import read_stl
    from shellrepair.mesh.io import read_mesh

    def arrays(m):
        if hasattr(m, "cells"):
            return np.asarray(m.points, np.float64), np.vstack([c.data for c in m.cells]).astype(np.int64)
        if hasattr(m, "triangles"):
            return np.asarray(m.vertices), np.asarray(m.triangles, np.int64)
        return m.V, m.F

    def kept_ours(m):
        t = m.texture
        return {"vertices": len(m.V), "faces": len(m.F), "colours": m.vertex_colors is not None,
                "texcoords": t is not None and len(t.uv) > 0,
                "materials/groups": t is not None and len(t.materials) > 0,
                "comments": bool(m.comments), "notes": len(m.notes)}

    def kept_meshio(m):
        keys = set(m.point_data) | set(m.cell_data)
        return {"vertices": len(m.points), "faces": sum(len(c.data) for c in m.cells),
                "colours": any("color" in k.lower() or "rgb" in k.lower() for k in keys),
                "texcoords": any("vt" in k or "uv" in k.lower() or "tex" in k.lower() for k in keys),
                "materials/groups": any("group" in k.lower() or "mat" in k.lower() for k in keys)
                or len(m.cells) > 1, "comments": False, "notes": 0}

    def kept_o3d(m):
        return {"vertices": len(m.vertices), "faces": len(m.triangles), "colours": m.has_vertex_colors(),
                "texcoords": m.has_triangle_uvs(), "materials/groups": m.has_triangle_material_ids()
                and len(np.unique(np.asarray(m.triangle_material_ids))) > 1, "comments": False, "notes": 0}

    with tempfile.TemporaryDirectory() as tmp:
        files, nf = _reader_files(Path(tmp))
        print(f"readers: {nf} faces (load average {os.getloadavg()[0]:.1f}); seconds (fastest of {repeat}), and what each keeps "
              "(ours: read_mesh, checks and notes included; parser: the format's reader alone)")
        for fmt, path in files.items():
            print(f"  {fmt.upper()} ({path.stat().st_size / 1e6:.0f} MB)")
            parse = {"obj": read_obj, "off": read_off, "off (plain)": read_off, "stl": read_stl}[fmt]
            for name, read, kept in (("ours", lambda: read_mesh(path), kept_ours),
                                     ("parser", lambda: parse(path.read_bytes()), kept_ours),
                                     ("meshio", lambda: meshio.read(path), kept_meshio),
                                     ("open3d", lambda: o3d.io.read_triangle_mesh(str(path)), kept_o3d)):
                try:
                    t, m = best_of(read, repeat)
                except (Exception, SystemExit) as exc:  # noqa: BLE001 - a reader that fails (meshio may exit): said so
                    print(f"    {name:7s} fails: {type(exc).__name__}: {str(exc)[:80]}")
                    continue
                if name == "ours":
                    ref = arrays(m)
                got = arrays(m)
                same = len(got[0]) == len(ref[0]) and np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
                print(f"    {name:7s} {t:6.2f} s  {kept(m)}, V and F equal to ours: {same}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sections", nargs="*", default=["polygon", "distance", "grid", "readers"])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    for s in args.sections:
        {"polygon": polygon, "distance": distance, "grid": grid, "readers": readers}[s](args.repeat)
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
