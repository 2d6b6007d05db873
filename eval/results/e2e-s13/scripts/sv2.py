import sys, time, threading
sys.path.insert(0, "/work/main")
from shellrepair.io import read_mesh
from shellrepair import fastmesh, kernels, cholesky
fastmesh.warm_up(); kernels.warm_up(); cholesky.warm_up()
import shellrepair.repair as R, shellrepair.selftest as ST, shellrepair.patch as P, shellrepair.intersect as IS
jobs = int(sys.argv[2])
T0 = [0]; log = []
def wrap(mod, name, label=None):
    f = getattr(mod, name)
    def g(*a, **k):
        t = time.perf_counter()
        try: return f(*a, **k)
        finally: log.append((threading.current_thread().name[:10], label or name, (t-T0[0])*1e3, (time.perf_counter()-T0[0])*1e3))
    setattr(mod, name, g)
wrap(kernels, "vertex_faces"); wrap(ST, "_relative_test"); wrap(ST, "_ring_walk"); wrap(ST, "_probe_band"); wrap(ST, "_refined"); wrap(ST, "fair_patch_orders")
wrap(ST, "_edge_bends"); wrap(IS.NearFaces, "__init__", "NearFaces")
vf_prop = P._Context.vf
def vfg(self):
    t = time.perf_counter(); r = vf_prop.fget(self); log.append((threading.current_thread().name[:10], "ctx.vf", (t-T0[0])*1e3, (time.perf_counter()-T0[0])*1e3)); return r
P._Context.vf = property(vfg)
m = read_mesh(sys.argv[1])
T0[0] = time.perf_counter(); R.repair_mesh(m, jobs=jobs)
for x in sorted(log, key=lambda x: x[2]):
    if x[2] < 700 and x[3]-x[2] > 2: print("%-10s %-20s %7.1f -> %7.1f (%5.1f)" % (x[0], x[1], x[2], x[3], x[3]-x[2]))
