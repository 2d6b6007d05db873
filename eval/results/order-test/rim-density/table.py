"""Per case, the regret of several trees' defaults against the forced orders of one eval/regret.py run.

``python table.py REGRET.json LABEL=AUTO.json [LABEL=AUTO.json ...]``: REGRET.json gives the forced
orders (``ours-o1/2/3``, the same code in every tree measured here: the forced fill does not read the
test); each AUTO.json (``autorows.py``) a tree's default on the same cases. Regret as eval/regret.py
takes it: (default + 0.05 per mille) / (best forced that closed every hole + 0.05).
"""

import json
import math
import sys

FLOOR = 0.05
run = json.load(open(sys.argv[1]))
trees = [(a.split("=", 1)[0], json.load(open(a.split("=", 1)[1]))) for a in sys.argv[2:]]
print("| case | best forced ‰ | " + " | ".join(f"{t} ‰ | {t} regret" for t, _ in trees) + " |")
print("|---|---:|" + "---:|---:|" * len(trees))
reg = {t: [] for t, _ in trees}
for c in run["cases"]:
    rows = c["rows"]
    forced = [rows[t]["rms_permille"] for t in ("ours-o1", "ours-o2", "ours-o3")
              if rows.get(t, {}).get("status") == "ok" and rows[t].get("holes_closed") == rows[t].get("holes")]
    best = min(forced)
    cells = []
    for t, auto in trees:
        a = auto[c["case"]]["rms_permille"]
        r = (a + FLOOR) / (best + FLOOR)
        reg[t].append(r)
        cells.append(f"{a:.4g} | {r:.3f}")
    print(f"| {c['case']} | {best:.4g} | " + " | ".join(cells) + " |")
print()
for t, v in reg.items():
    g = math.exp(sum(map(math.log, v)) / len(v))
    print(f"- {t}: regret geometric mean {g:.4f}, max {max(v):.3f}, over 1.5 on {sum(x > 1.5 for x in v)}")
