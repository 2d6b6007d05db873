"""One BLAS thread for the fill: the bundled OpenBLAS thread counts, set and put back.

The fill is many small dense products (NumPy's small matrix products;
the fronts of :mod:`shellrepair.fill.cholesky` were BLAS products too
until they became its own loops, for the same bytes on every processor).
NumPy and SciPy each bundle an OpenBLAS, whose default is a thread per
core; on a product of a few hundred rows the second thread costs more than
it gives, and after each call OpenBLAS's workers spin for a while, taking
the core the next step wanted (or another job's). Measured on
``hard-30pct`` (``repair_mesh`` at the default order, best of 5, two cores
with another job running): 216 and 264 ms a repair with the default
threads, 132 and 190 ms with one thread in both libraries (and 2-3x on
the loaded machine below).

:func:`one_thread` sets the thread count of every bundled OpenBLAS to one
(``scipy_openblas_set_num_threads``, NumPy's 64-bit-integer build's
``..._64_``) while any block is open, in any thread of the process, and
puts the counts back when the last one ends (:class:`~shellrepair.counted.CountedSetting`).
It is a setting of the whole process, and says so: the per-thread setter
these libraries also export (``openblas_set_num_threads_local``) keeps one
value for the whole process in the builds NumPy 2.4 and SciPy 1.17 bundle
(measured: a count set in one thread is what another reads back), so the
fill and its helper thread, each setting and restoring it, put back each
other's values (the last block to end left the process at one thread, and
a block still open was back at two); and two threads calling BLAS at once
ran in turn unless the global count was one (Numba-compiled 300x300
products on two threads: 2.0x the time of one alone; 1.2x with it at one).
Other threads of the process run their BLAS calls on one thread while a
repair runs; a NumPy or SciPy linked to another BLAS is left as it is.

Why not threadpoolctl (``threadpool_limits(1, "blas")``), which does the
same through the same setter: measured 2026-12-06 on this 2-core machine
under heavy load (load average 9-11; ``hard-30pct``, ``repair_mesh``, best
of 5 interleaved, two runs): the per-thread setter used before 504 / 865
ms, this module 759 ms (second run), ``threadpool_limits`` 532 / 667 ms, a
``ThreadpoolController`` made once 454 / 619 ms, default threads 994 /
2688 ms. The one-thread variants are the same within that noise and give
the same output to the bit (``eval/fingerprint.py``'s hash
``bc6167fb2423d578``); two BLAS threads give another one
(``f5d286a2a2c8555f``: the fronts' products are rounded differently), so
this setting is also what makes the output independent of the machine's
cores. What differs is the set-up every cold run pays: importing
threadpoolctl and finding the libraries (it inspects every shared library
the process has loaded) took 40-55 ms in a process that had imported
:mod:`shellrepair.repair`, against 0.8-0.9 ms here; ``threadpool_limits``
makes a controller at each call, 4-6 ms a block (31 blocks in one repair
of ``hard-30pct``), against 0.007 ms; and called in two threads whose
blocks overlap (the fill and its helper) it left the process at one
thread, as the per-thread setter did (both restore per block). A cold
repair's fixed cost is what issue 38 asks to bring under 0.1 s, so these
lines stay.
"""

from __future__ import annotations

import ctypes
import glob
import os
import threading

from shellrepair.counted import CountedSetting

__all__ = ["one_thread", "one_thread_everywhere", "global_setters", "counts"]

_LOCK = threading.Lock()
#: Where NumPy's and SciPy's wheels keep their bundled libraries (beside the package).
_BUNDLED = ("numpy.libs/libscipy_openblas*.so*", "scipy.libs/libscipy_openblas*.so*")
#: The thread-count (getter, setter) names of the bundled OpenBLAS builds
#: (SciPy's, NumPy's 64-bit-integer one).
_GLOBAL = (("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
           ("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"))
_GLOBALS = None


def _bundled():
    """The bundled OpenBLAS libraries (NumPy's, SciPy's), loaded; an empty
    list where there is none."""
    import numpy
    import scipy

    roots = sorted({os.path.dirname(os.path.dirname(m.__file__)) for m in (numpy, scipy)})
    return [ctypes.CDLL(path) for root in roots for pattern in _BUNDLED
            for path in sorted(glob.glob(os.path.join(root, pattern)))]


def global_setters():
    """``(get, set)`` of each bundled OpenBLAS's thread count (NumPy's,
    SciPy's: the one Numba's ``np.dot`` calls), found once; an empty list
    where there is none.

    Returns
    -------
    pairs : list of (callable, callable)
        ``get() -> int`` and ``set(n)``.
    """
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


def counts():
    """The bundled libraries' thread counts now, in :func:`global_setters` order."""
    return [get() for get, _ in global_setters()]


def _counts_to_one():
    before = counts()
    for _, put in global_setters():
        put(1)
    return before


def _counts_back(before):
    for (_, put), b in zip(global_setters(), before):
        put(b)


#: Within a block ``with one_thread():``, every thread's BLAS calls run on
#: the calling thread alone: the libraries' counts set to one when the
#: first block opens, put back when the last open block ends, in whatever
#: thread (other threads of the process see the change while a block is open).
one_thread = CountedSetting(_counts_to_one, _counts_back)
#: The same setting, under the name the fill's helper thread uses
#: (:class:`shellrepair.fill.beside.HelperThread`).
one_thread_everywhere = one_thread
