"""same_output.py CHANGE stress|big SEED N [JOBS]: each case repaired with a
change on and off in one process; the outputs' md5 compared, times printed.

CHANGE: faces_near (TriangleIndex.faces_near, 352f7b3), allowed (the kept
scan answers of patch._scan_allowed, 9d0fb8f) or delaunay (the kept
tetrahedralizations, 4b1768d). "off" is the code before that commit,
rebuilt here in place.
"""
import sys, time, hashlib
sys.path.insert(0, '/work/main')
import numpy as np
from eval.stress import stress_case
from eval.big_holes import big_hole_case
from eval.peers import _load_kernels
from shellrepair import intersect, patch as P, triangulate as TR
from shellrepair.intersect import patch_vs_index
from shellrepair.repair import repair_mesh
from shellrepair.io import Mesh

_load_kernels()
faces_near = intersect.TriangleIndex.faces_near
allowed_kept = P._scan_allowed


def allowed_each_time(ctx, loop):
    loop = np.asarray(loop, np.int64)

    def allowed(T):
        T = np.asarray(T, np.int64)
        ok = np.ones(len(T), bool)
        if len(T):
            ok[patch_vs_index(ctx.V[loop[T]], loop[T], ctx.index, return_faces=True)] = False
        return ok
    return allowed


def switch(change, on):
    if change == 'faces_near':
        if on:
            intersect.TriangleIndex.faces_near = faces_near
        elif hasattr(intersect.TriangleIndex, 'faces_near'):
            del intersect.TriangleIndex.faces_near
    elif change == 'allowed':
        P._scan_allowed = allowed_kept if on else allowed_each_time
    elif change == 'delaunay':
        TR.DELAUNAY_KEPT = 32 if on else 0
        TR._DELAUNAY.clear()


def digest(out):
    return hashlib.md5(np.ascontiguousarray(out.V).tobytes() + np.ascontiguousarray(out.F).tobytes()).hexdigest()[:12]


change, which, seed, n = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
jobs = int(sys.argv[5]) if len(sys.argv) > 5 else 1
different, t_on, t_off = 0, 0.0, 0.0
for idx in range(n):
    if which == 'stress':
        c = stress_case(idx, seed); V, F, name = c.V, c.F, c.name
    else:
        c = big_hole_case(idx, seed); V, F, name = c[-2], c[-1], c[0]
    res = []
    for on in (True, False):
        switch(change, on)
        m = Mesh(V=np.array(V, np.float64), F=np.array(F, np.int64))
        t = time.perf_counter(); out, _ = repair_mesh(m, order='auto', jobs=jobs); dt = time.perf_counter() - t
        res.append((digest(out), dt))
    switch(change, True)
    same = res[0][0] == res[1][0]
    different += not same
    t_on += res[0][1]; t_off += res[1][1]
    print(f"{name:42s} {'same' if same else 'DIFFERENT'} on {res[0][1]:6.2f}s off {res[1][1]:6.2f}s")
print('different', different, 'of', n, 'total on', round(t_on, 2), 'off', round(t_off, 2))
