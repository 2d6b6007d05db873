import sys, time, numpy as np
sys.path.insert(0,'/work/main')
from eval.stress import stress_case
from eval.big_holes import big_hole_case
from shellrepair import holes as H
from shellrepair.io import read_mesh
orig = H._band_rims
def kinds(V,F,on):
    H._band_rims = orig if on else (lambda *a, **k: None)
    try: return [(L.kind) for L in H.detect_holes(V,F).loops]
    finally: H._band_rims = orig
mode=sys.argv[1]
if mode=='shared':
    import glob
    for p in sorted(glob.glob('/work/shared/data/*.ply')):
        m=read_mesh(p); a=kinds(m.V,m.F,True); b=kinds(m.V,m.F,False)
        print(p.split('/')[-1], len(a), 'loops', 'borders', a.count('border'), 'changed', sum(x!=y for x,y in zip(a,b)))
else:
    seeds=[int(x) for x in sys.argv[2].split(',')]; n=int(sys.argv[3])
    tot=ch=0
    for s in seeds:
        for i in range(n):
            c=stress_case(i,s) if mode=='stress' else None
            V,F=c.V.astype(np.float64),c.F.astype(np.int64)
            a=kinds(V,F,True); b=kinds(V,F,False); tot+=1
            d=sum(x!=y for x,y in zip(a,b))
            if d: ch+=1; print('CHANGED', c.name, c.description if hasattr(c,'description') else '', d, 'borders before', b.count('border'))
    print('cases', tot, 'changed', ch)
