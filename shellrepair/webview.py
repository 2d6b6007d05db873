"""The repaired mesh as a turnable 3D view inside an HTML page.

A page's viewer draws a *display copy* of the repaired mesh with WebGL
(the script is :file:`shellrepair/webview.js`, written for this package,
inlined into the page, so the page needs no network and opens from disk):

- above :data:`DISPLAY_FACES` faces the copy is decimated (quadric edge
  collapse, fast-simplification); each face of the copy keeps the filled
  flag and the filled region of the original face nearest to its centroid,
  and each vertex the material of the original surface nearest to it
  (barycentric on that face). The repaired mesh itself is never changed;
- the material is glTF's metallic-roughness approximation of the aged
  look, from the same aging maps and the same formulas as the ``.glb``
  export (:func:`shellrepair.gltf.pbr_approximation`);
- the faces are ordered scan first, then the filled faces region by
  region (a region: filled faces joined by edges), so the viewer draws
  the filled part with or without its tint and frames one region from a
  button;
- the edges left open (holes not filled, borders) are the original
  mesh's boundary edges, drawn as lines.

The payload is a dict of plain JSON values; arrays are little-endian
bytes in base64: positions as uint16 over the box ``lo``..``hi`` (1/65535
of the box, finer than a pixel of any page), indices as uint16 or uint32,
colours as uint8 (sRGB base colour; metallic and roughness).

    view = view_payload(repaired_mesh, up=(0, 1, 0))   # dict
    html = viewer_html(view, "view-1")                  # a <div>, data inline
    assets = viewer_assets()                            # <style> and <script>, once per page
"""

from __future__ import annotations

import base64
import json
from importlib import resources

import numpy as np

__all__ = ["DISPLAY_FACES", "display_copy", "view_payload", "decode_payload", "viewer_html", "viewer_assets",
           "payload_script", "filled_regions", "PAYLOAD_VERSION"]

#: Faces above which the page's copy of the mesh is decimated (to this many).
DISPLAY_FACES = 300_000
#: Version of the payload's layout (read by webview.js).
PAYLOAD_VERSION = 1
#: Largest value of a quantized coordinate.
_Q = 65535


def filled_regions(F, filled):
    """Filled regions: the filled faces joined by an edge, numbered in order
    of their first face.

    Parameters
    ----------
    F : (m,3) int array
    filled : (m,) bool array

    Returns
    -------
    region : (m,) int64 array
        The region of each filled face (0, 1, ...), -1 for the scan's faces.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    F = np.asarray(F, np.int64)
    filled = np.asarray(filled, bool)
    region = np.full(len(F), -1, np.int64)
    idx = np.flatnonzero(filled)
    if len(idx) == 0:
        return region
    Ff = F[idx]
    # half-edges of the filled faces, keyed by their undirected edge
    a = Ff.ravel()
    b = Ff[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * (int(F.max()) + 1) + np.maximum(a, b)
    face = np.repeat(np.arange(len(idx)), 3)
    order = np.argsort(key, kind="stable")
    k, f = key[order], face[order]
    same = k[1:] == k[:-1]
    A = coo_matrix((np.ones(int(same.sum()), np.int8), (f[:-1][same], f[1:][same])), shape=(len(idx), len(idx)))
    _, lab = connected_components(A, directed=False)
    # renumber by first face, so the numbering does not depend on the solver's
    _, first = np.unique(lab, return_index=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    region[idx] = rank[lab]
    return region


def display_copy(V, F, *, max_faces=DISPLAY_FACES):
    """The mesh as a page draws it: itself up to ``max_faces`` faces, else a
    decimated copy, with where each of its faces and vertices lies on the
    original.

    Parameters
    ----------
    V : (n,3) float64 array
    F : (m,3) int64 array
    max_faces : int
        The face budget of the page.

    Returns
    -------
    Vd : (p,3) float64 array
    Fd : (q,3) int64 array
        ``q <= max_faces`` (the mesh itself when ``m <= max_faces``).
    face_source : (q,) int64 array
        The original face nearest to each face's centroid.
    vertex_face : (p,) int64 array
        The original face nearest to each vertex.
    vertex_bary : (p,3) float64 array
        The nearest point's barycentric coordinates on that face.
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if max_faces < 1:
        raise ValueError(f"the face budget must be positive, got {max_faces}")
    if len(F) <= max_faces:
        used = np.zeros(len(V), bool)
        used[F.ravel()] = True
        keep = np.flatnonzero(used)
        remap = np.full(len(V), -1, np.int64)
        remap[keep] = np.arange(len(keep))
        Fd = remap[F]
        # each vertex on one of its own faces, at that corner
        vf = np.empty(len(V), np.int64)
        corner = np.empty(len(V), np.int64)
        vf[F.ravel()[::-1]] = np.repeat(np.arange(len(F)), 3)[::-1]
        corner[F.ravel()[::-1]] = np.tile(np.arange(3), len(F))[::-1]
        bary = np.zeros((len(keep), 3))
        bary[np.arange(len(keep)), corner[keep]] = 1.0
        return V[keep], Fd, np.arange(len(F), dtype=np.int64), vf[keep], bary
    import fast_simplification
    import open3d as o3d

    Vd, Fd = fast_simplification.simplify(V.astype(np.float32), F.astype(np.int32),
                                          target_reduction=1.0 - max_faces / len(F))
    Vd = np.asarray(Vd, np.float64)
    Fd = np.asarray(Fd, np.int64)
    # where the copy lies on the original: its nearest surface point
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    near_c = scene.compute_closest_points(o3d.core.Tensor(Vd[Fd].mean(axis=1).astype(np.float32)))
    near_v = scene.compute_closest_points(o3d.core.Tensor(Vd.astype(np.float32)))
    face_source = near_c["primitive_ids"].numpy().astype(np.int64)
    vertex_face = near_v["primitive_ids"].numpy().astype(np.int64)
    uv = near_v["primitive_uvs"].numpy().astype(np.float64)
    bary = np.column_stack([1.0 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]])
    return Vd, Fd, face_source, vertex_face, np.clip(bary, 0.0, 1.0)


def _b64(a):
    return base64.b64encode(np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<"), copy=False).tobytes()).decode(
        "ascii")


def _srgb8(linear):
    """Linear [0, 1] values as 8-bit sRGB (IEC 61966-2-1 transfer)."""
    c = np.clip(np.asarray(linear, np.float64), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


def _unit(x):
    n = float(np.linalg.norm(x))
    return (np.asarray(x, np.float64) / n) if n > 0 and np.isfinite(n) else None


def view_payload(mesh, *, up=(0.0, 1.0, 0.0), age=None, seed=0, material="aged-bronze", max_faces=DISPLAY_FACES):
    """What a page's 3D view draws, as plain JSON values.

    Parameters
    ----------
    mesh : shellrepair.io.Mesh
        The repaired mesh (``face_filled`` marks the synthesized faces), or
        any mesh.
    up : (3,) sequence
        The scan's up axis: the camera turns about it, and the aging's
        rain comes down it.
    age : float, optional
        In [0, 1]; default :data:`shellrepair.aging.DEFAULT_AGE`.
    seed : int
        Seed of the aging's blotch noise.
    material : str
        A preset of :data:`shellrepair.materials.MATERIALS`.
    max_faces : int
        The page's face budget (:data:`DISPLAY_FACES`).

    Returns
    -------
    payload : dict or None
        None for a mesh without faces. Keys: ``version``; ``lo``, ``hi``
        (the box of the quantized positions); ``positions`` (uint16, 3 per
        vertex); ``index`` (``index_bytes`` 2 or 4 per corner) with the
        faces ordered scan first, then each region's; ``scan_faces``;
        ``regions`` (``start``, ``count`` in the display copy, ``faces`` in
        the mesh, ``centre``, ``radius``, ``normal``); ``color`` (uint8 sRGB,
        3 per vertex); ``mr`` (uint8 metallic, roughness per vertex);
        ``edges`` (uint16 positions, 2 ends per edge left open); ``up``;
        ``view`` (unit vector from the centre to the first camera);
        ``faces_total``, ``faces_shown``; ``tint``, ``edge_color`` (sRGB 0-255).
    """
    from . import aging as ag
    from .gltf import pbr_approximation
    from .htmlreport import OPEN_EDGE_COLOR, _tint
    from .topology import edge_topology

    V = np.asarray(mesh.V, np.float64)
    F = np.asarray(mesh.F, np.int64)
    if len(F) == 0:
        return None
    filled = np.zeros(len(F), bool) if mesh.face_filled is None else np.asarray(mesh.face_filled, bool)
    upv = _unit(up)
    if upv is None:
        raise ValueError(f"the up axis must be a non-zero vector, got {tuple(up)}")
    # the look: the aging maps of the whole repaired mesh (the scan's frame), as the .glb has it
    maps = ag.aging_maps(V, F, age=ag.DEFAULT_AGE if age is None else float(age), up=upv, seed=seed,
                         scan=~filled if filled.any() else None)
    base, metallic, rough = pbr_approximation(maps.coverage, maps.gild, maps.crust, material)
    region = filled_regions(F, filled)
    Vd, Fd, src, vface, vbary = display_copy(V, F, max_faces=max_faces)
    corners = F[vface]                                    # (p,3): the face each display vertex lies on
    w = vbary[:, :, None]
    base_d = (w * base[corners]).sum(axis=1)
    mr_d = np.column_stack([(vbary * metallic[corners]).sum(axis=1), (vbary * rough[corners]).sum(axis=1)])
    reg_d = region[src]
    order = np.lexsort((np.arange(len(Fd)), reg_d))      # scan (-1) first, then region by region
    Fd, reg_d = Fd[order], reg_d[order]
    # the edges left open, on the original surface
    topo = edge_topology(F, len(V))
    E = topo.edges[topo.edge_count == 1]
    P = V[E.ravel()] if len(E) else np.zeros((0, 3))
    allp = np.vstack([Vd, P])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)

    def quant(X):
        return np.round((X - lo) / span * _Q).astype(np.uint16)

    n_regions = int(region.max()) + 1 if filled.any() else 0
    regions = []
    starts = np.searchsorted(reg_d, np.arange(n_regions + 1))
    fa = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    for k in range(n_regions):
        sel = region == k
        pts = V[np.unique(F[sel])]
        c = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        nrm = _unit(fa[sel].sum(axis=0))
        regions.append({"start": int(starts[k]), "count": int(starts[k + 1] - starts[k]),
                        "faces": int(sel.sum()), "centre": [float(x) for x in c],
                        "radius": float(np.sqrt(((pts - c) ** 2).sum(axis=1).max())),
                        "normal": None if nrm is None else [float(x) for x in nrm]})
    # the first camera: looking at the filled part as the page's picture does, else the default view
    from .render import DEFAULT_VIEW, view_towards

    az, el = (view_towards(V, F, filled, up=upv) if filled.any() else None) or DEFAULT_VIEW
    ref = np.array([0.0, 0.0, 1.0]) if abs(upv[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    a = _unit(ref - upv * (ref @ upv))
    b = np.cross(upv, a)
    azr, elr = np.radians(az), np.radians(el)
    view = np.cos(elr) * (np.cos(azr) * a + np.sin(azr) * b) + np.sin(elr) * upv
    index_dtype = np.uint16 if len(Vd) <= 65535 else np.uint32
    return {
        "version": PAYLOAD_VERSION,
        "lo": [float(x) for x in lo], "hi": [float(x) for x in hi],
        "positions": _b64(quant(Vd)),
        "index": _b64(Fd.astype(index_dtype)), "index_bytes": int(np.dtype(index_dtype).itemsize),
        "vertices_shown": int(len(Vd)), "faces_shown": int(len(Fd)), "faces_total": int(len(F)),
        "scan_faces": int(np.count_nonzero(reg_d < 0)),
        "regions": regions,
        "color": _b64(_srgb8(base_d)),
        "mr": _b64(np.round(np.clip(mr_d, 0.0, 1.0) * 255.0).astype(np.uint8)),
        "edges": _b64(quant(P)), "open_edges": int(len(E)),
        "up": [float(x) for x in upv], "view": [float(x) for x in view],
        "tint": _tint(), "edge_color": list(OPEN_EDGE_COLOR),
    }


def decode_payload(payload):
    """The arrays of a payload (:func:`view_payload`), as the viewer reads them.

    Parameters
    ----------
    payload : dict

    Returns
    -------
    arrays : dict
        ``V`` (p,3) float64 (dequantized), ``F`` (q,3) int64, ``filled``
        (q,) bool, ``region`` (q,) int64 (-1 for the scan), ``color``
        (p,3) uint8, ``metallic`` and ``roughness`` (p,) float64 in [0, 1],
        ``edges`` (k,2,3) float64.
    """
    if payload.get("version") != PAYLOAD_VERSION:
        raise ValueError(f"unknown view payload version {payload.get('version')!r} (expected {PAYLOAD_VERSION})")
    lo, hi = np.asarray(payload["lo"]), np.asarray(payload["hi"])
    span = np.where(hi > lo, hi - lo, 1.0)

    def arr(key, dtype, cols):
        a = np.frombuffer(base64.b64decode(payload[key]), np.dtype(dtype).newbyteorder("<"))
        return a.reshape(-1, cols)

    V = lo + arr("positions", np.uint16, 3).astype(np.float64) / _Q * span
    F = arr("index", {2: np.uint16, 4: np.uint32}[payload["index_bytes"]], 3).astype(np.int64)
    region = np.full(len(F), -1, np.int64)
    for k, r in enumerate(payload["regions"]):
        region[r["start"]:r["start"] + r["count"]] = k
    mr = arr("mr", np.uint8, 2).astype(np.float64) / 255.0
    E = lo + arr("edges", np.uint16, 3).astype(np.float64) / _Q * span
    return {"V": V, "F": F, "filled": region >= 0, "region": region, "color": arr("color", np.uint8, 3),
            "metallic": mr[:, 0], "roughness": mr[:, 1], "edges": E.reshape(-1, 2, 3)}


def _asset(name):
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def viewer_assets():
    """The viewer's style and script, to put once in a page that has views.

    Returns
    -------
    html : str
        A ``<style>`` and a ``<script>`` element.
    """
    return f"<style>{_asset('webview.css')}</style>\n<script>{_asset('webview.js')}</script>"


def _json(payload):
    # compact; "</" never occurs in base64 or numbers, but a label might carry it one day
    return json.dumps(payload, separators=(",", ":"), sort_keys=True).replace("</", "<\\/")


def viewer_html(payload=None, element_id="view", *, src=None, eager=None, caption=True):
    """One view's element: the canvas is made when the page opens (``eager``)
    or when it scrolls into sight.

    Parameters
    ----------
    payload : dict, optional
        From :func:`view_payload`, embedded in the page.
    element_id : str
        The element's id (unique in the page).
    src : str, optional
        Instead of ``payload``: the relative path of a script written by
        :func:`payload_script` beside the page, loaded when the view starts.
    eager : bool, optional
        Start the view when the page opens, not when it is scrolled to;
        default: when its payload is embedded (a page of one scan).
    caption : bool
        Say below the view what it shows.

    Returns
    -------
    html : str
    """
    import html as _html

    if (payload is None) == (src is None):
        raise ValueError("a view needs either a payload or a src, not both")
    eid = _html.escape(element_id, quote=True)
    attrs = f'class="srv" id="{eid}"'
    data = ""
    if src is not None:
        attrs += f' data-src="{_html.escape(src, quote=True)}"'
    else:
        data = f'<script type="application/json" class="srv-data">{_json(payload)}</script>'
    if eager if eager is not None else src is None:
        attrs += ' data-eager="1"'
    cap = ('<figcaption>3D view of the repaired mesh: drag to turn, right-drag or shift-drag to move, '
           'wheel or pinch to zoom; filled faces tinted, edges left open drawn in blue.</figcaption>'
           if caption else "")
    return (f'<figure class="srv-fig"><div {attrs}><div class="srv-msg">3D view: loads when shown '
            f'(<button type="button" class="srv-start">show now</button>)</div>{data}</div>{cap}</figure>')


def payload_script(payload, key):
    """A payload as a script file to write beside a page (a collection
    page's views load theirs only when shown).

    Parameters
    ----------
    payload : dict
    key : str
        The name the page knows it by: the script's path as the page's
        ``src`` gives it.

    Returns
    -------
    text : str
    """
    return (f"(window.shellrepairViews=window.shellrepairViews||{{}})[{json.dumps(key)}]="
            f"{_json(payload)};\n")
