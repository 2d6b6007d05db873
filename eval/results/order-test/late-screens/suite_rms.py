import sys, os; sys.path.insert(0, ".")
from eval import cases, regret
var = sys.argv[1]; names = sys.argv[2].split(",")
for n in names:
    c = cases.build_case(n)
    rows = regret.run_case(c, tools=regret.FORCED + (regret.DEFAULT,), log=lambda *a: None)
    g, _ = regret.regret(rows)
    os.environ[var] = "1"
    r = regret.run_case(c, tools=(regret.DEFAULT,), log=lambda *a: None)[regret.DEFAULT]
    os.environ.pop(var, None)
    rows2 = dict(rows); rows2[regret.DEFAULT] = r
    g2, _ = regret.regret(rows2)
    f = " ".join(f"{rows[t]['rms_permille']:.4g}" for t in regret.FORCED)
    print(n, "forced", f, "A %.4g r %.3f" % (rows[regret.DEFAULT]["rms_permille"], g), "B %.4g r %.3f" % (r["rms_permille"], g2), flush=True)
