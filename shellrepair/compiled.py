"""The compiled kernels: machine code built ahead of time, Numba's JIT behind it.

Each kernel module sits beside the code it speeds up
(:mod:`shellrepair.fill.refine_kernels` beside :mod:`shellrepair.fill.refine`, and
so on for context, topology, triangulate, patch, intersect, intrinsic,
fair, checks, bridge and distance; :mod:`shellrepair.mesh.common_kernels` holds
the helpers several share; :mod:`shellrepair.fill.cholesky` is the fairing's
sparse factorisation). Each kernel does what a NumPy (or plain Python)
function of the package does, with the same floating-point operations in
the same order, so its result is the same to the bit; that function stays
as the path taken with the kernels off and as the test oracle. The kernels
exist because the per-hole work is many small steps: in NumPy each costs a
few microseconds of dispatch whatever its size, and loops of rounds (edge
flips) pay it hundreds of times a hole.

The kernels are written once, as Numba functions, and marked with
:func:`kernel` (in place of ``numba.njit``). ``make setup`` (``python -m shellrepair.aot
build``) compiles them ahead of time, for the argument types listed in
``shellrepair/aot_types.json``, into extension modules beside this file
(``_aot_<source hash>_<part>*.so``). A run then imports those modules in
a few milliseconds and never imports Numba: on this project's 2-core
machine ``import numba`` alone takes 1.5-1.8 s and loading the cached JIT
kernels a small repair uses another 1-1.3 s (a sphere with one small hole:
4.4-5.1 s wall with the JIT, against 1.4-1.6 s with the NumPy versions).

A call whose argument types are not among the compiled ones (another
dtype, a strided view, a read-only array), or any call when the modules
are missing or were built from other sources (the module name carries a
hash of the kernels' files, so a ``git pull`` without ``make`` never runs
stale code), goes to Numba's JIT instead, which compiles or loads the
kernel from its cache as before. Both are the same source compiled by the
same LLVM without fast-math, so they give the same bits (tests/test_aot.py
compares them); only the time differs.

The one switch: ``SHELLREPAIR_NO_NUMBA=1`` turns every kernel off, here
and in :mod:`shellrepair.mesh.fastmesh` and :mod:`shellrepair.appearance.reflectance`
(callers use their NumPy versions, as without Numba). :data:`ENABLED` is
the flag every caller reads (``if compiled.ENABLED:``, at call time, so a
test may set it False to run the NumPy versions). ``SHELLREPAIR_NO_AOT=1``
is the build's and the tests' own: it skips the compiled modules (the JIT
only), to record the types or to compare the two.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import inspect
import os
import threading
import types
from pathlib import Path

import numpy as np

__all__ = ["ENABLED", "kernel", "available", "numba_found", "aot_loaded", "jit_loaded", "source_hash", "TYPES_FILE",
           "PARTS", "MODULES", "describe", "aot_built"]

HERE = Path(__file__).resolve().parent
#: The argument types compiled ahead of time (written by ``python -m shellrepair.aot record``).
TYPES_FILE = HERE / "aot_types.json"
#: The modules whose kernels are compiled ahead of time (their source is hashed).
MODULES = (
    "shellrepair.mesh.common_kernels",
    "shellrepair.mesh.topology_kernels",
    "shellrepair.mesh.index_kernels",
    "shellrepair.fill.triangulate_kernels",
    "shellrepair.fill.patch_kernels",
    "shellrepair.mesh.intersect_kernels",
    "shellrepair.fill.intrinsic_kernels",
    "shellrepair.fill.refine_kernels",
    "shellrepair.fill.fair_kernels",
    "shellrepair.fill.checks_kernels",
    "shellrepair.fill.probe_kernels",
    "shellrepair.fill.bridge_kernels",
    "shellrepair.mesh.distance_kernels",
    "shellrepair.fill.cholesky",
)
#: Extension modules the kernels are split into (built side by side, one process each).
PARTS = 2

_NO_NUMBA = bool(os.environ.get("SHELLREPAIR_NO_NUMBA"))
_NO_AOT = bool(os.environ.get("SHELLREPAIR_NO_AOT"))

#: Every kernel, by module then name, in definition order.
REGISTRY: dict[str, dict[str, "Kernel"]] = {}

_LOCK = threading.RLock()
_AOT = None          # {(module, name): {arg types: function}} once looked up; {} when there is none
_JIT = False         # whether Numba's dispatchers were made
_RECORD = None       # set of (module, name, arg types) when recording


def source_hash() -> str:
    """The first 12 hex digits of a SHA-256 over the kernels' source files
    and the types file: the compiled modules' names carry it."""
    h = hashlib.sha256()
    for name in MODULES:
        h.update((HERE.parent / Path(*name.split("."))).with_suffix(".py").read_bytes())
    h.update(TYPES_FILE.read_bytes() if TYPES_FILE.exists() else b"")
    return h.hexdigest()[:12]


def _aot_names(digest=None):
    digest = digest or source_hash()
    return [f"_aot_{digest}_{p}" for p in range(PARTS)]


_BUILT = None


def aot_built() -> bool:
    """Whether the compiled modules for these sources are there (looked up once)."""
    global _BUILT
    if _BUILT is None:
        _BUILT = not (_NO_AOT or _NO_NUMBA) and all(
            importlib.util.find_spec(f"shellrepair.{n}") is not None for n in _aot_names())
    return _BUILT


@functools.cache
def numba_found() -> bool:
    """Whether Numba can be imported (looked up once, not imported)."""
    return importlib.util.find_spec("numba") is not None


def available() -> bool:
    """Whether kernels run at all: the compiled modules are built for these
    sources, or Numba can be imported (and ``SHELLREPAIR_NO_NUMBA`` is unset)."""
    if _NO_NUMBA:
        return False
    return aot_built() or numba_found()


#: The one flag: whether the kernels run (:func:`available`, once at import).
#: Every caller reads it at call time; when False, the NumPy versions run.
ENABLED = available()


#: NumPy's flag bits a kernel's type reads: C_CONTIGUOUS, F_CONTIGUOUS, ALIGNED, WRITEABLE.
_FLAG_BITS = 0x1 | 0x2 | 0x100 | 0x400
_ARRAY_KEYS = {}      # (dtype, ndim, flag bits) -> describe's key


def describe(v):
    """The key of an argument's Numba type, as the compiled table spells it:
    an array by (dtype, ndim, layout, writeable, aligned), a scalar by its
    dtype, a tuple by its items, None as None. What Numba would type
    otherwise (a list, a function) gets a key no compiled function has."""
    t = type(v)
    if t is np.ndarray:
        # (the flags as NumPy's bit mask: C and F contiguous, aligned,
        # writeable; each key made once, as dtype.str alone costs 0.4 us)
        num = v.flags.num & _FLAG_BITS
        k = (v.dtype, v.ndim, num)
        key = _ARRAY_KEYS.get(k)
        if key is None:
            key = _ARRAY_KEYS[k] = (v.dtype.str, v.ndim, "C" if num & 0x1 else "F" if num & 0x2 else "A",
                                    bool(num & 0x400), bool(num & 0x100))
        return key
    if t is float:
        return "<f8"
    if t is bool:
        return "|b1"
    if t is int:
        return "<i8" if -2 ** 63 <= v < 2 ** 63 else ("?", "int")
    if v is None:
        return None
    if t is tuple:
        return ("t",) + tuple(describe(x) for x in v)
    if isinstance(v, np.generic):
        return v.dtype.str
    return ("?", t.__name__)


def _frozen(x):
    """JSON lists back to the tuples :func:`describe` gives."""
    return tuple(_frozen(y) for y in x) if isinstance(x, list) else x


def read_types(path=TYPES_FILE):
    """The types file as ``[(module, name, arg keys), ...]`` in its order."""
    import json

    if not Path(path).exists():
        return []
    rows = json.loads(Path(path).read_text())
    return [(m, n, _frozen(a)) for m, n, a in rows]


def symbol(i: int) -> str:
    """The compiled function of the types file's row ``i``."""
    return f"k{i}"


def part_of(i: int) -> int:
    """Which compiled module holds row ``i``."""
    return i % PARTS


def _load_aot():
    global _AOT
    with _LOCK:
        if _AOT is not None:
            return _AOT
        table = {}
        if aot_built():
            digest = source_hash()
            mods = [importlib.import_module(f"shellrepair.{n}") for n in _aot_names(digest)]
            for i, (m, n, args) in enumerate(read_types()):
                table.setdefault((m, n), {})[args] = getattr(mods[part_of(i)], symbol(i))
        _AOT = table
        return table


def aot_loaded() -> bool:
    """Whether the compiled modules are in use in this process."""
    return bool(_load_aot())


def jit_loaded() -> bool:
    """Whether this process made Numba's dispatchers (a call fell back to the JIT)."""
    return _JIT


_GLOBALS = {}        # module -> the globals of its kernels' copies


def _make_jit():
    """Numba dispatchers for every registered kernel that has none yet
    (a kernel module imported later gets its own on its first call). Each
    wraps a copy of the Python function whose globals name the other
    kernels' dispatchers, its own module's and those it imports from
    another kernel module (Numba resolves a kernel's callees from its
    globals when it compiles it); the modules' own names stay
    :class:`Kernel` objects."""
    global _JIT
    with _LOCK:
        from numba import njit

        for module, kernels in list(REGISTRY.items()):
            todo = [k for k in list(kernels.values()) if k.jit is None]
            if not todo:
                continue
            g = _GLOBALS.get(module)
            if g is None:
                g = _GLOBALS[module] = dict(vars(importlib.import_module(module)))
            for k in todo:
                f = k.py_func
                copy = types.FunctionType(f.__code__, g, f.__name__, f.__defaults__, f.__closure__)
                copy.__qualname__, copy.__module__, copy.__doc__ = f.__qualname__, f.__module__, f.__doc__
                copy.__kwdefaults__ = f.__kwdefaults__
                k.jit = njit(**k.options)(copy)
        for g in _GLOBALS.values():   # every kernel named in a module's globals, by its dispatcher
            for name, v in list(g.items()):
                if isinstance(v, Kernel) and v.jit is not None:
                    g[name] = v.jit
        _JIT = True


class Kernel:
    """A kernel: calls the compiled function for the arguments' types when
    there is one, else Numba's JIT dispatcher (made on first need)."""

    def __init__(self, py_func, options):
        self.py_func = py_func
        self.options = options
        self.module = py_func.__module__
        self.name = py_func.__name__
        self.jit = None
        self._table = None
        sig = inspect.signature(py_func)
        self._params = list(sig.parameters.values())
        self.__doc__ = py_func.__doc__
        self.__wrapped__ = py_func

    def _bind(self, args, kwargs):
        out = list(args)
        for p in self._params[len(args):]:
            if p.name in kwargs:
                out.append(kwargs[p.name])
            elif p.default is not inspect.Parameter.empty:
                out.append(p.default)
            else:
                raise TypeError(f"{self.name}() missing argument {p.name!r}")
        return out

    def __call__(self, *args, **kwargs):
        table = self._table
        if table is None:
            table = self._table = _load_aot().get((self.module, self.name), {})
        if (table or _RECORD is not None) and (kwargs or len(args) != len(self._params)):
            args, kwargs = self._bind(args, kwargs), {}
        if table or _RECORD is not None:
            key = tuple(map(describe, args))
            if _RECORD is not None:
                _RECORD.add((self.module, self.name, key))
            f = table.get(key)
            if f is not None:
                return f(*args)
        if self.jit is None:
            _make_jit()
        return self.jit(*args, **kwargs)

    def __repr__(self):
        return f"<kernel {self.module}.{self.name}>"


def kernel(*args, **options):
    """Mark a Numba kernel (``@kernel(cache=True, nogil=True)``, the options
    ``numba.njit`` takes). Returns a :class:`Kernel`, or the function itself
    when kernels are off (``SHELLREPAIR_NO_NUMBA``, or neither the compiled
    modules nor Numba are there): callers then find :data:`ENABLED` False
    and run the NumPy versions."""
    def wrap(f):
        if not ENABLED:
            return f
        k = Kernel(f, options)
        REGISTRY.setdefault(k.module, {})[k.name] = k
        return k

    if args and callable(args[0]):
        return wrap(args[0])
    return wrap


def start_recording():
    """Record the argument types of every kernel called from Python from
    now on (``python -m shellrepair.aot record``)."""
    global _RECORD
    _RECORD = set()
    for ks in REGISTRY.values():
        for k in ks.values():
            k._table = None


def recorded():
    """The recorded ``(module, name, arg keys)`` rows, sorted."""
    return sorted(_RECORD or (), key=repr)


def stop_recording():
    """Stop recording; returns :func:`recorded`'s rows."""
    global _RECORD
    rows = recorded()
    _RECORD = None
    for ks in REGISTRY.values():
        for k in ks.values():
            k._table = None
    return rows
