"""Single-view range scans of the closed real meshes: holes closed, nothing crossed.

Run ``.venv/bin/python eval/range_scans.py [--resolution 300]``.

Each closed mesh of ../shared/data is ray-cast from five views
(:func:`eval.shapes.range_scan`, the Stanford range scans' triangulation
rule), written as a PLY, repaired by the command line's defaults (one
job) and written again; MeshLab's per-face self-intersection count
(pymeshlab, what users run) is taken on both files. The real dragon range
scan of ../shared/data is added as it is.

Writes ``eval/results/range-scans/range_scans.json`` and ``.md``; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

SHARED = ROOT.parent / "shared" / "data"
OUT = ROOT / "eval" / "results" / "range-scans"
MESHES = ("armadillo", "nefertiti_bust", "rocker_arm_genus1", "fandisk_cad", "cheburashka")
VIEWS = ((0.3, -1.0, 0.4), (1.0, 0.2, -0.3), (-0.5, 0.5, 1.0), (0.0, 0.0, 1.0), (-1.0, -0.2, 0.1))


def meshlab_self_intersecting(path):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    ms.compute_selection_by_self_intersections_per_face()
    return int(ms.current_mesh().selected_face_number())


def run_case(name, src, tmp):
    from shellrepair import read_mesh, write_mesh
    from shellrepair.repair import repair_mesh

    m = read_mesh(src)
    R, rep = repair_mesh(m, jobs=1)
    out = Path(tmp) / "out.ply"
    write_mesh(out, R)
    return {"case": name, "faces": int(rep["faces_before"]), "holes": rep["holes_before"], "filled": rep["filled"],
            "failed": rep["failed"], "points_joined": int(m.fixes.get("nonmanifold_vertices_split", 0)),
            "self_intersecting_before": meshlab_self_intersecting(src),
            "self_intersecting_after": meshlab_self_intersecting(out)}


def main(argv=None):
    from eval import shapes
    from shellrepair import Mesh, read_mesh, write_mesh

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=int, default=300)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in MESHES:
            path = SHARED / f"closed_{name}.ply"
            if not path.exists():
                print(f"{path} missing: skipped")
                continue
            m = read_mesh(path)
            for k, view in enumerate(VIEWS):
                P, T = shapes.range_scan(m.V, m.F, view=view, resolution=args.resolution)
                src = Path(tmp) / "scan.ply"
                write_mesh(src, Mesh(V=P, F=T))
                rows.append(run_case(f"{name} view {k}", src, tmp))
                print(rows[-1], flush=True)
        dragon = SHARED / "real_rangescan_dragon_000.ply"
        if dragon.exists():
            rows.append(run_case("real dragon range scan", dragon, tmp))
            print(rows[-1], flush=True)
    added = [r["self_intersecting_after"] - r["self_intersecting_before"] for r in rows]
    lines = [f"# Range scans ({len(rows)} cases, {args.resolution} rays per side)", "",
             "| case | faces | holes | filled | failed | points joined | MeshLab self-intersecting before → after |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['case']} | {r['faces']} | {r['holes']} | {r['filled']} | {r['failed']} | {r['points_joined']} "
              f"| {r['self_intersecting_before']} → {r['self_intersecting_after']} |" for r in rows]
    lines += ["", f"- holes {sum(r['holes'] for r in rows)}, filled {sum(r['filled'] for r in rows)}, "
              f"failed {sum(r['failed'] for r in rows)}; self-intersecting faces added: {sum(added)} in all, "
              f"{sum(a > 0 for a in added)} cases with any"]
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "range_scans.json").write_text(json.dumps({"resolution": args.resolution, "rows": rows}, indent=1))
    (OUT / "range_scans.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
