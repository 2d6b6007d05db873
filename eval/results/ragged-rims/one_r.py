import sys, os, json; sys.path.insert(0, ".")
import numpy as np
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
seed, i, rag = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
order = sys.argv[4] if len(sys.argv) > 4 else "auto"
order = int(order) if order.isdigit() else order
c = stress.stress_case(i, seed, shapes_ok=stress.available_shapes(), ragged=rag)
facts = stress.input_facts(c)
m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order=order)
meas = stress.measure(c, facts, m.V, m.F)
print(c.name, "rms", meas["rms_permille"], "closed", meas["holes_closed"], "/", meas["holes"])
for h in rep["holes"]:
    print(" ", h.get("id"), h.get("edges"), h.get("status"), h.get("option"))
