"""Polygons split into triangles that stay inside their outline.

Quads are split along the diagonal that lies inside them; larger polygons
are ear clipped in the plane of their Newell normal (see
:func:`polygons_to_triangles`).
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["polygons_to_triangles", "ear_clip"]


def polygons_to_triangles(polys, notes, V=None):
    """Split polygons into triangles that stay inside them; returns (m,3) int64.

    Parameters
    ----------
    polys : list of lists of int, or (counts, flat) pair of int arrays
        Corner indices, in the polygon's winding; as a pair, polygon ``i``
        has ``counts[i]`` corners, stored one polygon after the other in
        ``flat``.
    notes : list of str
        Gets one line per kind of change.
    V : (n,3) float64 array, optional
        Vertex positions. Without them (or with an index out of range,
        which validation reports later) polygons are fanned from corner 0.

    Notes
    -----
    Triangles are kept as they are, in file order; each polygon's triangles
    take its place. A quad is split along 0-2 unless that diagonal lies
    outside it (corners 1 and 3 on the same side), then along 1-3. Larger
    polygons are ear clipped in the plane of their Newell normal, which
    keeps every triangle inside a non-convex outline; a polygon with no ear
    (self-crossing) is fanned. All triangles keep the polygon's winding.
    Faces with fewer than 3 corners are dropped.
    """
    if isinstance(polys, tuple):
        counts = np.asarray(polys[0], np.int64)
        flat = np.asarray(polys[1], np.int64)
    else:
        counts = np.fromiter(map(len, polys), np.int64, len(polys))
        flat = np.fromiter(itertools.chain.from_iterable(polys), np.int64, int(counts.sum()))
    if counts.size and (counts == 3).all():
        return flat.reshape(-1, 3)
    off = np.zeros(len(counts), np.int64)
    np.cumsum(counts[:-1], out=off[1:])
    ntri = np.maximum(counts - 2, 0)
    at = np.zeros(len(counts), np.int64)  # first output row of each polygon
    np.cumsum(ntri[:-1], out=at[1:])
    out = np.empty((int(ntri.sum()), 3), np.int64)
    n = 0 if V is None else len(V)
    inside = np.zeros(len(counts), bool)  # every corner indexes V
    nz = np.flatnonzero(counts > 0)
    if n and nz.size:
        inside[nz] = (np.minimum.reduceat(flat, off[nz]) >= 0) & (np.maximum.reduceat(flat, off[nz]) < n)

    k3 = np.flatnonzero(counts == 3)
    out[at[k3]] = flat[off[k3, None] + np.arange(3)]
    k4 = np.flatnonzero(counts == 4)
    if k4.size:
        Q = flat[off[k4, None] + np.arange(4)]
        use13 = np.zeros(len(k4), bool)
        ok = inside[k4]
        if ok.any():
            with np.errstate(invalid="ignore", over="ignore"):
                P = V[Q[ok]]
                n1 = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])  # triangle 0-1-2
                n2 = np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0])  # triangle 0-2-3
                use13[ok] = np.einsum("ij,ij->i", n1, n2) < 0  # 1 and 3 on one side of 0-2: 0-2 lies outside
        out[at[k4]] = np.where(use13[:, None], Q[:, [1, 2, 3]], Q[:, [0, 1, 2]])
        out[at[k4] + 1] = np.where(use13[:, None], Q[:, [1, 3, 0]], Q[:, [0, 2, 3]])
    for i in np.flatnonzero(counts > 4).tolist():
        p = flat[off[i]:off[i] + counts[i]].tolist()
        tris = ear_clip(V, p) if inside[i] else [(p[0], p[j], p[j + 1]) for j in range(1, len(p) - 1)]
        out[at[i]:at[i] + len(tris)] = tris
    n_poly = int(np.count_nonzero(counts > 3))
    n_small = int(np.count_nonzero(counts < 3))
    if n_poly:
        notes.append(f"{n_poly} polygons with more than 3 corners split into triangles")
    if n_small:
        notes.append(f"{n_small} faces with fewer than 3 corners dropped")
    return out


def ear_clip(V, poly):
    """Ear clipping of one polygon in the plane of its Newell normal."""
    idx = list(poly)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        P = np.asarray(V, np.float64)[idx]
        P = P - P.mean(axis=0)
        nrm = np.sum(np.cross(P, np.roll(P, -1, axis=0)), axis=0)  # Newell normal (twice the vector area)
        ln = np.linalg.norm(nrm)
        if not np.isfinite(ln) or ln == 0:
            return [(idx[0], idx[j], idx[j + 1]) for j in range(1, len(idx) - 1)]
        nrm = nrm / ln
        t = np.array([1.0, 0.0, 0.0]) if abs(nrm[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(nrm, t)
        u /= np.linalg.norm(u)
        w = np.cross(nrm, u)
        xy = np.column_stack([P @ u, P @ w]).tolist()  # counter-clockwise seen along nrm

    def cross2(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    rest = list(range(len(idx)))
    out = []
    while len(rest) > 3:
        for j in range(len(rest)):
            i0, i1, i2 = rest[j - 1], rest[j], rest[(j + 1) % len(rest)]
            a, b, c = xy[i0], xy[i1], xy[i2]
            if cross2(a, b, c) <= 0:
                continue  # reflex or flat corner: not an ear
            inside = False
            for r in rest:
                if r in (i0, i1, i2):
                    continue
                q = xy[r]
                if cross2(a, b, q) >= 0 and cross2(b, c, q) >= 0 and cross2(c, a, q) >= 0:
                    inside = True
                    break
            if not inside:
                out.append((idx[i0], idx[i1], idx[i2]))
                del rest[j]
                break
        else:  # no ear: a self-crossing outline; fan what is left
            out.extend((idx[rest[0]], idx[rest[j]], idx[rest[j + 1]]) for j in range(1, len(rest) - 1))
            return out
    out.append(tuple(idx[r] for r in rest))
    return out
