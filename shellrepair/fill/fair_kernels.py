"""Compiled kernels of the fairing (:mod:`shellrepair.fill.fair`, Numba).

* :func:`fair_small`: a small patch's whole fairing
  (:func:`shellrepair.fill.fair.fair_patch`), the solves dense: equal to
  round-off, not to the bit (the one kernel with a tolerance, stated there);
* :func:`energy_blocks`: the unknown and fixed blocks of a large patch's
  fairing energy (:func:`shellrepair.fill.fair._energy` and its slices), equal
  to round-off (the sums in another order; tests/test_fair.py).

The Laplacian rows and intrinsic flips they call are
:mod:`shellrepair.fill.intrinsic_kernels`'; the sparse factorisation of large
patches is :mod:`shellrepair.fill.cholesky`. How the kernels are compiled and
switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fair_small", "energy_blocks", "cholesky_solve", "fair_round", "drop_spare_diagonal"]

from shellrepair import compiled
from shellrepair.fill.intrinsic_kernels import _cot_area, _flips, _laplacian_rows

njit = compiled.kernel


# --------------------------------------------------------------------------
# fairing of a small patch (dense normal equations)
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _matvec(ptr, col, val, x):
    y = np.zeros_like(x)
    for v in range(ptr.size - 1):
        for q in range(ptr[v], ptr[v + 1]):
            for c in range(x.shape[1]):
                y[v, c] += val[q] * x[col[q], c]
    return y


@njit(cache=True, nogil=True)
def _cholesky_solve(Q, B):
    """Solve Q x = B (Q symmetric positive definite) by Cholesky; ok False
    when a pivot is not positive.

    The factor's entries are those of the textbook row-by-row Cholesky
    (``L[i, j] = (Q[i, j] − Σ_k L[i, k] L[j, k]) / L[j, j]``, the sum taken
    for k = 0, 1, ... in turn; tests/test_kernels.py holds a Python
    version to the bit), computed a column at a time: column j of L, kept
    as row j of ``Lt``, is Q's row j less each earlier column k scaled by
    L[j, k], k ascending. Every entry sees the same operations in the same
    order, but the inner loop runs over independent entries, which the
    compiler vectorises (the row-by-row form's inner loop is one chain of
    dependent subtractions): ~2-3x faster at 150-400 unknowns. The forward
    substitution likewise subtracts column by column (each entry's terms in
    the same order), the backward one row by row.
    """
    n = Q.shape[0]
    Lt = np.zeros((n, n))     # Lt[k, i] = L[i, k]
    s = np.empty(n)
    for j in range(n):
        m = n - j
        sj = s[j:]            # (loops from 0 over views: the compiler then vectorises them)
        for i in range(m):
            sj[i] = Q[j + i, j]
        for k in range(j):
            row = Lt[k, j:]
            c = row[0]
            for i in range(m):
                sj[i] = sj[i] - row[i] * c
        if not sj[0] > 0.0:
            return B, False
        d = np.sqrt(sj[0])
        out = Lt[j, j:]
        out[0] = d
        for i in range(1, m):
            out[i] = sj[i] / d
    X = B.copy()
    x = np.empty(n)
    for c in range(B.shape[1]):
        for i in range(n):
            x[i] = B[i, c]
        for k in range(n):    # forward: x[i] −= L[i, k] x[k], k ascending, then / L[i, i]
            xk = x[k] / Lt[k, k]
            x[k] = xk
            row = Lt[k, k + 1:]
            xr = x[k + 1:]
            for i in range(n - k - 1):
                xr[i] = xr[i] - row[i] * xk
        for i in range(n - 1, -1, -1):
            t = x[i]
            row = Lt[i]
            for k in range(i + 1, n):
                t -= row[k] * x[k]
            x[i] = t / row[i]
        for i in range(n):
            X[i, c] = x[i]
    return X, True


@njit(cache=True, nogil=True)
def _fair_round(ptr, col, val, D, order, X, fixed, unk_pos, unk):
    """Minimise xᵀQx, Q = K (D K)^(order−1), over the unknown rows of X."""
    n = X.shape[0]
    nu = unk.size
    Xf = X.copy()
    for i in range(nu):
        Xf[unk[i]] = 0.0
    y = _matvec(ptr, col, val, Xf)
    for _ in range(order - 1):
        for v in range(n):
            y[v] *= D[v]
        y = _matvec(ptr, col, val, y)
    B = np.empty((nu, 3))
    for i in range(nu):
        B[i] = -y[unk[i]]
    # Q restricted to the unknowns: G = K[:, u] (n x nu), then (order − 1)
    # times G <- K D G, and Quu = K[u, :] D G (order 1: Quu = G[u])
    G = np.zeros((n, nu))
    for v in range(n):
        for q in range(ptr[v], ptr[v + 1]):
            p = unk_pos[col[q]]
            if p >= 0:
                G[v, p] += val[q]
    for _ in range(order - 2):
        H = np.zeros((n, nu))
        for v in range(n):
            for q in range(ptr[v], ptr[v + 1]):
                w = val[q] * D[col[q]]
                j = col[q]
                for p in range(nu):
                    H[v, p] += w * G[j, p]
        G = H
    Q = np.zeros((nu, nu))
    if order == 1:
        for i in range(nu):
            Q[i] = G[unk[i]]
    else:
        for v in range(n):
            for q in range(ptr[v], ptr[v + 1]):
                j = col[q]                    # K[v, j] = K[j, v]: row j of K[u, :]
                p = unk_pos[j]
                if p >= 0:
                    w = val[q] * D[v]
                    for r in range(nu):
                        Q[p, r] += w * G[v, r]
    for i in range(nu):                       # symmetric in exact arithmetic
        for j in range(i):
            a = 0.5 * (Q[i, j] + Q[j, i])
            Q[i, j] = a
            Q[j, i] = a
    return _cholesky_solve(Q, B)


@njit(cache=True, nogil=True)
def _fair_small(X, F, fixed, order, rounds, degenerate_area, flip_tol, flip_rounds, uniform_max_order):
    n = X.shape[0]
    m = F.shape[0]
    unk_pos = np.full(n, -1, np.int64)
    nu = 0
    for v in range(n):
        if not fixed[v]:
            unk_pos[v] = nu
            nu += 1
    unk = np.empty(nu, np.int64)
    for v in range(n):
        if unk_pos[v] >= 0:
            unk[unk_pos[v]] = v
    X = X.copy()
    ones = np.ones(n)
    ptr, col, val = _laplacian_rows(F, np.zeros((0, 3)), n, True)
    # the solves read K without its spare zero slots (_drop_spare_diagonal:
    # each added a zero product, so no sum changes; half the entries)
    pc, cc, vc = _drop_spare_diagonal(ptr, col, val)
    Xu, ok = _fair_round(pc, cc, vc, ones, min(order, uniform_max_order), X, fixed, unk_pos, unk)
    if not ok:
        return X, False, ptr, col, val
    for i in range(nu):
        X[unk[i]] = Xu[i]
    for _ in range(rounds):
        finite = True
        amin = np.inf
        for v in range(n):
            for c in range(3):
                if not np.isfinite(X[v, c]):
                    finite = False
        for f in range(m):
            a, b, c = F[f, 0], F[f, 1], F[f, 2]
            ux, uy, uz = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
            vx, vy, vz = X[c, 0] - X[a, 0], X[c, 1] - X[a, 1], X[c, 2] - X[a, 2]
            cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            ar = 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)
            if ar < amin:
                amin = ar
        if not finite or not amin > degenerate_area:
            break
        T = F.copy()
        L = np.empty((m, 3))
        for f in range(m):
            for s in range(3):
                a, b = T[f, s], T[f, (s + 1) % 3]
                dx, dy, dz = X[b, 0] - X[a, 0], X[b, 1] - X[a, 1], X[b, 2] - X[a, 2]
                L[f, s] = np.sqrt(dx * dx + dy * dy + dz * dz)
        settled, cot, A = _flips(T, L, n, flip_rounds, flip_tol)
        if not settled:
            _cot_area(L, cot, A)
        W = 0.5 * cot
        M = np.zeros(n)
        for f in range(m):
            for s in range(3):
                M[T[f, s]] += A[f] / 3.0
        ptr2, col2, val2 = _laplacian_rows(T, W, n, False)
        if not (np.isfinite(val2).all() and np.isfinite(M).all()):
            break
        floor = degenerate_area + 1e-3 * np.median(M)
        D = 1.0 / np.maximum(M, floor)
        pc, cc, vc = _drop_spare_diagonal(ptr2, col2, val2)
        Xn, ok = _fair_round(pc, cc, vc, D, order, X, fixed, unk_pos, unk)
        if not ok or not np.isfinite(Xn).all():
            break
        for i in range(nu):
            X[unk[i]] = Xn[i]
        ptr, col, val = ptr2, col2, val2
    return X, True, ptr, col, val


def fair_small(X, F, fixed, order, rounds, degenerate_area, flip_tol, flip_rounds, uniform_max_order=2):
    """:func:`shellrepair.fill.fair.fair_patch` for a small patch, compiled.

    The same rounds (a uniform-weight solve of order min(order,
    ``uniform_max_order``), then cotangent rounds on the
    intrinsic Delaunay triangulation, the same stopping tests), with the
    normal equations of the unknowns assembled dense and solved by a
    Cholesky factorisation instead of libigl's sparse one: equal to
    ``fair_patch`` to round-off (tests/test_kernels.py bounds the
    difference), for patches of up to a few hundred unknowns.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    fixed : (n,) bool
        Rows held (the scan's, and pinned new vertices).
    order : {1, 2, 3}
    rounds : int
    degenerate_area, flip_tol : float
    flip_rounds : int
        As in :mod:`shellrepair.fill.fair` and :mod:`shellrepair.fill.intrinsic`.
    uniform_max_order : int
        ``fair.UNIFORM_MAX_ORDER``.

    Returns
    -------
    X2 : (n,3) float64
    ok : bool
        False when the first solve's matrix is not positive definite
        (then use the sparse path).
    ptr, col, val : CSR arrays
        The order-1 operator of the last round used (``fair_patch``'s K;
        unused slots hold zeros on the diagonal).
    """
    return _fair_small(np.ascontiguousarray(X, np.float64), np.ascontiguousarray(F, np.int64),
                       np.ascontiguousarray(fixed, np.bool_), int(order), int(rounds), float(degenerate_area),
                       float(flip_tol), int(flip_rounds), int(uniform_max_order))


# --------------------------------------------------------------------------
# fairing of large patches: the energy's blocks, assembled directly
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _times_dk(ptr, col, val, D, acc, lst, cnt, acc2, mark2, lst2):
    """Sparse row r (``acc`` at columns ``lst[:cnt]``) times D K, K
    symmetric, into ``acc2`` / ``lst2`` (``acc2`` zero and ``mark2`` clear
    on entry); returns the new column count."""
    cnt2 = 0
    for t in range(cnt):
        w = lst[t]
        sw = acc[w] * D[w]
        for q in range(ptr[w], ptr[w + 1]):
            j = col[q]
            lst2[cnt2] = j            # listed once: the count moves on only for a new column
            cnt2 += 1 - np.int64(mark2[j])
            mark2[j] = 1
            acc2[j] += sw * val[q]
    return cnt2


@njit(cache=True, nogil=True)
def _energy_rows(ptr, col, val, D, order, unk, pos, is_fixed):
    """Rows ``unk`` of Q = K (D K)^(order−1), split by column into the
    unknowns' block (columns ``pos`` of unknowns) and the fixed block
    (columns ``pos`` of fixed vertices); each row's columns sorted.

    Row by row (Gustavson): the row of K, then (order − 1) times r ← (r D) K,
    in scattered accumulators, one per level, that hold zeros between rows
    (each row clears the entries it used): an entry's sum starts from 0.0
    and adds its terms in the order the row's expansion meets them. A row's
    columns are listed without branches (marks) and sorted by rank (each
    column's count of smaller ones; the columns are distinct; a row of more
    than 64 by a sort): ~1.3x the
    speed of first-touch stamps and an insertion sort, the same arrays."""
    n = ptr.size - 1
    nu = unk.size
    acc1, acc2, acc3 = np.zeros(n), np.zeros(n), np.zeros(n)
    # marks of one byte and column lists of four (a fairing submesh has far
    # fewer than 2^31 vertices): with the three accumulators they stay
    # within a core's L2 on a ~13k-vertex submesh (order 3, 11,847
    # unknowns: 27 -> 24 ms)
    m1, m2, m3 = np.zeros(n, np.uint8), np.zeros(n, np.uint8), np.zeros(n, np.uint8)
    l1, l2, l3 = np.empty(n + 1, np.int32), np.empty(n + 1, np.int32), np.empty(n + 1, np.int32)
    srt = np.empty(n, np.int64)
    # a row of Q reads ``order`` rings: 7, 19, 37 columns around a vertex of
    # valence six (1 + 3 order (order + 1)); room for a few more, so that an
    # order-3 system is not copied to larger arrays twice on the way
    cap_u = max((4 + 3 * order * (order + 1)) * nu, 16)
    cap_f = max(4 * nu, 16)
    u_ptr = np.zeros(nu + 1, np.int64)
    u_col = np.empty(cap_u, np.int64)
    u_val = np.empty(cap_u)
    f_ptr = np.zeros(nu + 1, np.int64)
    f_col = np.empty(cap_f, np.int64)
    f_val = np.empty(cap_f)
    nuu = 0
    nuf = 0
    for i in range(nu):
        v = unk[i]
        cnt1 = 0
        for q in range(ptr[v], ptr[v + 1]):           # level 1: row v of K
            j = col[q]
            l1[cnt1] = j
            cnt1 += 1 - np.int64(m1[j])
            m1[j] = 1
            acc1[j] += val[q]
        cnt, cnt2 = cnt1, 0
        acc, lst = acc1, l1
        if order >= 2:
            cnt2 = _times_dk(ptr, col, val, D, acc1, l1, cnt1, acc2, m2, l2)
            cnt, acc, lst = cnt2, acc2, l2
        if order >= 3:
            cnt = _times_dk(ptr, col, val, D, acc2, l2, cnt2, acc3, m3, l3)
            acc, lst = acc3, l3
        if cnt <= 64:
            for t in range(cnt):                       # the columns sorted, by rank
                j = lst[t]
                r = 0
                for u in range(cnt):
                    r += lst[u] < j
                srt[r] = j
        else:                                          # (a long row: rank sorting grows as its square)
            srt[:cnt] = np.sort(lst[:cnt])
        if nuu + cnt > cap_u:
            cap_u = 2 * (nuu + cnt)
            u_col = np.concatenate((u_col[:nuu], np.empty(cap_u - nuu, np.int64)))
            u_val = np.concatenate((u_val[:nuu], np.empty(cap_u - nuu)))
        if nuf + cnt > cap_f:
            cap_f = 2 * (nuf + cnt)
            f_col = np.concatenate((f_col[:nuf], np.empty(cap_f - nuf, np.int64)))
            f_val = np.concatenate((f_val[:nuf], np.empty(cap_f - nuf)))
        for t in range(cnt):
            j = srt[t]
            if is_fixed[j]:
                f_col[nuf] = pos[j]
                f_val[nuf] = acc[j]
                nuf += 1
            else:
                u_col[nuu] = pos[j]
                u_val[nuu] = acc[j]
                nuu += 1
        u_ptr[i + 1] = nuu
        f_ptr[i + 1] = nuf
        for t in range(cnt1):                          # clear what the row used
            j = l1[t]
            acc1[j] = 0.0
            m1[j] = 0
        if order >= 2:
            for t in range(cnt2):
                j = l2[t]
                acc2[j] = 0.0
                m2[j] = 0
        if order >= 3:
            for t in range(cnt):
                j = l3[t]
                acc3[j] = 0.0
                m3[j] = 0
    return u_ptr, u_col[:nuu].copy(), u_val[:nuu].copy(), f_ptr, f_col[:nuf].copy(), f_val[:nuf].copy()


@njit(cache=True, nogil=True)
def _symmetrise(ptr, col, val):
    """Q ← (Q + Qᵀ) / 2 in place, for sorted rows of a structurally
    symmetric matrix: both entries get the same value, to the bit.

    Row i's entries (i, j), j > i, meet their mirrors (j, i) in row j in
    increasing i, so each row j keeps a cursor that only moves forward to
    the first column not below i: one pass over the entries (a binary
    search per entry found the same slot)."""
    n = ptr.size - 1
    cur = ptr[:-1].copy()
    for i in range(n):
        for q in range(ptr[i], ptr[i + 1]):
            j = col[q]
            if j <= i:
                continue
            c = cur[j]
            end = ptr[j + 1]
            while c < end and col[c] < i:
                c += 1
            cur[j] = c
            if c < end and col[c] == i:
                m = 0.5 * (val[q] + val[c])
                val[q] = m
                val[c] = m
    return val


@njit(cache=True, nogil=True)
def _drop_spare_diagonal(ptr, col, val):
    """The rows without the spare zero slots :func:`shellrepair.fill.intrinsic_kernels.laplacian_rows` leaves
    on the diagonal (a zero entry of column i in row i after the row's
    first): about half of a cotangent Laplacian's entries, each adding a
    zero product in :func:`_energy_rows` (so dropping them changes no sum)."""
    n = ptr.size - 1
    keep = np.zeros(ptr[n], np.bool_)
    p2 = np.zeros(n + 1, np.int64)
    for i in range(n):
        seen = False
        for q in range(ptr[i], ptr[i + 1]):
            if col[q] == i:
                if seen and val[q] == 0.0:
                    continue
                seen = True
            keep[q] = True
            p2[i + 1] += 1
    for i in range(n):
        p2[i + 1] += p2[i]
    c2 = np.empty(p2[n], np.int64)
    v2 = np.empty(p2[n])
    t = 0
    for q in range(ptr[n]):
        if keep[q]:
            c2[t] = col[q]
            v2[t] = val[q]
            t += 1
    return p2, c2, v2


def energy_blocks(ptr, col, val, D, order, unknown, fixed):
    """The blocks of the fairing energy Q = K (D K)^(order−1) that a solve
    with the rows ``fixed`` given needs, assembled in one pass per row
    (:func:`shellrepair.fill.fair._energy` and slicing, without the sparse
    products, sorts and transposes; equal to round-off, the sums taken in
    another order).

    Parameters
    ----------
    ptr, col, val : CSR (or CSC) arrays of K (n,n), symmetric
    D : (n,) float64
        The diagonal between the factors (M⁻¹; ones for unit masses).
    order : {1, 2, 3}
    unknown, fixed : int64 arrays partitioning range(n)

    Returns
    -------
    uu : (ptr, col, val)
        Q[unknown][:, unknown], rows sorted, symmetric to the bit (the same
        arrays are its CSC).
    uf : (ptr, col, val)
        Q[unknown][:, fixed] as CSR.
    """
    unknown = np.ascontiguousarray(unknown, np.int64)
    fixed = np.ascontiguousarray(fixed, np.int64)
    n = ptr.size - 1
    pos = np.empty(n, np.int64)
    pos[unknown] = np.arange(unknown.size)
    pos[fixed] = np.arange(fixed.size)
    is_fixed = np.zeros(n, np.bool_)
    is_fixed[fixed] = True
    ptr, col, val = _drop_spare_diagonal(np.ascontiguousarray(ptr, np.int64), np.ascontiguousarray(col, np.int64),
                                         np.ascontiguousarray(val, np.float64))
    up, uc, uv, fp, fc, fv = _energy_rows(ptr, col, val, np.ascontiguousarray(D, np.float64), int(order), unknown, pos,
                                          is_fixed)
    uv = _symmetrise(up, uc, uv)
    return (up, uc, uv), (fp, fc, fv)


def cholesky_solve(Q, B):
    """Solve Q x = B by the dense Cholesky of :func:`fair_small`'s solves
    (compiled ``_cholesky_solve``: the factor of the textbook row-by-row
    Cholesky, each sum taken k = 0, 1, ... in turn).

    Parameters
    ----------
    Q : (n,n) float64
        Symmetric positive definite.
    B : (n,c) float64

    Returns
    -------
    X : (n,c) float64
    ok : bool
        False when a pivot was not positive (Q is not positive definite).
    """
    return _cholesky_solve(np.ascontiguousarray(Q, np.float64), np.ascontiguousarray(B, np.float64))


def fair_round(ptr, col, val, D, order, X, fixed, unk_pos, unk):
    """One round of :func:`fair_small` (compiled ``_fair_round``): minimise
    xᵀQx, Q = K (D K)^(order−1), over the unknown rows of X.

    Parameters
    ----------
    ptr, col, val : int64, int64, float64
        K as CSR rows (:func:`shellrepair.fill.intrinsic_kernels.laplacian_rows`,
        with or without its spare diagonal slots: :func:`drop_spare_diagonal`).
    D : (n,) float64
        The inverse masses (ones for the uniform Laplacian).
    order : int
    X : (n,3) float64
        The positions; the fixed rows are kept.
    fixed : (n,) bool
    unk_pos : (n,) int64
        Each vertex's row among the unknowns, −1 for a fixed one.
    unk : (u,) int64
        The unknown vertices.

    Returns
    -------
    Xu : (u,3) float64
        The unknowns' positions.
    ok : bool
        False when the solve's Cholesky failed.
    """
    return _fair_round(ptr, col, val, D, order, X, fixed, unk_pos, unk)


def drop_spare_diagonal(ptr, col, val):
    """K's CSR rows without the spare zero slots
    :func:`shellrepair.fill.intrinsic_kernels.laplacian_rows` leaves on the
    diagonal (compiled ``_drop_spare_diagonal``; dropping them changes no sum).

    Parameters
    ----------
    ptr, col, val : int64, int64, float64

    Returns
    -------
    ptr, col, val : int64, int64, float64
        The same rows, each without its spare slots.
    """
    return _drop_spare_diagonal(ptr, col, val)
