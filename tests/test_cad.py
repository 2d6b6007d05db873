"""Planar openings of CAD-like parts close flat, without crossing anything.

CAD parts are triangulated coarsely: long thin triangles fanned from
corners, flat faces whose triangles are coplanar neighbours of the opening,
zero-area faces where an exporter sealed a T-junction. Every opening cut
here is planar and bounded by scan that does not cross its plane region,
so it must close: every hole filled, every new vertex within 1e-9 of the
diameter off the opening's plane (beyond the loop's own round-off), no
self-intersection added (exact count), original vertices bit-identical.

The parts are built in :mod:`cad_parts`; the real fandisk CAD part of
../shared/data has its flat regions cut out when present.
"""

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial.transform import Rotation

import cad_parts as cp
from shellrepair import Mesh, detect_holes, read_mesh
from shellrepair.mesh.intersect import self_intersections
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import edge_topology

from conftest import shared_scan

#: New vertices may leave the opening's plane by this much of its diameter
#: (beyond the loop's own distance from its best-fit plane).
FLAT_TOL = 1e-9


def _seal_rim_with_zero_area_faces(V, F, groups, name):
    """Split every wall edge on the rim of face group ``name`` at its
    midpoint and seal the split with a zero-area face (a, b, m) on the rim,
    as exporters seal T-junctions: the opening's loop edges then belong to
    zero-area faces."""
    V = [np.asarray(p) for p in V]
    F = [list(f) for f in F]
    cap = set(groups[name].tolist())
    rim = {(F[f][i], F[f][(i + 1) % 3]) for f in cap for i in range(3)}
    out = []
    for fi, f in enumerate(F):
        for i in range(3):
            a, b, c = f[i], f[(i + 1) % 3], f[(i + 2) % 3]
            if fi not in cap and (b, a) in rim:
                m = len(V)
                V.append((V[a] + V[b]) / 2)
                out += [[a, m, c], [m, b, c], [a, b, m]]
                break
        else:
            out.append(f)
    return np.array(V), np.array(out, np.int64)


def _rim_sealed_cube():
    V, F, g = cp.coarse_cube(1)
    top = {tuple(F[f]) for f in g["top"]}
    V2, F2 = _seal_rim_with_zero_area_faces(V, F, g, "top")
    return V2, F2, [i for i, f in enumerate(map(tuple, F2.tolist())) if f in top]


def _capsule_with_zero_height_band(segments=48):
    """A capsule whose open end has a band of zero-area faces to a copy of
    its rim (coincident vertices, other ids): the opening is the copy."""
    V, F, g = cp.capsule(segments, length=6.0)
    V, F = cp.remove(V, F, g["cap"])
    rim = np.flatnonzero(V[:, 2] == 6.0)
    rim = rim[np.argsort(np.arctan2(V[rim, 1], V[rim, 0]))]
    dup = len(V) + np.arange(segments)
    V = np.vstack([V, V[rim]])
    j = np.roll(np.arange(segments), -1)
    band = np.concatenate([np.column_stack([rim, rim[j], dup[j]]), np.column_stack([rim, dup[j], dup])])
    # the walls use each rim edge once; the band must use it the other way
    he = {tuple(e) for f in F.tolist() for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    if (rim[0], rim[1]) in he:
        band = band[:, ::-1]
    return V, np.vstack([F, band]), []


def _cases():
    rot = Rotation.from_euler("xyz", [0.3, 0.7, 1.1]).as_matrix()
    cases = {}

    def add(name, part, groups, **kw):
        V, F, g = part
        faces = np.concatenate([g[x] for x in groups]) if groups else np.zeros(0, np.int64)
        cases[name] = (V, F, faces, kw)

    # a part open at one end reads as a cup (a single view) by default:
    # closed=True is how a user says it is a closed part (--closed yes);
    # parts with through-holes and pockets read closed by themselves
    add("cube, top missing", cp.coarse_cube(1), ["top"], closed=True)
    add("cube with split sides, top missing", cp.coarse_cube(5), ["top"], closed=True)
    add("capsule, flat end missing", cp.capsule(48), ["cap"], closed=True)
    add("capsule, dome missing (opening at the far end of long walls)", cp.capsule(48, rings=4), ["dome"], closed=True)
    add("box with a square hole through it, one tunnel side missing", cp.box_with_through_hole(False), ["tunnel1"])
    add("box with a square hole through it, one outer wall missing", cp.box_with_through_hole(False, n=3),
        ["wall2"])
    add("box with a round hole through it, one outer wall missing", cp.box_with_through_hole(True, 32), ["wall0"])
    add("box with a round hole through it, both mouths capped (tunnel missing)",
        cp.box_with_through_hole(True, 32), ["tunnel"], bridge="never")
    add("plate with a pocket, pocket bottom missing", cp.plate_with_pocket(2), ["pocket_bottom"])
    # a face with a hole in it: two loops on one plane, one inside the other
    add("box with a round hole through it, top face missing (a face with a hole)",
        cp.box_with_through_hole(True, 32), ["top"])
    add("box with a round hole through it, finely cut, top and bottom faces missing",
        cp.box_with_through_hole(True, 96, n=12), ["top", "bottom"])
    add("box with a square hole through it, top face missing (a face with a hole)",
        cp.box_with_through_hole(False, n=3), ["top"])
    add("plate with a boss, the ring of plate around the boss missing (a face with a hole)",
        cp.plate_with_boss(), ["top"])
    V, F, g = cp.plate_with_pocket(2)
    wall = g["pocket_walls"][np.abs(V[F[g["pocket_walls"]]][:, :, 0].mean(axis=1) - 1.0) < 1e-9]
    cases["plate with a pocket, one wall of the pocket missing"] = (V, F, wall, {})
    slab = cp.slab_with_grid_top(14, 10, size=(7.0, 5.0))
    cells = {"U": [(2, 2), (2, 3), (2, 4), (3, 2), (4, 2), (4, 3), (4, 4)],
             "spiral": [(6, 2), (7, 2), (8, 2), (8, 3), (8, 4), (7, 4), (6, 4), (6, 5), (6, 6), (7, 6),
                        (8, 6), (9, 6), (10, 6)],
             "L": [(10, 1), (11, 1), (12, 1), (10, 2), (10, 3)]}
    add("slab, U, L and spiral openings among coplanar neighbours", slab,
        [f"cell {i} {j}" for c in cells.values() for i, j in c])
    V, F, faces, kw = cases["slab, U, L and spiral openings among coplanar neighbours"]
    cases["the same (coplanar neighbours), rotated and 1e6 off the origin"] = (V @ rot.T + 1e6, F, faces, kw)
    V, F, faces, kw = cases["plate with a pocket, pocket bottom missing"]
    cases["plate with a pocket, rotated and 1e6 off the origin"] = (V @ rot.T + 1e6, F, faces, kw)
    V, F, top = _rim_sealed_cube()
    cases["cube whose rim edges are zero-area faces, top missing"] = (V, F, np.array(top, np.int64), {"closed": True})
    V, F, none = _capsule_with_zero_height_band()
    cases["capsule open behind a band of zero-area faces"] = (V, F, np.array(none, np.int64), {"closed": True})
    return cases


CASES = _cases()


def _flat_regions(V, F, cos_tol=1e-9):
    """Faces grouped into connected regions of one normal (across edges)."""
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    key = E[:, 0] * len(V) + E[:, 1]
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    a, b = order[:-1][same] % len(F), order[1:][same] % len(F)
    ok = np.einsum("ij,ij->i", n[a], n[b]) > 1 - cos_tol
    A = coo_matrix((np.ones(ok.sum()), (a[ok], b[ok])), shape=(len(F), len(F)))
    return connected_components(A, directed=False)[1]


def assert_openings_close_flat(V, F, si_before=None, **kw):
    """Repair the part ``V, F``; check every opening closed flat, nothing
    crossed (``si_before``: the input's crossing count, when known)."""
    scan = detect_holes(V, F, closed=kw.get("closed"))
    assert len(scan.loops) > 0
    assert all(L.kind == "hole" for L in scan.loops), [L.reason for L in scan.loops]
    R, report = repair_mesh(Mesh(V=V, F=F), **kw)
    rows = report["holes"]
    assert [r["status"] for r in rows] == ["filled"] * len(scan.loops), [r["reason"] for r in rows]
    # originals first, bit for bit; the part is closed again
    assert np.array_equal(R.V[:len(V)].view(np.uint64), V.view(np.uint64))
    assert np.array_equal(R.F[:len(F)], F)
    assert edge_topology(R.F, len(R.V)).n_boundary_edges == 0
    # each patch's new vertices (appended in hole order) lie on its loop's plane
    start = len(V)
    for row in sorted(rows, key=lambda r: r["id"]):
        loop = scan.loops[row["id"]].vertices
        P = V[loop]
        c = P.mean(axis=0)
        normal = np.linalg.svd(P - c)[2][-1]
        diameter = float(np.ptp(P, axis=0).max())
        new = R.V[start:start + row["new_vertices"]]
        start += row["new_vertices"]
        own = float(np.abs((P - c) @ normal).max())
        if len(new):
            assert float(np.abs((new - c) @ normal).max()) <= own + FLAT_TOL * diameter
    assert start == len(R.V)
    # nothing crossed: the exact count of crossing pairs is unchanged
    if si_before is None:
        si_before = self_intersections(V, F)
    assert self_intersections(R.V, R.F) == si_before
    return report


@pytest.mark.parametrize("name", list(CASES))
def test_every_planar_opening_of_a_cad_part_closes_flat(name):
    V, F, faces, kw = CASES[name]
    V2, F2 = cp.remove(V, F, faces)
    report = assert_openings_close_flat(V2, F2, **kw)
    if "coplanar" not in name and "mouths" not in name:
        # walls stand across these openings (at least along part of the rim):
        # the flat cap, at the first attempt; a face with a hole: one flat
        # face across both its loops
        assert all(r["option"].startswith("flat cap" if "hole)" not in name and "faces missing" not in name
                                          else "flat face with a hole") for r in report["holes"]), \
            [r["option"] for r in report["holes"]]


def test_the_parts_are_closed_consistent_and_do_not_cross_themselves():
    # the builders' own check: a wrong part would make the cases above meaningless
    for name, (V, F, faces, kw) in CASES.items():
        if "zero-area" in name:
            continue      # zero-area faces: coincident segments count as overlapping
        topo = edge_topology(F, len(V))
        he = topo.he[:, 0] * len(V) + topo.he[:, 1]
        assert topo.n_boundary_edges == 0 and topo.nonmanifold_edges.shape[0] == 0, name
        assert np.unique(he).size == he.size, name
        assert self_intersections(V, F) == 0, name


def test_an_opening_crossed_by_scan_through_its_plane_closes_over_it():
    # a needle of scan stands through the middle of a cube's missing top:
    # every flat triangulation crosses it, and so does every triangulation
    # of the rim's own vertices; the needle is a loose triangle, so a patch
    # with vertices of its own passes over it (shellrepair.fill.steiner), flat
    # where nothing is under it, and nothing is crossed
    V, F, g = cp.coarse_cube(8)
    V, F = cp.remove(V, F, g["top"])
    k = len(V)
    V = np.vstack([V, [[0.5, 0.5, 0.5], [0.5, 0.51, 1.5], [0.51, 0.5, 1.5]]])
    F = np.vstack([F, [[k, k + 1, k + 2]]])
    si = self_intersections(V, F)
    # (with bridges allowed the needle's own loop is a hole too, and a tube
    # from it to the opening is a valid fill: caps only here)
    R, report = repair_mesh(Mesh(V=V, F=F), fill_borders=True, bridge="never")
    top = [r for r in report["holes"] if r["edges"] == 32][0]
    assert top["status"] == "filled" and top["option"].startswith("Steiner points"), top["reason"]
    assert self_intersections(R.V, R.F) == si
    assert np.array_equal(R.V[:len(V)].view(np.uint64), V.view(np.uint64))
    start = len(V) + sum(r["new_vertices"] for r in report["holes"] if r["id"] < top["id"])
    new = R.V[start:start + top["new_vertices"]]
    assert new[:, 2].max() > 1.5                                   # over the needle's top
    assert (np.abs(new[:, 2] - 1.0) <= FLAT_TOL).any()             # on the top's plane away from it


def test_zero_area_rim_faces_no_longer_block_the_cap():
    # the failure reported on CAD files: a zero-area face across each loop
    # edge counted as crossing every patch triangle on that edge
    V, F, top = _rim_sealed_cube()
    V2, F2 = cp.remove(V, F, top)
    report = assert_openings_close_flat(V2, F2, closed=True)   # an open box reads as a cup by default
    assert report["holes"][0]["option"].startswith("flat cap")


def test_fandisk_flat_regions_close_flat():
    M = read_mesh(shared_scan("closed_fandisk_cad.ply"))
    V, F = M.V, M.F
    assert self_intersections(V, F) == 0     # so no part of it crosses either
    label = _flat_regions(V, F)
    sizes = np.bincount(label)
    biggest = np.argsort(-sizes, kind="stable")[:6]
    # one whole flat region at a time: the largest, bounded by creases all
    # round, and the fourth, beside a curved face that meets it almost
    # tangentially along part of its rim
    # (without its largest face, the part is a shallow tray: from below,
    # 3.4 % as much surface faces away as towards; it reads as a single view
    # unless the user says it is closed)
    for r, closed in ((biggest[0], True), (biggest[3], None)):
        V2, F2 = cp.remove(V, F, np.flatnonzero(label == r))
        assert_openings_close_flat(V2, F2, si_before=0, closed=closed)
    # two at once, and a disc inside the largest (coplanar neighbours all round)
    V2, F2 = cp.remove(V, F, np.flatnonzero(np.isin(label, biggest[4:6])))
    assert_openings_close_flat(V2, F2, si_before=0)
    faces = np.flatnonzero(label == biggest[0])
    C = V[F[faces]].mean(axis=1)
    centre = C[np.argmin(np.linalg.norm(C - C.mean(axis=0), axis=1))]
    d = np.linalg.norm(C - centre, axis=1)
    V2, F2 = cp.remove(V, F, faces[d < np.quantile(d, 0.2)])
    assert_openings_close_flat(V2, F2, si_before=0)


def test_fandisk_faces_planar_only_to_the_files_digits_still_close_flat():
    # the file's coordinates carry four to six decimals: some of the part's
    # flat faces are planar only to about 1e-5 of their size (their
    # triangles' normals agree to 1e-6, not 1e-9); walls stand across their
    # outlines (creases), so each is a CAD face's outline, capped flat, not
    # faired into a dome (as the stress suite's occlusions of them were
    # until 2026-12-07: 16.1 per mille from the truth, the cap 0.28)
    M = read_mesh(shared_scan("closed_fandisk_cad.ply"))
    label = _flat_regions(M.V, M.F, cos_tol=1e-6)
    tried = 0
    for r in np.argsort(-np.bincount(label), kind="stable")[:8]:
        V2, F2 = cp.remove(M.V, M.F, np.flatnonzero(label == r))
        loops = detect_holes(V2, F2, fill_borders=True).loops
        if not all(1e-6 < L.planarity < 1e-4 for L in loops):
            continue
        tried += 1
        report = assert_openings_close_flat(V2, F2, si_before=0)
        assert all(row["option"].startswith("flat cap") for row in report["holes"]), \
            [row["option"] for row in report["holes"]]
    assert tried >= 2


def test_a_planar_loop_without_walls_at_its_rim_is_still_faired_round():
    # the pole of a faceted dome cut at a ring of latitude: the loop is
    # exactly planar, but the faces around it slant (none stands across the
    # plane), so the surface is a dome to continue, not a flat face
    V, F, g = cp.capsule(48, rings=6)
    dome = g["dome"]
    ring = -0.5 * np.sin(np.radians(45))                    # the ring of latitude 45 degrees
    pole = dome[V[F[dome]][:, :, 2].max(axis=1) <= ring + 1e-12]
    V2, F2 = cp.remove(V, F, pole)
    loop = detect_holes(V2, F2, fill_borders=True).loops[0].vertices
    assert np.ptp(V2[loop, 2]) == 0.0                      # exactly planar
    R, report = repair_mesh(Mesh(V=V2, F=F2), fill_borders=True)
    row = report["holes"][0]
    assert row["status"] == "filled" and row["option"].startswith("faired")
    # the patch bulges out past the loop's plane, towards where the pole was
    assert R.V[len(V2):, 2].min() < V2[loop, 2].min() - 0.05
