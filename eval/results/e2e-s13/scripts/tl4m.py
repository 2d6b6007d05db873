import sys, time, threading
sys.path.insert(0, "/work/main")
import numpy as np
from shellrepair.io import read_mesh
from shellrepair import fastmesh, kernels, cholesky
fastmesh.warm_up(); kernels.warm_up(); cholesky.warm_up()
import shellrepair.repair as R, shellrepair.patch as P, shellrepair.fill as FL, shellrepair.merge as MG
jobs = int(sys.argv[2])
T0 = [0]; log = []
def wrap(mod, name):
    f = getattr(mod, name)
    def g(*a, **k):
        t = time.perf_counter()
        try: return f(*a, **k)
        finally: log.append((threading.current_thread().name[:10], name, (t - T0[0])*1e3, (time.perf_counter()-T0[0])*1e3))
    setattr(mod, name, g)
for n in ["edge_topology", "manifold_mesh", "detect_holes", "scan_verdict", "_find_bands", "_run_chunk", "split_pinched", "expand", "_merge", "edge_count_delta", "table1_dict"]:
    if hasattr(R, n): wrap(R, n)
wrap(P._Context, "__init__"); wrap(P._Context, "build_index"); wrap(P, "region_of")
m = read_mesh(sys.argv[1])
for _ in range(2):
    m = read_mesh(sys.argv[1])
    log.clear(); T0[0] = time.perf_counter(); out, rep = R.repair_mesh(m, jobs=jobs, order="auto"); tot = (time.perf_counter()-T0[0])*1e3
    print("total %.1f" % tot)
for th, n, a, b in sorted(log, key=lambda x: x[2]):
    if b - a > 5: print(f"{th:10s} {n:34s} {a:7.1f} -> {b:7.1f}  ({b-a:6.1f})")
