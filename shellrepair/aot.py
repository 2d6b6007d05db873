"""Build the kernels ahead of time: ``python -m shellrepair.aot build``.

``record`` runs the kernels' warm-ups (every kernel on tiny inputs, with the
argument types a repair passes) and a repair of a small perforated sphere
under Numba's JIT, notes the argument types of each kernel called from
Python, and writes them to ``shellrepair/aot_types.json`` (committed: the
build needs no JIT run). ``build`` compiles those kernels for those types
with ``numba.pycc`` into :data:`shellrepair.compiled.PARTS` extension
modules beside the package (``build --part P`` builds one, so that the
Makefile runs the parts in parallel processes), and removes modules built
from older sources. The exported functions release the GIL, as the JIT's
``nogil`` kernels do (the fill's helper thread runs beside them).

``numba.pycc`` is deprecated by Numba (kept in 0.68) and needs a C
compiler; when the build fails, runs use the JIT, as before this module
(the Makefile then runs the JIT warm-ups instead), so losing it costs
only the load time it saves.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
import tempfile
from pathlib import Path

from shellrepair import compiled
from shellrepair.files import atomic_write

__all__ = ["record", "build", "numba_type"]


def numba_type(key):
    """The Numba type of an argument key of :func:`shellrepair.compiled.describe`."""
    import numpy as np
    from numba.core import types
    from numba.np.numpy_support import from_dtype

    if key is None:
        return types.none
    if isinstance(key, str):
        return from_dtype(np.dtype(key))
    if key[0] == "t":
        items = [numba_type(k) for k in key[1:]]
        return types.Tuple(items) if items and len(set(items)) > 1 else types.UniTuple(items[0], len(items)) if items else types.Tuple(())
    dtype, ndim, layout, writeable, aligned = key
    return types.Array(from_dtype(np.dtype(dtype)), ndim, layout, readonly=not writeable, aligned=aligned)


def record(path=compiled.TYPES_FILE):
    """Write the argument types the warm-ups and a small repair pass to each kernel."""
    os.environ["SHELLREPAIR_NO_AOT"] = "1"
    compiled._BUILT = False
    from shellrepair import warmup
    from shellrepair.fill import cholesky

    compiled.start_recording()
    warmup.warm_up()
    cholesky.warm_up()
    _small_repair()
    rows = [[m, n, list(_listed(a))] for m, n, a in compiled.recorded()
            if not any(_unusable(k) for k in a)]
    atomic_write(path, "[\n" + ",\n".join(json.dumps(r, separators=(",", ":")) for r in rows) + "\n]\n")
    print(f"recorded {len(rows)} kernel signatures in {path}")


def _listed(x):
    return [_listed(y) for y in x] if isinstance(x, tuple) else x


def _unusable(key):
    return isinstance(key, tuple) and (key[0] == "?" or (key[0] == "t" and any(_unusable(k) for k in key[1:])))


def _small_repair():
    """A repair of a sphere with three holes of different sizes, in memory."""
    import numpy as np

    from shellrepair.mesh.core import Mesh
    from shellrepair.repair import repair_mesh

    t = (1 + 5 ** 0.5) / 2
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    for _ in range(5):
        E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        u, inv = np.unique(E, axis=0, return_inverse=True)
        inv = inv.ravel()
        mid = len(V) + inv.reshape(3, -1).T
        V = np.vstack([V, (V[u[:, 0]] + V[u[:, 1]]) / 2])
        a, b, c = F.T
        ab, bc, ca = mid.T
        F = np.concatenate([np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]])
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    keep = np.ones(len(F), bool)
    C = V[F].mean(axis=1)
    for centre, r in (([0, 0, 1], 0.12), ([1, 0, 0], 0.35), ([0, -1, 0], 0.6)):
        keep &= np.linalg.norm(C - centre, axis=1) > r
    repair_mesh(Mesh(V, F[keep]))


def build(part=None, out_dir=None):
    """Compile the recorded kernels into the extension modules (one part, or all)."""
    os.environ["SHELLREPAIR_NO_AOT"] = "1"
    compiled._BUILT = False
    import numba.pycc.compiler as pycc_compiler
    from numba.pycc import CC

    for module in compiled.MODULES:   # registers their kernels
        importlib.import_module(module)

    class _ReleaseGil(pycc_compiler.Flags):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self.release_gil = True

    pycc_compiler.Flags = _ReleaseGil
    compiled._make_jit()   # the copies whose globals name the callees' dispatchers
    out_dir = Path(out_dir or compiled.HERE)
    rows = compiled.read_types()
    names = compiled._aot_names()
    parts = range(compiled.PARTS) if part is None else [int(part)]
    for p in parts:
        cc = CC(names[p])
        cc.verbose = False
        with tempfile.TemporaryDirectory() as tmp:
            cc.output_dir = tmp
            for i, (m, n, args) in enumerate(rows):
                if compiled.part_of(i) != p:
                    continue
                k = compiled.REGISTRY[m][n]
                cc.export(compiled.symbol(i), tuple(numba_type(a) for a in args))(k.jit.py_func)
            cc.compile()
            built = [f for f in os.listdir(tmp) if f.startswith(names[p])]
            for f in built:  # a process importing the package meanwhile sees the old file or the new, whole
                src = os.path.join(tmp, f)
                with open(src, "rb") as fh:
                    atomic_write(out_dir / f, fh.read(), mode=os.stat(src).st_mode & 0o777, os_errors=True)
        print(f"built {names[p]} ({sum(compiled.part_of(i) == p for i in range(len(rows)))} kernel signatures)")
    current = set(names)
    for f in out_dir.glob("_aot_*"):
        if f.name.split(".")[0] not in current:
            f.unlink()


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m shellrepair.aot", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("record", help="write shellrepair/aot_types.json from the warm-ups under the JIT")
    b = sub.add_parser("build", help="compile the kernels for the recorded types")
    b.add_argument("--part", type=int, default=None)
    a = ap.parse_args(argv)
    if a.cmd == "record":
        record()
    else:
        build(a.part)
    return 0


if __name__ == "__main__":
    sys.exit(main())
