"""The two-disc case's phases before the fill, by thread: tlpre.py JOBS (best of 5)."""
import os, sys, time
sys.path.insert(0, "/work/main")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from timeline import Timeline
from eval.bench_fill import two_disc_case
from eval import peers
import shellrepair.repair as R, shellrepair.patch as P, shellrepair.intersect as IS
peers._load_kernels()
V, F, V2, F2, remove = two_disc_case()
jobs = int(sys.argv[1])
R.repair_mesh((V2, F2), jobs=jobs)
tl = Timeline()
for n in ["edge_topology", "manifold_mesh", "detect_holes", "scan_verdict", "_find_bands", "_run_chunk", "split_pinched", "as_mesh", "expand"]:
    if hasattr(R, n): tl.wrap(R, n)
tl.wrap(P._Context, "__init__"); tl.wrap(P._Context, "build_index"); tl.wrap(P._Context, "whole_index")
tl.wrap(IS.NearFaces, "__init__")
best = None
for _ in range(5):
    tl.start(); R.repair_mesh((V2, F2), jobs=jobs); tot = (time.perf_counter() - tl.t0) * 1e3
    if best is None or tot < best[0]: best = (tot, list(tl.log))
print("total %.1f" % best[0])
tl.print(best[1], longer=1)
