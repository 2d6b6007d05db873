import sys, json, numpy as np
sys.argv = ["x"]
exec(open("aggregate.py").read().split("sets = ")[0])
def geo(r, p):
    return {o: float(np.exp(np.mean([0.5*np.log(max(q["sq"][o]/q["n"],1e-300)) for q in p["probes"]])))**2 for o in "123"}
def unanimous(r, p):
    E = geo(r, p)
    w = min(("1","2","3"), key=lambda o: (E[o], o != "2", o))
    if w != "2":
        if not all(q["sq"][w] < q["sq"]["2"] for q in p["probes"]):
            return {"1":2.0,"2":1.0,"3":2.0}
    return E
def tstat(z):
    def f(r, p):
        E = geo(r, p)
        w = min(("1","2","3"), key=lambda o: (E[o], o != "2", o))
        if w == "2": return E
        l = np.array([0.5*np.log(max(q["sq"][w],1e-300)/max(q["sq"]["2"],1e-300)) for q in p["probes"]])
        if len(l) < 2: return E
        m, s = l.mean(), l.std(ddof=1) / np.sqrt(len(l))
        if -m < z * s: return {"1":2.0,"2":1.0,"3":2.0}
        return E
    return f
def oracle23(r):
    t=r["truth"]; return int(min("123", key=lambda o:t[o]))
for files in (["holes-seed11.json","holes-seed12.json","holes-seed13.json","holes-seed14.json"], ["holes-seed731.json","holes-seed733.json","holes-seed735.json"]):
    R = load(files)
    print(files[0], len(R))
    for name, agg in (("geo (now)", geo), ("unanimous vs 2", unanimous), ("t z=0.5", tstat(0.5)), ("t z=1", tstat(1)), ("t z=2", tstat(2))):
        f = pick_with(agg)
        print(f"   {name:16s} per-hole {per_hole(R, f)}  case-level {case_level(R, f)}")
    print("   always 2", per_hole(R, lambda r: 2), case_level(R, lambda r: 2))
    print("   oracle", per_hole(R, oracle23), case_level(R, oracle23))
