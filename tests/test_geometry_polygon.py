"""points_in_polygon: inside, on a side or at a corner, as the crossing
count the fill has always used (scikit-image's points_in_poly before it,
the compiled outline test beside it)."""

import numpy as np
import pytest

from shellrepair.mesh.geometry import points_in_polygon
from shellrepair.fill.triangulate_kernels import inside_outline


def _cases(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 300))
    a = np.sort(rng.uniform(0, 2 * np.pi, k))
    r = rng.uniform(0.2, 1.0, k)
    Q = np.column_stack([r * np.cos(a), r * np.sin(a)])
    if seed % 3 == 1:
        Q = np.round(Q * 8) / 8  # a grid: horizontal and vertical sides, repeated corners
    if seed % 3 == 2:
        Q = Q * 1e-3 + np.array([1e4, -3e5])  # small outline far from the origin
    mid = 0.5 * (Q + np.roll(Q, 1, axis=0))
    span = Q.max(axis=0) - Q.min(axis=0)
    P = np.vstack([Q.min(axis=0) - 0.1 * span + 1.2 * span * rng.random((2000, 2)),
                   Q, mid, Q + 1e-13, Q - 3e-12, np.full((1, 2), np.nan)])
    return P, Q


@pytest.mark.parametrize("seed", range(12))
def test_points_in_polygon_equals_scikit_image_points_in_poly(seed):
    points_in_poly = pytest.importorskip("skimage.measure").points_in_poly
    P, Q = _cases(seed)
    np.testing.assert_array_equal(points_in_polygon(P, Q), points_in_poly(P, Q))


@pytest.mark.parametrize("seed", range(6))
def test_points_in_polygon_equals_the_compiled_outline_test_on_triangle_centroids(seed):
    from scipy.spatial import Delaunay

    _, Q = _cases(seed)
    U = np.unique(Q, axis=0)  # the corners once each, in order round their centre
    c = U - U.mean(axis=0)
    Q = U[np.argsort(np.arctan2(c[:, 1], c[:, 0]))]
    S = Delaunay(Q).simplices.astype(np.int64)
    want = inside_outline(Q, S)
    got = S[points_in_polygon(Q[S].mean(axis=1), Q)]
    np.testing.assert_array_equal(got, want)


def test_points_in_polygon_many_pairs_in_chunks_give_the_same_answer(monkeypatch):
    from shellrepair.mesh import geometry

    P, Q = _cases(4)
    whole = points_in_polygon(P, Q)
    monkeypatch.setattr(geometry, "PAIR_CHUNK", 7)
    np.testing.assert_array_equal(points_in_polygon(P, Q), whole)


def test_points_in_polygon_of_nothing():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert points_in_polygon(np.zeros((0, 2)), square).shape == (0,)
    assert not points_in_polygon(np.array([[0.5, 0.5]]), np.zeros((0, 2))).any()
