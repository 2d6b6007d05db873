"""Object File Format: ``OFF`` and its variants (``COFF``, ``NOFF``, ``STOFF`` ...).

Why ours and not meshio's or Open3D's reader: measured by ``python
eval/bench_libs.py readers --repeat 1`` on a 1.3M-face sphere (2 cores
shared with other work, load average 17, so the seconds are several times
an idle machine's; their ratios are what counts). "ours" is
``read_mesh`` (checks and notes included), "parser" this module's reader
alone; "same V, F" compares with ours to the bit.

COFF (64 MB, vertex colours, a comment) and plain OFF (54 MB)::

    reader   COFF s  colours  same V, F   OFF s   same V, F
    ours       8.35    yes       -         4.32      -
    parser     6.79    yes      yes        2.76     yes
    meshio    fails (reads only "OFF")     6.56     yes
    open3d     8.79    yes      no         7.51     no

Open3D reads the coordinates as float32 (0.1 comes back as
0.10000000149011612), so its meshes are not the file's; meshio reads no
colour and no OFF variant (``COFF``, ``NOFF``, ...: tests/test_io.py's
test_off_variants), and is slower than ours on the file it reads.
"""

from __future__ import annotations

import re

import numpy as np

from shellrepair.errors import MeshError
from shellrepair.mesh.core import Mesh, written_faces
from shellrepair.mesh.formats.polygons import polygons_to_triangles
from shellrepair.mesh.formats.text import colors_to_uint8, parse_numbers, token_counts

__all__ = ["read_off", "off_bytes"]


def read_off(data):
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
    per_line = token_counts(data)
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
    vals = parse_numbers(text, np.float64, int(cnt.sum()), lambda j, t: (
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
            mesh.vertex_colors = colors_to_uint8(C, notes, "OFF", unit=True)
        else:
            notes.append("OFF: vertex colours dropped (not 3 or 4 values on every vertex)")
    elif nv and (cnt > announced).any():
        notes.append(f"OFF: values after the {announced} per vertex that '{head[0].decode()}' announces ignored")

    text, cnt = span(rest[nv:nv + nf])
    try:
        vals = parse_numbers(text, np.int64, int(cnt.sum()), lambda j, t: "")
    except MeshError:  # face colours as decimals
        vals = parse_numbers(text, np.float64, int(cnt.sum()), lambda j, t: (
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
    mesh.F = polygons_to_triangles((k, flat), notes, V)
    mesh.notes.extend(notes)
    return mesh


def off_bytes(mesh, binary=True):
    V = np.asarray(mesh.V, np.float64)
    F = written_faces(mesh)
    lines = ["OFF", f"{len(V)} {len(F)} 0"]
    lines += (np.char.mod("%.17g", V[:, 0]) + " " + np.char.mod("%.17g", V[:, 1]) + " "
              + np.char.mod("%.17g", V[:, 2])).tolist()
    lines += ("3 " + np.char.mod("%d", F[:, 0]) + " " + np.char.mod("%d", F[:, 1]) + " "
              + np.char.mod("%d", F[:, 2])).tolist()
    return "\n".join(lines) + "\n"
