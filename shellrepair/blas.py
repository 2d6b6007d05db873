"""One BLAS thread for the fill: OpenBLAS's per-thread setting, set and restored.

The fill is many small dense products (a hole's fronts in
:mod:`shellrepair.cholesky`, NumPy's small matrix products around it).
NumPy and SciPy each bundle an OpenBLAS, whose default is a thread per
core; on a product of a few hundred rows the second thread costs more than
it gives, and after each call OpenBLAS's workers spin for a while, taking
the core the next step wanted (or another job's). Measured on
``hard-30pct`` (default order, best of 5, two cores with another job
running): 216 and 264 ms a repair with the default threads, 132 and 190 ms
with one thread in both libraries; the outputs are the same to the bit
(``eval/fingerprint.py``), as OpenBLAS splits a product's rows, not the
sums, between threads.

:func:`one_thread` sets the calling thread's count to one in every bundled
OpenBLAS it finds (``openblas_set_num_threads_local``, OpenBLAS 0.3.27 on)
and puts the previous counts back; other threads of the process, and a
SciPy or NumPy linked to another BLAS, are left as they are.

:func:`one_thread_everywhere` sets the libraries' global counts to one as
well, for the time two of the fill's threads call BLAS at once (the
helper beside a run, :class:`shellrepair.fill.HelperThread`): with the
global count above one, OpenBLAS serialised the two threads' calls even
with each thread's own count at one (Numba-compiled 300x300 products on
two threads: 2.0x the time of one alone; 1.2x with the global count at
one).
"""

from __future__ import annotations

import contextlib
import ctypes
import glob
import os
import threading

from .counted import CountedSetting

__all__ = ["one_thread", "one_thread_everywhere", "setters"]

_SETTERS = None
_LOCK = threading.Lock()
#: Where NumPy's and SciPy's wheels keep their bundled libraries (beside the package).
_BUNDLED = ("numpy.libs/libscipy_openblas*.so*", "scipy.libs/libscipy_openblas*.so*")


def _bundled():
    """The bundled OpenBLAS libraries (NumPy's, SciPy's), loaded; an empty
    list where there is none."""
    import numpy
    import scipy

    roots = sorted({os.path.dirname(os.path.dirname(m.__file__)) for m in (numpy, scipy)})
    return [ctypes.CDLL(path) for root in roots for pattern in _BUNDLED
            for path in sorted(glob.glob(os.path.join(root, pattern)))]


def setters():
    """The ``openblas_set_num_threads_local`` of each bundled OpenBLAS
    (NumPy's, SciPy's: the one Numba's ``np.dot`` calls), found once; an
    empty list where there is none."""
    global _SETTERS
    with _LOCK:
        if _SETTERS is None:
            found = []
            try:
                for lib in _bundled():
                    f = getattr(lib, "openblas_set_num_threads_local", None)
                    if f is not None:
                        f.restype = ctypes.c_int
                        f.argtypes = [ctypes.c_int]
                        found.append(f)
            except (OSError, ImportError, AttributeError):
                found = []
            _SETTERS = found
        return _SETTERS


@contextlib.contextmanager
def one_thread():
    """Within the block, BLAS calls from this thread run on this thread alone."""
    fs = setters()
    before = [f(1) for f in fs]
    try:
        yield
    finally:
        for f, b in zip(fs, before):
            f(b)


#: The global thread-count (getter, setter) names of the bundled OpenBLAS
#: builds (SciPy's, NumPy's 64-bit-integer one).
_GLOBAL = (("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
           ("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"))
_GLOBALS = None


def _global_setters():
    """(get, set) of each bundled OpenBLAS's global thread count, found once."""
    global _GLOBALS
    with _LOCK:
        if _GLOBALS is None:
            found = []
            try:
                for lib in _bundled():
                    for get_name, set_name in _GLOBAL:
                        get, put = getattr(lib, get_name, None), getattr(lib, set_name, None)
                        if get is not None and put is not None:
                            get.restype, get.argtypes = ctypes.c_int, []
                            put.restype, put.argtypes = None, [ctypes.c_int]
                            found.append((get, put))
                            break
            except (OSError, ImportError, AttributeError):
                found = []
            _GLOBALS = found
        return _GLOBALS


def _global_counts_to_one():
    gs = _global_setters()
    before = [get() for get, _ in gs]
    for _, put in gs:
        put(1)
    return before


def _global_counts_back(before):
    for (_, put), b in zip(_global_setters(), before):
        put(b)


#: Within a block ``with one_thread_everywhere():``, every thread's BLAS
#: calls run on the calling thread alone: the libraries' global counts set
#: to one, put back when the last open block ends, in whatever thread
#: (other threads of the process see the change while a block is open).
one_thread_everywhere = CountedSetting(_global_counts_to_one, _global_counts_back)
