"""Per case: each faired order-2 hole's spreads between the candidate orders (o1-o2, o3-o2) on the real hole, keyed by loop."""
import sys, os, json
sys.path.insert(0, ".")
import numpy as np
from scipy.spatial import cKDTree
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
from shellrepair.holes.loops import boundary_loops
seed, n, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
ok = stress.available_shapes()
res = []
for i in range(n):
    c = stress.stress_case(i, seed, shapes_ok=ok)
    loops, _ = boundary_loops(np.asarray(c.F, np.int64), len(c.V))
    loopid = np.full(len(c.V), -1)
    for j, L in enumerate(loops):
        loopid[np.asarray(L)] = j
    log = f"/tmp/s45/exp/sp-{seed}-{i}.jsonl"
    if os.path.exists(log):
        os.remove(log)
    os.environ["AGREE_LOG"] = log; os.environ["AGREE_TOL"] = "1e30"
    repair_mesh(Mesh(V=c.V, F=c.F))
    tree = cKDTree(c.V)
    recs = []
    if os.path.exists(log):
        for line in open(log):
            q = json.loads(line)
            q["loop"] = int(loopid[tree.query(q.pop("p0"))[1]])
            recs.append(q)
    res.append({"case": c.name, "holes": recs})
    print(c.name, len(recs), flush=True)
    json.dump(res, open(out, "w"))
