import sys, json, math
sys.path.insert(0, '/work/main')
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from eval import stress
from shellrepair.repair import repair_mesh
from shellrepair.mesh.distance import point_mesh_distance
from shellrepair.mesh.topology import boundary_half_edges
ok = stress.available_shapes()
fracs = [float(x) for x in sys.argv[2].split(',')]
for spec in sys.argv[1].split(','):
    seed, i = map(int, spec.split(':'))
    c = stress.stress_case(i, seed, shapes_ok=ok)
    V, F = c.V, c.F
    E = np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    G = coo_matrix((w, (E[:, 0], E[:, 1])), shape=(len(V), len(V))).tocsr()
    he = np.asarray(boundary_half_edges(F, len(V)))
    rim = np.unique(F[he // 3, he % 3])
    d = dijkstra(G, directed=False, indices=rim, min_only=True)
    # hole "radius" from rim length
    rim_len = 0.5 * np.linalg.norm(V[rim] - V[rim].mean(0), axis=1).mean() * 2
    out = []
    for frac in fracs:
        cut = frac * rim_len
        vr = d < cut
        keepF = ~vr[F].any(axis=1)
        Q = V[vr & (d > 0)]
        used = np.unique(F[keepF]); remap = -np.ones(len(V), np.int64); remap[used] = np.arange(len(used))
        V2, F2 = V[used], remap[F[keepF]]
        res = {}
        for o in (1, 2, 3):
            m, rep = repair_mesh((V2, F2), order=o, jobs=1)
            Fa = np.asarray(m.F)[np.asarray(m.face_filled, bool)]
            dd = point_mesh_distance(Q, np.asarray(m.V), Fa)
            res[o] = float(np.sqrt((dd ** 2).mean()))
        out.append((frac, len(Q), res))
    print(spec, c.name[11:], ' | '.join(f"f{fr}: n{n} " + ' '.join(f"o{o} {v:.4g}" for o, v in r.items()) + f" -> o{min(r, key=r.get)}" for fr, n, r in out), flush=True)
