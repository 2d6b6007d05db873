"""run_cases.py TREE SETS OUT: repair each case of SETS (stress:SEED:N,big:SEED:N) with the
tree's shellrepair (order auto, jobs 1), after one warm-up call; write name -> (md5 of V,F, seconds, holes after, boundary edges)."""
import sys, json, time, hashlib
tree, sets, out = sys.argv[1], sys.argv[2], sys.argv[3]
sys.path.insert(0, tree)
import numpy as np
import shellrepair; assert shellrepair.__file__.startswith(tree), shellrepair.__file__
from eval.stress import stress_case
from eval.big_holes import big_hole_case
from eval.peers import _load_kernels
from shellrepair.repair import repair_mesh
from shellrepair.io import Mesh
from shellrepair.topology import edge_topology
_load_kernels()
res = {}
first = True
for spec in sets.split(','):
    kind, seed, n = spec.split(':')
    for i in range(int(n)):
        if kind == 'stress':
            c = stress_case(i, int(seed)); V, F, name = c.V, c.F, c.name
        else:
            c = big_hole_case(i, int(seed)); V, F, name = c[-2], c[-1], c[0]
        if first:
            repair_mesh(Mesh(V=np.array(V, np.float64), F=np.array(F, np.int64))); first = False
        m = Mesh(V=np.array(V, np.float64), F=np.array(F, np.int64))
        t = time.perf_counter(); o, rep = repair_mesh(m, order='auto'); dt = time.perf_counter() - t
        h = hashlib.md5(np.ascontiguousarray(o.V).tobytes() + np.ascontiguousarray(o.F).tobytes()).hexdigest()[:12]
        res[name] = [h, dt, rep.get('holes_after'), int(edge_topology(o.F, len(o.V)).n_boundary_edges)]
        print(name, res[name], flush=True)
json.dump(res, open(out, 'w'), indent=0)
