import sys, time, numpy as np, hashlib
sys.path.insert(0,'/work/main')
from eval.stress import stress_case
from eval.big_holes import big_hole_case
from eval.peers import _load_kernels
import shellrepair.patch as P
from shellrepair.intersect import patch_vs_index
from shellrepair.repair import repair_mesh
from shellrepair.io import Mesh
_load_kernels()
import shellrepair.triangulate as TR
def _unused(ctx, loop):
    loop = np.asarray(loop, np.int64)
    def allowed(T):
        T = np.asarray(T, np.int64)
        ok = np.ones(len(T), bool)
        if len(T):
            ok[patch_vs_index(ctx.V[loop[T]], loop[T], ctx.index, return_faces=True)] = False
        return ok
    return allowed
def h(out):
    return hashlib.md5(np.ascontiguousarray(out.V).tobytes()+np.ascontiguousarray(out.F).tobytes()).hexdigest()[:12]
which=sys.argv[1]; seed=int(sys.argv[2]); n=int(sys.argv[3]); jobs=int(sys.argv[4]) if len(sys.argv)>4 else 1
diff=0; tn=to=0
for idx in range(n):
    if which=='stress':
        c=stress_case(idx, seed); V,F,name=c.V,c.F,c.name
    else:
        c=big_hole_case(idx, seed); V,F,name=c[-2],c[-1],c[0]
    res=[]
    for kept in (32, 0):
        TR.DELAUNAY_KEPT = kept; TR._DELAUNAY.clear()
        m=Mesh(V=np.array(V,np.float64),F=np.array(F,np.int64))
        t=time.perf_counter(); out,rep=repair_mesh(m, order='auto', jobs=jobs); dt=time.perf_counter()-t
        res.append((h(out), dt))
    TR.DELAUNAY_KEPT = 32
    same = res[0][0]==res[1][0]; diff += not same; tn+=res[0][1]; to+=res[1][1]
    print(f"{name:42s} {'same' if same else 'DIFFERENT'} new {res[0][1]:6.2f}s old {res[1][1]:6.2f}s")
print('different', diff, 'of', n, 'total new', round(tn,2), 'old', round(to,2))
