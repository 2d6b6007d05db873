"""Our own small structures against the libraries that do the same job.

Run ``.venv/bin/python eval/bench_libs.py [polygon|distance|readers ...]``
(all three when none is named). Each section prints its numbers (the
fastest of ``--repeat`` runs, in one warm process) and whether the answers
are the same; the docstrings of the functions measured quote them.

* ``polygon``: :func:`shellrepair.geometry.points_in_polygon` (NumPy) against
  scikit-image's ``points_in_poly`` (Cython), which the fill used before:
  random outlines, and the outlines and samples hole detection tests
  (:func:`shellrepair.holes._inside_fractions`) on single-view scans.
* ``distance``: :func:`shellrepair.distance.point_mesh_distance` (SciPy's
  cKDTree of centroids, then the exact distance to the 8 nearest
  triangles) against libigl's ``point_mesh_squared_distance`` (an AABB
  tree, exact), on the order test's own queries.
* ``grid``: :class:`shellrepair.intersect.NearFaces` (vertices in xy
  columns) against a SciPy cKDTree of the vertices, for the crossing
  checks' box queries on a 1.3M-face mesh.
* ``readers``: our OBJ / OFF / STL readers (:mod:`shellrepair.formats`)
  against meshio and Open3D on a ~1M-face file of each format, and what
  each keeps.

Asserts nothing; needs the bench/test extras (scikit-image, meshio).
"""

from __future__ import annotations

import argparse
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
    from shellrepair import holes
    from shellrepair.geometry import points_in_polygon

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
    from shellrepair.holes import detect_holes

    scans = [shapes.range_scan(*shapes.bumpy_sphere(5, amplitude=0.05, frequency=5)),
             shapes.range_scan(*shapes.torus(nu=160, nv=60), view=(0.1, -1.0, 0.9))]
    from shellrepair.io import read_mesh

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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sections", nargs="*", default=["polygon", "distance", "grid", "readers"])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    for s in args.sections:
        {"polygon": polygon, "distance": distance, "grid": grid, "readers": readers}[s](args.repeat)
        print()
    return 0


def _distance_cases():
    """Scans whose holes the order test measures: (name, mesh)."""
    from eval import shapes
    from shellrepair.io import Mesh, read_mesh

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

    from shellrepair import distance as dist
    from shellrepair.io import mesh_bytes
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
    from shellrepair import fastmesh
    from shellrepair.geometry import concat_ranges
    from shellrepair.intersect import NearFaces

    fastmesh.warm_up()
    V, F = shapes.icosphere(8)   # 1.3M faces
    V = V + 1e-4 * np.random.default_rng(0).standard_normal(V.shape)
    t_grid, nf = best_of(lambda: NearFaces(V, F), repeat)
    t_tree, tree = best_of(lambda: cKDTree(V), repeat)
    from shellrepair import intersect_kernels

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


def readers(repeat):
    raise NotImplementedError


if __name__ == "__main__":
    sys.exit(main())
