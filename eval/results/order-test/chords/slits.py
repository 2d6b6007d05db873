import os, sys
sys.path.insert(0, ".")
from shellrepair.fill import refine
v = os.environ.get("LABEL", "now")
pass
from eval import regret, stress
ok = stress.available_shapes()
for spec in sys.argv[1:]:
    seed, idx = map(int, spec.split(":"))
    c = stress.stress_case(idx, seed, shapes_ok=ok)
    rows = regret.run_case(c, log=lambda *a: None)
    r, best = regret.regret(rows)
    print(f"{v} {c.name:34s} " + " ".join(f"{t[5:]} {rows[t]['rms_permille']:.4g}" for t in ("ours-auto", "ours-o1", "ours-o2", "ours-o3")) + f" regret {r:.3f} cost {regret.cost(rows):.2f}", flush=True)
