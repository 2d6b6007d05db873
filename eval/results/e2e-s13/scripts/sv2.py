"""The shared order test's calls, by thread, in a repair's first 700 ms: sv2.py SCAN.ply JOBS."""
import os, sys, time
sys.path.insert(0, "/work/main")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from timeline import Timeline
from shellrepair.io import read_mesh
from shellrepair import fastmesh, kernels, cholesky
fastmesh.warm_up(); kernels.warm_up(); cholesky.warm_up()
import shellrepair.repair as R, shellrepair.selftest as ST, shellrepair.patch as P, shellrepair.intersect as IS
jobs = int(sys.argv[2])
tl = Timeline()
tl.wrap(kernels, "vertex_faces"); tl.wrap(ST, "_relative_test"); tl.wrap(ST, "_ring_walk"); tl.wrap(ST, "_probe_band")
tl.wrap(ST, "_refined"); tl.wrap(ST, "fair_patch_orders"); tl.wrap(ST, "_edge_bends"); tl.wrap(IS.NearFaces, "__init__", "NearFaces")
vf_prop = P._Context.vf


def vfg(self):
    t = time.perf_counter(); r = vf_prop.fget(self); tl.record("ctx.vf", t); return r


P._Context.vf = property(vfg)
m = read_mesh(sys.argv[1])
tl.start(); R.repair_mesh(m, jobs=jobs)
tl.print(longer=2, before=700)
