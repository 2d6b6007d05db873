"""Compiled kernels of the intrinsic Delaunay triangulation (:mod:`shellrepair.fill.intrinsic`, Numba).

* :func:`intrinsic_flips`: intrinsic Delaunay edge flips in rounds, with
  the cotangents and areas of the result
  (:func:`shellrepair.fill.intrinsic.flip_to_delaunay`);
* :func:`laplacian_rows`: a Laplacian's CSR rows, the cotangent one of
  :func:`shellrepair.fill.intrinsic.intrinsic_laplacian` and the uniform one of
  :mod:`shellrepair.fill.fair` (whose kernels call these too).

Each gives what its NumPy version gives, to the bit (tests/test_kernels.py,
tests/test_intrinsic.py). How the kernels are compiled and switched off:
:mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["intrinsic_flips", "laplacian_rows"]

from shellrepair import compiled

njit = compiled.kernel


# --------------------------------------------------------------------------
# intrinsic Delaunay flips
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _cot_area(L, cot, A):
    """:func:`shellrepair.fill.intrinsic.cotangents` into ``cot``, ``A``."""
    for f in range(L.shape[0]):
        x, y, z = L[f, 0], L[f, 1], L[f, 2]
        # sides sorted a >= b >= c (the values, as np.sort gives them)
        if x < y:
            x, y = y, x
        if y < z:
            y, z = z, y
        if x < y:
            x, y = y, x
        a, b, c = x, y, z
        q = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c))
        area = 0.25 * np.sqrt(max(q, 0.0))
        A[f] = area
        den = 4.0 * max(area, 1e-300)
        for i in range(3):
            lb = L[f, (i + 1) % 3]
            lc = L[f, (i + 2) % 3]
            li = L[f, i]
            cot[f, i] = (lb * lb + lc * lc - li * li) / den


@njit(cache=True, nogil=True)
def _manifold_twins(T, n, twin, start, slot):
    """Twin half-edges of the edges with exactly two half-edges, else −1
    (:func:`shellrepair.fill.intrinsic.twins`): half-edges bucketed by their
    smaller vertex (a counting sort), then paired inside each bucket."""
    m3 = 3 * T.shape[0]
    start[:] = 0
    for f in range(T.shape[0]):
        for i in range(3):
            start[min(T[f, i], T[f, (i + 1) % 3]) + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    hi = np.empty(m3, np.int64)         # bucketed: the larger vertex of each half-edge
    for f in range(T.shape[0]):
        for i in range(3):
            a, b = T[f, i], T[f, (i + 1) % 3]
            v = min(a, b)
            slot[fill[v]] = 3 * f + i
            hi[fill[v]] = max(a, b)
            fill[v] += 1
    twin[:m3] = -1
    for v in range(n):
        s, e = start[v], start[v + 1]
        for p in range(s, e):
            w = hi[p]
            other = -1
            count = 0
            for q in range(s, e):
                if hi[q] == w:
                    count += 1
                    if q != p:
                        other = slot[q]
            if count == 2:
                twin[slot[p]] = other


@njit(cache=True, nogil=True)
def _flips(T, L, n, max_rounds, flip_tol):
    t = T.shape[0]
    twin = np.empty(3 * t, np.int64)
    start = np.empty(n + 1, np.int64)
    slot = np.empty(3 * t, np.int64)
    cot = np.empty((t, 3))
    A = np.empty(t)
    best = np.empty(t)
    taken = np.zeros(t, np.bool_)
    seen = np.zeros(t, np.bool_)
    second = np.zeros(t, np.bool_)
    cand = np.empty(3 * t, np.int64)
    exc = np.empty(3 * t)
    for _ in range(max_rounds):
        _manifold_twins(T, n, twin, start, slot)
        _cot_area(L, cot, A)
        # bad edges, each once (its smaller half-edge), in half-edge order
        nb = 0
        for h in range(3 * t):
            h2 = twin[h]
            if h2 <= h:
                continue
            f1, i1 = h // 3, h % 3
            f2, i2 = h2 // 3, h2 % 3
            s = cot[f1, i1] + cot[f2, i2]
            c, d = T[f1, (i1 + 2) % 3], T[f2, (i2 + 2) % 3]
            if s < -flip_tol and c != d and np.isfinite(s):
                cand[nb] = h
                exc[nb] = -s
                nb += 1
        if nb == 0:
            return True, cot, A
        # refine.independent_flips: each the worst edge of both its faces;
        # of ties the first keeps a face
        for j in range(nb):
            h = cand[j]
            best[h // 3] = -np.inf
            best[twin[h] // 3] = -np.inf
        for j in range(nb):
            h = cand[j]
            g1, g2 = h // 3, twin[h] // 3
            if exc[j] > best[g1]:
                best[g1] = exc[j]
            if exc[j] > best[g2]:
                best[g2] = exc[j]
        keep = np.zeros(nb, np.bool_)
        for j in range(nb):
            h = cand[j]
            g1, g2 = h // 3, twin[h] // 3
            if best[g1] == exc[j] and best[g2] == exc[j] and not seen[g1]:
                seen[g1] = True
                keep[j] = True
        for j in range(nb):
            if keep[j]:
                taken[cand[j] // 3] = True
        for j in range(nb):
            if keep[j]:
                g1, g2 = cand[j] // 3, twin[cand[j]] // 3
                if taken[g2] and g2 != g1:
                    keep[j] = False
        for j in range(nb):        # a second face kept by the first only
            if keep[j]:
                g2 = twin[cand[j]] // 3
                if second[g2]:
                    keep[j] = False
                else:
                    second[g2] = True
        k = 0
        for j in range(nb):
            h = cand[j]
            seen[h // 3] = False
            taken[h // 3] = False
            second[twin[h] // 3] = False
            if keep[j]:
                cand[k] = h
                k += 1
        # every new row from the old triangulation first, then the writes
        # (f1 rows, then f2 rows), as the vectorised assignment does
        rows = np.empty((k, 4, 3), np.int64)
        lens = np.empty((k, 2, 3))
        for j in range(k):
            h = cand[j]
            h2 = twin[h]
            F1, I1, F2, I2 = h // 3, h % 3, h2 // 3, h2 % 3
            a, b = T[F1, I1], T[F1, (I1 + 1) % 3]
            C, D = T[F1, (I1 + 2) % 3], T[F2, (I2 + 2) % 3]
            lab, lbc, lca = L[F1, I1], L[F1, (I1 + 1) % 3], L[F1, (I1 + 2) % 3]
            lad, ldb = L[F2, (I2 + 1) % 3], L[F2, (I2 + 2) % 3]
            # lay (a, b, c) and (b, a, d) flat: a at the origin, b on +x
            cx = (lab * lab + lca * lca - lbc * lbc) / (2.0 * lab)
            cy = np.sqrt(max(lca * lca - cx * cx, 0.0))
            dx = (lab * lab + lad * lad - ldb * ldb) / (2.0 * lab)
            dy = -np.sqrt(max(lad * lad - dx * dx, 0.0))
            lcd = np.hypot(cx - dx, cy - dy)
            rows[j, 0, 0], rows[j, 0, 1], rows[j, 0, 2] = C, a, D
            rows[j, 1, 0], rows[j, 1, 1], rows[j, 1, 2] = D, b, C
            rows[j, 2, 0], rows[j, 2, 1] = F1, F2
            lens[j, 0, 0], lens[j, 0, 1], lens[j, 0, 2] = lca, lad, lcd
            lens[j, 1, 0], lens[j, 1, 1], lens[j, 1, 2] = ldb, lbc, lcd
        for j in range(k):
            F1 = rows[j, 2, 0]
            for i in range(3):
                T[F1, i] = rows[j, 0, i]
                L[F1, i] = lens[j, 0, i]
        for j in range(k):
            F2 = rows[j, 2, 1]
            for i in range(3):
                T[F2, i] = rows[j, 1, i]
                L[F2, i] = lens[j, 1, i]
    return False, cot, A


def intrinsic_flips(T, L, n, max_rounds, flip_tol):
    """Intrinsic Delaunay flips in rounds (as :func:`shellrepair.fill.intrinsic.flip_to_delaunay`).

    Parameters
    ----------
    T : (m,3) int64
        Triangles; flipped in place.
    L : (m,3) float64
        ``L[f,i]``: length of side ``T[f,i] -> T[f,(i+1)%3]``; updated in place.
    n : int
        Vertex count.
    max_rounds : int
    flip_tol : float
        An edge flips when its opposite cotangents sum below ``-flip_tol``.

    Returns
    -------
    settled : bool
    cot : (m,3) float64, A : (m,) float64
        Cotangents and areas of the final triangulation (meaningful when settled).
    """
    return _flips(T, L, int(n), int(max_rounds), float(flip_tol))


# --------------------------------------------------------------------------
# Laplacian rows: the cotangent one here, the uniform one for the fairing
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _laplacian_rows(T, W, n, binary):
    """K = D − A as CSR rows (diagonal included, unsorted columns).

    ``binary``: A is the 0/1 adjacency of the edges of ``T`` (the uniform
    Laplacian of :func:`shellrepair.fill.fair.uniform_laplacian`); else
    ``A_ij`` sums ``W[f,s]`` over the sides s of T joining i and j (the
    cotangent Laplacian of :func:`shellrepair.fill.intrinsic.intrinsic_laplacian`
    with W = ½ cot)."""
    m = T.shape[0]
    cnt = np.ones(n + 1, np.int64)      # the diagonal, plus two entries a side
    cnt[n] = 0
    for f in range(m):
        for s in range(3):
            cnt[T[f, s]] += 1
            cnt[T[f, (s + 1) % 3]] += 1
    ptr = np.zeros(n + 1, np.int64)
    for v in range(n):
        ptr[v + 1] = ptr[v] + cnt[v]
    col = np.empty(ptr[n], np.int64)
    val = np.zeros(ptr[n])
    fill = ptr[:-1].copy()
    where = np.full(n, -1, np.int64)    # column -> slot in the row being built
    # rows built one vertex at a time from its half-edges: bucket them first
    hs = np.zeros(n + 1, np.int64)
    for f in range(m):
        for s in range(3):
            hs[T[f, s] + 1] += 1
            hs[T[f, (s + 1) % 3] + 1] += 1
    for v in range(n):
        hs[v + 1] += hs[v]
    hf = hs[:-1].copy()
    other = np.empty(hs[n], np.int64)
    wt = np.empty(hs[n])
    for f in range(m):
        for s in range(3):
            a, b = T[f, s], T[f, (s + 1) % 3]
            w = 1.0 if binary else W[f, s]
            other[hf[a]] = b
            wt[hf[a]] = w
            hf[a] += 1
            other[hf[b]] = a
            wt[hf[b]] = w
            hf[b] += 1
    for v in range(n):
        d = fill[v]
        col[d] = v
        fill[v] += 1
        diag = 0.0
        for p in range(hs[v], hs[v + 1]):
            j = other[p]
            if j == v:
                continue
            q = where[j]
            if q < 0:
                q = fill[v]
                fill[v] += 1
                col[q] = j
                where[j] = q
                val[q] = -wt[p] if not binary else -1.0
            elif not binary:
                val[q] -= wt[p]
        for q in range(d + 1, fill[v]):
            diag -= val[q]
            where[col[q]] = -1
        val[d] = diag
        ptr_end = fill[v]
        for q in range(ptr_end, ptr[v + 1]):
            col[q] = v                  # unused slots: zeros on the diagonal
            val[q] = 0.0
    return ptr, col, val


def laplacian_rows(T, W, n, binary):
    """A Laplacian K = D − A as CSR rows (the compiled ``_laplacian_rows``).

    Parameters
    ----------
    T : (m,3) int64, C-contiguous
        Triangles.
    W : (m,3) float64
        ``W[f,s]``: the weight of side s of triangle f (read unless ``binary``).
    n : int
        Vertex count.
    binary : bool
        A is the 0/1 adjacency of the edges of ``T`` (the uniform Laplacian
        of :func:`shellrepair.fill.fair.uniform_laplacian`); else ``A_ij`` sums
        ``W`` over the sides joining i and j (the cotangent Laplacian of
        :func:`shellrepair.fill.intrinsic.intrinsic_laplacian` with W = ½ cot).

    Returns
    -------
    ptr : (n+1,) int64
    col : int64
        Each row's columns, its diagonal first, unsorted; each row ends with
        spare slots (a zero on the diagonal) where sides repeat.
    val : float64
    """
    return _laplacian_rows(T, W, n, binary)
