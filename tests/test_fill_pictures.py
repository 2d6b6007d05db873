"""Pictures of each fill (issue 41, item 3): a close-up of every filled
region from the side that sees it best, the holes that failed marked,
one up axis per scan, inferred and recorded, and cameras that
``shellrepair render`` takes back."""

import io
import json
import re

import numpy as np
import pytest

from shellrepair.cli import main
from shellrepair.report.closeups import FAILED_COLOR, best_direction, closeups, fill_regions, parse_camera
from shellrepair.report.html import figure, scan_page
from shellrepair.mesh.io import Mesh, read_mesh, write_mesh
from shellrepair.appearance.render import frame_camera
from shellrepair.repair import repair_mesh
from shellrepair.report.upaxis import infer_up
from eval.shapes import icosphere

import cad_parts as cp

#: Where the five holes of the ellipsoid are cut (before stretching along x).
HOLE_CENTRES = [(-0.8, 0.3, 0.5), (-0.33, 0.9, 0.0), (0.0, -0.5, 0.8), (0.4, 0.2, -0.9), (0.83, -0.4, 0.3)]


def _ellipsoid_with_five_holes(subdiv=3):
    """An ellipsoid three times longer along x (a statue lying along x),
    with five separate holes."""
    V, F = icosphere(subdiv)
    C = V[F].mean(axis=1)
    keep = np.ones(len(F), bool)
    for c in HOLE_CENTRES:
        c = np.asarray(c) / np.linalg.norm(c)
        keep &= np.linalg.norm(C - c, axis=1) > 0.25
    return V * np.array([3.0, 1.0, 1.0]), F[keep]


def _linked_ring_cup():
    """A cup (a cube without its top) with a ring of scan linked through
    its rim: no surface the rim bounds avoids the ring, so the top cannot
    be filled (tests/test_steiner.py; a loose needle through the opening
    is closed over by the last layer now)."""
    return cp.cup_with_linked_ring()


def _closeup_figures(page):
    return re.findall(r'<figure><img [^>]*alt="close-up of the fill of ([^"]*)"', page)


def _colour_pixels(png, colour):
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    return int(np.count_nonzero(np.abs(img - np.asarray(colour)).max(axis=2) <= 2))


@pytest.fixture(scope="module")
def five(tmp_path_factory):
    """The five-hole scan repaired on the command line with --html."""
    d = tmp_path_factory.mktemp("five")
    V, F = _ellipsoid_with_five_holes()
    scan, out, page = d / "five.ply", d / "five.repaired.ply", d / "five.html"
    write_mesh(scan, Mesh(V=V, F=F))
    assert main(["repair", str(scan), "-o", str(out), "--html", str(page), "--jobs", "1", "-q"]) == 0
    report = json.loads((d / "five.report.json").read_text())
    return {"scan": scan, "out": out, "page": page.read_text(), "report": report, "dir": d}


def test_five_separately_filled_holes_give_five_closeups(five):
    report, page = five["report"], five["page"]
    assert report["filled"] == 5
    shown = _closeup_figures(page)
    assert len(shown) == 5
    # one region per hole, each naming its hole: together the five holes
    regions = report["pictures"]["regions"]
    assert sorted(h for r in regions for h in r["holes"]) == sorted(h["id"] for h in report["holes"])
    assert all(len(r["holes"]) == 1 for r in regions)
    assert [r["area"] for r in regions] == sorted((r["area"] for r in regions), reverse=True)
    # each close-up's camera printed under it, as `shellrepair render` takes it
    for r in regions:
        assert r["camera"] in page
    assert "could not be filled" not in page


def test_the_up_axis_of_a_scan_lying_along_x_is_x_and_is_in_the_report(five):
    up = five["report"]["up"]
    assert up["axis"] == [1.0, 0.0, 0.0] and up["name"] == "x" and up["rule"] == "longest axis"
    assert all(r["camera"].startswith("--up x ") for r in five["report"]["pictures"]["regions"])
    assert five["report"]["pictures"]["overview"].startswith("--up x ")


def test_render_reuses_the_up_axis_the_repair_recorded(five, capsys):
    # no --up, no --before: the repaired mesh's report beside it gives the axis
    capsys.readouterr()
    assert main(["render", str(five["out"]), "--size", "20x15", "-o", str(five["dir"] / "up.png")]) == 0
    line = re.search(r"^up: (.*)$", capsys.readouterr().out, re.M).group(1)
    assert line.startswith("x (") and "five.report.json" in line


def test_up_given_on_the_command_line_wins(tmp_path):
    V, F = _ellipsoid_with_five_holes(subdiv=2)
    scan = tmp_path / "s.ply"
    write_mesh(scan, Mesh(V=V, F=F))
    assert main(["repair", str(scan), "--gltf", str(tmp_path / "s.glb"), "--up", "-z", "--jobs", "1", "-q"]) == 0
    up = json.loads((tmp_path / "s.report.json").read_text())["up"]
    assert up["axis"] == [0.0, 0.0, -1.0] and up["rule"] == "given"


def test_a_bad_up_is_one_line_naming_the_flag(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["repair", str(tmp_path / "s.ply"), "--up", "1,0"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--up" in err and "'1,0'" in err


def test_a_planar_open_base_gives_the_up_axis_towards_the_scan():
    # a sphere standing on a cut base, turned so that the base faces -z
    V, F = icosphere(3)
    keep = V[F].mean(axis=1)[:, 1] > -0.6
    R = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])   # y -> z
    for Vt, want in ((V, [0.0, 1.0, 0.0]), (V @ R.T, [0.0, 0.0, 1.0]), (-(V @ R.T), [0.0, 0.0, -1.0])):
        up = infer_up(Vt, F[keep])
        assert up["rule"] == "base" and up["axis"] == want


def test_a_neck_cut_narrower_than_the_head_is_the_base():
    # a head on a neck, about x, the neck cut open: stored head down (along
    # -x), so the longest axis alone would say +x; the cut's walls stand
    # across its plane and the scan is on one side: up is -x, towards the head
    from test_bands import revolution

    def profile(t):
        x = 3.0 * t
        head = np.sqrt(np.clip(1.0 - (x - 2.0) ** 2, 0.0, None))
        return x, np.where(x <= 1.2, 0.3, head)

    V, F = revolution(profile, nu=32, nt=60)
    V = V * np.array([-1.0, 1.0, 1.0])
    keep = V[F].mean(axis=1)[:, 0] < -0.5
    up = infer_up(V, F[keep])
    assert up["rule"] == "base" and up["axis"] == [-1.0, 0.0, 0.0]


def test_no_base_and_no_longest_axis_keeps_the_files_y():
    V, F = icosphere(2)
    assert infer_up(V, F)["axis"] == [0.0, 1.0, 0.0]


def test_render_takes_the_printed_camera_back(five, capsys):
    cam_args = five["report"]["pictures"]["regions"][0]["camera"]
    png = five["dir"] / "again.png"
    capsys.readouterr()
    assert main(["render", str(five["out"]), "--before", str(five["scan"]), "--highlight-filled",
                 "--size", "40x30", "-o", str(png)] + cam_args.split()) == 0
    said = capsys.readouterr().out
    line = re.search(r"^camera: (.*)$", said, re.M).group(1)
    assert parse_camera(line) == parse_camera(cam_args)
    assert png.stat().st_size > 0


def test_a_negative_target_is_read_as_numbers(five, capsys):
    png = five["dir"] / "neg.png"
    assert main(["render", str(five["out"]), "--size", "20x15", "-o", str(png), "--up", "-x",
                 "--view", "-40,-10", "--look-at", "-2.5,-0.1,0.2", "--radius", "0.5"]) == 0
    assert "camera: --up -x --view -40,-10 --look-at -2.5,-0.1,0.2 --radius 0.5" in capsys.readouterr().out


def test_the_closeup_camera_sees_each_hole_from_outside():
    V, F = icosphere(3)
    C = V[F].mean(axis=1)
    for c in HOLE_CENTRES:
        c = np.asarray(c) / np.linalg.norm(c)
        faces = np.flatnonzero(np.linalg.norm(C - c, axis=1) < 0.25)
        best = best_direction(V, F, faces, (0.0, 1.0, 0.0))
        assert best["direction"] @ c > 0.9 and best["score"] >= best["runner_up"]


def test_a_failed_hole_is_marked_in_the_overview_and_in_a_view_of_its_own():
    V, F = _linked_ring_cup()
    mesh = Mesh(V=V, F=F)
    repaired, report = repair_mesh(mesh, fill_borders=True, bridge="never", jobs=1)
    failed = [h["id"] for h in report["holes"] if h["status"] == "failed"]
    assert failed
    fig = figure(mesh, repaired, report, size=(120, 90))
    assert fig["failed"] == failed
    assert _colour_pixels(fig["png"], FAILED_COLOR) > 0
    pics = closeups(mesh, repaired, report, size=(60, 45))
    assert [f["id"] for f in pics["failed"]] == failed
    assert all(_colour_pixels(f["png"], FAILED_COLOR) > 0 for f in pics["failed"])
    page = scan_page(report, fig, closeups=pics)
    assert "Holes that could not be filled" in page
    assert all(f'alt="hole {i}, which could not be filled' in page for i in failed)
    assert "ringed: " + ", ".join(map(str, failed)) in page


def test_a_repair_without_failures_marks_nothing():
    V, F = _ellipsoid_with_five_holes(subdiv=2)
    mesh = Mesh(V=V, F=F)
    repaired, report = repair_mesh(mesh, jobs=1)
    fig = figure(mesh, repaired, report, size=(80, 60))
    assert fig["failed"] == [] and _colour_pixels(fig["png"], FAILED_COLOR) == 0


def test_regions_past_the_limit_are_listed_with_their_centre():
    V, F = _ellipsoid_with_five_holes(subdiv=2)
    mesh = Mesh(V=V, F=F)
    repaired, report = repair_mesh(mesh, jobs=1)
    pics = closeups(mesh, repaired, report, size=(40, 30), limit=2)
    assert len(pics["regions"]) == 2 and len(pics["more"]) == 3
    regions = fill_regions(repaired.V, repaired.F, repaired.face_filled, n_original=len(V))
    for row, reg in zip(pics["regions"] + pics["more"], regions):
        assert np.allclose(row["center"], reg["centroid"], rtol=1e-5, atol=1e-6)
    page = scan_page(report, closeups=pics)
    assert len(_closeup_figures(page)) == 2
    listed = page.split('<table class="sortable regions">')[1].split("</table>")[0]
    assert listed.count("<tr>") == 1 + 3


def test_a_tube_is_one_region():
    # the torus's inner band: two loops joined by one tube (tests/test_bands.py)
    from test_bands import torus_inner_band

    _, _, V2, F2, _ = torus_inner_band(3, nu=80, nv=20)
    mesh = Mesh(V=V2, F=F2)
    repaired, report = repair_mesh(mesh, jobs=1)
    assert [b["chosen"] for b in report["bridges"]] == ["tube"]
    pics = closeups(mesh, repaired, report, size=(40, 30))
    assert len(pics["regions"]) == 1 and pics["regions"][0]["holes"] == [0, 1]


def test_the_camera_printed_is_the_camera_used():
    V, F = _ellipsoid_with_five_holes(subdiv=2)
    mesh = Mesh(V=V, F=F)
    repaired, report = repair_mesh(mesh, jobs=1)
    from shellrepair.report.closeups import closeup_camera

    reg = fill_regions(repaired.V, repaired.F, repaired.face_filled)[0]
    cam = closeup_camera(repaired.V, repaired.F, reg["faces"], reg["centroid"], reg["radius"], (1.0, 0, 0),
                         size=(40, 30))
    up, view, target, radius = parse_camera(cam["args"])
    again = frame_camera(V, (40, 30), view, up=up, center=target, radius=radius)
    for k in ("eye", "target", "up"):
        assert np.array_equal(getattr(again, k), getattr(cam["camera"], k))


def test_a_collection_page_links_each_closeup_written_beside_it(tmp_path):
    from shellrepair.batch import repair_folder

    src, out = tmp_path / "scans", tmp_path / "out"
    src.mkdir()
    V, F = _ellipsoid_with_five_holes(subdiv=2)
    write_mesh(src / "five.ply", Mesh(V=V, F=F))
    repair_folder(src, out, jobs=1, html=True)
    page = (out / "index.html").read_text()
    links = re.findall(r'<img src="(five\.fill-\d+\.png)"', page)
    assert len(links) == 5 and all((out / f).stat().st_size > 0 for f in links)
    report = json.loads((out / "five.report.json").read_text())
    assert report["up"]["name"] == "x" and len(report["pictures"]["regions"]) == 5
