"""A/B screen: default with and without env VAR=1; forced orders only where they differ.
usage: abscreen.py VAR SEED N FAMS(comma or "") [SHAPE or any] [RAGGED]
(:func:`ab_regret` is also what ``late-screens/suite_rms.py`` runs on eval's suite cases.)"""
import sys, os, hashlib; sys.path.insert(0, ".")
import numpy as np
from eval import stress, regret
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh


def ab_regret(c, var):
    """(rows, regret, row with VAR=1, its regret): the forced orders and the
    default run once, the default again with env ``var`` set to 1."""
    rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    g, _ = regret.regret(rows)
    os.environ[var] = "1"
    r = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
    os.environ.pop(var, None)
    rows2 = dict(rows); rows2[regret.DEFAULT] = r
    g2, _ = regret.regret(rows2)
    return rows, g, r, g2


def h(m): return hashlib.sha256(np.ascontiguousarray(m.V).tobytes() + np.ascontiguousarray(m.F).tobytes()).hexdigest()[:12]


if __name__ == "__main__":
    var, seed, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    fams = sys.argv[4].split(",") if len(sys.argv) > 4 and sys.argv[4] else None
    shape = sys.argv[5] if len(sys.argv) > 5 and sys.argv[5] != "any" else None
    ragged = float(sys.argv[6]) if len(sys.argv) > 6 else 0.0
    ok = stress.available_shapes()
    G = lambda a: float(np.exp(np.mean(np.log(a)))) if a else float("nan")
    ga, gb = [], []
    for i in range(n):
        fam = fams[i % len(fams)] if fams else None
        c = stress.stress_case(i, seed, shapes_ok=ok, family=fam, shape=shape, ragged=ragged)
        os.environ.pop(var, None)
        ma, _ = repair_mesh(Mesh(V=c.V, F=c.F), order="auto")
        os.environ[var] = "1"
        mb, _ = repair_mesh(Mesh(V=c.V, F=c.F), order="auto")
        os.environ.pop(var, None)
        if h(ma) == h(mb):
            print(c.name, "same", flush=True)
            continue
        rows, g, r, g2 = ab_regret(c, var)
        f = " ".join(f"{rows[t]['rms_permille']:.3g}" if rows[t].get('rms_permille') is not None else "none" for t in regret.FORCED)
        print(c.name, "forced", f, "A %.3g r %.3f" % (rows[regret.DEFAULT]["rms_permille"], g or 0), "B %.3g r %.3f" % (r["rms_permille"], g2 or 0), flush=True)
        if g and g2: ga.append(g); gb.append(g2)
    print("changed", len(ga), "A geomean %.4f  B geomean %.4f" % (G(ga), G(gb)))
