import sys, time, numpy as np
sys.path.insert(0,'/work/main')
from shellrepair import kernels
from shellrepair import triangulate as tr
rng=np.random.default_rng(int(sys.argv[1]) if len(sys.argv)>1 else 0)
t0=time.perf_counter(); kernels.liepa_tables(np.random.rand(5,3), np.zeros((5,3)), np.zeros(5,bool), np.zeros((5,5),bool), None, 1e-12); print('compile', time.perf_counter()-t0)
nd=0; tn=tk=0
for trial in range(300):
    k=int(rng.integers(4, 120))
    th=np.sort(rng.uniform(0,2*np.pi,k))
    kind=trial%5
    Q=np.column_stack([np.cos(th), np.sin(th), rng.normal(0, 0.3 if kind else 0.0, k)])
    if kind==2: Q=np.round(Q*4)/4   # coincident and collinear points
    if kind==3: Q[rng.integers(0,k,3)] = Q[0]
    rim=rng.normal(size=(k,3)); rim/=np.linalg.norm(rim,axis=1)[:,None]
    has=rng.random(k)<0.8
    rim[~has]=0
    if kind==4: rim[rng.integers(0,k,2)]=0
    forb=np.zeros((k,k),bool)
    for _ in range(int(rng.integers(0,k))):
        a,b=sorted(rng.integers(0,k,2))
        if b-a>1 and not (a==0 and b==k-1): forb[a,b]=True
    axis=None if trial%3==0 else rng.normal(size=3)
    if trial%7==0: axis=np.array([0,0,1.0])
    t=time.perf_counter(); O1,w1=tr._dp_tables(Q,rim,has,forb,axis); tn+=time.perf_counter()-t
    t=time.perf_counter(); O2,w2=kernels.liepa_tables(Q,rim,has,forb,axis,tr.ANGLE_TIE); tk+=time.perf_counter()-t
    same = np.array_equal(O1,O2) and (w1==w2 or (np.isnan(w1) and np.isnan(w2)))
    if not same:
        nd+=1; print('DIFF', trial, k, kind, w1, w2, np.argwhere(O1!=O2)[:3])
print('different', nd, 'numpy s', round(tn,3), 'kernel s', round(tk,3))
