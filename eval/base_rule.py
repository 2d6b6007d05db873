"""How good is the edge-on base rule? Random ``base`` stress cases, three ways.

``python eval/base_rule.py --seeds 48611,58231,66107 --n 12``

A planar opening that the scan meets edge-on gets a flat cap when the scan
turns into the opening's plane along most of its rim
(:func:`shellrepair.fill.patch.turns_into_opening`), and a faired fill
otherwise. This script builds cases ``0..n-1`` of each seed with the
``base`` family forced (:func:`eval.stress.stress_case`: the bottom 5–25 %
of a figure cut off by a plane tilted up to 25°) and repairs each at the
default order three times: with the rule, with the rule answering "faired"
for every opening, and with it answering "flat" (the two forced runs patch
the function in this process only); CGAL's
``triangulate_refine_and_fair_hole`` runs beside them. RMS distances of
the added faces to the closed truth, in ‰ of its bounding-box diagonal
(:func:`eval.metrics.evaluate`). Per case it prints and stores the three
RMS and CGAL's, the share of rim vertices whose first-ring faces turn into
the opening (the rule's statistic; flat above one half) for each opening
the rule was asked about, and which answer was closer to the truth.

Writes ``eval/results/base_rule-<seeds>.json`` and ``.md``; asserts
nothing. A case whose openings the rule is never asked about (not planar,
or not met edge-on) gives the same RMS three times and is counted apart.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

RESULTS = ROOT / "eval" / "results"
MODES = ("rule", "faired", "flat")


def turning_share(ctx, loop):
    """The rule's statistic: the share of rim vertices whose first-ring
    faces face out through the opening (:func:`shellrepair.fill.patch.rim_turning`)."""
    from shellrepair.fill.patch import rim_turning

    return rim_turning(ctx, loop) / len(loop)


def run_case(case, truth, facts):
    """The three repairs and CGAL's fill of one case: a row."""
    from eval import metrics, peers
    from shellrepair.fill import patch
    from shellrepair.mesh.io import Mesh
    from shellrepair.repair import repair_mesh

    rule = patch.turns_into_opening
    asked = []

    def spy(ctx, loop):
        answer = rule(ctx, loop)
        asked.append({"edges": int(len(loop)), "flat": bool(answer), "share": round(turning_share(ctx, loop), 3)})
        return answer

    row = {"case": case.name, "tilt_deg": case.params.get("tilt_deg"), "cut_area_pct": case.params.get("cut_area_pct"),
           "shape": case.params.get("shape")}
    try:
        for mode in MODES:
            patch.turns_into_opening = spy if mode == "rule" else (lambda ctx, loop, v=(mode == "flat"): v)
            out, rep = repair_mesh(Mesh(V=np.asarray(case.V, np.float64), F=np.asarray(case.F, np.int64)))
            ev = metrics.evaluate(case.V, case.F, out.V, out.F, truth, n_samples=20000, seed=0, facts=facts,
                                  self_intersections=False)
            row[mode] = ev.get("rms_permille")
            row[mode + "_holes_after"] = int(rep["holes_after"])
    finally:
        patch.turns_into_opening = rule
    row["asked"] = asked
    try:
        V, F, _ = peers.run_tool("cgal", case.V, case.F)
        row["cgal"] = metrics.evaluate(case.V, case.F, V, F, truth, n_samples=20000, seed=0, facts=facts,
                                       self_intersections=False).get("rms_permille")
    except Exception as exc:  # CGAL missing or failed: the row says so
        row["cgal"] = None
        row["cgal_error"] = f"{type(exc).__name__}: {exc}"[:200]
    return row


def summary(rows):
    """Geometric means and counts over the cases the rule was asked about."""
    asked = [r for r in rows if r["asked"] and all(r.get(m) for m in MODES)]
    out = {"cases": len(rows), "asked": len(asked)}
    if not asked:
        return out
    for m in MODES + ("cgal",):
        x = np.array([r[m] for r in asked if r.get(m)], float)
        out[f"{m}_geomean"] = float(np.exp(np.mean(np.log(x)))) if len(x) else None
    flat = [r for r in asked if r["asked"][0]["flat"]]
    out["rule_said_flat"] = len(flat)
    out["flat_was_closer"] = sum(r["flat"] < r["faired"] for r in flat)
    fair = [r for r in asked if not r["asked"][0]["flat"]]
    out["rule_said_faired"] = len(fair)
    out["faired_was_closer"] = sum(r["faired"] < r["flat"] for r in fair)
    with_cgal = [r for r in asked if r.get("cgal")]
    for m in MODES:
        out[f"{m}_worse_than_cgal"] = sum(r[m] > r["cgal"] for r in with_cgal)
    return out


def markdown(rows, s, command):
    lines = ["# The edge-on base rule on random base cases", "", f"Command: `{command}`", "",
             "RMS ‰ of the added faces to the truth. share: rim vertices turning into the opening "
             "(flat above 0.5), for the first opening the rule was asked about.", "",
             "| case | tilt ° | cut % | share | rule says | rule | always faired | always flat | CGAL |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        a = r["asked"][0] if r["asked"] else None
        lines.append(f"| {r['case']} | {r['tilt_deg']} | {r['cut_area_pct']} | "
                     f"{a['share'] if a else '–'} | {('flat' if a['flat'] else 'faired') if a else 'not asked'} | "
                     + " | ".join("–" if r.get(k) is None else f"{r[k]:.3g}" for k in MODES + ("cgal",)) + " |")
    lines += ["", "Summary (cases the rule was asked about):", "", "```", json.dumps(s, indent=1), "```", ""]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="48611", help="comma-separated seeds")
    ap.add_argument("--n", type=int, default=12, help="cases per seed")
    ap.add_argument("--out", default=str(RESULTS))
    a = ap.parse_args(argv)
    from eval import metrics, peers, stress

    peers._load_kernels()
    seeds = [int(s) for s in a.seeds.split(",")]
    shapes_ok = stress.available_shapes()
    rows = []
    for seed in seeds:
        for i in range(a.n):
            case = stress.stress_case(i, seed, family="base", shapes_ok=shapes_ok)
            row = run_case(case, metrics.TruthSurface(case.V_true, case.F_true), metrics.input_facts(case.V, case.F))
            rows.append(row)
            print(json.dumps(row, default=str), flush=True)
    s = summary(rows)
    stem = Path(a.out) / f"base_rule-{'-'.join(map(str, seeds))}"
    stem.parent.mkdir(parents=True, exist_ok=True)
    command = "python eval/base_rule.py " + " ".join(sys.argv[1:] if argv is None else argv)
    stem.with_suffix(".json").write_text(json.dumps({"command": command, "rows": rows, "summary": s}, indent=1,
                                                    default=str))
    stem.with_suffix(".md").write_text(markdown(rows, s, command))
    print(json.dumps(s, indent=1))
    print(f"wrote {stem}.json, {stem}.md")


if __name__ == "__main__":
    main()
