"""Specification of shellrepair.appearance.render on meshes built here."""

import os

import numpy as np
import pytest
from PIL import Image

from shellrepair.appearance import shader as sd
from shellrepair.appearance import render as rd


def icosphere(subdiv=3, radius=1.0, center=(0.0, 0.0, 0.0)):
    """Icosphere (V, F) by midpoint subdivision, outward winding."""
    t = (1.0 + 5 ** 0.5) / 2.0
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    for _ in range(subdiv):
        cache, F2 = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = V[a] + V[b]
                V.append(p / np.linalg.norm(p))
                cache[key] = len(V) - 1
            return cache[key]

        for a, b, c in F:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            F2 += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = F2
    return np.array(V) * radius + np.asarray(center), np.array(F, dtype=np.int64)


def quad_plane(y=-1.2, half=4.0):
    V = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]], float)
    F = np.array([[0, 2, 1], [0, 3, 2]], dtype=np.int64)
    return V, F


SIZE = (160, 120)


@pytest.fixture(scope="module")
def sphere():
    return icosphere(3, radius=100.0)  # 100 mm: a statue-scale pixel footprint


def test_image_shape_background_and_object(sphere):
    V, F = sphere
    img = rd.render_mesh(V, F, size=SIZE, coverage=np.full(len(V), 0.5))
    assert img.shape == (120, 160, 3) and img.dtype == np.uint8
    assert np.all(img[0, 0] == rd.BACKGROUND) and np.all(img[-1, -1] == rd.BACKGROUND)
    center = img[60, 80].astype(int)
    assert np.abs(center - rd.BACKGROUND.astype(int)).sum() > 30


@pytest.mark.parametrize("material", ["aged-bronze", "gilt", "bronze"])
def test_render_is_deterministic(sphere, material):
    V, F = sphere
    a = rd.render_mesh(V, F, size=SIZE, material=material, view=(40, 20))
    b = rd.render_mesh(V, F, size=SIZE, material=material, view=(40, 20))
    np.testing.assert_array_equal(a, b)


def test_materials_look_different(sphere):
    V, F = sphere
    imgs = [rd.render_mesh(V, F, size=SIZE, material=m, coverage=np.full(len(V), 0.8)).astype(int)
            for m in ("aged-bronze", "gilt", "bronze")]
    for i in range(3):
        for j in range(i + 1, 3):
            assert np.abs(imgs[i] - imgs[j]).mean() > 2.0
    # the corroded look is greener than gilt: G - R larger on the object
    mask = np.any(imgs[1] != rd.BACKGROUND, axis=-1)
    g_minus_r = [(im[..., 1] - im[..., 0])[mask].mean() for im in imgs]
    assert g_minus_r[0] > g_minus_r[1] + 5


def test_highlight_changes_exactly_the_filled_side(sphere):
    V, F = sphere
    filled = V[F].mean(axis=1)[:, 0] > 30.0  # faces on the +x side
    kw = dict(size=SIZE, view=(0, 0), filled=filled, coverage=np.full(len(V), 0.3))
    off = rd.render_mesh(V, F, highlight_filled=False, **kw).astype(int)
    on = rd.render_mesh(V, F, highlight_filled=True, **kw).astype(int)
    changed = np.any(on != off, axis=-1)
    assert changed.sum() > 500
    # camera on +z looking at -z with y up: +x is the right of the image
    assert not changed[:, : SIZE[0] // 2].any()
    # the tint is magenta: red + blue up relative to green
    d = (on - off)[changed]
    assert np.mean(d[:, 0] + d[:, 2] - 2 * d[:, 1]) > 40
    # no highlight without flags
    none = rd.render_mesh(V, F, highlight_filled=True, size=SIZE, view=(0, 0),
                          coverage=np.full(len(V), 0.3)).astype(int)
    np.testing.assert_array_equal(none, off)


def test_shadows_darken_the_ground(sphere):
    Vs, Fs = icosphere(3, radius=1.0)
    Vp, Fp = quad_plane()
    V = np.concatenate([Vs, Vp])
    F = np.concatenate([Fs, Fp + len(Vs)])
    cam = rd.frame_camera(V, SIZE, view=(0, 35))
    # fully corroded: the patina is diffuse, so the direct light shows everywhere
    with_sphere = rd.render_mesh(V, F, camera=cam, coverage=np.ones(len(V))).astype(int)
    plane_only = rd.render_mesh(Vp, Fp, camera=cam, coverage=np.ones(len(Vp))).astype(int)
    # pixels where the sphere itself is seen: those differ from the plane-only render
    # in any direction; elsewhere the sphere can only take light away (a shadow)
    sphere_px = rd.render_mesh(Vs, Fs, camera=cam, material="bronze")
    on_sphere = np.any(sphere_px != rd.BACKGROUND, axis=-1)
    diff = (with_sphere - plane_only).sum(axis=-1)[~on_sphere]
    assert (diff < -30).sum() > 50  # a visible shadow
    assert (diff > 3).sum() == 0  # nothing gets brighter


def test_side_by_side_shares_the_camera(sphere):
    V, F = sphere
    V2, F2 = icosphere(3, radius=100.0)
    filled = V2[F2].mean(axis=1)[:, 1] > 50.0
    img = rd.render_side_by_side(V, F, V2, F2, size=SIZE, filled=filled, highlight_filled=True, gap=6,
                                 labels=None, legend=None)
    assert img.shape == (120, 2 * 160 + 6, 3)
    left, right = img[:, :160].astype(int), img[:, 166:].astype(int)
    # same geometry, same camera: identical except where the right one is tinted
    changed = np.any(left != right, axis=-1)
    assert 0 < changed.sum() < 0.5 * np.any(left != rd.BACKGROUND, axis=-1).sum()
    assert not changed[SIZE[1] // 2:].any()  # only the top (+y) is flagged


@pytest.mark.slow
def test_degenerate_faces_and_scales_render_finite():
    V, F = icosphere(2)
    F = np.concatenate([F, [[0, 0, 1], [2, 2, 2]]])  # zero-area faces
    for scale in (1e-6, 1.0, 1e6):
        img = rd.render_mesh(V * scale, F, size=(64, 48))
        assert img.dtype == np.uint8 and np.any(img != rd.BACKGROUND)


def test_bad_input_raises_value_error(sphere):
    V, F = sphere
    with pytest.raises(ValueError, match="face"):
        rd.render_mesh(V, np.array([[0, 1, len(V)]]), size=SIZE)
    with pytest.raises(ValueError, match="filled"):
        rd.render_mesh(V, F, size=SIZE, filled=np.zeros(3, bool))
    with pytest.raises(ValueError, match="unknown material"):
        rd.render_mesh(V, F, size=SIZE, material="chrome")
    with pytest.raises(ValueError):
        rd.render_mesh(np.zeros((0, 3)), F, size=SIZE)
    Vn = V.copy()
    Vn[5, 1] = np.nan
    with pytest.raises(ValueError, match="vertex 5"):
        rd.render_mesh(Vn, F, size=SIZE)


def test_save_png_round_trip_and_atomic(tmp_path):
    img = np.zeros((7, 9, 3), np.uint8)
    img[2, 3] = (10, 200, 30)
    out = tmp_path / "a.png"
    rd.save_png(out, img)
    np.testing.assert_array_equal(np.asarray(Image.open(out)), img)
    with pytest.raises(ValueError):
        rd.save_png(tmp_path / "b.png", np.zeros((7, 9), np.uint8))
    with pytest.raises(OSError):
        rd.save_png(tmp_path / "missing" / "c.png", img)
    assert sorted(os.listdir(tmp_path)) == ["a.png"]  # no partial or temporary files


def test_model_choice_reported(sphere):
    V, F = sphere
    info = {}
    rd.render_mesh(V, F, size=SIZE, info=info)
    assert info["model"].model == "local"  # ~1 mm pixels vs ~10 um diffusion length
    info = {}
    rd.render_mesh(V * 1e-3, F, size=SIZE, info=info, unit="mm")  # a 0.1 mm sphere: um pixels
    assert info["model"].model == "dipole" and info["model"].error_estimate > 0.01


def test_unit_is_inferred_from_the_size_and_drives_the_model_choice(sphere):
    V, F = sphere  # 200 units across
    assert rd.infer_unit(V)[0] == "mm"  # 0.2 m: mm (cm would make it 2 m: also plausible, mm preferred)
    assert rd.infer_unit(V * 1e-3)[0] == "m"  # 0.2 units: only metres give a statue
    assert rd.infer_unit(V * 0.1)[0] == "cm"  # 20 units: 20 cm
    assert rd.infer_unit(V * 1e-6)[0] == "m"  # nothing plausible: the closest, and it says so
    assert "closest" in rd.infer_unit(V * 1e-6)[1]
    small = V * 1e-3
    got = {}
    for unit in (None, "m", "mm"):
        info = {}
        rd.render_mesh(small, F, size=(64, 48), unit=unit, info=info, supersample=1)
        got[unit] = info
    assert got[None]["unit"] == "m" and got[None]["model"].model == "local"
    assert got["m"]["footprint_um"] == pytest.approx(1000.0 * got["mm"]["footprint_um"])
    assert got["mm"]["model"].model == "dipole"
    # the switch lies where the documented footprint says
    switch = sd.model_switch_footprint_um("aged-bronze")
    assert sd.choose_model(1.05 * switch, "aged-bronze").model == "local"
    assert sd.choose_model(0.95 * switch, "aged-bronze").model == "dipole"
    with pytest.raises(ValueError, match="unit"):
        rd.render_mesh(V, F, size=SIZE, unit="inch")


def test_supersampling_is_the_linear_average_of_a_finer_render(sphere):
    V, F = sphere
    kw = dict(view=(30, 20), coverage=np.full(len(V), 0.4), unit="mm")
    aa = rd.render_mesh(V, F, size=(80, 60), supersample=2, **kw)
    fine = rd.render_mesh(V, F, size=(160, 120), supersample=1, **kw)
    # same rays: the 2x2 render averaged in linear light, re-encoded
    expect = rd.downsample(fine, 2)
    assert np.abs(aa.astype(int) - expect.astype(int)).max() <= 1
    # closer to a 4x4 reference than one ray per pixel is (jagged edges, aliased highlights)
    one = rd.render_mesh(V, F, size=(80, 60), supersample=1, **kw)
    ref = rd.downsample(rd.render_mesh(V, F, size=(320, 240), supersample=1, **kw), 4).astype(int)
    err_one = np.abs(one.astype(int) - ref).sum(-1)
    err_aa = np.abs(aa.astype(int) - ref).sum(-1)
    assert err_aa.mean() < 0.6 * err_one.mean()
    assert err_aa.max() < err_one.max()


def test_side_by_side_has_labels_and_a_legend(sphere):
    V, F = sphere
    filled = V[F].mean(axis=1)[:, 1] > 50.0
    kw = dict(size=(200, 150), filled=filled, highlight_filled=True, gap=6)
    plain = rd.render_side_by_side(V, F, V, F, labels=None, legend=None, **kw).astype(int)
    info = {}
    img = rd.render_side_by_side(V, F, V, F, info=info, **kw).astype(int)
    diff = np.any(img != plain, axis=-1)
    left, right = diff[:, :200], diff[:, 206:]
    assert left[:30, :80].any() and right[:30, :80].any()  # "before" / "after" at the top-left
    assert right[-30:, :120].any() and not left[-30:, :].any()  # legend only on the right
    # the legend's swatch shows the tint (magenta: red and blue above green)
    sw = img[-30:, 206:240][right[-30:, :34]]
    assert np.any((sw[:, 0] > sw[:, 1] + 60) & (sw[:, 2] > sw[:, 1] + 60))
    # one camera, one unit and one aging map for both panels
    assert info["before"]["camera"] == info["after"]["camera"]
    assert info["before"]["unit"] == info["after"]["unit"]


def test_cli_render_says_the_unit_and_model(tmp_path, capsys):
    from shellrepair.cli import main

    bunny = os.path.join(os.path.dirname(__file__), "..", "data", "bunny_zipper.ply")
    out = tmp_path / "b.png"
    assert main(["render", bunny, "-o", str(out), "--size", "96x72"]) == 0
    said = capsys.readouterr().out
    assert "unit: m (inferred" in said and "local model" in said and out.exists()
    assert main(["render", bunny, "-o", str(out), "--size", "96x72", "--unit", "mm", "--age", "0.8"]) == 0
    said = capsys.readouterr().out
    assert "unit: mm (given)" in said and "dipole model" in said
    with pytest.raises(SystemExit):
        main(["render", bunny, "-o", str(out), "--age", "1.5"])


def test_view_towards_faces_the_selected_faces():
    from shellrepair.appearance.render import frame_camera, view_towards
    from eval import shapes

    V, F = shapes.icosphere(3)
    C = V[F].mean(axis=1)
    for target in ([1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.3, -1.0]):
        t = np.asarray(target) / np.linalg.norm(target)
        mask = C @ t > 0.9
        cam = frame_camera(V, view=view_towards(V, F, mask))
        d = (np.asarray(cam.eye) - np.asarray(cam.target))
        d /= np.linalg.norm(d)
        # within the elevation clamp of 75 degrees, the camera looks at the patch
        assert d @ t > np.cos(np.radians(16))
    assert view_towards(V, F, np.zeros(len(F), bool)) is None
