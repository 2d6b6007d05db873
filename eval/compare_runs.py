"""Compare interleaved suite runs of two commits (eval/bench.py's bench.json).

Run ``.venv/bin/python eval/compare_runs.py --old A1.json A2.json --new B1.json B2.json``:
per tool, each case's time is the fastest of that commit's runs, and the
geometric mean over the cases of new / old is printed with the totals;
per run, the geometric mean of fillHoleNicely's time over ours. On this
shared machine single runs of the small cases swing by 30 % and more from
minute to minute, which is why the runs are interleaved (old, new, old,
new) and a peer that did not change is printed beside ours as the drift.
It prints and asserts nothing else.
"""

from __future__ import annotations

import argparse
import json

import numpy as np


def _rows(path):
    with open(path) as f:
        return {(r["case"], r["tool"]): r for r in json.load(f)["rows"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", nargs="+", required=True)
    ap.add_argument("--new", nargs="+", required=True)
    ap.add_argument("--ours", default="ours-auto,ours-o2")
    ap.add_argument("--peer", default="meshlib-nicely")
    args = ap.parse_args(argv)
    old = [_rows(p) for p in args.old]
    new = [_rows(p) for p in args.new]
    tools = args.ours.split(",") + [args.peer]
    cases = sorted({c for c, t in old[0] if t == tools[0]})

    def best(runs, case, tool):
        return min(r[(case, tool)]["seconds"] for r in runs)

    for tool in tools:
        o = np.array([best(old, c, tool) for c in cases])
        n = np.array([best(new, c, tool) for c in cases])
        print(f"{tool:16s} new/old geometric mean {np.exp(np.mean(np.log(n / o))):.3f}   "
              f"total old {o.sum():.2f} s, new {n.sum():.2f} s")
    for name, runs in (("old", old), ("new", new)):
        for i, r in enumerate(runs):
            parts = []
            for tool in args.ours.split(","):
                g = np.exp(np.mean(np.log([r[(c, args.peer)]["seconds"] / r[(c, tool)]["seconds"] for c in cases])))
                parts.append(f"{args.peer}/{tool} {g:.3f}")
            print(f"{name} run {i + 1}: " + ", ".join(parts))


if __name__ == "__main__":
    main()
