"""Tubes whose test found fewer than MIN_BANDS test bands: what the one band and the test holes said.

Usage, from the repository root:
``.venv/bin/python eval/results/order-test/one-band/oneband.py SEED [SEED ...] > OUT.jsonl``:
the band and scanner cases of each seed's first 16, one JSON line per tube
whose test found fewer than MIN_BANDS test bands.
"""
import json
import sys

sys.path.insert(0, ".")
import numpy as np

from eval import stress
from shellrepair.fill import band_test, selftest
from shellrepair.mesh.io import Mesh
from shellrepair.repair import repair_mesh

cap = {}
_te = band_test.tube_errors


def te(*a, **k):
    errs, n = _te(*a, **k)
    cap["band"] = ({str(o): float(v) for o, v in errs.items()}, int(n))
    return errs, n


band_test.tube_errors = te
_cb = selftest.choose_order_beside


def cb(*a, **k):
    t = _cb(*a, **k)
    cap.setdefault("beside", []).append((int(t.order), {int(o): float(v) for o, v in (t.errors or {}).items()}))
    return t


selftest.choose_order_beside = cb
ok = stress.available_shapes()
for seed in map(int, sys.argv[1:]):
    for i in range(16):
        c = stress.stress_case(i, seed, shapes_ok=ok)
        if not any(f in c.name for f in ("band", "scanner")):
            continue
        records = []
        from shellrepair.fill import band_fill as hole_mod
        _bo = hole_mod.band_order

        def bo(ctx, loops, _bo=_bo, records=records):
            cap.clear()
            out = _bo(ctx, loops)
            records.append({"band": cap.get("band"), "beside": cap.get("beside"), "order": out[0], "note": out[2]})
            return out

        hole_mod.band_order = bo
        try:
            repair_mesh(Mesh(V=c.V, F=c.F), order="auto", jobs=1)
        finally:
            hole_mod.band_order = _bo
        for r in records:
            if r["band"] is not None and r["band"][1] < band_test.MIN_BANDS:
                print(json.dumps({"case": c.name, **r}), flush=True)
