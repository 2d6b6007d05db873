"""The default on chosen cases under env variants: RMS, and per-hole options of the largest holes."""
import sys, os, json
sys.path.insert(0, ".")
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
ok = stress.available_shapes()
variants = [dict(kv.split("=") for kv in v.split(",")) if v != "-" else {} for v in sys.argv[2:]]
for spec in sys.argv[1].split(";"):
    seed, i = map(int, spec.split("-"))
    c = stress.stress_case(i, seed, shapes_ok=ok)
    facts = stress.input_facts(c)
    out = [c.name]
    for v in variants:
        os.environ.update(v)
        m, rep = repair_mesh(Mesh(V=c.V, F=c.F))
        for k in v:
            del os.environ[k]
        meas = stress.measure(c, facts, m.V, m.F)
        big = sorted(rep["holes"], key=lambda h: -h["edges"])[:2]
        out.append(f"{v or 'default'}: {meas['rms_permille']:.4f} closed {meas['holes_closed']}/{meas['holes']} s {rep['seconds']:.2f} | " +
                   " / ".join(f"{h['edges']}: {h['option'][:200]}" for h in big))
    print("\n  ".join(out), flush=True)
