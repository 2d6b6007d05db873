"""The fairing's sparse Cholesky (shellrepair.fill.cholesky): nested dissection,
dense fronts, and its place in fair.Factor.

Its solutions are checked against SciPy's sparse LU: the two sum in other
orders, so they agree to round-off, stated here as a relative residual of
1e-10 (the systems are scaled so that their condition numbers stay below
~1e5 where an error bound is asserted, and the residual is what any
backward-stable solver keeps small whatever the conditioning).
"""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from shellrepair import compiled
from shellrepair.fill import cholesky
from shellrepair.fill import fair

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="Numba not installed (libigl's factorisation runs instead)")


def grid_laplacian(m, power=1, shift=1e-3):
    """(K + shift I)^power of an m×m grid: the k-ring stencils of the fairing orders."""
    T = sp.diags([-np.ones(m - 1), 2 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1])
    I = sp.identity(m)
    K = (sp.kron(T, I) + sp.kron(I, T) + shift * sp.identity(m * m)).tocsc()
    Q = K
    for _ in range(power - 1):
        Q = Q @ K
    return sp.csc_matrix(Q)


def random_spd(n, density, seed):
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=density, random_state=rng, format="csc")
    return sp.csc_matrix(A @ A.T + sp.identity(n) * n * density)


def relative_residual(Q, X, B):
    return np.linalg.norm(Q @ X - B) / np.linalg.norm(B)


@pytest.mark.parametrize("Q", [grid_laplacian(12), grid_laplacian(30, 2), grid_laplacian(25, 3, shift=0.1),
                               random_spd(300, 0.02, 1), random_spd(40, 0.5, 2)],
                         ids=["grid-1ring", "grid-2ring", "grid-3ring", "random-sparse", "random-dense"])
def test_solution_matches_scipy_lu(Q):
    rng = np.random.default_rng(7)
    B = rng.standard_normal((Q.shape[0], 3))
    X = cholesky.factor(Q).solve(B)
    ref = spla.splu(sp.csc_matrix(Q)).solve(B)
    assert relative_residual(Q, X, B) < 1e-10
    assert np.linalg.norm(X - ref) <= 1e-8 * np.linalg.norm(ref)


def test_each_column_is_solved_as_if_alone_to_the_bit():
    Q = grid_laplacian(20, 2)
    B = np.random.default_rng(3).standard_normal((Q.shape[0], 7))
    f = cholesky.factor(Q)
    together = f.solve(B)
    for c in (1, 2, 3, 4, 7):
        part = f.solve(B[:, :c])
        assert np.array_equal(part, together[:, :c])
    one = f.solve(B[:, 5])
    assert one.shape == (Q.shape[0],)
    assert np.array_equal(one, together[:, 5])


def test_dissection_is_a_valid_elimination_tree():
    # every edge joins a node to itself or to one of its ancestors: the
    # separators separate, so a front's update only reaches its ancestors
    Q = grid_laplacian(40, 2)
    n = Q.shape[0]
    perm, start, parent = cholesky.nd_order(Q.indptr, Q.indices, n, leaf=16)
    assert np.array_equal(np.sort(perm), np.arange(n))
    assert start[0] == 0 and start[-1] == n and np.all(np.diff(start) >= 0)
    k = len(parent)
    assert np.all((parent == -1) | (parent > np.arange(k)))   # children before parents
    node_of = np.empty(n, np.int64)
    for i in range(k):
        node_of[perm[start[i]:start[i + 1]]] = i
    C = Q.tocoo()
    lo = np.minimum(node_of[C.row], node_of[C.col])
    hi = np.maximum(node_of[C.row], node_of[C.col])
    for a, b in set(zip(lo.tolist(), hi.tolist())):
        while a != b and a != -1:
            a = parent[a]
        assert a == b, "an edge between two nodes neither of which is the other's ancestor"
    assert k > 10        # a 1600-vertex grid with leaves of 16 is dissected, not one front


def test_disconnected_and_dense_parts():
    blocks = sp.block_diag([grid_laplacian(10), random_spd(60, 0.9, 4), sp.identity(5) * 2.0]).tocsc()
    B = np.random.default_rng(5).standard_normal((blocks.shape[0], 2))
    X = cholesky.factor(blocks).solve(B)
    assert relative_residual(blocks, X, B) < 1e-12


def test_tiny_systems():
    Q = sp.csc_matrix(np.array([[4.0]]))
    assert cholesky.factor(Q).solve(np.array([2.0]))[0] == 0.5
    Q2 = sp.csc_matrix(np.array([[2.0, -1.0], [-1.0, 2.0]]))
    np.testing.assert_allclose(Q2 @ cholesky.factor(Q2).solve(np.array([1.0, 0.0])), [1.0, 0.0], atol=1e-15)
    assert cholesky.factor(sp.csc_matrix((0, 0))).solve(np.zeros((0, 3))).shape == (0, 3)


@pytest.mark.parametrize("which", ["indefinite", "singular", "nan"])
def test_not_positive_definite_is_refused(which):
    Q = grid_laplacian(10).tolil()
    if which == "indefinite":
        Q[50, 50] = -5.0
    elif which == "singular":      # an unknown no equation reads
        Q[:, 42] = 0.0
        Q[42, :] = 0.0
    else:
        Q[3, 3] = np.nan
    with pytest.raises(cholesky.NotPositiveDefinite):
        cholesky.factor(sp.csc_matrix(Q))


def test_fair_factor_falls_back_where_not_positive_definite():
    # an indefinite block is still solved (libigl, else SciPy's LU)
    Q = grid_laplacian(8).tolil()
    Q[10, 10] = -3.0
    Q = sp.csc_matrix(Q)
    f = fair.Factor(Q, sp.csr_matrix((Q.shape[0], 1)))
    assert f.chol is None
    B = np.random.default_rng(1).standard_normal((Q.shape[0], 3))
    assert relative_residual(Q, f.apply(B), B) < 1e-10


def test_fairing_with_and_without_the_new_factorisation_agrees(monkeypatch):
    # a 900-unknown patch (the sparse path, not fair_small's dense one) faired
    # at orders 2 and 3: the positions agree to 1e-9 of the patch's size
    m = 34
    u, v = np.meshgrid(np.linspace(-1, 1, m), np.linspace(-1, 1, m))
    X = np.column_stack([u.ravel(), v.ravel(), 0.3 * np.sin(2 * u.ravel()) * np.cos(v.ravel())])
    idx = np.arange(m * m).reshape(m, m)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    F = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    ring = (np.abs(u.ravel()) > 0.8) | (np.abs(v.ravel()) > 0.8)
    order = np.concatenate([np.flatnonzero(ring), np.flatnonzero(~ring)])
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    Xs, Fs, nf = X[order].copy(), inv[F], int(ring.sum())
    Xs[nf:, 2] = 0.0                               # a flat start inside
    assert len(Xs) - nf > fair.SMALL_UNKNOWNS
    for k in (2, 3):
        ours, _ = fair.fair_patch(Xs, Fs, nf, order=k)
        monkeypatch.setattr(compiled, "ENABLED", False)   # libigl's factorisation (and SciPy's energy products)
        igl_, _ = fair.fair_patch(Xs, Fs, nf, order=k)
        monkeypatch.setattr(compiled, "ENABLED", True)
        assert np.abs(ours - igl_).max() < 1e-9 * 2.0
        assert np.abs(ours - X[order][nf:]).max() < 0.05     # and both are the surface, near enough
