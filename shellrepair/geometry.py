"""Small vector helpers used in hot loops (cheaper than np.cross on small arrays)."""

import numpy as np

__all__ = ["cross", "dot", "uniq"]


def cross(a, b):
    """Row-wise cross product of (..., 3) arrays."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def dot(a, b):
    """Row-wise dot product of (..., 3) arrays."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def uniq(a):
    """Sorted unique values of an int array (cheaper than np.unique on small arrays)."""
    a = np.sort(np.asarray(a).ravel())
    if a.size == 0:
        return a
    keep = np.empty(a.size, bool)
    keep[0] = True
    np.not_equal(a[1:], a[:-1], out=keep[1:])
    return a[keep]
