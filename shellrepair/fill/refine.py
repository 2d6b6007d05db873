"""Refine a hole's triangulation to the density of the scan around it.

Liepa's scheme: every loop vertex carries a scale σ, the mean length of its
scan edges. A patch triangle whose centroid is farther than σ/√2 from each
of its corners (with σ interpolated at the centroid) is split at the
centroid; after each round of splits the interior edges are relaxed (an
edge is flipped when the two angles opposite to it add up to more than π,
the Delaunay criterion) until no edge flips. Rounds repeat until no
triangle splits. The result has edge lengths matching the rim.

References
----------
P. Liepa, "Filling Holes in Meshes", Eurographics Symposium on Geometry
Processing, 2003, section 4 (density control, α = √2).
"""

from __future__ import annotations

import math

import numpy as np

from shellrepair import compiled
from shellrepair.fill import refine_kernels
from shellrepair.mesh.geometry import cross
from shellrepair.mesh.topology import edge_topology, manifold_pairs

__all__ = ["refine_patch", "refine_patches", "split_chords", "relax_edges", "relax", "relax_reference", "split_test_reference",
           "angle_between", "unfolded", "independent_flips", "in_sorted", "DENSITY_ALPHA"]

#: Liepa's density factor α.
DENSITY_ALPHA = math.sqrt(2.0)
#: Flip when the opposite angles exceed π by more than this (radians).
FLIP_EPS = 1e-9
#: A safety cap on patch size (triangles); beyond it refinement stops.
MAX_PATCH_FACES = 2_000_000


def refine_patch(P, T, sigma, n_loop, forbidden=None, alpha=DENSITY_ALPHA, max_faces=MAX_PATCH_FACES):
    """Split and relax a patch until its density matches ``sigma``.

    Parameters
    ----------
    P : (k,3) float64
        Patch vertex positions; the first ``n_loop`` are the loop vertices.
    T : (t,3) int64
        Patch triangles (indices into P).
    sigma : (n_loop,) float64
        Target edge length at each loop vertex.
    n_loop : int
    forbidden : set of (int, int), optional
        Loop-vertex pairs that must not become edges (the scan has them).
    alpha : float
        Liepa's density factor.
    max_faces : int

    Returns
    -------
    P2 : (k',3) float64
    T2 : (t',3) int64
        Same loop vertices first, new vertices after them.
    """
    P, T, s, is_loop = _start(P, T, sigma, n_loop)
    P, T, _, _ = _refine(P, T, s, is_loop, _forbidden_pairs(forbidden), alpha, max_faces)
    return P, T


def _start(P, T, sigma, n_loop):
    """A patch's arrays as :func:`refine_patch` and :func:`split_chords`
    take them: copies of ``P`` and ``T``, each vertex's scale (the rim's
    ``sigma``; vertices already inside get its mean) and the rim mask."""
    P = np.array(P, np.float64)
    T = np.array(T, np.int64)
    s = np.concatenate([np.asarray(sigma, np.float64), np.zeros(len(P) - n_loop)])
    if len(P) > n_loop:  # vertices already inside: give them the mean scale
        s[n_loop:] = np.mean(sigma)
    return P, T, s, np.arange(len(P)) < n_loop


def refine_patches(items, alpha=DENSITY_ALPHA, max_faces=MAX_PATCH_FACES):
    """:func:`refine_patch` of several patches at once.

    The patches are refined as one disjoint union, so a batch of small
    holes costs a few array rounds instead of a few rounds each. Every
    decision (which triangle splits, which edge flips) is local to a patch
    and ties are broken in an order the union keeps, so each result is the
    one :func:`refine_patch` gives on its own (tested).

    Parameters
    ----------
    items : list of (P, T, sigma, n_loop, forbidden)
        As for :func:`refine_patch`; here P holds only the loop
        (``len(P) == n_loop``).
    alpha : float
    max_faces : int
        Per patch; should the union reach it, the batch is refined one by
        one instead.

    Returns
    -------
    out : list of (P2, T2)
    """
    items = list(items)
    if not items:
        return []
    sizes = [len(P) for P, *_ in items]
    if any(len(P) != n for (P, _, _, n, _) in items):
        return [refine_patch(*it, alpha=alpha, max_faces=max_faces) for it in items]
    off = np.concatenate([[0], np.cumsum(sizes)])
    P = np.vstack([np.asarray(it[0], np.float64) for it in items])
    T = np.vstack([np.asarray(it[1], np.int64) + o for it, o in zip(items, off[:-1])])
    s = np.concatenate([np.asarray(it[2], np.float64) for it in items])
    n = len(P)
    forb = _forbidden_pairs([(a + o, b + o) for it, o in zip(items, off[:-1]) for a, b in (it[4] or ())])
    owner = np.repeat(np.arange(len(items)), sizes)
    P, T, owner, capped = _refine(P, T, s, np.ones(n, bool), forb, alpha, max_faces, owner)
    if capped:  # the cap applies per patch
        return [refine_patch(*it, alpha=alpha, max_faces=max_faces) for it in items]
    # split the union back: each patch's loop block, then its new vertices in creation order
    tri_owner = owner[T[:, 0]]
    out = []
    for i in range(len(items)):
        vs = np.flatnonzero(owner == i)
        loc = np.full(len(P), -1, np.int64)
        loc[vs] = np.arange(vs.size)
        out.append((P[vs], loc[T[tri_owner == i]]))
    return out


def split_chords(P, T, sigma, n_loop, forbidden=None, beta=DENSITY_ALPHA, max_faces=MAX_PATCH_FACES):
    """Split a refined patch's long chords at their midpoints, then relax.

    A chord is an interior edge between two rim vertices. Liepa's test
    (:func:`refine_patch`) splits a triangle by its centroid's distance to
    its corners, so a thin opening (a slit two faces wide, the narrow ends
    of a long hole) keeps triangles that span it rim to rim: their chords
    stand for the surface across it, with no vertex to fair. Here each
    chord longer than ``beta`` times its ends' mean scale (``beta`` is
    Liepa's density factor, so the same edge length his test leads to
    elsewhere) is split at its midpoint, each of its two triangles in two,
    and the patch relaxed as after a round of centroid splits; rounds
    repeat until no chord is that long. Only a faired patch is split
    (:func:`~shellrepair.fill.patch.build_patch` at order 2 or 3): a flat
    cap's or an order-1 patch's midpoints would lie a round-off off the
    plane of a planar opening, where the exact crossing tests could not
    tell the cap from the coplanar scan under it.

    Measured with ``eval/regret.py``'s cases (the default's RMS in ‰,
    before → after; ``eval/results/order-test/chords/``): slits on a star
    0.316 → 0.093 and 0.361 → 0.162 (fillHoleNicely 0.180 and 0.222), on a
    dumbbell 0.169 → 0.047 (0.104), on genus-2 shapes 0.076 → 0.034 and, on
    a seed drawn before the change, 0.066 → 0.033 (0.058) with a star's
    0.446 → 0.117 (0.205). A torus disc and a nefertiti base that splitting
    at ``beta = 1`` made worse (0.717 → 1.88 at order 2, 12.3 → 25.9 by
    default) stay at 0.717 and 12.27 → 12.35.

    Parameters
    ----------
    P : (k,3) float64
        The refined patch's positions, the ``n_loop`` rim vertices first.
    T : (t,3) int64
    sigma : (n_loop,) float64
        Each rim vertex's scale (as for :func:`refine_patch`).
    n_loop : int
    forbidden : set of (int, int), optional
    beta : float
    max_faces : int

    Returns
    -------
    P2 : (k',3) float64
    T2 : (t',3) int64
        The same vertices first, the midpoints after them.
    """
    # (the scale of a vertex inside is never read here: a chord joins two rim vertices)
    P, T, s, is_loop = _start(P, T, sigma, n_loop)
    forb = _forbidden_pairs(forbidden)
    settled = False
    for _ in range(64):
        got = _long_chords(P, T, s, is_loop, beta)
        if got is None:
            break
        a, b, T2, made = got
        if len(T2) > max_faces:
            break
        P = np.vstack([P, 0.5 * (P[a] + P[b])])
        s = np.concatenate([s, 0.5 * (s[a] + s[b])])
        is_loop = np.concatenate([is_loop, np.zeros(a.size, bool)])
        fresh = np.zeros(len(T2), bool)
        fresh[len(T2) - made:] = True
        T, _, settled = relax(P, T2, is_loop, forb, dirty=fresh if settled else None)
    return P, T


def _long_chords(P, T, s, is_loop, beta):
    """One round of :func:`split_chords`: every chord longer than ``beta``
    times its ends' mean scale that is the longest such chord of both its
    triangles (ties by its ends' ids) is split at its midpoint. Returns
    ``(a, b, T2, new triangles)`` (the split chords' ends, in edge order:
    the new vertex ``len(P) + i`` is the midpoint of ``a[i]``, ``b[i]``;
    the new triangles last in ``T2``), or None where no chord is split."""
    t = len(T)
    if t == 0:
        return None
    topo = edge_topology(T, len(P))
    g1, g2 = manifold_pairs(topo)          # the half-edges (3f + c) of each edge of two triangles, in edge order
    if g1.size == 0:
        return None
    a, b = topo.edges[topo.edge_count == 2].T
    # numbered slot * t + triangle, the lower first: each split triangle's
    # two halves go in that order
    g1, g2 = (g1 % 3) * t + g1 // 3, (g2 % 3) * t + g2 // 3
    h1, h2 = np.minimum(g1, g2), np.maximum(g1, g2)
    D = P[a] - P[b]
    L = np.sqrt((D * D).sum(axis=1))
    want = np.flatnonzero(is_loop[a] & is_loop[b] & (L > beta * 0.5 * (s[a] + s[b])))
    if want.size == 0:
        return None
    # each triangle's longest wanted chord; a chord both its triangles name
    # is split, so no triangle splits twice in a round
    rank = np.empty(want.size, np.int64)
    rank[np.lexsort((b[want], a[want], L[want]))] = np.arange(want.size)
    t1, t2 = h1[want] % t, h2[want] % t
    best = np.full(t, -1, np.int64)
    np.maximum.at(best, t1, rank)
    np.maximum.at(best, t2, rank)
    pick = (best[t1] == rank) & (best[t2] == rank)
    e = want[pick]
    m = len(P) + np.arange(e.size)
    keep = np.ones(t, bool)
    new = []
    for h in (h1[e], h2[e]):
        tri, slot = h % t, h // t
        x = T[tri, slot]
        y = T[tri, (slot + 1) % 3]
        z = T[tri, (slot + 2) % 3]
        keep[tri] = False
        new.append(np.column_stack([x, m, z]))
        new.append(np.column_stack([m, y, z]))
    made = np.vstack(new)
    return a[e], b[e], np.vstack([T[keep], made]), len(made)


def _forbidden_pairs(pairs):
    return np.array(sorted(pairs or ()), np.int64).reshape(-1, 2)


def _refine(P, T, s, is_loop, forb, alpha, max_faces, owner=None):
    """Body of :func:`refine_patch` (``is_loop`` marks loop vertices,
    ``forb`` (f,2) the forbidden chords; ``owner`` a label per vertex that
    new vertices inherit from the triangle they split). Also returns
    whether the face cap stopped it.

    Work per round follows what changed: a triangle that failed the split
    test and has not changed since fails it again, and after a relaxation
    that ran to the end only edges of new triangles can need a flip, so
    both the test and the next relaxation's first round look at the
    triangles the last round made or changed (the result is the one
    testing every triangle every round gives)."""
    T, changed, settled = relax(P, T, is_loop, forb)
    capped = False
    test = np.ones(len(T), bool)          # triangles whose split verdict may have changed
    for _ in range(64):
        rows = np.flatnonzero(test)
        C, sc, split_r = (refine_kernels.split_test if compiled.ENABLED else split_test_reference)(P, T[rows], s, alpha)
        if not split_r.any():
            break
        split = np.zeros(len(T), bool)
        split[rows[split_r]] = True
        Cs, scs = C[split_r], sc[split_r]   # in row order, as rows is sorted
        if len(T) + 2 * int(split.sum()) > max_faces:
            capped = True
            break
        ids = np.flatnonzero(split)
        new = len(P) + np.arange(ids.size)
        P = np.vstack([P, Cs])
        s = np.concatenate([s, scs])
        is_loop = np.concatenate([is_loop, np.zeros(ids.size, bool)])
        if owner is not None:
            owner = np.concatenate([owner, owner[T[ids, 0]]])
        a, b, c = T[ids, 0], T[ids, 1], T[ids, 2]
        keep = np.ones(len(T), bool)
        keep[ids] = False
        T = np.vstack([T[keep], np.column_stack([a, b, new]), np.column_stack([b, c, new]),
                       np.column_stack([c, a, new])])
        fresh = np.concatenate([np.zeros(int(keep.sum()), bool), np.ones(3 * ids.size, bool)])
        T, changed, settled = relax(P, T, is_loop, forb, dirty=fresh if settled else None)
        test = fresh | changed
    return P, T, owner, capped


def split_test_reference(P, Tr, s, alpha):
    """The triangles ``Tr`` to split: centroid ``C``, mean scale ``sc`` and
    whether ``alpha`` times the centroid's distance to every corner exceeds
    both ``sc`` and that corner's scale. In NumPy: the fallback when kernels
    are off, and the oracle of :func:`shellrepair.fill.refine_kernels.split_test`
    (the same, compiled).

    Parameters
    ----------
    P : (k,3) float64
    Tr : (r,3) int64
    s : (k,) float64
        Each vertex's scale.
    alpha : float

    Returns
    -------
    C : (r,3) float64
    sc : (r,) float64
    split : (r,) bool
    """
    C = P[Tr].mean(axis=1)
    sc = s[Tr].mean(axis=1)
    d = np.linalg.norm(C[:, None, :] - P[Tr], axis=2) * alpha  # (r,3)
    return C, sc, np.all((d > sc[:, None]) & (d > s[Tr]), axis=1)


def relax_edges(P, T, n_loop, forbidden=None, max_rounds=100):
    """Flip interior edges of a patch to the Delaunay criterion.

    An interior edge (two patch triangles) is flipped when the angles
    opposite to it sum to more than π, unless the new edge exists already,
    joins two loop vertices the scan already joins, or the flip would fold
    the surface (a new triangle facing against the old pair). Each round
    flips, vectorised, a set of edges no two of which share a triangle (each
    the worst of its two triangles' edges).

    Parameters
    ----------
    P : (k,3) float64
    T : (t,3) int64
    n_loop : int
    forbidden : set of (int, int), optional
    max_rounds : int

    Returns
    -------
    T2 : (t,3) int64
    """
    P = np.asarray(P, np.float64)
    return relax(P, np.array(T, np.int64), np.arange(len(P)) < n_loop, _forbidden_pairs(forbidden), max_rounds)[0]


def relax(P, T, is_loop, forb, max_rounds=100, dirty=None):
    """The Delaunay relaxation of :func:`relax_edges` on arrays:
    :func:`relax_reference`, its bookkeeping compiled
    (:func:`shellrepair.fill.refine_kernels.relax`, the same result) when Numba is there.

    Parameters
    ----------
    P : (k,3) float64
    T : (t,3) int64
        Triangles; may be changed in place.
    is_loop : (k,) bool
        The loop vertices.
    forb : (f,2) int64
        Forbidden chords between loop vertices.
    max_rounds : int
    dirty : (t,) bool, optional
        Only these triangles' edges are looked at first (see :func:`relax_reference`).

    Returns
    -------
    T : (t,3) int64
    changed : (t,) bool
        The triangles flips changed.
    settled : bool
        Whether it stopped because nothing was left to flip.
    """
    if compiled.ENABLED:
        out = refine_kernels.relax(P, T, is_loop, forb, max_rounds, dirty, None, None, FLIP_EPS)   # (angle_between's numbers, its products and sums compiled)
        if out is not None:   # None: a tie the vectorised writes order; redone below
            return out
    return relax_reference(P, T, is_loop, forb, max_rounds, dirty)


def relax_reference(P, T, is_loop, forb, max_rounds=100, dirty=None):
    """:func:`relax` in NumPy: the fallback when kernels are off (or when a
    tie needs the vectorised writes' order), and the oracle of
    :func:`shellrepair.fill.refine_kernels.relax`. Parameters as :func:`relax`.

    Returns ``(T, changed, settled)``: the triangles, which of them flips
    changed, and whether it stopped because nothing was left to flip (not
    at ``max_rounds``). With ``dirty`` (a mask of triangles), the first
    round looks only at their edges: for a triangulation that was settled
    before those triangles were made, no other edge can flip.

    One sort pairs the half-edges; flips then update the pairing (twins)
    in place, and each round looks only at the edges that may have become
    candidates: those of the faces the last round changed, and the
    candidates it left unflipped. Every other edge keeps both its faces
    and so its verdict; the round's choice is the one a full pass would
    make (candidates in edge-key order, as a full pass lists them)."""
    n = len(P)
    nt = len(T)
    changed = np.zeros(nt, bool)
    if nt < 2:
        return T, changed, True
    forb = np.sort(forb[:, 0] * n + forb[:, 1]) if len(forb) else np.zeros(0, np.int64)
    nxt = np.array([1, 2, 0])
    # pair the half-edges once: half-edge 3f+c runs T[f,c] -> T[f,(c+1)%3]
    src = T.ravel()
    dst = T[:, [1, 2, 0]].ravel()
    key = np.minimum(src, dst) * n + np.maximum(src, dst)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    pair = np.flatnonzero(ks[1:] == ks[:-1])
    twin = np.full(3 * nt, -1, np.int64)
    twin[order[pair]] = order[pair + 1]
    twin[order[pair + 1]] = order[pair]
    edge_keys = ks                       # every edge's key (sorted, repeated)
    changed_keys = {}                    # key -> present, for edges flips made or removed
    active = order[pair]                 # canonical half-edge (the smaller id) of each interior edge
    if dirty is not None:                # only edges of the dirty triangles
        active = active[dirty[active // 3] | dirty[twin[active] // 3]]
    settled = False
    for _ in range(max_rounds):
        if active.size == 0:
            settled = True
            break
        h1 = active
        h2 = twin[h1]
        f1, i1 = h1 // 3, h1 % 3
        f2, i2 = h2 // 3, h2 % 3
        a, b = T[f1, i1], T[f1, nxt[i1]]
        c, d = T[f1, nxt[nxt[i1]]], T[f2, nxt[nxt[i2]]]
        kab = np.minimum(a, b) * n + np.maximum(a, b)
        srt = np.argsort(kab, kind="stable")  # a full pass lists edges by key
        h1, h2, f1, f2, i1, i2, a, b, c, d = (x[srt] for x in (h1, h2, f1, f2, i1, i2, a, b, c, d))
        pa, pb, pc, pd = P[a], P[b], P[c], P[d]
        excess = angle_between(pa - pc, pb - pc) + angle_between(pa - pd, pb - pd) - np.pi
        geo = np.flatnonzero((excess > FLIP_EPS) & (c != d))
        if geo.size == 0:
            settled = True
            break
        cc, dd = c[geo], d[geo]
        ncd_c = np.minimum(cc, dd) * n + np.maximum(cc, dd)
        exists = in_sorted(ncd_c, edge_keys)
        if changed_keys:  # edges flips have made or removed since the pairing
            ck = np.fromiter(changed_keys.keys(), np.int64, len(changed_keys))
            cv = np.fromiter(changed_keys.values(), bool, len(changed_keys))
            by = np.argsort(ck)
            ck, cv = ck[by], cv[by]
            pos = np.minimum(np.searchsorted(ck, ncd_c), ck.size - 1)
            hit = ck[pos] == ncd_c
            exists[hit] = cv[pos[hit]]
        ok = ~exists                                     # the new edge must not exist
        if forb.size:
            ok &= ~(is_loop[cc] & is_loop[dd] & in_sorted(ncd_c, forb))
        ok &= unfolded(pa[geo], pb[geo], pc[geo], pd[geo])
        cand = geo[ok]
        if cand.size == 0:
            settled = True
            break
        ncd = np.zeros(len(c), np.int64)
        ncd[cand] = ncd_c[ok]
        cand = independent_flips(cand, f1[cand], f2[cand], excess[cand], ncd[cand], nt)
        if cand.size == 0:
            settled = True
            break
        # flip: f1 = (a,b,c) -> (c,a,d), f2 = (b,a,d) -> (d,b,c)
        F1, F2, I1, I2 = f1[cand], f2[cand], i1[cand], i2[cand]
        A, B, C, D = a[cand], b[cand], c[cand], d[cand]
        # the four outer half-edges, old slot -> new slot
        old = np.stack([3 * F1 + nxt[nxt[I1]],   # c->a  -> new f1 slot 0
                        3 * F2 + nxt[I2],        # a->d  -> new f1 slot 1
                        3 * F2 + nxt[nxt[I2]],   # d->b  -> new f2 slot 0
                        3 * F1 + nxt[I1]])       # b->c  -> new f2 slot 1
        new = np.stack([3 * F1, 3 * F1 + 1, 3 * F2, 3 * F2 + 1])
        outer = twin[old]                        # their twins, in old numbering
        old_s = old.ravel()
        by = np.argsort(old_s)
        old_s, new_s = old_s[by], new.ravel()[by]

        def remap(h):                            # a slot's id after the flips
            pos = np.minimum(np.searchsorted(old_s, h), old_s.size - 1)
            return np.where(old_s[pos] == h, new_s[pos], h)
        T[F1] = np.column_stack([C, A, D])
        T[F2] = np.column_stack([D, B, C])
        changed[F1] = True
        changed[F2] = True
        twin[3 * F1 + 2] = 3 * F2 + 2            # the new diagonal d->c / c->d
        twin[3 * F2 + 2] = 3 * F1 + 2
        o = outer.ravel()
        nw = new.ravel()
        has = o >= 0
        twin[nw] = np.where(has, remap(np.maximum(o, 0)), -1)
        twin[remap(o[has])] = nw[has]
        for k in ncd[cand].tolist():
            changed_keys[k] = True
        for k in (np.minimum(A, B) * n + np.maximum(A, B)).tolist():
            changed_keys[k] = False
        # next round: the edges of the changed faces and the unflipped candidates
        flipped = np.zeros(len(h1), bool)
        flipped[cand] = True
        stay = h1[geo[~flipped[geo]]]
        stay = stay[~np.isin(stay // 3, np.concatenate([F1, F2]))]   # slots of changed faces mean other edges now
        stay = np.minimum(stay, twin[stay])                          # canonical again if the twin moved
        touched = np.concatenate([3 * F1[:, None] + np.arange(3), 3 * F2[:, None] + np.arange(3)]).ravel()
        tw = twin[touched]
        touched = np.minimum(touched[tw >= 0], tw[tw >= 0])
        active = np.unique(np.concatenate([stay, touched]))
    return T, changed, settled


def unfolded(pa, pb, pc, pd):
    """Would flipping edge a-b of triangles (a,b,c), (b,a,d) to c-d keep both
    new triangles facing the way the old pair faced (no fold)? The oracle of
    :func:`shellrepair.fill.refine_kernels.unfolded`.

    Parameters
    ----------
    pa, pb, pc, pd : (m,3) float64
        The corners of each candidate edge's two triangles.

    Returns
    -------
    (m,) bool
    """
    nold = cross(pb - pa, pc - pa) + cross(pa - pb, pd - pb)
    m1 = cross(pa - pc, pd - pc)
    m2 = cross(pb - pd, pc - pd)
    return (np.sum(m1 * nold, axis=1) > 0) & (np.sum(m2 * nold, axis=1) > 0)


def independent_flips(cand, g1, g2, excess, ncd, nt):
    """The candidate flips of one round that can be made together.

    An edge flips if it is the worst (largest ``excess``) edge of both its
    faces ``g1``, ``g2``; of ties, the first in ``cand``'s order keeps each
    face (as either of its two faces: two edges of one face that tie as its
    worst never both flip, which would write that face twice and leave an
    edge with three faces), and of edges that would make the same new edge
    (key ``ncd``) the first.

    Parameters
    ----------
    cand : (c,) int64
        The candidate edges, in the order ties are broken.
    g1, g2 : (c,) int64
        Each candidate's two faces.
    excess : (c,) float64
        How far each candidate's opposite angles sum beyond π.
    ncd : (c,) int64
        The key of the edge each flip would make.
    nt : int
        Face count.

    Returns
    -------
    (f,) int64
        The chosen entries of ``cand``.
    """
    best = np.full(nt, -np.inf)
    np.maximum.at(best, g1, excess)
    np.maximum.at(best, g2, excess)
    sel = (best[g1] == excess) & (best[g2] == excess)
    cand, g1, g2, ncd = cand[sel], g1[sel], g2[sel], ncd[sel]
    _, first1 = np.unique(g1, return_index=True)
    keep = np.zeros(cand.size, bool)
    keep[first1] = True
    taken = np.zeros(nt, bool)
    taken[g1[keep]] = True
    keep &= ~taken[g2] | (g2 == g1)
    kept = np.flatnonzero(keep)
    _, first2 = np.unique(g2[kept], return_index=True)   # a second face kept by the first only
    keep[:] = False
    keep[kept[first2]] = True
    _, firstn = np.unique(ncd[keep], return_index=True)
    return cand[np.flatnonzero(keep)[firstn]]


def in_sorted(x, sorted_keys):
    """``np.isin(x, sorted_keys)`` for a sorted ``sorted_keys``.

    Parameters
    ----------
    x : (m,) int64
    sorted_keys : (k,) int64, sorted

    Returns
    -------
    (m,) bool
    """
    if sorted_keys.size == 0:
        return np.zeros(len(x), bool)
    pos = np.minimum(np.searchsorted(sorted_keys, x), sorted_keys.size - 1)
    return sorted_keys[pos] == x


def angle_between(u, v):
    """Angle between row vectors (atan2 form, accurate near 0 and π); the
    arctan2 arguments are those :func:`shellrepair.fill.refine_kernels.angle_parts` computes.

    Parameters
    ----------
    u, v : (m,3) float64

    Returns
    -------
    (m,) float64
        In [0, π].
    """
    cr = np.linalg.norm(cross(u, v), axis=1)
    return np.arctan2(cr, np.sum(u * v, axis=1))

