import sys, time, numpy as np, hashlib
sys.path.insert(0,'/work/main')
from eval.big_holes import big_hole_case
from eval.peers import _load_kernels
import shellrepair.triangulate as tr
from shellrepair.repair import repair_mesh
from shellrepair.io import Mesh
_load_kernels()
seen={}; tt=[0.0]
f0=tr.delaunay_faces
def w(P):
    key=hashlib.md5(np.ascontiguousarray(P).tobytes()).hexdigest(); seen[key]=seen.get(key,0)+1
    t=time.perf_counter()
    try: return f0(P)
    finally: tt[0]+=time.perf_counter()-t
tr.delaunay_faces=w
for spec in sys.argv[1:]:
    i,s=map(int,spec.split(':')); seen.clear(); tt[0]=0
    c=big_hole_case(i,s); V,F=c[-2],c[-1]
    repair_mesh(Mesh(V=np.array(V,np.float64),F=np.array(F,np.int64)))
    print(c[0], 'calls', sum(seen.values()), 'distinct', len(seen), 'time', round(tt[0],3))
