"""Openings no triangulation of their rim can close get vertices of their own.

Where the scan crosses an opening's plane inside it (a blind bore from
below rising through a box's missing top; a gear tooth split off the body
it stood on, whose opening lies on the body's wall), every triangulation of
the rim's own vertices crosses the scan. The last layer
(:mod:`shellrepair.fill.steiner`) closes such an opening with Steiner points
lifted over what crosses it: every ``hole`` loop filled, no crossing added
(exact count), original vertices bit-identical, flat where nothing is under
the patch.
"""

import numpy as np
import pytest

import cad_parts as cp
from shellrepair import Mesh, detect_holes
from shellrepair.mesh.index import ScanContext
from shellrepair.mesh.intersect import self_intersections
from shellrepair.repair import repair_mesh
from shellrepair.report.table import table1_text
from shellrepair.fill.steiner import LIFT, steiner_patch
from shellrepair.mesh.topology import edge_topology


def _repair_closes(V, F, **kw):
    """Repair; assert every loop (all classed ``hole``) closed, nothing
    crossed, the originals kept bit for bit. Returns (repaired, report,
    loops)."""
    scan = detect_holes(V, F, closed=kw.get("closed"))
    assert scan.loops and all(L.kind == "hole" for L in scan.loops), [L.reason for L in scan.loops]
    si = self_intersections(V, F)
    R, report = repair_mesh(Mesh(V=V, F=F), **kw)
    rows = report["holes"]
    assert [r["status"] for r in rows] == ["filled"] * len(scan.loops), [r["reason"] for r in rows]
    assert edge_topology(R.F, len(R.V)).n_boundary_edges == 0
    assert np.array_equal(R.V[:len(V)].view(np.uint64), V.view(np.uint64))
    assert np.array_equal(R.F[:len(F)], F)
    assert self_intersections(R.V, R.F) == si
    return R, report, scan.loops


def _new_vertices(R, n, rows):
    """Each row's new vertices (appended in hole order)."""
    out, start = {}, n
    for row in sorted(rows, key=lambda r: r["id"]):
        out[row["id"]] = R.V[start:start + row["new_vertices"]]
        start += row["new_vertices"]
    assert start == len(R.V)
    return out


def test_the_new_parts_are_what_they_say():
    # the bore part: open at its top only, its bore rising through that plane
    V, F, g = cp.box_with_bore_through_top(rise=0.5)
    topo = edge_topology(F, len(V))
    assert topo.nonmanifold_edges.shape[0] == 0 and self_intersections(V, F) == 0
    assert topo.n_boundary_edges == 8
    assert V[F[g["bore_end"]]][:, :, 2].min() == 1.5
    # the pocket with a pin: closed once its bottom is gone, nothing crossing
    V, F, g = cp.plate_with_shaped_pocket(cp.octagon_with_rib(), pin=(1.6, 2.3, 0.25, 0.8))
    V, F = cp.remove(V, F, g["pocket_bottom"])
    topo = edge_topology(F, len(V))
    assert topo.nonmanifold_edges.shape[0] == 0 and self_intersections(V, F) == 0
    assert topo.n_boundary_edges == len(cp.octagon_with_rib())
    # the gear: body and teeth closed or open where they touch, nothing crossing
    V, F, g = cp.gear_split_teeth(teeth=6)
    topo = edge_topology(F, len(V))
    assert topo.n_boundary_edges == 6 * 4 and topo.nonmanifold_edges.shape[0] == 0
    assert self_intersections(V, F) == 0


def test_a_box_top_crossed_by_a_bore_closes_over_it():
    # today's rim-only layers: "48 scan faces cross the opening's own plane
    # inside it, so no flat triangulation avoids them"
    V, F, g = cp.box_with_bore_through_top(rise=0.5)
    R, report, loops = _repair_closes(V, F, closed=True)
    row = report["holes"][0]
    assert row["option"].startswith("Steiner points")
    new = _new_vertices(R, len(V), report["holes"])[0]
    # over the bore's axis the patch passes above its end (z = 1.5) ...
    Fn = R.F[len(F):]
    A, B, C = (R.V[Fn[:, i]] for i in range(3))
    p = np.array([2.0, 1.5])

    def cross2(a, b):
        return (a[:, 0] - p[0]) * (b[:, 1] - p[1]) - (a[:, 1] - p[1]) * (b[:, 0] - p[0])

    w = np.column_stack([cross2(B, C), cross2(C, A), cross2(A, B)])
    over = (np.all(w >= 0, axis=1) | np.all(w <= 0, axis=1)) & (np.abs(w).sum(axis=1) > 0)
    assert over.any()
    z = (w[over] / w[over].sum(axis=1, keepdims=True) * np.column_stack([A[over, 2], B[over, 2], C[over, 2]])).sum(1)
    assert z.min() > 1.5
    # ... and the rest of it lies on the top's plane, or above it by more
    # than the bore's rise (a plateau, no slope grazing the rim's walls)
    rise = new[:, 2] - 1.0
    assert np.all((np.abs(rise) <= 1e-9 * 5) | (rise > 0.5))
    assert (np.abs(rise) <= 1e-9 * 5).any()
    # the patch faces out of the box, like the walls
    n = np.cross(R.V[Fn[:, 1]] - R.V[Fn[:, 0]], R.V[Fn[:, 2]] - R.V[Fn[:, 0]]).sum(axis=0)
    assert n[2] > 0


def test_a_bore_close_to_the_walls_closes_over_it():
    # the bore 0.15 from two walls: the triangles at the rim (whose rim
    # corners cannot be raised) must be thin enough to pass beside it
    V, F, g = cp.box_with_bore_through_top(radius=0.4, at=(0.55, 0.55))
    R, report, loops = _repair_closes(V, F, closed=True)
    assert report["holes"][0]["option"].startswith("Steiner points")
    new = _new_vertices(R, len(V), report["holes"])[0]
    assert new[:, 2].max() > 1.5 and (np.abs(new[:, 2] - 1.0) <= 1e-9 * 5).any()


def test_an_octagonal_pocket_with_a_rib_and_a_pin_through_its_missing_bottom_closes():
    # the pocket's outline is notched by a rib; a blind bore from below
    # rises 0.3 through the plane of the pocket's missing bottom
    V, F, g = cp.plate_with_shaped_pocket(cp.octagon_with_rib(), pin=(1.6, 2.3, 0.25, 0.8))
    V, F = cp.remove(V, F, g["pocket_bottom"])
    R, report, loops = _repair_closes(V, F)
    assert report["holes"][0]["option"].startswith("Steiner points")
    new = _new_vertices(R, len(V), report["holes"])[0]
    on_plane = np.abs(new[:, 2] - 0.5) <= 1e-9 * 3
    assert on_plane.any() and new[:, 2].max() > 0.8
    # what is not on the bottom's plane stands over the pin's end, near it
    assert np.all(np.hypot(new[~on_plane, 0] - 1.6, new[~on_plane, 1] - 2.3) < 1.0)


@pytest.mark.parametrize("teeth", [4, 11])
def test_gear_teeth_split_off_their_body_close(teeth):
    # each tooth is open where it stood on the body: its opening lies on the
    # body's wall (coplanar scan over all of it), so no flat patch avoids it
    V, F, g = cp.gear_split_teeth(teeth=teeth)
    R, report, loops = _repair_closes(V, F)
    new = _new_vertices(R, len(V), report["holes"])
    for row in report["holes"]:
        assert row["option"].startswith("Steiner points"), row["option"]
        P = V[loops[row["id"]].vertices]
        c = P.mean(axis=0)
        normal = np.linalg.svd(P - c)[2][-1]
        diameter = float(np.ptp(P, axis=0).max())
        off = np.abs((new[row["id"]] - c) @ normal)
        # lifted off the wall by the layer's own margin, no more: nearly flat
        assert off.size and off.min() > 0 and off.max() <= 1.01 * LIFT * diameter


def test_the_same_part_gives_the_same_bytes_with_any_jobs():
    V, F, g = cp.gear_split_teeth(teeth=6)
    R1, rep1 = repair_mesh(Mesh(V=V, F=F), jobs=1)
    R2, rep2 = repair_mesh(Mesh(V=V, F=F), jobs=2)
    R3, _ = repair_mesh(Mesh(V=V, F=F), jobs=1)
    assert all(r["option"].startswith("Steiner points") for r in rep1["holes"])
    assert R1.V.tobytes() == R2.V.tobytes() == R3.V.tobytes()
    assert R1.F.tobytes() == R2.F.tobytes() == R3.F.tobytes()


def test_a_loop_the_layer_cannot_close_in_its_budget_says_why():
    V, F, g = cp.box_with_bore_through_top()
    loop = detect_holes(V, F, closed=True).loops[0].vertices
    ctx = ScanContext(Mesh(V=V, F=F))
    res = steiner_patch(ctx, 0, loop, max_vertices=0)
    assert res.patch is None and "work budget" in res.reason
    assert res.over_budget and not res.degenerate      # the same, as data
    res = steiner_patch(ctx, 0, loop)
    assert res.patch is not None and res.spent >= len(res.patch.P) > 0 and not res.over_budget


def test_a_loop_with_no_extent_is_told_apart_from_one_that_crosses():
    V, F, g = cp.box_with_bore_through_top()
    ctx = ScanContext(Mesh(V=V, F=F))
    res = steiner_patch(ctx, 0, np.array([0, 1], np.int64))
    assert res.patch is None and res.degenerate and not res.over_budget


def test_a_rounds_refinement_stops_exactly_where_the_round_is_over_the_work_budget():
    # a round's patch is a disc: k rim vertices and n new ones make
    # k + 2n - 2 triangles; the round is over the budget where its two
    # sides' checks would spend 2n > budget - spent. The refinement stops
    # past round_faces triangles, so it stops only where the round would
    # be refused anyway, and a round it lets through is refined as before
    from shellrepair.fill.refine import MAX_PATCH_FACES
    from shellrepair.fill.steiner import round_faces

    for k in (3, 4, 8, 57, 400):
        for budget in (0, 1, 2, 7, 100, 25_090, 37_000):
            for spent in (0, 1, 5, 99, 30_000):
                cap = round_faces(k, budget, spent)
                n = np.arange(40_000)
                stopped = k + 2 * n - 2 > cap
                over = spent + 2 * n > budget
                assert (over[stopped]).all(), (k, budget, spent)
                if cap < MAX_PATCH_FACES:
                    assert np.array_equal(stopped, over), (k, budget, spent)
    assert round_faces(8, None, 0) == round_faces(8, 10 ** 9, 0) == MAX_PATCH_FACES


def test_a_patch_is_lifted_over_the_same_faces_whichever_it_reaches_first():
    # faces are paired with the patch's triangles as the patch rises to
    # them; lifting with every face paired at once gives the same heights
    from shellrepair.fill.steiner import LIFT_PASSES, lift_heights, overlapping_triangles

    rng = np.random.default_rng(5)
    for trial in range(20):
        X = rng.uniform(-1, 1, (40, 2))
        from scipy.spatial import Delaunay
        T = Delaunay(X).simplices.astype(np.int64)
        k = 6
        base = rng.uniform(-0.05, 0.05, len(X))
        m = 300
        c = rng.uniform(-1.2, 1.2, (m, 1, 2))
        xy = c + rng.uniform(-0.2, 0.2, (m, 3, 2))
        lo = rng.uniform(-0.5, 2.0, m) * rng.choice([0.1, 1.0], m)
        hmin, hmax = lo, lo + rng.uniform(0, 0.3, m)
        for side in (("out of", 1.0), ("into", -1.0)):
            got = lift_heights(X, T, base, (xy, hmin, hmax), side, k)
            # every face paired at once: the lift as it was written first
            sign = side[1]
            fmin, fmax = (hmin, hmax) if sign > 0 else (-hmax, -hmin)
            g = sign * base
            near = np.flatnonzero(fmax >= g.min() - 1e-9)
            pt, pf = overlapping_triangles(X[T], xy[near])
            pf = near[pf]
            rim = np.arange(len(X)) < k
            for _ in range(LIFT_PASSES):
                if not pt.size:
                    break
                gc = g[T]
                meet = (fmin[pf] <= gc.max(axis=1)[pt]) & (fmax[pf] >= gc.min(axis=1)[pt])
                need = np.full(len(T), -np.inf)
                np.maximum.at(need, pt[meet], fmax[pf[meet]] + LIFT)
                corner = np.full(len(X), -np.inf)
                np.maximum.at(corner, T.ravel(), np.repeat(need, 3))
                raised = ~rim & (corner > g)
                if not raised.any():
                    break
                g = np.where(raised, corner, g)
            assert got.tobytes() == (sign * g).tobytes(), trial


@pytest.mark.parametrize("where", ["rotated, 1e6 off the origin", "scaled by 1e-6", "scaled by 1e6"])
def test_the_bore_closes_at_any_place_and_scale(where):
    from scipy.spatial.transform import Rotation

    V, F, g = cp.box_with_bore_through_top()
    rot = Rotation.from_euler("xyz", [0.3, 0.7, 1.1]).as_matrix()
    V = {"rotated, 1e6 off the origin": V @ rot.T + 1e6, "scaled by 1e-6": V * 1e-6,
         "scaled by 1e6": V * 1e6}[where]
    R, report, loops = _repair_closes(V, F, closed=True)
    assert report["holes"][0]["option"].startswith("Steiner points")


def test_an_opening_linked_with_a_ring_stays_open_and_says_why():
    # every surface the rim bounds crosses a ring linked with it: the
    # Steiner layer tries, fails, and the hole stays open (the report says
    # what each plane and side met); nothing is added that crosses
    V, F = cp.cup_with_linked_ring()
    si = self_intersections(V, F)
    R, report = repair_mesh(Mesh(V=V, F=F), fill_borders=True, bridge="never")
    row = [r for r in report["holes"] if r["edges"] == 32][0]
    assert row["status"] == "failed"
    assert "last layer: Steiner points" in row["reason"] and "cross the scan" in row["reason"]
    assert row["failure"] == "no patch passes"        # the same, as data
    assert all("failure" not in r for r in report["holes"] if r["status"] != "failed")
    assert "failed because: no patch passes ×1" in table1_text(report)
    assert self_intersections(R.V, R.F) == si


def _outline_simple_along(P, d):
    """Is the closed polygon ``P`` (k,3), seen along ``d``, simple (no two
    non-adjacent edges meet, no two vertices at one point)?"""
    u = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    Q = np.column_stack([P @ u, P @ v])
    k = len(Q)

    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    for i in range(k):
        a, b = Q[i], Q[(i + 1) % k]
        for j in range(i + 1, k):
            c, e = Q[j], Q[(j + 1) % k]
            if j == i + 1 or (i == 0 and j == k - 1):
                continue
            o1, o2, o3, o4 = orient(a, b, c), orient(a, b, e), orient(c, e, a), orient(c, e, b)
            if o1 * o2 <= 0 and o3 * o4 <= 0:
                return False
    return True


def _rim_triangulation_exists(V, F, loop):
    """Is there any triangulation of the loop's own vertices (k - 2
    triangles over the polygon, every one of them) whose triangles each
    avoid the scan? Each of the C(k, 3) triangles is tested against every
    scan face by the exact crossing test; then the polygon's triangulations are
    searched by intervals (a triangulation of i..j uses one triangle
    (i, m, j) and triangulations of i..m and m..j)."""
    from shellrepair.mesh.intersect import pair_intersections

    k = len(loop)
    tris = np.array([(i, m, j) for i in range(k) for m in range(i + 1, k) for j in range(m + 1, k)], np.int64)
    ids = loop[tris]
    a, b = np.repeat(np.arange(len(tris)), len(F)), np.tile(np.arange(len(F)), len(tris))
    hit = pair_intersections(V[ids[a]], ids[a], V[F[b]], F[b]).reshape(len(tris), len(F)).any(axis=1)
    ok = {tuple(t): not h for t, h in zip(tris.tolist(), hit)}
    can = {}
    for span in range(1, k):
        for i in range(k - span):
            j = i + span
            can[i, j] = span == 1 or any(ok[i, m, j] and can[i, m] and can[m, j] for m in range(i + 1, j))
    return can[0, k - 1]


#: Windows round the pipe: (faces cut, as built or moved)
WINDOWS = {"270 degrees": ((6, 7, 0, 1, 2, 3), "as built"),
           "270 degrees, rotated, 1e6 off the origin": ((6, 7, 0, 1, 2, 3), "moved"),
           "225 degrees, the bore beside a chord's best places": ((6, 7, 0, 1, 2), "as built"),
           "315 degrees, the bore at its end": ((2, 3, 4, 5, 6, 7, 0), "as built")}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n.startswith("315") else n
                                  for n in WINDOWS])
def test_an_opening_wrapped_round_a_pipe_over_a_bore_closes_in_pieces(name):
    # a window cut 225 to 315 degrees round an octagonal pipe's wall, a
    # blind bore from the pipe's cavity running out through it: the
    # window's outline folds over itself seen along any direction (no plane
    # to triangulate it in), and no triangulation of its rim's own vertices
    # avoids the bore; cut along a chord into two pieces, each closed over
    # a plane
    from scipy.spatial.transform import Rotation

    window, where = WINDOWS[name]
    V, F, g = cp.pipe_with_wrapped_window(window=window, bore=(1.5, 0.35, 1.6))
    if where != "as built":
        V = V @ Rotation.from_euler("xyz", [0.3, 0.7, 1.1]).as_matrix().T + 1e6
    loop = detect_holes(V, F, closed=True).loops[0].vertices
    P = V[loop] - V[loop].mean(axis=0)
    rng = np.random.default_rng(0)
    dirs = rng.normal(size=(200, 3))
    dirs = np.vstack([dirs / np.linalg.norm(dirs, axis=1)[:, None], np.eye(3)])
    assert not any(_outline_simple_along(P, d) for d in dirs)
    if where == "as built":
        assert not _rim_triangulation_exists(V, F, loop)
    R, report, loops = _repair_closes(V, F, closed=True)
    row = report["holes"][0]
    assert row["option"].startswith("Steiner points") and "in 2 pieces cut along chords" in row["option"], \
        row["option"]
    # the patch passes over the bore's end, out of the pipe
    new = _new_vertices(R, len(V), report["holes"])[0]
    if where == "as built":
        assert new[:, 0].max() > 1.6


def test_a_wrapped_opening_with_nothing_through_it_closes():
    # the same window, the bore short of the pipe's outer wall: its rim's
    # own vertices have triangulations that avoid the scan (the search
    # above finds them where they exist); whatever closes it, nothing is
    # crossed
    V, F, g = cp.pipe_with_wrapped_window(bore=(1.5, 0.35, 0.9))
    assert _rim_triangulation_exists(V, F, detect_holes(V, F, closed=True).loops[0].vertices)
    _repair_closes(V, F, closed=True)
