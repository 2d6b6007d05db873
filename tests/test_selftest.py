"""The band test that picks a hole's fairing order (shellrepair.selftest)."""

import numpy as np
import pytest

from shellrepair import Mesh, detect_holes, read_mesh
from eval import shapes
from shellrepair.fill import _fill_one_order
from shellrepair.holes import boundary_loops
from shellrepair.patch import _Context, build_patch
from shellrepair.repair import repair_mesh
from shellrepair import selftest
from shellrepair.selftest import (MIN_EDGES, SMALL_SAMPLE, SMOOTH_BEND_DEG, OrderTest, _best, agrees, choose_order,
                                  point_mesh_distance, probe_band, rim_bend, sagitta, scan_verdict, size_class)

from conftest import shared_scan


def context(V, F):
    scan = detect_holes(V, F)
    ctx = _Context(Mesh(V=V, F=F))
    ctx.planarity = {L.id: L.planarity for L in scan.loops}
    return scan, ctx


def sphere_with_hole(subdivisions=4, radius=0.5):
    V, F = shapes.icosphere(subdivisions)
    top = int(np.argmax(V[:, 2]))
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[top], radius=radius)
    return V2, F2


def test_point_mesh_distance_is_exact_over_a_square_and_past_its_corner():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    Q = np.array([[0.3, 0.6, 0.25], [0.9, 0.1, -2.0], [2.0, 2.0, 0.0], [-1.0, 0.5, 1.0]])
    d = point_mesh_distance(Q, V, F)
    assert np.allclose(d, [0.25, 2.0, np.sqrt(2.0), np.sqrt(2.0)], atol=1e-12)


def test_the_band_is_an_annulus_of_known_scan_around_the_hole():
    V, F = sphere_with_hole()
    scan, ctx = context(V, F)
    loop = scan.holes[0].vertices
    Vl, Fl, ploop, known = probe_band(ctx, loop, 3)
    # the larger hole is a boundary loop of what is kept
    loops, chains = boundary_loops(Fl, len(Vl))
    assert not chains and any(set(b.tolist()) == set(ploop.tolist()) for b in loops)
    # the known vertices are the band's, off the larger hole's rim, and
    # include the real hole's rim; no kept face uses them
    assert not np.isin(known, ploop).any()
    loc = {tuple(p) for p in Vl[known].tolist()}
    assert {tuple(p) for p in V[loop].tolist()} <= loc
    assert not np.isin(Fl, known).any()
    # the band is 3 rings wide: the larger hole's rim is farther out than the hole's
    c = V[loop].mean(axis=0)
    assert np.linalg.norm(Vl[ploop] - c, axis=1).min() > np.linalg.norm(V[loop] - c, axis=1).max()


def test_no_band_where_it_would_reach_another_hole():
    V, F = shapes.icosphere(4)
    top = int(np.argmax(V[:, 2]))
    dist = np.linalg.norm(V - V[top], axis=1)
    near = int(np.argmin(np.where(dist > 0.35, dist, np.inf)))    # a vertex about 4 rings away
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[top, near], radius=0.05, min_separation=0.0)
    scan, ctx = context(V2, F2)
    assert len(scan.holes) == 2
    assert probe_band(ctx, scan.holes[0].vertices, 6) is None


def test_a_smooth_sphere_asks_for_order_3_and_order_3_is_truly_better_there():
    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    test = choose_order(ctx, h.id, h.vertices)
    assert test.order == 3 and test.errors[3] < test.errors[2] and test.rings >= 2
    p2 = build_patch(ctx, h.id, h.vertices, order=2)
    p3 = build_patch(ctx, h.id, h.vertices, order=3, initial=p2.T0)
    err = lambda p: np.sqrt(np.mean((np.linalg.norm(p.P, axis=1) - 1.0) ** 2))
    assert err(p3) < err(p2)
    ok, gap = agrees(test, ctx.V, p2, p3)
    assert ok and gap <= test.errors[2] + test.errors[3]


def test_holes_too_small_to_test_keep_order_2():
    V, F = shapes.icosphere(4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[0], radius=0.02)
    scan, ctx = context(V2, F2)
    h = scan.holes[0]
    assert h.edges < MIN_EDGES
    t = choose_order(ctx, h.id, h.vertices)
    assert t.order == 2 and not t.errors and "not tested" in t.describe()


def test_small_holes_share_one_verdict_tested_on_a_few_of_them():
    V, F = shapes.bumpy_sphere(5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=12, radius=0.09, seed=3)
    scan, ctx = context(V2, F2)
    small = [h for h in scan.holes if MIN_EDGES <= h.edges < 24]
    assert len(small) >= 10
    verdict = scan_verdict(ctx, scan.holes)
    assert verdict is not None and 1 <= verdict.shared <= 8 and set(verdict.errors) == {2, 3}
    R, rep = repair_mesh(Mesh(V=V2, F=F2), order="auto")
    assert rep["holes_after"] == 0
    assert sum("the scan's verdict on its holes of this size" in h["option"] for h in rep["holes"]) >= 10


def test_the_small_holes_verdict_is_the_same_with_its_tests_on_two_threads():
    """scan_verdict with its tests shared by this thread and a helper
    thread (fill.on_two_threads) gives the same verdicts, to the bit, and
    both threads ran tests."""
    import threading

    from shellrepair.fill import on_two_threads

    V, F = shapes.bumpy_sphere(5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=12, radius=0.09, seed=3)
    got = []
    for two in (False, True):
        scan, ctx = context(V2, F2)
        threads = set()
        real = selftest._relative_test

        def counted(c, *item):
            threads.add(threading.current_thread().name)
            return real(c, *item)

        selftest._relative_test = counted
        try:
            if two:
                verdict = scan_verdict(ctx, scan.holes, run=on_two_threads(ctx))
            else:
                verdict = scan_verdict(ctx, scan.holes)
        finally:
            selftest._relative_test = real
        got.append((verdict, ctx.auto_shared))
        assert len(threads) == (2 if two else 1)
    (a, sa), (b, sb) = got
    assert a is not None and a.shared >= 2
    for x, y in [(a, b)] + [(sa[c], sb[c]) for c in sa]:
        assert (x.order, x.rings, x.shared, x.why) == (y.order, y.rings, y.shared, y.why)
        assert x.errors == y.errors and x.floor == y.floor       # the floats themselves
    assert set(sa) == set(sb)


def test_the_two_thread_runner_keeps_the_order_and_raises_a_calls_error():
    from shellrepair.fill import on_two_threads

    V, F = shapes.icosphere(2)
    ctx = _Context(Mesh(V=V, F=F))
    run = on_two_threads(ctx)
    assert run(lambda c, i: i * i, [(i,) for i in range(40)]) == [i * i for i in range(40)]

    def bad(c, i):
        if i == 7:
            raise ValueError("item 7")
        return i

    with pytest.raises(ValueError, match="item 7"):
        run(bad, [(i,) for i in range(20)])
    assert run(lambda c, i: (c is ctx, i), [(1,)]) == [(True, 1)]      # one item: here, with ctx


def test_on_a_sculpted_bust_auto_is_as_true_as_order_2_and_truer_than_order_3():
    # 9 disc holes over the Nefertiti bust's relief: most rims hold an edge
    # bending over SMOOTH_BEND_DEG (sculpted detail, the scan's noise) and keep
    # order 2 untested; the few smooth ones are tested. Summed over the holes,
    # the choices are within 1 % of order 2 (measured 25.41 against 25.43)
    # and truer than order 3 (25.82; 28.7 before order 3 started from the
    # uniform thin-plate solve, fair.UNIFORM_MAX_ORDER): order 3 carried into
    # the holes overshoots.
    from scipy.spatial import cKDTree

    m = read_mesh(shared_scan("closed_nefertiti_bust.ply"))
    V, F = np.asarray(m.V, float), np.asarray(m.F, np.int64)
    diag = float(np.linalg.norm(np.ptp(V, axis=0)))
    sq = {2: 0.0, 3: 0.0, "auto": 0.0}
    held = 0
    for seed in (5, 6, 7):
        centers = np.random.default_rng(seed).choice(len(V), 3, replace=False)
        V2, F2, removed, _ = shapes.perforate_discs(V, F, centers=list(centers), radius=0.04 * diag)
        scan, ctx = context(V2, F2)
        tree = cKDTree(V[F[removed]].mean(axis=1))   # the removed faces' centres: the truth, densely
        for h in scan.holes:
            t = choose_order(ctx, h.id, h.vertices)
            held += "bends" in t.why
            assert ("bends" in t.why) == (rim_bend(ctx, h.vertices) > SMOOTH_BEND_DEG)
            p2, *_ = _fill_one_order(ctx, h.id, h.vertices, 2, 0)
            p3 = build_patch(ctx, h.id, h.vertices, order=3, initial=p2.T0)
            e = {o: float(np.mean(tree.query(p.P)[0] ** 2)) for o, p in ((2, p2), (3, p3))}
            sq[2] += e[2]
            sq[3] += e[3]
            sq["auto"] += e[t.order]
    assert held >= 5
    assert sq["auto"] <= 1.01 * sq[2] and sq["auto"] < sq[3]


def test_a_crease_near_the_rim_keeps_order_2_where_order_3_would_bulge():
    # a disc hole on the flat top of a part, two rings from a 90° edge: order
    # 3 reads the crease's curvature and lifts the fill off the plane; the
    # bend rule keeps order 2, which fills the plane exactly
    V, F = shapes.grid(24, 24, size=2.0)
    x = V[:, 0].copy()
    edge = x.max() - 3 * (2.0 / 24)                 # a crease 3 columns from the side: it folds down 90°
    V[:, 2] = np.where(x > edge, -(x - edge), 0.0)
    V[:, 0] = np.minimum(x, edge)
    c = int(np.argmin(np.linalg.norm(V[:, :2] - [edge - 4.5 * (2.0 / 24), 1.0], axis=1)))
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[c], radius=2.6 * (2.0 / 24))
    scan, ctx = context(V2, F2)
    h = scan.holes[0]
    assert rim_bend(ctx, h.vertices) > SMOOTH_BEND_DEG
    t = choose_order(ctx, h.id, h.vertices)
    assert t.order == 2 and not t.errors and "bends" in t.why
    p2, *_ = _fill_one_order(ctx, h.id, h.vertices, 2, 0)
    p3 = build_patch(ctx, h.id, h.vertices, order=3, initial=p2.T0)
    assert np.abs(p2.P[:, 2]).max() < 1e-9 and np.abs(p3.P[:, 2]).max() > 0.01 * (2.0 / 24)   # measured 0.043 edges


def test_a_smooth_rim_bends_a_few_degrees_and_is_tested():
    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    assert 0 < rim_bend(ctx, h.vertices) < 10
    assert choose_order(ctx, h.id, h.vertices).errors


def test_auto_is_the_default_order():
    from shellrepair.options import RepairOptions

    assert RepairOptions().order == "auto"
    V, F = sphere_with_hole(radius=0.6)
    _, rep = repair_mesh(Mesh(V=V, F=F))
    assert rep["holes_after"] == 0 and "auto: order 3" in rep["holes"][0]["option"]


def test_sagitta_of_a_sphere_is_its_chords_sag():
    # a unit sphere sampled at edge h: adjacent faces' normals are a centroid
    # spacing (h / √3) apart, θ = h / √3, so the floor is h² / (8 √3)
    V, F = shapes.icosphere(4)
    h = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1)
    s = sagitta(V, F)
    ref = np.sqrt(np.mean(h ** 4)) / (8 * np.sqrt(3))
    assert 0.9 * ref < s < 1.1 * ref
    # a flat grid: no bend, no floor
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    assert sagitta(P, np.array([[0, 1, 2], [0, 2, 3]])) == 0.0


def test_order_3_only_where_it_wins_by_more_than_the_floor():
    assert _best({2: 1.0, 3: 0.9}, 0.0, (2, 3)) == 3
    assert _best({2: 1.0, 3: 0.9}, 0.05, (2, 3)) == 3
    assert _best({2: 1.0, 3: 0.9}, 0.2, (2, 3)) == 2
    assert _best({2: 1.0, 3: 1.0}, 0.0, (2, 3)) == 2      # ties go to the first
    assert _best({2: 0.5, 3: 0.9}, 0.0, (2, 3)) == 2
    t = OrderTest(2, errors={2: 1.0, 3: 0.9}, rings=3, floor=0.2)
    assert "within the scan's resolution" in t.describe()


def test_the_coarse_test_picks_order_3_on_the_sphere_as_the_full_one_does(monkeypatch):
    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    full = choose_order(ctx, h.id, h.vertices)
    monkeypatch.setattr(selftest, "TEST_MAX_UNKNOWNS", 0)     # every test hole refined coarse
    coarse = choose_order(ctx, h.id, h.vertices)
    assert full.order == coarse.order == 3
    assert coarse.floor == pytest.approx(full.floor * selftest.TEST_COARSEN ** 2)


def test_many_holes_of_one_size_share_a_verdict_tested_on_a_few(monkeypatch):
    V, F = shapes.icosphere(6)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=12, radius=0.1, seed=2)
    scan, ctx = context(V2, F2)
    classes = [size_class(h.edges) for h in scan.holes]
    c = max(set(classes), key=classes.count)
    assert c >= 1 and classes.count(c) > SMALL_SAMPLE
    calls = []
    real = selftest._refined
    monkeypatch.setattr(selftest, "_refined", lambda *a: calls.append(1) or real(*a))
    scan_verdict(ctx, scan.holes)
    assert c in ctx.auto_shared and 1 <= ctx.auto_shared[c].shared <= SMALL_SAMPLE
    assert len(calls) <= SMALL_SAMPLE * len(set(classes))
    h = scan.holes[classes.index(c)]
    calls.clear()
    t = choose_order(ctx, h.id, h.vertices)
    assert not calls and t.shared and t.order == ctx.auto_shared[c].order
    assert "holes of this size" in t.describe()


def test_order_3_on_the_order_2_refinement_equals_refining_again():
    V, F = sphere_with_hole(radius=0.6)
    scan, ctx = context(V, F)
    h = scan.holes[0]
    p2 = build_patch(ctx, h.id, h.vertices, order=2)
    again = build_patch(ctx, h.id, h.vertices, order=3, initial=p2.T0)
    reused = build_patch(ctx, h.id, h.vertices, order=3, initial=(p2.P, p2.T), refine=False)
    assert np.array_equal(again.T, reused.T) and np.array_equal(again.P, reused.P)


def test_near_rim_counts_rings_from_the_rim_through_shared_triangles():
    # a strip: rim vertices 0, 1; then pairs (2,3), (4,5), (6,7) one ring further each
    T = np.array([[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4], [4, 5, 6], [5, 7, 6]])
    k, n_new = 2, 6
    assert selftest.near_rim(k, T, n_new, 1).tolist() == [0, 1]          # vertices 2, 3
    assert selftest.near_rim(k, T, n_new, 2).tolist() == [0, 1, 2, 3]
    assert selftest.near_rim(k, T, n_new, 10).tolist() == [0, 1, 2, 3, 4, 5]
    assert selftest.near_rim(k, np.zeros((0, 3), np.int64), 0, 3).size == 0
