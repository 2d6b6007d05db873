"""Fairing of large patches: later cotangent rounds by preconditioned CG.

The oracle is the direct path (a fresh factorisation every round, what
fair_patch did before), taken by raising PCG_MIN_UNKNOWNS past the patch.
Positions are in units of the mean edge (fair_patch's own frame); the
stated tolerance is TOLERANCE.
"""

import numpy as np
import pytest
import scipy.sparse as sp

from eval import shapes
from shellrepair import fair, kernels

#: CG against the direct solve, in mean edges. The direct solves themselves
#: differ by ~1e-9 between two sparse factorisations of these matrices
#: (bilaplacians: condition numbers ~1e7 here).
TOLERANCE = 1e-8


def _bumpy_grid(k, seed, jitter=0.15):
    """A jittered, bumpy k x k grid with the vertices three rows from its
    border fixed (first) and an initial guess off the surface for the rest."""
    V, F = shapes.grid(k, k)
    rng = np.random.default_rng(seed)
    V = V + rng.normal(scale=jitter / k, size=V.shape) * [1, 1, 0]
    V[:, 2] = 0.1 * np.sin(5 * V[:, 0]) * np.cos(4 * V[:, 1])
    ij = np.rint(V[:, :2] * (k - 1) / V[:, :2].max(axis=0))
    fixed = np.any((ij < 3) | (ij > k - 4), axis=1)
    order = np.concatenate([np.flatnonzero(fixed), np.flatnonzero(~fixed)])
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    X = V[order] / np.mean(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1))
    X[fixed.sum():, 2] += rng.normal(scale=0.3, size=len(X) - fixed.sum())
    return X, inv[F], int(fixed.sum())


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("seed", [0, 1])
def test_later_rounds_by_cg_equal_the_direct_solves(order, seed, monkeypatch):
    X, F, nf = _bumpy_grid(44 + 3 * seed, seed)
    assert len(X) - nf >= fair.PCG_MIN_UNKNOWNS
    monkeypatch.setattr(kernels, "ENABLED", False)        # no dense small-patch path either way
    monkeypatch.setattr(fair, "PCG_MAX_ITER", 60)          # started far off the surface: ~15 iterations
    calls = []
    real = fair._pcg
    monkeypatch.setattr(fair, "_pcg", lambda *a, **k: calls.append(real(*a, **k)) or calls[-1])
    got, K = fair.fair_patch(X, F, nf, order=order, rounds=3)
    assert len(calls) == 2 and all(c is not None for c in calls)   # rounds 2 and 3 went by CG
    monkeypatch.setattr(fair, "PCG_MIN_UNKNOWNS", len(X))
    ref, Kref = fair.fair_patch(X, F, nf, order=order, rounds=3)
    assert len(calls) == 2                                 # the oracle factorised every round
    assert np.abs(got - ref).max() <= TOLERANCE
    assert abs(K - Kref).max() <= 1e-6 * abs(Kref).max()   # operators of positions within TOLERANCE
    assert np.abs(got - X[nf:]).max() > 0.05              # it did move the free vertices


@pytest.mark.parametrize("max_iter", [0, 3])
def test_cg_that_does_not_converge_gives_way_to_a_factorisation(max_iter, monkeypatch):
    X, F, nf = _bumpy_grid(44, 2)
    monkeypatch.setattr(kernels, "ENABLED", False)
    monkeypatch.setattr(fair, "PCG_MAX_ITER", max_iter)   # too few for this start (~15 needed)
    got, _ = fair.fair_patch(X, F, nf, order=2)
    monkeypatch.setattr(fair, "PCG_MIN_UNKNOWNS", len(X))
    ref, _ = fair.fair_patch(X, F, nf, order=2)
    assert np.array_equal(got, ref)                        # the same factorisations, bit for bit


def test_pcg_solves_each_column_to_the_stated_residual():
    rng = np.random.default_rng(3)
    n = 400
    A = sp.random(n, n, density=0.01, random_state=4)
    A = (A @ A.T + sp.identity(n) * 0.5).tocsr()
    B = rng.normal(size=(n, 3))
    B[:, 1] = 0.0                                          # a zero column stays zero
    diag = A.diagonal()
    X = fair._pcg(A, B, np.zeros((n, 3)), lambda R: R / diag[:, None], tol=1e-12, max_iter=500)
    assert X is not None
    res = np.linalg.norm(B - A @ X, axis=0)
    assert np.all(res <= 1e-12 * np.linalg.norm(B, axis=0) + 1e-300)
    assert np.array_equal(X[:, 1], np.zeros(n))
    assert fair._pcg(A, B, np.zeros((n, 3)), lambda R: R, tol=1e-12, max_iter=2) is None


def test_the_factor_applies_the_inverse_of_the_unknown_block():
    X, F, nf = _bumpy_grid(20, 0)
    n = len(X)
    Q = fair._energy(fair.uniform_laplacian(F, n), None, 2)
    fixed, unknown = np.arange(nf), np.arange(nf, n)
    f = fair._Factor(Q, fixed, unknown)
    R = np.random.default_rng(0).normal(size=(unknown.size, 3))
    Z = f.apply(R)
    Quu = Q[unknown][:, unknown]
    assert np.abs(Quu @ Z - R).max() <= 1e-9 * np.abs(R).max()
    Xu = f.minimise(X)
    assert np.abs(Quu @ Xu + Q[unknown][:, fixed] @ X[fixed]).max() <= 1e-9 * np.abs(X).max() * abs(Q).max()
