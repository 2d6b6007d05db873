"""shellrepair: fill the holes of 3D scans with smooth shells, report what was
synthesized, and render the result with an aged-metal appearance.

>>> import numpy as np, open3d as o3d, shellrepair
>>> sphere = o3d.geometry.TriangleMesh.create_sphere(radius=1.0, resolution=12)
>>> V, F = np.asarray(sphere.vertices), np.asarray(sphere.triangles)
>>> repaired, report = shellrepair.repair_mesh((V, np.delete(F, [100, 101, 102], axis=0)))
>>> report["holes_before"], report["holes_after"]      # three neighbouring faces missing: one hole
(1, 0)
"""

from shellrepair.errors import MeshError
from shellrepair.holes.loops import boundary_loops, detect_holes
from shellrepair.mesh.convert import as_mesh, to_open3d, to_trimesh
from shellrepair.mesh.io import Mesh, read_mesh, write_mesh
from shellrepair.options import RepairOptions

__version__ = "0.1.0"
__all__ = ["MeshError", "Mesh", "read_mesh", "write_mesh", "detect_holes", "boundary_loops", "repair_mesh",
           "render_mesh", "as_mesh", "to_open3d", "to_trimesh", "RepairOptions", "__version__"]


def __getattr__(name):
    # imported on first use: the solvers and the renderer load libigl / open3d
    if name == "repair_mesh":
        from shellrepair.repair import repair_mesh
        return repair_mesh
    if name == "render_mesh":
        from shellrepair.appearance.render import render_mesh
        return render_mesh
    raise AttributeError(f"module 'shellrepair' has no attribute {name!r}")
