"""Exact orientation predicates for float64 points, vectorised.

``orient3d(a, b, c, d)`` is the sign of the determinant

    | ax-dx  ay-dy  az-dz |
    | bx-dx  by-dy  bz-dz |
    | cx-dx  cy-dy  cz-dz |

(positive when d lies below the plane through a, b, c seen turning
counter-clockwise from above), ``orient2d(a, b, c)`` the sign of
(b-a) × (c-a). Both are exact for the float64 inputs: the answer is the
sign of the real determinant of the numbers given, whatever their scale
or offset.

How
---
1. Every row is evaluated in float64 in Shewchuk's form and kept when the
   value exceeds his a-priori error bound (``o3derrboundA``,
   ``ccwerrboundA`` of his predicates): for
   orient3d ``|det| > (7 + 56ε)ε · permanent``, for orient2d
   ``|det| > (3 + 16ε)ε · permanent``, ε = 2⁻⁵³, the permanent being the
   same expression with every product and difference taken in absolute
   value. This decides nearly every row of a scan at NumPy speed.
2. The few rows left (points coplanar or collinear up to round-off, as in
   CAD parts) are first checked for two equal points, and (orient3d) for
   four points sharing one coordinate, both exactly 0; the rest are
   evaluated exactly: each coordinate is an integer times a
   power of two, so after scaling a row by a power of two (which keeps
   the sign) the determinant is an integer polynomial, computed with
   Python integers.

The bounds ignore underflow and overflow; rows whose permanent is below
``TINY`` (products of coordinates under ~1e-93 each) or not finite go to
the exact stage too. Inputs must be finite.

References
----------
J. R. Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast
Robust Geometric Predicates", Discrete & Computational Geometry 18, 1997.
"""

from __future__ import annotations

import numpy as np

__all__ = ["orient3d", "orient2d", "orient3d_exact", "orient2d_exact"]

#: Unit round-off of float64.
EPS = 2.0 ** -53
#: Shewchuk's error bound factor for orient3d (o3derrboundA).
O3D_BOUND = (7.0 + 56.0 * EPS) * EPS
#: Shewchuk's error bound factor for orient2d (ccwerrboundA).
O2D_BOUND = (3.0 + 16.0 * EPS) * EPS
#: Permanents below this may hide underflow: such rows are evaluated exactly.
TINY = 1e-280


def _ints(X):
    """Rows of float64 values as Python integers, each row scaled by its own
    power of two (the row's smallest exponent), as an object array."""
    m, e = np.frexp(X)
    M = (m * 2.0 ** 53).astype(np.int64)          # exact: m has 53 bits
    e = e.astype(np.int64) - 53
    nz = M != 0
    emin = np.where(nz, e, np.iinfo(np.int64).max).min(axis=1, keepdims=True)
    emin = np.where(emin == np.iinfo(np.int64).max, 0, emin)
    shift = np.where(nz, e - emin, 0)
    return M.astype(object) * np.left_shift(np.ones_like(shift, dtype=object), shift.astype(object))


def orient3d_exact(a, b, c, d):
    """Exact sign of orient3d for (p,3) float64 rows (integer arithmetic)."""
    p = len(a)
    if p == 0:
        return np.zeros(0, np.int8)
    X = _ints(np.concatenate([a, b, c, d], axis=1))
    ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz = X.T
    adx, ady, adz = ax - dx, ay - dy, az - dz
    bdx, bdy, bdz = bx - dx, by - dy, bz - dz
    cdx, cdy, cdz = cx - dx, cy - dy, cz - dz
    det = (adz * (bdx * cdy - cdx * bdy) + bdz * (cdx * ady - adx * cdy)
           + cdz * (adx * bdy - bdx * ady))
    return np.sign(det).astype(np.int8)


def orient2d_exact(a, b, c):
    """Exact sign of orient2d for (p,2) float64 rows (integer arithmetic)."""
    if len(a) == 0:
        return np.zeros(0, np.int8)
    X = _ints(np.concatenate([a, b, c], axis=1))
    ax, ay, bx, by, cx, cy = X.T
    det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return np.sign(det).astype(np.int8)


def _equal(p, q):
    return (p == q).all(axis=-1)


@np.errstate(over="ignore", invalid="ignore")
def orient3d(a, b, c, d):
    """Exact sign of the orientation of d against the plane through a, b, c.

    Parameters
    ----------
    a, b, c, d : (p,3) float64

    Returns
    -------
    s : (p,) int8
        +1, 0 or -1.
    """
    adx, bdx, cdx = a[:, 0] - d[:, 0], b[:, 0] - d[:, 0], c[:, 0] - d[:, 0]
    ady, bdy, cdy = a[:, 1] - d[:, 1], b[:, 1] - d[:, 1], c[:, 1] - d[:, 1]
    adz, bdz, cdz = a[:, 2] - d[:, 2], b[:, 2] - d[:, 2], c[:, 2] - d[:, 2]
    bdxcdy, cdxbdy = bdx * cdy, cdx * bdy
    cdxady, adxcdy = cdx * ady, adx * cdy
    adxbdy, bdxady = adx * bdy, bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    perm = (np.abs(adz) * (np.abs(bdxcdy) + np.abs(cdxbdy))
            + np.abs(bdz) * (np.abs(cdxady) + np.abs(adxcdy))
            + np.abs(cdz) * (np.abs(adxbdy) + np.abs(bdxady)))
    s = np.sign(det).astype(np.int8)
    unsure = ~(np.abs(det) > O3D_BOUND * perm) | ~(perm >= TINY) | ~np.isfinite(perm)
    if unsure.any():
        u = np.flatnonzero(unsure)
        au, bu, cu, du = a[u], b[u], c[u], d[u]
        # exactly zero without arithmetic: two equal points, or all four
        # points in one axis-aligned plane (the flat faces of CAD parts)
        zero = (_equal(au, bu) | _equal(au, cu) | _equal(au, du) | _equal(bu, cu)
                | _equal(bu, du) | _equal(cu, du)
                | ((au == bu) & (au == cu) & (au == du)).any(axis=1))
        s[u[zero]] = 0
        r = ~zero
        if r.any():
            s[u[r]] = orient3d_exact(au[r], bu[r], cu[r], du[r])
    return s


@np.errstate(over="ignore", invalid="ignore")
def orient2d(a, b, c):
    """Exact sign of (b − a) × (c − a) for (p,2) float64 rows.

    Returns
    -------
    s : (p,) int8
        +1 when a, b, c turn counter-clockwise, 0 when collinear.
    """
    detleft = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
    detright = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    det = detleft - detright
    perm = np.abs(detleft) + np.abs(detright)
    s = np.sign(det).astype(np.int8)
    unsure = ~(np.abs(det) > O2D_BOUND * perm) | ~(perm >= TINY) | ~np.isfinite(perm)
    if unsure.any():
        u = np.flatnonzero(unsure)
        au, bu, cu = a[u], b[u], c[u]
        zero = (_equal(au, bu) | _equal(au, cu) | _equal(bu, cu)
                | ((au == bu) & (au == cu)).any(axis=1))      # on one axis-parallel line
        s[u[zero]] = 0
        r = ~zero
        if r.any():
            s[u[r]] = orient2d_exact(au[r], bu[r], cu[r])
    return s
