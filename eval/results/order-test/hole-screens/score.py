"""Screen: order 2 or 3 by the test's ratio and the real hole's own convergence.

Usage, from this folder: ``python score.py DESIGN.json,... VALIDATION.json,...``
(the ``holes-seedS.json`` files). Where the test does not pick order 1,
order 3 is taken when log(e3/e2) + b log(d23/d12) + c < 0 (e: the test's
RMS; d: the real hole's patches' RMS differences), on a grid of (b, c)
fitted on the design files and shown on the validation files; per hole
and per case (the holes of a case pooled by their new vertices: an
approximation of the case's RMS, each hole filled alone).
"""
import json, sys
import numpy as np
FL = 0.05
def load(files):
    R = []
    for f in files: R += json.load(open(f))
    return [r for r in R if r["k"] >= 8 and "-band-" not in r["case"]]
def reg(r, o):
    t = r["truth"]; return (t[str(o)] + FL) / (min(t.values()) + FL)
def pick_now(r):
    e = r["test"]
    if not e: return 2
    p = int(min(("1", "2", "3"), key=lambda o: (e[o], o != "2", o)))
    if p == 3 and r["d23"] > r["d12"]: return 2
    return p
def pick_new(r, b, c):
    p = pick_now(r)
    e = r["test"]
    if not e or p == 1: return p
    s = np.log(e["3"] / e["2"]) + b * np.log(r["d23"] / r["d12"]) + c
    p = 3 if s < 0 else 2
    if p == 3 and r["d23"] > r["d12"]: return 2
    return p
def gm(R, f): 
    g = np.array([reg(r, f(r)) for r in R]); return np.exp(np.log(g).mean()), (g > 1.5).sum()
D = load(sys.argv[1].split(","))
print("now", gm(D, pick_now))
best = []
for b in (0, 0.25, 0.5, 1.0, 1.5, 2.0):
    for c in (-1.0, -0.5, -0.25, 0, 0.25, 0.5, 1.0):
        best.append((gm(D, lambda r: pick_new(r, b, c)), b, c))
best.sort()
for x in best[:8]: print(x)
if len(sys.argv) > 2:
    V = load(sys.argv[2].split(","))
    print("validation now", gm(V, pick_now))
    for (g, b, c) in best[:3]:
        print("validation", b, c, gm(V, lambda r: pick_new(r, b, c)))

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
for name, S in (("design", D), ("dev", V)):
    print(name, "case-level now", case_level(S, pick_now))
    for b, c in ((0.5, 0.5), (1.0, 1.0), (0.25, 0.5), (1.0, 0.0), (0.5, 0.0)):
        print(name, "case-level", b, c, case_level(S, lambda r: pick_new(r, b, c)))
