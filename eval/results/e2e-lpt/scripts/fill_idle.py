import sys, time, threading, os
sys.path.insert(0, "/work/main")
from eval.bench_fill import two_disc_case
from eval import peers
import shellrepair.repair as R, shellrepair.fill as FL
peers._load_kernels()
V, F, V2, F2, remove = two_disc_case()
R.repair_mesh((V2, F2), jobs=2)
rec = []
f0 = FL._run_chunk
def g(*a, **k):
    t = time.perf_counter(); c = time.thread_time()
    try: return f0(*a, **k)
    finally: rec.append((time.perf_counter() - t, time.thread_time() - c))
FL._run_chunk = g
R._run_chunk = g if hasattr(R, "_run_chunk") else None
res = []
for _ in range(int(sys.argv[1])):
    rec.clear()
    t = time.perf_counter(); R.repair_mesh((V2, F2), jobs=2); tot = time.perf_counter() - t
    w, c = rec[0]
    res.append((tot, w, c))
import numpy as np
a = np.array(res)
print(sys.argv[2], "total med %.3f  chunk wall med %.3f  main cpu med %.3f  main idle med %.3f min %.3f" % (np.median(a[:,0]), np.median(a[:,1]), np.median(a[:,2]), np.median(a[:,1]-a[:,2]), np.min(a[:,1]-a[:,2])))
