"""Delaunay flips made together in one round never write a triangle twice.

Each round of the refinement's relaxation (``refine.relax``) and of the
intrinsic Delaunay flips (``intrinsic._flip_to_delaunay``) flips a set of
edges at once, each the worst edge of both its triangles. When two edges
of one triangle tie as its worst, only one of them may flip: both flipping
rewrites that triangle twice and leaves an edge with three triangles. The
rule kept the first of two edges that shared their *first* triangle, but
not of two that shared their second; on an AMD EPYC the excess angles of a
refined occlusion hole tied exactly there (an Intel Xeon's last bits
differed), and the filled mesh kept a non-manifold edge and three boundary
edges while every hole said "filled" (tests/test_triangulate.py's seed 3).
"""

from pathlib import Path

import numpy as np

from shellrepair.fill import refine
from shellrepair.mesh.topology import edge_topology

DATA = Path(__file__).parent / "data" / "relax_tie.npz"


def test_two_tied_edges_sharing_their_second_triangle_do_not_both_flip():
    # candidates 0 and 1: different first triangles (0, 1), the same second (2),
    # the same excess, so each is the worst edge of both its triangles
    cand = np.array([10, 11])
    chosen = refine.independent_flips(cand, np.array([0, 1]), np.array([2, 2]), np.array([0.5, 0.5]),
                                       np.array([100, 101]), 3)
    assert chosen.tolist() == [10]                                     # the first keeps triangle 2


def test_flips_with_no_shared_triangle_all_go_ahead():
    cand = np.array([10, 11, 12])
    chosen = refine.independent_flips(cand, np.array([0, 1, 2]), np.array([3, 4, 5]), np.array([0.5, 0.7, 0.1]),
                                       np.array([100, 101, 102]), 6)
    assert sorted(chosen.tolist()) == [10, 11, 12]


def test_the_relaxation_of_a_refined_hole_whose_angles_tie_stays_manifold():
    """The refined occlusion hole whose relaxation went wrong on an AMD EPYC
    (its positions and triangles stored as they were): every edge keeps one
    or two triangles, the rim edges one, with the compiled relaxation and
    with the NumPy one."""
    z = np.load(DATA)
    P, T, is_loop, forb, dirty = z["P"], z["T"], z["is_loop"], z["forb"], z["dirty"]
    k = int(is_loop.sum())
    assert edge_topology(T, len(P)).edge_count.max() == 2
    for relax in (refine.relax, refine.relax_reference):
        T2, _, _ = relax(P, T.copy(), is_loop, forb, 100, dirty if dirty.size else None)
        t = edge_topology(np.asarray(T2, np.int64), len(P))
        assert t.edge_count.max() == 2 and t.edge_count.min() >= 1
        rim = np.sort(np.column_stack([np.arange(k), (np.arange(k) + 1) % k]), axis=1)
        bnd = t.edges[t.edge_count == 1]
        assert {tuple(e) for e in bnd.tolist()} == {tuple(e) for e in rim.tolist()}
