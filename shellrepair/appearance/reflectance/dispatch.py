"""From the public functions' arguments to the compiled kernels (no Numba here).

The kernels sit beside the code they speed up, one module each
(:mod:`.microfacet_kernels` for :mod:`.microfacet`, and so on for
:mod:`.albedo`, :mod:`.layered`, :mod:`.km`, :mod:`.dipole`;
:mod:`.shader_kernels` for :class:`shellrepair.appearance.shader.MaterialShader`;
:mod:`.common_kernels` holds what they share).  They are imported on first
use, so importing the package does not import Numba (~0.6 s).  Each public
function asks :func:`kernels` for its module and falls back to its NumPy
version (:mod:`.reference`, the test oracle) when they are off
(:data:`shellrepair.compiled.ENABLED` False: the one switch
``SHELLREPAIR_NO_NUMBA=1``, read at call time), when Numba is not
installed, or for an argument layout the kernels do not take (e.g. a
direction array whose last axis is not 3); the results then differ only
in speed.  :func:`run` splits a large call over threads.
"""

from __future__ import annotations

import importlib
import os
import threading

import numpy as np

from shellrepair import compiled

__all__ = ["KERNEL_MODULES", "kernels", "as_float", "per_point", "per_point_rows", "elementwise", "directional",
           "with_rows", "run", "n_threads", "MIN_POINTS_PER_THREAD"]

#: The kernel modules (``shellrepair/appearance/reflectance/<name>_kernels.py``), by the name :func:`kernels` takes.
KERNEL_MODULES = ("microfacet", "albedo", "layered", "km", "dipole", "shader")

_KERNELS = {}   # name -> the module, or None when it cannot be imported


def kernels(name):
    """The kernel module ``name`` (one of :data:`KERNEL_MODULES`), or None
    when the NumPy versions are to be used."""
    if not compiled.ENABLED:
        return None
    if name not in _KERNELS:
        if name not in KERNEL_MODULES:
            raise ValueError(f"no kernel module {name!r}; one of {', '.join(KERNEL_MODULES)}")
        try:
            module = importlib.import_module(f"{__package__}.{name}_kernels")
        except ImportError:  # numba missing: the NumPy versions are exact, only slower
            module = None
        _KERNELS[name] = module
    return _KERNELS[name]


def per_point(a, shape, P):
    """A per-point parameter: a float when it is one value, else a flat (P,) float64 array."""
    if a.size == 1:
        return float(a.reshape(-1)[0])
    if a.shape != shape:
        a = np.broadcast_to(a, shape)
    return np.ascontiguousarray(a, dtype=np.float64).reshape(P)


def per_point_rows(a, shape, P):
    """A ``(..., C)`` argument: one ``(C,)`` row for all points, or ``(P, C)`` rows."""
    C = a.shape[-1]
    if a.size == C:
        return np.ascontiguousarray(a, dtype=np.float64).reshape(C)
    if a.shape[:-1] != shape:
        a = np.broadcast_to(a, shape + (C,))
    return np.ascontiguousarray(a, dtype=np.float64).reshape(P, C)


def as_float(*args):
    """The arguments as float64 arrays."""
    return [np.asarray(a, dtype=np.float64) for a in args]


def elementwise(kernel, args, extra=()):
    """Run ``kernel(lo, hi, *params, *extra, out)`` on broadcast per-point parameters.

    Returns the ``(...)`` float64 result (0-d for scalar inputs, as NumPy's
    ``np.where`` gives).
    """
    args = as_float(*args)
    shape = np.broadcast_shapes(*(a.shape for a in args))
    P = int(np.prod(shape))
    out = np.empty(P, dtype=np.float64)
    if P:
        run(kernel, P, *[per_point(a, shape, P) for a in args], *extra, out)
    return out.reshape(shape)


def directional(kernel, vectors, params, rows=None, extra=(), C=None):
    """Run a kernel over ``(..., 3)`` directions, per-point parameters and ``(..., C)`` rows.

    Returns None (use the NumPy version) when a direction's last axis is
    not 3.  The output is ``(...)``, or ``(..., C)`` when ``C`` or ``rows``
    is given.
    """
    vectors = as_float(*vectors)
    params = as_float(*params)
    if any(v.ndim == 0 or v.shape[-1] != 3 for v in vectors):
        return None
    shapes = [v.shape[:-1] for v in vectors] + [p.shape for p in params]
    if rows is not None:
        rows = np.asarray(rows, dtype=np.float64)
        if rows.ndim == 0:
            rows = rows.reshape(1)
        shapes.append(rows.shape[:-1])
        C = rows.shape[-1]
    shape = np.broadcast_shapes(*shapes)
    P = int(np.prod(shape))
    out = np.empty((P,) if C is None else (P, C), dtype=np.float64)
    if P:
        pre = [per_point_rows(v, shape, P) for v in vectors] + [per_point(p, shape, P) for p in params]
        if rows is not None:
            pre.append(per_point_rows(rows, shape, P))
        run(kernel, P, *pre, *extra, out)
    return out.reshape(shape if C is None else shape + (C,))


def with_rows(kernel, params, rows, extra=()):
    """Per-point parameters and ``(..., C)`` rows (layered_diffuse's R_km), output ``(..., C)``."""
    params = as_float(*params)
    rows = np.asarray(rows, dtype=np.float64)
    if rows.ndim == 0:
        rows = rows.reshape(1)
    shape = np.broadcast_shapes(*(p.shape for p in params), rows.shape[:-1])
    P = int(np.prod(shape))
    C = rows.shape[-1]
    out = np.empty((P, C), dtype=np.float64)
    if P:
        run(kernel, P, *[per_point(p, shape, P) for p in params], per_point_rows(rows, shape, P), *extra, out)
    return out.reshape(shape + (C,))


# --------------------------------------------------------------------------
# Running a kernel over P points on the threads
# --------------------------------------------------------------------------

#: Fewest points given to one thread; below 2x this a call runs inline
#: (a pool round trip costs ~50 us, a kernel ~3-10 ns a point).
MIN_POINTS_PER_THREAD = 1 << 15

_POOL = None
_POOL_PID = None
_POOL_LOCK = threading.Lock()


def n_threads():
    """Threads a large call uses: ``SHELLREPAIR_THREADS`` or the CPUs there are."""
    env = os.environ.get("SHELLREPAIR_THREADS")
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            pass
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _pool(k):
    """A thread pool of k workers, remade after a fork (a forked child has no threads)."""
    global _POOL, _POOL_PID
    from concurrent.futures import ThreadPoolExecutor

    with _POOL_LOCK:
        if _POOL is None or _POOL_PID != os.getpid() or _POOL._max_workers != k:
            _POOL = ThreadPoolExecutor(k, thread_name_prefix="shellrepair-shade")
            _POOL_PID = os.getpid()
        return _POOL


def run(kernel, P, *args):
    """``kernel(lo, hi, *args)`` over [0, P), split over the threads when P is large."""
    k = min(n_threads(), P // MIN_POINTS_PER_THREAD)
    if k <= 1 or threading.current_thread().name.startswith("shellrepair-shade"):
        kernel(0, P, *args)
        return
    # k - 1 ranges to the pool, the first one on this thread (it releases the
    # GIL inside the kernel): one hand-off fewer, and no thread sits idle
    edges = [P * t // k for t in range(k + 1)]
    pool = _pool(k - 1)
    futures = [pool.submit(kernel, edges[t], edges[t + 1], *args) for t in range(1, k)]
    try:
        kernel(edges[0], edges[1], *args)
    finally:
        for f in futures:
            f.result()
