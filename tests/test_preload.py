"""The command line starts loading the fill's modules and compiled kernels
while it reads the scan (:func:`shellrepair.preload.preload_fill`): a
repair that starts while they load waits for them, and gives the same mesh
to the bit."""

import subprocess
import sys
from pathlib import Path

import pytest

from shellrepair import kernels

pytestmark = pytest.mark.skipif(not kernels.ENABLED, reason="needs the compiled kernels")

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = """
import hashlib, sys
from eval import shapes
from shellrepair.preload import preload_fill

preload = sys.argv[1] == "1"
thread = preload_fill() if preload else None
from shellrepair import cholesky, kernels
from shellrepair.io import Mesh
from shellrepair.repair import repair_mesh

V, F = shapes.bumpy_sphere(4, amplitude=0.03, frequency=5)
V, F, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.15, seed=4)
busy = thread is not None and thread.is_alive()
out, report = repair_mesh(Mesh(V=V, F=F))
if thread is not None:
    thread.join()
h = hashlib.sha256()
for a in (out.V, out.F, out.face_filled):
    h.update(a.tobytes())
print(h.hexdigest(), report["holes_before"], report["holes_after"], kernels._WARM, cholesky._WARM, busy)
"""


def _run(preload):
    r = subprocess.run([sys.executable, "-c", SCRIPT, "1" if preload else "0"], cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout.split()


def test_a_repair_started_while_the_kernels_load_gives_the_same_mesh():
    with_preload, without = _run(True), _run(False)
    assert with_preload[:5] == without[:5]
    assert with_preload[1:5] == ["3", "0", "True", "True"]


def test_without_the_kernels_the_modules_still_load(monkeypatch):
    from shellrepair import cholesky, preload

    monkeypatch.setattr(kernels, "ENABLED", False)
    warmed = []
    monkeypatch.setattr(kernels, "warm_up", lambda: warmed.append("kernels"))
    monkeypatch.setattr(cholesky, "warm_up", lambda: warmed.append("cholesky"))
    preload.preload_fill().join()
    assert warmed == []
