"""Sparse Cholesky factorisation of the fairing systems: nested dissection, multifrontal.

A hole's fairing solves Q_uu x = b with Q_uu symmetric positive definite
and the sparsity of a surface patch's k-ring stencil
(:mod:`shellrepair.fill.fair`). libigl's simplicial LLᵀ (Eigen's, with an AMD
ordering) does that a column at a time: on the order-3 system of a
12k-unknown patch (442k non-zeros) it took ~0.5 s, on the 350-unknown
holes of a bumpy sphere ~1 ms for 0.3 million multiply-adds. This module
does the same factorisation in dense blocks:

1. **Ordering** (:func:`nd_order`): nested dissection by breadth-first
   levels. From a pseudo-peripheral vertex of the matrix graph, any level
   is a separator: no edge joins the levels before it to the levels after
   it. Of the levels that leave at least ``BALANCE`` of the part on either
   side, the one with the fewest vertices touching the next level is taken
   (the median vertex's level if none does); its vertices that touch no
   later level go to the first half, the rest are the separator, numbered
   after both halves, which are dissected in turn; a part of at most
   ``LEAF`` vertices is not split. On a surface patch the levels are rings of the stencil's
   width around a far vertex, so a separator is a band across the patch,
   its length the patch's width: the orderings a mesh's geometry would give,
   read from the matrix alone.
2. **Symbolic** (:func:`_symbolic`): each node of the dissection tree (a
   separator or a leaf) is one dense front: its own vertices S and the
   later vertices B its subtree's columns reach (the rows of L below S).
3. **Numeric** (:func:`_numeric`, multifrontal): in post-order, a node's
   front gathers its columns of Q and its children's update matrices,
   factors the S block (:func:`_chol`), solves for the B rows
   (:func:`_forward_rows`), and hands the Schur complement
   F_BB − L_BS L_BSᵀ to its parent (:func:`_schur_lower`). The work is
   dense products, not sparse column updates.
4. **Solve** (:func:`_solve`): forward then backward substitution front
   by front.

The dense products are our own loops, not BLAS: every sum runs in one
fixed order, so a repair writes the same bytes on every processor.
OpenBLAS picks its kernels by processor, and they round differently: one
machine's repairs of eval's cases with OpenBLAS's SkylakeX, Haswell and
Prescott kernels (``OPENBLAS_CORETYPE``) wrote three different files
where the products and the S blocks' Cholesky (LAPACK's potrf) were
OpenBLAS's (24 of 32 stress cases; vertices apart by up to 5e-10), and
the same file once they were these loops (eval/results/cpu-independence/).
They cost a little on large fronts: the products sum four rows at a
time along contiguous rows (a front's update 0.6 ms against BLAS's 0.4
at 150 x 300, 2.2 against 1.3 at 300 x 400, where it sums the lower
triangle alone); a 28,877-unknown order-3 system's factorisation 1.91 s
against 1.44. Against the libraries below, again at that change
(``solvers-0ee7a91.md``, CHOLMOD not installed): ours 0.458 s over 188
systems, libigl 0.673, SuperLU 1.913; the 11k-unknown system 108 ms,
libigl 206.

Why our own and not the library the field uses, measured by
``eval/bench_solvers.py`` (``make bench-solvers``; its tables in
eval/results/solvers/) on the 167 systems the fill factorised on four
scans (a bumpy sphere with 4 discs, a 7-subdivision sphere's order-3
disc, the dragon range scan, the decimated bunny), factor and solve of
three right-hand sides, one warm process, BLAS on one thread:

=========  ========  ================  ===================  ===============
solver     total s   s on ≥1000 unk.   geomean time / ours  load + 1 solve
=========  ========  ================  ===================  ===============
ours       0.760     0.447             1.00                 0.101 s
CHOLMOD    1.443     0.916             1.18                 0.007 s
libigl     1.344     0.875             1.38                 0.008 s
SuperLU    3.445     2.301             2.86                 0.003 s
=========  ========  ================  ===================  ===============

(CHOLMOD: scikit-sparse 0.4.15 on Debian's SuiteSparse 5.12, supernodal;
libigl: Eigen's simplicial LLᵀ; SuperLU: SciPy's ``splu``.) On the
largest system (11k unknowns, 410k non-zeros) ours took 185 ms, CHOLMOD
556, libigl 466. Per fresh run the balance is the load column: ours pays
0.10 s to load its Numba kernels the first time a run factorises (with
the fill's other kernels already loaded), so on scans whose systems are
all small (the dragon: 0.18 s in ours against 0.15 in CHOLMOD) CHOLMOD
would be 0.1 s ahead, on the two spheres ours is (0.38 against 0.49 and
0.79 s). We keep ours: it is 1.9x faster where the time goes, and
CHOLMOD would add a C library and a source build to the install
(scikit-sparse has no wheel, and its 0.5 release does not build against
Debian 12's SuiteSparse). Holes of at most ``SMALL_UNKNOWNS`` unknowns
(:mod:`shellrepair.fill.fair`) never load this module. The load cost is what
the ahead-of-time build of these kernels (:mod:`shellrepair.compiled`,
``make setup``) removes: measured with Numba's JIT, it is now milliseconds.

The result agrees with libigl's to round-off, not to the bit (another
ordering sums in another order): ``tests/test_cholesky.py`` checks the
solution of random and degenerate SPD systems against SciPy's LU to a
relative residual of 1e-10, and :class:`shellrepair.fill.fair.Factor` keeps
libigl's factorisation as the path without Numba (and as the fallback
where a front is not positive definite: :class:`NotPositiveDefinite`).
"""

from __future__ import annotations

import threading

import numpy as np


__all__ = ["Factor", "NotPositiveDefinite", "factor", "nd_order", "LEAF", "warm_up"]

#: Parts of the dissection with at most this many vertices are not split
#: (one dense front: below it a split saves less than the fronts' overhead).
#: A speed setting only (any value gives the same solutions to round-off):
#: over the 40 systems of a bumpy_sphere-discs-medium repair 16: 103 ms,
#: 24: 93, 32: 92, 48: 87, 64: 86; over the 14 of the 1.3M two-disc case
#: 16: 559 ms, 32: 384, 48: 376, 64: 436.
LEAF = 48
#: A separating level leaves at least this share of its part on either side
#: (a speed setting: against always the median vertex's level, the 1.3M
#: two-disc case's three largest systems took 14-18 % fewer multiply-adds).
BALANCE = 0.3
#: Rows of the blocked triangular solves (one :func:`_sub_product` per block).
BLOCK = 64

from shellrepair import compiled

# The kernels run where :data:`shellrepair.compiled.ENABLED` is set (compiled
# ahead of time, or by Numba's JIT); where not, fair.py uses libigl's
# factorisation instead.
njit = compiled.kernel

_WARM = False
_WARM_LOCK = threading.Lock()


class NotPositiveDefinite(ValueError):
    """A front's pivot block is not positive definite (to working precision)."""


# --------------------------------------------------------------------------
# ordering
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _children(parent):
    """Each node's children in increasing id: those of node i are
    kids[first[i]:first[i+1]]."""
    k = parent.size
    first = np.zeros(k + 1, np.int64)
    for i in range(k):
        if parent[i] >= 0:
            first[parent[i] + 1] += 1
    for i in range(k):
        first[i + 1] += first[i]
    kids = np.empty(max(first[k], 1), np.int64)
    fill = first[:k].copy()
    for i in range(k):
        p = parent[i]
        if p >= 0:
            kids[fill[p]] = i
            fill[p] += 1
    return first, kids


@njit(cache=True, nogil=True)
def _bfs(start, ptr, idx, inset, stamp, level, queue):
    """Levels from ``start`` over the vertices with ``inset == stamp``;
    returns (vertices reached, in queue[:count], the last level)."""
    head = 0
    tail = 1
    queue[0] = start
    level[start] = 0
    inset[start] = -stamp          # visited
    while head < tail:
        v = queue[head]
        head += 1
        for e in range(ptr[v], ptr[v + 1]):
            w = idx[e]
            if inset[w] == stamp:
                inset[w] = -stamp
                level[w] = level[v] + 1
                queue[tail] = w
                tail += 1
    for i in range(tail):            # back to members, for the next sweep
        inset[queue[i]] = stamp
    return tail, level[queue[tail - 1]]


@njit(cache=True, nogil=True)
def _nd(ptr, idx, n, leaf):
    """Nested dissection (module docstring). Returns (perm, node_start,
    node_parent): new position p holds vertex perm[p]; node k owns
    positions node_start[k]..node_start[k+1], its parent is node_parent[k]
    (-1 for the root); nodes are in post-order (children before parents)."""
    verts = np.arange(n)
    inset = np.zeros(n, np.int64)
    level = np.zeros(n, np.int64)
    queue = np.empty(n, np.int64)
    buf = np.empty(n, np.int64)
    # tasks: segment of verts, parent node (creation id)
    t_a = np.empty(2 * n + 2, np.int64)
    t_b = np.empty(2 * n + 2, np.int64)
    t_p = np.empty(2 * n + 2, np.int64)
    # nodes by creation: vertex segment in ``own`` and parent
    own = np.empty(n, np.int64)
    c_start = np.empty(2 * n + 2, np.int64)
    c_end = np.empty(2 * n + 2, np.int64)
    c_par = np.empty(2 * n + 2, np.int64)
    n_nodes = 0
    n_own = 0
    t_a[0] = 0
    t_b[0] = n
    t_p[0] = -1
    top = 1
    stamp = 0
    while top > 0:
        top -= 1
        a, b, par = t_a[top], t_b[top], t_p[top]
        m = b - a
        if m == 0:
            continue
        node = n_nodes
        n_nodes += 1
        c_par[node] = par
        if m <= leaf:
            c_start[node] = n_own
            for i in range(a, b):
                own[n_own] = verts[i]
                n_own += 1
            c_end[node] = n_own
            continue
        stamp += 1
        for i in range(a, b):
            inset[verts[i]] = stamp
        count, last = _bfs(verts[a], ptr, idx, inset, stamp, level, queue)
        far = queue[count - 1]
        count, last = _bfs(far, ptr, idx, inset, stamp, level, queue)   # from a pseudo-peripheral vertex
        if count < m:
            # disconnected: the reached component and the rest, no separator
            c_start[node] = n_own
            c_end[node] = n_own
            for i in range(count):
                inset[queue[i]] = -stamp
            j = 0
            for i in range(a, b):
                if inset[verts[i]] == -stamp:
                    buf[j] = verts[i]
                    j += 1
            r = j
            for i in range(a, b):
                if inset[verts[i]] == stamp:
                    buf[j] = verts[i]
                    j += 1
            for i in range(m):
                verts[a + i] = buf[i]
            for i in range(a, b):
                inset[verts[i]] = 0
            t_a[top], t_b[top], t_p[top] = a, a + r, node
            top += 1
            t_a[top], t_b[top], t_p[top] = a + r, b, node
            top += 1
            continue
        if last < 2:
            # no level with vertices on both sides: one dense front
            c_start[node] = n_own
            for i in range(a, b):
                own[n_own] = verts[i]
                n_own += 1
            c_end[node] = n_own
            for i in range(a, b):
                inset[verts[i]] = 0
            continue
        # the separating level: the fewest vertices touching the next level,
        # among the levels that leave at least ``BALANCE`` of the part on
        # either side (the median vertex's level when none does)
        cnt = np.zeros(last + 2, np.int64)
        tch = np.zeros(last + 2, np.int64)
        for i in range(count):
            v = queue[i]
            lv = level[v]
            cnt[lv] += 1
            for e in range(ptr[v], ptr[v + 1]):
                w = idx[e]
                if inset[w] == stamp and level[w] == lv + 1:
                    tch[lv] += 1
                    break
        mid = level[queue[m // 2]]
        if mid < 1:
            mid = 1
        if mid > last - 1:
            mid = last - 1
        best = -1
        before = cnt[0]
        for lv in range(1, last):
            after = m - before - cnt[lv]
            if before >= BALANCE * m and after >= BALANCE * m:
                if best < 0 or tch[lv] < tch[best]:
                    best = lv
            before += cnt[lv]
        if best >= 0:
            mid = best
        # separator: the median level's vertices touching the next level
        c_start[node] = n_own
        j = 0
        for i in range(a, b):
            v = verts[i]
            lv = level[v]
            side = 0 if lv < mid else (2 if lv > mid else 1)
            if side == 1:
                touches = False
                for e in range(ptr[v], ptr[v + 1]):
                    w = idx[e]
                    if inset[w] == stamp and level[w] == mid + 1:
                        touches = True
                        break
                if touches:
                    own[n_own] = v
                    n_own += 1
                else:
                    buf[j] = v
                    j += 1
            elif side == 0:
                buf[j] = v
                j += 1
        r = j
        for i in range(a, b):
            v = verts[i]
            if level[v] > mid:
                buf[j] = v
                j += 1
        c_end[node] = n_own
        for i in range(j):
            verts[a + i] = buf[i]
        for i in range(a, b):
            inset[verts[i]] = 0
        t_a[top], t_b[top], t_p[top] = a, a + r, node
        top += 1
        t_a[top], t_b[top], t_p[top] = a + r, a + j, node
        top += 1
    # post-order of the creation tree: children lists, then an explicit DFS
    nchild, kids = _children(c_par[:n_nodes])
    post = np.empty(n_nodes, np.int64)
    stack = np.empty(n_nodes, np.int64)
    nxt = nchild[:n_nodes].copy()    # next child to visit
    np_ = 0
    for root in range(n_nodes):
        if c_par[root] != -1:
            continue
        sp_ = 1
        stack[0] = root
        while sp_ > 0:
            k = stack[sp_ - 1]
            if nxt[k] < nchild[k + 1]:
                stack[sp_] = kids[nxt[k]]
                nxt[k] += 1
                sp_ += 1
            else:
                post[np_] = k
                np_ += 1
                sp_ -= 1
    newid = np.empty(n_nodes, np.int64)
    for i in range(n_nodes):
        newid[post[i]] = i
    perm = np.empty(n, np.int64)
    node_start = np.empty(n_nodes + 1, np.int64)
    node_parent = np.empty(n_nodes, np.int64)
    p = 0
    for i in range(n_nodes):
        k = post[i]
        node_start[i] = p
        for s in range(c_start[k], c_end[k]):
            perm[p] = own[s]
            p += 1
        node_parent[i] = newid[c_par[k]] if c_par[k] >= 0 else -1
    node_start[n_nodes] = p
    return perm, node_start, node_parent


def nd_order(ptr, idx, n, leaf=LEAF):
    """Nested-dissection ordering of a symmetric sparsity pattern.

    Parameters
    ----------
    ptr, idx : (n+1,), (nnz,) int64
        The pattern in compressed form (CSC or CSR: symmetric), both
        triangles stored; the diagonal and duplicates are allowed.
    n : int
    leaf : int
        Parts of at most this many vertices are not split.

    Returns
    -------
    perm : (n,) int64
        New position p holds vertex ``perm[p]``.
    node_start : (k+1,) int64
        Dissection node i owns positions ``node_start[i]`` to
        ``node_start[i+1]`` (a separator or a leaf part).
    node_parent : (k,) int64
        Each node's parent (-1 for a root); children come before parents.
    """
    return _nd(np.ascontiguousarray(ptr, np.int64), np.ascontiguousarray(idx, np.int64), int(n), int(leaf))


# --------------------------------------------------------------------------
# symbolic and numeric factorisation
# --------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _symbolic(ptr, idx, n, perm, node_start, node_parent):
    """Each node's B set (the later positions its subtree's columns reach),
    sorted: returns (iperm, b_ptr, b_idx, first, kids), the children lists
    as :func:`_children` gives them."""
    k = node_start.size - 1
    iperm = np.empty(n, np.int64)
    for p in range(n):
        iperm[perm[p]] = p
    b_ptr = np.zeros(k + 1, np.int64)
    cap = max(4 * n, 16)
    b_idx = np.empty(cap, np.int64)
    mark = np.full(n, -1, np.int64)
    first, kids = _children(node_parent)     # a node reads its children's B sets
    tmp = np.empty(n, np.int64)
    for i in range(k):
        s0, s1 = node_start[i], node_start[i + 1]
        cnt = 0
        for p in range(s0, s1):
            o = perm[p]
            for e in range(ptr[o], ptr[o + 1]):
                q = iperm[idx[e]]
                if q >= s1 and mark[q] != i:
                    mark[q] = i
                    tmp[cnt] = q
                    cnt += 1
        for c in range(first[i], first[i + 1]):
            ch = kids[c]
            for e in range(b_ptr[ch], b_ptr[ch + 1]):
                q = b_idx[e]
                if q >= s1 and mark[q] != i:
                    mark[q] = i
                    tmp[cnt] = q
                    cnt += 1
        srt = np.sort(tmp[:cnt])
        if b_ptr[i] + cnt > cap:
            while b_ptr[i] + cnt > cap:
                cap *= 2
            grown = np.empty(cap, np.int64)
            grown[:b_ptr[i]] = b_idx[:b_ptr[i]]
            b_idx = grown
        b_idx[b_ptr[i]:b_ptr[i] + cnt] = srt
        b_ptr[i + 1] = b_ptr[i] + cnt
    return iperm, b_ptr, b_idx[:b_ptr[k]].copy(), first, kids


@njit(cache=True, nogil=True)
def _four_row_sums(R, A, B, i0, m, p, w):
    """R[q, :w] = Σ_{k<p} A[i0 + q, k] B[k, :w] for the ``m`` (at most four)
    rows q of A from ``i0`` (R's other rows: sums of zeros): for each inner
    index k in ascending order, B's row k times each row's factor is added
    to the rows' sums along contiguous memory. Every entry's sum runs over
    k in the same order on every CPU (no BLAS kernel chosen by the
    processor, no fused multiply-add): OpenBLAS's products, used before,
    gave a scan's repair other last bits with its Haswell kernels than with
    its SkylakeX kernels on one machine. The products of
    :func:`_sub_product` and :func:`_schur_lower`."""
    R[:, :w] = 0.0
    for k in range(p):
        f0 = A[i0, k]
        f1 = A[i0 + 1, k] if m > 1 else 0.0
        f2 = A[i0 + 2, k] if m > 2 else 0.0
        f3 = A[i0 + 3, k] if m > 3 else 0.0
        for b in range(w):
            z = B[k, b]
            R[0, b] += f0 * z
            R[1, b] += f1 * z
            R[2, b] += f2 * z
            R[3, b] += f3 * z


@njit(cache=True, nogil=True)
def _sub_product(C, r0, r1, A, B, p):
    """C[r0:r1] −= A[r0:r1, :p] · B[:p] in place (row-major, B's rows as
    wide as C's), four rows of C at a time (:func:`_four_row_sums`), the
    sums then subtracted."""
    n = C.shape[1]
    R = np.empty((4, n), np.float64)
    for i0 in range(r0, r1, 4):
        m = min(4, r1 - i0)
        _four_row_sums(R, A, B, i0, m, p, n)
        for a in range(m):
            for b in range(n):
                C[i0 + a, b] -= R[a, b]


@njit(cache=True, nogil=True)
def _schur_lower(Fm, ns, Z):
    """The update matrix F_BB − L_BS L_BSᵀ of a front, its lower triangle
    (all the parent reads): U[a, b] = Fm[ns + a, ns + b] − Σ_k Z[k, a] Z[k, b]
    for b ≤ a, Z = L_BSᵀ (ns, nb) row-major; four rows at a time
    (:func:`_four_row_sums`: the same bits on every CPU). Measured against BLAS's full product (one thread, this
    2-core machine): 0.03 ms either at 48 x 100, 0.62 against 0.42 ms at
    150 x 300, 2.2 against 1.3 ms at 300 x 400 (it sums only the lower
    triangle, half the work)."""
    nb = Z.shape[1]
    U = np.zeros((nb, nb), np.float64)
    R = np.empty((4, nb), np.float64)
    ZT = Z.T                              # (a view: its rows' factors are Z's columns)
    for i0 in range(0, nb, 4):
        m = min(4, nb - i0)
        w = i0 + m                        # the columns a lower triangle's rows reach
        _four_row_sums(R, ZT, Z, i0, m, ns, w)
        for a in range(m):
            for b in range(i0 + a + 1):
                U[i0 + a, b] = Fm[ns + i0 + a, ns + b] - R[a, b]
    return U


@njit(cache=True, nogil=True)
def _forward_rows(L, Z):
    """Z ← L⁻¹ Z in place (L lower triangular, Z (ns, nb) row-major), by
    blocks of ``BLOCK`` rows: the products with the rows already solved
    are :func:`_sub_product`, each row's own update an axpy along Z's
    contiguous rows."""
    ns = L.shape[0]
    nb = Z.shape[1]
    if nb == 0 or ns == 0:
        return
    for k0 in range(0, ns, BLOCK):
        k1 = min(k0 + BLOCK, ns)
        if k0 > 0:
            _sub_product(Z, k0, k1, L, Z, k0)
        for k in range(k0, k1):
            for j in range(k0, k):
                f = L[k, j]
                for r in range(nb):
                    Z[k, r] -= f * Z[j, r]
            d = 1.0 / L[k, k]
            for r in range(nb):
                Z[k, r] *= d


@njit(cache=True, nogil=True)
def _numeric(ptr, idx, val, n, perm, iperm, node_start, b_ptr, b_idx, first, kids):
    """Multifrontal factorisation. Returns (ok, l_ptr, l_val): node i's
    columns of L are stored at l_val[l_ptr[i]:l_ptr[i+1]] as L_SS (nS, nS)
    row-major (zeros above the diagonal), then L_BSᵀ (nS, nB) row-major;
    ok False where a pivot block is not positive definite. The update
    matrices wait on a stack (packed lower triangles): in post-order a
    node's children's are the topmost, so only those of the nodes whose
    parent is not yet done are held."""
    k = node_start.size - 1
    l_ptr = np.zeros(k + 1, np.int64)
    for i in range(k):
        ns = node_start[i + 1] - node_start[i]
        nb = b_ptr[i + 1] - b_ptr[i]
        l_ptr[i + 1] = l_ptr[i] + (ns + nb) * ns
    l_val = np.empty(l_ptr[k], np.float64)
    u_off = np.zeros(k, np.int64)        # each node's update matrix on the stack
    cap = 1024
    u_val = np.empty(cap, np.float64)
    top = 0
    loc = np.full(n, -1, np.int64)
    for i in range(k):
        s0, s1 = node_start[i], node_start[i + 1]
        ns = s1 - s0
        nb = b_ptr[i + 1] - b_ptr[i]
        f = ns + nb
        for p in range(s0, s1):
            loc[p] = p - s0
        for e in range(b_ptr[i], b_ptr[i + 1]):
            loc[b_idx[e]] = ns + e - b_ptr[i]
        Fm = np.zeros((f, f), np.float64)
        for p in range(s0, s1):
            o = perm[p]
            cp = p - s0
            for e in range(ptr[o], ptr[o + 1]):
                q = iperm[idx[e]]
                if q >= p:
                    Fm[loc[q], cp] += val[e]
        for c in range(first[i], first[i + 1]):
            ch = kids[c]
            cb0 = b_ptr[ch]
            cnb = b_ptr[ch + 1] - cb0
            base = u_off[ch]
            for a in range(cnb):
                ra = loc[b_idx[cb0 + a]]
                row = base + a * (a + 1) // 2
                for bcol in range(a + 1):
                    Fm[ra, loc[b_idx[cb0 + bcol]]] += u_val[row + bcol]
        if first[i + 1] > first[i]:         # the children's matrices popped
            top = u_off[kids[first[i]]]
        # factor the S block (lower triangle read), then the B rows
        if ns > 0:
            S = np.empty((ns, ns), np.float64)
            for a in range(ns):
                for bcol in range(a + 1):
                    S[a, bcol] = Fm[a, bcol]
                    S[bcol, a] = Fm[a, bcol]
            L = _chol(S)
            if L.shape[0] == 0:                        # a pivot not positive (_chol checks the diagonal first)
                return False, l_ptr, l_val
            Z = np.ascontiguousarray(Fm[ns:, :ns].T)      # L_BSᵀ after the solve
            _forward_rows(L, Z)
            base = l_ptr[i]
            for a in range(ns):
                for bcol in range(ns):
                    l_val[base + a * ns + bcol] = L[a, bcol] if bcol <= a else 0.0
            base += ns * ns
            for a in range(ns):
                for bcol in range(nb):
                    l_val[base + a * nb + bcol] = Z[a, bcol]
            if nb > 0:
                U = _schur_lower(Fm, ns, Z)
            else:
                U = np.zeros((0, 0), np.float64)
        else:
            U = np.ascontiguousarray(Fm[ns:, ns:])
        need = top + nb * (nb + 1) // 2
        if need > cap:
            while need > cap:
                cap *= 2
            grown = np.empty(cap, np.float64)
            grown[:top] = u_val[:top]
            u_val = grown
        u_off[i] = top
        for a in range(nb):
            row = top + a * (a + 1) // 2
            for bcol in range(a + 1):
                u_val[row + bcol] = U[a, bcol]
        top = need
        for p in range(s0, s1):
            loc[p] = -1
        for e in range(b_ptr[i], b_ptr[i + 1]):
            loc[b_idx[e]] = -1
    return True, l_ptr, l_val


@njit(cache=True, nogil=True)
def _chol(S):
    """Lower Cholesky factor of the symmetric matrix S (its lower triangle
    read); a (0,0) array where S is not positive definite.

    Right-looking: each column's pivot square-rooted and the column below
    it divided by it, then the trailing lower triangle less the column's
    outer product. Four columns at a time (a panel, each of its columns
    applied to the panel's later ones first), the trailing rows then less
    the four outer products in turn along contiguous rows: every entry
    gets the same operations in the same order as one column at a time,
    and on every CPU (LAPACK's potrf, used before, runs the BLAS kernels
    OpenBLAS picks by processor). 0.18 ms against potrf's 0.09 at 150 rows,
    1.2 against 0.44 at 300 (one thread, this 2-core machine)."""
    n = S.shape[0]
    for a in range(n):
        if not (S[a, a] > 0.0) or not np.isfinite(S[a, a]):
            return np.zeros((0, 0), np.float64)
    L = np.zeros((n, n), np.float64)
    for a in range(n):
        for b in range(a + 1):
            L[a, b] = S[a, b]
    C = np.zeros((4, n), np.float64)        # the panel's columns, along rows
    for j0 in range(0, n, 4):
        jb = min(4, n - j0)
        j1 = j0 + jb
        for j in range(j0, j1):
            d = L[j, j]
            if not (d > 0.0) or not np.isfinite(d):
                return np.zeros((0, 0), np.float64)
            d = np.sqrt(d)
            L[j, j] = d
            q = j - j0
            for i in range(j + 1, n):
                L[i, j] /= d
                C[q, i] = L[i, j]
            for i in range(j + 1, n):
                f = C[q, i]
                for c in range(j + 1, min(i + 1, j1)):
                    L[i, c] -= f * C[q, c]
        for i in range(j1, n):
            if jb == 4:
                f0, f1, f2, f3 = C[0, i], C[1, i], C[2, i], C[3, i]
                for c in range(j1, i + 1):
                    x = L[i, c]
                    x -= f0 * C[0, c]
                    x -= f1 * C[1, c]
                    x -= f2 * C[2, c]
                    x -= f3 * C[3, c]
                    L[i, c] = x
            else:
                for q in range(jb):
                    f = C[q, i]
                    for c in range(j1, i + 1):
                        L[i, c] -= f * C[q, c]
    return L


@njit(cache=True, nogil=True)
def _solve3(Y, node_start, b_ptr, b_idx, l_ptr, l_val):
    """L Lᵀ x = y in place for three right-hand sides, already in the
    factorisation's order (Y: (n, 3)); scalar accumulators, each entry of L
    read once per pass."""
    k = node_start.size - 1
    for i in range(k):                    # forward: L y = b
        s0 = node_start[i]
        ns = node_start[i + 1] - s0
        b0 = b_ptr[i]
        nb = b_ptr[i + 1] - b0
        base = l_ptr[i]
        for a in range(ns):
            row = base + a * ns
            t0 = Y[s0 + a, 0]
            t1 = Y[s0 + a, 1]
            t2 = Y[s0 + a, 2]
            for bcol in range(a):
                f = l_val[row + bcol]
                t0 -= f * Y[s0 + bcol, 0]
                t1 -= f * Y[s0 + bcol, 1]
                t2 -= f * Y[s0 + bcol, 2]
            d = l_val[row + a]
            Y[s0 + a, 0] = t0 / d
            Y[s0 + a, 1] = t1 / d
            Y[s0 + a, 2] = t2 / d
        zb = base + ns * ns
        for bcol in range(ns):
            row = zb + bcol * nb
            y0 = Y[s0 + bcol, 0]
            y1 = Y[s0 + bcol, 1]
            y2 = Y[s0 + bcol, 2]
            for a in range(nb):
                f = l_val[row + a]
                q = b_idx[b0 + a]
                Y[q, 0] -= f * y0
                Y[q, 1] -= f * y1
                Y[q, 2] -= f * y2
    for i in range(k - 1, -1, -1):        # backward: Lᵀ x = y
        s0 = node_start[i]
        ns = node_start[i + 1] - s0
        b0 = b_ptr[i]
        nb = b_ptr[i + 1] - b0
        base = l_ptr[i]
        zb = base + ns * ns
        for bcol in range(ns):
            row = zb + bcol * nb
            t0 = Y[s0 + bcol, 0]
            t1 = Y[s0 + bcol, 1]
            t2 = Y[s0 + bcol, 2]
            for a in range(nb):
                f = l_val[row + a]
                q = b_idx[b0 + a]
                t0 -= f * Y[q, 0]
                t1 -= f * Y[q, 1]
                t2 -= f * Y[q, 2]
            Y[s0 + bcol, 0] = t0
            Y[s0 + bcol, 1] = t1
            Y[s0 + bcol, 2] = t2
        for a in range(ns - 1, -1, -1):
            row = base + a * ns
            d = l_val[row + a]
            y0 = Y[s0 + a, 0] / d
            y1 = Y[s0 + a, 1] / d
            y2 = Y[s0 + a, 2] / d
            Y[s0 + a, 0] = y0
            Y[s0 + a, 1] = y1
            Y[s0 + a, 2] = y2
            for r in range(a):
                f = l_val[row + r]
                Y[s0 + r, 0] -= f * y0
                Y[s0 + r, 1] -= f * y1
                Y[s0 + r, 2] -= f * y2


@njit(cache=True, nogil=True)
def _solve(B, perm, node_start, b_ptr, b_idx, l_ptr, l_val):
    """Q⁻¹ B for the factorisation's fronts (B: (n, c)): three columns at a
    time (:func:`_solve3`; a last group of one or two padded with zeros,
    which stay zero)."""
    n, c = B.shape
    X = np.empty((n, c), np.float64)
    Y = np.empty((n, 3), np.float64)
    for j0 in range(0, c, 3):
        w = min(3, c - j0)
        for p in range(n):
            for j in range(3):
                Y[p, j] = B[perm[p], j0 + j] if j < w else 0.0
        _solve3(Y, node_start, b_ptr, b_idx, l_ptr, l_val)
        for p in range(n):
            for j in range(w):
                X[perm[p], j0 + j] = Y[p, j]
    return X


class Factor:
    """The Cholesky factorisation of a sparse symmetric positive definite
    matrix (:func:`factor`); :meth:`solve` gives Q⁻¹ B."""

    __slots__ = ("n", "perm", "node_start", "b_ptr", "b_idx", "l_ptr", "l_val")

    def __init__(self, n, perm, node_start, b_ptr, b_idx, l_ptr, l_val):
        self.n, self.perm, self.node_start = n, perm, node_start
        self.b_ptr, self.b_idx, self.l_ptr, self.l_val = b_ptr, b_idx, l_ptr, l_val

    @property
    def nnz(self):
        """Stored entries of L (the fronts' lower triangles and B rows)."""
        ns = np.diff(self.node_start)
        nb = np.diff(self.b_ptr)
        return int(np.sum(ns * (ns + 1) // 2 + ns * nb))

    def solve(self, B):
        """Q⁻¹ B.

        Parameters
        ----------
        B : (n,) or (n,c) float64

        Returns
        -------
        X : array of B's shape
        """
        B = np.asarray(B, np.float64)
        if self.n == 0:
            return np.zeros(B.shape)
        one = B.ndim == 1
        B2 = np.ascontiguousarray(B.reshape(self.n, -1))
        X = _solve(B2, self.perm, self.node_start, self.b_ptr, self.b_idx, self.l_ptr, self.l_val)
        return X[:, 0] if one else X


def factor(Q, leaf=LEAF):
    """Factorise a sparse symmetric positive definite matrix.

    Parameters
    ----------
    Q : (n,n) SciPy sparse matrix
        Symmetric, both triangles stored (CSC or CSR).
    leaf : int
        :func:`nd_order`'s leaf size.

    Returns
    -------
    F : Factor

    Raises
    ------
    NotPositiveDefinite
        Where a front's pivot block is not positive definite (a singular or
        indefinite Q, or one too ill-conditioned for working precision).
    """
    import scipy.sparse as sp

    Q = Q if sp.isspmatrix_csc(Q) or sp.isspmatrix_csr(Q) else sp.csc_matrix(Q)
    n = Q.shape[0]
    ptr = np.ascontiguousarray(Q.indptr, np.int64)
    idx = np.ascontiguousarray(Q.indices, np.int64)
    val = np.ascontiguousarray(Q.data, np.float64)
    if n == 0:
        z = np.zeros(1, np.int64)
        return Factor(0, np.zeros(0, np.int64), z, z, np.zeros(0, np.int64), z, np.zeros(0))
    perm, node_start, node_parent = _nd(ptr, idx, n, int(leaf))
    iperm, b_ptr, b_idx, first, kids = _symbolic(ptr, idx, n, perm, node_start, node_parent)
    ok, l_ptr, l_val = _numeric(ptr, idx, val, n, perm, iperm, node_start, b_ptr, b_idx, first, kids)
    if not ok:
        raise NotPositiveDefinite("a front's pivot block is not positive definite")
    return Factor(n, perm, node_start, b_ptr, b_idx, l_ptr, l_val)


def warm_up():
    """Compile with Numba's JIT (or load from its on-disk cache) the kernels
    on a small system, or run their ahead-of-time build where it is there
    (:mod:`shellrepair.compiled`); False when the kernels are off."""
    global _WARM
    if not compiled.ENABLED:
        return False
    if _WARM:
        return True
    with _WARM_LOCK:   # a second caller (the background load, a fill) waits for the first
        if _WARM:
            return True
        import scipy.sparse as sp

        m = 3 * LEAF
        T = sp.diags([-np.ones(m - 1), 2.5 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1], format="csc")
        f = factor(T)
        f.solve(np.ones((m, 3)))
        f.solve(np.ones(m))
        nd_order(T.indptr, T.indices, m)
        _WARM = True
    return True
