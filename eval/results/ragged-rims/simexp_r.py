"""One process per seed: forced orders 1-3, the default, and variants (env settings) of the default."""
import sys, os, json, time
sys.path.insert(0, ".")
import numpy as np
from eval import stress, regret
seed, cases, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
variants = [dict(kv.split("=") for kv in v.split(",")) for v in sys.argv[4:]]
idx = range(int(cases)) if "," not in cases and ":" not in cases else (
    [int(x) for x in cases.split(",")] if "," in cases else range(*map(int, cases.split(":"))))
ok = stress.available_shapes()
res = []
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok, ragged=float(os.environ.get("RAGGED_CASES", "0")))
    rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    g0, _ = regret.regret(rows)
    rec = {"case": c.name, "faces": int(len(c.F)), "auto": rows[regret.DEFAULT]["rms_permille"], "g_auto": g0,
           "s_auto": rows[regret.DEFAULT]["seconds"],
           "forced": {t: rows[t]["rms_permille"] for t in regret.FORCED},
           "forced_s": {t: rows[t]["seconds"] for t in regret.FORCED}, "variants": []}
    for v in variants:
        os.environ.update(v)
        r = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
        for k in v:
            del os.environ[k]
        rows2 = dict(rows); rows2[regret.DEFAULT] = r
        g, _ = regret.regret(rows2)
        rec["variants"].append({"env": v, "rms": r["rms_permille"], "g": g, "s": r["seconds"], "closed": r["holes_closed"] == r["holes"]})
    res.append(rec)
    print(c.name, rec["faces"], "auto", rec["auto"], round(g0, 3) if g0 else g0, rec["s_auto"], "|",
          " ".join(f"{v['rms']} {round(v['g'],3) if v['g'] else v['g']} {v['s']}" for v in rec["variants"]),
          "| forced", rec["forced"], flush=True)
    json.dump(res, open(out, "w"), indent=1)
G = lambda a: float(np.exp(np.log(np.array(a)).mean()))
base = [r["g_auto"] for r in res if r["g_auto"]]
print(f"seed {seed}: default {G(base):.4f} max {max(base):.3f} >1.5 {sum(b > 1.5 for b in base)}")
fast = [min(r["forced_s"].values()) for r in res]
print(f"  cost default {G([r['s_auto'] / f for r, f in zip(res, fast)]):.3f}")
for j, v in enumerate(variants):
    g = [r["variants"][j]["g"] for r in res if r["g_auto"] and r["variants"][j]["g"]]
    print(f"  {v}: {G(g):.4f} max {max(g):.3f} >1.5 {sum(x > 1.5 for x in g)}; cost {G([r['variants'][j]['s'] / f for r, f in zip(res, fast)]):.3f}")
