"""Compiled kernels of a loop's triangulation (:mod:`shellrepair.fill.triangulate`, Numba).

* :func:`inside_outline`, :func:`loop_cover`: the inside test and the cover
  test of :func:`shellrepair.fill.triangulate.delaunay_in_projection`;
* :func:`centred_area`, :func:`outline_cross`, :func:`cover_free`: a
  loop's centred positions and vector area, and the projected Delaunay
  triangulation's inside, normal and cover tests with the forbidden edges
  (:func:`shellrepair.fill.triangulate.triangulate_loop`,
  :func:`shellrepair.fill.triangulate.delaunay_in_projection`);
* :func:`tet_faces`, :func:`loop_edges_present`: the triangles of a
  tetrahedralization and the loop edges among them
  (:func:`shellrepair.fill.triangulate.delaunay_faces`,
  :func:`shellrepair.fill.triangulate.with_loop_edges`);
* :func:`restricted_prepare`, :func:`restricted_search`: the candidate
  triangles' edges and normals and the minimum-weight search over them by
  interval length (:func:`shellrepair.fill.triangulate.restricted_dp`);
* :func:`liepa_tables`, :func:`chord_rows`: the tables of Liepa's dynamic
  program (:func:`shellrepair.fill.triangulate.liepa_dp`) and the row search of
  :func:`shellrepair.fill.triangulate.best_chord_rows`.

Each gives what its NumPy version gives, to the bit
(tests/test_triangulate_kernels.py, tests/test_patch_kernels.py). How the
kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["inside_outline", "loop_cover", "centred_area", "outline_cross", "cover_free", "tet_faces", "loop_edges_present", "restricted_prepare", "restricted_search", "liepa_tables", "chord_rows"]

from shellrepair import compiled
from shellrepair.mesh.common_kernels import _in_sorted

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _outline_label(X, Y, x, y):
    # Where (x, y) lies against the closed outline (X, Y): 0 outside, 1
    # inside, 2 at a corner (within 1e-12), 3 on a side; the crossing
    # counts of the rays to the right and to the left of the point, with
    # the coordinates taken relative to it.
    k = X.size
    right = 0
    left = 0
    xb = X[k - 1] - x
    yb = Y[k - 1] - y
    for i in range(k):
        xa = X[i] - x
        ya = Y[i] - y
        if -1e-12 < xa < 1e-12 and -1e-12 < ya < 1e-12:
            return 2
        if (ya > 0) != (yb > 0):
            if (xa * yb - xb * ya) / (yb - ya) > 0:
                right += 1
        if (ya < 0) != (yb < 0):
            if (xa * yb - xb * ya) / (yb - ya) < 0:
                left += 1
        xb = xa
        yb = ya
    if (right & 1) != (left & 1):
        return 3
    return 1 if right & 1 else 0


@njit(cache=True, nogil=True)
def _inside_outline(Q, S):
    X = Q[:, 0].copy()
    Y = Q[:, 1].copy()
    keep = np.empty(S.shape[0], np.int64)
    n = 0
    for t in range(S.shape[0]):
        a, b, c = S[t, 0], S[t, 1], S[t, 2]
        x = (Q[a, 0] + Q[b, 0] + Q[c, 0]) / 3.0
        y = (Q[a, 1] + Q[b, 1] + Q[c, 1]) / 3.0
        if _outline_label(X, Y, x, y) != 0:
            keep[n] = t
            n += 1
    out = np.empty((n, 3), np.int64)
    for i in range(n):
        for c in range(3):
            out[i, c] = S[keep[i], c]
    return out


def inside_outline(Q, S):
    """The triangles of ``S`` whose centroid is inside the outline ``Q``,
    on its sides or at its corners (as
    :func:`shellrepair.fill.triangulate.delaunay_in_projection`'s test by
    ``skimage.measure.points_in_poly``: a crossing count, corners within
    1e-12).

    Parameters
    ----------
    Q : (k,2) float64
        The outline's corners in order (closed implicitly).
    S : (t,3) int64
        Triangles over ``Q``'s rows.

    Returns
    -------
    S_in : (r,3) int64
        The rows of ``S`` kept, in order.
    """
    return _inside_outline(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(S, np.int64))


@njit(cache=True, nogil=True)
def _loop_cover(S, n, k):
    t = S.shape[0]
    out = np.empty((t, 3), np.int64)
    mx = abs(n[0])
    for i in range(t):
        a = abs(n[i])
        if a > mx or np.isnan(a):
            if not np.isnan(mx):
                mx = a
    lim = 1e-12 * mx
    seen = np.zeros(k, np.bool_)
    ok = True
    for i in range(t):
        if abs(n[i]) <= lim:
            ok = False
        if n[i] < 0:
            out[i, 0], out[i, 1], out[i, 2] = S[i, 0], S[i, 2], S[i, 1]
        else:
            out[i, 0], out[i, 1], out[i, 2] = S[i, 0], S[i, 1], S[i, 2]
        for c in range(3):
            x = out[i, c]
            y = out[i, (c + 1) % 3]
            if x == (y + 1) % k:
                seen[y] = True
    if ok:
        for j in range(k):
            if not seen[j]:
                ok = False
                break
    return out, ok


def loop_cover(S, n, k):
    """Orient the triangles ``S`` by the signs of ``n`` and test that they
    triangulate the loop of ``k`` positions (as
    :func:`shellrepair.fill.triangulate.delaunay_in_projection`).

    Parameters
    ----------
    S : (t,3) int64
    n : (t,) float64
        Each triangle's normal along the viewing axis (unnormalised).
    k : int

    Returns
    -------
    S_oriented : (t,3) int64
        ``S``, the rows with negative ``n`` turned (corners 0, 2, 1).
    ok : bool
        Every ``|n|`` above 1e-12 of the largest, and every loop edge
        ``(i, i+1)`` the reversed half-edge ``i+1 -> i`` of some triangle.
    """
    return _loop_cover(np.ascontiguousarray(S, np.int64), np.ascontiguousarray(n, np.float64), int(k))


@njit(cache=True, nogil=True)
def _nan_max(x, y):
    # np.maximum of two floats: the first where it is NaN or not smaller (NaN propagates)
    return x if (x >= y or x != x) else y


@njit(cache=True, nogil=True)
def _clip_unit(d):
    # np.clip(d, -1.0, 1.0): NaN stays NaN
    if d < -1.0:
        return -1.0
    if d > 1.0:
        return 1.0
    return d


@njit(cache=True, nogil=True)
def _sorts_before(x, y):
    # x strictly before y in NumPy's sort order of floats (NaN last)
    return x < y or (y != y and x == x)


@njit(cache=True, nogil=True)
def _centred_area(P):
    k = P.shape[0]
    m0 = m1 = m2 = 0.0
    for i in range(k):
        m0 += P[i, 0]
        m1 += P[i, 1]
        m2 += P[i, 2]
    m0, m1, m2 = m0 / k, m1 / k, m2 / k
    C = np.empty((k, 3))
    for i in range(k):
        C[i, 0], C[i, 1], C[i, 2] = P[i, 0] - m0, P[i, 1] - m1, P[i, 2] - m2
    s0 = s1 = s2 = 0.0
    for i in range(k):
        j = i + 1 if i + 1 < k else 0
        s0 += C[i, 1] * C[j, 2] - C[i, 2] * C[j, 1]
        s1 += C[i, 2] * C[j, 0] - C[i, 0] * C[j, 2]
        s2 += C[i, 0] * C[j, 1] - C[i, 1] * C[j, 0]
    va = np.empty(3)
    va[0], va[1], va[2] = -0.5 * s0, -0.5 * s1, -0.5 * s2
    return C, va


def centred_area(P):
    """The loop ``P`` about its mean and minus its vector area, as
    :func:`shellrepair.fill.triangulate.triangulate_loop` computes them
    (``C = P - P.mean(axis=0)``, ``-0.5 * cross(C, C rolled by -1).sum(axis=0)``):
    NumPy sums a C-ordered array's columns row after row from 0.0, and so
    does this.

    Parameters
    ----------
    P : (k,3) float64, C-ordered (the caller's NumPy would sum an
        F-ordered one pairwise)

    Returns
    -------
    C : (k,3) float64
    va : (3,) float64
    """
    return _centred_area(np.ascontiguousarray(P, np.float64))


@njit(cache=True, nogil=True)
def _outline_cross(Q, S, P):
    S = _inside_outline(Q, S)
    raw = np.empty((S.shape[0], 3))
    for t in range(S.shape[0]):
        i0, i1, i2 = S[t, 0], S[t, 1], S[t, 2]
        a0, a1, a2 = P[i1, 0] - P[i0, 0], P[i1, 1] - P[i0, 1], P[i1, 2] - P[i0, 2]
        b0, b1, b2 = P[i2, 0] - P[i0, 0], P[i2, 1] - P[i0, 1], P[i2, 2] - P[i0, 2]
        raw[t, 0] = a1 * b2 - a2 * b1
        raw[t, 1] = a2 * b0 - a0 * b2
        raw[t, 2] = a0 * b1 - a1 * b0
    return S, raw


def outline_cross(Q, S, P):
    """:func:`inside_outline` and the kept triangles' cross products
    ``(P[b] - P[a]) × (P[c] - P[a])`` (the normal test of
    :func:`shellrepair.fill.triangulate.delaunay_in_projection`, before its
    product with the axis, which stays NumPy's).

    Parameters
    ----------
    Q : (k,2) float64
    S : (t,3) int64
    P : (k,3) float64

    Returns
    -------
    S_in : (r,3) int64
    raw : (r,3) float64
    """
    return _outline_cross(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(S, np.int64),
                          np.ascontiguousarray(P, np.float64))


@njit(cache=True, nogil=True)
def _cover_free(S, n, k, fk):
    out, ok = _loop_cover(S, n, k)
    if not ok:
        return out, 1
    if fk.size:
        for t in range(out.shape[0]):
            for c in range(3):
                x, y = out[t, c], out[t, (c + 1) % 3]
                if _in_sorted(fk, min(x, y) * k + max(x, y)):
                    return out, 2
    return out, 0


def cover_free(S, n, k, fk):
    """:func:`loop_cover`, then whether an edge of the triangles joins a
    forbidden pair (:func:`shellrepair.fill.triangulate._none_forbidden`).

    Parameters
    ----------
    S : (t,3) int64
    n : (t,) float64
    k : int
    fk : (f,) int64
        Sorted keys ``x·k + y`` of the forbidden pairs ``0 <= x < y < k``.

    Returns
    -------
    S_oriented : (t,3) int64
    status : int
        0 a cover without a forbidden edge; 1 not a cover; 2 a cover
        using a forbidden edge.
    """
    out, status = _cover_free(np.ascontiguousarray(S, np.int64), np.ascontiguousarray(n, np.float64), int(k),
                              np.ascontiguousarray(fk, np.int64))
    return out, int(status)


@njit(cache=True, nogil=True)
def _tet_faces(S, n):
    t = S.shape[0]
    first = np.empty(4 * t, np.int64)       # each face's smallest corner
    rest = np.empty(4 * t, np.int64)        # and b·n + c of the other two
    v = np.empty(4, np.int64)
    for i in range(t):
        for c in range(4):              # the corners sorted (insertion)
            x = S[i, c]
            j = c
            while j > 0 and v[j - 1] > x:
                v[j] = v[j - 1]
                j -= 1
            v[j] = x
        first[4 * i], rest[4 * i] = v[0], v[1] * n + v[2]
        first[4 * i + 1], rest[4 * i + 1] = v[0], v[1] * n + v[3]
        first[4 * i + 2], rest[4 * i + 2] = v[0], v[2] * n + v[3]
        first[4 * i + 3], rest[4 * i + 3] = v[1], v[2] * n + v[3]
    # the keys (a·n + b)·n + c in order: by a (counting sort), then by b·n + c
    start = np.zeros(n + 1, np.int64)
    for i in range(4 * t):
        start[first[i] + 1] += 1
    for a in range(n):
        start[a + 1] += start[a]
    fill = start[:n].copy()
    srt = np.empty(4 * t, np.int64)
    for i in range(4 * t):
        srt[fill[first[i]]] = rest[i]
        fill[first[i]] += 1
    m = 0
    D = np.empty((4 * t, 3), np.int64)
    for a in range(n):
        seg = srt[start[a]:start[a + 1]]
        if seg.size > 16:
            seg.sort()
        else:
            for p in range(1, seg.size):
                x = seg[p]
                j = p
                while j > 0 and seg[j - 1] > x:
                    seg[j] = seg[j - 1]
                    j -= 1
                seg[j] = x
        for p in range(seg.size):
            if p == 0 or seg[p] != seg[p - 1]:
                D[m, 0], D[m, 1], D[m, 2] = a, seg[p] // n, seg[p] % n
                m += 1
    return D[:m].copy()


def tet_faces(S, n):
    """The triangles of tetrahedra ``S`` over ``n`` points, each once,
    corners ascending, ordered by their key ``(a·n + b)·n + c``
    (:func:`shellrepair.fill.triangulate.delaunay_faces`'s sort, faces and
    ``np.unique``).

    Parameters
    ----------
    S : (t,4) int
        Corners in ``[0, n)``.
    n : int

    Returns
    -------
    D : (f,3) int64
    """
    return _tet_faces(np.ascontiguousarray(S, np.int64), int(n))


@njit(cache=True, nogil=True)
def _loop_edges_present(D, k):
    seen = np.zeros(k, np.bool_)
    for i in range(D.shape[0]):
        a, b, c = D[i, 0], D[i, 1], D[i, 2]
        for p, q in ((a, b), (b, c), (a, c)):
            if p < 0 or p >= k or q < 0 or q >= k:
                return seen, False
            if q == p + 1:
                seen[p] = True
            if p == 0 and q == k - 1:
                seen[k - 1] = True
    return seen, True


def loop_edges_present(D, k):
    """Which loop edges ``(i, i+1)`` (and ``(0, k-1)`` last) are an edge
    ``(a, b)``, ``(b, c)`` or ``(a, c)`` of some row of ``D``
    (:func:`shellrepair.fill.triangulate.with_loop_edges`'s ``np.isin``).

    Parameters
    ----------
    D : (t,3) int64
    k : int

    Returns
    -------
    seen : (k,) bool
    ok : bool
        False when a corner is outside ``[0, k)`` (``seen`` is then not
        complete: its keys could alias, the caller's NumPy decides).
    """
    return _loop_edges_present(np.ascontiguousarray(D, np.int64), int(k))


@njit(cache=True, nogil=True)
def _forbidden_chord(p, q, k, fk):
    # (p, q) is a chord (not a loop edge) and forbidden (restricted_dp's np.isin)
    return q - p > 1 and not (p == 0 and q == k - 1) and _in_sorted(fk, p * k + q)


@njit(cache=True, nogil=True)
def _restricted_prepare(P, cand, fk):
    k = P.shape[0]
    m0 = cand.shape[0]
    keep = np.empty(m0, np.int64)
    m = 0
    for r in range(m0):
        x, y, z = cand[r, 0], cand[r, 1], cand[r, 2]
        if not (x < y and y < z):
            continue
        if fk.size and (_forbidden_chord(x, y, k, fk) or _forbidden_chord(y, z, k, fk)
                        or _forbidden_chord(x, z, k, fk)):
            continue
        if x < 0 or z >= k:     # an index NumPy would wrap or reject: the caller's NumPy decides
            e = np.empty(0, np.int64)
            return e, e, e, e, e, e, 0, e, -1, np.empty((0, 3)), np.empty((0, 3)), np.empty(0, np.bool_), \
                np.empty(0), 1
        keep[m] = r
        m += 1
    a = np.empty(m, np.int64)
    b = np.empty(m, np.int64)
    c = np.empty(m, np.int64)
    for q in range(m):
        a[q], b[q], c[q] = cand[keep[q], 0], cand[keep[q], 1], cand[keep[q], 2]
    # edge ids: the loop edges (i, i+1), the interval (0, k-1), the candidates'
    # (a, b), (b, c), (a, c); bucketed by first corner, each (i, j) one id
    ne_all = k + 3 * m
    ei = np.empty(ne_all, np.int64)
    ej = np.empty(ne_all, np.int64)
    for i in range(k - 1):
        ei[i], ej[i] = i, i + 1
    ei[k - 1], ej[k - 1] = 0, k - 1
    for q in range(m):
        s = k + 3 * q
        ei[s], ej[s] = a[q], b[q]
        ei[s + 1], ej[s + 1] = b[q], c[q]
        ei[s + 2], ej[s + 2] = a[q], c[q]
    start = np.zeros(k + 1, np.int64)
    for s in range(ne_all):
        start[ei[s] + 1] += 1
    for i in range(k):
        start[i + 1] += start[i]
    fill = start[:k].copy()
    rows = np.empty(ne_all, np.int64)
    for s in range(ne_all):
        rows[fill[ei[s]]] = s
        fill[ei[s]] += 1
    stamp = np.full(k, -1, np.int64)
    idof = np.empty(k, np.int64)
    eid = np.empty(ne_all, np.int64)
    ne = 0
    for i in range(k):
        for p in range(start[i], start[i + 1]):
            s = rows[p]
            j = ej[s]
            if stamp[j] != i:
                stamp[j] = i
                idof[j] = ne
                ne += 1
            eid[s] = idof[j]
    base = eid[:k - 1].copy()
    top = eid[k - 1]
    el = np.empty(m, np.int64)
    er = np.empty(m, np.int64)
    et = np.empty(m, np.int64)
    for q in range(m):
        s = k + 3 * q
        el[q], er[q], et[q] = eid[s], eid[s + 1], eid[s + 2]
    # triangle (a, c, b): raw normal cross(P[c] - P[a], P[b] - P[a]), unit normal, area
    raw = np.empty((m, 3))
    n = np.empty((m, 3))
    nz = np.empty(m, np.bool_)
    area = np.empty(m)
    for q in range(m):
        ia, ib, ic = a[q], b[q], c[q]
        u0, u1, u2 = P[ic, 0] - P[ia, 0], P[ic, 1] - P[ia, 1], P[ic, 2] - P[ia, 2]
        v0, v1, v2 = P[ib, 0] - P[ia, 0], P[ib, 1] - P[ia, 1], P[ib, 2] - P[ia, 2]
        r0 = u1 * v2 - u2 * v1
        r1 = u2 * v0 - u0 * v2
        r2 = u0 * v1 - u1 * v0
        raw[q, 0], raw[q, 1], raw[q, 2] = r0, r1, r2
        ln = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        nz[q] = ln > 0
        d = ln if ln > 0 else 1.0
        n[q, 0], n[q, 1], n[q, 2] = r0 / d, r1 / d, r2 / d
        area[q] = 0.5 * ln
    return a, b, c, el, er, et, ne, base, top, raw, n, nz, area, 0


def restricted_prepare(P, cand, fk):
    """The candidates of :func:`shellrepair.fill.triangulate.restricted_dp` and
    their edges and geometry (its NumPy setup, the same products): the
    candidates kept (``a < b < c``, no chord in ``fk``), their edges
    ``(a, b)``, ``(b, c)``, ``(a, c)`` as ids (any numbering, one id per
    edge: the search reads them only as names), and each triangle
    ``(a, c, b)``'s cross product, unit normal and area.

    Parameters
    ----------
    P : (k,3) float64
    cand : (t,3) int64
    fk : (f,) int64
        Sorted keys ``x·k + y`` of the forbidden pairs.

    Returns
    -------
    a, b, c, el, er, et : (m,) int64
    ne : int
        Number of edge ids.
    base : (k-1,) int64
        The loop edges' ids.
    top : int
        The id of the interval ``(0, k-1)``.
    raw, n : (m,3) float64, nz : (m,) bool, area : (m,) float64
    status : int
        0; 1 when a kept candidate has a corner outside ``[0, k)`` (nothing
        else returned then).
    """
    out = _restricted_prepare(np.ascontiguousarray(P, np.float64), np.ascontiguousarray(cand, np.int64),
                              np.ascontiguousarray(fk, np.int64))
    return out[:6] + (int(out[6]), out[7], int(out[8])) + out[9:13] + (int(out[13]),)


@njit(cache=True, nogil=True)
def _restricted_search(k, a, b, c, el, er, et, ne, base, edge_normals, n, nz, area, bad0, top, tie):
    m = b.shape[0]
    inf = np.inf
    WA = np.full(ne, inf)
    WS = np.full(ne, inf)
    N = np.zeros((ne, 3))
    HN = np.zeros(ne, np.bool_)
    sel = np.full(ne, -1, np.int64)        # each solved interval's candidate
    best = np.full(ne, inf)                # the least finite worst cost among its candidates
    sws = np.full(ne, inf)                 # the chosen candidate's area (inf where past the tie)
    for i in range(k - 1):
        e = base[i]
        WA[e] = 0.0
        WS[e] = 0.0
        x, y, z = edge_normals[i, 0], edge_normals[i, 1], edge_normals[i, 2]
        N[e, 0] = x
        N[e, 1] = y
        N[e, 2] = z
        HN[e] = abs(x) + abs(y) + abs(z) > 0
    r0, r1, r2 = edge_normals[k - 1, 0], edge_normals[k - 1, 1], edge_normals[k - 1, 2]
    has_close = abs(r0) + abs(r1) + abs(r2) > 0
    rim_zero = r0 == 0 and r1 == 0 and r2 == 0
    # candidates by length c - a, stable (np.argsort(L, kind="stable") and its groups)
    start = np.zeros(k + 1, np.int64)
    for i in range(m):
        start[c[i] - a[i] + 1] += 1
    for s in range(k):
        start[s + 1] += start[s]
    fill = start[:k].copy()
    order = np.empty(m, np.int64)
    for i in range(m):
        s = c[i] - a[i]
        order[fill[s]] = i
        fill[s] += 1
    wa = np.empty(m)
    ws = np.empty(m)
    for length in range(2, k):
        q0, q1 = start[length], start[length + 1]
        # worst cost and area of each candidate, on the shorter intervals el, er
        for q in range(q0, q1):
            i = order[q]
            l, r, t = el[i], er[i], et[i]
            n0, n1, n2 = n[i, 0], n[i, 1], n[i, 2]
            d1 = _clip_unit(n0 * N[l, 0] + n1 * N[l, 1] + n2 * N[l, 2])
            d2 = _clip_unit(n0 * N[r, 0] + n1 * N[r, 1] + n2 * N[r, 2])
            a1 = ((1.0 - d1) if nz[i] else 2.0) if HN[l] else 0.0
            a2 = ((1.0 - d2) if nz[i] else 2.0) if HN[r] else 0.0
            w = _nan_max(_nan_max(a1, a2), _nan_max(WA[l], WA[r]))
            if has_close and t == top:      # the closing edge's scan face (triangulate._angle)
                if (n0 == 0 and n1 == 0 and n2 == 0) or rim_zero:
                    g = 2.0
                else:
                    g = 1.0 - _clip_unit(n0 * r0 + n1 * r1 + n2 * r2)
                w = _nan_max(w, g)
            if bad0[i]:
                w = inf
            wa[q] = w
            ws[q] = area[i] + WS[l] + WS[r]
            if np.isfinite(w) and w < best[t]:
                best[t] = w
        # per interval: the least area within ANGLE_TIE of the best cost, the first of equals
        for q in range(q0, q1):
            w = wa[q]
            if not np.isfinite(w):
                continue
            i = order[q]
            t = et[i]
            s = ws[q] if w <= best[t] + tie else inf
            if sel[t] < 0 or _sorts_before(s, sws[t]):
                sel[t] = i
                sws[t] = s
        for q in range(q0, q1):
            i = order[q]
            t = et[i]
            if sel[t] == i:
                WA[t] = wa[q]
                WS[t] = sws[t]
                N[t, 0] = n[i, 0]
                N[t, 1] = n[i, 1]
                N[t, 2] = n[i, 2]
                HN[t] = nz[i]
    T = np.empty((max(k - 2, 0), 3), np.int64)
    if not np.isfinite(WA[top]):
        return T[:0], 1, 0, k - 1
    # the triangles, depth first as restricted_dp's stack pops them
    stack = np.empty((2 * k + 2, 3), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, k - 1, top
    sp = 1
    nt = 0
    while sp > 0:
        sp -= 1
        i, j, e = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        if j - i < 2:
            continue
        s = sel[e]
        if s < 0 or nt >= T.shape[0]:
            return T[:nt], 2, i, j
        mm = b[s]
        T[nt, 0], T[nt, 1], T[nt, 2] = i, j, mm
        nt += 1
        stack[sp, 0], stack[sp, 1], stack[sp, 2] = i, mm, el[s]
        stack[sp + 1, 0], stack[sp + 1, 1], stack[sp + 1, 2] = mm, j, er[s]
        sp += 2
    return T[:nt], 0, 0, 0


def restricted_search(k, a, b, c, el, er, et, ne, base, edge_normals, n, nz, area, bad0, top, tie):
    """The group loop and the read-back of
    :func:`shellrepair.fill.triangulate.restricted_dp` (its NumPy form
    :func:`shellrepair.fill.triangulate.restricted_dp_reference`): intervals by
    increasing length, each closed by the candidate of least worst
    dihedral cost, the least area among costs within ``tie`` of it (the
    first of equal areas, as ``np.lexsort`` orders them), with the same
    products, clips and maxima.

    Parameters
    ----------
    k : int
        Loop length.
    a, b, c : (m,) int64
        The candidates' sorted corners.
    el, er, et : (m,) int64
        Their edges ``(a, b)``, ``(b, c)``, ``(a, c)`` as ids into the ``ne``
        edge keys.
    ne : int
    base : (k-1,) int64
        The ids of the loop edges ``(i, i+1)``.
    edge_normals : (k,3) float64
        Rim normals (zero rows unknown).
    n : (m,3) float64, nz : (m,) bool, area : (m,) float64, bad0 : (m,) bool
        The candidates' unit normals, whether they are not degenerate, their
        areas, and whether they face against the axis.
    top : int
        The id of the interval ``(0, k-1)``.
    tie : float
        ``ANGLE_TIE``.

    Returns
    -------
    T : (k-2,3) int64
        Triangles ``(i, j, apex)`` in the read-back's order (fewer on failure).
    status : int
        0; 1 when no triangulation uses only the candidates; 2 when the
        interval ``(i, j)`` has no apex.
    i, j : int
    """
    ci = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    cf = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    cb = lambda x: np.ascontiguousarray(x, np.bool_)  # noqa: E731
    T, status, i, j = _restricted_search(int(k), ci(a), ci(b), ci(c), ci(el), ci(er), ci(et), int(ne), ci(base),
                                         cf(edge_normals), cf(n), cb(nz), cf(area), cb(bad0), int(top), float(tie))
    return T, int(status), int(i), int(j)


@njit(cache=True, nogil=True)
def _liepa_tables(Q, rim, has_rim, forb, axis, use_axis, tie):
    k = Q.shape[0]
    inf = np.inf
    Qx = np.ascontiguousarray(Q[:, 0])
    Qy = np.ascontiguousarray(Q[:, 1])
    Qz = np.ascontiguousarray(Q[:, 2])
    # the tables by interval (i, j), and a copy by (j, i): the apex loop
    # reads edge (i, m) from a row and edge (m, j) from a row of the copy;
    # the normals as three planes, so that both loops over the apexes read
    # (and the first one vectorises) along rows
    WA = np.full((k, k), inf)
    WS = np.full((k, k), inf)
    WAc = np.full((k, k), inf)
    WSc = np.full((k, k), inf)
    Nx, Ny, Nz = np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k))
    Ncx, Ncy, Ncz = np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k))
    HN = np.zeros((k, k), np.bool_)
    HNc = np.zeros((k, k), np.bool_)
    forbc = np.ascontiguousarray(forb.T)
    O = np.full((k, k), -1, np.int64)
    for i in range(k - 1):
        WA[i, i + 1] = 0.0
        WS[i, i + 1] = 0.0
        WAc[i + 1, i] = 0.0
        WSc[i + 1, i] = 0.0
        if has_rim[i]:
            Nx[i, i + 1], Ny[i, i + 1], Nz[i, i + 1] = rim[i, 0], rim[i, 1], rim[i, 2]
            Ncx[i + 1, i], Ncy[i + 1, i], Ncz[i + 1, i] = rim[i, 0], rim[i, 1], rim[i, 2]
        h = has_rim[i] and (rim[i, 0] != 0 or rim[i, 1] != 0 or rim[i, 2] != 0)
        HN[i, i + 1] = h
        HNc[i + 1, i] = h
    c0, c1, c2 = rim[k - 1, 0], rim[k - 1, 1], rim[k - 1, 2]
    close_zero = (abs(c0) + abs(c1)) + abs(c2) == 0
    ax0, ax1, ax2 = axis[0], axis[1], axis[2]
    wa = np.empty(k)
    ws = np.empty(k)
    n0s, n1s, n2s = np.empty(k), np.empty(k), np.empty(k)
    ar = np.empty(k)
    axd = np.empty(k)
    nzs = np.empty(k, np.bool_)
    for L in range(2, k):
        for i in range(k - L):
            j = i + L
            n = L - 1
            q0, q1, q2 = Qx[i], Qy[i], Qz[i]
            a0, a1, a2 = Qx[j] - q0, Qy[j] - q1, Qz[j] - q2
            fij = forb[i, j]
            # each apex m = i + 1 + t: the triangle (i, j, m)'s unit normal and area
            for t in range(n):
                m = i + 1 + t
                b0, b1, b2 = Qx[m] - q0, Qy[m] - q1, Qz[m] - q2
                r0 = a1 * b2 - a2 * b1            # geometry.cross(Q[j] - Q[i], Q[m] - Q[i])
                r1 = a2 * b0 - a0 * b2
                r2 = a0 * b1 - a1 * b0
                ln = np.sqrt((r0 * r0 + r1 * r1) + r2 * r2)
                nz = ln > 0
                d = ln if nz else 1.0
                n0s[t], n1s[t], n2s[t] = r0 / d, r1 / d, r2 / d
                ar[t] = 0.5 * ln
                nzs[t] = nz
                axd[t] = (r0 * ax0 + r1 * ax1) + r2 * ax2
            # its worst dihedral cost and total area (selects: np.clip, np.maximum with NaN first)
            for t in range(n):
                m = i + 1 + t
                n0, n1, n2 = n0s[t], n1s[t], n2s[t]
                nz = nzs[t]
                d1 = (n0 * Nx[i, m] + n1 * Ny[i, m]) + n2 * Nz[i, m]
                d1 = -1.0 if d1 < -1.0 else (1.0 if d1 > 1.0 else d1)
                d2 = (n0 * Ncx[j, m] + n1 * Ncy[j, m]) + n2 * Ncz[j, m]
                d2 = -1.0 if d2 < -1.0 else (1.0 if d2 > 1.0 else d2)
                e1 = ((1.0 - d1) if nz else 2.0) if HN[i, m] else 0.0
                e2 = ((1.0 - d2) if nz else 2.0) if HNc[j, m] else 0.0
                x = e1 if ((e1 >= e2) | (e1 != e1)) else e2
                u, v = WA[i, m], WAc[j, m]
                y = u if ((u >= v) | (u != u)) else v
                w = x if ((x >= y) | (x != x)) else y
                bad = forb[i, m] | forbc[j, m] | fij | (use_axis & (axd[t] <= 0))
                wa[t] = inf if bad else w
                ws[t] = (ar[t] + WS[i, m]) + WSc[j, m]
            if L == k - 1 and has_rim[k - 1]:    # the closing edge's scan face (triangulate._angle)
                for t in range(n):
                    if wa[t] == inf:
                        continue
                    n0, n1, n2 = n0s[t], n1s[t], n2s[t]
                    if close_zero or (abs(n0) + abs(n1)) + abs(n2) == 0:
                        g = 2.0
                    else:
                        g = 1.0 - _clip_unit((n0 * c0 + n1 * c1) + n2 * c2)
                    wa[t] = _nan_max(wa[t], g)
            # np.min (NaN wins), then np.argmin of the areas within tie of it (first of equals, a NaN first)
            best = wa[0]
            for t in range(1, n):
                if best != best:
                    break
                x = wa[t]
                if x < best or x != x:
                    best = x
            lim = best + tie
            sel = 0
            cur = ws[0] if wa[0] <= lim else inf
            for t in range(1, n):
                if cur != cur:
                    break
                x = ws[t] if wa[t] <= lim else inf
                if x < cur or x != x:
                    cur = x
                    sel = t
            WA[i, j] = wa[sel]
            WAc[j, i] = wa[sel]
            WS[i, j] = cur
            WSc[j, i] = cur
            O[i, j] = i + 1 + sel
            Nx[i, j], Ny[i, j], Nz[i, j] = n0s[sel], n1s[sel], n2s[sel]
            Ncx[j, i], Ncy[j, i], Ncz[j, i] = n0s[sel], n1s[sel], n2s[sel]
            HN[i, j] = nzs[sel]
            HNc[j, i] = nzs[sel]
    return O, WA[0, k - 1]


def liepa_tables(Q, rim, has_rim, forb, axis, tie):
    """The tables of :func:`shellrepair.fill.triangulate.liepa_dp` (Liepa's O(k³)
    dynamic program), with its products, clips, maxima and first-of-equals
    choices, one interval at a time.

    Parameters
    ----------
    Q : (k,3) float64
        The sub-loop's positions.
    rim : (k,3) float64, has_rim : (k,) bool
        The scan face's normal across sub-loop edge ``(i, i+1)`` (``(k-1,
        0)`` last) and whether there is one.
    forb : (k,k) bool
        Forbidden chords ``(i, j)``, ``i < j``.
    axis : (3,) float64 or None
        Every triangle must face along it (``cross · axis > 0``).
    tie : float
        ``ANGLE_TIE``.

    Returns
    -------
    O : (k,k) int64
        The apex closing each interval ``(i, j)``.
    worst : float
        The whole loop's worst dihedral cost (inf: no triangulation).
    """
    use = axis is not None
    ax = np.ascontiguousarray(axis if use else np.zeros(3), np.float64).reshape(3)
    O, worst = _liepa_tables(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(rim, np.float64),
                             np.ascontiguousarray(has_rim, np.bool_), np.ascontiguousarray(forb, np.bool_), ax,
                             use, float(tie))
    return O, float(worst)


@njit(cache=True, nogil=True)
def _chord_rows(Q, q, fk):
    k = Q.shape[0]
    best = np.inf
    bi, bj, ties = -1, -1, 0
    for i in range(k - q):
        x, y, z = Q[i, 0], Q[i, 1], Q[i, 2]
        dmin = np.inf
        jmin, count = -1, 0
        for j in range(i + q, min(k, i + k - q + 1)):
            if fk.size and _in_sorted(fk, i * k + j):
                continue
            dx, dy, dz = Q[j, 0] - x, Q[j, 1] - y, Q[j, 2] - z
            d = np.sqrt((dx * dx + dy * dy) + dz * dz)     # np.linalg.norm(..., axis=1)
            if d < dmin:
                dmin, jmin, count = d, j, 1
            elif d == dmin:
                count += 1
        if jmin >= 0 and dmin < best:
            best, bi, bj, ties = dmin, i, jmin, count
    return bi, bj, ties


def chord_rows(Q, q, fk):
    """The row-by-row search of :func:`shellrepair.fill.triangulate.best_chord_rows`:
    the row ``i`` whose nearest allowed partner ``j`` (``i + q <= j <=
    min(k - 1, i + k - q)``) is nearest overall, the first such row.

    Parameters
    ----------
    Q : (k,3) float64
        The sub-loop's positions.
    q : int
    fk : (f,) int64
        Sorted keys ``u·k + v`` (``u < v``) of the forbidden position pairs.

    Returns
    -------
    i, j : int
        ``i = -1`` when no row has an allowed partner; ``j`` the first of
        the row's nearest partners.
    ties : int
        How many partners of row ``i`` are that near (more than one: the
        row's pick is NumPy's argsort's, the caller's to make).
    """
    i, j, t = _chord_rows(np.ascontiguousarray(Q, np.float64), int(q), np.ascontiguousarray(fk, np.int64))
    return int(i), int(j), int(t)
