"""The file formats, one module each: what each reads and writes.

Each format module has a reader ``read_<fmt>(data) -> Mesh`` (the file's
bytes in; a :class:`~shellrepair.mesh.core.Mesh` with ``notes`` out, neither
validated nor cleaned: :func:`shellrepair.mesh.io.read_mesh` does that) and a
writer ``<fmt>_bytes(mesh, binary) -> bytes or str``. :data:`READERS` and
:data:`WRITERS` map an extension to them.

* :mod:`.ply`: ascii and both binary byte orders; colours, ``filled`` flags,
  other vertex properties, the faces' texture coordinates (``texcoord``,
  ``texnumber``) and comments kept.
* :mod:`.obj`: Wavefront OBJ with vertex colours, texture coordinates and
  materials.
* :mod:`.off`: OFF and its variants (``COFF``, ``NOFF``, ``STOFF`` ...).
* :mod:`.stl`: binary and ascii STL, corners welded on exact coordinates.
* :mod:`.polygons`: polygons split into triangles inside their outline.
* :mod:`.text`: the tokenizer and number parser the text formats share.
"""

from shellrepair.mesh.formats.obj import obj_bytes, read_obj
from shellrepair.mesh.formats.off import off_bytes, read_off
from shellrepair.mesh.formats.ply import ply_bytes, read_ply
from shellrepair.mesh.formats.stl import read_stl, stl_bytes

__all__ = ["READERS", "WRITERS", "SUPPORTED"]

#: Extension -> ``reader(data: bytes) -> Mesh``.
READERS = {".ply": read_ply, ".obj": read_obj, ".off": read_off, ".stl": read_stl}
#: Extension -> ``writer(mesh, binary: bool) -> bytes or str``.
WRITERS = {".ply": ply_bytes, ".obj": obj_bytes, ".off": off_bytes, ".stl": stl_bytes}
#: The extensions read and written (lower case).
SUPPORTED = tuple(READERS)
