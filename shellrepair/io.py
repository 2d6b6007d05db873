"""Reading and writing scans: PLY (ascii and binary), OBJ, OFF, STL.

What loading guarantees
-----------------------
* Vertices keep their order and their exact values. A PLY stored as
  ``float`` is read as float32 and widened to float64 (exact), and written
  back as float32, so the original coordinates round-trip bit for bit.
* Vertex colours (PLY ``red green blue [alpha]``, OBJ ``v x y z r g b``,
  OFF ``COFF``) are kept as ``uint8``; float colours (0..1) are converted
  and NaN channels set to 0, each with a note.
* What a triangle mesh does not hold is skipped with a note: OBJ ``vt``,
  ``vn``, ``l``, ``p`` and free-form statements, PLY elements other than
  vertex and face and face properties other than the index list, OFF face
  colours. The readers follow the specifications as exporters use them
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
  :func:`shellrepair.clean.make_manifold`). ``mesh.fixes`` counts each.
* Each piece is wound consistently (:func:`shellrepair.clean.orient_faces`):
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
report together.
"""

from __future__ import annotations

import itertools
import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import MeshError
from . import fastmesh
from .topology import edge_topology, face_areas

__all__ = ["Mesh", "read_mesh", "write_mesh", "mesh_bytes", "check_output_path", "clean_faces", "manifold_mesh",
           "atomic_write", "atomic_write_many", "MAX_ABS_COORDINATE"]

SUPPORTED = (".ply", ".obj", ".off", ".stl")

#: Largest coordinate magnitude accepted. Squared lengths and cross
#: products of larger values overflow float64 (max ~1.8e308); real scans in
#: millimetres stay below 1e9.
MAX_ABS_COORDINATE = 1e100

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_PLY_NAMES = {"i1": "char", "u1": "uchar", "i2": "short", "u2": "ushort",
              "i4": "int", "u4": "uint", "f4": "float", "f8": "double"}


#: Rows of ``V`` and of ``F`` sampled to notice in-place edits (:meth:`Mesh.cached`).
CACHE_SAMPLE = 4096


@dataclass
class Mesh:
    """A triangle mesh with the per-element data a scan carries.

    Attributes
    ----------
    V : (n,3) float64 array
        Vertex positions.
    F : (m,3) int64 array
        Triangle corner indices into ``V``.
    vertex_colors : (n,3) or (n,4) uint8 array or None
        Per-vertex colour, if the file has it.
    vertex_filled, face_filled : (n,) / (m,) bool arrays or None
        True for elements synthesized by a repair.
    vertex_props : dict of str -> (n,) array
        Other scalar vertex properties of a PLY (normals, quality, ...),
        kept so that writing loses nothing.
    vertex_dtype : str
        ``'f4'`` or ``'f8'``: how the file stored coordinates; used when
        writing so original values round-trip exactly.
    path : str or None
        Where it was read from.
    notes : list of str
        What loading changed (polygons split, faces dropped, ...).
    F_out : (k,3) int64 array or None
        How the first ``k`` faces are written, when that differs from ``F``:
        ``F`` joins coincident vertices for the topology, ``F_out`` keeps a
        corner's own vertex where its attributes differ (a seam). Faces
        after the first ``k`` (added by a repair) are written as in ``F``.
        Code that replaces ``F`` with other faces sets it to None.
    fixes : dict
        What :func:`manifold_mesh` did (see
        :data:`shellrepair.clean.FIX_COUNTS`); empty when it did not run.
    comments : list of str
        A PLY header's ``comment`` and ``obj_info`` lines as read (each with
        its keyword), written back before shellrepair's own comment.
    """

    V: np.ndarray
    F: np.ndarray
    vertex_colors: np.ndarray | None = None
    vertex_filled: np.ndarray | None = None
    face_filled: np.ndarray | None = None
    vertex_props: dict = field(default_factory=dict)
    vertex_dtype: str = "f8"
    path: str | None = None
    notes: list = field(default_factory=list)
    F_out: np.ndarray | None = None
    comments: list = field(default_factory=list)
    fixes: dict = field(default_factory=dict)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __repr__(self):
        """One line: sizes and what the mesh carries, never the arrays."""
        extra = []
        if self.vertex_colors is not None:
            extra.append("colours")
        if self.face_filled is not None:
            extra.append(f"{int(np.count_nonzero(self.face_filled))} filled faces")
        if self.vertex_props:
            extra.append("props " + ",".join(sorted(self.vertex_props)))
        where = f" from {Path(self.path).name!r}" if self.path else ""
        more = ("; " + "; ".join(extra)) if extra else ""
        return f"Mesh({self.n_vertices:,} vertices, {self.n_faces:,} faces{more}{where})"

    def cached(self, name):
        """Whole-mesh data :func:`read_mesh` computed on its way, or None
        (when it computed none, or ``V`` or ``F`` has changed since).

        ``name``: ``"topology"`` (:func:`shellrepair.topology.edge_topology`),
        ``"pieces"`` (``(n_pieces, face_piece)`` as
        :func:`shellrepair.topology.face_pieces` gives them) or
        ``"face_areas"``. A change is noticed when ``V`` or ``F`` is
        replaced, or edited in place on any of the evenly spaced rows kept
        as a sample (a unit conversion or a shift of the whole scan is); an
        in-place edit of a few rows may not be: then clear ``mesh._cache``.
        """
        entry = self._cache.get(name)
        if entry is None or entry[0] is not self.V or entry[1] is not self.F:
            return None
        if not all(np.array_equal(a[rows], sample) for a, rows, sample in zip((self.V, self.F), *entry[3])):
            return None
        return entry[2]

    def remember(self, name, value):
        """Keep ``value`` as :meth:`cached` ``name`` for the current ``V`` and ``F``."""
        rows = [np.linspace(0, len(a) - 1, min(len(a), CACHE_SAMPLE)).astype(np.int64) for a in (self.V, self.F)]
        self._cache[name] = (self.V, self.F, value, (rows, [a[r] for a, r in zip((self.V, self.F), rows)]))

    @property
    def n_vertices(self):
        return int(self.V.shape[0])

    @property
    def n_faces(self):
        return int(self.F.shape[0])


# --------------------------------------------------------------------------
# public entry points
# --------------------------------------------------------------------------
def read_mesh(path, *, clean=True, orient=True, progress=False):
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
        outward (see :func:`shellrepair.clean.orient_faces`). Only the corner
        order of some faces changes; vertices and face order never do.
        Default True.
    progress : bool
        Show the loading stages (parse, clean, orient, measure) as a bar on
        stderr when it is a terminal; the line is left open for the next
        bar (see :func:`shellrepair.progress.step`).

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
    reader = {".ply": _read_ply, ".obj": _read_obj, ".off": _read_off, ".stl": _read_stl}[ext]
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
            mesh.notes.extend(notes)
    except MeshError as exc:
        raise MeshError(exc.message, path) from None
    stage()
    if clean:
        mesh = manifold_mesh(mesh, orient=orient)
        if not len(mesh.F):
            raise MeshError("no usable faces: all faces repeat a position", path)
    elif orient:
        from .clean import orient_faces

        res = orient_faces(mesh.F, mesh.V)
        mesh.F = res.F
        mesh.notes.extend(res.notes)
        # built on the way: hole detection and repair reuse them
        if res.topo is not None:
            mesh.remember("topology", res.topo)
        if res.piece is not None:
            mesh.remember("pieces", (res.n_pieces, res.piece))
    stage()
    unused = mesh.n_vertices - _used_vertex_count(written_faces(mesh), mesh.n_vertices)
    if unused:
        joined = int(mesh.fixes.get("vertices_joined", 0))
        mesh.notes.append(f"{unused} unreferenced vertices kept (vertex order never changes"
                          + (f"; the file is written with {joined} coincident vertices joined)" if joined else ")"))
    areas = face_areas(mesh.V, mesh.F)
    mesh.remember("face_areas", areas)
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
        (:func:`shellrepair.clean.orient_faces`).
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
    non-manifold edges split (:func:`shellrepair.clean.make_manifold`);
    pieces oriented; vertices where pieces meet at a point split
    (:func:`shellrepair.clean.split_piece_junctions`). When the file gave
    coincident vertices different attributes (colours, normals, UVs, other
    PLY properties), ``F_out`` writes each corner with a vertex carrying its
    own attributes; with identical attributes the corner is written joined.
    """
    from .clean import FIX_COUNTS, make_manifold, orient_faces, split_piece_junctions
    from .topology import face_pieces

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
    Vx = np.vstack([V, V[src]]) if src.size else V
    piece = None
    flipped = False
    if orient and len(F):
        o = orient_faces(F, Vx, topo=topo)
        if o.n_flipped:
            flipped = True
            F = o.F
            if Ffile is not None:
                Ffile = Ffile.copy()
                Ffile[o.flipped, 1], Ffile[o.flipped, 2] = Ffile[o.flipped, 2], Ffile[o.flipped, 1]
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
                         f"{src2.size} new vertices at the same positions, appended")
            F, src = F2, np.concatenate([src, src2])
            Vx = np.vstack([V, V[src]])
            topo = None
    out = Mesh(V=Vx, F=F, vertex_colors=mesh.vertex_colors, vertex_filled=mesh.vertex_filled,
               face_filled=face_filled, vertex_props=dict(mesh.vertex_props), vertex_dtype=mesh.vertex_dtype,
               path=mesh.path, notes=notes, fixes={k: int(fixes.get(k, 0)) for k in FIX_COUNTS},
               comments=list(getattr(mesh, "comments", [])))
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
    if topo is not None and not flipped:
        # kept for hole detection and repair; after flips or a junction split
        # it no longer matches F, and is rebuilt by whoever needs it
        out.remember("topology", topo)
    if piece is not None:
        out.remember("pieces", piece)
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


def written_faces(mesh):
    """The faces as a file gets them: ``mesh.F_out`` where set, else ``mesh.F``.

    Parameters
    ----------
    mesh : Mesh

    Returns
    -------
    F : (m,3) int64 array
    """
    F = np.asarray(mesh.F, np.int64)
    W = getattr(mesh, "F_out", None)
    if W is None:
        return F
    W = np.asarray(W, np.int64)
    k = len(W)
    V = np.asarray(mesh.V)
    if k > len(F) or W.size and (W.max() >= len(V) or not np.array_equal(V[W], V[F[:k]])):
        return F  # F was replaced since: F_out no longer describes it
    return np.vstack([W, F[k:]]) if k < len(F) else W


def _stages(on, label, n):
    """A callable that reports one more of ``n`` stages done (nothing when off)."""
    if not on:
        return lambda: None
    from .progress import step

    done = [0]
    step(label, 0, n)

    def stage():
        done[0] += 1
        step(label, done[0], n)

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
    writer = {".ply": _ply_bytes, ".obj": _obj_bytes, ".off": _off_bytes, ".stl": _stl_bytes}[ext]
    return writer(mesh, binary)


def check_output_path(path, *, what="output"):
    """Raise :class:`MeshError` unless ``path`` can be written as a new or replaced file.

    Parameters
    ----------
    path : str or Path
    what : str
        Names the file in the message (``"output"``, ``"report"``).
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise MeshError(f"{what} folder does not exist", path)
    if path.is_dir():
        raise MeshError(f"{what} path is a directory", path)
    if path.exists() and not path.is_file():
        raise MeshError(f"{what} path exists and is not a regular file", path)
    if not os.access(path.parent, os.W_OK):
        raise MeshError(f"{what} folder is not writable", path)


def write_mesh(path, mesh, *, binary=True):
    """Write a mesh; PLY keeps colours and the ``filled`` flags.

    Parameters
    ----------
    path : str or Path
        Output file; its extension picks the format (.ply, .obj, .off, .stl).
    mesh : Mesh
    binary : bool
        For PLY and STL, write binary (default) or ascii.

    Notes
    -----
    The file is written to a temporary file in the same folder and renamed
    into place, so a failure leaves no partial output.
    """
    path = Path(path)
    payload = mesh_bytes(path, mesh, binary=binary)
    check_output_path(path)
    atomic_write(path, payload)


def new_file_mode():
    """Permissions of a newly created file under the current umask (0o666 & ~umask)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write(path, payload):
    """Write ``payload`` (bytes or str) to ``path`` through a temp file + rename."""
    atomic_write_many([(path, payload)])


def atomic_write_many(items):
    """Write several files, none of them partially.

    Parameters
    ----------
    items : list of (path, payload)
        ``payload`` is bytes or str (written as UTF-8).

    Notes
    -----
    Every payload goes to a temporary file beside its target (same folder,
    so the rename cannot cross file systems) and is flushed to disk; only
    when all are written are they renamed into place, in order, so a
    failure while writing (disk full, interrupted) leaves every target as
    it was. If a rename fails, the targets this call created are removed
    again (a target that existed before keeps its new content). Any
    failure removes the temporary files and raises :class:`MeshError`
    naming the target.
    """
    tmps = []
    created = []  # targets that did not exist before and were already renamed into place
    try:
        for path, payload in items:
            path = Path(path)
            if isinstance(payload, str):
                payload = payload.encode("utf-8")
            try:
                fd, tmp = tempfile.mkstemp(prefix="." + path.name + ".", suffix=".tmp", dir=str(path.parent))
            except OSError as exc:
                raise MeshError(f"cannot write: {exc.strerror or exc}", path) from None
            tmps.append((tmp, path))
            try:
                os.fchmod(fd, new_file_mode())  # as a plain open() would, not mkstemp's 0600
                with os.fdopen(fd, "wb") as fh:
                    fh.write(payload)
                    fh.flush()
                    os.fsync(fh.fileno())
            except OSError as exc:
                raise MeshError(f"cannot write: {exc.strerror or exc}", path) from None
        for i, (tmp, path) in enumerate(tmps):
            existed = path.exists()
            try:
                os.replace(tmp, path)
            except OSError as exc:
                raise MeshError(f"cannot write: {exc.strerror or exc}", path) from None
            tmps[i] = (None, path)
            if not existed:
                created.append(path)
    except BaseException:
        for path in created:  # a later target failed: take back the new files of this call
            try:
                os.unlink(path)
            except OSError:
                pass
        raise
    finally:
        for tmp, _ in tmps:
            if tmp is not None and os.path.exists(tmp):
                os.unlink(tmp)


def clean_faces(F):
    """Drop faces that repeat a vertex and exact duplicate faces.

    Parameters
    ----------
    F : (m,3) int64 array

    Returns
    -------
    F_clean : (k,3) int64 array
        Kept faces, in their original order (``F`` itself when none is
        dropped).
    kept : (k,) int64 array
        Indices into ``F`` of the kept faces.
    notes : list of str
        One line per kind of face dropped.
    """
    F = np.asarray(F, dtype=np.int64)
    notes = []
    ok = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])
    n_degen = int((~ok).sum())
    idx = np.flatnonzero(ok)
    # duplicates share their sorted vertex triple, hence its hash; only the
    # faces whose hash value repeats (all duplicates, and rare collisions)
    # are grouped exactly, so a scan without duplicates sorts one array
    G = F if n_degen == 0 else F[idx]
    h = fastmesh.triple_hash(G) if fastmesh.enabled(len(G)) else _triple_hash(G)
    del G
    hs = np.sort(h)
    rep = np.unique(hs[1:][hs[1:] == hs[:-1]])
    del hs
    keep = np.ones(len(idx), bool)
    if rep.size:
        cand = np.flatnonzero(rep[np.minimum(np.searchsorted(rep, h), rep.size - 1)] == h)
        S = np.sort(F[idx[cand]], axis=1)
        # stable: the first face of a group of duplicates comes first
        order = np.lexsort((S[:, 2], S[:, 1], S[:, 0]))
        Ss = S[order]
        later = np.zeros(len(Ss), bool)
        later[1:] = (Ss[1:] == Ss[:-1]).all(axis=1)
        keep[cand[order[later]]] = False
    kept = idx[keep] if rep.size or n_degen else idx
    n_dup = len(idx) - len(kept)
    if n_degen:
        notes.append(f"{n_degen} faces with a repeated vertex dropped")
    if n_dup:
        notes.append(f"{n_dup} duplicate faces dropped")
    if len(kept) == len(F):   # nothing dropped (the usual scan): no copy of F
        return F, kept, notes
    return F[kept], kept, notes


def _triple_hash(F):
    """A 64-bit hash of each row's vertex set (equal for equal sets in any order)."""
    x, y, z = F[:, 0], F[:, 1], F[:, 2]
    a = np.minimum(x, y)
    np.minimum(a, z, out=a)
    c = np.maximum(x, y)
    np.maximum(c, z, out=c)
    b = x + y
    b += z
    b -= a
    b -= c
    # in place, as unsigned 64-bit words (products wrap around)
    h, b, c = a.view(np.uint64), b.view(np.uint64), c.view(np.uint64)
    h *= np.uint64(0x9E3779B97F4A7C15)
    b *= np.uint64(0xC2B2AE3D27D4EB4F)
    h ^= b
    c *= np.uint64(0x165667B19E3779F9)
    h ^= c
    del b, c
    h ^= h >> np.uint64(29)
    return h


# --------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------
def _validate(mesh):
    V, F = mesh.V, mesh.F
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] == 0:
        raise MeshError("no vertices")
    if F.shape[0] == 0:
        raise MeshError("no faces: this is a point cloud, not a surface mesh")
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


# --------------------------------------------------------------------------
# shared by the readers
# --------------------------------------------------------------------------
#: Bytes that separate tokens in the text formats (those ``bytes.split()`` splits on).
_WS = np.zeros(256, bool)
_WS[[9, 10, 11, 12, 13, 32]] = True


def _token_starts(x):
    """Where each token of the bytes ``x`` (uint8 array) starts, as ``bytes.split()`` splits."""
    ws = x <= 32
    if np.count_nonzero(ws) != np.count_nonzero(x == 32) + np.count_nonzero((x - np.uint8(9)) <= 4):
        ws = _WS[x]  # control bytes that do not separate tokens: look each byte up
    first = ~ws
    first[1:] &= ws[:-1]
    return first


def _token_counts(text, starts=None):
    """Tokens on each line of ``text`` (bytes, lines ended by ``\\n``), as ``bytes.split()`` finds them.

    Parameters
    ----------
    text : bytes
    starts : (k,) int64 array, optional
        Where the tokens start (``np.flatnonzero(_token_starts(x))``), if known.

    Returns
    -------
    counts : (text.count(b"\\n") + 1,) int64 array
    """
    x = np.frombuffer(text, np.uint8)
    at = np.concatenate([[0], np.flatnonzero(x == 10) + 1, [x.size]])
    if starts is None:
        starts = np.flatnonzero(_token_starts(x)) if x.size else np.zeros(0, np.int64)
    return np.diff(np.searchsorted(starts, at)).astype(np.int64)


def _parse_numbers(text, dtype, n, where):
    """The ``n`` whitespace-separated numbers of ``text`` (bytes) as a ``dtype`` array.

    Parsed in one pass when every token is one number; otherwise token by
    token, and the first bad token raises :class:`MeshError` with the message
    ``where(i, token)`` (``i`` counts tokens from 0). Returns an array of
    another length only when ``n`` is not the number of tokens.
    """
    try:
        vals = np.fromstring(text, dtype=dtype, sep=" ")
        if vals.size == n:
            return vals
    except ValueError:  # a token that is not a number
        pass
    return _to_numbers(text.split(), dtype, where)


def _to_numbers(tokens, dtype, where):
    """``tokens`` (list of bytes) as a ``dtype`` array; a bad token raises MeshError(``where(i, token)``)."""
    try:
        return np.array(tokens, dtype=dtype)
    except (ValueError, OverflowError):
        conv = float if np.dtype(dtype).kind == "f" else int
        for i, t in enumerate(tokens):
            try:
                v = conv(t)
                if conv is int and not -2**63 <= v < 2**63:
                    raise OverflowError
            except (ValueError, OverflowError):
                raise MeshError(where(i, t.decode("utf-8", errors="replace")[:40])) from None
        raise


def _colors_to_uint8(C, notes, what, unit=None):
    """Vertex colours as uint8, whatever the file stored.

    Parameters
    ----------
    C : (n,k) array
        k = 3 (RGB) or 4 (RGBA), any numeric dtype.
    notes : list of str
        Gets one line per conversion that is not the identity.
    what : str
        Names the source in the notes (``"PLY"``, ``"OBJ"``, ``"OFF"``).
    unit : bool or None
        True: floats are in 0..1 (the PLY convention for float colours);
        None: floats are 0..1 when none exceeds 1, else 0..255.

    Returns
    -------
    colors : (n,k) uint8 array
        NaN or infinite channels become 0 (alpha 255), with a note.
    """
    C = np.asarray(C)
    if C.dtype == np.uint8:
        return C
    k = C.shape[1]
    X = C.astype(np.float64)
    bad = ~np.isfinite(X)
    if bad.any():
        X[bad] = 0.0
        notes.append(f"{what}: {int(bad.any(axis=1).sum())} vertex colours with NaN or infinite "
                     "channels: those channels set to 0 (alpha to 255)")
    if C.dtype.kind == "f":
        if unit or (unit is None and X.max(initial=0.0) <= 1.0):
            X = X * 255.0
            notes.append(f"{what}: vertex colours stored as floats 0..1 converted to 8 bits")
        else:
            notes.append(f"{what}: vertex colours stored as floats 0..255 rounded to 8 bits")
    elif C.dtype.itemsize > 1 and X.max(initial=0.0) > 255:
        X = X / 257.0  # 16-bit channels
        notes.append(f"{what}: 16-bit vertex colours reduced to 8 bits")
    X = np.rint(X)
    out_of_range = (X < 0) | (X > 255)
    if out_of_range.any():
        notes.append(f"{what}: {int(out_of_range.any(axis=1).sum())} vertex colours outside 0..255 clipped")
    out = np.clip(X, 0, 255).astype(np.uint8)
    if k == 4:
        out[bad[:, 3], 3] = 255
    return out


def _polygons_to_triangles(polys, notes, V=None):
    """Split polygons into triangles that stay inside them; returns (m,3) int64.

    Parameters
    ----------
    polys : list of lists of int, or (counts, flat) pair of int arrays
        Corner indices, in the polygon's winding; as a pair, polygon ``i``
        has ``counts[i]`` corners, stored one polygon after the other in
        ``flat``.
    notes : list of str
        Gets one line per kind of change.
    V : (n,3) float64 array, optional
        Vertex positions. Without them (or with an index out of range,
        which validation reports later) polygons are fanned from corner 0.

    Notes
    -----
    Triangles are kept as they are, in file order; each polygon's triangles
    take its place. A quad is split along 0-2 unless that diagonal lies
    outside it (corners 1 and 3 on the same side), then along 1-3. Larger
    polygons are ear clipped in the plane of their Newell normal, which
    keeps every triangle inside a non-convex outline; a polygon with no ear
    (self-crossing) is fanned. All triangles keep the polygon's winding.
    Faces with fewer than 3 corners are dropped.
    """
    if isinstance(polys, tuple):
        counts = np.asarray(polys[0], np.int64)
        flat = np.asarray(polys[1], np.int64)
    else:
        counts = np.fromiter(map(len, polys), np.int64, len(polys))
        flat = np.fromiter(itertools.chain.from_iterable(polys), np.int64, int(counts.sum()))
    if counts.size and (counts == 3).all():
        return flat.reshape(-1, 3)
    off = np.zeros(len(counts), np.int64)
    np.cumsum(counts[:-1], out=off[1:])
    ntri = np.maximum(counts - 2, 0)
    at = np.zeros(len(counts), np.int64)  # first output row of each polygon
    np.cumsum(ntri[:-1], out=at[1:])
    out = np.empty((int(ntri.sum()), 3), np.int64)
    n = 0 if V is None else len(V)
    inside = np.zeros(len(counts), bool)  # every corner indexes V
    nz = np.flatnonzero(counts > 0)
    if n and nz.size:
        inside[nz] = (np.minimum.reduceat(flat, off[nz]) >= 0) & (np.maximum.reduceat(flat, off[nz]) < n)

    k3 = np.flatnonzero(counts == 3)
    out[at[k3]] = flat[off[k3, None] + np.arange(3)]
    k4 = np.flatnonzero(counts == 4)
    if k4.size:
        Q = flat[off[k4, None] + np.arange(4)]
        use13 = np.zeros(len(k4), bool)
        ok = inside[k4]
        if ok.any():
            with np.errstate(invalid="ignore", over="ignore"):
                P = V[Q[ok]]
                n1 = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])  # triangle 0-1-2
                n2 = np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0])  # triangle 0-2-3
                use13[ok] = np.einsum("ij,ij->i", n1, n2) < 0  # 1 and 3 on one side of 0-2: 0-2 lies outside
        out[at[k4]] = np.where(use13[:, None], Q[:, [1, 2, 3]], Q[:, [0, 1, 2]])
        out[at[k4] + 1] = np.where(use13[:, None], Q[:, [1, 3, 0]], Q[:, [0, 2, 3]])
    for i in np.flatnonzero(counts > 4).tolist():
        p = flat[off[i]:off[i] + counts[i]].tolist()
        tris = _ear_clip(V, p) if inside[i] else [(p[0], p[j], p[j + 1]) for j in range(1, len(p) - 1)]
        out[at[i]:at[i] + len(tris)] = tris
    n_poly = int(np.count_nonzero(counts > 3))
    n_small = int(np.count_nonzero(counts < 3))
    if n_poly:
        notes.append(f"{n_poly} polygons with more than 3 corners split into triangles")
    if n_small:
        notes.append(f"{n_small} faces with fewer than 3 corners dropped")
    return out


def _ear_clip(V, poly):
    """Ear clipping of one polygon in the plane of its Newell normal."""
    idx = list(poly)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        P = np.asarray(V, np.float64)[idx]
        P = P - P.mean(axis=0)
        nrm = np.sum(np.cross(P, np.roll(P, -1, axis=0)), axis=0)  # Newell normal (twice the vector area)
        ln = np.linalg.norm(nrm)
        if not np.isfinite(ln) or ln == 0:
            return [(idx[0], idx[j], idx[j + 1]) for j in range(1, len(idx) - 1)]
        nrm = nrm / ln
        t = np.array([1.0, 0.0, 0.0]) if abs(nrm[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(nrm, t)
        u /= np.linalg.norm(u)
        w = np.cross(nrm, u)
        xy = np.column_stack([P @ u, P @ w]).tolist()  # counter-clockwise seen along nrm

    def cross2(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    rest = list(range(len(idx)))
    out = []
    while len(rest) > 3:
        for j in range(len(rest)):
            i0, i1, i2 = rest[j - 1], rest[j], rest[(j + 1) % len(rest)]
            a, b, c = xy[i0], xy[i1], xy[i2]
            if cross2(a, b, c) <= 0:
                continue  # reflex or flat corner: not an ear
            inside = False
            for r in rest:
                if r in (i0, i1, i2):
                    continue
                q = xy[r]
                if cross2(a, b, q) >= 0 and cross2(b, c, q) >= 0 and cross2(c, a, q) >= 0:
                    inside = True
                    break
            if not inside:
                out.append((idx[i0], idx[i1], idx[i2]))
                del rest[j]
                break
        else:  # no ear: a self-crossing outline; fan what is left
            out.extend((idx[rest[0]], idx[rest[j]], idx[rest[j + 1]]) for j in range(1, len(rest) - 1))
            return out
    out.append(tuple(idx[r] for r in rest))
    return out


# --------------------------------------------------------------------------
# PLY
# --------------------------------------------------------------------------
def _parse_ply_header(data):
    end = data.find(b"end_header")
    if not data.startswith(b"ply"):
        raise MeshError("not a PLY file (missing 'ply' magic)")
    if end < 0:
        raise MeshError("PLY header has no 'end_header'")
    nl = data.find(b"\n", end)
    body_start = len(data) if nl < 0 else nl + 1
    lines = data[:end].decode("ascii", errors="replace").splitlines()
    fmt = None
    elements = []
    for lineno, raw in enumerate(lines, 1):
        tok = raw.split()
        if not tok or tok[0] in ("ply", "comment", "obj_info"):
            continue
        if tok[0] == "format":
            if len(tok) < 2 or tok[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise MeshError(f"PLY header line {lineno}: unknown format '{raw.strip()}'")
            fmt = tok[1]
        elif tok[0] == "element":
            if len(tok) != 3 or not tok[2].lstrip("-").isdigit():
                raise MeshError(f"PLY header line {lineno}: bad element line '{raw.strip()}'")
            count = int(tok[2])
            if count < 0:
                raise MeshError(f"PLY header line {lineno}: negative element count")
            elements.append({"name": tok[1], "count": count, "props": []})
        elif tok[0] == "property":
            if not elements:
                raise MeshError(f"PLY header line {lineno}: property before any element")
            if len(tok) > 1 and tok[1] == "list":
                if len(tok) != 5 or tok[2] not in _PLY_TYPES or tok[3] not in _PLY_TYPES:
                    raise MeshError(f"PLY header line {lineno}: bad list property '{raw.strip()}'")
                if _PLY_TYPES[tok[2]][0] == "f":
                    raise MeshError(f"PLY header line {lineno}: list length of type '{tok[2]}' "
                                    "(must be an integer type)")
                elements[-1]["props"].append((tok[4], "list", _PLY_TYPES[tok[2]], _PLY_TYPES[tok[3]]))
            else:
                if len(tok) != 3 or tok[1] not in _PLY_TYPES:
                    raise MeshError(f"PLY header line {lineno}: bad property '{raw.strip()}'")
                elements[-1]["props"].append((tok[2], "scalar", _PLY_TYPES[tok[1]], None))
        else:
            raise MeshError(f"PLY header line {lineno}: unknown keyword '{tok[0]}'")
    if fmt is None:
        raise MeshError("PLY header has no 'format' line")
    return fmt, elements, body_start


#: Names of vertex colour channels, in the order they are looked for.
_PLY_COLOR_NAMES = (("red", "green", "blue", "alpha"),
                    ("diffuse_red", "diffuse_green", "diffuse_blue", "diffuse_alpha"),
                    ("r", "g", "b", "a"))
#: Names of the face element's vertex index list.
_PLY_INDEX_NAMES = ("vertex_indices", "vertex_index")


def _ply_comments(data):
    """The header's ``comment`` and ``obj_info`` lines, keyword included."""
    end = data.find(b"end_header")
    lines = data[:max(end, 0)].decode("ascii", errors="replace").splitlines()
    return [ln.strip() for ln in lines if ln.split()[:1] in (["comment"], ["obj_info"])
            and ln.strip() != "comment written by shellrepair"]


def _read_ply(data):
    fmt, elements, pos = _parse_ply_header(data)
    names = [e["name"] for e in elements]
    if "vertex" not in names:
        raise MeshError("PLY has no vertex element")
    if "face" not in names:
        raise MeshError("no faces: this is a point cloud, not a surface mesh")
    notes = []
    if fmt == "ascii":
        tables = _ply_ascii_body(data[pos:], elements, notes)
    else:
        endian = "<" if fmt == "binary_little_endian" else ">"
        tables = _ply_binary_body(data, pos, elements, endian)
    vert = tables["vertex"]
    for c in "xyz":
        if c not in vert:
            raise MeshError(f"PLY vertex element has no '{c}' property")
    # float coordinates keep their width; anything else is written back as double
    vdt = "f4" if all(vert[c].dtype.kind == "f" and vert[c].dtype.itemsize == 4 for c in "xyz") else "f8"
    V = np.column_stack([vert[c].astype(np.float64) for c in "xyz"])
    mesh = Mesh(V=V, F=np.zeros((0, 3), np.int64), vertex_dtype=vdt)
    skip = {"x", "y", "z", "filled"}
    for cn in _PLY_COLOR_NAMES:
        if all(c in vert for c in cn[:3]):
            cn = cn if cn[3] in vert else cn[:3]
            cols = [vert[c] for c in cn]
            if all(c.dtype == np.uint8 for c in cols):
                mesh.vertex_colors = np.column_stack(cols)
            else:
                kind = "f" if any(c.dtype.kind == "f" for c in cols) else "i"
                C = np.column_stack([c.astype(np.float64 if kind == "f" else np.int64) for c in cols])
                mesh.vertex_colors = _colors_to_uint8(C, notes, "PLY", unit=True)
            skip.update(cn)
            break
    for name, arr in vert.items():
        if name not in skip and not name.startswith("__") and arr.ndim == 1:
            mesh.vertex_props[name] = arr
    if "filled" in vert:
        mesh.vertex_filled = vert["filled"].astype(bool)
    face = tables["face"]
    if "__F__" not in face and "__polys__" not in face:
        raise MeshError("PLY face element has no vertex index list")
    if "__polys__" in face:
        mesh.F = _polygons_to_triangles(face["__polys__"], notes, V)
    else:
        mesh.F = np.asarray(face["__F__"], dtype=np.int64).reshape(-1, 3)
        if "filled" in face:
            mesh.face_filled = face["filled"].astype(bool)
    dropped = [p[0] for p in next(e for e in elements if e["name"] == "face")["props"]
               if p[0] not in _PLY_INDEX_NAMES and not (p[0] == "filled" and "__polys__" not in face)]
    if dropped:
        notes.append(f"PLY: face properties not kept: {', '.join(dropped)}")
    others = [f"{e['name']} ({e['count']})" for e in elements if e["name"] not in ("vertex", "face")]
    if others:
        notes.append(f"PLY: elements skipped: {', '.join(others)}")
    mesh.notes.extend(notes)
    mesh.comments = _ply_comments(data)
    return mesh


def _ply_binary_body(data, pos, elements, endian):
    tables = {}
    for el in elements:
        props, count, name = el["props"], el["count"], el["name"]
        if all(p[1] == "scalar" for p in props):
            dt = np.dtype([(p[0], endian + p[2]) for p in props])
            need = dt.itemsize * count
            if pos + need > len(data):
                raise MeshError(f"truncated: {name} data needs {need} bytes, "
                                f"{max(0, len(data) - pos)} left")
            arr = np.frombuffer(data, dtype=dt, count=count, offset=pos)
            pos += need
            tables[name] = {p[0]: arr[p[0]] for p in props}
            continue
        tab, pos = _ply_binary_lists(data, pos, el, endian)
        tables[name] = tab
    if pos < len(data) and data[pos:].strip(b"\x00\r\n\t ") and len(data) - pos > 0:
        # trailing bytes are tolerated but only if they are whitespace/padding
        raise MeshError(f"header disagrees with body: {len(data) - pos} bytes after the last element")
    return tables


_STRUCT_CODES = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "f4": "f", "f8": "d"}


def _ply_list_table(props, scalars, lists, count):
    """The table of an element with list properties: scalars by name, the
    vertex index list as ``__F__`` (all triangles) or ``__polys__`` (counts, flat)."""
    tab = dict(scalars)
    idx_name = next((p[0] for p in props if p[1] == "list" and p[0] in _PLY_INDEX_NAMES), None)
    if idx_name is None:
        return tab
    counts, flat = lists[idx_name]
    if np.ndim(counts) == 0:  # every record has this many corners
        counts = int(counts)
        if counts == 3:
            tab["__F__"] = flat.reshape(-1, 3)
            return tab
        counts = np.full(count, counts, np.int64)
    if counts.size == count and (counts == 3).all():
        tab["__F__"] = flat.reshape(-1, 3)
    else:
        tab["__polys__"] = (counts, flat)
    return tab


def _ply_binary_lists(data, pos, el, endian):
    """Element with list properties.

    When every record has the list lengths of the first (all triangles, all
    quads, a fixed-length texcoord list...), the element is one structured
    array; otherwise records are walked one by one to find where each starts.
    """
    props, count, name = el["props"], el["count"], el["name"]
    if count == 0:
        return _ply_list_table(props, {p[0]: np.zeros(0, endian + p[2]) for p in props if p[1] == "scalar"},
                               {p[0]: (np.zeros(0, np.int64), np.zeros(0, np.int64)) for p in props
                                if p[1] == "list"}, 0), pos
    # lengths of the first record's lists
    first, at = [], pos
    for p in props:
        if p[1] == "scalar":
            at += np.dtype(p[2]).itemsize
            continue
        cdt = np.dtype(endian + p[2])
        if at + cdt.itemsize > len(data):
            raise MeshError(f"truncated: {name} 0 of {count} is cut off")
        k = int(np.frombuffer(data, cdt, 1, at)[0])
        if k < 0:
            raise MeshError(f"{name} 0: negative list length {k}")
        first.append(k)
        at += cdt.itemsize + k * np.dtype(p[3]).itemsize
    fields, j = [], 0
    for p in props:
        if p[1] == "scalar":
            fields.append((p[0], endian + p[2]))
        else:
            fields += [(f"__n{j}__", endian + p[2]), (p[0], endian + p[3], (first[j],))]
            j += 1
    dt = np.dtype(fields)
    need = dt.itemsize * count
    avail = min(count, max(0, len(data) - pos) // dt.itemsize)
    arr = np.frombuffer(data, dtype=dt, count=avail, offset=pos)
    same = all((arr[f"__n{j}__"] == k).all() for j, k in enumerate(first))
    if same and avail < count:
        raise MeshError(f"truncated: {name} data needs {need} bytes, {max(0, len(data) - pos)} left")
    if same:
        scalars = {p[0]: arr[p[0]] for p in props if p[1] == "scalar"}
        lists = {p[0]: (first[j], arr[p[0]].reshape(-1).astype(np.int64))
                 for j, p in enumerate(p for p in props if p[1] == "list") if p[3][0] != "f"}
        return _ply_list_table(props, scalars, lists, count), pos + need
    return _ply_binary_walk(data, pos, el, endian)


def _gather(b, at, dt):
    """Values of dtype ``dt`` stored at byte offsets ``at`` of the bytes ``b``
    (one value per offset, any alignment)."""
    return b[at[:, None] + np.arange(dt.itemsize)].reshape(-1).view(dt)


def _ply_binary_walk(data, pos, el, endian):
    """Element with list properties of varying length: walk the records, then gather."""
    import struct

    props, count, name = el["props"], el["count"], el["name"]
    plan = []
    for p in props:
        if p[1] == "scalar":
            plan.append((np.dtype(p[2]).itemsize, None, 0))
        else:
            plan.append((np.dtype(p[2]).itemsize, struct.Struct(endian + _STRUCT_CODES[p[2]]).unpack_from,
                         np.dtype(p[3]).itemsize))
    where = [[] for _ in props]   # byte offset of each scalar / of each list's first item
    lens = [[] for _ in props]
    n = len(data)
    one = [j for j, p in enumerate(props) if p[1] == "list"]
    if len(one) == 1 and props[one[0]][2] in ("u1", "i1") and count:
        return _ply_binary_walk_one(data, pos, el, endian, one[0])
    for i in range(count):
        for j, (size, unpack, isz) in enumerate(plan):
            if pos + size > n:
                raise MeshError(f"truncated: {name} {i} of {count} is cut off")
            if unpack is None:
                where[j].append(pos)
                pos += size
                continue
            k = unpack(data, pos)[0]
            if k < 0:
                raise MeshError(f"{name} {i}: negative list length {k}")
            pos += size
            where[j].append(pos)
            lens[j].append(k)
            pos += k * isz
            if pos > n:
                raise MeshError(f"truncated: {name} {i} of {count} is cut off")
    b = np.frombuffer(data, np.uint8)
    scalars, lists = {}, {}
    for j, p in enumerate(props):
        at = np.asarray(where[j], np.int64)
        if p[1] == "scalar":
            dt = np.dtype(endian + p[2])
            scalars[p[0]] = _gather(b, at, dt)
            continue
        if p[3][0] == "f":
            continue  # float lists (texture coordinates) are not kept
        dt = np.dtype(endian + p[3])
        k = np.asarray(lens[j], np.int64)
        start = np.repeat(at - np.concatenate([[0], np.cumsum(k)[:-1]]) * dt.itemsize, k)
        item = start + np.arange(int(k.sum()), dtype=np.int64) * dt.itemsize
        flat = _gather(b, item, dt).astype(np.int64)
        lists[p[0]] = (k, flat)
    return _ply_list_table(props, scalars, lists, count), pos


def _ply_binary_walk_one(data, pos, el, endian, j0):
    """:func:`_ply_binary_walk` for the usual face record: one list, whose
    length is one byte; the walk reads just that byte of each record."""
    props, count, name = el["props"], el["count"], el["name"]
    sizes = [np.dtype(p[2]).itemsize for p in props]
    before = sum(sizes[:j0])
    step = sum(sizes)  # a record's bytes less its list items
    isz = np.dtype(props[j0][3]).itemsize
    ks = []
    at = pos + before
    try:
        for _ in range(count):
            k = data[at]
            ks.append(k)
            at += step + k * isz
    except IndexError:
        raise MeshError(f"truncated: {name} {len(ks)} of {count} is cut off") from None
    k = np.array(ks, np.int64)
    if props[j0][2] == "i1":
        k = k.astype(np.uint8).view(np.int8).astype(np.int64)
        if (k < 0).any():
            i = int(np.flatnonzero(k < 0)[0])
            raise MeshError(f"{name} {i}: negative list length {int(k[i])}")
    rec = np.zeros(count, np.int64)  # where each record starts
    np.cumsum(step + k[:-1] * isz, out=rec[1:])
    rec += pos
    end = int(rec[-1]) + step + int(k[-1]) * isz
    if end > len(data):
        raise MeshError(f"truncated: {name} {count - 1} of {count} is cut off")
    b = np.frombuffer(data, np.uint8)
    scalars, lists = {}, {}
    for j, p in enumerate(props):
        at = rec + sum(sizes[:j]) + (k * isz if j > j0 else 0)
        if j != j0:
            dt = np.dtype(endian + p[2])
            scalars[p[0]] = _gather(b, at, dt)
            continue
        if p[3][0] == "f":
            continue  # float lists (texture coordinates) are not kept
        dt = np.dtype(endian + p[3])
        first = np.zeros(count, np.int64)
        np.cumsum(k[:-1], out=first[1:])
        item = np.repeat(at + sizes[j0] - first * dt.itemsize, k) + np.arange(int(k.sum()), dtype=np.int64) * dt.itemsize
        lists[p[0]] = (k, _gather(b, item, dt).astype(np.int64))
    return _ply_list_table(props, scalars, lists, count), end


def _ply_ascii_cast(col, code, name, prop, notes):
    """An ascii column (float64) as PLY type ``code``; integers that are not numbers or
    out of the type's range are set to 0 or clipped, with a note."""
    dt = np.dtype(code)
    if dt.kind == "f":
        with np.errstate(over="ignore"):
            return col.astype(dt)
    info = np.iinfo(dt)
    bad = ~np.isfinite(col)
    if bad.any():
        notes.append(f"PLY: {name} property '{prop}': {int(bad.sum())} values are not numbers, read as 0")
        col = np.where(bad, 0.0, col)
    out = (col < info.min) | (col > info.max)
    if out.any():
        notes.append(f"PLY: {name} property '{prop}': {int(out.sum())} values outside "
                     f"{info.min}..{info.max} clipped")
        col = np.clip(col, info.min, info.max)
    return col.astype(dt)


def _ply_ascii_body(body, elements, notes):
    """The elements of an ascii PLY body: one line per record, blank lines skipped."""
    x = np.frombuffer(body, np.uint8)
    at = np.concatenate([[0], np.flatnonzero(x == 10) + 1, [x.size]])
    cnt = _token_counts(body)
    rows = np.flatnonzero(cnt)
    total = sum(el["count"] for el in elements)
    if len(rows) != total:
        announced = ", ".join(f"{el['count']} {el['name']}" for el in elements)
        raise MeshError(f"header disagrees with body: header announces {announced} lines "
                        f"({total}), body has {len(rows)}")
    tables = {}
    done = 0
    for el in elements:
        r = rows[done:done + el["count"]]
        done += el["count"]
        text = body[at[r[0]]:at[r[-1] + 1]] if len(r) else b""
        tables[el["name"]] = _ply_ascii_element(text, cnt[r], el["props"], el["count"], el["name"], notes)
    return tables


def _ply_ascii_element(text, per_line, props, count, name, notes):
    """One element of an ascii PLY body.

    Parameters
    ----------
    text : bytes
        Its ``count`` lines (and any blank lines between them).
    per_line : (count,) int64 array
        Values on each of those lines.

    Notes
    -----
    All values are parsed at once; then each property is taken from every
    record together, a cursor per record moving past scalars and lists, so
    records of different lengths (triangles and quads, texture coordinate
    lists) need no loop over records.
    """
    if count == 0:
        return _ply_list_table(props, {p[0]: np.zeros(0, p[2]) for p in props if p[1] == "scalar"},
                               {p[0]: (np.zeros(0, np.int64), np.zeros(0, np.int64)) for p in props
                                if p[1] == "list"}, 0)
    if all(p[1] == "scalar" for p in props) and (per_line != len(props)).any():
        raise MeshError(f"header disagrees with body: {name} lines should have {len(props)} values each")
    off = np.zeros(count, np.int64)
    np.cumsum(per_line[:-1], out=off[1:])
    end = off + per_line
    vals = _parse_numbers(text, np.float64, int(per_line.sum()), lambda j, t: (
        f"{name} {np.searchsorted(off, j, side='right') - 1}: bad number '{t}'"))
    cur = off.copy()
    scalars, lists = {}, {}
    for p in props:
        short = np.flatnonzero(cur >= end)
        if short.size:
            raise MeshError(f"{name} {int(short[0])}: missing {'value' if p[1] == 'scalar' else 'list'} '{p[0]}'")
        if p[1] == "scalar":
            scalars[p[0]] = _ply_ascii_cast(vals[cur], p[2], name, p[0], notes)
            cur += 1
            continue
        k = vals[cur]
        bad = np.flatnonzero(~(k >= 0) | (k != np.floor(k)))
        if bad.size:
            raise MeshError(f"{name} {int(bad[0])}: bad list length '{k[bad[0]]:g}'")
        k = k.astype(np.int64)
        over = np.flatnonzero(cur + 1 + k > end)
        if over.size:
            i = int(over[0])
            raise MeshError(f"{name} {i}: list announces {int(k[i])} values, has {int(end[i] - cur[i] - 1)}")
        if p[3][0] != "f":  # float lists (texture coordinates) are not kept
            first = np.zeros(count, np.int64)
            np.cumsum(k[:-1], out=first[1:])
            L = vals[np.repeat(cur + 1 - first, k) + np.arange(int(k.sum()))]
            if not (L == np.round(L)).all():  # NaN fails too
                raise MeshError(f"{name}: list '{p[0]}' holds values that are not integers")
            lists[p[0]] = (int(k[0]) if (k == k[0]).all() else k, L.astype(np.int64))
        cur += 1 + k
    extra = np.flatnonzero(cur < end)
    if extra.size:
        i = int(extra[0])
        raise MeshError(f"{name} {i}: {int(end[i] - cur[i])} values more than the header announces")
    return _ply_list_table(props, scalars, lists, count)


def _ply_bytes(mesh, binary=True):
    V = np.asarray(mesh.V, dtype=np.float64)
    F = written_faces(mesh)
    n, m = len(V), len(F)
    vdt = mesh.vertex_dtype if mesh.vertex_dtype in ("f4", "f8") else "f8"
    endian = "<"
    vfields = [(c, endian + vdt) for c in "xyz"]
    vcols = {c: V[:, j] for j, c in enumerate("xyz")}
    for name, arr in mesh.vertex_props.items():
        arr = np.asarray(arr)
        if arr.shape == (n,) and arr.dtype.str[1:] in _PLY_NAMES:
            vfields.append((name, endian + arr.dtype.str[1:]))
            vcols[name] = arr
    if mesh.vertex_colors is not None:
        C = np.asarray(mesh.vertex_colors, dtype=np.uint8)
        for j, c in enumerate(("red", "green", "blue", "alpha")[:C.shape[1]]):
            vfields.append((c, "u1"))
            vcols[c] = C[:, j]
    if mesh.vertex_filled is not None:
        vfields.append(("filled", "u1"))
        vcols["filled"] = np.asarray(mesh.vertex_filled, dtype=np.uint8)
    ffields = [("n", "u1"), ("i", endian + "i4", (3,))]
    if mesh.face_filled is not None:
        ffields.append(("filled", "u1"))
    head = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0",
            *[c for c in getattr(mesh, "comments", []) if c.isascii() and "\n" not in c and "\r" not in c],
            "comment written by shellrepair", f"element vertex {n}"]
    head += [f"property {_PLY_NAMES[dt[-2:]]} {name}" for name, dt in vfields]
    head += [f"element face {m}", "property list uchar int vertex_indices"]
    if mesh.face_filled is not None:
        head.append("property uchar filled")
    head.append("end_header")
    header = ("\n".join(head) + "\n").encode("ascii")
    if binary:
        # one buffer, the records written into it in place (no copies joined)
        vdt, fdt = np.dtype(vfields), np.dtype(ffields)
        buf = bytearray(len(header) + n * vdt.itemsize + m * fdt.itemsize)
        buf[:len(header)] = header
        va = np.frombuffer(buf, dtype=vdt, count=n, offset=len(header))
        for name, _ in vfields:
            va[name] = vcols[name]
        fa = np.frombuffer(buf, dtype=fdt, count=m, offset=len(header) + n * vdt.itemsize)
        fa["n"] = 3
        fa["i"] = F
        if mesh.face_filled is not None:
            fa["filled"] = np.asarray(mesh.face_filled, dtype=np.uint8)
        del va, fa   # no view may outlive the function (the buffer stays resizable)
        return buf
    out = [header.decode()]
    cols = []
    for name, dt in vfields:
        a = vcols[name]
        if dt[-2] == "f":
            cols.append(np.char.mod("%.17g" if dt[-2:] == "f8" else "%.9g", a.astype(np.float64)))
        else:
            cols.append(np.char.mod("%d", a.astype(np.int64)))
    if n:
        rows = cols[0]
        for c in cols[1:]:
            rows = np.char.add(np.char.add(rows, " "), c)
        out.append("\n".join(rows.tolist()) + "\n")
    if m:
        fl = ("3 " + np.char.mod("%d", F[:, 0]) + " " + np.char.mod("%d", F[:, 1]) + " "
              + np.char.mod("%d", F[:, 2]))
        if mesh.face_filled is not None:
            fl = fl + " " + np.char.mod("%d", np.asarray(mesh.face_filled, np.int64))
        out.append("\n".join(fl.tolist()) + "\n")
    return "".join(out).encode("ascii")


# --------------------------------------------------------------------------
# OBJ
# --------------------------------------------------------------------------
#: OBJ statements that hold nothing a triangle mesh keeps (grouping, materials,
#: display and render attributes): skipped without a note.
_OBJ_QUIET = {b"o", b"g", b"s", b"mg", b"usemtl", b"mtllib", b"usemap", b"maplib", b"lod", b"bevel",
              b"c_interp", b"d_interp", b"shadow_obj", b"trace_obj", b"call", b"csh"}
#: Free-form curve and surface statements (cstype ... end).
_OBJ_FREEFORM = {b"cstype", b"deg", b"bmat", b"step", b"curv", b"curv2", b"surf", b"parm", b"trim",
                 b"hole", b"scrv", b"sp", b"end", b"con", b"ctech", b"stech", b"vp"}


def _obj_text(data):
    """OBJ bytes with comments removed and continued lines joined.

    A line ending in a backslash continues on the next; the joined line
    takes the place of the first and the lines it swallowed stay as empty
    lines, so line numbers still count physical lines.
    """
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    if b"\n" not in data and b"\r" in data:  # old Mac line ends
        data = data.replace(b"\r", b"\n")
    if b"#" in data:
        data = re.sub(rb"#[^\n]*", b"", data)
    if b"\\" in data:
        def join(m):
            s = m.group()
            return re.sub(rb"\\[ \t\r]*\n", b" ", s) + b"\n" * s.count(b"\n")

        data = re.sub(rb"(?m)^(?:[^\n]*\\[ \t\r]*\n)+[^\n]*", join, data)
        data = re.sub(rb"\\[ \t\r]*$", b"", data)  # a backslash on the very last line continues nothing
    return data


def _obj_lines_of(mask, buf, starts, ends):
    """The bytes of the lines in ``mask``, one per line (runs of adjacent lines are sliced at once)."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    first, stop = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return b"\n".join(buf[s:e] for s, e in zip(starts[first].tolist(), ends[stop - 1].tolist()))


def _read_obj(data):
    """Wavefront OBJ: ``v`` (with optional ``w`` or ``r g b`` colour) and ``f``
    lines; ``v/vt/vn``, ``v//vn``, ``v/vt`` corners and negative (relative)
    indices; line continuations, comments and CRLF. Everything else is
    skipped, with a note for what carries geometry (``vt``, ``vn``, ``l``, ...).
    """
    data = _obj_text(data)
    b = np.frombuffer(data, np.uint8)
    nl = np.flatnonzero(b == 10)
    starts = np.concatenate([[0], nl + 1])
    ends = np.concatenate([nl, [len(b)]])
    buf = np.concatenate([b, np.full(3, 32, np.uint8)])  # writable, padded for the look-ahead
    key = starts.copy()  # where each line's first token starts
    lead = np.flatnonzero(_WS[buf[starts]] & (ends > starts))
    blank = ends == starts
    for i in lead.tolist():  # lines that start with white space
        s = data[starts[i]:ends[i]]
        t = s.lstrip()
        if t.strip():
            key[i] += len(s) - len(t)
        else:
            blank[i] = True
    c0, c1, c2 = buf[key], buf[key + 1], buf[key + 2]
    is_v = (c0 == ord("v")) & _WS[c1] & ~blank
    is_f = (c0 == ord("f")) & _WS[c1] & ~blank
    is_vt = (c0 == ord("v")) & (c1 == ord("t")) & _WS[c2]
    is_vn = (c0 == ord("v")) & (c1 == ord("n")) & _WS[c2]
    other = np.flatnonzero(~(is_v | is_f | is_vt | is_vn | blank))
    notes = []
    skipped = {}
    for i in other.tolist():
        k = data[key[i]:ends[i]].split(None, 1)[0]
        skipped[k] = skipped.get(k, 0) + 1
    if not is_v.any():
        raise MeshError("no vertices")
    buf[key[is_v | is_f]] = 32  # blank the 'v' and 'f' keywords: what is left are values
    mv = buf.tobytes()
    v_line = np.flatnonzero(is_v)
    f_line = np.flatnonzero(is_f)

    # vertices: x y z, x y z w, or x y z r g b (MeshLab's vertex colours)
    text = _obj_lines_of(is_v, mv, starts, ends)
    cnt = _token_counts(text)
    if cnt.min() < 3:
        i = int(np.flatnonzero(cnt < 3)[0])
        raise MeshError(f"line {v_line[i] + 1}: vertex needs 3 coordinates")
    voff = np.zeros(len(cnt), np.int64)
    np.cumsum(cnt[:-1], out=voff[1:])
    vals = _parse_numbers(text, np.float64, int(cnt.sum()), lambda j, t: (
        f"line {v_line[np.searchsorted(voff, j, side='right') - 1] + 1}: bad number '{t}'"))
    if (cnt == 3).all():
        V = vals.reshape(-1, 3)
    else:
        V = vals[voff[:, None] + np.arange(3)]
    mesh = Mesh(V=V, F=np.zeros((0, 3), np.int64))
    with_w = cnt == 4
    if with_w.any():
        w = vals[voff[with_w] + 3]
        if (w != 1).any():
            notes.append(f"OBJ: w coordinates ignored ({int((w != 1).sum())} vertices have w other than 1)")
    with_c = cnt >= 6
    if with_c.all():
        mesh.vertex_colors = _colors_to_uint8(vals[voff[:, None] + np.arange(3, 6)], notes, "OBJ")
        if (cnt > 6).any():
            notes.append(f"OBJ: values after x y z r g b ignored on {int((cnt > 6).sum())} vertices")
    elif with_c.any():
        notes.append(f"OBJ: vertex colours dropped: only {int(with_c.sum())} of {len(cnt)} vertices have one")
    if (cnt == 5).any():
        notes.append(f"OBJ: values after x y z ignored on {int((cnt == 5).sum())} vertices")

    # faces: corners 'v', 'v/vt', 'v//vn' or 'v/vt/vn'; the position index comes first
    text = _obj_lines_of(is_f, mv, starts, ends)
    slashed = b"/" in text
    if slashed:
        text = text.replace(b"//", b"/0/")  # an empty texture slot
    x = np.frombuffer(text, np.uint8)
    tstart = np.flatnonzero(_token_starts(x)) if x.size else np.zeros(0, np.int64)
    cnt = _token_counts(text, tstart) if f_line.size else np.zeros(0, np.int64)
    foff = np.zeros(len(cnt), np.int64)
    np.cumsum(cnt[:-1], out=foff[1:])

    def line_of_corner(j):
        return int(f_line[np.searchsorted(foff, j, side="right") - 1] + 1)

    if slashed:
        slash = np.flatnonzero(x == ord("/"))
        parts = np.diff(np.searchsorted(slash, np.append(tstart, x.size))) + 1  # per corner
        pstart = np.zeros(len(parts), np.int64)
        np.cumsum(parts[:-1], out=pstart[1:])
        vals = _parse_numbers(text.replace(b"/", b" "), np.int64, int(parts.sum()), lambda j, t: (
            f"line {line_of_corner(np.searchsorted(pstart, j, side='right') - 1)}: bad face index '{t}'"))
        if vals.size != parts.sum():  # an empty part: '1/', '/2', '1///2'
            for j, t in enumerate(text.split()):
                if b"" in t.split(b"/"):
                    raise MeshError(f"line {line_of_corner(j)}: bad face corner "
                                    f"'{t.decode('utf-8', errors='replace')[:40]}'")
            raise MeshError("bad face corners")  # not reached: some corner has an empty part
        idx = vals[::int(parts[0])] if (parts == parts[0]).all() else vals[pstart]
    else:
        idx = _parse_numbers(text, np.int64, int(cnt.sum()),
                             lambda j, t: f"line {line_of_corner(j)}: bad face index '{t}'")
    idx = np.array(idx, np.int64)  # own, writable
    if idx.size and idx.min() <= 0:
        zero = np.flatnonzero(idx == 0)
        if zero.size:
            raise MeshError(f"line {line_of_corner(int(zero[0]))}: face index 0 (OBJ indices start at 1)")
        # a negative index counts back from the last vertex read before its line
        seen = np.searchsorted(v_line, f_line)  # vertices above each face line
        neg = np.flatnonzero(idx < 0)
        rel = np.repeat(seen, cnt)[neg] + idx[neg]
        if rel.min() < 0:
            j = int(neg[np.argmin(rel)])
            raise MeshError(f"line {line_of_corner(j)}: relative index {int(idx[j])} out of range "
                            f"({int(np.repeat(seen, cnt)[j])} vertices before this line)")
        idx[neg] = rel + 1
    idx -= 1
    mesh.F = _polygons_to_triangles((cnt, idx), notes, V)

    n_vt, n_vn = int(is_vt.sum()), int(is_vn.sum())
    if n_vt or n_vn:
        what = [f"{n} {name}" for n, name in ((n_vt, "texture coordinates (vt)"), (n_vn, "normals (vn)")) if n]
        notes.append(f"OBJ: {' and '.join(what)} not kept (shellrepair keeps positions and vertex colours)")
    for k, name in ((b"l", "polylines (l)"), (b"p", "points (p)")):
        if k in skipped:
            notes.append(f"OBJ: {skipped.pop(k)} {name} ignored")
    ff = sum(skipped.pop(k) for k in list(skipped) if k in _OBJ_FREEFORM)
    if ff:
        notes.append(f"OBJ: {ff} free-form curve and surface statements ignored")
    unknown = {k: n for k, n in skipped.items() if k not in _OBJ_QUIET}
    if unknown:
        notes.append("OBJ: unknown statements ignored: "
                     + ", ".join(f"'{k.decode('utf-8', errors='replace')[:20]}' ({n})"
                                 for k, n in sorted(unknown.items())[:5]))
    mesh.notes.extend(notes)
    return mesh


def _obj_bytes(mesh, binary=True):
    V = np.asarray(mesh.V, np.float64)
    lines = ["# written by shellrepair"]
    vs = "v " + np.char.mod("%.17g", V[:, 0]) + " " + np.char.mod("%.17g", V[:, 1]) + " " + np.char.mod("%.17g", V[:, 2])
    if mesh.vertex_colors is not None:
        C = np.asarray(mesh.vertex_colors)[:, :3].astype(np.float64) / 255.0
        for j in range(3):
            vs = vs + " " + np.char.mod("%.6g", C[:, j])
    lines += vs.tolist()
    F = written_faces(mesh) + 1
    lines += ("f " + np.char.mod("%d", F[:, 0]) + " " + np.char.mod("%d", F[:, 1]) + " "
              + np.char.mod("%d", F[:, 2])).tolist()
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------
# OFF
# --------------------------------------------------------------------------
def _read_off(data):
    """Object File Format: ``OFF``, ``COFF``, ``NOFF``, ``CNOFF``, ``STOFF``... (vertex
    lines ``x y z`` then the normal, colour and texture coordinates the keyword
    names), comments, counts on the keyword's line, faces with a colour after
    their indices (ignored, noted).

    Notes
    -----
    The Geomview specification orders the keyword ``[ST][C][N]OFF`` and the
    vertex values normal, colour, texture coordinates: the reverse of the
    keyword's letters. MeshLab writes ``NCOFF`` with the colour before the
    normal, again the reverse of its letters; so the values are read in the
    reverse order of the letters as written. Colours written as integers
    are 0..255, as decimals 0..1 (as the specification says).
    """
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    if b"\n" not in data and b"\r" in data:  # old Mac line ends
        data = data.replace(b"\r", b"\n")
    if b"#" in data:
        data = re.sub(rb"#[^\n\r]*", b"", data)
    x = np.frombuffer(data, np.uint8)
    at = np.concatenate([[0], np.flatnonzero(x == 10) + 1, [x.size]])
    per_line = _token_counts(data)
    rows = np.flatnonzero(per_line)  # lines with values

    def span(r):
        """The text of lines ``r`` (and the blank lines between them), and their value counts."""
        return (data[at[r[0]]:at[r[-1] + 1]] if len(r) else b""), per_line[r]

    head = span(rows[:1])[0].split()
    m = re.fullmatch(rb"((?:ST|C|N)*)(4)?(n)?OFF", head[0]) if head else None
    if m is None and head and head[0].isdigit():
        m, head = re.fullmatch(rb"()()()", b""), [b"OFF"] + head  # the keyword is optional
    if m is None:
        raise MeshError("not an OFF file (missing 'OFF' magic)")
    if m.group(2) or m.group(3):
        raise MeshError(f"OFF variant '{head[0].decode()}' is not 3-dimensional")
    if len(head) > 1 and head[1].upper() == b"BINARY":
        raise MeshError("binary OFF is not supported (write it as text OFF, PLY or STL)")
    letters = re.findall(rb"ST|C|N", m.group(1))[::-1]  # in the order of the values
    width = {b"N": 3, b"ST": 2}
    rest = rows[1:]
    first = head[1:]
    if not first:
        if not len(rest):
            raise MeshError("OFF file has no counts line")
        first = span(rest[:1])[0].split()
        rest = rest[1:]
    if len(first) < 2:
        raise MeshError("OFF counts line needs vertex and face counts")
    nv, nf = int(first[0]), int(first[1])
    if nv < 0 or nf < 0:
        raise MeshError(f"OFF counts line has a negative count ({nv} vertices, {nf} faces)")
    if len(rest) < nv + nf:
        raise MeshError(f"header disagrees with body: {nv} vertices and {nf} faces announced, {len(rest)} lines found")
    notes = []
    text, cnt = span(rest[:nv])
    if nv and cnt.min() < 3:
        i = int(np.flatnonzero(cnt < 3)[0])
        raise MeshError(f"vertex {i}: needs 3 coordinates, has {int(cnt[i])}")
    off = np.zeros(nv, np.int64)
    np.cumsum(cnt[:-1], out=off[1:])
    vals = _parse_numbers(text, np.float64, int(cnt.sum()), lambda j, t: (
        f"vertex {np.searchsorted(off, j, side='right') - 1}: bad number '{t}'"))
    V = vals.reshape(-1, 3) if (cnt == 3).all() else vals[off[:, None] + np.arange(3)]
    mesh = Mesh(V=V.reshape(-1, 3), F=np.zeros((0, 3), np.int64))
    announced = 3 + sum(width.get(c, 0) for c in letters) + (3 if b"C" in letters else 0)
    if b"C" in letters and nv:
        c0 = 3 + sum(width.get(c, 0) for c in letters[:letters.index(b"C")])
        k = cnt - (announced - 3)  # the colour has 3 or 4 values
        if (k == k[0]).all() and k[0] in (3, 4):
            cols = off[:, None] + c0 + np.arange(int(k[0]))
            tokens = text.split()
            decimal = any(not t.isdigit() for t in (tokens[j] for j in cols.ravel().tolist()))
            C = vals[cols] if decimal else vals[cols].astype(np.int64)
            mesh.vertex_colors = _colors_to_uint8(C, notes, "OFF", unit=True)
        else:
            notes.append("OFF: vertex colours dropped (not 3 or 4 values on every vertex)")
    elif nv and (cnt > announced).any():
        notes.append(f"OFF: values after the {announced} per vertex that '{head[0].decode()}' announces ignored")

    text, cnt = span(rest[nv:nv + nf])
    try:
        vals = _parse_numbers(text, np.int64, int(cnt.sum()), lambda j, t: "")
    except MeshError:  # face colours as decimals
        vals = _parse_numbers(text, np.float64, int(cnt.sum()), lambda j, t: (
            f"face {np.searchsorted(np.cumsum(cnt), j, side='right')}: bad value '{t}'"))
    off = np.zeros(nf, np.int64)
    np.cumsum(cnt[:-1], out=off[1:])
    k = vals[off[cnt > 0]]
    if k.dtype.kind == "f" and not (k == np.round(k)).all():
        i = int(np.flatnonzero(cnt > 0)[np.flatnonzero(k != np.round(k))[0]])
        raise MeshError(f"face {i}: corner count is not an integer")
    k = np.zeros(nf, np.int64)
    k[cnt > 0] = vals[off[cnt > 0]].astype(np.int64)
    short = (cnt == 0) | (k < 0) | (cnt < 1 + k)
    if short.any():
        i = int(np.flatnonzero(short)[0])
        raise MeshError(f"face {i}: announces {int(k[i])} corners, has {max(int(cnt[i]) - 1, 0)}")
    item = np.repeat(off + 1 - np.concatenate([[0], np.cumsum(k)[:-1]]), k) + np.arange(int(k.sum()))
    flat = vals[item]
    if flat.dtype.kind == "f":
        if not (flat == np.round(flat)).all():
            raise MeshError("OFF face indices must be integers")
        flat = flat.astype(np.int64)
    extra = cnt > 1 + k
    if extra.any():
        notes.append(f"OFF: face colours not kept ({int(extra.sum())} faces have values after their indices)")
    mesh.F = _polygons_to_triangles((k, flat), notes, V)
    mesh.notes.extend(notes)
    return mesh


def _off_bytes(mesh, binary=True):
    V = np.asarray(mesh.V, np.float64)
    F = written_faces(mesh)
    lines = ["OFF", f"{len(V)} {len(F)} 0"]
    lines += (np.char.mod("%.17g", V[:, 0]) + " " + np.char.mod("%.17g", V[:, 1]) + " "
              + np.char.mod("%.17g", V[:, 2])).tolist()
    lines += ("3 " + np.char.mod("%d", F[:, 0]) + " " + np.char.mod("%d", F[:, 1]) + " "
              + np.char.mod("%d", F[:, 2])).tolist()
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------
# STL
# --------------------------------------------------------------------------
_STL_RECORD = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])


def _read_stl(data):
    """STL, binary or ascii. A binary file is recognised by its size (84 bytes
    plus 50 per triangle), so binaries whose header starts with ``solid`` read
    as binaries; normals are not read (NaN normals are harmless)."""
    ntri = int(np.frombuffer(data, "<u4", 1, 80)[0]) if len(data) >= 84 else -1
    if ntri >= 0 and 84 + 50 * ntri == len(data):
        return _weld(np.frombuffer(data, _STL_RECORD, ntri, 84)["v"].reshape(-1, 3), "f4")
    head = data[:1024].lstrip().lower()
    ascii_like = head.startswith(b"solid") and (b"facet" in head or b"endsolid" in head)
    if ascii_like:
        text = data.decode("ascii", errors="replace")
        nums = re.findall(r"vertex\s+(\S+)\s+(\S+)\s+(\S+)", text, flags=re.IGNORECASE)
        if not nums or len(nums) % 3:
            raise MeshError("ASCII STL has no complete facets")
        P = _to_numbers([t.encode() for row in nums for t in row], np.float64,
                        lambda j, t: f"facet {j // 9}: bad number '{t}'").reshape(-1, 3)
        return _weld(P, "f8")
    if ntri >= 0 and 84 + 50 * ntri < len(data):
        mesh = _weld(np.frombuffer(data, _STL_RECORD, ntri, 84)["v"].reshape(-1, 3), "f4")
        mesh.notes.append(f"STL: {len(data) - 84 - 50 * ntri} bytes after the last of {ntri} triangles ignored")
        return mesh
    if ntri >= 0:
        raise MeshError(f"truncated or malformed binary STL: header announces {ntri} triangles "
                        f"({84 + 50 * ntri} bytes), file has {len(data)} bytes")
    raise MeshError("not an STL file")


def _weld(P, vdt):
    """Merge STL corners with identical coordinates into shared vertices.

    Vertices are numbered in the order they first appear in the file.
    Corners are grouped by a 64-bit hash of their coordinates' bits (-0.0
    taken as 0.0), checked exactly; if two different corners share a hash,
    they are grouped by an exact sort instead.
    """
    P = np.ascontiguousarray(P, dtype=np.float64) + 0.0  # -0.0 + 0.0 is 0.0
    bits = P.view(np.uint64)
    h = _row_hash(bits)
    order = np.argsort(h, kind="stable")
    B = bits[order]
    differ = (B[1:] != B[:-1]).any(axis=1)
    hs = h[order]
    if np.any(differ & (hs[1:] == hs[:-1])):  # a collision: group by the bits themselves
        order = np.lexsort((bits[:, 2], bits[:, 1], bits[:, 0]))
        B = bits[order]
        differ = (B[1:] != B[:-1]).any(axis=1)
    start = np.concatenate([[True], differ])
    group = np.cumsum(start) - 1          # group of each sorted corner
    first = order[start]                  # each group's first corner in the file (stable sorts)
    rank = np.empty(len(first), np.int64)
    by_appearance = np.argsort(first, kind="stable")
    rank[by_appearance] = np.arange(len(first))
    inv = np.empty(len(P), np.int64)
    inv[order] = rank[group]
    V = P[first[by_appearance]]
    mesh = Mesh(V=V, F=inv.reshape(-1, 3), vertex_dtype=vdt)
    mesh.notes.append(f"STL: {len(P)} corners welded into {len(V)} vertices")
    return mesh


def _row_hash(bits):
    """A 64-bit hash of each row of a (n,3) uint64 array."""
    h = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)  # products wrap around
    h ^= bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)
    h ^= bits[:, 2] * np.uint64(0x165667B19E3779F9)
    h ^= h >> np.uint64(29)
    return h


def _stl_bytes(mesh, binary=True):
    V = np.asarray(mesh.V, np.float64)
    F = np.asarray(mesh.F, np.int64)
    T = V[F]
    N = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    ln = np.linalg.norm(N, axis=1, keepdims=True)
    N = np.divide(N, ln, out=np.zeros_like(N), where=ln > 0)
    if binary:
        rec = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
        arr = np.zeros(len(F), rec)
        arr["n"] = N
        arr["v"] = T
        return b"shellrepair".ljust(80, b" ") + np.uint32(len(F)).tobytes() + arr.tobytes()
    out = ["solid shellrepair"]
    for n, t in zip(N, T):
        out.append(f"facet normal {n[0]:.9g} {n[1]:.9g} {n[2]:.9g}\nouter loop")
        out += [f"vertex {p[0]:.17g} {p[1]:.17g} {p[2]:.17g}" for p in t]
        out.append("endloop\nendfacet")
    out.append("endsolid shellrepair")
    return "\n".join(out) + "\n"
