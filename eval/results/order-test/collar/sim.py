import json, sys, math
import numpy as np
from collections import defaultdict, OrderedDict
FLOOR = 0.05


def calls_of(probes):
    """{loop: [ [probes of call 1], [call 2], ...] } in order."""
    out = defaultdict(OrderedDict)
    for q in probes:
        out[q["loop"]].setdefault(round(q["r"], 12), []).append(q)
    return {l: [sorted(v, key=lambda q: q["sidx"]) for v in c.values()] for l, c in out.items()}


def gm(errs):
    e = np.array(errs)
    return np.exp(np.log(np.maximum(e, 1e-300)).mean(axis=0))


def pick(score, tie=1):
    """argmin over orders 1..3, ties to order 2 then lower (index)."""
    best = min(score)
    cands = [i for i in range(3) if score[i] == best]
    return 2 if 1 in cands else cands[0] + 1


def take(call, n=3, key=lambda q: q["sidx"]):
    qs = sorted(call, key=key)[:n]
    return [q["err"] for q in qs if "err" in q]


def current(calls, n=3, key=lambda q: q["sidx"], agg=gm):
    for call in calls:
        errs = take(call, n, key)
        if len(errs) >= 2:
            return pick(list(agg(errs)))
    return None


def simulate(rec, policy):
    runs = rec["runs"]
    dec = {l: policy(c) for l, c in calls_of(rec["probes"]).items()}
    A = M = 0.0
    for key, (a, ms) in runs["auto"]["comps"].items():
        ls = [int(x) for x in key.split(",")]
        o = dec.get(ls[0])
        if o is not None and key in runs[str(o)]["comps"]:
            a, ms = runs[str(o)]["comps"][key]
        A += a; M += a * ms
    return 1000 * math.sqrt(M / A) / rec["diag"] if A > 0 else None


def recomb(rec, run):
    A = M = 0.0
    for key, (a, ms) in rec["runs"][run]["comps"].items():
        A += a; M += a * ms
    return 1000 * math.sqrt(M / A) / rec["diag"] if A > 0 else None


def regret(rec, rms):
    best = min(rec["runs"][k]["rms"] for k in "123" if rec["runs"][k]["closed"] and rec["runs"][k]["rms"] is not None)
    return (rms + FLOOR) / (best + FLOOR)


POLICIES = {
    "current": current,
    "similar3": lambda c: current(c, 3, key=lambda q: (q["d"], q["sidx"])),
    "all9": lambda c: current(c, 99),
    "minimax3": lambda c: current(c, 3, agg=lambda e: np.max(np.array(e) / np.array(e).min(axis=1, keepdims=True), axis=0)),
    "minimax9": lambda c: current(c, 99, agg=lambda e: np.max(np.array(e) / np.array(e).min(axis=1, keepdims=True), axis=0)),
    "meanreg9": lambda c: current(c, 99, agg=lambda e: gm(np.array(e) / np.array(e).min(axis=1, keepdims=True))),
    "similar5": lambda c: current(c, 5, key=lambda q: (q["d"], q["sidx"])),
    "o2": lambda c: 2,
}

def main():
    recs = []
    for f in sys.argv[1:]:
        recs += json.load(open(f))
    names = list(POLICIES)
    G = {n: [] for n in names}
    Gauto = []
    recs = [r for r in recs if r["runs"]["auto"]["rms"] is not None and all(r["runs"][k]["rms"] is not None for k in "123")]
    for rec in recs:
        auto = rec["runs"]["auto"]["rms"]
        row = [rec["case"][:34].ljust(34), f"auto {regret(rec, auto):.3f} (sim-recomb {recomb(rec,'auto')/auto:.3f})"]
        Gauto.append(regret(rec, auto))
        for n in names:
            s = simulate(rec, POLICIES[n])
            g = regret(rec, s) if s else float("nan")
            G[n].append(g)
            row.append(f"{n} {g:.3f}")
        print(" | ".join(row))
    gmean = lambda a: float(np.exp(np.nanmean(np.log(a))))
    print("auto actual", round(gmean(Gauto), 4), "max", round(max(Gauto), 3), ">1.5", sum(g > 1.5 for g in Gauto))
    for n in names:
        a = np.array(G[n])
        print(n.ljust(10), round(gmean(a), 4), "max", round(np.nanmax(a), 3), ">1.5", int((a > 1.5).sum()))


def agree2(calls):
    for call in calls:
        errs = take(call, 2)
        if len(errs) >= 2:
            if pick(errs[0]) == pick(errs[1]):
                return pick(list(gm(errs)))
            errs = take(call, 3)
            return pick(list(gm(errs)))
    return current(calls)


POLICIES.update({"first2": lambda c: current(c, 2), "agree2": agree2, "first4": lambda c: current(c, 4),
                 "first5": lambda c: current(c, 5)})
for k in ("all9", "meanreg9", "similar5", "minimax3"):
    POLICIES.pop(k)

if __name__ == "__main__":
    main()


def oracle(rec):
    runs = rec["runs"]
    A = M = 0.0
    for key, (a, ms) in runs["auto"]["comps"].items():
        opts = [runs[o]["comps"][key] for o in "123" if key in runs[o]["comps"]]
        if opts:
            a, ms = min(opts, key=lambda t: t[1])
        A += a; M += a * ms
    return 1000 * math.sqrt(M / A) / rec["diag"] if A > 0 else None


def oracle_report(files):
    recs = []
    for f in files:
        recs += json.load(open(f))
    recs = [r for r in recs if r["runs"]["auto"]["rms"] is not None and all(r["runs"][k]["rms"] is not None for k in "123")]
    g = [regret(r, oracle(r)) for r in recs]
    a = [regret(r, r["runs"]["auto"]["rms"]) for r in recs]
    print("oracle per hole", round(float(np.exp(np.mean(np.log(g)))), 4), "auto", round(float(np.exp(np.mean(np.log(a)))), 4))
    for r, x, y in zip(recs, g, a):
        if y > 1.15:
            print("  ", r["case"], "auto", round(y, 3), "oracle", round(x, 3))


def collar_policy_sim(cfile, kfile, which="raw", fi=0, fallback="current"):
    """Per case: (auto actual regret, sim-current regret, collar-policy regret)."""
    recs = {r["case"]: r for r in json.load(open(cfile))}
    ks = {r["case"]: r for r in json.load(open(kfile))}
    out = []
    for name, rec in recs.items():
        if rec["runs"]["auto"]["rms"] is None or any(rec["runs"][k]["rms"] is None for k in "123"):
            continue
        calls = calls_of(rec["probes"])
        dec = {}
        for h in ks[name]["holes"]:
            t = h["tests"][fi] if fi is not None else next((x for x in h["tests"] if x), None)
            if t is None:
                continue
            e = t[which]
            dec[h["loop"]] = pick(e)
        def pol_sim(rec, dec):
            runs = rec["runs"]
            A = M = 0.0
            for key, (a, ms) in runs["auto"]["comps"].items():
                ls = [int(x) for x in key.split(",")]
                o = dec.get(ls[0]) if len(ls) == 1 else None
                if o is None and fallback == "current" and ls[0] in calls:
                    o = current(calls[ls[0]])
                if o is not None and key in runs[str(o)]["comps"]:
                    a, ms = runs[str(o)]["comps"][key]
                A += a; M += a * ms
            return 1000 * math.sqrt(M / A) / rec["diag"]
        cur = simulate(rec, current)
        col = pol_sim(rec, dec)
        out.append((name, regret(rec, rec["runs"]["auto"]["rms"]), regret(rec, cur), regret(rec, col)))
    return out


def combo_sim(cfile, kfile, mode, fi=0, which="raw"):
    recs = {r["case"]: r for r in json.load(open(cfile))}
    ks = {r["case"]: r for r in json.load(open(kfile))}
    out = []
    for name, rec in recs.items():
        if rec["runs"]["auto"]["rms"] is None or any(rec["runs"][k]["rms"] is None for k in "123"):
            continue
        calls = calls_of(rec["probes"])
        col = {h["loop"]: h["tests"][fi][which] for h in ks[name]["holes"] if h["tests"][fi]}
        dec = {}
        for l in set(calls) | set(col):
            errs = None
            if l in calls:
                for call in calls[l]:
                    e = take(call)
                    if len(e) >= 2:
                        errs = e
                        break
            if mode == "untold":
                dec[l] = pick(list(gm(errs))) if errs else (pick(col[l]) if l in col else None)
            elif mode == "extra":
                ee = (errs or []) + ([col[l]] if l in col else [])
                dec[l] = pick(list(gm(ee))) if len(ee) >= 2 else (pick(col[l]) if l in col else None)
            elif mode == "extra2":
                ee = (errs or []) + ([col[l]] if l in col else [])
                dec[l] = pick(list(gm(ee))) if len(ee) >= 2 else None
        runs = rec["runs"]
        A = M = 0.0
        for key, (a, ms) in runs["auto"]["comps"].items():
            ls = [int(x) for x in key.split(",")]
            o = dec.get(ls[0]) if len(ls) == 1 else None
            if o is not None and key in runs[str(o)]["comps"]:
                a, ms = runs[str(o)]["comps"][key]
            A += a; M += a * ms
        out.append((name, regret(rec, rec["runs"]["auto"]["rms"]), regret(rec, simulate(rec, current)),
                    regret(rec, 1000 * math.sqrt(M / A) / rec["diag"])))
    return out
