import sys, os; sys.path.insert(0, "."); os.chdir(".")
import numpy as np
from eval import stress
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext
from shellrepair import detect_holes
from shellrepair.fill import bridge
seed, i, rag, sm = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
c = stress.stress_case(i, seed, shapes_ok=stress.available_shapes(), ragged=rag)
scan = detect_holes(c.V, c.F)
ctx = ScanContext(Mesh(V=c.V, F=c.F))
f = bridge._continuation_arcs_cat
bridge._continuation_arcs_cat = lambda V, Fn, lps, smooth=2: f(V, Fn, lps, sm)
arcs = {}
s = bridge.loop_sights(ctx.V, scan.loops, lambda lp: ctx.F[ctx.ring_faces(lp, 3)], arcs_out=arcs)
print(c.name, "smooth", sm, [(a, m, cnt.tolist()) for a, (cnt, m) in s.items()], ["%.2f/%.2f" % (np.median(A[3][A[5]]), np.subtract(*np.percentile(A[3][A[5]], [75, 25]))) for A in arcs.values()])
