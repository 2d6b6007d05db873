import sys, os; sys.path.insert(0, ".")
import numpy as np
from eval import stress, regret
for shape in ("torus-0.5", "torus-0.3", "torus-0.7", "dumbbell", "genus2"):
    for i in range(3):
        c = stress.stress_case(i, 5, quick=True, family="band", shape=shape, ragged=0.1)
        rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
        g0, _ = regret.regret(rows)
        os.environ["BAND_ROUGH"] = "2"
        r = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
        del os.environ["BAND_ROUGH"]
        rows[regret.DEFAULT] = r
        g1, _ = regret.regret(rows)
        print(c.name, len(c.F), "default", g0, "noise-aware", g1, {t: round(rows[t]["rms_permille"], 3) for t in regret.FORCED}, rows["ours-o2"]["seconds"], flush=True)
