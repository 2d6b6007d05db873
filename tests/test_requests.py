"""Per-hole requests: a hole left open on purpose, an order for one hole, a
cut capped flat, a border filled (RepairOptions.leave_open, .order_for,
.cap_flat, .fill)."""

import numpy as np
import pytest

from eval import shapes
from shellrepair import Mesh, read_mesh, write_mesh
from shellrepair.cli import main
from shellrepair.errors import MeshError
from shellrepair.holes.loops import detect_holes
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
                                 dict(order_for={1: True}), dict(leave_open=[1], order_for={1: 2}),
                                 dict(cap_flat=[-2]), dict(fill="1"), dict(cap_flat=[1], order_for={1: 3}),
                                 dict(leave_open=[1], cap_flat=[1]), dict(leave_open=[2], fill=[2])])
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


def cup(noise=1e-3, seed=0):
    """An open cylinder closed at the bottom: its top rim is a cut through
    walls that run on, planar to ``noise`` (a scan's, not CAD's)."""
    V, F = shapes.cylinder(0.5, 2.0, 48, 40)
    bottom = np.flatnonzero(V[:, 2] == -1.0)
    bottom = bottom[np.argsort(np.arctan2(V[bottom, 1], V[bottom, 0]))]
    fan = np.column_stack([bottom, np.roll(bottom, -1), np.full(len(bottom), len(V))])
    used = {(a, b) for f in F.tolist() for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    if (bottom[0], bottom[1]) in used:
        fan = fan[:, ::-1]
    V = np.vstack([V, [[0.0, 0.0, -1.0]]])
    top = V[:, 2] == 1.0
    V[top, 2] += np.random.default_rng(seed).uniform(-noise, noise, int(top.sum()))
    return V, np.vstack([F, fan])


def test_a_cut_capped_flat_by_request_stays_in_the_plane_of_its_rim():
    V, F = cup()
    (hole,) = detect_holes(V, F).holes
    rim = np.abs(V[hole.vertices, 2] - 1.0).max()
    R, rep = repair_mesh(Mesh(V=V, F=F))
    assert np.abs(R.V[len(V):, 2] - 1.0).max() > 100 * rim          # by itself: a dome over the cut
    R, rep = repair_mesh(Mesh(V=V, F=F), cap_flat=[hole.id])
    (row,) = rep["holes"]
    assert row["status"] == "filled" and row["requested"] == "flat cap"
    assert row["option"].startswith("flat cap by request")
    assert len(R.V) > len(V) and np.abs(R.V[len(V):, 2] - 1.0).max() <= rim
    assert rep["boundary_edges_after"] == 0


def test_loops_capped_flat_are_not_bridged_by_a_tube():
    # a pipe with a band missing across its middle: by itself a tube closes the band
    V, F = cup()
    V, F, _ = shapes.remove_faces(V, F, (np.abs(V[F][:, :, 2]) < 0.2).all(axis=1))
    ids = [h.id for h in detect_holes(V, F).holes if h.edges == 48 and np.abs(V[h.vertices, 2]).max() < 0.5]
    assert len(ids) == 2
    _, rep = repair_mesh(Mesh(V=V, F=F))
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    R, rep = repair_mesh(Mesh(V=V, F=F), cap_flat=ids)
    rep["holes"] = [h for h in rep["holes"] if h["id"] in ids]
    assert [h["new_faces"] > 0 for h in rep["holes"]] == [True, True]     # a cap each, no tube
    assert all(b["chosen"] != "tube" for b in rep["bridges"])
    for h in rep["holes"]:
        assert h["option"].startswith("flat cap by request")


def test_a_loop_classed_border_is_filled_by_request_and_only_then():
    V, F = shapes.icosphere(4)
    V, F, _ = shapes.remove_faces(V, F, (V[F][:, :, 2] > 0.0).any(axis=1))   # a bowl
    (rim,) = detect_holes(V, F).loops
    assert rim.kind == "border"
    _, rep = repair_mesh(Mesh(V=V, F=F))
    assert rep["holes_before"] == 0 and rep["boundary_edges_after"] == rim.edges
    R, rep = repair_mesh(Mesh(V=V, F=F), fill=[rim.id])
    (row,) = rep["holes"]
    assert row["status"] == "filled" and row["requested"] == "fill"
    assert rep["holes_before"] == 1 and rep["boundary_edges_after"] == 0 and rep["interpolation_rate"] == 100.0
    with pytest.raises(MeshError, match="no loop with id 5"):
        repair_mesh(Mesh(V=V, F=F), fill=[5])


def test_the_command_line_takes_cap_flat_and_fill(tmp_path):
    import json

    V, F = cup()
    (hole,) = detect_holes(V, F).holes
    p = tmp_path / "cup.ply"
    write_mesh(p, Mesh(V=V, F=F))
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--cap-flat", str(hole.id),
                 "--fill", str(hole.id), "--quiet"]) == 0
    (row,) = json.loads((tmp_path / "o.report.json").read_text())["holes"]
    assert row["requested"] == "flat cap, fill" and row["option"].startswith("flat cap by request")


def test_max_hole_takes_a_length_in_the_scans_units(tmp_path, capsys):
    import json

    V, F, ids = three_holes()
    V = V * 100 + 5e4                         # a 200 mm ball, far from the origin
    scan = detect_holes(V, F)
    widths = sorted(L.diameter for L in scan.loops)
    limit = (widths[0] + widths[1]) / 2        # between the narrowest hole and the others
    p = tmp_path / "ball.ply"
    write_mesh(p, Mesh(V=V, F=F))
    for arg, unit in ((f"{limit:.6f}mm", []), (f"{limit / 10:.7f}cm", []), (f"{limit:.6f}mm", ["--unit", "mm"])):
        assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--max-hole", arg, *unit, "--quiet"]) == 0
        d = json.loads((tmp_path / "o.report.json").read_text())
        assert d["holes_before"] == 1 and len(d["border_loops"]) == 2, arg
        assert all(b["reason"].startswith("wider than max_hole") for b in d["border_loops"])
        assert d["unit"].startswith("mm (")
    # a scan in metres: its loops are ~60 m wide, every one over the limit
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--max-hole", f"{limit:.6f}mm",
                 "--unit", "m", "--quiet"]) == 0
    d = json.loads((tmp_path / "o.report.json").read_text())
    assert d["holes_before"] == 0 and len(d["border_loops"]) == 3 and d["unit"] == "m (given)"
    with pytest.raises(SystemExit):
        main(["repair", str(p), "--max-hole", "20 furlongs"])
    assert "must be a number of edges" in capsys.readouterr().err
    with pytest.raises(MeshError):
        RepairOptions(max_hole_size=(-1, "mm"))


def _three_holes_and_their_plan(tmp_path, capsys):
    """``three_holes()`` written to ``s.ply`` and its ``holes --json``:
    (V, F, hole ids, the scan's path, the plan)."""
    import json

    V, F, ids = three_holes()
    p = tmp_path / "s.ply"
    write_mesh(p, Mesh(V=V, F=F))
    assert main(["holes", str(p), "--json"]) == 0
    return V, F, ids, p, json.loads(capsys.readouterr().out)


def test_a_plan_edited_from_holes_json_steers_the_repair_and_is_refused_on_another_scan(tmp_path, capsys):
    import json

    V, F, (a, b, c), p, plan = _three_holes_and_their_plan(tmp_path, capsys)
    by_id = {lp["id"]: lp for lp in plan["loops"]}
    by_id[a]["action"] = "leave open"
    by_id[b]["action"] = "order 1"
    (tmp_path / "plan.json").write_text(json.dumps(plan))
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--plan", str(tmp_path / "plan.json"),
                 "--cap-flat", str(c), "--quiet"]) == 0
    d = json.loads((tmp_path / "o.report.json").read_text())
    rows = {h["id"]: h for h in d["holes"]}
    assert [rows[i].get("requested") for i in (a, b, c)] == ["left open", "order 1", "flat cap"]
    assert rows[a]["status"] == "skipped" and rows[b]["option"].startswith("faired order 1")
    assert d["plan"] == str(tmp_path / "plan.json")
    # the same plan on another scan (other holes): refused before any work, nothing written
    V2, F2, _, _ = shapes.perforate_discs(*shapes.icosphere(4), n_holes=3, radius=0.25, seed=7)
    q = tmp_path / "other.ply"
    write_mesh(q, Mesh(V=V2, F=F2))
    assert main(["repair", str(q), "-o", str(tmp_path / "x.ply"), "--plan", str(tmp_path / "plan.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the plan was made for another scan" in err
    assert not (tmp_path / "x.ply").exists()


@pytest.mark.parametrize("text", ["[1, 2]", '{"leave_open": "3"}', '{"order_for": {"1": 4}}', '{"fil": [1]}',
                                  '{"loops": [{"id": 1, "action": "paint it"}]}', "not json"])
def test_a_file_that_is_not_a_plan_is_one_error(tmp_path, capsys, text):
    V, F, _ = three_holes()
    p = tmp_path / "s.ply"
    write_mesh(p, Mesh(V=V, F=F))
    (tmp_path / "plan.json").write_text(text)
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--plan", str(tmp_path / "plan.json")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "plan" in err
    assert not (tmp_path / "o.ply").exists()


def test_a_perforated_statue_repaired_with_a_plan_file_does_what_the_plan_says(tmp_path, capsys):
    # issue 41's case: a real bust with three holes; the plan, edited from
    # `holes --json`, leaves one open, caps one flat and forces order 3 on the third
    import json

    from conftest import shared_scan

    M = read_mesh(shared_scan("closed_nefertiti_bust.ply"))
    diag = float(np.linalg.norm(np.ptp(M.V, axis=0)))
    V, F, _, _ = shapes.perforate_discs(M.V, M.F, n_holes=3, radius=0.03 * diag, seed=3)
    p = tmp_path / "bust.ply"
    write_mesh(p, Mesh(V=V, F=F))
    assert main(["holes", str(p), "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    ids = [lp["id"] for lp in plan["loops"] if lp["kind"] == "hole"]
    assert len(ids) == 3
    a, b, c = ids
    actions = {a: "leave open", b: "cap flat", c: "order 3"}
    for lp in plan["loops"]:
        if lp["id"] in actions:
            lp["action"] = actions[lp["id"]]
    (tmp_path / "plan.json").write_text(json.dumps(plan))
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--plan", str(tmp_path / "plan.json"),
                 "--quiet"]) == 0
    d = json.loads((tmp_path / "o.report.json").read_text())
    rows = {h["id"]: h for h in d["holes"]}
    assert [rows[i]["requested"] for i in (a, b, c)] == ["left open", "flat cap", "order 3"]
    assert rows[a]["status"] == "skipped" and rows[a]["new_faces"] == 0
    assert rows[b]["status"] == "filled" and rows[b]["option"].startswith("flat cap by request")
    assert rows[c]["status"] == "filled" and "order 3" in rows[c]["option"]
    # what the report says is what the mesh has: the hole left open is the one open loop
    R = read_mesh(tmp_path / "o.ply")
    (left,) = detect_holes(R.V, R.F, fill_borders=True).loops
    holes = {L.id: L for L in detect_holes(V, F).loops}
    assert sorted(R.V[left.vertices].tolist()) == sorted(V[holes[a].vertices].tolist())
    assert d["holes_after"] == 1 and d["plan"] == str(tmp_path / "plan.json")


def test_a_plan_can_ask_for_the_flat_triangulation_of_one_hole(tmp_path, capsys):
    import json

    _, _, (a, b, c), p, plan = _three_holes_and_their_plan(tmp_path, capsys)
    next(lp for lp in plan["loops"] if lp["id"] == b)["action"] = "order flat"
    (tmp_path / "plan.json").write_text(json.dumps(plan))
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply"), "--plan", str(tmp_path / "plan.json"), "-q"]) == 0
    rows = {h["id"]: h for h in json.loads((tmp_path / "o.report.json").read_text())["holes"]}
    assert rows[b]["requested"] == "order flat" and rows[b]["kind"] == "flat" and rows[b]["new_vertices"] == 0
    assert rows[a]["kind"] == rows[c]["kind"] == "faired"
