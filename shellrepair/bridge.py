"""Bridge a missing band: two loops that bound one missing strip of surface.

A scanner that misses a whole band (the inner side of a ring-like fold, the
gap around a wrist) leaves two loops facing each other. Capping each loop
gives the wrong shape; a tube between them continues the surface.

Which pairs are candidates
--------------------------
At every loop vertex the scan arrives from one side; its *continuation
direction* points from the mean of the vertex's scan neighbours off the loop
to the vertex, i.e. the way the surface was heading when it stopped. For a
hole in a smooth surface these directions point all around the hole and
average to almost nothing; for a band's rim they all point across the gap.
Two loops are a candidate pair when

* both mean continuation directions have length ≥ ``MIN_COHERENCE``,
* each points towards the other loop (cosine with the line between the loop
  centres ≥ ``MIN_FACING``),
* their perimeters differ by at most a factor ``MAX_SIZE_RATIO``, and
* the gap between their centres is at most ``MAX_GAP`` times the larger
  diameter.

The loops may lie in different components: a missing ring cuts a cylinder
in two. Coherence and facing are measured as cosines over all rim vertices,
so a band whose rims head partly inwards (the inner side of a torus) still
qualifies: the radial parts cancel, the part across the gap remains.

Each loop joins at most one pair (best-aligned first). Whether the tube is
used is then decided by comparing the faired thin-plate energy of the tube
with that of the two caps (see :func:`shellrepair.repair.repair_mesh`).

The tube's first triangulation zips the two loops together, matched by arc
length (the second loop walked backwards, from the cyclic shift that best
matches the first); it is then refined and faired like any patch.
"""

from __future__ import annotations

import numpy as np

__all__ = ["continuation_direction", "band_pairs", "tube_triangles",
           "MIN_COHERENCE", "MIN_FACING", "MAX_SIZE_RATIO", "MAX_GAP"]

#: Minimum length of a loop's mean continuation direction (1 = all parallel).
MIN_COHERENCE = 0.2
#: Minimum cosine between a loop's continuation direction and the line to the other loop.
MIN_FACING = 0.2
#: Largest perimeter ratio of the two loops.
MAX_SIZE_RATIO = 2.0
#: Largest centre distance, in units of the larger loop diameter.
MAX_GAP = 2.0


def continuation_direction(V, F_ring, loop):
    """Mean unit direction in which the scan reaches the loop.

    Parameters
    ----------
    V : (n,3) float64
    F_ring : (r,3) int64
        Scan faces touching the loop.
    loop : (k,) int64

    Returns
    -------
    m : (3,) float64
        Mean of the per-vertex unit directions (length 0 … 1).
    """
    loop = np.asarray(loop, np.int64)
    on = np.zeros(int(max(F_ring.max(initial=0), loop.max())) + 1, bool)
    on[loop] = True
    pos = -np.ones(len(on), np.int64)
    pos[loop] = np.arange(len(loop))
    E = np.concatenate([F_ring[:, [0, 1]], F_ring[:, [1, 2]], F_ring[:, [2, 0]],
                        F_ring[:, [1, 0]], F_ring[:, [2, 1]], F_ring[:, [0, 2]]])
    E = np.unique(E, axis=0)
    E = E[on[E[:, 0]] & ~on[E[:, 1]]]          # loop vertex -> off-loop neighbour
    k = len(loop)
    acc = np.zeros((k, 3))
    cnt = np.zeros(k)
    np.add.at(acc, pos[E[:, 0]], V[E[:, 1]])
    np.add.at(cnt, pos[E[:, 0]], 1)
    ok = cnt > 0
    d = np.zeros((k, 3))
    d[ok] = V[loop[ok]] - acc[ok] / cnt[ok, None]
    ln = np.linalg.norm(d, axis=1, keepdims=True)
    d = np.divide(d, ln, out=np.zeros_like(d), where=ln > 0)
    return d[ok].mean(axis=0) if ok.any() else np.zeros(3)


def band_pairs(loops, directions, *, components=None, min_coherence=MIN_COHERENCE, min_facing=MIN_FACING,
               max_size_ratio=MAX_SIZE_RATIO, max_gap=MAX_GAP):
    """Candidate pairs of loops bounding one missing band.

    Parameters
    ----------
    loops : list of Loop
        With ``vertices``, ``perimeter``, ``diameter``; their centres are
        taken from ``centers``.
    directions : list of (centre (3,), direction (3,))
        Per loop: its centroid and mean continuation direction.
    components : list of int, optional
        Pairs are only formed within one component.

    Returns
    -------
    pairs : list of (i, j, score)
        Indices into ``loops``; each loop appears at most once; score is the
        smaller of the two facing cosines.
    """
    cand = []
    n = len(loops)
    for i in range(n):
        ci, mi = directions[i]
        if np.linalg.norm(mi) < min_coherence:
            continue
        for j in range(i + 1, n):
            cj, mj = directions[j]
            if np.linalg.norm(mj) < min_coherence:
                continue
            if components is not None and components[i] != components[j]:
                continue
            pa, pb = loops[i].perimeter, loops[j].perimeter
            if max(pa, pb) > max_size_ratio * min(pa, pb):
                continue
            gap = np.linalg.norm(cj - ci)
            if gap == 0 or gap > max_gap * max(loops[i].diameter, loops[j].diameter):
                continue
            u = (cj - ci) / gap
            fa = np.dot(mi, u) / np.linalg.norm(mi)
            fb = -np.dot(mj, u) / np.linalg.norm(mj)
            if min(fa, fb) >= min_facing:
                cand.append((float(min(fa, fb)), i, j))
    cand.sort(key=lambda t: -t[0])
    used = set()
    pairs = []
    for s, i, j in cand:
        if i in used or j in used:
            continue
        used.update((i, j))
        pairs.append((i, j, s))
    return pairs


def _arclength(P):
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    t = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    return t / max(seg.sum(), 1e-300)


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
    ka, kb = len(PA), len(PB)
    rev = np.arange(kb)[::-1]
    # best cyclic shift of the reversed second loop, matched by arc length
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
    order = np.roll(rev, -best[1])
    C = PB[order]
    tb = _arclength(C)
    tris = []
    i = t = 0
    while i < ka or t < kb:
        a0, a1 = i % ka, (i + 1) % ka
        c0, c1 = order[t % kb] + ka, order[(t + 1) % kb] + ka
        if i == ka:
            adv_a = False
        elif t == kb:
            adv_a = True
        else:  # advance the side whose next vertex comes first along the loops
            na = ta[i + 1] if i + 1 < ka else 1.0
            nb = tb[t + 1] if t + 1 < kb else 1.0
            adv_a = na <= nb
        if adv_a:
            tris.append((a0, c0, a1))
            i += 1
        else:
            tris.append((a0, c0, c1))
            t += 1
    return np.array(tris, np.int64)
