"""Large caps (20-40 % of the area) on smooth shapes: default (this tree; env var toggles) vs forced orders."""
import sys, os; sys.path.insert(0, '.')
import numpy as np
from eval import cases, metrics
from eval.cases import ground_truth, area_fraction_mask, make_case
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import face_areas
var = sys.argv[1]
shapes_ = sys.argv[2].split(',')
seeds = [int(x) for x in sys.argv[3].split(',')]
fracs = [float(x) for x in sys.argv[4].split(',')]
for sh in shapes_:
    V, F, notes = ground_truth(sh)
    for fr in fracs:
        for sd in seeds:
            rem = area_fraction_mask(V, F, fr, seed=sd)
            c = make_case(f"{sh}-{fr}-{sd}", "hard", sh, "cap", V, F, rem, seed=sd)
            truth = metrics.TruthSurface(c.V_true, c.F_true); facts = metrics.input_facts(c.V, c.F)
            ra = float(face_areas(c.V_true, c.F_true[c.removed]).sum())
            def rms(**kw):
                m, r = repair_mesh((c.V, c.F), **kw)
                if r.get('holes_after', 0): return None, r
                return metrics.evaluate(c.V, c.F, m.V, m.F, truth, removed_area=ra, n_samples=20000, seed=0, facts=facts)['rms_permille'], r
            os.environ.pop(var, None); a, ra_ = rms(order='auto')
            os.environ[var] = '1'; b, rb = rms(order='auto'); os.environ.pop(var, None)
            f = {o: rms(order=o)[0] for o in (1, 2, 3)}
            if not [v for v in f.values() if v is not None] or a is None or b is None:
                print(c.name, 'holes', ra_.get('holes_before'), 'left open or no hole: forced', f, 'A', a, 'B', b, flush=True); continue
            best = min(v for v in f.values() if v is not None)
            reg = lambda x: (x + 0.05) / (best + 0.05)
            ch = lambda r: [h.get('order') for h in r['holes'] if h['edges'] >= 8]
            print(c.name, 'forced', {k: round(v, 3) for k, v in f.items()}, 'A %.3f (%.3f) %s' % (a, reg(a), ch(ra_)), 'B %.3f (%.3f) %s' % (b, reg(b), ch(rb)), flush=True)
