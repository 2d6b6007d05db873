"""The repaired mesh with its aged look as glTF 2.0 (shellrepair.gltf, repair --gltf)."""

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shellrepair import read_mesh
from shellrepair.gltf import gltf_bytes, pbr_approximation
from shellrepair.materials import get_material
from shellrepair.repair import repair_mesh

trimesh = pytest.importorskip("trimesh", reason="trimesh writes and reads the glTF files")

BUNNY = Path(__file__).resolve().parents[1] / "data" / "bunny_zipper.ply"


@pytest.fixture(scope="module")
def repaired():
    R, _ = repair_mesh(read_mesh(BUNNY))
    return R


def test_the_glb_holds_the_scan_and_the_filled_part_as_two_meshes(repaired):
    scene = trimesh.load(io.BytesIO(gltf_bytes(repaired)), file_type="glb", process=False)
    assert set(scene.geometry) == {"scan", "filled"}
    filled = repaired.face_filled
    scan, fill = scene.geometry["scan"], scene.geometry["filled"]
    assert len(scan.faces) == int((~filled).sum()) and len(fill.faces) == int(filled.sum())
    # the same surface, as float32 (glTF's position type)
    got = np.sort(scan.vertices[scan.faces].reshape(-1, 9), axis=0)
    want = np.sort(repaired.V[repaired.F[~filled]].reshape(-1, 9).astype(np.float32), axis=0)
    assert np.array_equal(got.astype(np.float32), want)
    for part in (scan, fill):
        mat = part.visual.material
        assert 0.0 <= mat.metallicFactor <= 1.0 and 0.0 <= mat.roughnessFactor <= 1.0
        for key in ("_METALLIC", "_ROUGHNESS", "_COVERAGE"):
            a = np.asarray(part.vertex_attributes[key]).reshape(-1)   # read back as (n, 1)
            assert a.shape == (len(part.vertices),) and np.isfinite(a).all() and (a >= 0).all() and (a <= 1).all()
        colors = np.asarray(part.visual.vertex_attributes["color"])
        assert colors.shape == (len(part.vertices), 4) and colors[:, :3].std(axis=0).max() > 0


def test_gilt_metal_is_metallic_and_gold_coloured_and_corrosion_is_not_metallic():
    base, metallic, rough = pbr_approximation(np.array([0.0, 1.0, 0.0]), np.array([1.0, 1.0, 0.0]),
                                              np.zeros(3), "aged-bronze")
    gold, rusted, bronze = base
    assert metallic.tolist() == [1.0, 0.0, 1.0]
    assert gold[0] > gold[2] and gold.min() > 0.3          # yellow, bright
    assert not np.allclose(gold, bronze)                     # the worn gilding shows the bronze
    assert rusted[1] >= rusted[2] and rusted.max() < gold.max()
    assert rough[1] > rough[0] and np.isfinite(rough).all()


def test_layers_that_neither_absorb_nor_scatter_give_finite_colours():
    """K or S -> 0: an opaque layer that only scatters is white, one that
    does not scatter is black (R∞ = 0), never NaN."""
    import dataclasses

    mat = get_material("aged-bronze")
    for K, S, want in (((0.0,) * 3, (1.0,) * 3, 1.0), ((1.0,) * 3, (0.0,) * 3, 0.0), ((0.0,) * 3, (0.0,) * 3, 0.0)):
        layer = dataclasses.replace(mat.layers[-1][0], K=K, S=S)
        m = dataclasses.replace(mat, layers=mat.layers[:-1] + ((layer,) + tuple(mat.layers[-1][1:]),), crust=None)
        base, _, _ = pbr_approximation(np.array([1.0]), np.array([0.0]), np.array([0.0]), m)
        assert np.isfinite(base).all() and np.allclose(base, want)


def test_repair_writes_the_glb_beside_the_mesh_and_refuses_a_text_gltf(tmp_path):
    out, glb = tmp_path / "out.ply", tmp_path / "out.glb"
    run = subprocess.run([sys.executable, "-m", "shellrepair.cli", "repair", str(BUNNY), "-o", str(out),
                          "--gltf", str(glb), "-q"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    scene = trimesh.load(glb, process=False)
    assert set(scene.geometry) == {"scan", "filled"}
    bad = subprocess.run([sys.executable, "-m", "shellrepair.cli", "repair", str(BUNNY), "-o",
                          str(tmp_path / "x.ply"), "--gltf", str(tmp_path / "x.gltf")], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and ".glb" in bad.stderr
    assert not (tmp_path / "x.ply").exists()


def test_render_writes_the_look_it_draws_as_glb(tmp_path, repaired):
    from shellrepair import write_mesh

    write_mesh(tmp_path / "r.ply", repaired)
    run = subprocess.run([sys.executable, "-m", "shellrepair.cli", "render", str(tmp_path / "r.ply"), "-o",
                          str(tmp_path / "r.png"), "--size", "64x48", "--age", "0", "--gltf", str(tmp_path / "r.glb")],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    scene = trimesh.load(tmp_path / "r.glb", process=False)
    # age 0: all gilt, every vertex metallic
    for part in scene.geometry.values():
        assert np.asarray(part.vertex_attributes["_METALLIC"]).min() == 1.0
