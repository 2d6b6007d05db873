"""Triangle–triangle tests and the local triangle index."""

import numpy as np

from shellrepair import shapes
from shellrepair.intersect import TriangleIndex, pair_intersections, patch_vs_index, self_intersections


def tri(*p):
    return np.array(p, float)[None]


def test_crossing_touching_and_apart():
    A = tri([0, 0, 0], [2, 0, 0], [0, 2, 0])
    B = tri([0.5, 0.5, -1], [0.5, 0.5, 1], [1.5, 0.2, 0])        # pierces A
    C = tri([5, 5, 5], [6, 5, 5], [5, 6, 5])                    # far away
    ids = lambda *k: np.array([k])
    assert pair_intersections(A, ids(0, 1, 2), B, ids(3, 4, 5))[0]
    assert not pair_intersections(A, ids(0, 1, 2), C, ids(3, 4, 5))[0]
    # sharing an edge at an angle: touching, not crossing
    D = tri([0, 0, 0], [2, 0, 0], [1, -1, 1])
    assert not pair_intersections(A, ids(0, 1, 2), D, ids(0, 1, 6))[0]
    # sharing an edge folded flat onto each other: crossing
    E = tri([2, 0, 0], [0, 0, 0], [0.5, 1, 0])
    assert pair_intersections(A, ids(0, 1, 2), E, ids(1, 0, 7))[0]
    # sharing a vertex, the opposite edge piercing the other triangle
    G = tri([0, 0, 0], [1, 0.5, -1], [0.5, 1, 1])
    assert pair_intersections(A, ids(0, 1, 2), G, ids(0, 8, 9))[0]


def test_closed_sphere_has_no_self_intersections_and_a_dent_through_it_has():
    V, F = shapes.icosphere(3)
    assert self_intersections(V, F) == 0
    V2 = V.copy()
    V2[0] = -1.5 * V[0]          # pull one vertex through to the other side
    assert self_intersections(V2, F) > 0


def test_local_index_falls_back_to_every_face_outside_its_region():
    V, F = shapes.grid(60, 60)   # a flat sheet in z = 0 on [0, 1]^2
    corner = [(np.array([0.0, 0.0, -0.1]), np.array([0.1, 0.1, 0.1]))]
    full = TriangleIndex(V, F)
    local = TriangleIndex(V, F, region=corner)
    assert local.ids.size < len(F) / 10                       # only the corner is indexed
    probe = tri([0.7, 0.7, -0.5], [0.72, 0.7, 0.5], [0.7, 0.72, 0.5])   # pierces the sheet far from the corner
    ids = np.array([[-1, -2, -3]])
    assert patch_vs_index(probe, ids, full) > 0
    assert patch_vs_index(probe, ids, local) == patch_vs_index(probe, ids, full)
    inside = probe - [0.65, 0.65, 0.0]                          # the same probe in the corner
    assert patch_vs_index(inside, ids, local) == patch_vs_index(inside, ids, full) > 0
