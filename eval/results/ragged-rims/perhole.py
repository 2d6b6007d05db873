"""Per case: forced orders 1-3 and the default, each hole's patch measured against the truth on its own
(components of the added faces, keyed by the input loops they touch); and a logging run of the order test
(up to SIMILAR test holes per hole, each filled at every order, logged)."""
import sys, os, json, time
sys.path.insert(0, ".")
import numpy as np
from scipy.spatial import cKDTree
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from eval import stress, metrics
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
from shellrepair.holes.loops import boundary_loops
from shellrepair.mesh.topology import face_areas

ok = stress.available_shapes()


def per_loop(c, facts, V, F, loopid):
    truth = facts["truth"]
    added, missing, out_to_in, shift, exact = metrics.added_faces(c.V, c.F, V, F, metrics.MATCH_TOL * truth.diag)
    Fa = F[added]
    if len(Fa) == 0:
        return {}
    # components by shared edges
    E = np.sort(np.concatenate([Fa[:, [0, 1]], Fa[:, [1, 2]], Fa[:, [2, 0]]]), axis=1)
    fid = np.tile(np.arange(len(Fa)), 3)
    key = E[:, 0] * (len(V) + 1) + E[:, 1]
    o = np.argsort(key, kind="stable")
    same = key[o][1:] == key[o][:-1]
    a, b = fid[o][:-1][same], fid[o][1:][same]
    G = coo_matrix((np.ones(len(a)), (a, b)), shape=(len(Fa), len(Fa)))
    nc, lab = connected_components(G, directed=False)
    rng = np.random.default_rng(0)
    P, fi = metrics.sample_faces(V, Fa, 40000, rng)
    d, _, _ = truth.closest(P)
    A = face_areas(V, Fa)
    res = {}
    for ci in range(nc):
        fs = np.flatnonzero(lab == ci)
        vs = np.unique(Fa[fs])
        src = out_to_in[vs]
        src = src[src >= 0]
        lids = sorted(set(int(x) for x in loopid[src] if x >= 0))
        m = np.isin(fi, fs)
        if not lids:
            continue
        k = ",".join(map(str, lids))
        area = float(A[fs].sum())
        ms = float((d[m] ** 2).mean()) if m.any() else 0.0
        if k in res:
            a0, m0 = res[k]
            res[k] = (a0 + area, (a0 * m0 + area * ms) / max(a0 + area, 1e-300))
        else:
            res[k] = (area, ms)
    return res



seed, i, rag = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
c = stress.stress_case(i, seed, shapes_ok=ok, ragged=rag)
facts = stress.input_facts(c)
loops, _ = boundary_loops(np.asarray(c.F, np.int64), len(c.V))
loopid = np.full(len(c.V), -1)
for j, L in enumerate(loops):
    loopid[np.asarray(L)] = j
res = {}
for k in sys.argv[4].split(","):
    kk = int(k) if k.isdigit() else k
    m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order=kk)
    res[k] = per_loop(c, facts, np.asarray(m.V), np.asarray(m.F), loopid)
diag = facts["truth"].diag
keys = set().union(*[set(v) for v in res.values()])
rows = []
for key in keys:
    e = {k: (1000 * np.sqrt(res[k][key][1]) / diag if key in res[k] else None) for k in res}
    a = max(res[k][key][0] for k in res if key in res[k])
    rows.append((max(v or 0 for v in e.values()) * a, key, a, e))
for _, key, a, e in sorted(rows, reverse=True)[:8]:
    print(key, [len(loops[int(x)]) for x in key.split(",")][:5], "area", "%.3g" % a, {k: (round(v, 3) if v is not None else None) for k, v in e.items()})
