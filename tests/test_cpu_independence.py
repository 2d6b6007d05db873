"""The same scan and options give the same bytes on any processor.

OpenBLAS (bundled with NumPy and SciPy) picks its kernels by processor at
load time, and its kernels round differently: a Haswell's and a
Skylake-X's products of the same matrices differ in their last bits. A
repair whose numbers passed through them wrote other bytes on another
machine. The fairing's factorisation now sums in its own fixed order
(:mod:`shellrepair.fill.cholesky`), so these tests repair a scan in fresh
processes told to use other processors' kernels (``OPENBLAS_CORETYPE``,
and NumPy's dispatch without AVX-512: ``NPY_DISABLE_CPU_FEATURES``) and
compare the written files byte for byte. Before, the case below gave
three different files.
"""

import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shellrepair import Mesh, write_mesh

ROOT = Path(__file__).resolve().parents[1]

#: A processor of each kind: OpenBLAS's kernels for it, and the NumPy
#: dispatch targets it would lack.
MACHINES = {
    "skylakex": {"OPENBLAS_CORETYPE": "SkylakeX"},
    "haswell": {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": "X86_V4,AVX512_ICL,AVX512_SPR"},
    "prescott": {"OPENBLAS_CORETYPE": "Prescott",
                 "NPY_DISABLE_CPU_FEATURES": "X86_V3,X86_V4,AVX512_ICL,AVX512_SPR"},
}


def _openblas_picks_kernels():
    """Whether this NumPy's OpenBLAS picks kernels at load time (a
    DYNAMIC_ARCH build on x86-64), so that OPENBLAS_CORETYPE can stand in
    for another processor."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    try:
        cfg = np.show_config(mode="dicts")
    except TypeError:
        return False
    text = str(cfg.get("Build Dependencies", {}).get("blas", {}))
    return "openblas" in text.lower() and "DYNAMIC_ARCH" in text


pytestmark = pytest.mark.skipif(not _openblas_picks_kernels(),
                                reason="NumPy's BLAS is not an OpenBLAS that picks its kernels by processor "
                                       "(x86-64, DYNAMIC_ARCH): no other processor to stand in for")


def _scan_with_large_holes(path):
    """A bumpy sphere with two large discs cut out: patches of a few
    thousand unknowns, whose factorisations have fronts of hundreds of rows
    (where BLAS's kernels and their rounding took over)."""
    from eval import cases, shapes

    V, F = shapes.bumpy_sphere(5, amplitude=0.05, frequency=5, seed=3)
    rem = cases.disc_mask(V, F, 2, 0.45, seed=7, separation=2.5)
    keep = np.flatnonzero(~rem)
    F2 = F[keep]
    used = np.unique(F2)
    remap = np.full(len(V), -1, np.int64)
    remap[used] = np.arange(len(used))
    write_mesh(path, Mesh(V[used], remap[F2]))


def _repair_bytes(tmp_path, scan, name, env_extra):
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
    env.update(env_extra)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    out = tmp_path / f"{name}.ply"
    p = subprocess.run([sys.executable, "-m", "shellrepair.cli", "repair", str(scan), "-o", str(out),
                        "--report", str(tmp_path / f"{name}.json"), "-q"],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    return out.read_bytes()


def test_a_repair_writes_the_same_bytes_with_every_processors_blas_kernels(tmp_path):
    scan = tmp_path / "scan.ply"
    _scan_with_large_holes(scan)
    written = {name: _repair_bytes(tmp_path, scan, name, extra) for name, extra in MACHINES.items()}
    assert len(written["skylakex"]) > 0
    differ = [name for name, b in written.items() if b != written["skylakex"]]
    assert not differ, f"the repair wrote other bytes with the kernels of {differ} than with Skylake-X's"


def test_the_factorisation_gives_the_same_bits_with_every_processors_blas_kernels(tmp_path):
    # a 2-D grid Laplacian squared: fronts of a hundred and more rows
    code = (
        "import sys, numpy as np, scipy.sparse as sp\n"
        "from shellrepair.fill import cholesky\n"
        "n = 60\n"
        "T = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])\n"
        "L = sp.kronsum(T, T).tocsc()\n"
        "Q = (L @ L + 1e-3 * sp.eye(n * n)).tocsc()\n"
        "b = np.sin(np.arange(n * n * 3, dtype=float)).reshape(-1, 3)\n"
        "x = cholesky.factor(Q).solve(b)\n"
        "sys.stdout.write(x.tobytes().hex())\n")
    out = {}
    for name, extra in MACHINES.items():
        env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")}
        env.update(extra)
        env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
        p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                           timeout=600)
        assert p.returncode == 0, p.stderr
        out[name] = p.stdout
    assert out["skylakex"]
    assert out["haswell"] == out["skylakex"] and out["prescott"] == out["skylakex"]
