import sys, time, pickle
sys.path.insert(0, "/work/main")
import numpy as np
from numba import njit
import shellrepair.kernels as KN
from shellrepair.kernels import _times_dk
caps = pickle.load(open("/tmp/caps.pkl", "rb"))
def best(f, n=7):
    ts = []
    for _ in range(n):
        t = time.perf_counter(); f(); ts.append(time.perf_counter() - t)
    return min(ts) * 1e3
K, Minv, order, fixed, unknown = caps[(3, 11847, False)]
ptr, col, val = K
n = ptr.size - 1
p2, c2, v2 = KN._drop_spare_diagonal(ptr, col, val)
pos = np.empty(n, np.int64); pos[unknown] = np.arange(unknown.size); pos[fixed] = np.arange(fixed.size)
isf = np.zeros(n, np.bool_); isf[fixed] = True
src = open("/tmp/er_src.py").read().replace("@njit(cache=True, nogil=True)", "")
ns = {"np": np, "_times_dk": _times_dk}
exec(src, ns)
base = njit(nogil=True)(ns["_energy_rows"])
v_nosort = njit(nogil=True)(ns["_energy_rows"].__code__.co_consts and None or None) if False else None
src2 = src.replace("if cnt <= 64:", "if cnt <= -1:")
ns2 = {"np": np, "_times_dk": _times_dk}; exec(src2, ns2); npsort = njit(nogil=True)(ns2["_energy_rows"])
src3 = src.replace("cap_u = max(16 * nu, 16)", "cap_u = max(48 * nu, 16)").replace("cap_f = max(4 * nu, 16)", "cap_f = max(8*nu, 16)")
ns3 = {"np": np, "_times_dk": _times_dk}; exec(src3, ns3); bigcap = njit(nogil=True)(ns3["_energy_rows"])
for name, f in [("base", base), ("npsort", npsort), ("bigcap", bigcap), ("installed", KN._energy_rows)]:
    for o in (2, 3):
        f(p2, c2, v2, Minv, o, unknown, pos, isf)
        print(name, o, "%.2f" % best(lambda: f(p2, c2, v2, Minv, o, unknown, pos, isf)))
print("---- interleaved, cpu time, min of 15")
res = {}
for rep in range(15):
    for name, f in [("base", base), ("npsort", npsort), ("bigcap", bigcap)]:
        for o in (2, 3):
            t = time.thread_time(); f(p2, c2, v2, Minv, o, unknown, pos, isf); dt = time.thread_time() - t
            res.setdefault((name, o), []).append(dt * 1e3)
for k, v in res.items(): print(k, "min %.2f med %.2f" % (min(v), np.median(v)))
print("---- installed vs base (cpu, min of 15)")
res = {}
for rep in range(15):
    for name, f in [("base", base), ("installed", KN._energy_rows)]:
        for o in (2, 3):
            t = time.thread_time(); f(p2, c2, v2, Minv, o, unknown, pos, isf); dt = time.thread_time() - t
            res.setdefault((name, o), []).append(dt * 1e3)
for k, v in res.items(): print(k, "min %.2f med %.2f" % (min(v), np.median(v)))
a = base(p2, c2, v2, Minv, 3, unknown, pos, isf); b = KN._energy_rows(p2, c2, v2, Minv, 3, unknown, pos, isf)
print("same:", all(np.array_equal(x, y) for x, y in zip(a, b)))
