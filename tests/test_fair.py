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
from shellrepair import compiled
from shellrepair.fill import fair
from shellrepair.fill import fair_kernels
from shellrepair.fill import intrinsic_kernels

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
    monkeypatch.setattr(compiled, "ENABLED", False)        # no dense small-patch path either way
    monkeypatch.setattr(fair, "PCG_MAX_ITER", 60)          # started far off the surface: ~15 iterations
    calls = []
    real = fair.pcg
    monkeypatch.setattr(fair, "pcg", lambda *a, **k: calls.append(real(*a, **k)) or calls[-1])
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
    monkeypatch.setattr(compiled, "ENABLED", False)
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
    X = fair.pcg(A, B, np.zeros((n, 3)), lambda R: R / diag[:, None], tol=1e-12, max_iter=500)
    assert X is not None
    res = np.linalg.norm(B - A @ X, axis=0)
    assert np.all(res <= 1e-12 * np.linalg.norm(B, axis=0) + 1e-300)
    assert np.array_equal(X[:, 1], np.zeros(n))
    assert fair.pcg(A, B, np.zeros((n, 3)), lambda R: R, tol=1e-12, max_iter=2) is None


def test_the_factor_applies_the_inverse_of_the_unknown_block():
    X, F, nf = _bumpy_grid(20, 0)
    n = len(X)
    Q = fair.energy_matrix(fair.uniform_laplacian(F, n), None, 2)
    fixed, unknown = np.arange(nf), np.arange(nf, n)
    Quu, Quf = Q[unknown][:, unknown].tocsc(), Q[unknown][:, fixed].tocsr()
    f = fair.Factor(Quu, Quf)
    R = np.random.default_rng(0).normal(size=(unknown.size, 3))
    Z = f.apply(R)
    assert np.abs(Quu @ Z - R).max() <= 1e-9 * np.abs(R).max()
    Xu = f.minimise(X[fixed])
    assert np.abs(Quu @ Xu + Quf @ X[fixed]).max() <= 1e-9 * np.abs(X).max() * abs(Q).max()


#: The compiled energy blocks against SciPy's products: relative to the
#: largest entry (the same sums in another order).
BLOCKS_TOLERANCE = 1e-13


@pytest.mark.skipif(not compiled.ENABLED, reason="Numba is not installed")
@pytest.mark.parametrize("order", [1, 2, 3])
def test_the_compiled_energy_blocks_equal_scipys_products(order):
    from shellrepair.fill.intrinsic import intrinsic_laplacian

    X, F, nf = _bumpy_grid(30, 4)
    n = len(X)
    K, M = intrinsic_laplacian(X, F)
    Minv = 1.0 / M
    rng = np.random.default_rng(5)
    unknown = np.sort(rng.choice(n, n // 2, replace=False))     # any partition, not only a tail
    fixed = np.setdiff1d(np.arange(n), unknown)
    (up, uc, uv), (fp, fc, fv) = fair_kernels.energy_blocks(K.indptr, K.indices, K.data, Minv, order, unknown, fixed)
    Quu = sp.csr_matrix((uv, uc, up), shape=(unknown.size, unknown.size))
    Quf = sp.csr_matrix((fv, fc, fp), shape=(unknown.size, fixed.size))
    Q = fair.energy_matrix(K, Minv, order)
    scale = abs(Q).max()
    assert abs(Quu - Q[unknown][:, unknown]).max() <= BLOCKS_TOLERANCE * scale
    assert abs(Quf - Q[unknown][:, fixed]).max() <= BLOCKS_TOLERANCE * scale
    assert (Quu - Quu.T).count_nonzero() == 0                      # symmetric to the bit
    assert all(np.all(np.diff(uc[up[i]:up[i + 1]]) > 0) for i in range(unknown.size))   # sorted rows
    assert Quu.nnz >= Q[unknown][:, unknown].count_nonzero()


@pytest.mark.skipif(not compiled.ENABLED, reason="Numba is not installed")
@pytest.mark.parametrize("order", [2, 3])
def test_fairing_with_the_compiled_blocks_equals_the_scipy_path(order, monkeypatch):
    X, F, nf = _bumpy_grid(40, 6)
    assert len(X) - nf > fair.SMALL_UNKNOWNS                    # the sparse path
    got, _ = fair.fair_patch(X, F, nf, order=order)
    monkeypatch.setattr(compiled, "ENABLED", False)
    ref, _ = fair.fair_patch(X, F, nf, order=order)
    assert np.abs(got - ref).max() <= TOLERANCE
    assert np.abs(got - X[nf:]).max() > 0.05


def _min_angles(V, F):
    P = V[F]
    ang = []
    for k in range(3):
        u, w = P[:, (k + 1) % 3] - P[:, k], P[:, (k + 2) % 3] - P[:, k]
        c = np.sum(u * w, axis=1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
        ang.append(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    return np.min(ang, axis=0)


@pytest.mark.parametrize("radius,seed", [(0.35, 2), (0.3, 3)])
def test_order_3_fills_triangles_as_round_as_order_2(radius, seed):
    # Order 3 starts from the uniform thin-plate solve (UNIFORM_MAX_ORDER);
    # from a uniform order-3 solve its thinnest 1 % of filled triangles were
    # thinner than order 2's (1st-percentile smallest angle 25.5° against
    # 29.9° for the first hole; this test failed there), and its second
    # cotangent round needed a fresh factorisation.
    from shellrepair.mesh.io import Mesh
    from shellrepair.repair import repair_mesh

    V, F = shapes.bumpy_sphere(5, amplitude=0.03, frequency=5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=1, radius=radius, seed=seed)
    worst = {}
    for order in (2, 3):
        R, rep = repair_mesh(Mesh(V=V2, F=F2), order=order)
        assert rep["holes_after"] == 0
        worst[order] = np.percentile(_min_angles(R.V, R.F[R.face_filled]), 1)
    assert worst[3] >= 0.95 * worst[2]


@pytest.mark.parametrize("numba", [True, False])
@pytest.mark.parametrize("k", [12, 40])       # the dense small-patch path and the sparse one
def test_fairing_several_orders_at_once_equals_each_alone_to_the_bit(k, numba, monkeypatch):
    if numba and not compiled.ENABLED:
        pytest.skip("Numba is not installed")
    monkeypatch.setattr(compiled, "ENABLED", numba and compiled.ENABLED)
    X, F, nf = _bumpy_grid(k, 7)
    shared = []
    real = fair.Factor

    class Counted(real):
        def __init__(self, *a):
            shared.append(1)
            real.__init__(self, *a)

    monkeypatch.setattr(fair, "Factor", Counted)
    together = fair.fair_patch_orders(X, F, nf, (1, 2, 3), rounds=2)
    n_together = len(shared)
    for order, (Xu, K) in zip((1, 2, 3), together):
        ref, Kref = fair.fair_patch(X, F, nf, order=order, rounds=2)
        assert np.array_equal(Xu, ref)
        assert (K != Kref).nnz == 0
    if len(X) - nf > fair.SMALL_UNKNOWNS or not numba:
        # orders 2 and 3 share the uniform thin-plate solve: one factorisation fewer
        assert n_together == len(shared) - n_together - 1
    # without the operators (the order test's call): the same positions, no K
    for (Xu, K), (ref, _) in zip(fair.fair_patch_orders(X, F, nf, (1, 2, 3), rounds=2, operator=False), together):
        assert np.array_equal(Xu, ref) and K is None


def _count_factorisations(monkeypatch):
    made = []
    real = fair.Factor

    class Counted(real):
        def __init__(self, *a):
            made.append(a[0].shape[0])
            real.__init__(self, *a)

    monkeypatch.setattr(fair, "Factor", Counted)
    return made


@pytest.mark.parametrize("numba", [True, False])
def test_a_remembered_first_solve_gives_the_same_fairing_to_the_bit(numba, monkeypatch):
    monkeypatch.setattr(compiled, "ENABLED", numba and compiled.ENABLED)
    X, F, nf = _bumpy_grid(40, 8)
    assert len(X) - nf >= fair.FIRST_SOLVE_MEMO_UNKNOWNS
    made = _count_factorisations(monkeypatch)

    def fair_counted(X, order):
        before = len(made)
        Xu, _ = fair.fair_patch(X, F, nf, order=order)
        return Xu, len(made) - before

    (ref2, a), (ref3, b) = fair_counted(X, 2), fair_counted(X, 3)
    fair.first_solve_memo(True)
    try:
        got2, a2 = fair_counted(X, 2)
        got3, b2 = fair_counted(X, 3)        # the same uniform thin-plate system
        X2 = X.copy()
        rim = F[(F >= nf).any(axis=1)].min()    # a fixed vertex next to an unknown
        X2[rim, 2] += 1e-3                   # moved: another right-hand side
        moved, b3 = fair_counted(X2, 3)
    finally:
        fair.first_solve_memo(False)
    assert np.array_equal(got2, ref2) and np.array_equal(got3, ref3)
    assert (a2, b2, b3) == (a, b - 1, b)     # only the identical system was taken from the memo
    assert not np.array_equal(moved, got3)
    assert fair_counted(X, 2)[1] == a        # outside the memo's scope nothing is remembered


def test_a_thread_given_the_runs_memo_takes_the_first_solves_made_in_another(monkeypatch):
    """The fill's helper thread shares its run's memo (beside.Beside): an
    order-3 fairing there takes the order-2 fill's first solve."""
    import threading

    X, F, nf = _bumpy_grid(40, 8)
    ref3, _ = fair.fair_patch(X, F, nf, order=3)
    made = _count_factorisations(monkeypatch)
    fair.fair_patch(X, F, nf, order=3)
    alone = len(made)
    out = {}
    memo = fair.first_solve_memo(True)
    try:
        fair.fair_patch(X, F, nf, order=2)

        def helper():
            fair.first_solve_memo(memo)
            try:
                before = len(made)
                out["X"] = fair.fair_patch(X, F, nf, order=3)[0]
                out["made"] = len(made) - before
            finally:
                fair.first_solve_memo(False)

        t = threading.Thread(target=helper)
        t.start()
        t.join()
        assert fair.current_first_solve_memo() is memo      # the other thread leaving it does not end it here
    finally:
        fair.first_solve_memo(False)
    assert out["made"] == alone - 1 and np.array_equal(out["X"], ref3)


def _energy_rows_python(ptr, col, val, D, order, unknown, fixed):
    """Rows ``unknown`` of K (D K)^(order−1) in Python floats: each entry's
    sum starts from 0.0 and adds its terms in the order the row's expansion
    meets them (a dict keeps its columns in first-touch order); columns
    sorted, split into the unknowns' and the fixed block."""
    n = len(ptr) - 1
    pos = np.empty(n, np.int64)
    pos[unknown], pos[fixed] = np.arange(len(unknown)), np.arange(len(fixed))
    is_fixed = np.zeros(n, bool)
    is_fixed[fixed] = True
    rows_u, rows_f = [], []
    for v in unknown:
        acc = {}
        for q in range(ptr[v], ptr[v + 1]):
            acc[col[q]] = acc.get(col[q], 0.0) + float(val[q])
        for _ in range(order - 1):
            nxt = {}
            for w, a in acc.items():
                sw = a * float(D[w])
                for q in range(ptr[w], ptr[w + 1]):
                    nxt[col[q]] = nxt.get(col[q], 0.0) + sw * float(val[q])
            acc = nxt
        cols = sorted(acc)
        rows_u.append([(pos[j], acc[j]) for j in cols if not is_fixed[j]])
        rows_f.append([(pos[j], acc[j]) for j in cols if is_fixed[j]])
    return rows_u, rows_f


@pytest.mark.skipif(not compiled.ENABLED, reason="Numba is not installed")
@pytest.mark.parametrize("order", [1, 2, 3])
def test_the_compiled_energy_rows_equal_the_python_expansion_to_the_bit(order):
    from shellrepair.fill.intrinsic import laplacian_arrays

    X, F, nf = _bumpy_grid(16, 3)
    (ptr, col, val), M = laplacian_arrays(X, F)        # spare diagonal slots kept: repeated columns
    n = len(X)
    rng = np.random.default_rng(order)
    unknown = np.sort(rng.choice(n, n // 2, replace=False))
    fixed = np.setdiff1d(np.arange(n), unknown)
    D = 1.0 / M
    pos = np.empty(n, np.int64)
    pos[unknown], pos[fixed] = np.arange(unknown.size), np.arange(fixed.size)
    is_fixed = np.zeros(n, np.bool_)
    is_fixed[fixed] = True
    up, uc, uv, fp, fc, fv = fair.energy_rows(ptr, col, val, D, order, unknown, pos, is_fixed)
    ref_u, ref_f = _energy_rows_python(ptr, col, val, D, order, unknown, fixed)
    for i in range(unknown.size):
        assert list(zip(uc[up[i]:up[i + 1]].tolist(), uv[up[i]:up[i + 1]].tolist())) == ref_u[i]
        assert list(zip(fc[fp[i]:fp[i + 1]].tolist(), fv[fp[i]:fp[i + 1]].tolist())) == ref_f[i]
    # a fan of 90 triangles: rows of over 64 columns (sorted another way)
    k = 90
    T = np.array([[0, 1 + i, 1 + (i + 1) % k] for i in range(k)], np.int64)
    ptr, col, val = intrinsic_kernels.laplacian_rows(T, rng.random((k, 3)), k + 1, False)
    D = 1.0 + rng.random(k + 1)
    unknown, fixed = np.array([0, 5, 40], np.int64), np.setdiff1d(np.arange(k + 1), [0, 5, 40])
    pos = np.empty(k + 1, np.int64)
    pos[unknown], pos[fixed] = np.arange(3), np.arange(fixed.size)
    up, uc, uv, fp, fc, fv = fair.energy_rows(ptr, col, val, D, order, unknown, pos, np.isin(np.arange(k + 1), fixed))
    ref_u, ref_f = _energy_rows_python(ptr, col, val, D, order, unknown, fixed)
    assert up[1] + fp[1] == k + 1 > 64
    for i in range(3):
        assert list(zip(uc[up[i]:up[i + 1]].tolist(), uv[up[i]:up[i + 1]].tolist())) == ref_u[i]
        assert list(zip(fc[fp[i]:fp[i + 1]].tolist(), fv[fp[i]:fp[i + 1]].tolist())) == ref_f[i]


@pytest.mark.skipif(not compiled.ENABLED, reason="Numba is not installed")
@pytest.mark.parametrize("seed", range(3))
def test_the_compiled_symmetrisation_equals_scipys_half_sum_to_the_bit(seed):
    """fair.symmetrise_rows (the compiled step) on sorted rows of a structurally symmetric
    matrix (with mirrored entries missing too, kept as they are) against
    SciPy's (Q + Qᵀ) / 2, entry for entry."""
    rng = np.random.default_rng(seed)
    n = 60
    A = sp.random(n, n, density=0.15, random_state=seed, format="csr")
    S = (A + A.T + sp.eye(n)).tocsr()                # the pattern: symmetric
    S.sort_indices()
    Q = S.copy()
    Q.data = rng.normal(size=Q.nnz)                  # the values: not
    ref = ((Q + Q.T) * 0.5).tocsr()
    ref.sort_indices()
    got = fair.symmetrise_rows(Q.indptr.astype(np.int64), Q.indices.astype(np.int64), Q.data.copy())
    assert np.array_equal(ref.indptr, Q.indptr) and np.array_equal(ref.indices, Q.indices)
    assert np.array_equal(got, ref.data)
    # an entry without its mirror stays as it was
    keep = np.ones(Q.nnz, bool)
    r = np.repeat(np.arange(n), np.diff(Q.indptr))
    off = np.flatnonzero(r != Q.indices)
    keep[off[:5]] = False
    T = sp.csr_matrix((Q.data[keep], Q.indices[keep], np.concatenate([[0], np.cumsum(np.bincount(r[keep], minlength=n))])),
                      shape=(n, n))
    got = fair.symmetrise_rows(T.indptr.astype(np.int64), T.indices.astype(np.int64), T.data.copy())
    Td = T.toarray()
    G = sp.csr_matrix((got, T.indices, T.indptr), shape=(n, n)).toarray()
    both = (Td != 0) & (Td.T != 0)
    assert np.array_equal(G[both], ((Td + Td.T) * 0.5)[both]) and np.array_equal(G[~both], Td[~both])


def _wheel(spokes=40, rings=4):
    """A disc of ``rings`` rings of ``spokes`` vertices around one centre of
    valence ``spokes``, gently domed: rows of the energy longer than 64."""
    r = np.repeat(np.arange(1, rings + 1), spokes) / rings
    t = np.tile(np.arange(spokes), rings) * 2 * np.pi / spokes + 0.3 * np.repeat(np.arange(rings), spokes)
    X = np.vstack([[0.0, 0.0, 0.3], np.column_stack([r * np.cos(t), r * np.sin(t), 0.3 * (1 - r * r)])])
    F = [[0, 1 + i, 1 + (i + 1) % spokes] for i in range(spokes)]
    for k in range(rings - 1):
        a, b = 1 + k * spokes, 1 + (k + 1) * spokes
        for i in range(spokes):
            j = (i + 1) % spokes
            F += [[a + i, b + i, b + j], [a + i, b + j, a + j]]
    return X, np.array(F, np.int64)


@pytest.mark.skipif(not compiled.ENABLED, reason="Numba is not installed")
@pytest.mark.parametrize("order", [2, 3])
def test_the_energy_blocks_of_a_high_valence_vertex_equal_scipys_products(order):
    """Rows of more than 64 columns (a valence-40 centre) are sorted another
    way than short ones: the same blocks."""
    from shellrepair.fill.intrinsic import intrinsic_laplacian

    X, F = _wheel()
    n = len(X)
    K, M = intrinsic_laplacian(X, F)
    Minv = 1.0 / M
    fixed = np.arange(n - 40, n)                                    # the outer ring
    unknown = np.arange(n - 40)
    (up, uc, uv), (fp, fc, fv) = fair_kernels.energy_blocks(K.indptr, K.indices, K.data, Minv, order, unknown, fixed)
    assert np.diff(up).max() > 64                                   # the long rows are there
    Q = fair.energy_matrix(K, Minv, order)
    scale = abs(Q).max()
    Quu = sp.csr_matrix((uv, uc, up), shape=(unknown.size, unknown.size))
    Quf = sp.csr_matrix((fv, fc, fp), shape=(unknown.size, fixed.size))
    assert abs(Quu - Q[unknown][:, unknown]).max() <= BLOCKS_TOLERANCE * scale
    assert abs(Quf - Q[unknown][:, fixed]).max() <= BLOCKS_TOLERANCE * scale
    assert all(np.all(np.diff(uc[up[i]:up[i + 1]]) > 0) for i in range(unknown.size))   # sorted rows


@pytest.mark.skipif(not compiled.ENABLED, reason="Numba is not installed")
@pytest.mark.parametrize("order", [1, 2, 3])
def test_dropping_the_spare_diagonal_slots_changes_no_energy_entry(order):
    from shellrepair.fill.intrinsic import laplacian_arrays

    X, F, nf = _bumpy_grid(24, 9)
    (ptr, col, val), M = laplacian_arrays(X, F)
    spare = sum(int(np.sum((col[ptr[i] + 1:ptr[i + 1]] == i) & (val[ptr[i] + 1:ptr[i + 1]] == 0.0)))
                for i in range(len(X)))
    assert spare > len(col) // 4                                   # the slots are there to drop
    n = len(X)
    unknown, fixed = np.arange(nf, n), np.arange(nf)
    D = 1.0 / M
    got = fair_kernels.energy_blocks(ptr, col, val, D, order, unknown, fixed)
    pos = np.empty(n, np.int64)
    pos[unknown], pos[fixed] = np.arange(unknown.size), np.arange(fixed.size)
    up, uc, uv, fp, fc, fv = fair.energy_rows(ptr, col, val, D, order, unknown, pos, np.arange(n) < nf)
    ref = (up, uc, fair.symmetrise_rows(up, uc, uv)), (fp, fc, fv)   # the rows read with the slots
    for a, b in zip(got, ref):
        for x, y in zip(a, b):
            assert np.array_equal(x, y)


@pytest.mark.parametrize("k", [12, 40])       # the dense small-patch path and the sparse one
def test_the_returned_operator_is_assembled_when_read_and_equals_the_eager_matrix(k, monkeypatch):
    X, F, nf = _bumpy_grid(k, 3)
    Xu, K = fair.fair_patch(X, F, nf, order=2)
    assert isinstance(K, fair.Operator) and K.shape == (len(X), len(X))
    M = fair.as_matrix(K)
    assert sp.isspmatrix_csc(M) and M is K.tocsc()          # assembled once
    with monkeypatch.context() as m:                         # the matrix assembled at once, as before
        m.setattr(fair, "Operator", fair.as_sparse)
        Xe, E = fair.fair_patch(X, F, nf, order=2)
    assert sp.isspmatrix_csc(E) and np.array_equal(Xu, Xe)
    assert np.array_equal(M.indptr, E.indptr) and np.array_equal(M.indices, E.indices)
    assert np.array_equal(M.data, E.data)
    assert (K != E).nnz == 0 and abs(K - E).max() == 0 and (K @ X).shape == X.shape
    # interpolation reads the operator as it read the eager matrix
    values = np.linspace(0.0, 1.0, nf)[:, None]
    assert np.array_equal(fair.harmonic_interpolate(K, values, nf), fair.harmonic_interpolate(E, values, nf))


def test_a_blown_up_patch_has_infinite_energy_without_warnings():
    """A fairing that diverged to huge but finite positions (one vertex at
    1e200) overflows the energy sums: both energies are inf, quietly, so the
    patch loses every comparison; the same fan unmoved has finite energies."""
    import warnings

    from shellrepair.fill.fair import curvature_variation_energy, thin_plate_energy

    k = 8
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    X = np.vstack([np.column_stack([np.cos(t), np.sin(t), 0.1 * np.cos(2 * t)]), [[0.0, 0.0, 0.2]]])
    F = np.array([[i, (i + 1) % k, k] for i in range(k)], np.int64)
    rows = np.arange(k + 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        e0, c0 = thin_plate_energy(X, F, rows), curvature_variation_energy(X, F, rows)
        Xb = X.copy()
        Xb[k] = [3e200, -1e200, 2e200]
        e1, c1 = thin_plate_energy(Xb, F, rows), curvature_variation_energy(Xb, F, rows)
    assert np.isfinite(e0) and np.isfinite(c0) and e0 > 0
    assert e1 == np.inf and c1 == np.inf
