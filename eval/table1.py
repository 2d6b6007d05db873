"""The paper's Table 1 on an occlusion-perforated statue scan.

Yamamoto, Shiba & Okada report, for their gilt-bronze statue scan, 156
holes before their simple-shape-model ("seed") interpolation, 54 after, an
interpolation rate of 65.4 %. This prints the same table for a statue scan
perforated the way a handheld scanner perforates one (scanner occlusion,
:func:`eval.cases.occlusion_mask`: 24 positions on a helix around the bust,
every triangle no ray saw deleted) for ``method="seed"`` and for ours.

Run ``make table1`` (or ``.venv/bin/python eval/table1.py [--seed N]
[--order K] [--json]``). The scan is ``closed_nefertiti_bust.ply`` from
``../shared/data``; a clone without it gets a synthetic bumpy sphere and
the output says so.

Holes before and after are the counts of ``repair_mesh``'s report (holes
as classed by :mod:`shellrepair.holes.loops`); ``loops after`` counts the
boundary loops left in the output, as a check.
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

from eval import cases  # noqa: E402
from shellrepair.holes.loops import boundary_loops  # noqa: E402
from shellrepair.mesh.io import Mesh  # noqa: E402
from shellrepair.report.table import interpolation_rate  # noqa: E402

PAPER = {"holes_before": 156, "holes_after": 54, "interpolation_rate": 65.4}


def run(seed=0, order=2, case="nefertiti-occlusion-helix"):
    """Build the occlusion case and repair it with the seed method and ours."""
    from shellrepair.repair import repair_mesh

    c = cases.build_case(case, seed)
    rows = []
    for label, kw in (("seed method (paper)", {"method": "seed"}),
                      (f"ours (order {order})", {"method": "fair", "order": order})):
        mesh = Mesh(V=c.V.copy(), F=c.F.copy())
        t0 = time.perf_counter()
        out, rep = repair_mesh(mesh, **kw)
        dt = time.perf_counter() - t0
        loops, _ = boundary_loops(out.F, len(out.V))
        rows.append({"method": label, "holes_before": rep["holes_before"], "holes_after": rep["holes_after"],
                     "interpolation_rate": rep["interpolation_rate"]
                     if rep.get("interpolation_rate") is not None
                     else interpolation_rate(rep["holes_before"], rep["holes_after"]),
                     "loops_after": len(loops), "seconds": round(dt, 3)})
    return c, rows


def text(c, rows):
    truth = cases.REAL_SCANS.get(c.truth, c.truth)
    lines = ["Table 1: holes before and after the interpolation, and the interpolation rate",
             f"scan: {truth}, {c.description}; {len(c.F)} faces after perforation (seed {c.seed})"]
    lines += [f"note: {n}" for n in c.notes]
    lines += ["",
              f"  {'':24s} {'before':>7} {'after':>7} {'rate [%]':>9} {'loops after':>12} {'seconds':>8}",
              f"  {'paper (their statue)':24s} {PAPER['holes_before']:>7} {PAPER['holes_after']:>7} "
              f"{PAPER['interpolation_rate']:>9.1f} {'':>12} {'':>8}"]
    for r in rows:
        rate = "n/a" if r["interpolation_rate"] is None else f"{r['interpolation_rate']:.1f}"
        lines.append(f"  {r['method']:24s} {r['holes_before']:>7} {r['holes_after']:>7} {rate:>9} "
                     f"{r['loops_after']:>12} {r['seconds']:>8.2f}")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="eval/table1.py", description="The paper's Table 1 on an "
                                 "occlusion-perforated statue scan, for the seed method and ours.")
    ap.add_argument("--seed", type=int, default=0, help="seed of the scanner path (default 0)")
    ap.add_argument("--order", type=int, default=2, choices=(1, 2, 3), help="our fairing order (default 2)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of the table")
    args = ap.parse_args(argv)
    c, rows = run(args.seed, args.order)
    if args.json:
        print(json.dumps({"case": c.summary(), "paper": PAPER, "rows": rows}, indent=1))
    else:
        print(text(c, rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
