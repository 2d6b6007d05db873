"""Pictures of each fill: a close-up of every filled region and of every
hole the repair could not fill, each from the side that sees it best.

A **region** is a set of filled faces joined across edges: the patch of
one hole, or the tube or band that joins two (one region). Each gets a
camera of its own, the same for its *before* and *after* panels:

- **target**: the region's area-weighted centroid;
- **direction**: scored among the region's mean normal and 26 directions
  around the scan's up axis (every 45 degrees of azimuth at elevations -45,
  0 and 45, and straight up and down): the score is the share of the
  region's area seen from there, ``sum(a_f |n_f . d| seen_f) / sum(a_f)``,
  where ``seen_f`` says that a ray from face ``f``'s centroid along ``d``
  leaves the mesh without hitting it (a patch inside a head is seen through
  the opening it fills, not through the skull). The best wins (the first on
  a tie); its score and the runner-up's are kept;
- **framing**: the sphere about the target through the region's farthest
  vertex, times :data:`CLOSEUP_MARGIN` (the ring of scan around the rim).

A failed hole gets the same, with its rim's ring of faces as the region and
the rim's mean as the target.

Each camera is written as the ``shellrepair render`` arguments that give it
back (``--up y --view 30,-45 --look-at X,Y,Z --radius R``), rounded as
printed, and the picture is made with the camera read back from them, so
the printed camera is the one used.

    pics = closeups(before, repaired, report, up=(0, 0, 1))   # dict: regions, more, failed
"""

from __future__ import annotations

import io as _io

import numpy as np

from shellrepair.report.upaxis import up_text

__all__ = ["fill_regions", "failed_holes", "best_direction", "closeup_camera", "camera_args", "parse_camera",
           "closeups", "pictures_record", "CLOSEUP_SIZE", "CLOSEUP_SUPERSAMPLE", "CLOSEUP_LIMIT", "CLOSEUP_MARGIN", "FAILED_COLOR"]

#: Size (width, height) of each panel of a close-up, in pixels.
CLOSEUP_SIZE = (240, 180)
#: Close-ups on a page: the largest regions by area; the rest are listed.
CLOSEUP_LIMIT = 24
#: The framed sphere's radius over the region's own (shows the ring around the rim).
CLOSEUP_MARGIN = 1.5
#: Colour (sRGB) the rim of a hole that could not be filled is drawn in.
FAILED_COLOR = (255, 70, 0)
#: Rays per pixel along each axis of a close-up (1: one ray a pixel; the
#: overview's 2 x 2 would make a page of 24 close-ups four times slower).
CLOSEUP_SUPERSAMPLE = 1
#: Faces of a region whose visibility is tested, at most (evenly spread).
VIEW_SAMPLES = 2000
#: Ray origins are moved off their face by this share of the mesh's diagonal.
_RAY_EPS = 1e-5
#: Largest |elevation| of a close-up (degrees), so the up axis still orients the picture.
MAX_ELEVATION = 85.0


def _frame(up):
    """(a, b, up): the orthonormal frame of :func:`shellrepair.appearance.render.frame_camera`
    (azimuth 0 along a, 90 along b)."""
    up = np.asarray(up, np.float64)
    up = up / np.linalg.norm(up)
    ref = np.array([0.0, 0.0, 1.0]) if abs(up[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    a = ref - up * (ref @ up)
    a /= np.linalg.norm(a)
    return a, np.cross(up, a), up


def _direction(view, up):
    a, b, u = _frame(up)
    az, el = np.radians(view[0]), np.radians(view[1])
    return np.cos(el) * (np.cos(az) * a + np.sin(az) * b) + np.sin(el) * u


def _view_of(d, up):
    a, b, u = _frame(up)
    el = float(np.degrees(np.arcsin(np.clip(d @ u, -1.0, 1.0))))
    az = float(np.degrees(np.arctan2(d @ b, d @ a)))
    return az, float(np.clip(el, -MAX_ELEVATION, MAX_ELEVATION))


def fill_regions(V, F, filled, n_original=None):
    """The filled regions of a repaired mesh, largest first.

    Parameters
    ----------
    V : (n,3) float64 array
    F : (m,3) int64 array
    filled : (m,) bool array
        The faces the repair synthesized (``Mesh.face_filled``).
    n_original : int, optional
        Vertices the scan had (a repair keeps them first); the rim of a
        region is its vertices below this. Default: every vertex that a
        face not filled uses.

    Returns
    -------
    regions : list of dict
        ``faces`` ((k,) int64 face indices), ``area``, ``centroid`` ((3,)),
        ``radius`` (farthest vertex from the centroid), ``rim`` (the scan's
        vertices the region touches, sorted); by decreasing area, then by
        first face.
    """
    from shellrepair.mesh.topology import edge_topology, face_pieces

    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    filled = np.zeros(len(F), bool) if filled is None else np.asarray(filled, bool)
    idx = np.flatnonzero(filled)
    if len(idx) == 0:
        return []
    Ff = F[idx]
    n_piece, lab = face_pieces(edge_topology(Ff, len(V)), len(Ff))
    if n_original is None:
        scan_v = np.zeros(len(V), bool)
        scan_v[F[~filled].ravel()] = True
    else:
        scan_v = np.arange(len(V)) < int(n_original)
    T = V[Ff]
    cr = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    area = 0.5 * np.linalg.norm(cr, axis=1)
    order = np.argsort(lab, kind="stable")
    starts = np.searchsorted(lab[order], np.arange(n_piece))
    out = []
    for p, faces_p in enumerate(np.split(order, starts[1:])):
        a = area[faces_p]
        A = float(a.sum())
        C = T[faces_p].mean(axis=1)
        c = (a @ C) / A if A > 0 else C.mean(axis=0)
        verts = np.unique(Ff[faces_p])
        out.append({"faces": idx[faces_p], "area": A, "centroid": c,
                    "radius": float(np.sqrt(np.max(np.sum((V[verts] - c) ** 2, axis=1)))),
                    "rim": verts[scan_v[verts]]})
    out.sort(key=lambda r: (-r["area"], int(r["faces"][0])))
    return out


def failed_holes(before, report):
    """The holes a repair could not fill, located on the scan as read.

    A report row's ``id`` is the loop's place among the scan's boundary
    loops (:func:`shellrepair.holes.loops.boundary_loops`, the ids
    ``shellrepair holes`` lists); a row whose loop is not found there with
    its number of edges (a part of a pinched band, or a scan the repair had
    to mend first) is given with ``vertices`` None.

    Parameters
    ----------
    before : shellrepair.mesh.io.Mesh
    report : dict

    Returns
    -------
    holes : list of dict
        ``id``, ``edges``, ``reason``, ``vertices`` ((k,) int64 rim or
        None), ``center`` ((3,) or None), ``radius``; in id order.
    """
    from shellrepair.holes.loops import boundary_loops

    rows = sorted((h for h in (report or {}).get("holes", []) if h.get("status") == "failed"),
                  key=lambda h: h.get("id", 0))
    if not rows:
        return []
    loops, _ = boundary_loops(np.asarray(before.F, np.int64), len(before.V))
    V = np.asarray(before.V, np.float64)
    out = []
    for h in rows:
        i = int(h.get("id", -1))
        lp = loops[i] if 0 <= i < len(loops) and len(loops[i]) == h.get("edges") else None
        c = None if lp is None else V[lp].mean(axis=0)
        r = 0.0 if lp is None else float(np.sqrt(np.max(np.sum((V[lp] - c) ** 2, axis=1))))
        out.append({"id": i, "edges": h.get("edges"), "reason": h.get("reason"), "vertices": lp,
                    "center": c, "radius": r})
    return out


def _ring(F, verts):
    """Faces that use any of ``verts``."""
    mark = np.zeros(int(F.max()) + 1 if len(F) else 0, bool)
    mark[verts[verts < len(mark)]] = True
    return np.flatnonzero(mark[F].any(axis=1))


def _scene(V, F):
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(V, np.float32)), o3d.core.Tensor(np.asarray(F, np.uint32)))
    return scene


def best_direction(V, F, faces, up, *, scene=None, samples=VIEW_SAMPLES):
    """The side that sees the faces best (the module's score).

    Parameters
    ----------
    V : (n,3) float64 array
    F : (m,3) int64 array
    faces : (k,) int array
        The faces to see.
    up : (3,) floats
    scene : open3d RaycastingScene of V, F, optional
        Reused across calls.
    samples : int
        Faces tested at most (evenly spread over ``faces``).

    Returns
    -------
    best : dict
        ``direction`` ((3,) unit, from the faces towards the eye),
        ``view`` ((azimuth, elevation) degrees about ``up``), ``score``,
        ``runner_up`` (the next score) and ``candidate`` (``"mean normal"``
        or the (azimuth, elevation) of the grid direction that won).
    """
    import open3d as o3d

    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    faces = np.asarray(faces, np.int64)
    if len(faces) > samples:
        faces = faces[np.linspace(0, len(faces) - 1, samples).round().astype(np.int64)]
    T = V[F[faces]]
    cr = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    ln = np.linalg.norm(cr, axis=1)
    ok = ln > 0
    T, cr, ln = T[ok], cr[ok], ln[ok]
    a = 0.5 * ln
    N = cr / ln[:, None] if len(ln) else cr
    C = T.mean(axis=1)
    cands, names = [], []
    m = (a[:, None] * N).sum(axis=0) if len(a) else np.zeros(3)
    if np.linalg.norm(m) > 1e-12 * max(a.sum(), 1e-300):
        cands.append(m / np.linalg.norm(m))
        names.append("mean normal")
    for el in (-45.0, 0.0, 45.0):
        for az in np.arange(0.0, 360.0, 45.0):
            cands.append(_direction((az, el), up))
            names.append((float(az), el))
    for el in (90.0, -90.0):
        cands.append(_direction((0.0, el), up))
        names.append((0.0, el))
    if len(a) == 0:
        d = cands[0]
        return {"direction": d, "view": _view_of(d, up), "score": 0.0, "runner_up": 0.0, "candidate": names[0]}
    if scene is None:
        scene = _scene(V, F)
    eps = _RAY_EPS * float(np.linalg.norm(np.ptp(V, axis=0)) or 1.0)
    D = np.asarray(cands)
    O = np.repeat(C, len(D), axis=0) + eps * np.tile(D, (len(C), 1))
    rays = np.concatenate([O, np.tile(D, (len(C), 1))], axis=1).astype(np.float32)
    hit = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().reshape(len(C), len(D))
    seen = ~np.isfinite(hit)
    score = (a[:, None] * np.abs(N @ D.T) * seen).sum(axis=0) / a.sum()
    order = np.argsort(-score, kind="stable")
    k = int(order[0])
    return {"direction": D[k], "view": _view_of(D[k], up), "score": float(score[k]),
            "runner_up": float(score[order[1]]) if len(order) > 1 else 0.0, "candidate": names[k]}


def camera_args(up, view, target, radius):
    """The ``shellrepair render`` arguments of a close-up camera, rounded as
    printed: azimuth and elevation to 0.1 degree, target and radius to 6
    significant digits."""
    t = ",".join(f"{float(x):.6g}" for x in target)
    return (f"--up {up_text(up)} --view {float(view[0]):.1f},{float(view[1]):.1f} --look-at {t} "
            f"--radius {float(radius):.6g}")


def parse_camera(args):
    """(up, view, target, radius) from :func:`camera_args`' text."""
    from shellrepair.report.upaxis import parse_up

    w = args.split()
    kv = dict(zip(w[0::2], w[1::2]))
    return (parse_up(kv["--up"]), tuple(float(x) for x in kv["--view"].split(",")),
            tuple(float(x) for x in kv["--look-at"].split(",")), float(kv["--radius"]))


def closeup_camera(V, F, faces, target, radius, up, *, scene=None, size=CLOSEUP_SIZE):
    """The close-up camera of a set of faces (the module's rule).

    Parameters
    ----------
    V, F : arrays
        The mesh the faces belong to (and whose surface may hide them).
    faces : (k,) int array
    target : (3,) floats
    radius : float
        The region's radius about ``target`` (before :data:`CLOSEUP_MARGIN`).
    up : (3,) floats
    scene : open3d RaycastingScene of V, F, optional
    size : (int, int)

    Returns
    -------
    cam : dict
        ``args`` (the ``render`` arguments), ``camera``
        (:class:`shellrepair.appearance.render.Camera` read back from them), ``score``,
        ``runner_up``.
    """
    from shellrepair.appearance.render import frame_camera

    best = best_direction(V, F, faces, up, scene=scene)
    r = max(float(radius), 1e-9 * float(np.linalg.norm(np.ptp(np.asarray(V), axis=0)) or 1.0)) * CLOSEUP_MARGIN
    args = camera_args(up, best["view"], target, r)
    up_r, view_r, target_r, r_r = parse_camera(args)
    cam = frame_camera(np.asarray([target_r]), size, view_r, up=up_r, center=target_r, radius=r_r)
    return {"args": args, "camera": cam, "score": round(best["score"], 4), "runner_up": round(best["runner_up"], 4)}


def _png(img):
    from PIL import Image

    buf = _io.BytesIO()
    Image.fromarray(img, "RGB").save(buf, format="PNG")
    return buf.getvalue()


def _failed_edges(holes):
    """(k,2) rim edges of the failed holes that were located."""
    E = [np.stack([h["vertices"], np.roll(h["vertices"], -1)], axis=1) for h in holes if h["vertices"] is not None]
    return np.concatenate(E) if E else np.zeros((0, 2), np.int64)


def _open_edges(F, n):
    from shellrepair.mesh.topology import edge_topology

    topo = edge_topology(np.asarray(F, np.int64), n)
    return topo.edges[topo.edge_count == 1]


def _pair(before, repaired, cam, up, unit, maps, material, failed_E, known):
    """Before | after with one camera, open edges drawn (failed rims in
    FAILED_COLOR); ``known``: per mesh, its open edges and ray-casting scene."""
    from shellrepair.appearance import render as rd
    from shellrepair.report.overlay import draw_edges

    img = rd.render_side_by_side(before.V, before.F, repaired.V, repaired.F, camera=cam, maps=maps,
                                 material=material, filled=repaired.face_filled,
                                 highlight_filled=repaired.face_filled is not None, up=up, unit=unit,
                                 vertex_colors_before=before.vertex_colors,
                                 vertex_colors_after=repaired.vertex_colors, legend=None,
                                 supersample=CLOSEUP_SUPERSAMPLE, scenes=(known[0][1], known[1][1]))
    img = np.array(img, copy=True)
    W = cam.width
    right = img[:, img.shape[1] - W:]
    for panel, m, (E, scene) in ((img[:, :W], before, known[0]), (right, repaired, known[1])):
        draw_edges(panel, cam, m.V, m.F, E, scene=scene)
        if len(failed_E):
            draw_edges(panel, cam, m.V, m.F, failed_E, color=FAILED_COLOR, width=2, scene=scene)
    return img


def closeups(before, repaired, report=None, *, up=None, size=CLOSEUP_SIZE, limit=CLOSEUP_LIMIT,
             material="aged-bronze", unit=None):
    """The close-ups of one repair.

    Parameters
    ----------
    before, repaired : shellrepair.mesh.io.Mesh
        The scan as read and the repair's output (``face_filled`` set).
    report : dict, optional
        The repair's report: its rows name the holes of each region and
        the holes that failed.
    up : (3,) floats or None
        The scan's up axis; default the report's (``report["up"]``), else
        inferred from ``before`` (:func:`shellrepair.report.upaxis.infer_up`).
    size : (int, int)
        Size of each panel.
    limit : int
        Regions pictured (the largest); the rest are listed.
    material : str
    unit : {"mm", "cm", "m"} or None

    Returns
    -------
    pics : dict
        ``regions``: one dict per pictured region (``region`` number from
        1, ``holes`` (loop ids), ``faces``, ``area``, ``center``, ``camera``
        (the ``render`` arguments), ``score``, ``runner_up``, ``png``,
        ``width``, ``height``, ``alt``); ``more``: the regions not pictured
        (the same without the picture); ``failed``: one dict per failed hole
        (``id``, ``edges``, ``reason``, ``center``, and where located the
        picture and camera as above); ``up``: the axis used.
    """
    from shellrepair.appearance import aging as ag
    from shellrepair.holes.loops import boundary_loops
    from shellrepair.report.upaxis import scan_up

    up = tuple(float(x) for x in (scan_up(before, report) if up is None else up))
    n0 = len(before.V)
    regions = fill_regions(repaired.V, repaired.F, repaired.face_filled,
                           n_original=n0 if np.array_equal(np.asarray(repaired.V)[:n0], before.V) else None)
    failed = failed_holes(before, report)
    out = {"regions": [], "more": [], "failed": [], "up": list(up)}
    if not regions and not failed:
        return out
    loops, _ = boundary_loops(np.asarray(before.F, np.int64), n0)
    owner = np.full(n0, -1, np.int64)       # a rim vertex's loop (the first, where two loops touch)
    for i in range(len(loops) - 1, -1, -1):
        owner[loops[i]] = i
    maps = None
    filled = repaired.face_filled
    if before.vertex_colors is None and repaired.vertex_colors is None:
        from shellrepair.appearance.materials import get_material

        if get_material(material).corrodes:
            maps = ag.aging_maps(repaired.V, repaired.F, age=ag.DEFAULT_AGE, up=up, seed=0,
                                 scan=None if filled is None else ~np.asarray(filled, bool))
    failed_E = _failed_edges(failed)
    scene_before, scene_after = _scene(before.V, before.F), _scene(repaired.V, repaired.F)
    known = ((_open_edges(before.F, n0), scene_before), (_open_edges(repaired.F, len(repaired.V)), scene_after))
    for k, reg in enumerate(regions):
        rim = reg["rim"][reg["rim"] < n0]
        holes = sorted({int(i) for i in owner[rim] if i >= 0})
        row = {"region": k + 1, "holes": holes, "faces": int(len(reg["faces"])), "area": reg["area"],
               "center": [float(f"{x:.6g}") for x in reg["centroid"]]}
        if k >= limit:
            out["more"].append(row)
            continue
        cam = closeup_camera(repaired.V, repaired.F, reg["faces"], reg["centroid"], reg["radius"], up,
                             scene=scene_after, size=size)
        img = _pair(before, repaired, cam["camera"], up, unit, maps, material, failed_E, known)
        what = (f"hole {holes[0]}" if len(holes) == 1 else f"holes {', '.join(map(str, holes))}" if holes
                else "a filled region")
        row.update(camera=cam["args"], score=cam["score"], runner_up=cam["runner_up"], png=_png(img),
                   width=int(img.shape[1]), height=int(img.shape[0]),
                   alt=f"close-up of the fill of {what}, before (left) and after (right)")
        out["regions"].append(row)
    for h in failed:
        row = {"id": h["id"], "edges": h["edges"], "reason": h["reason"],
               "center": None if h["center"] is None else [float(f"{x:.6g}") for x in h["center"]]}
        if h["vertices"] is not None:
            ring = _ring(np.asarray(before.F, np.int64), h["vertices"])
            cam = closeup_camera(before.V, before.F, ring, h["center"], h["radius"], up, scene=scene_before,
                                 size=size)
            img = _pair(before, repaired, cam["camera"], up, unit, maps, material, failed_E, known)
            row.update(camera=cam["args"], score=cam["score"], runner_up=cam["runner_up"], png=_png(img),
                       width=int(img.shape[1]), height=int(img.shape[0]),
                       alt=f"hole {h['id']}, which could not be filled, before (left) and after (right)")
        out["failed"].append(row)
    return out


def pictures_record(fig, pics, files=None):
    """What a report keeps of a page's pictures: the overview's camera and
    every close-up's row without its PNG (its camera as ``shellrepair
    render`` takes it, and its file where written beside the page).

    Parameters
    ----------
    fig : dict
        :func:`shellrepair.report.html.figure`'s.
    pics : dict
        :func:`closeups`'.
    files : dict, optional
        ``("region", number)`` or ``("failed", id)`` -> file name of the
        picture written beside the page.

    Returns
    -------
    record : dict
        ``overview`` (camera), ``up``, ``regions``, ``more``, ``failed``;
        :func:`shellrepair.report.html.closeups_html` shows it as it shows
        ``pics`` (linking the files).
    """
    files = files or {}

    def strip(row, key):
        r = {k: v for k, v in row.items() if k != "png"}
        if key in files:
            r["file"] = files[key]
        return r

    return {"overview": fig.get("camera"), "up": pics.get("up"),
            "regions": [strip(r, ("region", r["region"])) for r in pics.get("regions", [])],
            "more": list(pics.get("more", [])),
            "failed": [strip(f, ("failed", f["id"])) for f in pics.get("failed", [])]}
