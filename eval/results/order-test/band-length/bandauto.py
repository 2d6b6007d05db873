"""auto only on band-family cases: python bandauto.py SEED N OUT.json"""
import json, sys
from pathlib import Path
sys.path.insert(0, ".")
from eval import regret, stress
seed, n, out = int(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
shapes_ok = stress.available_shapes()
res = {}
for i in range(n):
    case = stress.stress_case(i, seed, family="band", shapes_ok=shapes_ok)
    rows = regret.run_case(case, tools=(regret.DEFAULT,), log=lambda *a: None)
    res[case.name] = rows[regret.DEFAULT]
    print(case.name, rows[regret.DEFAULT].get("rms_permille"), flush=True)
    out.write_text(json.dumps(res, indent=1, default=float))
