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


def case_rms(rec, order_of):
    """The case's RMS (per mille) with each piece of the default's added
    surface (keyed by the input loops it touches) taken from the run at
    ``order_of(key)`` where that run has the same piece; the default's own
    piece where ``order_of`` gives None or the run has no such piece."""
    runs = rec["runs"]
    A = M = 0.0
    for key, (a, ms) in runs["auto"]["comps"].items():
        o = order_of(key)
        if o is not None and key in runs[str(o)]["comps"]:
            a, ms = runs[str(o)]["comps"][key]
        A += a; M += a * ms
    return 1000 * math.sqrt(M / A) / rec["diag"] if A > 0 else None


def first_loop(key):
    """The first input loop of a piece's key."""
    return int(key.split(",")[0])


def single_loop(key):
    """The loop of a piece that touches one loop, else None."""
    return None if "," in key else int(key)


def simulate(rec, policy):
    dec = {l: policy(c) for l, c in calls_of(rec["probes"]).items()}
    return case_rms(rec, lambda key: dec.get(first_loop(key)))


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



def oracle(rec):
    runs = rec["runs"]
    return case_rms(rec, lambda key: min((o for o in "123" if key in runs[o]["comps"]),
                                         key=lambda o: runs[o]["comps"][key][1], default=None))


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
        def order_of(key):
            o = dec.get(single_loop(key))
            if o is None and fallback == "current" and first_loop(key) in calls:
                o = current(calls[first_loop(key)])
            return o
        cur = simulate(rec, current)
        col = case_rms(rec, order_of)
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
        out.append((name, regret(rec, rec["runs"]["auto"]["rms"]), regret(rec, simulate(rec, current)),
                    regret(rec, case_rms(rec, lambda key: dec.get(single_loop(key))))))
    return out


def paired(calls, z=1.0, n=3, every=False):
    for call in calls:
        errs = take(call, n)
        if len(errs) >= 2:
            L = np.log(np.maximum(np.array(errs), 1e-300))      # (tests, 3)
            d = L - L[:, [1]]                                     # against order 2
            m = d.mean(axis=0)
            se = d.std(axis=0, ddof=1) / np.sqrt(len(d))
            best, score = 2, 0.0
            for k in (0, 2):
                ok = (d[:, k] < 0).all() if every else (m[k] + z * se[k] < 0)
                if ok and m[k] < score:
                    best, score = k + 1, m[k]
            return best
    return None


POLICIES.update({"z0": lambda c: paired(c, 0.0), "z0.5": lambda c: paired(c, 0.5),
                 "z1": lambda c: paired(c, 1.0), "z2": lambda c: paired(c, 2.0), "every": lambda c: paired(c, every=True),
                 "o2": lambda c: 2})


if __name__ == "__main__":
    main()


def extrap_sim(cfile, kfile, target=1.0, which="raw", mode="collar-first"):
    recs = {r["case"]: r for r in json.load(open(cfile))}
    ks = {r["case"]: r for r in json.load(open(kfile))}
    out = []
    for name, rec in recs.items():
        if rec["runs"]["auto"]["rms"] is None or any(rec["runs"][k]["rms"] is None for k in "123"):
            continue
        calls = calls_of(rec["probes"])
        dec = {}
        for h in ks[name]["holes"]:
            a, b = h["tests"][0], h["tests"][1]
            if not a or not b or a["m"] == b["m"]:
                continue
            ea, eb = np.log(np.maximum(a[which], 1e-300)), np.log(np.maximum(b[which], 1e-300))
            slope = (eb - ea) / np.log(b["m"] / a["m"])
            pred = eb + slope * np.log(target / 0.3)
            dec[h["loop"]] = pick(list(pred))
        for l, c in calls.items():
            if l not in dec or mode == "probes-first":
                o = current(c)
                if o is not None:
                    dec[l] = o
        out.append((name, regret(rec, rec["runs"]["auto"]["rms"]), regret(rec, simulate(rec, current)),
                    regret(rec, case_rms(rec, lambda key: dec.get(single_loop(key))))))
    return out
