"""Reading and writing scans: PLY (ascii and binary), OBJ, OFF, STL.

This module is the entry point: :func:`read_mesh` picks a reader by
extension, checks and cleans what it gives and makes it manifold;
:func:`write_mesh` picks a writer and writes atomically. The pieces live
beside it:

* :mod:`shellrepair.mesh.core`: the :class:`Mesh` type and its cache;
* :mod:`shellrepair.mesh.formats`: one module per format (``ply``, ``obj``,
  ``off``, ``stl``), polygon splitting (``polygons``) and the tokenizer the
  text formats share (``text``);
* :mod:`shellrepair.files`: atomic writes and output path checks;
* :mod:`shellrepair.mesh.clean`: :func:`clean_faces` and the manifold repairs.

Every name this module had before that split is still importable from it.

What loading guarantees
-----------------------
* Vertices keep their order and their exact values. A PLY stored as
  ``float`` is read as float32 and widened to float64 (exact), and written
  back as float32, so the original coordinates round-trip bit for bit.
* Vertex colours (PLY ``red green blue [alpha]``, OBJ ``v x y z r g b``,
  OFF ``COFF``) are kept as ``uint8``; float colours (0..1) are converted
  and NaN channels set to 0, each with a note.
* Texture coordinates and materials of the faces are kept
  (:class:`shellrepair.mesh.core.FaceTexture`): OBJ ``vt``, ``usemtl`` and
  ``mtllib``; PLY ``texcoord`` lists and ``texnumber``. PLY per-vertex
  ``u v`` (or ``s t``) are kept as vertex properties.
* What a triangle mesh does not hold is skipped with a note: OBJ ``vn``,
  ``l``, ``p`` and free-form statements, PLY elements other than vertex
  and face and face properties other than the index list, ``texcoord``,
  ``texnumber`` and ``filled``, OFF face colours. The readers follow the specifications as exporters use them
  (OBJ line continuations, relative indices and ``v/vt/vn`` corners; PLY
  ascii and both binary byte orders, any list count and index types; the
  OFF variants; binary STL whose header starts with ``solid``).
* Polygons with more than three corners are split into a fan of triangles.
* Faces that repeat a vertex (``[a, a, b]``) and duplicate faces (the same
  three vertices, in any order) are dropped; zero-area faces with three
  distinct corners are kept and counted; unreferenced vertices are kept
  (vertex order never changes) and counted.
* Topology by position (:func:`manifold_mesh`): vertices on open edges
  whose positions are bit-identical are one vertex for the topology, so a
  triangle soup or a surface cut at texture seams reads as the surface it
  stands for. ``mesh.F`` holds the faces the topology, hole detection and
  repair work on (each corner at the lowest-numbered vertex of its
  position); ``mesh.F_out``, when set, is how those faces are written: a
  corner whose own vertex carries other attributes than that first vertex
  (a colour or UV seam) keeps its own vertex, so every face keeps its
  attributes. Without such differences the file is written joined.
* Faces folded over a surface that is closed without them are dropped;
  non-manifold edges, and vertices where pieces meet at a point, are split
  by appending copies of vertices (same position, same attributes) and
  re-pointing faces; nothing is moved (see
  :func:`shellrepair.mesh.clean.make_manifold`). ``mesh.fixes`` counts each.
  The copies at points where pieces meet are joined again when the mesh is
  written (``mesh.joins``, :func:`shellrepair.mesh.core.as_written`): the
  written scan has the file's own vertices and faces, and a patch at such
  a point shares the file's vertex instead of lying on a copy of it (which
  MeshLab's self-intersection test counts as a crossing).
* Each piece is wound consistently (:func:`shellrepair.mesh.clean.orient_faces`):
  some faces get corners 1 and 2 swapped, nothing else changes; closed
  pieces face outward; non-orientable pieces are reported.
* ``mesh.notes`` lists each of these changes in one line.
* STL's per-triangle vertices are welded on exact coordinates.
* Anything that cannot be read raises :class:`~shellrepair.errors.MeshError`
  naming the file and what is wrong; NaN/inf coordinates of a vertex a face
  uses (of a vertex no face uses: kept, with a note), out-of-range or
  negative indices, a file with no faces, truncated or inconsistent files,
  directories, unreadable or non-regular files (a FIFO would block).
* Reading prints nothing: NumPy warnings on odd values are notes or errors.

Writing always goes to a temporary file in the target folder that is
flushed to disk and renamed into place, so a failed write never leaves a
partial file behind; :func:`atomic_write_many` does this for a mesh and its
report together (:mod:`shellrepair.files`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Union

import numpy as np

from shellrepair.errors import MeshError
from shellrepair.files import atomic_write, atomic_write_many, check_output_path, new_file_mode
from shellrepair.mesh import fastmesh
from shellrepair.mesh.clean import clean_faces
from shellrepair.mesh.core import Mesh, as_written, written_faces
from shellrepair.mesh.formats import READERS, SUPPORTED, WRITERS
from shellrepair.mesh.formats.obj import obj_bytes
from shellrepair.mesh.topology import edge_topology, face_areas
from shellrepair.progress import ProgressArg

__all__ = ["Mesh", "read_mesh", "write_mesh", "mesh_bytes", "check_output_path", "clean_faces", "manifold_mesh",
           "atomic_write", "atomic_write_many", "new_file_mode", "written_faces", "SUPPORTED",
           "MAX_ABS_COORDINATE", "check_references"]

#: Largest coordinate magnitude accepted. Squared lengths and cross
#: products of larger values overflow float64 (max ~1.8e308); real scans in
#: millimetres stay below 1e9.
MAX_ABS_COORDINATE = 1e100


def read_mesh(path: Union[str, os.PathLike], *, clean: bool = True, orient: bool = True,
              progress: ProgressArg = None) -> Mesh:
    """Read a triangle mesh from a PLY, OBJ, OFF or STL file.

    Parameters
    ----------
    path : str or Path
        The file. Its extension picks the reader; PLY and OFF also check
        their magic line.
    clean : bool
        Drop faces that repeat a vertex and exact duplicate faces
        (see :func:`clean_faces`). Default True.
    orient : bool
        Flip faces so that every piece is wound consistently, closed pieces
        outward (see :func:`shellrepair.mesh.clean.orient_faces`). Only the corner
        order of some faces changes; vertices and face order never do.
        Default True.
    progress : callable, optional
        Called as ``progress(label, done, total)`` with the label
        ``"loading <file name>"`` as each of the 4 stages (parse, clean,
        orient, measure) ends, and with ``done = 0`` first (the protocol of
        :mod:`shellrepair.progress`). Default None: nothing is reported.
        ``True`` draws the terminal bar, as it did before the callback.

    Returns
    -------
    mesh : Mesh
        ``mesh.notes`` says what loading changed or found.

    Raises
    ------
    MeshError
        For any file that cannot be read as a triangle mesh.
    """
    path = Path(path)
    if path.is_dir():
        raise MeshError("is a directory, not a mesh file", path)
    if not path.exists():
        raise MeshError("no such file", path)
    if not path.is_file():
        raise MeshError("not a regular file", path)
    ext = path.suffix.lower()
    if ext not in SUPPORTED:
        raise MeshError(f"unknown extension '{path.suffix}' (expected one of {', '.join(SUPPORTED)})", path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MeshError(f"cannot read: {exc.strerror or exc}", path) from None
    if len(data) == 0:
        raise MeshError("empty file", path)
    # a large scan: the compiled kernels load in the background while it is parsed
    # (a binary PLY holds about 19 bytes a face; text formats more)
    fastmesh.preload(len(data) // 19)
    reader = READERS[ext]
    stage = _stages(progress, f"loading {path.name}", 4)
    try:
        mesh = reader(data)
    except MeshError as exc:
        raise MeshError(exc.message, path) from None
    except (ValueError, IndexError, UnicodeDecodeError, OverflowError, MemoryError) as exc:
        raise MeshError(f"malformed {ext[1:].upper()} file ({type(exc).__name__}: {exc})"[:300], path) from None
    mesh.path = str(path)
    stage()
    try:
        _validate(mesh)
        if clean:
            F, kept, notes = clean_faces(mesh.F)
            if F.shape[0] == 0:
                raise MeshError(f"no usable faces: all {mesh.F.shape[0]} faces repeat a vertex")
            mesh.F = F
            if mesh.face_filled is not None:
                mesh.face_filled = mesh.face_filled[kept]
            if mesh.texture is not None and len(kept) != len(mesh.texture.face_uv):
                mesh.texture = mesh.texture.take(kept)
            mesh.notes.extend(notes)
    except MeshError as exc:
        raise MeshError(exc.message, path) from None
    stage()
    keep = {}       # whole-mesh data built on the way, remembered with the areas
    if clean:
        mesh = manifold_mesh(mesh, orient=orient)
        if not len(mesh.F):
            raise MeshError("no usable faces: all faces repeat a position", path)
    elif orient:
        from shellrepair.mesh.clean import orient_faces

        res = orient_faces(mesh.F, mesh.V)
        mesh.F = res.F
        if mesh.texture is not None and res.flipped.any():
            mesh.texture = mesh.texture.flip(res.flipped)
        mesh.notes.extend(res.notes)
        # built on the way: hole detection and repair reuse them
        if res.topo is not None:
            keep["topology"] = res.topo
        if res.piece is not None:
            keep["pieces"] = (res.n_pieces, res.piece)
    stage()
    unused = mesh.n_vertices - _used_vertex_count(written_faces(mesh), mesh.n_vertices)
    if unused:
        joined = int(mesh.fixes.get("vertices_joined", 0))
        mesh.notes.append(f"{unused} unreferenced vertices kept (vertex order never changes"
                          + (f"; the file is written with {joined} coincident vertices joined)" if joined else ")"))
    areas = face_areas(mesh.V, mesh.F)
    mesh.remember(face_areas=areas, **keep)
    zero = int(np.count_nonzero(areas == 0))
    if zero:
        mesh.notes.append(f"{zero} zero-area faces kept")
    stage()
    return mesh


def manifold_mesh(mesh, *, orient=True, topo=None):
    """The mesh with its topology by position and made manifold.

    Parameters
    ----------
    mesh : Mesh
        Not changed. Its faces should have no repeated vertex and no
        duplicate (:func:`clean_faces`).
    orient : bool
        Also wind every piece consistently
        (:func:`shellrepair.mesh.clean.orient_faces`).
    topo : EdgeTopology, optional
        The edge topology of ``mesh.F``, if already built.

    Returns
    -------
    out : Mesh
        ``V`` starts with ``mesh.V`` unchanged (the same array when no vertex
        is added); copies made by splits are appended with the attributes of
        the vertex they copy. ``F`` is the topology's faces, ``F_out`` how
        to write them (None when that is ``F``), ``fixes`` the counts,
        ``notes`` one line per change. The pieces, and the edge topology
        when no face was flipped, are cached on it (:meth:`Mesh.cached`).

    Notes
    -----
    In order: coincident open vertices joined, folded faces dropped and
    non-manifold edges split (:func:`shellrepair.mesh.clean.make_manifold`);
    pieces oriented; vertices where pieces meet at a point split
    (:func:`shellrepair.mesh.clean.split_piece_junctions`). When the file gave
    coincident vertices different attributes (colours, normals, UVs, other
    PLY properties), ``F_out`` writes each corner with a vertex carrying its
    own attributes; with identical attributes the corner is written joined.
    """
    from shellrepair.mesh.clean import FIX_COUNTS, make_manifold, orient_faces, split_piece_junctions
    from shellrepair.mesh.topology import face_pieces

    V = np.asarray(mesh.V, np.float64)
    F0 = np.asarray(mesh.F, np.int64)
    n = len(V)
    if topo is None:
        topo = edge_topology(F0, n)
    res = make_manifold(V, F0, topo)
    F, topo, src = res.F, res.topo, res.src
    fixes = dict(res.counts)
    notes = list(mesh.notes) + res.notes
    Ffile = F0[res.kept] if res.rep is not None else None
    face_filled = None if mesh.face_filled is None else np.asarray(mesh.face_filled)[res.kept]
    texture = getattr(mesh, "texture", None)
    if texture is not None and len(texture.face_uv) == len(F0):
        texture = texture.take(res.kept) if len(res.kept) != len(F0) else texture
    else:
        texture = None
    Vx = np.vstack([V, V[src]]) if src.size else V
    piece = None
    joins = None
    flipped = False
    if orient and len(F):
        o = orient_faces(F, Vx, topo=topo)
        if o.n_flipped:
            flipped = True
            F = o.F
            if Ffile is not None:
                Ffile = Ffile.copy()
                Ffile[o.flipped, 1], Ffile[o.flipped, 2] = Ffile[o.flipped, 2], Ffile[o.flipped, 1]
            if texture is not None:
                texture = texture.flip(o.flipped)
        notes.extend(o.notes)
        if o.piece is not None:
            piece = (o.n_pieces, o.piece)
    if piece is None and len(F):
        piece = face_pieces(topo, len(F))   # flips leave the edges, hence the pieces, as they are
    if len(F):
        F2, src2 = split_piece_junctions(F, len(Vx), piece[1])
        if src2.size:
            src2 = np.where(src2 >= n, src[np.maximum(src2 - n, 0)] if src.size else src2, src2)
            fixes["nonmanifold_vertices_split"] += int(np.unique(src2).size)
            fixes["vertices_added"] += int(src2.size)
            notes.append(f"{np.unique(src2).size} vertices where pieces meet at a point split: "
                         f"{src2.size} new vertices at the same positions, appended for the topology "
                         "(the written file joins them again)")
            joins = np.c_[n + len(src) + np.arange(src2.size), src2]
            F, src = F2, np.concatenate([src, src2])
            Vx = np.vstack([V, V[src]])
            topo = None
    out = Mesh(V=Vx, F=F, vertex_colors=mesh.vertex_colors, vertex_filled=mesh.vertex_filled,
               face_filled=face_filled, vertex_props=dict(mesh.vertex_props), vertex_dtype=mesh.vertex_dtype,
               path=mesh.path, notes=notes, fixes={k: int(fixes.get(k, 0)) for k in FIX_COUNTS},
               comments=list(getattr(mesh, "comments", [])), joins=joins, texture=texture)
    if Ffile is not None:
        out.F_out, seam_src = _seam_faces(mesh, res.rep, Ffile, F, n + len(src))
        if out.F_out is not None:
            k = int(np.count_nonzero(out.F_out != F))
            out.notes.append(f"{k} face corners keep their own vertex in the written file "
                             "(coincident vertices with their own colours or properties: a seam)")
        src = np.concatenate([src, seam_src])
        out.fixes["vertices_added"] += int(seam_src.size)
    if src.size:
        _append_copies(out, V, mesh, src)
    # kept for hole detection and repair; after flips or a junction split the
    # topology no longer matches F, and is rebuilt by whoever needs it
    out.remember(**({"topology": topo} if topo is not None and not flipped else {}),
                 **({} if piece is None else {"pieces": piece}))
    return out


def _seam_faces(mesh, rep, Ffile, F, n_topology):
    """How to write the topology's faces ``F`` so that each corner keeps its attributes.

    Returns
    -------
    F_out : (m,3) int64 or None
        None when every corner's own vertex has the attributes of the vertex
        the topology uses.
    src : (q,) int64
        Vertices to copy (appended after the topology's copies) where a
        seam vertex's corners fall into several fans of the topology.
    """
    none = (None, np.zeros(0, np.int64))
    attrs = []
    if mesh.vertex_colors is not None:
        attrs.append(np.asarray(mesh.vertex_colors))
    attrs += [np.asarray(a) for a in mesh.vertex_props.values() if np.asarray(a).shape[:1] == (len(mesh.V),)]
    if mesh.vertex_filled is not None:
        attrs.append(np.asarray(mesh.vertex_filled))
    if not attrs:
        return none
    n = len(mesh.V)
    grouped = rep != np.arange(n)          # joined to another vertex ...
    grouped[rep[grouped]] = True            # ... or another was joined to it
    g = np.flatnonzero(grouped)
    cols = [rep[g].astype("<i8").view(np.uint8).reshape(len(g), -1)]
    for a in attrs:
        cols.append(np.ascontiguousarray(a[g]).view(np.uint8).reshape(len(g), -1))
    K = np.ascontiguousarray(np.hstack(cols))
    _, first, inv = np.unique(K.view(np.dtype((np.void, K.shape[1]))).ravel(), return_index=True,
                              return_inverse=True)
    attr_rep = np.arange(n, dtype=np.int64)
    attr_rep[g] = g[first[inv.ravel()]]
    A = attr_rep[Ffile]
    seam = A != rep[Ffile]
    if not seam.any():
        return none
    out = np.where(seam, A, F)
    # a seam vertex whose corners lie in several fans of the topology gets a copy per extra fan
    c = np.flatnonzero(seam.ravel())
    pairs, inv = np.unique(np.column_stack([A.ravel()[c], F.ravel()[c]]), axis=0, return_inverse=True)
    inv = inv.ravel()
    later = np.ones(len(pairs), bool)
    later[0] = False
    later[1:] = pairs[1:, 0] == pairs[:-1, 0]
    if later.any():
        base = int(n_topology)
        new_id = np.full(len(pairs), -1, np.int64)
        new_id[later] = base + np.arange(int(later.sum()))
        flat = out.ravel()
        moved = new_id[inv] >= 0
        flat[c[moved]] = new_id[inv[moved]]
        out = flat.reshape(-1, 3)
        return out, pairs[later, 0]
    return out, np.zeros(0, np.int64)


def _append_copies(out, V, mesh, src):
    """Append copies of vertices ``src`` (positions and attributes) to ``out``."""
    out.V = np.vstack([V, V[src]])
    if mesh.vertex_colors is not None:
        C = np.asarray(mesh.vertex_colors)
        out.vertex_colors = np.vstack([C, C[src]])
    if mesh.vertex_filled is not None:
        f = np.asarray(mesh.vertex_filled)
        out.vertex_filled = np.concatenate([f, f[src]])
    out.vertex_props = {k: (np.concatenate([np.asarray(a), np.asarray(a)[src]])
                            if np.asarray(a).shape[:1] == (len(V),) else a)
                        for k, a in mesh.vertex_props.items()}


def _stages(progress, label, n):
    """A callable that reports one more of ``n`` stages done to ``progress``
    (a callback of :mod:`shellrepair.progress`; nothing when None); the
    start (0 of ``n``) is reported now."""
    if progress is None or progress is False:
        return lambda: None
    from shellrepair.progress import as_callback

    report = as_callback(progress)
    done = [0]
    report(label, 0, n)

    def stage():
        done[0] += 1
        report(label, done[0], n)

    return stage


def mesh_bytes(path, mesh, *, binary=True):
    """The bytes :func:`write_mesh` would write to ``path`` (format from its extension):
    ``bytes``, or a ``bytearray`` for binary PLY (built in place, one buffer).

    Raises
    ------
    MeshError
        For an unknown extension.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in SUPPORTED:
        raise MeshError(f"unknown output extension '{path.suffix}' (expected one of {', '.join(SUPPORTED)})", path)
    if _filled_library(path, mesh):
        from shellrepair.mesh.formats.mtl import companion_name

        return obj_bytes(as_written(mesh), binary, libraries=[f"mtllib {companion_name(path)}"])
    writer = WRITERS[ext]
    return writer(as_written(mesh), binary)


def _filled_library(path, mesh):
    """Whether an OBJ written to ``path`` comes with the filled faces' material
    library: a textured mesh (it has materials) with filled faces."""
    tex = getattr(mesh, "texture", None)
    filled = getattr(mesh, "face_filled", None)
    return (Path(path).suffix.lower() == ".obj" and tex is not None and bool(tex.materials)
            and filled is not None and bool(np.asarray(filled).any()))


def write_mesh(path: Union[str, os.PathLike], mesh: Mesh, *, binary: bool = True,
               progress: ProgressArg = None) -> None:
    """Write a mesh; PLY keeps colours and the ``filled`` flags.

    Parameters
    ----------
    path : str or Path
        Output file; its extension picks the format (.ply, .obj, .off, .stl).
    mesh : Mesh
    binary : bool
        For PLY and STL, write binary (default) or ascii.
    progress : callable, optional
        Called as ``progress("writing <file name>", done, 2)``: 0 at the
        start, 1 when the bytes are made, 2 when they are on disk (the
        protocol of :mod:`shellrepair.progress`). Default None.

    Notes
    -----
    The file is written to a temporary file in the same folder and renamed
    into place, so a failure leaves no partial output. A textured OBJ with
    filled faces comes with ``<stem>.filled.mtl`` beside it (named by an
    ``mtllib`` line after the scan's own), defining the filled faces'
    material in the scan's colour at their rims (:mod:`shellrepair.mesh.formats.mtl`);
    both files are written or neither.
    """
    path = Path(path)
    stage = _stages(progress, f"writing {path.name}", 2)
    payload = mesh_bytes(path, mesh, binary=binary)
    items = [(path, payload)]
    if _filled_library(path, mesh):
        # the filled faces' material, in the scan's colour at their rims
        from shellrepair.mesh.formats.mtl import companion_name, filled_library, rim_colour

        folder = Path(mesh.path).parent if mesh.path else path.parent
        items.append((path.parent / companion_name(path), filled_library(rim_colour(mesh, folder))))
    stage()
    check_output_path(path)
    atomic_write_many(items)
    stage()


def format_losses(path, mesh):
    """What the format of ``path`` cannot hold of ``mesh``, one line each
    (the CLI adds them to the report's notes and prints them).

    Parameters
    ----------
    path : str or Path
    mesh : Mesh

    Returns
    -------
    notes : list of str
    """
    ext = Path(path).suffix.lower()
    notes = []
    tex = getattr(mesh, "texture", None)
    if tex is not None and ext in (".off", ".stl") and (len(tex.uv) or tex.materials):
        notes.append(f"{ext[1:].upper()} output: the texture coordinates and materials are not written "
                     "(write .obj or .ply to keep them)")
    elif tex is not None and ext == ".ply" and tex.materials:
        notes.append("PLY output: the materials (usemtl, mtllib) are not written; the texture coordinates "
                     "are (write .obj to keep both)")
    elif tex is not None and ext == ".obj" and tex.face_texnumber is not None:
        notes.append("OBJ output: the faces' texnumber is not written (no usemtl or mtllib is made from "
                     "the TextureFile comments); the texture coordinates are (write .ply to keep both)")
    if ext in (".off", ".stl") and mesh.face_filled is not None and np.any(mesh.face_filled):
        notes.append(f"{ext[1:].upper()} output: no flag marks the filled faces "
                     "(the report lists each hole's new faces; .ply and .obj mark them)")
    return notes


def check_references(V, F):
    """Raise :class:`MeshError` where a face refers to a vertex outside
    ``V`` or to a vertex with a NaN or infinite coordinate (the checks
    :func:`read_mesh` makes; :func:`shellrepair.repair.repair_mesh` makes
    them on arrays it is given).

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    bad : (n,) bool array
        The vertices with a non-finite coordinate (no face uses them).
    """
    if F.size:
        lo, hi = F.min(), F.max()
        if lo < 0 or hi >= V.shape[0]:
            rows = np.flatnonzero(((F < 0) | (F >= V.shape[0])).any(axis=1))
            i = int(rows[0])
            raise MeshError(f"face {i} has vertex index {int(F[i][(F[i] < 0) | (F[i] >= V.shape[0])][0])} "
                            f"out of range 0..{V.shape[0] - 1}")
    bad = ~np.isfinite(V).all(axis=1)
    if bad.any():
        used = np.zeros(V.shape[0], bool)
        used[F.ravel()] = True
        bad_used = bad & used
        if bad_used.any():
            i = int(np.flatnonzero(bad_used)[0])
            raise MeshError(f"vertex {i} has a non-finite coordinate "
                            f"({int(bad_used.sum())} such vertices)")
    return bad


def _validate(mesh):
    V, F = mesh.V, mesh.F
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] == 0:
        raise MeshError("no vertices")
    if F.shape[0] == 0:
        raise MeshError("no faces: this is a point cloud, not a surface mesh")
    bad = check_references(V, F)
    if bad.any():
        # nothing refers to them: they are kept, like every unreferenced vertex
        mesh.notes.append(f"{int(bad.sum())} unreferenced vertices with NaN or infinite coordinates "
                          "kept as they are")
    if not bad.any() and -MAX_ABS_COORDINATE <= V.min() and V.max() <= MAX_ABS_COORDINATE:
        return   # the usual scan: all finite, none too large (two passes, no temporaries)
    with np.errstate(invalid="ignore"):
        huge = (np.abs(V) > MAX_ABS_COORDINATE).any(axis=1) & ~bad  # finite but too large
    if huge.any():
        i = int(np.flatnonzero(huge)[0])
        raise MeshError(f"vertex {i} has a coordinate beyond {MAX_ABS_COORDINATE:.0e} "
                        f"({int(huge.sum())} such vertices)")


def _used_vertex_count(F, n):
    used = np.zeros(int(n), bool)
    used[np.asarray(F).ravel()] = True
    return int(used.sum())
