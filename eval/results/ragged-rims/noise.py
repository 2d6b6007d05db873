import sys; sys.path.insert(0, ".")
import numpy as np, os
from eval import shapes
from shellrepair.repair import repair_mesh
from shellrepair.mesh.io import Mesh
from shellrepair.holes.loops import detect_holes
for ico, rad in ((4, 0.5), (5, 0.6), (6, 0.5), (5, 0.3)):
  for noise in (0.0, 0.0005, 0.001, 0.002, 0.005):
    V, F = shapes.icosphere(ico)
    top = int(np.argmax(V[:, 2]))
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[top], radius=rad)
    rim = detect_holes(V2, F2).loops[0].vertices
    V3 = V2.copy()
    V3[rim] += noise * np.random.default_rng(0).standard_normal((len(rim), 3))
    err = {}
    for o in (1, 2, 3, "auto", "q"):
        if o == "q": os.environ["QRULE"] = "0.2"; os.environ["AGREE_LOG"] = "/tmp/s45/exp/noise.jsonl"
        R, rep = repair_mesh(Mesh(V=V3, F=F2), order="auto" if o == "q" else o)
        os.environ.pop("QRULE", None); os.environ.pop("AGREE_LOG", None)
        err[o] = float(np.sqrt(np.mean((np.linalg.norm(np.asarray(R.V)[len(V3):], axis=1) - 1.0) ** 2)))
    import json
    q = json.loads(open("/tmp/s45/exp/noise.jsonl").readlines()[-1])
    print(ico, rad, noise, {k: round(v, 5) for k, v in err.items()}, "q", round(q["s23"] / q["s12"], 3), "rough/s23", round(q["rough"] / q["s23"], 3), "rough/e", round(q["rough"]/q["edge"],4))
