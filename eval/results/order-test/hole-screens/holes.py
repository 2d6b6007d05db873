"""Per hole: the real hole's patches at orders 1/2/3 (same vertices), their
spreads d12, d23, truth RMS of each, and the order test's errors.

Usage, from the repository root: ``.venv/bin/python eval/results/order-test/hole-screens/holes.py SEED N OUT.json``
(``NOROUGH=1``: the test rims not roughened).
"""
import json
import sys
import time

sys.path.insert(0, ".")
import numpy as np

from eval import stress
from shellrepair.errors import MeshError
from shellrepair.fill.patch import PatchError, build_patch
from shellrepair.fill.probe import probe_errors
from shellrepair.holes.loops import detect_holes
from shellrepair.mesh.distance import point_mesh_distance
from shellrepair.mesh.index import ScanContext
from shellrepair.mesh.io import Mesh

seed, n, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
import os
if os.environ.get("NOROUGH"):
    from shellrepair.fill import probe as _pm
    _pm.roughen = lambda Vl, Fl, ploop, rough, s: Vl
ok = stress.available_shapes()
rows = []
from shellrepair.fill import probe as _pr
_cap = {"passes": [], "stash": None}
_af = _pr.as_filled
def _as_filled(cands, faired):
    P = dict(zip(cands, faired))
    dd = lambda a, b: float(np.sqrt(((P[a] - P[b]) ** 2).sum(axis=1).mean()))
    _cap["stash"] = (dd(1, 2), dd(2, 3))
    return _af(cands, faired)
_pr.as_filled = _as_filled
_add = _pr.Pooled.add
def _padd(self, distances):
    d = list(distances)
    ok = _add(self, iter(d))
    if ok and _cap["passes"]:
        _cap["passes"][-1]["probes"].append({"sq": {str(o): float((x * x).sum()) for o, x in d}, "n": int(len(d[0][1])),
                                              "d12": _cap["stash"][0], "d23": _cap["stash"][1]})
    return ok
_pr.Pooled.add = _padd
_pe = _pr._probe_errors
def _ppe(*a):
    _cap["passes"].append({"probes": []})
    e, n_, al = _pe(*a)
    _cap["passes"][-1]["errors"] = {str(k): float(v) for k, v in e.items()}
    _cap["passes"][-1]["n"] = int(n_)
    return e, n_, al
_pr._probe_errors = _ppe
for i in range(n):
    c = stress.stress_case(i, seed, shapes_ok=ok)
    V, F = np.asarray(c.V, float), np.asarray(c.F, np.int64)
    diag = float(np.linalg.norm(c.V_true.max(0) - c.V_true.min(0)))
    scan = detect_holes(V, F)
    ctx = ScanContext(Mesh(V=V, F=F))
    t0 = time.perf_counter()
    for L in scan.loops:
        loop = np.asarray(L.vertices, np.int64)
        if len(loop) < 8 or getattr(L, "kind", "hole") not in ("hole",):
            pass
        try:
            p2 = build_patch(ctx, L.id, loop, order=2)
            if len(p2.P) == 0:
                continue
            p1 = build_patch(ctx, L.id, loop, order=1, initial=(p2.P, p2.T), refine=False)
            p3 = build_patch(ctx, L.id, loop, order=3, initial=(p2.P, p2.T), refine=False)
        except (PatchError, MeshError, ValueError, IndexError) as e:
            continue
        P = {1: p1.P, 2: p2.P, 3: p3.P}
        if not all(len(P[o]) == len(p2.P) for o in P):
            continue
        d = lambda a, b: 1e3 * float(np.sqrt(((P[a] - P[b]) ** 2).sum(axis=1).mean())) / diag
        truth = {}
        for o in (1, 2, 3):
            dist = point_mesh_distance(P[o], c.V_true, c.F_true)
            truth[o] = 1e3 * float(np.sqrt(np.mean(dist * dist))) / diag
        _cap["passes"] = []
        try:
            e, nprobe, scale = _pr.probe_errors(ctx, loop, (1, 2, 3))
        except Exception as ex:
            e, nprobe, scale = {}, 0, 0.0
        rows.append({"case": c.name, "hole": int(L.id), "k": int(len(loop)), "n": int(len(p2.P)),
                     "d12": d(1, 2), "d23": d(2, 3), "d13": d(1, 3), "truth": truth,
                     "test": {str(o): 1e3 * float(v) / diag for o, v in e.items()}, "probes": int(nprobe), "passes": [p for p in _cap["passes"] if p["probes"]], "diag": diag,
                     "scale": float(scale)})
    print(c.name, len(scan.loops), "loops", round(time.perf_counter() - t0, 1), "s", flush=True)
json.dump(rows, open(out, "w"))
