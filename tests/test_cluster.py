"""The batch on Dask: one task per scan on local worker processes or on an
existing cluster, with the same bytes out as scans repaired one after
another in this process."""

import io
import json
import logging
import os
import re

import numpy as np
import pytest

distributed = pytest.importorskip(
    "distributed", reason="dask.distributed is not installed (pip install 'shellrepair[cluster]')")

from shellrepair import batch  # noqa: E402
from eval import shapes  # noqa: E402
from shellrepair.batch import repair_folder  # noqa: E402
from terminal import at_empty_line  # noqa: E402
from shellrepair.cli import main  # noqa: E402
from shellrepair.mesh.io import Mesh, read_mesh, write_mesh  # noqa: E402
from shellrepair.mesh.topology import edge_topology  # noqa: E402

#: Report and summary fields that measure time, the only ones allowed to differ.
TIMING = re.compile(rb'("seconds(?:_total)?": )-?[0-9.eE+-]+')
#: Decimal numbers and the time of writing on the HTML page (its seconds
#: among them; the values themselves are compared through the reports and
#: the summary).
DECIMAL = re.compile(rb"[0-9]+\.[0-9]+|[0-9]{4}-[0-9]{2}-[0-9]{2} [0-9]{2}:[0-9]{2} UTC")


def holed_sphere(subdivisions, n_holes, seed):
    """A bumpy sphere with ``n_holes`` disc holes (seeded)."""
    V, F = shapes.bumpy_sphere(subdivisions, amplitude=0.03, frequency=6, seed=seed)
    V2, F2, _ = shapes.perforate_discs(V, F, n_holes=n_holes, radius=0.25, seed=seed)[:3]
    return V2, F2


@pytest.fixture(scope="module")
def scans(tmp_path_factory):
    """A folder of four holed meshes of three sizes and formats, and one
    truncated file."""
    folder = tmp_path_factory.mktemp("cluster") / "scans"
    folder.mkdir()
    for name, (sub, k, seed) in {"a.ply": (3, 2, 1), "b.obj": (3, 3, 2), "c.ply": (2, 1, 3),
                                 "d.off": (3, 1, 4)}.items():
        V, F = holed_sphere(sub, k, seed)
        write_mesh(folder / name, Mesh(V=V, F=F))
    (folder / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n0 0 0\n")
    return folder


def untimed(path):
    """A file's bytes with the values of its timing fields masked."""
    return TIMING.sub(rb'\1"T"', path.read_bytes())


def assert_same_outputs(a, b):
    """Two output folders hold the same files, byte for byte, except the
    timing fields of the JSON (and the summary's runner, which says where
    the scans ran, and its outdir) and the decimals of the HTML page."""
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    for name in names:
        if name == "summary.json":
            sa, sb = (json.loads(untimed(d / name)) for d in (a, b))
            for s in (sa, sb):
                s.pop("runner")
                s.pop("outdir")
            assert sa == sb
        elif name.endswith(".json"):
            assert untimed(a / name) == untimed(b / name), name
        elif name.endswith(".html"):  # all its text, tags and integers
            pa, pb = (DECIMAL.sub(b"D", (d / name).read_bytes()).decode().split("><") for d in (a, b))
            assert pa == pb
        else:
            assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.slow
def test_jobs_1_and_2_write_the_same_bytes(scans, tmp_path, capsys):
    out = tmp_path / "out"
    runs = {}
    for jobs in (1, 2):
        assert main(["batch", str(scans), "-o", str(out), "--jobs", str(jobs), "--no-html"]) == 2
        cap = capsys.readouterr()
        runs[jobs] = out.rename(tmp_path / f"out{jobs}")
        # the broken file is one line on stderr, whichever way the scans ran
        assert [ln for ln in cap.err.splitlines() if ln] == \
            [f"error: {scans / 'broken.ply'}: " + json.loads((runs[jobs] / "summary.json").read_text())
             ["scans"][2]["error"]]
        assert "Traceback" not in cap.err
    s1, s2 = (json.loads((runs[j] / "summary.json").read_text()) for j in (1, 2))
    assert s1["runner"]["kind"] == "in-process" and s2["runner"]["kind"] == "local-cluster"
    assert s2["runner"]["workers"] == 2 and s2["runner"]["jobs_per_scan"] == 1
    assert_same_outputs(runs[1], runs[2])
    # what was written is a real repair: rows in name order, the broken file recorded, holes closed
    assert [r["file"] for r in s2["scans"]] == ["a.ply", "b.obj", "broken.ply", "c.ply", "d.off"]
    assert [r["status"] for r in s2["scans"]] == ["ok", "ok", "error", "ok", "ok"]
    bad = s2["scans"][2]["error"]
    assert "\n" not in bad and len(bad) > 10
    assert s2["complete"] and s2["n_ok"] == 4 and s2["n_failed"] == 1
    assert s2["holes_before"] == 7 and s2["holes_after"] == 0
    for stem, src in (("a", "a.ply"), ("b", "b.obj"), ("c", "c.ply"), ("d", "d.off")):
        m = read_mesh(runs[2] / f"{stem}.repaired.ply")
        assert np.array_equal(m.V[:len(read_mesh(scans / src).V)], read_mesh(scans / src).V)
        assert edge_topology(m.F, len(m.V)).n_boundary_edges == 0
    assert not list(runs[2].glob("broken.*"))


class _Tty(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture(scope="module")
def cluster():
    """An existing cluster: two worker processes of one thread."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as c:
        yield c


@pytest.mark.slow
def test_existing_scheduler_one_task_per_scan_same_page_and_pictures(tmp_path, cluster, monkeypatch):
    from shellrepair.progress import end_line, terminal_bar

    folder = tmp_path / "scans"
    folder.mkdir()
    V, F = holed_sphere(2, 2, 5)
    write_mesh(folder / "bust.ply", Mesh(V=V, F=F))
    (folder / "empty.stl").write_bytes(b"")
    local = repair_folder(folder, tmp_path / "out", jobs=1, html=True, progress=False)
    (tmp_path / "out").rename(tmp_path / "local")
    tty = _Tty()
    monkeypatch.setattr("sys.stderr", tty)
    bar = terminal_bar()
    seen = []
    before = cluster.scheduler.task_prefixes.get("shellrepair-scan")
    before = before.state_counts["memory"] if before is not None else 0
    s = repair_folder(folder, tmp_path / "out", scheduler=cluster.scheduler_address, html=True, progress=bar,
                      on_scan=lambda r: (bar.clear(), seen.append((r["file"], r["status"], tty.tell()))))
    end_line(bar)
    assert s["runner"] == {"kind": "scheduler", "workers": 2, "scheduler": cluster.scheduler_address,
                           "jobs_per_scan": 1}
    # one task per scan ran on the cluster's workers
    assert cluster.scheduler.task_prefixes["shellrepair-scan"].state_counts["memory"] - before == 2
    assert sorted(f for f, _, _ in seen) == ["bust.ply", "empty.stl"]
    assert dict((f, st) for f, st, _ in seen) == {"bust.ply": "ok", "empty.stl": "error"}
    # progress on this side: the scans bar (the caller wipes its line before its own, as the CLI does)
    drawn = tty.getvalue()
    assert "2/2 100%" in drawn and all(at_empty_line(drawn[:at]) for _, _, at in seen)
    assert_same_outputs(tmp_path / "local", tmp_path / "out")
    assert (tmp_path / "out" / "bust.view.png").stat().st_size > 1000
    assert "bust.view.png" in (tmp_path / "out" / "index.html").read_text()
    assert [r["status"] for r in local["scans"]] == [r["status"] for r in s["scans"]] == ["ok", "error"]


def test_unreachable_scheduler_is_one_line_exit_2(scans, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(batch, "CONNECT_TIMEOUT", 1.0)
    out = tmp_path / "out"
    assert main(["batch", str(scans), "-o", str(out), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: cannot reach the Dask scheduler at tcp://127.0.0.1:1 within 1 s")
    assert "\n" not in err
    assert not out.exists()  # nothing written, not even the folder


@pytest.mark.slow
def test_a_scan_that_kills_its_worker_is_a_failed_row(tmp_path, monkeypatch):
    folder = tmp_path / "scans"
    folder.mkdir()
    V, F = holed_sphere(2, 1, 6)
    for name in ("a.ply", "boom.ply", "c.ply"):
        write_mesh(folder / name, Mesh(V=V, F=F))

    def dies_on_boom(task, options, progress=False):  # sent by value: the workers keep the real task
        if task["name"] == "boom.ply":
            os._exit(3)  # as a segfault or the out-of-memory killer would end it
        from shellrepair.batch import repair_scan_task
        return repair_scan_task(task, options, progress)

    monkeypatch.setattr(batch, "repair_scan_task", dies_on_boom)
    s = repair_folder(folder, tmp_path / "out", jobs=2, progress=False)
    assert s["runner"]["kind"] == "local-cluster"
    assert [r["status"] for r in s["scans"]] == ["ok", "error", "ok"]
    assert s["scans"][1]["error"].startswith("a worker died repairing it")
    assert s["complete"] and s["holes_after"] == 0 and s["n_failed"] == 1
    assert not list((tmp_path / "out").glob("boom.*"))
