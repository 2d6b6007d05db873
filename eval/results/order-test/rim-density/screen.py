"""Screen: what the order test's verdicts are worth by the scale of its test holes.

Reads the per-hole records of ``../hole-screens/holes-seedS.json`` (each hole
filled alone at orders 1, 2, 3 at `c03ee53`: its RMS to the truth per order,
the test's pooled errors, how many test holes and at which scale) and pools
the holes of each case by their new vertices into an approximate per-case
RMS for each policy; prints the geometric mean of the regret
((RMS + 0.05) / (best forced order's RMS + 0.05)) over the cases, the
design seeds (11-14) and the development seeds (731, 733, 735) apart.

Run from the repository root: ``python eval/results/order-test/rim-density/screen.py``.
"""

import collections
import json
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
FLOOR = 0.05


def policies(h):
    e = {int(k): v for k, v in h["test"].items()} if h.get("test") else None
    pick = min(e, key=e.get) if e else 2
    sc = h.get("scale") or 1.0
    few = (h.get("probes") or 0) < 2
    return {"the test (as at c03ee53)": pick, "order 1": 1, "order 2": 2, "order 3": 3,
            "quarter -> order 2": 2 if sc <= 0.25 else pick,
            "quarter -> order 1": 1 if sc <= 0.25 else pick,
            "half or quarter -> order 2": 2 if sc < 1 else pick,
            "one test hole -> order 2": 2 if few else pick,
            "quarter or one test hole -> order 2 (taken)": 2 if (sc <= 0.25 or few) else pick}


def main():
    for name, group in (("design", (11, 12, 13, 14)), ("development", (731, 733, 735))):
        cases = collections.defaultdict(list)
        count = collections.Counter()
        for s in group:
            for h in json.loads((HERE.parent / "hole-screens" / f"holes-seed{s}.json").read_text()):
                if h.get("truth"):
                    cases[h["case"]].append(h)
                    count[(h.get("scale"), h.get("probes"))] += 1
        res = collections.defaultdict(list)
        for hs in cases.values():
            tot = sum(h["n"] for h in hs)
            if tot == 0:
                continue

            def rms(choose):
                return math.sqrt(sum(h["n"] * h["truth"][str(choose(h))] ** 2 for h in hs) / tot)

            best = min(rms(lambda h, o=o: o) for o in (1, 2, 3))
            for p in policies(hs[0]):
                res[p].append((rms(lambda h, p=p: policies(h)[p]) + FLOOR) / (best + FLOOR))
        print(f"{name} seeds {group}: {len(res['order 1'])} cases; holes by (scale, test holes): "
              + ", ".join(f"{k}: {v}" for k, v in sorted(count.items(), key=str)))
        for p, v in res.items():
            g = math.exp(sum(map(math.log, v)) / len(v))
            print(f"  {p:45s} geometric mean {g:.4f}  max {max(v):.3f}  over 1.5: {sum(x > 1.5 for x in v)}")


if __name__ == "__main__":
    main()
