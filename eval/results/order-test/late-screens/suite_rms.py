"""The default with and without env VAR=1 on eval's named suite cases, against the forced orders.
usage (from the repository root): suite_rms.py VAR NAME,NAME,..."""
import sys
from pathlib import Path
sys.path.insert(0, "."); sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "band-pooled"))
from eval import cases, regret
from abscreen import ab_regret
var = sys.argv[1]; names = sys.argv[2].split(",")
for n in names:
    rows, g, r, g2 = ab_regret(cases.build_case(n), var)
    f = " ".join(f"{rows[t]['rms_permille']:.4g}" for t in regret.FORCED)
    print(n, "forced", f, "A %.4g r %.3f" % (rows[regret.DEFAULT]["rms_permille"], g), "B %.4g r %.3f" % (r["rms_permille"], g2), flush=True)
