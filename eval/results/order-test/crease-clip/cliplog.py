import sys; sys.path.insert(0,'.')
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
seed = int(sys.argv[1]); fams = sys.argv[2].split(","); idx = [int(x) for x in sys.argv[3].split(",")]
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=stress.available_shapes(), family=fams[i % len(fams)], shape='fandisk')
    print(c.name, flush=True)
    m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order='auto', jobs=1)
