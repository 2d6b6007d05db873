"""eval's three cases with a planar opening, repaired at the default and with --base flat (a figure that stood on
its base): RMS to the truth as eval/bench.py measures it (20 000 samples, seed 0), and the holes of 8 or more rim
edges capped flat. Run from the checkout: python eval/results/base-flat-suite/baseflat.py CASE[,CASE...]"""
import sys; sys.path.insert(0,'.')
import numpy as np
from eval import cases, metrics
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import face_areas
for name in sys.argv[1].split(','):
    c = cases.build_case(name)
    truth = metrics.TruthSurface(c.V_true, c.F_true)
    facts = metrics.input_facts(c.V, c.F)
    ra = float(face_areas(c.V_true, c.F_true[c.removed]).sum())
    for kw in ({'order': 'auto'}, {'order': 'auto', 'base': 'flat'}):
        m, r = repair_mesh((c.V, c.F), **kw)
        e = metrics.evaluate(c.V, c.F, m.V, m.F, truth, removed_area=ra, n_samples=20000, seed=0, facts=facts)
        flat = [(h['id'], h['edges']) for h in r['holes'] if h.get('kind') == 'flat cap' and h['edges'] >= 8]
        print(name, kw, 'rms %.3f' % e['rms_permille'], 'flat caps (id, edges)', flat, 'base', r.get('base'), flush=True)
