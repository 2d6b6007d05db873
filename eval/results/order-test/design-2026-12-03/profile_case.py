import sys, time, json
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[4]))  # the repository
import numpy as np
from eval import stress
from shellrepair import Mesh
from shellrepair.repair import repair_mesh
import cProfile, pstats
seed, idx = int(sys.argv[1]), int(sys.argv[2])
case = stress.stress_case(idx, seed)
pr = cProfile.Profile(); pr.enable()
R, rep = repair_mesh(Mesh(V=case.V, F=case.F), jobs=1)
pr.disable()
rows = rep["holes"]
e = np.array([r["edges"] for r in rows]); s = np.array([r["seconds"] for r in rows]); t = np.array(["choice" in r for r in rows])
print("holes", len(rows), "tested", t.sum(), "total s", s.sum(), "tested s", s[t].sum(), "report seconds", rep["seconds"])
for lo, hi in ((0, 8), (8, 16), (16, 32), (32, 64), (64, 10**6)):
    m = (e >= lo) & (e < hi)
    print(f"edges {lo}-{hi}: {m.sum()} holes, {s[m].sum():.2f} s, tested {t[m].sum()}")
pstats.Stats(pr).sort_stats("cumulative").print_stats(25)
