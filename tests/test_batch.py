"""Batch repair of a folder, parallel filling that does not change the output,
and the progress bar that only a terminal sees."""

import io
import json
import os

import numpy as np
import pytest
from scipy.spatial import cKDTree

from eval import shapes
from shellrepair import batch
from shellrepair.batch import default_jobs, list_scans, repair_folder, summary_table
from shellrepair.cli import main, parse_args
from shellrepair.mesh.io import Mesh, read_mesh, write_mesh
from shellrepair.progress import TerminalBar, as_callback, end_line, terminal_bar
from shellrepair.mesh.topology import edge_topology
from terminal import Tty, at_empty_line, screen


def ball_perforate(V, F, n_holes, radius, seed=0):
    """Remove the faces whose centroid lies within ``radius`` of one of
    ``n_holes`` seeded points of the surface (the scale benchmark's cut)."""
    rng = np.random.default_rng(seed)
    centres = V[rng.choice(len(V), n_holes, replace=False)]
    d, _ = cKDTree(centres).query(V[F].mean(axis=1))
    V2, F2, _ = shapes.remove_faces(V, F, d < radius)
    return V2, F2


@pytest.fixture
def many_holes():
    """A bumpy sphere (5120 faces) with ~24 small holes."""
    V, F = shapes.bumpy_sphere(4, amplitude=0.03, frequency=6)
    return ball_perforate(V, F, n_holes=24, radius=0.09, seed=3)


def _write_scans(folder, meshes):
    folder.mkdir()
    for name, (V, F) in meshes.items():
        write_mesh(folder / name, Mesh(V=V, F=F))


@pytest.mark.slow
def test_jobs_do_not_change_the_output(tmp_path, many_holes):
    V, F = many_holes
    holes = len(edge_topology(F, len(V)).boundary_he)
    assert holes > 0
    _write_scans(tmp_path / "in", {"statue.ply": many_holes})
    for jobs in (1, 2):
        assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / f"out{jobs}"), "--jobs", str(jobs)]) == 0
    one = (tmp_path / "out1" / "statue.repaired.ply").read_bytes()
    two = (tmp_path / "out2" / "statue.repaired.ply").read_bytes()
    assert one == two  # byte for byte
    r1 = json.loads((tmp_path / "out1" / "statue.report.json").read_text())
    r2 = json.loads((tmp_path / "out2" / "statue.report.json").read_text())
    assert r1["holes_before"] >= 20
    assert r1["holes_after"] == 0 and r1["boundary_edges_after"] == 0
    assert [(h["id"], h["status"], h["new_faces"]) for h in r1["holes"]] == \
        [(h["id"], h["status"], h["new_faces"]) for h in r2["holes"]]
    assert r2["jobs"] == 2
    # the repaired scan keeps the original vertices bit for bit, first
    out = read_mesh(tmp_path / "out2" / "statue.repaired.ply")
    assert np.array_equal(out.V[:len(V)], read_mesh(tmp_path / "in" / "statue.ply").V)
    assert edge_topology(out.F, len(out.V)).n_boundary_edges == 0


@pytest.mark.slow
def test_batch_goes_on_past_a_bad_scan(tmp_path, capsys, many_holes):
    V, F = shapes.icosphere(3)
    V2, F2 = ball_perforate(V, F, n_holes=3, radius=0.15, seed=1)
    _write_scans(tmp_path / "in", {"a.ply": (V2, F2), "c.obj": many_holes})
    (tmp_path / "in" / "b.off").write_text("OFF\n3 1 0\n0 0 0\n")  # truncated
    (tmp_path / "in" / "notes.txt").write_text("not a scan")
    outdir = tmp_path / "new_out"  # created by the batch
    assert main(["batch", str(tmp_path / "in"), "-o", str(outdir)]) == 2
    cap = capsys.readouterr()
    err_lines = [ln for ln in cap.err.splitlines() if ln]
    assert len(err_lines) == 1 and err_lines[0].startswith("error: ") and "b.off" in err_lines[0]
    assert "Traceback" not in cap.err
    for stem in ("a", "c"):  # the scans after and before the bad one were repaired
        assert (outdir / f"{stem}.repaired.ply").is_file()
        assert json.loads((outdir / f"{stem}.report.json").read_text())["holes_after"] == 0
    assert not list(outdir.glob("b.*"))  # nothing written for the bad scan
    s = json.loads((outdir / "summary.json").read_text())
    assert [r["file"] for r in s["scans"]] == ["a.ply", "b.off", "c.obj"]  # sorted, .txt ignored
    assert [r["status"] for r in s["scans"]] == ["ok", "error", "ok"]
    bad = s["scans"][1]
    assert "header disagrees" in bad["error"] and "\n" not in bad["error"]
    assert s["complete"] and s["n_ok"] == 2 and s["n_failed"] == 1
    assert s["holes_before"] == sum(r["holes_before"] for r in s["scans"] if r["status"] == "ok")
    assert s["holes_after"] == 0 and s["rate"] == 100.0
    # the printed table has a row per scan and the totals
    for name in ("a.ply", "b.off", "c.obj", "total"):
        assert any(ln.startswith(name) for ln in cap.out.splitlines())


@pytest.mark.slow
def test_all_good_exits_0_and_json_summary(tmp_path, capsys):
    V, F = shapes.icosphere(3)
    _write_scans(tmp_path / "in", {"x.ply": ball_perforate(V, F, 2, 0.15, seed=2)})
    assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["n_failed"] == 0 and s["scans"][0]["holes_before"] == 2 and s["scans"][0]["holes_after"] == 0


def test_without_dask_scans_run_one_at_a_time_on_all_the_cores(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(batch, "_import_distributed", lambda: None)  # as where dask is not installed
    V, F = shapes.icosphere(2)
    _write_scans(tmp_path / "in", {"p.ply": ball_perforate(V, F, 1, 0.3, seed=0),
                                   "q.ply": ball_perforate(V, F, 2, 0.25, seed=1)})
    assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--jobs", "2", "--no-html"]) == 0
    err = capsys.readouterr().err.strip()
    assert err.startswith("note: dask.distributed is not installed") and "shellrepair[cluster]" in err
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["runner"]["kind"] == "in-process" and s["runner"]["jobs_per_scan"] == 2
    assert s["n_ok"] == 2 and s["holes_after"] == 0
    assert json.loads((tmp_path / "out" / "q.report.json").read_text())["jobs"] == 2  # the holes had the cores


def test_scheduler_without_dask_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(batch, "_import_distributed", lambda: None)
    V, F = shapes.icosphere(2)
    _write_scans(tmp_path / "in", {"p.ply": (V, F)})
    assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--scheduler", "tcp://x:8786"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "shellrepair[cluster]" in err and "\n" not in err
    assert not (tmp_path / "out").exists()


def test_jobs_default_to_the_cores_there_are_in_batch_and_repair(tmp_path, capsys):
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert default_jobs() == cores >= 1
    assert parse_args(["batch", "in", "-o", "out"]).jobs == cores
    assert parse_args(["repair", "s.ply"]).jobs == cores  # the repair fills its holes on them too
    (tmp_path / "in").mkdir()
    assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--jobs", "0"]) == 2
    assert "jobs must be a whole number, at least 1, got 0" in capsys.readouterr().err


@pytest.mark.slow
def test_same_stem_gets_distinct_outputs(tmp_path):
    V, F = shapes.icosphere(2)
    V2, F2 = ball_perforate(V, F, 1, 0.3, seed=0)
    _write_scans(tmp_path / "in", {"bust.ply": (V2, F2), "bust.obj": (V2, F2)})
    s = repair_folder(tmp_path / "in", tmp_path / "out", progress=False)
    assert s["n_ok"] == 2
    assert (tmp_path / "out" / "bust.ply.repaired.ply").is_file()
    assert (tmp_path / "out" / "bust.obj.repaired.ply").is_file()


def test_output_into_the_scan_folder_is_not_rescanned(tmp_path):
    V, F = shapes.icosphere(2)
    _write_scans(tmp_path / "in", {"s.ply": ball_perforate(V, F, 1, 0.3, seed=0)})
    repair_folder(tmp_path / "in", tmp_path / "in", progress=False)
    s = repair_folder(tmp_path / "in", tmp_path / "in", progress=False)
    assert [r["file"] for r in s["scans"]] == ["s.ply"]
    assert [p.name for p in list_scans(tmp_path / "in")] == ["s.ply", "s.repaired.ply"]


@pytest.mark.parametrize("make, what", [
    (lambda p: None, "no such directory"),
    (lambda p: p.mkdir(), "no scans"),
])
def test_unusable_folder_is_one_line_exit_2(tmp_path, capsys, make, what):
    make(tmp_path / "scans")
    assert main(["batch", str(tmp_path / "scans"), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and what in err and "\n" not in err


def test_outdir_parent_must_exist(tmp_path, capsys):
    V, F = shapes.icosphere(2)
    _write_scans(tmp_path / "in", {"s.ply": (V, F)})
    assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / "no" / "such" / "out")]) == 2
    assert "parent does not exist" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


def test_summary_table_lines_up():
    s = {"scans": [{"file": "a.ply", "status": "ok", "error": None, "vertices": 1000, "faces": 2000,
                    "holes_before": 5, "holes_after": 1, "rate": 80.0, "seconds": 1.25},
                   {"file": "bad.stl", "status": "error", "error": "not an STL file", "vertices": None,
                    "faces": None, "holes_before": None, "holes_after": None, "rate": None, "seconds": 0.0}],
         "holes_before": 5, "holes_after": 1, "rate": 80.0, "seconds": 1.3, "n_ok": 1, "n_failed": 1}
    lines = summary_table(s).splitlines()
    assert lines[2].split() == ["a.ply", "1,000", "2,000", "5", "1", "80.0", "1.2", "ok"] or \
        lines[2].split() == ["a.ply", "1,000", "2,000", "5", "1", "80.0", "1.3", "ok"]
    assert lines[3].split()[-1] == "error"
    assert lines[-1] == "error: bad.stl: not an STL file"
    assert "error:" not in summary_table(s, errors=False)


# --------------------------------------------------------------------------
# progress
# --------------------------------------------------------------------------
def test_progress_is_silent_when_not_a_terminal(monkeypatch):
    quiet = io.StringIO()
    monkeypatch.setattr("sys.stderr", quiet)
    assert terminal_bar() is None
    as_callback(True)("filling holes", 1, 2)  # older callers' progress=True
    assert quiet.getvalue() == ""


def test_progress_draws_throttled_and_always_the_last_item():
    s = Tty()
    bar = TerminalBar(stream=s)
    for i in range(1, 1001):  # a thousand quick updates: tqdm redraws every MIN_INTERVAL s, not 1000 times
        bar("filling holes", i, 1000)
    assert s.getvalue().count("filling holes [") < 100
    lines, _ = screen(s.getvalue())
    assert len(lines) == 1 and lines[0].startswith("filling holes [") and "1000/1000 100%" in lines[0]
    assert lines[0].endswith(" s")  # the seconds since the label started


def test_a_new_label_or_a_new_loop_replaces_the_bar_on_its_line():
    s = Tty()
    bar = TerminalBar(stream=s)
    for i in range(1, 4):
        bar("2/3 bust.ply: filling holes", i, 3)
    lines, _ = screen(s.getvalue())
    assert len(lines) == 1 and lines[0].startswith("2/3 bust.ply: filling holes [") and "3/3 100%" in lines[0]
    bar("filling holes", 1, 5)  # a new label: a new bar, on the same line
    lines, _ = screen(s.getvalue())
    assert len(lines) == 1 and lines[0].startswith("filling holes [") and "1/5" in lines[0]
    bar("filling holes", 3, 5)
    bar("filling holes", 0, 5)  # the count goes down: a new loop
    lines, _ = screen(s.getvalue())
    assert len(lines) == 1 and "0/5" in lines[0]


def test_batch_bars_on_a_terminal_leave_each_scan_on_its_own_line(tmp_path, monkeypatch, capsys):
    V, F = shapes.icosphere(2)
    _write_scans(tmp_path / "in", {"p.ply": ball_perforate(V, F, 1, 0.3, seed=0),
                                   "q.ply": ball_perforate(V, F, 2, 0.25, seed=1)})
    tty = Tty()
    monkeypatch.setattr("sys.stderr", tty)
    bar = terminal_bar()
    lines = []
    # one scan at a time in this process: each scan draws its own bars
    # the caller wipes the bar's line before its own, as the command line does
    repair_folder(tmp_path / "in", tmp_path / "out", jobs=1, progress=bar,
                  on_scan=lambda r: (bar.clear(), lines.append(tty.tell())))
    end_line(bar)
    drawn = tty.getvalue()
    assert "1/2 p.ply: filling holes [" in drawn and "2/2 q.ply: filling holes [" in drawn
    shown, column = screen(drawn)
    assert shown[-2].startswith("scans [") and "2/2 100%" in shown[-2] and shown[-1] == "" and column == 0
    # before each per-scan line the bar's line is wiped and the cursor is at its start
    assert all(at_empty_line(drawn[:at]) for at in lines)


def test_loading_shows_its_stages_on_a_terminal_only(tmp_path, monkeypatch):
    V, F = shapes.icosphere(2)
    write_mesh(tmp_path / "bust.ply", Mesh(V=V, F=F))
    quiet = io.StringIO()
    monkeypatch.setattr("sys.stderr", quiet)
    read_mesh(tmp_path / "bust.ply", progress=True)
    assert quiet.getvalue() == ""
    tty = Tty()
    monkeypatch.setattr("sys.stderr", tty)
    m = read_mesh(tmp_path / "bust.ply", progress=True)  # older callers: a bar of this call's own
    drawn = tty.getvalue()
    assert "loading bust.ply [" in drawn and "0/4" in drawn and "4/4 100%" in drawn
    tty = Tty()
    monkeypatch.setattr("sys.stderr", tty)
    bar = terminal_bar()
    read_mesh(tmp_path / "bust.ply", progress=bar)
    lines, _ = screen(tty.getvalue())
    assert len(lines) == 1 and lines[0].startswith("loading bust.ply [") and "4/4 100%" in lines[0]
    assert not tty.getvalue().endswith("\n")              # left open for the repair's bars
    assert len(m.F) == len(F)


def test_an_error_after_a_bar_starts_on_its_own_line(tmp_path, monkeypatch):
    # a file that parses, then fails validation: the loading bar was drawn
    (tmp_path / "range.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    tty = Tty()
    monkeypatch.setattr("sys.stderr", tty)
    assert main(["repair", str(tmp_path / "range.obj")]) == 2
    out = tty.getvalue()
    assert "loading range.obj [" in out
    err = [ln for ln in out.split("\n") if "error:" in ln]
    assert err == ["error: " + err[0].split("error: ", 1)[1]]   # the whole line, from column 0
    assert out.endswith("\n")


def test_holes_command_ends_the_loading_bar_line(tmp_path, monkeypatch, capsys):
    V, F = shapes.icosphere(2)
    write_mesh(tmp_path / "bust.ply", Mesh(V=V, F=F[3:]))
    tty = Tty()
    monkeypatch.setattr("sys.stderr", tty)
    assert main(["holes", str(tmp_path / "bust.ply")]) == 0
    assert "loading bust.ply [" in tty.getvalue() and tty.getvalue().endswith("\n")
    assert "hole" in capsys.readouterr().out


def test_the_collection_page_reads_each_report_once_and_equals_a_fresh_build(tmp_path, monkeypatch):
    V, F = shapes.bumpy_sphere(3, amplitude=0.03, frequency=6)
    scans = {f"s{i}.ply": ball_perforate(V, F, n_holes=2, radius=0.15, seed=i) for i in range(2)}
    _write_scans(tmp_path / "in", scans)
    from shellrepair.report import html as htmlreport
    reads = []
    real = htmlreport.report_json
    monkeypatch.setattr(htmlreport, "report_json", lambda r: reads.append(1) or real(r))
    # the pictures are not what this checks: a 1-pixel stand-in spares their rendering
    monkeypatch.setattr(htmlreport, "figure", lambda *a, **k: {"png": b"\x89PNG", "alt": "scan", "width": 1, "height": 1})
    summary = repair_folder(tmp_path / "in", tmp_path / "out", jobs=1, html=True)
    assert len(reads) == 2  # one section per scan, not one per scan per rewrite
    written = (tmp_path / "out" / batch.INDEX_NAME).read_text()
    (tmp_path / "fresh").mkdir()
    batch.write_index(summary, tmp_path / "fresh")
    assert (tmp_path / "fresh" / batch.INDEX_NAME).read_text() == written
    # scans on a cluster finish in any order: the second scan's section,
    # built first at position 0, is not the first scan's at position 0
    cache = {}
    batch.write_index({**summary, "scans": summary["scans"][1:]}, tmp_path / "fresh", cache)
    batch.write_index(summary, tmp_path / "fresh", cache)
    assert (tmp_path / "fresh" / batch.INDEX_NAME).read_text() == written


@pytest.mark.slow
def test_a_scan_with_holes_the_fill_could_not_close_is_partial_not_ok(tmp_path, capsys):
    import sys
    sys.path.insert(0, os.path.dirname(__file__))
    import cad_parts as cp

    # a ring of scan linked with a cup's rim (through its opening and its
    # wall): no surface the rim bounds avoids it, so that opening stays open
    V, F = cp.cup_with_linked_ring()
    Vb, Fb = shapes.icosphere(3)
    _write_scans(tmp_path / "in", {"good.ply": ball_perforate(Vb, Fb, 2, 0.15, seed=2), "needle.ply": (V, F)})
    assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--fill-borders",
                 "--bridge", "never", "--no-html"]) == 0            # both repaired and written
    out = capsys.readouterr().out
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    rows = {r["file"]: r for r in s["scans"]}
    assert rows["good.ply"]["status"] == "ok" and rows["needle.ply"]["status"] == "partial"
    assert rows["needle.ply"]["holes_failed"] >= 1 and rows["needle.ply"]["holes_after"] >= 1
    assert s["n_ok"] == 1 and s["n_partial"] == 1 and s["n_failed"] == 0
    assert "1 ok, 1 partial, 0 failed" in out and "could not be closed" in out
