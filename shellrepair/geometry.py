"""Small vector helpers used in hot loops (cheaper than np.cross on small arrays)."""

import math

import numpy as np

__all__ = ["cross", "dot", "uniq", "plane_frame", "bounding_spheres", "bounds", "triangle_boxes", "concat_ranges"]


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


def plane_frame(axis):
    """Two unit vectors (u, v) spanning the plane normal to ``axis``.

    ``axis`` is (3,) or (k,3) (any length, not zero); ``u`` is built from the
    coordinate axis least aligned with it, so (u, v, axis) is right-handed.
    """
    a = np.asarray(axis, np.float64)
    if a.shape == (3,):
        got = _plane_frame_one(*a.tolist())
        if got is not None:
            return got
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    t = np.where((np.abs(a[..., :1]) < 0.9), [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = cross(a, t)
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    return u, cross(a, u)


def _plane_frame_one(x, y, z):
    """:func:`plane_frame` of one finite, non-zero axis in Python floats:
    the same operations in the same order as the array version (its norms
    add the squares left to right), without NumPy's per-call cost; None
    when a norm is zero or not finite (the array version then decides)."""
    ln = math.sqrt(x * x + y * y + z * z)
    if not (0.0 < ln < math.inf):
        return None
    x, y, z = x / ln, y / ln, z / ln
    tx, ty, tz = (1.0, 0.0, 0.0) if abs(x) < 0.9 else (0.0, 1.0, 0.0)
    u0, u1, u2 = y * tz - z * ty, z * tx - x * tz, x * ty - y * tx
    lu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    if not (0.0 < lu < math.inf):
        return None
    u0, u1, u2 = u0 / lu, u1 / lu, u2 / lu
    return np.array([u0, u1, u2]), np.array([y * u2 - z * u1, z * u0 - x * u2, x * u1 - y * u0])


def bounding_spheres(T):
    """Centroid and radius (farthest corner) of each triangle of T (t,3,3)."""
    c = T.mean(axis=1)
    return c, np.sqrt(np.max(np.sum((T - c[:, None, :]) ** 2, axis=2), axis=1))


def bounds(P):
    """Column minima and maxima of an (n,d) array: ``P.min(axis=0)``,
    ``P.max(axis=0)``, read from a column-major copy (NumPy reduces a
    row-major array's columns a row at a time: ~15x slower at thousands of
    rows). Minima and maxima pick an element, so the values are the same
    (only a zero's sign might not be, which no comparison sees; NaN
    propagates either way).

    Parameters
    ----------
    P : (n,d) array, n >= 1

    Returns
    -------
    lo, hi : (d,) arrays
    """
    Pt = np.ascontiguousarray(np.asarray(P).T)
    return Pt.min(axis=1), Pt.max(axis=1)


def triangle_boxes(C):
    """Each triangle's box: ``C.min(axis=1)``, ``C.max(axis=1)`` of its
    corners, by two elementwise minima / maxima (the values of
    :func:`bounds`'s note; several times faster than the reduction).

    Parameters
    ----------
    C : (t,3,d) array

    Returns
    -------
    lo, hi : (t,d) arrays
    """
    a, b, c = C[:, 0], C[:, 1], C[:, 2]
    return np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)


def concat_ranges(start, count):
    """The indices ``start[i] .. start[i] + count[i] - 1``, all ranges in order."""
    start = np.asarray(start, np.int64)
    count = np.asarray(count, np.int64)
    total = int(count.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    return np.repeat(start - np.concatenate([[0], np.cumsum(count)[:-1]]), count) + np.arange(total)


def vertex_faces_scipy(F, n_vertices):
    """Vertex-to-face lists by SciPy's sparse conversion (the lists of
    :func:`shellrepair.topology.vertex_faces` where the compiled kernels are
    off): ``order`` (positions in ``F.ravel()`` grouped by vertex, in order
    within a vertex) and ``start`` ((n+1,) int64)."""
    import scipy.sparse as sp

    flat = np.asarray(F, np.int64).ravel()
    n = int(n_vertices)
    # a counting sort by vertex: SciPy's COO -> CSR conversion, stable within a row
    A = sp.csr_matrix((np.ones(flat.size, np.int8), (flat, np.arange(flat.size))), shape=(n, flat.size))
    return A.indices.astype(np.int64), A.indptr.astype(np.int64)
