"""The compiled per-hole kernels of the patch, the triangulation and the
band search give their NumPy oracles' results to the bit.

Each test runs the compiled path and the NumPy one (kept in the package as
the oracle) on seeded random and degenerate inputs and compares with
``np.array_equal`` (no tolerance)."""

import numpy as np
import pytest

from eval import shapes
from shellrepair import compiled
from shellrepair.fill import bridge_kernels
from shellrepair.mesh import index_kernels as context_kernels
from shellrepair.fill import triangulate_kernels
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext, submesh_reference, submesh

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="numba is not installed")


def _same_bits(a, b):
    """Same dtype, shape and bytes (-0.0 is not 0.0, NaN is NaN)."""
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _perforated_torus(seed):
    V, F = shapes.torus(1.0, 0.35, 40, 16)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.3, seed=seed)
    return Mesh(V=V2, F=F2)


@pytest.mark.parametrize("seed", range(3))
def test_ring_faces_grow_their_buffers_past_any_first_guess(seed):
    """Many seed vertices and many rings: the walk's buffers are made room
    for per ring, and the faces and cleared marks are the NumPy walk's."""
    ctx = ScanContext(_perforated_torus(seed))
    rng = np.random.default_rng(seed)
    for verts, rings in ((rng.integers(0, ctx.n, 1), 40), (rng.integers(0, ctx.n, 200), 3),
                         (np.arange(ctx.n), 2), (np.array([5, 5, 5, 5]), 7)):
        a = ctx._ring_faces_numpy(verts, rings)
        b = ctx.ring_faces(verts, rings)
        assert a.dtype == b.dtype and np.array_equal(a, b)
        assert not ctx._vmark.any() and not ctx._fmark.any()


@pytest.mark.parametrize("seed", range(4))
def test_submesh_numbering_equals_the_numpy_one(seed):
    from shellrepair.holes.loops import boundary_loops

    mesh = _perforated_torus(seed)
    ctx = ScanContext(mesh)
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
            got = submesh(ctx, loop, None, T, rings)
            want = submesh_reference(ctx, loop, T, rf)
            assert got[2] == want[2]
            for a, b in ((got[0], want[0]), (got[1], want[1]), (got[3], want[3])):
                assert a.dtype == b.dtype and np.array_equal(a, b)
            assert (ctx._vpos == -1).all()


def test_submesh_of_a_loop_off_its_faces_takes_the_numpy_path():
    """A loop vertex on none of the faces: the kernel says so and the
    NumPy numbering decides (it fails as before, on the missing vertex)."""
    mesh = _perforated_torus(0)
    F = np.ascontiguousarray(mesh.F, np.int64)
    faces = np.array([0, 1], np.int64)
    far = int(np.setdiff1d(np.arange(len(mesh.V)), F[faces].ravel())[0])
    vpos = np.full(len(mesh.V), -1, np.int64)
    g, Fs, loc, ok = context_kernels.submesh(faces, F, np.array([F[0, 0], far, F[0, 1]], np.int64),
                                     np.array([[0, 1, 2]], np.int64), vpos)
    assert not ok and np.array_equal(g, np.unique(F[faces]))
    g, Fs, loc, ok = context_kernels.submesh(np.zeros(0, np.int64), F, np.array([1, 2, 3], np.int64),
                                     np.array([[0, 1, 2]], np.int64), vpos)
    assert not ok and g.size == 0
    assert (vpos == -1).all()   # the scratch is left as it was given


def _outlines(seed):
    """Loops of many kinds: star-shaped with noise, self-overlapping,
    with collinear runs, repeated corners and a 1e6 offset."""
    rng = np.random.default_rng(seed)
    out = []
    for k in (3, 4, 7, 12, 30):
        t = np.sort(rng.uniform(0, 2 * np.pi, k))
        r = rng.uniform(0.3, 1.0, k)
        P = np.column_stack([r * np.cos(t), r * np.sin(t), 0.05 * rng.standard_normal(k)])
        out.append(P)
        out.append(P[::-1].copy())                                  # the other way round
        out.append(P + 1e6)                                         # far from the origin
        W = P.copy()
        W[: k // 2] = W[: k // 2][::-1]                             # overlapping itself
        out.append(W)
    g = np.linspace(0, 1, 5)
    square = np.array([[x, 0, 0] for x in g] + [[1, y, 0] for y in g[1:]] + [[x, 1, 0] for x in g[-2::-1]]
                      + [[0, y, 0] for y in g[-2:0:-1]], float)                   # collinear runs, cocircular
    out.append(square)
    dup = square.copy()
    dup[3] = dup[2]                                                 # a repeated corner
    out.append(dup)
    return out


@pytest.mark.parametrize("seed", range(6))
def test_inside_outline_labels_equal_points_in_poly(seed):
    from skimage.measure import points_in_poly

    rng = np.random.default_rng(seed)
    for P in _outlines(seed):
        Q = np.ascontiguousarray(P[:, :2])
        k = len(Q)
        # centroids of random triples, corners, side midpoints and points far out
        S = rng.integers(0, k, (60, 3))
        S[:k, :] = np.arange(k)[:, None]                       # centroid = a corner
        S[k:2 * k, 0] = S[k:2 * k, 1] = np.arange(k)           # (2a + b) / 3: on a side's line
        S[k:2 * k, 2] = (np.arange(k) + 1) % k
        got = triangulate_kernels.inside_outline(Q, S)
        want = S[points_in_poly(Q[S].mean(axis=1), Q)]
        assert got.dtype == want.dtype and np.array_equal(got, want)


@pytest.mark.parametrize("seed", range(6))
def test_delaunay_in_projection_compiled_equals_numpy(seed, monkeypatch):
    from shellrepair.fill import triangulate as tr

    rng = np.random.default_rng(seed)
    answers = 0
    for P in _outlines(seed):
        for axis in (np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]), rng.standard_normal(3)):
            k = len(P)
            for forbidden in (set(), {(0, k // 2)}, {(0, 1)}):
                got = tr.delaunay_in_projection(P, axis, forbidden)
                monkeypatch.setattr(compiled, "ENABLED", False)
                want = tr.delaunay_in_projection(P, axis, forbidden)
                monkeypatch.setattr(compiled, "ENABLED", True)
                assert (got is None) == (want is None)
                if want is not None:
                    answers += 1
                    assert got.dtype == want.dtype and np.array_equal(got, want)
    assert answers > 10   # the comparison covers accepted triangulations, not only rejections


@pytest.mark.parametrize("seed", range(6))
def test_loop_cover_equals_the_numpy_checks_on_flat_and_nan_normals(seed):
    from shellrepair.fill.triangulate import loop_cover_reference

    rng = np.random.default_rng(seed)
    for k in (3, 5, 9):
        fan = np.column_stack([np.zeros(k - 2, np.int64), np.arange(1, k - 1), np.arange(2, k)])
        for S in (fan, fan[:, ::-1].copy(), rng.integers(0, k, (k - 2, 3))):
            for n in (rng.standard_normal(len(S)), -np.abs(rng.standard_normal(len(S))),
                      np.where(rng.random(len(S)) < 0.3, 0.0, 1.0), np.r_[np.nan, np.ones(len(S) - 1)],
                      np.r_[np.ones(len(S) - 1), np.nan], np.r_[1e-13, np.ones(len(S) - 1)]):
                a, ok_a = loop_cover_reference(S, n, k)
                b, ok_b = triangulate_kernels.loop_cover(S, n, k)
                assert ok_a == ok_b and a.dtype == b.dtype and np.array_equal(a, b)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("scratch", [True, False])
def test_block_ids_equal_unique_and_searchsorted_by_marks_and_by_sorting(seed, scratch):
    """Both ways of numbering the arcs' blocks (a scratch of one entry per
    vertex, or each block's corners sorted) give np.unique's keys and
    np.searchsorted's positions; empty blocks, repeated and face-less loop
    vertices included."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(80, 400))
    fcount = rng.integers(0, 40, 6)
    fcount[seed % 6] = 0
    sizes = rng.integers(1, 12, 6)
    Fcat = rng.integers(0, n, (int(fcount.sum()), 3))
    loopcat = rng.integers(0, n, int(sizes.sum()))
    lid_f = np.repeat(np.arange(6), fcount)
    lid_p = np.repeat(np.arange(6), sizes)
    fkey, pkey = lid_f[:, None] * n + Fcat, lid_p * n + loopcat
    want = np.unique(np.concatenate([fkey.ravel(), pkey]))
    ukey, L, li = bridge_kernels.block_ids(Fcat, fcount, loopcat, sizes, n, scratch=scratch)
    assert np.array_equal(ukey, want)
    assert np.array_equal(L, np.searchsorted(want, fkey)) and np.array_equal(li, np.searchsorted(want, pkey))


@pytest.mark.parametrize("seed", range(4))
def test_patch_corners_and_rim_sigma_equal_numpy(seed):
    """Corners and ids of patches with and without new vertices, and the
    rim scale with some rim vertices lacking scan edges (their loop edge
    instead), non-finite positions included: to the bit."""
    from shellrepair.mesh.index import rim_sigma, rim_sigma_reference
    from shellrepair.fill.patch import Patch, corners, corners_reference

    mesh = _perforated_torus(seed)
    ctx = ScanContext(mesh)
    rng = np.random.default_rng(seed)
    V = ctx.V.copy()
    V[rng.integers(0, len(V), 3)] = [np.nan, np.inf, -0.0]
    ctx.V = V
    for k, q in ((3, 0), (8, 5), (20, 1)):
        loop = rng.choice(len(V), k, replace=False).astype(np.int64)
        P = rng.standard_normal((q, 3)) * 1e3
        T = rng.integers(0, k + q, (k + 2 * q, 3))
        patch = Patch(hole_id=0, loop=loop, P=P, T=T)
        for a, b in zip(corners(ctx, patch), corners_reference(ctx, patch)):
            assert _same_bits(a, b)
        cnt = rng.integers(0, 4, k).astype(np.float64)
        tot = rng.random(k) * cnt
        assert _same_bits(rim_sigma(ctx, loop, tot, cnt), rim_sigma_reference(ctx, loop, tot, cnt))


@pytest.mark.parametrize("seed", range(4))
def test_boundary_loops_of_a_few_faces_of_a_large_mesh_are_the_same_numbered_compactly(seed, monkeypatch):
    """A small face set of a large mesh (its boundary vertices numbered
    among themselves) and the same faces numbered over all vertices give
    the same loops and chains in the same order; pinched sets included."""
    from shellrepair.holes import loops as holes

    mesh = _perforated_torus(seed)
    ctx = ScanContext(mesh)
    rng = np.random.default_rng(seed)
    for rings in (1, 2, 4):
        seedv = rng.integers(0, ctx.n, int(rng.integers(1, 4)))
        Fs = ctx.F[ctx.ring_faces(seedv, rings)]
        if seed % 2:
            Fs = Fs[rng.random(len(Fs)) > 0.15]          # ragged: pinches and open chains
        n = ctx.n * 50
        got = holes.boundary_loops(Fs, n)
        monkeypatch.setattr(holes, "COMPACT_RATIO", 10 ** 12)   # never compact
        want = holes.boundary_loops(Fs, n)
        monkeypatch.undo()
        assert len(got[0]) == len(want[0]) and len(got[1]) == len(want[1])
        for a, b in zip(got[0] + got[1], want[0] + want[1]):
            assert a.dtype == b.dtype and np.array_equal(a, b)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("compiled", [True, False])
def test_edge_topology_of_a_few_faces_of_a_large_mesh_equals_the_full_numbering(seed, compiled, monkeypatch):
    """Every field of the topology of a small face set is the same whether
    its vertices are numbered among themselves or over the whole mesh
    (non-manifold and flipped faces included), and a vertex id out of
    range is still refused."""
    from shellrepair.mesh import fastmesh
    from shellrepair.mesh import topology

    if compiled:
        fastmesh.warm_up()                   # loaded: used for any size
    else:
        monkeypatch.setattr(fastmesh, "enabled", lambda n_faces: False)
    mesh = _perforated_torus(seed)
    ctx = ScanContext(mesh)
    rng = np.random.default_rng(seed)
    Fs = ctx.F[ctx.ring_faces(rng.integers(0, ctx.n, 2), 3)].copy()
    Fs = np.vstack([Fs, Fs[:2], Fs[2:3, ::-1]])            # an edge with 3+ faces, a flipped face
    n = 50 * ctx.n
    got = topology.edge_topology(Fs, n)
    monkeypatch.setattr(topology, "COMPACT_RATIO", 10 ** 12)
    want = topology.edge_topology(Fs, n)
    monkeypatch.setattr(topology, "COMPACT_RATIO", 4)
    for name in ("edges", "edge_count", "boundary_he", "nonmanifold_edges", "he_order", "edge_of_he"):
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert got.consistent == want.consistent and got.faces is Fs
    assert len(want.nonmanifold_edges) and (want.consistent is None) == (not compiled)
    with pytest.raises(ValueError, match="outside"):
        topology.edge_topology(np.array([[0, 1, n]]), n)


def test_turns_into_opening_leaves_the_vertex_scratch_clear():
    """The base test reads loop positions from the context's scratch and
    sets them back: later users find it all -1."""
    from shellrepair.holes.loops import boundary_loops
    from shellrepair.fill.patch import turns_into_opening

    mesh = _perforated_torus(1)
    ctx = ScanContext(mesh)
    for loop in boundary_loops(mesh.F, len(mesh.V))[0]:
        turns_into_opening(ctx, np.asarray(loop, np.int64))
        assert (ctx.vpos() == -1).all()
