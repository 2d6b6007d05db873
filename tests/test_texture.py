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
from shellrepair.formats.obj import FILLED_GROUP, FILLED_MATERIAL
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
    from shellrepair.io import mesh_bytes

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
