"""Meshes from and to the types other Python libraries use.

:func:`as_mesh` takes what a user is likely to hold — a
:class:`~shellrepair.mesh.io.Mesh`, a ``(V, F)`` pair, an open3d
``TriangleMesh`` (legacy or tensor), a ``trimesh.Trimesh`` or a file path —
and gives a :class:`~shellrepair.mesh.io.Mesh`; :func:`to_open3d` and
:func:`to_trimesh` go the other way. Neither open3d nor trimesh is imported
unless one of their objects is involved.

>>> import numpy as np
>>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.]]); F = np.array([[0, 1, 2]])
>>> as_mesh((V, F)).n_faces
1
"""

from __future__ import annotations

from os import PathLike
from typing import Any, Tuple, Union

import numpy as np

from shellrepair.errors import MeshError
from shellrepair.mesh.core import Mesh

__all__ = ["as_mesh", "to_open3d", "to_trimesh", "MeshLike"]

#: What :func:`as_mesh` (and so ``repair_mesh``) takes: a Mesh, a ``(V, F)``
#: pair, an open3d (legacy or tensor) or trimesh mesh, or a path (``Any``
#: stands for the other libraries' types, which are optional imports).
MeshLike = Union[Mesh, Tuple[np.ndarray, np.ndarray], str, PathLike, Any]


def _from_arrays(V, F, what):
    from shellrepair.mesh.io import Mesh

    try:
        V = np.asarray(V, dtype=np.float64)
        F = np.asarray(F)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"{what}: vertices and faces must be numeric arrays ({exc})") from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshError(f"{what}: vertices must be an (n,3) array, got shape {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or (F.size and not np.issubdtype(F.dtype, np.integer)):
        raise MeshError(f"{what}: faces must be an (m,3) integer array, got shape {F.shape} of {F.dtype}")
    F = F.astype(np.int64)
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise MeshError(f"{what}: a face refers to a vertex outside 0..{len(V) - 1}")
    return Mesh(V=V, F=F)


def as_mesh(obj: MeshLike) -> Mesh:
    """A :class:`~shellrepair.mesh.io.Mesh` from what the caller holds.

    Parameters
    ----------
    obj : Mesh, (V, F) tuple, open3d.geometry.TriangleMesh,
          open3d.t.geometry.TriangleMesh, trimesh.Trimesh, str or PathLike
        A path is read with :func:`shellrepair.mesh.io.read_mesh` (cleaned and
        oriented); arrays and other libraries' meshes are taken as they
        are (vertex colours kept where present).

    Returns
    -------
    mesh : Mesh
        ``obj`` itself when it is already a Mesh.

    Raises
    ------
    MeshError
        For anything else, or arrays of the wrong shape.
    """
    from shellrepair.mesh.io import Mesh, read_mesh

    if isinstance(obj, Mesh):
        return obj
    if isinstance(obj, (str, PathLike)):
        return read_mesh(obj)
    if isinstance(obj, (tuple, list)) and len(obj) == 2:
        return _from_arrays(obj[0], obj[1], "(V, F)")
    mod = type(obj).__module__ or ""
    name = type(obj).__name__
    if mod.startswith("open3d") and name == "TriangleMesh":
        if hasattr(obj, "vertex") and hasattr(obj, "triangle"):  # tensor API
            V = obj.vertex["positions"].numpy()
            F = obj.triangle["indices"].numpy()
            mesh = _from_arrays(V, F, "open3d TriangleMesh")
            if "colors" in obj.vertex:
                mesh.vertex_colors = _colors_u8(obj.vertex["colors"].numpy())
            return mesh
        mesh = _from_arrays(np.asarray(obj.vertices), np.asarray(obj.triangles), "open3d TriangleMesh")
        if obj.has_vertex_colors():
            mesh.vertex_colors = _colors_u8(np.asarray(obj.vertex_colors))
        return mesh
    if mod.startswith("trimesh") and hasattr(obj, "vertices") and hasattr(obj, "faces"):
        mesh = _from_arrays(np.asarray(obj.vertices), np.asarray(obj.faces), "trimesh")
        vc = getattr(getattr(obj, "visual", None), "vertex_colors", None)
        if getattr(obj.visual, "kind", None) == "vertex" and vc is not None and len(vc) == mesh.n_vertices:
            mesh.vertex_colors = np.asarray(vc, np.uint8)[:, :3].copy()
        return mesh
    raise MeshError(f"cannot take a {mod + '.' if mod else ''}{name} as a mesh "
                    "(expected a Mesh, (V, F), an open3d or trimesh mesh, or a path)")


def _colors_u8(C):
    C = np.asarray(C, np.float64)
    if C.size and C.max() <= 1.0:
        C = C * 255.0
    return np.clip(np.rint(np.nan_to_num(C)), 0, 255).astype(np.uint8)[:, :3]


def to_open3d(mesh: MeshLike, *, tensor: bool = False) -> Any:
    """The mesh as an open3d ``TriangleMesh`` (legacy, or tensor with ``tensor=True``).

    Parameters
    ----------
    mesh : Mesh or anything :func:`as_mesh` takes
    tensor : bool

    Returns
    -------
    open3d.geometry.TriangleMesh or open3d.t.geometry.TriangleMesh
        Positions in float64 (legacy) or float32 (tensor, open3d's usual);
        vertex colours as floats in [0, 1] when the mesh has them.
    """
    import open3d as o3d

    m = as_mesh(mesh)
    if tensor:
        t = o3d.t.geometry.TriangleMesh()
        t.vertex["positions"] = o3d.core.Tensor(np.asarray(m.V, np.float32))
        t.triangle["indices"] = o3d.core.Tensor(np.asarray(m.F, np.int32))
        if m.vertex_colors is not None:
            t.vertex["colors"] = o3d.core.Tensor(np.asarray(m.vertex_colors[:, :3], np.float32) / 255.0)
        return t
    out = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(np.asarray(m.V, np.float64)),
                                    o3d.utility.Vector3iVector(np.asarray(m.F, np.int32)))
    if m.vertex_colors is not None:
        out.vertex_colors = o3d.utility.Vector3dVector(np.asarray(m.vertex_colors[:, :3], np.float64) / 255.0)
    return out


def to_trimesh(mesh: MeshLike) -> Any:
    """The mesh as a ``trimesh.Trimesh`` (not processed: vertices and faces as they are).

    Raises
    ------
    MeshError
        When trimesh is not installed (it is no dependency of shellrepair).
    """
    try:
        import trimesh
    except ImportError:
        raise MeshError("trimesh is not installed (pip install trimesh)") from None
    m = as_mesh(mesh)
    kw = {}
    if m.vertex_colors is not None:
        kw["vertex_colors"] = m.vertex_colors
    return trimesh.Trimesh(vertices=m.V, faces=m.F, process=False, **kw)
