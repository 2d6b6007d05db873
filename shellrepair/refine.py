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


def relax_edges(P, T, n_loop, forbidden=None, max_rounds=50):
    """Flip interior edges of a patch to the Delaunay criterion.

    An interior edge (two patch triangles) is flipped when the angles
    opposite to it sum to more than π, unless the new edge exists already,
    joins two loop vertices the scan already joins, or the flip would fold
    the surface (a new triangle facing against the old pair).

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
    forbidden = forbidden or set()
    tris = [list(map(int, t)) for t in T]
    pts = [tuple(p) for p in np.asarray(P, np.float64).tolist()]
    ef = {}
    for fi, (a, b, c) in enumerate(tris):
        for u, v in ((a, b), (b, c), (c, a)):
            ef.setdefault((u, v) if u < v else (v, u), []).append(fi)
    queue = [e for e, fs in ef.items() if len(fs) == 2]
    for _ in range(max_rounds):
        flipped = 0
        next_queue = []
        for e in queue:
            fs = ef.get(e)
            if fs is None or len(fs) != 2:
                continue
            res = _try_flip(e, fs, tris, pts, ef, n_loop, forbidden)
            if res:
                flipped += 1
                next_queue.extend(res)
        if not flipped:
            break
        queue = next_queue
    return np.array(tris, np.int64).reshape(-1, 3)


def _sub(p, q):
    return (p[0] - q[0], p[1] - q[1], p[2] - q[2])


def _cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _angle_at(c, a, b):
    u, v = _sub(a, c), _sub(b, c)
    cr = _cross(u, v)
    return math.atan2(math.sqrt(_dot(cr, cr)), _dot(u, v))


def _try_flip(e, fs, tris, pts, ef, n_loop, forbidden):
    f1, f2 = fs
    t1, t2 = tris[f1], tris[f2]
    # orient: t1 contains a->b, t2 contains b->a
    a, b = e
    i1 = t1.index(a)
    if t1[(i1 + 1) % 3] != b:
        a, b = b, a
        i1 = t1.index(a)
    if t1[(i1 + 1) % 3] != b:
        return None
    c = t1[(i1 + 2) % 3]
    i2 = t2.index(b)
    if t2[(i2 + 1) % 3] != a:
        return None
    d = t2[(i2 + 2) % 3]
    if c == d:
        return None
    pa, pb, pc, pd = pts[a], pts[b], pts[c], pts[d]
    if _angle_at(pc, pa, pb) + _angle_at(pd, pa, pb) <= math.pi + FLIP_EPS:
        return None
    key = (c, d) if c < d else (d, c)
    if key in ef:
        return None
    if c < n_loop and d < n_loop and key in forbidden:
        return None
    n1 = _cross(_sub(pb, pa), _sub(pc, pa))
    n2 = _cross(_sub(pa, pb), _sub(pd, pb))
    nold = (n1[0] + n2[0], n1[1] + n2[1], n1[2] + n2[2])
    m1 = _cross(_sub(pa, pc), _sub(pd, pc))  # new (c, a, d)
    m2 = _cross(_sub(pb, pd), _sub(pc, pd))  # new (d, b, c)
    if _dot(m1, nold) <= 0 or _dot(m2, nold) <= 0:
        return None
    tris[f1] = [c, a, d]
    tris[f2] = [d, b, c]
    del ef[(a, b) if a < b else (b, a)]
    ef[key] = [f1, f2]
    ad = (a, d) if a < d else (d, a)
    bc = (b, c) if b < c else (c, b)
    ef[ad] = [f1 if f == f2 else f for f in ef[ad]]
    ef[bc] = [f2 if f == f1 else f for f in ef[bc]]
    return [(a, c) if a < c else (c, a), ad, bc, (b, d) if b < d else (d, b)]
