"""The triangle mesh type, with the per-element data a scan carries.

:class:`Mesh` holds positions, faces, colours, the ``filled`` flags of a
repair, other PLY vertex properties and what loading noted; it caches the
whole-mesh data reading computed on its way (edge topology, pieces, face
areas) so that hole detection and repair need not build it again.
:func:`written_faces` gives the faces as a file gets them, :func:`as_written`
the whole mesh as a file gets it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Mesh", "FaceTexture", "written_faces", "as_written"]


def _signature(V, F):
    """What :meth:`Mesh.cached` compares: the arrays' shapes, dtypes and a
    CRC-32 of all their bytes (zlib's: 0.21 s for 5M vertices and 10M faces
    on the development machine, against 1.0 s for BLAKE2b; a sample of rows
    missed edits elsewhere, issue 39)."""
    import zlib

    out = []
    for a in (V, F):
        a = np.ascontiguousarray(a)
        out.append((a.shape, a.dtype.str, zlib.crc32(memoryview(a).cast("B")) if a.size else 0))
    return tuple(out)


@dataclass
class FaceTexture:
    """A file's texture coordinates and materials, per face corner and face.

    Kept for the first ``k`` faces of the mesh (the file's own, in order);
    faces after them (added by a repair) have none. Every step that drops
    or turns the file's faces applies the same to this (:meth:`take`,
    :meth:`flip`), so a written file gives each original corner the UV it
    was read with, bit for bit.

    Attributes
    ----------
    uv : (t,2) float array
        The file's texture coordinates, in file order: OBJ ``vt`` (float64),
        or a PLY face's ``texcoord`` list, two values a corner (the file's
        float type, so the written values have the bits read).
    face_uv : (k,3) int64
        Each corner's row of ``uv``; -1 where the file gave the corner none.
    face_material : (k,) int64
        Each face's index into ``materials``; -1 before any ``usemtl``.
    materials : list of str
        Material names (OBJ ``usemtl``), in order of first use.
    libraries : list of str
        The material library lines (OBJ ``mtllib ...``) as read.
    face_texnumber : (k,) int array or None
        A PLY's ``texnumber`` of each face (the file's integer type): which
        ``comment TextureFile`` line of the header its UVs refer to.
    """

    uv: np.ndarray
    face_uv: np.ndarray
    face_material: np.ndarray
    materials: list = field(default_factory=list)
    libraries: list = field(default_factory=list)
    face_texnumber: np.ndarray | None = None

    def take(self, rows):
        """The texture of faces ``rows`` (indices into the kept faces), in that order."""
        rows = np.asarray(rows, np.int64)
        tn = None if self.face_texnumber is None else self.face_texnumber[rows]
        return FaceTexture(self.uv, self.face_uv[rows], self.face_material[rows], list(self.materials),
                           list(self.libraries), tn)

    def flip(self, rows):
        """The texture with faces ``rows`` turned as a flip turns them (corners 1 and 2 swapped)."""
        fu = self.face_uv.copy()
        fu[rows, 1], fu[rows, 2] = self.face_uv[rows, 2], self.face_uv[rows, 1]
        return FaceTexture(self.uv, fu, self.face_material, list(self.materials), list(self.libraries),
                           self.face_texnumber)


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
    joins : (k,2) int64 array or None
        Vertex copies the reader made where pieces of the file meet at a
        single vertex (``joins[:, 0]`` the copy, ``joins[:, 1]`` the file's
        vertex; same position, same attributes): the topology and the
        repair see the pieces apart, the file is written with the copies
        joined again (:func:`as_written`), so a written scan keeps the
        file's own vertices and faces and a patch at such a point shares
        the file's vertex, not one lying on it.
    fixes : dict
        What :func:`manifold_mesh` did (see
        :data:`shellrepair.mesh.clean.FIX_COUNTS`); empty when it did not run.
    comments : list of str
        A PLY header's ``comment`` and ``obj_info`` lines as read (each with
        its keyword), written back before shellrepair's own comment.
    texture : FaceTexture or None
        The texture coordinates and materials of the file's faces (an OBJ's
        ``vt`` and ``usemtl``, a PLY's ``texcoord`` and ``texnumber``).
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
    joins: np.ndarray | None = None
    comments: list = field(default_factory=list)
    fixes: dict = field(default_factory=dict)
    texture: FaceTexture | None = None
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

    def cached(self, *names):
        """Whole-mesh data :func:`read_mesh` computed on its way, or None
        (when it computed none, or ``V`` or ``F`` has changed since).

        ``names``: ``"topology"`` (:func:`shellrepair.mesh.topology.edge_topology`),
        ``"pieces"`` (``(n_pieces, face_piece)`` as
        :func:`shellrepair.mesh.topology.face_pieces` gives them) or
        ``"face_areas"``; one name gives its value, several a tuple (one
        check of the arrays for all). A change is noticed when ``V`` or ``F``
        is replaced or edited in place anywhere: every byte is compared by
        its checksum (:func:`_signature`), so a kept value is never one of
        other arrays.
        """
        entries = [self._cache.get(n) for n in names]
        if any(e is not None for e in entries):
            live = None
            for i, e in enumerate(entries):
                if e is None or e[0] is not self.V or e[1] is not self.F:
                    entries[i] = None
                    continue
                if live is None:
                    live = _signature(self.V, self.F)
                if e[3] != live:
                    entries[i] = None
        values = [None if e is None else e[2] for e in entries]
        return values[0] if len(names) == 1 else tuple(values)

    def remember(self, **values):
        """Keep each ``name=value`` for :meth:`cached` with the current ``V``
        and ``F`` (one checksum of the arrays for all)."""
        if not values:
            return
        sig = _signature(self.V, self.F)
        for name, value in values.items():
            self._cache[name] = (self.V, self.F, value, sig)

    def forget(self):
        """Drop every value :meth:`remember` kept (:meth:`cached` then
        gives None), so that its arrays can be freed."""
        self._cache.clear()

    @property
    def n_vertices(self):
        return int(self.V.shape[0])

    @property
    def n_faces(self):
        return int(self.F.shape[0])


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


def as_written(mesh):
    """The mesh as a file gets it: :func:`written_faces`, and the vertex
    copies of ``mesh.joins`` joined again to the file's vertices they copy
    (the copies dropped, later vertices moved down, every face re-pointed).

    A copy that no longer sits where its vertex is (the arrays were replaced
    since) leaves the mesh as it is.

    Parameters
    ----------
    mesh : Mesh

    Returns
    -------
    Mesh
        ``mesh`` itself when there is nothing to join, else a new mesh
        (``F_out`` and ``joins`` None: it is written as it stands).
    """
    J = getattr(mesh, "joins", None)
    if J is None or len(J) == 0:
        return mesh
    V = np.asarray(mesh.V)
    n = len(V)
    J = np.asarray(J, np.int64)
    if J.max() >= n or not np.array_equal(V[J[:, 0]], V[J[:, 1]]):
        return mesh
    F = written_faces(mesh)
    to = np.arange(n)
    to[J[:, 0]] = J[:, 1]
    keep = np.ones(n, bool)
    keep[J[:, 0]] = False
    at = np.cumsum(keep) - 1

    def rows(a):
        a = None if a is None else np.asarray(a)
        return a[keep] if a is not None and a.shape[:1] == (n,) else a

    return Mesh(V=V[keep], F=at[to[F]], vertex_colors=rows(mesh.vertex_colors),
                vertex_filled=rows(mesh.vertex_filled), face_filled=mesh.face_filled,
                vertex_props={k: rows(a) for k, a in mesh.vertex_props.items()},
                vertex_dtype=mesh.vertex_dtype, path=mesh.path, notes=list(mesh.notes),
                comments=list(getattr(mesh, "comments", [])), fixes=dict(getattr(mesh, "fixes", {})),
                texture=getattr(mesh, "texture", None))
