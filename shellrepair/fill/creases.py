"""Creases, and the holes the scan stands across: where a test hole stops.

The order test (:mod:`shellrepair.fill.probe`) cuts test holes of a hole's
own outline into intact scan beside it. On a CAD part the views miss whole
faces, or parts of them, up to their creases: the walls stand across such a
hole. A test hole of its outline laid across a crease is unlike it: there
orders 2 and 3 are truer than order 1, where on the hole order 1 is. So
where the scan stands across a hole (:func:`walled`), each test hole stops at
the creases its outline crosses (:func:`crease_cut`): the part beyond
a crease stays scan, and the crease becomes the test hole's rim, with walls
standing across it as they stand across the hole. Sharp relief that the
test hole encloses (a scanned statue's fine detail) is cut with it: it
lies within the hole, not beyond a crease.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CREASE_DEGREES", "walled", "smooth_component", "crease_cut"]

#: Where the scan stands across a hole (:func:`walled`), a test hole stops
#: at creases: edges whose two faces' normals are more than
#: ``CREASE_DEGREES`` apart. The part of the outline beyond a crease stays
#: scan, and the crease becomes the test hole's rim, with the walls standing
#: across it as they stand across the hole. On a CAD part such a hole is a
#: face, or part of one, that the views missed up to its creases; a test
#: hole laid across a crease is not like it, and there orders 2 and 3 are
#: truer than order 1 where on the hole order 1 is (fandisk occlusions,
#: eval/results/order-test/crease-clip/). Holes the scan does not stand
#: across (a disc cut across a crease) keep their test holes whole: stopped
#: at creases there, every disc of the fandisk took order 1, 1.28 → 1.72.
#: 45, 60 and 75 degrees gave the same choices on every case measured (the
#: fandisk's edges over 40 degrees are over 75 but for 17 of 710).
#: Measured at 45: fandisk occlusions of design seed 745606500, regret
#: 1.587 → 1.396; seeds drawn after it was fixed, 297394076 1.832 → 1.400
#: and 273734861 2.641 → 1.645; the fandisk's discs and slits unchanged on
#: 297394076 (1.049), 1.275 → 1.292 on design seed 731; on the 48 cases of
#: design seeds 569393493 and 733 and fresh seed 737888350 four outputs
#: changed (a Cheburashka base 1.358 → 1.000, a fandisk 1.584 → 1.000, a
#: Nefertiti occlusion 1.286 → 1.285, a Nefertiti base 1.000 → 1.247), the
#: other 44 are the same bytes.
CREASE_DEGREES = 45.0


def walled(ctx, loop):
    """Does the scan stand across the hole: the faces of six rings around it
    at an area-weighted mean |cos| to its best-fit plane's normal of at most
    ``EDGE_ON_COS`` (:func:`shellrepair.fill.patch.walls_cos`; the flat-cap
    rule asks this of planar openings, here the rim's planarity is not
    asked)?

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
    loop : (k,) int64

    Returns
    -------
    bool
    """
    from shellrepair.fill.patch import EDGE_ON_COS, walls_cos
    from shellrepair.holes.loops import loop_stats

    c = walls_cos(ctx, loop, loop_stats(ctx.V, loop)["axis"])
    return c is not None and c <= EDGE_ON_COS


def smooth_component(X, F, seed, cos_limit):
    """The faces joined to one face across edges that are not creases.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
        A piece of surface (each edge in at most two faces).
    seed : int
        The face to start from (a position in ``F``).
    cos_limit : float
        An edge joins its two faces where their unit normals' cosine is at
        least this (``cos(CREASE_DEGREES)``).

    Returns
    -------
    faces : (c,) int64
        Positions in ``F``, ascending; ``seed`` among them.
    """
    _, _, _, inside = _smooth(X, F, seed, cos_limit)
    return np.flatnonzero(inside)


def crease_cut(X, F, seed, cos_limit):
    """A test hole stopped at the creases it crosses: the faces joined to
    one face across edges that are not creases (:func:`smooth_component`),
    with the pieces of the rest that they enclose.

    Only a piece of the rest that reaches the edge of ``F`` (the outline's
    edge) lies beyond a crease. A piece enclosed by the smooth part is
    relief within the test hole (a scanned statue's fine detail has edges
    past the crease angle here and there): left as scan, it made islands in
    the test hole, and a test hole with islands is no hole of one rim: on
    two Nefertiti bases of seed 865890797, 374 placements failed so (2 to
    62 rims each), and the test fell back to test holes of half the hole's
    size; with the relief cut, none failed, and the default's fill took
    0.33 and 0.28 s instead of 2.53 and 2.11.

    Parameters
    ----------
    X, F, seed, cos_limit
        As for :func:`smooth_component`.

    Returns
    -------
    faces : (c,) int64
        Positions in ``F``, ascending; ``seed`` among them.
    """
    from shellrepair.mesh.components import connected_components

    topo, a, b, inside = _smooth(X, F, seed, cos_limit)
    if inside.all():
        return np.arange(len(F), dtype=np.int64)
    rest = ~inside[a] & ~inside[b]
    _, lab = connected_components(len(F), a[rest], b[rest])
    edge = np.asarray(topo.boundary_he, np.int64) // 3
    edge = edge[~inside[edge]]
    reach = np.zeros(int(lab.max()) + 1, bool)
    reach[lab[edge]] = True
    beyond = ~inside & reach[lab]
    return np.flatnonzero(~beyond)


def _smooth(X, F, seed, cos_limit):
    """(topology of ``F``, face pairs (a, b) of its two-face edges, the
    faces joined to ``seed`` across non-creases as a mask)."""
    from shellrepair.mesh.components import connected_components
    from shellrepair.mesh.topology import edge_topology, face_normals, manifold_pairs

    n = face_normals(X, F)
    n = n / np.maximum(np.sqrt((n * n).sum(axis=1)), 1e-300)[:, None]
    topo = edge_topology(F, len(X))
    h1, h2 = manifold_pairs(topo)
    a, b = h1 // 3, h2 // 3              # half-edge 3f + j is face f's
    smooth = (n[a] * n[b]).sum(axis=1) >= cos_limit
    _, lab = connected_components(len(F), a[smooth], b[smooth])
    return topo, a, b, lab == lab[seed]
