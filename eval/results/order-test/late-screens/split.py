import sys, time; sys.path.insert(0, ".")
from eval import cases
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
from shellrepair.fill import probe
orig = probe._probe_errors
acc = {"ok": [0, 0.0], "fail": [0, 0.0]}
def wrap(*a, **k):
    t = time.perf_counter(); out = orig(*a, **k); dt = time.perf_counter() - t
    key = "ok" if out[1] >= 2 else "fail"
    acc[key][0] += 1; acc[key][1] += dt
    return out
probe._probe_errors = wrap
orig_cut = probe.cut_test_hole
cut = {"ok": [0, 0.0], "none": [0, 0.0]}
def wcut(*a, **k):
    t = time.perf_counter(); out = orig_cut(*a, **k); dt = time.perf_counter() - t
    key = "ok" if out is not None else "none"; cut[key][0] += 1; cut[key][1] += dt
    return out
probe.cut_test_hole = wcut
for c in cases.suite():
    repair_mesh(Mesh(V=c.V, F=c.F), order="auto", jobs=1)
print(acc); print(cut)
