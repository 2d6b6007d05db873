"""The order test's compiled steps give the numbers of their NumPy ones, to the bit (issue 14).

``order="auto"`` fills test holes beside each hole (:mod:`shellrepair.fill.selftest`,
:mod:`shellrepair.fill.probe`) and measures each candidate's fill: the centroid
query, the distances of the removed scan to each fill have a compiled path (:mod:`shellrepair.mesh.distance_kernels`) beside the NumPy one
it replaces; the NumPy one is the oracle. The tests below compare the two on
inputs that reach the awkward cases (degenerate triangles, far offsets,
walks that run out of mesh), and the last one compares the whole test's
verdicts with and without them.
"""

import numpy as np
import pytest

from eval import shapes
from shellrepair import Mesh, compiled, detect_holes
from shellrepair.mesh import index_kernels as context_kernels
from shellrepair.mesh import distance
from shellrepair.mesh import distance_kernels
from shellrepair.fill import selftest
from shellrepair.mesh.index import ScanContext

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="the compiled kernels are off (SHELLREPAIR_NO_NUMBA)")


def perforated(n_holes=6, seed=0, subdivisions=4, radius=0.12):
    """A bumpy sphere with round holes, its holes and a context."""
    V, F = shapes.bumpy_sphere(subdivisions, amplitude=0.03, frequency=4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=n_holes, radius=radius, seed=seed)
    scan = detect_holes(V2, F2)
    ctx = ScanContext(Mesh(V=V2, F=F2))
    return ctx, scan.holes


def test_one_walk_holds_the_faces_within_each_ring_count():
    ctx, holes = perforated()
    F = np.ascontiguousarray(ctx.F, np.int64)
    for h in holes:
        loop = np.asarray(h.vertices, np.int64)
        faces, off = context_kernels.ring_walk(loop, 9, ctx.vf_order, ctx.vf_start, F, ctx._vmark, ctx._fmark)
        assert off.shape == (10,) and off[0] == 0 and np.all(np.diff(off) > 0)
        for r in range(1, 10):
            assert np.array_equal(np.sort(faces[:off[r]]), ctx._ring_faces_numpy(loop, r))
    assert not ctx._vmark.any() and not ctx._fmark.any()        # the scratch marks are left clear


def test_a_walk_that_runs_out_of_mesh_repeats_its_last_ring_end():
    V, F = shapes.icosphere(1)                                     # 80 faces: a few rings cover it
    ctx = ScanContext(Mesh(V=V, F=F))
    faces, off = context_kernels.ring_walk(np.array([0], np.int64), 30, ctx.vf_order, ctx.vf_start, F, ctx._vmark,
                                   ctx._fmark)
    assert off[-1] == len(F) and np.array_equal(np.sort(faces), np.arange(len(F)))
    full = int(np.argmax(off == len(F)))
    assert 1 < full < 30 and np.all(off[full:] == len(F))
    assert np.array_equal(np.sort(faces[:off[2]]), ctx._ring_faces_numpy(np.array([0]), 2))


def _within(ctx, faces, c, reach):
    """The faces of ``faces`` with a corner within ``reach`` of ``c``."""
    D = ctx.V[ctx.F[faces]] - c
    return faces[((D * D).sum(axis=2) <= reach * reach).any(axis=1)]


@pytest.mark.parametrize("shift", [0.0, 1e6])
def test_the_test_region_is_every_face_within_reach_where_the_scan_within_reach_is_one_piece(shift, monkeypatch):
    """ScanContext.faces_near on a perforated sphere (the scan within any
    ball around a hole is one piece there): the faces within the rings
    that have a corner within reach, as the full ring walk finds them;
    the NumPy walk finds the same; the scratch marks are left clear."""
    ctx, holes = perforated()
    ctx = ScanContext(Mesh(V=ctx.V + shift, F=ctx.F))
    for h in holes:
        loop = np.asarray(h.vertices, np.int64)
        c = ctx.V[loop].mean(axis=0)
        for rings, reach in ((3, 10.0), (60, 0.3), (60, 0.05), (12, 0.4)):
            got = ctx.faces_near(loop, rings, c, reach)
            assert got.dtype == np.int64 and np.all(np.diff(got) > 0)
            assert np.array_equal(got, _within(ctx, ctx.ring_faces(loop, rings), c, reach))
    assert not ctx._vmark.any() and not ctx._fmark.any()
    with monkeypatch.context() as m:
        m.setattr(compiled, "ENABLED", False)
        loop = np.asarray(holes[0].vertices, np.int64)
        c = ctx.V[loop].mean(axis=0)
        numpy_walk = ctx.faces_near(loop, 60, c, 0.3)
    assert np.array_equal(numpy_walk, ctx.faces_near(loop, 60, c, 0.3))


def hairpin(length=4.0, radius=0.15, nu=160, nv=9):
    """A strip folded back on itself: a lower sheet at z = 0 (x from 0 to
    ``length``), a half turn of ``radius``, an upper sheet at z = 2 radius
    back over it."""
    total = 2 * length + np.pi * radius
    u, v = np.meshgrid(np.linspace(0.0, total, nu), np.linspace(0.0, 1.0, nv), indexing="ij")
    u, v = u.ravel(), v.ravel()
    t = np.clip((u - length) / radius, 0.0, np.pi)
    x = np.where(u < length, u, np.where(u > length + np.pi * radius, length - (u - length - np.pi * radius),
                                          length + radius * np.sin(t)))
    z = np.where(u < length, 0.0, np.where(u > length + np.pi * radius, 2 * radius, radius - radius * np.cos(t)))
    V = np.column_stack([x, v, z])
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="ij")
    a = (i * nv + j).ravel()
    F = np.concatenate([np.column_stack([a, a + nv, a + nv + 1]), np.column_stack([a, a + nv + 1, a + 1])])
    return V, F.astype(np.int64)


def test_the_test_region_leaves_out_scan_joined_to_the_hole_only_beyond_reach(monkeypatch):
    """The sheet folded back over the start lies within reach of it, but
    the fold that joins the two lies beyond: the walk within reach keeps
    the lower sheet's faces alone, where the full ring walk with the faces
    beyond reach dropped after it kept the upper sheet's too."""
    V, F = hairpin()
    ctx = ScanContext(Mesh(V=V, F=F))
    start = np.array([int(np.argmin(((V - [1.0, 0.5, 0.0]) ** 2).sum(axis=1)))], np.int64)
    c, reach, rings = V[start[0]], 1.0, 400
    got = ctx.faces_near(start, rings, c, reach)
    upper = (V[F][:, :, 2] > 0.29).all(axis=1)
    full = _within(ctx, ctx.ring_faces(start, rings), c, reach)
    assert upper[full].any() and not upper[got].any()
    assert np.array_equal(got, full[~upper[full]])
    with monkeypatch.context() as m:
        m.setattr(compiled, "ENABLED", False)
        assert np.array_equal(ctx.faces_near(start, rings, c, reach), got)


@pytest.mark.parametrize("shift", [0.0, 1e6])
def test_centroids_are_numpys_means(shift):
    rng = np.random.default_rng(5)
    V = rng.normal(size=(300, 3)) + shift
    V[:10] = -0.0
    F = rng.integers(0, 300, size=(500, 3))
    assert np.array_equal(distance_kernels.centroids(V, F), V[F].mean(axis=1))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_distances_read_from_the_vertices_equal_numpys_closest_points(seed):
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(200, 3)) * (1e6 if seed == 3 else 1.0)
    F = rng.integers(0, 200, size=(150, 3))
    F[:5, 1] = F[:5, 0]                                            # zero-area triangles
    V[F[5:9, 2]] = 0.5 * (V[F[5:9, 0]] + V[F[5:9, 1]])             # collinear ones
    Q = np.concatenate([rng.normal(size=(80, 3)) * 3, V[F[:9]].mean(axis=1), V[:5]])
    idx = rng.integers(0, len(F), size=(len(Q), 8))
    got = distance_kernels.nearest_triangle_distances(Q, V, F, idx)
    assert np.array_equal(got, _numpy_nearest(Q, V, F, idx))


def _numpy_nearest(Q, V, F, idx):
    """point_mesh_distance's NumPy step on given candidates (the oracle)."""
    return distance.nearest_triangle_distances_reference(Q, V, F, idx)


def _old_steps(monkeypatch):
    """The order test with its compiled steps replaced by the NumPy ones
    they replace (the other kernels stay: fair_small, for one, is equal to
    round-off only, so the test with every kernel off is not the same to
    the bit)."""
    monkeypatch.setattr(distance_kernels, "centroids", lambda V, F: V[F].mean(axis=1))
    monkeypatch.setattr(distance_kernels, "nearest_triangle_distances", _numpy_nearest)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_order_test_decides_and_measures_the_same_with_the_old_steps(seed, monkeypatch):
    ctx, holes = perforated(n_holes=4, seed=seed, radius=0.15)
    runs = []
    for old in (False, True):
        if old:
            _old_steps(monkeypatch)
        runs.append([selftest.choose_order(ctx, h.id, h.vertices) for h in holes])
    monkeypatch.undo()
    a, b = runs
    assert sum(1 for t in a if t.errors) >= 2                     # the test ran on several holes
    assert a == b                                                 # orders, and the floats themselves
