import sys, hashlib; sys.path.insert(0, ".")
import numpy as np
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
seed, n = int(sys.argv[1]), sys.argv[2]
fam = sys.argv[3] if len(sys.argv) > 3 and sys.argv[3] else None
shape = sys.argv[4] if len(sys.argv) > 4 and sys.argv[4] else None
fams = fam.split(",") if fam else None
ok = stress.available_shapes()
idx = range(int(n)) if "," not in n else [int(x) for x in n.split(",")]
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok, family=fams[i % len(fams)] if fams else None, shape=shape)
    m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order="auto", jobs=1)
    h = hashlib.sha256(np.ascontiguousarray(m.V).tobytes() + np.ascontiguousarray(m.F).tobytes()).hexdigest()[:16]
    print(c.name, h, rep["holes_after"], "%.3f" % rep["seconds"], flush=True)
