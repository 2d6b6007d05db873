import sys, json, numpy as np
sys.argv = ["x"]
exec(open("aggregate.py").read().split("sets = ")[0])
def geo_of(probes):
    return {o: float(np.exp(np.mean([0.5*np.log(max(q["sq"][o]/q["n"],1e-300)) for q in probes])))**2 for o in "123"}
def make(X):
    stats = {"saved": 0, "probes": 0}
    def f(r):
        p = final_pass(r)
        if p is None: return 2 if not r["test"] else choose(r["test"], r)
        pr = p["probes"]
        stats["probes"] += len(pr)
        first = geo_of(pr[:1])
        s = sorted(first.values())
        if len(pr) >= 2 and s[1] > X * X * s[0]:     # margin in RMS: runner-up / best > X
            stats["saved"] += len(pr) - 1
            return choose(first, r)
        return choose(geo_of(pr), r)
    return f, stats
for files in (["holes-seed11.json","holes-seed12.json","holes-seed13.json","holes-seed14.json"], ["holes-seed731.json","holes-seed733.json","holes-seed735.json"]):
    R = load(files)
    print(files[0], len(R))
    for X in (1e9, 3.0, 2.0, 1.5, 1.25):
        f, st = make(X)
        ph = per_hole(R, f); cl = case_level(R, f)
        print(f"   margin {X:>6}: per-hole {ph} case-level {cl}  test holes saved {st['saved']} of {st['probes']}")
