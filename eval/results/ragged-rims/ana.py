import json, sys, math, numpy as np
from sim import calls_of, current, case_rms, regret, single_loop, first_loop
seeds = sys.argv[1].split(",")
rows = []
cases = []
for s in seeds:
    C = {r["case"]: r for r in json.load(open(f"c-{s}.json"))}
    S = {r["case"]: r for r in json.load(open(f"sp-{s}.json"))}
    for name, rec in C.items():
        if rec["runs"]["auto"]["rms"] is None or any(rec["runs"][k]["rms"] is None for k in "123"):
            continue
        calls = calls_of(rec["probes"])
        sp = {h["loop"]: h for h in S.get(name, {"holes": []})["holes"]}
        cases.append((rec, calls, sp))
        for l, h in sp.items():
            key = str(l)
            errs = [rec["runs"][o]["comps"].get(key, [0, None])[1] for o in "123"]
            if None in errs: continue
            a = rec["runs"]["2"]["comps"][key][0]
            cur = current(calls[l]) if l in calls else None
            rows.append(dict(case=name, loop=l, k=h["k"], n=h["n"], q=h["s23"] / max(h["s12"], 1e-300), s12e=h["s12"] / h["edge"],
                             e=[math.sqrt(x) / rec["diag"] * 1000 for x in errs], cur=cur, area=a))
if "-v" in sys.argv:
    for r in rows:
        if r["n"] >= 5:
            best = int(np.argmin(r["e"])) + 1
            print(f"{r['case'][:30]:30s} {r['loop']:4d} k{r['k']:5d} n{r['n']:5d} q {r['q']:.3f} s12/e {r['s12e']:.3f} best {best} cur {r['cur']} e " + " ".join(f"{x:.4f}" for x in r["e"]))

def evaluate(policy):
    g = []
    for rec, calls, sp in cases:
        def order_of(key):
            l = single_loop(key)
            if l is None: return None
            return policy(l, calls.get(l), sp.get(l))
        g.append(regret(rec, case_rms(rec, order_of)))
    g = np.array(g)
    return f"{np.exp(np.log(g).mean()):.4f} max {g.max():.2f} >1.5 {(g>1.5).sum()} (n={len(g)})"

def cur(l, c, h):
    return current(c) if c else None
print("auto-sim current", evaluate(cur))
print("o2 all", evaluate(lambda l, c, h: 2))
for t in (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0):
    print(f"q<{t} ->3 else 2", evaluate(lambda l, c, h: None if h is None else (3 if h["s23"] < t * h["s12"] else 2)))
    print(f"q<{t} ->3 else cur", evaluate(lambda l, c, h: None if h is None else (3 if h["s23"] < t * h["s12"] else cur(l, c, h))))
    print(f"cur, but 3 only if q<{t}", evaluate(lambda l, c, h: (lambda o: 2 if (o == 3 and h is not None and h["s23"] >= t * h["s12"]) else o)(cur(l, c, h))))

def percase(policy):
    out = []
    for rec, calls, sp in cases:
        def order_of(key):
            l = single_loop(key)
            if l is None: return None
            return policy(l, calls.get(l), sp.get(l))
        out.append(regret(rec, case_rms(rec, order_of)))
    return out
if "-c" in sys.argv:
    A = percase(lambda l, c, h: None if h is None else (3 if h["s23"] < 0.3 * h["s12"] else 2))
    B = percase(lambda l, c, h: (lambda o: 2 if (o == 3 and h is not None and h["s23"] >= 1.0 * h["s12"]) else o)(cur(l, c, h)))
    for (rec, calls, sp), a, b in zip(cases, A, B):
        real = regret(rec, rec["runs"]["auto"]["rms"])
        if max(a, b) > 1.2:
            print(f"{rec['case'][:36]:36s} q0.3 {a:7.3f}  cur+dep {b:7.3f}  real {real:7.3f}  forced " + " ".join(f"{rec['runs'][o]['rms']:.3f}" for o in "123"))
