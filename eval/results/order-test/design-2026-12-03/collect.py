"""Design-seed data for the order criterion: forced RMS per case and the
test errors best_candidate saw per hole (default criterion)."""
import sys, json, time
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[4]))  # the repository
from eval import stress
from shellrepair import Mesh, selftest
from shellrepair.repair import repair_mesh

seed = int(sys.argv[1]); n = int(sys.argv[2]); out = sys.argv[3]
LOG = []
orig = selftest.best_candidate
def spy(errors):
    c = orig(errors)
    LOG.append({"errors": {str(k): float(v) for k, v in errors.items()}, "chosen": str(c)})
    return c
selftest.best_candidate = spy
rows = []
for i in range(n):
    case = stress.stress_case(i, seed)
    facts = stress.input_facts(case)
    row = {"case": case.name}
    for order in [1, 2, 3, "auto"]:
        LOG.clear()
        t0 = time.perf_counter()
        R, rep = repair_mesh(Mesh(V=case.V, F=case.F), order=order)
        m = stress.measure(case, facts, R.V, R.F)
        closed = m.get("holes_closed") == int(facts["is_hole"].sum())
        row[str(order)] = {"rms": m["rms_permille"], "closed": closed, "seconds": rep.get("seconds")}
        if order == "auto":
            row["tests"] = list(LOG)
    rows.append(row)
    print(row["case"], {k: row[k]["rms"] for k in ["1", "2", "3", "auto"]}, len(row["tests"]), flush=True)
    json.dump(rows, open(out, "w"), indent=1)
