import sys, time, numpy as np
sys.path.insert(0,'/work/main')
from shellrepair import triangulate as tr, kernels
from shellrepair.errors import MeshError
rng=np.random.default_rng(int(sys.argv[1])); nd=0; ties=0; tc=tn=0
def ans(f,*a):
    try: return f(*a)
    except MeshError as e: return str(e)
for trial in range(300):
    k=int(rng.integers(8, 700)); kind=trial%4
    th=np.sort(rng.uniform(0,2*np.pi,k)); P=np.column_stack([np.cos(th)*(1+0.3*rng.random(k)), np.sin(th), 0.2*rng.normal(size=k)])
    if kind==1: P=np.round(P*3)/3          # ties
    if kind==2: P[::7]=P[0]
    idx=np.arange(k) if trial%3 else rng.permutation(k+20)[:k]
    Pfull=np.zeros((k+20,3)); Pfull[idx]=P if trial%3==0 else P
    if trial%3: Pfull=P
    forb=set()
    for _ in range(int(rng.integers(0, 3*k))):
        a,b=sorted(rng.choice(idx,2,replace=False).tolist()); forb.add((a,b))
    t=time.perf_counter(); a=ans(tr._best_chord_compiled,Pfull,np.asarray(idx),forb); tc+=time.perf_counter()-t
    t=time.perf_counter(); b=ans(tr._best_chord_rows,Pfull,np.asarray(idx),forb); tn+=time.perf_counter()-t
    if a!=b: nd+=1; print('DIFF', trial, k, kind, a, b)
print('different', nd, 'compiled s', round(tc,3), 'rows s', round(tn,3))
