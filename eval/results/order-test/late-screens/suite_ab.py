import sys, os, time, hashlib; sys.path.insert(0, ".")
import numpy as np
from eval import cases
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
var = sys.argv[1]
cs = list(cases.suite())
c = cs[0]; repair_mesh(Mesh(V=c.V, F=c.F), order=2, jobs=int(os.environ.get("J","1")))
def h(m): return hashlib.sha256(m.V.tobytes() + m.F.tobytes()).hexdigest()[:10]
ra, rb = [], []
for c in cs:
    t = {}
    for o, v in ((2, None), ("auto", None), ("auto", "1")):
        if v: os.environ[var] = v
        else: os.environ.pop(var, None)
        t0 = time.perf_counter(); m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order=o, jobs=int(os.environ.get("J","1"))); t[(o, v)] = (time.perf_counter() - t0, h(m))
    os.environ.pop(var, None)
    a = t[("auto", None)][0] / t[(2, None)][0]; b = t[("auto", "1")][0] / t[(2, None)][0]
    ra.append(a); rb.append(b)
    print(f"{c.name:32s} o2 {t[(2,None)][0]:.3f} A {a:.2f} B {b:.2f} {'same' if t[('auto',None)][1]==t[('auto','1')][1] else 'DIFF'}", flush=True)
G = lambda x: float(np.exp(np.mean(np.log(x))))
print("geomean A %.2f B %.2f; max A %.2f B %.2f" % (G(ra), G(rb), max(ra), max(rb)))
