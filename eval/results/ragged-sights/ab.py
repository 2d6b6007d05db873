"""A/B of the gate SR_NEW_SIGHTS=1 (the sights read over each arc's stretch of rim) against 0 on stress cases; regret where bytes differ. usage: ab_sm.py B SEED N FAMS RAGGED"""
import sys, os, hashlib; sys.path.insert(0, "."); os.chdir(".")
import numpy as np
from eval import stress, regret
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
B, seed, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
fams = sys.argv[4].split(",") if sys.argv[4] else [None]; rag = float(sys.argv[5])
ok = stress.available_shapes()
def h(m): return hashlib.sha256(m.V.tobytes() + m.F.tobytes()).hexdigest()[:12]
ga, gb = [], []
for i in range(n):
    c = stress.stress_case(i, seed, shapes_ok=ok, family=fams[i % len(fams)], ragged=rag)
    os.environ["SR_NEW_SIGHTS"] = "0"; ma, _ = repair_mesh(Mesh(V=c.V, F=c.F), order="auto")
    os.environ["SR_NEW_SIGHTS"] = "1"; mb, _ = repair_mesh(Mesh(V=c.V, F=c.F), order="auto")
    if h(ma) == h(mb):
        print(c.name, "same", flush=True); continue
    os.environ["SR_NEW_SIGHTS"] = "0"
    rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    g, _ = regret.regret(rows)
    os.environ["SR_NEW_SIGHTS"] = "1"
    rb = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    g2, _ = regret.regret({**rows, regret.DEFAULT: rb[regret.DEFAULT]})
    # best over both arms' forced runs
    allr = {**{k + "A": v for k, v in rows.items()}, **{k + "B": v for k, v in rb.items() if k != regret.DEFAULT}}
    f = lambda rr: " ".join("%.3g" % (rr[t].get("rms_permille") or -1) for t in regret.FORCED)
    print(c.name, "A forced", f(rows), "def %.3g r %.3f" % (rows[regret.DEFAULT]["rms_permille"], g), "| B forced", f(rb), "def %.3g r %.3f" % (rb[regret.DEFAULT]["rms_permille"], g2), flush=True)
    ga.append(g); gb.append(g2)
G = lambda a: float(np.exp(np.mean(np.log(a)))) if a else float("nan")
print("changed", len(ga), "A %.4f B %.4f" % (G(ga), G(gb)))
