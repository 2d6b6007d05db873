"""Benchmark cases: a closed ground truth and a seeded perforation of it.

Every case keeps the closed mesh it was cut from, so a filled surface can be
measured against the true one (:mod:`eval.metrics`). Everything is
deterministic from a seed.

Ground truths
-------------
``icosphere``, ``torus``, ``ellipsoid``, ``bumpy_sphere`` (a sphere with fine
radial relief, like a cast statue's surface) from :mod:`eval.shapes`,
and the closed real scans ``closed_armadillo.ply`` and
``closed_nefertiti_bust.ply`` from ``../shared/data`` (or the folder named by
the environment variable ``SHELLREPAIR_DATA``). A clone without them gets a
bumpy sphere in their place and the case says so in its ``notes``.
All coordinates are rounded to float32, as a scan stored in a PLY ``float``
file is, so every tool sees vertices it can store exactly.

Perforations
------------
* :func:`disc_mask`: geodesic discs (small / medium / large).
* :func:`occlusion_mask`: scanner occlusion. A handheld scanner circles the
  object on a ring or a helix; a triangle is *seen* from a position when the
  ray from the scanner to its centroid hits that triangle first and meets it
  at less than ``max_incidence`` from its normal. Every triangle no position
  saw is deleted (deep folds, under the chin, between the legs).
* :func:`tiny_holes_mask`: many (about 150) tiny holes, one- and two-ring
  wide, like the paper's scan.
* hard cases: :func:`pinch_mask` (two holes touching at one vertex),
  :func:`slit_mask`, a saddle hole (a disc on a torus's inner equator),
  :func:`split_rim_edges` (slivers along a rim), :func:`band_mask` (a band
  between two loops) and :func:`area_fraction_mask` (one hole of 30 % of the
  surface).

After removing faces, pieces cut off from the main surface are removed too
(``keep_largest``), as a scan's islands would be cleaned; their faces count
as removed. Pieces are joined across edges, so faces hanging on by a single
vertex between two holes are removed with the islands.
"""

from __future__ import annotations

import os
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from eval import shapes
from shellrepair.holes.loops import boundary_loops
from shellrepair.mesh.topology import edge_topology, face_areas, face_pieces

__all__ = ["Case", "SHARED_DATA", "ground_truth", "make_case", "disc_mask", "occlusion_mask",
           "scanner_positions", "occlusion_scanner", "tiny_holes_mask", "pinch_mask", "slit_mask", "band_mask",
           "area_fraction_mask", "split_rim_edges", "suite", "case_names", "build_case"]

SHARED_DATA = Path(os.environ.get("SHELLREPAIR_DATA",
                                  Path(__file__).resolve().parents[2] / "shared" / "data"))

REAL_SCANS = {"armadillo": "closed_armadillo.ply", "nefertiti": "closed_nefertiti_bust.ply"}


@dataclass
class Case:
    """A perforated mesh and the closed surface it was cut from.

    Attributes
    ----------
    name, family, truth : str
        ``family`` is ``discs``, ``occlusion``, ``tiny`` or ``hard``;
        ``truth`` names the ground truth.
    description : str
    V_true : (N,3) float64 array
    F_true : (M,3) int64 array
        The closed ground truth.
    V : (n,3) float64 array
    F : (m,3) int64 array
        The perforated mesh; ``V = V_true[kept_vertices]``.
    removed : (M,) bool array
        Faces of ``F_true`` that are missing from ``F``.
    kept_vertices : (n,) int64 array
    seed : int
    notes : list of str
    """

    name: str
    family: str
    truth: str
    description: str
    V_true: np.ndarray
    F_true: np.ndarray
    V: np.ndarray
    F: np.ndarray
    removed: np.ndarray
    kept_vertices: np.ndarray
    seed: int = 0
    notes: list = field(default_factory=list)

    @property
    def n_loops(self):
        """Boundary loops of the perforated mesh (every one is a hole)."""
        loops, _ = boundary_loops(self.F, len(self.V))
        return len(loops)

    def summary(self):
        return {"name": self.name, "family": self.family, "truth": self.truth,
                "description": self.description, "seed": int(self.seed),
                "faces_true": int(len(self.F_true)), "faces": int(len(self.F)),
                "vertices": int(len(self.V)), "removed_faces": int(self.removed.sum()),
                "notes": list(self.notes)}


# --------------------------------------------------------------------------
# ground truths
# --------------------------------------------------------------------------
def _f32(V):
    """Round coordinates to float32 (as a PLY ``float`` stores them)."""
    return np.asarray(V, np.float64).astype(np.float32).astype(np.float64)


def ground_truth(name, *, quick=False):
    """A closed, outward-oriented ground-truth mesh.

    Parameters
    ----------
    name : str
        ``icosphere``, ``torus``, ``ellipsoid``, ``bumpy_sphere``,
        ``armadillo`` or ``nefertiti``.
    quick : bool
        Smaller meshes (for tests).

    Returns
    -------
    V : (n,3) float64, F : (m,3) int64, notes : list of str
        A real scan that is not available is replaced by a bumpy sphere and
        ``notes`` says so.
    """
    notes = []
    if name == "icosphere":
        V, F = shapes.icosphere(3 if quick else 5)
    elif name == "torus":
        V, F = shapes.torus(1.0, 0.35, 64 if quick else 192, 24 if quick else 64)
    elif name == "ellipsoid":
        V, F = shapes.ellipsoid(3 if quick else 5, axes=(1.0, 0.7, 0.5))
    elif name == "bumpy_sphere":
        # relief wavelength 2*pi/24 = 0.26, about 15 edges at 6 subdivisions
        V, F = shapes.bumpy_sphere(4 if quick else 6, amplitude=0.01, frequency=24, seed=7)
    elif name in REAL_SCANS:
        path = SHARED_DATA / REAL_SCANS[name]
        if not path.exists():
            notes.append(f"{REAL_SCANS[name]} not found in {SHARED_DATA}: a synthetic bumpy sphere stands in")
            V, F = shapes.bumpy_sphere(4 if quick else 6, amplitude=0.01, frequency=24, seed=7)
        else:
            from shellrepair.mesh.io import read_mesh

            m = read_mesh(path)
            V, F = m.V, m.F
    else:
        raise ValueError(f"unknown ground truth '{name}'")
    return _f32(V), np.asarray(F, np.int64), notes


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def _edge_graph(V, F):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    A = sp.csr_matrix((w, (E[:, 0], E[:, 1])), shape=(len(V), len(V)))
    return A.maximum(A.T).tocsr()


def _mean_edge(V, F):
    return float(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean())


def _surface_scale(V, F):
    """sqrt of the surface area: the length unit of disc radii."""
    return float(np.sqrt(face_areas(V, F).sum()))


def _case_seed(name, seed):
    return (zlib.crc32(name.encode()) + 7919 * int(seed)) % (2 ** 31)


def _pick_centers(A, n, sep, rng, candidates=None, max_tries=None):
    """Up to ``n`` vertices pairwise at least ``sep`` apart (edge-graph distance)."""
    nv = A.shape[0]
    pool = np.arange(nv) if candidates is None else np.asarray(candidates)
    dmin = np.full(nv, np.inf)
    centers = []
    for _ in range(max_tries or 200 * n):
        if len(centers) == n:
            break
        c = int(pool[rng.integers(len(pool))])
        if dmin[c] < sep:
            continue
        centers.append(c)
        d = dijkstra(A, indices=c, limit=sep)
        dmin = np.minimum(dmin, d)
    return centers


def keep_largest(F, remove):
    """Also remove every face outside the largest piece that remains.

    Pieces are faces joined across edges: a face left hanging on by one
    vertex (debris between two holes) is cut off like an island, as a scan's
    clean-up would remove it. Every tool gets the same cleaned input.
    """
    remove = np.asarray(remove, bool).copy()
    keep = np.flatnonzero(~remove)
    if keep.size == 0:
        return remove
    n = int(F.max()) + 1
    Fk = F[keep]
    nc, fc = face_pieces(edge_topology(Fk, n), len(Fk))
    if nc > 1:
        big = np.argmax(np.bincount(fc))
        remove[keep[fc != big]] = True
    return remove


# --------------------------------------------------------------------------
# perforations
# --------------------------------------------------------------------------
def disc_mask(V, F, n_holes, radius, seed=0, separation=3.0):
    """Faces within geodesic discs of ``radius`` around ``n_holes`` seeded centres.

    Parameters
    ----------
    V : (n,3) float64, F : (m,3) int64
    n_holes : int
    radius : float
        Edge-graph geodesic radius; a face with a vertex closer than this to
        a centre is removed.
    seed : int
    separation : float
        Centres are at least ``separation * radius`` apart.

    Returns
    -------
    remove : (m,) bool
    """
    A = _edge_graph(V, F)
    rng = np.random.default_rng(seed)
    centers = _pick_centers(A, n_holes, separation * radius, rng)
    d = dijkstra(A, indices=centers, limit=radius, min_only=True)
    return (d[F] < radius).any(axis=1)


def tiny_holes_mask(V, F, n_holes=150, seed=0, rings=(1.0, 2.2), separation=7.0):
    """Many tiny holes: one- to two-ring discs around ``n_holes`` centres.

    Radii are drawn uniformly in ``rings`` times the mean edge length;
    centres are ``separation`` mean edges apart so holes never merge.
    """
    e = _mean_edge(V, F)
    A = _edge_graph(V, F)
    rng = np.random.default_rng(seed)
    centers = _pick_centers(A, n_holes, separation * e, rng)
    remove = np.zeros(len(F), bool)
    radii = rng.uniform(rings[0], rings[1], len(centers)) * e
    for c, r in zip(centers, radii):
        d = dijkstra(A, indices=c, limit=r)
        remove |= (d[F] < r).any(axis=1)
    return remove


def scanner_positions(V, n_views=36, *, path="helix", turns=3.0, elevation=(-25.0, 55.0),
                      distance=1.5, up=None, seed=0):
    """Positions of a handheld scanner circling the object.

    Parameters
    ----------
    V : (n,3) float64
    n_views : int
    path : str
        ``'ring'`` (one height, the middle of ``elevation``) or ``'helix'``
        (``turns`` turns rising from ``elevation[0]`` to ``elevation[1]``).
    elevation : (2,) degrees
        Above the object's centre, seen from it.
    distance : float
        Distance from the centre in bounding-box diagonals.
    up : int, optional
        Axis the scanner circles around; default the longest extent.
    seed : int
        Phase and a small jitter of the positions.

    Returns
    -------
    P : (n_views,3) float64
    """
    V = np.asarray(V, np.float64)
    lo, hi = V.min(axis=0), V.max(axis=0)
    c = 0.5 * (lo + hi)
    diag = float(np.linalg.norm(hi - lo))
    ax = int(np.argmax(hi - lo)) if up is None else int(up)
    u = np.zeros(3)
    u[ax] = 1.0
    e1 = np.zeros(3)
    e1[(ax + 1) % 3] = 1.0
    e2 = np.cross(u, e1)
    rng = np.random.default_rng(seed)
    k = np.arange(n_views)
    if path == "helix":
        theta = rng.uniform(0, 2 * np.pi) + 2 * np.pi * turns * k / n_views
        el = np.linspace(elevation[0], elevation[1], n_views)
    elif path == "ring":
        theta = rng.uniform(0, 2 * np.pi) + 2 * np.pi * k / n_views
        el = np.full(n_views, 0.5 * (elevation[0] + elevation[1]))
    else:
        raise ValueError(f"path must be 'ring' or 'helix', got '{path}'")
    theta = theta + rng.normal(0.0, 0.5 * np.pi / n_views, n_views)
    el = np.radians(el + rng.normal(0.0, 1.0, n_views))
    R = distance * diag
    dirs = (np.cos(el)[:, None] * (np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2)
            + np.sin(el)[:, None] * u)
    return c + R * dirs


def occlusion_mask(V, F, positions, *, max_incidence=75.0):
    """Faces that no scanner position saw (ray-cast with open3d).

    Parameters
    ----------
    V : (n,3) float64, F : (m,3) int64
        A closed, outward-oriented mesh.
    positions : (k,3) float64
        Scanner positions (:func:`scanner_positions`).
    max_incidence : float
        Degrees; a face seen at a larger angle from its normal (grazing) is
        not measured.

    Returns
    -------
    remove : (m,) bool
        True for faces no ray saw.

    Notes
    -----
    From each position one ray goes to each face's centroid; the face is
    seen when that ray's first hit is the face itself and it faces the
    scanner within ``max_incidence``. The result depends only on the
    positions, so it is deterministic.
    """
    import open3d as o3d

    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    c = 0.5 * (V.min(axis=0) + V.max(axis=0))
    Vc = (V - c).astype(np.float32)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(Vc), o3d.core.Tensor(F.astype(np.uint32)))
    T = V[F] - c
    C = T.mean(axis=1)
    N = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)
    cos_max = np.cos(np.radians(max_incidence))
    ids = np.arange(len(F))
    seen = np.zeros(len(F), bool)
    for p in np.asarray(positions, np.float64) - c:
        D = C - p
        D /= np.linalg.norm(D, axis=1, keepdims=True)
        facing = -(N * D).sum(axis=1) > cos_max
        idx = np.flatnonzero(facing & ~seen)
        if idx.size == 0:
            continue
        rays = np.concatenate([np.broadcast_to(p, (idx.size, 3)), D[idx]], axis=1).astype(np.float32)
        hit = scene.cast_rays(o3d.core.Tensor(rays))["primitive_ids"].numpy().astype(np.int64)
        seen[idx[hit == ids[idx]]] = True
    return ~seen


def _fan(F, v):
    """Faces around vertex ``v`` in rotational order (closed manifold fan)."""
    fan = np.flatnonzero((F == v).any(axis=1))
    nxt = {}
    for f in fan:
        k = int(np.flatnonzero(F[f] == v)[0])
        nxt[int(F[f][(k + 1) % 3])] = (int(F[f][(k + 2) % 3]), int(f))
    start = next(iter(nxt))
    order, a = [], start
    for _ in range(len(fan)):
        a, f = nxt[a]
        order.append(f)
        if a == start:
            break
    return order


def pinch_mask(V, F, seed=0, grow=2):
    """Two holes that touch at exactly one vertex.

    Two opposite pairs of faces of a vertex's fan are removed, each grown
    ``grow`` rings outward (never through the shared vertex), and any face
    that would join the two holes elsewhere is kept.
    """
    rng = np.random.default_rng(seed)
    val = np.bincount(F.ravel(), minlength=len(V))
    cand = np.flatnonzero(val == 6)
    v = int(cand[rng.integers(len(cand))])
    fan = _fan(F, v)
    k = len(fan)
    A = {fan[0], fan[1]}
    B = {fan[k // 2], fan[k // 2 + 1]}
    has_v = (F == v).any(axis=1)
    ring1 = set(np.unique(F[fan]).tolist())
    kept_fan = set(np.unique(F[[f for f in fan if f not in A | B]]).tolist())
    for S in (A, B):
        # grow away from v: only from vertices no kept fan face uses
        seeds = set(np.unique(F[list(S)]).tolist()) - kept_fan
        for _ in range(grow):
            new = np.flatnonzero(np.isin(F, list(seeds)).any(axis=1) & ~has_v)
            S.update(int(f) for f in new)
            seeds = set(np.unique(F[new]).tolist()) - ring1
    # keep the holes apart except at v
    while True:
        va = set(np.unique(F[list(A)]).tolist())
        vb = set(np.unique(F[list(B)]).tolist())
        shared = (va & vb) - {v}
        if not shared:
            break
        drop = {f for f in A | B if (set(F[f].tolist()) & shared) and v not in F[f]}
        A -= drop
        B -= drop
    remove = np.zeros(len(F), bool)
    remove[list(A | B)] = True
    return remove


def slit_mask(V, F, length=0.8, seed=0):
    """A slit: the faces touching a shortest edge path of about ``length``."""
    A = _edge_graph(V, F)
    rng = np.random.default_rng(seed)
    s = int(rng.integers(len(V)))
    d, pred = dijkstra(A, indices=s, return_predecessors=True)
    t = int(np.argmin(np.abs(d - length)))
    path = [t]
    while path[-1] != s:
        path.append(int(pred[path[-1]]))
    path = np.array(path[1:-1])  # the ends stay, so the slit tapers
    return np.isin(F, path).any(axis=1)


def band_mask(V, F, start=0.0, width=0.35):
    """A band across a torus's tube: faces with a vertex whose azimuth is in
    ``[start, start + width)`` radians. Leaves two loops that the true
    surface joins with a tube."""
    phi = np.mod(np.arctan2(V[:, 1], V[:, 0]) - start, 2 * np.pi)
    return (phi[F] < width).any(axis=1)


def area_fraction_mask(V, F, fraction=0.3, seed=0):
    """One hole of ``fraction`` of the surface area: a geodesic disc grown
    from a seeded centre until it covers that fraction."""
    rng = np.random.default_rng(seed)
    c = int(rng.integers(len(V)))
    d = dijkstra(_edge_graph(V, F), indices=c)
    fd = d[F].max(axis=1)
    order = np.argsort(fd, kind="stable")
    A = face_areas(V, F)
    cum = np.cumsum(A[order])
    k = int(np.searchsorted(cum, fraction * cum[-1]))
    remove = np.zeros(len(F), bool)
    remove[order[:k + 1]] = True
    return remove


def split_rim_edges(V, F, remove, t=0.03):
    """Put slivers along a hole's rim without changing the surface.

    Every edge between a removed and a kept face is split at ``t`` of its
    length; both faces beside it are split in two, so the rim gets a short
    edge and a sliver on each side. The new point lies on the edge, so the
    surface (the ground truth) is geometrically unchanged.

    Returns
    -------
    V2, F2 : the refined closed mesh
    remove2 : (m2,) bool
    """
    V = np.asarray(V, np.float64)
    F = [list(map(int, f)) for f in np.asarray(F, np.int64)]
    rem = list(map(bool, remove))
    he_face = {}
    for i, (a, b, c) in enumerate(F):
        he_face[(a, b)] = i
        he_face[(b, c)] = i
        he_face[(c, a)] = i
    rim = sorted({(min(a, b), max(a, b)) for (a, b), f in he_face.items()
                  if (b, a) in he_face and rem[f] and not rem[he_face[(b, a)]]})
    P = list(V)
    for a, b in rim:
        m = len(P)
        P.append(V[a] + t * (V[b] - V[a]))
        for s, e in ((a, b), (b, a)):
            f = he_face.pop((s, e))
            tri = F[f]
            k = tri.index(s)
            o = tri[(k + 2) % 3]
            # (s, e, o) -> (s, m, o) and (m, e, o)
            F[f] = [s, m, o]
            F.append([m, e, o])
            rem.append(rem[f])
            g = len(F) - 1
            he_face[(s, m)] = f
            he_face[(m, o)] = f
            he_face[(o, s)] = f
            he_face[(m, e)] = g
            he_face[(e, o)] = g
            he_face[(o, m)] = g
    V2 = _f32(np.array(P))
    return V2, np.array(F, np.int64), np.array(rem, bool)


# --------------------------------------------------------------------------
# cases
# --------------------------------------------------------------------------
def make_case(name, family, truth, description, V_true, F_true, remove, *, seed=0, notes=(),
              clean=True):
    """Cut ``remove`` out of the ground truth (plus cut-off pieces) into a Case."""
    remove = keep_largest(F_true, remove) if clean else np.asarray(remove, bool)
    V, F, kept = shapes.remove_faces(V_true, F_true, remove)
    return Case(name=name, family=family, truth=truth, description=description,
                V_true=V_true, F_true=F_true, V=V, F=F, removed=remove, kept_vertices=kept,
                seed=int(seed), notes=list(notes))


DISC_SIZES = {"small": (6, 0.02), "medium": (4, 0.06), "large": (1, 0.15)}


def _discs(truth, size):
    def build(seed, quick):
        V, F, notes = ground_truth(truth, quick=quick)
        n, frac = DISC_SIZES[size]
        r = frac * _surface_scale(V, F)
        name = f"{truth}-discs-{size}"
        s = _case_seed(name, seed)
        rem = disc_mask(V, F, n, r, seed=s)
        return make_case(name, "discs", truth, f"{n} geodesic disc(s) of radius {frac:g}*sqrt(area)",
                         V, F, rem, seed=s, notes=notes)
    return build


#: Scanner paths of the occlusion cases: views, elevation range (degrees), and
#: the largest incidence angle a face is measured at. The helix leaves about
#: as many holes in the Nefertiti bust as the paper's statue had (156).
SCANNER_PATHS = {"helix": dict(n_views=24, elevation=(-10.0, 40.0), max_incidence=70.0),
                 "ring": dict(n_views=24, elevation=(20.0, 20.0), max_incidence=80.0)}


def occlusion_scanner(V, path, seed):
    """Scanner positions and max incidence of the occlusion cases."""
    p = SCANNER_PATHS[path]
    P = scanner_positions(V, p["n_views"], path=path, elevation=p["elevation"], seed=seed)
    return P, p["max_incidence"]


def _occlusion(truth, path):
    def build(seed, quick):
        V, F, notes = ground_truth(truth, quick=quick)
        name = f"{truth}-occlusion-{path}"
        s = _case_seed(name, seed)
        P, inc = occlusion_scanner(V, path, s)
        rem = occlusion_mask(V, F, P, max_incidence=inc)
        return make_case(name, "occlusion", truth,
                         f"faces unseen from {len(P)} scanner positions on a {path}", V, F, rem,
                         seed=s, notes=notes)
    return build


def _tiny(truth, n=150):
    def build(seed, quick):
        V, F, notes = ground_truth(truth, quick=quick)
        name = f"{truth}-tiny{n}"
        s = _case_seed(name, seed)
        rem = tiny_holes_mask(V, F, n_holes=n if not quick else n // 5, seed=s)
        return make_case(name, "tiny", truth, f"{n} one- to two-ring holes", V, F, rem, seed=s,
                         notes=notes)
    return build


def _hard(kind):
    def build(seed, quick):
        name = f"hard-{kind}"
        s = _case_seed(name, seed)
        if kind == "pinch":
            V, F, notes = ground_truth("icosphere", quick=quick)
            rem = pinch_mask(V, F, seed=s)
            return make_case(name, "hard", "icosphere", "two holes touching at one vertex", V, F, rem,
                             seed=s, notes=notes)
        if kind == "slit":
            V, F, notes = ground_truth("icosphere", quick=quick)
            rem = slit_mask(V, F, length=0.8, seed=s)
            return make_case(name, "hard", "icosphere", "a slit along a 0.8-long edge path", V, F, rem,
                             seed=s, notes=notes)
        if kind == "saddle":
            V, F, notes = ground_truth("torus", quick=quick)
            inner = np.flatnonzero(np.abs(V[:, 2]) < 1e-6)
            inner = inner[np.argsort(np.hypot(V[inner, 0], V[inner, 1]))][:8]
            rng = np.random.default_rng(s)
            c = int(inner[rng.integers(len(inner))])
            d = dijkstra(_edge_graph(V, F), indices=c, limit=0.3)
            rem = (d[F] < 0.25).any(axis=1)
            return make_case(name, "hard", "torus", "a disc on the torus's inner (saddle) equator",
                             V, F, rem, seed=s, notes=notes)
        if kind == "slivers":
            V, F, notes = ground_truth("icosphere", quick=quick)
            rem = disc_mask(V, F, 1, 0.35, seed=s)
            V, F, rem = split_rim_edges(V, F, rem, t=0.03)
            return make_case(name, "hard", "icosphere", "a disc whose rim edges are split at 3 %: slivers "
                             "along the rim", V, F, rem, seed=s, notes=notes)
        if kind == "band":
            V, F, notes = ground_truth("torus", quick=quick)
            rng = np.random.default_rng(s)
            rem = band_mask(V, F, start=rng.uniform(0, 2 * np.pi), width=0.35)
            return make_case(name, "hard", "torus", "a band across the tube: two loops the true surface "
                             "joins", V, F, rem, seed=s, notes=notes)
        if kind == "torus-hole-band":
            V, F, notes = ground_truth("torus", quick=quick)
            rho = np.hypot(V[:, 0], V[:, 1])
            R, r = 0.5 * (rho.max() + rho.min()), 0.5 * (rho.max() - rho.min())
            rng = np.random.default_rng(s)
            theta = np.radians(rng.uniform(35.0, 55.0))   # half-width of the band around the inner equator
            C = V[F].mean(axis=1)
            rem = np.hypot(C[:, 0], C[:, 1]) < R - r * np.cos(theta)
            return make_case(name, "hard", "torus", "the band around the torus's central hole (its inner "
                             f"side within {np.degrees(theta):.0f}° of the inner equator): two coaxial loops",
                             V, F, rem, seed=s, notes=notes)
        if kind == "bust-base":
            V, F, notes = ground_truth("nefertiti", quick=quick)
            rng = np.random.default_rng(s)
            frac = rng.uniform(0.06, 0.12)
            C = V[F].mean(axis=1)
            lo, hi = V[:, 2].min(), V[:, 2].max()          # the bust stands along z
            rem = C[:, 2] < lo + frac * (hi - lo)
            return make_case(name, "hard", "nefertiti", f"the bust's base: its bottom {100 * frac:.0f} % cut "
                             "off, as a scan that never saw it", V, F, rem, seed=s, notes=notes)
        if kind == "30pct":
            V, F, notes = ground_truth("ellipsoid", quick=quick)
            rem = area_fraction_mask(V, F, 0.30, seed=s)
            return make_case(name, "hard", "ellipsoid", "one hole of 30 % of the surface", V, F, rem,
                             seed=s, notes=notes)
        raise ValueError(kind)
    return build


#: name -> builder(seed, quick) -> Case, in the order the benchmark runs them.
SUITE = {
    "icosphere-discs-small": _discs("icosphere", "small"),
    "icosphere-discs-medium": _discs("icosphere", "medium"),
    "icosphere-discs-large": _discs("icosphere", "large"),
    "torus-discs-medium": _discs("torus", "medium"),
    "ellipsoid-discs-medium": _discs("ellipsoid", "medium"),
    "bumpy_sphere-discs-small": _discs("bumpy_sphere", "small"),
    "bumpy_sphere-discs-medium": _discs("bumpy_sphere", "medium"),
    "armadillo-discs-medium": _discs("armadillo", "medium"),
    "nefertiti-discs-medium": _discs("nefertiti", "medium"),
    "nefertiti-discs-large": _discs("nefertiti", "large"),
    "nefertiti-occlusion-helix": _occlusion("nefertiti", "helix"),
    "armadillo-occlusion-ring": _occlusion("armadillo", "ring"),
    "bumpy_sphere-tiny150": _tiny("bumpy_sphere"),
    "hard-pinch": _hard("pinch"),
    "hard-slit": _hard("slit"),
    "hard-saddle": _hard("saddle"),
    "hard-slivers": _hard("slivers"),
    "hard-band": _hard("band"),
    "hard-30pct": _hard("30pct"),
    "hard-torus-hole-band": _hard("torus-hole-band"),
    "hard-bust-base": _hard("bust-base"),
}


def case_names():
    return list(SUITE)


def build_case(name, seed=0, quick=False):
    """Build one case of the suite by name."""
    if name not in SUITE:
        raise ValueError(f"unknown case '{name}' (known: {', '.join(SUITE)})")
    return SUITE[name](seed, quick)


def suite(seed=0, quick=False, names=None):
    """Yield the cases (built one at a time), deterministic from ``seed``."""
    for name in (names or case_names()):
        yield build_case(name, seed, quick)
