"""The HTML report's 3D view (shellrepair.report.webview).

The payload is read back in Python: the faces, their filled flags, the
regions and the edges left open are those of the repaired mesh, and a
mesh above the page's face budget is drawn as a lighter copy whose
filled part stays where the fill is. The browser tests open the pages in
headless Chromium (Debian's ``chromium``; WebGL through its software
renderer, SwiftShader) and check what a person sees: the statue drawn
over the background, the tint toggle changing the filled faces' pixels,
a region's button moving the camera and the reset button bringing the
first view back, the views of a collection page starting only when
scrolled to, a message without WebGL, and no console error.
"""

import json
import re
import subprocess

import numpy as np
import pytest

from chromium import FLAGS, Chromium, find_chromium
from eval.shapes import icosphere
from shellrepair.appearance.aging import aging_maps
from shellrepair.appearance.gltf import pbr_approximation
from shellrepair.report.html import scan_page
from shellrepair.mesh.io import Mesh, write_mesh
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import edge_topology
from shellrepair.report.webview import (DISPLAY_FACES, decode_payload, display_copy, filled_regions, view_payload,
                                 viewer_html)


def _sphere_with_holes(centres, radius, subdiv=4):
    V, F = icosphere(subdiv)
    C = V[F].mean(axis=1)
    keep = np.ones(len(F), bool)
    for c in centres:
        c = np.asarray(c, float) / np.linalg.norm(c)
        keep &= np.linalg.norm(C - c, axis=1) > radius
    return V, F[keep]


_HOLES = [(1, 0.3, 0.6), (-0.5, 0.4, 0.8), (0.2, -1, 0.3)]


@pytest.fixture(scope="module")
def repaired():
    """A sphere with three holes, the third left open."""
    from shellrepair.options import RepairOptions

    V, F = _sphere_with_holes(_HOLES, 0.3)
    mesh = Mesh(V=V, F=F)
    _, report = repair_mesh(mesh)
    ids = sorted(h["id"] for h in report["holes"])
    out, report = repair_mesh(mesh, RepairOptions(leave_open=[ids[-1]]))
    assert report["holes_after"] == 1
    report["file"] = "sphere.ply"
    return mesh, out, report


def _key(T):
    return set(map(tuple, np.sort(T, axis=1)))


def test_the_payload_reads_back_to_the_repaired_faces_flags_and_open_edges(repaired):
    _, out, _ = repaired
    p = view_payload(out)
    json.dumps(p)                                    # plain JSON values
    d = decode_payload(p)
    assert p["faces_shown"] == p["faces_total"] == len(out.F) <= DISPLAY_FACES
    # the vertices of the faces, in the mesh's order, within the quantization step
    used = np.unique(out.F)
    step = (np.asarray(p["hi"]) - np.asarray(p["lo"])) / 65535
    assert d["V"].shape == (len(used), 3) and np.all(np.abs(d["V"] - out.V[used]) <= step)
    # the same faces, and the filled ones are the filled ones
    assert _key(used[d["F"]]) == _key(out.F)
    assert _key(used[d["F"][d["filled"]]]) == _key(out.F[out.face_filled])
    # scan first, then one region after another, as many as the mesh's filled components
    assert np.all(np.diff(d["region"]) >= 0)
    assert len(p["regions"]) == filled_regions(out.F, out.face_filled).max() + 1 == 2
    assert [r["faces"] for r in p["regions"]] == [r["count"] for r in p["regions"]]
    # the edges left open: the repaired mesh's boundary edges, both ends
    topo = edge_topology(out.F, len(out.V))
    E = topo.edges[topo.edge_count == 1]
    assert p["open_edges"] == len(E) > 0
    got = {tuple(sorted(map(tuple, np.round(e, 3)))) for e in d["edges"]}
    want = {tuple(sorted(map(tuple, np.round(out.V[e], 3)))) for e in E}
    assert got == want
    # the material: the .glb's metallic-roughness values from the same aging maps, to 8 bits
    maps = aging_maps(out.V, out.F, up=(0, 1, 0), scan=~out.face_filled)
    base, metallic, rough = pbr_approximation(maps.coverage, maps.gild, maps.crust)
    assert np.abs(d["metallic"] - metallic[used]).max() <= 0.5 / 255 + 1e-9
    assert np.abs(d["roughness"] - rough[used]).max() <= 0.5 / 255 + 1e-9
    srgb = np.where(base <= 0.0031308, 12.92 * base, 1.055 * base ** (1 / 2.4) - 0.055)[used] * 255
    assert d["color"].shape == (len(used), 3) and np.abs(d["color"] - srgb).max() <= 0.5 + 1e-6


def test_the_same_mesh_gives_the_same_bytes(repaired):
    _, out, _ = repaired
    assert json.dumps(view_payload(out), sort_keys=True) == json.dumps(view_payload(out), sort_keys=True)


def test_filled_regions_are_the_filled_faces_joined_by_edges_numbered_by_first_face():
    V, F = icosphere(3)
    C = V[F].mean(axis=1)
    filled = (np.linalg.norm(C - [0, 0, 1], axis=1) < 0.4) | (np.linalg.norm(C - [0, 0, -1], axis=1) < 0.4)
    region = filled_regions(F, filled)
    assert set(region[filled]) == {0, 1} and np.all(region[~filled] == -1)
    assert region[np.flatnonzero(filled)[0]] == 0
    assert np.all(region[filled & (C[:, 2] > 0)] == region[np.flatnonzero(filled & (C[:, 2] > 0))[0]])
    assert np.all(filled_regions(F, np.zeros(len(F), bool)) == -1)


def test_a_mesh_above_the_budget_is_drawn_lighter_with_its_fill_where_it_was():
    V, F = icosphere(6)                               # 81,920 faces
    C = V[F].mean(axis=1)
    filled = np.linalg.norm(C - [0.6, 0.0, 0.8], axis=1) < 0.35
    out = Mesh(V=V, F=F, face_filled=filled)
    p = view_payload(out, max_faces=20_000)
    d = decode_payload(p)
    assert p["faces_total"] == len(F) and 0 < p["faces_shown"] <= 20_000 and len(d["F"]) == p["faces_shown"]
    # still a sphere
    assert np.allclose(np.linalg.norm(d["V"], axis=1), 1.0, atol=0.01)
    # the filled faces of the copy are where the fill is, and cover about its share of the area
    Cd = d["V"][d["F"]].mean(axis=1)
    assert np.all(np.linalg.norm(Cd[d["filled"]] - [0.6, 0.0, 0.8], axis=1) < 0.35 + 0.05)
    area = np.linalg.norm(np.cross(d["V"][d["F"][:, 1]] - d["V"][d["F"][:, 0]],
                                   d["V"][d["F"][:, 2]] - d["V"][d["F"][:, 0]]), axis=1)
    area0 = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    assert area[d["filled"]].sum() / area.sum() == pytest.approx(area0[filled].sum() / area0.sum(), rel=0.1)
    assert len(p["regions"]) == 1 and p["regions"][0]["faces"] == int(filled.sum())


def test_the_display_copy_says_where_each_face_and_vertex_came_from():
    V, F = icosphere(5)
    Vd, Fd, face_source, vertex_map = display_copy(V, F, max_faces=4000)
    assert len(Fd) <= 4000 and len(vertex_map) == len(V) and vertex_map.max() == len(Vd) - 1
    # each face of the copy is its original face with its corners moved
    assert np.array_equal(np.sort(vertex_map[F[face_source]], axis=1), np.sort(Fd, axis=1))
    # each vertex of the copy is near the vertices collapsed into it
    assert np.max(np.linalg.norm(Vd[vertex_map] - V, axis=1)) < 0.2
    # under the budget: the mesh itself
    Vs, Fs, src, vmap = display_copy(V, F)
    assert np.array_equal(Vs, V) and np.array_equal(Fs, F) and np.array_equal(src, np.arange(len(F)))


def test_bad_input_says_what_was_wrong():
    V, F = icosphere(1)
    with pytest.raises(ValueError, match="budget"):
        display_copy(V, F, max_faces=0)
    with pytest.raises(ValueError, match="up axis"):
        view_payload(Mesh(V=V, F=F), up=(0, 0, 0))
    assert view_payload(Mesh(V=V, F=np.zeros((0, 3), np.int64))) is None
    with pytest.raises(ValueError, match="payload or a src"):
        viewer_html()
    with pytest.raises(ValueError, match="version"):
        decode_payload({"version": 99})


def test_the_page_carries_the_view_and_its_script_and_fetches_nothing(repaired):
    mesh, out, report = repaired
    page = scan_page(report, None, view=view_payload(out))
    assert not re.search(r'(src|href)="(https?:)?//', page) and "http://" not in page.split("<body>")[1][:200]
    assert page.count('class="srv"') == 1 and page.count("function View(") == 1
    data = re.search(r'<script type="application/json" class="srv-data">(.*?)</script>', page).group(1)
    assert decode_payload(json.loads(data))["F"].shape == out.F.shape
    assert "class=\"srv\"" not in scan_page(report, None)      # no view asked for: no script either


# --------------------------------------------------------------------------
# in a real browser
# --------------------------------------------------------------------------
def _browser():
    browser = find_chromium()
    if browser is None:
        pytest.skip("no chromium on this machine (make test-all installs Debian's chromium where apt can)")
    return browser


# what a person sees, read in the page: each view scrolled to in turn (it starts when shown),
# then the first view's pixels before and after its buttons are clicked
_PROBE = """new Promise(function (done) {
var BG = [233, 231, 225];
function image(cv) {
  var c = document.createElement('canvas'); c.width = cv.width; c.height = cv.height;
  var x = c.getContext('2d'); x.drawImage(cv, 0, 0); return x.getImageData(0, 0, c.width, c.height).data;
}
function stats(px) {
  var s = {pixels: px.length / 4, background: 0, tinted: 0};
  for (var i = 0; i < px.length; i += 4) {
    var r = px[i], g = px[i + 1], b = px[i + 2];
    if (Math.abs(r - BG[0]) + Math.abs(g - BG[1]) + Math.abs(b - BG[2]) <= 6) s.background++;
    if (r - g > 60 && b - g > 40) s.tinted++;            // the filled faces' magenta
  }
  return s;
}
function changed(a, b) {
  var n = 0;
  for (var i = 0; i < a.length; i += 4)
    if (Math.abs(a[i] - b[i]) + Math.abs(a[i + 1] - b[i + 1]) + Math.abs(a[i + 2] - b[i + 2]) > 24) n++;
  return n;
}
var els = document.querySelectorAll('.srv'), k = 0, t0 = Date.now();
function states() { return Array.prototype.map.call(els, function (e) { return e.dataset.state || ''; }); }
var r = {at_load: states()};
function settled(e) { return /^(drawn|no-webgl|error)$/.test(e.dataset.state || ''); }
(function next() {
  if (k === els.length) return finish();
  els[k].scrollIntoView();
  (function poll() { if (settled(els[k]) || Date.now() - t0 > 60000) { k++; next(); } else setTimeout(poll, 20); })();
})();
function finish() {
  r.states = states();
  r.drawn_ms = Array.prototype.map.call(els, function (e) { return +(e.dataset.drawnMs || -1); });
  r.messages = Array.prototype.map.call(els, function (e) { var m = e.querySelector('.srv-msg'); return m ? m.textContent : ''; });
  var el = els[0], cv = el && el.querySelector('canvas');
  if (cv) {
    el.scrollIntoView();
    var a = image(cv); r.first = stats(a);
    var tint = el.querySelector('.srv-tint');
    if (tint) {
      tint.click(); var b = image(cv); r.untinted = stats(b); r.changed_by_tint = changed(a, b);
      tint.click(); r.changed_by_tint_back = changed(a, image(cv));
    }
    var reg = el.querySelector('.srv-region');
    if (reg) {
      reg.click(); r.changed_by_region = changed(a, image(cv));
      el.querySelector('.srv-reset').click(); r.changed_by_reset = changed(a, image(cv));
    }
    r.n_region_buttons = el.querySelectorAll('.srv-region').length;
  }
  done(r);
}
})"""


def _open_views(page, flags=(), size=(1000, 800)):
    """Open ``page`` in headless Chromium and probe its views; return what
    they showed and the console's messages."""
    with Chromium(_browser(), flags, size=size) as c:
        c.open(page.as_uri())
        return c.evaluate(_PROBE), c.console()


def _no_console_error(console):
    assert not [m for m in console if m[0] in ("error", "warning", "assert", "exception")], console


@pytest.mark.slow
def test_the_repair_page_shows_a_view_that_turns_tints_and_frames(tmp_path):
    from shellrepair.cli import main

    V, F = _sphere_with_holes(_HOLES, 0.3)
    scan = tmp_path / "s.ply"
    write_mesh(scan, Mesh(V=V, F=F))
    page = tmp_path / "s.html"
    assert main(["repair", str(scan), "--html", str(page), "--quiet"]) == 0
    r, console = _open_views(page)
    assert r["at_load"] != ["waiting"]                        # a page of one scan starts its view at once
    assert r["states"] == ["drawn"]
    # the statue drawn over the background: a good part of the canvas, not all of it
    s = r["first"]
    assert 0.1 < 1 - s["background"] / s["pixels"] < 0.95
    # the filled faces tinted (190 of 4,966 faces); the toggle takes the tint off them, and
    # changes no more than a small part of the statue
    statue = s["pixels"] - s["background"]
    assert s["tinted"] > 0.002 * s["pixels"] and r["untinted"]["tinted"] < 0.2 * s["tinted"]
    assert 0.8 * s["tinted"] <= r["changed_by_tint"] < 0.25 * statue
    assert r["changed_by_tint_back"] == 0
    # a button per filled region: framing one moves the camera; reset brings the first view back
    assert r["n_region_buttons"] == 3
    assert r["changed_by_region"] > 0.05 * s["pixels"] and r["changed_by_reset"] == 0
    _no_console_error(console)


_PIXELS = """window.__snap = function () {
  var cv = document.querySelector('.srv canvas'), c = document.createElement('canvas');
  c.width = cv.width; c.height = cv.height; var x = c.getContext('2d'); x.drawImage(cv, 0, 0);
  return x.getImageData(0, 0, c.width, c.height).data;
};
window.__look = function (a) {            // statue pixels, their mean column, and how many differ from a
  var p = __snap(), n = 0, sx = 0, d = 0, w = document.querySelector('.srv canvas').width;
  for (var i = 0; i < p.length; i += 4) {
    if (Math.abs(p[i] - 233) + Math.abs(p[i + 1] - 231) + Math.abs(p[i + 2] - 225) > 6) { n++; sx += (i / 4) % w; }
    if (a && Math.abs(p[i] - a[i]) + Math.abs(p[i + 1] - a[i + 1]) + Math.abs(p[i + 2] - a[i + 2]) > 24) d++;
  }
  return {statue: n, x: n ? sx / n : -1, changed: d};
};
window.__frame = function () { return new Promise(function (ok) { requestAnimationFrame(function () { setTimeout(ok, 0); }); }); };
1"""


@pytest.mark.slow
def test_the_view_turns_moves_and_zooms_under_the_mouse_and_fingers(tmp_path, repaired):
    _, out, report = repaired
    page = tmp_path / "p.html"
    page.write_text(scan_page(report, None, view=view_payload(out)))
    with Chromium(_browser()) as c:
        c.open(page.as_uri())
        c.evaluate("new Promise(function (ok) { var e = document.querySelector('.srv'); e.scrollIntoView();"
                   " (function w() { if (e.dataset.state === 'drawn') ok(1); else setTimeout(w, 20); })(); })")
        c.evaluate(_PIXELS)
        x, y = c.evaluate("(function () { var r = document.querySelector('.srv canvas').getBoundingClientRect();"
                          " return [r.left + r.width / 2, r.top + r.height / 2]; })()")

        def after(events):
            c.evaluate("window.__a = __snap(); 1")
            for kind, params in events:
                c.call(kind, session=True, **params)
            return c.evaluate("__frame().then(function () { return __look(__a); })")

        def mouse(kind, px, py, button="left", **more):
            return ("Input.dispatchMouseEvent", dict(type=kind, x=px, y=py, button=button, clickCount=1, **more))

        first = c.evaluate("__look()")
        # a drag with the left button turns the statue about its up axis
        turned = after([mouse("mousePressed", x, y), mouse("mouseMoved", x + 60, y, buttons=1),
                        mouse("mouseMoved", x + 120, y, buttons=1), mouse("mouseReleased", x + 120, y)])
        assert turned["changed"] > 0.2 * first["statue"]
        c.evaluate("document.querySelector('.srv-reset').click(); 1")
        assert c.evaluate("__frame().then(function () { return __look(); })") == first
        # a drag with the right button moves it sideways, by about the drag
        moved = after([mouse("mousePressed", x, y, "right"), mouse("mouseMoved", x + 100, y, "right", buttons=2),
                       mouse("mouseReleased", x + 100, y, "right")])
        assert 60 < moved["x"] - first["x"] < 140
        c.evaluate("document.querySelector('.srv-reset').click(); 1")
        # the wheel zooms in
        zoomed = after([("Input.dispatchMouseEvent", dict(type="mouseWheel", x=x, y=y, deltaX=0, deltaY=-300))])
        assert zoomed["statue"] > 1.3 * first["statue"]
        c.evaluate("document.querySelector('.srv-reset').click(); 1")
        # two fingers apart zoom in too, one finger turns
        pinched = after([("Input.dispatchTouchEvent", dict(type="touchStart", touchPoints=[
                             {"x": x - 20, "y": y, "id": 1}, {"x": x + 20, "y": y, "id": 2}])),
                         ("Input.dispatchTouchEvent", dict(type="touchMove", touchPoints=[
                             {"x": x - 80, "y": y, "id": 1}, {"x": x + 80, "y": y, "id": 2}])),
                         ("Input.dispatchTouchEvent", dict(type="touchEnd", touchPoints=[]))])
        assert pinched["statue"] > 1.3 * first["statue"]
        c.evaluate("document.querySelector('.srv-reset').click(); 1")
        swiped = after([("Input.dispatchTouchEvent", dict(type="touchStart", touchPoints=[{"x": x, "y": y, "id": 1}])),
                        ("Input.dispatchTouchEvent", dict(type="touchMove", touchPoints=[{"x": x + 120, "y": y, "id": 1}])),
                        ("Input.dispatchTouchEvent", dict(type="touchEnd", touchPoints=[]))])
        assert swiped["changed"] > 0.2 * first["statue"]
        _no_console_error(c.console())


@pytest.mark.slow
def test_a_collection_page_starts_each_view_when_it_is_scrolled_to(tmp_path):
    from shellrepair.batch import repair_folder

    scans = tmp_path / "scans"
    scans.mkdir()
    for name, holes in (("a.ply", _HOLES[:2]), ("b.ply", _HOLES)):
        V, F = _sphere_with_holes(holes, 0.3)
        write_mesh(scans / name, Mesh(V=V, F=F))
    out = tmp_path / "out"
    repair_folder(scans, out, html=True)
    page = (out / "index.html").read_text()
    assert page.count('class="srv"') == 2 and page.count("function View(") == 1
    assert (out / "a.view.js").is_file() and (out / "b.view.js").is_file()
    assert 'type="application/json"' not in page             # the meshes stay in their files until shown
    r, console = _open_views(out / "index.html")
    assert r["at_load"][-1] == "waiting"                      # far down the page: not started
    assert r["states"] == ["drawn", "drawn"]
    assert 0.1 < 1 - r["first"]["background"] / r["first"]["pixels"] and r["changed_by_tint"] > 0
    _no_console_error(console)


@pytest.mark.slow
def test_without_webgl_the_view_says_so(tmp_path, repaired):
    _, out, report = repaired
    page = tmp_path / "p.html"
    page.write_text(scan_page(report, None, view=view_payload(out)))
    r, console = _open_views(page, flags=["--disable-webgl", "--disable-3d-apis"])
    assert r["states"] == ["no-webgl"] and "no WebGL" in r["messages"][0]
    _no_console_error(console)


def _large_scan():
    """About 1.3M faces: a bumpy sphere, one hole left open, one filled patch."""
    V, F = icosphere(8)
    V = V * (1 + 0.04 * np.sin(9 * V[:, :1]) * np.cos(7 * V[:, 1:2]))
    C = V[F].mean(axis=1)
    keep = np.linalg.norm(C - [0, 0, -1], axis=1) > 0.2
    F, C = F[keep], C[keep]
    return Mesh(V=V, F=F, face_filled=np.linalg.norm(C - [0.6, 0.0, 0.8], axis=1) < 0.3)


@pytest.mark.slow
def test_a_page_of_a_million_faces_is_under_20_mb_and_opens_in_seconds(tmp_path):
    browser = _browser()
    mesh = _large_scan()
    assert len(mesh.F) > 1_000_000
    page = tmp_path / "big.html"
    page.write_text(scan_page({"file": "big.ply"}, None, view=view_payload(mesh)))
    assert page.stat().st_size < 20e6
    # opened as a person would (no harness, no virtual time): the page's clock when the first frame is done
    res = subprocess.run([browser, *FLAGS, "--enable-logging=stderr", "--v=0", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=300)
    m = re.search(r'data-state="drawn" data-drawn-ms="(\d+)"', res.stdout)
    assert m, res.stdout[-1000:] + res.stderr[-2000:]
    # measured 1.8-2.7 s on a 2-core machine shared with other jobs (docs/viewer.md); generous here
    print(f"1.3M-face page: {page.stat().st_size / 1e6:.1f} MB, first frame complete at {m.group(1)} ms")
    assert int(m.group(1)) < 10_000
    _no_console_error([ln for ln in res.stderr.splitlines() if "CONSOLE" in ln])


def test_a_mesh_all_filled_or_without_fill_still_has_a_view():
    V, F = icosphere(2)
    for filled in (np.ones(len(F), bool), None):
        p = view_payload(Mesh(V=V, F=F, face_filled=filled))
        d = decode_payload(p)
        assert len(d["F"]) == len(F) and d["filled"].sum() == (0 if filled is None else len(F))
        assert len(p["regions"]) == (0 if filled is None else 1) and p["open_edges"] == 0


@pytest.mark.slow
def test_past_six_views_the_oldest_out_of_sight_pauses_and_shows_again(tmp_path, repaired):
    _, out, report = repaired
    p = view_payload(out)
    page = scan_page(report, None, view=p)
    more = "".join(viewer_html(p, f"more-{i}", eager=False) + '<div style="height:900px"></div>' for i in range(6))
    i = page.rindex("<script>")                              # the viewer's script stays last
    (tmp_path / "seven.html").write_text(page[:i] + more + page[i:])
    r, console = _open_views(tmp_path / "seven.html")
    assert r["states"] == ["paused"] + ["drawn"] * 6
    assert "too many views" in r["messages"][0]
    with Chromium(_browser()) as c:                          # and back, from the payload read before
        c.open((tmp_path / "seven.html").as_uri())
        c.evaluate(_PROBE)
        states = c.evaluate("""new Promise(function (ok) {
          var els = document.querySelectorAll('.srv'); els[0].scrollIntoView();
          els[0].querySelector('.srv-msg button').click();
          (function w() { if (els[0].dataset.state === 'drawn') ok(Array.prototype.map.call(els, function (e) {
            return e.dataset.state; })); else setTimeout(w, 20); })(); })""")
    assert states.count("drawn") == 6 and states[0] == "drawn" and states.count("paused") == 1
    _no_console_error(console)
