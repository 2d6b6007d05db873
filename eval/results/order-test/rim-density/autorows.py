"""The default (ours-auto) alone on stress cases 0..n-1 of a seed, its rows saved: the same cases
repaired by another tree's default, to set beside the forced orders of one eval/regret.py run.

Run from the root of the tree to measure: ``python PATH/autorows.py SEED N OUT.json``.
"""
import json, sys
sys.path.insert(0, ".")
from eval import regret, stress
seed, n, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
shapes_ok = stress.available_shapes()
res = {}
for i in range(n):
    case = stress.stress_case(i, seed, shapes_ok=shapes_ok)
    rows = regret.run_case(case, tools=(regret.DEFAULT,), log=lambda *a: None)
    res[case.name] = rows[regret.DEFAULT]
    print(case.name, rows[regret.DEFAULT].get("rms_permille"), flush=True)
    json.dump(res, open(out, "w"), indent=1)
