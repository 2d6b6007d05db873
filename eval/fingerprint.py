"""Fingerprints of the repair's outputs, to show a refactor changed no bit.

Repairs the bundled scan (orders 2 and 3, the seed method), a 30-hole
bumpy sphere with one and two processes, and every synthetic case of the
eval suite (``quick`` size, no real scans), and prints one SHA-256 prefix
per run over the output arrays (V, F and every per-vertex / per-face array
of the mesh) and the report without its timing fields and file path.

Usage: run it on the old and the new code and compare::

    git stash; python eval/fingerprint.py > before.json; git stash pop
    python eval/fingerprint.py > after.json; cmp before.json after.json

The module split of issue 16 was checked this way (all 20 runs equal).
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from eval import shapes  # noqa: E402
from shellrepair.mesh.io import Mesh, read_mesh  # noqa: E402
from shellrepair.repair import repair_mesh  # noqa: E402
from eval import cases  # noqa: E402


def _strip(x):
    if isinstance(x, dict):
        return {k: _strip(v) for k, v in x.items()
                if "second" not in k and "time" not in k and k != "file"}
    if isinstance(x, (list, tuple)):
        return [_strip(v) for v in x]
    return x


def fingerprint(mesh, report):
    """SHA-256 prefix of a repaired mesh's arrays and its report (timings dropped)."""
    d = hashlib.sha256()
    for k in sorted(vars(mesh)):
        v = getattr(mesh, k)
        if isinstance(v, np.ndarray):
            d.update(k.encode())
            d.update(np.ascontiguousarray(v).tobytes())
    d.update(json.dumps(_strip(report), sort_keys=True, default=str).encode())
    return d.hexdigest()[:16]


def main():
    out = {}
    scan = read_mesh(ROOT / "data" / "bunny_zipper.ply")
    out["bunny"] = fingerprint(*repair_mesh(scan))
    out["bunny-o3"] = fingerprint(*repair_mesh(scan, order=3))
    out["bunny-seed"] = fingerprint(*repair_mesh(scan, method="seed"))
    V, F = shapes.bumpy_sphere(4, amplitude=0.02, frequency=5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=30, radius=0.09, seed=5)
    out["discs-j1"] = fingerprint(*repair_mesh(Mesh(V=V2, F=F2)))
    out["discs-j2"] = fingerprint(*repair_mesh(Mesh(V=V2, F=F2), jobs=2))
    for name in cases.case_names():
        if name.split("-")[0] in cases.REAL_SCANS or "bust" in name:
            continue  # real scans need ../shared
        c = cases.build_case(name, quick=True)
        out[name] = fingerprint(*repair_mesh(Mesh(V=c.V, F=c.F)))
    print(json.dumps(out, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
