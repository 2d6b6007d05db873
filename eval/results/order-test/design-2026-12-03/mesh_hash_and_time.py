import sys, time, hashlib
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[4]))  # the repository
from eval import stress
from shellrepair import Mesh
from shellrepair.repair import repair_mesh
for seed, idx in [(int(a), int(b)) for a, b in (x.split(":") for x in sys.argv[2:])]:
    case = stress.stress_case(idx, seed)
    t = time.perf_counter()
    R, rep = repair_mesh(Mesh(V=case.V, F=case.F), jobs=int(sys.argv[1]))
    h = hashlib.sha256(R.V.tobytes() + R.F.tobytes()).hexdigest()[:16]
    print(seed, idx, h, round(time.perf_counter() - t, 2), flush=True)
