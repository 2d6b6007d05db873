"""A textured PLY keeps its texture through a repair.

MeshLab and many photogrammetry tools give each face of a PLY a
``texcoord`` list (u v for each corner, usually ``float``), often a
``texnumber`` naming which ``comment TextureFile`` image the UVs refer to.
A repaired file must give every original face the six values it was read
with, bit for bit and in the same float type, keep its texnumber and the
TextureFile comments, and flag the filled faces; those have no UVs (zeros)
and a texnumber that names no texture.

The written files are read back by the hand parser below (plyfile is not
installed here), and once by trimesh.
"""

import struct

import numpy as np
import pytest

from eval import shapes
from shellrepair import read_mesh, write_mesh
from shellrepair.cli import main
from shellrepair.repair import repair_mesh

_CODES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
          "float": "f", "double": "d"}
_NP = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
       "float": "f4", "double": "f8"}


def ply_file(fmt, V, faces, *, texnumber_type="int", comments=()):
    """PLY bytes: float vertices, then per face its corners, its texcoord list
    (the given float32 values, any length) and a texnumber. ``faces``:
    (corners, uv values, texnumber) each."""
    head = ["ply", f"format {fmt} 1.0", *comments, f"element vertex {len(V)}",
            "property float x", "property float y", "property float z", f"element face {len(faces)}",
            "property list uchar int vertex_indices", "property list uchar float texcoord",
            f"property {texnumber_type} texnumber", "end_header"]
    out = ("\n".join(head) + "\n").encode()
    V = np.asarray(V, np.float32)
    if fmt == "ascii":
        lines = [" ".join(str(x) for x in p) for p in V]
        for f, uv, tn in faces:
            uv = np.asarray(uv, np.float32)
            lines.append(" ".join([str(len(f)), *map(str, f), str(len(uv)), *(str(u) for u in uv), str(tn)]))
        return out + ("\n".join(lines) + "\n").encode()
    e = "<" if fmt == "binary_little_endian" else ">"
    out += V.astype(e + "f4").tobytes()
    for f, uv, tn in faces:
        out += struct.pack(f"{e}B{len(f)}iB{len(uv)}f{_CODES[texnumber_type]}", len(f), *f, len(uv),
                           *np.asarray(uv, np.float32).tolist(), tn)
    return out


def parse_ply(data):
    """A PLY read by hand: (header lines, V (n,3) float64, face records as
    dicts of property name -> value, lists as NumPy arrays of the file's type)."""
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode().splitlines()
    fmt = head[1].split()[1]
    elements = []
    for line in head:
        t = line.split()
        if t[0] == "element":
            elements.append((t[1], int(t[2]), []))
        elif t[0] == "property":
            elements[-1][2].append(tuple(t[1:]))
    e = "<" if fmt == "binary_little_endian" else ">"
    tokens = data[end:].split() if fmt == "ascii" else None
    pos = [end, 0]

    def value(typ):
        if tokens is not None:
            pos[1] += 1
            return np.array(tokens[pos[1] - 1].decode(), dtype=float).astype(_NP[typ])
        dt = np.dtype(e + _NP[typ])
        pos[0] += dt.itemsize
        return np.frombuffer(data, dt, 1, pos[0] - dt.itemsize)[0].astype(_NP[typ])

    tables = {}
    for name, count, props in elements:
        rows = []
        for _ in range(count):
            r = {}
            for p in props:
                if p[0] == "list":
                    k = int(value(p[1]))
                    r[p[3]] = np.array([value(p[2]) for _ in range(k)], _NP[p[2]])
                else:
                    r[p[1]] = value(p[0])
            rows.append(r)
        tables[name] = rows
    V = np.array([[r["x"], r["y"], r["z"]] for r in tables["vertex"]], np.float64)
    return head, V, tables["face"]


TEXTURES = ("comment TextureFile statue_0.png", "comment TextureFile statue_1.png")


def textured_sphere(fmt, rng, texnumber_type="int"):
    """A sphere with two holes as a textured PLY: every face six random
    float32 UVs (full 24-bit mantissas), texnumber 0 or 1. Returns (bytes,
    V, F, UV (m,6) float32, texnumber (m,))."""
    V, F = shapes.icosphere(3)
    V, F, _, _ = shapes.perforate_discs(V, F, n_holes=2, radius=0.35, seed=1)
    V = V.astype(np.float32).astype(np.float64)
    UV = rng.random((len(F), 6)).astype(np.float32)
    tn = (np.arange(len(F)) % 2).astype(np.int64)
    data = ply_file(fmt, V, list(zip(F.tolist(), UV, tn.tolist())), texnumber_type=texnumber_type,
                    comments=TEXTURES)
    return data, V, F, UV, tn


@pytest.mark.parametrize("fmt, texnumber_type", [("binary_little_endian", "int"),
                                                 ("binary_big_endian", "uchar"), ("ascii", "int")])
@pytest.mark.parametrize("binary", [True, False], ids=["write-binary", "write-ascii"])
def test_a_repaired_textured_ply_keeps_every_faces_uvs_texnumber_and_texture_files(tmp_path, fmt,
                                                                                   texnumber_type, binary):
    data, V, F, UV, tn = textured_sphere(fmt, np.random.default_rng(3), texnumber_type)
    (tmp_path / "scan.ply").write_bytes(data)
    mesh = read_mesh(tmp_path / "scan.ply")
    assert not any("texcoord" in n or "texnumber" in n for n in mesh.notes), mesh.notes
    R, report = repair_mesh(mesh)
    assert report["holes_before"] == 2 and report["holes_after"] == 0
    write_mesh(tmp_path / "out.ply", R, binary=binary)
    head, Vo, faces = parse_ply((tmp_path / "out.ply").read_bytes())
    assert [c for c in head if "TextureFile" in c] == list(TEXTURES)
    assert "property list uchar float texcoord" in head and f"property {texnumber_type} texnumber" in head
    assert np.array_equal(Vo[:len(V)], V)
    # the scan's faces first and in order, each with its six UVs bit for bit and its texnumber
    for i, r in enumerate(faces[:len(F)]):
        assert r["vertex_indices"].tolist() == F[i].tolist() and r["filled"] == 0
        assert r["texcoord"].dtype == np.float32
        assert np.array_equal(r["texcoord"].view(np.uint32), UV[i].view(np.uint32)), i
        assert r["texnumber"] == tn[i]
    # the filled faces: flagged, no UVs, a texnumber that names none of the two textures
    filled = faces[len(F):]
    assert len(filled) == len(R.F) - len(F) > 0
    no_texture = -1 if texnumber_type == "int" else len(TEXTURES)
    for r in filled:
        assert r["filled"] == 1 and (r["texcoord"] == 0).all() and len(r["texcoord"]) == 6
        assert r["texnumber"] == no_texture


def test_a_quad_split_in_two_gives_each_triangle_its_corners_uvs(tmp_path):
    """A non-convex quad (its corner 1 reflex: split along corners 1-3, the
    diagonal inside it) and a convex one (split along 0-2): each triangle corner keeps the UV the
    quad gave that corner; written and read again, the same."""
    V = [[0, 0, 0], [2, 0, 0], [0.5, 0.5, 0], [0, 2, 0], [3, 0, 0], [3, 1, 0], [2, 1, 0]]
    quads = [([1, 2, 3, 0], np.float32([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]), 0),
             ([1, 4, 5, 6], np.float32([0.15, 0.25, 0.35, 0.45, 0.55, 0.65, 0.75, 0.85]), 1)]
    (tmp_path / "q.ply").write_bytes(ply_file("binary_little_endian", V, quads, comments=TEXTURES))
    m = read_mesh(tmp_path / "q.ply")
    assert len(m.F) == 4
    want = {}    # (quad, vertex) -> its corner's UV
    for q, (f, uv, _) in enumerate(quads):
        for j, v in enumerate(f):
            want[q, v] = uv[2 * j:2 * j + 2]
    write_mesh(tmp_path / "out.ply", m)
    _, _, faces = parse_ply((tmp_path / "out.ply").read_bytes())
    kinds = set()
    for r in faces:
        f = r["vertex_indices"].tolist()
        q = int(r["texnumber"])
        assert set(f) <= set(quads[q][0])
        kinds.add((q, tuple(sorted(f))))
        for j, v in enumerate(f):
            assert np.array_equal(r["texcoord"][2 * j:2 * j + 2].view(np.uint32), want[q, v].view(np.uint32))
    # the non-convex quad split from its reflex corner (vertex 2, at (0.5, 0.5)) to vertex 0,
    # the convex one along its corners 0-2 (vertices 1-5)
    assert kinds == {(0, (0, 1, 2)), (0, (0, 2, 3)), (1, (1, 4, 5)), (1, (1, 5, 6))}


def test_a_face_turned_to_agree_with_its_neighbours_keeps_each_corners_uv(tmp_path):
    """A strip of two triangles, the second wound against the first: reading
    turns it, and its UVs turn with its corners."""
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    uv0, uv1 = np.float32([0, 0.1, 0.2, 0.3, 0.4, 0.5]), np.float32([0.6, 0.7, 0.8, 0.9, 0.125, 0.375])
    faces = [([0, 1, 2], uv0, 0), ([1, 2, 3], uv1, 0)]      # edge 1-2 used in the same direction twice
    (tmp_path / "s.ply").write_bytes(ply_file("ascii", V, faces))
    write_mesh(tmp_path / "out.ply", read_mesh(tmp_path / "s.ply"))
    _, _, out = parse_ply((tmp_path / "out.ply").read_bytes())
    for (f, uv, _), r in zip(faces, out):
        read = {(v, r["texcoord"][2 * j].item(), r["texcoord"][2 * j + 1].item())
                for j, v in enumerate(r["vertex_indices"].tolist())}
        assert read == {(v, uv[2 * j].item(), uv[2 * j + 1].item()) for j, v in enumerate(f)}
    assert [r["vertex_indices"].tolist() for r in out] != [f for f, _, _ in faces]   # one was turned


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_a_texcoord_list_of_the_wrong_length_is_a_one_line_error(tmp_path, capsys, fmt):
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    faces = [([0, 1, 2], np.float32([0] * 6), 0), ([2, 1, 3], np.float32([0.5] * 5), 0)]
    p = tmp_path / "bad.ply"
    p.write_bytes(ply_file(fmt, V, faces))
    assert main(["repair", str(p), "-o", str(tmp_path / "out.ply")]) == 2
    err = capsys.readouterr().err
    assert err == (f"error: {p}: face 1: texcoord list has 5 values, expected 6 "
                   "(u v for each of its 3 corners) or none\n")
    assert not (tmp_path / "out.ply").exists()


def test_trimesh_reads_the_written_texture_coordinates(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    data, V, F, UV, _ = textured_sphere("binary_little_endian", np.random.default_rng(4))
    (tmp_path / "scan.ply").write_bytes(data)
    R, _ = repair_mesh(read_mesh(tmp_path / "scan.ply"))
    write_mesh(tmp_path / "out.ply", R)
    t = trimesh.load(tmp_path / "out.ply", process=False)
    assert len(t.faces) == len(R.F)
    got = np.asarray(t.visual.uv)[t.faces[:len(F)]].reshape(-1, 6)
    assert np.array_equal(got.astype(np.float32), UV)


def test_a_textured_ply_written_as_obj_keeps_the_uvs_and_says_texnumber_is_not_written(tmp_path, capsys):
    data, V, F, UV, _ = textured_sphere("binary_little_endian", np.random.default_rng(5))
    (tmp_path / "scan.ply").write_bytes(data)
    assert main(["repair", str(tmp_path / "scan.ply"), "-o", str(tmp_path / "out.obj")]) == 0
    assert "OBJ output: the faces' texnumber is not written" in capsys.readouterr().out
    m = read_mesh(tmp_path / "out.obj")
    # the float32 values widened to double, exactly
    got = m.texture.uv[m.texture.face_uv[:len(F)]].reshape(-1, 6)
    assert np.array_equal(got, UV.astype(np.float64))
    assert (m.texture.face_uv[len(F):] == -1).all() and len(m.F) > len(F)


@pytest.mark.parametrize("fmt", ["ascii", "binary_big_endian"])
def test_triangles_quads_and_a_face_without_uvs_in_one_file(tmp_path, fmt):
    """Faces of different lengths (read record by record) and an empty
    texcoord list: the face without UVs reads as having none and is written
    with zeros and a texnumber naming no texture; the others keep theirs."""
    V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]]
    faces = [([0, 1, 2, 3], np.float32([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]), 1),
             ([1, 4, 5], np.float32([]), 0),
             ([1, 5, 2], np.float32([0.9, 0.125, 0.25, 0.375, 0.625, 0.875]), 0)]
    (tmp_path / "m.ply").write_bytes(ply_file(fmt, V, faces, comments=TEXTURES))
    m = read_mesh(tmp_path / "m.ply")
    assert len(m.F) == 4 and (m.texture.face_uv[2] == -1).all() and (m.texture.face_uv[[0, 1, 3]] >= 0).all()
    write_mesh(tmp_path / "out.ply", m)
    _, _, out = parse_ply((tmp_path / "out.ply").read_bytes())
    assert [int(r["texnumber"]) for r in out] == [1, 1, -1, 0]
    assert (out[2]["texcoord"] == 0).all()
    assert out[3]["vertex_indices"].tolist() == faces[2][0]
    assert np.array_equal(out[3]["texcoord"].view(np.uint32), faces[2][1].view(np.uint32))


def test_the_list_length_type_does_not_change_what_is_read(tmp_path):
    """Mixed polygons with a scalar before, between and after the lists,
    some faces without UVs: with uchar or ushort list lengths (two ways of
    walking the records) the same faces, UVs and texnumbers."""
    rng = np.random.default_rng(6)
    V = rng.random((50, 3)).astype(np.float32)
    faces = []
    for i in range(300):
        c = (3, 4, 3, 5)[i % 4]
        uv = rng.random(2 * c).astype(np.float32) if i % 5 else np.zeros(0, np.float32)
        faces.append((rng.choice(50, c, replace=False).tolist(), uv, i % 7))
    meshes = []
    for code, name in (("B", "uchar"), ("H", "ushort")):
        head = (f"ply\nformat binary_big_endian 1.0\nelement vertex 50\nproperty float x\nproperty float y\n"
                f"property float z\nelement face {len(faces)}\nproperty short q\n"
                f"property list {name} int vertex_indices\nproperty list {name} float texcoord\n"
                "property int texnumber\nproperty uchar flags\nend_header\n")
        body = b"".join(struct.pack(f">h{code}{len(f)}i{code}{len(uv)}fiB", i, len(f), *f, len(uv), *uv.tolist(), tn, 9)
                        for i, (f, uv, tn) in enumerate(faces))
        (tmp_path / f"{name}.ply").write_bytes(head.encode() + V.astype(">f4").tobytes() + body)
        meshes.append(read_mesh(tmp_path / f"{name}.ply", clean=False, orient=False))
    a, b = meshes
    assert np.array_equal(a.F, b.F) and len(a.F) == sum(len(f) - 2 for f, _, _ in faces)
    assert np.array_equal(a.texture.uv.view(np.uint32), b.texture.uv.view(np.uint32))
    assert np.array_equal(a.texture.face_uv, b.texture.face_uv)
    assert np.array_equal(a.texture.face_texnumber, b.texture.face_texnumber)
    # and what is read is the file's: each triangle corner has the UV its polygon gave that vertex
    start = 0
    for f, uv, tn in faces:
        for t in range(start, start + len(f) - 2):
            assert a.texture.face_texnumber[t] == tn and set(a.F[t].tolist()) <= set(f)
            if not len(uv):
                assert (a.texture.face_uv[t] == -1).all()
                continue
            for v, row in zip(a.F[t].tolist(), a.texture.face_uv[t].tolist()):
                j = f.index(v)
                assert np.array_equal(a.texture.uv[row].view(np.uint32), uv[2 * j:2 * j + 2].view(np.uint32))
        start += len(f) - 2
