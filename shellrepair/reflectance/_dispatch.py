"""From the public functions' arguments to the compiled kernels (no Numba here).

The kernels (:mod:`._kernels`) are imported on first use, so importing
the package does not import Numba (~0.6 s).  Each public function asks
:func:`kernels` for them and falls back to its NumPy version (the test
oracle) when they are off (:data:`shellrepair.compiled.ENABLED` False: the
one switch ``SHELLREPAIR_NO_NUMBA=1``, read at call time), when Numba is not
installed, or for an argument layout the kernels do not take (e.g. a
direction array whose last axis is not 3); the results then differ only
in speed.
"""

from __future__ import annotations

import numpy as np

from .. import compiled

_KERNELS = None
_TRIED = False


def kernels():
    """The kernel module, or None when the NumPy versions are to be used."""
    global _KERNELS, _TRIED
    if not compiled.ENABLED:
        return None
    if not _TRIED:
        _TRIED = True
        try:
            from . import _kernels
        except ImportError:  # numba missing: the NumPy versions are exact, only slower
            _kernels = None
        _KERNELS = _kernels
    return _KERNELS


def _param(a, shape, P):
    """A per-point parameter: a float when it is one value, else a flat (P,) float64 array."""
    if a.size == 1:
        return float(a.reshape(-1)[0])
    if a.shape != shape:
        a = np.broadcast_to(a, shape)
    return np.ascontiguousarray(a, dtype=np.float64).reshape(P)


def _rows(a, shape, P):
    """A ``(..., C)`` argument: one ``(C,)`` row for all points, or ``(P, C)`` rows."""
    C = a.shape[-1]
    if a.size == C:
        return np.ascontiguousarray(a, dtype=np.float64).reshape(C)
    if a.shape[:-1] != shape:
        a = np.broadcast_to(a, shape + (C,))
    return np.ascontiguousarray(a, dtype=np.float64).reshape(P, C)


def as_float(*args):
    return [np.asarray(a, dtype=np.float64) for a in args]


def elementwise(kernel, args, extra=()):
    """Run ``kernel(lo, hi, *params, *extra, out)`` on broadcast per-point parameters.

    Returns the ``(...)`` float64 result (0-d for scalar inputs, as NumPy's
    ``np.where`` gives).
    """
    K = kernels()
    args = as_float(*args)
    shape = np.broadcast_shapes(*(a.shape for a in args))
    P = int(np.prod(shape))
    out = np.empty(P, dtype=np.float64)
    if P:
        K.run(kernel, P, *[_param(a, shape, P) for a in args], *extra, out)
    return out.reshape(shape)


def directional(kernel, vectors, params, rows=None, extra=(), C=None):
    """Run a kernel over ``(..., 3)`` directions, per-point parameters and ``(..., C)`` rows.

    Returns None (use the NumPy version) when a direction's last axis is
    not 3.  The output is ``(...)``, or ``(..., C)`` when ``C`` or ``rows``
    is given.
    """
    K = kernels()
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
        pre = [_rows(v, shape, P) for v in vectors] + [_param(p, shape, P) for p in params]
        if rows is not None:
            pre.append(_rows(rows, shape, P))
        K.run(kernel, P, *pre, *extra, out)
    return out.reshape(shape if C is None else shape + (C,))


def with_rows(kernel, params, rows, extra=()):
    """Per-point parameters and ``(..., C)`` rows (layered_diffuse's R_km), output ``(..., C)``."""
    K = kernels()
    params = as_float(*params)
    rows = np.asarray(rows, dtype=np.float64)
    if rows.ndim == 0:
        rows = rows.reshape(1)
    shape = np.broadcast_shapes(*(p.shape for p in params), rows.shape[:-1])
    P = int(np.prod(shape))
    C = rows.shape[-1]
    out = np.empty((P, C), dtype=np.float64)
    if P:
        K.run(kernel, P, *[_param(p, shape, P) for p in params], _rows(rows, shape, P), *extra, out)
    return out.reshape(shape + (C,))
