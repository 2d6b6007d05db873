"""Specification of the renderer's lights: soft shadows, the same bytes every time, and the aging setting."""

import numpy as np
import pytest
from scipy import ndimage

from shellrepair.appearance import render as rd
from eval import shapes


def floor_and_post():
    """A 4 x 4 floor (y = 0, facing up) and a square post 0.3 wide and 1.5 tall on it."""
    V, F = shapes.grid(40, 40)
    V = np.asarray(V, float)
    V = (V - V.min(axis=0)) / np.ptp(V[:, :2], axis=0).max() * 4.0 - [2.0, 2.0, 0.0]
    V = np.stack([V[:, 0], np.zeros(len(V)), -V[:, 1]], axis=1)  # the xz-plane, normals +y
    F = np.asarray(F, np.int64)
    if np.cross(V[F[0, 1]] - V[F[0, 0]], V[F[0, 2]] - V[F[0, 0]])[1] < 0:
        F = F[:, ::-1].copy()
    c = np.array([[x, y, z] for x in (-0.15, 0.15) for y in (0.0, 1.5) for z in (-0.15, 0.15)])
    hull = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
            [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    Fp = np.asarray(hull, np.int64)
    # wind the post outward
    cen = c.mean(axis=0)
    n = np.cross(c[Fp[:, 1]] - c[Fp[:, 0]], c[Fp[:, 2]] - c[Fp[:, 0]])
    out = np.einsum("ij,ij->i", n, c[Fp].mean(axis=1) - cen) > 0
    Fp[~out] = Fp[~out][:, ::-1]
    return np.concatenate([V, c]), np.concatenate([F, Fp + len(V)])


def shadow_map():
    """Light left on the floor by the post, 0 (all direct light blocked) to 1
    (none), from a render with the post over one without it (one camera,
    from high above); the pixels where the post itself is seen are left out."""
    V, F = floor_and_post()
    nf = len(F) - 12
    info = {}
    kw = dict(coverage=np.ones(len(V)), gild=np.ones(len(V)))  # all patina: diffuse, shadows show
    img = rd.render_mesh(V, F, size=(320, 240), view=(0.0, 80.0), info=info, **kw)
    cam = info["camera"]
    bare = rd.render_mesh(V, F[:nf], camera=cam, **kw)
    post = rd.render_mesh(V, F[nf:], camera=cam, **kw)
    L, L0 = img.astype(float).mean(axis=-1), bare.astype(float).mean(axis=-1)
    floor = ndimage.binary_erosion(np.any(bare != rd.BACKGROUND, axis=-1), iterations=3)
    floor &= ~ndimage.binary_dilation(np.any(post != rd.BACKGROUND, axis=-1), iterations=3)
    r = np.where(floor, L / np.maximum(L0, 1.0), 1.0)
    return img, r, floor


def test_shadows_have_a_penumbra_and_the_picture_is_the_same_bytes_every_time():
    """The lights are small discs, not points: a shadow's edge fades over
    several pixels instead of cutting the surface with a line."""
    img, r, floor = shadow_map()
    img2, _, _ = shadow_map()
    np.testing.assert_array_equal(img, img2)
    dark = r[floor].min()
    assert dark < 0.8  # the post's shadow is there
    s = (r - dark) / (1.0 - dark)  # 0 where the key light is blocked, 1 in full light
    inner = ndimage.binary_erosion(floor)
    step = np.maximum(np.abs(np.diff(s, axis=0, append=1.0)), np.abs(np.diff(s, axis=1, append=1.0)))
    # a point light's shadow jumps from dark to lit within a pixel (measured:
    # a step of 0.99); the disc's is at most 0.37, at the post's foot, where
    # the penumbra narrows to nothing
    assert step[inner].max() < 0.5, step[inner].max()


def test_render_setting_outdoor_ages_the_statue_by_rain_not_by_recesses(tmp_path):
    from PIL import Image

    import shellrepair
    from shellrepair.cli import main

    V, F = shapes.bumpy_sphere(4, amplitude=0.08, frequency=4)
    scan = tmp_path / "s.ply"
    shellrepair.write_mesh(scan, shellrepair.Mesh(V=V, F=F))
    pics = {}
    for setting in ("indoor", "outdoor"):
        out = tmp_path / (setting + ".png")
        assert main(["render", str(scan), "-o", str(out), "--size", "96x72", "--setting", setting, "-q"]) == 0
        pics[setting] = np.asarray(Image.open(out))
    changed = np.any(pics["indoor"] != pics["outdoor"], axis=-1)
    assert changed.mean() > 0.05
    # the default is indoor
    out = tmp_path / "default.png"
    assert main(["render", str(scan), "-o", str(out), "--size", "96x72", "-q"]) == 0
    np.testing.assert_array_equal(np.asarray(Image.open(out)), pics["indoor"])


def test_an_unknown_setting_is_refused_in_one_line():
    V, F = shapes.icosphere(1)
    with pytest.raises(ValueError, match="setting must be one of indoor, outdoor"):
        rd.render_mesh(V, F, size=(32, 24), setting="garden")
