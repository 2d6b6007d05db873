import sys, time, cProfile, pstats; sys.path.insert(0, ".")
from eval import cases
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
cs = list(cases.suite())
# warm
c = cs[0]; repair_mesh(Mesh(V=c.V, F=c.F), order=2, jobs=1)
rows = []
pr = cProfile.Profile()
for c in cs:
    t = {}
    for o in (2, "auto"):
        t0 = time.perf_counter()
        if o == "auto": pr.enable()
        repair_mesh(Mesh(V=c.V, F=c.F), order=o, jobs=1)
        if o == "auto": pr.disable()
        t[o] = time.perf_counter() - t0
    print(c.name, "o2 %.3f auto %.3f ratio %.2f" % (t[2], t["auto"], t["auto"] / t[2]), flush=True)
pr.dump_stats("/tmp/s51/suite.prof")
