"""The fill's speed on few large holes in a big scan: ours against the peers.

Run ``.venv/bin/python eval/bench_fill.py [--tools ...] [--profile]``.

Case (issue 14's "two-disc" case): a bumpy sphere of 8 subdivisions
(:func:`eval.shapes.bumpy_sphere`, 1,310,720 faces, relief 0.03 at
frequency 6), coordinates rounded to float32, with two holes cut as the
faces whose centroid direction lies within a chord of 0.292 and 0.0775 of
two fixed directions (+z, +x): loops of 510 and 132 rim edges. The holes are
few and large, so the fill's whole-mesh set-up and per-hole overheads show,
not the number of holes.

Ours (``repair_mesh``, order 2, one job; its time is the report's
``seconds``: detection, set-up, fill and merge), MeshLib's
``fillHoleNicely`` (hole search included) and CGAL's
``triangulate_refine_and_fair_hole`` run in the same run, each in its own
child (:func:`eval.bench_scale.compare_peers`), and are measured against the
unperforated surface. ``--profile`` instead prints a cProfile of ours
in this process (no peers).

It writes ``eval/results/bench_fill.json`` and asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

RESULTS = ROOT / "eval" / "results"
SUBDIVISIONS, AMPLITUDE, FREQUENCY = 8, 0.03, 6
#: (direction, chord radius) of the two holes.
DISCS = (((0.0, 0.0, 1.0), 0.292), ((1.0, 0.0, 0.0), 0.0775))
TOOLS = ("ours-o2", "meshlib-nicely", "cgal")


def two_disc_case():
    """The truth (V, F), the perforated (V2, F2) and the removed-face mask."""
    from eval import shapes

    V, F = shapes.bumpy_sphere(SUBDIVISIONS, amplitude=AMPLITUDE, frequency=FREQUENCY)
    V = V.astype(np.float32).astype(np.float64)
    C = V[F].mean(axis=1)
    U = C / np.linalg.norm(C, axis=1, keepdims=True)
    remove = np.zeros(len(F), bool)
    for d, r in DISCS:
        remove |= np.linalg.norm(U - np.asarray(d), axis=1) < r
    V2, F2, _ = shapes.remove_faces(V, F, remove)
    return V, F, V2, F2, remove


def profile(V2, F2, n=30):
    import cProfile
    import pstats

    from shellrepair.io import Mesh
    from shellrepair.repair import repair_mesh

    repair_mesh(Mesh(V=V2, F=F2))  # warm (imports, JIT caches)
    pr = cProfile.Profile()
    t0 = time.perf_counter()
    pr.enable()
    _, rep = repair_mesh(Mesh(V=V2, F=F2))
    pr.disable()
    print(f"repair_mesh {time.perf_counter() - t0:.3f} s (report seconds {rep['seconds']:.3f})")
    pstats.Stats(pr).sort_stats("cumulative").print_stats(n)
    pstats.Stats(pr).sort_stats("tottime").print_stats(n)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tools", default=",".join(TOOLS))
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--out", default=str(RESULTS / "bench_fill.json"))
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    V, F, V2, F2, remove = two_disc_case()
    print(f"two-disc case: {len(F2):,} faces, built in {time.perf_counter() - t0:.1f} s")
    if a.profile:
        profile(V2, F2)
        return 0
    from eval.bench_scale import compare_peers

    with tempfile.TemporaryDirectory(prefix="bench_fill_") as tmp:
        d = Path(tmp)
        np.save(d / "V.npy", V2)
        np.save(d / "F.npy", F2)
        np.savez(d / "truth.npz", V=V, F=F, removed=remove)
        rows = compare_peers(d, a.tools.split(","), a.timeout)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps({"faces": int(len(F2)), "rows": rows}, indent=1, default=str))
    print(f"{'tool':16s} {'fill s':>8s} {'RMS ‰':>8s}")
    for r in rows:
        if r.get("status") == "ok":
            print(f"{r['tool']:16s} {r['seconds']:8.3f} {r['rms_permille']:8.4f}")
        else:
            print(f"{r['tool']:16s} {r.get('status')}: {r.get('error')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
