"""Choose a hole's fairing order by what the scan says at the hole's own size (``order="auto"``).

Which fairing order continues a scan best depends on the surface and on
the hole's size against it: order 1 (harmonic, a membrane) is truest on a
planar cut or a CAD face, order 2 (thin plate) where the scan carries
relief or noise that a higher order would carry on into the hole, order 3
(curvature continuous) on smooth curved surfaces and large holes in them.
Instead of rules on the rim's bends, the opening's plane or a band of scan
next to the rim, one measured criterion decides (:func:`choose_order`):

1. Cut test holes of the hole's own outline and size into intact scan
   near it (:func:`shellrepair.probe.probe_errors`: up to ``PROBES``,
   spread around the hole; a disc of its area where the outline does not
   fit; half and a quarter of the size only where nothing of the full
   size fits), their rims given the real rim's roughness
   (:func:`shellrepair.probe.rim_roughness`: a ragged rim is noise that a
   higher order carries on into the hole).
2. Fill each with every candidate order exactly as a hole is filled
   (:func:`_refined`: triangulate, refine; then
   :func:`shellrepair.fair.fair_patch_orders`).
3. Measure each fill against the scan that was cut away: the RMS
   distance of the removed vertices to the filled surface
   (:func:`point_mesh_distance`), pooled over the test holes.
4. The order with the lowest error fills the real hole; equal errors
   (a test hole too small for new vertices fills alike at every order) go
   to ``DEFAULT_ORDER``, then to the lower order.

Where no test hole fits (the hole is as large as the intact scan around
it) the scan cannot tell: the hole takes ``DEFAULT_ORDER`` and the report
says so. Holes with fewer than ``MIN_EDGES`` rim edges are not tested (a
patch of a few triangles, where the orders differ by less than the scan's
own noise). A tube (the band between two loops) is tested by its own
kind: test bands beside its loops, refilled as tubes
(:func:`shellrepair.probe.tube_errors`, :func:`shellrepair.fill.band_order`).

Judged by its regret (the default's RMS over the best forced order's,
``eval/regret.py``) on stress cases of seeds never used while developing
it: BENCHMARKS.md, "The order test".
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from . import kernels

__all__ = ["choose_order", "best_candidate", "point_mesh_distance", "OrderTest", "CANDIDATES", "DEFAULT_ORDER"]

#: Candidate fairing orders (ties go to ``DEFAULT_ORDER``, then the lower order).
CANDIDATES = (1, 2, 3)
#: The order of holes that are not tested, or where the scan cannot tell.
DEFAULT_ORDER = 2
#: Holes with fewer rim edges are not tested.
MIN_EDGES = 8
#: Cotangent rounds of the test's fairing (the fill itself uses
#: ``fair.COTAN_ROUNDS``); fewer make the test cheaper.
TEST_ROUNDS = 2
#: A test hole that refined at the rim's density would have more than this
#: many new vertices is refined at ``TEST_COARSEN`` times the rim's edge
#: length instead (about ``TEST_COARSEN²`` times fewer unknowns).
TEST_MAX_UNKNOWNS = 1000
TEST_COARSEN = 2.0
#: Triangles nearest (by centroid) to each measured point searched for its closest point.
NEAREST_TRIANGLES = 8


@dataclass(frozen=True)
class OrderTest:
    """What :func:`choose_order` found for one hole.

    Attributes
    ----------
    order : int
        The chosen order.
    errors : dict of int -> float
        RMS distance of the scan cut away by the test holes to each
        candidate's fill, in the scan's units (empty when not tested).
    probes : int
        Test holes filled (0 when not tested).
    scale : float
        Their size over the hole's (1, 0.5 or 0.25; 0 when not tested).
    why : str
        Why the hole was not tested, or ''.
    """

    order: int
    errors: dict = field(default_factory=dict)
    probes: int = 0
    scale: float = 0.0
    why: str = ""

    @property
    def runner_up(self):
        """The candidate with the next lowest error, or None."""
        rest = sorted((e, o) for o, e in self.errors.items() if o != self.order)
        return rest[0][1] if rest else None

    def as_dict(self):
        """The report's ``choice`` field of a hole: the chosen order, the
        runner-up, each candidate's test RMS (scan units), how many test
        holes and at which scale, and ``untold`` where the scan could not
        tell (or the hole was too small to test) and the default was taken."""
        return {"by": "test holes" if self.errors else "default",
                "order": int(self.order),
                "runner_up": None if self.runner_up is None else int(self.runner_up),
                "test_rms": {str(o): float(e) for o, e in sorted(self.errors.items(), key=lambda t: str(t[0]))},
                "probes": int(self.probes), "scale": float(self.scale),
                "untold": not self.errors, "why": self.why}

    def describe(self):
        """One line for the report: the choice, its evidence and the runner-up."""
        if not self.errors:
            return f"auto: order {self.order}, {self.why}"
        size = "its size" if self.scale == 1.0 else f"{self.scale:g} its size"
        errs = ", ".join(f"order {o} {e:.3g}" for o, e in sorted(self.errors.items()))
        line = f"auto: order {self.order}, by {self.probes} test holes of {size}, RMS {errs}"
        ru = self.runner_up
        if ru is not None:
            line += f"; runner-up order {ru}"
        return line


def choose_order(ctx, hole_id, loop, candidates=None):
    """Pick the fairing order of one hole by test holes of its size (module docstring).

    Parameters
    ----------
    ctx : shellrepair.patch._Context
        The scan (read only).
    hole_id : int
    loop : (k,) int64
        The hole's rim.
    candidates : sequence of int, optional
        Default :data:`CANDIDATES`.

    Returns
    -------
    test : OrderTest
    """
    from .probe import probe_errors

    candidates = CANDIDATES if candidates is None else tuple(candidates)
    loop = np.asarray(loop, np.int64)
    k = len(loop)
    if k < MIN_EDGES:
        return OrderTest(DEFAULT_ORDER, why=f"{k} rim edges, not tested")
    errors, n, scale = probe_errors(ctx, loop, candidates)
    if not errors:
        return OrderTest(DEFAULT_ORDER, why="no intact scan of the hole's size around it: the scan cannot tell")
    best = best_candidate({o: errors[o] for o in candidates})
    return OrderTest(int(best), errors=errors, probes=n, scale=scale)


def best_candidate(errors):
    """The candidate with the lowest error; equal errors go to
    ``DEFAULT_ORDER``, then to the lower order (the fairing orders come
    before ``probe.HELD``).

    Parameters
    ----------
    errors : dict of (int or str) -> float

    Returns
    -------
    candidate : int or str
    """
    return min(errors, key=lambda o: (errors[o], o != DEFAULT_ORDER, str(o)))


def _refined(ctx, loop, rings):
    """The test hole triangulated and refined as :func:`~shellrepair.patch.build_patch`
    does, in the hole's local frame, with ``rings`` rings of scan around it;
    at ``TEST_COARSEN`` times the rim's edge length when the rim's density
    would give more than ``TEST_MAX_UNKNOWNS`` new vertices.

    Returns ((X, Fs, nf, g, scale, origin), T, c): the submesh positions
    (fixed scan vertices first), its faces (the patch's last), the number
    of fixed vertices, their ids in ``ctx``, the frame, the patch
    triangles, and the refinement's edge length in rim edges (1 or
    ``TEST_COARSEN``).
    """
    from .patch import _local_frame, _rim_data, _submesh
    from .refine import refine_patch
    from .triangulate import triangulate_loop

    k = len(loop)
    sigma, edge_normals, forbidden = _rim_data(ctx, loop)
    origin, scale, Pl = _local_frame(ctx, loop, sigma)
    T = triangulate_loop(Pl, edge_normals, forbidden)
    # new vertices at the rim's density: ~ the area over an equilateral
    # triangle's, halved (a mesh has about half as many vertices as faces)
    e = Pl[T]
    area = 0.5 * np.linalg.norm(np.cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]), axis=1).sum()
    s2 = float(np.mean(sigma / scale)) ** 2
    c = TEST_COARSEN if area / (np.sqrt(3.0) / 4.0 * s2) / 2.0 > TEST_MAX_UNKNOWNS else 1.0
    Pl, T = refine_patch(Pl, T, c * sigma / scale, k, forbidden)
    g, Fs, nf, _ = _submesh(ctx, loop, Pl, T, rings=rings)
    X = np.vstack([(ctx.V[g] - origin) / scale, Pl[k:]])
    return (X, Fs, nf, g, scale, origin), T, c


def point_mesh_distance(Q, V, F, nearest=NEAREST_TRIANGLES):
    """Distance of points to a small triangle mesh.

    Each point is measured against the ``nearest`` triangles whose centroids
    are closest to it (exact point-triangle distance), which is the true
    distance for a patch of triangles of even size like a refined fill.

    Parameters
    ----------
    Q : (p,3) float64
    V : (n,3) float64
    F : (m,3) int64

    Returns
    -------
    d : (p,) float64
    """
    Q = np.asarray(Q, np.float64)
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if len(Q) == 0 or len(F) == 0:
        return np.full(len(Q), np.inf)
    kk = min(int(nearest), len(F))
    if kernels.ENABLED:    # the same operations, compiled
        _, idx = cKDTree(kernels.centroids(V, F)).query(Q, k=kk)
        return kernels.nearest_triangle_distances(Q, V, F, np.asarray(idx).reshape(len(Q), kk))
    T = V[F]
    _, idx = cKDTree(T.mean(axis=1)).query(Q, k=kk)
    idx = np.asarray(idx).reshape(len(Q), kk)
    P = np.repeat(Q, kk, axis=0)
    Tn = T[idx.ravel()]
    E = P - _closest_on_triangles(P, Tn[:, 0], Tn[:, 1], Tn[:, 2])
    d = np.sqrt(_dot3(E, E))
    return d.reshape(len(Q), kk).min(axis=1)


def _dot3(a, b):
    """Row-wise dot products of (n,3) arrays, summed left to right (as the
    compiled :func:`shellrepair.kernels.nearest_triangle_distances` does; einsum's
    order depends on the CPU's vector width)."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _closest_on_triangles(P, A, B, C):
    """Closest point of triangle ABC to P, row by row.

    The point is written as A + v (B − A) + w (C − A); the barycentric
    coordinates of P's projection are clamped to the triangle, checking the
    three edges where the projection falls outside (degenerate triangles
    reduce to their longest edge's segment).
    """
    AB, AC = B - A, C - A
    AP = P - A
    d00 = _dot3(AB, AB)
    d01 = _dot3(AB, AC)
    d11 = _dot3(AC, AC)
    d20 = _dot3(AP, AB)
    d21 = _dot3(AP, AC)
    den = d00 * d11 - d01 * d01
    ok = den > 1e-30 * np.maximum(d00 * d11, 1e-300)
    inv = np.where(ok, 1.0 / np.where(ok, den, 1.0), 0.0)
    v = (d11 * d20 - d01 * d21) * inv
    w = (d00 * d21 - d01 * d20) * inv
    inside = ok & (v >= 0) & (w >= 0) & (v + w <= 1)
    X = A + v[:, None] * AB + w[:, None] * AC
    best = np.where(inside, np.sqrt(_dot3(P - X, P - X)), np.inf)
    out = X.copy()
    for S, E in ((A, B), (B, C), (C, A)):   # the edges, for points projecting outside
        D = E - S
        t = np.clip(_dot3(P - S, D) / np.maximum(_dot3(D, D), 1e-300), 0.0, 1.0)
        Y = S + t[:, None] * D
        dy = np.sqrt(_dot3(P - Y, P - Y))
        take = ~inside & (dy < best)
        out[take] = Y[take]
        best = np.where(take, dy, best)
    return out
