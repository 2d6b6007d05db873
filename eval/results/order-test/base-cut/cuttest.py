"""Offline screen: a base (planar cut) tested by cutting the scan again at a
parallel plane moved into the scan by t (the slab between removed), filled at
orders 1, 2, 3; the RMS of the slab's vertices to each fill. Compared with the
real case's forced orders (truth) from a regret JSON."""
import sys, json, glob
sys.path.insert(0, ".")
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from eval import stress, peers
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
from shellrepair.holes.loops import detect_holes
from shellrepair.mesh.distance import point_mesh_distance
peers._load_kernels()

def slab_test(V, F, loop, frac):
    P = V[loop]; c = P.mean(axis=0)
    _, _, vt = np.linalg.svd(P - c, full_matrices=False); n = vt[2]
    if ((V - c) @ n).mean() > 0: n = -n            # n points out of the scan, into the missing cap
    Q = P - c
    r = np.sqrt(np.abs(np.dot(Q @ vt[0], np.roll(Q @ vt[1], -1)) - np.dot(Q @ vt[1], np.roll(Q @ vt[0], -1))) / 2 / np.pi)
    t = frac * r
    h = (V - c) @ n                                # <= ~0 on the scan
    inside = h >= -t
    cand = inside[F].all(axis=1)
    # faces of the slab connected to the rim
    rimv = np.zeros(len(V), bool); rimv[loop] = True
    fc = np.flatnonzero(cand)
    E = np.sort(np.concatenate([F[fc][:, [0, 1]], F[fc][:, [1, 2]], F[fc][:, [2, 0]]]), axis=1)
    fid = np.tile(np.arange(len(fc)), 3)
    key = E[:, 0] * (len(V) + 1) + E[:, 1]
    o = np.argsort(key, kind="stable"); ks = key[o]; same = ks[1:] == ks[:-1]
    a, b = fid[o][:-1][same], fid[o][1:][same]
    A = coo_matrix((np.ones(len(a)), (a, b)), shape=(len(fc), len(fc)))
    _, lab = connected_components(A, directed=False)
    touch = rimv[F[fc]].any(axis=1)
    keep_lab = np.unique(lab[touch])
    rem = np.zeros(len(F), bool); rem[fc[np.isin(lab, keep_lab)]] = True
    F2 = F[~rem]
    used = np.unique(F2)
    gone = np.setdiff1d(np.unique(F[rem]), used)
    remap = np.full(len(V), -1, np.int64); remap[used] = np.arange(len(used))
    return V[used], remap[F2], V[gone], r, int(rem.sum())

def main():
    seed, idx, frac = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
    truth = None
    for f in glob.glob(f"/work/main/eval/results/**/regret-seed{seed}.json", recursive=True):
        d = json.load(open(f))
        for c in d.get("cases", []):
            if (c.get("name") or c.get("case") or "").startswith(f"s{seed}-{idx:02d}-"):
                truth = {t: c["rows"].get(t, {}).get("rms_permille") for t in ("ours-o1", "ours-o2", "ours-o3", "ours-auto")}
    case = stress.stress_case(idx, seed, shapes_ok=stress.available_shapes())
    scan = detect_holes(case.V, case.F)
    loops = sorted(scan.loops, key=lambda L: -len(L.vertices))
    loop = np.asarray(loops[0].vertices, np.int64)
    V2, F2, Qgone, r, nrem = slab_test(case.V, case.F, loop, frac)
    diag = float(np.linalg.norm(np.ptp(case.V, axis=0)))
    res = {}
    for k in (1, 2, 3):
        m, rep = repair_mesh(Mesh(V=V2, F=F2), order=k, jobs=1)
        fill = m.F[np.asarray(m.face_filled, bool)] if getattr(m, "face_filled", None) is not None else m.F
        d = point_mesh_distance(Qgone, m.V, m.F)
        res[k] = float(np.sqrt(np.mean(d * d)) / diag * 1e3)
    pick = min(res, key=res.get)
    tb = None
    if truth and all(truth.get(f"ours-o{k}") is not None for k in (1, 2, 3)):
        tb = min((1, 2, 3), key=lambda k: truth[f"ours-o{k}"])
    print(json.dumps({"case": case.name, "frac": frac, "slab_faces": nrem, "test": {k: round(v, 4) for k, v in res.items()},
                      "pick": pick, "truth": truth, "truth_best": tb}))

main()
