import sys; sys.path.insert(0, ".")
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
c = stress.stress_case(15, 430560960, shapes_ok=stress.available_shapes(), ragged=float(sys.argv[1]))
for o in (2, 3, "auto"):
    m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order=o)
    for h in rep["holes"]:
        if h["edges"] in (513, 358):
            print(o, h["id"], h["edges"], h["status"], h.get("new_vertices"), (h.get("option") or "")[:250], "|", (h.get("reason") or "")[:300])
