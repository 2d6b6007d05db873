"""The NumPy connected components label every graph as SciPy's do."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components as scipy_components

from eval import shapes
from shellrepair.mesh.components import connected_components


def scipy_labels(n, a, b):
    A = sp.csr_matrix((np.ones(len(a), np.int8), (a, b)), shape=(n, n))
    return scipy_components(A, directed=False)


@pytest.mark.parametrize("seed", range(40))
def test_random_graphs_get_scipys_labels(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 300))
    e = int(rng.integers(0, 2 * n))
    a, b = rng.integers(0, n, e), rng.integers(0, n, e)
    k, lab = connected_components(n, a, b)
    k_ref, lab_ref = scipy_labels(n, a, b)
    assert k == k_ref
    assert lab.dtype == lab_ref.dtype and np.array_equal(lab, lab_ref)


def test_a_long_path_numbered_backwards_is_one_piece():
    """The worst order for hooking: each edge joins a node to a lower one far away."""
    n = 5000
    perm = np.random.default_rng(1).permutation(n)
    k, lab = connected_components(n + 3, perm[:-1], perm[1:])
    assert k == 4 and np.array_equal(lab, np.r_[np.zeros(n, np.int32), [1, 2, 3]])


def test_no_nodes_and_no_edges():
    k, lab = connected_components(0, np.zeros(0, np.int64), np.zeros(0, np.int64))
    assert k == 0 and lab.shape == (0,)
    k, lab = connected_components(3, [], [])
    assert k == 3 and lab.tolist() == [0, 1, 2]


def test_the_faces_of_a_mesh_in_pieces():
    """Two spheres side by side, faces joined across shared edges: two pieces, in face order."""
    V, F = shapes.icosphere(2)
    F2 = np.vstack([F + len(V), F])
    m = len(F2)
    E = np.sort(np.concatenate([F2[:, [0, 1]], F2[:, [1, 2]], F2[:, [2, 0]]]), axis=1)
    key = E[:, 0] * (2 * len(V)) + E[:, 1]
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order][1:] == key[order][:-1])
    fid = np.tile(np.arange(m), 3)
    a, b = fid[order[same]], fid[order[same + 1]]
    k, lab = connected_components(m, a, b)
    assert k == 2 and np.array_equal(lab, np.repeat([0, 1], len(F)))
    assert np.array_equal(lab, scipy_labels(m, a, b)[1])
