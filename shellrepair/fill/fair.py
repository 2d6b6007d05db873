"""Fair a hole patch: solve Δᵏx = 0 on its interior, the scan around it fixed.

The solve is local: the patch plus ``order`` rings of scan faces around
its loop (enough for the discrete operator at every unknown to see complete
neighbourhoods), never the whole scan. Unknowns are only the patch's new
vertices; every scan vertex, the loop included, is fixed, so position
(k = 1), tangent plane (k = 2) and curvature (k = 3) continue across the
rim.

With K = −L the (positive semidefinite) cotangent Laplacian and M the
Voronoi mass matrix, the energy is xᵀ Q x with

    k = 1:  Q = K                   (membrane, harmonic)
    k = 2:  Q = K M⁻¹ K             (thin plate, bilaplacian)
    k = 3:  Q = K M⁻¹ K M⁻¹ K       (minimum variation of curvature)

minimised with the fixed rows given: Q_uu x_u = −Q_uf x_f, one sparse LLᵀ
factorisation of the unknowns' block Q_uu (:mod:`shellrepair.fill.cholesky`;
libigl's ``min_quad_with_fixed`` without Numba),
the three coordinates solved as three right-hand sides. The two blocks are
assembled row by row by a compiled kernel
(:func:`shellrepair.fill.fair_kernels.energy_blocks`), not by sparse products and
slices. The first round uses uniform (umbrella) weights, since cotangents
of the initial, flat patch are meaningless, at order min(k, 2)
(``UNIFORM_MAX_ORDER``); later rounds re-evaluate cotangent weights and
masses on the patch's own current geometry, taken on its intrinsic
Delaunay triangulation
(:mod:`shellrepair.fill.intrinsic`): the slivers a scan's rim is full of then
give neither negative weights nor vanishing masses. Where a triangle is
degenerate the round falls back to uniform weights.

Order 3 starts from the uniform thin-plate (k = 2) solve, not a uniform
k = 3 one: the cube of the umbrella operator leaves the patch's vertices
so unevenly spread along the surface that the first cotangent round moved
them far, and the second round's matrix still differed from the first's
by 36 % (Frobenius norm; the 15k-unknown patch of ``eval/bench_fill.py``,
against 0.3 % at k = 2): the first round's factors could not precondition
it, and it took a third factorisation. From the thin-plate start the rounds
differ as little as at k = 2, and the first factorisation has half the
non-zeros.

From the second cotangent round on, the matrix differs little from the
previous round's (the geometry moved by a fraction of an edge), so that
round is solved by conjugate gradients preconditioned with the previous
round's factorisation, started from the current positions: a few
triangular solves instead of a new factorisation (four iterations on the
12k-unknown patch of ``eval/bench_fill.py``). It stops at a relative
residual of ``PCG_TOL`` per coordinate, where it agrees with the direct
solve to the direct solve's own round-off (a few 1e-10 mean rim edges; the
tolerance ``tests/test_fair.py`` states and checks is 1e-8); it falls back
to a fresh factorisation after ``PCG_MAX_ITER`` iterations.

Coordinates are centred on the loop and scaled by its mean edge length
before any solve, so scans in millimetres far from the origin give the same
relative result as unit-scale meshes.

References
----------
M. Botsch, L. Kobbelt, "An intuitive framework for real-time freeform
modeling", SIGGRAPH 2004. M. Desbrun, M. Meyer, P. Schröder, A. Barr,
"Implicit fairing of irregular meshes", SIGGRAPH 1999. G. Taubin, "A signal
processing approach to fair surface design", SIGGRAPH 1995.
"""

from __future__ import annotations

import threading

import numpy as np

from shellrepair import compiled
from shellrepair.fill import cholesky, fair_kernels, intrinsic_kernels
from shellrepair.fill.intrinsic import intrinsic_laplacian
from shellrepair.lazyscipy import sparse as sp
from shellrepair.lazyscipy import sparse_linalg as spla

__all__ = ["fair_patch", "fair_patch_orders", "Operator", "as_matrix", "first_solve_memo", "uniform_laplacian", "taubin_smooth", "umbrella_smooth", "harmonic_interpolate",
           "cotan_operators", "energy_matrix", "as_sparse", "Factor", "pcg", "current_first_solve_memo", "energy_rows",
           "symmetrise_rows"]

#: Rounds of cotangent re-evaluation after the uniform first solve.
COTAN_ROUNDS = 2
#: The uniform first solve is of order min(order, this) (module docstring).
UNIFORM_MAX_ORDER = 2
#: Triangles with area below this (in units of the squared mean rim edge) are degenerate.
DEGENERATE_AREA = 1e-10
#: Patches with at most this many unknowns (and unknowns × submesh vertices
#: at most ``SMALL_WORK``) are faired by the compiled dense solve
#: (:func:`shellrepair.fill.fair_kernels.fair_small`; equal to round-off).
SMALL_UNKNOWNS = 200
SMALL_WORK = 200_000
#: Later cotangent rounds: conjugate gradients stop at this relative residual
#: (2-norm per coordinate, against the right-hand side's) ...
PCG_TOL = 1e-14
#: ... or give up and factorise afresh after this many iterations, or as
#: soon as the residual's rate of decrease predicts more (an iteration costs
#: a pair of triangular solves, ~1/13 of a factorisation at 12k unknowns;
#: the refined patches of eval/bench_fill.py need 3-4, a bumpy grid started
#: far off its surface 15).
PCG_MAX_ITER = 8
#: Unknowns from which later rounds try conjugate gradients at all (below it
#: a factorisation costs about what a few iterations do).
PCG_MIN_UNKNOWNS = 1000
#: Taubin λ|μ smoothing factors (non-shrinking pass band).
TAUBIN_LAMBDA = 0.5
TAUBIN_MU = -0.53


def uniform_laplacian(F, n):
    """K = D − A of the edge graph (positive semidefinite), CSC."""
    F = np.asarray(F, np.int64)
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2], F[:, 1], F[:, 2], F[:, 0]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0], F[:, 0], F[:, 1], F[:, 2]])
    A = sp.csc_matrix((np.ones(i.size), (i, j)), shape=(n, n))  # duplicates summed
    A.data[:] = 1.0
    deg = np.diff(A.indptr).astype(np.float64)  # A is symmetric: column counts are row counts
    d = np.arange(n)
    return sp.csc_matrix((np.concatenate([deg, -A.data]),
                          (np.concatenate([d, A.indices]),
                           np.concatenate([d, np.repeat(d, np.diff(A.indptr))]))), shape=(n, n))


def cotan_operators(X, F):
    """K and lumped M of the submesh's intrinsic Delaunay triangulation
    (what each cotangent fairing round and energy builds once).

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64

    Returns
    -------
    K : (n,n) sparse
        The cotangent Laplacian.
    M : (n,) float64
        The lumped masses.
    """
    return intrinsic_laplacian(X, F)


def energy_matrix(K, Minv, order):
    """Q of the module docstring, by SciPy's sparse products.

    Parameters
    ----------
    K : (n,n) sparse
        The Laplacian.
    Minv : (n,) float64 or None
        Inverse masses; None for unit masses.
    order : 1, 2 or 3

    Returns
    -------
    Q : (n,n) sparse, symmetric
    """
    if order == 1:
        return K
    if Minv is None:  # K symmetric: its powers are too
        Q = K @ K
        return (Q @ K if order == 3 else Q).tocsc()
    K = sp.csc_matrix(K)
    if order == 2:
        # K M⁻¹ K = Bᵀ B with B = M^(−1/2) K (K symmetric): symmetric as built
        B = sp.csc_matrix((K.data * np.sqrt(Minv)[K.indices], K.indices, K.indptr), shape=K.shape)
        return (B.T @ B).tocsc()
    Dm = sp.diags(Minv)
    Q = K @ Dm @ K @ Dm @ K
    return ((Q + Q.T) * 0.5).tocsc()


def _blocks(K, Minv, order, fixed, unknown):
    """The unknowns' block Q_uu (CSC) and the fixed coupling Q_uf (CSR) of
    :func:`energy_matrix`'s Q: compiled in one pass per row
    (:func:`shellrepair.fill.fair_kernels.energy_blocks`) when Numba is there, else
    SciPy's products and slices. ``K``: sparse, or the CSR arrays of
    :func:`_operators`."""
    if compiled.ENABLED:
        if sp.issparse(K):
            K = sp.csc_matrix(K)
            K = (K.indptr, K.indices, K.data)
        ptr, col, val = K
        D = np.ones(ptr.size - 1) if Minv is None else Minv
        (up, uc, uv), (fp, fc, fv) = fair_kernels.energy_blocks(ptr, col, val, D, order, unknown, fixed)
        return (sp.csc_matrix((uv, uc, up), shape=(unknown.size, unknown.size)),
                sp.csr_matrix((fv, fc, fp), shape=(unknown.size, fixed.size)))
    Qu = energy_matrix(K, Minv, order)[unknown]
    return Qu[:, unknown].tocsc(), Qu[:, fixed].tocsr()


def _operators(X, F, uniform=False):
    """K (and M, None for ``uniform``) of a fairing round: as compiled CSR
    arrays when Numba is there (no SciPy assembly), else sparse."""
    if not compiled.ENABLED:
        return (uniform_laplacian(F, len(X)), None) if uniform else cotan_operators(X, F)
    if uniform:
        return intrinsic_kernels._laplacian_rows(np.ascontiguousarray(F, np.int64), np.zeros((0, 3)), len(X), True), None
    from shellrepair.fill.intrinsic import laplacian_arrays

    return laplacian_arrays(X, F)


def as_sparse(K, n):
    """The CSC matrix of :func:`_operators`' K, assembled now (what
    :class:`Operator` assembles when first read).

    Parameters
    ----------
    K : sparse, or (ptr, col, val) CSR arrays
    n : int

    Returns
    -------
    (n,n) CSC sparse matrix
    """
    if sp.issparse(K):
        return K
    ptr, col, val = K
    return sp.csr_matrix((val, col, ptr), shape=(n, n)).tocsc()


def energy_rows(ptr, col, val, D, order, unknown, pos, is_fixed):
    """The rows ``unknown`` of ``K (D K)^(order−1)``, the compiled step of
    :func:`shellrepair.fill.fair_kernels.energy_blocks` before its
    symmetrisation: each entry summed from 0.0 in the order the row's
    expansion meets its terms, the columns sorted and split into the
    unknowns' block and the fixed one. Needs the kernels.

    Parameters
    ----------
    ptr, col, val : CSR arrays of K (n,n)
    D : (n,) float64
        The inverse masses.
    order : 1, 2 or 3
    unknown : (u,) int64
    pos : (n,) int64
        Each vertex's place in ``unknown``, or in the fixed ones.
    is_fixed : (n,) bool

    Returns
    -------
    u_ptr, u_col, u_val, f_ptr, f_col, f_val
        The unknowns' block and the fixed block, as CSR arrays.
    """
    return fair_kernels._energy_rows(ptr, col, val, D, order, unknown, pos, is_fixed)


def symmetrise_rows(ptr, col, val):
    """``(Q + Qᵀ) / 2`` of a matrix whose pattern is symmetric, on its sorted
    CSR rows: the compiled last step of
    :func:`shellrepair.fill.fair_kernels.energy_blocks`; an entry without its
    mirror is kept as it is. Needs the kernels.

    Parameters
    ----------
    ptr, col : CSR pattern, each row's columns sorted
    val : values (changed in place)

    Returns
    -------
    val : the half-sums, on the same pattern
    """
    return fair_kernels._symmetrise(ptr, col, val)


class Operator:
    """:func:`fair_patch`'s K, assembled as a CSC matrix when first read.

    Most callers read only the positions (a fill without colours or
    properties never interpolates with K), and assembling SciPy's matrix
    from the compiled kernels' CSR arrays cost as much as a small patch's
    whole fairing. :meth:`tocsc` (or :func:`as_matrix`) gives the matrix;
    any other attribute, and ``-``, ``!=``, ``abs``, ``@``, are the matrix's.
    """

    __slots__ = ("_arrays", "_n", "_K")

    def __init__(self, K, n):
        self._arrays, self._n, self._K = K, int(n), None

    def tocsc(self):
        """The (n,n) CSC matrix (assembled once)."""
        if self._K is None:
            self._K = as_sparse(self._arrays, self._n)
            self._arrays = None
        return self._K

    @property
    def shape(self):
        return (self._n, self._n)

    def __getattr__(self, name):
        return getattr(self.tocsc(), name)

    def __sub__(self, other):
        return self.tocsc() - as_matrix(other)

    def __rsub__(self, other):
        return as_matrix(other) - self.tocsc()

    def __ne__(self, other):
        return self.tocsc() != as_matrix(other)

    def __eq__(self, other):
        return self.tocsc() == as_matrix(other)

    __hash__ = None

    def __abs__(self):
        return abs(self.tocsc())

    def __matmul__(self, other):
        return self.tocsc() @ other


def as_matrix(K):
    """K as a SciPy sparse matrix: an :class:`Operator`'s, or K itself."""
    return K.tocsc() if isinstance(K, Operator) else K


class Factor:
    """Q_uu, the unknowns' block of Q, factorised once: by
    :func:`shellrepair.fill.cholesky.factor` (nested dissection, dense fronts)
    where the kernels are there, else (and where a front is not positive
    definite) libigl's sparse LLᵀ (``min_quad_with_fixed_precompute`` with
    no fixed rows), or SciPy's LU where libigl fails or gives non-finite
    values. ``Q_uf`` couples the unknowns to the fixed rows.

    Parameters
    ----------
    Quu : (u,u) sparse
        The unknowns' block, symmetric positive definite.
    Quf : (u,f) sparse
        The coupling to the fixed rows.
    """

    def __init__(self, Quu, Quf):
        self.Quu, self.Quf = Quu, Quf
        self.data = self.lu = self.chol = None
        if compiled.ENABLED:
            try:
                self.chol = cholesky.factor(Quu)
                return
            except cholesky.NotPositiveDefinite:
                pass                     # libigl's LLᵀ (or SciPy's LU) below
        self._use_igl()

    def _use_igl(self):
        try:
            import igl

            data = igl.min_quad_with_fixed_data()
            igl.min_quad_with_fixed_precompute(self.Quu, np.zeros(0, np.int64), sp.csc_matrix((0, self.Quu.shape[0])),
                                               True, data)
            self.data = data
        except Exception:  # SciPy's LU instead
            self._use_lu()

    def _use_lu(self):
        self.data = None
        if self.lu is None:
            self.lu = spla.splu(sp.csc_matrix(self.Quu))

    def _solve(self, R):
        """Q_uu⁻¹ R (R: (u,c))."""
        R = np.asarray(R, np.float64)
        if self.chol is not None:
            Z = self.chol.solve(R)
            if np.isfinite(Z).all():
                return Z
            self.chol = None
            self._use_igl()
        if self.data is not None:
            import igl

            try:   # libigl minimises ½ zᵀ Q_uu z + zᵀ B: z = −Q_uu⁻¹ B
                Z = igl.min_quad_with_fixed_solve(self.data, np.ascontiguousarray(-R), np.zeros((0, R.shape[1])),
                                                  np.zeros((0, R.shape[1])))
            except Exception:
                Z = None
            if Z is not None and np.isfinite(Z).all():
                return Z
            self._use_lu()
        return self.lu.solve(R)

    def minimise(self, Xf):
        """X[unknown] minimising xᵀQx, X[fixed] = ``Xf`` given."""
        return self._solve(-(self.Quf @ Xf))

    def apply(self, R):
        """Q_uu⁻¹ R (R: (u,c))."""
        return self._solve(R)


def pcg(A, B, X0, precond, tol=None, max_iter=None):
    """Conjugate gradients on A X = B (A symmetric positive definite), one
    run per column, preconditioned by ``precond(R) ≈ A⁻¹ R``.

    Parameters
    ----------
    A : (n,n) sparse
    B : (n,c) float64
    X0 : (n,c) float64
        The start.
    precond : callable
        ``precond(R)`` for R (n,c).
    tol : float, optional
        Relative residual per column (default ``PCG_TOL``).
    max_iter : int, optional
        Default ``PCG_MAX_ITER``.

    Returns
    -------
    X : (n,c) float64, or None
        None when some column has not reached ‖B − A X‖ ≤ tol ‖B‖ within
        ``max_iter`` iterations (or broke down).
    """
    tol = PCG_TOL if tol is None else tol
    max_iter = PCG_MAX_ITER if max_iter is None else max_iter
    X = np.array(X0, np.float64)
    R = B - A @ X
    target = tol * np.linalg.norm(B, axis=0)
    active = np.linalg.norm(R, axis=0) > target
    if not active.any():
        return X
    res0 = np.linalg.norm(R, axis=0)
    Z = precond(R)
    P = Z.copy()
    rz = np.einsum("ij,ij->j", R, Z)
    for it in range(1, int(max_iter) + 1):
        AP = A @ P
        pap = np.einsum("ij,ij->j", P, AP)
        if not (np.all(pap[active] > 0) and np.all(rz[active] > 0)):
            return None  # breakdown: not positive definite in practice
        alpha = np.where(active, rz / np.where(active, pap, 1.0), 0.0)
        X += alpha * P
        R -= alpha * AP
        res = np.linalg.norm(R, axis=0)
        active &= res > target
        if not active.any():
            return X if np.isfinite(X).all() else None
        if it >= 2:   # iterations still needed at the mean rate so far
            a = np.flatnonzero(active)
            rate = (res[a] / res0[a]) ** (1.0 / it)
            if np.any(rate >= 1.0) or np.any(it + np.log(np.maximum(target[a], 1e-300) / res[a]) / np.log(rate) > max_iter):
                return None
        Z = precond(R)
        rzn = np.einsum("ij,ij->j", R, Z)
        beta = np.where(active, rzn / np.where(active, rz, 1.0), 0.0)
        P = Z + beta * P
        rz = np.where(active, rzn, rz)
    return None


def fair_patch(X, F, n_fixed, order=2, rounds=COTAN_ROUNDS, pinned=None):
    """Fair the free vertices of a local submesh.

    Parameters
    ----------
    X : (n,3) float64
        Submesh positions: the first ``n_fixed`` are scan vertices (fixed),
        the rest the patch's new vertices (initial guess).
    F : (m,3) int64
        Submesh triangles: scan ring faces and patch faces.
    n_fixed : int
    order : {1, 2, 3}
    rounds : int
        Cotangent re-evaluations after the uniform first solve.
    pinned : array of int, optional
        Free vertices (indices counted from ``n_fixed``) held at their
        current positions as well.

    Returns
    -------
    Xu : (n - n_fixed, 3) float64
        Faired positions of the free vertices.
    K : (n,n) CSC, as an :class:`Operator`
        The order-1 operator of the last round (for interpolating colours;
        assembled when first read: :func:`as_matrix`).
    """
    return fair_patch_orders(X, F, n_fixed, (order,), rounds, pinned)[0]


def fair_patch_orders(X, F, n_fixed, orders, rounds=COTAN_ROUNDS, pinned=None, operator=True):
    """:func:`fair_patch` of one submesh at several orders, sharing the work
    the orders have in common: the same result for each order, to the bit.

    Orders whose uniform first solve is of the same order (every order from
    ``UNIFORM_MAX_ORDER`` on: 2 and 3 both start from the uniform thin
    plate) share that solve, and with it the first cotangent round's
    operators (K and M of the same positions); only the energies' blocks,
    their factorisations and the later rounds are per order.

    Parameters
    ----------
    X, F, n_fixed, rounds, pinned
        As in :func:`fair_patch`.
    orders : sequence of {1, 2, 3}
    operator : bool
        Also return each order's last K (False: None in its place, for a
        caller that reads only the positions, such as the order test).

    Returns
    -------
    results : list of (Xu, K)
        :func:`fair_patch`'s result for each order, in the order given.
    """
    op = Operator if operator else (lambda K, n: None)
    X = np.array(X, np.float64)
    n = len(X)
    if n == n_fixed:
        return [(X[n_fixed:], uniform_laplacian(F, n) if operator else None) for _ in orders]
    pin = np.zeros(n, bool)
    pin[:n_fixed] = True
    if pinned is not None and len(pinned):
        pin[n_fixed + np.asarray(pinned, np.int64)] = True
    fixed = np.flatnonzero(pin)
    unknown = np.flatnonzero(~pin)
    if unknown.size == 0:
        return [(X[n_fixed:], uniform_laplacian(F, n) if operator else None) for _ in orders]
    small = compiled.ENABLED and unknown.size <= SMALL_UNKNOWNS and n * unknown.size <= SMALL_WORK
    first = {}     # uniform order -> (positions after the first solve, its K, the first cotangent round's K and M)
    out = []
    for order in orders:
        if small:
            from shellrepair.fill.intrinsic import FLIP_TOL, MAX_ROUNDS

            Xs, ok, ptr, col, val = fair_kernels.fair_small(X, F, pin, order, rounds, DEGENERATE_AREA, FLIP_TOL,
                                                       MAX_ROUNDS, UNIFORM_MAX_ORDER)
            if ok:
                out.append((Xs[n_fixed:], op((ptr, col, val), n)))
                continue
        u = min(order, UNIFORM_MAX_ORDER)
        if u not in first:
            K, _ = _operators(X, F, uniform=True)
            Quu, Quf = _blocks(K, None, u, fixed, unknown)
            X1 = X.copy()
            X1[unknown] = _first_solve(Quu, Quf, X1[fixed])
            first[u] = [X1, K, None]
        X1, K, ops = first[u]
        if ops is None and int(rounds) > 0:
            ops = first[u][2] = _round_operators(X1, F)
        Xo, Ko = _cotan_rounds(X1.copy(), F, fixed, unknown, order, rounds, K, ops)
        out.append((Xo[n_fixed:], op(Ko, n)))
    return out


#: The uniform first solves of at least this many unknowns are remembered
#: (:func:`_first_solve`; every one on the sparse path: the smaller patches
#: fair_small solves dense are not kept) ...
FIRST_SOLVE_MEMO_UNKNOWNS = 1
#: ... up to this many bytes of their matrices, right-hand sides and solutions.
FIRST_SOLVE_MEMO_BYTES = 64 << 20

_memo = threading.local()


class _Memo:
    """The remembered first solves of one fill's run (:func:`_first_solve`),
    shared by the run's threads (the fill's and its helper's)."""

    def __init__(self):
        self.entries = {}
        self.bytes = 0
        self.lock = threading.Lock()


def first_solve_memo(on):
    """Start (``on`` True) or end, and forget, the memo of the sparse
    path's uniform first solves in this thread (:func:`_first_solve`);
    ``on`` a memo this returned: use that one (another thread's, shared).

    Returns
    -------
    memo : the memo now in use in this thread, or None
    """
    _memo.store = on if isinstance(on, _Memo) else (_Memo() if on else None)
    return _memo.store


def current_first_solve_memo():
    """The memo of first solves in use in this thread (:func:`first_solve_memo`).

    Returns
    -------
    memo : the memo, or None when none is in use
    """
    return getattr(_memo, "store", None)


def _first_solve(Quu, Quf, Xf):
    """The uniform first solve, Q_uu⁻¹ (−Q_uf X_f), remembered in a fill's run.

    ``order="auto"`` fills a hole at order 2, then, where the order test asks
    for order 3, fairs the same refined patch at order 3
    (:func:`shellrepair.fill.hole.fill_hole`): both start from the uniform thin
    plate, and the order-3 submesh's extra ring of fixed scan does not enter
    the unknowns' rows (their K² reads two rings), so the system is the
    same, entry for entry (the ~12k-unknown hole of ``eval/bench_fill.py``:
    one factorisation of ~0.1-0.15 s; the 350-unknown holes of
    bumpy_sphere-discs-medium: ~1.5 ms each). Between :func:`first_solve_memo`
    ``(True)`` and ``(False)`` (the fill of a run of holes,
    :func:`shellrepair.fill.runs.run_chunk`), a system of at least
    ``FIRST_SOLVE_MEMO_UNKNOWNS`` unknowns is kept with its solution (per
    run, shared by its threads; the least recently used dropped past
    ``FIRST_SOLVE_MEMO_BYTES``),
    and a later system whose matrix and right-hand side are equal to the bit
    takes that solution: the factorisation is deterministic, so the result
    is the one solving it again would give.
    """
    R = -(Quf @ Xf)
    store = getattr(_memo, "store", None)
    if store is None or Quu.shape[0] < FIRST_SOLVE_MEMO_UNKNOWNS:
        return Factor(Quu, Quf)._solve(R)
    Q = sp.csc_matrix(Quu)
    arrays = (Q.indptr.copy(), Q.indices.copy(), Q.data.copy(), R.copy())   # before a factorisation sorts them
    key = (Quu.shape[0], Quu.nnz, hash(arrays[2].tobytes()), hash(arrays[3].tobytes()))
    memo = store.entries
    with store.lock:
        hit = memo.pop(key, None)
        if hit is not None:
            memo[key] = hit                  # most recently used last
    if hit is not None and all(a.dtype == b.dtype and np.array_equal(a, b) for a, b in zip(arrays, hit[0])):
        return hit[1].copy()
    Z = Factor(Quu, Quf)._solve(R)          # (two threads may solve one system at once: the same Z)
    size = lambda e: sum(a.nbytes for a in e[0]) + e[1].nbytes
    entry = (arrays, Z.copy())
    with store.lock:
        old = memo.pop(key, None)            # the same key: another system, or this one again
        if old is not None:
            store.bytes -= size(old)
        memo[key] = entry
        store.bytes += size(entry)
        while len(memo) > 1 and store.bytes > FIRST_SOLVE_MEMO_BYTES:
            store.bytes -= size(memo.pop(next(iter(memo))))   # the least recently used
    return Z


def _round_operators(X, F):
    """The cotangent round's K and M at positions X, or False where a
    triangle is degenerate or the operators are not finite (the rounds stop
    there)."""
    e = X[F]
    area = 0.5 * np.linalg.norm(np.cross(e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]), axis=1)
    if not np.isfinite(X).all() or area.min() <= DEGENERATE_AREA:
        return False
    Kc, Mc = _operators(X, F)
    if not (np.isfinite(Kc[2] if isinstance(Kc, tuple) else Kc.data).all() and np.isfinite(Mc).all()):
        return False
    return Kc, Mc


def _cotan_rounds(X, F, fixed, unknown, order, rounds, K, ops=None):
    """The cotangent rounds of :func:`fair_patch` from the first solve's
    positions X (changed in place) and its operator K; ``ops``: the first
    round's :func:`_round_operators`, when already known. Returns X and the
    last round's K."""
    last = None  # the previous cotangent round's factorisation
    for r in range(int(rounds)):
        got = ops if (r == 0 and ops is not None) else _round_operators(X, F)
        if got is False:
            break
        Kc, Mc = got
        floor = DEGENERATE_AREA + 1e-3 * np.median(Mc)
        Quu, Quf = _blocks(Kc, 1.0 / np.maximum(Mc, floor), order, fixed, unknown)
        Xn = None
        if last is not None:   # a later round: the previous round's factors precondition CG
            Xn = pcg(Quu, -(Quf @ X[fixed]), X[unknown], last.apply)
        if Xn is None:
            f = Factor(Quu, Quf)
            Xn = f.minimise(X[fixed])
            if unknown.size >= PCG_MIN_UNKNOWNS:
                last = f
        if not np.isfinite(Xn).all():
            break
        X[unknown] = Xn
        K = Kc
    return X, K


def taubin_smooth(X, F, n_fixed, passes, lam=TAUBIN_LAMBDA, mu=TAUBIN_MU):
    """Non-shrinking λ|μ smoothing of the free vertices (umbrella operator).

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    n_fixed : int
        The first ``n_fixed`` vertices do not move.
    passes : int

    Returns
    -------
    Xu : (n - n_fixed, 3) float64
    """
    return umbrella_smooth(X, F, passes, (lam, mu), n_fixed)[n_fixed:]


def umbrella_smooth(X, F, passes, factors, n_fixed=0):
    """Repeated umbrella steps x ← x + f (mean of neighbours − x).

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    passes : int
    factors : sequence of float
        The step factors of one pass, in order (``(λ, μ)`` for Taubin,
        ``(0.5,)`` for the plain Laplacian smoothing of the seed method).
    n_fixed : int
        The first ``n_fixed`` vertices do not move.

    Returns
    -------
    X2 : (n,3) float64
    """
    X = np.array(X, np.float64)
    n = len(X)
    K = uniform_laplacian(F, n)
    deg = K.diagonal()
    W = (sp.diags(deg) - K).tocsr()
    inv = 1.0 / np.maximum(deg, 1.0)
    free = np.arange(n_fixed, n)
    for _ in range(int(passes)):
        for f in factors:
            D = (W @ X) * inv[:, None] - X
            X[free] += f * D[free]
    return X


def harmonic_interpolate(K, values_fixed, n_fixed):
    """Interpolate per-vertex values from the fixed vertices (ΔC = 0).

    Parameters
    ----------
    K : (n,n) sparse, or :func:`fair_patch`'s :class:`Operator`
        Order-1 operator of the submesh.
    values_fixed : (n_fixed, c) float64
    n_fixed : int

    Returns
    -------
    values_free : (n - n_fixed, c) float64
    """
    K = sp.csc_matrix(as_matrix(K))
    n = K.shape[0]
    if n == n_fixed:
        return np.zeros((0, values_fixed.shape[1]))
    u = np.arange(n_fixed, n)
    f = np.arange(n_fixed)
    Kuu = K[u][:, u].tocsc()
    rhs = -(K[u][:, f] @ values_fixed)
    out = spla.splu(Kuu).solve(np.asarray(rhs, np.float64))
    lo, hi = values_fixed.min(axis=0), values_fixed.max(axis=0)
    return np.clip(out, lo, hi)  # the maximum principle, against round-off and negative cotangents


def thin_plate_energy(X, F, rows):
    """Discrete thin-plate energy Σ |(K X)_v|² / M_v over the given vertices.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    rows : (r,) int64
        Vertices whose complete neighbourhoods are in ``F`` (the patch and
        its rim).

    Returns
    -------
    E : float
        Dimensionless (∫ (2H)² dA for a smooth surface): the same for a
        scaled copy, so tubes and caps of different sizes compare; inf
        where the sum overflows or is undefined (a patch whose fairing blew
        up to huge but finite positions), so such a patch loses every
        comparison.
    """
    X = np.asarray(X, np.float64)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):   # a blown-up patch: inf, below
        K, M = cotan_operators(X, np.asarray(F, np.int64))
    return _thin_plate(K, M, X, rows)


def _thin_plate(K, M, X, rows):
    """:func:`thin_plate_energy` from the operators K, M of (X, F)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        KX = np.asarray(K[rows] @ X)
        m = np.maximum(M[rows], 1e-300)
        E = float(np.sum(np.sum(KX * KX, axis=1) / m))
    return E if np.isfinite(E) else np.inf


def curvature_variation_energy(X, F, S):
    """Dirichlet energy of the mean-curvature normal over vertex set ``S``.

    Σ over edges (i, j) inside S of w_ij |Hn_i − Hn_j|², Hn = M⁻¹ K X: the
    energy that order-3 fairing minimises (∫ |∇(2H n)|² dA), measured where
    every vertex of S has its complete neighbourhood in ``F``.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    S : (s,) int64

    Returns
    -------
    E : float
        In units of 1/length²: compare options at the same scale; inf where
        the sum overflows or is undefined (as :func:`thin_plate_energy`).
    """
    X = np.asarray(X, np.float64)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):   # a blown-up patch: inf, below
        K, M = cotan_operators(X, np.asarray(F, np.int64))
    return _curvature_variation(K, M, X, S)


def _curvature_variation(K, M, X, S):
    """:func:`curvature_variation_energy` from the operators K, M of (X, F)."""
    inS = np.zeros(len(X), bool)
    inS[np.asarray(S, np.int64)] = True
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        Hn = np.asarray(K @ X) / np.maximum(M, 1e-300)[:, None]
        C = sp.triu(-K, k=1).tocoo()
        keep = inS[C.row] & inS[C.col]
        d = Hn[C.row[keep]] - Hn[C.col[keep]]
        E = float(np.sum(C.data[keep] * np.sum(d * d, axis=1)))
    return E if np.isfinite(E) else np.inf


def patch_energies(X, F, rows, S):
    """:func:`thin_plate_energy` over ``rows`` and
    :func:`curvature_variation_energy` over ``S`` of one (X, F), from one
    intrinsic cotangent Laplacian (the flips and the assembly done once):
    the same two numbers, to the bit, as the two calls.

    Parameters
    ----------
    X : (n,3) float64
    F : (m,3) int64
    rows : (r,) int64
    S : (s,) int64

    Returns
    -------
    E : float
        The thin-plate energy (dimensionless).
    C : float
        The curvature-variation energy (1/length²).
    """
    X = np.asarray(X, np.float64)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):   # a blown-up patch: inf
        K, M = cotan_operators(X, np.asarray(F, np.int64))
    return _thin_plate(K, M, X, rows), _curvature_variation(K, M, X, S)
