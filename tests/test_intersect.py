"""Triangle–triangle tests and the local triangle index."""

import numpy as np

from shellrepair import shapes
from shellrepair.topology import edge_topology
from shellrepair.intersect import (NearFaces, TriangleIndex, _one_side, _seg_tri, crossing_pairs,
                                   embeds_by_projection,
                                   pair_intersections, patch_vs_index, self_intersections)


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


def test_pairs_set_aside_by_the_plane_test_are_never_crossing_ones():
    # pairs sharing no corner, with B's corners drawn at every scale of
    # distance from A's plane (down to round-off) and either side of it
    rng = np.random.default_rng(3)
    n = 60000
    A = rng.normal(size=(n, 3, 3))
    B = rng.normal(size=(n, 3, 3)) * 0.7
    nA = np.cross(A[:, 1] - A[:, 0], A[:, 2] - A[:, 0])
    nA /= np.linalg.norm(nA, axis=1)[:, None]
    off = np.einsum("pij,pj->pi", B - A[:, :1], nA)
    squeeze = 10.0 ** rng.uniform(-16, 0, size=(n, 1))
    B -= ((1 - squeeze) * off)[:, :, None] * nA[:, None, :]
    skip = np.zeros((n, 3), bool)
    apart = _one_side(A, B, skip) | _one_side(B, A, skip)
    exact = np.zeros(n, bool)
    for i in range(3):
        j = (i + 1) % 3
        exact |= _seg_tri(A[:, i], A[:, j], B[:, 0], B[:, 1], B[:, 2])
        exact |= _seg_tri(B[:, i], B[:, j], A[:, 0], A[:, 1], A[:, 2])
    assert exact.sum() > 1000 and apart.sum() > 10000   # both kinds are there
    assert not (apart & exact).any()
    ids_a = np.arange(3 * n).reshape(n, 3)
    assert np.array_equal(pair_intersections(A, ids_a, B, ids_a + 3 * n), exact)
    # one shared corner: the opposite edges decide
    B[:, 0] = A[:, 0]
    ida, idb = ids_a, ids_a + 3 * n
    idb[:, 0] = ida[:, 0]
    exact = (_seg_tri(A[:, 1], A[:, 2], B[:, 0], B[:, 1], B[:, 2])
             | _seg_tri(B[:, 1], B[:, 2], A[:, 0], A[:, 1], A[:, 2]))
    skip_b = np.zeros((n, 3), bool)
    skip_b[:, 0] = True
    apart = _one_side(A, B, skip_b) | _one_side(B, A, skip_b)
    assert exact.sum() > 1000 and apart.sum() > 10000
    assert not (apart & exact).any()
    assert np.array_equal(pair_intersections(A, ida, B, idb), exact)


def test_crossing_pairs_are_exactly_the_crossing_pairs_among_all_pairs():
    # a soup of small triangles in a box, a few huge ones through it, some
    # corners shared; every pair tested by brute force is the reference
    rng = np.random.default_rng(5)
    t = 400
    c = rng.uniform(0, 4, size=(t, 1, 3))
    C = c + rng.normal(scale=0.25, size=(t, 3, 3))
    C[:3] = rng.uniform(-2, 6, size=(3, 3, 3))            # huge triangles
    ids = np.arange(3 * t).reshape(t, 3)
    ids[10:40, 0] = ids[40:70, 0]                        # shared corners ...
    C[10:40, 0] = C[40:70, 0]                            # ... at one position
    i, j = np.triu_indices(t, 1)
    ref = pair_intersections(C[i], ids[i], C[j], ids[j])
    got = crossing_pairs(C, ids)
    assert ref.sum() > 50
    assert (got[:, 0] < got[:, 1]).all()
    assert {tuple(p) for p in got} == set(zip(i[ref], j[ref]))


def test_closed_sphere_has_no_self_intersections_and_a_dent_through_it_has():
    V, F = shapes.icosphere(3)
    assert self_intersections(V, F) == 0
    V2 = V.copy()
    V2[0] = -1.5 * V[0]          # pull one vertex through to the other side
    assert self_intersections(V2, F) > 0


def test_near_faces_finds_what_the_whole_mesh_index_finds_and_looks_only_nearby():
    V, F = shapes.grid(60, 60)   # a flat sheet in z = 0 on [0, 1]^2
    full = TriangleIndex(V, F)
    tree = NearFaces(V, F)
    tree.BRUTE = 0   # pairs through its k-d tree path, not the brute-force product
    nears = (NearFaces(V, F), NearFaces(V, F, topo=edge_topology(F, len(V))), tree)
    for near in nears:
        assert near.faces_near([0.0, 0.0, -0.1], [0.1, 0.1, 0.1]).size < len(F) / 10
    rng = np.random.default_rng(3)
    ids = np.array([[-1, -2, -3]])
    hits = 0
    for _ in range(40):
        c = np.append(rng.uniform(0, 1, 2), rng.uniform(-0.05, 0.05))
        probe = c + rng.normal(scale=0.03, size=(3, 3, 3))
        ids = -1 - np.arange(9).reshape(3, 3)
        n = patch_vs_index(probe, ids, full)
        assert all(patch_vs_index(probe, ids, near) == n for near in nears)
        hits += n
    assert hits > 0   # some probes pierce the sheet


def test_near_faces_keeps_a_long_triangle_reaching_in_from_far_away():
    V, F = shapes.grid(30, 30)
    # one sliver from far outside the sheet whose tip passes under the middle
    V = np.vstack([V, [[5.0, 0.5, -0.01], [5.0, 0.52, -0.01], [0.5, 0.51, -0.01]]])
    F = np.vstack([F, [[len(V) - 3, len(V) - 2, len(V) - 1]]])
    for near in (NearFaces(V, F), NearFaces(V, F, topo=edge_topology(F, len(V)))):
        assert near.big.tolist() == [len(F) - 1]         # kept apart, not growing every box
        assert len(F) - 1 in near.faces_near([0.45, 0.45, -0.1], [0.55, 0.55, 0.1])
        probe = np.array([[[0.7, 0.505, -0.05], [0.7, 0.515, 0.05], [0.72, 0.51, 0.05]]])
        assert patch_vs_index(probe, np.array([[-1, -2, -3]]), near, return_faces=True).size == 1


def test_near_face_pairs_are_the_same_by_tree_and_by_product_with_huge_faces_about():
    # a sheet with a few long triangles lying across it (a scan's flat base
    # seen from its wall): the tree path pairs them apart, the set of
    # sphere-meeting pairs is the one the all-pairs product finds
    V, F = shapes.grid(40, 40)
    rng = np.random.default_rng(8)
    extra = []
    for _ in range(6):
        a = rng.uniform(0, 1, 3) * [1, 1, 0.02]
        extra.append([a, a + [0.9, 0.1, 0], a + [0.1, 0.8, 0.01]])
    V = np.vstack([V, np.reshape(extra, (-1, 3))])
    F = np.vstack([F, len(V) - 18 + np.arange(18).reshape(6, 3)])
    by_tree, by_product = NearFaces(V, F), NearFaces(V, F)
    by_tree.BRUTE, by_product.BRUTE = 0, 10 ** 12
    for _ in range(10):
        C = np.column_stack([rng.uniform(0.2, 0.8, (50, 2)), rng.uniform(-0.02, 0.02, 50)])
        R = rng.uniform(0.005, 0.03, 50)
        a = set(zip(*by_tree.candidate_pairs(C, R)))
        b = set(zip(*by_product.candidate_pairs(C, R)))
        assert a == b and any(j >= len(F) - 6 for _, j in a)


def test_projection_certificate_accepts_a_dome_and_refuses_a_fold():
    k = 24
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    loop = np.column_stack([np.cos(t), np.sin(t), np.zeros(k)])
    inner = np.column_stack([0.5 * np.cos(t), 0.5 * np.sin(t), np.full(k, 0.3)])
    P = np.vstack([loop, inner, [[0, 0, 0.4]]])
    T = []
    for i in range(k):
        j = (i + 1) % k
        # loop edges appear reversed (i+1 -> i) in the patch, as in a repair
        T += [[j, i, k + i], [j, k + i, k + j], [k + j, k + i, 2 * k]]
    T = np.array(T)
    assert embeds_by_projection(P, T, k)                 # a dome over a circle
    bad = P.copy()
    bad[2 * k] = [0.9, 0.0, 0.4]                         # the apex pulled over the rim: triangles flip
    assert not embeds_by_projection(bad, T, k)
    assert not embeds_by_projection(P, T[:, ::-1], k)    # wound the wrong way round
    eight = P.copy()
    eight[:k // 2, 1] *= -1                              # a loop whose outline crosses itself
    assert not embeds_by_projection(eight, T, k)


def test_projection_certificate_never_covers_a_patch_that_crosses_itself():
    k = 24
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    rings = [np.column_stack([r * np.cos(t + 0.1 * r), r * np.sin(t + 0.1 * r), np.full(k, 1 - r * r)])
             for r in (1.0, 0.7, 0.4)]
    P0 = np.vstack(rings + [[[0, 0, 1.0]]])
    T = []
    for ring in range(2):
        a, b = ring * k, (ring + 1) * k
        for i in range(k):
            j = (i + 1) % k
            T += [[a + j, a + i, b + i], [a + j, b + i, b + j]]
    T += [[2 * k + (i + 1) % k, 2 * k + i, 3 * k] for i in range(k)]
    T = np.array(T)
    rng = np.random.default_rng(11)
    certified = crossing = 0
    for trial in range(150):
        P = P0.copy()
        P[k:] += rng.normal(scale=0.01 * (1 + trial // 15), size=(len(P) - k, 3))
        ok = embeds_by_projection(P, T, k)
        n = self_intersections(P, T)
        assert not (ok and n > 0)
        certified += ok
        crossing += n > 0
    assert certified > 20 and crossing > 5   # both kinds were drawn
