import sys, os, json; sys.path.insert(0, ".")
import numpy as np
from eval import stress, regret
seed, n, shape = int(sys.argv[1]), sys.argv[2], sys.argv[3]
fams = sys.argv[4].split(",") if len(sys.argv) > 4 and sys.argv[4] else None
variants = sys.argv[5:] if len(sys.argv) > 5 else []
idx = range(int(n)) if "," not in n else [int(x) for x in n.split(",")]
ok = stress.available_shapes()
G = lambda a: float(np.exp(np.mean(np.log(a))))
res = {"base": []}; res.update({v: [] for v in variants})
out = []
for i in idx:
    fam = fams[i % len(fams)] if fams else None
    c = stress.stress_case(i, seed, shapes_ok=ok, family=fam, shape=None if shape == "any" else shape)
    os.environ.pop("CLIP", None)
    rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    g, _ = regret.regret(rows)
    res["base"].append(g)
    line = [c.name, "forced " + " ".join((f"{rows[t]['rms_permille']:.3f}" if rows[t].get('rms_permille') is not None else 'none') for t in regret.FORCED),
            f"base {rows[regret.DEFAULT]['rms_permille']:.3f} r {g:.3f}" if g else "base none"]
    rec = {"case": c.name, "forced": {t: rows[t]["rms_permille"] for t in regret.FORCED}, "base": rows[regret.DEFAULT]["rms_permille"], "g": {"base": g}}
    for v in variants:
        os.environ["CLIP"] = v
        r = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
        rows2 = dict(rows); rows2[regret.DEFAULT] = r
        g2, _ = regret.regret(rows2)
        res[v].append(g2)
        rec["g"][v] = g2
        line.append(f"clip{v} {r['rms_permille']:.3f} r {g2:.3f}" if g2 else f"clip{v} none")
    os.environ.pop("CLIP", None)
    out.append(rec)
    print(" | ".join(line), flush=True)
for k in res:
    g = [x for x in res[k] if x]
    print(k, "geomean %.4f max %.3f over1.5 %d n %d" % (G(g), max(g), sum(x > 1.5 for x in g), len(g)))
