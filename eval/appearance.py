"""Appearance error of a repair: how different a filled region *looks*.

The geometric metrics (:mod:`eval.metrics`) say how far a filled surface is
from the true one; this module says how much that shows on a rendered aged
gilt-bronze statue. For every case (:mod:`eval.cases`) and tool
(:mod:`eval.peers`, each run in its own child process, :mod:`eval.worker`):

1. **Cameras** aimed at the holes: the largest connected regions of removed
   faces of the ground truth (up to ``--views`` per case), each seen along
   its area-weighted mean normal (:func:`shellrepair.appearance.render.view_towards`)
   and framed on the region with context around it
   (:func:`shellrepair.appearance.render.frame_camera`). The same cameras serve the
   truth and every tool.
2. **One material and one aging state**: the aging map
   (:func:`shellrepair.appearance.aging.aging_maps`: rust coverage, gilding, crust) is
   computed once on the ground truth and carried to each tool's mesh by
   nearest vertex, and the unit is inferred once from the truth, so the
   renders differ only by geometry (normals, shape, silhouettes, shadows).
3. **The filled region's pixels**: pixels whose centre ray hits a face the
   tool added (:func:`eval.metrics.added_faces`) or, in the truth, a face
   that was cut away (so a hole left open counts as error instead of
   vanishing from the measure), dilated by ``--dilate`` pixels.
4. **Errors over those pixels only**: SSIM (``skimage.metrics.
   structural_similarity``, 7 x 7 windows on the RGB image, computed on the
   region's bounding box plus half a window and averaged over the mask) and
   CIEDE2000 (``skimage.color.rgb2lab`` then ``deltaE_ciede2000``; mean and
   95th percentile). A view's numbers are pooled over views by pixel count.

Outputs under ``eval/results/``: ``appearance.json`` (every view),
``appearance.md`` (a table per case and a summary per tool) and
``appearance_worst.png`` (each tool's worst view, truth | tool, the region
outlined). Run ``make appearance`` or
``python eval/appearance.py [--cases a,b] [--tools x,y]``.

It is a measurement, not a test: it asserts nothing and exits 0 unless it
could not run at all. ΔE00 of about 1 is a just-noticeable difference; 2-10
is visible at a glance.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

__all__ = ["hole_regions", "region_cameras", "truth_look", "transfer_look", "render_view",
           "face_ids", "region_pixels", "region_error", "measure_views", "DEFAULT_CASES",
           "DEFAULT_TOOLS"]

RESULTS = ROOT / "eval" / "results"

#: The subset run by ``make appearance`` (about 6 minutes on 2 loaded
#: cores): smooth, bumpy and real-scan truths, medium and large discs,
#: scanner occlusion, tiny holes, a saddle and one very large hole.
DEFAULT_CASES = ("icosphere-discs-large", "torus-discs-medium", "bumpy_sphere-discs-medium",
                 "bumpy_sphere-tiny150", "armadillo-discs-medium", "armadillo-occlusion-ring",
                 "nefertiti-discs-medium", "nefertiti-discs-large", "hard-saddle", "hard-30pct")
DEFAULT_TOOLS = ("ours-o2", "cgal", "meshlib-nicely", "pymeshlab")

#: SSIM's window (pixels, odd) and the outline colour of the figure (sRGB).
SSIM_WIN = 7
OUTLINE = np.array([255, 0, 200], np.uint8)


# --------------------------------------------------------------------------
# cameras
# --------------------------------------------------------------------------
def hole_regions(F, removed, n_max=None):
    """Connected regions of the removed faces, largest (by face count) first.

    Parameters
    ----------
    F : (m,3) int array
        Faces of the ground truth.
    removed : (m,) bool array
        Faces cut away.
    n_max : int or None
        Keep at most this many regions.

    Returns
    -------
    regions : list of (m,) bool arrays
        Faces joined through shared vertices form one region.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    F = np.asarray(F, np.int64)
    idx = np.flatnonzero(np.asarray(removed, bool))
    if len(idx) == 0:
        return []
    sub = F[idx]
    verts, inv = np.unique(sub.ravel(), return_inverse=True)
    inv = inv.reshape(-1, 3)
    nf = len(idx)
    rows = np.repeat(np.arange(nf), 3)
    A = sp.csr_matrix((np.ones(3 * nf), (rows, inv.ravel())), shape=(nf, len(verts)))
    n, lab = connected_components(A @ A.T, directed=False)
    sizes = np.bincount(lab, minlength=n)
    order = np.argsort(-sizes, kind="stable")[: (n if n_max is None else int(n_max))]
    out = []
    for r in order:
        mask = np.zeros(len(F), bool)
        mask[idx[lab == r]] = True
        out.append(mask)
    return out


def region_cameras(V, F, removed, *, n_views=2, size=(256, 256), margin=1.7, up=(0.0, 1.0, 0.0)):
    """Cameras aimed at the largest holes of a ground truth.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    removed : (m,) bool array
        Faces cut away from the truth.
    n_views : int
        At most this many cameras, one per region, largest first.
    size : (int, int)
        Image (width, height).
    margin : float
        The region's bounding sphere is scaled by this: the rest of the
        frame is the surface around the hole.
    up : (3,) sequence

    Returns
    -------
    cameras : list of shellrepair.appearance.render.Camera
    """
    from shellrepair.appearance import render

    import open3d as o3d

    V = np.asarray(V, np.float64)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)),
                        o3d.core.Tensor(np.asarray(F, np.uint32)))
    cams = []
    for reg in hole_regions(F, removed, n_views):
        view = render.view_towards(V, F, reg, up=up)
        pts = V[np.unique(np.asarray(F, np.int64)[reg])]
        cam = render.frame_camera(pts, size, view, up=up, margin=margin)
        cams.append(_unblocked(cam, pts, scene))
    return cams


def _unblocked(cam, pts, scene, max_steps=8):
    """Move the camera towards its target until no other surface is in between.

    A hole in a concave place (a torus's inner equator) seen from far along
    its normal is hidden by the surface opposite. Walking from the target
    towards the eye, hits within the region's own radius are the region
    (stepped over); the first hit beyond it blocks the view, and the eye is
    put at 85 % of that distance with the field of view widened to keep the
    region framed (at most 100 degrees).
    """
    import open3d as o3d

    from shellrepair.appearance import render

    target = np.asarray(cam.target, np.float64)
    d = np.asarray(cam.eye, np.float64) - target
    dist = float(np.linalg.norm(d))
    d /= dist
    radius = float(np.sqrt(np.max(np.sum((pts - target) ** 2, axis=1))))
    s = 0.0
    blocked = None
    for _ in range(max_steps):
        ray = np.concatenate([target + s * d, d])[None].astype(np.float32)
        t = float(scene.cast_rays(o3d.core.Tensor(ray))["t_hit"].numpy()[0])
        if not np.isfinite(t) or s + t >= dist:
            break
        if s + t > 1.2 * radius:
            blocked = s + t
            break
        s += t + 1e-4 * radius
    if blocked is None:
        return cam
    new = 0.85 * blocked
    half = np.degrees(np.arctan(np.tan(0.5 * np.radians(cam.fov_y_deg)) * dist / new))
    fov = float(min(100.0, 2.0 * half))
    return render.Camera(target + new * d, target, np.asarray(cam.up), fov, cam.width, cam.height)


# --------------------------------------------------------------------------
# one aging state for every mesh
# --------------------------------------------------------------------------
def truth_look(V, F, *, age=None, up=(0.0, 1.0, 0.0), seed=0):
    """The aging state of the ground truth: (coverage, gild, crust) per vertex.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    age : float or None
        Aging level (None: the library's default).
    up : (3,) sequence
    seed : int

    Returns
    -------
    look : dict of (n,) float64 arrays ``coverage``, ``gild``, ``crust``
    """
    from shellrepair.appearance import aging

    m = aging.aging_maps(V, F, age=aging.DEFAULT_AGE if age is None else float(age), up=up, seed=seed)
    return {"coverage": m.coverage, "gild": m.gild, "crust": m.crust}


def transfer_look(look, V_src, V_dst):
    """Carry a per-vertex look to other vertices by nearest source vertex.

    Parameters
    ----------
    look : dict of (n,) arrays
    V_src : (n,3) float array
        The vertices ``look`` belongs to.
    V_dst : (p,3) float array

    Returns
    -------
    look : dict of (p,) arrays
    """
    from scipy.spatial import cKDTree

    _, j = cKDTree(np.asarray(V_src, np.float64)).query(np.asarray(V_dst, np.float64), k=1)
    return {k: np.asarray(v)[j] for k, v in look.items()}


def render_view(V, F, camera, look, *, unit="m", material="aged-bronze", supersample=2):
    """Render a mesh with a given look through a given camera.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    camera : shellrepair.appearance.render.Camera
    look : dict of (n,) arrays ``coverage``, ``gild``, ``crust``
    unit : str
        Mesh unit, the same for every mesh compared (sets the model choice).
    material : str
    supersample : int

    Returns
    -------
    image : (H,W,3) uint8 array
    """
    from shellrepair.appearance import render

    return render.render_mesh(V, F, camera=camera, material=material, coverage=look["coverage"],
                              gild=look["gild"], crust=look["crust"], unit=unit,
                              supersample=supersample)


# --------------------------------------------------------------------------
# the filled region's pixels and the error over them
# --------------------------------------------------------------------------
def face_ids(V, F, camera):
    """Face hit by each pixel's centre ray, -1 for background.

    Returns
    -------
    ids : (H,W) int64 array
    """
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(V, np.float32)),
                        o3d.core.Tensor(np.asarray(F, np.uint32)))
    hit = scene.cast_rays(o3d.core.Tensor(camera.rays()))
    t = hit["t_hit"].numpy().reshape(camera.height, camera.width)
    ids = hit["primitive_ids"].numpy().reshape(camera.height, camera.width).astype(np.int64)
    return np.where(np.isfinite(t), ids, -1)


def region_pixels(ids, face_mask, dilate=2):
    """Pixels whose face is in ``face_mask``, grown by ``dilate`` pixels.

    Parameters
    ----------
    ids : (H,W) int64 array
        From :func:`face_ids` (-1: background).
    face_mask : (m,) bool array
    dilate : int

    Returns
    -------
    mask : (H,W) bool array
    """
    from scipy import ndimage

    fm = np.asarray(face_mask, bool)
    mask = np.zeros(ids.shape, bool)
    hit = ids >= 0
    mask[hit] = fm[ids[hit]]
    if dilate > 0 and mask.any():
        mask = ndimage.binary_dilation(mask, iterations=int(dilate))
    return mask


def region_error(img_true, img, mask):
    """SSIM and CIEDE2000 between two renders over the masked pixels.

    Parameters
    ----------
    img_true, img : (H,W,3) uint8 arrays
        The truth's render and the tool's, same camera.
    mask : (H,W) bool array
        The filled region's pixels.

    Returns
    -------
    err : dict
        ``pixels`` (mask size), ``ssim`` (mean of the SSIM map over the
        mask, 1 for identical images), ``delta_e`` (mean ΔE00 over the
        mask, 0 for identical images), ``delta_e_p95``; the three are None
        for an empty mask.

    Notes
    -----
    SSIM's 7 x 7 windows see pixels just outside the mask (the context of
    the region's edge); the map is computed on the mask's bounding box
    grown by half a window (at least one window wide) and averaged over
    the mask's pixels.
    """
    from skimage.color import deltaE_ciede2000, rgb2lab
    from skimage.metrics import structural_similarity

    mask = np.asarray(mask, bool)
    n = int(mask.sum())
    if n == 0:
        return {"pixels": 0, "ssim": None, "delta_e": None, "delta_e_p95": None}
    a = np.asarray(img_true)
    b = np.asarray(img)
    H, W = mask.shape
    ys, xs = np.nonzero(mask)
    h = SSIM_WIN // 2
    y0, y1 = max(0, ys.min() - h), min(H, ys.max() + 1 + h)
    x0, x1 = max(0, xs.min() - h), min(W, xs.max() + 1 + h)
    # at least one window in each direction
    if y1 - y0 < SSIM_WIN:
        y0 = max(0, min(y0, H - SSIM_WIN))
        y1 = min(H, y0 + SSIM_WIN)
    if x1 - x0 < SSIM_WIN:
        x0 = max(0, min(x0, W - SSIM_WIN))
        x1 = min(W, x0 + SSIM_WIN)
    ca = a[y0:y1, x0:x1].astype(np.float64)
    cb = b[y0:y1, x0:x1].astype(np.float64)
    _, smap = structural_similarity(ca, cb, channel_axis=2, data_range=255.0, win_size=SSIM_WIN,
                                    full=True)
    cm = mask[y0:y1, x0:x1]
    ssim = float(smap.mean(axis=2)[cm].mean())
    de = deltaE_ciede2000(rgb2lab(a[mask][None] / 255.0), rgb2lab(b[mask][None] / 255.0))[0]
    return {"pixels": n, "ssim": ssim, "delta_e": float(de.mean()),
            "delta_e_p95": float(np.percentile(de, 95))}


def measure_views(V_true, F_true, removed, V_out, F_out, added, cameras, look, truth_images, *,
                  unit="m", dilate=2, supersample=2):
    """Render one tool's mesh through every camera and measure each view.

    Parameters
    ----------
    V_true, F_true : arrays
        The ground truth; ``look`` is per vertex of ``V_true``.
    removed : (len(F_true),) bool array
        Faces of the truth that were cut away.
    V_out, F_out : arrays
        The tool's mesh.
    added : (len(F_out),) bool array
        Faces the tool added.
    cameras : list of Camera
    look : dict
        From :func:`truth_look`.
    truth_images : list of (H,W,3) uint8 arrays
        The truth rendered through ``cameras`` (with ``look``).
    unit, dilate, supersample :
        As :func:`render_view` and :func:`region_pixels`.

    Returns
    -------
    views : list of dict
        Per view: :func:`region_error`'s numbers and, under the keys
        ``image`` and ``mask``, the tool's render and the region's pixels.
    """
    look_out = transfer_look(look, V_true, V_out)
    views = []
    for cam, img_t in zip(cameras, truth_images):
        mask = region_pixels(face_ids(V_out, F_out, cam), added, dilate)
        mask |= region_pixels(face_ids(V_true, F_true, cam), removed, dilate)
        img = render_view(V_out, F_out, cam, look_out, unit=unit, supersample=supersample)
        err = region_error(img_t, img, mask)
        err.update(image=img, mask=mask)
        views.append(err)
    return views


def pool(views):
    """Pixel-weighted means of the per-view numbers (views with pixels)."""
    vs = [v for v in views if v["pixels"]]
    if not vs:
        return {"pixels": 0, "ssim": None, "delta_e": None, "delta_e_p95": None}
    w = np.array([v["pixels"] for v in vs], float)
    out = {"pixels": int(w.sum())}
    for k in ("ssim", "delta_e", "delta_e_p95"):
        out[k] = float(np.average([v[k] for v in vs], weights=w))
    return out


# --------------------------------------------------------------------------
# the run
# --------------------------------------------------------------------------
def _outline(img, mask):
    from scipy import ndimage

    edge = mask & ~ndimage.binary_erosion(mask)
    out = img.copy()
    out[edge] = OUTLINE
    return out


def worst_figure(worst, path):
    """Each tool's worst view: truth | tool, the region outlined, one row per tool."""
    from shellrepair.appearance import render

    rows = []
    for tool, w in worst.items():
        t = render.draw_label(_outline(w["truth"], w["mask"]), f"truth  {w['case']}")
        o = render.draw_label(_outline(w["image"], w["mask"]),
                              f"{tool}  dE {w['delta_e']:.1f}  SSIM {w['ssim']:.2f}")
        gap = np.full((t.shape[0], 6, 3), 255, np.uint8)
        rows.append(np.concatenate([t, gap, o], axis=1))
    if not rows:
        return False
    width = max(r.shape[1] for r in rows)
    rows = [np.pad(r, ((0, 6), (0, width - r.shape[1]), (0, 0)), constant_values=255) for r in rows]
    render.save_png(path, np.concatenate(rows, axis=0))
    return True


def _fmt(x, nd):
    return "–" if x is None else f"{x:.{nd}f}"


def markdown(result):
    """The result as tables a person reads."""
    L = ["# Appearance error of a repair", "",
         f"`{result['command']}`; {result['machine']['date']}, commit {result['machine']['commit']}, "
         f"{result['total_seconds']:.0f} s.", "",
         f"Renders {result['size'][0]}x{result['size'][1]}, {result['supersample']}x{result['supersample']} "
         f"rays a pixel, material `{result['material']}`, up to {result['views']} views a case aimed at the "
         f"largest holes; aging map of the truth carried to each mesh by nearest vertex; region = pixels on "
         f"faces the tool added or the truth lost, dilated {result['dilate']} px. ΔE00 mean (p95) and SSIM "
         "over the region's pixels, pooled over views by pixel count. ΔE00 ≈ 1 is just noticeable. "
         "appearance_worst.png: each tool's worst single view (truth | tool, region outlined).", ""]
    tools = result["tools"]
    L += ["## Summary (mean over the cases each tool completed)", "",
          "| tool | cases | ΔE00 mean | ΔE00 p95 | SSIM | worst case (ΔE00) |", "|---|---|---|---|---|---|"]
    for tool in tools:
        rs = [r for r in result["rows"] if r["tool"] == tool and r.get("delta_e") is not None]
        if not rs:
            L.append(f"| {tool} | 0 | – | – | – | – |")
            continue
        w = max(rs, key=lambda r: r["delta_e"])
        L.append(f"| {tool} | {len(rs)} | {np.mean([r['delta_e'] for r in rs]):.2f} | "
                 f"{np.mean([r['delta_e_p95'] for r in rs]):.2f} | {np.mean([r['ssim'] for r in rs]):.3f} | "
                 f"{w['case']} ({w['delta_e']:.2f}) |")
    L.append("")
    for c in result["cases"]:
        L += [f"## {c['name']}", "", f"{c['description']}; {c['views']} views.", "",
              "| tool | status | pixels | ΔE00 mean | ΔE00 p95 | SSIM |", "|---|---|---|---|---|---|"]
        for r in result["rows"]:
            if r["case"] != c["name"]:
                continue
            L.append(f"| {r['tool']} | {r['status']}{(': ' + r['error']) if r.get('error') else ''} | "
                     f"{r.get('pixels', '–')} | {_fmt(r.get('delta_e'), 2)} | {_fmt(r.get('delta_e_p95'), 2)} | "
                     f"{_fmt(r.get('ssim'), 3)} |")
        L.append("")
    return "\n".join(L)


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="eval/appearance.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default=",".join(DEFAULT_CASES), help="comma-separated case names")
    ap.add_argument("--tools", default=",".join(DEFAULT_TOOLS), help="comma-separated tools")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--views", type=int, default=3, help="cameras per case (largest holes first)")
    ap.add_argument("--size", type=int, default=256, help="image width = height in pixels")
    ap.add_argument("--supersample", type=int, default=2)
    ap.add_argument("--dilate", type=int, default=2, help="pixels added around the region")
    ap.add_argument("--timeout", type=float, default=90.0, help="seconds per tool and case")
    ap.add_argument("--out", default=str(RESULTS))
    return ap.parse_args(argv)


def main(argv=None):
    from eval import cases as casemod
    from eval import metrics, peers
    from eval.bench import machine_info
    from eval.worker import ToolRunner
    from shellrepair.appearance import render

    args = parse_args(sys.argv[1:] if argv is None else argv)
    names = [s.strip() for s in args.cases.split(",") if s.strip()]
    tools = [s.strip() for s in args.tools.split(",") if s.strip()]
    bad = [n for n in names if n not in casemod.SUITE] + [t for t in tools if t not in peers.TOOLS]
    if bad:
        print(f"error: unknown case or tool: {', '.join(bad)}", file=sys.stderr)
        return 2
    out = Path(args.out)
    tmp = out / "tmp"
    tmp.mkdir(parents=True, exist_ok=True)
    command = "python eval/appearance.py" + "".join(
        " " + shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv))
    size = (args.size, args.size)
    result = {"command": command, "machine": machine_info(), "tools": tools, "seed": args.seed,
              "size": size, "supersample": args.supersample, "views": args.views, "dilate": args.dilate,
              "material": "aged-bronze", "cases": [], "rows": []}
    worst = {}
    t_start = time.perf_counter()
    runners = {t: ToolRunner(t, tmp, args.timeout) for t in tools}
    try:
        for name in names:
            t0 = time.perf_counter()
            case = casemod.build_case(name, args.seed)
            unit, _ = render.infer_unit(case.V_true)
            look = truth_look(case.V_true, case.F_true, seed=args.seed)
            cams = region_cameras(case.V_true, case.F_true, case.removed, n_views=args.views, size=size)
            truth_imgs = [render_view(case.V_true, case.F_true, c, look, unit=unit,
                                      supersample=args.supersample) for c in cams]
            result["cases"].append({"name": name, "description": case.description, "views": len(cams),
                                    "unit": unit, "notes": list(case.notes)})
            print(f"{name}: {len(cams)} views, unit {unit}", flush=True)
            case_npz = tmp / f"{name}.npz"
            np.savez(case_npz, V=case.V, F=case.F)
            diag = float(np.linalg.norm(case.V_true.max(0) - case.V_true.min(0)))
            for tool in tools:
                row = {"case": name, "tool": tool}
                ok, why = peers.tool_available(tool)
                if not ok:
                    row.update(status="missing", error=why)
                    result["rows"].append(row)
                    print(f"  {tool:15s} missing: {why}", flush=True)
                    continue
                out_npz = tmp / f"{name}.{tool}.out.npz"
                res = runners[tool].run(case_npz, out_npz)
                row["status"] = res["status"]
                if res["status"] != "ok":
                    row["error"] = res.get("error")
                    result["rows"].append(row)
                    print(f"  {tool:15s} {res['status']}: {res.get('error')}", flush=True)
                    continue
                with np.load(out_npz) as d:
                    V_out, F_out = d["V"].astype(np.float64), d["F"].astype(np.int64)
                out_npz.unlink()
                added = metrics.added_faces(case.V, case.F, V_out, F_out, metrics.MATCH_TOL * diag)[0]
                views = measure_views(case.V_true, case.F_true, case.removed, V_out, F_out, added, cams,
                                      look, truth_imgs, unit=unit, supersample=args.supersample)
                row.update(pool(views))
                row["faces_added"] = int(added.sum())
                row["views"] = [{k: v[k] for k in ("pixels", "ssim", "delta_e", "delta_e_p95")}
                                for v in views]
                result["rows"].append(row)
                for v, img_t in zip(views, truth_imgs):
                    if v["delta_e"] is not None and (tool not in worst
                                                     or v["delta_e"] > worst[tool]["delta_e"]):
                        worst[tool] = dict(v, truth=img_t, case=name)
                print(f"  {tool:15s} dE {_fmt(row['delta_e'], 2):>6} p95 {_fmt(row['delta_e_p95'], 2):>6} "
                      f"SSIM {_fmt(row['ssim'], 3)} ({row['pixels']} px)", flush=True)
            case_npz.unlink()
            result["cases"][-1]["seconds"] = round(time.perf_counter() - t0, 1)
            result["total_seconds"] = time.perf_counter() - t_start
            (out / "appearance.json").write_text(json.dumps(result, indent=1))
    finally:
        for r in runners.values():
            r.close()
    result["total_seconds"] = time.perf_counter() - t_start
    (out / "appearance.json").write_text(json.dumps(result, indent=1))
    (out / "appearance.md").write_text(markdown(result) + "\n")
    worst_figure(worst, out / "appearance_worst.png")
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
