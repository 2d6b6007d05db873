"""Reading and writing scans: PLY (ascii and binary), OBJ, OFF, STL.

What loading guarantees
-----------------------
* Vertices keep their order and their exact values. A PLY stored as
  ``float`` is read as float32 and widened to float64 (exact), and written
  back as float32, so the original coordinates round-trip bit for bit.
* Vertex colours (PLY ``red green blue [alpha]``, OBJ ``v x y z r g b``,
  OFF ``COFF``) are kept as ``uint8``.
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
  naming the file and what is wrong; NaN/inf coordinates, out-of-range or
  negative indices, a file with no faces, truncated or inconsistent files,
  directories, unreadable or non-regular files (a FIFO would block).

Writing always goes to a temporary file in the target folder that is
flushed to disk and renamed into place, so a failed write never leaves a
partial file behind; :func:`atomic_write_many` does this for a mesh and its
report together.
"""

from __future__ import annotations

import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import MeshError
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
    fixes: dict = field(default_factory=dict)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

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
               path=mesh.path, notes=notes, fixes={k: int(fixes.get(k, 0)) for k in FIX_COUNTS})
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
    """The bytes :func:`write_mesh` would write to ``path`` (format from its extension).

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
        Kept faces, in their original order.
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
    h = _triple_hash(F if n_degen == 0 else F[idx])
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
    bad = ~np.isfinite(V).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise MeshError(f"vertex {i} has a non-finite coordinate ({int(bad.sum())} such vertices)")
    huge = (np.abs(V) > MAX_ABS_COORDINATE).any(axis=1)
    if huge.any():
        i = int(np.flatnonzero(huge)[0])
        raise MeshError(f"vertex {i} has a coordinate beyond {MAX_ABS_COORDINATE:.0e} "
                        f"({int(huge.sum())} such vertices)")
    if F.shape[0] == 0:
        raise MeshError("no faces: this is a point cloud, not a surface mesh")
    lo, hi = F.min(), F.max()
    if lo < 0 or hi >= V.shape[0]:
        rows = np.flatnonzero(((F < 0) | (F >= V.shape[0])).any(axis=1))
        i = int(rows[0])
        raise MeshError(f"face {i} has vertex index {int(F[i][(F[i] < 0) | (F[i] >= V.shape[0])][0])} "
                        f"out of range 0..{V.shape[0] - 1}")


def _used_vertex_count(F, n):
    used = np.zeros(int(n), bool)
    used[np.asarray(F).ravel()] = True
    return int(used.sum())


def _polygons_to_triangles(polys, notes, V=None):
    """Split polygons into triangles that stay inside them; returns (m,3) int64.

    Parameters
    ----------
    polys : list of lists of int
        Corner indices, in the polygon's winding.
    notes : list of str
        Gets one line per kind of change.
    V : (n,3) float64 array, optional
        Vertex positions. Without them (or with an index out of range,
        which validation reports later) polygons are fanned from corner 0.

    Notes
    -----
    A quad is split along 0-2 unless that diagonal lies outside it (corners
    1 and 3 on the same side), then along 1-3. Larger polygons are ear
    clipped in the plane of their Newell normal, which keeps every triangle
    inside a non-convex outline; a polygon with no ear (self-crossing) is
    fanned. All triangles keep the polygon's winding.
    """
    tris = []
    quads = []
    n_poly = 0
    n_small = 0
    n = -1 if V is None else len(V)
    for p in polys:
        k = len(p)
        if k < 3:
            n_small += 1
            continue
        if k == 3:
            tris.append(tuple(p))
            continue
        n_poly += 1
        if n > 0 and min(p) >= 0 and max(p) < n:
            if k == 4:
                quads.append((len(tris), p))
                tris.append(None)
                tris.append(None)
                continue
            tris.extend(_ear_clip(V, p))
            continue
        for j in range(1, k - 1):
            tris.append((p[0], p[j], p[j + 1]))
    if quads:
        at = np.array([q[0] for q in quads], np.int64)
        Q = np.array([q[1] for q in quads], np.int64)
        P = V[Q]
        n1 = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])  # triangle 0-1-2
        n2 = np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0])  # triangle 0-2-3
        use13 = np.einsum("ij,ij->i", n1, n2) < 0  # 1 and 3 on the same side of 0-2: 0-2 lies outside
        A = np.where(use13[:, None], Q[:, [1, 2, 3]], Q[:, [0, 1, 2]])
        B = np.where(use13[:, None], Q[:, [1, 3, 0]], Q[:, [0, 2, 3]])
        for i, a, b in zip(at.tolist(), A.tolist(), B.tolist()):
            tris[i] = tuple(a)
            tris[i + 1] = tuple(b)
    if n_poly:
        notes.append(f"{n_poly} polygons with more than 3 corners split into triangles")
    if n_small:
        notes.append(f"{n_small} faces with fewer than 3 corners dropped")
    return np.array(tris, dtype=np.int64).reshape(-1, 3)


def _ear_clip(V, poly):
    """Ear clipping of one polygon in the plane of its Newell normal."""
    idx = list(poly)
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
    xy = np.column_stack([P @ u, P @ w])  # counter-clockwise seen along nrm

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
            if tok[1] == "list":
                if len(tok) != 5 or tok[2] not in _PLY_TYPES or tok[3] not in _PLY_TYPES:
                    raise MeshError(f"PLY header line {lineno}: bad list property '{raw.strip()}'")
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


def _read_ply(data):
    fmt, elements, pos = _parse_ply_header(data)
    names = [e["name"] for e in elements]
    if "vertex" not in names:
        raise MeshError("PLY has no vertex element")
    if "face" not in names:
        raise MeshError("no faces: this is a point cloud, not a surface mesh")
    if fmt == "ascii":
        tables = _ply_ascii_body(data[pos:], elements)
    else:
        endian = "<" if fmt == "binary_little_endian" else ">"
        tables = _ply_binary_body(data, pos, elements, endian)
    vert = tables["vertex"]
    for c in "xyz":
        if c not in vert:
            raise MeshError(f"PLY vertex element has no '{c}' property")
    vdt = "f8" if any(vert[c].dtype == np.float64 for c in "xyz") else "f4"
    V = np.column_stack([vert[c].astype(np.float64) for c in "xyz"])
    mesh = Mesh(V=V, F=np.zeros((0, 3), np.int64), vertex_dtype=vdt)
    col = [c for c in ("red", "green", "blue", "alpha") if c in vert]
    if len(col) >= 3 and col[:3] == ["red", "green", "blue"]:
        cols = [vert[c] for c in col]
        if all(c.dtype == np.uint8 for c in cols):
            mesh.vertex_colors = np.column_stack(cols).astype(np.uint8)
        else:  # float colours in [0, 1]
            mesh.vertex_colors = np.clip(np.round(np.column_stack(cols).astype(np.float64) * 255), 0, 255).astype(np.uint8)
    skip = {"x", "y", "z", "red", "green", "blue", "alpha", "filled"}
    for name, arr in vert.items():
        if name not in skip and arr.ndim == 1:
            mesh.vertex_props[name] = arr
    if "filled" in vert:
        mesh.vertex_filled = vert["filled"].astype(bool)
    face = tables["face"]
    F = face.get("__F__")
    if F is None:
        raise MeshError("PLY face element has no vertex index list")
    if "__polys__" in face:
        F = _polygons_to_triangles(face["__polys__"], mesh.notes, V)
    else:
        F = F.astype(np.int64)
    mesh.F = F
    if "filled" in face and "__polys__" not in face:
        mesh.face_filled = face["filled"].astype(bool)
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


def _ply_binary_lists(data, pos, el, endian):
    """Element with list properties: a fast path for all-triangle faces."""
    props, count, name = el["props"], el["count"], el["name"]
    tab = {}
    list_props = [p for p in props if p[1] == "list"]
    idx_name = next((p[0] for p in list_props if p[0] in ("vertex_indices", "vertex_index")), None)
    if len(list_props) == 1 and idx_name is not None and count > 0:
        fields = []
        for p in props:
            if p[1] == "list":
                fields += [("__n__", endian + p[2]), ("__F__", endian + p[3], (3,))]
            else:
                fields.append((p[0], endian + p[2]))
        dt = np.dtype(fields)
        need = dt.itemsize * count
        avail = min(count, max(0, len(data) - pos) // dt.itemsize)
        arr = np.frombuffer(data, dtype=dt, count=avail, offset=pos)
        if (arr["__n__"] == 3).all() and avail < count:
            raise MeshError(f"truncated: {name} data needs {need} bytes, {max(0, len(data) - pos)} left")
        if avail == count:
            if (arr["__n__"] == 3).all():
                for p in props:
                    tab[p[0] if p[1] == "scalar" else "__F__"] = arr[p[0] if p[1] == "scalar" else "__F__"]
                return tab, pos + need
    # general path: walk records one by one
    scal = {p[0]: [] for p in props if p[1] == "scalar"}
    lists = {p[0]: [] for p in props if p[1] == "list"}
    mv = memoryview(data)
    for i in range(count):
        for p in props:
            if p[1] == "scalar":
                dt = np.dtype(endian + p[2])
                if pos + dt.itemsize > len(data):
                    raise MeshError(f"truncated: {name} {i} of {count} is cut off")
                scal[p[0]].append(np.frombuffer(mv, dt, 1, pos)[0])
                pos += dt.itemsize
            else:
                cdt, idt = np.dtype(endian + p[2]), np.dtype(endian + p[3])
                if pos + cdt.itemsize > len(data):
                    raise MeshError(f"truncated: {name} {i} of {count} is cut off")
                n = int(np.frombuffer(mv, cdt, 1, pos)[0])
                pos += cdt.itemsize
                if pos + n * idt.itemsize > len(data):
                    raise MeshError(f"truncated: {name} {i} of {count} is cut off")
                lists[p[0]].append(np.frombuffer(mv, idt, n, pos).astype(np.int64).tolist())
                pos += n * idt.itemsize
    for k, v in scal.items():
        tab[k] = np.array(v)
    if idx_name is not None:
        polys = lists[idx_name]
        if all(len(p) == 3 for p in polys):
            tab["__F__"] = np.array(polys, dtype=np.int64).reshape(-1, 3)
        else:
            tab["__F__"] = np.zeros((0, 3), np.int64)
            tab["__polys__"] = polys
    return tab, pos


def _ply_ascii_body(body, elements):
    text = body.decode("ascii", errors="replace")
    lines = [ln for ln in text.splitlines() if ln.strip()]
    total = sum(el["count"] for el in elements)
    if len(lines) != total:
        announced = ", ".join(f"{el['count']} {el['name']}" for el in elements)
        raise MeshError(f"header disagrees with body: header announces {announced} lines "
                        f"({total}), body has {len(lines)}")
    tables = {}
    at = 0
    for el in elements:
        props, count, name = el["props"], el["count"], el["name"]
        chunk = lines[at:at + count]
        if len(chunk) < count:
            raise MeshError(f"header disagrees with body: {count} {name} lines announced, {len(chunk)} found")
        at += count
        tab = {}
        if all(p[1] == "scalar" for p in props):
            if count:
                flat = " ".join(chunk).split()
                if len(flat) != count * len(props):
                    raise MeshError(f"header disagrees with body: {name} lines should have {len(props)} values each")
                arr = np.array(flat, dtype=np.float64).reshape(count, len(props))
            else:
                arr = np.zeros((0, len(props)))
            for j, p in enumerate(props):
                tab[p[0]] = arr[:, j].astype(p[2]) if p[2] not in ("f4", "f8") else arr[:, j].astype(p[2])
        else:
            scal = {p[0]: [] for p in props if p[1] == "scalar"}
            polys = []
            for li, ln in enumerate(chunk):
                tok = ln.split()
                k = 0
                for p in props:
                    if p[1] == "scalar":
                        if k >= len(tok):
                            raise MeshError(f"{name} {li}: missing value '{p[0]}'")
                        scal[p[0]].append(float(tok[k]))
                        k += 1
                    else:
                        if k >= len(tok):
                            raise MeshError(f"{name} {li}: missing list '{p[0]}'")
                        n = int(tok[k])
                        if n < 0:
                            raise MeshError(f"{name} {li}: negative list length {n}")
                        vals = tok[k + 1:k + 1 + n]
                        if len(vals) != n:
                            raise MeshError(f"{name} {li}: list announces {n} values, has {len(vals)}")
                        if p[0] in ("vertex_indices", "vertex_index"):
                            polys.append([int(v) for v in vals])
                        k += 1 + n
            for p in props:
                if p[1] == "scalar":
                    tab[p[0]] = np.array(scal[p[0]], dtype=p[2])
            if all(len(p) == 3 for p in polys):
                tab["__F__"] = np.array(polys, dtype=np.int64).reshape(-1, 3)
            else:
                tab["__F__"] = np.zeros((0, 3), np.int64)
                tab["__polys__"] = polys
        tables[name] = tab
    if at < len(lines):
        raise MeshError(f"header disagrees with body: {len(lines) - at} extra lines after the last element")
    return tables


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
            "comment written by shellrepair", f"element vertex {n}"]
    head += [f"property {_PLY_NAMES[dt[-2:]]} {name}" for name, dt in vfields]
    head += [f"element face {m}", "property list uchar int vertex_indices"]
    if mesh.face_filled is not None:
        head.append("property uchar filled")
    head.append("end_header")
    header = ("\n".join(head) + "\n").encode("ascii")
    if binary:
        va = np.empty(n, dtype=np.dtype(vfields))
        for name, _ in vfields:
            va[name] = vcols[name]
        fa = np.empty(m, dtype=np.dtype(ffields))
        fa["n"] = 3
        fa["i"] = F
        if mesh.face_filled is not None:
            fa["filled"] = np.asarray(mesh.face_filled, dtype=np.uint8)
        return header + va.tobytes() + fa.tobytes()
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
def _read_obj(data):
    text = data.decode("utf-8", errors="replace")
    verts, cols, polys = [], [], []
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line or line[0] not in "vf":
            continue
        tok = line.split()
        if tok[0] == "v":
            if len(tok) < 4:
                raise MeshError(f"line {lineno}: vertex needs 3 coordinates")
            try:
                vals = [float(t) for t in tok[1:]]
            except ValueError:
                raise MeshError(f"line {lineno}: bad number in '{line.strip()}'") from None
            verts.append(vals[:3])
            if len(vals) >= 6:
                cols.append(vals[3:6])
        elif tok[0] == "f":
            n = len(verts)
            idx = []
            for t in tok[1:]:
                s = t.split("/", 1)[0]
                try:
                    k = int(s)
                except ValueError:
                    raise MeshError(f"line {lineno}: bad face index '{t}'") from None
                if k == 0:
                    raise MeshError(f"line {lineno}: face index 0 (OBJ indices start at 1)")
                idx.append(k - 1 if k > 0 else n + k)
            polys.append(idx)
    if not verts:
        raise MeshError("no vertices")
    mesh = Mesh(V=np.array(verts, dtype=np.float64), F=np.zeros((0, 3), np.int64))
    V = mesh.V
    if cols and len(cols) == len(verts):
        c = np.array(cols, dtype=np.float64)
        if c.max() <= 1.0:
            c = c * 255.0
        mesh.vertex_colors = np.clip(np.round(c), 0, 255).astype(np.uint8)
    mesh.F = _polygons_to_triangles(polys, mesh.notes, V)
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
    text = data.decode("utf-8", errors="replace")
    lines = [ln.split("#", 1)[0].strip() for ln in text.splitlines()]
    lines = [ln for ln in lines if ln]
    if not lines or not re.match(r"^C?N?OFF", lines[0]):
        raise MeshError("not an OFF file (missing 'OFF' magic)")
    head = lines[0]
    rest = lines[1:]
    first = head[head.index("OFF") + 3:].split()
    if not first:
        if not rest:
            raise MeshError("OFF file has no counts line")
        first = rest[0].split()
        rest = rest[1:]
    if len(first) < 2:
        raise MeshError("OFF counts line needs vertex and face counts")
    nv, nf = int(first[0]), int(first[1])
    if len(rest) < nv + nf:
        raise MeshError(f"header disagrees with body: {nv} vertices and {nf} faces announced, {len(rest)} lines found")
    if nv < 0 or nf < 0:
        raise MeshError(f"OFF counts line has a negative count ({nv} vertices, {nf} faces)")
    vrows = [r.split() for r in rest[:nv]]
    for i, r in enumerate(vrows):
        if len(r) < 3:
            raise MeshError(f"vertex {i}: needs 3 coordinates, has {len(r)}")
    V = np.array([[float(x) for x in r[:3]] for r in vrows], dtype=np.float64).reshape(-1, 3)
    mesh = Mesh(V=V, F=np.zeros((0, 3), np.int64))
    if head.startswith("C") and all(len(r) >= 6 for r in vrows):
        c = np.array([[float(x) for x in r[3:6]] for r in vrows])
        if c.max() <= 1.0:
            c = c * 255
        mesh.vertex_colors = np.clip(np.round(c), 0, 255).astype(np.uint8)
    polys = []
    for i, r in enumerate(rest[nv:nv + nf]):
        tok = r.split()
        k = int(tok[0])
        if k < 0 or len(tok) < 1 + k:
            raise MeshError(f"face {i}: announces {k} corners, has {len(tok) - 1}")
        polys.append([int(t) for t in tok[1:1 + k]])
    mesh.F = _polygons_to_triangles(polys, mesh.notes, V)
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
def _read_stl(data):
    if len(data) >= 84:
        ntri = int(np.frombuffer(data, "<u4", 1, 80)[0])
        if 84 + 50 * ntri == len(data):
            rec = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
            arr = np.frombuffer(data, rec, ntri, 84)
            P = arr["v"].reshape(-1, 3)
            return _weld(P, "f4")
    head = data[:5].lower()
    if head.startswith(b"solid"):
        text = data.decode("ascii", errors="replace")
        nums = re.findall(r"vertex\s+(\S+)\s+(\S+)\s+(\S+)", text)
        if not nums or len(nums) % 3:
            raise MeshError("ASCII STL has no complete facets")
        P = np.array(nums, dtype=np.float64)
        return _weld(P, "f8")
    if len(data) >= 84:
        ntri = int(np.frombuffer(data, "<u4", 1, 80)[0])
        raise MeshError(f"truncated or malformed binary STL: header announces {ntri} triangles "
                        f"({84 + 50 * ntri} bytes), file has {len(data)} bytes")
    raise MeshError("not an STL file")


def _weld(P, vdt):
    """Merge STL corners with bit-identical coordinates into shared vertices."""
    P = np.ascontiguousarray(P, dtype=np.float64)
    V, inv = np.unique(P, axis=0, return_inverse=True)
    F = inv.reshape(-1, 3).astype(np.int64)
    mesh = Mesh(V=V, F=F, vertex_dtype=vdt)
    mesh.notes.append(f"STL: {len(P)} corners welded into {len(V)} vertices")
    return mesh


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
