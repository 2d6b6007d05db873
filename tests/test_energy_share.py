"""Per-hole work shared or batched without changing a bit.

The oracles are the per-call functions the shared / batched code replaced:
:func:`shellrepair.fill.fair.thin_plate_energy` and
:func:`shellrepair.fill.fair.curvature_variation_energy` (one intrinsic
Laplacian each) for :func:`shellrepair.fill.fair.patch_energies`; the step by
step walk :func:`shellrepair.fill.tube.zip_rings_reference` for the merged
:func:`shellrepair.fill.tube.zip_rings`; one :func:`shellrepair.fill.tube.lerp_loop`
per array for :func:`shellrepair.fill.tube.lerp_arcs`; NumPy's ``mean`` and
``linalg.norm`` for :func:`shellrepair.holes.loops.loop_stats`; a walk over the
triangles for :func:`shellrepair.fill.merge.scan_edges`; NumPy's ``min`` /
``max`` reductions for :func:`shellrepair.mesh.geometry.bounds` and
:func:`shellrepair.mesh.geometry.triangle_boxes`; the NumPy gathering
``_faces_of_numpy`` for the compiled ``ScanContext.faces_of``.
"""

import types
import warnings

import numpy as np
import pytest

from eval import shapes
from shellrepair import compiled
from shellrepair.mesh import index as context
from shellrepair.fill import fair
from shellrepair.fill import tube
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext
from shellrepair.mesh.topology import edge_topology
from shellrepair.mesh.geometry import bounds, triangle_boxes
from shellrepair.holes.loops import loop_stats
from shellrepair.fill.merge import scan_edges


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
    real = fair.cotan_operators
    monkeypatch.setattr(fair, "cotan_operators", lambda X, F: calls.append(1) or real(X, F))
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


def _params(kind, k, rng):
    """Ring parameters as guide_tube / resample_tube pass them: arc
    lengths of a random loop, even ``arange(k) / k`` (ties between rings of
    related counts), coarsely rounded (ties inside a ring), or unsorted
    (the step-by-step fallback)."""
    if kind == "arclength":
        return tube.loop_parameters(rng.normal(size=(k, 3)))
    if kind == "even":
        return np.arange(k) / k
    if kind == "rounded":
        t = np.sort(np.round(rng.random(k), 1))
        t[0] = 0.0
        return t
    t = rng.random(k)
    t[0] = 0.0
    return t


@pytest.mark.parametrize("kind", ["arclength", "even", "rounded", "unsorted"])
def test_merged_zip_equals_the_step_by_step_walk(kind):
    rng = np.random.default_rng(["arclength", "even", "rounded", "unsorted"].index(kind))
    for _ in range(300):
        ka, kc = (int(x) for x in rng.integers(3, 40, 2))
        ta, tc = _params(kind, ka, rng), _params(kind, kc, rng)
        ia, ic = np.arange(ka) + 7, rng.permutation(kc) + 100
        got, want = tube.zip_rings(ta, tc, ia, ic), tube.zip_rings_reference(ta, tc, ia, ic)
        assert got.dtype == want.dtype == np.int64
        assert np.array_equal(got, want)


def test_zip_of_a_last_parameter_past_one_walks_step_by_step():
    """Round-off can put a loop's last arc-length parameter a hair past 1
    (the appended end): the parameters then do not run upwards, and the
    triangles are still the walk's."""
    ta = np.array([0.0, 0.4, np.nextafter(1.0, 2.0)])
    tc = np.array([0.0, 0.5, 0.999])
    ia, ic = np.arange(3), np.arange(3) + 3
    assert np.array_equal(tube.zip_rings(ta, tc, ia, ic), tube.zip_rings_reference(ta, tc, ia, ic))
    assert len(tube.zip_rings(ta, tc, ia, ic)) == 6


@pytest.mark.parametrize("seed", range(4))
def test_interpolating_arcs_together_equals_one_array_at_a_time(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 50))
    t = tube.loop_parameters(rng.normal(size=(k, 3)))
    arcs = (rng.normal(size=(k, 3)), rng.normal(size=(k, 3)), rng.normal(size=(k, 3)),
            rng.normal(size=k), rng.random(k), 1e6 * rng.random(k))
    for m in (3, k, 2 * k + 1):
        u = np.arange(m) / m
        got = tube.lerp_arcs(t, arcs, u)
        for g, a in zip(got, arcs):
            want = tube.lerp_loop(t, a, u)
            assert g.shape == want.shape
            assert g.tobytes() == np.ascontiguousarray(want).tobytes()


@pytest.mark.parametrize("offset", [0.0, 1e6])
def test_loop_stats_equal_numpys_mean_and_norms_to_the_bit(offset):
    """Centre, edge lengths and vector area by NumPy's own functions (what
    loop_stats called before it did their steps itself), at a scan's
    coordinate offsets too."""
    rng = np.random.default_rng(int(offset))
    V = rng.normal(scale=3.0, size=(400, 3)) + offset
    for _ in range(200):
        loop = rng.choice(len(V), size=int(rng.integers(3, 60)), replace=False)
        st = loop_stats(V, loop)
        P = V[loop]
        c = P.mean(axis=0)
        Q = P - c
        Qn = np.roll(Q, -1, axis=0)
        perimeter = float(np.linalg.norm(Qn - Q, axis=1).sum())
        area = float(np.linalg.norm(0.5 * np.cross(Q, Qn).sum(axis=0)))
        assert st["center"].tobytes() == c.tobytes()
        assert st["perimeter"] == perimeter and st["mean_edge"] == perimeter / len(loop)
        assert st["area"] == area


def _scan_edges_by_walk(loop, T):
    """The scan edges a patch makes, edge slot by edge slot over its triangles."""
    k, out = len(loop), []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        for t in T.tolist():
            if t[a] < k and t[b] < k:
                x, y = int(loop[t[a]]), int(loop[t[b]])
                out.append((min(x, y), max(x, y)))
    return out


@pytest.mark.slow
def test_scan_edges_list_the_triangles_edges_slot_by_slot():
    rng = np.random.default_rng(3)
    for i in range(500):
        k, q = int(rng.integers(3, 30)), int(rng.integers(0, 20))
        T = rng.integers(0, k + q, size=(0 if i % 50 == 0 else int(rng.integers(1, 60)), 3)).astype(np.int64)
        patch = types.SimpleNamespace(loop=rng.permutation(10 ** 6)[:k].astype(np.int64), T=T)
        got = scan_edges(patch)
        assert got == _scan_edges_by_walk(patch.loop, T)
        assert all(type(v) is int for e in got for v in e)   # hashable like the accepted edges' set


@pytest.mark.parametrize("t", [1, 7, 3000])
def test_bounds_and_triangle_boxes_equal_numpys_reductions(t):
    """The same values as NumPy's min / max over the corners (at scan
    offsets, with repeated values); a NaN corner gives NaN, as there."""
    rng = np.random.default_rng(t)
    C = np.round(rng.normal(size=(t, 3, 3)), 2) + 1e6
    P = C.reshape(-1, 3)
    lo, hi = bounds(P)
    assert lo.tobytes() == P.min(axis=0).tobytes() and hi.tobytes() == P.max(axis=0).tobytes()
    blo, bhi = triangle_boxes(C)
    assert blo.tobytes() == C.min(axis=1).tobytes() and bhi.tobytes() == C.max(axis=1).tobytes()
    C[0, 1, 2] = np.nan
    assert np.isnan(bounds(C.reshape(-1, 3))[0][2]) and np.isnan(bounds(C.reshape(-1, 3))[1][2])
    assert np.isnan(triangle_boxes(C)[0][0, 2]) and np.isnan(triangle_boxes(C)[1][0, 2])
    assert np.array_equal(np.isnan(triangle_boxes(C)[0]), np.isnan(C.min(axis=1)))


@pytest.mark.skipif(not compiled.ENABLED, reason="the compiled ring walk needs the kernels")
def test_faces_of_by_the_ring_walk_equal_the_numpy_lists(monkeypatch):
    """The faces at a set of vertices (repeated ones too), from the local
    region's lists and then from the whole mesh's: the NumPy gathering's
    faces, and the scratch marks are left clear."""
    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    V, F = shapes.bumpy_sphere(5, amplitude=0.03, frequency=5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.12, seed=1)
    ctx = ScanContext(Mesh(V=V2, F=F2), topo=edge_topology(F2, len(V2)))
    loops = np.unique(ctx.topo.ends(ctx.topo.boundary_he))
    rng = np.random.default_rng(0)
    sets = [loops, loops[:1], loops[:0], np.concatenate([loops[:9], loops[3:7]]), rng.permutation(loops)[:20]]
    for verts in sets:
        got = ctx.faces_of(verts)
        assert got.dtype == np.int64 and np.array_equal(got, ctx._faces_of_numpy(verts))
    assert ctx._vf is None                                  # all from the region
    far = np.flatnonzero(~ctx.region().covered)[:5]
    for verts in (far, np.concatenate([far, loops[:4], far])):
        assert np.array_equal(ctx.faces_of(verts), ctx._faces_of_numpy(verts))
        assert np.array_equal(ctx.faces_of(verts), np.flatnonzero(np.isin(F2, verts).any(axis=1)))
    assert ctx._vf is not None
    assert not ctx._vmark.any() and not ctx._fmark.any()
