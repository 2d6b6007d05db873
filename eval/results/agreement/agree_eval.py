"""python agree_eval.py SET SEED N OUT [variants] : RMS per case for agreement variants.
SET: stress | big | suite"""
import sys, json, time
sys.path.insert(0, "/work/main")
import numpy as np
from eval import peers, metrics
import shellrepair.selftest as ST
from shellrepair import repair_mesh
peers._load_kernels()
orig_agrees = ST.agrees

def rim_agrees(test, V, low, high):
    if not test.errors or low.order not in test.errors or high.order not in test.errors:
        return False, float("nan")
    k = len(high.loop)
    T = np.asarray(high.T)
    n = k + len(high.P)
    ring = np.full(n, -1); ring[:k] = 0
    w = max(int(test.rings), 1)
    for r in range(1, w + 1):
        hit = (ring[T] == r - 1).any(axis=1)
        cand = T[hit].ravel()
        cand = cand[ring[cand] < 0]
        ring[cand] = r
    sel = np.flatnonzero(ring[k:] > 0)
    P = high.P[sel] if len(sel) else high.P
    d = ST.point_mesh_distance(P, np.vstack([V[low.loop], low.P]), low.T)
    gap = float(np.sqrt(np.mean(d * d))) if len(d) else 0.0
    return gap <= test.errors[low.order] + test.errors[high.order], gap

def old_agrees(test, V, low, high):
    if not test.errors or low.order not in test.errors or high.order not in test.errors:
        return False, float("nan")
    d = ST.point_mesh_distance(high.P, np.vstack([V[low.loop], low.P]), low.T)
    gap = float(np.sqrt(np.mean(d * d))) if len(d) else 0.0
    return gap <= test.errors[low.order] + test.errors[high.order], gap

VARIANTS = {"current": orig_agrees, "none": lambda test, V, low, high: (bool(test.errors), 0.0), "rim": rim_agrees,
            "old": old_agrees}

def cases(which, seed, n):
    if which == "stress":
        from eval.stress import stress_case
        for i in range(n):
            c = stress_case(i, seed); yield c.name, c.V_true, c.F_true, c.V, c.F
    elif which == "big":
        from eval.big_holes import big_hole_case
        for i in range(n):
            name, _, Vt, Ft, V, F = big_hole_case(i, seed); yield name, Vt, Ft, V, F
    else:
        from eval.cases import build_case, case_names
        for name in case_names():
            c = build_case(name); yield name, c.V_true, c.F_true, c.V, c.F

which, seed, n, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
variants = sys.argv[5].split(",") if len(sys.argv) > 5 else list(VARIANTS)
rows = []
for name, Vt, Ft, V, F in cases(which, seed, n):
    truth = metrics.TruthSurface(Vt, Ft)
    row = {"case": name}
    for v in variants:
        ST.agrees = VARIANTS[v]
        t = time.perf_counter()
        try:
            m, rep = repair_mesh((V, F))
        except Exception as e:
            row[v] = {"error": str(e)[:100]}; continue
        dt = time.perf_counter() - t
        ev = metrics.evaluate(V, F, m.V, m.F, truth, self_intersections=False)
        rej = sum("order 2 kept" in (h.get("reason") or "") for h in rep["holes"])
        o3 = sum((h.get("reason") or "").startswith("faired order 3") for h in rep["holes"])
        row[v] = {"rms": ev["rms_permille"], "s": dt, "rejected": rej, "o3": o3,
                  "after": rep.get("holes_after"), "bnd": rep.get("boundary_edges_after")}
    ST.agrees = orig_agrees
    rows.append(row)
    print(name, " | ".join(f"{v}: rms {row[v].get('rms', float('nan')):.4g} o3 {row[v].get('o3')} rej {row[v].get('rejected')} s {row[v].get('s', 0):.2f}" for v in variants), flush=True)
json.dump(rows, open(out, "w"), indent=1)
