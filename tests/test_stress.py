"""A seeded slice of the stress suite (eval/stress.py), and its measuring tools.

The slice takes a few cheap procedural cases (coarse meshes, ``quick=True``)
of design seeds (below 1000; the suite's validation seeds start at 1000)
and asserts what issue 13 asks of every case: original vertices
bit-identical, no self-intersection added, every loop classed ``hole``
closed, and, since the truths are closed, every loop classed ``hole`` and
the truth's topology restored. A property that the current fill does not
meet on a case is marked ``xfail(strict=False)`` with the failure it shows,
so it is flipped (the mark removed) when the fix lands.

The measuring functions are tested first on meshes whose answer is known,
so a failing slice test is the fill's failure, not the suite's.
"""

from functools import lru_cache

import numpy as np
import pytest

from eval import stress
from eval import shapes


# --------------------------------------------------------------------------
# the measuring tools
# --------------------------------------------------------------------------
def _tri_pair(B):
    """Triangle A in z = 0 and triangle B as given, as one mesh; B is 'added'."""
    V = np.vstack([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], B]).astype(float)
    F = np.array([[0, 1, 2], [3, 4, 5]], np.int64)
    return V, F, np.array([False, True])


def test_a_triangle_piercing_another_is_one_pair():
    V, F, added = _tri_pair([[0.2, 0.2, -1], [0.3, 0.2, 1], [0.2, 0.3, 1]])
    assert stress.triangle_pairs_added(V, F, added) == 1


def test_triangles_touching_or_apart_are_no_pair():
    # a corner of B on A's interior (touching), and B above A
    V, F, added = _tri_pair([[0.2, 0.2, 0], [0.3, 0.2, 1], [0.2, 0.3, 1]])
    assert stress.triangle_pairs_added(V, F, added) == 0
    V, F, added = _tri_pair([[0.2, 0.2, 0.1], [0.3, 0.2, 1], [0.2, 0.3, 1]])
    assert stress.triangle_pairs_added(V, F, added) == 0


def test_pairs_of_original_faces_only_are_not_counted():
    V, F, added = _tri_pair([[0.2, 0.2, -1], [0.3, 0.2, 1], [0.2, 0.3, 1]])
    assert stress.triangle_pairs_added(V, F, np.zeros(2, bool)) == 0


def test_a_face_folded_onto_its_neighbour_is_a_pair_and_a_hinge_is_not():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 0.5, 0.0]], float)
    folded = np.array([[0, 1, 2], [0, 3, 1]], np.int64)  # the same side of edge 0-1, flat
    assert stress.triangle_pairs_added(V, folded, np.array([False, True])) == 1
    V2 = V.copy()
    V2[3] = [0.5, -0.5, 0.3]  # the other side of the edge: an ordinary hinge
    assert stress.triangle_pairs_added(V2, folded, np.array([False, True])) == 0


def test_a_crossing_beside_a_duplicated_shared_corner_is_one_pair():
    # B shares A's corner (0,0,0) through a duplicate vertex; its opposite edge pierces A
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [0.3, 0.3, -0.5], [0.3, 0.3, 0.5]], float)
    F = np.array([[0, 1, 2], [3, 4, 5]], np.int64)
    assert stress.triangle_pairs_added(V, F, np.array([False, True])) == 1


def test_closed_loops_tells_a_filled_hole_from_an_open_one():
    V, F = shapes.icosphere(2)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.5, seed=1)
    from shellrepair.holes.loops import boundary_loops

    loops, _ = boundary_loops(F2, len(V2))
    assert len(loops) == 2
    # fill the first loop with a fan around a new centre vertex
    lp = loops[0]
    c = len(V2)
    fan = np.column_stack([np.roll(lp, -1), lp, np.full(len(lp), c)])
    Vo = np.vstack([V2, V2[lp].mean(axis=0)])
    Fo = np.vstack([F2, fan])
    in_to_out = np.arange(len(V2))
    assert stress.closed_loops(loops, in_to_out, Fo).tolist() == [True, False]
    # a third face on a rim edge leaves the loop open (non-manifold)
    extra = np.array([[lp[1], lp[0], c]])
    assert stress.closed_loops(loops, in_to_out, np.vstack([Fo, extra])).tolist() == [False, False]
    # a loop vertex missing from the output leaves it open
    gone = in_to_out.copy()
    gone[lp[0]] = -1
    assert stress.closed_loops(loops, gone, Fo).tolist() == [False, False]


def test_cases_are_reproducible_from_seed_and_index():
    a = stress.stress_case(3, 7, quick=True, family="slit", shape="bumpy")
    b = stress.stress_case(3, 7, quick=True, family="slit", shape="bumpy")
    c = stress.stress_case(4, 7, quick=True, family="slit", shape="bumpy")
    assert np.array_equal(a.V, b.V) and np.array_equal(a.F, b.F) and a.params == b.params
    assert not (len(a.F) == len(c.F) and np.array_equal(a.V, c.V))


def test_a_ragged_case_moves_only_its_rims_and_next_ring_along_their_normals_and_keeps_the_clean_truth():
    clean = stress.stress_case(0, 7, quick=True, family="discs", shape="bumpy")
    rag = stress.stress_case(0, 7, quick=True, family="discs", shape="bumpy", ragged=0.2)
    assert np.array_equal(rag.F, clean.F) and np.array_equal(rag.V_true, clean.V_true)
    assert rag.params["ragged"] == 0.2 and "ragged" not in clean.params
    moved = np.flatnonzero(np.any(rag.V != clean.V, axis=1))
    from shellrepair.mesh.topology import boundary_half_edges, half_edge_ends

    rim = np.unique(half_edge_ends(clean.F, boundary_half_edges(clean.F, len(clean.V))))
    ring = np.unique(clean.F[np.isin(clean.F, rim).any(axis=1)])
    assert np.isin(rim, moved).mean() > 0.9 and np.isin(moved, ring).all()
    # along the normal: the offsets are about sigma edges, not a tangential slide
    E = np.concatenate([clean.F[:, [0, 1]], clean.F[:, [1, 2]]])
    h = np.linalg.norm(clean.V[E[:, 0]] - clean.V[E[:, 1]], axis=1).mean()
    off = np.linalg.norm(rag.V[rim] - clean.V[rim], axis=1)
    assert 0.1 * h < np.sqrt(np.mean(off ** 2)) < 0.3 * h
    # the same draw for the same case, and none at 0
    again = stress.stress_case(0, 7, quick=True, family="discs", shape="bumpy", ragged=0.2)
    assert np.array_equal(again.V, rag.V)
    assert np.array_equal(stress.stress_case(0, 7, quick=True, family="discs", shape="bumpy", ragged=0.0).V, clean.V)


def test_scanner_cases_keep_the_unseen_area_in_their_range():
    for fam in ("scanner", "scanner-hard"):
        case = stress.stress_case(0, 11, quick=True, family=fam, shape="torus-0.3")
        lo, hi = stress.UNSEEN[fam]
        assert lo < case.params["unseen_area_pct"] / 100 <= hi, case.params
        assert 3 <= case.params["views"] <= 16


def test_every_family_is_drawn_once_in_six_cases():
    assert sorted(stress.family_of(i, 1000) for i in range(6)) == sorted(stress.FAMILIES)


# --------------------------------------------------------------------------
# the slice: ours on a few seeded cases
# --------------------------------------------------------------------------
#: (family, shape, index, seed) -> the properties the current fill misses there
SLICE = {
    ("band", "torus-0.5", 1, 2): {},
    ("slit", "torus-0.5", 0, 0): {},
    ("scanner", "genus2", 1, 0): {},
    ("base", "bumpy", 0, 1): {},
    ("band", "torus-0.15", 5, 3): {},
    # a star's arm cut off by a band: the tip a capped tube (back ratio 2.7 %,
    # 62 % of it edge-on), read closed, joined to the arm by a tube
    ("band", "star", 0, 5): {},
    # a torus seen from a ring at 0.9°: its inner band's two loops share 8
    # vertices (the band pinched there); both caps made the same chords
    # between them, one failed; now the band's 8 parts are filled
    ("scanner", "torus-0.5", 0, 135): {},
    ("scanner-hard", "bumpy", 3, 2): {
        "classed": "a bumpy sphere 42 % unseen from a ring at 55° is what one view of a ball records: past "
                   "~39 % unseen the piece reads as a single view and its loop as a border (documented; "
                   "--closed yes fills it)",
        "topology": "the loop classed border stays open"},
}


@lru_cache(maxsize=None)
def _outcome(key):
    from eval import peers

    family, shape, index, seed = key
    case = stress.stress_case(index, seed, quick=True, family=family, shape=shape)
    facts = stress.input_facts(case)
    V, F, info = peers.run_tool(stress.OURS, case.V, case.F)  # the default call
    return case, facts, stress.measure(case, facts, V, F, n_samples=2000), info


def _params(prop):
    out = []
    for key, fails in SLICE.items():
        marks = [pytest.mark.xfail(strict=False, reason=fails[prop])] if prop in fails else []
        out.append(pytest.param(key, marks=marks, id="-".join(map(str, key))))
    return out


@pytest.mark.parametrize("key", _params("originals"))
@pytest.mark.slow
def test_slice_keeps_original_vertices_bit_identical(key):
    _, _, m, _ = _outcome(key)
    assert m["orig_changed"] == 0


@pytest.mark.parametrize("key", _params("intersections"))
def test_slice_adds_no_self_intersection(key):
    _, _, m, _ = _outcome(key)
    assert m["si_added"] == 0


@pytest.mark.parametrize("key", _params("closed"))
def test_slice_closes_every_hole_loop(key):
    _, _, m, info = _outcome(key)
    assert m["holes_closed"] == m["holes"], info["statuses"]
    assert m["nonmanifold_edges"] == 0


@pytest.mark.parametrize("key", _params("classed"))
def test_slice_classes_every_loop_of_a_closed_truth_hole(key):
    _, facts, _, _ = _outcome(key)
    assert facts["is_hole"].all(), facts["border_reasons"]


@pytest.mark.parametrize("key", _params("topology"))
def test_slice_restores_the_truths_topology(key):
    _, _, m, _ = _outcome(key)
    assert m["watertight"] and m["euler"] == m["euler_truth"], (m["euler"], m["euler_truth"], m["boundary_edges"])


def test_an_implicit_shape_is_kept_once_built_and_read_back_the_same(tmp_path, monkeypatch):
    # pymeshlab's remeshing did not always give the same mesh in another
    # process: a regret run's forced rows and a later run's default were
    # measured on different cases; the first build is kept for every later one
    from eval import stress

    monkeypatch.setattr(stress, "SHAPE_CACHE", tmp_path)
    V1, F1, meta1 = stress.implicit_shape("dumbbell", True)
    kept = list(tmp_path.glob("dumbbell-quick-*.npz"))
    assert len(kept) == 1
    V2, F2, meta2 = stress.implicit_shape("dumbbell", True)
    assert np.array_equal(V1, V2) and np.array_equal(F1, F2) and meta1 == meta2
    kept[0].write_bytes(b"not a kept shape")         # a damaged file is built and kept again
    V3, F3, _ = stress.implicit_shape("dumbbell", True)
    assert len(F3) > 0
    with np.load(kept[0]) as z:
        assert np.array_equal(z["F"], F3)
