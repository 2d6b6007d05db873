import json, sys, glob
import numpy as np
G = lambda a: float(np.exp(np.mean(np.log(a))))
seeds = sys.argv[2].split(",")
for tag in sys.argv[1].split(","):
    recs = {s: json.load(open(f"/tmp/s44/exp/{tag}-{s}.json")) for s in seeds if glob.glob(f"/tmp/s44/exp/{tag}-{s}.json")}
    nv = len(next(iter(recs.values()))[0]["variants"])
    for j in range(-1, nv):
        allg, allc, per = [], [], []
        for s, rs in recs.items():
            g = [r["g_auto"] if j < 0 else r["variants"][j]["g"] for r in rs if r["g_auto"] and (j < 0 or r["variants"][j]["g"])]
            c = [(r["s_auto"] if j < 0 else r["variants"][j]["s"]) / min(r["forced_s"].values()) for r in rs]
            allg += g; allc += c; per.append(f"{s}:{G(g):.3f}")
        name = "default" if j < 0 else ",".join(f"{k}={v}" for k, v in rs[0]["variants"][j]["env"].items())
        print(f"{tag} {name[:70]:70s} regret {G(allg):.4f} max {max(allg):.2f} >1.5 {sum(x > 1.5 for x in allg):2d} cost {G(allc):.2f} max {max(allc):.1f} | {' '.join(per)}")
