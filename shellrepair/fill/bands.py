"""Find the missing bands of a scan: pairs of hole loops one tube joins.

:func:`find_bands` reads the scan's ``hole`` loops, follows the
continuation arcs of those with another loop within reach
(:func:`shellrepair.fill.bridge.loop_sights`) and pairs them by the rules of
:mod:`shellrepair.fill.bridge` (:func:`~shellrepair.fill.bridge.band_pairs`,
:func:`~shellrepair.fill.bridge.pants_triples`); :func:`wrapped_pairs` adds the
loops that cross a thin tube obliquely and wrap it.
"""

from __future__ import annotations

from itertools import chain
from typing import NamedTuple

import numpy as np

from shellrepair.fill.bridge import (
    ARC_SAMPLES,
    MAX_REACH,
    SIGHT_SLACK,
    band_pairs,
    continuation_arcs_many,
    loop_sights,
    pants_triples,
)
from shellrepair.lazyscipy import cKDTree

__all__ = ["Band", "Bands", "find_bands", "wrapped_pairs", "loops_with_partner"]


class Band(NamedTuple):
    """Two ``hole`` loops bounding one missing band (:func:`find_bands`)."""
    A: object              # shellrepair.holes.loops.Loop
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
    cand = loops_with_partner(ctx, loops, cand, hole, touching)
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
    # three loops bounding one region (shellrepair.fill.pants): the pairs among
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
    # (how the pair was found, for the record: every pair's caps are filled as the holes alone would be)
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
    found = dict(zip(todo, continuation_arcs_many(V, [faces_near(rims[x]) for x in todo],
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


def loops_with_partner(ctx, loops, cand, hole, touching=None):
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

    Parameters
    ----------
    ctx : ScanContext
        The scan.
    loops : list of Loop
        The scan's loops (:class:`shellrepair.holes.loops.Loop`).
    cand : list of int
        The loops to filter (ids).
    hole : (len(loops),) bool
        Which loops are classed ``hole``.
    touching : set of (int, int), optional
        The pairs of hole loops that share a vertex (found here when not
        given).

    Returns
    -------
    list of int
        The loops of ``cand`` kept, in their order.
    """
    from shellrepair.mesh.geometry import concat_ranges

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
