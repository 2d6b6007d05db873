import sys, numpy as np
seeds = sys.argv[1]
sys.argv = ["ana.py", seeds]
exec(open("ana.py").read().split("if \"-v\"")[0])
exec("def evaluate" + open("ana.py").read().split("def evaluate")[1].split("def cur")[0])
def cur(l, c, h): return current(c) if c else None
def curdep(l, c, h, t=1.0):
    o = cur(l, c, h)
    return 2 if (o == 3 and h is not None and h["s23"] >= t * h["s12"]) else o
def oracle(l, c, h):
    return None
import math
P = {
 "cur+dep": curdep,
 "cur+dep0.3": lambda l, c, h: curdep(l, c, h, 0.3),
 "band .05-.2 ->3 else cur+dep": lambda l, c, h: 3 if h and 0.05 * h["s12"] <= h["s23"] < 0.2 * h["s12"] else curdep(l, c, h),
 "band .05-.3 ->3 else 2": lambda l, c, h: None if h is None else (3 if 0.05 * h["s12"] <= h["s23"] < 0.3 * h["s12"] else 2),
 "band .05-.2 ->3 else 2": lambda l, c, h: None if h is None else (3 if 0.05 * h["s12"] <= h["s23"] < 0.2 * h["s12"] else 2),
 "q<.2 ->3 else 2": lambda l, c, h: None if h is None else (3 if h["s23"] < 0.2 * h["s12"] else 2),
 "q<.3 ->3 else 2": lambda l, c, h: None if h is None else (3 if h["s23"] < 0.3 * h["s12"] else 2),
 "q<.2 ->3, untold->cur+dep... i.e. cur+dep where told else q": lambda l, c, h: curdep(l, c, h) if (c and current(c)) else (None if h is None else (3 if h["s23"] < 0.2 * h["s12"] else 2)),
}
for n, p in P.items():
    print(f"{n:50s}", evaluate(p))
