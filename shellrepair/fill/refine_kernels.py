"""Compiled kernels of a patch's refinement and relaxation (:mod:`shellrepair.fill.refine`, Numba).

* :func:`relax`: a patch's Delaunay edge flips
  (:func:`shellrepair.fill.refine.relax`), the angles still NumPy's, and
  :func:`relax_round_parts`: one round's angle parts and fold tests;
* :func:`angle_parts`, :func:`unfolded`: the products and sums of the
  relaxation's opposite angles (the arctan2 left to NumPy) and its fold
  test (:func:`shellrepair.fill.refine.angle_between`, :func:`shellrepair.fill.refine.unfolded`);
* :func:`split_test`: the refinement's split test (:func:`shellrepair.fill.refine._refine`).

Each gives what its NumPy version gives, to the bit (tests/test_kernels.py).
How the kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["relax", "relax_round_parts", "angle_parts", "unfolded", "split_test", "pair_half_edges"]

from shellrepair import compiled
from shellrepair.mesh.common_kernels import _in_sorted

njit = compiled.kernel


# --------------------------------------------------------------------------
# Delaunay relaxation of a patch (refine.relax): the bookkeeping compiled,
# the angles left to NumPy (its arctan2 is not libm's to the last bit)
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _relax_gather(T, twin, active, n):
    m = active.size
    h1 = active.copy()
    h2 = np.empty(m, np.int64)
    kab = np.empty(m, np.int64)
    for j in range(m):
        h = h1[j]
        h2[j] = twin[h]
        a, b = T[h // 3, h % 3], T[h // 3, (h % 3 + 1) % 3]
        kab[j] = min(a, b) * n + max(a, b)
    srt = np.argsort(kab, kind="mergesort")       # stable: edge-key order, as a full pass lists them
    out = np.empty((m, 8), np.int64)              # h1, h2, a, b, c, d, f1, f2
    for j in range(m):
        h, g = h1[srt[j]], h2[srt[j]]
        f1, i1, f2, i2 = h // 3, h % 3, g // 3, g % 3
        out[j, 0], out[j, 1] = h, g
        out[j, 2], out[j, 3], out[j, 4] = T[f1, i1], T[f1, (i1 + 1) % 3], T[f1, (i1 + 2) % 3]
        out[j, 5] = T[f2, (i2 + 2) % 3]
        out[j, 6], out[j, 7] = f1, f2
    return out


@njit(cache=True, nogil=True)
def _relax_apply(T, twin, changed, is_loop, forb, edge_keys, ck_keys, ck_vals, g, excess, unfolded, flip_eps, n):
    """One round of refine.relax after its angles: returns (status, active);
    status 0: flipped, go on; 1: settled; 2: faces shared by two flips of
    the round (a tie NumPy's vectorised writes resolve by order: the caller
    redoes the whole relaxation in NumPy). ``ck_keys`` (sorted) and
    ``ck_vals``: edges flips made (True) or removed (False); returned
    updated."""
    m = g.shape[0]
    nt = T.shape[0]
    none = np.empty(0, np.int64)
    geo = np.empty(m, np.int64)
    ng = 0
    for j in range(m):
        if excess[j] > flip_eps and g[j, 4] != g[j, 5]:
            geo[ng] = j
            ng += 1
    if ng == 0:
        return 1, none, ck_keys, ck_vals
    cand = np.empty(ng, np.int64)
    ncd = np.zeros(m, np.int64)
    nc = 0
    for q in range(ng):
        j = geo[q]
        c, d = g[j, 4], g[j, 5]
        key = min(c, d) * n + max(c, d)
        exists = _in_sorted(edge_keys, key)
        if ck_keys.size:
            p = min(np.searchsorted(ck_keys, key), ck_keys.size - 1)
            if ck_keys[p] == key:
                exists = ck_vals[p]
        ok = not exists
        if forb.size and is_loop[c] and is_loop[d] and _in_sorted(forb, key):
            ok = False
        if ok and unfolded[j]:
            cand[nc] = j
            ncd[j] = key
            nc += 1
    if nc == 0:
        return 1, none, ck_keys, ck_vals
    # refine.independent_flips
    best = np.empty(nt)
    for q in range(nc):
        j = cand[q]
        best[g[j, 6]] = -np.inf
        best[g[j, 7]] = -np.inf
    for q in range(nc):
        j = cand[q]
        best[g[j, 6]] = max(best[g[j, 6]], excess[j])
        best[g[j, 7]] = max(best[g[j, 7]], excess[j])
    seen = np.zeros(nt, np.bool_)
    taken = np.zeros(nt, np.bool_)
    keep = np.zeros(nc, np.bool_)
    for q in range(nc):
        j = cand[q]
        g1, g2 = g[j, 6], g[j, 7]
        if best[g1] == excess[j] and best[g2] == excess[j] and not seen[g1]:
            seen[g1] = True
            keep[q] = True
            taken[g1] = True
    kept = np.empty(nc, np.int64)
    nk = 0
    for q in range(nc):
        j = cand[q]
        if keep[q] and (not taken[g[j, 7]] or g[j, 7] == g[j, 6]):
            kept[nk] = j
            nk += 1
    if nk == 0:
        return 1, none, ck_keys, ck_vals
    # of flips making the same new edge the first; in new-edge order
    keys = np.empty(nk, np.int64)
    for q in range(nk):
        keys[q] = ncd[kept[q]]
    by = np.argsort(keys, kind="mergesort")
    flips = np.empty(nk, np.int64)
    nf = 0
    for q in range(nk):
        if q == 0 or keys[by[q]] != keys[by[q - 1]]:
            flips[nf] = kept[by[q]]
            nf += 1
    flips = flips[:nf]
    if nf == 0:
        return 1, none, ck_keys, ck_vals
    used = np.zeros(nt, np.bool_)
    for q in range(nf):
        j = flips[q]
        for f in (g[j, 6], g[j, 7]):
            if used[f]:
                return 2, none, ck_keys, ck_vals
            used[f] = True
    # flip: f1 = (a,b,c) -> (c,a,d), f2 = (b,a,d) -> (d,b,c); outer half-edges move slots
    slot_new = np.full(3 * nt, -1, np.int64)
    old = np.empty((4, nf), np.int64)
    new = np.empty((4, nf), np.int64)
    for q in range(nf):
        j = flips[q]
        h1, h2 = g[j, 0], g[j, 1]
        F1, I1, F2, I2 = h1 // 3, h1 % 3, h2 // 3, h2 % 3
        old[0, q], old[1, q] = 3 * F1 + (I1 + 2) % 3, 3 * F2 + (I2 + 1) % 3
        old[2, q], old[3, q] = 3 * F2 + (I2 + 2) % 3, 3 * F1 + (I1 + 1) % 3
        new[0, q], new[1, q], new[2, q], new[3, q] = 3 * F1, 3 * F1 + 1, 3 * F2, 3 * F2 + 1
    outer = np.empty((4, nf), np.int64)
    for r in range(4):
        for q in range(nf):
            outer[r, q] = twin[old[r, q]]
            slot_new[old[r, q]] = new[r, q]
    for q in range(nf):
        j = flips[q]
        F1, F2 = g[j, 6], g[j, 7]
        A, B, C, D = g[j, 2], g[j, 3], g[j, 4], g[j, 5]
        T[F1, 0], T[F1, 1], T[F1, 2] = C, A, D
        T[F2, 0], T[F2, 1], T[F2, 2] = D, B, C
        changed[F1] = True
        changed[F2] = True
        twin[3 * F1 + 2] = 3 * F2 + 2
        twin[3 * F2 + 2] = 3 * F1 + 2
    for r in range(4):
        for q in range(nf):
            o = outer[r, q]
            if o >= 0:
                ro = slot_new[o] if slot_new[o] >= 0 else o
                twin[new[r, q]] = ro
            else:
                twin[new[r, q]] = -1
    for r in range(4):
        for q in range(nf):
            o = outer[r, q]
            if o >= 0:
                ro = slot_new[o] if slot_new[o] >= 0 else o
                twin[ro] = new[r, q]
    # the made edges (True), then the removed ones (False): the last write of a key counts
    uk = np.empty(2 * nf, np.int64)
    uv = np.empty(2 * nf, np.bool_)
    for q in range(nf):
        j = flips[q]
        uk[q], uv[q] = ncd[j], True
        A, B = g[j, 2], g[j, 3]
        uk[nf + q], uv[nf + q] = min(A, B) * n + max(A, B), False
    by = np.argsort(uk, kind="mergesort")
    nk2 = ck_keys.size + 2 * nf
    mk = np.empty(nk2, np.int64)
    mv = np.empty(nk2, np.bool_)
    p, t = 0, 0
    for q in range(2 * nf):
        if q + 1 < 2 * nf and uk[by[q + 1]] == uk[by[q]]:
            continue                       # a later write of the same key follows
        key, val = uk[by[q]], uv[by[q]]
        while p < ck_keys.size and ck_keys[p] < key:
            mk[t], mv[t] = ck_keys[p], ck_vals[p]
            p += 1
            t += 1
        if p < ck_keys.size and ck_keys[p] == key:
            p += 1
        mk[t], mv[t] = key, val
        t += 1
    while p < ck_keys.size:
        mk[t], mv[t] = ck_keys[p], ck_vals[p]
        p += 1
        t += 1
    ck_keys, ck_vals = mk[:t], mv[:t]
    # next round: the edges of the changed faces and the unflipped candidates
    flipped = np.zeros(m, np.bool_)
    for q in range(nf):
        flipped[flips[q]] = True
    nxt = np.empty(ng + 6 * nf, np.int64)
    k = 0
    for q in range(ng):
        j = geo[q]
        if flipped[j]:
            continue
        h = g[j, 0]
        if used[h // 3]:
            continue
        nxt[k] = min(h, twin[h])
        k += 1
    for q in range(nf):
        j = flips[q]
        for f in (g[j, 6], g[j, 7]):
            for i in range(3):
                h = 3 * f + i
                if twin[h] >= 0:
                    nxt[k] = min(h, twin[h])
                    k += 1
    return 0, np.unique(nxt[:k]), ck_keys, ck_vals


@njit(cache=True, nogil=True)
def _pair_half_edges(T, n):
    """The half-edge pairing of :func:`shellrepair.fill.refine.relax_reference`
    (``key = min·n + max`` per half-edge ``3f+c``, its stable argsort, twins
    of neighbours in it), by a counting sort on the lower vertex and an
    insertion sort on the higher one within it (the same order).

    Returns the sorted keys, the twins (−1: none) and ``order[pair]``."""
    m = 3 * T.shape[0]
    lo = np.empty(m, np.int64)
    hi = np.empty(m, np.int64)
    for f in range(T.shape[0]):
        for c in range(3):
            a = T[f, c]
            b = T[f, (c + 1) % 3]
            lo[3 * f + c] = min(a, b)
            hi[3 * f + c] = max(a, b)
    start = np.zeros(n + 1, np.int64)
    for h in range(m):
        start[lo[h] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    order = np.empty(m, np.int64)
    fill = start[:n].copy()
    for h in range(m):          # stable: by id within a lower vertex
        order[fill[lo[h]]] = h
        fill[lo[h]] += 1
    for v in range(n):          # stable insertion sort by the higher vertex
        for i in range(start[v] + 1, start[v + 1]):
            h = order[i]
            j = i - 1
            while j >= start[v] and hi[order[j]] > hi[h]:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = h
    ks = np.empty(m, np.int64)
    for i in range(m):
        h = order[i]
        ks[i] = lo[h] * n + hi[h]
    twin = np.full(m, -1, np.int64)
    npair = 0
    for i in range(m - 1):
        if ks[i + 1] == ks[i]:
            npair += 1
    active = np.empty(npair, np.int64)
    k = 0
    for i in range(m - 1):      # in the order of NumPy's two fancy assignments
        if ks[i + 1] == ks[i]:
            twin[order[i]] = order[i + 1]
            active[k] = order[i]
            k += 1
    for i in range(m - 1):
        if ks[i + 1] == ks[i]:
            twin[order[i + 1]] = order[i]
    return ks, twin, active


def relax(P, T, is_loop, forb, max_rounds, dirty, angle, unfolded, flip_eps):
    """:func:`shellrepair.fill.refine.relax` with its bookkeeping compiled.

    The same rounds, choices and results; the opposite angles and the fold
    test stay NumPy's own (``angle``, ``unfolded``: refine's functions),
    so every decision sees the same numbers. ``angle`` None: both from
    :func:`relax_round_parts` (refine's compiled angle parts and fold
    test, one pass a round) and NumPy's arctan2.

    Returns
    -------
    T, changed, settled : as :func:`shellrepair.fill.refine.relax`; or None when two flips of a round
        share a face (a tie between equal excesses), for the caller to
        redo in NumPy.
    """
    n = len(P)
    nt = len(T)
    changed = np.zeros(nt, bool)
    if nt < 2:
        return T, changed, True
    T = np.array(T, np.int64)
    if angle is None:
        P = np.ascontiguousarray(P, np.float64)
    forb = np.sort(forb[:, 0] * n + forb[:, 1]) if len(forb) else np.zeros(0, np.int64)
    ks, twin, active = _pair_half_edges(T, n)
    if dirty is not None:
        active = active[dirty[active // 3] | dirty[twin[active] // 3]]
    ck_keys, ck_vals = np.zeros(0, np.int64), np.zeros(0, np.bool_)
    is_loop = np.ascontiguousarray(is_loop, np.bool_)
    settled = False
    for _ in range(max_rounds):
        if active.size == 0:
            settled = True
            break
        g = _relax_gather(T, twin, np.ascontiguousarray(active, np.int64), n)
        if angle is None:     # the compiled parts of both (refine's own numbers), NumPy's arctan2
            cr1, dt1, cr2, dt2, unf = _relax_round_parts(P, g)
            excess = np.arctan2(cr1, dt1) + np.arctan2(cr2, dt2) - np.pi
        else:
            pa, pb, pc, pd = P[g[:, 2]], P[g[:, 3]], P[g[:, 4]], P[g[:, 5]]
            excess = angle(pa - pc, pb - pc) + angle(pa - pd, pb - pd) - np.pi
            unf = np.ascontiguousarray(unfolded(pa, pb, pc, pd), np.bool_)
        status, active, ck_keys, ck_vals = _relax_apply(T, twin, changed, is_loop, forb, ks, ck_keys, ck_vals, g,
                                                        np.ascontiguousarray(excess), unf, float(flip_eps), n)
        if status == 2:
            return None
        if status == 1:
            settled = True
            break
    return T, changed, settled


@njit(cache=True, nogil=True)
def _angle_part(a0, a1, a2, b0, b1, b2, q0, q1, q2):
    """:func:`_angle_parts` of (a − q, b − q), one row: its operations."""
    u0, u1, u2 = a0 - q0, a1 - q1, a2 - q2
    v0, v1, v2 = b0 - q0, b1 - q1, b2 - q2
    c0 = u1 * v2 - u2 * v1
    c1 = u2 * v0 - u0 * v2
    c2 = u0 * v1 - u1 * v0
    # the dot product from 0.0, as np.sum's reduction starts: +0.0 where every product is −0.0
    return np.sqrt(c0 * c0 + c1 * c1 + c2 * c2), 0.0 + u0 * v0 + u1 * v1 + u2 * v2


@njit(cache=True, nogil=True)
def _relax_round_parts(P, g):
    m = g.shape[0]
    cr1, dt1 = np.empty(m), np.empty(m)
    cr2, dt2 = np.empty(m), np.empty(m)
    pa, pb = np.empty((m, 3)), np.empty((m, 3))
    pc, pd = np.empty((m, 3)), np.empty((m, 3))
    for r in range(m):
        for i in range(3):
            pa[r, i], pb[r, i] = P[g[r, 2], i], P[g[r, 3], i]
            pc[r, i], pd[r, i] = P[g[r, 4], i], P[g[r, 5], i]
        cr1[r], dt1[r] = _angle_part(pa[r, 0], pa[r, 1], pa[r, 2], pb[r, 0], pb[r, 1], pb[r, 2],
                                     pc[r, 0], pc[r, 1], pc[r, 2])
        cr2[r], dt2[r] = _angle_part(pa[r, 0], pa[r, 1], pa[r, 2], pb[r, 0], pb[r, 1], pb[r, 2],
                                     pd[r, 0], pd[r, 1], pd[r, 2])
    return cr1, dt1, cr2, dt2, _unfolded(pa, pb, pc, pd)


def relax_round_parts(P, g):
    """One relaxation round's numbers for the candidate edges of
    :func:`_relax_gather` (rows of ``g``: h1, h2, a, b, c, d, f1, f2):
    :func:`angle_parts` of the angles at c and at d facing edge a-b
    (``(a − c, b − c)``, ``(a − d, b − d)``) and :func:`unfolded` of the
    flip, in one pass with the same operations (the arctan2 stays NumPy's).

    Returns
    -------
    cr1, dt1, cr2, dt2 : (m,) float64
    unf : (m,) bool
    """
    return _relax_round_parts(np.ascontiguousarray(P, np.float64), np.ascontiguousarray(g, np.int64))


@njit(cache=True, nogil=True)
def _angle_parts(u, v):
    m = u.shape[0]
    cr = np.empty(m)
    dt = np.empty(m)
    for r in range(m):
        c0 = u[r, 1] * v[r, 2] - u[r, 2] * v[r, 1]
        c1 = u[r, 2] * v[r, 0] - u[r, 0] * v[r, 2]
        c2 = u[r, 0] * v[r, 1] - u[r, 1] * v[r, 0]
        cr[r] = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        dt[r] = 0.0 + u[r, 0] * v[r, 0] + u[r, 1] * v[r, 1] + u[r, 2] * v[r, 2]   # from 0.0, as np.sum
    return cr, dt


def angle_parts(u, v):
    """The two arguments of :func:`shellrepair.fill.refine.angle_between`'s arctan2:
    ``|u × v|`` and ``u · v`` per row, as its NumPy products and sums
    give them (the arctan2 stays NumPy's).

    Parameters
    ----------
    u, v : (m,3) float64

    Returns
    -------
    cr, dot : (m,) float64
    """
    return _angle_parts(np.ascontiguousarray(u, np.float64), np.ascontiguousarray(v, np.float64))


@njit(cache=True, nogil=True)
def _cross_row(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, nogil=True)
def _unfolded(pa, pb, pc, pd):
    m = pa.shape[0]
    out = np.empty(m, np.bool_)
    for r in range(m):
        a0, a1, a2 = pa[r, 0], pa[r, 1], pa[r, 2]
        b0, b1, b2 = pb[r, 0], pb[r, 1], pb[r, 2]
        c0, c1, c2 = pc[r, 0], pc[r, 1], pc[r, 2]
        d0, d1, d2 = pd[r, 0], pd[r, 1], pd[r, 2]
        x0, x1, x2 = _cross_row(b0 - a0, b1 - a1, b2 - a2, c0 - a0, c1 - a1, c2 - a2)
        y0, y1, y2 = _cross_row(a0 - b0, a1 - b1, a2 - b2, d0 - b0, d1 - b1, d2 - b2)
        n0, n1, n2 = x0 + y0, x1 + y1, x2 + y2
        m0, m1, m2 = _cross_row(a0 - c0, a1 - c1, a2 - c2, d0 - c0, d1 - c1, d2 - c2)
        k0, k1, k2 = _cross_row(b0 - d0, b1 - d1, b2 - d2, c0 - d0, c1 - d1, c2 - d2)
        out[r] = (m0 * n0 + m1 * n1 + m2 * n2 > 0) and (k0 * n0 + k1 * n1 + k2 * n2 > 0)
    return out


def unfolded(pa, pb, pc, pd):
    """:func:`shellrepair.fill.refine.unfolded` compiled: would flipping edge
    a-b of triangles (a,b,c), (b,a,d) to c-d keep both new triangles
    facing the way the old pair faced? The same products and sums.

    Parameters
    ----------
    pa, pb, pc, pd : (m,3) float64

    Returns
    -------
    ok : (m,) bool
    """
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    return _unfolded(c(pa), c(pb), c(pc), c(pd))


@njit(cache=True, nogil=True)
def _split_test(P, Tr, s, alpha):
    r = Tr.shape[0]
    C = np.empty((r, 3))
    sc = np.empty(r)
    split = np.empty(r, np.bool_)
    for i in range(r):
        a, b, c = Tr[i, 0], Tr[i, 1], Tr[i, 2]
        for k in range(3):
            C[i, k] = (P[a, k] + P[b, k] + P[c, k]) / 3.0
        sc[i] = (s[a] + s[b] + s[c]) / 3.0
        ok = True
        for v in (a, b, c):
            e0, e1, e2 = C[i, 0] - P[v, 0], C[i, 1] - P[v, 1], C[i, 2] - P[v, 2]
            d = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2) * alpha
            if not (d > sc[i] and d > s[v]):
                ok = False
        split[i] = ok
    return C, sc, split


def split_test(P, Tr, s, alpha):
    """The refinement's split test (:func:`shellrepair.fill.refine._refine`):
    each triangle's centroid ``C`` and mean scale ``sc``, and whether
    ``alpha`` times the centroid's distance to every corner exceeds both
    ``sc`` and the corner's scale; NumPy's means and norms, the same sums.

    Parameters
    ----------
    P : (n,3) float64
    Tr : (r,3) int64
    s : (n,) float64
    alpha : float

    Returns
    -------
    C : (r,3) float64, sc : (r,) float64, split : (r,) bool
    """
    return _split_test(np.ascontiguousarray(P, np.float64), np.ascontiguousarray(Tr, np.int64),
                       np.ascontiguousarray(s, np.float64), float(alpha))


def pair_half_edges(T, n):
    """The half-edge pairing :func:`relax` starts from (compiled ``_pair_half_edges``):
    ``key = min·n + max`` per half-edge ``3f+c`` (running ``T[f,c] -> T[f,(c+1)%3]``),
    as NumPy's stable argsort of the keys pairs them.

    Parameters
    ----------
    T : (t,3) int64
    n : int
        Vertex count (above every id in ``T``).

    Returns
    -------
    ks : (3t,) int64
        The sorted keys.
    twin : (3t,) int64
        Each half-edge's neighbour of equal key in the sorted order (−1: none).
    active : int64
        ``order[pair]``: the first half-edge of each pair, in key order.
    """
    return _pair_half_edges(np.ascontiguousarray(T, np.int64), n)
