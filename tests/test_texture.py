"""A textured OBJ keeps its texture through a repair.

Photogrammetry and many scanners deliver meshes whose colour is a texture:
each face corner has a texture coordinate (``vt``), each face a material
(``usemtl``) from a library (``mtllib``). A repaired file must give every
original corner the UV it was read with, bit for bit, and every original
face its material; the filled faces, which have no UVs, are their own
group and material.
"""

import numpy as np

from eval import shapes
from shellrepair import Mesh, read_mesh, write_mesh
from shellrepair.mesh.formats.obj import FILLED_GROUP, FILLED_MATERIAL
from shellrepair.repair import repair_mesh


def textured_sphere_with_hole(rng):
    """OBJ text of a sphere with one hole; every corner its own vt (random
    values of 17 digits), faces below the equator material ``bronze``, the
    rest ``gold``. Returns (text, V, F, UV (m,3,2), material per face)."""
    V, F = shapes.icosphere(3)
    top = int(np.argmax(V[:, 2]))
    V, F, _, _ = shapes.perforate_discs(V, F, centers=[top], radius=0.45)
    UV = rng.random((len(F), 3, 2))
    below = V[F].mean(axis=1)[:, 2] < 0
    lines = ["mtllib statue.mtl"] + [f"v {x!r} {y!r} {z!r}" for x, y, z in V.tolist()]
    lines += [f"vt {u!r} {v!r}" for u, v in UV.reshape(-1, 2).tolist()]
    current = None
    for i, f in enumerate(F.tolist()):
        name = "bronze" if below[i] else "gold"
        if name != current:
            lines.append(f"usemtl {name}")
            current = name
        lines.append("f " + " ".join(f"{a + 1}/{3 * i + j + 1}" for j, a in enumerate(f)))
    return "\n".join(lines) + "\n", V, F, UV, np.where(below, "bronze", "gold")


def parse_obj(text):
    """Faces as (corner vertex ids, corner uv or None, material, group), read by hand."""
    V, T, faces = [], [], []
    mat = group = None
    for line in text.splitlines():
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            V.append([float(x) for x in t[1:4]])
        elif t[0] == "vt":
            T.append([float(x) for x in t[1:3]])
        elif t[0] == "usemtl":
            mat = t[1]
        elif t[0] == "g":
            group = t[1]
        elif t[0] == "f":
            ids = [int(c.split("/")[0]) - 1 for c in t[1:]]
            uv = [T[int(c.split("/")[1]) - 1] for c in t[1:]] if "/" in t[1] else None
            faces.append((ids, uv, mat, group))
    return np.array(V), faces


def test_a_repaired_textured_obj_keeps_every_corners_uv_and_every_faces_material(tmp_path):
    text, V, F, UV, material = textured_sphere_with_hole(np.random.default_rng(0))
    (tmp_path / "scan.obj").write_text(text)
    mesh = read_mesh(tmp_path / "scan.obj")
    assert not any("texture" in n for n in mesh.notes), mesh.notes
    R, report = repair_mesh(mesh)
    assert report["holes_after"] == 0 and report["holes_before"] == 1
    write_mesh(tmp_path / "out.obj", R)
    out_text = (tmp_path / "out.obj").read_text()
    assert "mtllib statue.mtl" in out_text.splitlines()[:3]
    Vo, faces = parse_obj(out_text)
    assert np.array_equal(Vo[:len(V)].view(np.uint64), V.view(np.uint64))
    # the scan's faces first and in order, each corner with its UV, bit for bit
    for i, (ids, uv, mat, group) in enumerate(faces[:len(F)]):
        assert ids == F[i].tolist() and mat == material[i] and group == "scan"
        assert np.array_equal(np.array(uv).view(np.uint64), UV[i].view(np.uint64)), i
    # the filled faces: their own group and material, no UVs
    filled = faces[len(F):]
    assert len(filled) == len(R.F) - len(F) > 0
    assert all(uv is None and mat == FILLED_MATERIAL and group == FILLED_GROUP for _, uv, mat, group in filled)


def test_a_textured_obj_reads_back_the_texture_it_was_written_with(tmp_path):
    """Quads and triangles, relative vt indices, a face without vt: written
    and read again, the same corners get the same UVs."""
    text = ("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
            "vt 0.1 0.2\nvt 0.30000000000000004 0.4\nvt 0.5 0.6\nvt 0.7 0.8\n"
            "usemtl stone\nf 1/1 2/2 3/3 4/4\nusemtl moss\nf 2/-3 5/-2 6/-1\nf 2 6 3\n")
    (tmp_path / "a.obj").write_text(text)
    m = read_mesh(tmp_path / "a.obj")
    write_mesh(tmp_path / "b.obj", m)
    m2 = read_mesh(tmp_path / "b.obj")
    for k in (m, m2):
        t = k.texture
        assert t.materials == ["stone", "moss"] and t.face_material.tolist() == [0, 0, 1, 1]
        assert t.libraries == ["mtllib a.mtl"]
        assert (t.face_uv[3] == -1).all()       # the face the file gave no vt
    assert np.array_equal(m.F, m2.F)
    got = [m2.texture.uv[r] if (r >= 0).all() else None for r in m2.texture.face_uv]
    want = [m.texture.uv[r] if (r >= 0).all() else None for r in m.texture.face_uv]
    assert all((a is None and b is None) or np.array_equal(a, b) for a, b in zip(got, want))
    assert want[2].tolist() == [[0.30000000000000004, 0.4], [0.5, 0.6], [0.7, 0.8]]


def test_a_mesh_without_a_texture_writes_no_vt_or_material():
    V, F = shapes.icosphere(1)
    from shellrepair.mesh.io import mesh_bytes

    text = mesh_bytes("x.obj", Mesh(V=V, F=F))
    assert "vt " not in text and "usemtl" not in text and "mtllib" not in text


def test_writing_a_textured_repair_to_ply_says_the_materials_are_not_written(tmp_path):
    import json
    import subprocess
    import sys

    text, *_ = textured_sphere_with_hole(np.random.default_rng(2))
    (tmp_path / "scan.obj").write_text(text)
    run = subprocess.run([sys.executable, "-m", "shellrepair.cli", "repair", str(tmp_path / "scan.obj"),
                          "-o", str(tmp_path / "out.ply"), "--report", str(tmp_path / "r.json")],
                         capture_output=True, text=True, check=True)
    assert "PLY output: the materials (usemtl, mtllib) are not written" in run.stdout
    assert any("not written" in n for n in json.loads((tmp_path / "r.json").read_text())["notes"])
    # the texture coordinates are: each face's texcoord list
    assert read_mesh(tmp_path / "out.ply").texture is not None


def _two_tone_texture(path):
    """A 4x2 texture: left half red, right half blue (OBJ's u left to right)."""
    from PIL import Image

    img = np.zeros((2, 4, 3), np.uint8)
    img[:, :2] = (200, 0, 0)
    img[:, 2:] = (0, 0, 200)
    Image.fromarray(img).save(path)


def test_the_filled_faces_material_takes_the_scans_colour_at_the_rim(tmp_path):
    # every corner's UV well inside the texture's red half (u 0.15-0.35): the filled material is red
    text, V, F, UV, material = textured_sphere_with_hole(np.random.default_rng(4))
    lines = [ln if not ln.startswith("vt ") else f"vt {0.15 + 0.2 * float(ln.split()[1])!r} {ln.split()[2]}"
             for ln in text.splitlines()]
    (tmp_path / "scan.obj").write_text("\n".join(lines) + "\n")
    _two_tone_texture(tmp_path / "stone.png")
    (tmp_path / "statue.mtl").write_text("newmtl gold\nKd 1 1 0\nmap_Kd -s 1 1 1 stone.png\n"
                                         "newmtl bronze\nKd 0 1 0\nmap_Kd stone.png\n")
    R, report = repair_mesh(read_mesh(tmp_path / "scan.obj"))
    assert report["holes_after"] == 0
    out = tmp_path / "out" / "repaired scan.obj"
    out.parent.mkdir()
    write_mesh(out, R)
    head = out.read_text().splitlines()[:4]
    assert "mtllib statue.mtl" in head and "mtllib repaired_scan.filled.mtl" in head
    lib = (out.parent / "repaired_scan.filled.mtl").read_text()
    kd = [ln.split()[1:] for ln in lib.splitlines() if ln.startswith("Kd ")]
    assert f"newmtl {FILLED_MATERIAL}" in lib and len(kd) == 1
    assert np.allclose([float(x) for x in kd[0]], [200 / 255, 0, 0], atol=1e-6)


def test_without_an_image_the_filled_material_takes_the_rim_materials_kd(tmp_path):
    # the hole is at the top: its rim is all "gold" faces, whose Kd is yellow
    text, *_ = textured_sphere_with_hole(np.random.default_rng(5))
    (tmp_path / "scan.obj").write_text(text)
    (tmp_path / "statue.mtl").write_text("# no images\nnewmtl gold\nKd 1 0.8 0.0\nnewmtl bronze\nKd 0.4 0.2 0.1\n")
    R, _ = repair_mesh(read_mesh(tmp_path / "scan.obj"))
    write_mesh(tmp_path / "out.obj", R)
    lib = (tmp_path / "out.filled.mtl").read_text()
    kd = [float(x) for ln in lib.splitlines() if ln.startswith("Kd ") for x in ln.split()[1:]]
    assert kd == [1.0, 0.8, 0.0]


def test_a_missing_library_gives_a_neutral_filled_material_and_says_so(tmp_path):
    text, *_ = textured_sphere_with_hole(np.random.default_rng(6))
    (tmp_path / "scan.obj").write_text(text)          # statue.mtl is not there
    R, _ = repair_mesh(read_mesh(tmp_path / "scan.obj"))
    write_mesh(tmp_path / "out.obj", R)
    lib = (tmp_path / "out.filled.mtl").read_text()
    assert "Kd 0.500000 0.500000 0.500000" in lib and "no colour found" in lib


def test_an_obj_without_filled_faces_or_materials_gets_no_companion_library(tmp_path):
    text, *_ = textured_sphere_with_hole(np.random.default_rng(7))
    (tmp_path / "scan.obj").write_text(text)
    write_mesh(tmp_path / "same.obj", read_mesh(tmp_path / "scan.obj"))       # nothing filled
    V, F = shapes.icosphere(2)
    top = int(np.argmax(V[:, 2]))
    V, F, _, _ = shapes.perforate_discs(V, F, centers=[top], radius=0.45)
    R, _ = repair_mesh(Mesh(V=V, F=F))
    write_mesh(tmp_path / "plain.obj", R)                                     # no materials
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plain.obj", "same.obj", "scan.obj"]
