"""Bands and islands: loops that bound one missing region are filled as one surface.

A torus's inner band, the cut around a thin arm, a hole with an island in
it: each is one missing region with two boundary loops. The loops find each
other by their continuation arcs (shellrepair.fill.bridge), the tube is built
along those arcs, refined, faired and checked, and is kept when the two
caps are impossible, when each loop's arcs land on the other, or when its
energy is lower. Borders are never bridged.
"""

import numpy as np
import pytest

from shellrepair import Mesh, detect_holes
from eval import shapes
from shellrepair.fill.bridge import arc_points, band_pairs, continuation_arcs, loop_sights
from shellrepair.fill.tube import guide_tube, resample_tube, tube_triangles
from shellrepair.mesh.intersect import crossing_pairs
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import edge_topology

from conftest import auto_and_forced_rms, shared_scan


# --------------------------------------------------------------------------
# shapes
# --------------------------------------------------------------------------
def face_normals(V, F):
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    return N / np.linalg.norm(N, axis=1, keepdims=True)


def torus_inner_band(ratio, cos_band=-0.7, nu=160, nv=40):
    """Torus R = 1, r = 1/ratio without the faces whose normal points towards
    the axis within a band of latitude around the inner equator."""
    V, F = shapes.torus(R=1.0, r=1.0 / ratio, nu=nu, nv=nv)
    C = V[F].mean(axis=1)
    radial = np.column_stack([C[:, :2], np.zeros(len(C))])
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    toward_axis = -np.sum(face_normals(V, F) * radial, axis=1)     # cos of the normal to -radial
    V2, F2, kept = shapes.remove_faces(V, F, toward_axis > -cos_band)
    return V, F, V2, F2, kept


def revolution(profile, nu=64, nt=80):
    """Closed surface of revolution about x: ``profile(t) -> (x, radius)``
    for t in [0, 1], radius 0 at both ends (pole vertices there)."""
    t = np.linspace(0, 1, nt + 1)[1:-1]
    x, r = profile(t)
    phi = 2 * np.pi * np.arange(nu) / nu
    ring = np.stack([np.repeat(x, nu), np.outer(r, np.cos(phi)).ravel(), np.outer(r, np.sin(phi)).ravel()], axis=1)
    x0, _ = profile(np.array([0.0]))
    x1, _ = profile(np.array([1.0]))
    V = np.vstack([ring, [[x0[0], 0, 0]], [[x1[0], 0, 0]]])
    s, e = len(ring), len(ring) + 1
    F = []
    m = len(t)
    for i in range(m - 1):
        for j in range(nu):
            a, b = i * nu + j, i * nu + (j + 1) % nu
            c, d = (i + 1) * nu + (j + 1) % nu, (i + 1) * nu + j
            F += [(a, b, c), (a, c, d)]
    for j in range(nu):
        F.append((s, (j + 1) % nu, j))
        F.append((e, (m - 1) * nu + j, (m - 1) * nu + (j + 1) % nu))
    F = np.array(F, np.int64)
    # outward orientation: the signed volume is positive
    vol = np.sum(np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])))
    return V, (F if vol > 0 else F[:, ::-1].copy())


def dumbbell(arm=0.18, nu=64, nt=120):
    """Two round bulbs joined by a thin arm of radius ``arm`` along x."""
    def profile(t):
        x = -1.6 * np.cos(np.pi * t)
        bulb = 0.55 * np.exp(-((np.abs(x) - 1.05) / 0.35) ** 2)
        return x, (arm + bulb) * np.sqrt(np.clip(1 - (np.abs(x) / 1.6) ** 8, 0, 1))
    return revolution(profile, nu, nt)


def ellipsoid(kind, axes):
    """Ellipsoid from an icosphere or from open3d's UV sphere (meridians and parallels)."""
    if kind == "ico":
        return shapes.ellipsoid(4, axes)
    o3d = pytest.importorskip("open3d")
    m = o3d.geometry.TriangleMesh.create_sphere(1.0, resolution=40)
    return np.asarray(m.vertices) * np.asarray(axes), np.asarray(m.triangles, np.int64)


def self_intersections(V, F):
    from eval.metrics import self_intersecting_faces

    return self_intersecting_faces(V, F)


def filled_rms_permille(V_true, F_true, R):
    """RMS distance of the filled faces to the true surface, ‰ of the box diagonal."""
    from eval.metrics import TruthSurface, sample_faces

    truth = TruthSurface(V_true, F_true)
    P, _ = sample_faces(R.V, R.F[R.face_filled], 20000, np.random.default_rng(0))
    d, _, _ = truth.closest(P)
    return 1000 * float(np.sqrt(np.mean(d ** 2))) / truth.diag


def assert_closed_and_clean(M, R, rep):
    """No hole left, manifold, original vertices bit-identical, no self-intersection added."""
    assert rep["holes_after"] == 0, rep["holes"]
    assert rep["boundary_edges_after"] == 0 and rep["nonmanifold_edges_after"] == 0
    assert np.array_equal(R.V[:len(M.V)], M.V)
    assert self_intersections(R.V, R.F) == self_intersections(M.V, M.F)


# --------------------------------------------------------------------------
# the torus's inner band
# --------------------------------------------------------------------------
@pytest.mark.parametrize("ratio", [2, 3, 5])
def test_torus_inner_band_is_one_tube_and_keeps_the_genus(ratio):
    V, F, V2, F2, _ = torus_inner_band(ratio)
    M = Mesh(V=V2, F=F2)
    assert [L.kind for L in detect_holes(V2, F2).loops] == ["hole", "hole"]
    R, rep = repair_mesh(M)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_before"] == 0 and rep["euler_after"] == 0          # still genus 1
    assert filled_rms_permille(V, F, R) < 5.0


def torus_seen_from_a_ring(ratio):
    """A torus scanned from 12 positions on a ring in its equatorial plane:
    the top, the inner side and the bottom go unseen (60 % of the surface),
    two coaxial loops of 200 edges are left on the outer side."""
    o3d = pytest.importorskip("open3d")
    from eval.cases import keep_largest, occlusion_mask, scanner_positions

    m = o3d.geometry.TriangleMesh.create_torus(torus_radius=1.0, tube_radius=1.0 / ratio,
                                               radial_resolution=200, tubular_resolution=40)
    V, F = np.asarray(m.vertices, np.float64), np.asarray(m.triangles, np.int64)
    P = scanner_positions(V, 12, path="ring", elevation=(0.0, 0.0), up=2, seed=0)
    V2, F2, _ = shapes.remove_faces(V, F, keep_largest(F, occlusion_mask(V, F, P)))
    return V, F, V2, F2


@pytest.mark.parametrize("ratio", [3, 5])
def test_torus_unseen_from_a_ring_is_bridged_through_its_hole(ratio):
    """Caps would be valid here (two discs across the central hole) and have
    the lower energy, but each loop's continuation arcs land on the other:
    the tube is kept, and it is far closer to the truth than the caps (and
    than the peers' 45-66 per mille on such a band)."""
    V, F, V2, F2 = torus_seen_from_a_ring(ratio)
    M = Mesh(V=V2, F=F2)
    assert len(detect_holes(V2, F2).holes) == 2
    R, rep = repair_mesh(M)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 0
    rms = filled_rms_permille(V, F, R)
    Rc, repc = repair_mesh(M, bridge="never")
    assert repc["euler_after"] == 2
    assert rms < 30.0 and rms < 0.5 * filled_rms_permille(V, F, Rc)


def test_a_band_whose_guide_fills_its_budget_gets_the_tube_resampled_on_the_faired_coarse_guide(monkeypatch):
    """Where the guide tube alone would take more than GUIDE_SHARE of the
    band's work budget (forced here: share 0), the first tube is the faired
    coarse guide resampled at the rim's spacing: still one clean tube of
    the right genus, as close to the truth, and of about the size of the
    tube refined from this guide (which does not crumple: 916 new vertices,
    the resampled tube 1045)."""
    from shellrepair.fill import band_fill

    V, F, V2, F2, _ = torus_inner_band(3)
    M = Mesh(V=V2, F=F2)
    R0, rep0 = repair_mesh(M, order=2)      # (the first tube's guide, not the choice of order, is under test)
    monkeypatch.setattr(band_fill, "GUIDE_SHARE", 0.0)
    R, rep = repair_mesh(M, order=2)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert "resampled on their faired coarse tube" in rep["holes"][0]["option"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 0
    assert filled_rms_permille(V, F, R) < 5.0
    assert rep["holes"][0]["new_vertices"] <= 1.25 * rep0["holes"][0]["new_vertices"]


@pytest.mark.slow
def test_a_band_seen_both_ways_whose_tubes_all_cross_is_mended_before_it_is_capped():
    """A random scanner case (stress seed 33333, case 11: a torus of ratio
    0.3, 31 % unseen from 3 views): each loop's arcs land on the other (42
    and 31 of 48), but every tube crossed the scan at 2 to 71 triangles and
    the two caps closed the band, genus 0 where the truth has genus 1; the
    tube's last layer now comes before the caps."""
    from conftest import STRESS_SHAPES
    from eval import stress

    shapes = STRESS_SHAPES
    c = stress.stress_case(11, 33333, shapes_ok=shapes)
    assert "torus-0.3" in c.name
    M = Mesh(V=c.V, F=c.F)
    R, rep = repair_mesh(M)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    tube = [h for h in rep["holes"] if (h["option"] or "").startswith("tube to loop")]
    assert len(tube) == 1 and "mended" in tube[0]["option"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 0


# --------------------------------------------------------------------------
# a thin arm cut around
# --------------------------------------------------------------------------
def test_band_around_a_thin_arm_is_a_tube_along_the_arm():
    V, F = dumbbell(arm=0.18)
    C = V[F].mean(axis=1)
    V2, F2, _ = shapes.remove_faces(V, F, np.abs(C[:, 0] - 0.1) < 0.2)   # the arm, cut in two pieces
    M = Mesh(V=V2, F=F2)
    scan = detect_holes(V2, F2)
    assert [L.kind for L in scan.loops] == ["hole", "hole"] and scan.n_components == 2
    R, rep = repair_mesh(M)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 2                                    # one closed piece again
    P = R.V[R.vertex_filled]
    assert np.abs(np.hypot(P[:, 1], P[:, 2]) - 0.18).max() < 0.1 * 0.18  # on the arm (measured 8 %)
    assert filled_rms_permille(V, F, R) < 3.5                          # measured 2.4


def test_band_across_a_thin_ring_is_a_tube():
    """A thin ring (R/r = 8) missing a band across its tube: one piece, two loops."""
    V, F = shapes.torus(R=1.0, r=0.125, nu=160, nv=24)
    phi = np.mod(np.arctan2(V[:, 1], V[:, 0]), 2 * np.pi)
    V2, F2, _ = shapes.remove_faces(V, F, (np.abs(phi[F] - 2.0) < 0.3).any(axis=1))
    M = Mesh(V=V2, F=F2)
    R, rep = repair_mesh(M)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 0
    assert filled_rms_permille(V, F, R) < 2.0                          # measured 1.1


# --------------------------------------------------------------------------
# slits
# --------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["ico", "uv"])
@pytest.mark.parametrize("seed", [11, 12, 13])
def test_long_thin_slit_across_an_ellipsoid_closes_without_self_intersections(kind, seed):
    from eval.cases import keep_largest, slit_mask

    V, F = ellipsoid(kind, (1.5, 0.5, 0.3))
    V2, F2, _ = shapes.remove_faces(V, F, keep_largest(F, slit_mask(V, F, length=2.5, seed=seed)))
    M = Mesh(V=V2, F=F2)
    R, rep = repair_mesh(M)
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 2


def test_a_slit_pinched_into_many_loops_is_not_bridged_across_its_pinches():
    """Faces along an edge path only: the slit pinches at every path vertex
    into small loops that touch; loops that share a vertex never pair."""
    from eval.cases import _edge_graph
    from scipy.sparse.csgraph import dijkstra

    V, F = ellipsoid("ico", (1.5, 0.5, 0.3))
    d, pred = dijkstra(_edge_graph(V, F), indices=0, return_predecessors=True)
    t = int(np.argmin(np.abs(d - 2.0)))
    path = [t]
    while path[-1] != 0:
        path.append(int(pred[path[-1]]))
    on = {(a, b) for a, b in zip(path[:-1], path[1:])} | {(b, a) for a, b in zip(path[:-1], path[1:])}
    remove = np.array([any((f[i], f[(i + 1) % 3]) in on for i in range(3)) for f in F.tolist()])
    V2, F2, _ = shapes.remove_faces(V, F, remove)
    M = Mesh(V=V2, F=F2)
    scan = detect_holes(V2, F2)
    assert len(scan.holes) > 5
    R, rep = repair_mesh(M)
    for b in rep["bridges"]:
        A, B = (scan.loops[i].vertices for i in b["loops"])
        assert np.intersect1d(A, B).size == 0
    assert_closed_and_clean(M, R, rep)


def test_two_slits_end_to_end_are_capped_not_bridged():
    """Two slits along one edge path with a short piece of scan between
    them: their arcs cross each slit's width and land on its own far side,
    so the two loops are no band; each is capped."""
    from eval.cases import _edge_graph
    from scipy.sparse.csgraph import dijkstra

    V, F = ellipsoid("uv", (1.5, 0.5, 0.3))
    d, pred = dijkstra(_edge_graph(V, F), indices=5, return_predecessors=True)
    t = int(np.argmin(np.abs(d - 2.4)))
    path = [t]
    while path[-1] != 5:
        path.append(int(pred[path[-1]]))
    path = np.array(path[1:-1])
    m = len(path) // 2
    cut = np.concatenate([path[:m - 2], path[m + 2:]])                # a gap of three path vertices
    V2, F2, _ = shapes.remove_faces(V, F, np.isin(F, cut).any(axis=1))
    M = Mesh(V=V2, F=F2)
    assert len(detect_holes(V2, F2).holes) == 2
    R, rep = repair_mesh(M)
    assert all(b["chosen"] == "caps" for b in rep["bridges"])
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 2


# --------------------------------------------------------------------------
# borders are never bridged
# --------------------------------------------------------------------------
def short_ring(z0, h=0.1, radius=0.5, nu=48):
    V, F = shapes.cylinder(radius, h, nu, 2)
    V = V + np.array([0.0, 0.0, z0])
    return V, F


def test_facing_border_loops_of_floating_rings_are_never_bridged():
    """Two short coaxial rings of scan a small gap apart, read as single
    views: their facing rims are borders, never bridged."""
    V1, F1 = short_ring(0.0)
    V2, F2 = short_ring(0.25)
    V = np.vstack([V1, V2])
    F = np.vstack([F1, F2 + len(V1)])
    # each ring wraps around its axis, so it reads as part of a closed object
    # by default; read as single views, every rim is a border
    scan = detect_holes(V, F, closed=False)
    borders = {L.id for L in scan.loops if L.kind == "border"}
    assert len(borders) == 2       # one outer rim per ring along its view
    for mode in ("auto", "always"):
        R, rep = repair_mesh(Mesh(V=V, F=F), bridge=mode, closed=False)
        assert all(not borders & set(b["loops"]) for b in rep["bridges"])
        assert all(b["chosen"] != "tube" for b in rep["bridges"])
        assert len(rep["border_loops"]) == 2
    # with every loop read as a hole, the facing rims do pair
    R, rep = repair_mesh(Mesh(V=V, F=F), fill_borders=True)
    assert any(b["chosen"] == "tube" for b in rep["bridges"])


def test_a_sheet_with_floating_islands_bridges_nothing():
    """A single-view sheet (height field) with a hole and two floating
    islands of triangles beside it: the islands' rims and the sheet's rim
    are borders; nothing is bridged, the hole is capped."""
    V, F = shapes.grid(30, 30, 1.0)
    V[:, 2] = 0.05 * np.sin(3 * V[:, 0]) * np.cos(2 * V[:, 1])
    C = V[F].mean(axis=1)
    hole = np.hypot(C[:, 0] - 0.5, C[:, 1] - 0.5) < 0.2
    isl_a = np.hypot(C[:, 0] - 0.45, C[:, 1] - 0.5) < 0.05
    isl_b = np.hypot(C[:, 0] - 0.58, C[:, 1] - 0.5) < 0.05
    V2, F2, _ = shapes.remove_faces(V, F, hole & ~isl_a & ~isl_b)
    scan = detect_holes(V2, F2)
    kinds = sorted(L.kind for L in scan.loops)
    assert kinds.count("border") >= 3
    R, rep = repair_mesh(Mesh(V=V2, F=F2))
    for b in rep["bridges"]:
        assert b["kinds"] == ["hole", "hole"]
    assert all(scan.loops[b].kind == "hole" for r in rep["bridges"] for b in r["loops"])


def test_a_real_single_view_range_scan_pairs_no_border():
    """The range scan's outer edge and its floating debris are borders; a
    pair, if any, joins two holes."""
    from shellrepair import read_mesh
    from shellrepair.fill.bands import find_bands
    from shellrepair.mesh.index import ScanContext

    m = read_mesh(shared_scan("real_rangescan_dragon_000.ply"))
    scan = detect_holes(m.V, m.F)
    assert len(scan.borders) >= 2
    for A, B, *_ in find_bands(ScanContext(m), scan).pairs:
        assert A.kind == "hole" and B.kind == "hole"


def test_band_pairs_skips_loops_not_eligible():
    counts = {0: (np.array([0, 40, 8]), 48), 1: (np.array([45, 0, 3]), 48), 2: (np.array([30, 0, 0]), 48)}
    assert band_pairs(counts, np.array([True, True, True]))[0][:2] == (0, 1)
    assert band_pairs(counts, np.array([True, False, True])) == [(0, 2, 30 / 48, False)]
    assert band_pairs(counts, np.array([True, False, False])) == []


# --------------------------------------------------------------------------
# islands
# --------------------------------------------------------------------------
def test_hole_with_an_island_is_filled_as_an_annulus():
    """A sphere with a wide hole and a floating piece of it in the middle:
    the island's arcs land on the surrounding loop; the outer cap would run
    through the island, so the annulus between them is kept."""
    V, F = shapes.icosphere(4)
    C = V[F].mean(axis=1)
    z = C[:, 2] / np.linalg.norm(C, axis=1)
    V2, F2, _ = shapes.remove_faces(V, F, (z > 0.6) & (z < 0.9))
    M = Mesh(V=V2, F=F2)
    scan = detect_holes(V2, F2)
    assert scan.n_components == 2 and len(scan.loops) == 2
    # the island is read as a border (its piece lies inside its rim) unless every loop is filled
    R, rep = repair_mesh(M, fill_borders=True)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 2
    assert filled_rms_permille(V, F, R) < 2.0


# --------------------------------------------------------------------------
# the pieces
# --------------------------------------------------------------------------
def test_continuation_arcs_follow_the_surface_across_the_gap():
    """On a cylinder the arcs are straight, on a torus's meridian they have its curvature."""
    V, F = shapes.cylinder(0.5, 2.0, 48, 40)
    V2, F2, _ = shapes.remove_faces(V, F, np.abs(V[F].mean(axis=1)[:, 2]) < 0.2)
    lp = detect_holes(V2, F2).loops[0].vertices
    U, T, N, kap, s0, ok = continuation_arcs(V2, F2, lp)
    assert ok.all() and np.abs(kap).max() < 0.02                      # straight (1/r across is 2)
    assert np.abs(T[:, 2]).min() > 0.999
    V, F, V2, F2, _ = torus_inner_band(3, nu=200, nv=60)
    for L in detect_holes(V2, F2).loops:
        U, T, N, kap, s0, ok = continuation_arcs(V2, F2, L.vertices)
        assert ok.all() and np.abs(np.abs(kap) - 3.0).max() < 0.15        # 1/r, within 5 %
        X = arc_points(U, T, N, kap, np.linspace(0.0, 1.0, 7)[None].repeat(len(U), 0))
        rho = np.hypot(np.hypot(X[..., 0], X[..., 1]) - 1.0, X[..., 2])
        assert np.abs(rho - 1 / 3).max() < 0.02                          # the arcs stay on the tube


def test_loops_of_a_torus_band_see_each_other_and_a_disc_hole_sees_itself():
    V, F, V2, F2, _ = torus_inner_band(3)
    loops = detect_holes(V2, F2).loops
    s = loop_sights(V2, loops, lambda lp: F2)
    assert s[0][0][1] == s[0][1] and s[1][0][0] == s[1][1]           # every arc lands on the other loop
    V, F = shapes.icosphere(4)
    V3, F3, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.4, seed=1, min_separation=1.0)
    loops = detect_holes(V3, F3).loops
    s = loop_sights(V3, loops, lambda lp: F3)
    for a, (counts, m) in s.items():
        assert counts[a] > m // 2                                      # lands on its own far side


@pytest.mark.parametrize("ka,kb,shift", [(60, 13, 5), (17, 90, 44), (40, 40, 23)])
def test_tube_zips_loops_of_different_counts_and_twisted_starts(ka, kb, shift):
    t = 2 * np.pi * np.arange(ka) / ka
    A = np.column_stack([np.cos(t), np.sin(t), np.zeros(ka)])
    s = 2 * np.pi * (np.arange(kb) + 0.37) / kb
    B = np.column_stack([np.cos(-s), np.sin(-s), np.full(kb, 0.8)])   # the other way round
    B = np.roll(B, shift, axis=0)
    for T in (tube_triangles(A, B),):
        topo = edge_topology(T, ka + kb)
        he = {(int(a), int(b)) for a, b in topo.he[topo.boundary_he]}
        assert len(he) == ka + kb and topo.nonmanifold_edges.shape[0] == 0
        assert all(((i + 1) % ka, i) in he for i in range(ka))
        assert all((ka + (i + 1) % kb, ka + i) in he for i in range(kb))
        P = np.vstack([A, B])
        assert len(crossing_pairs(P[T], T)) == 0
    # the guided tube: rings on the cylinder between them, a manifold strip
    z = lambda P: P[:, 2]
    arcs = []
    for P, up in ((A, 1.0), (B, -1.0)):
        k = len(P)
        arcs.append((P - np.array([0, 0, 0.1 * up]), np.tile([0.0, 0.0, up], (k, 1)),
                     np.column_stack([P[:, 0], P[:, 1], np.zeros(k)]), np.zeros(k), np.full(k, 0.1),
                     np.ones(k, bool)))
    Pg, Tg = guide_tube(A, B, *arcs, spacing=0.1, reach=2.0)
    assert len(Pg) > 0
    sag = 1 - np.cos(np.pi / min(ka, kb))                              # chords of the coarser loop
    rho = np.hypot(Pg[:, 0], Pg[:, 1])
    assert (rho <= 1 + 1e-9).all() and (rho >= 1 - sag - 1e-9).all() and (z(Pg) > 0).all() and (z(Pg) < 0.8).all()
    n = ka + kb + len(Pg)
    topo = edge_topology(Tg, n)
    assert topo.nonmanifold_edges.shape[0] == 0 and topo.n_boundary_edges == ka + kb
    P = np.vstack([A, B, Pg])
    assert len(crossing_pairs(P[Tg], Tg)) == 0
    # a coarse guide resampled at the fine spacing: the same kind of strip,
    # its rings 0.1 apart on the coarse tube's surface (the cylinder)
    Pc, Tc, params, order = guide_tube(A, B, *arcs, spacing=0.4, reach=2.0, rings=True)
    Pr, Tr = resample_tube(A, B, params, order, Pc, spacing=0.1)
    level = 10 * z(Pr)
    assert np.abs(level - np.round(level)).max() < 0.2 and set(np.round(level).astype(int).tolist()) == set(range(1, 8))
    assert len(Pr) > 2 * len(Pc)
    rho = np.hypot(Pr[:, 0], Pr[:, 1])
    sag_c = 1 - np.cos(np.pi / min(len(u) for u in params))            # chords of the coarsest ring
    assert (rho <= 1 + 1e-9).all() and (rho >= 1 - 2 * sag_c).all()    # its chords, and chords across them
    topo = edge_topology(Tr, ka + kb + len(Pr))
    assert topo.nonmanifold_edges.shape[0] == 0 and topo.n_boundary_edges == ka + kb
    assert {tuple(e) for e in topo.he[topo.boundary_he].tolist()} == \
        {tuple(e) for e in edge_topology(Tg, n).he[edge_topology(Tg, n).boundary_he].tolist()}
    P = np.vstack([A, B, Pr])
    assert len(crossing_pairs(P[Tr], Tr)) == 0


# --------------------------------------------------------------------------
# a real genus-1 part
# --------------------------------------------------------------------------
def rocker_arm_band():
    """The rocker arm without a band of its hole's wall: faces near the hole
    whose normals point at its axis, in the middle half of the wall."""
    from scipy import ndimage

    from shellrepair import read_mesh

    m = read_mesh(shared_scan("closed_rocker_arm_genus1.ply"))
    V, F = m.V, m.F
    c = V.mean(axis=0)
    X = V - c
    _, U = np.linalg.eigh(X.T @ X)
    ax, u, v = U[:, 0], U[:, 1], U[:, 2]                   # the thinnest extent is the hole's axis
    n = 200
    T = V[F] - c
    S = np.concatenate([(1 - a - b) * T[:, 0] + a * T[:, 1] + b * T[:, 2]
                        for a in np.linspace(0, 1, 6) for b in np.linspace(0, 1 - a, 6)])
    Q = np.column_stack([S @ u, S @ v])
    lo, hi = Q.min(axis=0), Q.max(axis=0)
    ij = ((Q - lo) / (hi - lo) * (n - 1)).round().astype(int)
    img = np.zeros((n, n), bool)
    img[ij[:, 0], ij[:, 1]] = True
    lab, k = ndimage.label(~ndimage.binary_closing(img, iterations=2))
    inner = [i for i in range(1, k + 1) if not (lab == i)[[0, -1]].any() and not (lab == i)[:, [0, -1]].any()]
    reg = lab == inner[0]
    centre = np.argwhere(reg).mean(axis=0) / (n - 1) * (hi - lo) + lo
    radius = np.sqrt(reg.sum() / np.pi) / (n - 1) * np.mean(hi - lo)
    Cf = V[F].mean(axis=1) - c
    d2 = np.column_stack([Cf @ u, Cf @ v]) - centre
    rad = np.linalg.norm(d2, axis=1)
    N = face_normals(V, F)
    toward = -(N @ u * d2[:, 0] + N @ v * d2[:, 1]) / np.maximum(rad, 1e-12)
    wall = (rad < 1.5 * radius) & (toward > 0.5)
    h = Cf @ ax
    mid, half = np.median(h[wall]), 0.5 * np.ptp(h[wall])
    remove = wall & (np.abs(h - mid) < 0.5 * half)
    V2, F2, _ = shapes.remove_faces(V, F, remove)
    return V, F, V2, F2


def test_rocker_arm_band_around_its_hole_is_a_tube():
    V, F, V2, F2 = rocker_arm_band()
    M = Mesh(V=V2, F=F2)
    scan = detect_holes(V2, F2)
    assert len(scan.holes) == 2
    R, rep = repair_mesh(M)
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 0
    assert filled_rms_permille(V, F, R) < 2.0


def test_a_band_pinched_at_shared_vertices_is_split_into_its_parts():
    """Loops A and B share vertices 0 and 3 (B meets them in the reverse
    order): the band between them is two discs, each a stretch of A and a
    stretch of B, together every edge of both once."""
    from shellrepair.holes.pinched import pinched_parts

    A = np.array([0, 1, 2, 3, 4, 5])
    B = np.array([10, 3, 11, 0])
    parts = pinched_parts(A, B)
    assert [p.tolist() for p in parts] == [[0, 1, 2, 3, 11], [3, 4, 5, 0, 10]]
    edges = sorted((int(a), int(b)) for p in parts for a, b in zip(p, np.roll(p, -1)))
    own = sorted((int(a), int(b)) for L in (A, B) for a, b in zip(L, np.roll(L, -1)))
    # each part's closing edges (2->3 of A ... ) are the loops' own edges
    assert len(edges) == len(own) == 10 and set(edges) == set(own)
    # the same order on both (not a pinched band), or a single shared vertex: left alone
    assert pinched_parts(A, np.array([10, 0, 11, 3, 12, 4])) is None
    assert pinched_parts(A, np.array([10, 0, 11])) is None


# --------------------------------------------------------------------------
# the band search's shortcuts change nothing
# --------------------------------------------------------------------------
def _many_loops():
    """Scans with many loops: tiny and medium disc holes on a bumpy sphere
    (loops of 3 to ~60 vertices, some within reach of each other), a torus
    band, and a slit pinched into touching loops."""
    from shellrepair.mesh.index import ScanContext

    out = []
    V, F = shapes.bumpy_sphere(3, amplitude=0.03, frequency=4)
    for radius, n, seed in ((0.05, 40, 3), (0.2, 12, 4)):
        V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=n, radius=radius, seed=seed)
        out.append((V2, F2))
    out.append(torus_inner_band(3)[2:4])
    V, F = shapes.icosphere(4)
    P = V[F].mean(axis=1)
    cut = (np.abs(P[:, 0]) < 0.05) & (P[:, 2] > -0.6) & (np.abs(P[:, 2] + 0.0) > 0.03)   # a slit with a bridge
    out.append(shapes.remove_faces(V, F, cut)[:2])
    res = []
    for V2, F2 in out:
        ctx = ScanContext(Mesh(V=V2, F=F2))
        res.append((ctx, detect_holes(V2, F2)))
    return res


def _loop_sights_reference(V, loops, faces_near, candidates):
    """loop_sights as it was first written: one loop's arcs at a time, every
    sample of every arc looked up in one query."""
    from scipy.spatial import cKDTree

    from shellrepair.fill.bridge import ARC_SAMPLES, ARCS_PER_LOOP, MAX_REACH, SELF_SKIP, SIGHT_SLACK

    sizes = [len(L.vertices) for L in loops]
    owner = np.repeat(np.arange(len(loops)), sizes)
    place = np.concatenate([np.arange(s) for s in sizes])
    edge = np.array([L.mean_edge for L in loops])
    tree = cKDTree(V[np.concatenate([L.vertices for L in loops])])
    out = {}
    for a in candidates:
        loop = loops[a].vertices
        k = len(loop)
        if k < 2 * SELF_SKIP + 2:
            continue
        U, T, N, kap, s0, ok = continuation_arcs(V, faces_near(loop), loop)
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            continue
        if idx.size > ARCS_PER_LOOP:
            idx = idx[np.linspace(0, idx.size - 1, ARCS_PER_LOOP).round().astype(np.int64)]
        reach = MAX_REACH * max(loops[a].diameter, 1e-300)
        turn = np.where(np.abs(kap[idx]) > 0, 2 * np.pi / np.maximum(np.abs(kap[idx]), 1e-300), np.inf)
        length = np.minimum(reach, turn)
        s = s0[idx, None] + length[:, None] * (np.arange(1, ARC_SAMPLES + 1) / ARC_SAMPLES)[None]
        X = arc_points(U[idx], T[idx], N[idx], kap[idx], s)
        tol = (length / ARC_SAMPLES)[:, None] + SIGHT_SLACK * (s - s0[idx, None])
        d, j = tree.query(X.reshape(-1, 3), distance_upper_bound=float(tol.max() + edge.max()))
        d, j = d.reshape(X.shape[:2]), j.reshape(X.shape[:2])
        found = np.isfinite(d)
        jj = np.where(found, j, 0)
        who = owner[jj]
        gap = np.abs(place[jj] - idx[:, None])
        hit = found & (d <= tol + edge[who]) & ~((who == a) & (np.minimum(gap, k - gap) <= SELF_SKIP))
        first = np.where(hit.any(axis=1), np.argmax(hit, axis=1), -1)
        out[a] = (np.bincount(who[np.arange(len(idx)), np.maximum(first, 0)][first >= 0], minlength=len(loops)),
                  len(idx))
    return out


def test_arcs_of_many_loops_at_once_are_those_of_each_loop_alone_to_the_bit():
    # one loop's block of the batch sees no other loop: batched with all the
    # scan's loops, each gets the bits it gets alone (a batch of one)
    from shellrepair.fill.bridge import continuation_arcs_many

    n = 0
    for ctx, scan in _many_loops():
        loops = [L.vertices for L in scan.loops]
        near = [ctx.F[ctx.ring_faces(lp, 3)] for lp in loops]
        for lp, fn, many in zip(loops, near, continuation_arcs_many(ctx.V, near, loops)):
            for x, y in zip(continuation_arcs(ctx.V, fn, lp), many):
                assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()
            n += 1
    assert n >= 40


def test_sights_stop_each_arc_at_its_first_landing_with_the_same_counts():
    for ctx, scan in _many_loops():
        fn = lambda lp: ctx.F[ctx.ring_faces(lp, 3)]   # noqa: E731
        want = _loop_sights_reference(ctx.V, scan.loops, fn, range(len(scan.loops)))
        got = loop_sights(ctx.V, scan.loops, fn)
        assert sorted(got) == sorted(want)
        for a in want:
            assert np.array_equal(got[a][0], want[a][0]) and got[a][1] == want[a][1]


def test_loops_left_out_of_the_band_search_land_on_no_loop_they_could_pair_with(monkeypatch):
    """bands.loops_with_partner drops only loops whose arcs cannot land on a hole
    they do not touch (checked by following them), and the pairs found
    are those found without it."""
    from shellrepair.fill import bands

    dropped = 0
    for ctx, scan in _many_loops():
        loops = scan.loops
        hole = np.array([L.kind == "hole" for L in loops])
        cand = list(np.flatnonzero(hole))
        kept = set(bands.loops_with_partner(ctx, loops, cand, hole))
        out = [a for a in cand if a not in kept]
        dropped += len(out)
        sights = _loop_sights_reference(ctx.V, loops, lambda lp: ctx.F[ctx.ring_faces(lp, 3)], out)
        for a, (counts, _) in sights.items():
            for b in np.flatnonzero(counts):
                assert b == a or not hole[b] or np.intersect1d(loops[a].vertices, loops[b].vertices).size
        with_filter = [(b.A.id, b.B.id, b.score) for b in bands.find_bands(ctx, scan).pairs]
        monkeypatch.setattr(bands, "loops_with_partner", lambda ctx, loops, cand, hole, touching=None: cand)
        without = [(b.A.id, b.B.id, b.score) for b in bands.find_bands(ctx, scan).pairs]
        monkeypatch.undo()
        assert with_filter == without
    assert dropped >= 1


# --------------------------------------------------------------------------
# two holes whose caps cross each other
# --------------------------------------------------------------------------
def test_holes_whose_caps_cross_each_other_are_joined_by_a_tube(monkeypatch):
    """The torus's inner band with the arcs' pairing taken away: each loop
    is filled alone, the two caps cross (both span the torus's hole), so the
    pair is filled as a band after all, and the tube keeps the genus."""
    import shellrepair.repair as rp

    monkeypatch.setattr(rp, "find_bands", lambda ctx, scan: rp.Bands([], []))
    V, F, V2, F2, _ = torus_inner_band(3)
    M = Mesh(V=V2, F=F2)
    R, rep = repair_mesh(M)
    assert [(b["chosen"], b["reason"].split(";")[0]) for b in rep["bridges"]] == [
        ("tube", "the two holes' caps cross each other")]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 0
    assert filled_rms_permille(V, F, R) < 5.0


@pytest.mark.slow
def test_a_fat_torus_seen_from_a_ring_keeps_its_genus():
    """Stress case s86420-04 (torus r/R = 0.7, 4 views): two coaxial loops
    on the inner side send half their arcs to each other and half to
    themselves, so the arcs pair nothing; each cap crosses the other. At
    e950432 loop 1 stayed open (its refill around loop 0's cap ran out of
    budget); now the two are one tube."""
    from conftest import STRESS_SHAPES
    from eval import stress

    c = stress.stress_case(4, 86420, shapes_ok=STRESS_SHAPES)
    assert "torus-0.7" in c.name
    M = Mesh(V=c.V, F=c.F)
    R, rep = repair_mesh(M)
    assert [sorted(b["loops"]) for b in rep["bridges"] if b["chosen"] == "tube"] == [[0, 1]]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == 0


@pytest.mark.parametrize("kind, ratio", [
    ("inner", 3), ("ring", 3), ("ring", 5),
    pytest.param("inner", 5, marks=pytest.mark.xfail(strict=True, reason=(
        "the test bands rank the held tube (0.00087) just ahead of order 3 (0.00098); "
        "on the real band order 3 is truer (0.127 against 0.279 per mille)")))])
@pytest.mark.slow
def test_a_tubes_default_is_as_true_as_its_best_forced_order(kind, ratio):
    """The tube's order, and whether it is held on its arcs or faired, come
    from test bands of the tube's own kind cut beside its loops; where the
    band is too long for one to fit, the scan cannot tell and the default
    order's held-or-faired energy decides. Either way the default lies
    within 10 % of the best forced order (an issue's torus seen from a
    ring of views had 68.2 per mille by default against 1.08 at order 3)."""
    V, F, V2, F2 = torus_inner_band(ratio)[:4] if kind == "inner" else torus_seen_from_a_ring(ratio)
    M = Mesh(V=V2, F=F2)
    rms = {}
    for o in (1, 2, 3, "auto"):
        R, rep = repair_mesh(M, order=o)
        assert rep["holes_after"] == 0
        rms[o] = filled_rms_permille(V, F, R)
    assert "auto: " in rep["holes"][0]["option"]
    assert rms["auto"] <= 1.1 * min(rms[1], rms[2], rms[3]), rms


@pytest.mark.parametrize("shape", ["torus-0.5", "genus2"])
def test_a_tube_between_ragged_rims_is_as_true_as_its_best_forced_order(shape):
    """A scanner's ragged fringe on both loops (noise along the normal of
    0.1 edge, :func:`eval.stress.ragged_rims`) is carried across the whole
    band by a faired tube; the test bands, cut through clean scan, are
    given the real loops' noise, so they rank the orders as the real band
    does. Before, they ranked order 3 first on this torus band (3.18 per
    mille, where order 2 gives 1.22) and the faired order 3 or the held
    tube on this genus-2 arm (1.82 against 1.14)."""
    from eval import stress
    from shellrepair.repair import repair_mesh

    case = stress.stress_case(2, 5, quick=True, family="band", shape=shape, ragged=0.1)
    facts = stress.input_facts(case)
    M = Mesh(V=case.V, F=case.F)
    rms = {}
    for o in (1, 2, 3, "auto"):
        R, rep = repair_mesh(M, order=o)
        m = stress.measure(case, facts, R.V, R.F)
        assert m["holes_closed"] == m["holes"] == 2
        rms[o] = m["rms_permille"]
    assert "test bands" in rep["holes"][0]["option"]
    assert rms["auto"] <= 1.05 * min(rms[1], rms[2], rms[3]), rms


@pytest.mark.parametrize("seed, index, family", [(751, 7, "band"), (993128398, 11, None)])
def test_the_loops_of_a_band_with_ragged_rims_see_each_other_both_ways(seed, index, family):
    """A scanner's ragged fringe (noise of 0.1 edge along the normal) makes
    the curvature read at one rim vertex scatter by about the tube's own;
    each arc that pairs the loops now reads the rim between its
    neighbours' arcs. A torus's cut band (development seed 751, case 7) and
    a torus whose inner band no view saw (seed 993128398, case 11): their
    two loops see each other both ways, as their clean twins' do, and the
    band is filled by a tube. Before, the first pair was found one way only
    (37.8 per mille, order 2's tube 4.6) and the second not at all (two caps
    60.6 per mille from the truth, the tube 7.7)."""
    from eval import stress
    from shellrepair.fill.bands import find_bands
    from shellrepair.mesh.index import ScanContext

    case = stress.stress_case(index, seed, family=family, ragged=0.1)
    scan = detect_holes(case.V, case.F)
    assert len(scan.holes) == 2
    pairs = find_bands(ScanContext(Mesh(V=case.V, F=case.F)), scan).pairs
    assert [(p.A.id, p.B.id, p.mutual) for p in pairs] == [(0, 1, True)]
    R, rep = repair_mesh(Mesh(V=case.V, F=case.F))
    assert [h["kind"] for h in rep["holes"]] == ["tube", "tube"]
    facts = stress.input_facts(case)
    m = stress.measure(case, facts, R.V, R.F)
    assert m["holes_closed"] == 2 and m["rms_permille"] < 10.0


@pytest.mark.slow
def test_a_tube_with_no_room_for_test_bands_is_faired_at_the_order_test_holes_beside_its_loops_choose():
    """A fat torus whose inner band no view saw (eval's stress case 14 of
    development seed 733): no test band fits beside the loops; order 2's
    energies keep the faired tube, which took order 2 (21.8 per mille)
    before; the test holes beside the loops choose order 3 (10.1). (Where
    the energies hold the tube on its arcs, as on the torus seen from a
    ring above, it stays held.)"""
    from eval import stress

    case = stress.stress_case(14, 733)
    facts = stress.input_facts(case)
    M = Mesh(V=case.V, F=case.F)
    R, rep = repair_mesh(M)
    tube = next(h for h in rep["holes"] if h["reason"].startswith("tube"))
    assert "no test band fits" in tube["reason"] and "test holes beside them, 3" in tube["reason"]
    assert "faired order 3" in tube["reason"]
    auto = stress.measure(case, facts, R.V, R.F)["rms_permille"]
    R2, _ = repair_mesh(M, order=2)
    assert auto < 0.6 * stress.measure(case, facts, R2.V, R2.F)["rms_permille"]


def test_a_tube_that_fails_its_checks_at_its_order_is_faired_again_on_the_harmonic_tube():
    """A torus r/R = 0.5 whose underside a scanner missed (development seed
    739, case 2 of the scanner-hard family): the order-2 tube crosses the
    scan at a spike of a rim, and the harmonic tube it fell back on ran
    straight across the missing arc of the torus's section (51.5 per mille
    at every order). That tube's mesh is now faired again at order 2, held
    on the harmonic tube only around the faults: four times closer to the
    truth, still closed and clean."""
    from eval import stress

    case = stress.stress_case(2, 739, family="scanner-hard", shape="torus-0.5")
    facts = stress.input_facts(case)
    M = Mesh(V=case.V, F=case.F)
    rms = {}
    for o in (1, 2):
        R, rep = repair_mesh(M, order=o)
        assert_closed_and_clean(M, R, rep)
        rms[o] = stress.measure(case, facts, R.V, R.F)["rms_permille"]
        tube = next(h for h in rep["holes"] if h["reason"].startswith("tube"))
        assert ("faired again at order 2 on its mesh" in tube["reason"]) == (o == 2)
    assert rms[2] < 0.5 * rms[1], rms


@pytest.mark.slow
def test_one_test_band_is_not_enough_evidence_for_a_tube():
    """A torus seen from a ring of views, its inner band unseen (case 7 of
    seed 1538843172): only the band beside one loop can be cut, and it
    rated orders 2 and 3 alike (0.041 and 0.043) where order 3 is six times
    truer on the real band. One band alone does not decide (band_test.MIN_BANDS):
    the tube goes the way of a tube with no test band, faired at the order
    the test holes beside its loops choose."""
    from eval import stress
    from shellrepair.fill.band_test import MIN_BANDS

    assert MIN_BANDS == 2
    case = stress.stress_case(7, 1538843172)
    if case.name != "s1538843172-07-scanner-hard-torus-0.3":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    auto, forced, rep = auto_and_forced_rms(case, 3)
    tube = next(h for h in rep["holes"] if h["reason"].startswith("tube"))
    assert "1 test band beside the loops, fewer than 2" in tube["reason"] and "faired order 3" in tube["reason"]
    assert auto <= 1.05 * forced


def test_one_test_band_decides_where_no_test_hole_beside_tells(monkeypatch):
    """Where one test band fits and no test hole beside the loops does, the
    band's verdict is taken (as a hole whose scales give one test hole takes
    it), not the default order."""
    from shellrepair.fill import band_test, selftest
    from shellrepair.fill.hole import band_order

    monkeypatch.setattr(band_test, "tube_errors", lambda ctx, A, B, cands: ({1: 0.06, 2: 0.011, 3: 0.0008}, 1))
    monkeypatch.setattr(selftest, "choose_order_beside",
                        lambda ctx, loops: selftest.OrderTest(selftest.DEFAULT_ORDER, why="no test hole fits"))
    order, held, note, refair = band_order(None, ("A", "B"))
    assert (order, held, refair) == (3, None, None)
    assert "by 1 test band" in note and "order 3 0.0008" in note
    # where a test hole beside does tell, one band still does not decide
    told = selftest.OrderTest(3, errors={1: 0.1, 2: 0.02, 3: 0.01}, probes=3, scale=1.0)
    monkeypatch.setattr(selftest, "choose_order_beside", lambda ctx, loops: told)
    order, held, note, refair = band_order(None, ("A", "B"))
    assert order == selftest.DEFAULT_ORDER and refair == 3


def test_one_test_band_is_pooled_with_the_test_holes_beside_the_loops(monkeypatch):
    """With one test band and test holes beside the loops, every test
    weighs alike: a band that tells the orders far apart outweighs test
    holes that rate them alike (a star's band: the test holes alone took
    order 2 where order 3 is 7x truer), and a band that rates them alike
    leaves the verdict to the test holes."""
    from shellrepair.fill import band_test, selftest
    from shellrepair.fill.hole import band_order, pooled_with_band

    alike = selftest.OrderTest(2, errors={1: 0.0088, 2: 0.00171, 3: 0.00173}, probes=5, scale=1.0)
    telling = {1: 0.0497, 2: 0.0068, 3: 0.00098}
    pooled = pooled_with_band(telling, alike)
    assert pooled.order == 3 and pooled.probes == 6
    assert pooled.errors[2] == pytest.approx((0.0068 * 0.00171 ** 5) ** (1 / 6))
    monkeypatch.setattr(band_test, "tube_errors", lambda ctx, A, B, cands: (telling, 1))
    monkeypatch.setattr(selftest, "choose_order_beside", lambda ctx, loops: alike)
    order, held, note, refair = band_order(None, ("A", "B"))
    assert (order, held, refair) == (selftest.DEFAULT_ORDER, None, 3)
    assert "pooled with the test band" in note
    # a band rating orders 2 and 3 alike: the test holes' clear verdict stands
    clear = selftest.OrderTest(3, errors={1: 0.1, 2: 0.02, 3: 0.01}, probes=3, scale=1.0)
    assert pooled_with_band({1: 0.2, 2: 0.041, 3: 0.043}, clear).order == 3
    # and a band that does not judge a candidate leaves it out
    assert set(pooled_with_band({2: 0.01, 3: 0.02}, clear).errors) == {2, 3}
    # a band its refill restores exactly (RMS 0) wins, without a log of 0
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exact = pooled_with_band({1: 0.0, 2: 0.01, 3: 0.02}, clear)
    assert exact.order == 1 and np.isfinite(list(exact.errors.values())).all()


@pytest.mark.slow
def test_a_thin_torus_band_seen_by_one_test_band_gets_its_order():
    """A thin torus (r/R 0.15) whose unseen band is one tube (case 15 of
    design seed 14): one test band fits, rating order 3 4x truer than order
    2, and no test hole fits beside the loops; order 2 by default gave 12.2
    per mille, order 3 1.20."""
    from eval import stress

    case = stress.stress_case(15, 14)
    if case.name != "s14-15-scanner-hard-torus-0.15":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    auto, forced, rep = auto_and_forced_rms(case, 3)
    tube = next(h for h in rep["holes"] if h["reason"].startswith("tube"))
    assert "by 1 test band" in tube["reason"]
    assert "faired order 3" in tube["reason"] or "faired (order 3)" in tube["reason"]
    assert auto <= 1.05 * forced


def test_a_test_band_measured_at_every_kth_removed_vertex_ranks_as_the_whole_band(monkeypatch):
    """A test band's removed scan is measured at ``band_test.TUBE_MEASURE_POINTS``
    of its vertices at most (a test tube far from its band made each
    measure visit every triangle): on a torus's unseen inner band, measured
    at every vertex or at a few hundred, the candidates rank alike."""
    from shellrepair.fill import band_test
    from shellrepair.mesh.index import ScanContext

    V, F, V2, F2 = torus_inner_band(3)[:4]
    scan = detect_holes(V2, F2)
    ctx = ScanContext(Mesh(V=V2, F=F2))
    ctx.know_loops(scan.loops)
    A, B = sorted(scan.holes, key=lambda L: -L.edges)[:2]
    got = []
    for most in (10 ** 9, 300):
        monkeypatch.setattr(band_test, "TUBE_MEASURE_POINTS", most)
        errs, n = band_test.tube_errors(ctx, A, B, (1, 2, 3, band_test.HELD))
        got.append((n, sorted(errs, key=errs.get, reverse=False), errs))
    assert got[0][0] == got[1][0] == 2
    assert got[0][1] == got[1][1] and got[0][2] != got[1][2]


@pytest.mark.slow
def test_the_caps_of_a_pair_take_their_own_order_test(monkeypatch):
    """Two loops on a torus seen by a scanner (case 0 of validation seed
    134226128) whose tubes from the arcs all fail. Without the seam (below)
    they are filled as caps, and each cap is filled as the hole would be
    alone, its order chosen by its own test holes (the 484-edge cap took
    the tube's default order 2 before, where its test chose order 3)."""
    from eval import stress
    from shellrepair.fill import band_fill

    case = stress.stress_case(0, 134226128)
    if case.name != "s134226128-00-scanner-torus-0.7":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    monkeypatch.setattr(band_fill, "SEAM", False)
    R, rep = repair_mesh(Mesh(V=case.V, F=case.F))
    cap = next(h for h in rep["holes"] if h["id"] == 0)
    assert cap["status"] == "filled" and cap["choice"]["by"] == "test holes"
    assert f"faired order {cap['choice']['order']} (auto: order" in cap["reason"]


@pytest.mark.slow
def test_a_scanned_torus_band_no_tube_closes_keeps_its_genus_through_a_seam():
    """The same pair with the seam: the band cut open between the loops'
    nearest vertices and filled as one hole keeps the torus's genus and
    lies 0.58 per mille from the truth, where the caps lay 8.12 (genus 0)."""
    from eval import stress

    case = stress.stress_case(0, 134226128)
    if case.name != "s134226128-00-scanner-torus-0.7":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    R, rep = repair_mesh(Mesh(V=case.V, F=case.F))
    assert any(h["kind"] == "tube" and "cut open along a seam" in h["option"] for h in rep["holes"]
               if h["status"] == "filled")
    m = stress.measure(case, stress.input_facts(case), R.V, R.F)
    assert m["holes_closed"] == m["holes"] and m["topology_ok"] and m["si_added"] == 0
    assert m["rms_permille"] < 1.0


def test_each_filled_row_names_its_patch_kind_and_the_table_counts_them():
    """The report's rows say what filled each loop as data, not only as a
    sentence: ``kind`` (one of shellrepair.fill.patch.KINDS) and the
    fairing ``order``; both loops of a band joined by one tube say "tube",
    and the table's "filled by" line counts the kinds."""
    from shellrepair.fill.patch import KINDS
    from shellrepair.report.table import table1_text

    _, _, V2, F2, _ = torus_inner_band(3)
    R, rep = repair_mesh(Mesh(V=V2, F=F2), order=2)
    filled = [h for h in rep["holes"] if h["status"] == "filled"]
    assert len(filled) == 2 and all(h["kind"] in KINDS for h in filled)
    assert [h["kind"] for h in filled] == ["tube", "tube"]
    assert all(h["order"] == 2 for h in filled)
    line = next(x for x in table1_text(rep).splitlines() if x.strip().startswith("filled by:"))
    assert line.split(":", 1)[1].strip() == "tube ×2"


@pytest.mark.slow
def test_a_band_left_to_its_caps_says_why_it_has_no_tube():
    """Where the loops' continuation arcs give no tube to start from and
    the caps pass, the band is capped and its record says so. Before, two
    such bands of a ragged scanner occlusion on a Nefertiti (stress seed
    524575295, case 8: 1335 loops) read "tube failed: " and nothing else."""
    from eval import stress

    case = stress.stress_case(8, 524575295, ragged=0.1)
    if case.name != "s524575295-08-scanner-nefertiti-ragged0.1":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    _, rep = repair_mesh(Mesh(V=case.V, F=case.F))
    failed = [b for b in rep["bridges"] if b["reason"].startswith("tube failed")]
    assert failed
    assert all(b["reason"] != "tube failed: " and b["chosen"] == "caps" for b in failed)
    assert any("gave no tube to start from" in b["reason"] for b in failed)


@pytest.mark.slow
def test_a_ragged_band_no_tube_closes_is_cut_open_along_a_seam_and_filled_as_one_hole():
    """A fat torus 29 % unseen by a scanner (stress seed 524575295, case 6):
    one missing annulus between loops of 649 and 374 edges that wander
    round the whole section. Every tube zipped between them ran into the
    scan, and the band was capped: 34.9 per mille from the truth, genus 0
    where the truth has genus 1. Cut open along a seam between the loops'
    nearest vertices and filled as one hole, it keeps the genus and comes
    within 5 per mille, with nothing crossed and no scan vertex moved."""
    from eval import stress
    from shellrepair.fill.band_fill import seam_loop
    from shellrepair.mesh.index import ScanContext

    case = stress.stress_case(6, 524575295)
    if case.name != "s524575295-06-scanner-hard-torus-0.5":    # the draw depends on the shapes at hand
        pytest.skip(f"drew {case.name} without ../shared's scans")
    scan = detect_holes(case.V, case.F)
    A, B = sorted((L for L in scan.holes if len(L.vertices) > 300), key=lambda L: -len(L.vertices))
    loop = seam_loop(ScanContext(Mesh(V=case.V, F=case.F)), A, B)
    assert len(loop) == len(A.vertices) + len(B.vertices) + 2
    assert sorted(set(loop.tolist())) == sorted(set(A.vertices) | set(B.vertices))
    R, rep = repair_mesh(Mesh(V=case.V, F=case.F))
    band = next(h for h in rep["holes"] if h["id"] == A.id)
    assert band["kind"] == "tube" and "cut open along a seam" in band["option"]
    facts = stress.input_facts(case)
    m = stress.measure(case, facts, R.V, R.F)
    assert m["holes_closed"] == m["holes"] and m["topology_ok"]
    assert m["si_added"] == 0 and m["orig_changed"] == 0
    assert m["rms_permille"] < 5.0
