"""Per-hole requests: a hole left open on purpose, an order for one hole (RepairOptions.leave_open, .order_for)."""

import numpy as np
import pytest

from eval import shapes
from shellrepair import Mesh, write_mesh
from shellrepair.cli import main
from shellrepair.errors import MeshError
from shellrepair.holes import detect_holes
from shellrepair.options import RepairOptions
from shellrepair.repair import repair_mesh


def three_holes():
    V, F = shapes.icosphere(4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.25, seed=1)
    ids = [h.id for h in detect_holes(V2, F2).holes]
    assert len(ids) == 3
    return V2, F2, ids


def test_a_hole_left_open_stays_open_and_another_takes_the_order_asked_for():
    V, F, (a, b, c) = three_holes()
    R, rep = repair_mesh(Mesh(V=V, F=F), leave_open=[a], order_for={b: 1})
    rows = {h["id"]: h for h in rep["holes"]}
    assert rows[a]["status"] == "skipped" and rows[a]["reason"] == "left open by request"
    assert rows[a]["requested"] == "left open"
    assert rows[b]["status"] == "filled" and rows[b]["option"].startswith("faired order 1")
    assert rows[b]["requested"] == "order 1"
    assert rows[c]["status"] == "filled" and "auto: order" in rows[c]["option"] and "requested" not in rows[c]
    # the report counts the open hole: not 100 %, and its rim is still open in the output
    assert rep["holes_before"] == 3 and rep["holes_after"] == 1 and rep["interpolation_rate"] < 100
    open_loops = detect_holes(R.V, R.F).holes
    assert len(open_loops) == 1 and open_loops[0].edges == rows[a]["edges"]
    assert np.array_equal(R.V[:len(V)], V)


def test_a_request_for_a_hole_the_scan_does_not_have_is_one_error_before_any_work(tmp_path, capsys):
    V, F, ids = three_holes()
    with pytest.raises(MeshError, match="no hole with id 9"):
        repair_mesh(Mesh(V=V, F=F), order_for={9: 2})
    p = tmp_path / "s.ply"
    write_mesh(p, Mesh(V=V, F=F))
    out = tmp_path / "o.ply"
    assert main(["repair", str(p), "-o", str(out), "--leave-open", "9"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no hole with id 9" in err and not out.exists()


def test_the_command_line_takes_ids_and_id_order_pairs(tmp_path):
    V, F, (a, b, c) = three_holes()
    p = tmp_path / "s.ply"
    write_mesh(p, Mesh(V=V, F=F))
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--leave-open", str(a),
                 "--order-for", f"{b}=2,{c}=1", "--quiet"]) == 0
    import json
    rep = json.loads((tmp_path / "o.report.json").read_text())
    rows = {h["id"]: h for h in rep["holes"]}
    assert [rows[i]["status"] for i in (a, b, c)] == ["skipped", "filled", "filled"]
    assert rows[b]["option"].startswith("faired order 2") and rows[c]["option"].startswith("faired order 1")
    with pytest.raises(SystemExit):
        main(["repair", str(p), "--order-for", f"{b}=4"])


@pytest.mark.parametrize("bad", [dict(leave_open=[-1]), dict(leave_open="3"), dict(order_for={1: 4}),
                                 dict(order_for={1: True}), dict(leave_open=[1], order_for={1: 2})])
def test_requests_are_checked_with_the_other_options(bad):
    with pytest.raises(MeshError):
        RepairOptions(**bad)


def test_holes_lists_each_loops_id_and_centre_in_the_scans_units(tmp_path, capsys):
    V, F, ids = three_holes()
    shift = np.array([1.0e5, -2.0e5, 3.0e4])                 # millimetres far from the origin
    p = tmp_path / "s.ply"
    write_mesh(p, Mesh(V=V + shift, F=F))
    assert main(["holes", str(p), "--json"]) == 0
    import json
    d = json.loads(capsys.readouterr().out)
    scan = detect_holes(V + shift, F)
    for lp in d["loops"]:
        rim = scan.loops[lp["id"]].vertices
        assert np.allclose(lp["center"], (V + shift)[rim].mean(axis=0), rtol=0, atol=1e-6)
    assert main(["holes", str(p)]) == 0
    table = capsys.readouterr().out
    assert "centre (x, y, z)" in table and f"({lp['center'][0]:.7g}, " in table
