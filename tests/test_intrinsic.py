"""The intrinsic Delaunay Laplacian: Delaunay, exact on flat pieces, the
ordinary cotangent Laplacian where nothing needs flipping."""

import numpy as np

from eval import shapes
from shellrepair.fill.intrinsic import cotangents, intrinsic_delaunay, intrinsic_laplacian, twins


def _slivered_grid(k=12, seed=0):
    """A flat, slightly jittered grid with many interior edges split at 2 %
    of their length: slivers everywhere, angles near 0 and near π."""
    V, F = shapes.grid(k, k)
    rng = np.random.default_rng(seed)
    Vs = [p + [rng.normal(scale=0.01), rng.normal(scale=0.01), 0.0] for p in V]
    Fs = [list(map(int, f)) for f in F]
    edges = sorted({(min(a, b), max(a, b)) for f in Fs for a, b in zip(f, f[1:] + f[:1])})
    for a, b in edges[::3]:
        faces = [g for g, t in enumerate(Fs) if a in t and b in t]
        if len(faces) != 2:
            continue                       # a boundary edge
        m = len(Vs)
        Vs.append(Vs[a] + 0.02 * (Vs[b] - Vs[a]))
        for g in faces:
            t = Fs[g]
            i = next(i for i in range(3) if {t[i], t[(i + 1) % 3]} == {a, b})
            s, d, o = t[i], t[(i + 1) % 3], t[(i + 2) % 3]
            Fs[g] = [s, m, o]
            Fs.append([m, d, o])
    return np.array(Vs, float), np.array(Fs, np.int64)


def test_a_delaunay_mesh_keeps_its_triangles_and_gets_the_ordinary_cotangent_laplacian():
    import igl

    V, F = shapes.icosphere(2)
    T, L, settled = intrinsic_delaunay(V, F)
    assert settled and np.array_equal(T, F)
    K, M = intrinsic_laplacian(V, F)
    Kref = -igl.cotmatrix(V, F)
    Mref = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_BARYCENTRIC).diagonal()
    assert abs(K - Kref).max() < 1e-12 * abs(Kref).max()
    assert np.allclose(M, Mref, rtol=1e-12, atol=0)


def test_slivers_are_flipped_away_and_the_operator_stays_exact_on_a_flat_piece():
    V, F = _slivered_grid()
    cot0, _ = cotangents(np.linalg.norm(V[F][:, [1, 2, 0]] - V[F], axis=2))
    assert cot0.max() > 20 and cot0.min() < -1    # angles near 0, and obtuse ones
    T, L, settled = intrinsic_delaunay(V, F)
    assert settled and not np.array_equal(T, F)
    # flat: intrinsic flips are ordinary flips, lengths are plane distances
    assert np.allclose(L, np.linalg.norm(V[T][:, [1, 2, 0]] - V[T], axis=2), rtol=1e-10, atol=1e-12)
    # Delaunay: the two angles facing every interior edge sum to at most π
    cot, A = cotangents(L)
    twin = twins(T, len(V))
    h = np.flatnonzero(twin >= 0)
    assert (cot.ravel()[h] + cot.ravel()[twin[h]] >= -1e-9).all()
    K, M = intrinsic_laplacian(V, F)
    assert abs(K - K.T).max() < 1e-12 * abs(K).max()
    assert np.abs(K @ np.ones(len(V))).max() < 1e-9
    assert np.isclose(M.sum(), A.sum()) and (M > 0).all()
    # linear precision: K x = 0 for linear x at every interior vertex
    bnd = np.unique(np.concatenate([T.ravel()[twin < 0], T[:, [1, 2, 0]].ravel()[twin < 0]]))
    inner = np.setdiff1d(np.arange(len(V)), bnd)
    assert inner.size > 50
    assert np.abs((K @ V[:, :2])[inner]).max() < 1e-9
    # off the diagonal, interior weights are never negative (K_ij <= 0)
    Kc = K.tocoo()
    off = (Kc.row != Kc.col) & np.isin(Kc.row, inner) & np.isin(Kc.col, inner)
    assert (Kc.data[off] <= 1e-12).all()


def test_on_a_curved_surface_flips_keep_the_area_and_leave_no_negative_inner_weight():
    V, F = shapes.icosphere(3)
    # slide some vertices along the sphere to make thin triangles
    rng = np.random.default_rng(1)
    W = V.copy()
    pick = rng.choice(len(V), 60, replace=False)
    W[pick] += rng.normal(scale=0.06, size=(60, 3))
    W /= np.linalg.norm(W, axis=1)[:, None]
    T, L, settled = intrinsic_delaunay(W, F)
    assert settled and not np.array_equal(T, F)           # something was flipped
    _, A0 = cotangents(np.linalg.norm(W[F][:, [1, 2, 0]] - W[F], axis=2))
    K, M = intrinsic_laplacian(W, F)
    assert np.isclose(M.sum(), A0.sum(), rtol=1e-12)
    Kc = K.tocoo()
    assert (Kc.data[Kc.row != Kc.col] <= 1e-12).all()     # closed: every edge is interior


def test_the_compiled_arrays_are_the_same_operator():
    import pytest
    import scipy.sparse as sp

    from shellrepair import compiled
    from shellrepair.fill.intrinsic import laplacian_arrays

    if not compiled.ENABLED:
        pytest.skip("Numba is not installed")
    V, F = _slivered_grid(seed=2)
    K, M = intrinsic_laplacian(V, F)
    (ptr, col, val), M2 = laplacian_arrays(V, F)
    K2 = sp.csr_matrix((val, col, ptr), shape=K.shape)
    assert abs(K2 - K).max() <= 1e-14 * abs(K).max()      # the same sums in another order
    assert np.array_equal(M2, M)
    assert abs(K2 - K2.T).max() == 0                       # so its arrays are its CSC too
