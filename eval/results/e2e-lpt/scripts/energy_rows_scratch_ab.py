import sys, time, pickle
sys.path.insert(0, "/work/main")
import numpy as np
from numba import njit
import shellrepair.kernels as KN
caps = pickle.load(open("/tmp/caps.pkl", "rb"))
src = open("/tmp/er_src3.py").read().replace("@njit(cache=True, nogil=True)", "@njit(nogil=True)")
src = src[:src.index("\n\n\n@njit(nogil=True)\ndef _symmetrise")] if "def _symmetrise" in src else src
ns = {"np": np, "njit": njit}; exec(src, ns); base = ns["_energy_rows"]
src2 = (src.replace("m1, m2, m3 = np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64)",
                    "m1, m2, m3 = np.zeros(n, np.uint8), np.zeros(n, np.uint8), np.zeros(n, np.uint8)")
           .replace("l1, l2, l3 = np.empty(n + 1, np.int64), np.empty(n + 1, np.int64), np.empty(n + 1, np.int64)",
                    "l1, l2, l3 = np.empty(n + 1, np.int32), np.empty(n + 1, np.int32), np.empty(n + 1, np.int32)")
           .replace("cnt2 += 1 - mark2[j]", "cnt2 += 1 - np.int64(mark2[j])")
           .replace("cnt1 += 1 - m1[j]", "cnt1 += 1 - np.int64(m1[j])"))
assert src2 != src
ns2 = {"np": np, "njit": njit}; exec(src2, ns2); small = ns2["_energy_rows"]
for key in [(3, 11847, False), (2, 11847, False), (3, 4010, False)]:
    K, Minv, order, fixed, unknown = caps[key]
    ptr, col, val = K
    n = ptr.size - 1
    p2, c2, v2 = KN._drop_spare_diagonal(ptr, col, val)
    pos = np.empty(n, np.int64); pos[unknown] = np.arange(unknown.size); pos[fixed] = np.arange(fixed.size)
    isf = np.zeros(n, np.bool_); isf[fixed] = True
    a = base(p2, c2, v2, Minv, order, unknown, pos, isf); b = small(p2, c2, v2, Minv, order, unknown, pos, isf)
    same = all(np.array_equal(x, y) for x, y in zip(a, b))
    res = {}
    for rep in range(21):
        for name, f in [("base", base), ("small", small)]:
            t = time.thread_time(); f(p2, c2, v2, Minv, order, unknown, pos, isf); res.setdefault(name, []).append((time.thread_time() - t) * 1e3)
    print(key, "same", same, " ".join("%s min %.2f med %.2f" % (k, min(v), np.median(v)) for k, v in res.items()))
