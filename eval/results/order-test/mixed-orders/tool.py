import sys, json, os
sys.path.insert(0, os.environ.get('TREE', '/tmp/s54/B'))
from eval import stress, peers
seed, n, out, tool = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
ragged = float(sys.argv[5]) if len(sys.argv) > 5 else 0.0
start = int(os.environ.get('START', '0'))
ok = stress.available_shapes()
res = {}
for i in range(start, start + n):
    c = stress.stress_case(i, seed, shapes_ok=ok, ragged=ragged)
    facts = stress.input_facts(c)
    V, F, info = peers.run_tool(tool, c.V, c.F)
    m = stress.measure(c, facts, V, F)
    res[c.name] = {"rms": m.get("rms_permille"), "closed": m.get("holes_closed"), "holes": int(facts["is_hole"].sum()), "seconds": info.get("seconds")}
    print(c.name, res[c.name], flush=True)
json.dump(res, open(out, 'w'))
