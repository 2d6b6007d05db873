import sys; sys.path.insert(0, ".")
import numpy as np
from eval import stress
from shellrepair.holes.loops import boundary_loops, loop_stats
seed = int(sys.argv[1]); fams = sys.argv[2].split(","); idx = [int(x) for x in sys.argv[3].split(",")]
th = float(sys.argv[4]) if len(sys.argv) > 4 else 45.0
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=stress.available_shapes(), family=fams[i % len(fams)], shape='fandisk')
    V = np.asarray(c.V, float); F = np.asarray(c.F, np.int64)
    n = np.cross(V[F[:,1]]-V[F[:,0]], V[F[:,2]]-V[F[:,0]]); n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    fid = np.tile(np.arange(len(F)), 3); key = E[:, 0] * len(V) + E[:, 1]
    o = np.argsort(key, kind="stable"); same = key[o][1:] == key[o][:-1]
    a, b = fid[o][:-1][same], fid[o][1:][same]
    ed = E[o][:-1][same]
    ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n[a], n[b]), -1, 1)))
    cr = ed[ang >= th]
    loops, _ = boundary_loops(F, len(V))
    out = []
    for j, L in enumerate(loops):
        L = np.asarray(L)
        if len(L) < 8: continue
        st = loop_stats(V, L)
        on = np.zeros(len(V), bool); on[L] = True
        m = on[cr[:, 0]] ^ on[cr[:, 1]]
        ents = []
        for e in cr[m]:
            v, w = (e[0], e[1]) if on[e[0]] else (e[1], e[0])
            d = V[v] - V[w]; d /= np.linalg.norm(d)
            ents.append(abs(d @ st["axis"]))
        ents = np.array(ents)
        out.append(f"k{len(L)}: enter(<0.5) {int((ents < 0.5).sum())} all {len(ents)}")
    print(c.name, "; ".join(out))
