import sys, time
tree=sys.argv[1]; sys.path.insert(0, tree)
import numpy as np
from eval.stress import stress_case
from eval.peers import _load_kernels
from shellrepair.repair import repair_mesh
from shellrepair.io import Mesh
_load_kernels()
for spec in sys.argv[2:]:
    seed, i = map(int, spec.split(':'))
    c = stress_case(i, seed)
    ts=[]
    for r in range(6):
        m=Mesh(V=np.array(c.V,np.float64),F=np.array(c.F,np.int64))
        t=time.perf_counter(); repair_mesh(m, order='auto'); ts.append(time.perf_counter()-t)
    print(tree.split('/')[-1], c.name, 'min', round(min(ts[1:]),3), 'median', round(sorted(ts[1:])[2],3))
