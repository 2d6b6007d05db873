"""The repaired mesh with its aged look as glTF 2.0 (shellrepair.appearance.gltf, repair --gltf)."""

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shellrepair import read_mesh
from shellrepair.appearance.gltf import gltf_bytes, pbr_approximation
from shellrepair.appearance.materials import get_material
from shellrepair.repair import repair_mesh

trimesh = pytest.importorskip("trimesh", reason="trimesh writes and reads the glTF files")

BUNNY = Path(__file__).resolve().parents[1] / "data" / "bunny_zipper.ply"


@pytest.fixture(scope="module")
def repaired():
    R, _ = repair_mesh(read_mesh(BUNNY))
    return R


_COMPONENT = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_glb(data):
    """A binary glTF read by the specification, not by the writer's library:
    the container checked (magic, version, length, 4-byte chunks), every
    accessor inside its buffer view and aligned to its component, POSITION
    with the min and max the specification requires. Returns
    ``{node name: (world positions (n,3) float64, triangles (m,3),
    {attribute: array}, material)}``."""
    import json
    import struct

    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and length == len(data)
    n_json, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON" and n_json % 4 == 0
    doc = json.loads(data[20:20 + n_json])
    n_bin, kind = struct.unpack_from("<I4s", data, 20 + n_json)
    assert kind == b"BIN\0" and n_bin % 4 == 0 and 28 + n_json + n_bin == len(data)
    blob = data[28 + n_json:28 + n_json + n_bin]
    assert doc["buffers"][0]["byteLength"] <= n_bin

    def accessor(i):
        a = doc["accessors"][i]
        view = doc["bufferViews"][a["bufferView"]]
        dt = np.dtype(_COMPONENT[a["componentType"]])
        width = _WIDTH[a["type"]]
        off = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        assert off % dt.itemsize == 0
        assert a.get("byteOffset", 0) + a["count"] * width * dt.itemsize <= view["byteLength"]
        assert view.get("byteOffset", 0) + view["byteLength"] <= n_bin
        x = np.frombuffer(blob, dt, a["count"] * width, off).reshape(a["count"], width)
        return a, x

    out = {}
    for node in doc["nodes"]:
        if "mesh" not in node:
            continue
        M = np.array(node.get("matrix", np.eye(4).ravel()), np.float64).reshape(4, 4).T   # column-major
        (prim,) = doc["meshes"][node["mesh"]]["primitives"]
        assert prim.get("mode", 4) == 4                                   # triangles
        a, P = accessor(prim["attributes"]["POSITION"])
        assert np.array_equal(np.float32(a["min"]), P.min(axis=0)) and np.array_equal(np.float32(a["max"]), P.max(axis=0))
        _, idx = accessor(prim["indices"])
        assert idx.max() < len(P)
        world = P.astype(np.float64) @ M[:3, :3].T + M[:3, 3]
        attrs = {k: accessor(v)[1] for k, v in prim["attributes"].items() if k != "POSITION"}
        out[node["name"]] = (world, idx.reshape(-1, 3).astype(np.int64), attrs, doc["materials"][prim["material"]])
    return out


def test_the_glb_holds_the_scan_and_the_filled_part_as_two_meshes(repaired):
    parts = read_glb(gltf_bytes(repaired))
    assert set(parts) == {"scan", "filled"}
    filled = repaired.face_filled
    size = float(np.ptp(repaired.V, axis=0).max())
    for name, sel in (("scan", ~filled), ("filled", filled)):
        P, T, attrs, mat = parts[name]
        assert len(T) == int(sel.sum())
        # the same triangles, each corner within float32's rounding of the scan's size
        got = np.sort(P[T].reshape(-1, 9), axis=0)
        want = np.sort(repaired.V[repaired.F[sel]].reshape(-1, 9), axis=0)
        assert np.abs(got - want).max() <= 1e-7 * size
        pbr = mat["pbrMetallicRoughness"]
        assert 0.0 <= pbr["metallicFactor"] <= 1.0 and 0.0 <= pbr["roughnessFactor"] <= 1.0
        for key in ("_METALLIC", "_ROUGHNESS", "_COVERAGE"):
            a = attrs[key].reshape(-1)
            assert a.shape == (len(P),) and np.isfinite(a).all() and (a >= 0).all() and (a <= 1).all()
        colors = attrs["COLOR_0"]
        assert colors.shape == (len(P), 4) and colors[:, :3].std(axis=0).max() > 0
    # what another reader makes of it: trimesh, the writer's own library
    scene = trimesh.load(io.BytesIO(gltf_bytes(repaired)), file_type="glb", process=False)
    assert set(scene.geometry) == {"scan", "filled"}


def test_pygltflib_reads_the_same_faces_the_filled_part_and_the_material(repaired, tmp_path):
    # a second, independent reader (pygltflib, the test extra): the two
    # meshes by name, their triangle counts, a metallic-roughness material
    # each, and the vertex colour and the per-vertex maps as attributes
    pygltflib = pytest.importorskip("pygltflib", reason="pygltflib is in the test extra")
    (tmp_path / "r.glb").write_bytes(gltf_bytes(repaired))
    g = pygltflib.GLTF2().load(str(tmp_path / "r.glb"))
    blob = g.binary_blob()
    by_name = {g.meshes[n.mesh].name or n.name: g.meshes[n.mesh] for n in g.nodes if n.mesh is not None}
    assert set(by_name) == {"scan", "filled"}
    filled = repaired.face_filled
    for name, sel in (("scan", ~filled), ("filled", filled)):
        (prim,) = by_name[name].primitives
        acc = g.accessors[prim.indices]
        assert acc.count == 3 * int(sel.sum())
        view = g.bufferViews[acc.bufferView]
        dt = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}[acc.componentType]
        idx = np.frombuffer(blob, dt, acc.count, (view.byteOffset or 0) + (acc.byteOffset or 0))
        assert idx.max() < g.accessors[prim.attributes.POSITION].count
        mat = g.materials[prim.material]
        assert mat.pbrMetallicRoughness is not None
        assert 0.0 <= mat.pbrMetallicRoughness.metallicFactor <= 1.0
        assert prim.attributes.COLOR_0 is not None
        extra = {k for k, v in vars(prim.attributes).items() if k.startswith("_") and v is not None}
        assert {"_METALLIC", "_ROUGHNESS", "_COVERAGE"} <= extra, extra


def test_a_scan_far_from_its_origin_keeps_its_precision(repaired):
    # millimetres 1e6 from the origin: float32 positions there are 0.06 mm
    # apart; stored about the scan's centre, they keep ~6e-8 of its size
    from shellrepair import Mesh

    offset = np.array([1.0e6, -2.5e6, 3.0e5])
    far = Mesh(V=repaired.V * 1000.0 + offset, F=repaired.F, face_filled=repaired.face_filled)
    size = float(np.ptp(far.V, axis=0).max())
    parts = read_glb(gltf_bytes(far))
    for name, sel in (("scan", ~far.face_filled), ("filled", far.face_filled)):
        P, T, _, _ = parts[name]
        got = np.sort(P[T].reshape(-1, 9), axis=0)
        want = np.sort(far.V[far.F[sel]].reshape(-1, 9), axis=0)
        assert np.abs(got - want).max() <= 1e-7 * size      # (at the offset itself float32 gives 0.06 mm)
    assert 1e-7 * size < 0.06


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
