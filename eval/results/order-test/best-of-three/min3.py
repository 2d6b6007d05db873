import sys, time, hashlib; sys.path.insert(0, ".")
import numpy as np
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
seed = int(sys.argv[1]); idx = [int(x) for x in sys.argv[2].split(",")] if "," in sys.argv[2] else range(int(sys.argv[2]))
ok = stress.available_shapes()
tot = 0
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok)
    best = 1e9
    for k in range(int(sys.argv[3]) if len(sys.argv) > 3 else 2):
        t = time.perf_counter(); m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order="auto", jobs=1); best = min(best, time.perf_counter() - t)
    h = hashlib.sha256(np.ascontiguousarray(m.V).tobytes() + np.ascontiguousarray(m.F).tobytes()).hexdigest()[:16]
    tot += best
    print(c.name, h, "%.3f" % best, flush=True)
print("total %.3f" % tot)
