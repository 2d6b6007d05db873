"""Hole detection: every boundary loop, its order, its class."""

import numpy as np
import pytest

from shellrepair import detect_holes, read_mesh
from eval import shapes
from shellrepair.holes.loops import boundary_loops, loop_stats
from shellrepair.mesh.topology import edge_topology

from conftest import shared_scan


def _assert_faces_left_of_loops(F, loops):
    """Each loop edge (a, b) is a half-edge of exactly one face."""
    he = {(int(a), int(b)) for f in F for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    for lp in loops:
        for a, b in zip(lp, np.roll(lp, -1)):
            assert (int(a), int(b)) in he
            assert (int(b), int(a)) not in he


def test_closed_sphere_has_no_loops(sphere):
    V, F = sphere
    scan = detect_holes(V, F)
    assert scan.loops == [] and scan.n_boundary_edges == 0
    assert scan.euler == 2


def test_perforated_sphere_loops_match_removed_region():
    V, F = shapes.icosphere(4)
    V2, F2, removed, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.25, seed=1)
    scan = detect_holes(V2, F2)
    assert len(scan.loops) == 3 and len(scan.holes) == 3
    assert all(lp.reading == "closed" and lp.back_ratio > 0.8 for lp in scan.loops)  # 1 with no hole at all
    assert scan.n_components == 1
    assert sum(lp.edges for lp in scan.loops) == scan.n_boundary_edges
    assert scan.euler == 2 - 3
    _assert_faces_left_of_loops(F2, [lp.vertices for lp in scan.loops])
    for lp in scan.loops:  # discs of geodesic radius 0.25 on a unit sphere
        assert 2 * 0.25 < lp.diameter < 2 * 0.4
        assert lp.planarity < 0.05


def test_torus_with_two_holes():
    V, F = shapes.torus()
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.2, seed=3)
    scan = detect_holes(V2, F2)
    assert len(scan.holes) == 2 and not scan.borders
    assert scan.euler == 0 - 2


def test_grid_outer_edge_is_one_border():
    V, F = shapes.grid(8, 5)
    scan = detect_holes(V, F)
    assert len(scan.loops) == 1
    lp = scan.loops[0]
    assert lp.edges == 2 * (8 - 1) + 2 * (5 - 1)
    assert lp.kind == "border" and lp.reading == "single view" and lp.back_ratio == 0.0
    assert lp.inside_fraction == pytest.approx(1.0, abs=0.02)
    assert lp.perimeter == pytest.approx(4.0)


def test_fill_borders_and_max_hole_override_the_class():
    V, F = shapes.grid(8, 8)
    assert detect_holes(V, F, fill_borders=True).loops[0].kind == "hole"
    V, F = shapes.icosphere(3)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=1, radius=0.4, seed=0)
    lp = detect_holes(V2, F2, max_hole=5).loops[0]
    assert lp.kind == "border" and "max_hole" in lp.reason


def test_two_holes_touching_at_a_vertex_are_two_loops(two_pinched_holes):
    V, F, pinch = two_pinched_holes
    loops, chains = boundary_loops(F, len(V))
    assert chains == []
    sizes = sorted(len(lp) for lp in loops)
    assert sizes == [4, 4, 20]
    small = [lp for lp in loops if len(lp) == 4]
    assert all(pinch in lp.tolist() for lp in small)
    _assert_faces_left_of_loops(F, loops)
    scan = detect_holes(V, F)
    assert [lp.kind for lp in sorted(scan.loops, key=lambda x: x.edges)] == ["hole", "hole", "border"]


def test_sheet_with_a_hole_has_a_border_and_a_hole():
    V, F = shapes.grid(20, 20)
    c = np.array([0.5, 0.5, 0.0])
    remove = (np.linalg.norm(V[F].mean(axis=1) - c, axis=1) < 0.2)
    V2, F2, _ = shapes.remove_faces(V, F, remove)
    V2 = V2.copy()
    V2[:, 2] = 0.1 * np.sin(3 * V2[:, 0])  # a gently curved sheet
    scan = detect_holes(V2, F2)
    kinds = sorted((lp.kind, lp.edges) for lp in scan.loops)
    assert [k for k, _ in kinds] == ["border", "hole"]
    assert kinds[0][1] == 4 * 19


def test_nonmanifold_edges_are_reported_not_crashed_on():
    V, F = shapes.grid(4, 4)
    # a fin: a third triangle on an interior edge
    V = np.vstack([V, [[0.5, 0.5, 1.0]]])
    a, b = F[0][0], F[0][2]
    F = np.vstack([F, [[a, b, len(V) - 1]]])
    scan = detect_holes(V, F)
    assert scan.n_nonmanifold_edges == 1


def test_loop_stats_of_a_square():
    V = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]], float)
    st = loop_stats(V, np.arange(4))
    assert st["perimeter"] == pytest.approx(8.0)
    assert st["area"] == pytest.approx(4.0)
    assert st["diameter"] == pytest.approx(np.sqrt(8))
    assert st["planarity"] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(np.abs(st["axis"]), [0, 0, 1])


def test_real_bunny_has_five_holes():
    m = read_mesh(shared_scan("real_bunny_zipper.ply"))
    scan = detect_holes(m.V, m.F)
    assert sorted((lp.edges for lp in scan.holes), reverse=True) == [80, 42, 40, 39, 22]
    assert scan.borders == [] and scan.n_components == 1


def test_real_range_scan_outer_edges_are_borders():
    m = read_mesh(shared_scan("real_rangescan_dragon_000.ply"))
    scan = detect_holes(m.V, m.F)
    # 28 components in the file; 16 vertices where islands touch another piece
    # at a point are split on reading (one copy each), which leaves 42
    assert m.fixes["nonmanifold_vertices_split"] == 16 and scan.n_components == 42
    # the longest loop of every piece is its outer edge, never a hole
    by_comp = {}
    for lp in scan.loops:
        if lp.component not in by_comp or lp.edges > by_comp[lp.component].edges:
            by_comp[lp.component] = lp
    assert len(by_comp) == 42
    assert all(lp.kind == "border" for lp in by_comp.values())
    big = max(scan.loops, key=lambda x: x.edges)
    holes_big = sorted((lp.edges for lp in scan.holes if lp.component == big.component), reverse=True)
    assert holes_big[0] > 300 and 59 in holes_big and 48 in holes_big


def test_edge_count_delta_matches_a_full_recount():
    from shellrepair.mesh.topology import edge_count_delta, euler_characteristic
    V, F = shapes.icosphere(3)
    V2, F2, removed, kept = shapes.perforate_discs(V, F, n_holes=3, radius=0.3, seed=4)
    topo = edge_topology(F2, len(V2))
    # append part of the removed faces back (in the perforated numbering where possible) plus a fin
    remap = -np.ones(len(V), np.int64)
    remap[kept] = np.arange(len(kept))
    back = remap[F[removed]]
    back = back[(back >= 0).all(axis=1)][:5]
    fin = np.array([[F2[0, 0], F2[0, 1], len(V2)]])            # a third face on an existing edge
    new = np.vstack([back, fin])
    d = edge_count_delta(topo, new, len(V2) + 1)
    full = edge_topology(np.vstack([F2, new]), len(V2) + 1)
    assert topo.n_boundary_edges + d["boundary_edges"] == full.n_boundary_edges
    assert topo.nonmanifold_edges.shape[0] + d["nonmanifold_edges"] == full.nonmanifold_edges.shape[0] == 1
    assert topo.edges.shape[0] + d["edges"] == full.edges.shape[0]


@pytest.mark.parametrize("seed", range(4))
def test_edge_count_delta_is_the_same_by_every_look_up(seed):
    """The record search (few edges asked of many), the key search and the
    shortcut for edges at new vertices (``n_before``) count alike."""
    from shellrepair.mesh.topology import edge_count_delta
    V, F = shapes.icosphere(5)
    V2, F2, removed, kept = shapes.perforate_discs(V, F, n_holes=4, radius=0.2, seed=seed)
    topo = edge_topology(F2, len(V2))
    rng = np.random.default_rng(seed)
    n = len(V2)
    # a fan to a new vertex at each of a few scan edges, a third face on some edges, faces among new vertices
    e = topo.edges[rng.choice(len(topo.edges), 30, replace=False)]
    new = np.vstack([np.column_stack([e, np.full(len(e), n)]), [[n, n + 1, n + 2]], F2[:3][:, ::-1]])
    full = edge_topology(np.vstack([F2, new]), n + 3)
    want = {"boundary_edges": full.n_boundary_edges - topo.n_boundary_edges,
            "nonmanifold_edges": full.nonmanifold_edges.shape[0] - topo.nonmanifold_edges.shape[0],
            "edges": full.edges.shape[0] - topo.edges.shape[0]}
    assert edge_count_delta(topo, new, n + 3) == want
    assert edge_count_delta(topo, new, n + 3, n_before=n) == want
    assert len(new) * 3 * 64 < len(topo.edges)          # the record search ran


@pytest.mark.parametrize("seed", range(3))
def test_the_boundary_half_edges_alone_are_the_topologys_and_give_the_same_loops(seed, monkeypatch):
    # face soups with open edges, edges of three faces and pinched rims:
    # the boundary half-edges found by one sort of the edge keys are the
    # whole topology's, and the loops walked from them are the same
    from shellrepair.mesh import fastmesh
    from shellrepair.mesh.topology import boundary_half_edges

    monkeypatch.setattr(fastmesh, "enabled", lambda n_faces: False)    # the half-edges alone, whatever is loaded

    rng = np.random.default_rng(seed)
    for _ in range(300):
        n = int(rng.integers(3, 30))
        F = rng.integers(0, n, (int(rng.integers(1, 40)), 3))
        F = F[(F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])]
        if not len(F):
            continue
        nv = n + int(rng.integers(0, 200))
        topo = edge_topology(F, nv)
        assert np.array_equal(boundary_half_edges(F, nv), topo.boundary_he)
        (l1, c1), (l2, c2) = boundary_loops(F, nv), boundary_loops(F, nv, topo)
        assert [x.tolist() for x in l1] == [x.tolist() for x in l2]
        assert [x.tolist() for x in c1] == [x.tolist() for x in c2]
