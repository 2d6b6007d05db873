"""Topology by position: coincident vertices are one point, non-manifold input
is made manifold by copying vertices, and the report says what is left.

Specification (issues 13.4 and 18.2/18.3):
* a triangle soup has the holes of its welded mesh and repairs to a closed
  surface, by position and (without attributes) by index in the written file;
* a surface cut at colour seams reads as closed, and each face keeps its own
  colours through a write and a read;
* non-manifold edges and vertices are split by appended copies, positions
  bit-identical, with exact counts;
* ordinary manifold files load exactly as before;
* the table never shows 100 % while the output keeps boundary edges outside
  its borders or non-manifold edges.
"""

import numpy as np
import pytest

from eval import shapes
from shellrepair.holes.loops import detect_holes
from shellrepair.mesh.io import Mesh, read_mesh, written_faces, write_mesh
from shellrepair.repair import repair_mesh
from shellrepair.report.table import REASON_WIDTH, short_reason, table1_dict, table1_text
from shellrepair.mesh.topology import coincident_vertices, edge_topology

from conftest import shared_scan


# --------------------------------------------------------------------------
# builders
# --------------------------------------------------------------------------
def _soup(V, F):
    """Every face with its own three vertices, as converters write."""
    P = V[F].reshape(-1, 3).copy()
    return P, np.arange(len(P), dtype=np.int64).reshape(-1, 3)


def _cube(origin=(0.0, 0.0, 0.0), size=1.0):
    """A closed cube, 8 vertices, 12 outward triangles."""
    o = np.asarray(origin, np.float64)
    V = o + size * np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.float64)
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    F = [[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads]
    return V, np.array(F, np.int64), quads


def _edges_left_by_position(V, F):
    """Boundary and non-manifold edges with every coincident vertex joined."""
    rep = coincident_vertices(V)
    G = F if rep is None else rep[F]
    topo = edge_topology(G, len(V))
    return topo.n_boundary_edges, int(topo.nonmanifold_edges.shape[0])


def _bits(V):
    return np.ascontiguousarray(V, np.float64).view(np.uint64)


# --------------------------------------------------------------------------
# coincident vertices
# --------------------------------------------------------------------------
def test_coincident_vertices_join_bit_identical_positions_and_both_zeros():
    V = np.array([[0.0, 1.0, 2.0], [1e-300, 1.0, 2.0], [-0.0, 1.0, 2.0], [0.0, 1.0, 2.0], [5.0, 5.0, 5.0]])
    assert coincident_vertices(V).tolist() == [0, 1, 0, 0, 4]
    assert coincident_vertices(V, [1, 2, 3]).tolist() == [0, 1, 2, 2, 4]   # only among the given ones
    assert coincident_vertices(V[[0, 1, 4]]) is None


def _brute_rep(V):
    key = [tuple(v + 0.0) for v in V]
    return np.array([min(j for j in range(len(V)) if key[j] == key[i]) for i in range(len(V))])


@pytest.mark.parametrize("collide", [False, True])
def test_coincident_vertices_equal_a_brute_force_join(monkeypatch, collide):
    import shellrepair.mesh.topology as topology

    if collide:   # every position hashes alike: the exact ordering path must still be right
        monkeypatch.setattr(topology, "_mix64", lambda w: w * np.uint64(0))
    rng = np.random.default_rng(7)
    for _ in range(100):
        V = rng.integers(-2, 3, (int(rng.integers(2, 50)), 3)).astype(np.float64) * 0.5
        V[rng.random(V.shape) < 0.3] *= -1.0                 # some zeros become -0.0
        rep = topology.coincident_vertices(V)
        want = _brute_rep(V)
        assert np.array_equal(want, np.arange(len(V))) if rep is None else np.array_equal(rep, want)


def test_triangle_soup_has_the_holes_of_its_welded_mesh_and_closes(tmp_path):
    V, F = shapes.icosphere(3)
    Vh, Fh, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.3, seed=2)
    want = sorted(lp.edges for lp in detect_holes(Vh, Fh).holes)
    assert len(want) == 3
    P, S = _soup(Vh, Fh)
    path = tmp_path / "soup.ply"
    write_mesh(path, Mesh(V=P, F=S))
    m = read_mesh(path)
    assert sorted(lp.edges for lp in detect_holes(m.V, m.F).holes) == want
    used = len(np.unique(Fh))
    assert m.fixes["vertices_joined"] == len(P) - used
    assert any("vertices joined" in n for n in m.notes)
    assert _bits(m.V).tobytes() == _bits(P).tobytes() and m.F_out is None

    R, rep = repair_mesh(m)
    assert rep["holes_before"] == 3 and rep["filled"] == 3 and rep["holes_after"] == 0
    assert rep["vertices_joined"] == len(P) - used
    assert rep["boundary_edges_after"] == 0 and rep["nonmanifold_edges_after"] == 0
    assert _edges_left_by_position(R.V, R.F) == (0, 0)
    assert np.array_equal(_bits(R.V[:len(P)]), _bits(P))
    # no attributes: the written file is closed by index too
    out = tmp_path / "closed.ply"
    write_mesh(out, R)
    raw = read_mesh(out, clean=False, orient=False)
    topo = edge_topology(raw.F, len(raw.V))
    assert topo.n_boundary_edges == 0 and topo.nonmanifold_edges.shape[0] == 0
    assert np.array_equal(_bits(raw.V[:len(P)]), _bits(P))


def test_a_soup_given_to_repair_directly_is_joined_the_same_way():
    V, F = shapes.icosphere(2)
    Vh, Fh, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.4, seed=5)
    P, S = _soup(Vh, Fh)
    R, rep = repair_mesh(Mesh(V=P, F=S))
    assert rep["holes_before"] == len(detect_holes(Vh, Fh).holes) == 2
    assert rep["filled"] == 2 and _edges_left_by_position(R.V, R.F) == (0, 0)
    assert np.array_equal(_bits(R.V[:len(P)]), _bits(P))


def test_negative_zero_is_the_same_point():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [-0.0, 0, 0], [1, 1, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [3, 4, 5]])
    R, rep = repair_mesh(Mesh(V=V, F=F), fill_borders=True)
    assert rep["vertices_joined"] == 2
    assert detect_holes(V, R.F[:2]).loops[0].edges == 4          # one square, not two triangles
    assert np.array_equal(_bits(R.V[:len(V)]), _bits(V))        # -0.0 stays -0.0 in the file


def test_seamed_cube_reads_closed_and_each_face_keeps_its_colours(tmp_path):
    Vc, _, quads = _cube()
    V, F, C = [], [], []
    for i, q in enumerate(quads):                 # each side has its own 4 vertices and colour
        base = len(V)
        V.extend(Vc[q])
        C.extend([[40 * i, 255 - 40 * i, 7 * i]] * 4)
        F.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]])
    V, F, C = np.array(V), np.array(F, np.int64), np.array(C, np.uint8)
    path = tmp_path / "cube.ply"
    write_mesh(path, Mesh(V=V, F=F, vertex_colors=C))
    m = read_mesh(path)
    scan = detect_holes(m.V, m.F)
    assert scan.loops == [] and scan.n_boundary_edges == 0 and scan.n_components == 1
    assert m.fixes["vertices_joined"] == 16 and m.F_out is not None
    R, rep = repair_mesh(m)
    assert rep["holes_before"] == 0 and rep["borders"] == 0 and rep["boundary_edges_after"] == 0
    out = tmp_path / "cube_out.ply"
    write_mesh(out, R)
    raw = read_mesh(out, clean=False, orient=False)
    assert len(raw.V) == len(V) and np.array_equal(_bits(raw.V), _bits(V))
    side = np.repeat(np.arange(6), 2)
    for f in range(len(F)):                        # every corner of a side has that side's colour
        assert (raw.vertex_colors[raw.F[f]] == C[4 * side[f]]).all()
        assert sorted(map(tuple, raw.V[raw.F[f]])) == sorted(map(tuple, V[F[f]]))
    again = read_mesh(out)
    assert detect_holes(again.V, again.F).loops == []


def test_coincident_vertices_with_equal_colours_are_written_joined(tmp_path):
    V, F = shapes.icosphere(2)
    P, S = _soup(V, F)
    C = np.clip(np.round((P + 1) * 100), 0, 255).astype(np.uint8)   # a colour per position
    path = tmp_path / "s.ply"
    write_mesh(path, Mesh(V=P, F=S, vertex_colors=C))
    m = read_mesh(path)
    assert m.F_out is None and np.array_equal(written_faces(m), m.F)
    topo = edge_topology(m.F, len(m.V))
    assert topo.n_boundary_edges == 0 and topo.nonmanifold_edges.shape[0] == 0


# --------------------------------------------------------------------------
# non-manifold input
# --------------------------------------------------------------------------
def test_three_fins_on_one_edge_keep_the_flattest_consistent_pair(tmp_path):
    V = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0.5], [-1, 0, 0.5], [0, 1, 0.5]], np.float64)
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]], np.int64)    # fins A, B (a flat sheet with A), C
    path = tmp_path / "fins.ply"
    write_mesh(path, Mesh(V=V, F=F))
    m = read_mesh(path, orient=False)
    assert {k: m.fixes[k] for k in ("nonmanifold_edges_found", "nonmanifold_edges_split",
                                    "nonmanifold_vertices_split", "vertices_added", "folded_faces_dropped")} \
        == {"nonmanifold_edges_found": 1, "nonmanifold_edges_split": 1, "nonmanifold_vertices_split": 2,
            "vertices_added": 2, "folded_faces_dropped": 0}
    assert np.array_equal(_bits(m.V[:5]), _bits(V)) and np.array_equal(_bits(m.V[5:]), _bits(V[[0, 1]]))
    assert m.F[:2].tolist() == F[:2].tolist() and m.F[2].tolist() == [5, 6, 4]
    topo = edge_topology(m.F, len(m.V))
    assert topo.nonmanifold_edges.shape[0] == 0 and topo.n_boundary_edges == 7


def test_two_cubes_sharing_a_vertex_get_one_copy_and_stay_closed(tmp_path):
    V1, F1, _ = _cube()
    V2, F2, _ = _cube(origin=(1.0, 1.0, 1.0))
    shared = 7                                        # (1,1,1) of the first is (0,0,0) of the second
    V = np.vstack([V1, V2[1:]])
    F2 = np.where(F2 == 0, shared, F2 + len(V1) - 1)
    F = np.vstack([F1, F2])
    path = tmp_path / "cubes.ply"
    write_mesh(path, Mesh(V=V, F=F))
    m = read_mesh(path)
    assert m.fixes["nonmanifold_vertices_split"] == 1 and m.fixes["vertices_added"] == 1
    assert m.fixes["nonmanifold_edges_found"] == 0
    assert np.array_equal(_bits(m.V[:len(V)]), _bits(V)) and np.array_equal(_bits(m.V[-1]), _bits(V[shared]))
    # each cube now has its own corner there, and both are closed
    assert ((m.F == shared).any(axis=1)).sum() == ((m.F == len(V)).any(axis=1)).sum() > 0
    scan = detect_holes(m.V, m.F)
    assert scan.loops == [] and scan.n_components == 2
    R, rep = repair_mesh(m)
    assert rep["nonmanifold_vertices_split"] == 1 and rep["holes_before"] == 0
    assert rep["boundary_edges_after"] == 0 and rep["nonmanifold_edges_after"] == 0


def test_two_cubes_sharing_an_edge_each_keep_a_closed_copy_of_it():
    V1, F1, _ = _cube()
    V2, F2, _ = _cube(origin=(1.0, 1.0, 0.0))
    # the first cube's vertices 6, 7 ((1,1,0), (1,1,1)) are the second's 0, 1
    V = np.vstack([V1, V2[2:]])
    F = np.vstack([F1, np.where(F2 < 2, F2 + 6, F2 + len(V1) - 2)])
    R, rep = repair_mesh(Mesh(V=V, F=F))
    assert rep["nonmanifold_edges_found"] == 1 and rep["nonmanifold_edges_split"] == 1
    assert rep["nonmanifold_vertices_split"] == 2 and rep["vertices_added"] == 2
    assert np.array_equal(_bits(R.V[:len(V)]), _bits(V))
    assert np.array_equal(_bits(R.V[len(V):]), _bits(V[[6, 7]]))
    scan = detect_holes(R.V, R.F)
    assert scan.loops == [] and scan.n_components == 2 and scan.n_nonmanifold_edges == 0
    assert rep["holes_before"] == 0 and rep["boundary_edges_after"] == 0


@pytest.mark.parametrize("seed", range(6))
def test_extra_faces_on_a_closed_surface_are_split_off_without_moving_anything(seed):
    """Random faces on random edges of a sphere (three or four faces per
    edge): every non-manifold edge is resolved, and each face kept is the
    same triangle in space as before."""
    from shellrepair.mesh.io import clean_faces, manifold_mesh

    V, F = shapes.icosphere(2)
    rng = np.random.default_rng(seed)
    E = edge_topology(F, len(V)).edges
    E = E[rng.choice(len(E), 15, replace=False)]
    Fx, _, _ = clean_faces(np.vstack([F, np.column_stack([E, rng.integers(0, len(V), len(E))])]))
    m = manifold_mesh(Mesh(V=V, F=Fx))
    topo = edge_topology(m.F, len(m.V))
    assert topo.nonmanifold_edges.shape[0] == 0
    assert m.fixes["nonmanifold_edges_found"] >= 15
    assert np.array_equal(_bits(m.V[:len(V)]), _bits(V))
    # the copies sit on their originals, so every face is where it was (up to orientation)
    assert len(m.F) == len(Fx) - m.fixes["folded_faces_dropped"]
    got = {tuple(sorted(map(tuple, t))) for t in m.V[m.F]}
    assert got <= {tuple(sorted(map(tuple, t))) for t in V[Fx]}
    assert len(got) == len(m.F)
    # the sphere itself is untouched: its faces keep their vertices
    sphere = {tuple(sorted(f)) for f in F.tolist()}
    assert sphere <= {tuple(sorted(f)) for f in m.F.tolist()}


def test_bowtie_is_split_into_two_triangles():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0]], np.float64)
    F = np.array([[0, 1, 2], [0, 3, 4]], np.int64)
    R, rep = repair_mesh(Mesh(V=V, F=F))
    assert rep["nonmanifold_vertices_split"] == 1 and rep["vertices_added"] == 1
    assert rep["nonmanifold_edges_found"] == 0
    assert np.array_equal(_bits(R.V[:5]), _bits(V)) and np.array_equal(_bits(R.V[5]), _bits(V[0]))
    assert R.F.tolist() == [[0, 1, 2], [5, 3, 4]]
    assert rep["borders"] == 2 and rep["boundary_edges_after"] == 6 == rep["border_edges_after"]


def test_a_manifold_file_loads_exactly_as_written(tmp_path):
    V, F = shapes.icosphere(3)
    Vh, Fh, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.3, seed=3)
    path = tmp_path / "m.ply"
    write_mesh(path, Mesh(V=Vh, F=Fh))
    m = read_mesh(path)
    assert not any(m.fixes.values()) and m.F_out is None
    assert np.array_equal(m.F, Fh) and np.array_equal(_bits(m.V), _bits(Vh))


def test_real_decimated_bunny_comes_out_closed_and_manifold(tmp_path):
    from shellrepair.mesh.intersect import self_intersections

    src = shared_scan("real_bunny_pymeshfix_decimated.ply")
    raw = read_mesh(src, clean=False, orient=False)
    assert edge_topology(raw.F, len(raw.V)).nonmanifold_edges.shape[0] == 132
    m = read_mesh(src)
    assert m.fixes["folded_faces_dropped"] == 66 and m.fixes["nonmanifold_edges_found"] == 132
    R, rep = repair_mesh(m)
    assert _edges_left_by_position(R.V, R.F) == (0, 0)
    assert rep["boundary_edges_after"] == 0 and rep["nonmanifold_edges_after"] == 0
    assert rep["holes_after"] == 0 and rep["interpolation_rate"] == 100.0
    assert np.array_equal(_bits(R.V[:len(raw.V)]), _bits(raw.V))
    assert self_intersections(R.V, R.F) == 0


# --------------------------------------------------------------------------
# the report
# --------------------------------------------------------------------------
def _rows(k):
    return [{"id": i, "edges": 5, "status": "filled", "reason": "ok", "option": "faired order 2"} for i in range(k)]


@pytest.mark.parametrize("left", [{"nonmanifold_edges_after": 3, "boundary_edges_after": 0},
                                  {"nonmanifold_edges_after": 0, "boundary_edges_after": 7}])
def test_rate_is_withheld_while_the_output_is_not_closed(left):
    d = table1_dict(2, _rows(2), extra={"border_edges_after": 0, **left})
    assert d["interpolation_rate"] is None and "still has" in d["rate_withheld"]
    text = table1_text(d)
    assert "100" not in text.splitlines()[2] and "rate withheld" in text
    assert f"{left['boundary_edges_after']} boundary edges" in text
    assert f"{left['nonmanifold_edges_after']} non-manifold edges" in text


def test_borders_left_open_do_not_withhold_the_rate_and_open_chains_count_as_not_filled():
    d = table1_dict(2, _rows(2), borders=1,
                    extra={"border_edges_after": 40, "boundary_edges_after": 40, "nonmanifold_edges_after": 0})
    assert d["interpolation_rate"] == 100.0 and d["rate_withheld"] is None
    d = table1_dict(1, _rows(1), open_chains=[np.arange(3)],
                    extra={"border_edges_after": 0, "boundary_edges_after": 2, "nonmanifold_edges_after": 0})
    assert d["open_chains"] == 1 and d["interpolation_rate"] == 50.0
    assert "1 boundary chains that do not close" in table1_text(d)


def test_a_hole_left_open_reads_as_one_line_in_the_table_and_whole_in_the_json():
    """The last layer's account of a hole it gave up on runs to thousands of
    characters; the table shows its first and last steps (a step's own
    account in parentheses is not split) and how many lie between, the
    JSON row keeps every step."""
    first = "no triangulation avoids crossing the scan (2 chords re-routed)"
    middle = [f"attempt {i}: patch would cross the scan ({i} triangles; tried twice)" for i in range(12)]
    last = "last layer: Steiner points (seen along its normal; round 4: over 11847 points)"
    reason = "; ".join([first] + middle + [last])
    rows = _rows(1) + [{"id": 7, "edges": 4, "status": "failed", "reason": reason, "failure": "no patch passes"}]
    d = table1_dict(2, rows)
    assert d["holes"][1]["reason"] == reason
    line = next(x for x in table1_text(d).splitlines() if x.strip().startswith("hole    7"))
    assert len(line) < len("    hole    7 (4 edges): failed: ") + REASON_WIDTH + 40
    shown = short_reason(reason)
    assert shown.startswith(first) and "[12 more steps: the JSON report]" in shown
    assert shown.endswith(last)                              # its "; " inside parentheses kept
    long_last = short_reason("; ".join([first, "x" * 500]))
    assert long_last.startswith(first + "; [the JSON report has it all]; xxx") and long_last.endswith("x…")
    brief = "flat: patch would cross the scan (1 triangles)"
    assert short_reason(brief) == brief
