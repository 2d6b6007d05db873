"""The band search's compiled walk along the continuation arcs gives the
NumPy walk's landings to the bit.

:func:`shellrepair.fill.bridge_kernels.arc_landings` follows each arc sample by
sample in its own k-d tree of the rim vertices;
:func:`shellrepair.fill.bridge.landings_reference` (its oracle) asks SciPy's
``cKDTree`` run by run. Both are run here on the arcs
:func:`shellrepair.fill.bridge.loop_sights` builds for seeded scans with many
holes, holes close to each other, loops pinched together at a shared
vertex (the same point in two loops: a tie the kernel settles by the
``cKDTree``'s own order) and a torus band (exact mirror symmetry), and
compared with ``np.array_equal``.
"""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from eval import shapes
from shellrepair import compiled, detect_holes
from shellrepair.fill import bridge
from shellrepair.fill import bridge_kernels
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="numba is not installed")


def _scans():
    """Seeded scans: many disc holes (some within reach of each other),
    random single faces and small clusters removed (holes a few edges
    apart, many pinched together at a vertex), a torus's inner band."""
    out = []
    V, F = shapes.bumpy_sphere(3, amplitude=0.03, frequency=4)
    for n, radius, seed in ((40, 0.05, 11), (25, 0.1, 12), (10, 0.25, 13)):
        out.append(shapes.perforate_discs(V, F, n_holes=n, radius=radius, seed=seed, min_separation=0.0)[:2])
    for seed in (21, 22, 23):
        rng = np.random.default_rng(seed)
        cut = rng.random(len(F)) < 0.02                    # single faces: many share a vertex
        C = V[F].mean(axis=1)
        for c in V[rng.choice(len(V), 6, replace=False)]:  # and a few clusters
            cut |= np.linalg.norm(C - c, axis=1) < rng.uniform(0.05, 0.15)
        out.append(shapes.remove_faces(V, F, cut)[:2])
    Vt, Ft = shapes.torus(R=1.0, r=1.0 / 3, nu=96, nv=32)
    Ct = Vt[Ft].mean(axis=1)
    out.append(shapes.remove_faces(Vt, Ft, np.hypot(Ct[:, 0], Ct[:, 1]) < 1.0 - 0.8 / 3)[:2])
    return out


def _walks(V, F):
    """The arguments loop_sights gives the kernel on a scan, whether the
    kernel asked for the tree's order, its landings and the NumPy walk's."""
    ctx = ScanContext(Mesh(V=V, F=F))
    scan = detect_holes(V, F)
    seen = []
    real = bridge_kernels.arc_landings

    def spy(*args, rank_of=None):
        asked = []
        got = real(*args, rank_of=lambda P: asked.append(1) or rank_of(P))
        seen.append((args, bool(asked), got))
        return got

    bridge_kernels.arc_landings = spy
    try:
        bridge.loop_sights(V, scan.loops, lambda lp: F[ctx.ring_faces(lp, 3)])
    finally:
        bridge_kernels.arc_landings = real
    assert len(seen) == 1
    (U, T, N, kap, s0, length, n_samples, slack, ent, nent, P, owner, place, edge, arow, krow, irow, skip), asked, got = seen[0]
    first = np.concatenate([[0], np.cumsum(np.bincount(ent, minlength=nent))])
    want = bridge.landings_reference(U, T, N, kap, s0, length, n_samples, slack, ent, first, cKDTree(P), owner, place,
                                  edge, arow, krow, irow)
    return seen[0][0], asked, got, want


def test_landings_equal_the_numpy_walk_on_scans_with_many_close_and_pinched_holes():
    ties = asked = landed = 0
    for V, F in _scans():
        args, ask, (got, status), want = _walks(V, F)
        assert status == 0                                   # decided by the kernel, no fallback
        assert got.dtype == want.dtype and np.array_equal(got, want)
        P, owner = args[10], args[11]
        # the same point in two loops (a pinch): ties the kernel settles by the tree's order
        _, inv, cnt = np.unique(P, axis=0, return_inverse=True, return_counts=True)
        ties += int(np.count_nonzero(cnt[inv.ravel()] > 1))
        landed += int(np.count_nonzero(got >= 0))
        asked += ask
    assert ties > 20 and asked >= 2 and landed > 400


def test_loop_sights_with_and_without_the_kernels_agree(monkeypatch):
    for V, F in _scans()[::2]:
        ctx = ScanContext(Mesh(V=V, F=F))
        loops = detect_holes(V, F).loops
        fn = lambda lp: F[ctx.ring_faces(lp, 3)]   # noqa: E731
        got = bridge.loop_sights(V, loops, fn)
        monkeypatch.setattr(compiled, "ENABLED", False)
        want = bridge.loop_sights(V, loops, fn)
        monkeypatch.setattr(compiled, "ENABLED", True)
        assert sorted(got) == sorted(want) and len(got) >= 2
        for a in want:
            assert np.array_equal(got[a][0], want[a][0]) and got[a][1] == want[a][1]


def _one_arc(P, owner, n_samples=4):
    """One straight arc from the origin along x, length 1, against rim
    vertices ``P`` of loops ``owner`` (the arc's own loop is loop 0, far away)."""
    P = np.vstack([np.asarray(P, np.float64), [[50.0, 50, 50], [51, 50, 50], [50, 51, 50], [50, 50, 51]]])
    owner = np.concatenate([owner, [0, 0, 0, 0]]).astype(np.int64)
    place = np.zeros(len(P), np.int64)
    for w in np.unique(owner):
        place[owner == w] = np.arange(np.count_nonzero(owner == w))
    e = np.int64
    args = (np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([[0.0, 0, 1]]), np.zeros(1), np.zeros(1), np.ones(1),
            n_samples, 0.15, np.zeros(1, e), 1, P, owner, place, np.full(owner.max() + 1, 0.01), np.zeros(1, e),
            np.array([4], e), np.zeros(1, e), 2)
    return args


def _leaf_rank(tree):
    """Each point's position in a cKDTree's leaf order (``tree.indices``):
    of points at one place, the tree's query keeps the first."""
    rank = np.empty(len(tree.indices), np.int64)
    rank[tree.indices] = np.arange(len(tree.indices))
    return rank


def test_a_tie_at_one_place_is_settled_as_the_scipy_tree_settles_it():
    # the arc's third sample (x = 0.75) is 0.25 from the point (1, 0, 0),
    # which is in loops 1 and 2 (a pinch): within its slack, so it lands
    # on whichever copy cKDTree returns
    for order in ([1, 2], [2, 1]):
        args = _one_arc([[1.0, 0, 0], [1.0, 0, 0]], np.array(order))
        got, status = bridge_kernels.arc_landings(*args, rank_of=lambda P: _leaf_rank(cKDTree(P)))
        P, owner = args[10], args[11]
        _, j = cKDTree(P).query([0.75, 0, 0])
        assert status == 0 and got[0] == owner[j]
        want = bridge.landings_reference(*args[:9], np.array([0, 1]), cKDTree(P), owner, args[12], *args[13:17])
        assert np.array_equal(got, want)
        # without the tree's order the kernel does not guess
        assert bridge_kernels.arc_landings(*args)[1] == 1


def test_a_tie_between_places_that_decide_differently_is_left_to_numpy():
    # (1, 0.1, 0) and (1, -0.1, 0) of loops 1 and 2 are at the same
    # distance from every sample: the kernel declines, loop_sights' NumPy
    # walk decides
    args = _one_arc([[1.0, 0.1, 0], [1.0, -0.1, 0]], np.array([1, 2]))
    assert bridge_kernels.arc_landings(*args, rank_of=lambda P: _leaf_rank(cKDTree(P)))[1] == 1
    # the same places in one loop decide alike: the kernel keeps either
    args = _one_arc([[1.0, 0.1, 0], [1.0, -0.1, 0]], np.array([1, 1]))
    got, status = bridge_kernels.arc_landings(*args)
    assert status == 0 and got[0] == 1


def test_an_operand_that_is_not_finite_is_left_to_numpy():
    args = list(_one_arc([[1.0, 0, 0]], np.array([1])))
    args[3] = np.array([np.nan])
    assert bridge_kernels.arc_landings(*args)[1] == 2


@pytest.mark.parametrize("seed", range(4))
def test_kd_tree_splits_every_node_between_its_children(seed):
    # every point of a left child is at most the split along the node's
    # axis and every point of a right child at least it (duplicates too):
    # the query's box bounds rest on this
    rng = np.random.default_rng(seed)
    P = np.round(rng.random((500, 3)) * 6) / 6                     # many equal coordinates
    order, lo, hi, axis, split, left = bridge_kernels.kd_build(P)
    assert np.array_equal(np.sort(order), np.arange(len(P)))
    for b in np.flatnonzero(axis >= 0):
        a = axis[b]
        L, R = left[b], left[b] + 1
        assert lo[L] == lo[b] and hi[L] == lo[R] and hi[R] == hi[b]
        assert P[order[lo[L]:hi[L]], a].max() <= split[b] <= P[order[lo[R]:hi[R]], a].min()
    assert (hi - lo)[axis < 0].max() <= bridge_kernels.KD_LEAF
