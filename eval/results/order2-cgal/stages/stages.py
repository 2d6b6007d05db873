"""Which stage separates our order 2 from CGAL's on one hole of eval/order2_cgal.py.

Usage, from the repository root:
``.venv/bin/python eval/results/order2-cgal/stages/stages.py SEED INDEX``
(the case ``INDEX`` of ``eval/order2_cgal.py --seed SEED``).

Crosses the two tools' stages on the same hole: our refined patch faired by
CGAL's ``fair``, CGAL's ``triangulate_and_refine_hole`` patch faired by our
``build_patch(order=2)``, and the thin plate solved by hand on the whole
mesh (scan fixed), its cotangent weights and Voronoi masses re-evaluated
round by round, from either starting patch, with libigl's extrinsic
operators and with ours (intrinsic Delaunay). RMS and max against the truth
in per mille of its diagonal (eval.metrics.evaluate).
"""
import os
import sys
import tempfile

sys.path.insert(0, ".")  # run from the repository root
import numpy as np

from eval import metrics, peers
from eval.order2_cgal import case
from shellrepair.fill.patch import build_patch
from shellrepair.holes.loops import boundary_loops
from shellrepair.mesh.index import ScanContext
from shellrepair.mesh.io import Mesh

seed, idx = int(sys.argv[1]), int(sys.argv[2])
name, desc, rims, Vt, Ft, V, F = case(idx, seed)
V = np.asarray(V, np.float64)
F = np.asarray(F, np.int64)
print(name, desc)
TRUTH = metrics.TruthSurface(Vt, Ft)


def ev(Vo, Fo, label):
    m = metrics.evaluate(V, F, Vo, Fo, TRUTH, self_intersections=False)
    print(f"{label:40s} rms {m['rms_permille']:.5f} max {m['max_permille']:.4f} new {len(Vo) - len(V)}", flush=True)


for tool in ("ours-o2", "cgal"):
    Vo, Fo, info = peers.run_tool(tool, V, F)
    ev(Vo, Fo, tool)

loops = boundary_loops(F, len(V))[0]
loop = np.asarray(loops[0], np.int64)
ctx = ScanContext(Mesh(V=V.copy(), F=F.copy()))


def assemble(P, T, loop):
    k = len(loop)
    ids = np.concatenate([loop, len(V) + np.arange(len(P))])
    return np.vstack([V, P]), np.vstack([F, ids[T]])


p_flat = build_patch(ctx, 0, loop, order=2, fair=False)
p2 = build_patch(ctx, 0, loop, order=2)
ev(*assemble(p2.P, p2.T, loop), "ours build_patch o2")
ev(*assemble(p_flat.P, p_flat.T, loop), "ours flat refined (unfaired)")

import CGAL.CGAL_Polygon_mesh_processing as PMP
from CGAL.CGAL_Polyhedron_3 import Polyhedron_3


def off(Vx, Fx, path):
    with open(path, "w") as fh:
        fh.write(peers._off_text(Vx, Fx))


def cgal_fair(Vx, Fx, first_new):
    with tempfile.TemporaryDirectory() as tmp:
        off(Vx, Fx, tmp + "/a.off")
        P = Polyhedron_3(tmp + "/a.off")
        vs = list(P.vertices())
        sel = [v for i, v in enumerate(vs) if i >= first_new]
        ok = PMP.fair(P, sel)
        out = np.array([(v.point().x(), v.point().y(), v.point().z()) for v in P.vertices()])
    return out, ok


Vx, Fx = assemble(p_flat.P, p_flat.T, loop)
Vf, ok = cgal_fair(Vx, Fx, len(V))
ev(Vf, Fx, f"ours refined + CGAL fair ({ok})")
# CGAL's triangulate and refine, then its fair and ours
with tempfile.TemporaryDirectory() as tmp:
    off(V, F, tmp + "/a.off")
    P = Polyhedron_3(tmp + "/a.off")
    for i, v in enumerate(P.vertices()):
        v.set_id(i)
    P.normalize_border()
    h = next(iter(P.border_halfedges()))
    if not h.is_border():
        h = h.opposite()
    fo, vo = [], []
    PMP.triangulate_and_refine_hole(P, h, fo, vo)
    newP = np.array([(q.point().x(), q.point().y(), q.point().z()) for q in vo])
    for j, q in enumerate(vo):
        q.set_id(len(V) + j)
    faces = []
    for f in fo:
        hh = f.halfedge()
        ids = []
        for _ in range(3):
            ids.append(hh.vertex().id())
            hh = hh.next()
        faces.append(ids)
faces = np.array(faces, np.int64)
print("CGAL refine: new", len(newP), "faces", len(faces))
Vc = np.vstack([V, newP])
Fc = np.vstack([F, faces])
ev(Vc, Fc, "CGAL refined (unfaired)")
Vf, ok = cgal_fair(Vc, Fc, len(V))
ev(Vf, Fc, f"CGAL refined + CGAL fair ({ok})")
# ours on CGAL's refined patch: T over loop positions
pos = {int(v): i for i, v in enumerate(loop)}
k = len(loop)
T = np.array([[pos[i] if i < len(V) else k + i - len(V) for i in f] for f in faces], np.int64)
pc = build_patch(ctx, 0, loop, order=2, initial=(newP, T), refine=False)
ev(*assemble(pc.P, pc.T, loop), "CGAL refined + ours o2")
pc1 = build_patch(ctx, 0, loop, order=3, initial=(newP, T), refine=False)
ev(*assemble(pc1.P, pc1.T, loop), "CGAL refined + ours o3")

# --- the operator, by hand on the whole mesh (scan fixed) ---
import igl
import scipy.sparse as sps
import scipy.sparse.linalg as spl
from shellrepair.fill.fair import cotan_operators


def solve(Xinit, Fall, nfix, K, M, order=2):
    Minv = sps.diags(1.0 / M)
    Q = K @ Minv @ K if order == 2 else (K if order == 1 else K @ Minv @ K @ Minv @ K)
    Q = Q.tocsr()
    u = np.arange(nfix, len(Xinit))
    f = np.arange(nfix)
    A = Q[u][:, u].tocsc()
    b = -Q[u][:, f] @ Xinit[:nfix]
    X = Xinit.copy()
    X[nfix:] = spl.splu(A).solve(b)
    return X


def ext_ops(X, Fall):
    K = -igl.cotmatrix(X, Fall)
    M = igl.massmatrix(X, Fall, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    return K.tocsc(), M


def int_ops(X, Fall):
    K, M = cotan_operators(X, Fall)
    return sps.csc_matrix(K), np.asarray(M)


for label, ops in (("extrinsic", ext_ops), ("intrinsic", int_ops)):
    X = Vc.copy()
    for r in range(4):
        K, M = ops(X, Fc)
        X = solve(X, Fc, len(V), K, M)
        ev(X, Fc, f"CGAL refined, {label} cotan round {r + 1}")
    Xo = np.vstack([V, p_flat.P]); Fo_ = np.vstack([F, np.concatenate([loop, len(V) + np.arange(len(p_flat.P))])[p_flat.T]])
    K = igl.cotmatrix(Xo, Fo_) * 0
    # ours: uniform first
    A = igl.adjacency_matrix(Fo_).astype(float)
    Ku = (sps.diags(np.asarray(A.sum(axis=1)).ravel()) - A).tocsc()
    X = solve(Xo, Fo_, len(V), Ku, np.ones(len(Xo)))
    ev(X, Fo_, f"ours refined, uniform")
    for r in range(4):
        K, M = ops(X, Fo_)
        X = solve(X, Fo_, len(V), K, M)
        ev(X, Fo_, f"ours refined, {label} cotan round {r + 1}")
