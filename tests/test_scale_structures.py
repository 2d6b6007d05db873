"""Faster whole-mesh structures and batched per-hole steps give exactly
what their straightforward versions give."""

import numpy as np

from shellrepair import shapes
from shellrepair.refine import refine_patch, refine_patches
from shellrepair.repair import _rim_data, _local_frame, _Context
from shellrepair.io import Mesh
from shellrepair.holes import detect_holes
from shellrepair.topology import (components_of_pieces, edge_topology, face_components, face_pieces,
                                  vertex_faces)
from shellrepair.triangulate import triangulate_loop


def _pieces_and_pinches():
    """Three spheres: two touching at one vertex (one component, two
    pieces), one apart; plus a fan glued to a sphere by a lone vertex."""
    V, F = shapes.icosphere(2)
    Vs, Fs = [], []
    for k, shift in enumerate([0.0, 2.0, 6.0]):
        W = V + [shift, 0, 0]
        Vs.append(W)
        Fs.append(F + k * len(V))
    V3, F3 = np.vstack(Vs), np.vstack(Fs)
    # glue sphere 1 to sphere 0: the vertex of sphere 1 nearest sphere 0 is replaced by sphere 0's
    a = int(np.argmax(V3[:len(V), 0]))
    b = len(V) + int(np.argmin(V3[len(V):2 * len(V), 0]))
    F3[F3 == b] = a
    fan = np.array([[a, len(V3), len(V3) + 1]])
    V3 = np.vstack([V3, [[1.0, 1.0, 0.0], [1.0, 1.0, 1.0]]])
    return V3, np.vstack([fan, F3])


def test_components_from_pieces_equal_the_vertex_graph_components():
    V, F = _pieces_and_pinches()
    rng = np.random.default_rng(0)
    for trial in range(4):
        G = F[rng.permutation(len(F))] if trial else F
        topo = edge_topology(G, len(V))
        n_piece, fpiece = face_pieces(topo, len(G))
        got = components_of_pieces(G, len(V), fpiece, n_piece)
        want = face_components(G, len(V))
        assert got[0] == want[0] == 2 and n_piece == 4
        assert np.array_equal(got[1], want[1]) and np.array_equal(got[2], want[2])


def test_vertex_face_lists_equal_a_stable_sort():
    V, F = _pieces_and_pinches()
    order, start = vertex_faces(F, len(V) + 3)   # three vertices no face uses
    flat = F.ravel()
    ref = np.argsort(flat, kind="stable")
    assert np.array_equal(order, ref)
    assert np.array_equal(start, np.searchsorted(flat[ref], np.arange(len(V) + 4)))


def test_ring_faces_are_the_faces_within_k_edges():
    V, F = shapes.icosphere(3)
    ctx = _Context(Mesh(V=V, F=F))
    seed = np.array([0, 5])
    for rings in (1, 2, 4):
        # reference: grow a vertex set ring by ring
        vs = set(seed.tolist())
        faces = set()
        for _ in range(rings):
            new = {f for f in range(len(F)) if vs & set(F[f].tolist())}
            faces |= new
            vs |= {int(v) for f in new for v in F[f]}
        assert ctx.ring_faces(seed, rings).tolist() == sorted(faces)
    assert not ctx._vmark.any() and not ctx._fmark.any()   # scratch marks are left clean


def test_batched_refinement_equals_refining_each_patch_alone():
    V, F = shapes.bumpy_sphere(4, amplitude=0.05, frequency=5)
    centers = [0, 40, 90, 130, 200, 260]
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=centers, radius=0.25)
    scan = detect_holes(V2, F2)
    ctx = _Context(Mesh(V=V2, F=F2))
    items = []
    for L in scan.holes:
        sigma, normals, forbidden = _rim_data(ctx, L.vertices)
        _, scale, Pl = _local_frame(ctx, L.vertices, sigma)
        items.append((Pl, triangulate_loop(Pl, normals, forbidden), sigma / scale, len(L.vertices), forbidden))
    assert len(items) >= 4
    together = refine_patches(items)
    for item, (P2, T2) in zip(items, together):
        P1, T1 = refine_patch(*item)
        assert len(T1) > 2 * len(item[1])          # refinement did split
        assert np.array_equal(P1, P2) and np.array_equal(T1, T2)
