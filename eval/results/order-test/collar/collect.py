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

seed, cases, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
idx = range(int(cases)) if ":" not in cases else range(*map(int, cases.split(":")))
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


res = []
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok)
    facts = stress.input_facts(c)
    loops, _ = boundary_loops(np.asarray(c.F, np.int64), len(c.V))
    loopid = np.full(len(c.V), -1)
    for j, L in enumerate(loops):
        loopid[np.asarray(L)] = j
    rec = {"case": c.name, "diag": float(facts["truth"].diag), "loops": [len(L) for L in loops], "runs": {}}
    for k in (1, 2, 3, "auto"):
        t0 = time.perf_counter()
        m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order=k)
        meas = stress.measure(c, facts, m.V, m.F)
        rec["runs"][str(k)] = {"rms": meas["rms_permille"], "closed": meas["holes_closed"] == meas["holes"],
                               "comps": per_loop(c, facts, np.asarray(m.V), np.asarray(m.F), loopid),
                               "s": time.perf_counter() - t0}
    log = f"/tmp/s44/exp/plog-{seed}-{i}.jsonl"
    if os.path.exists(log):
        os.remove(log)
    os.environ["PROBELOG"] = log
    os.environ["SIMILAR"] = os.environ.get("LOGK", "9")
    repair_mesh(Mesh(V=c.V, F=c.F))
    del os.environ["PROBELOG"], os.environ["SIMILAR"]
    tree = cKDTree(c.V)
    probes = []
    if os.path.exists(log):
        for line in open(log):
            q = json.loads(line)
            q["loop"] = int(loopid[tree.query(q.pop("p0"))[1]])
            probes.append(q)
    rec["probes"] = probes
    res.append(rec)
    print(c.name, {k: round(v["rms"], 4) if v["rms"] else None for k, v in rec["runs"].items()}, len(probes), flush=True)
    json.dump(res, open(out, "w"))
