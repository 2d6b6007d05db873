"""A scan's planar opening met edge-on: faired, unless the user says its
base is there (``--base flat``); a CAD face's outline is capped flat."""

import numpy as np

from shellrepair import Mesh, detect_holes
from eval import shapes
from shellrepair.repair import repair_mesh

NU, NH = 48, 40


def walls_open_below(fillet, noise=1e-3):
    """A closed-top cylinder (radius 0.5, z in [-1, 1]) whose bottom was not
    scanned: its rim at z ≈ -1. With ``fillet``, its last two rows of
    vertices bend in towards the axis, as the scan of a base's rounded
    edge does."""
    V, F = shapes.cylinder(0.5, 2.0, NU, NH)
    top = np.arange(NU) * (NH + 1) + NH
    c = len(V)
    V = np.vstack([V, [[0.0, 0.0, 1.0]]])
    F = np.vstack([F, np.column_stack([top, np.roll(top, -1), np.full(NU, c)])])
    rim = np.arange(NU) * (NH + 1)
    if fillet:
        for row, r in ((0, 0.40), (1, 0.47)):
            i = rim + row
            V[i, :2] *= r / 0.5
    V[rim, 2] += noise * np.random.default_rng(0).standard_normal(NU)
    return V, F, rim


def test_walls_cut_across_an_opening_are_continued_below_it():
    V, F, rim = walls_open_below(fillet=False)
    scan = detect_holes(V, F, fill_borders=True)
    assert 1e-6 < scan.loops[0].planarity < 0.02        # a scan's opening, not a CAD face
    R, rep = repair_mesh(Mesh(V=V, F=F), fill_borders=True)
    assert rep["holes_after"] == 0
    assert rep["holes"][0]["option"].startswith("faired order")     # faired (order 2 or 3 by the auto rule), not capped
    assert R.V[R.vertex_filled][:, 2].max() < V[rim, 2].min()     # a dome below the rim


def test_a_base_whose_edge_the_scan_rounds_into_is_faired_unless_the_user_says_flat():
    """Until 2026-12-06 walls rounding into a planar opening got a flat cap
    by a rule; measured against always fairing it lost (patch.EDGE_ON_COS),
    so only the user's ``--base flat`` caps a scan's opening flat."""
    V, F, rim = walls_open_below(fillet=True)
    scan = detect_holes(V, F, fill_borders=True)
    assert 1e-6 < scan.loops[0].planarity < 0.02
    R, rep = repair_mesh(Mesh(V=V, F=F), fill_borders=True)
    assert rep["holes_after"] == 0
    assert rep["holes"][0]["option"].startswith("faired order")
    assert R.V[R.vertex_filled][:, 2].max() < V[rim, 2].min()     # a dome below the rim
    R, rep = repair_mesh(Mesh(V=V, F=F), fill_borders=True, base="flat")
    assert rep["holes"][0]["option"].startswith("flat cap")
    z = R.V[R.vertex_filled][:, 2]
    assert np.abs(z - V[rim, 2].mean()).max() < 0.01           # in the opening's plane


def test_the_user_says_what_a_planar_opening_is():
    """base="flat": walls cut straight across are capped in the opening's
    plane all the same (the figure stood there); base="faired": walls that
    round into the opening are continued below it. The report says which."""
    V, F, rim = walls_open_below(fillet=False)
    R, rep = repair_mesh(Mesh(V=V, F=F), fill_borders=True, base="flat")
    assert rep["holes_after"] == 0 and rep["base"] == "flat"
    assert rep["holes"][0]["option"].startswith("flat cap")
    assert np.abs(R.V[R.vertex_filled][:, 2] - V[rim, 2].mean()).max() < 0.01
    V, F, rim = walls_open_below(fillet=True)
    R, rep = repair_mesh(Mesh(V=V, F=F), fill_borders=True, base="faired")
    assert rep["holes_after"] == 0 and rep["base"] == "faired"
    assert rep["holes"][0]["option"].startswith("faired order")
    assert R.V[R.vertex_filled][:, 2].max() < V[rim, 2].min()
    assert np.array_equal(R.V[: len(V)], V)                        # the scan's own vertices untouched


def test_base_takes_three_words():
    import pytest

    from shellrepair.cli import build_parser
    from shellrepair.errors import MeshError
    from shellrepair.options import RepairOptions

    with pytest.raises(MeshError, match="base must be 'auto', 'flat' or 'faired'"):
        RepairOptions(base="round")
    assert build_parser().parse_args(["repair", "x.ply", "--base", "flat"]).base == "flat"
    assert build_parser().parse_args(["batch", "d", "-o", "o", "--base", "faired"]).base == "faired"
    assert build_parser().parse_args(["repair", "x.ply"]).base == "auto"


def test_base_flat_that_cannot_apply_says_why_in_the_row():
    """--base flat caps openings the scan meets edge-on; on a round hole in
    a sphere (the sphere runs on into the opening's plane) it does not
    apply, and the row says so instead of keeping silent."""
    from eval import shapes
    from shellrepair import Mesh
    from shellrepair.repair import repair_mesh

    V, F = shapes.icosphere(4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[int(np.argmax(V[:, 2]))], radius=0.4)
    _, flat = repair_mesh(Mesh(V=V2, F=F2), base="flat")
    row = flat["holes"][0]
    assert row["status"] == "filled" and not row["option"].startswith("flat cap")
    assert "--base flat does not apply: the scan beside it does not stand across its plane" in row["option"]
    _, auto = repair_mesh(Mesh(V=V2, F=F2))
    assert "--base flat" not in auto["holes"][0]["option"]
