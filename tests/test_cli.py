"""The command line, driven through main([...])."""

import json

import numpy as np

from shellrepair import Mesh, write_mesh, shapes
from shellrepair.cli import main


def _perforated(tmp_path, name="s.ply"):
    V, F = shapes.icosphere(3)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.3, seed=2)
    p = tmp_path / name
    write_mesh(p, Mesh(V=V2, F=F2))
    return p


def test_holes_json_lists_loops_and_counts(tmp_path, capsys):
    p = _perforated(tmp_path)
    assert main(["holes", str(p), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["holes"] == 2 and d["borders"] == 0 and d["components"] == 1
    assert d["file"] == str(p) and d["faces"] > 0 and d["vertices"] > 0
    assert len(d["loops"]) == 2
    for lp in d["loops"]:
        assert {"edges", "perimeter", "mean_edge", "area", "diameter", "planarity", "component", "kind"} <= set(lp)


def test_holes_table_is_readable(tmp_path, capsys):
    p = _perforated(tmp_path)
    assert main(["holes", str(p)]) == 0
    out = capsys.readouterr().out
    assert "2 holes, 0 borders" in out


def test_bad_file_is_one_line_and_exit_2(tmp_path, capsys):
    p = tmp_path / "bad.ply"
    p.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\n")
    assert main(["holes", str(p)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {p}: ")
    assert "Traceback" not in err


def test_repair_table_says_how_holes_were_filled(tmp_path, capsys):
    V, F = shapes.icosphere(3)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.3, seed=2)
    p = tmp_path / "s.ply"
    write_mesh(p, Mesh(V=V2, F=F2))
    assert main(["repair", str(p), "-o", str(tmp_path / "o.ply")]) == 0
    assert "filled by: faired order 2 ×2" in capsys.readouterr().out
