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
