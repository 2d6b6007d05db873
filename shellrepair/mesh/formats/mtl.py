"""The material of a repaired textured OBJ's filled faces: a flat colour taken from the scan at the rims.

A textured scan's filled faces have no texture coordinates (nothing was
photographed there), so they get a material of their own,
:data:`shellrepair.mesh.formats.obj.FILLED_MATERIAL`. So that a viewer draws
them in the scan's colour rather than its default white or grey, the
repaired OBJ comes with a small companion library, ``<out>.filled.mtl``
(:func:`companion_name`), defining that material with a flat diffuse colour
(``Kd``) taken from the scan around the fills (:func:`rim_colour`): each
scan face corner at a vertex a filled face uses, coloured by its material's
texture image (``map_Kd``, sampled at the corner's UV, bilinear, repeating)
or, without an image, by its material's ``Kd``; the mean of those corners.
The user's own material libraries are read, never written.

    colour = rim_colour(mesh, folder)       # (3,) in [0, 1], or None
    text = filled_library(colour)           # the companion .mtl text
"""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np

__all__ = ["read_mtl", "rim_colour", "filled_library", "companion_name", "NEUTRAL"]

#: Diffuse colour of the filled faces where the scan gives none (no image or Kd found).
NEUTRAL = (0.5, 0.5, 0.5)


def read_mtl(path):
    """The materials of one ``.mtl`` file: ``{name: {"Kd": (3,) or None, "map_Kd": Path or None}}``.

    ``map_Kd``'s options (``-s``, ``-o``, ``-bm`` ...) are skipped; its
    file name is resolved against the library's folder. A line that does
    not parse is skipped (a library is the user's, read as far as it goes).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    materials : dict
    """
    path = Path(path)
    out, cur = {}, None
    for raw in path.read_text(errors="replace").splitlines():
        t = raw.strip().split(None, 1)
        if not t or t[0].startswith("#"):
            continue
        key, rest = t[0], (t[1] if len(t) > 1 else "")
        if key == "newmtl":
            cur = out.setdefault(rest.strip(), {"Kd": None, "map_Kd": None})
        elif cur is None:
            continue
        elif key == "Kd":
            try:
                kd = np.array([float(x) for x in rest.split()[:3]], np.float64)
            except ValueError:
                continue
            if kd.size == 3 and np.isfinite(kd).all():
                cur["Kd"] = np.clip(kd, 0.0, 1.0)
        elif key == "map_Kd" and rest.strip():
            try:
                words = shlex.split(rest, posix=True)
            except ValueError:
                words = rest.split()
            if words:
                cur["map_Kd"] = path.parent / words[-1]      # the options come before the file name
    return out


def _libraries(lines, folder):
    """The material libraries named by ``mtllib`` lines, read from ``folder`` (missing ones skipped)."""
    mats = {}
    for line in lines:
        for name in line.split()[1:]:
            p = Path(folder) / name
            if p.is_file():
                for k, v in read_mtl(p).items():
                    mats.setdefault(k, v)
    return mats


def _sample(image, uv):
    """Bilinear samples (p,3) in [0, 1] of an (h,w,3) uint8 image at UVs (p,2)
    (OBJ's v up, repeating outside [0, 1])."""
    h, w = image.shape[:2]
    u = np.mod(uv[:, 0], 1.0) * w - 0.5
    v = (1.0 - np.mod(uv[:, 1], 1.0)) * h - 0.5
    x0, y0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fx, fy = (u - x0)[:, None], (v - y0)[:, None]
    img = image.astype(np.float64) / 255.0

    def at(x, y):
        return img[np.mod(y, h), np.mod(x, w)]

    return ((1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0)
            + (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1))


def rim_colour(mesh, folder):
    """The mean colour of the scan's face corners at the vertices the filled faces use.

    Parameters
    ----------
    mesh : shellrepair.mesh.core.Mesh
        A repaired mesh with ``texture`` (a :class:`~shellrepair.mesh.core.FaceTexture`)
        and ``face_filled``.
    folder : str or Path
        Where the scan's material libraries are (the input file's folder).

    Returns
    -------
    colour : (3,) float64 in [0, 1], or None
        None where no corner at a rim has a colour (no library, no image
        or ``Kd`` for its material, or no filled face).
    """
    tex = getattr(mesh, "texture", None)
    filled = getattr(mesh, "face_filled", None)
    if tex is None or filled is None or not np.asarray(filled).any() or not tex.materials:
        return None
    F = np.asarray(mesh.F, np.int64)
    k = min(len(tex.face_uv), len(F))
    at_fill = np.zeros(len(mesh.V), bool)
    at_fill[F[np.asarray(filled, bool)]] = True
    rows, cols = np.nonzero(at_fill[F[:k]])
    mat = np.asarray(tex.face_material, np.int64)[rows]
    if not rows.size:
        return None
    library = _libraries(tex.libraries, folder)
    colours = []
    for m in np.unique(mat[mat >= 0]):
        spec = library.get(tex.materials[m])
        if spec is None:
            continue
        sel = mat == m
        image = None
        if spec["map_Kd"] is not None and Path(spec["map_Kd"]).is_file():
            from PIL import Image, UnidentifiedImageError

            try:
                with Image.open(spec["map_Kd"]) as im:
                    image = np.asarray(im.convert("RGB"))
            except (OSError, UnidentifiedImageError):
                image = None
        corner_uv = np.asarray(tex.face_uv, np.int64)[rows[sel], cols[sel]]
        if image is not None and image.size:
            ok = corner_uv >= 0
            if ok.any():
                colours.append(_sample(image, np.asarray(tex.uv, np.float64)[corner_uv[ok]]))
                continue
        if spec["Kd"] is not None:
            colours.append(np.repeat(spec["Kd"][None], int(sel.sum()), axis=0))
    if not colours:
        return None
    return np.concatenate(colours).mean(axis=0)


def companion_name(path):
    """The companion library's file name for an OBJ written to ``path``:
    ``<stem>.filled.mtl`` (white space made ``_``: ``mtllib`` splits names on it)."""
    return "_".join((Path(path).stem + ".filled.mtl").split())


def filled_library(colour):
    """The companion library's text: the filled faces' material, matte, in ``colour``
    (:data:`NEUTRAL` where None, and a comment says so)."""
    from shellrepair.mesh.formats.obj import FILLED_MATERIAL

    how = "the mean colour of the scan at the rims of the fills"
    if colour is None:
        colour, how = NEUTRAL, "no colour found at the rims of the fills: neutral grey"
    c = np.clip(np.asarray(colour, np.float64), 0.0, 1.0)
    return (f"# written by shellrepair: the material of the faces it added ({how})\n"
            f"newmtl {FILLED_MATERIAL}\n"
            f"Ka 0 0 0\nKd {c[0]:.6f} {c[1]:.6f} {c[2]:.6f}\nKs 0 0 0\nillum 1\n")
