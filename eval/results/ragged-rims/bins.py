import sys, numpy as np
sys.argv = ["ana.py", "731,733,270074373,569393493,541225744,922665491"]
exec(open("ana.py").read().split("if \"-v\"")[0])
bins = [0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 2, 100]
for lo, hi in zip(bins[:-1], bins[1:]):
    R = [r for r in rows if lo <= r["q"] < hi and r["n"] >= 3 and max(r["e"]) > 0]
    if not R: continue
    best = [int(np.argmin(r["e"])) + 1 for r in R]
    # mean log ratio of o3/o2 and o1/o2
    l32 = np.mean([np.log((r["e"][2] + 1e-3) / (r["e"][1] + 1e-3)) for r in R])
    l12 = np.mean([np.log((r["e"][0] + 1e-3) / (r["e"][1] + 1e-3)) for r in R])
    print(f"q [{lo},{hi}) n={len(R):3d} best1 {best.count(1):3d} best2 {best.count(2):3d} best3 {best.count(3):3d}  mean log(e3/e2) {l32:+.3f} log(e1/e2) {l12:+.3f}")
