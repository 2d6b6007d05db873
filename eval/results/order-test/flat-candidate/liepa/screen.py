import sys, os, json; sys.path.insert(0, ".")  # run from the repository root
os.environ.setdefault("SHELLREPAIR_SHAPE_CACHE", "eval/.shape-cache")
import numpy as np
from eval import stress, regret
from shellrepair.fill import selftest
_co = selftest.choose_order
def co_flat(ctx, hole_id, loop, candidates=None):
    return _co(ctx, hole_id, loop, selftest.WITH_FLAT if candidates is None else candidates)
seed, n = int(sys.argv[1]), int(sys.argv[2]); ragged = float(sys.argv[3]) if len(sys.argv) > 3 else 0.0
ok = stress.available_shapes()
G = lambda a: float(np.exp(np.mean(np.log(a))))
FORCED = regret.FORCED + ("ours-flat",)
res = {"base3": [], "base4": [], "flat4": []}
recs = []
for i in range(n):
    c = stress.stress_case(i, seed, shapes_ok=ok, ragged=ragged)
    selftest.choose_order = _co
    rows = regret.run_case(c, tools=FORCED + (regret.DEFAULT,), log=lambda *a: None)
    selftest.choose_order = co_flat
    rf = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
    selftest.choose_order = _co
    def reg(d, forced):
        if not regret._ok(rows, regret.DEFAULT) or d.get("rms_permille") is None: return None
        cands = [rows[t]["rms_permille"] for t in forced if regret._ok(rows, t)]
        return (d["rms_permille"] + .05) / (min(cands) + .05)
    g3 = reg(rows[regret.DEFAULT], regret.FORCED); g4 = reg(rows[regret.DEFAULT], FORCED); f4 = reg(rf, FORCED)
    for k, v in (("base3", g3), ("base4", g4), ("flat4", f4)):
        if v: res[k].append(v)
    f = lambda t: f"{rows[t]['rms_permille']:.3g}" if rows[t].get('rms_permille') is not None else "none"
    print(c.name, "| forced", " ".join(f(t) for t in FORCED), f"| base {f(regret.DEFAULT)} r3 {g3 and round(g3,3)} r4 {g4 and round(g4,3)} | withflat {rf.get('rms_permille') and round(rf['rms_permille'],3)} r4 {f4 and round(f4,3)} | s {rows[regret.DEFAULT]['seconds']} {rf.get('seconds')}", flush=True)
    recs.append({"case": c.name, "rows": rows, "withflat": rf})
json.dump(recs, open(f"screen-{seed}-{ragged}.json", "w"))
for k in res:
    g = res[k]
    if g: print(k, "geomean %.4f max %.3f over1.5 %d n %d" % (G(g), max(g), sum(x > 1.5 for x in g), len(g)))
