"""The order test: each hole's fairing order chosen by test holes of its size (shellrepair.fill.selftest, .probe)."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from eval import shapes
from shellrepair import Mesh, detect_holes, read_mesh
from shellrepair.fill import placement, probe
from shellrepair.fill import selftest
from shellrepair.fill.hole import fill_hole_at_order
from shellrepair.mesh.index import ScanContext
from shellrepair.fill.patch import build_patch
from shellrepair.fill.probe import MIN_PROBES, PROBES, Pooled, hole_radius, probe_errors
from shellrepair.repair import repair_mesh
from shellrepair.mesh.distance import point_mesh_distance
from shellrepair.fill.selftest import CANDIDATES, DEFAULT_ORDER, MIN_EDGES, OrderTest, choose_order

from conftest import auto_and_forced_rms, shared_scan


def context(V, F):
    scan = detect_holes(V, F)
    ctx = ScanContext(Mesh(V=V, F=F))
    ctx.know_loops(scan.loops)
    return scan, ctx


def sphere_with_hole(subdivisions=4, radius=0.5):
    V, F = shapes.icosphere(subdivisions)
    top = int(np.argmax(V[:, 2]))
    V2, F2, removed, _ = shapes.perforate_discs(V, F, centers=[top], radius=radius)
    return V2, F2


def true_rms(patch, truth):
    """RMS distance of a patch's new vertices to the surface that was cut away (densely sampled)."""
    return float(np.sqrt(np.mean(truth.query(patch.P)[0] ** 2)))


def forced_and_auto(V, F, centers, radius):
    """Each hole's true error filled at every candidate order and at the order the test chose."""
    V2, F2, removed, _ = shapes.perforate_discs(V, F, centers=list(centers), radius=radius)
    scan, ctx = context(V2, F2)
    S = shapes._subdivide(*shapes._subdivide(V, F[removed]))   # the removed surface, sampled finer
    truth = cKDTree(S[0])
    rows = []
    for h in scan.holes:
        t = choose_order(ctx, h.id, h.vertices)
        p1, *_ = fill_hole_at_order(ctx, h.id, h.vertices, 1, 0)
        p2, *_ = fill_hole_at_order(ctx, h.id, h.vertices, 2, 0)
        p3 = build_patch(ctx, h.id, h.vertices, order=3, initial=p2.T0)
        rows.append((t, {o: true_rms(p, truth) for o, p in ((1, p1), (2, p2), (3, p3))}))
    return rows


def test_point_mesh_distance_is_exact_over_a_square_and_past_its_corner():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    Q = np.array([[0.3, 0.6, 0.25], [0.9, 0.1, -2.0], [2.0, 2.0, 0.0], [-1.0, 0.5, 1.0]])
    d = point_mesh_distance(Q, V, F)
    assert np.allclose(d, [0.25, 2.0, np.sqrt(2.0), np.sqrt(2.0)], atol=1e-12)


def test_a_holes_radius_is_the_disc_of_its_area():
    V, F = shapes.grid(40, 40, size=2.0)
    c = int(np.argmin(np.linalg.norm(V[:, :2] - 1.0, axis=1)))
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[c], radius=0.5)
    h = detect_holes(V2, F2).holes[0]
    # the rim runs along the grid's edges about the disc of geodesic radius
    # 0.5 (measured along edges: a little inside the round disc)
    assert 0.42 < hole_radius(V2, h.vertices) < 0.5 + 2.0 / 40


def test_test_holes_of_the_holes_size_fit_beside_a_hole_on_a_sphere():
    """They fit at the hole's own size; on a sphere every test hole ranks
    the same order first, so the test stops at two of its three
    (:meth:`Pooled.settled`)."""
    V, F = sphere_with_hole(radius=0.5)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    errors, n, scale = probe_errors(ctx, h.vertices, CANDIDATES)
    assert n == 2 < PROBES and scale == 1.0 and set(errors) == set(CANDIDATES)
    assert all(np.isfinite(e) and e > 0 for e in errors.values())


def test_a_smooth_sphere_asks_for_order_3_and_order_3_is_truly_better_there():
    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    test = choose_order(ctx, h.id, h.vertices)
    assert test.order == 3 and test.errors[3] < test.errors[2] < test.errors[1]
    p2 = build_patch(ctx, h.id, h.vertices, order=2)
    p3 = build_patch(ctx, h.id, h.vertices, order=3, initial=p2.T0)
    err = lambda p: np.sqrt(np.mean((np.linalg.norm(p.P, axis=1) - 1.0) ** 2))
    assert err(p3) < err(p2)
    assert "runner-up order 2" in test.describe()


def test_on_bumpy_relief_the_chosen_order_is_as_true_as_the_best_one():
    # large holes in a relief of bumps: the test's choice is, hole by hole,
    # within 10 % of the best candidate's true error (its regret)
    V, F = shapes.bumpy_sphere(5, amplitude=0.04, frequency=5)
    top, bottom = int(np.argmax(V[:, 2])), int(np.argmin(V[:, 2]))
    side = int(np.argmax(V[:, 0]))
    rows = forced_and_auto(V, F, centers=[top, bottom, side], radius=0.35)
    assert len(rows) == 3
    for t, err in rows:
        assert t.errors and t.scale > 0
        assert err[t.order] <= 1.1 * min(err.values()), (t.describe(), err)


def test_holes_too_small_to_test_keep_the_default_order():
    V, F = shapes.icosphere(4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[0], radius=0.02)
    scan, ctx = context(V2, F2)
    h = scan.holes[0]
    assert h.edges < MIN_EDGES
    t = choose_order(ctx, h.id, h.vertices)
    assert t.order == DEFAULT_ORDER and not t.errors and "not tested" in t.describe()


def test_where_no_intact_scan_of_the_holes_size_is_left_the_scan_cannot_tell():
    # a sphere with most of it cut away: no test hole of the hole's size,
    # nor of half or a quarter of it, fits in what is left
    V, F = shapes.icosphere(4)
    top = int(np.argmax(V[:, 2]))
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[top], radius=2.9)
    scan, ctx = context(V2, F2)
    h = max(scan.loops, key=lambda L: L.edges)     # (a cap this small reads as the scan's border)
    assert h.edges >= MIN_EDGES
    t = choose_order(ctx, h.id, h.vertices)
    assert t.order == DEFAULT_ORDER and not t.errors and "cannot tell" in t.describe()


def test_the_test_is_the_same_on_a_fresh_context_to_the_bit():
    V, F = shapes.bumpy_sphere(4, amplitude=0.03, frequency=4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.3, seed=2)
    got = []
    for _ in range(2):
        scan, ctx = context(V2, F2)
        got.append([choose_order(ctx, h.id, h.vertices) for h in scan.holes])
    assert got[0] == got[1] and any(t.errors for t in got[0])


@pytest.mark.parametrize("seed", [2, 5])
def test_the_test_is_the_same_whether_placements_sort_their_own_edges_or_the_near_scans(monkeypatch, seed):
    # the near scan's edges sorted once (placement._NearEdges) or each placement's
    # region sorted on its own: a cost, never a different test hole
    V, F = shapes.bumpy_sphere(4, amplitude=0.03, frequency=4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=4, radius=0.25, seed=seed)
    got = []
    for after in (0.0, float("inf")):
        monkeypatch.setattr(placement, "EDGES_AFTER", after)
        scan, ctx = context(V2, F2)
        got.append([choose_order(ctx, h.id, h.vertices) for h in scan.holes])
    assert got[0] == got[1] and any(t.errors for t in got[0])


@pytest.mark.parametrize("seed", [2, 5])
def test_the_test_is_the_same_whether_placements_are_walked_compiled_or_by_numpy_steps(monkeypatch, seed):
    # the compiled walk of a placement's region (probe_kernels.placement)
    # against the centroid tree, edge sort and labelling it replaces: the
    # same test holes, the same errors to the bit
    from shellrepair import compiled

    if not compiled.ENABLED:
        pytest.skip("the kernels are off")
    V, F = shapes.bumpy_sphere(4, amplitude=0.03, frequency=4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=4, radius=0.25, seed=seed)
    got = []
    for on in (True, False):
        monkeypatch.setattr(placement, "COMPILED_WALK", on)
        scan, ctx = context(V2, F2)
        got.append([choose_order(ctx, h.id, h.vertices) for h in scan.holes])
    assert got[0] == got[1] and any(t.errors for t in got[0])


def test_a_near_scan_that_is_not_a_plain_surface_is_left_to_the_numpy_steps():
    from shellrepair import compiled
    from shellrepair.fill import probe_kernels

    if not compiled.ENABLED:
        pytest.skip("the kernels are off")
    fan = np.array([[0, 1, 2], [1, 0, 3]], np.int64)
    start, pos, across, ok = probe_kernels.near_adjacency(fan, 4)
    assert ok and across.tolist() == [[1, 2, 2], [0, 2, 2]]
    assert pos[start[0]:start[1]].tolist() == [0, 1]
    fin = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]], np.int64)      # an edge of three faces
    assert not probe_kernels.near_adjacency(fin, 5)[3]
    assert not probe_kernels.near_adjacency(np.array([[0, 0, 1]], np.int64), 2)[3]    # a degenerate face


@pytest.mark.parametrize("seed", [2, 5])
def test_placements_walked_all_at_once_end_as_each_walked_alone(seed):
    # probe_kernels.placement_statuses walks many placements over one scratch
    # (reset after each): each status is the one placement gives alone
    from shellrepair import compiled
    from shellrepair.fill import probe_kernels

    if not compiled.ENABLED:
        pytest.skip("the kernels are off")
    V, F = shapes.bumpy_sphere(4, amplitude=0.03, frequency=4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=6, radius=0.25, seed=seed)
    corners = np.ascontiguousarray(F2, np.int64)
    verts = np.unique(corners)
    start, pos, across, ok = probe_kernels.near_adjacency(np.searchsorted(verts, corners), len(verts))
    assert ok
    pids = verts[::7]
    lps = np.searchsorted(verts, pids)
    seen = set()
    for R, limit in ((0.3, 0.25), (0.15, 0.1), (1e-9, 0.0)):
        alone = [probe_kernels.placement(V2, corners, across, start, pos, lp, V2[v], R, limit)[0]
                 for lp, v in zip(lps, pids)]
        together = probe_kernels.placement_statuses(V2, corners, across, start, pos, lps, pids, R, limit)
        assert together.tolist() == alone
        seen |= set(alone)
    assert seen == {0, 1, 2}      # regions, walks ended at an open edge, vertices with no face within reach


@pytest.mark.parametrize("seed", [0, 1])
def test_the_compiled_reach_filter_keeps_what_numpy_keeps(seed):
    # the rim distance's vertices within bound, compiled: the same ones to the bit,
    # also for vertices exactly at the reach and at a large offset
    from shellrepair import compiled
    from shellrepair.fill import probe_kernels

    if not compiled.ENABLED:
        pytest.skip("the kernels are off")
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(400, 3)) + 1e6 * seed
    c = V[3].copy()
    d = np.sqrt(((V - c) ** 2).sum(axis=1))
    for reach in (0.5, float(d[10]), float(np.median(d)), 0.0):
        verts = np.sort(rng.choice(400, 250, replace=False))
        want = np.flatnonzero(np.sqrt(((V[verts] - c) ** 2).sum(axis=1)) <= reach)
        assert np.array_equal(probe_kernels.within_distance(V, verts, c, reach), want)


def test_ties_go_to_the_default_order_then_the_lower():
    t = OrderTest(2, errors={1: 1.0, 2: 1.0, 3: 1.0}, probes=3, scale=1.0)
    assert t.runner_up == 1
    assert "order 1 1, order 2 1, order 3 1" in t.describe()


def test_the_coarse_test_picks_order_3_on_the_sphere_as_the_full_one_does(monkeypatch):
    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    full = choose_order(ctx, h.id, h.vertices)
    monkeypatch.setattr(probe, "TEST_MAX_UNKNOWNS", 0)     # every test hole refined coarse
    coarse = choose_order(ctx, h.id, h.vertices)
    assert full.order == coarse.order == 3 and coarse.errors != full.errors


def test_auto_is_the_default_order_and_the_report_gives_its_evidence():
    from shellrepair.options import RepairOptions

    assert RepairOptions().order == "auto"
    V, F = sphere_with_hole(radius=0.6)
    _, rep = repair_mesh(Mesh(V=V, F=F))
    opt = rep["holes"][0]["option"]
    assert rep["holes_after"] == 0 and "auto: order 3, by 2 test holes of its size" in opt and "runner-up" in opt


def test_the_report_row_holds_the_choice_its_runner_up_and_the_test_errors():
    V, F = sphere_with_hole(radius=0.6)
    _, rep = repair_mesh(Mesh(V=V, F=F))
    choice = rep["holes"][0]["choice"]
    errs = choice["test_rms"]
    assert set(errs) == {str(o) for o in CANDIDATES} and choice["by"] == "test holes" and not choice["untold"]
    # the chosen order has the lowest test error, the runner-up the next
    ranked = sorted(errs, key=errs.get)
    assert [str(choice["order"]), str(choice["runner_up"])] == ranked[:2]
    assert choice["probes"] >= 1 and choice["scale"] in (1.0, 0.5, 0.25)
    assert f"faired order {choice['order']}" in rep["holes"][0]["option"]
    # a forced order is no choice: the row has none
    _, forced = repair_mesh(Mesh(V=V, F=F), order=2)
    assert "choice" not in forced["holes"][0]


def test_order_3_on_the_order_2_refinement_equals_refining_again():
    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    p2 = build_patch(ctx, h.id, h.vertices, order=2)
    again = build_patch(ctx, h.id, h.vertices, order=3, initial=p2.T0)
    reused = build_patch(ctx, h.id, h.vertices, order=3, initial=(p2.P, p2.T), refine=False)
    assert np.array_equal(again.T, reused.T) and np.array_equal(again.P, reused.P)


@pytest.mark.slow
def test_on_a_sculpted_bust_auto_is_within_5_percent_of_the_best_single_order():
    # 9 disc holes over the Nefertiti bust's relief, summed squared error
    # against the removed scan: the test's choices against each order forced
    m = read_mesh(shared_scan("closed_nefertiti_bust.ply"))
    V, F = np.asarray(m.V, float), np.asarray(m.F, np.int64)
    diag = float(np.linalg.norm(np.ptp(V, axis=0)))
    sq = {1: 0.0, 2: 0.0, 3: 0.0, "auto": 0.0}
    for seed in (5, 6, 7):
        centers = np.random.default_rng(seed).choice(len(V), 3, replace=False)
        for t, err in forced_and_auto(V, F, centers, 0.04 * diag):
            for o in (1, 2, 3):
                sq[o] += err[o] ** 2
            sq["auto"] += err[t.order] ** 2
    assert sq["auto"] <= 1.05 * min(sq[1], sq[2], sq[3]), sq


def test_a_rims_noise_is_the_noise_it_was_given_and_not_the_surfaces_curvature():
    from shellrepair.fill.roughness import add_noise, rim_noise

    V, F = sphere_with_hole(radius=0.5)
    rim = detect_holes(V, F).loops[0].vertices
    h = float(np.mean(np.linalg.norm(V[rim] - V[np.roll(rim, -1)], axis=1)))
    # a clean rim: its umbrella offsets are the curvature term, about h²/2
    # on the unit sphere; its noise is a fraction of that (what is left is
    # the jagged rim's own: vertices of two faces beside those of three)
    assert rim_noise(V, F, rim) < 0.15 * h * h
    for sigma in (0.002, 0.01):
        n = V[rim] / np.linalg.norm(V[rim], axis=1)[:, None]
        V2 = V.copy()
        V2[rim] += sigma * np.random.default_rng(1).standard_normal(len(rim))[:, None] * n
        real = rim_noise(V2, F, rim)
        assert 0.7 * sigma < real < 1.3 * sigma
        # given to a clean rim, the real rim's noise is found there again
        # (another draw of some 60 offsets: within their sampling error)
        V3 = add_noise(V, F, rim, real, seed=0)
        assert 0.7 * real < rim_noise(V3, F, rim) < 1.3 * real
        # a rim as noisy already is left as it is
        assert add_noise(V2, F, rim, 0.5 * sigma, seed=0) is V2


def test_a_clean_rim_on_curved_scan_gives_a_test_rim_on_flatter_scan_no_noise():
    """Two clean rims of one density: on the unit sphere, and on a sphere
    of radius 2 sampled twice as finely (half the curvature). Their
    umbrella offsets differ by the curvature term (about κh²/2: 0.0104
    against 0.0052 here), their noise does not. The rim on the flatter
    sphere, taken for a test hole's, is given a small fraction of the
    curvature term: a difference in curvature is not taken for noise (it
    ranked order 3 after order 2 on discs of a fat torus, where order 3
    is truest)."""
    from shellrepair.fill.roughness import add_noise, rim_noise

    Vc, Fc = sphere_with_hole(subdivisions=3, radius=0.5)
    rc = detect_holes(Vc, Fc).loops[0].vertices
    Vf, Ff = sphere_with_hole(subdivisions=4, radius=0.5)
    Vf = 2.0 * Vf
    rf = detect_holes(Vf, Ff).loops[0].vertices
    hc = float(np.mean(np.linalg.norm(Vc[rc] - Vc[np.roll(rc, -1)], axis=1)))
    hf = float(np.mean(np.linalg.norm(Vf[rf] - Vf[np.roll(rf, -1)], axis=1)))
    assert hf == pytest.approx(hc, rel=0.05)
    given = add_noise(Vf, Ff, rf, rim_noise(Vc, Fc, rc), seed=0)
    moved = float(np.sqrt(np.mean(np.sum((given[rf] - Vf[rf]) ** 2, axis=1))))
    assert moved < 0.1 * hc * hc / 2.0


def test_a_test_rim_is_given_noise_only_where_the_real_rim_is_clearly_the_noisier():
    """Two clean rims' noise differs by their grids' jags, within its
    sampling error: counted, that difference is not given (it would weigh
    against order 3 where order 3 is truest). A ragged real rim, ten times
    noisier, still gives its noise, as without the count."""
    from shellrepair.fill.roughness import add_noise, rim_noise

    V, F = sphere_with_hole(radius=0.5)
    rim = detect_holes(V, F).loops[0].vertices
    clean = rim_noise(V, F, rim)
    assert add_noise(V, F, rim, 1.2 * clean, seed=0, count=len(rim)) is V          # within the error: nothing
    assert add_noise(V, F, rim, 1.2 * clean, seed=0) is not V                      # uncounted: the excess
    n = V[rim] / np.linalg.norm(V[rim], axis=1)[:, None]
    ragged = V.copy()
    ragged[rim] += 10 * clean * np.random.default_rng(2).standard_normal(len(rim))[:, None] * n
    real = rim_noise(ragged, F, rim)
    given = add_noise(V, F, rim, real, seed=0, count=len(rim))
    assert np.array_equal(given, add_noise(V, F, rim, real, seed=0))
    assert 0.7 * real < rim_noise(given, F, rim) < 1.3 * real


def test_a_hole_whose_patch_has_no_vertex_of_its_own_is_not_tested(monkeypatch):
    """A patch with no new vertex is the same at every order (nothing to
    fair): the candidates agree, so no test hole is cut for it, and the
    fill is the forced order's, to the bit (a scanner occlusion of a star
    shape: three of its nine holes have 8 or more rim edges and no new
    vertex)."""
    from eval import stress

    case = stress.stress_case(1, 7, quick=True, family="scanner")
    tested = []
    real = selftest.choose_order
    monkeypatch.setattr(selftest, "choose_order", lambda ctx, hole_id, *a, **k: tested.append(hole_id)
                        or real(ctx, hole_id, *a, **k))
    R, rep = repair_mesh(Mesh(V=case.V, F=case.F))
    bare = [h for h in rep["holes"] if h["edges"] >= MIN_EDGES and h["new_vertices"] == 0]
    assert len(bare) >= 2
    for h in bare:
        assert h["id"] not in tested and h["choice"]["untold"] and "no new vertex" in h["choice"]["why"]
    assert tested, "the other holes are still tested"
    R2, _ = repair_mesh(Mesh(V=case.V, F=case.F), order_for={h["id"]: 2 for h in bare})
    assert np.array_equal(R.F, R2.F) and np.array_equal(R.V.view(np.uint64), R2.V.view(np.uint64))



@pytest.mark.slow
def test_one_test_hole_is_not_enough_evidence_the_next_scale_with_two_decides(monkeypatch):
    """A fat torus seen from a ring of views (eval's stress case 0 of seed
    409305035): beside its 467-edge hole only one disc of the hole's area
    fits, and it ranks order 2 first; the three of half the size rank
    order 3 first, as the truth does. (Discs as wide as the hole across its
    narrow axis, tried first, fit three times at full size and rank order 3
    first as well; they are set aside for the rest.)"""
    from eval import stress

    case = stress.stress_case(0, 409305035)
    scan, ctx = context(case.V, case.F)
    big = max(scan.holes, key=lambda L: hole_radius(case.V, L.vertices))
    assert big.edges == 467
    errors, n, scale = probe_errors(ctx, big.vertices, CANDIDATES)
    assert MIN_PROBES <= n <= PROBES and scale == 1.0 and min(errors, key=errors.get) == 3
    monkeypatch.setattr(probe, "outline_narrow_axis", lambda poly: np.inf)     # the disc of its area only
    monkeypatch.setattr(probe, "MIN_PROBES", 1)
    errors, n, scale = probe_errors(ctx, big.vertices, CANDIDATES)
    assert (n, scale) == (1, 1.0) and min(errors, key=errors.get) == 2
    monkeypatch.setattr(probe, "MIN_PROBES", 2)
    errors, n, scale = probe_errors(ctx, big.vertices, CANDIDATES)
    assert n >= 2 and scale == 0.5 and min(errors, key=errors.get) == 3
    facts = stress.input_facts(case)
    rms = {}
    for o in (2, 3):
        R, _ = repair_mesh(Mesh(V=case.V, F=case.F), order=2, order_for={big.id: o})
        rms[o] = stress.measure(case, facts, R.V, R.F)["rms_permille"]
    assert rms[3] < 0.5 * rms[2], rms


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_even_odd_test_answers_as_numpy(seed):
    # random outlines (with horizontal edges and repeated corners) and points
    # on their corners, on their edges' heights and at random
    from shellrepair import compiled
    from shellrepair.fill import probe_kernels

    if not compiled.ENABLED:
        pytest.skip("the kernels are off")
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * np.pi, 40))
    poly = np.column_stack([np.cos(t), np.sin(t)]) * rng.uniform(0.5, 1.5, (40, 1))
    poly[5, 1] = poly[4, 1]              # a horizontal edge
    poly[9] = poly[8]                    # a repeated corner
    x = np.concatenate([rng.uniform(-2, 2, 500), poly[:, 0], np.full(10, 0.1)])
    y = np.concatenate([rng.uniform(-2, 2, 500), poly[:, 1], np.full(10, poly[4, 1])])
    got = probe_kernels.inside_polygon(x, y, poly)
    assert np.array_equal(got, placement.inside_polygon_reference(x, y, poly)) and got.any() and not got.all()


def test_the_order_test_keeps_no_scan_alive_after_its_repair():
    # what the test keeps for a scan's other holes (the near faces, their
    # adjacency, the vertex scratch) goes with the scan
    import gc
    import weakref

    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    t = choose_order(ctx, scan.holes[0].id, scan.holes[0].vertices)
    assert t.errors
    gone = weakref.ref(ctx)
    del ctx
    gc.collect()
    assert gone() is None


def _split_open_edges(V, F):
    """Each open edge split at its midpoint, the face on it split in two."""
    F = np.asarray(F, np.int64)
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(E, axis=0, return_counts=True)
    open_edges = {tuple(e) for e in keys[counts == 1]}
    Vl, out = list(np.asarray(V, np.float64)), []
    for f in F.tolist():
        for j in range(3):
            a, b, c = f[j], f[(j + 1) % 3], f[(j + 2) % 3]
            if (min(a, b), max(a, b)) in open_edges:
                Vl.append((Vl[a] + Vl[b]) / 2.0)
                out += [[a, len(Vl) - 1, c], [len(Vl) - 1, b, c]]
                break
        else:
            out.append(f)
    return np.asarray(Vl), np.asarray(out, np.int64)


def test_test_holes_of_the_holes_size_fit_where_its_rim_edges_are_shorter_than_the_scans_faces(monkeypatch):
    # a rim of quarter-length edges between the sphere's own faces (a disc cut
    # across a coarse grid gives such rims): the intact margin a test hole
    # needs is counted in the faces' size, not only in rim edges, or no test
    # hole of the hole's size is found complete anywhere
    V, F = sphere_with_hole(radius=0.5)
    V, F = _split_open_edges(*_split_open_edges(V, F))
    scan, ctx = context(V, F)
    h = scan.holes[0]
    T = V[F[ctx.ring_faces(h.vertices, 1)]]
    longest = np.linalg.norm(T - np.roll(T, 1, axis=1), axis=2).max(axis=1).mean()
    assert longest > 3.0 * probe.mean_edge(V, h.vertices)
    errors, n, scale = probe_errors(ctx, h.vertices, CANDIDATES)
    assert MIN_PROBES <= n <= PROBES and scale == 1.0 and errors[3] < errors[2] < errors[1]
    monkeypatch.setattr(probe, "MARGIN_FACES", 0.0)      # the margin in rim edges alone
    assert probe_errors(ctx, h.vertices, CANDIDATES)[2] < 1.0


def test_an_outlines_narrow_axis_is_the_half_width_of_the_ellipse_of_its_moments():
    t = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    circle = np.column_stack([np.cos(t), np.sin(t)])
    assert placement.outline_narrow_axis(2.0 * circle + [5.0, -3.0]) == pytest.approx(2.0, rel=1e-4)
    ellipse = circle * [3.0, 1.0]
    turned = ellipse @ np.array([[0.6, 0.8], [-0.8, 0.6]])
    assert placement.outline_narrow_axis(turned[::-1]) == pytest.approx(1.0, rel=1e-4)     # either turn, any axis
    # a 4 x 1 rectangle: second moment 1/12 across it, half width 2 * sqrt(1/12)
    rect = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.0]])
    assert placement.outline_narrow_axis(rect) == pytest.approx(2.0 * np.sqrt(1.0 / 12.0))


def test_test_holes_with_no_vertex_of_their_own_are_not_evidence(monkeypatch):
    # every test hole refined so coarsely that it gets no vertex of its own:
    # each order fills it with the same flat triangulation, so it says nothing
    # of the order; the scan cannot tell (before, such ties were counted and
    # order 2 was reported as chosen "by 3 test holes")
    V, F = sphere_with_hole(radius=0.5)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    assert probe_errors(ctx, h.vertices, CANDIDATES)[1] >= MIN_PROBES
    monkeypatch.setattr(probe, "TEST_MAX_UNKNOWNS", 0)
    monkeypatch.setattr(probe, "TEST_COARSEN", 1e6)
    assert probe_errors(ctx, h.vertices, CANDIDATES) == ({}, 0, 0.0)
    t = choose_order(ctx, h.id, h.vertices)
    assert t.order == DEFAULT_ORDER and not t.errors and "no vertex of their own" in t.describe()


def test_a_rim_collapsed_to_a_point_gets_no_test_hole_and_no_error():
    # every rim vertex at one position: no radius, no edge length; the test
    # says the scan cannot tell instead of failing
    V, F = sphere_with_hole(radius=0.5)
    h = context(V, F)[0].holes[0]
    V = V.copy()
    V[h.vertices] = V[h.vertices[0]]
    _, ctx = context(V, F)
    assert probe_errors(ctx, h.vertices, CANDIDATES) == ({}, 0, 0.0)
    t = choose_order(ctx, h.id, h.vertices)
    assert t.order == DEFAULT_ORDER and "cannot tell" in t.describe()


@pytest.mark.slow
def test_a_strip_under_a_torus_is_tested_by_a_disc_as_wide_as_the_strip():
    """Case 6 of design seed 12: a torus (tube 0.3) seen from a ring of
    views, a strip about 2.1 x 0.45 unseen under its tube (hole 1). The
    strip's outline fits nowhere beside it; a disc of its area (radius
    0.5) wrapped round the tube in every test hole and ranked order 2
    first, where order 3 is 11x truer on the strip. A disc as wide as the
    strip ranks order 3 first, and the repair is as true as order 3 forced."""
    from eval import stress

    case = stress.stress_case(6, 12)
    if case.name != "s12-06-scanner-torus-0.3":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    scan, ctx = context(case.V, case.F)
    strip = next(h for h in scan.holes if h.id == 1)
    outline = placement.hole_outline(case.V, strip.vertices)[0]
    assert placement.outline_narrow_axis(outline) < 0.5 * hole_radius(case.V, strip.vertices)
    test = choose_order(ctx, strip.id, strip.vertices)
    assert test.order == 3 and test.scale == 1.0 and MIN_PROBES <= test.probes <= PROBES
    auto, forced, _ = auto_and_forced_rms(case, 3)
    assert auto <= 1.05 * forced


@pytest.mark.slow
def test_an_order_3_patch_departing_from_order_2_more_than_order_1_does_is_not_taken():
    """Case 1 of seed 270074373: one disc of 188 rim edges in a Nefertiti.
    Its test holes rated order 3 first, and the order-3 patch bulged 23.9
    from the order-2 one where the order-1 patch lies 8.06 from it: the
    orders do not converge there, order 2 is kept (0.84 per mille from the
    truth, order 3 30.4)."""
    from eval import stress

    case = stress.stress_case(1, 270074373)
    if case.name != "s270074373-01-discs-nefertiti":
        pytest.skip(f"drew {case.name} without ../shared's scans")
    facts = stress.input_facts(case)
    M = Mesh(V=case.V, F=case.F)
    R, rep = repair_mesh(M)
    row = rep["holes"][0]
    assert row["choice"]["order"] == 3 and "order 3 departs from order 2 more than order 1 does" in row["option"]
    auto = stress.measure(case, facts, R.V, R.F)["rms_permille"]
    R2, _ = repair_mesh(M, order=2)
    assert auto == pytest.approx(stress.measure(case, facts, R2.V, R2.F)["rms_permille"], rel=1e-9)


@pytest.mark.parametrize("seed", range(2))
def test_a_test_regions_rim_is_the_vertices_of_its_loops_or_none_where_a_chain_is_left(seed):
    """placement.rim_tails judges a placement's region without walking its
    loops: on face soups (open edges, edges of three faces, pinches, flipped
    faces) and on pieces of a sphere, it is None exactly where the walk
    leaves an open chain, and otherwise the vertices of the walk's loops."""
    from shellrepair.holes.loops import boundary_loops

    rng = np.random.default_rng(seed)
    V, F = shapes.icosphere(3)
    for t in range(600):
        if t % 2:
            n = int(rng.integers(3, 25))
            T = rng.integers(0, n, (int(rng.integers(1, 30)), 3))
            T = T[(T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 0] != T[:, 2])]
        else:
            n, T = len(V), F[rng.random(len(F)) < rng.uniform(0.05, 0.9)]
        if not len(T):
            continue
        loops, chains = boundary_loops(T, n)
        tails = placement.rim_tails(T, n)
        assert (tails is None) == bool(chains)
        if tails is not None:
            on = np.zeros(n, bool)
            for L in loops:
                on[L] = True
            assert np.array_equal(np.flatnonzero(on), np.unique(tails))


def test_a_test_holes_order_3_patch_is_taken_as_the_fill_would_keep_it():
    """Order 3 counts on a test hole as the fill would keep it on a real
    one: where its patch departs from order 2's more than order 1's does,
    order 2's patch stands in its place (hole._departs); elsewhere, and
    where the candidates are not orders 1, 2 and 3, the patches are as
    faired."""
    P2 = np.zeros((4, 3))
    P1 = P2 + [0.0, 0.0, 0.1]
    calm, wild = P2 + [0.0, 0.0, -0.05], P2 + [0.0, 0.0, -0.3]
    got = probe.as_filled((1, 2, 3), [P1, P2, wild])
    assert got[0] is P1 and got[1] is P2 and got[2] is P2
    got = probe.as_filled((1, 2, 3), [P1, P2, calm])
    assert got[2] is calm
    got = probe.as_filled((2, 3), [P2, wild])
    assert got[1] is wild


def test_each_test_hole_weighs_alike_whatever_its_count_of_removed_vertices():
    """The test holes' errors combine by the geometric mean of each one's
    RMS: one test hole on finer scan (4000 removed vertices) where order 3
    lies twice as far as order 2 does not outweigh two (100 vertices each)
    where order 3 is five times truer."""
    pool = probe.Pooled((2, 3))
    for n, e2, e3 in ((4000, 0.005, 0.010), (100, 0.010, 0.002), (100, 0.010, 0.002)):
        assert pool.add(iter([(2, np.full(n, e2)), (3, np.full(n, e3))]))
    got = pool.rms()
    assert got[3] < got[2]
    assert got[2] == pytest.approx((0.005 * 0.010 * 0.010) ** (1 / 3))
    assert got[3] == pytest.approx((0.010 * 0.002 * 0.002) ** (1 / 3))
    assert not pool.add(iter([(2, np.full(3, np.nan)), (3, np.zeros(3))]))     # a test with a non-finite distance is dropped
    assert pool.tests == 3


def test_two_test_holes_that_agree_settle_a_test_of_three_and_two_that_differ_do_not():
    """Best of three: a third test hole is cut only where the first two
    rank the candidates differently; two that agree are a majority the
    third could not outvote, and the pooled errors rank their candidate
    first."""
    agree, differ = Pooled((1, 2, 3)), Pooled((1, 2, 3))
    for pool, tests in ((agree, ((3.0, 1.0, 2.0), (5.0, 0.5, 0.6))), (differ, ((3.0, 1.0, 2.0), (5.0, 0.9, 0.6)))):
        pool.add(iter([(o, np.full(4, e)) for o, e in zip((1, 2, 3), tests[0])]))
        assert not pool.settled(PROBES)                 # one test is no majority
        pool.add(iter([(o, np.full(4, e)) for o, e in zip((1, 2, 3), tests[1])]))
    assert agree.settled(PROBES) and min(agree.rms().items(), key=lambda t: t[1])[0] == 2
    assert not differ.settled(PROBES)
    assert not agree.settled(2)                         # every planned test made: nothing left to settle
    tied = Pooled((2, 3))
    for _ in range(2):
        tied.add(iter([(2, np.full(4, 1.0)), (3, np.full(4, 1.0))]))
    assert not tied.settled(PROBES)                     # ties rank no order first: the third test decides


@pytest.mark.slow
def test_discs_on_a_fat_torus_get_order_3_where_a_test_hole_balloons_at_order_3():
    """Case 2 of seed 114979771: four discs on a torus of r/R 0.7. Beside two
    199-edge discs one of the two test holes had order 3 ballooning (test
    RMS 0.084 against order 2's 0.0053), which the fill would never keep;
    taken as the fill keeps it, order 3 wins there, as it does on the discs
    (truth: order 3 0.44 per mille, order 2 3.18). The fourth hole (413
    edges) is judged by test holes of half its size. Each test hole weighs
    alike (the geometric mean): pooled over their removed vertices, one
    holding most of them outvoted the others. The test rims are given the
    real rim's noise only where it is clearly the larger: given the
    difference of two clean rims' noise (the grid's jags, 0.000172 against
    0.000156), one disc took order 2 on a near tie (0.00428 against
    0.00458), and given the difference of their umbrella offsets
    (curvature included), the 413-edge hole took order 2."""
    from eval import stress

    case = stress.stress_case(2, 114979771)
    if case.name != "s114979771-02-discs-torus-0.7":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    auto, forced, rep = auto_and_forced_rms(case, 2)
    assert auto <= 0.3 * forced          # order 2 on the discs was 2.61 per mille; order 2 everywhere 3.1
    discs = [h for h in rep["holes"] if h.get("choice") and h["edges"] < 300]
    assert len(discs) == 3 and all(h["choice"]["order"] == 3 for h in discs)


# --------------------------------------------------------------------------
# holes the scan stands across: test holes stop at creases (fill.creases)
# --------------------------------------------------------------------------
@pytest.mark.slow
def test_discs_on_a_fat_torus_whose_test_holes_lie_on_flatter_scan_get_order_3():
    """Case 8 of seed 162639851: five discs on a torus of r/R 0.7, tested
    by test holes of half their size on less curved scan. Given the
    difference of the rims' umbrella offsets (the curvature term) as
    noise, every disc took order 2 (4.95 per mille; order 3 0.577). Given
    only noise the real rims clearly have more of, they take order 3."""
    from eval import stress

    case = stress.stress_case(8, 162639851)
    if case.name != "s162639851-08-discs-torus-0.7":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    auto, forced, rep = auto_and_forced_rms(case, 3)
    assert auto <= 1.05 * forced
    discs = [h for h in rep["holes"] if h.get("choice")]
    assert len(discs) == 4 and all(h["choice"]["order"] == 3 for h in discs)


def test_the_scan_stands_across_a_cylinders_open_end_and_not_across_a_disc_in_a_sphere():
    from shellrepair.fill.creases import walled

    V, F = shapes.cylinder(0.5, 2.0, 48, 40)
    top = np.arange(48) * 41 + 40
    V = np.vstack([V, [[0.0, 0.0, 1.0]]])
    F = np.vstack([F, np.column_stack([top, np.roll(top, -1), np.full(48, len(V) - 1)])])   # closed at the top
    scan, ctx = context(V, F)
    assert walled(ctx, scan.loops[0].vertices)          # the open bottom: walls across its plane
    V2, F2 = sphere_with_hole()
    scan, ctx = context(V2, F2)
    assert not walled(ctx, scan.loops[0].vertices)      # a cap's opening: the scan turns into its plane


def test_faces_are_joined_across_edges_but_not_across_a_crease():
    from shellrepair.fill.creases import CREASE_DEGREES, smooth_component

    # a strip folded along x = 1: two faces flat at z = 0, two standing up at 90 degrees
    X = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 1], [1, 1, 1]], float)
    F = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3], [4, 5, 3]], np.int64)
    limit = np.cos(np.radians(CREASE_DEGREES))
    assert smooth_component(X, F, 0, limit).tolist() == [0, 1]
    assert smooth_component(X, F, 3, limit).tolist() == [2, 3]
    assert smooth_component(X, F, 0, -1.0).tolist() == [0, 1, 2, 3]     # no edge a crease: one piece
    X[4:, 0] = 1.1                                                      # a fold of a few degrees is no crease
    X[4:, 2] = 0.05
    assert smooth_component(X, F, 0, limit).tolist() == [0, 1, 2, 3]


def test_a_test_hole_stops_at_a_crease_it_crosses_and_keeps_the_relief_inside_it():
    """A grid with a wall standing up along one side and a sharp spike in
    its middle: the test hole from a corner face stops at the wall's crease,
    which reaches its edge, and takes the spike with it (a piece that the
    smooth part encloses is relief within the hole, not beyond a crease: left
    as scan, it was an island, and a test hole with an island has two rims)."""
    from shellrepair.fill.creases import CREASE_DEGREES, crease_cut, smooth_component

    n = 7
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    i, j = i.ravel(), j.ravel()
    X = np.column_stack([i, j, np.zeros(n * n)]).astype(float)
    X[i == n - 1, 0] = n - 2                 # the last column stands up: a wall at x = n - 2
    X[i == n - 1, 2] = 1.0
    spike = 2 * n + 3
    X[spike, 2] = 3.0
    quads = [(a * n + b, (a + 1) * n + b, a * n + b + 1, (a + 1) * n + b + 1) for a in range(n - 1) for b in range(n - 1)]
    F = np.array([f for p, q, r, t in quads for f in ((p, q, t), (p, t, r))], np.int64)
    wall = np.flatnonzero((X[F][:, :, 2] == 1.0).any(axis=1))
    at_spike = np.flatnonzero((F == spike).any(axis=1))
    limit = np.cos(np.radians(CREASE_DEGREES))
    cut = crease_cut(X, F, 0, limit)
    assert set(cut.tolist()) == set(range(len(F))) - set(wall.tolist())
    assert not set(at_spike.tolist()) & set(smooth_component(X, F, 0, limit).tolist())   # the spike's edges are creases
    assert crease_cut(X, F, 0, -1.0).tolist() == list(range(len(F)))                     # no crease: the whole outline


def test_a_cad_faces_occlusion_is_tested_by_test_holes_stopped_at_its_creases():
    """Case 0 of seed 297394076, the fandisk under a ring of views: its
    holes are faces the views missed up to their creases, the walls standing
    across them. Test holes laid across the creases beside them rated
    orders 2 and 3 first, and the repair was 9.73 per mille from the truth
    where order 1 forced gives 4.82. Stopped at the creases, the test holes
    are met by walls as the holes are, and the repair is as true as order 1."""
    from eval import stress

    if "fandisk" not in stress.available_shapes():
        pytest.skip("the fandisk is one of ../shared's scans")
    case = stress.stress_case(0, 297394076, family="scanner", shape="fandisk")
    auto, forced, rep = auto_and_forced_rms(case, 1)
    assert auto <= 1.05 * forced
    assert any(row.get("choice", {}).get("order") == 1 for row in rep["holes"])


def test_the_flat_triangulation_can_be_measured_like_the_orders():
    """Asked for (``WITH_FLAT``; not the default's candidates), the test
    holes are also measured against the rim's triangulation with no new
    vertex; on a sphere it lies far from the scan cut away, and order 3 is
    chosen."""
    from shellrepair.fill.selftest import FLAT, WITH_FLAT

    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    assert FLAT not in choose_order(ctx, h.id, h.vertices).errors          # the default's candidates: the orders
    test = choose_order(ctx, h.id, h.vertices, WITH_FLAT)
    assert set(test.errors) == set(WITH_FLAT)
    assert test.order == 3 and test.errors[FLAT] > 3 * test.errors[3]
    assert "flat " in test.describe() and test.as_dict()["test_rms"]["flat"] == test.errors[FLAT]


def test_a_hole_the_test_gives_the_flat_triangulation_is_filled_with_no_new_vertex(monkeypatch):
    from shellrepair.fill.hole import fill_hole

    V, F = sphere_with_hole(radius=0.5)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    told = OrderTest("flat", errors={1: 0.3, 2: 0.2, 3: 0.25, "flat": 0.1}, probes=2, scale=1.0)
    monkeypatch.setattr(selftest, "choose_order", lambda *a, **k: told)
    out = fill_hole(ctx, h.id, h.vertices, "auto", 0)
    assert out.patch.kind == "flat" and len(out.patch.P) == 0 and out.patch.choice is told
    assert out.patch.option.startswith("flat triangulation (auto: flat, by 2 test holes")
    assert told.as_dict()["order"] == "flat" and told.as_dict()["runner_up"] == 2


def test_order_flat_fills_every_single_hole_with_its_rim_triangulation():
    V, F = sphere_with_hole(radius=0.5)
    R, rep = repair_mesh(Mesh(V=V, F=F), order="flat")
    assert rep["holes_after"] == 0 and len(R.V) == len(V)
    assert [(r["kind"], r["order"]) for r in rep["holes"]] == [("flat", None)]


def test_the_flat_triangulation_of_a_rim_bent_round_a_cylinder_follows_the_cylinder():
    """A disc cut from a cylinder as wide as the cylinder's radius: its rim
    bends round the axis. The rim's projection along its own axis gives a
    valid triangulation whose triangles cut the bend's chord (up to 0.2
    off the surface, before the flat fill became the minimum-weight
    triangulation); Liepa's minimum-weight triangulation keeps to the
    surface, within the chords' own sag between neighbouring columns."""
    n = 48
    V, F = shapes.cylinder(1.0, 6.0, n, 59)
    V, F, _ = shapes.remove_faces(V, F, np.linalg.norm(V[F].mean(axis=1) - [1.0, 0.0, 0.0], axis=1) <= 0.8)
    R, rep = repair_mesh(Mesh(V=V, F=F), order="flat")
    assert rep["holes_after"] == 0 and len(R.V) == len(V)
    new = R.F[len(F):]
    at_disc = new[(np.linalg.norm(R.V[new] - [1.0, 0.0, 0.0], axis=2) < 1.0).all(axis=1)]
    assert len(at_disc) > 20
    off = np.abs(np.linalg.norm(R.V[at_disc].mean(axis=1)[:, :2], axis=1) - 1.0)
    sag = 1.0 - np.cos(np.pi / n)           # a chord between neighbouring columns
    assert off.max() < 2 * sag


def test_every_hole_the_order_test_measured_has_its_verdict_in_its_row():
    """A scanner-hard fandisk (seed 557931736, case 6): its 257-edge hole's
    order-2 fill crossed the scan and holds vertices on the flat
    triangulation, so order 3 is not built on it. The test's verdict
    (order 3, each candidate's error, the runner-up) is still the row's
    ``choice``, and the reason says why order 2 stayed; before, the row
    said nothing of the test that had run."""
    from eval import stress

    case = stress.stress_case(6, 557931736)
    tested = []
    real = selftest.choose_order

    def spy(ctx, hole_id, *a, **k):
        tested.append(hole_id)
        return real(ctx, hole_id, *a, **k)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(selftest, "choose_order", spy)
        R, rep = repair_mesh(Mesh(V=case.V, F=case.F), jobs=1)
    rows = {h["id"]: h for h in rep["holes"]}
    assert tested and all("choice" in rows[i] for i in tested if rows[i]["status"] == "filled"), \
        [rows[i].get("option") for i in tested]
    row = rows[0]
    assert row["order"] == 2 and row["choice"]["order"] == 3 and set(row["choice"]["test_rms"]) == {"1", "2", "3"}
    assert "held on the flat triangulation" in row["option"] and "order 3 not tried" in row["option"]
