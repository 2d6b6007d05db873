"""Which fairing order continues the scan best, asked of the hole's own collar.

:func:`collar_errors` widens the hole by a collar of its own scan: the
faces within ``m`` rings of its rim are taken away, ``m`` being
``COLLAR_WIDTH`` times the hole's radius (:func:`shellrepair.fill.probe.hole_radius`)
over its mean rim edge, at least ``MIN_RINGS`` and at most ``MAX_RINGS``.
The widened hole is filled at every candidate order exactly as a test hole
is (triangulate, refine, fair with the rings beyond the collar held:
:func:`shellrepair.fill.probe._refined`,
:func:`shellrepair.fill.fair.fair_patch_orders`), and each fill is measured
against the scan it replaced: the RMS distance of the collar's removed
vertices to the filled surface. The order whose fill lies closest to them
fills the hole (:func:`shellrepair.fill.selftest.choose_order`).

Why the hole's own collar and not test holes beside it: a test hole of the
hole's size laid on the scan next to it sees other scan than the rim does.
On a bust's flat-cut base, the test holes lie on its curved walls; on a
CAD part, they cross its creases; on a large occlusion, none fits at all,
and the hole took order 2 by default. The collar is the scan that meets the
hole's own rim, at the hole's own place and outline, so it is there for
every hole whose surroundings are scan. It also says where order 3
balloons: on a disc of 188 rim edges in a Nefertiti (case 1 of seed
270074373) the test holes beside it rated order 3 first, whose patch lay
30.4 per mille from the truth where order 2 gives 0.84; a rule (order 3
kept only where its patch departed from order 2's less than order 1's did)
kept order 2 there, but also kept it on a rocker arm's occlusion where
order 3 is twice as true (case 7 of seed 569393493). The collar rates
order 2 first on the first and order 3 on the second, and the rule is gone.

Judged on six design seeds (eval/results/order-test/collar/), the
default's regret went 1.1735 -> 1.1505 (geometric mean over 96 cases) and
its cost over the fastest forced order 4.25 -> 3.24: one fill per order
instead of two or three test holes' fills. Collars of 0.05, 0.1, 0.3 and
0.5 of the radius gave 1.176, 1.168, 1.184 and 1.227; the validation seeds'
figures are in BENCHMARKS.md.

The collar is cut where it leaves one widened loop of scan around the
hole. Islands of scan inside the collar go with it (the largest piece of
the scan kept around the collar stays). Other holes the collar reaches
join the widened hole: its loop runs along collar edges and the scan's
own boundary edges, and the fill spans them all (only the collar's own
removed vertices are measured). Where the widened loop would run into the
edge of the region walked (the collar reaches the scan's open border, or
the hole is as large as the scan around it), or where more than one loop
would be left, no collar is cut and the test holes beside the hole decide
(:mod:`shellrepair.fill.probe`).
"""

from __future__ import annotations

import numpy as np

from shellrepair.mesh.geometry import mean_edge

__all__ = ["collar_errors", "collar_rings", "COLLAR_WIDTH", "MIN_RINGS", "MAX_RINGS"]

#: The collar's width, times the hole's radius (in rim edges: rings).
COLLAR_WIDTH = 0.15
#: At least this many rings.
MIN_RINGS = 2
#: At most this many rings (a 1371-edge occlusion of radius 52 rim edges
#: takes 8).
MAX_RINGS = 60
#: Rings of scan kept around the collar: the fairing holds three; the rest
#: leaves the fill's rings whole where the collar's edge is ragged.
KEPT_RINGS = 6


def collar_rings(V, loop):
    """The collar's width in rings for a hole: ``COLLAR_WIDTH`` times its
    radius over its mean rim edge, within ``MIN_RINGS..MAX_RINGS``; 0 where
    the rim has no length.

    Parameters
    ----------
    V : (n,3) float64
    loop : (k,) int64

    Returns
    -------
    m : int
    """
    from shellrepair.fill.probe import hole_radius

    loop = np.asarray(loop, np.int64)
    r, h = hole_radius(V, loop), mean_edge(V, loop)
    if not (np.isfinite(r) and np.isfinite(h) and h > 0):
        return 0
    return int(min(MAX_RINGS, max(MIN_RINGS, round(COLLAR_WIDTH * r / h))))


def _edge_keys(T, n):
    """Each face's three edges as ``min * (n + 1) + max`` keys, (3f,) int64."""
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    E.sort(axis=1)
    return E[:, 0] * (n + 1) + E[:, 1]


def _largest_piece(T, n):
    """Which faces of ``T`` (f,3) are in its largest piece joined across
    shared edges ((f,) bool; the first such piece on a tie)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    key = _edge_keys(T, n)
    fid = np.tile(np.arange(len(T)), 3)
    o = np.argsort(key, kind="stable")
    same = key[o][1:] == key[o][:-1]
    A = coo_matrix((np.ones(int(same.sum())), (fid[o][:-1][same], fid[o][1:][same])), shape=(len(T), len(T)))
    _, lab = connected_components(A, directed=False)
    return lab == np.argmax(np.bincount(lab))


def _widened(ctx, loop, m):
    """The scan around the hole with its collar of ``m`` rings taken away.

    Returns (Vl, Fl, wloop, Q): the kept scan's positions and faces (local
    ids), the widened hole's loop, the collar's removed vertices'
    positions; None where no single widened loop is left.
    """
    from shellrepair.holes.loops import boundary_loops

    V, F = ctx.V, ctx.F
    n = len(V)
    collar = ctx.ring_faces(loop, m)
    near = ctx.ring_faces(loop, m + KEPT_RINGS)
    kept = np.setdiff1d(near, collar)
    if not len(kept):
        return None
    piece = _largest_piece(F[kept], n)
    collar = np.union1d(collar, kept[~piece])     # islands of scan inside the collar go with it
    kept = kept[piece]
    g, inv = np.unique(np.concatenate([F[collar].ravel(), F[kept].ravel()]), return_inverse=True)
    Cl = inv[:3 * len(collar)].reshape(-1, 3)
    Fl = inv[3 * len(collar):].reshape(-1, 3)
    used = np.zeros(len(g), bool)
    used[Fl] = True
    removed = np.unique(Cl)
    removed = removed[~used[removed]]
    if removed.size == 0:
        return None
    # the scan's own boundary edges within reach: open in one more ring's faces
    wider = _edge_keys(F[ctx.ring_faces(loop, m + KEPT_RINGS + 1)], n)
    u, cnt = np.unique(wider, return_counts=True)
    own_open = u[cnt == 1]
    collar_edges = np.unique(_edge_keys(F[collar], n))
    loops, chains = boundary_loops(Fl, len(g))
    if chains:
        return None
    widened = []
    for L in loops:
        L = np.asarray(L, np.int64)
        a, b = g[L], g[np.roll(L, -1)]
        key = np.minimum(a, b) * (n + 1) + np.maximum(a, b)
        on_collar = np.isin(key, collar_edges)
        if not on_collar.any():
            continue                 # another hole, or the region's edge, away from the collar
        if not (on_collar | np.isin(key, own_open)).all():
            return None              # the widened loop runs into the edge of the region walked
        widened.append(L)
    if len(widened) != 1:
        return None
    ids = np.flatnonzero(used)
    remap = np.full(len(g), -1, np.int64)
    remap[ids] = np.arange(ids.size)
    Vg = V[g]
    return Vg[ids], remap[Fl], remap[widened[0]], Vg[removed]


def collar_errors(ctx, loop, candidates):
    """RMS error of each candidate order on the hole's own collar (module docstring).

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
        The scan (read only).
    loop : (k,) int64
        The hole's rim.
    candidates : sequence of int
        Fairing orders.

    Returns
    -------
    errors : dict of int -> float
        RMS distance (scan units) of the collar's removed vertices to each
        candidate's fill of the widened hole; empty where no collar is cut
        (see the module docstring) or its fill has no vertex of its own.
    rings : int
        The collar's width in rings (0 where none is cut).
    """
    from shellrepair.errors import MeshError
    from shellrepair.fill.fair import fair_patch_orders
    from shellrepair.fill.patch import PatchError
    from shellrepair.fill.probe import TEST_ROUNDS, _refined
    from shellrepair.mesh.distance import point_mesh_distance
    from shellrepair.mesh.index import ScanContext
    from shellrepair.mesh.io import Mesh

    candidates = tuple(candidates)
    loop = np.asarray(loop, np.int64)
    m = collar_rings(ctx.V, loop)
    got = _widened(ctx, loop, m) if m else None
    if got is None:
        return {}, 0
    Vl, Fl, wloop, Q = got
    origin = Vl.mean(axis=0)         # local coordinates: a scan far from the origin keeps its digits
    try:
        lctx = ScanContext(Mesh(V=Vl - origin, F=Fl))
        (X0, Fs, nf, _, scale, org), T, _ = _refined(lctx, wloop, max(candidates))
    except (MeshError, PatchError, ValueError, IndexError):
        return {}, 0
    if len(X0) == nf:
        return {}, 0                 # no vertex of its own: every order fills it alike
    Tp = Fs[len(Fs) - len(T):]
    errors = {}
    for o, (Xu, _) in zip(candidates, fair_patch_orders(X0, Fs, nf, candidates, rounds=TEST_ROUNDS,
                                                         operator=False)):
        d = point_mesh_distance(Q - origin, org + scale * np.vstack([X0[:nf], Xu]), Tp)
        if not np.isfinite(d).all():
            return {}, 0
        errors[o] = float(np.sqrt((d * d).mean()))
    return errors, m
