"""The kernels compiled ahead of time (shellrepair.compiled, shellrepair.aot).

A repair runs the compiled modules when ``make setup`` built them for the
current sources, and imports no Numba; any call they do not cover goes to
Numba's JIT, which must give the same bits.
"""

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shellrepair import compiled

ROOT = Path(__file__).resolve().parents[1]
BUNNY = ROOT / "data" / "bunny_zipper.ply"

_built = pytest.mark.skipif(not compiled.aot_built(),
                            reason="the ahead-of-time kernels are not built for these sources (make setup builds them)")


def _values():
    a = np.arange(12.0).reshape(4, 3)
    ro = a.copy()
    ro.flags.writeable = False
    return [a, a[:, 0], a[::2], np.asfortranarray(a), a.T, ro, np.zeros(0, np.int64), np.zeros((0, 3)),
            np.array(3.0), np.ones(3, np.bool_), np.ones(2, np.int32), 1.5, 7, True, np.float64(2.0), np.int64(3),
            np.bool_(False), None, (1, 2), (1.0, np.ones(2))]


def test_argument_keys_name_the_types_numba_gives_them():
    """describe() and the build's key-to-type map agree with numba.typeof on
    arrays of every layout (strided, Fortran, read-only, empty, 0-d),
    scalars of Python and NumPy, None and tuples: a compiled function is
    called only with the types it was compiled for."""
    numba = pytest.importorskip("numba")
    from shellrepair.aot import numba_type

    for v in _values():
        assert numba_type(compiled.describe(v)) == numba.typeof(v), v


def test_the_types_file_lists_only_known_kernels_with_usable_types():
    rows = compiled.read_types()
    assert rows, "shellrepair/aot_types.json is empty"
    for module in compiled.MODULES:   # register their kernels
        importlib.import_module(module)

    for module, name, args in rows:
        k = compiled.REGISTRY[module][name]
        assert len(args) == len(k._params), (name, args)
    assert len({(m, n, a) for m, n, a in rows}) == len(rows)


_RUN = """
import sys
from shellrepair import cli, compiled
sys.argv = ["shellrepair", "repair", sys.argv[1], "-o", sys.argv[2], "--jobs", "1"]
try:
    cli.main()
except SystemExit:
    pass
print("RESULT", "numba" in sys.modules, compiled.aot_loaded(), compiled.jit_loaded())
"""


def _repair(src, out, **env):
    e = {k: v for k, v in os.environ.items() if k not in ("SHELLREPAIR_NO_AOT", "SHELLREPAIR_NO_NUMBA")}
    e.update(env)
    r = subprocess.run([sys.executable, "-c", _RUN, str(src), str(out)], capture_output=True, text=True, env=e,
                       cwd=ROOT, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT")][-1].split()[1:]
    return [w == "True" for w in line]


@_built
@pytest.mark.slow
def test_a_repair_runs_the_compiled_kernels_and_never_imports_numba(tmp_path):
    """The bundled scan (5 holes) repaired in a fresh process: every kernel
    call finds its compiled function (none falls back to the JIT) and Numba
    is never imported."""
    numba_imported, aot, jit = _repair(BUNNY, tmp_path / "out.ply")
    assert aot and not jit and not numba_imported


@pytest.mark.slow
@_built
def test_compiled_and_jit_kernels_write_the_same_bytes(tmp_path):
    """The same repair with the compiled modules and with Numba's JIT alone
    (``SHELLREPAIR_NO_AOT=1``, what a machine where the build failed runs)
    writes the same file."""
    pytest.importorskip("numba")
    _repair(BUNNY, tmp_path / "aot.ply")
    numba_imported, aot, jit = _repair(BUNNY, tmp_path / "jit.ply", SHELLREPAIR_NO_AOT="1")
    assert numba_imported and jit and not aot
    assert (tmp_path / "aot.ply").read_bytes() == (tmp_path / "jit.ply").read_bytes()


def test_every_module_that_defines_kernels_is_compiled_and_hashed():
    """Each module that marks kernels with ``compiled.kernel`` is among
    :data:`shellrepair.compiled.MODULES`: the build compiles its kernels
    and the source hash covers its file."""
    marking = {".".join(p.relative_to(ROOT).with_suffix("").parts) for p in (ROOT / "shellrepair").rglob("*.py")
               if "njit = compiled.kernel" in p.read_text(encoding="utf-8")}
    assert marking == set(compiled.MODULES)
    for module in compiled.MODULES:
        assert (ROOT / Path(*module.split("."))).with_suffix(".py").exists(), module


def test_a_changed_kernel_source_names_other_modules(tmp_path, monkeypatch):
    """The compiled modules' names carry a hash of the kernels' sources and
    of the types file, so a checkout whose kernels changed (a pull without
    ``make``) finds no module to load and runs the JIT."""
    files = [str(Path(*m.split(".")[1:]).with_suffix(".py")) for m in compiled.MODULES]
    here = tmp_path / "shellrepair"
    for name in files + ["aot_types.json"]:
        (here / name).parent.mkdir(parents=True, exist_ok=True)
        (here / name).write_bytes((compiled.HERE / name).read_bytes())
    monkeypatch.setattr(compiled, "HERE", here)
    monkeypatch.setattr(compiled, "TYPES_FILE", here / "aot_types.json")
    before = compiled.source_hash()
    for name in files:   # an edit of any kernel module
        with open(here / name, "a") as f:
            f.write("\n# an edit\n")
        assert compiled.source_hash() != before, name
        (here / name).write_bytes((ROOT / "shellrepair" / name).read_bytes())
        assert compiled.source_hash() == before
    rows = json.loads((here / "aot_types.json").read_text())
    (here / "aot_types.json").write_text(json.dumps(rows[:-1]))
    assert compiled.source_hash() != before
