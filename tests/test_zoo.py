"""The export zoo: the same meshes, written by every writer in reach, read
back to the same surface and the same holes; and no file of the zoo makes
the command line print anything on stderr.

Meshes (built here): a sphere with three holes; the same with vertex
colours; a quad mesh (a cube-sphere) with two holes; the cube-sphere with
texture coordinates, once per corner (vertices shared, as OBJ writes them)
and once split at the seams (each cube side with its own vertices, as
exporters that store UVs per vertex write them).

Writers: open3d, pymeshlab, and trimesh / meshio / plyfile when installed
(they are not dependencies: their cases are skipped saying so), plus
hand-written files for the corners of the OBJ, PLY, OFF and STL
specifications that exporters use.

"Same surface": every vertex a face uses lies within the writer's rounding
of one original vertex, and the faces, in original vertices, are the
original triangles (for quads: each quad is covered by two triangles that
span its four corners). "Same holes": the boundary loops that
``shellrepair holes --json`` lists have the edge counts of the original's.
A file whose writer splits vertices at seams only has the original holes
once coincident vertices are one point for the topology; those cases are
expected to fail until then.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import itertools
import json
import os
import struct
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from shellrepair import cli, read_mesh
from eval import shapes
from shellrepair.holes.loops import boundary_loops

ROOT = Path(__file__).resolve().parents[1]

#: Largest position error a writer may add, for coordinates of size ~1: the
#: text writers of open3d print 6 significant digits (5e-7), binary float
#: writers round to float32 (6e-8).
TOL = 1e-6


# --------------------------------------------------------------------------
# the meshes
# --------------------------------------------------------------------------
@dataclass
class Ref:
    """A mesh as written: positions, faces (all triangles or all quads), and extras."""

    name: str
    V: np.ndarray              # (n,3), float32-exact
    P: np.ndarray              # (m,3) or (m,4) faces
    colors: np.ndarray | None = None    # (n,3) uint8
    vertex_uv: np.ndarray | None = None  # (n,2): vertices split at the seams
    corner_uv: np.ndarray | None = None  # (m,k,2)

    @property
    def tris(self):
        """The faces as triangles (quads along their 0-2 diagonal)."""
        if self.P.shape[1] == 3:
            return self.P
        return np.vstack([self.P[:, [0, 1, 2]], self.P[:, [0, 2, 3]]])

    @property
    def split(self):
        """True when coincident vertices stand for one point (seams)."""
        return len(self.welded()[0]) < len(self.V)

    def welded(self):
        """Positions without repeats and the faces on them: the surface as a point set sees it."""
        W, inv = np.unique(self.V, axis=0, return_inverse=True)
        return W, inv.reshape(-1)[self.P]


def _f32(V):
    return np.asarray(V, np.float64).astype(np.float32).astype(np.float64)


def _sphere_with_holes():
    V, F = shapes.icosphere(3)
    V, F, _, _ = shapes.perforate_discs(V, F, n_holes=3, radius=0.35, seed=3)
    return _f32(V), F


def _cube_sphere(n=4, split=False):
    """Quads of a cube with ``n`` x ``n`` cells per side, pushed onto the unit sphere.

    Returns V, Q (quads, outward winding), and per-vertex UVs when ``split``
    (each side has its own vertices; the UV of a vertex is its place on its side).
    """
    V, Q, UV = [], [], []
    index = {}
    for axis in range(3):
        for sign in (-1, 1):
            u_ax, v_ax = [a for a in range(3) if a != axis]
            ids = np.empty((n + 1, n + 1), np.int64)
            for i in range(n + 1):
                for j in range(n + 1):
                    p = np.zeros(3)
                    p[axis] = sign
                    p[u_ax] = -1 + 2 * i / n
                    p[v_ax] = -1 + 2 * j / n
                    key = (axis, sign, i, j) if split else tuple(np.round(p * n).astype(int))
                    if key not in index:
                        index[key] = len(V)
                        V.append(p / np.linalg.norm(p))
                        UV.append((i / n, j / n))
                    ids[i, j] = index[key]
            for i in range(n):
                for j in range(n):
                    q = [ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]]
                    # outward: (u x v) points along +axis for the cyclic order of (axis, u, v)
                    outward = sign * (1 if (u_ax - axis) % 3 == 1 else -1)
                    Q.append(q if outward > 0 else q[::-1])
    return _f32(np.array(V)), np.array(Q, np.int64), (np.array(UV) if split else None)


def _remove_quads(Q):
    """Two holes of one quad each, far apart (first side and the side opposite)."""
    keep = np.ones(len(Q), bool)
    keep[[5, len(Q) - 6]] = False
    return Q[keep]


def _make_refs():
    V, F = _sphere_with_holes()
    rng = np.random.default_rng(7)
    refs = [Ref("sphere_holes", V, F),
            Ref("sphere_colours", V, F, colors=rng.integers(0, 256, (len(V), 3)).astype(np.uint8))]
    V, Q, _ = _cube_sphere()
    Q = _remove_quads(Q)
    refs.append(Ref("quads", V, Q))
    # per-corner UVs on shared vertices: a seam lives in the UVs only
    T = Ref("uv_corners", V, Q).tris
    refs.append(Ref("uv_corners", V, T, corner_uv=rng.random((len(T), 3, 2))))
    V, Q, UV = _cube_sphere(split=True)
    Q = _remove_quads(Q)
    refs.append(Ref("uv_split", V, Ref("x", V, Q).tris, vertex_uv=UV))
    return {r.name: r for r in refs}


REFS = _make_refs()


def _expected_loops(ref):
    """Edge counts of the boundary loops, coincident vertices taken as one."""
    W, P = ref.welded()
    loops, chains = boundary_loops(Ref("w", W, P).tris, len(W))
    assert not chains
    return sorted(len(lp) for lp in loops)


def test_the_meshes_have_the_holes_they_are_built_with():
    assert len(_expected_loops(REFS["sphere_holes"])) == 3
    assert _expected_loops(REFS["quads"]) == [4, 4]
    assert _expected_loops(REFS["uv_split"]) == [4, 4]
    assert REFS["uv_split"].split and not REFS["quads"].split


# --------------------------------------------------------------------------
# the writers
# --------------------------------------------------------------------------
def _has(module):
    return importlib.util.find_spec(module) is not None


def _o3d_mesh(ref):
    import open3d as o3d

    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(ref.V), o3d.utility.Vector3iVector(ref.tris))
    if ref.colors is not None:
        m.vertex_colors = o3d.utility.Vector3dVector(ref.colors / 255.0)
    if ref.corner_uv is not None:
        m.triangle_uvs = o3d.utility.Vector2dVector(ref.corner_uv.reshape(-1, 2))
    if ref.vertex_uv is not None:
        m.triangle_uvs = o3d.utility.Vector2dVector(ref.vertex_uv[ref.tris].reshape(-1, 2))
    m.compute_triangle_normals()
    return m


def _o3d(ascii_):
    def write(ref, path):
        import open3d as o3d

        assert o3d.io.write_triangle_mesh(str(path), _o3d_mesh(ref), write_ascii=ascii_)
    return write


def _pml(**kw):
    def write(ref, path):
        import pymeshlab

        extra = {}
        if ref.colors is not None:
            extra["v_color_matrix"] = np.column_stack([ref.colors / 255.0, np.ones(len(ref.V))])
        if ref.P.shape[1] == 4:
            m = pymeshlab.Mesh(ref.V, face_list_of_indices=[q.astype(np.uint32) for q in ref.P], **extra)
        else:
            if ref.corner_uv is not None:
                extra["w_tex_coords_matrix"] = ref.corner_uv.reshape(-1, 2)
            if ref.vertex_uv is not None:
                extra["v_tex_coords_matrix"] = ref.vertex_uv
            m = pymeshlab.Mesh(ref.V, ref.P.astype(np.int32), **extra)
        ms = pymeshlab.MeshSet()
        ms.add_mesh(m)
        ms.save_current_mesh(str(path), **kw)
    return write


def _trimesh(ref, path):
    import trimesh

    trimesh.Trimesh(ref.V, ref.tris, vertex_colors=ref.colors, process=False).export(str(path))


def _meshio(ref, path):
    import meshio

    kind = "triangle" if ref.P.shape[1] == 3 else "quad"
    meshio.write_points_cells(str(path), ref.V, [(kind, ref.P)])


def _plyfile(binary):
    def write(ref, path):
        from plyfile import PlyData, PlyElement

        vd = [("x", "f4"), ("y", "f4"), ("z", "f4")] + ([("red", "u1"), ("green", "u1"), ("blue", "u1")]
                                                         if ref.colors is not None else [])
        v = np.empty(len(ref.V), vd)
        for j, c in enumerate("xyz"):
            v[c] = ref.V[:, j]
        if ref.colors is not None:
            for j, c in enumerate(("red", "green", "blue")):
                v[c] = ref.colors[:, j]
        f = np.empty(len(ref.P), [("vertex_indices", "i4", (ref.P.shape[1],))])
        f["vertex_indices"] = ref.P
        PlyData([PlyElement.describe(v, "vertex"), PlyElement.describe(f, "face")], text=not binary).write(str(path))
    return write


# ---- hand-written files: the corners of the specifications -----------------
def _num(x):
    return repr(float(x))


def _obj_spec(ref, path):
    """Every OBJ statement exporters write, CRLF, comments, continuations, relative indices."""
    n = len(ref.V)
    out = ["# exported by a hand-written writer", "mtllib scene.mtl", "o statue", "g body  "]
    for i, p in enumerate(ref.V):
        xyz = " ".join(map(_num, p))
        if ref.colors is not None:
            line = f"v {xyz} " + " ".join(f"{c / 255:.6f}" for c in ref.colors[i])
        else:
            line = f"v {xyz} 1.0" if i % 3 == 0 else f"v {xyz}"   # w coordinates
        if i % 7 == 0:
            line = "  \t" + line.replace(" ", "\t", 1)  # leading white space, a tab after the keyword
        if i % 11 == 0:
            a, b = line.rsplit(" ", 1)
            line = a + " \\\r\n   " + b  # continued on the next line
        out.append(line + ("   # trailing comment" if i % 5 == 0 else " "))
    out += [f"vt {i / n:.4f} 0.5" for i in range(n)]
    out += ["vn 0 0 1", "vp 0.5 0.5", "usemtl stone", "s 1"]
    forms = ["{v}", "{v}/{v}", "{v}//1", "{v}/{v}/1"]
    for k, f in enumerate(ref.P):
        rel = k % 2 == 1
        corners = [forms[k % 4].format(v=(int(i) - n if rel else int(i) + 1)) for i in f]
        if k % 9 == 0:
            out.append("f " + " ".join(corners[:2]) + " \\\r\n  " + " ".join(corners[2:]))
        else:
            out.append("f " + " ".join(corners))
        if k == 3:
            out += ["g other", "usemtl marble", "l 1 2 3"]
    path.write_bytes(("\r\n".join(out) + "\r\n").encode())


def _obj_soup(ref, path):
    """Each face with its own three vertices, by relative indices (vertices split everywhere)."""
    out = []
    for f in ref.P:
        out += [f"v {' '.join(map(_num, ref.V[i]))}" for i in f]
        out.append("f " + " ".join(str(-len(f) + j) for j in range(len(f))))
    path.write_text("\n".join(out) + "\n")


def _ply_spec(fmt, count_type, index_type, crlf=False, float_colours=False):
    """PLY with comments, obj_info, extra elements before and after the faces, face colours."""
    def write(ref, path):
        endian = {"binary_big_endian": ">", "binary_little_endian": "<"}.get(fmt)
        codes = {"uchar": "u1", "ushort": "u2", "int": "i4", "uint": "u4", "float": "f4", "double": "f8"}
        vprops = [("x", "float"), ("y", "float"), ("z", "float"), ("nx", "float"), ("ny", "float"),
                  ("nz", "float")]
        if ref.colors is not None:
            ct = "float" if float_colours else "uchar"
            vprops += [("red", ct), ("green", ct), ("blue", ct)]
        k = ref.P.shape[1]
        head = ["ply", f"format {fmt} 1.0", "comment written by hand: every corner of the spec",
                "obj_info a statue", f"element vertex {len(ref.V)}"]
        head += [f"property {t} {name}" for name, t in vprops]
        head += ["element material 2", "property float ambient_coeff", "property uchar shininess",
                 f"element face {len(ref.P)}", f"property list {count_type} {index_type} vertex_indices",
                 "property uchar red", "property uchar green", "property uchar blue",
                 "element edge 3", "property int vertex1", "property int vertex2", "end_header"]
        nl = "\r\n" if crlf else "\n"
        header = (nl.join(head) + nl).encode()
        N = ref.V / np.linalg.norm(ref.V, axis=1, keepdims=True)
        vcols = {"x": ref.V[:, 0], "y": ref.V[:, 1], "z": ref.V[:, 2],
                 "nx": N[:, 0], "ny": N[:, 1], "nz": N[:, 2]}
        if ref.colors is not None:
            for j, c in enumerate(("red", "green", "blue")):
                vcols[c] = ref.colors[:, j] / 255.0 if float_colours else ref.colors[:, j]
        fcol = (np.arange(len(ref.P))[:, None] * [3, 5, 7]) % 256
        if endian is None:
            rows = [" ".join(repr(float(vcols[nm][i])) if t == "float" else str(int(vcols[nm][i]))
                             for nm, t in vprops) for i in range(len(ref.V))]
            rows += ["0.25 12", "0.5 40"]
            rows += [f"{k} " + " ".join(map(str, f)) + " " + " ".join(map(str, c)) for f, c in zip(ref.P, fcol)]
            rows += ["0 1", "1 2", "2 0"]
            path.write_bytes(header + (nl.join(rows) + nl).encode())
            return
        va = np.empty(len(ref.V), [(nm, endian + codes[t]) for nm, t in vprops])
        for nm, _ in vprops:
            va[nm] = vcols[nm]
        ma = np.array([(0.25, 12), (0.5, 40)], [("a", endian + "f4"), ("s", "u1")])
        fa = np.empty(len(ref.P), [("n", endian + codes[count_type]), ("i", endian + codes[index_type], (k,)),
                                   ("c", "u1", (3,))])
        fa["n"], fa["i"], fa["c"] = k, ref.P, fcol
        ea = np.array([(0, 1), (1, 2), (2, 0)], [("a", endian + "i4"), ("b", endian + "i4")])
        path.write_bytes(header + va.tobytes() + ma.tobytes() + fa.tobytes() + ea.tobytes())
    return write


def _off_spec(keyword, counts_on_keyword_line=False, face_colours=True):
    """OFF variants: colours (integers 0..255), normals in the order the keyword's letters say."""
    def write(ref, path):
        N = ref.V / np.linalg.norm(ref.V, axis=1, keepdims=True)
        cols = ref.colors if ref.colors is not None else np.full((len(ref.V), 3), 128, np.uint8)
        out = ["# an OFF file", keyword + (f" {len(ref.V)} {len(ref.P)} 0" if counts_on_keyword_line else "")]
        if not counts_on_keyword_line:
            out += ["", f"{len(ref.V)} {len(ref.P)} 0   # vertices faces edges"]
        letters = {"C": lambda i: " ".join(map(str, cols[i])) + " 255",
                   "N": lambda i: " ".join(map(_num, N[i]))}
        order = [c for c in keyword[:-3]][::-1]   # values in the reverse order of the letters
        for i, p in enumerate(ref.V):
            out.append(" ".join(map(_num, p)) + "".join(" " + letters[c](i) for c in order))
        for j, f in enumerate(ref.P):
            out.append(f"{len(f)} " + " ".join(map(str, f)) + (f" {j % 256} 0 0" if face_colours else ""))
        path.write_text("\n".join(out) + "\n")
    return write


def _stl_ascii(ref, path):
    """ASCII STL, upper-case keywords in one facet, NaN normals."""
    out = ["solid statue"]
    for k, t in enumerate(ref.tris):
        out.append("  facet normal nan nan nan" if k % 2 else "  FACET NORMAL 0 0 0")
        out.append("    outer loop")
        out += [f"      vertex {' '.join(map(_num, ref.V[i]))}" for i in t]
        out += ["    endloop", "  endfacet"]
    out.append("endsolid statue")
    path.write_text("\n".join(out) + "\n")


def _stl_binary_solid(ref, path):
    """Binary STL whose 80-byte header starts with 'solid', NaN normals."""
    T = ref.tris
    rec = np.zeros(len(T), [("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"] = np.nan
    rec["v"] = ref.V[T]
    path.write_bytes(b"solid exported by a CAD tool".ljust(80, b" ") + struct.pack("<I", len(T)) + rec.tobytes())


def _need(module):
    return pytest.mark.skipif(not _has(module), reason=f"{module} is not installed (not a dependency)")


#: name -> (extension, writer, writes vertex colours, marks)
WRITERS = {
    "open3d-ply-ascii": (".ply", _o3d(True), True, [_need("open3d")]),
    "open3d-ply-binary": (".ply", _o3d(False), True, [_need("open3d")]),
    "open3d-obj": (".obj", _o3d(True), True, [_need("open3d")]),
    "open3d-off": (".off", _o3d(True), True, [_need("open3d")]),
    "open3d-stl": (".stl", _o3d(False), False, [_need("open3d")]),
    "pymeshlab-ply-binary": (".ply", _pml(binary=True), True, [_need("pymeshlab")]),
    "pymeshlab-ply-ascii": (".ply", _pml(binary=False), True, [_need("pymeshlab")]),
    "pymeshlab-obj": (".obj", _pml(save_polygonal=True), True, [_need("pymeshlab")]),
    "pymeshlab-off": (".off", _pml(save_polygonal=True), True, [_need("pymeshlab")]),
    "pymeshlab-stl-binary": (".stl", _pml(binary=True), False, [_need("pymeshlab")]),
    "pymeshlab-stl-ascii": (".stl", _pml(binary=False), False, [_need("pymeshlab")]),
    "trimesh-ply": (".ply", _trimesh, True, [_need("trimesh")]),
    "trimesh-obj": (".obj", _trimesh, False, [_need("trimesh")]),
    "meshio-obj": (".obj", _meshio, False, [_need("meshio")]),
    "meshio-off": (".off", _meshio, False, [_need("meshio")]),
    "plyfile-ascii": (".ply", _plyfile(False), True, [_need("plyfile")]),
    "plyfile-binary": (".ply", _plyfile(True), True, [_need("plyfile")]),
    "spec-obj": (".obj", _obj_spec, True, []),
    "spec-obj-soup": (".obj", _obj_soup, False, []),
    "spec-ply-big-endian": (".ply", _ply_spec("binary_big_endian", "uint", "int"), True, []),
    "spec-ply-little-int-uint": (".ply", _ply_spec("binary_little_endian", "int", "uint", crlf=True,
                                                   float_colours=True), True, []),
    "spec-ply-ascii": (".ply", _ply_spec("ascii", "uchar", "uint", float_colours=True), True, []),
    "spec-ply-ascii-crlf": (".ply", _ply_spec("ascii", "ushort", "int", crlf=True), True, []),
    "spec-off-coff": (".off", _off_spec("COFF"), True, []),
    "spec-off-noff": (".off", _off_spec("NOFF", counts_on_keyword_line=True), False, []),
    "spec-off-cnoff": (".off", _off_spec("CNOFF"), True, []),
    "spec-off-ncoff": (".off", _off_spec("NCOFF", face_colours=False), True, []),
    "spec-stl-ascii": (".stl", _stl_ascii, False, []),
    "spec-stl-binary-solid": (".stl", _stl_binary_solid, False, []),
}

#: The hand-written writers the UV meshes go through: OBJ (which writes vt and
#: vn of its own) and binary STL (which welds the seams on reading).
UV_SPEC_WRITERS = ("spec-obj", "spec-stl-binary-solid")


def _cases():
    for mesh, ref in REFS.items():
        for writer, (ext, _, _, marks) in WRITERS.items():
            if writer == "spec-obj-soup" and mesh != "sphere_holes":
                continue  # one soup is enough
            if ref.P.shape[1] == 4 and (writer.startswith("open3d") or writer == "meshio-off"):
                continue  # open3d holds triangles only; meshio's OFF writer drops quads
            if mesh.startswith("uv_") and writer.startswith("spec-") and writer not in UV_SPEC_WRITERS:
                continue  # hand-written files write no UVs: the other meshes cover their corners
            # files split at seams (or soups) read to the same holes through
            # topology by position
            yield pytest.param(mesh, writer, marks=marks,
                               id=f"{mesh}-{writer}")


CASES = list(_cases())


@pytest.fixture(scope="module")
def zoo(tmp_path_factory):
    """Writes each case's file on first use; returns a function (mesh, writer) -> path."""
    folder = tmp_path_factory.mktemp("zoo")
    made = {}

    def get(mesh, writer):
        if (mesh, writer) not in made:
            ext, write, _, _ = WRITERS[writer]
            path = folder / f"{mesh}-{writer}{ext}"
            with contextlib.redirect_stdout(io.StringIO()):
                write(REFS[mesh], path)
            made[mesh, writer] = path
        return made[mesh, writer]

    return get


def _holes_json(path, capsys):
    capsys.readouterr()
    assert cli.main(["holes", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _same_surface(ref, mesh):
    """Map the read vertices to the original points; check the faces are the original surface.

    Returns, per read vertex, the original point it lies on (-1 when unused).
    """
    W, P = ref.welded()
    used = np.unique(mesh.F)
    d, ids = cKDTree(W).query(mesh.V[used], k=2)
    assert d[:, 0].max() <= TOL, f"a vertex moved by {d[:, 0].max():.3g}"
    assert d[:, 1].min() > 100 * TOL  # each read vertex is near exactly one original
    orig = np.full(len(mesh.V), -1)
    orig[used] = ids[:, 0]
    T = np.sort(orig[mesh.F], axis=1)
    if P.shape[1] == 3:
        assert len(T) == len(P)
        assert np.array_equal(np.unique(T, axis=0), np.unique(np.sort(P, axis=1), axis=0))
    else:
        quad_of = {c: q for q, corners in enumerate(P.tolist())
                   for c in itertools.combinations(sorted(corners), 3)}
        q = np.array([quad_of.get(tuple(t), -1) for t in T.tolist()])
        assert (q >= 0).all(), "a triangle that is not inside one quad"
        assert (np.bincount(q, minlength=len(P)) == 2).all()
        for i in range(len(P)):
            assert set(T[q == i].ravel().tolist()) == set(P[i].tolist())
    return orig


@pytest.mark.parametrize("mesh,writer", CASES)
def test_every_writer_reads_to_the_same_surface_and_holes(zoo, mesh, writer, capsys):
    ref = REFS[mesh]
    path = zoo(mesh, writer)
    m = read_mesh(path)
    orig = _same_surface(ref, m)
    if ref.colors is not None and WRITERS[writer][2]:
        assert m.vertex_colors is not None, "vertex colours lost"
        used = np.unique(m.F)
        W = ref.welded()[0]
        _, first = np.unique(ref.V, axis=0, return_index=True)  # the colour of each original point
        assert len(W) == len(ref.V)
        diff = np.abs(m.vertex_colors[used, :3].astype(int) - ref.colors[first[orig[used]]].astype(int))
        assert diff.max() <= 1  # 8 bits, or a float 0..1 printed with 6 decimals
    loops = sorted(lp["edges"] for lp in _holes_json(path, capsys)["loops"])
    assert loops == _expected_loops(ref)


# --------------------------------------------------------------------------
# no stray line on stderr
# --------------------------------------------------------------------------
def _hostile_files(folder):
    """Files with NaN where exporters leave it, that still repair; and one that cannot."""
    ref = REFS["sphere_holes"]
    V, F = ref.V, ref.P
    n = len(V)
    files = {}
    # PLY with float colours, some NaN or infinite
    C = np.tile([0.2, 0.4, 0.6], (n, 1))
    C[::17] = np.nan
    C[5] = np.inf
    va = np.empty(n, [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "<f4"), ("green", "<f4"), ("blue", "<f4")])
    for j, c in enumerate("xyz"):
        va[c] = V[:, j]
    for j, c in enumerate(("red", "green", "blue")):
        va[c] = C[:, j]
    fa = np.empty(len(F), [("n", "u1"), ("i", "<i4", (3,))])
    fa["n"], fa["i"] = 3, F
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\n"
            + "".join(f"property float {c}\n" for c in ("x", "y", "z", "red", "green", "blue"))
            + f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n")
    files["nan-colours.ply"] = head.encode() + va.tobytes() + fa.tobytes()
    # OBJ with NaN colours and an unreferenced vertex at NaN
    lines = [f"v {' '.join(map(_num, p))} {'nan' if i % 13 == 0 else '0.5'} 0.5 0.5" for i, p in enumerate(V)]
    lines.append("v nan nan nan 0.5 0.5 0.5")
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in F]
    files["nan-colours-unused-nan-vertex.obj"] = ("\n".join(lines) + "\n").encode()
    # OFF with an unreferenced infinite vertex
    files["inf-unused.off"] = (f"OFF\n{n + 1} {len(F)} 0\n" + "".join(" ".join(map(_num, p)) + "\n" for p in V)
                               + "inf 0 -inf\n" + "".join("3 " + " ".join(map(str, f)) + "\n" for f in F)).encode()
    # a vertex a face uses is NaN: one clear error line
    bad = [f"v {' '.join(map(_num, p))}" for p in V]
    bad[int(F[0, 0])] = "v nan 0 0"
    files["ERROR-nan-used.obj"] = ("\n".join(bad + ["f " + " ".join(str(i + 1) for i in f) for f in F]) + "\n").encode()
    paths = []
    for name, data in files.items():
        (folder / name).write_bytes(data)
        paths.append(folder / name)
    return paths


_DRIVER = r"""
import sys, warnings
from shellrepair import cli
for line in sys.stdin.read().splitlines():
    src, out = line.split("\t")
    for m in list(sys.modules.values()):  # show a warning again for each file
        reg = getattr(m, "__warningregistry__", None)
        if isinstance(reg, dict):
            reg.clear()
    print("@@ " + src, file=sys.stderr, flush=True)
    code = cli.main(["repair", src, "-o", out])
    sys.stderr.flush()
    print(f"@@ exit {code}", file=sys.stderr, flush=True)
"""


def _run_cli(args, **kw):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=600, **kw)


@pytest.mark.slow
def test_no_zoo_file_prints_anything_on_stderr(zoo, tmp_path):
    """``shellrepair repair FILE -o OUT`` on every zoo file (and on files with NaN colours
    and NaN / infinite unreferenced vertices): exit 0 and not one line on stderr.
    A file whose used vertex is NaN exits 2 with exactly one line.
    One Python process runs the command line's ``main`` on each file in turn
    (as ``python -m shellrepair.cli`` does), marking on stderr where each starts."""
    files = []
    for p in CASES:
        mesh, writer = p.values
        if any(m.name == "skipif" and m.args[0] for m in p.marks):
            continue
        files.append(zoo(mesh, writer))
    files += _hostile_files(tmp_path)
    jobs = "\n".join(f"{f}\t{tmp_path / (f.stem + '.out.ply')}" for f in files)
    res = _run_cli(["-c", _DRIVER], input=jobs)
    assert res.returncode == 0, res.stderr[-2000:]
    chunks = res.stderr.split("@@ ")[1:]
    assert len(chunks) == 2 * len(files), res.stderr[-2000:]
    for src_chunk, exit_chunk in zip(chunks[::2], chunks[1::2]):
        src, _, printed = src_chunk.partition("\n")
        code = int(exit_chunk.split()[1])
        if Path(src).name.startswith("ERROR-"):
            assert code == 2 and printed.count("\n") == 1 and printed.startswith("error: "), (src, printed)
            assert "non-finite coordinate" in printed
        else:
            assert (code, printed) == (0, ""), src
            # every loop classed ``hole`` closed: none failed, none left
            report = json.loads((tmp_path / (Path(src).stem + ".out.report.json")).read_text())
            assert report["failed"] == 0 and report["holes_after"] == 0, \
                (src, [h["reason"] for h in report["holes"] if h["status"] != "filled"])


@pytest.mark.parametrize("mesh", list(REFS))
def test_every_hole_of_the_zoo_closes(zoo, mesh):
    """Each zoo mesh, as the hand-written binary PLY has it (the other
    writers read to the same surface and holes, above): every loop is
    classed ``hole`` and filled, none failed, nothing left open."""
    from shellrepair.repair import repair_mesh

    path = zoo(mesh, "spec-ply-big-endian" if mesh != "uv_split" else "spec-stl-binary-solid")
    m = read_mesh(path)
    R, report = repair_mesh(m)
    assert report["holes_before"] == len(_expected_loops(REFS[mesh])) and report["borders"] == 0
    assert report["failed"] == 0 and report["holes_after"] == 0, [h["reason"] for h in report["holes"]]
    assert boundary_loops(R.F, len(R.V)) == ([], [])


def test_the_command_line_itself_prints_nothing_on_stderr(tmp_path):
    """The literal ``python -m shellrepair.cli repair FILE -o OUT`` on a file with
    NaN colours, line continuations and an unreferenced NaN vertex."""
    src = next(p for p in _hostile_files(tmp_path) if p.suffix == ".obj" and "unused" in p.name)
    text = src.read_text().replace("\nf ", "\nf \\\n ", 5)
    src.write_text(text)
    res = _run_cli(["-m", "shellrepair.cli", "repair", str(src), "-o", str(tmp_path / "out.ply")])
    assert (res.returncode, res.stderr) == (0, "")
    out = read_mesh(tmp_path / "out.ply", clean=False, orient=False)
    ref = REFS["sphere_holes"]
    assert np.array_equal(out.V[:len(ref.V)], ref.V)  # original vertices bit-identical
    assert np.isnan(out.V[len(ref.V)]).all()          # the unreferenced one kept as it was
    assert np.isfinite(out.V[np.unique(out.F)]).all()
    assert boundary_loops(out.F, len(out.V)) == ([], [])  # every hole filled
