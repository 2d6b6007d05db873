"""Wavefront OBJ: positions (with optional ``w`` or vertex colours) and faces.

Corners ``v``, ``v/vt``, ``v//vn`` and ``v/vt/vn``, relative indices, line
continuations, comments and CRLF are read; what a triangle mesh does not
hold is skipped, with a note for what carries geometry. Texture
coordinates (``vt``), materials (``usemtl``) and material libraries
(``mtllib``) are kept per face corner and face (:class:`FaceTexture`) and
written back as read.

Why ours and not meshio's or Open3D's reader: measured by ``python
eval/bench_libs.py readers --repeat 1`` on a 1.3M-face sphere (2 cores
shared with other work, load average 17, so the seconds are several times
an idle machine's; their ratios are what counts). "ours" is
``read_mesh`` (checks and notes included), "parser" this module's reader
alone; "same V, F" compares with ours to the bit.

OBJ (113 MB: vertex colours, ``vt`` on every corner, a comment, two
``g`` groups with a ``usemtl`` each, ``mtllib``)::

    reader   seconds  colours           texcoords          groups, materials   same V, F
    ours       16.70  yes               per corner         materials, lines    -
    parser     10.98  yes               per corner         materials, lines    yes
    meshio     37.57  as 3 more point   per vertex         group ids only      no (points are
                      coordinates       (``obj:vt``)                              (n,6): xyz rgb)
    open3d     17.83  yes               per corner         material ids        no (1269762 vertices
                                                                                for 655362: split where
                                                                                the UVs differ)

Neither keeps the per-corner UV rows and material of each face in file
order (``FaceTexture``, written back bit for bit: tests/test_texture.py),
the ``mtllib`` lines, the notes for what is skipped, relative indices with
the messages naming the line (tests/test_io.py); Open3D renumbers the
vertices, so a repaired file would not keep the scan's numbering. No
reader keeps the comments or the group names (we write our own group of
filled faces).
"""

from __future__ import annotations

import re

import numpy as np

from shellrepair.errors import MeshError
from shellrepair.mesh.core import FaceTexture, Mesh, written_faces
from shellrepair.mesh.formats.polygons import polygons_to_triangles
from shellrepair.mesh.formats.text import WS, colors_to_uint8, parse_numbers, token_counts, token_starts

__all__ = ["read_obj", "obj_bytes"]


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


def _numbers_of(mask, mv, starts, ends, least, short):
    """The float values of the lines in ``mask`` (their keyword blanked in
    ``mv``): (values, count per line, offset of each line's first value);
    a line with fewer than ``least`` values, or a bad number, is a
    :class:`MeshError` naming its line (``short``: what a short line lacks)."""
    line_no = np.flatnonzero(mask)
    text = _obj_lines_of(mask, mv, starts, ends)
    cnt = token_counts(text)
    if cnt.min() < least:
        i = int(np.flatnonzero(cnt < least)[0])
        raise MeshError(f"line {line_no[i] + 1}: {short}")
    off = np.zeros(len(cnt), np.int64)
    np.cumsum(cnt[:-1], out=off[1:])
    vals = parse_numbers(text, np.float64, int(cnt.sum()), lambda j, t: (
        f"line {line_no[np.searchsorted(off, j, side='right') - 1] + 1}: bad number '{t}'"))
    return vals, cnt, off


def read_obj(data):
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
    lead = np.flatnonzero(WS[buf[starts]] & (ends > starts))
    blank = ends == starts
    for i in lead.tolist():  # lines that start with white space
        s = data[starts[i]:ends[i]]
        t = s.lstrip()
        if t.strip():
            key[i] += len(s) - len(t)
        else:
            blank[i] = True
    c0, c1, c2 = buf[key], buf[key + 1], buf[key + 2]
    is_v = (c0 == ord("v")) & WS[c1] & ~blank
    is_f = (c0 == ord("f")) & WS[c1] & ~blank
    is_vt = (c0 == ord("v")) & (c1 == ord("t")) & WS[c2]
    is_vn = (c0 == ord("v")) & (c1 == ord("n")) & WS[c2]
    other = np.flatnonzero(~(is_v | is_f | is_vt | is_vn | blank))
    notes = []
    skipped = {}
    materials_at = []       # (line, name) of each usemtl; the mtllib lines as read
    libraries = []
    for i in other.tolist():
        line = data[key[i]:ends[i]]
        k = line.split(None, 1)[0]
        skipped[k] = skipped.get(k, 0) + 1
        if k == b"usemtl":
            materials_at.append((i, line[6:].strip().decode("utf-8", errors="replace")))
        elif k == b"mtllib":
            libraries.append(line.rstrip(b"\r").decode("utf-8", errors="replace"))
    if not is_v.any():
        raise MeshError("no vertices")
    buf[key[is_v | is_f]] = 32  # blank the 'v' and 'f' keywords: what is left are values
    buf[key[is_vt]] = 32
    buf[key[is_vt] + 1] = 32
    mv = buf.tobytes()
    v_line = np.flatnonzero(is_v)
    f_line = np.flatnonzero(is_f)

    # vertices: x y z, x y z w, or x y z r g b (MeshLab's vertex colours)
    vals, cnt, voff = _numbers_of(is_v, mv, starts, ends, 3, "vertex needs 3 coordinates")
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
        mesh.vertex_colors = colors_to_uint8(vals[voff[:, None] + np.arange(3, 6)], notes, "OBJ")
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
    tstart = np.flatnonzero(token_starts(x)) if x.size else np.zeros(0, np.int64)
    cnt = token_counts(text, tstart) if f_line.size else np.zeros(0, np.int64)
    foff = np.zeros(len(cnt), np.int64)
    np.cumsum(cnt[:-1], out=foff[1:])

    def line_of_corner(j):
        return int(f_line[np.searchsorted(foff, j, side="right") - 1] + 1)

    if slashed:
        slash = np.flatnonzero(x == ord("/"))
        parts = np.diff(np.searchsorted(slash, np.append(tstart, x.size))) + 1  # per corner
        pstart = np.zeros(len(parts), np.int64)
        np.cumsum(parts[:-1], out=pstart[1:])
        vals = parse_numbers(text.replace(b"/", b" "), np.int64, int(parts.sum()), lambda j, t: (
            f"line {line_of_corner(np.searchsorted(pstart, j, side='right') - 1)}: bad face index '{t}'"))
        if vals.size != parts.sum():  # an empty part: '1/', '/2', '1///2'
            for j, t in enumerate(text.split()):
                if b"" in t.split(b"/"):
                    raise MeshError(f"line {line_of_corner(j)}: bad face corner "
                                    f"'{t.decode('utf-8', errors='replace')[:40]}'")
            raise MeshError("bad face corners")  # not reached: some corner has an empty part
        idx = vals[::int(parts[0])] if (parts == parts[0]).all() else vals[pstart]
    else:
        idx = parse_numbers(text, np.int64, int(cnt.sum()),
                            lambda j, t: f"line {line_of_corner(j)}: bad face index '{t}'")
    idx = np.array(idx, np.int64)  # own, writable
    vt_idx = None
    if slashed and is_vt.any():
        has = parts >= 2
        vt_idx = np.where(has, vals[np.minimum(pstart + 1, vals.size - 1)], 0).astype(np.int64)
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
    n_vt, n_vn = int(is_vt.sum()), int(is_vn.sum())
    if (n_vt or materials_at) and idx.size and idx.min() >= 0 and idx.max() < len(V):
        # textured: the triangles as corners of the file's faces, so that each
        # keeps its corner's vt and its face's material (the same triangles:
        # the split reads positions only)
        C = polygons_to_triangles((cnt, np.arange(idx.size)), notes, V[idx])
        mesh.F = idx[C]
        mesh.texture = _texture(mv, starts, ends, is_vt, n_vt, vt_idx, f_line, cnt, foff, C,
                                materials_at, libraries, notes)
    else:
        mesh.F = polygons_to_triangles((cnt, idx), notes, V)
        if n_vt:
            notes.append(f"OBJ: {n_vt} texture coordinates (vt) not kept (no face refers to them)")
    if n_vn:
        notes.append(f"OBJ: {n_vn} normals (vn) not kept (shellrepair keeps positions, vertex colours, "
                     "texture coordinates and materials)")
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


def _texture(mv, starts, ends, is_vt, n_vt, vt_idx, f_line, cnt, foff, C, materials_at, libraries, notes):
    """The :class:`FaceTexture` of a read OBJ's triangles ``C`` (corner ids)."""
    uv = np.zeros((0, 2))
    face_uv = np.full(C.shape, -1, np.int64)
    if n_vt:
        vt_line = np.flatnonzero(is_vt)
        vals, tc, toff = _numbers_of(is_vt, mv, starts, ends, 1, "texture coordinate needs a value")
        uv = np.zeros((len(tc), 2))
        uv[:, 0] = vals[toff]
        two = tc >= 2
        uv[two, 1] = vals[toff[two] + 1]
        w = tc >= 3
        if w.any() and (vals[toff[w] + 2] != 0).any():
            notes.append(f"OBJ: the third texture coordinate (w) of {int(w.sum())} vt lines not kept")
        if vt_idx is not None:
            t = vt_idx.copy()
            neg = t < 0
            if neg.any():   # relative: counted back from the last vt above the face's line
                seen = np.repeat(np.searchsorted(vt_line, f_line), cnt)
                t[neg] = seen[neg] + t[neg] + 1
            t -= 1          # 0 (no vt slot) becomes -1
            bad = (t < -1) | (t >= len(uv))
            if bad.any():
                j = int(np.flatnonzero(bad)[0])
                line = int(f_line[np.searchsorted(foff, j, side="right") - 1] + 1)
                raise MeshError(f"line {line}: texture coordinate index {int(vt_idx[j])} out of range "
                                f"({len(uv)} vt lines)")
            face_uv = t[C]
            partial = (face_uv < 0).any(axis=1) & (face_uv >= 0).any(axis=1)
            face_uv[partial] = -1
    names = []
    face_material = np.full(len(C), -1, np.int64)
    if materials_at:
        lines = np.array([i for i, _ in materials_at], np.int64)
        ids = []
        for _, name in materials_at:
            if name not in names:
                names.append(name)
            ids.append(names.index(name))
        poly = np.searchsorted(foff, C[:, 0], side="right") - 1        # each triangle's face line
        at = np.searchsorted(lines, f_line[poly], side="right") - 1     # the usemtl above it
        face_material = np.where(at >= 0, np.asarray(ids, np.int64)[np.maximum(at, 0)], -1)
    return FaceTexture(uv=uv, face_uv=face_uv, face_material=face_material, materials=names,
                       libraries=libraries)


#: OBJ group names of a repaired mesh's faces: what the repair added, and the scan's own.
FILLED_GROUP = "shellrepair_filled"
SCAN_GROUP = "scan"


#: The material name of a repaired textured mesh's filled faces (they have no UVs).
FILLED_MATERIAL = "shellrepair_filled"


def obj_bytes(mesh, binary=True, libraries=()):
    """The mesh as OBJ text: ``v`` (with colours), ``vt``, ``f`` (``a/ta`` where
    a face has texture coordinates), ``mtllib`` and ``usemtl`` as read, and
    the filled faces as the group :data:`FILLED_GROUP` (material
    :data:`FILLED_MATERIAL` where the file has materials); floats with 17
    significant digits, so each reads back to the same bits. ``libraries``:
    more ``mtllib`` lines, after the file's own (the filled faces' library,
    :mod:`shellrepair.mesh.formats.mtl`)."""
    V = np.asarray(mesh.V, np.float64)
    tex = getattr(mesh, "texture", None)
    lines = ["# written by shellrepair"] + ([] if tex is None else list(tex.libraries)) + list(libraries)
    vs = "v " + np.char.mod("%.17g", V[:, 0]) + " " + np.char.mod("%.17g", V[:, 1]) + " " + np.char.mod("%.17g", V[:, 2])
    if mesh.vertex_colors is not None:
        C = np.asarray(mesh.vertex_colors)[:, :3].astype(np.float64) / 255.0
        for j in range(3):
            vs = vs + " " + np.char.mod("%.6g", C[:, j])
    lines += vs.tolist()
    F = written_faces(mesh) + 1
    corner = [np.char.mod("%d", F[:, j]) for j in range(3)]
    k = 0 if tex is None else min(len(tex.face_uv), len(F))
    if k and len(tex.uv):
        U = np.asarray(tex.uv, np.float64)
        # the shortest text that reads back to the same bits
        lines += ("vt " + U[:, 0].astype(str).astype(object) + " " + U[:, 1].astype(str).astype(object)).tolist()
        T = np.asarray(tex.face_uv[:k], np.int64)
        with_uv = np.flatnonzero((T >= 0).all(axis=1))
        for j in range(3):
            corner[j] = corner[j].astype(object)
            corner[j][with_uv] = (corner[j][with_uv].astype(str) + "/"
                                  + np.char.mod("%d", T[with_uv, j] + 1)).astype(object)
    fl = ("f " + corner[0].astype(str) + " " + corner[1].astype(str) + " " + corner[2].astype(str)).tolist()
    filled = None if mesh.face_filled is None else np.asarray(mesh.face_filled, bool)
    if filled is not None and (not filled.any() or len(filled) != len(fl)):
        filled = None
    material = None
    if tex is not None and tex.materials:
        names = list(tex.materials) + [FILLED_MATERIAL]
        material = np.full(len(fl), len(names) - 1, np.int64)
        material[:k] = tex.face_material[:k]
    if filled is None and material is None:
        return "\n".join(lines + fl) + "\n"
    # OBJ has no per-face flags: the filled faces are the group FILLED_GROUP
    # (the rest SCAN_GROUP), a group line where the flag changes, a usemtl
    # line where the material does, faces in order
    key = np.zeros((len(fl), 2), np.int64)
    if filled is not None:
        key[:, 0] = filled
    if material is not None:
        key[:, 1] = material
    change = np.flatnonzero((np.diff(key, axis=0) != 0).any(axis=1)) + 1
    at, group, mat = 0, None, -1
    for end in list(change) + [len(fl)]:
        if filled is not None and filled[at] != group:
            group = filled[at]
            lines.append(f"g {FILLED_GROUP if group else SCAN_GROUP}")
        if material is not None and material[at] != mat and material[at] >= 0:
            mat = material[at]
            lines.append(f"usemtl {names[mat]}")
        lines += fl[at:end]
        at = end
    return "\n".join(lines) + "\n"
