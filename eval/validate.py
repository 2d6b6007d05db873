"""Validate a choice on fresh stress cases, families forced in turn.

``python eval/validate.py --seed 6200 --n 21 --families discs,base,scanner``
builds case ``i`` of the seed with family ``families[i % len(families)]``
(:func:`eval.stress.stress_case`, so the same seed and index give the same
mesh as the stress suite with that family), runs each tool in its child
process (:mod:`eval.worker`) and measures it as the stress suite does
(:func:`eval.stress.run_case`). Writes ``<out>/validation-seed<seed>.json``
(the rows) and ``.md``: RMS per case and tool, each of ours against the
best peer (the lower RMS of CGAL and MeshLib's fillHoleNicely among those
that closed every hole), geometric means per family, and ours-auto
against ours-o2. ``--report-only`` rewrites the ``.md`` from the ``.json``.

Seeds used to choose a constant must not be used to validate it: say in
BENCHMARKS.md which seeds were looked at.
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

from eval import stress  # noqa: E402

TOOLS = ("ours-o2", "ours-auto", "cgal", "meshlib-nicely")
PEERS = ("cgal", "meshlib-nicely")


def run(seed, n, families, tools=TOOLS, timeout=90.0, out=ROOT / "eval" / "results"):
    from eval.worker import ToolRunner

    out = Path(out)
    tmp = out / "tmp"
    tmp.mkdir(parents=True, exist_ok=True)
    runners = {t: ToolRunner(t, tmp, timeout) for t in tools}
    rows = []
    shapes_ok = stress.available_shapes()
    try:
        for i in range(n):
            case = stress.stress_case(i, seed, family=families[i % len(families)], shapes_ok=shapes_ok)
            facts = stress.input_facts(case)
            print(f"{case.name}: {len(case.F)} faces, {int(facts['is_hole'].sum())} holes ({case.description})",
                  flush=True)
            rows.extend(stress.run_case(case, facts, tools, runners, tmp, log=lambda s: print(s, flush=True)))
            (out / f"validation-seed{seed}.json").write_text(json.dumps(rows, default=str))
    finally:
        for r in runners.values():
            r.close()
    return rows


def markdown(rows, command):
    cases = {}
    for r in rows:
        cases.setdefault(r["case"], {})[r["tool"]] = r
    tools = [t for t in TOOLS if any(t in v for v in cases.values())]
    lines = [f"Command: `{command}`", "",
             "| case | " + " | ".join(f"{t} RMS ‰" for t in tools) + " | best peer | o2 / best | auto / best |",
             "|---|" + "---|" * (len(tools) + 3)]
    ratio = {"ours-o2": [], "ours-auto": []}
    fam = {}
    both = []
    for name, v in cases.items():
        def rms(t):
            r = v.get(t)
            return r.get("rms_permille") if r and r.get("status") == "ok" else None
        full = {t: rms(t) for t in PEERS if rms(t) is not None and v[t]["holes_closed"] == v[t]["holes"]}
        peers = full or {t: rms(t) for t in PEERS if rms(t) is not None}
        cells = []
        for t in tools:
            r = v.get(t)
            x = rms(t)
            cells.append("–" if x is None else f"{x:.3g}" + ("" if r["holes_closed"] == r["holes"]
                                                            else f" ({r['holes_closed']}/{r['holes']} closed)"))
        if peers and rms("ours-o2") and rms("ours-auto"):
            best = min(peers, key=peers.get)
            r2, ra = rms("ours-o2") / peers[best], rms("ours-auto") / peers[best]
            ratio["ours-o2"].append(r2)
            ratio["ours-auto"].append(ra)
            fam.setdefault(name.split("-")[2], []).append((r2, ra))
            both.append((rms("ours-o2"), rms("ours-auto")))
            cells += [best, f"{r2:.2f}", f"{ra:.2f}"]
        else:
            cells += ["–", "–", "–"]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines.append("")
    gm = lambda a: float(np.exp(np.mean(np.log(np.asarray(a))))) if len(a) else float("nan")
    for t, r in ratio.items():
        r = np.asarray(r)
        lines.append(f"- {t} against the best peer: geometric mean {gm(r):.3f}; better on {int((r < 1).sum())}, "
                     f"over 1.1x on {int((r > 1.1).sum())} of {len(r)}")
    for f, rr in fam.items():
        rr = np.asarray(rr)
        lines.append(f"- family {f}: geometric mean against the best peer, ours-o2 {gm(rr[:, 0]):.3f}, "
                     f"ours-auto {gm(rr[:, 1]):.3f}")
    if both:
        b = np.asarray(both)
        q = b[:, 1] / b[:, 0]
        lines.append(f"- ours-auto against ours-o2: lower RMS on {int((q < 0.99).sum())}, higher on "
                     f"{int((q > 1.01).sum())}, within 1 % on {int((np.abs(q - 1) <= 0.01).sum())}")
    secs = {t: sum(float(v[t]["seconds"] or 0) for v in cases.values() if t in v) for t in ("ours-o2", "ours-auto")}
    lines.append(f"- fill seconds in all: ours-o2 {secs['ours-o2']:.1f}, ours-auto {secs['ours-auto']:.1f}")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--n", type=int, default=21)
    p.add_argument("--families", default="discs,base,scanner")
    p.add_argument("--tools", default=",".join(TOOLS))
    p.add_argument("--timeout", type=float, default=90.0)
    p.add_argument("--out", default=str(ROOT / "eval" / "results"))
    p.add_argument("--report-only", action="store_true")
    a = p.parse_args(argv)
    out = Path(a.out)
    command = f"python eval/validate.py --seed {a.seed} --n {a.n} --families {a.families}"
    if a.report_only:
        rows = json.loads((out / f"validation-seed{a.seed}.json").read_text())
    else:
        rows = run(a.seed, a.n, a.families.split(","), tuple(a.tools.split(",")), a.timeout, out)
    (out / f"validation-seed{a.seed}.md").write_text(markdown(rows, command))
    print(markdown(rows, command))
    return 0


if __name__ == "__main__":
    sys.exit(main())
