"""The HTML report: one self-contained page per scan and per collection.

The browser test opens a collection page in headless Chromium (Debian's
``chromium``, installed by ``make test`` where apt can) and checks what a
person would see: every picture loaded, one table row per scan and per
hole, sorting by a column, no console error.
"""

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from shellrepair.batch import repair_folder
from shellrepair.report.html import figure, scan_page
from shellrepair.mesh.io import Mesh, read_mesh, write_mesh
from shellrepair.repair import repair_mesh
from eval.shapes import icosphere

from conftest import shared_scan


def _sphere_with_holes(n_holes, seed, subdiv=3):
    V, F = icosphere(subdiv)
    rng = np.random.default_rng(seed)
    keep = np.ones(len(F), bool)
    C = V[F].mean(axis=1)
    for c in rng.normal(size=(n_holes, 3)):
        c /= np.linalg.norm(c)
        keep &= np.linalg.norm(C - c, axis=1) > 0.25
    return V, F[keep]


def test_scan_page_is_self_contained_and_lists_every_hole():
    V, F = _sphere_with_holes(3, seed=1)
    mesh = Mesh(V=V, F=F)
    repaired, report = repair_mesh(mesh)
    report["file"] = "sphere.ply"
    fig = figure(mesh, repaired, report, size=(160, 120))
    assert fig["png"][:8] == b"\x89PNG\r\n\x1a\n"
    assert fig["open_edges_before"] > 0 and fig["open_edges_after"] == report["boundary_edges_after"]
    page = scan_page(report, fig, options={"order": 2}, sha256="0" * 64)
    # nothing fetched from elsewhere: no http(s) URL in any src or href
    assert not re.search(r'(src|href)="(https?:)?//', page)
    assert page.count('src="data:image/png;base64,') == 1
    holes = page.split('<table class="sortable holes">')[1].split("</table>")[0]
    assert holes.count("<tr>") + holes.count('<tr class="open">') == 1 + report["holes_before"]
    assert "0" * 64 in page and "--order 2" in page
    # each filled hole's patch kind, a column of its own to sort by
    assert '<th class="t">patch</th>' in holes
    assert holes.count('<td class="t">faired</td>') == sum(h["kind"] == "faired" for h in report["holes"]) > 0


def test_holes_left_open_come_first_with_their_reason():
    V, F = _sphere_with_holes(3, seed=2)
    mesh = Mesh(V=V, F=F)
    repaired, report = repair_mesh(mesh)
    report["holes"][-1] = dict(report["holes"][-1], status="failed", reason="a test reason")
    page = scan_page(report)
    rows = re.findall(r"<tr( class=\"open\")?><td data-v=\"(\d+)\"", page)
    assert rows[0][0] and [r[0] for r in rows].count(' class="open"') == 1
    assert "a test reason" in page


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


_HARNESS = """<!DOCTYPE html><html><body>
<iframe id="f" src="index.html" style="width:1280px;height:900px"></iframe><pre id="out">pending</pre>
<script>
document.getElementById('f').addEventListener('load', function () {
  var d = this.contentDocument, r = {};
  r.images = Array.prototype.map.call(d.images, function (i) {
    return {src: i.getAttribute('src'), width: i.naturalWidth, alt: i.alt}; });
  r.scan_rows = d.querySelectorAll('table.scans tbody tr').length;
  r.hole_rows = Array.prototype.map.call(d.querySelectorAll('table.holes'), function (t) {
    return t.tBodies[0].rows.length; });
  var t = d.querySelector('table.holes'), th = t.querySelectorAll('th')[1];
  th.click();
  r.edges_ascending = Array.prototype.map.call(t.tBodies[0].rows, function (x) { return +x.cells[1].textContent; });
  th.click();
  r.edges_descending = Array.prototype.map.call(t.tBodies[0].rows, function (x) { return +x.cells[1].textContent; });
  document.getElementById('out').textContent = 'RESULT' + JSON.stringify(r) + 'END';
});
</script></body></html>
"""


@pytest.mark.slow
def test_collection_page_in_a_real_browser(tmp_path):
    browser = _chromium()
    if browser is None:
        pytest.skip("no chromium on this machine (make test installs Debian's chromium where apt can)")
    scans = tmp_path / "scans"
    scans.mkdir()
    n_holes = {}
    for name, k, seed in (("a.ply", 2, 3), ("b.ply", 4, 4)):
        V, F = _sphere_with_holes(k, seed)
        write_mesh(scans / name, Mesh(V=V, F=F))
    (scans / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nend_header\n")
    out = tmp_path / "out"
    summary = repair_folder(scans, out, html=True)
    for r in summary["scans"]:
        if r["status"] == "ok":
            n_holes[r["file"]] = r["holes_before"]
    assert len(n_holes) == 2
    r = _open_in_browser(browser, out, tmp_path)
    # one row per scan (the broken one too), one per hole of each scan
    assert r["scan_rows"] == 3
    assert r["hole_rows"] == [n_holes["a.ply"], n_holes["b.ply"]]


@pytest.mark.slow
def test_collection_page_of_the_real_scans(tmp_path):
    browser = _chromium()
    if browser is None:
        pytest.skip("no chromium on this machine (make test installs Debian's chromium where apt can)")
    scans = tmp_path / "scans"
    scans.mkdir()
    for name in ("real_bunny_zipper.ply", "real_rangescan_dragon_000.ply"):
        shutil.copy(shared_scan(name), scans / name)
    summary = repair_folder(scans, tmp_path / "out", html=True)
    r = _open_in_browser(browser, tmp_path / "out", tmp_path)
    assert r["scan_rows"] == 2
    assert r["hole_rows"] == [row["holes_before"] for row in summary["scans"]]


def _open_in_browser(browser, out, tmp_path):
    """Open OUT/index.html in headless Chromium; check the pictures, the
    sorting and the console; return what the page showed."""
    assert (out / "index.html").is_file()
    (out / "_check.html").write_text(_HARNESS)
    res = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--allow-file-access-from-files",
                          "--enable-logging=stderr", "--v=0", "--virtual-time-budget=10000", "--dump-dom",
                          (out / "_check.html").as_uri()], capture_output=True, text=True, timeout=120)
    m = re.search(r"RESULT(.*?)END", res.stdout)
    assert m, res.stdout[-2000:] + res.stderr[-2000:]
    r = json.loads(m.group(1))
    # every picture loaded, with alt text; one overview per repaired scan (and its close-ups)
    assert len([i for i in r["images"] if i["src"].endswith(".view.png")]) == len(r["hole_rows"]) > 0
    assert all(i["width"] > 0 and len(i["alt"]) > 20 for i in r["images"])
    assert r["edges_ascending"] == sorted(r["edges_ascending"])
    assert r["edges_descending"] == sorted(r["edges_ascending"], reverse=True)
    # no console error from the page itself
    console = [ln for ln in res.stderr.splitlines() if "CONSOLE" in ln]
    assert not [ln for ln in console if re.search(r"error|uncaught", ln, re.I)], console
    shot = tmp_path / "index.png"
    subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
                    "--window-size=1200,1400", (out / "index.html").as_uri()], capture_output=True, timeout=120)
    assert shot.is_file() and shot.stat().st_size > 10_000
    return r


@pytest.mark.slow
def test_repair_command_writes_the_page_with_the_mesh(tmp_path):
    from shellrepair.cli import main

    V, F = _sphere_with_holes(2, seed=5)
    scan = tmp_path / "s.ply"
    write_mesh(scan, Mesh(V=V, F=F))
    page = tmp_path / "s.html"
    assert main(["repair", str(scan), "--html", str(page)]) == 0
    text = page.read_text()
    assert "Repair of s.ply" in text and (tmp_path / "s.repaired.ply").is_file()
    assert read_mesh(tmp_path / "s.repaired.ply").face_filled.any()


def test_the_page_gives_the_options_as_the_command_line_spells_them():
    from shellrepair.report.html import options_text
    from shellrepair.options import RepairOptions

    text = options_text(RepairOptions(leave_open=[3], order_for={2: 1}, max_hole_size=(20, "mm")).as_dict())
    assert "--closed auto" in text and "None" not in text and "closed=" not in text
    assert "--leave-open 3" in text and "--order-for 2=1" in text and "--max-hole 20mm" in text
    assert "--cap-flat" not in text and "--fill-borders" not in text      # not asked for
