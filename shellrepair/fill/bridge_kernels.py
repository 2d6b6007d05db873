"""Compiled kernels of the continuation arcs between loops (:mod:`shellrepair.fill.bridge`, Numba).

* :func:`ring_sums`: the sums over the two rings around a loop's vertices
  (:func:`shellrepair.reference.ring_sums`), and :func:`block_ids`,
  :func:`corner_normal_sums`: the arcs' local vertex numbers and vertex
  normal sums;
* :func:`arc_landings`: where each continuation arc lands first, arc by
  arc, sample by sample, in a k-d tree of the rim vertices
  (:func:`shellrepair.fill.bridge.landings_reference`, which asks SciPy's
  ``cKDTree`` run by run).

Each gives what its NumPy version gives, to the bit (tests/test_kernels.py,
tests/test_bridge_kernels.py). How the kernels are compiled and switched
off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ring_sums", "block_ids", "corner_normal_sums", "arc_landings", "kd_build", "KD_LEAF"]

from shellrepair import compiled
from shellrepair.fill.patch_kernels import _face_cross

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _ring_sums(E, li, level, X, Nv):
    nv = level.size
    # each vertex's neighbours (unsorted, with repeats); the rows read
    # below (levels 0 and 1) sorted in place, repeats skipped when read
    start = np.zeros(nv + 1, np.int64)
    for r in range(E.shape[0]):
        start[E[r, 0] + 1] += 1
        start[E[r, 1] + 1] += 1
    for v in range(nv):
        start[v + 1] += start[v]
    nb = np.empty(start[nv], np.int64)
    fill = start[:nv].copy()
    for r in range(E.shape[0]):
        a, b = E[r, 0], E[r, 1]
        nb[fill[a]] = b
        fill[a] += 1
        nb[fill[b]] = a
        fill[b] += 1
    for v in range(nv):
        if level[v] <= 1:
            for i in range(start[v] + 1, start[v + 1]):       # insertion sort: a few entries
                x = nb[i]
                j = i - 1
                while j >= start[v] and nb[j] > x:
                    nb[j + 1] = nb[j]
                    j -= 1
                nb[j + 1] = x
    p = li.size
    s1 = np.zeros((p, 3))
    n1 = np.zeros((p, 3))
    c1 = np.zeros(p)
    s2 = np.zeros((p, 3))
    n2 = np.zeros((p, 3))
    c2 = np.zeros(p)
    mark = np.zeros(nv, np.bool_)
    got = np.empty(nv, np.int64)
    for i in range(p):
        v = li[i]
        ng = 0
        for jj in range(start[v], start[v + 1]):
            w = nb[jj]
            if level[w] != 1 or (jj > start[v] and nb[jj - 1] == w):
                continue
            c1[i] += 1.0
            for k in range(3):
                s1[i, k] += X[w, k]
                n1[i, k] += Nv[w, k]
            for tt in range(start[w], start[w + 1]):
                x = nb[tt]
                if level[x] == 2 and not mark[x]:
                    mark[x] = True
                    got[ng] = x
                    ng += 1
        two = np.sort(got[:ng])
        for x in two:
            mark[x] = False
            c2[i] += 1.0
            for k in range(3):
                s2[i, k] += X[x, k]
                n2[i, k] += Nv[x, k]
    return s1, c1, n1, s2, c2, n2


def ring_sums(E, li, level, X, Nv):
    """:func:`shellrepair.reference.ring_sums` compiled: per rim vertex the
    sums over its level-1 neighbours and over their level-2 neighbours, in
    ascending vertex order from zero, as the sparse products add them.

    Parameters
    ----------
    E : (k,2) int64
        Edges (repeats and both directions allowed).
    li : (p,) int64
        Rim vertices.
    level : (nv,) int64
    X, Nv : (nv,3) float64

    Returns
    -------
    s1, c1, n1, s2, c2, n2
        As :func:`shellrepair.reference.ring_sums`.
    """
    c = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    i = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    return _ring_sums(i(E).reshape(-1, 2), i(li), i(level), c(X), c(Nv))


@njit(cache=True, nogil=True)
def _block_ids(Fcat, fcount, loopcat, sizes, n, vpos):
    if vpos.size:
        return _block_ids_marked(Fcat, fcount, loopcat, sizes, n, vpos)
    nb = fcount.size
    ukey = np.empty(3 * Fcat.shape[0] + loopcat.size, np.int64)
    L = np.empty(Fcat.shape, np.int64)
    li = np.empty(loopcat.size, np.int64)
    nu = 0
    f0 = 0
    p0 = 0
    for blk in range(nb):
        f1, p1 = f0 + fcount[blk], p0 + sizes[blk]
        vs = np.empty(3 * (f1 - f0) + (p1 - p0), np.int64)
        q = 0
        for f in range(f0, f1):
            for c in range(3):
                vs[q] = Fcat[f, c]
                q += 1
        for i in range(p0, p1):
            vs[q] = loopcat[i]
            q += 1
        vs = np.sort(vs)
        m = 0
        for i in range(vs.size):
            if i == 0 or vs[i] != vs[i - 1]:
                vs[m] = vs[i]
                m += 1
        vs = vs[:m]
        base = np.int64(blk) * n
        for i in range(m):
            ukey[nu + i] = base + vs[i]
        for f in range(f0, f1):
            for c in range(3):
                L[f, c] = nu + np.searchsorted(vs, Fcat[f, c])
        for i in range(p0, p1):
            li[i] = nu + np.searchsorted(vs, loopcat[i])
        nu += m
        f0, p0 = f1, p1
    return ukey[:nu], L, li


@njit(cache=True, nogil=True)
def _block_ids_marked(Fcat, fcount, loopcat, sizes, n, vpos):
    # _block_ids with a vertex-position scratch (all -1, left so): each
    # block's distinct vertices marked and sorted, then read off.
    nb = fcount.size
    ukey = np.empty(3 * Fcat.shape[0] + loopcat.size, np.int64)
    L = np.empty(Fcat.shape, np.int64)
    li = np.empty(loopcat.size, np.int64)
    seen = np.empty(max(1, 3 * Fcat.shape[0] + loopcat.size), np.int64)
    nu = 0
    f0 = 0
    p0 = 0
    for blk in range(nb):
        f1, p1 = f0 + fcount[blk], p0 + sizes[blk]
        m = 0
        for f in range(f0, f1):
            for c in range(3):
                w = Fcat[f, c]
                if vpos[w] < 0:
                    vpos[w] = 0
                    seen[m] = w
                    m += 1
        for i in range(p0, p1):
            w = loopcat[i]
            if vpos[w] < 0:
                vpos[w] = 0
                seen[m] = w
                m += 1
        vs = np.sort(seen[:m])
        base = np.int64(blk) * n
        for i in range(m):
            ukey[nu + i] = base + vs[i]
            vpos[vs[i]] = nu + i
        for f in range(f0, f1):
            for c in range(3):
                L[f, c] = vpos[Fcat[f, c]]
        for i in range(p0, p1):
            li[i] = vpos[loopcat[i]]
        for i in range(m):
            vpos[vs[i]] = -1
        nu += m
        f0, p0 = f1, p1
    return ukey[:nu], L, li


#: :func:`block_ids` marks vertices in a scratch of one entry per mesh vertex
#: when the mesh has at most this many vertices per face corner and loop
#: vertex given (the scratch then costs less than sorting each block's
#: corners); else it sorts them. The results are the same.
BLOCK_SCRATCH_RATIO = 8


def block_ids(Fcat, fcount, loopcat, sizes, n, scratch=None):
    """Local vertex numbers of several blocks of faces and loops
    (:func:`shellrepair.fill.bridge._continuation_arcs_many`): the keys
    ``block * n + vertex`` of every block's vertices, sorted and unique
    (``np.unique``), and each face corner's and loop vertex's position
    among them (``np.searchsorted``); block by block, without sorting all
    keys at once.

    Parameters
    ----------
    Fcat : (r,3) int64
        The blocks' faces, block after block.
    fcount : (b,) int64
        Faces per block.
    loopcat : (p,) int64
        The blocks' loop vertices, block after block.
    sizes : (b,) int64
        Loop vertices per block.
    n : int
        Number of vertices of the mesh.
    scratch : bool, optional
        Number the vertices through a scratch of ``n`` entries (True) or by
        sorting each block's corners (False); by default the scratch when
        ``n`` is at most ``BLOCK_SCRATCH_RATIO`` times the entries given.

    Returns
    -------
    ukey : (nv,) int64
    L : (r,3) int64
    li : (p,) int64
    """
    i = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    Fcat, loopcat = i(Fcat).reshape(-1, 3), i(loopcat)
    if scratch is None:
        scratch = n <= BLOCK_SCRATCH_RATIO * (Fcat.size + loopcat.size)
    vpos = np.full(int(n) if scratch else 0, -1, np.int64)
    return _block_ids(Fcat, i(fcount), loopcat, i(sizes), np.int64(n), vpos)


@njit(cache=True, nogil=True)
def _corner_normal_sums(L, Fcat, V, nv):
    m = Fcat.shape[0]
    Nf = _face_cross(np.arange(m), Fcat, V)
    acc = np.zeros((nv, 3))
    for c in range(3):
        for f in range(m):
            for k in range(3):
                acc[L[f, c], k] += Nf[f, k]
    return acc


def corner_normal_sums(L, Fcat, V, nv):
    """``np.add.at(acc, L[:, c], np.cross(e1, e2))`` for c = 0, 1, 2 in
    turn (``e1, e2`` the sides of the faces ``Fcat`` from corner 0): the
    area-weighted normal sums at local vertices, the same additions in the
    same order.

    Returns
    -------
    acc : (nv,3) float64
    """
    return _corner_normal_sums(np.ascontiguousarray(L, np.int64), np.ascontiguousarray(Fcat, np.int64),
                               np.ascontiguousarray(V, np.float64), int(nv))


#: Points per leaf of :func:`arc_landings`' k-d tree of rim vertices. The tree is
#: our own because the compiled kernel queries it sample by sample from inside
#: its loop, where SciPy's ``cKDTree`` (a Python object) cannot be called; the
#: NumPy oracle (:func:`shellrepair.fill.bridge.landings_reference`) asks a
#: ``cKDTree`` and lands every arc on the same loop (tests/test_bridge_kernels.py).
KD_LEAF = 8


@njit(cache=True, nogil=True)
def _kd_select(order, P, ax, a, z, k):
    # Wirth's selection: order[a:z] rearranged in place so that the points
    # before position k lie at most, and those after at least, at order[k]
    # along axis ax
    lo, hi = a, z - 1
    while lo < hi:
        x = P[order[k], ax]
        i, j = lo, hi
        while i <= j:
            while P[order[i], ax] < x:
                i += 1
            while x < P[order[j], ax]:
                j -= 1
            if i <= j:
                order[i], order[j] = order[j], order[i]
                i += 1
                j -= 1
        if j < k:
            lo = i
        if k < i:
            hi = j


@njit(cache=True, nogil=True)
def _kd_build(P):
    # a k-d tree by index medians along the widest axis: node b covers
    # order[lo[b]:hi[b]]; an inner node's left child holds the points at
    # most split[b] along axis[b], its right child those at least it
    n = P.shape[0]
    cap = n + 2      # a split node has more than KD_LEAF points: leaves hold 4 or more
    lo = np.empty(cap, np.int64)
    hi = np.empty(cap, np.int64)
    axis = np.full(cap, -1, np.int64)
    split = np.zeros(cap)
    left = np.full(cap, -1, np.int64)
    order = np.arange(n)
    lo[0], hi[0] = 0, n
    nb = 1
    todo = np.empty(cap, np.int64)
    todo[0] = 0
    nt = 1
    while nt:
        nt -= 1
        b = todo[nt]
        a, z = lo[b], hi[b]
        if z - a <= KD_LEAF:
            continue
        best, ax = -1.0, 0
        for k in range(3):
            mn, mx = np.inf, -np.inf
            for i in range(a, z):
                x = P[order[i], k]
                mn = min(mn, x)
                mx = max(mx, x)
            if mx - mn > best:
                best, ax = mx - mn, k
        mid = a + (z - a) // 2
        _kd_select(order, P, ax, a, z, mid)
        axis[b] = ax
        split[b] = P[order[mid], ax]
        left[b] = nb
        lo[nb], hi[nb] = a, mid
        lo[nb + 1], hi[nb + 1] = mid, z
        todo[nt] = nb
        todo[nt + 1] = nb + 1
        nt += 2
        nb += 2
    return order, lo[:nb], hi[:nb], axis[:nb], split[:nb], left[:nb]


@njit(cache=True, nogil=True)
def _sinc(x):
    # np.sinc of one value: sin(y) / y, y = pi x (eps where y is 0)
    y = np.pi * x
    if y == 0.0:
        y = 2.220446049250313e-16
    return np.sin(y) / y


@njit(cache=True, nogil=True)
def _arc_key(j, r, owner, place, arow, krow, irow, skip):
    # what a landing on rim vertex j decides for arc r: its loop, and
    # whether it is the arc's own start (2 * loop + 1) or not (2 * loop)
    w = owner[j]
    if w == arow[r]:
        g = abs(place[j] - irow[r])
        if min(g, krow[r] - g) <= skip:
            return 2 * w + 1
    return 2 * w


#: Ties :func:`arc_landings` keeps per sample; more sends it to NumPy.
_MAX_TIES = 16


@njit(cache=True, nogil=True)
def _arc_landings(U, T, N, kap, s0, length, frac, slack, ent, nent, P, owner, place, edge, arow, krow, irow, skip,
                  rank, landed, r0):
    m = U.shape[0]
    J = frac.size
    # every operand finite, else the NumPy version decides (NaN bounds)
    for r in range(m):
        for k in range(3):
            if not (np.isfinite(U[r, k]) and np.isfinite(T[r, k]) and np.isfinite(N[r, k])):
                return 2, r0
        if not (np.isfinite(kap[r]) and np.isfinite(s0[r]) and np.isfinite(length[r])):
            return 2, r0
    for i in range(P.shape[0]):
        for k in range(3):
            if not np.isfinite(P[i, k]):
                return 2, r0
    emax = -np.inf
    for i in range(edge.size):
        if not np.isfinite(edge[i]):
            return 2, r0
        emax = max(emax, edge[i])
    # per loop the largest slack of its arcs' samples, plus the largest edge
    bound = np.full(nent, -np.inf)
    for r in range(m):
        h = length[r] / J
        for c in range(J):
            s = s0[r] + length[r] * frac[c]
            bound[ent[r]] = max(bound[ent[r]], h + slack * (s - s0[r]))
    for e in range(nent):
        bound[e] += emax
    order, lo, hi, axis, split, left = _kd_build(P)
    Q = np.empty((P.shape[0], 3))      # the points in leaf order
    for i in range(P.shape[0]):
        for k in range(3):
            Q[i, k] = P[order[i], k]
    stack = np.empty(256, np.int64)
    side = np.empty((256, 3))      # per queued node, the sample's distance to its box along each axis
    bmin = np.full(3, np.inf)
    bmax = np.full(3, -np.inf)
    for i in range(P.shape[0]):
        for k in range(3):
            bmin[k] = min(bmin[k], P[i, k])
            bmax[k] = max(bmax[k], P[i, k])
    x = np.empty(3)
    ties = np.empty(_MAX_TIES, np.int64)
    for r in range(r0, m):
        rb = bound[ent[r]]
        h = length[r] / J
        for c in range(J):
            s = s0[r] + length[r] * frac[c]
            # only a vertex within the sample's slack plus the largest edge
            # can be a landing (a margin over that radius: a wider search
            # only costs time)
            tol = h + slack * (s - s0[r])
            rc = min(rb, (tol + emax) * (1.0 + 1e-9))
            rb2 = rc * rc
            ks = kap[r] * s
            a = s * _sinc(ks / np.pi)
            sc = _sinc(ks / (2 * np.pi))
            bq = 0.5 * kap[r] * (s * s) * (sc * sc)
            for k in range(3):
                x[k] = U[r, k] + a * T[r, k] + bq * N[r, k]
            # the rim vertices nearest the sample and nearer than the bound
            # (cKDTree's squared distance, summed in its order); a box's
            # squared distance, summed in that order from per-axis
            # distances that round no higher than a point's, is no more
            # than any of its points'
            best = np.inf
            nt = 0
            stack[0] = 0
            for k in range(3):
                side[0, k] = max(0.0, bmin[k] - x[k], x[k] - bmax[k])
            ns = 1
            while ns:
                ns -= 1
                b = stack[ns]
                lb = side[ns, 0] * side[ns, 0] + side[ns, 1] * side[ns, 1] + side[ns, 2] * side[ns, 2]
                if lb > best or lb > rb2:
                    continue
                if axis[b] < 0:
                    for i in range(lo[b], hi[b]):
                        d0 = Q[i, 0] - x[0]
                        d1 = Q[i, 1] - x[1]
                        d2 = Q[i, 2] - x[2]
                        dd = d0 * d0 + d1 * d1 + d2 * d2
                        if dd > rb2 or dd > best:
                            continue
                        if dd < best:
                            best = dd
                            nt = 0
                        if nt == _MAX_TIES:
                            return 1, r
                        ties[nt] = order[i]
                        nt += 1
                    continue
                ax = axis[b]
                diff = x[ax] - split[b]
                if diff < 0:
                    near, far, gap = left[b], left[b] + 1, split[b] - x[ax]
                else:
                    near, far, gap = left[b] + 1, left[b], diff
                for k in range(3):
                    side[ns + 1, k] = side[ns, k]
                side[ns, ax] = max(side[ns, ax], gap)
                stack[ns] = far
                stack[ns + 1] = near
                ns += 2
            if nt == 0:
                continue
            d = np.sqrt(best)
            if not d < rb:
                continue
            bj = ties[0]
            if nt > 1:
                # cKDTree keeps one of the vertices at the same distance:
                # of points at one place, the first in its leaf order
                # (rank); vertices that decide alike need no choice
                key = _arc_key(bj, r, owner, place, arow, krow, irow, skip)
                alike = True
                same = True
                for t in range(1, nt):
                    j = ties[t]
                    alike &= _arc_key(j, r, owner, place, arow, krow, irow, skip) == key
                    same &= P[j, 0] == P[bj, 0] and P[j, 1] == P[bj, 1] and P[j, 2] == P[bj, 2]
                if not alike:
                    if not same:
                        return 1, r
                    if rank.size == 0:
                        return 3, r
                    for t in range(1, nt):
                        if rank[ties[t]] < rank[bj]:
                            bj = ties[t]
            who = owner[bj]
            if not d <= tol + edge[who]:
                continue
            if _arc_key(bj, r, owner, place, arow, krow, irow, skip) & 1:
                continue
            landed[r] = who
            break
    return 0, m


def arc_landings(U, T, N, kap, s0, length, n_samples, slack, ent, nent, P, owner, place, edge, arow, krow, irow,
                 skip, rank_of=None):
    """The loop each continuation arc lands on first
    (:func:`shellrepair.fill.bridge.loop_sights`' walk along the arcs, the
    NumPy version :func:`shellrepair.fill.bridge.landings_reference` its oracle),
    arc by arc and sample by sample, each sample looked up in a k-d tree
    of the rim vertices.

    A sample lands on its nearest rim vertex (the squared distance summed
    as SciPy's ``cKDTree`` sums it) when that vertex is nearer than its
    loop's bound and within the sample's slack plus the target's mean
    edge, and is not the arc's own start. Of several vertices at the same
    distance that would decide differently, ``cKDTree`` keeps the first in
    its own leaf order: for vertices at one place (a vertex shared by
    touching loops) that order is read from a ``cKDTree`` of ``P``, built
    by ``rank_of(P)`` when first needed; vertices at different places at
    the same distance that decide differently give status 1.

    Parameters
    ----------
    U, T, N : (m,3) float64
        The arcs' base points, unit tangents and normals.
    kap, s0, length : (m,) float64
        Curvatures, base-to-rim lengths and lengths followed.
    n_samples : int
        Samples per arc, at ``s0 + length * (1..n_samples) / n_samples``.
    slack : float
        Lateral slack per unit of arc length.
    ent : (m,) int64
        Each arc's followed loop (0..nent-1): the loop's bound is the
        largest slack of its arcs' samples plus the largest ``edge``.
    nent : int
    P : (p,3) float64
        Rim vertices of every loop, loop after loop.
    owner, place : (p,) int64
        Each rim vertex's loop and position along it.
    edge : (L,) float64
        Loops' mean edge lengths.
    arow, krow, irow : (m,) int64
        Each arc's loop, that loop's vertex count and the arc's vertex.
    skip : int
        Rim vertices this many steps from the arc's own are its start.
    rank_of : callable, optional
        ``rank_of(P)`` -> (p,) int64, each vertex's position in the leaf
        order of ``cKDTree(P)``; without it such ties give status 1.

    Returns
    -------
    landed : (m,) int64
        The loop each arc lands on first, -1 for none.
    status : int
        0; 1 where a tie the kernel cannot decide was met, 2 where an
        operand is not finite (``landed`` is then unusable).
    """
    f = lambda x: np.ascontiguousarray(x, np.float64)  # noqa: E731
    i = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    frac = np.arange(1, int(n_samples) + 1) / int(n_samples)
    args = (f(U).reshape(-1, 3), f(T).reshape(-1, 3), f(N).reshape(-1, 3), f(kap), f(s0), f(length), frac,
            float(slack), i(ent), int(nent), f(P).reshape(-1, 3), i(owner), i(place), f(edge), i(arow), i(krow),
            i(irow), int(skip))
    landed = np.full(len(args[0]), -1, np.int64)
    status, r = _arc_landings(*args, np.zeros(0, np.int64), landed, 0)
    if status == 3:
        if rank_of is None:
            return landed, 1
        status, r = _arc_landings(*args, i(rank_of(args[10])), landed, r)
    return landed, status


def kd_build(P):
    """The k-d tree :func:`arc_landings` queries (compiled ``_kd_build``):
    index medians along the widest axis; node b covers ``order[lo[b]:hi[b]]``,
    an inner node's left child (``left[b]``, its right one ``left[b] + 1``)
    the points at most ``split[b]`` along ``axis[b]``, its right child those
    at least it; a leaf (``axis`` −1) holds at most ``KD_LEAF`` points.

    Parameters
    ----------
    P : (n,3) float64

    Returns
    -------
    order : (n,) int64
    lo, hi : int64
        Each node's range in ``order``.
    axis : int64
        Each node's split axis, −1 for a leaf.
    split : float64
    left : int64
    """
    return _kd_build(np.ascontiguousarray(P, np.float64))
