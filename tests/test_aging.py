"""Specification of shellrepair.appearance.aging: where the statue corrodes and keeps its gold."""

from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from shellrepair.appearance import aging as ag
from shellrepair.appearance import render as rd
from shellrepair.mesh.topology import face_areas
from eval import shapes

BUNNY = Path(__file__).resolve().parents[1] / "data" / "bunny_zipper.ply"


def box(center, half, n=12):
    """Closed axis-aligned box (V, F) with n x n quads per side, outward winding."""
    V, F = shapes.grid(n, n)  # unit square in z = 0, normals +z
    V = np.asarray(V, float)
    V = (V - V.min(axis=0)) / np.ptp(V[:, :2], axis=0).max() * 2.0 - [1.0, 1.0, 0.0]
    V[:, 2] = 1.0
    Vs, Fs = [], []
    # rotations taking +z to each face normal
    rots = [np.eye(3), np.diag([1.0, -1.0, -1.0]),
            np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0.0]]), np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0.0]]),
            np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0.0]]), np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0.0]])]
    for k, Rm in enumerate(rots):
        Vs.append(V @ Rm.T)
        Fs.append(np.asarray(F) + k * len(V))
    V = np.concatenate(Vs) * np.asarray(half, float) + np.asarray(center, float)
    return V, np.concatenate(Fs).astype(np.int64)


def area_weights(V, F):
    """Each vertex's share of the surface: a third of the area of each face around it."""
    F = np.asarray(F, np.int64)
    a = face_areas(np.asarray(V, float), F)
    return np.bincount(F.ravel(), np.repeat(a / 3.0, 3), minlength=len(V))


def colour_masks(img):
    """Gold (hue 25-65 deg, saturation >= 0.3, value >= 0.25) and green patina
    (hue 80-200 deg, saturation >= 0.2, value >= 0.15) pixels of the object."""
    obj = np.any(img != rd.BACKGROUND, axis=-1)
    x = img.astype(float) / 255.0
    mx, mn = x.max(-1), x.min(-1)
    d = mx - mn
    sat = np.where(mx > 0, d / np.maximum(mx, 1e-9), 0.0)
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    ds = np.maximum(d, 1e-9)
    hue = 60.0 * np.where(mx == r, ((g - b) / ds) % 6, np.where(mx == g, (b - r) / ds + 2, (r - g) / ds + 4))
    hue = np.where(d > 0, hue, 0.0)
    gold = obj & (hue >= 25) & (hue <= 65) & (sat >= 0.3) & (mx >= 0.25)
    green = obj & (hue >= 80) & (hue <= 200) & (sat >= 0.2) & (mx >= 0.15)
    return obj, gold, green


def in_patches(mask, min_px):
    """Fraction of the mask's pixels in 8-connected components of >= min_px pixels."""
    lab, n = ndimage.label(mask, structure=np.ones((3, 3)))
    if n == 0:
        return 0.0
    sizes = np.bincount(lab.ravel())[1:]
    return float(sizes[sizes >= min_px].sum() / mask.sum())


# --------------------------------------------------------------------------
# The measures
# --------------------------------------------------------------------------


def test_convexity_of_a_sphere_is_1_25_scale_over_radius():
    """The grid convexity is a mean-curvature estimate at its scale: kappa = 1.25 s / R."""
    V, F = shapes.icosphere(5)
    far = np.array([12.0, 0.0, 0.0])  # a second sphere stretches the diagonal: R >> s
    for r in (0.5, 1.0, 3.0):
        V2 = np.concatenate([V * r, V + far])
        F2 = np.concatenate([F, F + len(V)])
        maps = ag.aging_maps(V2, F2)
        diag = np.linalg.norm(V2.max(0) - V2.min(0))
        s = ag.AgingParams().edge_scale * diag
        k = maps.convexity_edge[: len(V)]
        assert np.median(k) == pytest.approx(1.25 * s / r, rel=0.03)
        lo, hi = np.percentile(k, [2, 98]) / np.median(k)
        assert lo > 0.85 and hi < 1.15  # uniform on a sphere up to the grid's anisotropy


def test_exposure_rain_from_above_and_shelter_under_an_overhang():
    """Outdoors, rain greens the washed faces and a dark crust builds on the sheltered ones."""
    # a low block and, above its left half, a roof: rain reaches the right half only
    Vb, Fb = box((0.0, 0.0, 0.0), (2.0, 0.3, 1.0))
    Vr, Fr = box((-1.0, 2.0, 0.0), (1.1, 0.2, 1.2))
    V = np.concatenate([Vb, Vr])
    F = np.concatenate([Fb, Fr + len(Vb)])
    maps = ag.aging_maps(V, F, up=(0, 1, 0), setting="outdoor")
    top = (np.abs(V[:, 1] - 0.3) < 1e-9) & (np.arange(len(V)) < len(Vb))
    under = top & (V[:, 0] < -0.5) & (V[:, 0] > -1.6) & (np.abs(V[:, 2]) < 0.6)
    open_ = top & (V[:, 0] > 0.8) & (V[:, 0] < 1.4) & (np.abs(V[:, 2]) < 0.6)
    assert np.all(maps.exposure[open_] > 0.9)
    assert np.all(maps.exposure[under] < 0.1)
    bottom = np.abs(V[:, 1] + 0.3) < 1e-9
    assert np.all(maps.exposure[bottom] == 0.0)  # facing down: no rain
    assert maps.crust[under].mean() > maps.crust[open_].mean()  # unwashed: dark crust
    plain = ag.aging_maps(V, F, up=(0, 1, 0), params=ag.AgingParams(d_blotch=0.0, setting="outdoor"))
    p = ag.AgingParams()
    np.testing.assert_allclose(plain.crust[under], p.d_shelter - p.d_offset, atol=0.08)
    assert np.all(plain.crust[open_] == 0.0)
    # turning the world upside down swaps the roles of top and bottom faces
    flipped = ag.aging_maps(V, F, up=(0, -1, 0), setting="outdoor")
    assert np.all(flipped.exposure[top] == 0.0)


def test_wear_on_convex_edges_and_cavities_in_hollows():
    V, F = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), n=16)
    maps = ag.aging_maps(V, F)
    on_edge = np.sum(np.abs(np.abs(V) - 1.0) < 1e-9, axis=1) >= 2
    mid_face = np.sum(np.abs(V) < 0.3, axis=1) == 2
    assert maps.wear[on_edge].mean() > 0.8
    assert np.all(maps.wear[mid_face] == 0.0)
    assert np.all(maps.cavity == 0.0)  # a convex solid has no hollows
    # inside corner of an L-shaped pair of blocks: a hollow
    V1, F1 = box((0.0, 0.0, 0.0), (2.0, 0.5, 1.0))
    V2, F2 = box((-1.5, 1.5, 0.0), (0.5, 1.0, 1.0))
    V = np.concatenate([V1, V2])
    F = np.concatenate([F1, F2 + len(V1)])
    maps = ag.aging_maps(V, F)
    floor = (np.arange(len(V)) < len(V1)) & (np.abs(V[:, 1] - 0.5) < 1e-9) & (np.abs(V[:, 2]) < 0.5)
    corner = floor & (V[:, 0] > -1.0) & (V[:, 0] < -0.8)  # the floor beside the wall
    away = floor & (V[:, 0] > 0.0) & (V[:, 0] < 1.5)
    assert corner.any() and maps.cavity[corner].mean() > 0.5
    assert np.all(maps.cavity[away] == 0.0)
    # rain does not wash hollows: a dark crust builds there first
    plain = ag.aging_maps(V, F, params=ag.AgingParams(d_blotch=0.0))
    assert plain.crust[corner].mean() > 0.2 and np.all(plain.crust[away] == 0.0)


# --------------------------------------------------------------------------
# The age and the maps it makes
# --------------------------------------------------------------------------


def test_age_sets_the_corroded_and_ungilded_area():
    V, F = shapes.icosphere(4)
    V = V * (1.0 + 0.2 * np.sin(3 * V[:, :1]) * np.cos(2 * V[:, 1:2]))
    w = area_weights(V, F)
    w = w / w.sum()
    new = ag.aging_maps(V, F, age=0.0)
    assert np.all(new.coverage == 0.0) and np.all(new.gild == 1.0)
    old = ag.aging_maps(V, F, age=1.0)
    assert np.all(old.coverage == 1.0)
    fractions = []
    for age in (0.2, 0.4, 0.6, 0.8):
        maps = ag.aging_maps(V, F, age=age)
        assert np.sum(w * maps.coverage) == pytest.approx(age, abs=0.03)
        lost = np.sum(w * (1.0 - maps.coverage) * (1.0 - maps.gild)) / np.sum(w * (1.0 - maps.coverage))
        assert lost == pytest.approx(ag.AgingParams().loss * age, abs=0.03)
        fractions.append(np.sum(w * maps.coverage))
    assert np.all(np.diff(fractions) > 0)
    with pytest.raises(ValueError, match="age"):
        ag.aging_maps(V, F, age=1.2)


def test_deterministic_seeded_and_resolution_independent():
    V, F = shapes.icosphere(4)
    a = ag.aging_maps(V, F, seed=3)
    b = ag.aging_maps(V, F, seed=3)
    np.testing.assert_array_equal(a.coverage, b.coverage)
    np.testing.assert_array_equal(a.gild, b.gild)
    c = ag.aging_maps(V, F, seed=4)
    assert np.mean(np.abs(a.coverage - c.coverage)) > 0.1
    # a finer mesh of the same shape gives the same map at the shared vertices
    V5, F5 = shapes.icosphere(5)  # icosphere(4)'s vertices come first
    np.testing.assert_allclose(V5[: len(V)], V, atol=1e-12)
    fine = ag.aging_maps(V5, F5, seed=3)
    assert np.mean(np.abs(fine.coverage[: len(V)] - a.coverage)) < 0.08
    # the noise at a point does not depend on the other points sampled with it
    P = np.random.default_rng(0).uniform(-1, 1, (500, 3))
    full = ag.value_noise(P, 0.3, seed=2, normalize=False)
    part = ag.value_noise(P[:7], 0.3, seed=2, normalize=False)
    np.testing.assert_allclose(part, full[:7], rtol=0, atol=1e-15)
    z = ag.value_noise(P, 0.3, seed=2)
    assert abs(z.mean()) < 1e-12 and z.std() == pytest.approx(1.0)


# --------------------------------------------------------------------------
# What a person sees
# --------------------------------------------------------------------------


def _aged_render(path, up, size=(240, 180), seed=0):
    from shellrepair.mesh.io import read_mesh

    mesh = read_mesh(path)
    return rd.render_mesh(mesh.V, mesh.F, size=size, up=up, seed=seed)


def _assert_reads_as_aged_gilt_bronze(img):
    obj, gold, green = colour_masks(img)
    n = obj.sum()
    assert gold.sum() >= 0.15 * n, gold.sum() / n
    assert green.sum() >= 0.10 * n, green.sum() / n
    # in patches, not salt and pepper: most of each colour lies in blobs of
    # at least 0.5 % of the object's pixels
    assert in_patches(gold, 0.005 * n) > 0.7
    assert in_patches(green, 0.005 * n) > 0.7


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.slow
def test_default_aged_bunny_shows_gilding_and_patina_in_patches(seed):
    _assert_reads_as_aged_gilt_bronze(_aged_render(BUNNY, (0, 1, 0), seed=seed))


def test_default_aged_bust_shows_gilding_and_patina_in_patches():
    from conftest import shared_scan

    path = shared_scan("closed_nefertiti_bust.ply")  # z-up, in mm
    _assert_reads_as_aged_gilt_bronze(_aged_render(path, (0, 0, 1)))


def test_the_scans_own_vertices_keep_their_map_whatever_fills_its_holes():
    """A before | after pair must differ only where the surface changed: the
    bundled bunny filled flat (order 1) and domed (order 3, which bulges
    past the scan's bounding box under its base) gives the scan's own
    vertices the coverage and gilding they have without any fill (the
    issue's bar: within 0.05 on 98 % of them; here to round-off on all)."""
    from shellrepair import read_mesh
    from shellrepair.repair import repair_mesh

    scan = read_mesh(BUNNY)
    n = len(scan.V)
    used = np.zeros(n, bool)
    used[scan.F.ravel()] = True
    alone = ag.aging_maps(scan.V, scan.F)
    for order in (1, 3):
        R, _ = repair_mesh(read_mesh(BUNNY), order=order)
        assert R.face_filled.any()
        maps = ag.aging_maps(R.V, R.F, scan=~R.face_filled)
        for a, b in ((maps.coverage, alone.coverage), (maps.gild, alone.gild)):
            d = np.abs(a[:n] - b)[used]
            assert np.mean(d <= 0.05) >= 0.98 and d.max() < 1e-9, (order, np.mean(d <= 0.05), d.max())
        # the filled vertices get a map too, read from the same fields
        assert np.isfinite(maps.coverage[n:]).all() and ((maps.coverage[n:] >= 0) & (maps.coverage[n:] <= 1)).all()
    # without the scan's faces named, the fill moves the map (what the flag is for)
    R, _ = repair_mesh(read_mesh(BUNNY), order=3)
    moved = np.abs(ag.aging_maps(R.V, R.F).coverage[:n] - alone.coverage)[used]
    assert moved.max() > 0.05


def test_a_scan_flag_of_the_wrong_length_is_refused():
    V, F = shapes.icosphere(1)
    with pytest.raises(ValueError, match="one flag per face"):
        ag.aging_maps(V, F, scan=np.ones(len(F) + 1, bool))


# --------------------------------------------------------------------------
# Indoors: occlusion, recesses and raised gold
# --------------------------------------------------------------------------


def revolve(profile, n=48):
    """Closed surface of revolution about +y of a profile [(r, y), ...] that
    starts and ends on the axis (r = 0), wound outward."""
    profile = np.asarray(profile, float)
    ring = profile[1:-1]
    t = 2.0 * np.pi * np.arange(n) / n
    V = [[0.0, profile[0, 1], 0.0]]
    for r, y in ring:
        V += [[r * np.cos(a), y, r * np.sin(a)] for a in t]
    V.append([0.0, profile[-1, 1], 0.0])
    V = np.asarray(V)
    k, last = len(ring), len(V) - 1
    F = [[0, 1 + (j + 1) % n, 1 + j] for j in range(n)]
    for i in range(k - 1):
        for j in range(n):
            a, b = 1 + i * n + j, 1 + i * n + (j + 1) % n
            F += [[a, b, b + n], [a, b + n, a + n]]
    F += [[last, 1 + (k - 1) * n + j, 1 + (k - 1) * n + (j + 1) % n] for j in range(n)]
    F = np.asarray(F, np.int64)
    vol = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum()
    return V, (F if vol > 0 else F[:, ::-1].copy())


def bowl():
    """A thick hemispherical bowl, opening up: outer radius 1, inner 0.8."""
    outer = [(np.sin(a), -np.cos(a)) for a in np.linspace(0.0, np.pi / 2, 13)]
    inner = [(0.8 * np.sin(a), -0.8 * np.cos(a)) for a in np.linspace(np.pi / 2, 0.0, 11)]
    return revolve(outer + inner)


def test_ambient_occlusion_is_deterministic_in_unit_range_and_sees_a_bowl_from_inside():
    V, F = bowl()
    ao = ag.ambient_occlusion(V, F)
    np.testing.assert_array_equal(ao, ag.ambient_occlusion(V, F))  # the same bytes
    assert ao.shape == (len(V),) and np.all((ao >= 0.0) & (ao <= 1.0))
    r = np.hypot(V[:, 0], V[:, 2])
    radius = np.linalg.norm(V, axis=1)
    floor = (np.abs(radius - 0.8) < 1e-9) & (r < 0.3)           # inside, at the bottom
    outside = (np.abs(radius - 1.0) < 1e-9) & (V[:, 1] < -0.2)   # the outer wall
    assert floor.any() and outside.any()
    # from the bottom the opening is a cone of half-angle 45 degrees: 1 - cos 45 of the
    # hemisphere's solid angle escapes, so about 0.7 of the rays hit the wall
    assert ao[floor].mean() == pytest.approx(1.0 - (1.0 - np.cos(np.pi / 4)), abs=0.1)
    assert np.all(ao[outside] == 0.0)
    # the indoor map puts the patina in the bowl and keeps the outside gilt
    maps = ag.aging_maps(V, F)
    inside = (np.abs(radius - 0.8) < 1e-9) & (V[:, 1] < -0.3)
    assert maps.occlusion[inside].mean() > maps.occlusion[outside].mean() + 0.3
    assert maps.coverage[inside].mean() > 2.0 * maps.coverage[outside].mean()
    with pytest.raises(ValueError, match="rays"):
        ag.ambient_occlusion(V, F, rays=0)


def test_recess_ratio_compares_the_most_and_least_occluded_tenths():
    ao = np.linspace(0.0, 1.0, 100)
    assert ag.recess_ratio(ao, ao) == pytest.approx(np.mean(ao[-10:]) / np.mean(ao[:10]))
    assert ag.recess_ratio(ao, 1.0 - ao) < 1.0
    # ties at the low end are all counted in, whatever the vertex order
    ao = np.r_[np.zeros(30), np.linspace(0.1, 1.0, 70)]
    cov = np.r_[np.full(30, 0.2), np.ones(70)]
    assert ag.recess_ratio(ao, cov) == pytest.approx(5.0)
    assert ag.recess_ratio(ao[::-1], cov[::-1]) == pytest.approx(5.0)


def _decimated(path, faces):
    """The scan as read, or a quadric-decimated copy with about ``faces`` faces."""
    from shellrepair.mesh.io import read_mesh

    mesh = read_mesh(path)
    if faces is None:
        return mesh.V, mesh.F
    import open3d as o3d

    tm = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(mesh.V), o3d.utility.Vector3iVector(mesh.F))
    tm = tm.simplify_quadric_decimation(faces)
    tm.remove_unreferenced_vertices()
    return np.asarray(tm.vertices, np.float64), np.asarray(tm.triangles, np.int64)


@pytest.mark.parametrize("name, up, faces", [
    ("closed_cheburashka.ply", (0, 1, 0), None),          # as scanned, 13k faces
    ("closed_nefertiti_bust.ply", (0, 0, 1), 20000),      # decimated from 100k, to keep the test fast
    ("real_bunny_zipper.ply", (0, 1, 0), 3000),           # a coarse mesh: the map must still follow the shape
])
def test_indoors_the_patina_gathers_in_recesses_and_gold_survives_on_raised_areas(name, up, faces):
    """The issue's measure: with AO as the fraction of 64 hemisphere rays per
    vertex that hit the mesh, the most occluded tenth of the vertices has at
    least twice the mean coverage of the least occluded tenth."""
    from conftest import shared_scan

    V, F = _decimated(shared_scan(name), faces)
    ao = ag.ambient_occlusion(V, F, rays=64)
    maps = ag.aging_maps(V, F, up=up)  # the default: indoor, DEFAULT_AGE
    assert ag.recess_ratio(ao, maps.coverage) >= 2.0
    k = len(V) // 10
    order = np.argsort(ao, kind="stable")
    gold = maps.gild * (1.0 - maps.coverage)
    assert gold[order[:k]].mean() > 2.0 * gold[order[-k:]].mean()
    # outdoors the rain decides, not the recesses
    out = ag.aging_maps(V, F, up=up, setting="outdoor")
    assert ag.recess_ratio(ao, out.coverage) < ag.recess_ratio(ao, maps.coverage)


def test_outdoors_rain_greens_the_washed_faces_indoors_the_sheltered_ones_gather_patina():
    """One shape, two settings: under a low roof the air is still and no rain
    comes; the open top is washed by rain and free of dust."""
    Vb, Fb = box((0.0, 0.0, 0.0), (2.0, 0.3, 1.0))
    Vr, Fr = box((-1.0, 1.0, 0.0), (1.1, 0.2, 1.2))  # roof 0.5 above the block's left half
    V = np.concatenate([Vb, Vr])
    F = np.concatenate([Fb, Fr + len(Vb)])
    top = (np.abs(V[:, 1] - 0.3) < 1e-9) & (np.arange(len(V)) < len(Vb))
    under = top & (V[:, 0] < -0.5) & (V[:, 0] > -1.6) & (np.abs(V[:, 2]) < 0.6)
    open_ = top & (V[:, 0] > 0.8) & (V[:, 0] < 1.4) & (np.abs(V[:, 2]) < 0.6)
    flat = ag.AgingParams(a_blotch=0.0, a_blotch_indoor=0.0)
    indoor = ag.aging_maps(V, F, params=flat, age=0.2)
    outdoor = ag.aging_maps(V, F, params=flat, age=0.2, setting="outdoor")
    assert indoor.occlusion[under].mean() > indoor.occlusion[open_].mean() + 0.3
    assert indoor.coverage[under].mean() > 0.9 and indoor.coverage[open_].mean() < 0.1
    assert outdoor.coverage[open_].mean() > 0.9 and outdoor.coverage[under].mean() < 0.1
    assert np.all(outdoor.occlusion == 0.0)  # outdoors no occlusion rays are cast
    with pytest.raises(ValueError, match="setting"):
        ag.aging_maps(V, F, setting="garden")


def test_the_field_reads_the_map_between_the_vertices_of_a_coarse_mesh():
    """Soft patch edges at any resolution: a coarse sphere's field, read on
    the sphere between its vertices, gives what a fine mesh of the same
    sphere gives there, not a blend of its corners (which follows the
    triangles)."""
    Vc, Fc = shapes.icosphere(2)
    Vf, Ff = shapes.icosphere(5)
    coarse = ag.aging_maps(Vc, Fc, seed=1)
    fine = ag.aging_maps(Vf, Ff, seed=1)
    c, g, k = coarse.field.at(Vc)
    np.testing.assert_allclose(c, coarse.coverage, atol=1e-12)  # at the vertices: the vertex map
    np.testing.assert_allclose(g, coarse.gild, atol=1e-12)
    read, _, _ = coarse.field.at(Vf)
    # the blend of the coarse corners at the fine vertices (nearest coarse face by its centroid)
    from scipy.spatial import cKDTree

    cen = Vc[Fc].mean(axis=1)
    _, f = cKDTree(cen).query(Vf)
    T = Vc[Fc[f]]
    # barycentric coordinates of the fine vertex's projection on that face
    e1, e2, d = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0], Vf - T[:, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    b1 = ((d * e1).sum(1) * d22 - (d * e2).sum(1) * d12) / (d11 * d22 - d12 * d12)
    b2 = ((d * e2).sum(1) * d11 - (d * e1).sum(1) * d12) / (d11 * d22 - d12 * d12)
    blend = (1 - b1 - b2) * coarse.coverage[Fc[f, 0]] + b1 * coarse.coverage[Fc[f, 1]] + b2 * coarse.coverage[Fc[f, 2]]
    err_field = np.mean(np.abs(read - fine.coverage))
    err_blend = np.mean(np.abs(blend - fine.coverage))
    assert err_field < 0.1 and err_field < 0.6 * err_blend, (err_field, err_blend)
