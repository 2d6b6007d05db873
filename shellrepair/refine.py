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

from .geometry import cross

__all__ = ["refine_patch", "refine_patches", "relax_edges", "DENSITY_ALPHA"]

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
    P = np.array(P, np.float64)
    T = np.array(T, np.int64)
    s = np.concatenate([np.asarray(sigma, np.float64), np.zeros(len(P) - n_loop)])
    if len(P) > n_loop:  # vertices already inside: give them the mean scale
        s[n_loop:] = np.mean(sigma)
    is_loop = np.arange(len(P)) < n_loop
    P, T, _, _ = _refine(P, T, s, is_loop, _forbidden_pairs(forbidden), alpha, max_faces)
    return P, T


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


def _forbidden_pairs(pairs):
    return np.array(sorted(pairs or ()), np.int64).reshape(-1, 2)


def _refine(P, T, s, is_loop, forb, alpha, max_faces, owner=None):
    """Body of :func:`refine_patch` (``is_loop`` marks loop vertices,
    ``forb`` (f,2) the forbidden chords; ``owner`` a label per vertex that
    new vertices inherit from the triangle they split). Also returns
    whether the face cap stopped it."""
    T = _relax(P, T, is_loop, forb)
    capped = False
    for _ in range(64):
        C = P[T].mean(axis=1)
        sc = s[T].mean(axis=1)
        d = np.linalg.norm(C[:, None, :] - P[T], axis=2) * alpha  # (t,3)
        split = np.all((d > sc[:, None]) & (d > s[T]), axis=1)
        if not split.any():
            break
        if len(T) + 2 * int(split.sum()) > max_faces:
            capped = True
            break
        ids = np.flatnonzero(split)
        new = len(P) + np.arange(ids.size)
        P = np.vstack([P, C[ids]])
        s = np.concatenate([s, sc[ids]])
        is_loop = np.concatenate([is_loop, np.zeros(ids.size, bool)])
        if owner is not None:
            owner = np.concatenate([owner, owner[T[ids, 0]]])
        a, b, c = T[ids, 0], T[ids, 1], T[ids, 2]
        keep = np.ones(len(T), bool)
        keep[ids] = False
        T = np.vstack([T[keep], np.column_stack([a, b, new]), np.column_stack([b, c, new]),
                       np.column_stack([c, a, new])])
        T = _relax(P, T, is_loop, forb)
    return P, T, owner, capped


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
    return _relax(P, np.array(T, np.int64), np.arange(len(P)) < n_loop, _forbidden_pairs(forbidden), max_rounds)


def _relax(P, T, is_loop, forb, max_rounds=100):
    """Body of :func:`relax_edges` (``forb`` (f,2) forbidden chords)."""
    n = len(P)
    nt = len(T)
    if nt < 2:
        return T
    forb = np.sort(forb[:, 0] * n + forb[:, 1]) if len(forb) else np.zeros(0, np.int64)
    for _ in range(max_rounds):
        he = np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2)
        opp = np.roll(T, -2, axis=1).reshape(-1)          # corner opposite to half-edge 3f+c
        lo = np.minimum(he[:, 0], he[:, 1])
        hi = np.maximum(he[:, 0], he[:, 1])
        key = lo * n + hi
        order = np.argsort(key, kind="stable")
        ks = key[order]
        pair = np.flatnonzero(ks[1:] == ks[:-1])
        if pair.size == 0:
            break
        h1, h2 = order[pair], order[pair + 1]
        # orient: h1 is a -> b, h2 is b -> a
        a, b = he[h1, 0], he[h1, 1]
        c, d = opp[h1], opp[h2]
        pa, pb, pc, pd = P[a], P[b], P[c], P[d]
        excess = _angle(pa - pc, pb - pc) + _angle(pa - pd, pb - pd) - np.pi
        cand = np.flatnonzero((excess > FLIP_EPS) & (c != d))
        if cand.size == 0:
            break
        cc, dd = c[cand], d[cand]
        ncd_c = np.minimum(cc, dd) * n + np.maximum(cc, dd)
        ok = ~_in_sorted(ncd_c, ks)                     # the new edge must not exist
        if forb.size:
            ok &= ~(is_loop[cc] & is_loop[dd] & _in_sorted(ncd_c, forb))
        qa, qb, qc, qd = pa[cand], pb[cand], pc[cand], pd[cand]
        nold = cross(qb - qa, qc - qa) + cross(qa - qb, qd - qb)
        m1 = cross(qa - qc, qd - qc)
        m2 = cross(qb - qd, qc - qd)
        ok &= (np.sum(m1 * nold, axis=1) > 0) & (np.sum(m2 * nold, axis=1) > 0)
        cand = cand[ok]
        if cand.size == 0:
            break
        ncd = np.zeros(len(c), np.int64)
        ncd[cand] = ncd_c[ok]
        f1, f2 = h1[cand] // 3, h2[cand] // 3
        # independent set: an edge flips if it is the worst edge of both its faces
        best = np.full(nt, -np.inf)
        np.maximum.at(best, f1, excess[cand])
        np.maximum.at(best, f2, excess[cand])
        sel = (best[f1] == excess[cand]) & (best[f2] == excess[cand])
        # ties: keep one candidate per face
        cand, f1, f2 = cand[sel], f1[sel], f2[sel]
        _, first1 = np.unique(f1, return_index=True)
        keep = np.zeros(cand.size, bool)
        keep[first1] = True
        taken = np.zeros(nt, bool)
        taken[f1[keep]] = True
        keep &= ~taken[f2] | (f2 == f1)
        _, firstn = np.unique(ncd[cand[keep]], return_index=True)
        idx = np.flatnonzero(keep)[firstn]
        cand, f1, f2 = cand[idx], f1[idx], f2[idx]
        if cand.size == 0:
            break
        T[f1] = np.column_stack([c[cand], a[cand], d[cand]])
        T[f2] = np.column_stack([d[cand], b[cand], c[cand]])
    return T


def _in_sorted(x, sorted_keys):
    """``np.isin(x, sorted_keys)`` for a sorted ``sorted_keys``."""
    if sorted_keys.size == 0:
        return np.zeros(len(x), bool)
    pos = np.minimum(np.searchsorted(sorted_keys, x), sorted_keys.size - 1)
    return sorted_keys[pos] == x


def _angle(u, v):
    """Angle between row vectors (atan2 form, accurate near 0 and π)."""
    cr = np.linalg.norm(cross(u, v), axis=1)
    return np.arctan2(cr, np.sum(u * v, axis=1))
