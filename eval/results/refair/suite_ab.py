import sys, os, hashlib, numpy as np
sys.path.insert(0, ".")
from eval import cases, regret
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
var=sys.argv[1]
names=[c for c in cases.SUITE] if hasattr(cases,'SUITE') else None
def h(m): return hashlib.sha256(np.ascontiguousarray(m.V).tobytes()+np.ascontiguousarray(m.F).tobytes()).hexdigest()[:12]
for n in sys.argv[2].split(","):
    c=cases.build_case(n)
    out=[]
    for o in ("auto",1,2,3):
        os.environ.pop(var,None); a,_=repair_mesh(Mesh(V=c.V,F=c.F),order=o)
        os.environ[var]="1"; b,_=repair_mesh(Mesh(V=c.V,F=c.F),order=o); os.environ.pop(var,None)
        out.append(h(a)==h(b))
    if all(out): print(n,"same",flush=True); continue
    rows=regret.run_case(c,tools=regret.FORCED+(regret.DEFAULT,),log=lambda *a:None)
    os.environ[var]="1"; rows2=regret.run_case(c,tools=regret.FORCED+(regret.DEFAULT,),log=lambda *a:None); os.environ.pop(var,None)
    f=lambda R:" ".join(f"{R[t]['rms_permille']:.4g}" for t in regret.FORCED+(regret.DEFAULT,))
    print(n,"changed",out,"A",f(rows),"r %.3f"%regret.regret(rows)[0],"| B",f(rows2),"r %.3f"%regret.regret(rows2)[0],flush=True)
