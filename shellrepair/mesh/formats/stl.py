"""STL, binary and ascii; corners welded into shared vertices on exact coordinates.

Why ours and not meshio's or Open3D's reader: measured by ``python
eval/bench_libs.py readers --repeat 1`` on a 1.3M-face sphere (2 cores
shared with other work, load average 17, so the seconds are several times
an idle machine's; their ratios are what counts). "ours" is
``read_mesh`` (checks and notes included), "parser" this module's reader
alone; "same V, F" compares with ours to the bit.

Binary STL (66 MB)::

    reader   seconds  same V, F
    ours       14.38     -
    parser     12.50    yes
    meshio     33.61    yes
    open3d      9.73    yes

Open3D welds the corners into the same vertices in the same order and was
faster here (three more runs of the parser against it, same load:
12.70-14.18 s against 10.72-12.09 s, about 15 %); it is not used because
it reads only from a path (``read_mesh`` reads the bytes once), returns an
empty mesh with a warning where ours names the fault ("truncated or
malformed binary STL: header announces N triangles ...", bytes after the
last triangle, ASCII STL's bad numbers: tests/test_io.py), and its weld is
not specified (ours: exact coordinates, -0.0 as 0.0, numbered in order of
appearance, tested); 15 % of a read that is a small part of a repair does
not pay for a second path through the reader.
"""

from __future__ import annotations

import re

import numpy as np

from shellrepair.errors import MeshError
from shellrepair.mesh.core import Mesh
from shellrepair.mesh.formats.text import to_numbers

__all__ = ["read_stl", "stl_bytes"]


_STL_RECORD = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])


def read_stl(data):
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
        P = to_numbers([t.encode() for row in nums for t in row], np.float64,
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


def stl_bytes(mesh, binary=True):
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
