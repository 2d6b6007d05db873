"""One process per seed: forced orders 1-3, the default, and the default with order 3's departs check off."""
import sys, os, json
sys.path.insert(0, ".")
import numpy as np
from eval import stress, regret
seed, n, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
ok = stress.available_shapes()
res = []
for i in range(n):
    c = stress.stress_case(i, seed, shapes_ok=ok)
    rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    os.environ["DEPARTS_OFF"] = "1"
    off = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
    del os.environ["DEPARTS_OFF"]
    g_on, _ = regret.regret(rows)
    rows2 = dict(rows); rows2[regret.DEFAULT] = off
    g_off, _ = regret.regret(rows2)
    res.append({"case": c.name, "on": g_on, "off": g_off, "auto_on": rows[regret.DEFAULT]["rms_permille"], "auto_off": off["rms_permille"],
                "forced": {t: rows[t]["rms_permille"] for t in regret.FORCED}})
    print(c.name, g_on, g_off, flush=True)
    json.dump(res, open(out, "w"), indent=1)
on = np.array([r["on"] for r in res if r["on"] and r["off"]]); off = np.array([r["off"] for r in res if r["on"] and r["off"]])
print(f"seed {seed}: departs on {np.exp(np.log(on).mean()):.4f} (max {on.max():.3f}, >1.5 {(on > 1.5).sum()}), off {np.exp(np.log(off).mean()):.4f} (max {off.max():.3f}, >1.5 {(off > 1.5).sum()})")
