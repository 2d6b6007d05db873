"""The repaired mesh as a turnable 3D view inside an HTML page.

A page's viewer draws a *display copy* of the repaired mesh with WebGL
(the script is :file:`shellrepair/report/webview.js`, written for this package,
inlined into the page, so the page needs no network and opens from disk):

- above :data:`DISPLAY_FACES` faces the copy is decimated (quadric edge
  collapse, fast-simplification); each face of the copy keeps the filled
  flag and the filled region of the original face it stands for, and each
  vertex the mean material of the original vertices collapsed into it.
  The repaired mesh itself is never changed;
- the material is glTF's metallic-roughness approximation of the aged
  look, from the same aging maps and the same formulas as the ``.glb``
  export (:func:`shellrepair.appearance.gltf.pbr_approximation`);
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
    from shellrepair.mesh.topology import edge_topology, face_pieces

    F = np.asarray(F, np.int64)
    filled = np.asarray(filled, bool)
    region = np.full(len(F), -1, np.int64)
    idx = np.flatnonzero(filled)
    if len(idx) == 0:
        return region
    Ff = F[idx]
    # the pieces of the filled faces, as closeups.fill_regions finds them
    _, lab = face_pieces(edge_topology(Ff, int(F.max()) + 1), len(Ff))
    # renumber by first face, so the numbering does not depend on the solver's
    _, first = np.unique(lab, return_index=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    region[idx] = rank[lab]
    return region


def _face_keys(T, n):
    s = np.sort(np.asarray(T, np.int64), axis=1)
    return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]


def display_copy(V, F, *, max_faces=DISPLAY_FACES):
    """The mesh as a page draws it: itself up to ``max_faces`` faces, else a
    decimated copy, with where its faces and vertices come from.

    Decimation is fast-simplification's quadric edge collapse. Each vertex
    of the copy stands for the original vertices collapsed into it (read
    from the collapses the library reports; a face of the copy is an
    original face whose corners moved, so each face knows its original).
    Should a version of the library number its output otherwise, the
    nearest original vertex and face centroid are used instead.

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
        ``q <= max_faces`` (the mesh itself, unused vertices dropped, when
        ``m <= max_faces``).
    face_source : (q,) int64 array
        The original face each face of the copy stands for.
    vertex_map : (n,) int64 array
        The vertex of the copy each original vertex went to (-1 for a
        vertex of no face).
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if max_faces < 1:
        raise ValueError(f"the face budget must be positive, got {max_faces}")
    n = len(V)
    if len(F) <= max_faces:
        used = np.zeros(n, bool)
        used[F.ravel()] = True
        keep = np.flatnonzero(used)
        remap = np.full(n, -1, np.int64)
        remap[keep] = np.arange(len(keep))
        return V[keep], remap[F], np.arange(len(F), dtype=np.int64), remap
    import fast_simplification

    Vd, Fd, collapses = fast_simplification.simplify(V.astype(np.float32), F.astype(np.int32),
                                                     target_reduction=1.0 - max_faces / len(F),
                                                     return_collapses=True)
    Vd = np.asarray(Vd, np.float64)
    Fd = np.asarray(Fd, np.int64)
    collapses = np.asarray(collapses, np.int64).reshape(-1, 2)
    # each collapse (kept, removed) sends a vertex to another; follow the chains
    parent = np.arange(n, dtype=np.int64)
    parent[collapses[:, 1]] = collapses[:, 0]
    while True:
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    used = np.zeros(n, bool)
    used[F.ravel()] = True
    roots = np.unique(parent[used])
    rank = np.full(n, -1, np.int64)
    rank[roots] = np.arange(len(roots))
    vertex_map = np.where(used, rank[parent], -1)
    # the original faces whose corners stay apart are the copy's faces, one for one
    M = vertex_map[F]
    alive = np.flatnonzero((M[:, 0] != M[:, 1]) & (M[:, 1] != M[:, 2]) & (M[:, 0] != M[:, 2]))
    ok = len(roots) == len(Vd) and len(alive) == len(Fd)
    if ok:
        kd, ka = _face_keys(Fd, len(Vd)), _face_keys(M[alive], len(Vd))
        od, oa = np.argsort(kd, kind="stable"), np.argsort(ka, kind="stable")
        ok = np.array_equal(kd[od], ka[oa])
    if ok:
        face_source = np.empty(len(Fd), np.int64)
        face_source[od] = alive[oa]
        return Vd, Fd, face_source, vertex_map
    from scipy.spatial import cKDTree  # another numbering: the nearest instead

    vertex_map = np.where(used, cKDTree(Vd).query(V)[1], -1).astype(np.int64)
    face_source = cKDTree(V[F].mean(axis=1)).query(Vd[Fd].mean(axis=1))[1].astype(np.int64)
    return Vd, Fd, face_source, vertex_map


def _b64(a):
    """An array's bytes, little-endian, in base64."""
    a = np.ascontiguousarray(a)
    return base64.b64encode(a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes()).decode("ascii")


def _srgb255(rgb):
    """A colour given in [0, 1] or in 0-255, as 0-255 numbers."""
    t = np.asarray(rgb, np.float64)[:3]
    return np.round(t * 255.0 if t.max() <= 1.0 else t)


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
    mesh : shellrepair.mesh.io.Mesh
        The repaired mesh (``face_filled`` marks the synthesized faces), or
        any mesh.
    up : (3,) sequence
        The scan's up axis: the camera turns about it, and the aging's
        rain comes down it.
    age : float, optional
        In [0, 1]; default :data:`shellrepair.appearance.aging.DEFAULT_AGE`.
    seed : int
        Seed of the aging's blotch noise.
    material : str
        A preset of :data:`shellrepair.appearance.materials.MATERIALS`.
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
    from shellrepair.appearance import aging as ag
    from shellrepair.appearance.gltf import pbr_approximation
    from shellrepair.appearance.render import FILLED_TINT
    from shellrepair.mesh.topology import edge_topology
    from shellrepair.report.overlay import OPEN_EDGE_COLOR

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
                         scan=~filled if filled.any() and not filled.all() else None)
    base, metallic, rough = pbr_approximation(maps.coverage, maps.gild, maps.crust, material)
    region = filled_regions(F, filled)
    Vd, Fd, src, vmap = display_copy(V, F, max_faces=max_faces)
    # each vertex of the copy: the mean of the original vertices it stands for
    on = vmap >= 0
    cnt = np.maximum(np.bincount(vmap[on], minlength=len(Vd)), 1)
    look = np.column_stack([base, metallic, rough])[on]
    look_d = np.column_stack([np.bincount(vmap[on], weights=look[:, j], minlength=len(Vd))
                              for j in range(5)]) / cnt[:, None]
    base_d, mr_d = look_d[:, :3], look_d[:, 3:]
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
    from shellrepair.appearance.render import DEFAULT_VIEW, view_towards

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
        "tint": [int(x) for x in _srgb255(FILLED_TINT)], "edge_color": [int(x) for x in OPEN_EDGE_COLOR],
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
