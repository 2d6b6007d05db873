import sys, hashlib; sys.path.insert(0, ".")
import numpy as np
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
seed, n = int(sys.argv[1]), int(sys.argv[2])
ok = stress.available_shapes()
for i in (range(n) if len(sys.argv) < 4 else [int(x) for x in sys.argv[3].split(",")]):
    c = stress.stress_case(i, seed, shapes_ok=ok)
    m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order="auto", jobs=1)
    h = hashlib.sha256(np.ascontiguousarray(m.V).tobytes() + np.ascontiguousarray(m.F).tobytes()).hexdigest()[:16]
    print(c.name, h, rep["holes_after"], flush=True)
