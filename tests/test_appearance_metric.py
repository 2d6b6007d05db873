"""The appearance error of a repair (eval/appearance.py) on cases whose answer is known."""

import numpy as np
import pytest

from eval import appearance as ap
from eval import shapes

SIZE = (96, 96)


@pytest.fixture(scope="module")
def capped_sphere():
    """A sphere, a cap of it standing for a filled hole, the truth's look and a camera on the cap."""
    V, F = shapes.icosphere(4)
    cap = V[F].mean(axis=1)[:, 2] > 0.8
    look = ap.truth_look(V, F)
    cams = ap.region_cameras(V, F, cap, n_views=1, size=SIZE)
    truth = [ap.render_view(V, F, c, look, supersample=1) for c in cams]
    return V, F, cap, look, cams, truth


def test_identical_meshes_have_no_appearance_error(capped_sphere):
    V, F, cap, look, cams, truth = capped_sphere
    (view,) = ap.measure_views(V, F, cap, V.copy(), F.copy(), cap, cams, look, truth, supersample=1)
    assert view["pixels"] > 100
    assert view["delta_e"] == 0.0
    assert view["ssim"] == pytest.approx(1.0, abs=1e-12)


def test_a_dented_patch_shows_and_the_rest_does_not_count(capped_sphere):
    V, F, cap, look, cams, truth = capped_sphere
    z = V[:, 2]
    inner = np.zeros(len(V), bool)
    inner[np.unique(F[cap])] = True
    inner &= z > 0.83  # the cap's rim stays on the sphere, as a fill's rim is the hole's
    dented = V.copy()
    dented[inner] *= (1.0 - 0.6 * (z[inner] - 0.83))[:, None]  # a dent 0.1 deep at the pole
    (view,) = ap.measure_views(V, F, cap, dented, F, cap, cams, look, truth, supersample=1)
    assert view["delta_e"] > 2.0  # visible at a glance (1 is just noticeable)
    assert view["ssim"] < 0.95
    # far from the cap nothing changed: a mask there measures no error
    far = ~ap.region_pixels(ap.face_ids(V, F, cams[0]), cap, dilate=4) & (truth[0] != truth[0][0, 0]).any(axis=2)
    assert far.sum() > 50
    assert ap.region_error(truth[0], view["image"], far)["delta_e"] == 0.0


def test_a_hole_left_open_is_measured_not_skipped(capped_sphere):
    V, F, cap, look, cams, truth = capped_sphere
    # the tool added nothing; the pixels are those of the faces the truth lost
    (view,) = ap.measure_views(V, F, cap, V, F[~cap], np.zeros((~cap).sum(), bool), cams, look, truth,
                               supersample=1)
    assert view["pixels"] > 100
    assert view["delta_e"] > 5.0


def test_region_error_of_an_empty_mask_and_hole_regions():
    img = np.zeros((20, 20, 3), np.uint8)
    assert ap.region_error(img, img, np.zeros((20, 20), bool))["delta_e"] is None
    V, F = shapes.icosphere(3)
    z = V[F].mean(axis=1)[:, 2]
    removed = (z > 0.85) | (z < -0.9)
    regions = ap.hole_regions(F, removed)
    assert len(regions) == 2
    assert regions[0].sum() >= regions[1].sum()
    assert np.array_equal(regions[0] | regions[1], removed)
