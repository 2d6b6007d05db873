"""Bridge a missing band: two loops that bound one missing region of surface.

A scanner that misses a whole band (the inner side of a ring-like fold, the
gap around a wrist or a thin arm, the inner equator of a torus seen from a
ring of views) leaves two loops that one tube of surface joins. A hole with
a floating island of scan inside it leaves an outer and an inner loop that
one annulus joins. Capping each loop gives the wrong shape (and often
cannot be done at all: a cap of a torus's inner band crosses the opposite
side); a tube continues the surface.

Which loops see each other
--------------------------
At each rim vertex the scan arrives from one side and is heading somewhere
when it stops. The *continuation arc* extends it: it starts one ring off
the loop, at the mean ``q1`` of the rim vertex's neighbours there, heads
towards the rim (along ``p - q2``, ``q2`` the mean of the next ring) and
bends like the scan does in that direction: its curvature is the normal
curvature across the rim, measured by how far the vertex normals turn
between the two rings (:func:`continuation_arcs`). The arc is the circle
the surface would follow if its curvature across the gap stayed what it is
at the rim.

* On a hole in a smooth surface the arcs cross the hole and land on the
  same loop's far side.
* Around a cut arm or cylinder the arcs run straight across the gap and
  land on the other loop; around a torus's inner band they turn with the
  tube (more than a half turn) and land on the other loop too, although the
  loops' mean directions point away from each other.
* From an island the arcs run outwards and land on the surrounding loop.

Loop A *sees* loop B when most of A's arcs (a strict majority, the only
rule used) land on B before any other loop; a pair is a candidate when
either sees the other. Arcs are followed up to ``MAX_REACH`` times the
loop's diameter or one full turn, whichever is shorter (the search horizon,
not a decision threshold). Only loops classed ``hole`` are looked at: a
border (the rim of a single-view scan, the edge of floating debris) is
never bridged.

Which option is kept
--------------------
Seeing is only the reason to try. The tube is built along both loops'
arcs (:func:`guide_tube`), refined to the rim's edge length, and then
either faired with both loops' rings fixed or kept on the arcs, whichever
valid one has the lower curvature-variation energy; every option is
checked like a cap: it must cross neither the scan nor itself, nor repeat
an edge of the scan. Then (see :func:`shellrepair.fill._fill_pair`):

* loops that see each other both ways keep a valid tube (the surface
  continues from each into the other; the caps are not built);
* otherwise the two caps are built and checked, against each other too;
  an option that fails its checks loses, and between valid ones the lower
  energy wins.

Two loops that cross a thin tube obliquely send their arcs round the tube
and back to themselves; :func:`wrapped_pairs` pairs such loops from the scan
at their rims (they wrap the tube and head to each other). Three loops that
bound one region are filled by :mod:`shellrepair.pants`.

The tube's rings, and the plain zip used when no guide can be built, are
matched by arc length from the cyclic shift of the second loop (walked
backwards) that best matches the first, so loops of very different vertex
counts or with unrelated start vertices zip without a twist.
"""

from __future__ import annotations

from itertools import chain
from typing import NamedTuple

import numpy as np
from .lazyscipy import cKDTree

from . import bridge_kernels, compiled

__all__ = ["continuation_arcs", "arc_points", "loop_sights", "band_pairs", "tube_triangles", "guide_tube",
           "resample_tube", "pants_triples", "wrapped_pairs", "MAX_REACH", "ARCS_PER_LOOP", "ARC_SAMPLES", "SIGHT_SLACK"]

#: Arcs are followed at most this many loop diameters (or one full turn):
#: the search horizon for a partner loop, not a decision threshold.
MAX_REACH = 4.0
#: Rim vertices (evenly spaced) whose arcs are followed, per loop.
ARCS_PER_LOOP = 48
#: Samples per arc.
ARC_SAMPLES = 96
#: Lateral slack of a landing, per unit of arc length travelled (about 9°):
#: the one-ring curvature and direction estimates at a rim are this
#: accurate on the meshes tested (tori, cylinders, ellipsoids, scans).
SIGHT_SLACK = 0.15
#: Rim vertices this many steps along the loop from an arc's own vertex are
#: where the arc starts, not where it lands.
SELF_SKIP = 2


def continuation_arcs(V, F_near, loop, smooth=2):
    """Where the scan heads at each rim vertex, as an osculating circle.

    Parameters
    ----------
    V : (n,3) float64
    F_near : (r,3) int64
        Scan faces within three rings of the loop (every face of the
        vertices two rings off it).
    loop : (k,) int64
    smooth : int
        Tangents, normals and curvatures are averaged over ``2*smooth+1``
        consecutive rim vertices.

    Returns
    -------
    U : (k,3) float64
        Base point ``q1``: mean of the rim vertex's neighbours one ring off
        the loop.
    Tn : (k,3) float64
        Unit direction of the scan at the base, towards the rim.
    Nn : (k,3) float64
        Unit scan normal at the base.
    kappa : (k,) float64
        Normal curvature along ``Tn`` (positive: bends towards ``Nn``).
    s0 : (k,) float64
        Arc length from the base to the rim vertex.
    ok : (k,) bool
        The vertex has neighbours one and two rings off the loop.

    Notes
    -----
    ``q2`` is the mean of the vertices two rings off the loop next to those
    ring-one neighbours, ``n1`` and ``n2`` the mean vertex normals there.
    The arc leaves ``q1`` parallel to ``p - q2`` (projected on the tangent
    plane) with the normal curvature ``κ = -(n1 - n2)·t / ((q1 - q2)·t)``
    (Weingarten: the normal turns by ``-κ`` per unit length along ``t``);
    the median over ``2*smooth+1`` rim vertices is taken. Averaging over each ring
    cancels most of the sideways spread of the neighbours; what is left
    (a skewed triangulation's) is removed by projecting ``q1`` and ``q2`` on
    the plane through ``p`` normal to the loop, so the circle lies across
    the rim.
    """
    return _continuation_arcs_many(V, [F_near], [loop], smooth)[0]


def _continuation_arcs_many(V, F_nears, loops, smooth=2):
    """:func:`continuation_arcs` of several loops at once (the one
    implementation: a single loop is a batch of one).

    Each loop keeps its own copy of the vertices around it (a block of one
    block-diagonal adjacency), so every sparse product, sum and median is
    the one-loop computation with its operands in the same order, run once
    for all loops instead of once per loop (a loop's arcs cost mostly the
    fixed cost of some twenty SciPy calls).

    Parameters
    ----------
    V : (n,3) float64
    F_nears : list of (r,3) int64
        Per loop, its ``F_near``.
    loops : list of (k,) int64
    smooth : int

    Returns
    -------
    arcs : list of tuple
        Per loop, what :func:`continuation_arcs` returns for it.
    """
    if not loops:
        return []
    *cols, bounds = _continuation_arcs_cat(V, F_nears, loops, smooth)
    return [tuple(x[bounds[i]:bounds[i + 1]] for x in cols) for i in range(len(bounds) - 1)]


def _continuation_arcs_cat(V, F_nears, loops, smooth=2):
    """:func:`_continuation_arcs_many` with the loops' rows concatenated.

    Returns
    -------
    U, T, N, kappa, s0, ok : arrays of ``sum(len(loop))`` rows
        What :func:`continuation_arcs` returns, loop after loop.
    bounds : (len(loops)+1,) int64
        Loop ``i``'s rows are ``bounds[i]:bounds[i+1]``.
    """
    n = np.int64(len(V))
    loops = [np.asarray(lp, np.int64) for lp in loops]
    F_nears = [np.asarray(f, np.int64).reshape(-1, 3) for f in F_nears]
    sizes = np.array([len(lp) for lp in loops], np.int64)
    Fcat = np.concatenate(F_nears)
    loopcat = np.concatenate(loops)
    if compiled.ENABLED:
        ukey, L, li = bridge_kernels.block_ids(Fcat, [len(f) for f in F_nears], loopcat, sizes, n)
    else:
        lid_f = np.repeat(np.arange(len(loops), dtype=np.int64), [len(f) for f in F_nears])
        lid_p = np.repeat(np.arange(len(loops), dtype=np.int64), sizes)
        fkey = lid_f[:, None] * n + Fcat
        pkey = lid_p * n + loopcat
        ukey = np.unique(np.concatenate([fkey.ravel(), pkey]))       # per loop its sorted vertices, loop by loop
        L = np.searchsorted(ukey, fkey)
        li = np.searchsorted(ukey, pkey)
    nv = len(ukey)
    E = np.concatenate([L[:, [0, 1]], L[:, [1, 2]], L[:, [2, 0]]])
    level = np.full(nv, 3, np.int64)
    level[li] = 0
    ring1 = _next_to(E, level == 0) & (level > 0)     # the adjacency's rows li meet these columns
    level[ring1] = 1
    ring2 = _next_to(E, ring1) & (level > 1)
    level[ring2] = 2
    X = V[ukey % n]
    # area-weighted vertex normals, summed block by block
    if compiled.ENABLED:
        acc = bridge_kernels.corner_normal_sums(L, Fcat, V, nv)
    else:
        Nf = np.cross(V[Fcat[:, 1]] - V[Fcat[:, 0]], V[Fcat[:, 2]] - V[Fcat[:, 0]])
        acc = np.zeros((nv, 3))
        for c in range(3):
            np.add.at(acc, L[:, c], Nf)
    ln = np.linalg.norm(acc, axis=1, keepdims=True)
    Nv = np.divide(acc, ln, out=np.zeros_like(acc), where=ln > 0)
    sums = bridge_kernels.ring_sums if compiled.ENABLED else _ring_sums
    s1, c1, N, s2, c2, N2 = sums(E, li, level, X, Nv)
    ok = (c1 > 0) & (c2 > 0)
    q1 = s1 / np.maximum(c1, 1)[:, None]
    q2 = s2 / np.maximum(c2, 1)[:, None]
    P = V[loopcat]
    start = np.repeat(np.cumsum(sizes) - sizes, sizes)
    pos = np.arange(len(loopcat)) - start
    k_of = np.repeat(sizes, sizes)

    def shifted(d):   # rows of np.roll(Y, d, axis=0) within each loop
        return start + (pos - d) % k_of

    tau = P[shifted(-1)] - P[shifted(1)]
    tau = tau / np.maximum(np.linalg.norm(tau, axis=1, keepdims=True), 1e-300)
    q1 = q1 - np.sum((q1 - P) * tau, axis=1)[:, None] * tau
    q2 = q2 - np.sum((q2 - P) * tau, axis=1)[:, None] * tau
    a, b, c = q1 - q2, P - q1, P - q2
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    ok &= (la > 0) & (lb > 0) & (lc > 0)
    N = N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)
    N2 = N2 / np.maximum(np.linalg.norm(N2, axis=1, keepdims=True), 1e-300)
    T = np.divide(c, lc[:, None], out=np.zeros_like(c), where=lc[:, None] > 0)
    step = np.sum(a * T, axis=1)
    kap = np.where(np.abs(step) > 0, -np.sum((N - N2) * T, axis=1) / np.where(step != 0, step, 1.0), 0.0)
    ok &= step > 0
    s0 = lb
    sm = (k_of > 2 * smooth + 1) if smooth else np.zeros(len(loopcat), bool)
    if sm.any():
        r = np.flatnonzero(sm)
        shifts = [shifted(d)[r] for d in range(-smooth, smooth + 1)]

        def ring_sum(Y):
            return sum(Y[ix] for ix in shifts)
        Nn = ring_sum(N * ok[:, None])
        Nn = Nn / np.maximum(np.linalg.norm(Nn, axis=1, keepdims=True), 1e-300)
        kw = np.where(ok, kap, np.nan)
        km = _nanmedian_columns(np.stack([kw[ix] for ix in shifts]))
        kap = kap.copy()
        kap[r] = np.where(np.isfinite(km), km, 0.0)
        Ts = ring_sum(T * ok[:, None])
        T = T.copy()
        T[r] = Ts
        N = N.copy()
        N[r] = Nn
    rest = np.flatnonzero(~sm)
    if rest.size:
        N[rest] = N[rest] / np.maximum(np.linalg.norm(N[rest], axis=1, keepdims=True), 1e-300)
    T = T - np.sum(T * N, axis=1)[:, None] * N
    tl = np.linalg.norm(T, axis=1, keepdims=True)
    ok &= tl[:, 0] > 0
    T = np.divide(T, tl, out=np.zeros_like(T), where=tl > 0)
    bounds = np.concatenate([[0], np.cumsum(sizes)])
    return q1, T, N, kap, s0, ok, bounds


def _ring_sums(E, li, level, X, Nv):
    """Per rim vertex ``li[i]``: the sums of ``X`` and ``Nv`` over its
    neighbours at level 1, their count, and the same over the level-2
    neighbours of those (the rows of ``R1 = A[li]`` and ``R2 = R1 A``
    restricted to those levels, ``A`` the all-ones adjacency of the edges
    ``E``): as sparse products, each row summed in column order from zero
    (:func:`shellrepair.bridge_kernels.ring_sums` is the same sums compiled).

    Returns
    -------
    s1 : (p,3) float64, c1 : (p,) float64, n1 : (p,3) float64
    s2 : (p,3) float64, c2 : (p,) float64, n2 : (p,3) float64
    """
    import scipy.sparse as sp

    nv = len(level)
    A = sp.csr_matrix((np.ones(2 * len(E)), (np.concatenate([E[:, 0], E[:, 1]]), np.concatenate([E[:, 1], E[:, 0]]))),
                      shape=(nv, nv))
    A.data[:] = 1.0
    R1 = A[li].multiply((level == 1)[None]).tocsr()
    R1.eliminate_zeros()
    R2 = (R1 @ A).multiply((level == 2)[None]).tocsr()
    R2.eliminate_zeros()
    R2.data[:] = 1.0
    return R1 @ X, R1.sum(axis=1).A1, R1 @ Nv, R2 @ X, R2.sum(axis=1).A1, R2 @ Nv


def _next_to(E, mark):
    """The vertices joined by an edge of ``E`` (k,2) to a marked one: the
    columns the rows ``mark`` of the (symmetric, all ones) adjacency of
    ``E`` meet, without building the rows."""
    out = np.zeros(len(mark), bool)
    out[E[mark[E[:, 0]], 1]] = True
    out[E[mark[E[:, 1]], 0]] = True
    return out


def _nanmedian_columns(W):
    """``np.nanmedian(W, axis=0)`` bit for bit (NaN where a column is all
    NaN, without the warning), by one sort of a few rows: the masked-array
    route NumPy takes for short columns costs more than the median itself.

    As NumPy does it: NaN sorted behind everything (as +inf), the two
    middle values (the middle one twice for an odd count) summed from the
    reduction's identity +0.0 (so a median of -0.0 is +0.0), then halved.
    """
    isnan = np.isnan(W)
    filled = np.where(isnan, np.inf, W)
    srt = np.take_along_axis(filled, np.argsort(filled, axis=0), axis=0)
    c = W.shape[0] - np.count_nonzero(isnan, axis=0)
    h = c // 2
    lo = np.where(c % 2 == 1, h, h - 1)
    cols = np.arange(W.shape[1])
    with np.errstate(over="ignore", invalid="ignore"):
        m = ((0.0 + srt[lo, cols]) + srt[np.minimum(h, W.shape[0] - 1), cols]) / 2.0
    m[c == 0] = np.nan
    return m


def arc_points(U, T, N, kappa, s):
    """Points at arc length ``s`` along circles (straight lines where κ = 0).

    Parameters
    ----------
    U, T, N : (m,3) float64
        Base points, unit tangents, unit normals.
    kappa : (m,) float64
    s : (m,j) float64

    Returns
    -------
    X : (m,j,3) float64

    Notes
    -----
    ``x(s) = u + sin(κs)/κ t + (1 - cos(κs))/κ n``, written with ``sinc`` so
    that it is exact and stable as κ → 0.
    """
    ks = kappa[:, None] * s
    a = s * np.sinc(ks / np.pi)                                  # sin(κs)/κ
    b = 0.5 * kappa[:, None] * s ** 2 * np.sinc(ks / (2 * np.pi)) ** 2  # (1 - cos κs)/κ
    return U[:, None] + a[..., None] * T[:, None] + b[..., None] * N[:, None]


def loop_sights(V, loops, faces_near, *, candidates=None, max_reach=MAX_REACH, n_arcs=ARCS_PER_LOOP,
                n_samples=ARC_SAMPLES, slack=SIGHT_SLACK, arcs_out=None):
    """Which loop each loop's continuation arcs land on first.

    Parameters
    ----------
    V : (n,3) float64
    loops : list of Loop
        With ``vertices``, ``diameter``, ``mean_edge``; every loop that
        can stop an arc (holes and borders).
    faces_near : callable
        ``faces_near(loop_vertices)`` -> scan faces within three rings.
    candidates : iterable of int, optional
        Indices of the loops whose arcs are followed (default all).
    arcs_out : dict, optional
        Filled with each followed loop's :func:`continuation_arcs` (by
        index), for a caller that reads them again (:func:`wrapped_pairs`).

    Returns
    -------
    sights : dict of int -> (counts (len(loops),) int64, n_arcs int)
        Per followed loop: how many of its arcs landed first on each loop
        (its own far side included).
    """
    if not loops:
        return {}
    sizes = np.array([len(L.vertices) for L in loops], np.int64)
    allv = np.concatenate([np.asarray(L.vertices, np.int64) for L in loops])
    owner = np.repeat(np.arange(len(loops)), sizes)
    place = np.arange(len(allv)) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    edge = np.array([L.mean_edge for L in loops], np.float64)
    follow = [a for a in (range(len(loops)) if candidates is None else candidates)
              if len(loops[a].vertices) >= 2 * SELF_SKIP + 2]
    if not follow:
        return {}
    rims = [np.asarray(loops[a].vertices, np.int64) for a in follow]
    *cols, bounds = _continuation_arcs_cat(V, [faces_near(lp) for lp in rims], rims)
    if arcs_out is not None:
        arcs_out.update((a, tuple(x[bounds[i]:bounds[i + 1]] for x in cols)) for i, a in enumerate(follow))
    # per followed loop with arcs: its evenly spaced arcs (rows), all loops'
    # rows together; every quantity below is per row or per sample, so it
    # is what the loop alone gives
    ok = cols[5]
    rows = np.flatnonzero(ok)
    nok = np.add.reduceat(ok, bounds[:-1]).astype(np.int64)      # every followed loop has vertices
    keep = np.ones(len(rows), bool)
    picks = {}
    ok_first = np.cumsum(nok) - nok
    for i in np.flatnonzero(nok > n_arcs).tolist():
        c = int(nok[i])
        if c not in picks:
            picks[c] = np.linspace(0, c - 1, n_arcs).round().astype(np.int64)
        keep[ok_first[i]:ok_first[i] + c] = False
        keep[ok_first[i] + picks[c]] = True
    has = np.flatnonzero(nok > 0)
    if has.size == 0:
        return {}
    rows = rows[keep]
    fol = np.asarray(follow, np.int64)
    ent_a = fol[has]
    m = np.bincount(np.repeat(np.arange(len(follow)), nok)[keep], minlength=len(follow))[has]
    first = np.concatenate([[0], np.cumsum(m)])
    U, T, N, kap, s0 = (x[rows] for x in cols[:5])
    reach = np.repeat([max_reach * max(loops[a].diameter, 1e-300) for a in ent_a.tolist()], m)
    turn = np.where(np.abs(kap) > 0, 2 * np.pi / np.maximum(np.abs(kap), 1e-300), np.inf)
    length = np.minimum(reach, turn)
    # only an arc's first landing counts (see _landings_numpy)
    ent = np.repeat(np.arange(len(ent_a)), m)
    arow = np.repeat(ent_a, m)
    krow = np.repeat(sizes[ent_a], m)
    irow = rows - np.repeat(bounds[:-1][has], m)
    status, trees = -1, []

    def tree_of(P):      # one cKDTree of the rim vertices, built when first needed
        if not trees:
            trees.append(cKDTree(P))
        return trees[0]

    if compiled.ENABLED:
        landed, status = bridge_kernels.arc_landings(U, T, N, kap, s0, length, n_samples, slack, ent, len(ent_a), V[allv],
                                              owner, place, edge, arow, krow, irow, SELF_SKIP,
                                              rank_of=lambda P: _leaf_rank(tree_of(P)))
    if status != 0:
        landed = _landings_numpy(U, T, N, kap, s0, length, n_samples, slack, ent, first, tree_of(V[allv]),
                                 owner, place, edge, arow, krow, irow)
    out = {}
    for e, a in enumerate(ent_a.tolist()):
        got = landed[first[e]:first[e + 1]]
        out[a] = (np.bincount(got[got >= 0], minlength=len(loops)), int(m[e]))
    return out


def _leaf_rank(tree):
    """Each point's position in a ``cKDTree``'s leaf order (``tree.indices``):
    of points at one place, the tree's query keeps the first."""
    rank = np.empty(len(tree.indices), np.int64)
    rank[tree.indices] = np.arange(len(tree.indices))
    return rank


def _landings_numpy(U, T, N, kap, s0, length, n_samples, slack, ent, first, tree, owner, place, edge, arow, krow,
                    irow):
    """The loop each arc lands on first (-1: none), the NumPy version of
    :func:`shellrepair.bridge_kernels.arc_landings` (its oracle; arguments as
    there, ``first`` the followed loops' first rows and ``tree`` a
    ``cKDTree`` of the rim vertices).

    Samples are looked up from the rim outwards, in growing runs, and an
    arc stops at its first landing (a sample's lookup does not depend on
    which others are asked with it); a run's samples of all arcs still
    going are made (:func:`arc_points` is per sample) and looked up
    together, bounded by the largest loop's bound: a sample's nearest rim
    vertex is the same under any bound that reaches it, and one beyond its
    own loop's bound is no landing.
    """
    frac = np.arange(1, n_samples + 1) / n_samples
    s = s0[:, None] + length[:, None] * frac[None]
    h = (length / n_samples)[:, None]
    tol = h + slack * (s - s0[:, None])                       # (m, j) without the target's edge
    bound = np.maximum.reduceat(tol.max(axis=1), first[:-1]) + edge.max()
    landed = np.full(len(irow), -1, np.int64)
    rows = np.arange(len(irow))
    for c0, c1 in _sample_runs(n_samples):
        if rows.size == 0:
            break
        w = c1 - c0
        X = arc_points(U[rows], T[rows], N[rows], kap[rows], s[rows, c0:c1])
        rb = bound[ent[rows]]
        d, j = tree.query(X.reshape(-1, 3), distance_upper_bound=float(rb.max()))
        d = d.reshape(rows.size, w)
        j = j.reshape(rows.size, w)
        found = np.isfinite(d) & (d < rb[:, None])
        jj = np.where(found, j, 0)
        who = owner[jj]
        hit = found & (d <= tol[rows, c0:c1] + edge[who])
        # the arc's own start: rim vertices next to its vertex on its own loop
        gap = np.abs(place[jj] - irow[rows, None])
        gap = np.minimum(gap, krow[rows, None] - gap)
        hit &= ~((who == arow[rows, None]) & (gap <= SELF_SKIP))
        done = hit.any(axis=1)
        landed[rows[done]] = who[done, np.argmax(hit[done], axis=1)]
        rows = rows[~done]
    return landed


def _sample_runs(n):
    """Column ranges ``[c0, c1)`` covering ``range(n)``: 8, 8, 16, 32, ... wide."""
    out, c0, w = [], 0, 8
    while c0 < n:
        out.append((c0, min(n, c0 + w)))
        c0 += w
        w = 8 if c0 < 16 else 2 * w
    return out


def band_pairs(sights, eligible):
    """Pairs of loops that see each other (either way), best first.

    Parameters
    ----------
    sights : dict of int -> (counts, n_arcs)
        From :func:`loop_sights`.
    eligible : (len(loops),) bool
        Loops that may be bridged (classed ``hole``).

    Returns
    -------
    pairs : list of (i, j, score, mutual)
        ``i < j``; each loop appears at most once; score is the larger
        fraction of arcs one loop sends to the other (> 1/2); ``mutual``
        when each loop sends most of its arcs to the other.
    """
    eligible = np.asarray(eligible, bool)
    sees = {}
    for a, (counts, m) in sights.items():
        if not eligible[a] or m == 0:
            continue
        c = counts.astype(np.float64)
        c[a] = -1
        c[~eligible] = -1
        b = int(np.argmax(c))
        if 2 * c[b] > m:                      # a strict majority of a's arcs land on b
            sees[a] = (b, c[b] / m)
    cand = {}
    for a, (b, f) in sees.items():
        key = (min(a, b), max(a, b))
        mutual = sees.get(b, (None,))[0] == a
        cand[key] = (max(cand.get(key, (0.0,))[0], f), mutual)
    order = sorted(cand.items(), key=lambda kv: (not kv[1][1], -kv[1][0], kv[0]))
    used, pairs = set(), []
    for (i, j), (sc, mutual) in order:
        if i in used or j in used:
            continue
        used.update((i, j))
        pairs.append((i, j, float(sc), bool(mutual)))
    return pairs


def pants_triples(sights, eligible, touching=()):
    """Waists and legs: triples of loops that bound one missing region.

    Parameters
    ----------
    sights : dict of int -> (counts, n_arcs)
        From :func:`shellrepair.bridge.loop_sights`.
    eligible : (len(loops),) bool
        Loops that may be joined (classed ``hole``).
    touching : set of (int, int)
        Loops that share a vertex (never joined).

    Returns
    -------
    triples : list of (a, b, c)
        Waist ``a`` and legs ``b < c``; each loop in at most one triple,
        the triple whose legs send the larger share of their arcs to the
        waist first.
    """
    eligible = np.asarray(eligible, bool)

    def majority_on(x):
        counts, m = sights[x]
        c = counts.astype(np.float64)
        c[x] = -1
        c[~eligible] = -1
        y = int(np.argmax(c))
        return (y, c[y] / m) if m and 2 * c[y] > m else (None, 0.0)

    legs = {}
    for x in sights:
        if not eligible[x]:
            continue
        y, f = majority_on(x)
        if y is not None and (x, y) not in touching:
            legs.setdefault(y, []).append((f, x))
    cand = []
    for a, ls in legs.items():
        if a not in sights or not eligible[a] or len(ls) < 2:
            continue
        counts, m = sights[a]
        ls = sorted(ls, reverse=True)
        # the two legs that take the most of the waist's arcs
        best = sorted(ls, key=lambda t: (-int(counts[t[1]]), -t[0], t[1]))[:2]
        (fb, b), (fc, c) = best
        if (b, c) in touching or not (counts[b] and counts[c]) or 2 * int(counts[b] + counts[c]) <= m:
            continue
        cand.append((min(fb, fc), a, min(b, c), max(b, c)))
    used, out = set(), []
    for _, a, b, c in sorted(cand, key=lambda t: (-t[0], t[1:])):
        if {a, b, c} & used:
            continue
        used.update((a, b, c))
        out.append((a, b, c))
    return out


def _arclength(P):
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    t = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    return t / max(seg.sum(), 1e-300)


def _facing_order(PA, PB):
    """Indices of PB walked backwards from the cyclic shift that best matches
    PA by arc length (the second loop's vertices in the first loop's sense)."""
    kb = len(PB)
    rev = np.arange(kb)[::-1]
    ta = _arclength(PA)
    best = (np.inf, 0)
    shifts = range(kb) if kb <= 512 else np.linspace(0, kb - 1, 512).astype(int)
    for s in shifts:
        order = np.roll(rev, -s)
        Q = PB[order]
        tb = _arclength(Q)
        j = np.minimum(np.searchsorted(tb, ta), kb - 1)
        cost = np.linalg.norm(PA - Q[j], axis=1).sum()
        if cost < best[0]:
            best = (cost, s)
    return np.roll(rev, -best[1])


def _zip(ta, tc, ia, ic):
    """Triangles zipping two rings walked the same way round, advancing the
    side whose next vertex comes first by (normalised) arc length ``ta``,
    ``tc``; ``ia``, ``ic`` are the rings' vertex indices.

    The walk is a merge of the two rings' next parameters (ties to ``ia``):
    where both run upwards, each step's place comes from one
    ``searchsorted``; else (round-off past 1, NaN) :func:`_zip_walk` takes
    the steps one by one. The triangles are the same either way."""
    ka, kc = len(ia), len(ic)
    na = np.append(np.asarray(ta, np.float64)[1:ka], 1.0)   # A's next parameter at each A step
    nc = np.append(np.asarray(tc, np.float64)[1:kc], 1.0)
    if not (na.size == ka and nc.size == kc and np.all(na[1:] >= na[:-1]) and np.all(nc[1:] >= nc[:-1])):
        return _zip_walk(ta, tc, ia, ic)
    ia, ic = np.asarray(ia, np.int64), np.asarray(ic, np.int64)
    ca = np.searchsorted(nc, na, side="left")    # C steps taken before A step i
    cc = np.searchsorted(na, nc, side="right")   # A steps taken before C step t
    i, t = np.arange(ka), np.arange(kc)
    tris = np.empty((ka + kc, 3), np.int64)
    tris[i + ca] = np.column_stack([ia, ic[ca % kc], ia[(i + 1) % ka]])
    tris[t + cc] = np.column_stack([ia[cc % ka], ic, ic[(t + 1) % kc]])
    return tris


def _zip_walk(ta, tc, ia, ic):
    """:func:`_zip` one step at a time (any parameters)."""
    ka, kc = len(ia), len(ic)
    tris = []
    i = t = 0
    while i < ka or t < kc:
        a0, a1 = ia[i % ka], ia[(i + 1) % ka]
        c0, c1 = ic[t % kc], ic[(t + 1) % kc]
        if i == ka:
            adv_a = False
        elif t == kc:
            adv_a = True
        else:
            na = ta[i + 1] if i + 1 < ka else 1.0
            nc = tc[t + 1] if t + 1 < kc else 1.0
            adv_a = na <= nc
        if adv_a:
            tris.append((a0, c0, a1))
            i += 1
        else:
            tris.append((a0, c0, c1))
            t += 1
    return np.array(tris, np.int64)


def tube_triangles(PA, PB):
    """Zip two facing loops into a closed strip of triangles.

    Parameters
    ----------
    PA : (ka,3) float64
        First loop, in its boundary half-edge order.
    PB : (kb,3) float64
        Second loop, in its own boundary half-edge order.

    Returns
    -------
    T : (ka+kb,3) int64
        Triangles over the concatenated positions ``[PA; PB]``, oriented
        consistently with both loops' scan faces (each loop edge appears
        reversed).
    """
    ka = len(PA)
    order = _facing_order(PA, PB)
    return _zip(_arclength(PA), _arclength(PB[order]), np.arange(ka), order + ka)


def _lerp_loop(t, X, u):
    """Values ``X`` (k,...) given at loop parameters ``t`` (k,) increasing
    from 0, interpolated at ``u`` in [0, 1) cyclically."""
    k = len(t)
    tt = np.concatenate([t, [1.0]])
    j = np.clip(np.searchsorted(tt, u, side="right") - 1, 0, k - 1)
    f = (u - tt[j]) / np.maximum(tt[j + 1] - tt[j], 1e-300)
    f = f.reshape((-1,) + (1,) * (X.ndim - 1))
    return (1 - f) * X[j] + f * X[(j + 1) % k]


def _lerp_arcs(t, arcs, u):
    """:func:`_lerp_loop` of each of the arrays ``arcs`` (k,) or (k,3) at
    ``u``, in one call on their columns side by side (the same numbers:
    every column is interpolated by itself)."""
    X = np.column_stack(arcs)
    L = _lerp_loop(t, X, u)
    out, c = [], 0
    for a in arcs:
        w = 1 if a.ndim == 1 else a.shape[1]
        out.append(L[:, c] if a.ndim == 1 else L[:, c:c + w])
        c += w
    return out


def _landing(arcs, P, targets, reach, n=128):
    """Per vertex: arc length along its continuation arc to the point
    nearest its target, and whether the arc gets nearer to it than half the
    straight chord (else the arc is replaced by the chord)."""
    U, T, N, kap, s0, ok = arcs
    chord = np.linalg.norm(targets - P, axis=1)
    turn = np.where(np.abs(kap) > 0, 2 * np.pi / np.maximum(np.abs(kap), 1e-300), np.inf)
    length = np.minimum(np.maximum(reach, 2 * chord), turn)
    s = s0[:, None] + length[:, None] * (np.arange(1, n + 1) / n)[None]
    X = arc_points(U, T, N, kap, s)
    d = np.linalg.norm(X - targets[:, None], axis=2)
    j = np.argmin(d, axis=1)
    S = s[np.arange(len(P)), j] - s0
    good = ok & (d[np.arange(len(P)), j] <= 0.5 * chord)
    return S, good


def guide_tube(PA, PB, arcs_a, arcs_b, spacing, reach, rings=False):
    """A first tube between two loops that follows both loops' continuation
    arcs, with rings of vertices about ``spacing`` apart.

    Parameters
    ----------
    PA, PB : (ka,3), (kb,3) float64
        The loops, each in its boundary half-edge order.
    arcs_a, arcs_b : tuple
        :func:`continuation_arcs` of each loop.
    spacing : float
        Target distance between rings (the rim's edge length).
    reach : float
        How far arcs are followed looking for the other loop.
    rings : bool
        Also return the rings' parameters (for :func:`resample_tube`).

    Returns
    -------
    P : (q,3) float64
        Positions of the new ring vertices.
    T : (t,3) int64
        Triangles over ``[PA; PB; P]``, oriented like :func:`tube_triangles`.
    params : list of arrays, only with ``rings``
        Arc-length parameter in [0, 1) of each vertex of each ring, from
        loop A (its own) through the new rings (in the order of ``P``) to
        loop B walked in A's sense; None when the tube has no new rings.
    order : (kb,) int64, only with ``rings``
        Loop B's vertices in that sense (:func:`_facing_order`).

    Notes
    -----
    Rim vertex ``a`` whose zip partner on the other loop is ``b`` (same
    arc-length parameter) gets its arc length ``S_a`` to the arc's point
    nearest ``b`` (a straight chord where its arc misses ``b``). The ring at
    ``τ ∈ (0, 1)`` is the blend ``(1 - w) x_a(τ S_a) + w x_b((1 - τ) S_b)``,
    ``w = 3τ² - 2τ³``: exact for a cylinder (straight arcs) and for a torus
    (both arcs the same circle).
    """
    ka, kb = len(PA), len(PB)
    order = _facing_order(PA, PB)
    C = PB[order]
    arcs_c = tuple(x[order] for x in arcs_b)
    ta, tc = _arclength(PA), _arclength(C)
    to_c = _lerp_loop(tc, C, ta)                    # partner of each A vertex on C
    to_a = _lerp_loop(ta, PA, tc)
    Sa, ga = _landing(arcs_a, PA, to_c, reach)
    Sc, gc = _landing(arcs_c, C, to_a, reach)

    def repair(arcs, t, P, Q, S, good):
        """Arcs that miss their partner take the direction, normal,
        curvature and length of the nearest arcs that do (by arc-length
        parameter); if none does, the straight chord."""
        U, T, N, kap, s0, ok = (np.array(x, copy=True) for x in arcs)
        S = np.array(S, copy=True)
        bad = ~good
        if not bad.any():
            return U, T, N, kap, s0, S
        if good.sum() >= 2:
            g = np.flatnonzero(good)
            tg = np.concatenate([t[g] - 1.0, t[g], t[g] + 1.0])
            for X in (T, N, kap, S):
                Y = np.concatenate([X[g]] * 3)
                if X.ndim == 1:
                    X[bad] = np.interp(t[bad], tg, Y)
                else:
                    for c in range(X.shape[1]):
                        X[bad, c] = np.interp(t[bad], tg, Y[:, c])
            N[bad] /= np.maximum(np.linalg.norm(N[bad], axis=1, keepdims=True), 1e-300)
            T[bad] -= np.sum(T[bad] * N[bad], axis=1)[:, None] * N[bad]
            T[bad] /= np.maximum(np.linalg.norm(T[bad], axis=1, keepdims=True), 1e-300)
            # the borrowed arc starts at the rim vertex itself, turned by
            # the borrowed curvature over the borrowed base-to-rim length
            s0g = np.interp(t[bad], tg, np.concatenate([s0[g]] * 3))
            ang = (kap[bad] * s0g)[:, None]
            Tb, Nb = T[bad].copy(), N[bad].copy()
            T[bad] = np.cos(ang) * Tb + np.sin(ang) * Nb
            N[bad] = -np.sin(ang) * Tb + np.cos(ang) * Nb
            U[bad], s0[bad] = P[bad], 0.0
            S[bad] = np.maximum(S[bad] - s0g, 0.0)
            return U, T, N, kap, s0, S
        D = Q - P
        ln = np.maximum(np.linalg.norm(D, axis=1), 1e-300)
        return P, D / ln[:, None], np.zeros_like(P), np.zeros(len(P)), np.zeros(len(P)), ln

    Ua, Ta, Na, Ka, S0a, Sa = repair(arcs_a, ta, PA, to_c, Sa, ga)
    Uc, Tc, Nc, Kc, S0c, Sc = repair(arcs_c, tc, C, to_a, Sc, gc)
    length = 0.5 * (float(np.mean(Sa)) + float(np.mean(Sc)))
    M = int(max(0, round(length / max(spacing, 1e-300)) - 1))
    if M == 0:
        T = _zip(ta, tc, np.arange(ka), order + ka)     # tube_triangles(PA, PB)
        return (np.zeros((0, 3)), T, None, order) if rings else (np.zeros((0, 3)), T)
    want_rings, rings, params, ids = rings, [], [ta], [np.arange(ka)]
    base = ka + kb
    side_a, side_c = (Ua, Ta, Na, Ka, S0a, Sa), (Uc, Tc, Nc, Kc, S0c, Sc)

    def at(u):
        """Both sides' arcs interpolated at ring parameters ``u``."""
        return _lerp_arcs(ta, side_a, u), _lerp_arcs(tc, side_c, u)

    def ring(tau, arcs_u):
        (U, T, N, K, S0, S), (Uo, To, No, Ko, S0o, So) = arcs_u
        w = 3 * tau ** 2 - 2 * tau ** 3
        XA = arc_points(U, T, N, K, (S0 + tau * S)[:, None])[:, 0]
        XC = arc_points(Uo, To, No, Ko, (S0o + (1 - tau) * So)[:, None])[:, 0]
        return (1 - w) * XA + w * XC

    fine = max(ka, kb)
    at_fine = at(np.arange(fine) / fine)   # the same parameters for every ring's first try
    for r in range(1, M + 1):
        tau = r / (M + 1)
        # as many vertices as the ring's length holds at ``spacing`` (at
        # most the finer loop's count): triangles stay about as long as wide
        X = ring(tau, at_fine)
        m = _ring_count(X, spacing, fine)
        u = np.arange(m) / m
        rings.append(X if m == fine else ring(tau, at(u)))
        params.append(u)
        ids.append(base + np.arange(m))
        base += m
    params.append(tc)
    ids.append(order + ka)
    T = np.vstack([_zip(params[r], params[r + 1], ids[r], ids[r + 1]) for r in range(M + 1)])
    if want_rings:
        return np.vstack(rings), T, params, order
    return np.vstack(rings), T


def _ring_count(X, spacing, fine):
    """Vertices of a tube ring through the closed polyline ``X``: as many as
    its length holds at ``spacing``, at least 3 and at most ``fine``."""
    length = float(np.linalg.norm(np.roll(X, -1, axis=0) - X, axis=1).sum())
    return int(np.clip(round(length / max(spacing, 1e-300)), 3, fine))


def resample_tube(PA, PB, params, order, P, spacing):
    """A tube over the surface of another one, with rings ``spacing`` apart.

    The tube ``P`` (positions of a :func:`guide_tube` built with a coarser
    spacing, typically faired) is read as a surface swept from loop A to
    loop B: along each of ``max(ka, kb)`` evenly spaced loop parameters
    ``u`` the rings are joined by a polyline, and the new rings are placed
    at equal fractions of its length, as many as the mean length holds at
    ``spacing``; each new ring gets as many vertices as its length holds
    (at most the finer loop's count), as :func:`guide_tube` does. The new
    tube follows the coarse one's shape, not the arcs: its size is that of
    the surface it spans.

    Parameters
    ----------
    PA, PB : (ka,3), (kb,3) float64
        The loops, each in its boundary half-edge order.
    params, order
        As :func:`guide_tube` returns them with ``rings=True`` (``params``
        not None).
    P : (q,3) float64
        Positions of that tube's new vertices (in its order).
    spacing : float
        Target distance between rings (the rim's edge length).

    Returns
    -------
    P2 : (q2,3) float64
    T2 : (t2,3) int64
        Triangles over ``[PA; PB; P2]``, oriented like :func:`guide_tube`'s.
    """
    ka = len(PA)
    C = np.asarray(PB, np.float64)[order]
    fine = max(ka, len(C))
    us = np.arange(fine) / fine
    sizes = [len(p) for p in params[1:-1]]
    Xr = np.split(np.asarray(P, np.float64), np.cumsum(sizes)[:-1])
    Y = np.stack([_lerp_loop(params[0], PA, us)] + [_lerp_loop(p, X, us) for p, X in zip(params[1:-1], Xr)]
                 + [_lerp_loop(params[-1], C, us)])            # (rings, fine, 3): the sweep
    seg = np.linalg.norm(np.diff(Y, axis=0), axis=2)
    cum = np.vstack([np.zeros(fine), np.cumsum(seg, axis=0)])  # length along each sweep line
    M = int(max(0, round(float(cum[-1].mean()) / max(spacing, 1e-300)) - 1))
    if M == 0:
        return np.zeros((0, 3)), _zip(params[0], params[-1], np.arange(ka), order + ka)
    cols = np.arange(fine)
    rings, ps, ids = [], [params[0]], [np.arange(ka)]
    base = ka + len(C)
    for r in range(1, M + 1):
        s = (r / (M + 1)) * cum[-1]
        j = np.minimum((cum[1:] <= s[None]).sum(axis=0), len(Y) - 2)  # segment of each line holding s
        w = np.clip((s - cum[j, cols]) / np.maximum(seg[j, cols], 1e-300), 0.0, 1.0)
        Z = (1 - w)[:, None] * Y[j, cols] + w[:, None] * Y[j + 1, cols]
        m = _ring_count(Z, spacing, fine)
        u = np.arange(m) / m
        rings.append(Z if m == fine else _lerp_loop(us, Z, u))
        ps.append(u)
        ids.append(base + np.arange(m))
        base += m
    ps.append(params[-1])
    ids.append(order + ka)
    T = np.vstack([_zip(ps[r], ps[r + 1], ids[r], ids[r + 1]) for r in range(M + 1)])
    return np.vstack(rings), T

class Band(NamedTuple):
    """Two ``hole`` loops bounding one missing band (:func:`find_bands`)."""
    A: object              # shellrepair.holes.Loop
    B: object
    score: float
    mutual: bool = False   # each loop sends most of its arcs to the other
    wrapped: bool = False  # paired as wrapping one tube (:func:`wrapped_pairs`)


class Bands(NamedTuple):
    """What :func:`find_bands` found: the pairs, and the three-loop regions."""
    pairs: list
    triples: list


def find_bands(ctx, scan):
    """Pairs of ``hole`` loops whose continuation arcs land on each other.

    Only loops classed ``hole`` are paired (a border is never bridged);
    borders still stop arcs. Only loops with another loop within reach of
    their arcs (``MAX_REACH`` diameters) have their arcs followed. Loops
    that share a vertex are never paired. Hole loops left unpaired by their
    arcs may still be paired as wrapping one tube (:func:`wrapped_pairs`).
    Reads the scan only (nothing is written on ``ctx``).

    Returns
    -------
    Bands
        ``pairs``: a :class:`Band` per pair; ``triples``: ``(waist, leg,
        leg, bands)`` per region bounded by three loops
        (:func:`pants_triples`; ``bands`` those among them, the pants'
        fallback), whose loops are in no pair.
    """
    loops = scan.loops
    hole = np.array([L.kind == "hole" for L in loops], bool)
    if hole.sum() < 2:
        return Bands([], [])
    ids = np.flatnonzero(hole)
    centres = np.array([ctx.V[loops[i].vertices].mean(axis=0) for i in ids])
    radius = np.array([0.5 * loops[i].diameter for i in ids])
    reach = radius + MAX_REACH * 2 * radius
    tree = cKDTree(centres)
    # holes with another hole within reach of their arcs (all queries at once)
    near = tree.query_ball_point(centres, reach + radius.max())
    row = np.repeat(np.arange(len(ids)), [len(x) for x in near])
    nb = np.concatenate([np.asarray(x, np.int64) for x in near])
    ok = (nb != row) & (np.linalg.norm(centres[nb] - centres[row], axis=1) <= reach[row] + radius[nb])
    cand = [int(i) for i in ids[np.unique(row[ok])]]
    touching = _touching(loops, ids)
    cand = _with_partner(ctx, loops, cand, hole, touching)
    if not cand:
        return Bands([], [])
    arcs = {}
    sights = loop_sights(ctx.V, loops, lambda lp: ctx.F[ctx.ring_faces(lp, 3)], candidates=cand, arcs_out=arcs)
    # loops that touch (share a vertex, e.g. the pinched pieces of a slit)
    # are one opening split at a pinch, not the two ends of a band
    for a, (counts, m) in sights.items():
        for b in np.flatnonzero(counts).tolist():
            if b != a and ((a, b) in touching if hole[b] else
                           np.intersect1d(loops[a].vertices, loops[b].vertices).size):
                counts[b] = 0
    pairs = band_pairs(sights, hole)
    # pairs whose loops each send most of their arcs to the other (the fill
    # weighs their tube and caps differently: Band.mutual)
    mutual = {frozenset((loops[i].id, loops[j].id)) for i, j, _, m in pairs if m}
    # three loops bounding one region (shellrepair.pants): the pairs among
    # them are kept as the pants' fallback (a pair reaching out of the
    # triple leaves the triple to the pairs, as before)
    triples = []
    for tri in pants_triples(sights, hole, touching):
        inside = [t for t in pairs if t[0] in tri or t[1] in tri]
        if all(t[0] in tri and t[1] in tri for t in inside):
            pairs = [t for t in pairs if t not in inside]
            triples.append((tri, inside))
    used = {x for i, j, _, _ in pairs for x in (i, j)} | {x for tri, _ in triples for x in tri}
    rest = [a for a in sorted(sights) if a not in used and hole[a]]
    wrapped = []
    if len(rest) >= 2:
        wrapped = wrapped_pairs(ctx.V, loops, rest, lambda lp: ctx.F[ctx.ring_faces(lp, 3)], touching, arcs)
        pairs = pairs + wrapped
    # such a pair's caps are filled as the holes alone would be (Band.wrapped)
    wrapped = {frozenset((loops[i].id, loops[j].id)) for i, j, _, _ in wrapped}

    def band(i, j, sc):
        key = frozenset((loops[i].id, loops[j].id))
        return Band(loops[i], loops[j], sc, key in mutual, key in wrapped)

    return Bands([band(i, j, sc) for i, j, sc, _ in pairs],
                 [(*(loops[x] for x in tri), [band(i, j, sc) for i, j, sc, _ in inside]) for tri, inside in triples])


def wrapped_pairs(V, loops, ids, faces_near, touching=(), arcs=None):
    """Pairs of loops that wrap one handle (a thin tube, an arm) and face
    each other across the band missing between them, found from the scan at
    their rims where their continuation arcs do not pair them.

    A loop *wraps* when the scan meets the loop's best-fit plane steeply
    all round: at a strict majority of its rim vertices the scan normal
    (at the base of the continuation arc) is nearer the plane's radial
    direction (from the loop's centre to the vertex) than the plane's
    normal. The rim of a hole smaller than a hemisphere of the surface
    around it has normals along the plane's normal; the rim of a cut
    across a tube has them radial. Loop A *heads to* loop B when at a
    strict majority of A's rim vertices the scan arrives heading towards
    B's centre (``T·u > SIGHT_SLACK``, ``T`` the arc's direction, ``u``
    the unit vector from the vertex to the centre: within about 80°; a
    direction across the line to the centre is not heading to it): across
    a tube the scan on each side of the band heads into the band, towards
    the other side, while the two rims of a scan that is itself a band
    (two large holes) head away from each other.

    Arcs miss such a pair when the loops cross the tube obliquely: the arc
    leaves the rim along the scan's direction, mostly round the tube, with
    the tube's curvature, and the circle comes back round to the loop it
    left instead of following the tube (a helix) to the other loop.

    Parameters
    ----------
    V : (n,3) float64
    loops : list of Loop
    ids : list of int
        Indices of the ``hole`` loops not paired by their arcs.
    faces_near : callable
        As for :func:`loop_sights`.
    touching : set of (int, int)
        Loops that share a vertex (never paired).
    arcs : dict, optional
        Loops' :func:`continuation_arcs` already known (by index; from
        :func:`loop_sights`' ``arcs_out``); the others are computed.

    Returns
    -------
    pairs : list of (i, j, score, mutual)
        As :func:`band_pairs` (``mutual`` False: the fill compares the
        tube with the caps); score is the smaller of the two loops'
        fractions of rim vertices heading to the other. Each loop once,
        nearest centres first; loops farther apart than ``MAX_REACH`` times
        the larger diameter are not paired.
    """
    rims = [np.asarray(loops[a].vertices, np.int64) for a in ids]
    known = {} if arcs is None else arcs
    todo = [x for x, a in enumerate(ids) if a not in known]
    found = dict(zip(todo, _continuation_arcs_many(V, [faces_near(rims[x]) for x in todo],
                                                   [rims[x] for x in todo]))) if todo else {}
    info = {}
    for x, (a, lp) in enumerate(zip(ids, rims)):
        U, T, N, kap, s0, ok = found[x] if x in found else known[a]
        if ok.sum() < 3:
            continue
        P = V[lp]
        c = P.mean(axis=0)
        _, _, vt = np.linalg.svd(P - c, full_matrices=False)
        n = vt[2]
        R = (P - c) - ((P - c) @ n)[:, None] * n
        R /= np.maximum(np.linalg.norm(R, axis=1, keepdims=True), 1e-300)
        radial = np.abs(np.sum(N * R, axis=1)) > np.abs(N @ n)
        if 2 * np.count_nonzero(radial & ok) > np.count_nonzero(ok):
            info[a] = (c, P[ok], T[ok])
    keys = sorted(info)
    cand = []
    for x, a in enumerate(keys):
        for b in keys[x + 1:]:
            if (a, b) in touching:
                continue
            ca, cb = info[a][0], info[b][0]
            if np.linalg.norm(cb - ca) > MAX_REACH * max(loops[a].diameter, loops[b].diameter):
                continue
            fa, fb = _heading(info[a][2], info[a][1], cb), _heading(info[b][2], info[b][1], ca)
            if fa > 0.5 and fb > 0.5:
                cand.append((float(np.linalg.norm(cb - ca)), a, b, float(min(fa, fb))))
    used, pairs = set(), []
    for _, a, b, sc in sorted(cand):
        if a in used or b in used:
            continue
        used.update((a, b))
        pairs.append((a, b, sc, False))
    return pairs


def _heading(T, P, c):
    """Share of the rim vertices ``P`` whose scan direction ``T`` heads to
    the point ``c``: more than ``SIGHT_SLACK`` (the direction estimates'
    accuracy) towards it, so that a direction across the line to ``c``
    counts as not heading to it."""
    D = c - P
    D = D / np.maximum(np.linalg.norm(D, axis=1, keepdims=True), 1e-300)
    return float(np.mean(np.sum(T * D, axis=1) > SIGHT_SLACK))


def _touching(loops, ids):
    """Pairs ``(a, b)`` (both ways) of the loops ``ids`` that share a vertex."""
    allv = np.concatenate([np.asarray(loops[i].vertices, np.int64) for i in ids])
    owner = np.repeat(ids, [len(loops[i].vertices) for i in ids])
    order = np.argsort(allv, kind="stable")
    vs = allv[order]
    dup = np.flatnonzero(vs[1:] == vs[:-1])
    touching = set()
    by_v = {}
    for i in np.unique(np.concatenate([dup, dup + 1])).tolist():
        by_v.setdefault(int(vs[i]), set()).add(int(owner[order[i]]))
    for os_ in by_v.values():
        touching.update((x, y) for x in os_ for y in os_ if x != y)
    return touching


def _with_partner(ctx, loops, cand, hole, touching=None):
    """The loops of ``cand`` whose continuation arcs can land on another
    ``hole`` loop they do not touch; the others cannot see any loop that
    may be paired with them, so following their arcs changes no pair.

    A bound from the loop alone, with :func:`loop_sights`' defaults: the
    arc of rim vertex ``p`` starts at ``q1``, within the longest edge ``e``
    of the faces at the rim from ``p`` (``q1`` is a mean of ``p``'s
    neighbours, projected on a plane through ``p``), runs at most
    ``s0 + reach`` (``s0 ≤ e``, ``reach = MAX_REACH`` diameters) and a
    circle's chord is no longer than its arc; a landing is within
    ``reach / ARC_SAMPLES + SIGHT_SLACK reach`` plus the target's mean
    edge of a target vertex. So every landing on loop ``b`` has a vertex of
    ``b`` within ``r + 2e + reach (1 + 1/ARC_SAMPLES + SIGHT_SLACK) +
    edge_b`` of the loop's centre, ``r`` its farthest rim vertex.
    """
    from .geometry import concat_ranges

    ids = np.flatnonzero(hole)
    # touching loops (a shared vertex) are never paired; a loop that touches
    # none is kept without the bound below (dropping a loop is only a saving)
    if touching is None:
        touching = _touching(loops, ids)
    if not touching:
        return list(cand)
    allv = np.concatenate([np.asarray(loops[i].vertices, np.int64) for i in ids])
    owner = np.repeat(ids, [len(loops[i].vertices) for i in ids])
    touches = {x for x, _ in touching}
    keep = [a for a in cand if a not in touches]
    test = [a for a in cand if a in touches]
    if not test:
        return list(cand)
    edge = np.array([L.mean_edge for L in loops], np.float64)
    V, F = ctx.V, ctx.F
    rims = [np.asarray(loops[a].vertices, np.int64) for a in test]
    sizes = np.array([len(lp) for lp in rims], np.int64)
    first = np.cumsum(sizes) - sizes
    rv = np.concatenate(rims)
    # the longest edge of the faces at each rim vertex, then per loop
    s0, cnt = ctx.vf_start[rv], ctx.vf_start[rv + 1] - ctx.vf_start[rv]
    T = V[F[ctx.vf_order[concat_ranges(s0, cnt)] // 3]]
    el = ((T - np.roll(T, 1, axis=1)) ** 2).sum(axis=2).max(axis=1)
    per_v = np.zeros(len(rv))
    has = cnt > 0
    per_v[has] = np.maximum.reduceat(el, (np.cumsum(cnt) - cnt)[has])
    e = np.sqrt(np.maximum.reduceat(per_v, first))
    P = V[rv]
    c = np.add.reduceat(P, first) / sizes[:, None]
    r = np.sqrt(np.maximum.reduceat(((P - np.repeat(c, sizes, axis=0)) ** 2).sum(axis=1), first))
    reach = MAX_REACH * np.maximum([loops[a].diameter for a in test], 1e-300)
    R = (r + 2 * e + reach * (1 + 1 / ARC_SAMPLES + SIGHT_SLACK)) * (1 + 1e-9)
    tree = cKDTree(V[allv])
    near = tree.query_ball_point(c, R + edge[ids].max() * (1 + 1e-9), return_sorted=False)   # (order unused)
    counts = np.array([len(x) for x in near], np.int64)
    if counts.sum():
        row = np.repeat(np.arange(len(test)), counts)
        nb = np.fromiter(chain.from_iterable(near), np.int64, count=int(counts.sum()))
        who = owner[nb]
        d = np.linalg.norm(V[allv[nb]] - c[row], axis=1)
        ta = np.asarray(test, np.int64)
        ok = (who != ta[row]) & (d <= R[row] + edge[who] * (1 + 1e-9))
        # each (loop, partner) pair once, then the pairs that do not touch
        m = np.int64(len(loops))
        ab = np.unique(ta[row[ok]] * m + who[ok])
        tk = np.array([a * int(m) + b for a, b in touching], np.int64)
        keep += np.unique(ab[~np.isin(ab, tk)] // m).tolist()
    return sorted(keep)

