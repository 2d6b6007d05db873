"""Synthetic meshes with known geometry, and seeded perforation.

Used by the tests and by ``eval/`` to make perforated meshes whose true
surface is known. All meshes are consistently oriented, normals outward.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

__all__ = ["icosphere", "torus", "grid", "ellipsoid", "bumpy_sphere", "cylinder",
           "geodesic_distance", "remove_faces", "perforate_discs", "range_scan"]


def icosphere(subdivisions=3, radius=1.0):
    """Unit icosphere.

    Parameters
    ----------
    subdivisions : int
        0 gives the icosahedron (12 vertices); each level splits every
        triangle in four.
    radius : float

    Returns
    -------
    V : (n,3) float64
    F : (m,3) int64
    """
    t = (1.0 + 5 ** 0.5) / 2.0
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    for _ in range(int(subdivisions)):
        V, F = _subdivide(V, F)
        V /= np.linalg.norm(V, axis=1, keepdims=True)
    return V * radius, F


def _subdivide(V, F):
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uE, inv = np.unique(E, axis=0, return_inverse=True)
    mids = 0.5 * (V[uE[:, 0]] + V[uE[:, 1]])
    m = len(F)
    n = len(V)
    a, b, c = inv[:m] + n, inv[m:2 * m] + n, inv[2 * m:] + n
    F2 = np.concatenate([np.column_stack([F[:, 0], a, c]), np.column_stack([F[:, 1], b, a]),
                         np.column_stack([F[:, 2], c, b]), np.column_stack([a, b, c])])
    return np.vstack([V, mids]), F2.astype(np.int64)


def torus(R=1.0, r=0.35, nu=64, nv=24):
    """Torus around the z axis.

    Parameters
    ----------
    R, r : float
        Major and minor radius.
    nu, nv : int
        Segments around the axis and around the tube.

    Returns
    -------
    V : (nu*nv,3) float64
    F : (2*nu*nv,3) int64
    """
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    U, W = np.meshgrid(u, v, indexing="ij")
    V = np.column_stack([((R + r * np.cos(W)) * np.cos(U)).ravel(),
                         ((R + r * np.cos(W)) * np.sin(U)).ravel(),
                         (r * np.sin(W)).ravel()])
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    F = np.concatenate([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                        np.column_stack([a.ravel(), c.ravel(), d.ravel()])]).astype(np.int64)
    return V, F


def cylinder(radius=0.5, height=2.0, nu=48, nh=40):
    """Open cylinder around the z axis (two border loops), z in [-h/2, h/2]."""
    u = 2 * np.pi * np.arange(nu) / nu
    z = np.linspace(-height / 2, height / 2, nh + 1)
    U, Z = np.meshgrid(u, z, indexing="ij")
    V = np.column_stack([(radius * np.cos(U)).ravel(), (radius * np.sin(U)).ravel(), Z.ravel()])
    i, j = np.meshgrid(np.arange(nu), np.arange(nh), indexing="ij")
    a = i * (nh + 1) + j
    b = ((i + 1) % nu) * (nh + 1) + j
    c = ((i + 1) % nu) * (nh + 1) + j + 1
    d = i * (nh + 1) + j + 1
    F = np.concatenate([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                        np.column_stack([a.ravel(), c.ravel(), d.ravel()])]).astype(np.int64)
    return V, F


def grid(nx=10, ny=10, size=1.0):
    """Flat triangulated square sheet in z = 0, normals +z.

    Parameters
    ----------
    nx, ny : int
        Vertices along x and y.
    size : float
        Side length.

    Returns
    -------
    V : (nx*ny,3) float64
    F : (2*(nx-1)*(ny-1),3) int64
    """
    x = np.linspace(0, size, nx)
    y = np.linspace(0, size, ny)
    X, Y = np.meshgrid(x, y, indexing="ij")
    V = np.column_stack([X.ravel(), Y.ravel(), np.zeros(nx * ny)])
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = i * ny + j
    b = (i + 1) * ny + j
    c = (i + 1) * ny + j + 1
    d = i * ny + j + 1
    F = np.concatenate([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                        np.column_stack([a.ravel(), c.ravel(), d.ravel()])]).astype(np.int64)
    return V, F


def ellipsoid(subdivisions=4, axes=(1.0, 0.7, 0.5)):
    """Icosphere scaled along x, y, z."""
    V, F = icosphere(subdivisions)
    return V * np.asarray(axes, float), F


def bumpy_sphere(subdivisions=5, amplitude=0.03, frequency=6, seed=0):
    """Unit sphere with smooth radial relief (a cast statue's fine surface).

    The radius is ``1 + amplitude * g(x)`` with ``g`` a sum of a few seeded
    sinusoids of the given frequency, so the relief is known analytically.
    """
    V, F = icosphere(subdivisions)
    r = 1.0 + amplitude * bump_field(V, frequency, seed)
    return V * r[:, None], F


def bump_field(P, frequency=6, seed=0):
    """The relief function of :func:`bumpy_sphere` on unit directions ``P``."""
    rng = np.random.default_rng(seed)
    D = rng.normal(size=(4, 3))
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    ph = rng.uniform(0, 2 * np.pi, 4)
    U = P / np.linalg.norm(P, axis=1, keepdims=True)
    return np.sum(np.sin(frequency * (U @ D.T) + ph), axis=1) / 4.0


def geodesic_distance(V, F, source):
    """Edge-graph (Dijkstra) distance from one vertex to all others."""
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    A = sp.csr_matrix((w, (E[:, 0], E[:, 1])), shape=(len(V), len(V)))
    A = A.maximum(A.T)
    return dijkstra(A, directed=False, indices=int(source))


def remove_faces(V, F, remove):
    """Delete faces and the vertices no face uses any more.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    remove : (m,) bool
        Faces to delete.

    Returns
    -------
    V2 : (k,3) float64
    F2 : (m',3) int64
    kept_vertices : (k,) int64
        ``V2 = V[kept_vertices]``.
    """
    F2 = F[~np.asarray(remove, bool)]
    kept = np.unique(F2)
    remap = np.full(len(V), -1, np.int64)
    remap[kept] = np.arange(kept.size)
    return V[kept], remap[F2], kept


def perforate_discs(V, F, n_holes=1, radius=0.3, seed=0, centers=None, min_separation=None):
    """Cut geodesic discs out of a closed mesh.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    n_holes : int
    radius : float
        Geodesic radius of each disc; faces with a vertex closer than this
        to the centre are removed.
    seed : int
        Picks the centres (ignored when ``centers`` is given).
    centers : list of int, optional
        Centre vertices.
    min_separation : float, optional
        Minimum geodesic distance between centres (default ``3*radius``)
        so discs do not merge.

    Returns
    -------
    V2, F2 : the perforated mesh (unused vertices removed)
    removed : (m,) bool
        Which faces of ``F`` were removed (the ground truth of the holes).
    kept_vertices : (k,) int64
    """
    rng = np.random.default_rng(seed)
    sep = 3 * radius if min_separation is None else min_separation
    if centers is None:
        centers = []
        dmin = np.full(len(V), np.inf)
        for _ in range(100 * n_holes):
            if len(centers) == n_holes:
                break
            c = int(rng.integers(len(V)))
            if dmin[c] < sep:
                continue
            centers.append(c)
            dmin = np.minimum(dmin, geodesic_distance(V, F, c))
    remove = np.zeros(len(F), bool)
    for c in centers:
        d = geodesic_distance(V, F, c)
        remove |= (d[F] < radius).any(axis=1)
    V2, F2, kept = remove_faces(V, F, remove)
    return V2, F2, remove, kept


def range_scan(V, F, view=(0.3, -1.0, 0.4), resolution=200, margin=0.55):
    """One view of a closed mesh as a range scanner triangulates it.

    An orthographic scanner looks along ``view`` at the mesh's centroid; a
    ``resolution`` x ``resolution`` grid of rays spanning ``2 * margin``
    times the bounding-box diagonal is cast (open3d), each hit a sample.
    The range grid is triangulated as the Stanford range scans of
    ../shared/data were: each 2x2 block of samples split along its shorter
    diagonal, a block with three samples gives one triangle, and triangles
    with an edge longer than 4x the grid spacing are dropped (depth jumps).
    The result is an open sheet: its outer border, holes where something in
    front hid the surface, islands, and pieces that meet at single vertices
    (two diagonal blocks around a missing sample), as on a real range scan.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    view : 3 floats
        Direction the scanner looks in.
    resolution : int
        Rays per side of the grid.
    margin : float
        Half the grid's side, in bounding-box diagonals.

    Returns
    -------
    P : (k,3) float64
        The samples any triangle uses, in grid order.
    T : (t,3) int64
        Triangles wound to face the scanner.
    """
    import open3d as o3d

    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    d = np.asarray(view, np.float64)
    d = d / np.linalg.norm(d)
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    up = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(up, d)
    u /= np.linalg.norm(u)
    w = np.cross(d, u)
    s = np.linspace(-margin, margin, int(resolution)) * diag
    gu, gw = np.meshgrid(s, s, indexing="ij")
    O = (V.mean(axis=0) - 2.0 * diag * d) + gu[..., None] * u + gw[..., None] * w
    O = O.reshape(-1, 3)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    rays = np.concatenate([O, np.broadcast_to(d, O.shape)], axis=1).astype(np.float32)
    t = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(np.float64)
    hit = np.isfinite(t)
    P = O[hit] + t[hit, None] * d
    idx = np.full(len(O), -1, np.int64)
    idx[hit] = np.arange(int(hit.sum()))
    grid_ids = idx.reshape(len(s), len(s))
    q = np.stack([grid_ids[:-1, :-1], grid_ids[1:, :-1], grid_ids[1:, 1:], grid_ids[:-1, 1:]], axis=-1).reshape(-1, 4)
    have = q >= 0
    full = have.all(axis=1)

    def length(a, b):
        return np.linalg.norm(P[a] - P[b], axis=1)

    Q = q[full]
    short_ac = length(Q[:, 0], Q[:, 2]) <= length(Q[:, 1], Q[:, 3])
    a, b, c, e = Q.T
    T = [np.c_[a, b, c][short_ac], np.c_[a, c, e][short_ac],
         np.c_[a, b, e][~short_ac], np.c_[b, c, e][~short_ac]]
    three = have.sum(axis=1) == 3
    if three.any():
        Q3 = q[three]
        T.append(Q3[Q3 >= 0].reshape(-1, 3))   # the three samples, in block order
    T = np.concatenate(T)
    longest = np.max([length(T[:, i], T[:, (i + 1) % 3]) for i in range(3)], axis=0)
    T = T[longest <= 4 * (s[1] - s[0])]
    n = np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]])
    away = n @ d > 0
    T[away] = T[away][:, ::-1]
    used = np.unique(T)
    at = np.full(len(P), -1, np.int64)
    at[used] = np.arange(used.size)
    return P[used], at[T]
