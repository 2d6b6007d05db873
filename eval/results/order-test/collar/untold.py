import json, sys, math, glob
import numpy as np
from sim import calls_of
recs = []
for f in sys.argv[1:] or sorted(glob.glob("c-*[0-9].json")):
    recs += json.load(open(f))
rows = []
for r in recs:
    if r["runs"]["auto"]["rms"] is None or any(r["runs"][k]["rms"] is None for k in "123"):
        continue
    calls = calls_of(r["probes"])
    comps = r["runs"]["auto"]["comps"]
    totA = sum(a for a, _ in comps.values())
    for key, (a, ms) in comps.items():
        ls = [int(x) for x in key.split(",")]
        if len(ls) != 1 or ls[0] in calls or r["loops"][ls[0]] < 8:
            continue
        per = {o: r["runs"][o]["comps"].get(key) for o in "123"}
        if any(v is None for v in per.values()):
            continue
        auto_o = [o for o in "123" if abs(per[o][1] - ms) <= 1e-9 * max(ms, 1e-300)]
        rms = [1000 * math.sqrt(per[o][1]) / r["diag"] for o in "123"]
        rows.append((r["case"], ls[0], r["loops"][ls[0]], a / totA, auto_o, rms))
for row in sorted(rows, key=lambda t: -t[3]):
    if row[3] >= 0.02:
        print(row[0][:36].ljust(36), "loop", row[1], "k", row[2], f"share {row[3]:.2f}", "auto", row[4], "rms", [round(x, 3) for x in row[5]])
r2 = np.array([x[5][1] for x in rows]); r3 = np.array([x[5][2] for x in rows]); w = np.array([x[3] for x in rows])
big = w >= 0.05
print("untold-or-untested holes", len(rows), "with share>=0.05:", big.sum(), " o3 better on", int((r3[big] < r2[big]).sum()),
      " geomean (o3+f)/(o2+f)", float(np.exp(np.mean(np.log((r3[big] + 0.05) / (r2[big] + 0.05))))))
