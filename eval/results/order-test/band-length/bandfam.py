"""band-family regret on a fresh seed: python bandfam.py SEED N OUT.json [FORCED_FROM.json]
with FORCED_FROM: only ours-auto is run, the forced rows taken from that file."""
import json, sys
from pathlib import Path
sys.path.insert(0, ".")
import numpy as np
from eval import regret, stress
seed, n, out = int(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
prev = {c["case"]: c["rows"] for c in json.loads(Path(sys.argv[4]).read_text())} if len(sys.argv) > 4 else None
shapes_ok = stress.available_shapes()
res = []
for i in range(n):
    case = stress.stress_case(i, seed, family="band", shapes_ok=shapes_ok)
    if prev is not None:
        rows = dict(prev[case.name]); rows.update(regret.run_case(case, tools=(regret.DEFAULT,), log=lambda *a: None))
    else:
        rows = regret.run_case(case, log=lambda *a: None)
    r, best = regret.regret(rows)
    res.append({"case": case.name, "regret": r, "rows": rows})
    print(case.name, "regret", r, {t: round(rows[t]["rms_permille"], 4) for t in rows if rows[t].get("rms_permille") is not None}, flush=True)
    out.write_text(json.dumps(res, indent=1, default=float))
rr = np.array([x["regret"] for x in res if x["regret"] is not None])
print(f"geomean {np.exp(np.log(rr).mean()):.4f} max {rr.max():.3f} over 1.5 {(rr > 1.5).sum()} n {len(rr)}")
