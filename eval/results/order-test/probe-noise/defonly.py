import sys, json; sys.path.insert(0, '.')
from eval import stress, regret
seed = int(sys.argv[1]); n = int(sys.argv[2]); rag = float(sys.argv[3]) if len(sys.argv) > 3 else 0.0
idx = [int(x) for x in sys.argv[4].split(',')] if len(sys.argv) > 4 else range(n)
ok = stress.available_shapes()
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok, ragged=rag)
    r = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
    print(c.name, r.get('rms_permille'), r.get('holes_closed'), r.get('holes'), flush=True)
