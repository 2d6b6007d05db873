"""Output paths are checked before any work, and the error names the flag.

A repair of a large scan takes minutes: an output that cannot be written
must be refused before the scan is read, in one line that names the flag to
change. The checks create a file to be sure (``os.access`` says yes to root
everywhere, /proc included), so they hold when the tests run as root: the
unwritable places used here are a path under a regular file and /proc.
"""

import re
from pathlib import Path

import pytest

from eval import shapes
from shellrepair import Mesh, write_mesh
from shellrepair.cli import main


def _proc_is_unwritable():
    try:
        (Path("/proc") / "shellrepair-test").write_bytes(b"")
    except OSError:
        return Path("/proc").is_dir()
    return False


needs_proc = pytest.mark.skipif(not _proc_is_unwritable(), reason="no /proc that refuses new files here")


@pytest.fixture
def scans(tmp_path):
    """A folder with one perforated sphere, and a regular file beside it."""
    V, F = shapes.icosphere(2)
    V, F, _, _ = shapes.perforate_discs(V, F, n_holes=1, radius=0.4, seed=0)
    (tmp_path / "in").mkdir()
    write_mesh(tmp_path / "in" / "s.ply", Mesh(V=V, F=F))
    (tmp_path / "notes.txt").write_text("a file, not a folder\n")
    return tmp_path


@pytest.fixture
def no_work(monkeypatch):
    """Reading a scan fails the test: the checks must come first."""
    def read_mesh(*a, **k):
        raise AssertionError("a scan was read before the output paths were checked")

    monkeypatch.setattr("shellrepair.mesh.io.read_mesh", read_mesh)


def _one_line(err, culprit, flag, pattern):
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"error: {culprit}: {flag}: "), err
    assert re.search(pattern, err), err


def _files(root):
    return sorted(str(p.relative_to(root)) for p in Path(root).rglob("*"))


@pytest.mark.parametrize("flag, what", [("-o", "output"), ("--report", "report"), ("--html", "page"),
                                        ("--gltf", "glTF")])
def test_repair_refuses_an_output_under_a_regular_file_naming_the_flag(scans, capsys, no_work, flag, what):
    bad = scans / "notes.txt" / ("x.glb" if flag == "--gltf" else "x.ply" if flag == "-o" else "x.json")
    args = ["repair", str(scans / "in" / "s.ply"), flag, str(bad)]
    if flag != "-o":
        args += ["-o", str(scans / "out.ply")]
    before = _files(scans)
    assert main(args) == 2
    _one_line(capsys.readouterr().err, bad, flag, f"{what} folder is not a directory$")
    assert _files(scans) == before


@needs_proc
@pytest.mark.parametrize("flag, name", [("-o", "x.ply"), ("--report", "r.json"), ("--html", "p.html"),
                                        ("--gltf", "g.glb")])
def test_repair_refuses_an_output_in_proc_before_reading_the_scan(scans, capsys, no_work, flag, name):
    args = ["repair", str(scans / "in" / "s.ply"), flag, f"/proc/{name}"]
    if flag != "-o":
        args += ["-o", str(scans / "out.ply")]
    assert main(args) == 2
    _one_line(capsys.readouterr().err, f"/proc/{name}", flag, r"folder is not writable \(.+\)$")
    assert not (scans / "out.ply").exists()


@needs_proc
def test_render_refuses_a_picture_in_proc_before_reading_the_mesh(scans, capsys, no_work):
    assert main(["render", str(scans / "in" / "s.ply"), "-o", "/proc/x.png"]) == 2
    _one_line(capsys.readouterr().err, "/proc/x.png", "-o", r"output folder is not writable")


def test_batch_refuses_an_output_folder_under_a_regular_file_before_any_scan(scans, capsys, no_work):
    bad = scans / "notes.txt" / "out"
    before = _files(scans)
    assert main(["batch", str(scans / "in"), "-o", str(bad), "--jobs", "1"]) == 2
    _one_line(capsys.readouterr().err, bad, "-o", "the output folder's parent is not a directory$")
    assert _files(scans) == before


def test_batch_refuses_a_regular_file_as_its_output_folder(scans, capsys, no_work):
    assert main(["batch", str(scans / "in"), "-o", str(scans / "notes.txt"), "--jobs", "1"]) == 2
    _one_line(capsys.readouterr().err, scans / "notes.txt", "-o", "output folder exists and is not a directory$")


@needs_proc
@pytest.mark.parametrize("outdir, pattern", [("/proc", r"output folder is not writable \(.+\)$"),
                                             ("/proc/shellrepair-out", r"cannot be created in /proc \(.+\)$")])
def test_batch_refuses_an_unwritable_output_folder_before_any_scan(scans, capsys, no_work, outdir, pattern):
    assert main(["batch", str(scans / "in"), "-o", outdir, "--jobs", "1"]) == 2
    _one_line(capsys.readouterr().err, outdir, "-o", pattern)


def test_a_writable_output_is_left_as_it_was_by_the_check(scans, capsys):
    """The check's probe file is gone again: the folder holds the outputs only."""
    out = scans / "o"
    out.mkdir()
    assert main(["repair", str(scans / "in" / "s.ply"), "-o", str(out / "s.ply"), "-q"]) == 0
    assert _files(out) == ["s.ply", "s.report.json"]
