import os, sys
sys.path.insert(0, ".")
from eval import regret, stress
ok = stress.available_shapes()
v = os.environ.get("LABEL", "now")
for spec in sys.argv[1:]:
    seed, idx = map(int, spec.split(":"))
    c = stress.stress_case(idx, seed, shapes_ok=ok)
    tools = ("ours-auto",) if os.environ.get("AUTOONLY") else ("ours-auto", "ours-o1", "ours-o2", "ours-o3")
    rows = regret.run_case(c, tools=tools, log=lambda *a: None)
    print(f"{v} {c.name:36s} " + " ".join(f"{t[5:]} {rows[t]['rms_permille']:.4g}" for t in tools), flush=True)
