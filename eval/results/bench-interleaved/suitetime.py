import sys, os, time; sys.path.insert(0, sys.argv[1])
os.environ.setdefault("SHELLREPAIR_SHAPE_CACHE", "eval/.shape-cache")
from eval import cases
from shellrepair.repair import repair_mesh
cs = list(cases.suite())
for c in cs: repair_mesh((c.V, c.F), order="auto", jobs=1); repair_mesh((c.V, c.F), order=2, jobs=1)
for o in (2, "auto"):
    tot = 0.0; wall = time.perf_counter()
    for c in cs:
        M, rep = repair_mesh((c.V, c.F), order=o, jobs=1); tot += rep["seconds"]
    print(sys.argv[1], o, "report seconds", round(tot, 3), "wall", round(time.perf_counter() - wall, 3), flush=True)
