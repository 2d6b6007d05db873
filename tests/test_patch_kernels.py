"""The compiled per-hole kernels of the patch, the triangulation and the
band search give their NumPy oracles' results to the bit.

Each test runs the compiled path and the NumPy one (kept in the package as
the oracle) on seeded random and degenerate inputs and compares with
``np.array_equal`` (no tolerance)."""

import numpy as np
import pytest

from eval import shapes
from shellrepair import kernels
from shellrepair.io import Mesh
from shellrepair.patch import _Context, _submesh, _submesh_numpy

pytestmark = pytest.mark.skipif(not kernels.ENABLED, reason="numba is not installed")


def _perforated_torus(seed):
    V, F = shapes.torus(1.0, 0.35, 40, 16)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.3, seed=seed)
    return Mesh(V=V2, F=F2)


@pytest.mark.parametrize("seed", range(3))
def test_ring_faces_grow_their_buffers_past_any_first_guess(seed):
    """Many seed vertices and many rings: the walk's buffers are made room
    for per ring, and the faces and cleared marks are the NumPy walk's."""
    ctx = _Context(_perforated_torus(seed))
    rng = np.random.default_rng(seed)
    for verts, rings in ((rng.integers(0, ctx.n, 1), 40), (rng.integers(0, ctx.n, 200), 3),
                         (np.arange(ctx.n), 2), (np.array([5, 5, 5, 5]), 7)):
        a = ctx._ring_faces_numpy(verts, rings)
        b = ctx.ring_faces(verts, rings)
        assert a.dtype == b.dtype and np.array_equal(a, b)
        assert not ctx._vmark.any() and not ctx._fmark.any()


@pytest.mark.parametrize("seed", range(4))
def test_submesh_numbering_equals_the_numpy_one(seed):
    from shellrepair.holes import boundary_loops

    mesh = _perforated_torus(seed)
    ctx = _Context(mesh)
    rng = np.random.default_rng(seed)
    loops = boundary_loops(mesh.F, len(mesh.V))
    loops = loops[0] if isinstance(loops, tuple) else loops
    assert len(loops) >= 2
    for loop in loops:
        loop = np.asarray(loop, np.int64)
        k = len(loop)
        # a fan over the loop plus some new vertices (any indices do: the numbering is what is compared)
        q = int(rng.integers(0, 6))
        T = np.column_stack([np.zeros(k - 2, np.int64), np.arange(1, k - 1), np.arange(2, k)])
        if q:
            T = np.vstack([T, rng.integers(0, k + q, (q + 2, 3))])
        for rings in (1, 2, 3):
            rf = ctx.ring_faces(loop, rings)
            got = _submesh(ctx, loop, None, T, rings)
            want = _submesh_numpy(ctx, loop, T, rf)
            assert got[2] == want[2]
            for a, b in ((got[0], want[0]), (got[1], want[1]), (got[3], want[3])):
                assert a.dtype == b.dtype and np.array_equal(a, b)


def test_submesh_of_a_loop_off_its_faces_takes_the_numpy_path():
    """A loop vertex on none of the faces: the kernel says so and the
    NumPy numbering decides (it fails as before, on the missing vertex)."""
    mesh = _perforated_torus(0)
    F = np.ascontiguousarray(mesh.F, np.int64)
    faces = np.array([0, 1], np.int64)
    far = int(np.setdiff1d(np.arange(len(mesh.V)), F[faces].ravel())[0])
    g, Fs, loc, ok = kernels.submesh(faces, F, np.array([F[0, 0], far, F[0, 1]], np.int64),
                                     np.array([[0, 1, 2]], np.int64))
    assert not ok and np.array_equal(g, np.unique(F[faces]))
    g, Fs, loc, ok = kernels.submesh(np.zeros(0, np.int64), F, np.array([1, 2, 3], np.int64),
                                     np.array([[0, 1, 2]], np.int64))
    assert not ok and g.size == 0
