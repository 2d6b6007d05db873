"""A run loads only what it uses (issue 38): reading a scan loads no SciPy,
and a small repair no SciPy sparse graphs or solvers.

Each case runs in a fresh interpreter (what a module has imported is a
property of the process), with this checkout first on the path.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from eval import shapes
from shellrepair import Mesh, write_mesh

ROOT = Path(__file__).resolve().parents[1]

_RUN = """
import json, sys
{code}
print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in ('scipy', 'numba', 'open3d', 'igl', 'trimesh',
                                                                   'multiprocessing'))))
"""


def modules_after(code, tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "SHELLREPAIR_NO_NUMBA")}
    env["PYTHONPATH"] = str(ROOT)
    p = subprocess.run([sys.executable, "-c", _RUN.format(code=code)], capture_output=True, text=True, env=env,
                       cwd=tmp_path, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    return set(json.loads(p.stdout.strip().splitlines()[-1]))


def small_disc(tmp_path):
    V, F = shapes.icosphere(4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[int(np.argmax(V[:, 2]))], radius=0.2)
    path = tmp_path / "disc.ply"
    write_mesh(path, Mesh(V=V2, F=F2))
    return path


def test_reading_a_scan_loads_no_scipy(tmp_path):
    scan = small_disc(tmp_path)
    loaded = modules_after(f"import shellrepair\nm = shellrepair.read_mesh({str(scan)!r})\n"
                           f"assert len(m.F) > 0", tmp_path)
    assert not {m for m in loaded if m.startswith("scipy")}, sorted(loaded)[:10]


def test_a_small_repair_loads_no_sparse_graphs_solvers_or_pools(tmp_path):
    """The fill triangulates with Qhull and measures with k-d trees
    (scipy.spatial), nothing more of SciPy; one run of holes starts no pool."""
    scan = small_disc(tmp_path)
    out = tmp_path / "out.ply"
    loaded = modules_after("from shellrepair.cli import main\n"
                           f"assert main(['repair', {str(scan)!r}, '-o', {str(out)!r}, '-q']) == 0", tmp_path)
    assert "scipy.spatial" in loaded
    assert not loaded & {"scipy.sparse.csgraph", "scipy.sparse.linalg", "multiprocessing", "numba", "open3d", "igl",
                         "trimesh"}, sorted(loaded & {"scipy.sparse.csgraph", "scipy.sparse.linalg", "multiprocessing",
                                                       "numba", "open3d", "igl", "trimesh"})
    assert json.loads((tmp_path / "out.report.json").read_text())["filled"] == 1
