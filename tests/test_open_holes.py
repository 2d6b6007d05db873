"""A hole none of whose triangulations passes its checks is still closed.

The fill tries the faired patch on the first triangulation, then re-routes
chords until a flat triangulation crosses nothing, and builds the harmonic
patch (its last option) on that one. On two openings of unseen scans (the
1698-edge loop of stress case s9001-07: its budget ran out after two
re-routing rounds; the 223-edge refill of s97531-13: twelve rounds all
crossed) no triangulation passed, so the harmonic patch was never built,
the faired patch could not be mended, and the loop stayed open; the
harmonic patch on the first triangulation crossed the scan in a few places
only, which the last layer mends. Now it is built there.

The mesh: a closed lens whose top is the trough z = x², an elliptic
opening (semi-axes a = 1.8 along the trough, b = 1) in the top, and a
pebble (a flat closed ellipsoid) sunk into the trough inside the opening.
The trough is biharmonic, so the faired patch follows it through the
pebble, and so does the flat triangulation (its chords run across the
opening, along the trough's level lines); the harmonic patch, a² b² /
(a² + b²) ≈ 0.76 above the trough at the centre, passes over the pebble.
A budget spent after the first round (a loop whose re-routing rounds
outlast it) stands in for the large loop.
"""

import numpy as np
import pytest

import shellrepair.fill.checks as checks
from shellrepair import Mesh
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import edge_topology
from eval import shapes
from eval.stress import triangle_pairs_added


#: The opening's semi-axes along the trough (x) and across it (y).
A, B = 1.8, 1.0
#: The pebble: a flat ellipsoid sunk halfway into the trough's bottom, its
#: top at z = 0.15, below the harmonic patch over its footprint (at least
#: 0.76 - 0.76 * 0.75² = 0.33). The trough runs through it, so the faired
#: patch crosses its surface along a closed curve round a region it lies
#: in, too wide for the last layer (``mend.MEND_MAX_LOOP``) to mend.
PEBBLE_AXES = np.array([1.4, 0.75, 0.15])
PEBBLE_CENTRE = np.array([0.03, 0.02, 0.0])


def _lens_with_a_pebble(n=101):
    """A closed lens over [-2, 2]² (top z = x², bottom below it, sharing
    the rim), its top's faces inside the ellipse of semi-axes ``A`` (x)
    and ``B`` (y) removed, and a closed flat ellipsoid (``PEBBLE_AXES``
    at ``PEBBLE_CENTRE``) inside the opening."""
    t = np.linspace(-2.0, 2.0, n)
    X, Y = np.meshgrid(t, t, indexing="ij")
    top = np.column_stack([X.ravel(), Y.ravel(), X.ravel() ** 2])
    w = (4 - X.ravel() ** 2) * (4 - Y.ravel() ** 2) / 16
    bottom = top - np.column_stack([0 * w, 0 * w, w])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    Ft = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    rim = np.zeros(n * n, bool)
    rim[idx[[0, -1], :].ravel()] = True
    rim[idx[:, [0, -1]].ravel()] = True
    # the bottom: its own copies of the inner vertices, the rim shared with the top
    bid = np.where(rim, np.arange(n * n), n * n + np.arange(n * n))
    Ft = Ft[~rim[Ft].all(axis=1)]      # a corner's face on rim vertices only would be both sheets' face
    Fb = bid[Ft[:, [0, 2, 1]]]
    cen = top[Ft].mean(axis=1)
    Ft = Ft[(cen[:, 0] / A) ** 2 + (cen[:, 1] / B) ** 2 >= 1.0]
    V = np.vstack([top, bottom])
    F = np.vstack([Ft, Fb])
    used = np.unique(F)
    remap = np.full(len(V), -1, np.int64)
    remap[used] = np.arange(used.size)
    V, F = V[used], remap[F]
    Vs, Fs = shapes.icosphere(3)
    Vs = PEBBLE_AXES * Vs / np.linalg.norm(Vs, axis=1, keepdims=True) + PEBBLE_CENTRE
    return np.vstack([V, Vs]), np.vstack([F, Fs + len(V)]).astype(np.int64)


@pytest.fixture
def spent_budget(monkeypatch):
    """No faired attempt after the first fits (the work budget is spent by then)."""
    monkeypatch.setattr(checks, "HOLE_VERTICES", 0)
    monkeypatch.setattr(checks, "HOLE_VERTICES_PER_EDGE", 0)


def test_a_hole_with_no_passing_triangulation_gets_its_harmonic_patch(spent_budget):
    V, F = _lens_with_a_pebble()
    before = edge_topology(F, len(V))
    assert before.n_boundary_edges > 0 and len(before.nonmanifold_edges) == 0
    repaired, report = repair_mesh(Mesh(V=V.copy(), F=F.copy()), order=2)
    (row,) = report["holes"]
    assert row["status"] == "filled", row["reason"]
    assert row["option"].startswith("harmonic (order 1)")
    # watertight and manifold, originals bit-identical and first, faces kept
    topo = edge_topology(repaired.F, len(repaired.V))
    assert topo.n_boundary_edges == 0 and len(topo.nonmanifold_edges) == 0
    assert np.array_equal(repaired.V[:len(V)], V) and np.array_equal(repaired.F[:len(F)], F)
    # no added face crosses the scan (the pebble included) or another added face
    added = np.arange(len(F), len(repaired.F))
    assert triangle_pairs_added(repaired.V, repaired.F, added) == 0
    # it passes over the pebble: the new vertices over its footprint are above its top
    P = repaired.V[len(V):]
    over = (((P[:, :2] - PEBBLE_CENTRE[:2]) / PEBBLE_AXES[:2]) ** 2).sum(axis=1) < 1
    assert over.any() and (P[over, 2] > PEBBLE_CENTRE[2] + PEBBLE_AXES[2]).all()


def test_the_first_attempts_cross_the_pebble():
    """The faired patch and the flat triangulation of this opening do cross
    (what leaves only the harmonic patch)."""
    from shellrepair.holes.loops import detect_holes
    from shellrepair.mesh.index import ScanContext
    from shellrepair.fill.patch import build_patch

    V, F = _lens_with_a_pebble()
    (hole,) = detect_holes(V, F).holes
    ctx = ScanContext(Mesh(V=V, F=F))
    flat = build_patch(ctx, hole.id, hole.vertices, order=1, refine=False, fair=False)
    faired = build_patch(ctx, hole.id, hole.vertices, order=2, initial=flat.T0)
    assert "cross the scan" in checks.check_patch(ctx, flat)[0]
    assert "cross the scan" in checks.check_patch(ctx, faired)[0]


@pytest.mark.parametrize("lift, crosses", [(0.0, True), (1.5, False)])
@pytest.mark.parametrize("compiled", [True, False])
def test_patches_crossing_each_other_are_found_with_or_without_the_kernels(monkeypatch, lift, crosses, compiled):
    """The merge's check between patches (candidate pairs by boxes with the
    compiled kernels, by spheres without) gives one answer: a vertical
    triangle through a fan, or lifted clear of it."""
    from types import SimpleNamespace

    from shellrepair import compiled
    from shellrepair.fill.merge import Accepted
    from shellrepair.fill.patch import Patch

    if compiled and not compiled.ENABLED:
        pytest.skip("Numba is not installed")
    monkeypatch.setattr(compiled, "ENABLED", compiled)
    # a long thin first patch: a fan over a 10 x 1 rectangle, its centre a new vertex
    V = np.array([[0, 0, 0], [10, 0, 0], [10, 1, 0], [0, 1, 0],
                  [5, 0.5, -1 + lift], [5.2, 0.5, 1 + lift], [4.8, 0.5, 1 + lift]], float)
    ctx = SimpleNamespace(V=V)
    fan = Patch(hole_id=0, loop=np.arange(4), P=np.array([[5.0, 0.5, 0.0]]),
                T=np.array([[1, 0, 4], [2, 1, 4], [3, 2, 4], [0, 3, 4]]))
    spike = Patch(hole_id=1, loop=np.array([4, 5, 6]), P=np.zeros((0, 3)), T=np.array([[0, 2, 1]]))
    acc = Accepted()
    assert acc.place(ctx, fan)[0] is fan
    placed, why, _ = acc.place(ctx, spike)
    assert (placed is None) == crosses
    assert (why == "patch would cross the patch of hole 0") == crosses
