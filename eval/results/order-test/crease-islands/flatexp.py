import sys, os, json; sys.path.insert(0, ".")
import numpy as np
from eval import stress, regret
import shellrepair.fill.patch as P
orig = P.fair_patch
FLAT = {"on": False}
def fp(X, F, nf, order=2, **kw):
    if FLAT["on"]:
        return X[nf:].copy(), None
    return orig(X, F, nf, order=order, **kw)
P.fair_patch = fp
seed, n = int(sys.argv[1]), sys.argv[2]
fam = sys.argv[3] if len(sys.argv) > 3 and sys.argv[3] else None
idx = range(int(n)) if "," not in n else [int(x) for x in n.split(",")]
ok = stress.available_shapes()
out = []
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok, family=fam)
    rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    FLAT["on"] = True
    fr = regret.run_case(c, tools=("ours-o1",), log=lambda *a: None)["ours-o1"]
    FLAT["on"] = False
    g, _ = regret.regret(rows)
    f = fr["rms_permille"] if regret._ok({"x": fr}, "x") else None
    rec = {"case": c.name, **{t: rows[t].get("rms_permille") for t in rows}, "flat": f, "regret": g}
    out.append(rec)
    print(c.name, " ".join(f"{t[5:]} {rows[t].get('rms_permille')}" for t in rows), "flat", f, "r %.3f" % g if g else "", flush=True)
json.dump(out, open(f"/tmp/s47/flat-{seed}-{fam}.json", "w"))
