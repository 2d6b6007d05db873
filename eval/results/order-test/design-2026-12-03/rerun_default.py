import sys, json, math
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[4]))  # the repository
from eval import stress
from shellrepair import Mesh
from shellrepair.repair import repair_mesh
src = json.load(open(sys.argv[1])); seed = int(sys.argv[2])
F = 0.05; out = []
for i, r in enumerate(src):
    case = stress.stress_case(i, seed)
    facts = stress.input_facts(case)
    R, rep = repair_mesh(Mesh(V=case.V, F=case.F))
    m = stress.measure(case, facts, R.V, R.F)
    best = min(r[k]["rms"] for k in "123" if r[k]["closed"])
    g_old = (r["auto"]["rms"] + F) / (best + F); g = (m["rms_permille"] + F) / (best + F)
    out.append((r["case"], round(g_old, 3), round(g, 3)))
    print(out[-1], flush=True)
print("old", math.exp(sum(math.log(x[1]) for x in out) / len(out)), "new", math.exp(sum(math.log(x[2]) for x in out) / len(out)))
