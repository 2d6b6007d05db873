"""The order test's compiled steps give the numbers of its NumPy ones, to the bit (issue 14).

``order="auto"`` runs a band test per hole (:mod:`shellrepair.selftest`):
the band's probe, the distances of the band to each candidate's fill, the
rim's bends and mean edge. Each of these steps has a compiled path
(:mod:`shellrepair.kernels`) beside the NumPy one it replaces; the NumPy
one is the oracle. Every test below compares the two on inputs that reach
the awkward cases (walks that run out of mesh, bands that are no annulus,
pinched and open boundaries, degenerate triangles, far offsets), and the
last ones compare the whole test's verdicts with and without the kernels.
"""

import numpy as np
import pytest

from eval import shapes
from shellrepair import Mesh, detect_holes, kernels, selftest
from shellrepair.holes import boundary_loops
from shellrepair.patch import _Context
from shellrepair.topology import edge_topology

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(not kernels.ENABLED, reason="the compiled kernels are off (SHELLREPAIR_NO_NUMBA)")


def perforated(n_holes=6, seed=0, subdivisions=4, radius=0.12):
    """A bumpy sphere with round holes, its holes and a context."""
    V, F = shapes.bumpy_sphere(subdivisions, amplitude=0.03, frequency=4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=n_holes, radius=radius, seed=seed)
    scan = detect_holes(V2, F2)
    ctx = _Context(Mesh(V=V2, F=F2))
    return ctx, scan.holes


def test_one_walk_holds_the_faces_within_each_ring_count():
    ctx, holes = perforated()
    F = selftest._faces(ctx)
    for h in holes:
        loop = np.asarray(h.vertices, np.int64)
        faces, off = kernels.ring_walk(loop, 9, ctx.vf_order, ctx.vf_start, F, ctx._vmark, ctx._fmark)
        assert off.shape == (10,) and off[0] == 0 and np.all(np.diff(off) > 0)
        for r in range(1, 10):
            assert np.array_equal(np.sort(faces[:off[r]]), ctx._ring_faces_numpy(loop, r))
    assert not ctx._vmark.any() and not ctx._fmark.any()        # the scratch marks are left clear


def test_a_walk_that_runs_out_of_mesh_repeats_its_last_ring_end():
    V, F = shapes.icosphere(1)                                     # 80 faces: a few rings cover it
    ctx = _Context(Mesh(V=V, F=F))
    faces, off = kernels.ring_walk(np.array([0], np.int64), 30, ctx.vf_order, ctx.vf_start, F, ctx._vmark,
                                   ctx._fmark)
    assert off[-1] == len(F) and np.array_equal(np.sort(faces), np.arange(len(F)))
    full = int(np.argmax(off == len(F)))
    assert 1 < full < 30 and np.all(off[full:] == len(F))
    assert np.array_equal(np.sort(faces[:off[2]]), ctx._ring_faces_numpy(np.array([0]), 2))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_band_split_equals_the_numpy_one(seed):
    ctx, holes = perforated(seed=seed)
    F = selftest._faces(ctx)
    seen = 0
    for h in holes:
        loop = np.asarray(h.vertices, np.int64)
        walk = selftest._ring_walk(ctx, loop, 6 + selftest.MARGIN_RINGS)
        for rings in (1, 2, 3, 6):
            ref = selftest._band_parts_numpy(ctx, loop, rings)
            got = selftest._band_parts(ctx, loop, rings, walk)
            assert (ref is None) == (got is None)
            if ref is None:
                continue
            seen += 1
            for a, b in zip(ref[:5], got[:5]):
                assert a.dtype == b.dtype == np.int64 and np.array_equal(a, b)
            assert ref[5] == got[5]
    assert seen >= 3 * len(holes)
    assert np.all(ctx.vpos() == -1)                               # the scratch numbering is left clear
    del F


@pytest.mark.parametrize("rings", [2, 3, 6])
def test_the_probe_is_the_same_with_and_without_the_kernels(rings, monkeypatch):
    ctx, holes = perforated(n_holes=10, seed=3, radius=0.1)
    outcomes = []
    for h in holes:
        got = selftest.probe_band(ctx, h.vertices, rings)
        monkeypatch.setattr(kernels, "ENABLED", False)
        ref = selftest.probe_band(ctx, h.vertices, rings)
        monkeypatch.undo()
        assert (got is None) == (ref is None)
        outcomes.append(got is not None)
        if got is not None:
            for a, b in zip(got, ref):
                assert a.dtype == b.dtype and np.array_equal(a, b)
    assert any(outcomes)
    if rings == 6:
        assert not all(outcomes)       # a 6-ring band meets another hole somewhere: no probe there either way


def _boundary_cases():
    """Face sets with simple boundaries, a pinch (two holes touching at a
    vertex), an open chain (a face flipped against its neighbours), none."""
    out = []
    ctx, holes = perforated(seed=4)
    out.append((ctx.F, ctx.n))
    V, F = shapes.grid(6, 6)
    out.append((F, len(V)))
    remove = np.zeros(len(F), bool)
    remove[[12, 37, 18, 43]] = True                               # two cells touching at a corner
    out.append((F[~remove], len(V)))
    Ff = F.copy()
    Ff[0] = Ff[0][::-1]                                           # a border face flipped: two open chains
    out.append((Ff, len(V)))
    V, F = shapes.icosphere(2)
    out.append((F, len(V)))                                       # closed: no boundary
    band = ctx.F[ctx.ring_faces(holes[0].vertices, 3)]            # an annulus: two loops
    out.append((band, ctx.n))
    return out


@pytest.mark.parametrize("case", range(6))
def test_simple_boundaries_walked_compiled_are_boundary_loops_loops(case):
    F, n = _boundary_cases()[case]
    topo = edge_topology(F, n)
    ok, verts, off = kernels.boundary_cycles(F, n, topo.boundary_he)
    loops, chains = boundary_loops(F, n)
    assert (len(chains) == 2) == (case == 3)
    got = selftest._boundary_loops(F, n)
    assert len(got[0]) == len(loops) and len(got[1]) == len(chains)
    assert all(np.array_equal(a, b) for a, b in zip(got[0], loops))
    assert all(np.array_equal(a, b) for a, b in zip(got[1], chains))
    assert len(loops) == {0: 6, 1: 1, 2: 3, 3: 0, 4: 0, 5: 2}[case]
    if ok:
        assert not chains and [verts[off[i]:off[i + 1]].tolist() for i in range(len(off) - 1)] == \
            [lp.tolist() for lp in loops]
    # the plain cases take the compiled walk; a pinch and a flipped face do not
    assert ok == (case in (0, 1, 4, 5))


@pytest.mark.parametrize("shift", [0.0, 1e6])
def test_centroids_are_numpys_means(shift):
    rng = np.random.default_rng(5)
    V = rng.normal(size=(300, 3)) + shift
    V[:10] = -0.0
    F = rng.integers(0, 300, size=(500, 3))
    assert np.array_equal(kernels.centroids(V, F), V[F].mean(axis=1))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_distances_read_from_the_vertices_equal_numpys_closest_points(seed):
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(200, 3)) * (1e6 if seed == 3 else 1.0)
    F = rng.integers(0, 200, size=(150, 3))
    F[:5, 1] = F[:5, 0]                                            # zero-area triangles
    V[F[5:9, 2]] = 0.5 * (V[F[5:9, 0]] + V[F[5:9, 1]])             # collinear ones
    Q = np.concatenate([rng.normal(size=(80, 3)) * 3, V[F[:9]].mean(axis=1), V[:5]])
    idx = rng.integers(0, len(F), size=(len(Q), 8))
    got = kernels.nearest_triangle_distances(Q, V, F, idx)
    assert np.array_equal(got, _numpy_nearest(Q, V, F, idx))


def _numpy_nearest(Q, V, F, idx):
    """point_mesh_distance's NumPy step on given candidates (the oracle)."""
    kk = idx.shape[1]
    P = np.repeat(Q, kk, axis=0)
    T = V[F][idx.ravel()]
    E = P - selftest._closest_on_triangles(P, T[:, 0], T[:, 1], T[:, 2])
    return np.sqrt(selftest._dot3(E, E)).reshape(len(Q), kk).min(axis=1)


def test_a_loops_mean_edge_is_numpys_pairwise_mean_at_every_length():
    rng = np.random.default_rng(6)
    for k in list(range(1, 300)) + [1023, 1024, 1025, 4099, 10007, 100003]:
        V = rng.normal(size=(k + 2, 3)) * rng.choice([1e-3, 1.0, 1e6])
        loop = rng.permutation(k + 2)[:k]
        assert kernels.loop_mean_edge(V, loop) == selftest._mean_edge_numpy(V, loop), k


def test_the_largest_bend_clips_as_numpy_does():
    for c in ([0.5, 0.99], [-1.0000000000000002, 0.3], [1.0000000000000002], [np.nan, 0.2], [0.2, np.nan], [-0.0]):
        c = np.array(c)
        want = float(np.degrees(np.arccos(np.clip(c.min(), -1.0, 1.0))))
        got = selftest._largest_bend(c)
        assert got == want or (np.isnan(got) and np.isnan(want))


def _old_steps(monkeypatch):
    """The order test with its compiled steps of issue 14 replaced by the
    NumPy ones they replace (the other kernels stay: fair_small, for one, is
    equal to round-off only, so the test with every kernel off is not the
    same to the bit)."""
    monkeypatch.setattr(selftest, "_band_parts", lambda ctx, loop, rings, walk=None:
                        selftest._band_parts_numpy(ctx, loop, rings))
    monkeypatch.setattr(selftest, "_boundary_loops", lambda F, n, topo=None: boundary_loops(F, n, topo=topo))
    monkeypatch.setattr(selftest, "_mean_edge", selftest._mean_edge_numpy)
    monkeypatch.setattr(selftest, "_largest_bend", lambda c: 0.0 if c.size == 0 else
                        float(np.degrees(np.arccos(np.clip(c.min(), -1.0, 1.0)))))
    monkeypatch.setattr(kernels, "centroids", lambda V, F: V[F].mean(axis=1))
    monkeypatch.setattr(kernels, "nearest_triangle_distances", _numpy_nearest)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_order_test_decides_and_measures_the_same_with_the_old_steps(seed, monkeypatch):
    ctx, holes = perforated(n_holes=8, seed=seed, radius=0.1)
    runs = []
    for old in (False, True):
        if old:
            _old_steps(monkeypatch)
        verdict = selftest.scan_verdict(ctx, holes)
        ctx.auto_small = verdict
        tests = [selftest.choose_order(ctx, h.id, h.vertices, shared=False) for h in holes]
        tests += [selftest.choose_order(ctx, h.id, h.vertices) for h in holes]
        runs.append([verdict] + tests)
    monkeypatch.undo()
    a, b = runs
    assert sum(1 for t in a[1:] if t.errors) >= 3                # the band test ran on several holes
    for x, y in zip(a, b):
        assert (x is None) == (y is None)
        if x is not None:
            assert (x.order, x.rings, x.why, x.shared) == (y.order, y.rings, y.why, y.shared)
            assert x.errors == y.errors and x.floor == y.floor  # the floats themselves, not near


def test_the_walk_reads_the_region_lists_where_ring_faces_does(monkeypatch):
    from shellrepair import patch
    from shellrepair.topology import edge_topology as topology

    monkeypatch.setattr(patch, "LOCAL_MIN_FACES", 0)               # the large-scan path: a region around the loops
    V, F = shapes.bumpy_sphere(5, amplitude=0.03, frequency=5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.12, seed=1)
    ctx = _Context(Mesh(V=V2, F=F2))
    ctx.topo = topology(F2, len(V2))
    reg = ctx.region()
    assert reg is not None and 0 < reg.faces.size < len(F2)
    holes = detect_holes(V2, F2).holes
    for h in holes:
        loop = np.asarray(h.vertices, np.int64)
        faces, off = selftest._ring_walk(ctx, loop, 10)
        assert ctx._vf is None                                     # answered from the region's lists
        for r in (2, 3, 10):
            assert np.array_equal(np.sort(faces[:off[r]]), ctx.ring_faces(loop, r))
    far = np.concatenate([holes[0].vertices, np.flatnonzero(~reg.covered)[:1]])
    faces, off = selftest._ring_walk(ctx, far, 2)                  # a vertex outside: the whole mesh's lists
    assert ctx._vf is not None and np.array_equal(np.sort(faces), ctx._ring_faces_numpy(far, 2))
