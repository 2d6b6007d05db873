"""Screen: other ways to pool the test holes' errors into one per order.

Usage, from this folder: ``python aggregate.py DESIGN.json,... VALIDATION.json,...``.
Pooled (the test's: all removed vertices' squared distances), each test
hole's mean square averaged, and test holes weighted by how like the real
hole's their convergence is (exp(-p |log(d23/d12)_test - log(d23/d12)_hole|)).
Per hole and per case as in score.py.
"""
import json, sys
import numpy as np
FL = 0.05
def load(files):
    R = []
    for f in files: R += json.load(open(f))
    return [r for r in R if r["k"] >= 8 and "-band-" not in r["case"]]
def final_pass(r):
    if not r["test"]: return None
    for p in r["passes"]:
        if p["errors"] and all(abs(1e3 * p["errors"][o] / r["diag"] - r["test"][o]) <= 1e-9 * max(1, r["test"][o]) for o in "123"):
            return p
    return None
def reg(r, o):
    t = r["truth"]; return (t[str(o)] + FL) / (min(t.values()) + FL)
def choose(E, r):
    p = int(min(("1", "2", "3"), key=lambda o: (E[o], o != "2", o)))
    if p == 3 and r["d23"] > r["d12"]: return 2
    return p
def agg_pooled(r, p):
    n = sum(q["n"] for q in p["probes"])
    return {o: sum(q["sq"][o] for q in p["probes"]) / n for o in "123"}
def agg_sim(power):
    def f(r, p):
        rho = np.log(max(r["d23"], 1e-300) / max(r["d12"], 1e-300))
        w = []
        for q in p["probes"]:
            rq = np.log(max(q["d23"], 1e-300) / max(q["d12"], 1e-300))
            w.append(np.exp(-power * abs(rq - rho)))
        w = np.array(w)
        n = sum(wj * q["n"] for wj, q in zip(w, p["probes"]))
        return {o: sum(wj * q["sq"][o] for wj, q in zip(w, p["probes"])) / n for o in "123"}
    return f
def agg_permean(r, p):   # each test hole its own mean square, averaged
    return {o: np.mean([q["sq"][o] / q["n"] for q in p["probes"]]) for o in "123"}
def pick_with(agg):
    def f(r):
        p = final_pass(r)
        if p is None: return 2 if not r["test"] else choose(r["test"], r)
        return choose(agg(r, p), r)
    return f
def per_hole(R, f):
    g = np.array([reg(r, f(r)) for r in R]); return round(float(np.exp(np.log(g).mean())), 4), int((g > 1.5).sum())
def case_level(R, f):
    cases = {}
    for r in R: cases.setdefault(r["case"], []).append(r)
    out = []
    for c, H in cases.items():
        w = np.array([h["n"] for h in H], float)
        def rms(sel): return np.sqrt(np.sum(w * np.array([h["truth"][str(sel(h))] ** 2 for h in H])) / w.sum())
        best = min(rms(lambda h, o=o: o) for o in (1, 2, 3))
        out.append((rms(f) + FL) / (best + FL))
    out = np.array(out)
    return round(float(np.exp(np.log(out).mean())), 4), round(float(out.max()), 2), int((out > 1.5).sum())
sets = [a.split(",") for a in sys.argv[1:]]
for files in sets:
    R = load(files)
    miss = sum(1 for r in R if r["test"] and final_pass(r) is None)
    print(files[0], "...", len(R), "holes; final pass not found", miss)
    for name, agg in (("pooled (now)", agg_pooled), ("per-probe mean", agg_permean), ("sim 0.5", agg_sim(0.5)), ("sim 1", agg_sim(1.0)), ("sim 2", agg_sim(2.0)), ("sim 4", agg_sim(4.0))):
        f = pick_with(agg)
        print(f"   {name:16s} per-hole {per_hole(R, f)}  case-level {case_level(R, f)}")
