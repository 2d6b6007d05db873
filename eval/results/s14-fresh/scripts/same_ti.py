import sys, time, numpy as np, hashlib
sys.path.insert(0,'/work/main')
from eval.stress import stress_case
from eval.big_holes import big_hole_case
from eval.peers import _load_kernels
from shellrepair import intersect
from shellrepair.repair import repair_mesh
from shellrepair.io import Mesh
_load_kernels()
fn = intersect.TriangleIndex.faces_near
def h(out): 
    return hashlib.md5(np.ascontiguousarray(out.V).tobytes()+np.ascontiguousarray(out.F).tobytes()).hexdigest()[:12]
which=sys.argv[1]; seed=int(sys.argv[2]); n=int(sys.argv[3])
diff=0
for idx in range(n):
    if which=='stress':
        c=stress_case(idx, seed); V,F,name=c.V,c.F,c.name
    else:
        c=big_hole_case(idx, seed); V,F,name=c[-2],c[-1],c[0]
    res=[]
    for on in (True, False):
        if on: intersect.TriangleIndex.faces_near = fn
        else: del intersect.TriangleIndex.faces_near
        m=Mesh(V=np.array(V,np.float64),F=np.array(F,np.int64))
        t=time.perf_counter(); out,rep=repair_mesh(m, order='auto'); dt=time.perf_counter()-t
        res.append((h(out), dt, rep.get('holes_after')))
    intersect.TriangleIndex.faces_near = fn
    same = res[0][0]==res[1][0]
    diff += not same
    print(f"{name:42s} {'same' if same else 'DIFFERENT'} new {res[0][1]:6.2f}s old {res[1][1]:6.2f}s")
print('different', diff, 'of', n)
