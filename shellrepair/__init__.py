"""shellrepair: fill the holes of 3D scans with smooth shells, report what was
synthesized, and render the result with an aged-metal appearance."""

from .errors import MeshError
from .io import Mesh, read_mesh, write_mesh
from .holes import detect_holes, boundary_loops

__version__ = "0.1.0"
__all__ = ["MeshError", "Mesh", "read_mesh", "write_mesh", "detect_holes", "boundary_loops", "__version__"]
