import sys, os
sys.path.insert(0, os.environ.get('TREE', '/tmp/s54/C'))
from eval import stress, peers
from shellrepair.mesh.intersect import self_intersections
ok = stress.available_shapes()
for spec in sys.argv[1].split(','):
    seed, i, rag = spec.split(':')
    c = stress.stress_case(int(i), int(seed), shapes_ok=ok, ragged=float(rag))
    facts = stress.input_facts(c)
    for t in sys.argv[2].split(','):
        V, F, info = peers.run_tool(t, c.V, c.F)
        m = stress.measure(c, facts, V, F)
        print(c.name, t, 'rms %.4g' % m['rms_permille'], 'closed', m['holes_closed'], '/', int(facts['is_hole'].sum()), 'topo', m.get('topology_ok'), 'si+', m.get('si_added'), 'orig', m.get('input_faces_missing'), '%.2fs' % info.get('seconds', 0), flush=True)
