"""Per-hole work shared or batched without changing a bit.

The oracles are the per-call functions the shared / batched code replaced:
:func:`shellrepair.fair.thin_plate_energy` and
:func:`shellrepair.fair.curvature_variation_energy` (one intrinsic
Laplacian each) for :func:`shellrepair.fair.patch_energies`.
"""

import warnings

import numpy as np
import pytest

from eval import shapes
from shellrepair import fair


def _bumpy_patch(k, seed):
    """A jittered bumpy k x k grid, its inner vertices as the rows."""
    V, F = shapes.grid(k, k)
    rng = np.random.default_rng(seed)
    V = V + rng.normal(scale=0.2 / k, size=V.shape) * [1, 1, 0]
    V[:, 2] = 0.1 * np.sin(5 * V[:, 0]) * np.cos(4 * V[:, 1]) + rng.normal(scale=0.01, size=len(V))
    ij = np.rint(V[:, :2] * (k - 1) / V[:, :2].max(axis=0))
    inner = np.flatnonzero(np.all((ij > 0) & (ij < k - 1), axis=1))
    deep = np.flatnonzero(np.all((ij > 1) & (ij < k - 2), axis=1))
    return V, np.asarray(F, np.int64), inner, deep


@pytest.mark.parametrize("seed", range(6))
def test_shared_energies_equal_the_separate_ones_to_the_bit(seed):
    V, F, inner, deep = _bumpy_patch(9 + seed, seed)
    E, C = fair.patch_energies(V, F, inner, deep)
    assert E == fair.thin_plate_energy(V, F, inner)
    assert C == fair.curvature_variation_energy(V, F, deep)
    assert np.isfinite(E) and np.isfinite(C) and E > 0 and C > 0


def test_shared_energies_build_the_laplacian_once(monkeypatch):
    V, F, inner, deep = _bumpy_patch(8, 0)
    calls = []
    real = fair._cotan_operators
    monkeypatch.setattr(fair, "_cotan_operators", lambda X, F: calls.append(1) or real(X, F))
    fair.patch_energies(V, F, inner, deep)
    assert len(calls) == 1
    fair.thin_plate_energy(V, F, inner)
    fair.curvature_variation_energy(V, F, deep)
    assert len(calls) == 3


def test_shared_energies_of_a_blown_up_patch_are_infinite_quietly():
    V, F, inner, deep = _bumpy_patch(8, 1)
    V[deep[0]] = [3e200, -1e200, 2e200]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert fair.patch_energies(V, F, inner, deep) == (np.inf, np.inf)
