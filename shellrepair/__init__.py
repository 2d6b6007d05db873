"""shellrepair: fill the holes of 3D scans with smooth shells, report what was
synthesized, and render the result with an aged-metal appearance.

>>> import shellrepair
>>> from shellrepair.shapes import icosphere
>>> V, F = icosphere(2)
>>> repaired, report = shellrepair.repair_mesh((V, F[5:]))   # a sphere missing five faces
>>> report["holes_before"], report["holes_after"]
(1, 0)
"""

from .errors import MeshError
from .io import Mesh, read_mesh, write_mesh
from .holes import detect_holes, boundary_loops
from .convert import as_mesh, to_open3d, to_trimesh
from .options import RepairOptions

__version__ = "0.1.0"
__all__ = ["MeshError", "Mesh", "read_mesh", "write_mesh", "detect_holes", "boundary_loops", "repair_mesh",
           "render_mesh", "as_mesh", "to_open3d", "to_trimesh", "RepairOptions", "__version__"]


def __getattr__(name):
    # imported on first use: the solvers and the renderer load libigl / open3d
    if name == "repair_mesh":
        from .repair import repair_mesh
        return repair_mesh
    if name == "render_mesh":
        from .render import render_mesh
        return render_mesh
    raise AttributeError(f"module 'shellrepair' has no attribute {name!r}")
