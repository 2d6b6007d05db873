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

__all__ = ["refine_patch", "relax_edges", "DENSITY_ALPHA"]

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
    T = relax_edges(P, T, n_loop, forbidden)
    for _ in range(64):
        C = P[T].mean(axis=1)
        sc = s[T].mean(axis=1)
        d = np.linalg.norm(C[:, None, :] - P[T], axis=2) * alpha  # (t,3)
        split = np.all((d > sc[:, None]) & (d > s[T]), axis=1)
        if not split.any() or len(T) + 2 * int(split.sum()) > max_faces:
            break
        ids = np.flatnonzero(split)
        new = len(P) + np.arange(ids.size)
        P = np.vstack([P, C[ids]])
        s = np.concatenate([s, sc[ids]])
        a, b, c = T[ids, 0], T[ids, 1], T[ids, 2]
        keep = np.ones(len(T), bool)
        keep[ids] = False
        T = np.vstack([T[keep], np.column_stack([a, b, new]), np.column_stack([b, c, new]),
                       np.column_stack([c, a, new])])
        T = relax_edges(P, T, n_loop, forbidden)
    return P, T


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
    T = np.array(T, np.int64)
    n = len(P)
    nt = len(T)
    if nt < 2:
        return T
    forb = np.array([a * n + b for a, b in (forbidden or ())], np.int64)
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
        ok = (excess > FLIP_EPS) & (c != d)
        if not ok.any():
            break
        ncd = np.minimum(c, d) * n + np.maximum(c, d)
        ok &= ~np.isin(ncd, ks)
        if forb.size:
            ok &= ~((c < n_loop) & (d < n_loop) & np.isin(ncd, forb))
        nold = cross(pb - pa, pc - pa) + cross(pa - pb, pd - pb)
        m1 = cross(pa - pc, pd - pc)
        m2 = cross(pb - pd, pc - pd)
        ok &= (np.sum(m1 * nold, axis=1) > 0) & (np.sum(m2 * nold, axis=1) > 0)
        cand = np.flatnonzero(ok)
        if cand.size == 0:
            break
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


def _angle(u, v):
    """Angle between row vectors (atan2 form, accurate near 0 and π)."""
    cr = np.linalg.norm(cross(u, v), axis=1)
    return np.arctan2(cr, np.sum(u * v, axis=1))
