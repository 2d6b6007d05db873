"""The compiled kernels give the NumPy versions' results to the bit.

Each kernel of the kernel modules (``shellrepair/*_kernels.py``) replaces a NumPy or Python
function that stays in the package as its oracle (a public ``*_reference``
function beside its caller, or :mod:`shellrepair.reference`); these tests run both on
seeded random, slivered and degenerate inputs and compare with
``np.array_equal`` (no tolerance)."""

import numpy as np
import pytest

from shellrepair import compiled
from shellrepair.fill import bridge_kernels
from shellrepair.fill import checks_kernels
from shellrepair.mesh import index_kernels as context_kernels
from shellrepair.fill import fair_kernels
from shellrepair.mesh import intersect_kernels
from shellrepair.fill import intrinsic
from shellrepair.fill import intrinsic_kernels
from shellrepair.fill import patch_kernels
from shellrepair.fill import refine_kernels
from shellrepair.mesh import topology
from shellrepair.mesh import topology_kernels
from eval import shapes
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext, rim_data, rim_data_numpy

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="numba is not installed")


def _angle_compiled(u, v):
    """refine.angle_between with its products and sums compiled
    (refine_kernels.angle_parts), NumPy's arctan2."""
    return np.arctan2(*refine_kernels.angle_parts(u, v))


def _slivered(k, seed):
    """A jittered grid whose every third interior edge is split at 2 %."""
    from test_intrinsic import _slivered_grid

    return _slivered_grid(k, seed)


def _same_flips(X, F, max_rounds=intrinsic.MAX_ROUNDS):
    a = intrinsic.flip_to_delaunay_reference(X, F, max_rounds)
    b = intrinsic.flip_to_delaunay(X, F, max_rounds)
    assert a[2] == b[2]
    assert np.array_equal(a[0], b[0])
    assert np.array_equal(a[1], b[1])
    assert (a[3] is None) == (b[3] is None)
    if a[3] is not None:
        assert np.array_equal(a[3][0], b[3][0]) and np.array_equal(a[3][1], b[3][1])
    return a


@pytest.mark.parametrize("seed", range(8))
def test_intrinsic_flips_equal_the_numpy_rounds_on_slivered_grids(seed):
    T, _, settled, _ = _same_flips(*_slivered(9, seed))
    assert settled


@pytest.mark.parametrize("seed", range(8))
def test_intrinsic_flips_equal_the_numpy_rounds_on_noisy_closed_and_open_meshes(seed):
    rng = np.random.default_rng(seed)
    V, F = shapes.icosphere(2)
    _same_flips(V + rng.normal(scale=0.08, size=V.shape), F)
    V, F = shapes.grid(9, 7)
    T = _same_flips(V + rng.normal(scale=0.06, size=V.shape) * [1, 1, 0.3], F)[0]
    assert not np.array_equal(T, F)  # the noise made it flip


def test_intrinsic_flips_equal_when_rounds_run_out_and_on_degenerate_input():
    V, F = _slivered(9, 3)
    for rounds in (0, 1, 2, 3):
        assert _same_flips(V, F, rounds)[2] is False or rounds > 0
    # zero-area triangles (collinear corners and a repeated position), and no faces
    W = V.copy()
    W[F[5, 2]] = 0.5 * (W[F[5, 0]] + W[F[5, 1]])
    W[F[20, 1]] = W[F[20, 0]]
    _same_flips(W, F)
    _same_flips(V, F[:0])


def test_intrinsic_flips_equal_on_a_mesh_with_a_nonmanifold_edge():
    V, F = shapes.grid(6, 6)
    rng = np.random.default_rng(1)
    V = V + rng.normal(scale=0.05, size=V.shape) * [1, 1, 0]
    a, b = F[10, 0], F[10, 1]                       # a third face on one interior edge
    V = np.vstack([V, [V[a] + V[b]] * np.array([[0.5, 0.5, 0.0]]) + [0, 0, 0.3]])
    F = np.vstack([F, [[a, b, len(V) - 1]]])
    _same_flips(V, F)


@pytest.mark.parametrize("sub", [2, 3, 6])
@pytest.mark.parametrize("two", [False, True])
def test_vertex_faces_equal_the_sparse_counting_sort(sub, two, monkeypatch):
    # two: each step in two halves on two threads (forced on a small mesh;
    # sub 6 has more than two buckets of vertices)
    monkeypatch.setattr(topology_kernels, "VF_HALVES_MIN", 0 if two else 10 ** 12)
    V, F = shapes.icosphere(sub)
    rng = np.random.default_rng(sub)
    F = F[rng.permutation(len(F))]
    for n in (len(V), len(V) + 5):  # with unused vertices at the end
        o1, s1 = topology.vertex_faces(F, n)
        o2, s2 = topology_kernels.vertex_faces(F, n)
        assert o2.dtype == np.int64 and s2.dtype == np.int64
        assert np.array_equal(o1, o2) and np.array_equal(s1, s2)
    with pytest.raises(ValueError, match="outside"):
        topology_kernels.vertex_faces(np.vstack([F, [[0, 1, len(V) + 9]]]), len(V))


def test_rim_data_equals_the_python_walk():
    V, F = shapes.bumpy_sphere(3)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.3, seed=4)
    from shellrepair.holes.loops import detect_holes

    ctx = ScanContext(Mesh(V=V2, F=F2))
    loops = [h.vertices for h in detect_holes(V2, F2).holes]
    assert len(loops) == 3
    # a loop through a vertex twice (a pinch): the last position counts in both
    loops.append(np.concatenate([loops[0][:5], loops[0][2:3], loops[0][5:]]))
    for loop in loops:
        s1, n1, f1 = rim_data_numpy(ctx, np.asarray(loop, np.int64))
        s2, n2, f2 = rim_data(ctx, np.asarray(loop, np.int64))
        assert np.array_equal(s1, s2) and np.array_equal(n1, n2) and f1 == f2


def test_warm_up_compiles_every_kernel():
    from shellrepair import warmup

    assert warmup.warm_up() is True


@pytest.mark.parametrize("rings", [1, 2, 3, 6])
def test_ring_faces_equal_the_numpy_walk_and_leave_the_marks_clear(rings):
    V, F = shapes.torus(1.0, 0.35, 40, 16)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.3, seed=1)
    ctx = ScanContext(Mesh(V=V2, F=F2))
    rng = np.random.default_rng(rings)
    for verts in (rng.integers(0, len(V2), 5), np.array([3, 3, 7]), np.zeros(0, np.int64)):
        a = ctx._ring_faces_numpy(verts, rings)
        b = ctx.ring_faces(verts, rings)
        assert a.dtype == b.dtype and np.array_equal(a, b)
        assert not ctx._vmark.any() and not ctx._fmark.any()
    # rings past the whole component: every face of it, then the walk stops
    assert np.array_equal(ctx.ring_faces(np.array([0]), 500), ctx._ring_faces_numpy(np.array([0]), 500))


@pytest.mark.parametrize("seed", range(4))
def test_box_pairs_are_exactly_the_overlapping_boxes(seed):
    rng = np.random.default_rng(seed)
    A = rng.random((300, 3))
    Amax = A + rng.random((300, 3)) * [0.05, 0.1, 0.02]
    B = rng.random((700, 3)) * 1.2 - 0.1
    Bmax = B + rng.random((700, 3)) * 0.04
    B[:3] = -0.5
    Bmax[:3] = 1.5                                   # a few boxes spanning everything
    ai, bj = intersect_kernels.box_pairs(A, Amax, B, Bmax)
    M = np.all((A[:, None] <= Bmax[None]) & (B[None] <= Amax[:, None]), axis=2)
    assert sorted(zip(ai.tolist(), bj.tolist())) == sorted(zip(*map(np.ndarray.tolist, np.nonzero(M))))
    i, j = intersect_kernels.box_pairs(A, Amax)
    S = np.triu(np.all((A[:, None] <= Amax[None]) & (A[None] <= Amax[:, None]), axis=2), 1)
    assert sorted(zip(i.tolist(), j.tolist())) == sorted(zip(*map(np.ndarray.tolist, np.nonzero(S))))


@pytest.mark.parametrize("seed", range(3))
def test_crossing_tests_give_the_same_answers_with_the_box_candidates(seed, monkeypatch):
    """A crumpled patch over a scan: the crossing count, faces and pairs
    (against the scan) and the self-crossing pairs are those of the
    bounding-sphere candidates."""
    from shellrepair.mesh.intersect import NearFaces, crossing_pairs, patch_vs_index

    V, F = shapes.bumpy_sphere(3, amplitude=0.05, seed=seed)
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(60, 3)) * 0.3 + [0.0, 0.0, 0.9]
    T = np.array([rng.choice(60, 3, replace=False) for _ in range(80)])
    Pt, ids = P[T], -1 - T
    Pt[:5] = V[F[:5]]                              # five coincide with scan faces
    ids[:5] = F[:5]
    index = NearFaces(V, F, origin=V.mean(axis=0))
    out = {}
    for on in (True, False):
        monkeypatch.setattr(compiled, "ENABLED", on)
        pairs = patch_vs_index(Pt, ids, index, return_pairs=True)
        self_pairs = crossing_pairs(Pt - index.origin, ids)
        out[on] = (patch_vs_index(Pt, ids, index), patch_vs_index(Pt, ids, index, return_faces=True),
                   sorted(map(tuple, pairs.tolist())), sorted(map(tuple, self_pairs.tolist())))
    assert out[True][0] > 0 and len(out[True][3]) > 0
    assert out[True][0] == out[False][0]
    assert np.array_equal(out[True][1], out[False][1])
    assert out[True][2] == out[False][2] and out[True][3] == out[False][3]


def test_faces_near_equals_the_numpy_walk(monkeypatch):
    from shellrepair.mesh.intersect import NearFaces

    V, F = shapes.bumpy_sphere(3, amplitude=0.05)
    F = np.vstack([F, [[0, 100, 200]]])            # one long face: in every answer ("big")
    index = NearFaces(V, F, origin=V.mean(axis=0))
    assert index.big.size
    rng = np.random.default_rng(0)
    boxes = [(c - w, c + w) for c, w in zip(rng.normal(size=(20, 3)) * 0.7, rng.random((20, 1)) * 0.3)]
    boxes += [(np.full(3, 5.0), np.full(3, 6.0)), (np.full(3, -2.0), np.full(3, 2.0))]
    for lo, hi in boxes:
        monkeypatch.setattr(compiled, "ENABLED", False)
        a = index.faces_near(lo, hi)
        monkeypatch.setattr(compiled, "ENABLED", True)
        b = index.faces_near(lo, hi)
        assert a.dtype == b.dtype and np.array_equal(a, b)
        assert not index._fmark.any()


def test_the_vertex_grid_has_the_same_keys_and_cells(monkeypatch):
    from shellrepair.mesh.intersect import NearFaces

    V, F = shapes.bumpy_sphere(3, amplitude=0.05)
    V = V * [3.0, 1.0, 1.0] + 1e6                  # far from the origin, not square
    idx = {}
    for on in (False, True):
        monkeypatch.setattr(compiled, "ENABLED", on)
        idx[on] = NearFaces(V, F, origin=V.mean(axis=0))
    a, b = idx[False], idx[True]
    assert np.array_equal(a.lo2, b.lo2) and a.h == b.h and a.ny == b.ny
    assert np.array_equal(a.vkey, b.vkey)           # order within a cell is free
    assert np.array_equal(np.sort(a.vorder), np.arange(len(V)))
    assert np.array_equal(a.vkey[np.argsort(a.vorder)], b.vkey[np.argsort(b.vorder)])


#: The compiled dense fairing (fair_kernels.fair_small) against libigl's sparse
#: solve: positions in units of the mean edge.
FAIR_TOLERANCE = 1e-9


def _submesh_with_free_middle(k, seed, jitter=0.15):
    """A jittered, bumpy k x k grid; the vertices two rings from its border
    and beyond are free; returned with the fixed vertices first."""
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
    X[fixed.sum():] += rng.normal(scale=0.3, size=(len(X) - fixed.sum(), 3))   # an initial guess off the surface
    return X, inv[F], int(fixed.sum())


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("seed", range(3))
def test_the_dense_fairing_equals_the_sparse_solve_to_round_off(order, seed, monkeypatch):
    from shellrepair.fill import fair

    X, F, nf = _submesh_with_free_middle(10 + 2 * seed, seed)
    assert 0 < len(X) - nf <= fair.SMALL_UNKNOWNS
    pinned = np.array([0, 3]) if seed == 2 else None
    monkeypatch.setattr(compiled, "ENABLED", False)
    ref, Kref = fair.fair_patch(X, F, nf, order=order, pinned=pinned)
    monkeypatch.setattr(compiled, "ENABLED", True)
    got, K = fair.fair_patch(X, F, nf, order=order, pinned=pinned)
    assert np.abs(got - ref).max() <= FAIR_TOLERANCE
    assert abs(K - Kref).max() <= FAIR_TOLERANCE * abs(Kref).max()
    assert np.abs(got - X[nf:]).max() > 0.01        # it did move the free vertices
    if pinned is not None:
        assert np.array_equal(got[pinned], X[nf:][pinned])


def _textbook_cholesky_solve(Q, B):
    """Q x = B by the row-by-row Cholesky, each sum taken k = 0, 1, ... in
    turn, in Python floats (the operations the compiled kernel must repeat)."""
    n = len(Q)
    L = [[0.0] * n for _ in range(n)]
    for j in range(n):
        s = float(Q[j, j])
        for k in range(j):
            s -= L[j][k] * L[j][k]
        if not s > 0.0:
            return None
        L[j][j] = d = float(np.sqrt(s))
        for i in range(j + 1, n):
            s = float(Q[i, j])
            for k in range(j):
                s -= L[i][k] * L[j][k]
            L[i][j] = s / d
    X = np.array(B, np.float64)
    for c in range(X.shape[1]):
        x = [float(v) for v in X[:, c]]
        for i in range(n):
            s = x[i]
            for k in range(i):
                s -= L[i][k] * x[k]
            x[i] = s / L[i][i]
        for i in range(n - 1, -1, -1):
            s = x[i]
            for k in range(i + 1, n):
                s -= L[k][i] * x[k]
            x[i] = s / L[i][i]
        X[:, c] = x
    return X


@pytest.mark.parametrize("seed", range(3))
def test_the_dense_cholesky_equals_the_textbook_one_to_the_bit(seed):
    """fair_kernels.cholesky_solve (fair_small's solve, column by column)
    against the row-by-row factorisation: dense, sparse with exact zeros,
    nearly singular; and a matrix that is not positive definite is refused."""
    rng = np.random.default_rng(seed)
    for n in (1, 2, 3, 7, 16, 33, 61):
        A = rng.normal(size=(n, n))
        if seed == 1:
            A[rng.random((n, n)) < 0.8] = 0.0      # exact zeros in Q and fill-in in L
        Q = A @ A.T + (1e-6 if seed == 2 else n) * np.eye(n)
        Q = 0.5 * (Q + Q.T)
        B = rng.normal(size=(n, 3))
        got, ok = fair_kernels.cholesky_solve(Q, B)
        ref = _textbook_cholesky_solve(Q, B)
        assert ok and np.array_equal(got, ref)
        assert np.abs(Q @ got - B).max() <= 1e-6 * max(1.0, np.abs(B).max()) * np.linalg.cond(Q)
    Q = np.diag([1.0, -1.0, 2.0])
    assert not fair_kernels.cholesky_solve(Q, np.ones((3, 3)))[1] and _textbook_cholesky_solve(Q, np.ones((3, 3))) is None


def test_a_repair_with_the_kernels_equals_the_numpy_repair_to_round_off(monkeypatch):
    """Same faces and flags, original vertices bit-identical, new vertices
    within FAIR_TOLERANCE mean edges (the dense fairing is the one kernel
    that is not bit-exact)."""
    from shellrepair.repair import repair_mesh

    V, F = shapes.bumpy_sphere(4, amplitude=0.02, frequency=5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=8, radius=0.12, seed=3)
    out = {}
    for on in (False, True):
        monkeypatch.setattr(compiled, "ENABLED", on)
        out[on] = repair_mesh(Mesh(V=V2, F=F2))
    (a, ra), (b, rb) = out[False], out[True]
    assert ra["holes_after"] == rb["holes_after"] == 0
    assert np.array_equal(a.F, b.F) and np.array_equal(a.face_filled, b.face_filled)
    assert np.array_equal(a.V[:len(V2)], b.V[:len(V2)]) and np.array_equal(b.V[:len(V2)], V2)
    edge = np.linalg.norm(V2[F2[:, 0]] - V2[F2[:, 1]], axis=1).mean()
    assert len(a.V) > len(V2) and np.abs(a.V - b.V).max() <= FAIR_TOLERANCE * edge


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_relaxation_equals_the_numpy_rounds(seed):
    """Delaunay flips of a patch (refine.relax): the same triangles, the
    same changed faces, the same verdict, with forbidden chords, dirty
    faces, a round cap and the symmetric ties of a regular fan."""
    from shellrepair.fill import refine
    from shellrepair.fill import triangulate

    rng = np.random.default_rng(seed)
    k = 24 + 4 * seed
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    P = np.column_stack([np.cos(t) * (1 + 0.3 * seed), np.sin(t), 0.2 * np.sin(3 * t)])
    if seed == 5:                                  # a regular polygon: exact ties in the angles
        t = np.linspace(0, 2 * np.pi, k, endpoint=False)
        P = np.column_stack([np.cos(t), np.sin(t), np.zeros(k)])
    T = triangulate.triangulate_loop(P)
    P2, T2 = refine.refine_patch(P, T, np.full(k, 0.15), k)
    T2 = T2.copy()
    T2[:, [1, 2]] = T2[:, [2, 1]] if seed == 4 else T2[:, [1, 2]]   # either winding
    forb = np.array([[0, k // 2], [1, k // 3]], np.int64)
    is_loop = np.arange(len(P2)) < k
    dirty = rng.random(len(T2)) < 0.3
    for rounds, d, fb in ((100, None, forb), (2, None, forb), (100, dirty, np.zeros((0, 2), np.int64))):
        # a jitter so that there is something to flip
        Pj = P2 + rng.normal(scale=0.03, size=P2.shape) * (~is_loop)[:, None]
        a = refine.relax_reference(Pj, T2.copy(), is_loop, fb, rounds, d)
        b = refine_kernels.relax(Pj, T2.copy(), is_loop, fb, rounds, d, refine.angle_between, refine.unfolded,
                                 refine.FLIP_EPS)
        if b is None:                              # a face shared by two flips of a round: NumPy redoes it
            b = refine.relax(Pj, T2.copy(), is_loop, fb, rounds, d)
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and a[2] == b[2]
        assert d is not None or rounds < 100 or a[1].any()


@pytest.mark.parametrize("seed", range(4))
def test_the_compiled_half_edge_pairing_equals_the_stable_argsort(seed):
    """relax's pairing: sorted keys, twins and canonical half-edges as the
    NumPy argsort gives them, with a non-manifold edge (three faces) and
    vertices no face uses."""
    rng = np.random.default_rng(seed)
    V, F = shapes.icosphere(1 + seed % 2)
    F = F[rng.permutation(len(F))]
    a, b = F[3, 0], F[3, 1]
    F = np.vstack([F, [[a, b, len(V)]], [[b, a, len(V) + 1]]]) if seed >= 2 else F
    n = len(V) + 4
    key = np.minimum(F.ravel(), F[:, [1, 2, 0]].ravel()) * n + np.maximum(F.ravel(), F[:, [1, 2, 0]].ravel())
    order = np.argsort(key, kind="stable")
    ks = key[order]
    pair = np.flatnonzero(ks[1:] == ks[:-1])
    twin = np.full(3 * len(F), -1, np.int64)
    twin[order[pair]] = order[pair + 1]
    twin[order[pair + 1]] = order[pair]
    ks2, twin2, active2 = refine_kernels.pair_half_edges(F, n)
    assert np.array_equal(ks, ks2) and np.array_equal(twin, twin2) and np.array_equal(order[pair], active2)
    assert (seed >= 2) == bool(np.any(np.bincount(np.searchsorted(np.unique(ks), ks)) > 2))


@pytest.mark.parametrize("seed", range(4))
def test_plane_separated_pairs_never_cross_and_most_far_pairs_are_found(seed):
    """The prefilter only rules out pairs the exact test calls apart: on
    random, nearly coplanar, touching and offset (1e6) triangle pairs."""
    from shellrepair.mesh.intersect import SIDE_BOUND, TINY, triangles_cross

    rng = np.random.default_rng(seed)
    p = 4000
    A = rng.normal(size=(p, 3, 3))
    B = A[rng.permutation(p)] * 0.5 + rng.normal(scale=0.3, size=(p, 1, 3))
    flat = rng.random(p) < 0.3                       # a third in (nearly) one plane
    A[flat, :, 2] = 0.0
    B[flat, :, 2] = rng.choice([0.0, 1e-17, -1e-300], size=(int(flat.sum()), 1))
    touch = rng.random(p) < 0.1                      # corners on the other's plane
    B[touch, 0] = A[touch].mean(axis=1)
    if seed == 3:
        A, B = A + 1e6, B + 1e6
    ai = bj = np.arange(p)
    Aid, Bid = np.arange(3 * p).reshape(p, 3), 3 * p + np.arange(3 * p).reshape(p, 3)
    sep = intersect_kernels.separated(A, Aid, ai, B, Bid, bj, SIDE_BOUND, TINY)
    hit = triangles_cross(A, B)
    assert not (sep & hit).any()
    assert sep.sum() > 0.3 * (~hit).sum()


def _outlines(seed):
    """Closed 2-D polygons: star-shaped (simple), self-crossing, with a
    repeated vertex, collinear runs, a spike folded back on itself, and
    coordinates on a coarse lattice so that edges touch exactly."""
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 60))
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    star = np.column_stack([np.cos(t), np.sin(t)]) * rng.uniform(0.5, 1.5, (k, 1))
    crossing = star[rng.permutation(k)]
    repeated = star.copy()
    repeated[k // 2] = repeated[0]
    lattice = np.round(star * 3) / 3
    collinear = np.column_stack([np.linspace(0, 1, k), np.zeros(k)])
    spike = np.vstack([star, star[-1] + [1e-13, 0.0], star[-1] + [2.0, 0.0]])
    far = star * 1e6 + 1e7
    return [star, crossing, repeated, lattice, collinear, spike, far]


@pytest.mark.parametrize("seed", range(30))
def test_outline_simplicity_equals_the_numpy_pair_test(seed):
    from shellrepair.mesh.intersect import outline_is_simple, outline_is_simple_reference

    answers = []
    for Q in _outlines(seed):
        a, b = outline_is_simple_reference(Q), outline_is_simple(Q)
        assert a == b
        answers.append(a)
    assert answers[0]                  # a star-shaped outline is simple
    if len(_outlines(seed)[4]) > 3:
        assert not answers[4]          # a doubled-back segment is not


@pytest.mark.parametrize("seed", range(20))
def test_loop_diameter_equals_the_numpy_chunks_to_the_bit(seed):
    from shellrepair import reference
    from shellrepair.mesh import common_kernels
    from shellrepair.holes.loops import loop_stats

    def diameter(Q):
        """The compiled diameter (holes' once the kernels are loaded)."""
        return float(np.sqrt(common_kernels.max_sq_distance(Q)))

    rng = np.random.default_rng(seed)
    k = int(rng.integers(2, 700))
    for Q in (rng.normal(size=(k, 3)), np.round(rng.normal(size=(k, 3)), 1),     # ties
              rng.normal(size=(k, 3)) * 1e-7 + 1e6, np.zeros((k, 3))):
        a, b = reference.loop_diameter(Q, chunk=97), diameter(Q)
        assert np.float64(a).tobytes() == np.float64(b).tobytes()
        # the hole's measure uses it, on the loop about its mean
        c = loop_stats(Q, np.arange(k))["center"]
        assert np.float64(loop_stats(Q, np.arange(k))["diameter"]).tobytes() == \
            np.float64(reference.loop_diameter(Q - c, chunk=97)).tobytes()
    P = rng.normal(size=(k, 3))
    assert diameter(P) == pytest.approx(np.max(np.linalg.norm(P[:, None] - P[None], axis=2)), rel=1e-15)


@pytest.mark.parametrize("seed", range(10))
def test_boxes_meeting_equals_the_numpy_mask(seed):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(0, 3000))
    bmin = np.round(rng.normal(size=(m, 3)), 1)              # coarse: boxes touching the query exactly
    bmax = bmin + np.round(rng.uniform(0, 0.5, (m, 3)), 1)
    bmin[rng.random(m) < 0.01, 1] = np.nan
    lo = np.round(rng.normal(size=3) * 0.5, 1)
    hi = lo + 0.7
    want = np.all((bmin <= hi) & (bmax >= lo), axis=1)
    got = context_kernels.boxes_meeting(bmin, bmax, lo, hi)
    assert got.dtype == bool and np.array_equal(got, want)
    assert m < 200 or 0 < got.sum() < m


@pytest.mark.parametrize("seed", range(6))
def test_fold_test_equals_the_numpy_one(seed):
    """Patches over a noisy grid hole, some triangles flipped onto a
    neighbour (exact folds), some pushed nearly flat against one (within
    and beyond FOLD_DEGREES), plus a zero-area triangle: the compiled fold
    test flags exactly the triangles the NumPy one does."""
    from shellrepair.fill.checks import FOLD_DEGREES, folds_reference

    rng = np.random.default_rng(seed)
    n = 7
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2).astype(float)
    V = np.column_stack([g + rng.normal(0, 0.1, g.shape), rng.normal(0, 0.05, len(g))])
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            F += [[a, b, c], [a, c, d]]
    F = np.array(F, np.int64)
    patch = rng.choice(len(F), len(F) // 2, replace=False)
    scan = np.setdiff1d(np.arange(len(F)), patch)
    ids = F[patch].copy()
    C = V[ids].copy()
    # new vertices get negative ids, as in a patch
    newv = np.unique(ids)[rng.random(np.unique(ids).size) < 0.3]
    ids = np.where(np.isin(ids, newv), -1 - ids, ids)
    # triangles folded back over a patch triangle's edge (a, b): the far
    # corner on the same side, turned out of its plane by 0, 0.05 or 0.2°
    pick = rng.choice(len(C), 6, replace=False)
    A, B, Cc = C[pick, 0], C[pick, 1], C[pick, 2]
    nrm = np.cross(B - A, Cc - A)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    far = A + 0.6 * (Cc - A) + 0.2 * (B - A)
    dist = np.linalg.norm(far - A - np.sum((far - A) * (B - A), 1)[:, None] * (B - A)
                          / np.sum((B - A) ** 2, 1)[:, None], axis=1)
    turn = np.radians(rng.choice([0.0, 0.05, 0.2], len(pick)))
    far += (np.tan(turn) * dist)[:, None] * nrm
    C = np.concatenate([C, np.stack([B, A, far], 1)])
    ids = np.concatenate([ids, np.column_stack([ids[pick, 1], ids[pick, 0], -1000 - np.arange(len(pick))])])
    C[0, 2] = C[0, 0]                      # zero area
    Cs, Fr = V[F[scan]], F[scan]
    want = folds_reference(C, ids, Cs, Fr)
    got = checks_kernels.folds(C, ids, Cs, Fr, np.cos(np.radians(FOLD_DEGREES)))
    assert got.dtype == want.dtype == np.int64
    assert np.array_equal(got, want)
    assert want.size > 0                   # the flipped triangles do fold
    empty = checks_kernels.folds(C[:0], ids[:0], Cs[:0], Fr[:0], 0.5)
    assert empty.size == 0 and np.array_equal(empty, folds_reference(C[:0], ids[:0], Cs[:0], Fr[:0]))


def test_face_cross_equals_the_numpy_cross_products():
    """Faces of a noisy sphere far from the origin, a zero-area face and a
    repeated face: the compiled gather-and-cross gives geometry.cross's
    products to the bit."""
    from shellrepair.mesh.geometry import cross

    V, F = shapes.bumpy_sphere(2)
    V = V * 1e-3 + 1e6
    F = np.vstack([F, [[0, 0, 1]]])
    faces = np.concatenate([np.arange(0, len(F), 3), [len(F) - 1, 5, 5]])
    T = F[faces]
    want = cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    got = patch_kernels.face_cross(faces, F, V)
    assert np.array_equal(got, want)
    assert not want[-3].any() and want[-1].any()
    assert patch_kernels.face_cross(faces[:0], F, V).shape == (0, 3)


@pytest.mark.parametrize("seed", range(4))
def test_ring_sums_equal_the_sparse_products(seed):
    """The sums over the two rings around rim vertices (the continuation
    arcs' base points and normals): compiled, they equal the sparse
    products to the bit, on a random graph with repeated edges and
    self-loops and on the rings of real holes (via the arcs themselves)."""
    from shellrepair import reference

    def next_to(E, mark):
        """The vertices an edge of E joins to a marked one."""
        out = np.zeros(len(mark), bool)
        out[E[mark[E[:, 0]], 1]] = True
        out[E[mark[E[:, 1]], 0]] = True
        return out

    rng = np.random.default_rng(seed)
    nv = 80
    E = rng.integers(0, nv, (240, 2))
    E = np.vstack([E, E[:20][:, ::-1], [[3, 3], [4, 4]]])
    li = rng.choice(nv, 12, replace=False)
    li = np.concatenate([li, li[:2]])                 # a rim vertex listed twice
    level = np.full(nv, 3, np.int64)
    level[li] = 0
    r1 = next_to(E, level == 0) & (level > 0)
    level[r1] = 1
    level[next_to(E, r1) & (level > 1)] = 2
    X = rng.normal(size=(nv, 3)) * 10.0 ** rng.integers(-3, 4, (nv, 1))
    Nv = rng.normal(size=(nv, 3))
    Nv[::7] = -0.0
    want = reference.ring_sums(E, li, level, X, Nv)
    got = bridge_kernels.ring_sums(E, li, level, X, Nv)
    for a, b in zip(want, got):
        assert np.array_equal(np.asarray(a), b)
    assert want[1].min() >= 0 and want[4].max() > 0


def test_continuation_arcs_equal_with_the_sparse_ring_sums(monkeypatch):
    """Whole continuation arcs of a perforated bumpy sphere's holes: the
    compiled ring sums give the arcs the sparse products give, bit for bit."""
    from shellrepair.fill import bridge
    from shellrepair.holes.loops import detect_holes

    V, F = shapes.bumpy_sphere(3)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=4, radius=0.3, seed=2)
    ctx = ScanContext(Mesh(V=V2, F=F2))
    loops = [np.asarray(h.vertices, np.int64) for h in detect_holes(V2, F2).holes]
    near = [F2[ctx.ring_faces(lp, 3)] for lp in loops]
    assert len(loops) == 4
    got = [bridge.continuation_arcs(V2, f, lp) for f, lp in zip(near, loops)]
    monkeypatch.setattr(compiled, "ENABLED", False)
    want = [bridge.continuation_arcs(V2, f, lp) for f, lp in zip(near, loops)]
    for a, b in zip(want, got):
        for x, y in zip(a, b):
            assert np.array_equal(x, y)


def test_block_ids_and_normal_sums_equal_unique_searchsorted_and_add_at():
    """Blocks of faces and loop vertices (one block without faces, repeated
    vertices, a loop vertex no face uses): the compiled local numbering is
    np.unique / np.searchsorted of the keys ``block * n + vertex``, and the
    normal sums are np.add.at's, to the bit."""
    rng = np.random.default_rng(5)
    n = 500
    V = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-2, 3, (n, 1))
    fcount = np.array([30, 0, 45, 12], np.int64)
    sizes = np.array([9, 4, 15, 6], np.int64)
    Fcat = rng.integers(0, 60, (fcount.sum(), 3))
    Fcat[::5, 2] = Fcat[::5, 0]
    loopcat = rng.integers(0, 70, sizes.sum())
    lid_f = np.repeat(np.arange(4), fcount)
    lid_p = np.repeat(np.arange(4), sizes)
    fkey, pkey = lid_f[:, None] * n + Fcat, lid_p * n + loopcat
    want = np.unique(np.concatenate([fkey.ravel(), pkey]))
    ukey, L, li = bridge_kernels.block_ids(Fcat, fcount, loopcat, sizes, n)
    assert np.array_equal(ukey, want)
    assert np.array_equal(L, np.searchsorted(want, fkey)) and np.array_equal(li, np.searchsorted(want, pkey))
    Nf = np.cross(V[Fcat[:, 1]] - V[Fcat[:, 0]], V[Fcat[:, 2]] - V[Fcat[:, 0]])
    acc = np.zeros((len(want), 3))
    for c in range(3):
        np.add.at(acc, L[:, c], Nf)
    assert np.array_equal(bridge_kernels.corner_normal_sums(L, Fcat, V, len(want)), acc)


@pytest.mark.parametrize("seed", range(4))
def test_relaxation_angle_and_fold_terms_equal_the_numpy_ones(seed):
    """The relaxation's opposite angles and fold test on random quads of
    mixed scales (flat, folded, degenerate and far-offset ones included):
    the compiled products and sums give refine.angle_between's and
    refine.unfolded's results to the bit."""
    from shellrepair.fill.refine import angle_between, unfolded

    rng = np.random.default_rng(seed)
    m = 400
    pa, pb, pc, pd = (rng.normal(size=(m, 3)) * 10.0 ** rng.integers(-4, 3, (m, 1)) for _ in range(4))
    pd[:40] = pc[:40]                               # degenerate: c = d
    pc[40:80, 2] = pa[40:80, 2] = pb[40:80, 2] = pd[40:80, 2] = 0.0   # flat
    pa[80:120] += 1e6                               # far from the origin
    pb[80:120] += 1e6
    pc[80:120] += 1e6
    pd[80:120] += 1e6
    u, v = pa - pc, pb - pc
    u[120:160] = 0.0                                # a side of length 0 ...
    u[120:140] *= -1.0                              # ... some as -0.0: the angle is 0, not π
    v[150:160] = -v[150:160]
    assert np.array_equal(_angle_compiled(u, v), angle_between(u, v))
    assert (_angle_compiled(u, v)[120:160] == 0.0).all()
    assert np.array_equal(np.signbit(refine_kernels.angle_parts(u, v)[1]), np.signbit(np.sum(u * v, axis=1)))
    want = unfolded(pa, pb, pc, pd)
    assert np.array_equal(refine_kernels.unfolded(pa, pb, pc, pd), want)
    assert want.any() and not want.all()


@pytest.mark.parametrize("seed", range(4))
def test_refinement_split_test_equals_the_numpy_one(seed):
    """Centroids, mean scales and split verdicts of random triangles of
    mixed scales, far from the origin and degenerate ones included: the
    compiled split test equals refine's NumPy one to the bit."""
    from shellrepair.fill.refine import DENSITY_ALPHA, split_test_reference

    rng = np.random.default_rng(seed)
    n = 300
    P = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-3, 3, (n, 1))
    P[:30] += 1e6
    s = rng.random(n) * 10.0 ** rng.integers(-3, 3, n)
    Tr = rng.integers(0, n, (500, 3))
    Tr[:20, 2] = Tr[:20, 0]
    want = split_test_reference(P, Tr, s, DENSITY_ALPHA)
    got = refine_kernels.split_test(P, Tr, s, DENSITY_ALPHA)
    for a, b in zip(want, got):
        assert np.array_equal(a, b)
    assert want[2].any() and not want[2].all()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_point_triangle_distances_equal_the_numpy_version_to_the_bit(seed, monkeypatch):
    from shellrepair.mesh.distance import point_mesh_distance

    rng = np.random.default_rng(seed)
    V, F = shapes.bumpy_sphere(2, amplitude=0.05)
    V = V + rng.normal(scale=0.02, size=V.shape)
    V[F[:5, 1]] = V[F[:5, 0]]                                      # zero-area triangles ...
    V[F[5:9, 2]] = 0.5 * (V[F[5:9, 0]] + V[F[5:9, 1]])             # ... and collinear ones
    Q = np.concatenate([V[:50] + rng.normal(scale=0.05, size=(50, 3)),    # near the surface, off it
                        rng.normal(scale=2.0, size=(50, 3)),              # far away
                        V[F[:9]].mean(axis=1), V[:5]])                     # on degenerate faces, on vertices
    for shift in (0.0, 1e6):
        got = point_mesh_distance(Q + shift, V + shift, F)
        monkeypatch.setattr(compiled, "ENABLED", False)
        ref = point_mesh_distance(Q + shift, V + shift, F)
        monkeypatch.undo()
        assert np.array_equal(got, ref)
    assert got.max() > 1.0 and got.min() == 0.0                    # far points and exact hits were both measured


def _crossing_pairs_mix(seed):
    """Triangle pairs of every kind the crossing test meets: random ones
    near each other, pairs in one plane (overlapping, touching, apart),
    pairs sharing a vertex or an edge (the same ids at the same positions),
    corners exactly on the other's plane, near-coplanar ones (the filters
    cannot decide), zero-area triangles, and all of it at a 1e6 offset."""
    rng = np.random.default_rng(seed)
    p = 3000
    A = rng.normal(size=(p, 3, 3))
    B = A[rng.permutation(p)] * 0.6 + rng.normal(scale=0.4, size=(p, 1, 3))
    Aid = np.arange(3 * p).reshape(p, 3)
    Bid = 3 * p + np.arange(3 * p).reshape(p, 3)
    kind = rng.integers(0, 8, p)
    flat = kind == 1                                   # one plane
    A[flat, :, 2] = 0.0
    B[flat, :, 2] = 0.0
    lattice = kind == 2                                # one plane, corners on a coarse lattice
    A[lattice] = np.round(A[lattice] * 2) / 2
    A[lattice, :, 2] = 0.0
    B[lattice] = np.round(B[lattice] * 2) / 2
    B[lattice, :, 2] = 0.0
    for k, n_shared in ((3, 1), (4, 2)):               # a shared vertex, a shared edge
        m = np.flatnonzero(kind == k)
        B[m, :n_shared] = A[m, :n_shared]
        Bid[m, :n_shared] = Aid[m, :n_shared]
    m = np.flatnonzero(kind == 5)                      # a corner on the other's plane
    B[m, 0] = A[m].mean(axis=1)
    m = np.flatnonzero(kind == 6)                      # nearly one plane
    A[m, :, 2] = 0.0
    B[m, :, 2] = rng.choice([0.0, 1e-17, -1e-300, 3e-16], size=(m.size, 3))
    m = np.flatnonzero(kind == 7)                      # zero-area: collinear, repeated corner
    A[m, 2] = 0.5 * (A[m, 0] + A[m, 1])
    B[m[::2], 1] = B[m[::2], 0]
    if seed % 2:
        A, B = A + 1e6, B + 1e6
    return A, Aid, B, Bid, kind


@pytest.mark.parametrize("seed", range(6))
def test_compiled_crossing_filters_decide_as_the_exact_test(seed):
    """intersect_kernels.cross_status answers only where its filters are certain, and
    then as triangles_cross does; pair_intersections with the kernels
    equals the NumPy one on every pair (random, coplanar, shared vertices
    and edges, degenerate, 1e6 offsets)."""
    from shellrepair.mesh.intersect import SIDE_BOUND, pair_intersections, pair_intersections_numpy
    from shellrepair.mesh.predicates import O3D_BOUND, TINY

    A, Aid, B, Bid, kind = _crossing_pairs_mix(seed)
    r = np.arange(len(A))
    st = intersect_kernels.cross_status(A, Aid, r, B, Bid, r, SIDE_BOUND, O3D_BOUND, TINY)
    ref = pair_intersections_numpy(A, Aid, B, Bid)
    done = st != intersect_kernels.UNDECIDED
    assert np.array_equal(st[done] == intersect_kernels.CROSS, ref[done])
    assert np.array_equal(pair_intersections(A, Aid, B, Bid), ref)
    assert ref.sum() > 100 and (~ref).sum() > 100               # both answers occur
    assert done[kind == 0].mean() > 0.95 and (~done[np.isin(kind, [1, 2])]).all()   # coplanar: the NumPy test
    # pairs given by index (each triangle used by many pairs)
    rng = np.random.default_rng(seed)
    ai, bj = rng.integers(0, len(A), 5000), rng.integers(0, len(B), 5000)
    st = intersect_kernels.cross_status(A, Aid, ai, B, Bid, bj, SIDE_BOUND, O3D_BOUND, TINY)
    ref = pair_intersections_numpy(A[ai], Aid[ai], B[bj], Bid[bj])
    done = st != intersect_kernels.UNDECIDED
    assert np.array_equal(st[done] == intersect_kernels.CROSS, ref[done])


@pytest.mark.parametrize("seed", range(3))
def test_patch_pairs_are_the_overlapping_boxes_with_their_answers(seed):
    """intersect_kernels.patch_pairs (the faces' corners, boxes, pairs and tests in one
    call) gives the pairs box_pairs gives and cross_status's answers, both
    with all boxes compared (small) and with the grid (large)."""
    from shellrepair.mesh.intersect import SIDE_BOUND
    from shellrepair.mesh.predicates import O3D_BOUND, TINY

    V, F = shapes.bumpy_sphere(3, amplitude=0.05, seed=seed)
    offset = 1e6 if seed == 2 else 0.0
    near = np.flatnonzero(np.linalg.norm(V[F].mean(axis=1) - [0, 0, 1], axis=1) < 0.6)
    V = V + offset
    origin = V.mean(axis=0)
    rng = np.random.default_rng(seed)
    for n_patch in (12, 400):
        P = rng.normal(size=(60, 3)) * 0.2 + [0.0, 0.0, 0.95] + offset
        T = np.array([rng.choice(60, 3, replace=False) for _ in range(n_patch)])
        Pt, ids = P[T], -1 - T
        Pt[:5] = V[F[:5]]                              # five coincide with scan faces
        ids[:5] = F[:5]
        ids[5:8, 0] = F[10:13, 0]                      # three share a corner with one
        Pt[5:8, 0] = V[F[10:13, 0]]
        f = np.union1d(near, np.arange(13))
        Q = Pt - origin
        ai, bj, st = intersect_kernels.patch_pairs(Q, ids, f, V, F, origin, SIDE_BOUND, O3D_BOUND, TINY)
        Tf = V[F[f]] - origin
        a2, b2 = intersect_kernels.box_pairs(Q.min(axis=1), Q.max(axis=1), Tf.min(axis=1), Tf.max(axis=1))
        assert sorted(zip(ai.tolist(), bj.tolist())) == sorted(zip(a2.tolist(), b2.tolist()))
        assert np.array_equal(st, intersect_kernels.cross_status(Q, ids, ai, Tf, F[f], bj, SIDE_BOUND, O3D_BOUND, TINY))
        assert (st == intersect_kernels.CROSS).sum() > 0 and len(ai) > 50
        assert (n_patch * len(f) > intersect_kernels.PAIRS_BRUTE) == (n_patch == 400)


@pytest.mark.parametrize("seed", range(20))
def test_projection_certificate_equals_the_numpy_one(seed, monkeypatch):
    """embeds_by_projection with intersect_kernels.projection_embeds equals its NumPy
    tail: fans over wavy loops (simple, self-crossing, with a repeated
    vertex, with triangles turned over or of zero area), at offset 1e6 too."""
    from shellrepair.mesh.intersect import embeds_by_projection

    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 40))
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    radius = 1.0 + 0.3 * np.sin(2 * t + rng.uniform(0, 6))[:, None]
    loop = np.column_stack([np.cos(t), np.sin(t), 0.2 * np.sin(3 * t)]) * radius
    inner = rng.normal(scale=0.2, size=(3, 3))
    inner[0] = [0.0, 0.0, 0.1]
    P = np.vstack([loop, inner])
    T = np.array([[(i + 1) % k, i, k] for i in range(k)])               # a fan, against the loop
    cases = [(P, T), (P, np.array([[(i + 1) % k, i, k + i % 3] for i in range(k)]))]
    Q = P.copy()
    Q[k] = [3.0, 0.0, 0.0]                                              # the centre outside: turned over
    cases.append((Q, T))
    cases.append((P[np.r_[rng.permutation(k), k:k + 3]], T))            # a self-crossing outline
    Q = P.copy()
    Q[k // 2] = Q[0]                                                    # a repeated vertex
    cases.append((Q, T))
    cases.append((P, np.vstack([T, [[0, 0, k]]])))                      # a zero-area triangle
    cases += [(Q + 1e6, T) for Q, T in cases]
    answers = []
    for Q, Tq in cases:
        got = {}
        for on in (True, False):
            monkeypatch.setattr(compiled, "ENABLED", on)
            got[on] = embeds_by_projection(Q, Tq, k)
        assert got[True] == got[False]
        answers.append(got[True])
    assert not answers[2] and answers[0]                  # turned over: no; a plain fan: yes


def test_scan_edges_are_the_loop_edges_of_the_sorted_edge_list():
    """merge.scan_edges (masks per edge column) lists what sorting every
    patch edge and keeping those between loop vertices lists, in that order."""
    from types import SimpleNamespace

    from shellrepair.fill.merge import edges_of, scan_edges

    rng = np.random.default_rng(5)
    loop = rng.permutation(1000)[:30]
    T = rng.integers(0, 45, (200, 3))                # ids >= 30: new vertices
    patch = SimpleNamespace(loop=loop, T=T)
    k = len(loop)
    E = edges_of(np.where(T < k, loop[np.minimum(T, k - 1)], -1))
    want = [tuple(e) for e in E[(E >= 0).all(axis=1)].tolist()]
    assert scan_edges(patch) == want and len(want) > 50
    assert scan_edges(SimpleNamespace(loop=loop, T=T[:0])) == []


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("seed", range(3))
def test_the_dense_fairing_round_reads_k_without_its_spare_slots_to_the_bit(order, seed):
    """fair_small's solves take K without laplacian_rows' spare zero
    diagonal slots (each only added a zero product): every round's
    positions as with the spare slots, uniform and cotangent weights."""
    X, F, nf = _submesh_with_free_middle(9 + 3 * seed, seed)
    n = len(X)
    fixed = np.arange(n) < nf
    unk = np.flatnonzero(~fixed)
    unk_pos = np.full(n, -1, np.int64)
    unk_pos[unk] = np.arange(unk.size)
    rng = np.random.default_rng(seed)
    W = 0.5 * rng.uniform(0.1, 2.0, size=F.shape)          # positive weights, as on a Delaunay mesh
    D = 1.0 / rng.uniform(0.2, 1.0, size=n)
    for ptr, col, val, d in (intrinsic_kernels.laplacian_rows(F, np.zeros((0, 3)), n, True) + (np.ones(n),),
                             intrinsic_kernels.laplacian_rows(F, W, n, False) + (D,)):
        pc, cc, vc = fair_kernels.drop_spare_diagonal(ptr, col, val)
        assert pc[-1] < ptr[-1]                              # there were spare slots to drop
        full, ok1 = fair_kernels.fair_round(ptr, col, val, d, order, X, fixed, unk_pos, unk)
        lean, ok2 = fair_kernels.fair_round(pc, cc, vc, d, order, X, fixed, unk_pos, unk)
        assert ok1 and ok2 and np.array_equal(full, lean)


@pytest.mark.parametrize("seed", range(4))
def test_a_relaxation_rounds_fused_parts_equal_refines_angles_and_fold_test(seed):
    """relax_round_parts (the angle parts at c and d and the fold test of
    each candidate edge in one pass) gives refine.angle_between's arctan2
    arguments and refine.unfolded's verdicts to the bit, on random quads
    of mixed scales, degenerate, flat and far-offset ones included; and
    the relaxation that uses it (refine.relax) flips as the NumPy rounds do."""
    from shellrepair.fill import refine
    from shellrepair.fill import triangulate

    rng = np.random.default_rng(seed)
    m = 300
    P = rng.normal(size=(4 * m, 3)) * 10.0 ** rng.integers(-4, 3, (4 * m, 1))
    P[m:m + 40] = P[:40]                            # c = a: degenerate angles
    P[:80, 2] = 0.0
    P[2 * m:2 * m + 60] += 1e6
    g = np.zeros((m, 8), np.int64)
    g[:, 2:6] = rng.integers(0, 4 * m, size=(m, 4))
    g[:40, 4] = g[:40, 2]
    cr1, dt1, cr2, dt2, unf = refine_kernels.relax_round_parts(P, g)
    pa, pb, pc, pd = P[g[:, 2]], P[g[:, 3]], P[g[:, 4]], P[g[:, 5]]
    assert np.array_equal(np.arctan2(cr1, dt1), _angle_compiled(pa - pc, pb - pc))
    assert np.array_equal(np.arctan2(cr2, dt2), _angle_compiled(pa - pd, pb - pd))
    # and NumPy's angle_between, sides of length 0 included (there every product
    # is ±0.0 and the dot product, summed from 0.0 as np.sum does, is +0.0:
    # arctan2 gives 0, not π)
    zero = ~np.any(pa != pc, axis=1) | ~np.any(pb != pc, axis=1)
    assert 40 <= zero.sum() <= 50                    # (random ids may meet too)
    assert np.array_equal(np.arctan2(cr1, dt1), refine.angle_between(pa - pc, pb - pc))
    assert (np.arctan2(cr1, dt1)[zero] == 0.0).all()
    assert np.array_equal(np.arctan2(cr2, dt2), refine.angle_between(pa - pd, pb - pd))
    assert np.array_equal(unf, refine.unfolded(pa, pb, pc, pd)) and unf.any() and not unf.all()
    k = 20 + 6 * seed
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    Q = np.column_stack([np.cos(t), np.sin(t) * (1 + 0.2 * seed), 0.3 * np.cos(2 * t)])
    Q2, T2 = refine.refine_patch(Q, triangulate.triangulate_loop(Q), np.full(k, 0.2), k)
    is_loop = np.arange(len(Q2)) < k
    Qj = Q2 + rng.normal(scale=0.04, size=Q2.shape) * (~is_loop)[:, None]
    forb = np.zeros((0, 2), np.int64)
    a = refine.relax_reference(Qj, T2.copy(), is_loop, forb)
    b = refine.relax(Qj, T2.copy(), is_loop, forb)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and a[2] == b[2] and a[1].any()
