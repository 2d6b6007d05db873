"""A faired patch's long chords are split: a thin opening gets vertices to fair."""

import numpy as np

from eval import shapes
from eval.cases import keep_largest, slit_mask
from shellrepair.fill.patch import build_patch
from shellrepair.fill.refine import DENSITY_ALPHA, refine_patch, split_chords
from shellrepair.holes.loops import detect_holes
from shellrepair.mesh.distance import point_mesh_distance
from shellrepair.mesh.index import ScanContext
from shellrepair.mesh.io import Mesh
from shellrepair.repair import repair_mesh


def _strip(n=20, width=1.0):
    """The rim of a strip two rows of ``n`` points long, ``width`` apart
    (edge 1 along it), in loop order, triangulated rim to rim."""
    top = np.column_stack([np.arange(n, dtype=float), np.zeros(n), np.zeros(n)])
    bottom = np.column_stack([np.arange(n, dtype=float)[::-1], np.full(n, width), np.zeros(n)])
    P = np.vstack([top, bottom])
    T = []
    for i in range(n - 1):        # quads between top i, i+1 and bottom (mirrored ids)
        a, b = i, i + 1
        c, d = 2 * n - 2 - i, 2 * n - 1 - i
        T += [[a, b, c], [a, c, d]]
    return P, np.array(T, np.int64)


def _edges(T):
    E = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(E, axis=0, return_counts=True)
    return keys, counts


def test_a_strip_two_rows_wide_gets_a_vertex_at_each_long_chords_midpoint():
    P, T = _strip(width=1.6)
    k = len(P)
    sigma = np.ones(k)
    Pr, Tr = refine_patch(P, T, sigma, k)
    assert len(Pr) == k                      # Liepa's test splits no triangle of the strip
    P2, T2 = split_chords(Pr, Tr, sigma, k)
    new = P2[k:]
    assert len(new) > 0
    np.testing.assert_array_equal(P2[:k], P)                  # the rim is not moved
    # each new vertex is the midpoint of two rim vertices a chord joined
    mid = 0.5 * (P[:, None, :] + P[None, :, :])
    assert all(np.abs(mid - q).max(axis=2).min() < 1e-12 for q in new)
    assert len(T2) == len(T) + 2 * len(new)   # each split makes two triangles of one
    keys, counts = _edges(T2)
    assert counts.max() == 2                  # still a manifold disc
    assert len(P2) - len(keys) + len(T2) == 1
    # no chord (edge between two rim vertices, inside) is longer than the density factor allows
    inner = keys[counts == 2]
    chords = inner[(inner < k).all(axis=1)]
    L = np.linalg.norm(P2[chords[:, 0]] - P2[chords[:, 1]], axis=1)
    assert L.size == 0 or L.max() <= DENSITY_ALPHA * 1.0 + 1e-12


def test_short_chords_are_left_alone():
    P, T = _strip(width=1.0)      # chords of length 1 and sqrt(2), not over sqrt(2) times the scale
    k = len(P)
    Pr, Tr = refine_patch(P, T, np.ones(k), k)
    P2, T2 = split_chords(Pr, Tr, np.ones(k), k)
    assert len(P2) == len(Pr)
    np.testing.assert_array_equal(np.sort(np.sort(T2, axis=1), axis=0), np.sort(np.sort(Tr, axis=1), axis=0))


def _slit_sphere():
    V, F = shapes.icosphere(5)
    V2, F2, _ = shapes.remove_faces(V, F, keep_largest(F, slit_mask(V, F, length=1.2, seed=3)))
    return V, F, V2, F2


def test_a_slit_faired_at_order_2_lies_on_the_sphere_its_chords_cut_across():
    V, F, V2, F2 = _slit_sphere()
    R, rep = repair_mesh(Mesh(V=V2, F=F2), order=2)
    assert rep["holes_after"] == 0
    assert sum(h["new_vertices"] for h in rep["holes"]) > 0
    new = R.V[len(V2):]
    # closer to the sphere than the order-1 patch, which keeps the chords across the slit
    R1, _ = repair_mesh(Mesh(V=V2, F=F2), order=1)
    P1 = R1.V[len(V2):]
    d2 = point_mesh_distance(R.V[R.F[len(F2):]].mean(axis=1), V, F)
    d1 = point_mesh_distance(R1.V[R1.F[len(F2):]].mean(axis=1), V, F)
    assert np.sqrt(np.mean(d2 ** 2)) < 0.5 * np.sqrt(np.mean(d1 ** 2))
    assert len(P1) < len(new)


def test_an_order_1_patch_is_not_split():
    # a flat cap's or an order-1 patch's midpoints would leave a planar
    # opening's exact plane by a round-off, where the exact crossing tests
    # could no longer tell the cap from coplanar scan under it
    V, F, V2, F2 = _slit_sphere()
    scan = detect_holes(V2, F2)
    ctx = ScanContext(Mesh(V=V2, F=F2))
    L = max(scan.loops, key=lambda L: len(L.vertices))
    loop = np.asarray(L.vertices, np.int64)
    plain = build_patch(ctx, L.id, loop, order=1)
    asked = build_patch(ctx, L.id, loop, order=1, chords=True)
    np.testing.assert_array_equal(plain.P, asked.P)
    np.testing.assert_array_equal(plain.T, asked.T)
    faired = build_patch(ctx, L.id, loop, order=2, chords=True)
    assert len(faired.P) > len(plain.P)
