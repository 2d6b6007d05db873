"""Randomized large holes in dense meshes: the cases the fixed suite and the
stress suite do not have.

Run ``.venv/bin/python eval/big_holes.py --seed S [--n N] [--name NAME]``.

eval's suite and ``eval/stress.py`` cut holes of tens to a few hundred new
vertices (procedural shapes at modest resolution); a museum scan of a few
million triangles that misses the base or the underside of a chin has
holes of thousands. Each case here draws, from ``--seed``:

* a dense closed truth: a bumpy sphere of 7 subdivisions (327,680 faces;
  relief amplitude 0.01-0.04 at frequency 3-9, its own seed), an
  ellipsoid of 7 subdivisions (axes 1 and two drawn in 0.45-0.95), a fine
  torus (tube radius 0.25-0.45 of the centre radius, about 100k faces), or
  one of the real scans in ``../shared/data`` (Nefertiti, the Armadillo)
  split once at its edge midpoints (4x the faces, the same surface);
  rotated at random and rounded to float32 as a PLY ``float`` file is;
* one to three geodesic discs whose rims have 150-600 edges (radius
  ``k e / 2 pi`` for ``k`` drawn in that range and ``e`` the mean edge),
  at least three radii apart (:func:`eval.cases.disc_mask`).

Each tool of ``--tools`` (default ``ours-auto``: ``repair_mesh`` with the
default options; any of eval/peers.py's names) runs in this process, our
kernels loaded first (as eval/peers.py does); each case's RMS against the
truth (:func:`eval.metrics.evaluate`, ‰ of the truth's diagonal), the
tool's seconds (ours: the report's), holes closed and boundary edges left
(counted on the output), and, for ours, every hole's decision are written
to ``eval/results/NAME.json`` and a table to ``NAME.md``. It asserts
nothing; run it on two commits and compare the JSON files to see what a
change did to large holes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from eval import cases, metrics, shapes  # noqa: E402
from eval.stress import random_rotation  # noqa: E402

RESULTS = ROOT / "eval" / "results"
RIM_EDGES = (150, 600)
SHAPES = ("bumpy_sphere", "ellipsoid", "torus", "nefertiti", "armadillo")


def _midpoint_split(V, F):
    """Each triangle split in four at its edge midpoints (the same surface).

    :func:`eval.shapes._subdivide` splits alike but lists the corners of
    two of the four triangles from another corner; the cases of a seed, and
    the results stored under eval/results/big_holes, were drawn with this
    ordering (its faces differ after the discs are cut)."""
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(E, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    mid = len(V) + inv.reshape(3, -1).T                       # (m,3): midpoints of edges 01, 12, 20
    V2 = np.vstack([V, 0.5 * (V[uniq[:, 0]] + V[uniq[:, 1]])])
    a, b, c = F[:, 0], F[:, 1], F[:, 2]
    ab, bc, ca = mid[:, 0], mid[:, 1], mid[:, 2]
    F2 = np.vstack([np.column_stack(t) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return V2, F2.astype(np.int64)


def _truth(kind, rng):
    """A dense closed truth of ``kind`` and a description."""
    if kind == "bumpy_sphere":
        amp, freq, s = rng.uniform(0.01, 0.04), int(rng.integers(3, 10)), int(rng.integers(1 << 30))
        V, F = shapes.bumpy_sphere(7, amplitude=amp, frequency=freq, seed=s)
        return V, F, f"bumpy sphere, relief {amp:.3f} at frequency {freq}"
    if kind == "ellipsoid":
        b, c = sorted(rng.uniform(0.45, 0.95, 2))[::-1]
        V, F = shapes.ellipsoid(7, axes=(1.0, b, c))
        return V, F, f"ellipsoid 1 x {b:.2f} x {c:.2f}"
    if kind == "torus":
        r = rng.uniform(0.25, 0.45)
        V, F = shapes.torus(1.0, r, 384, int(round(384 * r)) + 8)
        return V, F, f"torus, tube radius {r:.2f}"
    V, F, notes = cases.ground_truth(kind)
    if notes:
        return V, F, f"{kind} ({'; '.join(notes)})"
    V, F = _midpoint_split(np.asarray(V, np.float64), np.asarray(F, np.int64))
    return V, F, f"{kind}, split once at edge midpoints"


def big_hole_case(index, seed):
    """The ``index``-th case of ``seed``: (name, description, V_true, F_true, V, F)."""
    rng = np.random.default_rng([int(seed), int(index)])
    kind = SHAPES[int(rng.integers(len(SHAPES)))]
    V, F, what = _truth(kind, rng)
    V = cases._f32(V @ random_rotation(rng).T)
    F = np.asarray(F, np.int64)
    e = float(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean())
    n_holes = int(rng.integers(1, 4))
    k = rng.uniform(*RIM_EDGES)
    radius = k * e / (2 * np.pi)
    remove = cases.disc_mask(V, F, n_holes, radius, seed=int(rng.integers(1 << 30)))
    remove = cases.keep_largest(F, remove)
    V2, F2, _ = shapes.remove_faces(V, F, remove)
    name = f"b{seed}-{index:02d}-{kind}"
    return name, f"{what}; {n_holes} disc(s) of ~{k:.0f} rim edges", V, F, V2, F2


def run(seed, n, name, out=RESULTS, only=None, tools=("ours-auto",)):
    from eval import peers

    peers._load_kernels()
    rows = []
    for i in range(n):
        if only is not None and i not in only:
            continue
        cname, what, Vt, Ft, V, F = big_hole_case(i, seed)
        truth = metrics.TruthSurface(Vt, Ft)
        for tool in tools:
            rows.append(_run_tool(tool, cname, what, truth, V, F))
            r = rows[-1]
            print(f"{cname:28s} {tool:15s} {r['status']:6s} {r['closed']}/{r['holes']} holes, "
                  f"{r['new_vertices']:6d} new vertices, RMS {r['rms_permille']:.4g} ‰, {r['seconds']:.2f} s", flush=True)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    doc = {"command": " ".join(sys.argv), "seed": seed, "n": n, "tools": list(tools), "rows": rows}
    (out / f"{name}.json").write_text(json.dumps(doc, indent=1))
    lines = [f"# Large holes in dense meshes, seed {seed}", "", f"`{doc['command']}`", "",
             "| case | truth and holes | faces | tool | closed | boundary edges after | new vertices | RMS ‰ | max ‰ | s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['case']} | {r['description']} | {r['faces']} | {r['tool']} | {r['closed']}/{r['holes']} "
              f"| {r['boundary_edges_after']} | {r['new_vertices']} | {r['rms_permille']:.4g} | {r['max_permille']:.4g} "
              f"| {r['seconds']:.2f} |" for r in rows]
    (out / f"{name}.md").write_text("\n".join(lines) + "\n")
    return rows


def _run_tool(tool, cname, what, truth, V, F):
    """One tool on one case: its row (ours: the report's holes and decisions;
    a peer: the holes counted on its output)."""
    from eval import peers
    from shellrepair import repair_mesh
    from shellrepair.holes.loops import boundary_loops
    from shellrepair.mesh.topology import edge_topology

    row = {"case": cname, "description": what, "faces": int(len(F)), "tool": tool,
           "holes": len(boundary_loops(F, len(V))[0]), "status": "ok", "decisions": None}
    try:
        if tool == "ours-auto":     # in this process, with its report
            repaired, report = repair_mesh((V, F))
            Vo, Fo, secs = repaired.V, repaired.F, report["seconds"]
            row["decisions"] = [h.get("reason") for h in report["holes"]]
        else:
            Vo, Fo, info = peers.run_tool(tool, V, F)
            secs = info["seconds"]
    except Exception as exc:        # a peer that fails: the row says so
        row.update(status="failed", error=f"{type(exc).__name__}: {exc}"[:200], closed=0, new_vertices=0,
                   rms_permille=float("nan"), max_permille=float("nan"), seconds=float("nan"),
                   boundary_edges_after=None)
        return row
    m = metrics.evaluate(V, F, Vo, Fo, truth, self_intersections=False)
    Fo = np.asarray(Fo, np.int64)
    loops, chains = boundary_loops(Fo, len(Vo))
    row.update(closed=max(row["holes"] - len(loops) - len(chains), 0), new_vertices=int(len(Vo) - len(V)),
               boundary_edges_after=int(np.count_nonzero(edge_topology(Fo, len(Vo)).edge_count == 1)),
               rms_permille=m["rms_permille"], max_permille=m["max_permille"], seconds=secs)
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--only", default=None, help="comma-separated case indices")
    ap.add_argument("--tools", default="ours-auto", help="comma-separated tools (eval/peers.py names)")
    ap.add_argument("--name", default=None, help="output file stem (default big_holes-SEED)")
    ap.add_argument("--out", default=str(RESULTS))
    a = ap.parse_args(argv)
    only = None if a.only is None else {int(x) for x in a.only.split(",")}
    run(a.seed, a.n, a.name or f"big_holes-{a.seed}", a.out, only, tuple(a.tools.split(",")))


if __name__ == "__main__":
    main()
