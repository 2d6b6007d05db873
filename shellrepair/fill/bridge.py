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
arcs (:func:`shellrepair.fill.tube.guide_tube`), refined to the rim's edge length, and then
either faired with both loops' rings fixed or kept on the arcs, whichever
valid one has the lower curvature-variation energy; every option is
checked like a cap: it must cross neither the scan nor itself, nor repeat
an edge of the scan. Then (see :func:`shellrepair.fill.band_fill._fill_pair`):

* loops that see each other both ways keep a valid tube (the surface
  continues from each into the other; the caps are not built);
* otherwise the two caps are built and checked, against each other too;
  an option that fails its checks loses, and between valid ones the lower
  energy wins.

Two loops that cross a thin tube obliquely send their arcs round the tube
and back to themselves; :func:`shellrepair.fill.bands.wrapped_pairs` pairs such loops from the scan
at their rims (they wrap the tube and head to each other). Three loops that
bound one region are filled by :mod:`shellrepair.fill.pants`.

This module follows the arcs and states the pairing rules; the scan's pairs
are found by :func:`shellrepair.fill.bands.find_bands`, the tube is built by
:mod:`shellrepair.fill.tube`.
"""

from __future__ import annotations

import numpy as np

from shellrepair import compiled
from shellrepair.fill import bridge_kernels
from shellrepair.lazyscipy import cKDTree
from shellrepair.reference import ring_sums as ring_sums_reference

__all__ = ["continuation_arcs", "continuation_arcs_many", "next_to", "arc_points", "loop_sights", "band_pairs",
           "pants_triples", "MAX_REACH", "ARCS_PER_LOOP", "ARC_SAMPLES", "SIGHT_SLACK", "ARC_SMOOTH"]

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
#: An arc's direction and curvature are read over ``2 * ARC_SMOOTH + 1``
#: consecutive rim vertices at least (:func:`continuation_arcs`);
#: :func:`loop_sights` reads each over the rim between its neighbours' arcs
#: where that is longer.
ARC_SMOOTH = 2


def continuation_arcs(V, F_near, loop, smooth=ARC_SMOOTH):
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
    return continuation_arcs_many(V, [F_near], [loop], smooth)[0]


def continuation_arcs_many(V, F_nears, loops, smooth=ARC_SMOOTH):
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
    smooth : int or sequence of int
        As for :func:`continuation_arcs`; a sequence gives each loop its own.

    Returns
    -------
    arcs : list of tuple
        Per loop, what :func:`continuation_arcs` returns for it.
    """
    if not loops:
        return []
    *cols, bounds = _continuation_arcs_cat(V, F_nears, loops, smooth)
    return [tuple(x[bounds[i]:bounds[i + 1]] for x in cols) for i in range(len(bounds) - 1)]


def _continuation_arcs_cat(V, F_nears, loops, smooth=ARC_SMOOTH):
    """:func:`continuation_arcs_many` with the loops' rows concatenated.

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
    ring1 = next_to(E, level == 0) & (level > 0)     # the adjacency's rows li meet these columns
    level[ring1] = 1
    ring2 = next_to(E, ring1) & (level > 1)
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
    sums = bridge_kernels.ring_sums if compiled.ENABLED else ring_sums_reference
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
    w_row = np.repeat(np.broadcast_to(np.asarray(smooth, np.int64), (len(loops),)), sizes)
    sm = (k_of > 2 * w_row + 1) & (w_row > 0)
    if sm.any():
        N0, T0, kw = N, T, np.where(ok, kap, np.nan)
        kap, T, N = kap.copy(), T.copy(), N.copy()
        for w in np.unique(w_row[sm]).tolist():      # the loops of each window, each from the unsmoothed rows
            r = np.flatnonzero(sm & (w_row == w))
            shifts = [shifted(d)[r] for d in range(-w, w + 1)]

            def ring_sum(Y):
                return sum(Y[ix] for ix in shifts)
            Nn = ring_sum(N0 * ok[:, None])
            Nn = Nn / np.maximum(np.linalg.norm(Nn, axis=1, keepdims=True), 1e-300)
            km = _nanmedian_columns(np.stack([kw[ix] for ix in shifts]))
            kap[r] = np.where(np.isfinite(km), km, 0.0)
            T[r] = ring_sum(T0 * ok[:, None])
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


def next_to(E, mark):
    """The vertices joined by an edge to a marked one: the columns the rows
    ``mark`` of the (symmetric, all ones) adjacency of ``E`` meet, without
    building the rows (the rings around a loop, :func:`continuation_arcs`).

    Parameters
    ----------
    E : (k,2) int64
        Edges (repeated edges and self-loops allowed).
    mark : (n,) bool
        The marked vertices.

    Returns
    -------
    (n,) bool
        The vertices an edge joins to a marked vertex.
    """
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
        index, read over the sights' windows), for a caller that reads them
        again (:func:`shellrepair.fill.bands.wrapped_pairs`).

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
    # each arc stands for the rim between its neighbours' arcs, and reads
    # its direction and curvature over that stretch (the curvatures'
    # median), five vertices at least: on a ragged rim (a scanner's fringe,
    # noise of a tenth of an edge along the normal) the curvature at one
    # vertex scatters by about the tube's own (a torus's band: interquartile
    # range 1.2 around -2.0), and its two loops' arcs missed each other over
    # five vertices (eval/results/ragged-sights/)
    wide = [max(ARC_SMOOTH, int(round(len(lp) / max(n_arcs, 1)))) for lp in rims]
    *cols, bounds = _continuation_arcs_cat(V, [faces_near(lp) for lp in rims], rims, wide)
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
    # only an arc's first landing counts (see landings_reference)
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
        landed = landings_reference(U, T, N, kap, s0, length, n_samples, slack, ent, first, tree_of(V[allv]),
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


def landings_reference(U, T, N, kap, s0, length, n_samples, slack, ent, first, tree, owner, place, edge, arow, krow,
                       irow):
    """The loop each arc lands on first (-1: none), the NumPy version of
    :func:`shellrepair.fill.bridge_kernels.arc_landings` (its oracle; arguments as
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
        From :func:`shellrepair.fill.bridge.loop_sights`.
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

