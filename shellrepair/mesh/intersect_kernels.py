"""Compiled kernels of the crossing tests (:mod:`shellrepair.mesh.intersect`, Numba).

* :func:`grid_sort`, :func:`faces_in_box`: the vertex grid of
  :class:`shellrepair.mesh.intersect.NearFaces` and its box query;
* :func:`box_pairs`: candidate triangle pairs for the crossing tests
  (a superset of the crossing pairs, like the bounding-sphere pairs of
  :mod:`shellrepair.mesh.intersect` it replaces, so the tests' results are
  the same; :mod:`shellrepair.fill.merge` uses it too);
* :func:`separated`: pairs a certified plane test rules out before the
  exact crossing tests;
* :func:`cross_status`: the crossing test of triangle pairs where its float
  filters decide (:func:`shellrepair.mesh.intersect.triangles_cross`), the rest
  left to it, and :func:`patch_pairs`: a patch's candidate pairs with the
  scan and their tests in one call;
* :func:`projection_embeds`, :func:`outline_simple`: the projected area and
  outline tests of :func:`shellrepair.mesh.intersect.embeds_by_projection`.

Each gives what its NumPy version gives, to the bit (tests/test_kernels.py).
How the kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["faces_in_box", "grid_sort", "box_pairs", "separated", "cross_status", "patch_pairs", "projection_embeds", "outline_simple"]

from shellrepair import compiled
from shellrepair.mesh.common_kernels import _ring_collect

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _grow(a, size):
    if size < a.size:
        return a
    b = np.empty(2 * a.size + 16, a.dtype)
    b[:a.size] = a
    return b


@njit(cache=True, nogil=True)
def _faces_in_box(vkey, vorder, V, vf_order, vf_start, big, lo2, h, ny, lo, hi, fmark):
    c00 = max(np.floor((lo[0] - lo2[0]) / h), 0.0)
    c01 = max(np.floor((lo[1] - lo2[1]) / h), 0.0)
    c10 = np.floor((hi[0] - lo2[0]) / h)
    c11 = min(np.floor((hi[1] - lo2[1]) / h), ny - 1.0)
    # the vertices in the box, then their faces: arrays sized in advance (an
    # array grown inside the loops costs reference counts at every step)
    nrow = int(c10) - int(c00) + 1 if not (c10 < c00 or c11 < c01) else 0
    ra = np.empty(max(nrow, 0), np.int64)
    rb = np.empty(max(nrow, 0), np.int64)
    total = 0
    for r in range(nrow):
        row = int(c00) + r
        ra[r] = np.searchsorted(vkey, row * ny + int(c01), side="left")
        rb[r] = np.searchsorted(vkey, row * ny + int(c11), side="right")
        total += rb[r] - ra[r]
    inbox = np.empty(total, np.int64)
    nv = 0
    bound = big.size
    for r in range(nrow):
        for p in range(ra[r], rb[r]):
            v = vorder[p]
            if (lo[0] <= V[v, 0] <= hi[0] and lo[1] <= V[v, 1] <= hi[1]
                    and lo[2] <= V[v, 2] <= hi[2]):
                inbox[nv] = v
                nv += 1
                bound += vf_start[v + 1] - vf_start[v]
    found = np.empty(bound, np.int64)
    nf = _ring_collect(inbox, nv, vf_order, vf_start, fmark, found, 0)   # the box's vertices' faces
    for f in big:
        if not fmark[f]:
            fmark[f] = True
            found[nf] = f
            nf += 1
    for j in range(nf):
        fmark[found[j]] = False
    return np.sort(found[:nf])


def faces_in_box(index, lo, hi, fmark):
    """:meth:`shellrepair.mesh.intersect.NearFaces.faces_near`'s walk, compiled.

    Parameters
    ----------
    index : NearFaces
    lo, hi : (3,) float64
        The box, already grown by ``index.grow``.
    fmark : (m,) bool
        Scratch marks, all False; left all False.

    Returns
    -------
    faces : (r,) int64
        Sorted, distinct: the faces of the vertices in the box, and the big faces.
    """
    return _faces_in_box(index.vkey, index.vorder, index.V, index.vf_order, index.vf_start,
                         np.ascontiguousarray(index.big, np.int64), np.asarray(index.lo2, np.float64),
                         float(index.h), int(index.ny), np.asarray(lo, np.float64), np.asarray(hi, np.float64), fmark)


@njit(cache=True, nogil=True)
def _xy_bounds(V):
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    for v in range(V.shape[0]):
        for c in range(2):
            x = V[v, c]
            if x < lo[c]:
                lo[c] = x
            if x > hi[c]:
                hi[c] = x
    return lo, hi


@njit(cache=True, nogil=True)
def _grid_sort(V, lo, h):
    n = V.shape[0]
    ix = np.empty(n, np.int64)
    iy = np.empty(n, np.int64)
    nx = 1
    ny = 1
    for v in range(n):
        ix[v] = np.int64(np.floor((V[v, 0] - lo[0]) / h))
        iy[v] = np.int64(np.floor((V[v, 1] - lo[1]) / h))
        nx = max(nx, ix[v] + 1)
        ny = max(ny, iy[v] + 1)
    # least significant digit first: by row, then (stably) by column
    tmp = np.empty(n, np.int64)
    order = np.empty(n, np.int64)
    count = np.zeros(ny + 1, np.int64)
    for v in range(n):
        count[iy[v] + 1] += 1
    for b in range(ny):
        count[b + 1] += count[b]
    for v in range(n):
        tmp[count[iy[v]]] = v
        count[iy[v]] += 1
    count = np.zeros(nx + 1, np.int64)
    for v in range(n):
        count[ix[v] + 1] += 1
    for b in range(nx):
        count[b + 1] += count[b]
    for p in range(n):
        v = tmp[p]
        order[count[ix[v]]] = v
        count[ix[v]] += 1
    key = np.empty(n, np.int64)
    for p in range(n):
        v = order[p]
        key[p] = ix[v] * ny + iy[v]
    return order, key, ny


def grid_sort(V, h=None, grow=0.0):
    """The vertex grid of :class:`shellrepair.mesh.intersect.NearFaces`, by two
    counting sorts instead of one comparison sort.

    Parameters
    ----------
    V : (n,3) float64, n >= 1, x and y finite (else ValueError)
    grow : float
        The index's longest ordinary edge: columns are
        ``h = max(4 grow, span / 4096, 1e-300)`` wide, ``span`` the larger
        side of V's bounding box in x and y.

    Returns
    -------
    lo : (2,) float64
        Corner of the grid (V's smallest x and y).
    h : float
    order : (n,) int64
        Vertices sorted by column key (within a key, by vertex id).
    key : (n,) int64
        Their keys ``i * ny + j``, ascending.
    ny : int
    """
    V = np.asarray(V, np.float64)
    lo, hi = _xy_bounds(V)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all() and np.isfinite(V[:, :2]).all()):
        raise ValueError("grid_sort needs finite x and y")
    span = float(np.max(hi - lo))
    h = max(4 * grow, span / 4096, 1e-300)
    order, key, ny = _grid_sort(V, lo, h)
    return lo, h, order, key, int(ny)


# --------------------------------------------------------------------------
# candidate pairs for the crossing tests
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _box_pairs(Amin, Amax, Bmin, Bmax, self_pairs):
    na, nb = Amin.shape[0], Bmin.shape[0]
    ai = np.empty(0, np.int64)
    if na == 0 or nb == 0:
        return ai, ai.copy()
    lo = np.empty(3)
    hi = np.empty(3)
    ext = 0.0
    for c in range(3):
        lo[c] = Bmin[0, c]
        hi[c] = Bmax[0, c]
    for j in range(nb):
        e = 0.0
        for c in range(3):
            lo[c] = min(lo[c], Bmin[j, c])
            hi[c] = max(hi[c], Bmax[j, c])
            e = max(e, Bmax[j, c] - Bmin[j, c])
        ext += e
    # a grid over B's boxes: cells about twice B's mean extent, at most 64 a side
    h = 2.0 * ext / nb
    dims = np.ones(3, np.int64)
    cell = np.empty(3)
    for c in range(3):
        span = hi[c] - lo[c]
        k = 1
        if h > 0 and span > 0:
            k = min(64, max(1, int(span / h)))
        dims[c] = k
        cell[c] = span / k if span > 0 else 1.0
    ncell = dims[0] * dims[1] * dims[2]
    rng = np.empty((nb, 6), np.int64)
    count = np.zeros(ncell + 1, np.int64)
    for j in range(nb):
        for c in range(3):
            i0 = int((Bmin[j, c] - lo[c]) / cell[c])
            i1 = int((Bmax[j, c] - lo[c]) / cell[c])
            rng[j, c] = min(max(i0, 0), dims[c] - 1)
            rng[j, 3 + c] = min(max(i1, 0), dims[c] - 1)
        for x in range(rng[j, 0], rng[j, 3] + 1):
            for y in range(rng[j, 1], rng[j, 4] + 1):
                for z in range(rng[j, 2], rng[j, 5] + 1):
                    count[(x * dims[1] + y) * dims[2] + z + 1] += 1
    for q in range(ncell):
        count[q + 1] += count[q]
    fill = count[:-1].copy()
    items = np.empty(count[ncell], np.int64)
    for j in range(nb):
        for x in range(rng[j, 0], rng[j, 3] + 1):
            for y in range(rng[j, 1], rng[j, 4] + 1):
                for z in range(rng[j, 2], rng[j, 5] + 1):
                    q = (x * dims[1] + y) * dims[2] + z
                    items[fill[q]] = j
                    fill[q] += 1
    stamp = np.full(nb, -1, np.int64)
    out_a = np.empty(16, np.int64)
    out_b = np.empty(16, np.int64)
    npair = 0
    r = np.empty(6, np.int64)
    buf = np.empty(nb, np.int64)   # one query's pairs: the outputs grow once a query, not inside its loops
    for i in range(na):
        skip = False
        for c in range(3):
            if Amax[i, c] < lo[c] or Amin[i, c] > hi[c]:
                skip = True
        if skip:
            continue
        for c in range(3):
            r[c] = min(max(int((Amin[i, c] - lo[c]) / cell[c]), 0), dims[c] - 1)
            r[3 + c] = min(max(int((Amax[i, c] - lo[c]) / cell[c]), 0), dims[c] - 1)
        m = 0
        for x in range(r[0], r[3] + 1):
            for y in range(r[1], r[4] + 1):
                for z in range(r[2], r[5] + 1):
                    q = (x * dims[1] + y) * dims[2] + z
                    for p in range(count[q], count[q + 1]):
                        j = items[p]
                        if stamp[j] == i or (self_pairs and j <= i):
                            continue
                        stamp[j] = i
                        if (Amin[i, 0] <= Bmax[j, 0] and Bmin[j, 0] <= Amax[i, 0]
                                and Amin[i, 1] <= Bmax[j, 1] and Bmin[j, 1] <= Amax[i, 1]
                                and Amin[i, 2] <= Bmax[j, 2] and Bmin[j, 2] <= Amax[i, 2]):
                            buf[m] = j
                            m += 1
        while out_a.size < npair + m:
            out_a = _grow(out_a, out_a.size)
            out_b = _grow(out_b, out_b.size)
        for t in range(m):
            out_a[npair + t] = i
            out_b[npair + t] = buf[t]
        npair += m
    return out_a[:npair], out_b[:npair]


def box_pairs(Amin, Amax, Bmin=None, Bmax=None):
    """Pairs (i, j) of boxes of A and of B that overlap (closed, on every axis).

    Parameters
    ----------
    Amin, Amax : (a,3) float64
        Box corners, finite.
    Bmin, Bmax : (b,3) float64, optional
        Without them, pairs within A with ``i < j``.

    Returns
    -------
    ai, bj : (p,) int64
        Sorted by ``i``, then in an order fixed by the input.

    Notes
    -----
    B's boxes are bucketed in a uniform grid (cells about twice their mean
    extent, at most 64 a side); each A box is tested against the boxes in
    the cells it covers. Every overlapping pair is reported once; the
    crossing tests then decide exactly, so this set replaces any other
    superset of the crossing pairs (bounding spheres, say) without
    changing a result.
    """
    self_pairs = Bmin is None
    if self_pairs:
        Bmin, Bmax = Amin, Amax
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    return _box_pairs(c(Amin), c(Amax), c(Bmin), c(Bmax), self_pairs)


@njit(cache=True, nogil=True)
def _strict_side(T, P, side_bound, tiny):
    """+1 / -1 when all three points P are certainly on one side of T's
    plane (intersect._plane_signs' error bound), else 0."""
    e1x, e1y, e1z = T[1, 0] - T[0, 0], T[1, 1] - T[0, 1], T[1, 2] - T[0, 2]
    e2x, e2y, e2z = T[2, 0] - T[0, 0], T[2, 1] - T[0, 1], T[2, 2] - T[0, 2]
    n0, n1, n2 = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    m0 = abs(e1y * e2z) + abs(e1z * e2y)
    m1 = abs(e1z * e2x) + abs(e1x * e2z)
    m2 = abs(e1x * e2y) + abs(e1y * e2x)
    side = 0
    for i in range(3):
        w0, w1, w2 = P[i, 0] - T[0, 0], P[i, 1] - T[0, 1], P[i, 2] - T[0, 2]
        det = n0 * w0 + n1 * w1 + n2 * w2
        perm = m0 * abs(w0) + m1 * abs(w1) + m2 * abs(w2)
        if not (abs(det) > side_bound * perm and perm >= tiny and np.isfinite(perm)):
            return 0
        s = 1 if det > 0 else -1
        if i == 0:
            side = s
        elif s != side:
            return 0
    return side


@njit(cache=True, nogil=True)
def _separated(A, Aid, ai, B, Bid, bj, side_bound, tiny):
    out = np.zeros(ai.size, np.bool_)
    for q in range(ai.size):
        i, j = ai[q], bj[q]
        common = False
        for x in range(3):
            for y in range(3):
                if Aid[i, x] == Bid[j, y]:
                    common = True
        if common:
            continue
        if _strict_side(A[i], B[j], side_bound, tiny) != 0 or _strict_side(B[j], A[i], side_bound, tiny) != 0:
            out[q] = True
    return out


def separated(A, Aid, ai, B, Bid, bj, side_bound, tiny):
    """Pairs (A[ai], B[bj]) that certainly cannot cross: one triangle's
    corners all strictly on one side of the other's plane, as the
    error-bounded plane test of :func:`shellrepair.mesh.intersect._plane_signs`
    certifies it (pairs sharing a vertex id are never claimed). The crossing
    test answers False for every such pair, so it need not see them.

    Parameters
    ----------
    A, B : (a,3,3), (b,3,3) float64
    Aid, Bid : (a,3), (b,3) int64
    ai, bj : (p,) int64
    side_bound, tiny : float
        The filter's error factor and smallest trusted permanent.

    Returns
    -------
    sep : (p,) bool
    """
    c = np.ascontiguousarray
    return _separated(c(A, np.float64), c(Aid, np.int64), c(ai, np.int64), c(B, np.float64), c(Bid, np.int64),
                      c(bj, np.int64), float(side_bound), float(tiny))


#: :func:`cross_status` codes: the pair does not cross, crosses, or was not
#: decided by the float filters (the caller's exact NumPy test decides).
APART, CROSS, UNDECIDED = 0, 1, 2


@njit(cache=True, nogil=True)
def _o3d(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, o3d_bound, tiny):
    """:func:`shellrepair.mesh.predicates.orient3d` of one row where its float
    filter (or its exact-zero shortcuts) decides, else 2: the same
    products, sums and bound."""
    adx, bdx, cdx = ax - dx, bx - dx, cx - dx
    ady, bdy, cdy = ay - dy, by - dy, cy - dy
    adz, bdz, cdz = az - dz, bz - dz, cz - dz
    bdxcdy, cdxbdy = bdx * cdy, cdx * bdy
    cdxady, adxcdy = cdx * ady, adx * cdy
    adxbdy, bdxady = adx * bdy, bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    perm = (abs(adz) * (abs(bdxcdy) + abs(cdxbdy))
            + abs(bdz) * (abs(cdxady) + abs(adxcdy))
            + abs(cdz) * (abs(adxbdy) + abs(bdxady)))
    if abs(det) > o3d_bound * perm and perm >= tiny and np.isfinite(perm):
        return 1 if det > 0 else -1
    # exactly zero without arithmetic: two equal points, or the four in one axis-aligned plane
    if ((ax == bx and ay == by and az == bz) or (ax == cx and ay == cy and az == cz)
            or (ax == dx and ay == dy and az == dz) or (bx == cx and by == cy and bz == cz)
            or (bx == dx and by == dy and bz == dz) or (cx == dx and cy == dy and cz == dz)
            or (ax == bx and ax == cx and ax == dx) or (ay == by and ay == cy and ay == dy)
            or (az == bz and az == cz and az == dz)):
        return 0
    return 2


@njit(cache=True, nogil=True)
def _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2, px, py, pz,
          side_bound, o3d_bound, tiny):
    """The side of p of the plane through t0, t1, t2 (normal n, its
    permanent factors m): intersect._plane_signs of one point, 2 where the
    filters cannot decide."""
    w0, w1, w2 = px - t0x, py - t0y, pz - t0z
    det = n0 * w0 + n1 * w1 + n2 * w2
    perm = m0 * abs(w0) + m1 * abs(w1) + m2 * abs(w2)
    if abs(det) > side_bound * perm and perm >= tiny and np.isfinite(perm):
        return -1 if det > 0 else 1
    return _o3d(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, px, py, pz, o3d_bound, tiny)


@njit(cache=True, nogil=True)
def _side_signs(TT, t, PP, p, known, side_bound, o3d_bound, tiny):
    """:func:`shellrepair.mesh.intersect._plane_signs` of one pair: the sides of
    the corners of ``PP[p]`` of the plane of ``TT[t]`` (2 where the filters
    cannot decide; 0 for corners whose bit is set in ``known``)."""
    t0x, t0y, t0z = TT[t, 0, 0], TT[t, 0, 1], TT[t, 0, 2]
    t1x, t1y, t1z = TT[t, 1, 0], TT[t, 1, 1], TT[t, 1, 2]
    t2x, t2y, t2z = TT[t, 2, 0], TT[t, 2, 1], TT[t, 2, 2]
    e1x, e1y, e1z = t1x - t0x, t1y - t0y, t1z - t0z
    e2x, e2y, e2z = t2x - t0x, t2y - t0y, t2z - t0z
    n0, n1, n2 = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    m0 = abs(e1y * e2z) + abs(e1z * e2y)
    m1 = abs(e1z * e2x) + abs(e1x * e2z)
    m2 = abs(e1x * e2y) + abs(e1y * e2x)
    s0 = s1 = s2 = 0
    if not known & 1:
        s0 = _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2,
                   PP[p, 0, 0], PP[p, 0, 1], PP[p, 0, 2], side_bound, o3d_bound, tiny)
    if not known & 2:
        s1 = _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2,
                   PP[p, 1, 0], PP[p, 1, 1], PP[p, 1, 2], side_bound, o3d_bound, tiny)
    if not known & 4:
        s2 = _side(t0x, t0y, t0z, t1x, t1y, t1z, t2x, t2y, t2z, n0, n1, n2, m0, m1, m2,
                   PP[p, 2, 0], PP[p, 2, 1], PP[p, 2, 2], side_bound, o3d_bound, tiny)
    return s0, s1, s2


@njit(cache=True, nogil=True)
def _alone_corner(s0, s1, s2):
    """intersect._alone of one sign row: the corner alone on its side (the
    first positive one when one is positive, else the first negative one)."""
    if (s0 > 0) + (s1 > 0) + (s2 > 0) == 1:
        return 0 if s0 > 0 else 1 if s1 > 0 else 2
    return 0 if s0 < 0 else 1 if s1 < 0 else 2


@njit(cache=True, nogil=True)
def _cross_one(A, Aid, i, B, Bid, j, side_bound, o3d_bound, tiny):
    """One pair of :func:`_cross_status`, ``A[i]`` and ``B[j]``."""
    ka = 0       # bit x: corner x of A is a corner of B (the same id)
    kb = 0
    for x in range(3):
        for y in range(3):
            if Aid[i, x] == Bid[j, y]:
                ka |= 1 << x
                kb |= 1 << y
    b0, b1, b2 = _side_signs(A, i, B, j, kb, side_bound, o3d_bound, tiny)
    if b0 == 2 or b1 == 2 or b2 == 2:
        return UNDECIDED
    if b0 == 0 and b1 == 0 and b2 == 0:
        return UNDECIDED                           # in one plane: the NumPy test
    if not ((b0 > 0 or b1 > 0 or b2 > 0) and (b0 < 0 or b1 < 0 or b2 < 0)):
        return APART
    a0, a1, a2 = _side_signs(B, j, A, i, ka, side_bound, o3d_bound, tiny)
    if a0 == 2 or a1 == 2 or a2 == 2:
        return UNDECIDED
    if a0 == 0 and a1 == 0 and a2 == 0:
        return UNDECIDED
    if not ((a0 > 0 or a1 > 0 or a2 > 0) and (a0 < 0 or a1 < 0 or a2 < 0)):
        return APART
    # both straddle: intersect._straddling_cross (Guigue-Devillers)
    ra, rb = _alone_corner(a0, a1, a2), _alone_corner(b0, b1, b2)
    pa, qa, xa = ra, (ra + 1) % 3, (ra + 2) % 3
    pb, qb, xb = rb, (rb + 1) % 3, (rb + 2) % 3
    if (a0, a1, a2)[ra] < 0:
        qb, xb = xb, qb
    if (b0, b1, b2)[rb] < 0:
        qa, xa = xa, qa
    s1 = _o3d(A[i, pa, 0], A[i, pa, 1], A[i, pa, 2], A[i, qa, 0], A[i, qa, 1], A[i, qa, 2],
              B[j, pb, 0], B[j, pb, 1], B[j, pb, 2], B[j, qb, 0], B[j, qb, 1], B[j, qb, 2], o3d_bound, tiny)
    if s1 != 2 and s1 >= 0:
        return APART
    s2 = _o3d(A[i, pa, 0], A[i, pa, 1], A[i, pa, 2], A[i, xa, 0], A[i, xa, 1], A[i, xa, 2],
              B[j, xb, 0], B[j, xb, 1], B[j, xb, 2], B[j, pb, 0], B[j, pb, 1], B[j, pb, 2], o3d_bound, tiny)
    if s2 != 2 and s2 >= 0:
        return APART
    if s1 == 2 or s2 == 2:
        return UNDECIDED
    return CROSS


@njit(cache=True, nogil=True)
def _cross_status(A, Aid, ai, B, Bid, bj, side_bound, o3d_bound, tiny):
    out = np.empty(ai.size, np.int8)
    for q in range(ai.size):
        out[q] = _cross_one(A, Aid, ai[q], B, Bid, bj[q], side_bound, o3d_bound, tiny)
    return out


def cross_status(A, Aid, ai, B, Bid, bj, side_bound, o3d_bound, tiny):
    """Do the triangle pairs (A[ai], B[bj]) cross? The tests of
    :func:`shellrepair.mesh.intersect.triangles_cross` (ids equal: corners known
    to be shared) for the pairs its float filters decide: the plane sides,
    then, for pairs that straddle each other's plane, the two orient3d
    signs of the segment overlap, each by the filter and the exact-zero
    shortcuts of :func:`shellrepair.mesh.predicates.orient3d`. Every decided
    answer is the exact one; pairs that need exact arithmetic or lie in
    one plane (or have a zero-area triangle) are left ``UNDECIDED`` for
    the NumPy test.

    Parameters
    ----------
    A, B : (a,3,3), (b,3,3) float64
    Aid, Bid : (a,3), (b,3) int64
    ai, bj : (p,) int64
    side_bound, o3d_bound, tiny : float
        The plane filter's and orient3d's error factors, the smallest trusted permanent.

    Returns
    -------
    status : (p,) int8
        ``APART``, ``CROSS`` or ``UNDECIDED`` per pair.
    """
    c = np.ascontiguousarray
    return _cross_status(c(A, np.float64), c(Aid, np.int64), c(ai, np.int64), c(B, np.float64),
                         c(Bid, np.int64), c(bj, np.int64), float(side_bound), float(o3d_bound), float(tiny))


@njit(cache=True, nogil=True)
def _min3(a, b, c):
    """np.min of three values (NaN propagates)."""
    m = a
    if b < m or b != b:
        m = b
    if m == m and (c < m or c != c):
        m = c
    return m


@njit(cache=True, nogil=True)
def _max3(a, b, c):
    """np.max of three values (NaN propagates)."""
    m = a
    if b > m or b != b:
        m = b
    if m == m and (c > m or c != c):
        m = c
    return m


@njit(cache=True, nogil=True)
def _boxes(T):
    lo = np.empty((T.shape[0], 3))
    hi = np.empty((T.shape[0], 3))
    for t in range(T.shape[0]):
        for c in range(3):
            lo[t, c] = _min3(T[t, 0, c], T[t, 1, c], T[t, 2, c])
            hi[t, c] = _max3(T[t, 0, c], T[t, 1, c], T[t, 2, c])
    return lo, hi


#: Patch triangles × faces up to which :func:`patch_pairs` compares all
#: boxes (above: :func:`box_pairs`' grid); the same pairs either way.
PAIRS_BRUTE = 8192


@njit(cache=True, nogil=True)
def _patch_pairs(Q, Qid, f, V, F, origin, side_bound, o3d_bound, tiny):
    nf = f.size
    T = np.empty((nf, 3, 3))
    Tid = np.empty((nf, 3), np.int64)
    for j in range(nf):
        for k in range(3):
            v = F[f[j], k]
            Tid[j, k] = v
            for c in range(3):
                T[j, k, c] = V[v, c] - origin[c]
    qlo, qhi = _boxes(Q)
    tlo, thi = _boxes(T)
    if Q.shape[0] * nf <= PAIRS_BRUTE:
        ai = np.empty(Q.shape[0] * nf, np.int64)     # (no growing in the loop: that costs
        bj = np.empty(Q.shape[0] * nf, np.int64)     # reference counts at every step)
        n = 0
        for i in range(Q.shape[0]):
            for j in range(nf):
                if (qlo[i, 0] <= thi[j, 0] and tlo[j, 0] <= qhi[i, 0] and qlo[i, 1] <= thi[j, 1]
                        and tlo[j, 1] <= qhi[i, 1] and qlo[i, 2] <= thi[j, 2] and tlo[j, 2] <= qhi[i, 2]):
                    ai[n] = i
                    bj[n] = j
                    n += 1
        ai, bj = ai[:n], bj[:n]
    else:
        ai, bj = _box_pairs(qlo, qhi, tlo, thi, False)
    st = _cross_status(Q, Qid, ai, T, Tid, bj, side_bound, o3d_bound, tiny)
    return ai, bj, st


def patch_pairs(Q, Qid, f, V, F, origin, side_bound, o3d_bound, tiny):
    """:func:`cross_status` of a patch against some faces of a mesh, their
    candidate pairs found here: the faces' corners minus ``origin``, both
    sides' boxes, the overlapping pairs (:func:`box_pairs`), then the
    tests (:func:`shellrepair.mesh.intersect.patch_vs_index`'s steps in one call).

    Parameters
    ----------
    Q : (t,3,3) float64
        Patch triangle corners minus ``origin``, finite.
    Qid : (t,3) int64
        Their corner ids in the mesh's numbering (new vertices: ids no face uses).
    f : (r,) int64
        The faces to test.
    V : (n,3) float64
    F : (m,3) int64
    origin : (3,) float64
    side_bound, o3d_bound, tiny : float
        As for :func:`cross_status`.

    Returns
    -------
    ai, bj : (p,) int64
        The pairs (patch triangle, index into ``f``) whose boxes overlap, sorted by ``ai``.
    status : (p,) int8
    """
    c = np.ascontiguousarray
    return _patch_pairs(c(Q, np.float64), c(Qid, np.int64), c(f, np.int64), c(V, np.float64), c(F, np.int64),
                        c(origin, np.float64), float(side_bound), float(o3d_bound), float(tiny))


@njit(cache=True, nogil=True)
def _projection_embeds(Q, T, k, sgn, area_tol):
    t = T.shape[0]
    areas = np.empty(t)
    amax = 0.0
    for r in range(t):
        a, b, c = T[r, 0], T[r, 1], T[r, 2]
        e1x, e1y = Q[b, 0] - Q[a, 0], Q[b, 1] - Q[a, 1]
        e2x, e2y = Q[c, 0] - Q[a, 0], Q[c, 1] - Q[a, 1]
        ar = -(0.5 * (e1x * e2y - e1y * e2x) * sgn)
        if ar != ar:
            return False                  # NaN: NumPy's max and comparisons fail too
        areas[r] = ar
        amax = max(amax, abs(ar))
    for r in range(t):
        if not areas[r] > area_tol * amax:
            return False
    lo0 = hi0 = Q[0, 0]
    lo1 = hi1 = Q[0, 1]
    for i in range(1, k):
        lo0, hi0 = min(lo0, Q[i, 0]), max(hi0, Q[i, 0])
        lo1, hi1 = min(lo1, Q[i, 1]), max(hi1, Q[i, 1])
    span = max(hi0 - lo0, hi1 - lo1)
    if span == 0.0:
        span = 1.0
    return _outline_simple(Q[:k], 1e-12 * span * span)


def projection_embeds(Q, T, k, sgn, area_tol):
    """The tail of :func:`shellrepair.mesh.intersect.embeds_by_projection` in one
    call: every projected patch triangle turns against the loop with an
    area above ``area_tol`` times the largest, and the loop's outline (the
    first ``k`` rows of ``Q``) is simple (:func:`outline_simple`, with
    :func:`shellrepair.mesh.intersect.outline_is_simple`'s tolerance); the same
    products, comparisons and tolerance, so the same answer.

    Parameters
    ----------
    Q : (n,2) float64
        Projected patch vertices, loop first, finite.
    T : (t,3) int64
        Patch triangles, t >= 1.
    k : int
        Loop length, >= 3.
    sgn : float
        Sign of the loop's projected area (+1.0 or -1.0).
    area_tol : float

    Returns
    -------
    ok : bool
    """
    return bool(_projection_embeds(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(T, np.int64),
                                   int(k), float(sgn), float(area_tol)))


@njit(cache=True, nogil=True)
def _orient2(px, py, qx, qy, rx, ry):
    return (qx - px) * (ry - py) - (qy - py) * (rx - px)


@njit(cache=True, nogil=True)
def _outline_simple(Q, eps):
    k = Q.shape[0]
    for i in range(k):
        ax, ay = Q[i, 0], Q[i, 1]
        i1 = i + 1 if i + 1 < k else 0
        bx, by = Q[i1, 0], Q[i1, 1]
        for j in range(i + 2, k):
            if i == 0 and j == k - 1:
                continue    # edges k-1 and 0 are adjacent
            cx, cy = Q[j, 0], Q[j, 1]
            j1 = j + 1 if j + 1 < k else 0
            dx, dy = Q[j1, 0], Q[j1, 1]
            o1 = _orient2(ax, ay, bx, by, cx, cy)
            o2 = _orient2(ax, ay, bx, by, dx, dy)
            o3 = _orient2(cx, cy, dx, dy, ax, ay)
            o4 = _orient2(cx, cy, dx, dy, bx, by)
            if (o1 > eps and o2 > eps) or (o1 < -eps and o2 < -eps) \
                    or (o3 > eps and o4 > eps) or (o3 < -eps and o4 < -eps):
                continue
            if (max(ax, bx) < min(cx, dx) or max(cx, dx) < min(ax, bx)
                    or max(ay, by) < min(cy, dy) or max(cy, dy) < min(ay, by)):
                continue
            return False
    return True


def outline_simple(Q, eps):
    """:func:`shellrepair.mesh.intersect.outline_is_simple`'s pair test on every
    pair of non-adjacent edges of the closed polygon ``Q`` (k,2), k >= 3,
    with its tolerance ``eps``: the same orientations, in the same
    arithmetic, so the same answer; it stops at the first pair that meets."""
    return bool(_outline_simple(np.ascontiguousarray(Q, np.float64), float(eps)))
