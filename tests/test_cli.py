"""The command line, driven through main([...])."""

import io
import json
import re

import numpy as np
import pytest

from shellrepair import Mesh, write_mesh
from eval import shapes
from shellrepair.cli import main
from terminal import screen


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
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.strip().startswith("filled by:"))
    parts = [re.fullmatch(r"faired order ([123]) ×(\d+)", x.strip()) for x in line.split(":", 1)[1].split(",")]
    assert all(parts) and sum(int(m.group(2)) for m in parts) == 2      # each hole's kind, counted


# ---------------------------------------------------------------------------
# -q / --quiet: no bar, nothing on stdout but asked-for JSON, errors unchanged
# ---------------------------------------------------------------------------
class _Tty(io.StringIO):
    """A stderr that says it is a terminal, so the bars would be drawn."""

    def isatty(self):
        return True


def _commands(tmp_path):
    """One successful run of each subcommand (the arguments after the subcommand name)."""
    scan = _perforated(tmp_path)
    folder = tmp_path / "in"
    folder.mkdir()
    _perforated(folder, "a.ply")
    return {"holes": ["holes", str(scan)],
            "repair": ["repair", str(scan), "-o", str(tmp_path / "o.ply")],
            "batch": ["batch", str(folder), "-o", str(tmp_path / "out"), "--no-html"],
            "render": ["render", str(scan), "-o", str(tmp_path / "v.png"), "--size", "48x32"]}


@pytest.mark.parametrize("cmd", ["holes", "repair", "batch", "render"])
@pytest.mark.slow
def test_quiet_prints_nothing_and_draws_no_bar_on_a_terminal(tmp_path, monkeypatch, capsys, cmd):
    args = _commands(tmp_path)[cmd]
    tty = _Tty()
    monkeypatch.setattr("sys.stderr", tty)
    assert main(args) == 0
    loud_out, loud_err = capsys.readouterr().out, tty.getvalue()
    assert loud_out.strip() and "[" in loud_err  # without -q: a table on stdout, bars on the terminal
    tty.seek(0)
    tty.truncate()
    assert main(args + ["-q"]) == 0
    assert capsys.readouterr().out == "" and tty.getvalue() == ""
    assert main(args + ["--quiet"]) == 0
    assert capsys.readouterr().out == "" and tty.getvalue() == ""


def test_quiet_still_writes_the_outputs(tmp_path, capsys):
    args = _commands(tmp_path)
    assert main(args["repair"] + ["-q"]) == 0
    assert main(args["batch"] + ["-q"]) == 0
    assert main(args["render"] + ["-q"]) == 0
    assert (tmp_path / "o.ply").stat().st_size > 0 and (tmp_path / "o.report.json").stat().st_size > 0
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["n_ok"] == 1
    assert (tmp_path / "v.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert capsys.readouterr().out == ""


def test_quiet_keeps_the_json_that_is_asked_for(tmp_path, capsys):
    assert main(_commands(tmp_path)["holes"] + ["-q", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["holes"] == 2


@pytest.mark.parametrize("cmd", ["holes", "repair", "render"])
def test_quiet_errors_are_still_one_line_with_the_same_exit_status(tmp_path, capsys, cmd):
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\n")
    args = {"holes": ["holes", str(bad)], "repair": ["repair", str(bad)],
            "render": ["render", str(bad), "-o", str(tmp_path / "v.png")]}[cmd]
    assert main(args) == 2
    loud = capsys.readouterr().err
    assert main(args + ["-q"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == loud and err.count("\n") == 1 and err.startswith(f"error: {bad}: ")


@pytest.mark.slow
def test_quiet_batch_still_names_each_failed_scan_on_stderr_and_exits_2(tmp_path, capsys):
    args = _commands(tmp_path)["batch"]
    (tmp_path / "in" / "bad.stl").write_bytes(b"not an stl")
    assert main(args + ["-q"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == f"error: {tmp_path / 'in' / 'bad.stl'}: not an STL file\n"


def test_the_terminal_bar_is_made_only_for_a_terminal_and_not_when_quiet(monkeypatch):
    from shellrepair.progress import TerminalBar, terminal_bar

    monkeypatch.setattr("sys.stderr", io.StringIO())
    assert terminal_bar() is None
    tty = _Tty()
    monkeypatch.setattr("sys.stderr", tty)
    assert terminal_bar(quiet=True) is None
    bar = terminal_bar()
    assert isinstance(bar, TerminalBar)
    bar("loading a.ply", 0, 4)
    bar("loading a.ply", 4, 4)
    lines, _ = screen(tty.getvalue())
    assert len(lines) == 1 and lines[0].startswith("loading a.ply [") and "4/4 100%" in lines[0]
    bar.clear()  # wiped: what is printed next starts at column 0 of an empty line
    assert screen(tty.getvalue()) == ([""], 0)
    bar("writing a.ply", 1, 2)
    bar.end()  # the last state stays, and the line is ended
    lines, column = screen(tty.getvalue())
    assert lines[0].startswith("writing a.ply [") and "1/2" in lines[0] and lines[1:] == [""] and column == 0


def test_a_view_with_a_negative_azimuth_is_read_as_a_value(tmp_path):
    # `--view -46,12` (argparse alone takes "-46,12" for an option and stops)
    from shellrepair.cli import parse_args, signed_values

    args = parse_args(["render", "m.ply", "-o", "x.png", "--view", "-46,12"])
    assert args.view == "-46,12" or tuple(args.view) == (-46.0, 12.0)
    assert signed_values(["render", "m.ply", "--view", "-46,12"])[-1] == "--view=-46,12"


def test_render_prints_the_camera_it_picked_so_it_can_be_given_again(tmp_path, capsys):
    from shellrepair.appearance import render as rd
    from shellrepair.repair import repair_mesh

    V, F = shapes.icosphere(3)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=1, radius=0.4, seed=5)
    R, _ = repair_mesh(Mesh(V=V2, F=F2))
    write_mesh(tmp_path / "r.ply", R)
    assert main(["render", str(tmp_path / "r.ply"), "-o", str(tmp_path / "a.png"), "--highlight-filled",
                 "--size", "96x72"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("view: "))
    az, el = (float(x) for x in line.split()[1].split(","))
    want = rd.view_towards(R.V, R.F, R.face_filled, up=(0.0, 1.0, 0.0))   # --up y, the default
    assert "picked to face the filled faces" in line and np.allclose((az, el), want, atol=1e-8)
    assert main(["render", str(tmp_path / "r.ply"), "-o", str(tmp_path / "b.png"), "--size", "96x72"]) == 0
    assert "view: 25,15 (the default" in capsys.readouterr().out
