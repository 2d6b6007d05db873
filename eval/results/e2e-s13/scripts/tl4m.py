"""A repair's phases on a scan, by thread: tl4m.py SCAN.ply JOBS (two runs, the second printed)."""
import os, sys, time
sys.path.insert(0, "/work/main")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from timeline import Timeline
from shellrepair.io import read_mesh
from shellrepair import fastmesh, kernels, cholesky
fastmesh.warm_up(); kernels.warm_up(); cholesky.warm_up()
import shellrepair.repair as R, shellrepair.patch as P
jobs = int(sys.argv[2])
tl = Timeline()
for n in ["edge_topology", "manifold_mesh", "detect_holes", "scan_verdict", "_find_bands", "_run_chunk", "split_pinched", "expand", "_merge", "edge_count_delta", "table1_dict"]:
    if hasattr(R, n): tl.wrap(R, n)
tl.wrap(P._Context, "__init__"); tl.wrap(P._Context, "build_index"); tl.wrap(P, "region_of")
m = read_mesh(sys.argv[1])
for _ in range(2):
    m = read_mesh(sys.argv[1])
    tl.start(); out, rep = R.repair_mesh(m, jobs=jobs, order="auto"); tot = (time.perf_counter() - tl.t0) * 1e3
    print("total %.1f" % tot)
tl.print(longer=5)
