"""The command line starts loading the fill's modules and Numba's set-up
while it reads the scan (:func:`shellrepair.preload.preload_fill`); the
kernels load when first called. A repair that starts while that goes on
gives the same mesh to the bit."""

import subprocess
import sys
from pathlib import Path

import pytest

from shellrepair import compiled
from shellrepair.mesh import common_kernels

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="needs the compiled kernels")

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = """
import hashlib, sys
from eval import shapes
from shellrepair.preload import preload_fill

preload = sys.argv[1] == "1"
thread = preload_fill() if preload else None
from shellrepair.mesh.io import Mesh
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
print(h.hexdigest(), report["holes_before"], report["holes_after"], busy)
"""


def _run(preload):
    r = subprocess.run([sys.executable, "-c", SCRIPT, "1" if preload else "0"], cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout.split()


@pytest.mark.slow
def test_a_repair_started_while_the_kernels_load_gives_the_same_mesh():
    with_preload, without = _run(True), _run(False)
    assert with_preload[:3] == without[:3]
    assert with_preload[1:3] == ["3", "0"]


def test_the_preload_sets_numba_up_only_where_the_kernels_are_on(monkeypatch):
    from shellrepair import preload

    calls = []
    monkeypatch.setattr(common_kernels, "max_sq_distance", lambda Q: calls.append(len(Q)) or 0.0)
    for on in (False, True):
        monkeypatch.setattr(compiled, "ENABLED", on)
        preload.preload_fill().join()
    assert calls == [1]
