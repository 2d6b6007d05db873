import json, sys, math, glob
import numpy as np
from sim import calls_of, current, gm, regret, take
recs = []
for f in sorted(glob.glob("c-*[0-9].json")):
    recs += json.load(open(f))
for r in recs:
    if r["runs"]["auto"]["rms"] is None or any(r["runs"][k]["rms"] is None for k in "123"):
        continue
    g = regret(r, r["runs"]["auto"]["rms"])
    if g < 1.15:
        continue
    print(r["case"], "regret", round(g, 3), {k: round(v["rms"], 3) for k, v in r["runs"].items()})
    calls = calls_of(r["probes"])
    comps = r["runs"]["auto"]["comps"]
    totA = sum(a for a, _ in comps.values())
    for key, (a, ms) in sorted(comps.items(), key=lambda kv: -kv[1][0]):
        per = {o: r["runs"][o]["comps"].get(key) for o in "123"}
        if a / totA < 0.05:
            continue
        ls = [int(x) for x in key.split(",")]
        c = calls.get(ls[0])
        ch = current(c) if c else None
        est = None
        feat = None
        if c:
            for call in c:
                e = take(call)
                if len(e) >= 2:
                    est = [round(x, 5) for x in gm(e)]
                    break
            feat = [q.get("feat") for q in c[0]][0]
        auto_o = [o for o in "123" if per[o] and abs(per[o][1] - ms) <= 1e-9 * max(ms, 1e-300)]
        print(f"   loops {key} k {[r['loops'][l] for l in ls]} share {a / totA:.2f} auto-is {auto_o} sim {ch} "
              f"hole-rms {[round(1000 * math.sqrt(per[o][1]) / r['diag'], 2) if per[o] else None for o in '123']} "
              f"test {est} feat {np.round(feat, 3) if feat else None}")
