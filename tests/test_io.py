"""Loading and writing scans: exact values, colours, flags, clean failure."""

import numpy as np
import pytest

from shellrepair import MeshError, Mesh, read_mesh, write_mesh
from shellrepair import shapes
from shellrepair import io as io_module
from shellrepair.io import clean_faces


def _mesh(float32=True, colors=True):
    V, F = shapes.icosphere(2)
    V = V * 123.456 + 1e6  # millimetres far from the origin
    if float32:
        V = V.astype(np.float32).astype(np.float64)
    m = Mesh(V=V, F=F, vertex_dtype="f4" if float32 else "f8")
    if colors:
        m.vertex_colors = (np.arange(len(V) * 3).reshape(-1, 3) % 256).astype(np.uint8)
    return m


@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("float32", [True, False])
def test_ply_round_trip_is_bit_exact_with_colours_and_flags(tmp_path, binary, float32):
    m = _mesh(float32)
    m.face_filled = np.arange(len(m.F)) % 3 == 0
    m.vertex_filled = np.arange(len(m.V)) % 5 == 0
    p = tmp_path / "a.ply"
    write_mesh(p, m, binary=binary)
    r = read_mesh(p)
    assert r.V.dtype == np.float64 and r.F.dtype == np.int64
    assert np.array_equal(r.V.view(np.uint64), m.V.view(np.uint64))
    assert np.array_equal(r.F, m.F)
    assert np.array_equal(r.vertex_colors, m.vertex_colors)
    assert np.array_equal(r.face_filled, m.face_filled)
    assert np.array_equal(r.vertex_filled, m.vertex_filled)
    assert r.vertex_dtype == ("f4" if float32 else "f8")


@pytest.mark.parametrize("ext", [".obj", ".off"])
def test_text_formats_round_trip_exactly(tmp_path, ext):
    m = _mesh(float32=False, colors=False)
    p = tmp_path / ("a" + ext)
    write_mesh(p, m)
    r = read_mesh(p)
    assert np.array_equal(r.V, m.V)
    assert np.array_equal(r.F, m.F)


@pytest.mark.parametrize("binary", [True, False])
def test_stl_vertices_are_welded(tmp_path, binary):
    m = _mesh(float32=True, colors=False)
    p = tmp_path / "a.stl"
    write_mesh(p, m, binary=binary)
    r = read_mesh(p)
    assert len(r.V) == len(m.V)  # 3 corners per triangle welded back
    assert len(r.F) == len(m.F)
    # the same triangles, as sets of corner coordinates (rotation of corners aside)
    tri = lambda V, F: sorted(tuple(sorted(map(tuple, V[f]))) for f in F)
    assert tri(r.V, r.F) == tri(m.V, m.F)


def test_polygons_are_split_and_bad_faces_dropped(tmp_path):
    p = tmp_path / "q.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
                 "f 1 2 3 4\n"       # a quad -> 2 triangles
                 "f 1 2 3\n"         # duplicate of the first triangle
                 "f 2 2 5\n")        # repeats a vertex
    r = read_mesh(p)
    assert r.F.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert any("polygons" in n for n in r.notes)
    assert any("duplicate" in n for n in r.notes)
    assert any("repeated vertex" in n for n in r.notes)
    assert len(r.V) == 5  # the unreferenced vertex is kept: vertex order never changes


def test_clean_faces_keeps_order_and_reports_indices():
    F = np.array([[0, 1, 2], [2, 3, 0], [1, 2, 0], [4, 4, 1], [2, 3, 0]])
    Fc, kept, notes = clean_faces(F)
    assert kept.tolist() == [0, 1]
    assert Fc.tolist() == [[0, 1, 2], [2, 3, 0]]


@pytest.mark.parametrize("colliding", [False, True])
def test_clean_faces_drops_exactly_the_later_copies_of_a_vertex_set(monkeypatch, colliding):
    # random faces with copies in other vertex orders; the specification is
    # the first face of each vertex set, by exact comparison of sorted rows
    rng = np.random.default_rng(2)
    F = rng.integers(0, 40, size=(3000, 3))
    F = np.vstack([F, F[rng.integers(0, 3000, 500)][:, [2, 0, 1]]])
    if colliding:   # a hash with many collisions must not change the result
        monkeypatch.setattr(io_module, "_triple_hash", lambda G: (G.min(axis=1) % 3).astype(np.uint64))
    Fc, kept, notes = clean_faces(F)
    ok = np.flatnonzero((F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2]))
    _, first = np.unique(np.sort(F[ok], axis=1), axis=0, return_index=True)
    assert kept.tolist() == sorted(ok[first].tolist())
    assert np.array_equal(Fc, F[kept])
    assert len(kept) < len(ok) < len(F)


def test_write_to_missing_folder_raises_and_writes_nothing(tmp_path):
    m = _mesh()
    with pytest.raises(MeshError, match="folder does not exist"):
        write_mesh(tmp_path / "nope" / "a.ply", m)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name,content,message", [
    ("empty.ply", b"", "empty file"),
    ("magic.ply", b"solid x\n", "not a PLY"),
    ("x.xyz", b"1 2 3\n", "unknown extension"),
    ("cloud.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                  b"property float z\nend_header\n0 0 0\n", "no faces"),
    ("nan.obj", b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "vertex 1 has a non-finite"),
    ("range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "out of range"),
    ("neg.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n", "out of range"),
    ("short.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n", "header disagrees with body"),
    ("ascii.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                  b"property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
                  b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "header disagrees with body"),
])
def test_bad_input_raises_one_clear_error(tmp_path, name, content, message):
    p = tmp_path / name
    p.write_bytes(content)
    with pytest.raises(MeshError, match=message) as exc:
        read_mesh(p)
    assert str(p) in str(exc.value)
    assert "\n" not in str(exc.value)


def test_truncated_binary_ply_is_reported(tmp_path):
    p = tmp_path / "t.ply"
    write_mesh(p, _mesh())
    data = p.read_bytes()
    p.write_bytes(data[:-100])
    with pytest.raises(MeshError, match="truncated"):
        read_mesh(p)


def test_directory_is_not_a_mesh(tmp_path):
    d = tmp_path / "d.ply"
    d.mkdir()
    with pytest.raises(MeshError, match="directory"):
        read_mesh(d)


@pytest.mark.parametrize("name,outline", [
    # a chevron: corner 1 is reflex, so the fan's diagonal 0-2 would lie outside
    ("chevron", [(0, 0), (1, 0.4), (2, 0), (1, 2)]),
    # an L: corner 0 sits at the reflex corner's far side, a fan from it leaves the outline
    ("L", [(2, 1), (1, 1), (1, 2), (0, 2), (0, 0), (2, 0)]),
    ("comb", [(0, 0), (4, 0), (4, 2), (3, 2), (3, 0.5), (2, 0.5), (2, 2), (1, 2), (1, 0.5), (0.5, 0.5), (0.5, 2), (0, 2)]),
])
def test_non_convex_polygons_are_split_inside_their_outline(tmp_path, name, outline):
    """Every triangle keeps the polygon's winding (+z) and the areas add up
    to the polygon's: no triangle leaves the outline or overlaps another."""
    P = np.array(outline, float)
    area = 0.5 * np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1])
    p = tmp_path / f"{name}.obj"
    p.write_text("".join(f"v {x} {y} 0\n" for x, y in outline)
                 + "f " + " ".join(str(i + 1) for i in range(len(outline))) + "\n")
    m = read_mesh(p)
    assert len(m.F) == len(outline) - 2
    T = m.V[m.F]
    nz = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])[:, 2]
    assert (nz > 0).all()
    assert np.isclose(0.5 * nz.sum(), area)
    assert m.notes == ["1 polygons with more than 3 corners split into triangles"]


def test_written_files_get_ordinary_permissions(tmp_path):
    import os
    old = os.umask(0o022)
    try:
        p = tmp_path / "a.ply"
        write_mesh(p, _mesh())
        assert (p.stat().st_mode & 0o777) == 0o644
    finally:
        os.umask(old)


# --------------------------------------------------------------------------
# what other tools write (issue 18): OBJ, PLY, OFF and STL corners
# --------------------------------------------------------------------------
def _read_bytes(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data if isinstance(data, bytes) else data.encode())
    return read_mesh(p, clean=False, orient=False)


SQUARE = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"


@pytest.mark.filterwarnings("error")
def test_obj_line_continuations_are_joined_and_lines_still_counted(tmp_path):
    """A backslash at the end of a line continues it (OBJ specification); errors
    further down still name the physical line."""
    m = _read_bytes(tmp_path, "c.obj", SQUARE + "f 1 2 \\\n 3\nf 1 \\\r\n3 \\\n  4\n")
    assert m.F.tolist() == [[0, 1, 2], [0, 2, 3]]
    with pytest.raises(MeshError, match=r"line 10: bad face index 'x'"):
        _read_bytes(tmp_path, "e.obj", SQUARE + "f 1 2 \\\n 3\nf 1 \\\n3 \\\n  4\nf 1 2 x\n")


@pytest.mark.filterwarnings("error")
def test_obj_relative_indices_count_back_from_the_vertices_read_so_far(tmp_path):
    m = _read_bytes(tmp_path, "r.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
                                       "v 5 0 0\nv 5 1 0\nf -3 -1 -2\nf 1 -2 -1\n")
    assert m.F.tolist() == [[0, 1, 2], [2, 4, 3], [0, 3, 4]]
    with pytest.raises(MeshError, match=r"line 2: relative index -2 out of range \(1 vertices before this line\)"):
        _read_bytes(tmp_path, "b.obj", "v 0 0 0\nf -1 -1 -2\n")


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("form", ["{}", "{}/7", "{}//3", "{}/7/3", "mixed"])
def test_obj_corner_forms_take_the_position_index(tmp_path, form):
    forms = ["{}", "{}/7", "{}//3", "{}/7/3"]
    faces = [[1, 2, 3], [1, 3, 4]]
    lines = []
    for k, f in enumerate(faces):   # "mixed": every corner of a different form
        lines.append("f " + " ".join((forms[(k + j) % 4] if form == "mixed" else form).format(i)
                                     for j, i in enumerate(f)))
    m = _read_bytes(tmp_path, "f.obj", SQUARE + "vt 0 0\n" * 7 + "vn 0 0 1\n" * 3 + "\n".join(lines) + "\n")
    assert m.F.tolist() == [[0, 1, 2], [0, 2, 3]]
    with pytest.raises(MeshError, match="bad face corner '2/'"):
        _read_bytes(tmp_path, "g.obj", SQUARE + "f 1/1 2/ 3/1\n")


@pytest.mark.filterwarnings("error")
def test_obj_statements_that_hold_no_triangles_are_skipped_and_named(tmp_path):
    text = ("# comment\r\nmtllib m.mtl\r\no a\r\ng b c\r\ns 1\r\nusemtl x\r\n" + SQUARE.replace("\n", "  \r\n")
            + "vt 0 0\r\nvt 1 0\r\nvn 0 0 1\r\nvp 0.5\r\nl 1 2 3\r\np 4\r\ncstype bezier\r\nfoo bar\r\n"
            + "\tf 1/1/1 2/2/1 3/1/1   # a face\r\n")
    m = _read_bytes(tmp_path, "s.obj", text)
    assert m.F.tolist() == [[0, 1, 2]]
    assert "OBJ: 2 texture coordinates (vt) and 1 normals (vn) not kept" in " ".join(m.notes)
    for part in ("1 polylines (l) ignored", "1 points (p) ignored", "2 free-form curve and surface",
                 "unknown statements ignored: 'foo' (1)"):
        assert any(part in n for n in m.notes), part
    assert not any("mtllib" in n or "usemtl" in n for n in m.notes)


@pytest.mark.filterwarnings("error")
def test_obj_vertex_colours_and_w(tmp_path):
    m = _read_bytes(tmp_path, "c.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0.501961 nan 0\nf 1 2 3\n")
    assert m.vertex_colors.tolist() == [[255, 0, 0], [0, 255, 0], [128, 0, 0]]
    assert any("1 vertex colours with NaN" in n for n in m.notes)
    assert any("floats 0..1 converted" in n for n in m.notes)
    m = _read_bytes(tmp_path, "w.obj", "v 0 0 0 1\nv 1 0 0 2\nv 0 1 0\nf 1 2 3\n")
    assert m.V.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert any("w coordinates ignored (1 vertices" in n for n in m.notes)
    m = _read_bytes(tmp_path, "p.obj", "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert m.vertex_colors is None and any("only 1 of 3 vertices" in n for n in m.notes)


def _ply(fmt, vprops, vrows, fprops, frows, extra_head="", extra_body=b"", nl="\n"):
    """A PLY file from rows of Python values (binary rows packed with the given types)."""
    import struct
    codes = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
             "float": "f", "double": "d"}
    head = ["ply", f"format {fmt} 1.0", "comment made by a test", "obj_info nothing",
            f"element vertex {len(vrows)}"] + [f"property {t} {n}" for n, t in vprops]
    head += [f"element face {len(frows)}"] + [f"property {t} {n}" for n, t in fprops]
    head = nl.join(head) + nl + extra_head + "end_header" + nl
    if fmt == "ascii":
        body = "".join(" ".join(str(x) for x in r) + nl for r in vrows)
        body += "".join(" ".join(str(x) for x in r) + nl for r in frows)
        return head.encode() + body.encode() + extra_body
    e = ">" if fmt.endswith("big_endian") else "<"
    out = b""
    for r in vrows:
        out += b"".join(struct.pack(e + codes[t], x) for (n, t), x in zip(vprops, r))
    for r in frows:
        j = 0
        for n, t in fprops:
            if t.startswith("list"):
                _, ct, it = t.split()
                k = r[j]
                out += struct.pack(e + codes[ct], k) + struct.pack(e + codes[it] * k, *r[j + 1:j + 1 + k])
                j += 1 + k
            else:
                out += struct.pack(e + codes[t], r[j])
                j += 1
    return head.encode() + out + extra_body


XYZ = [("x", "float"), ("y", "float"), ("z", "float")]
SQ = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0), (2.0, 0.0, 0.0)]


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("count_type,index_type", [("uchar", "int"), ("uint", "int"), ("int", "uint"),
                                                   ("ushort", "uint")])
def test_ply_list_types_endianness_and_mixed_polygons(tmp_path, fmt, count_type, index_type):
    """Triangles and quads mixed (each record walked), face colours after the list,
    all list count and index types; the same faces whatever the encoding."""
    faces = [(3, 1, 4, 2, 9, 9, 9), (4, 0, 1, 2, 3, 1, 2, 3)]
    data = _ply(fmt, XYZ, SQ, [("vertex_indices", f"list {count_type} {index_type}"), ("red", "uchar"),
                               ("green", "uchar"), ("blue", "uchar")], faces)
    m = _read_bytes(tmp_path, "m.ply", data)
    assert m.V.tolist() == [list(p) for p in SQ]
    assert m.F.tolist() == [[1, 4, 2], [0, 1, 2], [0, 2, 3]]
    assert any("face properties not kept: red, green, blue" in n for n in m.notes)
    assert any("1 polygons with more than 3 corners" in n for n in m.notes)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_extra_elements_are_skipped_and_float_colours_converted(tmp_path, fmt):
    vprops = XYZ + [("red", "float"), ("green", "float"), ("blue", "float")]
    rows = [p + c for p, c in zip(SQ[:3], [(1.0, 0.0, 0.5), (float("nan"), 0.25, 1.0), (0.0, 0.0, float("inf"))])]
    extra = "element edge 2\nproperty int vertex1\nproperty int vertex2\n"
    import struct
    tail = ("0 1\n1 2\n".encode() if fmt == "ascii"
            else struct.pack((">" if "big" in fmt else "<") + "4i", 0, 1, 1, 2))
    data = _ply(fmt, vprops, rows, [("vertex_indices", "list uchar int")], [(3, 0, 1, 2)],
                extra_head=extra, extra_body=tail)
    m = _read_bytes(tmp_path, "c.ply", data)
    assert m.F.tolist() == [[0, 1, 2]]
    assert m.vertex_colors.tolist() == [[255, 0, 128], [0, 64, 255], [0, 0, 0]]
    assert any("elements skipped: edge (2)" in n for n in m.notes)
    assert any("floats 0..1 converted to 8 bits" in n for n in m.notes)
    assert any("2 vertex colours with NaN or infinite" in n for n in m.notes)


@pytest.mark.filterwarnings("error")
def test_ply_crlf_header_and_big_endian_doubles_round_trip(tmp_path):
    V = [(0.1, 1e6 + 0.3, -2.5), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
    data = _ply("binary_big_endian", [("x", "double"), ("y", "double"), ("z", "double")], V,
                [("vertex_indices", "list uchar uint")], [(3, 0, 1, 2)], nl="\r\n")
    m = _read_bytes(tmp_path, "d.ply", data)
    assert m.V.tolist() == [list(p) for p in V] and m.vertex_dtype == "f8"
    p = tmp_path / "back.ply"
    write_mesh(p, m)
    assert read_mesh(p).V.tolist() == m.V.tolist()


@pytest.mark.filterwarnings("error")
def test_ply_ascii_integer_property_holding_nan_is_read_as_zero_with_a_note(tmp_path):
    vprops = XYZ + [("red", "uchar"), ("green", "uchar"), ("blue", "uchar")]
    rows = [p + c for p, c in zip(SQ[:3], [(1, 2, 3), ("nan", 2, 300), (4, 5, 6)])]
    m = _read_bytes(tmp_path, "n.ply", _ply("ascii", vprops, rows, [("vertex_indices", "list uchar int")],
                                              [(3, 0, 1, 2)]))
    assert m.vertex_colors.tolist() == [[1, 2, 3], [0, 2, 255], [4, 5, 6]]
    assert any("'red': 1 values are not numbers" in n for n in m.notes)
    assert any("'blue': 1 values outside 0..255 clipped" in n for n in m.notes)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("text,colors,notes", [
    ("COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2 1 0 0\n",
     "dropped", ["vertex colours dropped", "face colours not kept (1 faces"]),
    ("COFF 3 1 0\n0 0 0 1.0 0 0\n1 0 0 0 1.0 0\n0 1 0 0 0 0.5\n3 0 1 2\n",
     [[255, 0, 0], [0, 255, 0], [0, 0, 128]], ["floats 0..1 converted"]),
    ("NOFF\n# normals\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n", None, []),
    # Geomview order for CNOFF: normal, then colour; MeshLab's NCOFF: colour, then normal
    ("CNOFF\n3 1 0\n0 0 0 0 0 1 10 20 30 255\n1 0 0 0 0 1 10 20 30 255\n0 1 0 0 0 1 10 20 30 255\n3 0 1 2\n",
     [[10, 20, 30, 255]] * 3, []),
    ("NCOFF\n3 1 0\n0 0 0 10 20 30 255 0 0 1\n1 0 0 10 20 30 255 0 0 1\n0 1 0 10 20 30 255 0 0 1\n3 0 1 2\n",
     [[10, 20, 30, 255]] * 3, []),
    ("3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", None, []),   # the keyword is optional
])
def test_off_variants(tmp_path, text, colors, notes):
    m = _read_bytes(tmp_path, "a.off", text)
    assert m.V.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]] and m.F.tolist() == [[0, 1, 2]]
    if colors == "dropped" or colors is None:
        assert m.vertex_colors is None
    else:
        assert m.vertex_colors.tolist() == colors
    for part in notes:
        assert any(part in n for n in m.notes), (part, m.notes)


@pytest.mark.parametrize("text,message", [
    ("4OFF\n1 0 0\n0 0 0 1\n", "not 3-dimensional"),
    ("OFF BINARY\n", "binary OFF is not supported"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "face 0: announces 3 corners, has 2"),
])
def test_off_that_cannot_be_read_says_why(tmp_path, text, message):
    with pytest.raises(MeshError, match=message):
        _read_bytes(tmp_path, "x.off", text)


@pytest.mark.filterwarnings("error")
def test_stl_binary_named_solid_with_nan_normals_and_padding(tmp_path):
    import struct
    T = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0], [0, 1, 0]]], np.float32)
    rec = np.zeros(2, [("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"], rec["v"] = np.nan, T
    data = b"solid from a CAD tool".ljust(80) + struct.pack("<I", 2) + rec.tobytes()
    m = _read_bytes(tmp_path, "s.stl", data)
    assert len(m.V) == 4 and len(m.F) == 2 and m.vertex_dtype == "f4"
    m = _read_bytes(tmp_path, "p.stl", data + b"\0" * 7)
    assert len(m.F) == 2 and any("7 bytes after the last of 2 triangles ignored" in n for n in m.notes)


@pytest.mark.filterwarnings("error")
def test_nan_vertex_no_face_uses_is_kept_with_a_note_one_a_face_uses_is_an_error(tmp_path):
    p = tmp_path / "u.obj"
    p.write_text(SQUARE + "v nan inf 0\nf 1 2 3\n")
    m = read_mesh(p)
    assert np.isnan(m.V[4, 0]) and np.isinf(m.V[4, 1])
    assert any("1 unreferenced vertices with NaN or infinite coordinates kept" in n for n in m.notes)
    p.write_text(SQUARE + "v nan inf 0\nf 1 2 5\n")
    with pytest.raises(MeshError, match=r"vertex 4 has a non-finite coordinate \(1 such vertices\)$"):
        read_mesh(p)


@pytest.mark.filterwarnings("error")
def test_polygons_of_every_size_keep_their_place(tmp_path):
    """Each polygon's triangles come where the polygon was, k-2 of them, on its
    corners; faces with fewer than 3 corners are dropped and counted."""
    rng = np.random.default_rng(5)
    ang = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    V = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(9)])  # a convex 9-gon
    polys = [sorted(rng.choice(9, size=k, replace=False).tolist()) for k in rng.integers(1, 10, size=40)]
    notes = []
    F = io_module._polygons_to_triangles(polys, notes, V)
    assert len(F) == sum(max(len(p) - 2, 0) for p in polys)
    at = 0
    for p in polys:
        if len(p) < 3:
            continue
        T = F[at:at + len(p) - 2]
        at += len(p) - 2
        assert set(T.ravel().tolist()) <= set(p)
        E = V[T]
        nz = np.cross(E[:, 1] - E[:, 0], E[:, 2] - E[:, 0])[:, 2]
        P = V[p]
        area = 0.5 * np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1])
        assert (nz > 0).all() and np.isclose(0.5 * nz.sum(), area)
    n_small = sum(len(p) < 3 for p in polys)
    assert f"{n_small} faces with fewer than 3 corners dropped" in notes
    # the same from (counts, flat) arrays
    flat = np.concatenate([np.asarray(p) for p in polys])
    assert np.array_equal(io_module._polygons_to_triangles(([len(p) for p in polys], flat), [], V), F)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("count_type", ["uchar", "char", "int"])
@pytest.mark.parametrize("fmt", ["binary_little_endian", "binary_big_endian"])
def test_ply_face_records_with_scalars_around_a_list_of_varying_length(tmp_path, count_type, fmt):
    fprops = [("flags", "uchar"), ("vertex_indices", f"list {count_type} int"), ("quality", "float")]
    faces = [(7, 3, 1, 4, 2, 0.5), (8, 4, 0, 1, 2, 3, 1.5), (9, 3, 0, 2, 3, 2.5)]
    m = _read_bytes(tmp_path, "f.ply", _ply(fmt, XYZ, SQ, fprops, faces))
    assert m.F.tolist() == [[1, 4, 2], [0, 1, 2], [0, 2, 3], [0, 2, 3]]
    assert any("face properties not kept: flags, quality" in n for n in m.notes)
    data = _ply(fmt, XYZ, SQ, fprops, faces)
    fmt_, elements, pos = io_module._parse_ply_header(data)
    face = io_module._ply_binary_body(data, pos, elements, ">" if "big" in fmt else "<")["face"]
    assert face["flags"].tolist() == [7, 8, 9] and face["quality"].tolist() == [0.5, 1.5, 2.5]
    with pytest.raises(MeshError, match="truncated"):
        _read_bytes(tmp_path, "t.ply", _ply(fmt, XYZ, SQ, fprops, faces)[:-3])


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("colliding", [False, True])
def test_stl_weld_joins_equal_corners_in_order_of_appearance(monkeypatch, colliding):
    """Corners with equal coordinates (0.0 and -0.0 alike) become one vertex,
    numbered by first appearance; a hash with many collisions changes nothing."""
    rng = np.random.default_rng(3)
    P = rng.integers(-3, 4, (3000, 3)).astype(np.float64)
    P[rng.random(P.shape) < 0.2] *= -1  # some zeros become -0.0
    if colliding:
        monkeypatch.setattr(io_module, "_row_hash", lambda bits: (bits[:, 0] % np.uint64(3)))
    m = io_module._weld(P, "f8")
    assert np.array_equal(m.V[m.F.reshape(-1)], P + 0.0)
    _, first = np.unique(P + 0.0, axis=0, return_index=True)
    assert np.array_equal(m.V, (P + 0.0)[np.sort(first)])


def test_ply_comments_are_kept_through_a_repair(tmp_path):
    from shellrepair.repair import repair_mesh
    from shellrepair.shapes import icosphere

    V, F = icosphere(2)
    src = tmp_path / "s.ply"
    write_mesh(src, Mesh(V=V, F=F[3:], comments=["comment scanned by the museum, 2024", "obj_info units mm"]))
    head = src.read_bytes().split(b"end_header")[0].decode()
    assert "comment scanned by the museum, 2024\n" in head and "obj_info units mm\n" in head
    m = read_mesh(src)
    assert m.comments == ["comment scanned by the museum, 2024", "obj_info units mm"]
    R, _ = repair_mesh(m)
    out = tmp_path / "r.ply"
    write_mesh(out, R)
    assert read_mesh(out).comments == m.comments     # shellrepair's own line is not taken for the scan's
