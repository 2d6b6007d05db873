import sys, time; sys.path.insert(0, ".")
from eval import cases
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
from shellrepair.fill import probe
import numpy as np
orig = probe._probe_errors
rows = []
cur = [None]
def wrap(ctx, loop, cand, mp, r, shape, *a, **k):
    t = time.perf_counter(); out = orig(ctx, loop, cand, mp, r, shape, *a, **k); dt = time.perf_counter() - t
    rows.append((cur[0], len(loop), round(r, 4), len(shape[0]), out[1], out[2], round(dt, 4)))
    return out
probe._probe_errors = wrap
for c in cases.suite():
    cur[0] = c.name
    repair_mesh(Mesh(V=c.V, F=c.F), order="auto", jobs=1)
import collections
fails = [r for r in rows if r[4] < 2]
by = collections.defaultdict(lambda: [0, 0.0])
for r in fails: by[r[0]][0] += 1; by[r[0]][1] += r[6]
for k, v in by.items(): print(k, v)
for r in sorted(fails, key=lambda r: -r[6])[:15]: print(r)
