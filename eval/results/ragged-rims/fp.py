import sys, hashlib, json, time; sys.path.insert(0, ".")
import numpy as np
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
seed, n, rag = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
ok = stress.available_shapes()
for i in range(n):
    c = stress.stress_case(i, seed, shapes_ok=ok, ragged=rag)
    t = time.perf_counter()
    m, rep = repair_mesh(Mesh(V=c.V, F=c.F))
    h = hashlib.sha256(np.ascontiguousarray(m.V).tobytes() + np.ascontiguousarray(m.F).tobytes()).hexdigest()[:16]
    st = sum(1 for x in rep["holes"] if "Steiner" in (x.get("option") or "") or "Steiner" in (x.get("reason") or ""))
    print(c.name, h, "steiner-holes", st, "open", rep.get("holes_after"), "s %.1f" % (time.perf_counter() - t), flush=True)
