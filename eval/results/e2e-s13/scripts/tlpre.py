import sys, time, threading
sys.path.insert(0, "/work/main")
from eval.bench_fill import two_disc_case
from eval import peers
import shellrepair.repair as R, shellrepair.fill as FL, shellrepair.patch as P, shellrepair.holes as H, shellrepair.topology as TP, shellrepair.intersect as IS
peers._load_kernels()
V, F, V2, F2, remove = two_disc_case()
jobs = int(sys.argv[1])
R.repair_mesh((V2, F2), jobs=jobs)
T0 = [0]; log = []
def wrap(mod, name):
    f = getattr(mod, name)
    def g(*a, **k):
        t = time.perf_counter()
        try: return f(*a, **k)
        finally: log.append((threading.current_thread().name[:10], name, (t - T0[0])*1e3, (time.perf_counter()-T0[0])*1e3))
    setattr(mod, name, g)
for n in ["edge_topology", "manifold_mesh", "detect_holes", "scan_verdict", "_find_bands", "_run_chunk", "split_pinched", "as_mesh", "expand"]:
    if hasattr(R, n): wrap(R, n)
wrap(P._Context, "__init__"); wrap(P._Context, "build_index"); wrap(P._Context, "whole_index")
wrap(IS.NearFaces, "__init__") if hasattr(IS, 'NearFaces') else None
best = None
for _ in range(5):
    log.clear(); T0[0] = time.perf_counter(); R.repair_mesh((V2, F2), jobs=jobs); tot = (time.perf_counter()-T0[0])*1e3
    if best is None or tot < best[0]: best = (tot, list(log))
print("total %.1f" % best[0])
for th, n, a, b in sorted(best[1], key=lambda x: x[2]):
    if b - a > 1: print(f"{th:10s} {n:34s} {a:7.1f} -> {b:7.1f}  ({b-a:6.1f})")
