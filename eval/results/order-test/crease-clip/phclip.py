import sys, os, json, io, contextlib
sys.path.insert(0, ".")
import numpy as np
src = open("/work/main/eval/results/ragged-rims/perhole.py").read()
src = src[:src.index("seed, i, rag = int(sys.argv[1])")]
exec(src)
seed = int(sys.argv[1]); fams = sys.argv[2].split(","); idx = [int(x) for x in sys.argv[3].split(",")]
out = []
for i in idx:
    c = stress.stress_case(i, seed, shapes_ok=ok, family=fams[i % len(fams)], shape="fandisk")
    facts = stress.input_facts(c)
    loops, _ = boundary_loops(np.asarray(c.F, np.int64), len(c.V))
    loopid = np.full(len(c.V), -1)
    for j, L in enumerate(loops):
        loopid[np.asarray(L)] = j
    res = {}
    for o in (1, 2, 3):
        m, rep = repair_mesh(Mesh(V=c.V, F=c.F), order=o)
        res[o] = per_loop(c, facts, np.asarray(m.V), np.asarray(m.F), loopid)
    os.environ.update(CLIP="45", CLIPFORCE="1", CLIPLOG="1")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        repair_mesh(Mesh(V=c.V, F=c.F), order="auto", jobs=1)
    for k in ("CLIP", "CLIPFORCE", "CLIPLOG"):
        os.environ.pop(k)
    logs = [json.loads(l[9:]) for l in buf.getvalue().splitlines() if l.startswith("CLIPJSON ")]
    diag = facts["truth"].diag
    for lg in logs:
        j = [jj for jj, L in enumerate(loops) if int(np.min(L)) == lg["v0"]]
        if not j:
            continue
        key = str(j[0])
        if not all(key in res[o] for o in (1, 2, 3)):
            continue
        lg["true"] = {str(o): 1000 * np.sqrt(res[o][key][1]) / diag for o in (1, 2, 3)}
        lg["area"] = res[2][key][0]
        lg["case"] = c.name
        out.append(lg)
        bp = min(lg["plain"], key=lg["plain"].get) if lg["plain"] else "-"
        bc = min(lg["clipped"], key=lg["clipped"].get) if lg["clipped"] else "-"
        bt = min(lg["true"], key=lg["true"].get)
        print(c.name[-28:], "k", lg["k"], "plan %.1e c1 %.2f c6 %.2f" % (lg["plan"], lg["c1"], lg["c6"]), "np", lg["np"], "nc", lg["nc"],
              "plain->", bp, "clip->", bc, "true", {o: round(v, 2) for o, v in lg["true"].items()}, "best", bt, flush=True)
json.dump(out, open(sys.argv[4], "w"))
