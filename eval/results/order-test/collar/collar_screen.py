"""Leave-a-collar-out test of each hole: the hole enlarged by m rings of its own scan, filled at orders 1-3 as a
test hole is, and each fill measured against the collar's removed vertices."""
import sys, os, json, time
sys.path.insert(0, ".")
import numpy as np
from eval import stress
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext
from shellrepair.holes.loops import boundary_loops
from shellrepair.fill.probe import _refined, hole_radius, as_filled, TEST_ROUNDS
from shellrepair.fill.fair import fair_patch_orders
from shellrepair.mesh.distance import point_mesh_distance
from shellrepair.mesh.geometry import mean_edge

seed, cases, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
FRACS = [float(x) for x in os.environ.get("FRACS", "0.15,0.3").split(",")]
idx = range(int(cases)) if ":" not in cases else range(*map(int, cases.split(":")))
ok = stress.available_shapes()
res = []


def collar_test(ctx, L, m):
    V, F = ctx.V, ctx.F
    C = ctx.ring_faces(L, m)
    R = ctx.ring_faces(L, m + 6)
    keep = np.setdiff1d(R, C)
    Fk = F[keep]
    g, inv = np.unique(np.concatenate([F[C].ravel(), Fk.ravel()]), return_inverse=True)
    Fl = inv[3 * len(C):].reshape(-1, 3)
    Cl = inv[:3 * len(C)].reshape(-1, 3)
    used = np.zeros(len(g), bool)
    used[Fl] = True
    Qv = np.unique(Cl)
    Qv = Qv[~used[Qv]]
    if Qv.size == 0:
        return None
    loops, _ = boundary_loops(Fl, len(g))
    touch = np.zeros(len(g), bool)
    touch[np.unique(Cl)] = True
    inner = [np.asarray(l, np.int64) for l in loops if touch[np.asarray(l)].all()]
    if len(inner) != 1:
        return None
    ids = np.flatnonzero(used)
    remap = np.full(len(g), -1, np.int64)
    remap[ids] = np.arange(ids.size)
    Vl = V[g][ids]
    origin = Vl.mean(axis=0)
    lctx = ScanContext(Mesh(V=Vl - origin, F=remap[Fl]))
    ploop = remap[inner[0]]
    P0, T, _ = _refined(lctx, ploop, 3)
    X0, Fs, nf, _, scale, org = P0
    if len(X0) == nf:
        return None
    faired = [Xu for Xu, _ in fair_patch_orders(X0, Fs, nf, (1, 2, 3), rounds=TEST_ROUNDS, operator=False)]
    Tp = Fs[len(Fs) - len(T):]
    Q = V[g][Qv] - origin
    raw = [float(np.sqrt((point_mesh_distance(Q, org + scale * np.vstack([X0[:nf], Xu]), Tp) ** 2).mean())) for Xu in faired]
    filled = as_filled((1, 2, 3), faired)
    asf = [float(np.sqrt((point_mesh_distance(Q, org + scale * np.vstack([X0[:nf], Xu]), Tp) ** 2).mean())) for Xu in filled]
    return {"m": int(m), "q": int(Qv.size), "raw": raw, "asf": asf}


for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok)
    t0 = time.perf_counter()
    ctx = ScanContext(Mesh(V=np.asarray(c.V, np.float64), F=np.asarray(c.F, np.int64)))
    loops, _ = boundary_loops(np.asarray(c.F, np.int64), len(c.V))
    rows = []
    for j, L in enumerate(loops):
        L = np.asarray(L, np.int64)
        if len(L) < 8:
            continue
        r, h = hole_radius(ctx.V, L), mean_edge(ctx.V, L)
        row = {"loop": j, "k": int(len(L)), "tests": []}
        for f in FRACS:
            m = int(min(60, max(2, round(f * r / h))))
            try:
                t = collar_test(ctx, L, m)
            except Exception as exc:
                t = None
            row["tests"].append(t)
        rows.append(row)
    res.append({"case": c.name, "holes": rows, "s": time.perf_counter() - t0})
    print(c.name, len(rows), "holes", round(time.perf_counter() - t0, 1), "s", flush=True)
    json.dump(res, open(out, "w"))
