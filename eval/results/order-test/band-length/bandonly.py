"""ours-auto again on the band/torus cases of stored regret runs: python bandonly.py OUT.json BASE.json..."""
import json, sys, re
from pathlib import Path
sys.path.insert(0, ".")
import numpy as np
from eval import regret, stress
out = Path(sys.argv[1])
shapes_ok = stress.available_shapes()
res = []
for b in sys.argv[2:]:
    base = json.loads(Path(b).read_text())
    seed = int(re.search(r"seed(\d+)", b).group(1))
    for c in base["cases"]:
        if not re.search(r"band|torus", c["case"]):
            continue
        case = stress.stress_case(int(c["case"].split("-")[1]), seed, shapes_ok=shapes_ok)
        if case.name != c["case"]:
            print("skip", c["case"], case.name); continue
        rows = dict(c["rows"])
        rows.update(regret.run_case(case, tools=(regret.DEFAULT,), log=lambda *a: None))
        r, _ = regret.regret(rows)
        res.append({"case": c["case"], "regret": r, "old": c["regret"], "auto": rows["ours-auto"]["rms_permille"],
                    "forced": {t: rows[t]["rms_permille"] for t in regret.FORCED if t in rows}})
        print(c["case"], "regret", r, "was", c["regret"], flush=True)
        out.write_text(json.dumps(res, indent=1))
rr = np.array([x["regret"] for x in res if x["regret"] is not None and x["old"] is not None])
ro = np.array([x["old"] for x in res if x["regret"] is not None and x["old"] is not None])
print(f"geomean {np.exp(np.log(rr).mean()):.4f} (was {np.exp(np.log(ro).mean()):.4f}) max {rr.max():.3f} (was {ro.max():.3f}) over 1.5 {(rr > 1.5).sum()} (was {(ro > 1.5).sum()}) n {len(rr)}")
