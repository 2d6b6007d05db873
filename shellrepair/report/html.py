"""A repair as a page people look at: one self-contained HTML file per scan
and one per collection.

A page holds, for each scan, the paper's Table 1 (holes before, after and
the interpolation rate), a before | after picture aimed at the filled
region with the synthesized faces tinted, the boundary left open drawn
in its own colour and the holes that could not be filled ringed, a
close-up of each filled region and of each failed hole
(:mod:`shellrepair.report.closeups`, shown by :func:`closeups_html`), a per-hole table (holes left open first, every column
sortable by a click), the borders left open, the notes of loading, and a
provenance block: software version, options, input file and its SHA-256.

Below the picture, a 3D view of the repaired mesh (:mod:`shellrepair.report.webview`):
turned, moved and zoomed with the mouse or by touch, the filled faces
tinted (a checkbox), the edges left open drawn, a button per filled
region that frames it.

The page needs no server and no network: its style and its scripts are
inline; a scan page embeds its picture as a ``data:`` URI and its view's
mesh as JSON, a collection page (``OUTDIR/index.html`` of ``shellrepair
batch``) links the pictures and the views' scripts written beside it.

    fig = figure(mesh, repaired, report)         # PNG bytes and alt text
    html = scan_page(report, fig, options=opts)  # str
"""

from __future__ import annotations

import base64
import datetime as _dt
import hashlib
import html as _html
import io as _io
import json
from pathlib import Path

import numpy as np

from shellrepair.report.overlay import OPEN_EDGE_COLOR, draw_edges, draw_open_edges, project  # noqa: F401 (draw_* kept in this module's API)
from shellrepair.report.table import repaired, status_counts

__all__ = ["figure", "scan_page", "collection_page", "closeups_html", "draw_edges", "draw_open_edges", "file_sha256",
           "OPEN_EDGE_COLOR", "FIGURE_SIZE"]

#: Size (width, height) of each panel of a page's picture, in pixels.
FIGURE_SIZE = (480, 360)

_STATUS_ORDER = {"failed": 0, "skipped": 1, "filled": 2}


def file_sha256(path, chunk=1 << 20):
    """SHA-256 of a file's bytes, as hex."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while True:
            b = fh.read(chunk)
            if not b:
                break
            h.update(b)
    return h.hexdigest()


# --------------------------------------------------------------------------
# the picture
# --------------------------------------------------------------------------
def figure(before, repaired, report=None, *, size=FIGURE_SIZE, material="aged-bronze", unit=None,
           up=None):
    """Before | after picture of one repair, aimed at the filled region.

    Both panels use one camera (the filled faces' side, or the default view
    when nothing was filled); filled faces are tinted in the right panel;
    the edges left open are drawn in :data:`OPEN_EDGE_COLOR` in both (on
    the left they show every hole and border of the scan); the rims of the
    holes the repair could not fill are drawn in
    :data:`shellrepair.report.closeups.FAILED_COLOR` and ringed, with their id,
    in both (the ring also where the surface hides the rim).

    Parameters
    ----------
    before, repaired : shellrepair.mesh.io.Mesh
        The scan as read and the repair's output (``face_filled`` set).
    report : dict, optional
        The repair's report, for the alt text.
    size : (int, int)
        Size of each panel.
    material : str
    unit : {"mm", "cm", "m"} or None
        The mesh's length unit; None infers it from the size
        (see :func:`shellrepair.appearance.render.render_mesh`).
    up : (3,) floats or None
        The scan's up axis; default the report's (``report["up"]``), else
        inferred from ``before`` (:func:`shellrepair.report.upaxis.infer_up`).

    Returns
    -------
    fig : dict
        ``png`` (bytes), ``alt`` (str), ``width``, ``height``, ``view``
        ((azimuth, elevation) or None), ``camera`` (the ``shellrepair
        render --before`` arguments that give the camera back),
        ``open_edges_before`` and ``open_edges_after`` (counts), ``failed``
        (ids of the failed holes marked).
    """
    from PIL import Image

    from shellrepair.appearance import render as rd
    from shellrepair.report.closeups import FAILED_COLOR, failed_holes
    from shellrepair.report.upaxis import scan_up, up_text

    up = scan_up(before, report) if up is None else up
    filled = repaired.face_filled
    view, info = None, {}
    if filled is not None and np.any(filled):
        view = rd.view_towards(repaired.V, repaired.F, filled, up=up)
        if view is not None:
            view = (round(view[0], 1), round(view[1], 1))   # as printed
    img = rd.render_side_by_side(before.V, before.F, repaired.V, repaired.F, size=size, material=material,
                                 filled=filled, highlight_filled=filled is not None, view=view,
                                 vertex_colors_before=before.vertex_colors,
                                 vertex_colors_after=repaired.vertex_colors, unit=unit, up=up, info=info)
    img = np.array(img, copy=True)
    cam = info["after"]["camera"]   # one camera for both panels
    W = cam.width
    n_before = draw_open_edges(img[:, :W], cam, before.V, before.F)
    right = img[:, img.shape[1] - W:]
    n_after = draw_open_edges(right, cam, repaired.V, repaired.F)
    failed = [dict(h, points=np.asarray(before.V, np.float64)[h["vertices"]])
              for h in failed_holes(before, report) if h["vertices"] is not None]
    if failed:
        E = np.concatenate([np.stack([h["vertices"], np.roll(h["vertices"], -1)], axis=1) for h in failed])
        for panel, m in ((img[:, :W], before), (right, repaired)):
            draw_edges(panel, cam, m.V, m.F, E, color=FAILED_COLOR, width=3)
        img[:, :W] = _ring_failed(img[:, :W], cam, failed, FAILED_COLOR)
        right[:] = _ring_failed(right, cam, failed, FAILED_COLOR)
    buf = _io.BytesIO()
    Image.fromarray(img, "RGB").save(buf, format="PNG", optimize=True)
    what = "the scan before (left) and after (right) the repair"
    if report is not None:
        what += (f"; {report.get('holes_before', '?')} holes before, {report.get('holes_after', '?')} after; "
                 f"{int(np.count_nonzero(filled)) if filled is not None else 0} synthesized faces tinted")
    if failed:
        what += f"; holes {', '.join(str(h['id']) for h in failed)} could not be filled (ringed)"
    shown = rd.DEFAULT_VIEW if view is None else view
    return {"png": buf.getvalue(), "alt": what, "width": int(img.shape[1]), "height": int(img.shape[0]),
            "view": view, "camera": f"--up {up_text(up)} --view {shown[0]:.10g},{shown[1]:.10g}",
            "open_edges_before": n_before, "open_edges_after": n_after, "failed": [h["id"] for h in failed]}


def _ring_failed(image, cam, holes, color):
    """A ring and the id of each hole (``id``, ``points`` its rim), around
    the rim's projection (drawn
    also where the surface hides the rim: a failed hole is never out of
    the picture unmarked while in its frame)."""
    from PIL import Image, ImageDraw

    from shellrepair.appearance.render import _font

    im = Image.fromarray(np.ascontiguousarray(image), "RGB")
    dr = ImageDraw.Draw(im)
    font = _font(int(np.clip(round(image.shape[0] / 24), 10, 20)))
    for h in holes:
        col, row, z = project(cam, h["points"])
        ok = (z > 0) & np.isfinite(col) & np.isfinite(row)
        if not np.any(ok):
            continue
        c0, r0 = float(col[ok].mean()), float(row[ok].mean())
        rad = float(np.max(np.hypot(col[ok] - c0, row[ok] - r0))) + 6.0
        dr.ellipse([c0 - rad, r0 - rad, c0 + rad, r0 + rad], outline=tuple(color), width=2)
        dr.text((c0 + rad * 0.75, r0 - rad * 0.75 - 12), str(h["id"]), fill=tuple(color), font=font)
    return np.asarray(im).copy()


# --------------------------------------------------------------------------
# the page
# --------------------------------------------------------------------------
_CSS = """
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0 auto;max-width:1100px;
 padding:1em 1.5em;color:#1d1d1f;background:#fbfbf8}
h1{font-size:1.6em;margin:.3em 0}h2{font-size:1.3em;margin:1.6em 0 .4em;border-bottom:1px solid #ccc}
h3{font-size:1.05em;margin:1.2em 0 .3em}
table{border-collapse:collapse;margin:.4em 0 1em}th,td{padding:.25em .7em;border-bottom:1px solid #ddd;
 text-align:right;vertical-align:top}th{background:#eee;position:sticky;top:0}
td.t,th.t{text-align:left}table.sortable th{cursor:pointer;user-select:none}
table.sortable th:after{content:" \\2195";color:#999;font-size:.8em}
tr.open td{background:#fff1ee}tr.total td{font-weight:600;border-top:2px solid #999}
figure{margin:.5em 0}figure img{max-width:100%;height:auto;border:1px solid #ccc}
figcaption{font-size:.9em;color:#444}.sw{display:inline-block;width:1em;height:1em;vertical-align:-.15em;
 border:1px solid #666;margin:0 .3em 0 .8em}dl{display:grid;grid-template-columns:max-content auto;gap:.1em 1em}
dt{font-weight:600}dd{margin:0;overflow-wrap:anywhere}.warn{color:#a03000;font-weight:600}
code{font-size:.92em}
"""

_JS = """
document.querySelectorAll('table.sortable').forEach(function(t){
 t.querySelectorAll('th').forEach(function(th,i){th.addEventListener('click',function(){
  var b=t.tBodies[0],rows=Array.prototype.slice.call(b.rows),asc=th.dataset.dir!=='asc';
  t.querySelectorAll('th').forEach(function(x){delete x.dataset.dir});th.dataset.dir=asc?'asc':'desc';
  rows.sort(function(r,s){var x=r.cells[i].dataset.v!==undefined?r.cells[i].dataset.v:r.cells[i].textContent,
   y=s.cells[i].dataset.v!==undefined?s.cells[i].dataset.v:s.cells[i].textContent,
   p=parseFloat(x),q=parseFloat(y),c=(!isNaN(p)&&!isNaN(q))?p-q:x.localeCompare(y);return asc?c:-c});
  rows.forEach(function(r){b.appendChild(r)})})})});
"""


def _e(x):
    return _html.escape("-" if x is None else str(x), quote=True)


def _num(x, spec=""):
    if x is None:
        return "-"
    try:
        return format(x, spec)
    except (TypeError, ValueError):
        return str(x)


def _rate_text(report):
    """The interpolation rate, with the open or non-manifold edges that
    remain named beside it (a full rate alone never hides them)."""
    rate = report.get("interpolation_rate")
    if rate is None:
        why = report.get("rate_withheld")
        return f"withheld: {why}" if why else "-"
    txt = f"{float(rate):.1f} %"
    left = (report.get("boundary_edges_after") or 0) + (report.get("nonmanifold_edges_after") or 0)
    if left:
        txt += f" of holes; {left} open or non-manifold edges remain"
    return txt


def _table1(report):
    rows = [("holes", report.get("holes_before"), report.get("holes_after"), _rate_text(report))]
    out = ['<table class="table1"><thead><tr><th class="t"></th><th>before</th><th>after</th>'
           '<th>interpolation rate</th></tr></thead><tbody>']
    for name, b, a, r in rows:
        out.append(f'<tr><td class="t">{_e(name)}</td><td>{_e(b)}</td><td>{_e(a)}</td><td>{_e(r)}</td></tr>')
    out.append("</tbody></table>")
    facts = [("filled", report.get("filled")), ("skipped", report.get("skipped")),
             ("failed", report.get("failed")), ("borders left open", report.get("borders")),
             ("boundary edges after", report.get("boundary_edges_after")),
             ("non-manifold edges after", report.get("nonmanifold_edges_after")),
             ("Euler characteristic", f"{_num(report.get('euler_before'))} → {_num(report.get('euler_after'))}"),
             ("vertices", f"{_num(report.get('vertices_before'), ',')} → {_num(report.get('vertices_after'), ',')}"),
             ("faces", f"{_num(report.get('faces_before'), ',')} → {_num(report.get('faces_after'), ',')}"),
             ("fill time", f"{_num(report.get('seconds'), '.2f')} s")]
    out.append("<dl>" + "".join(f"<dt>{_e(k)}</dt><dd>{_e(v)}</dd>" for k, v in facts) + "</dl>")
    return "\n".join(out)


def _hole_rows(report):
    holes = sorted(report.get("holes", []), key=lambda h: (_STATUS_ORDER.get(h.get("status"), 3), h.get("id", 0)))
    cols = [("id", "id"), ("edges", "edges"), ("status", "status"), ("patch", "kind"), ("order", "order"),
            ("reason", "reason"), ("option", "option"),
            ("new vertices", "new_vertices"), ("new faces", "new_faces"), ("seconds", "seconds")]
    text_cols = {"status", "kind", "reason", "option"}
    head = "".join(f'<th class="t">{_e(n)}</th>' if k in text_cols else f"<th>{_e(n)}</th>" for n, k in cols)
    body = []
    for h in holes:
        cls = ' class="open"' if h.get("status") != "filled" else ""
        cells = []
        for _, k in cols:
            v = h.get(k)
            if k in text_cols:
                cells.append(f'<td class="t">{_e(v)}</td>')
            else:
                cells.append(f'<td data-v="{_e(v if v is not None else "")}">{_e(v)}</td>')
        body.append(f"<tr{cls}>{''.join(cells)}</tr>")
    return (f'<table class="sortable holes"><thead><tr>{head}</tr></thead><tbody>\n'
            + "\n".join(body) + "\n</tbody></table>")


def _border_rows(report):
    borders = report.get("border_loops") or []
    if not borders:
        return "<p>No border left open.</p>"
    keys = [k for k in ("id", "edges", "reason") if any(k in b for b in borders)]
    head = "".join(f'<th class="t">{_e(k)}</th>' if k == "reason" else f"<th>{_e(k)}</th>" for k in keys)
    body = "".join("<tr>" + "".join(f'<td class="t">{_e(b.get(k))}</td>' if k == "reason" else
                                    f"<td>{_e(b.get(k))}</td>" for k in keys) + "</tr>" for b in borders)
    return f'<table class="sortable borders"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _figure_html(fig, src):
    legend = (f'<span class="sw" style="background:rgb{tuple(_tint())}"></span>synthesized (filled) faces'
              f'<span class="sw" style="background:rgb{OPEN_EDGE_COLOR}"></span>edges left open')
    return (f'<figure><img src="{_e(src)}" alt="{_e(fig.get("alt", "before and after the repair"))}" '
            f'width="{int(fig.get("width", 0))}" height="{int(fig.get("height", 0))}">'
            f"<figcaption><b>before</b> (left) | <b>after</b> (right), one camera. {legend}{_failed_legend(fig)}"
            f"{_camera_line(fig)}</figcaption></figure>")


def _failed_legend(fig):
    from shellrepair.report.closeups import FAILED_COLOR

    ids = fig.get("failed") or []
    if not ids:
        return ""
    return (f'<span class="sw" style="background:rgb{tuple(FAILED_COLOR)}"></span>'
            f'<span class="warn">holes that could not be filled (ringed: {_e(", ".join(map(str, ids)))})</span>')


def _camera_line(fig):
    return f"<br>Camera: <code>{_e(fig['camera'])}</code>" if fig.get("camera") else ""


_CLOSEUP_CSS = (".closeups{display:grid;grid-template-columns:repeat(auto-fill,minmax(300px,1fr));gap:.4em 1em}"
                ".closeups figure{margin:0}.closeups figcaption code{font-size:.8em;overflow-wrap:anywhere}"
                ".failed{color:rgb%s;font-weight:600}")


def _src(item):
    """A picture's ``src``: the file written beside the page, else its PNG inline."""
    if item.get("file"):
        return item["file"]
    return "data:image/png;base64," + base64.b64encode(item["png"]).decode("ascii")


def _xyz(c):
    return "-" if c is None else "(" + ", ".join(f"{float(x):.6g}" for x in c) + ")"


def _holes_of(r):
    h = r.get("holes") or []
    return ("hole " if len(h) == 1 else "holes ") + ", ".join(map(str, h)) if h else "(no hole found)"


def closeups_html(pics, *, level=3, scan=None, output=None):
    """The page's part for :func:`shellrepair.report.closeups.closeups`: a close-up
    per filled region (the largest), the other regions listed with their
    centre, and a view of each hole that could not be filled.

    Parameters
    ----------
    pics : dict
        :func:`shellrepair.report.closeups.closeups`' result (pictures inline as
        ``png``, or linked as ``file``).
    level : int
        Heading level.
    scan, output : str, optional
        The scan and the repaired mesh, for the ``shellrepair render``
        command under each picture.

    Returns
    -------
    html : str
    """
    from shellrepair.report.closeups import FAILED_COLOR

    h = f"h{level}"
    regions, more, failed = pics.get("regions", []), pics.get("more", []), pics.get("failed", [])
    n = len(regions) + len(more)
    if not n and not failed:
        return ""
    cmd = (f"shellrepair render {output or 'OUT.ply'} --before {scan or 'SCAN'} --highlight-filled "
           f"--size {{w}}x{{h}} -o pic.png ")
    parts = [f"<style>{_CLOSEUP_CSS % (tuple(FAILED_COLOR),)}</style>"]

    def fig_html(item, title):
        w = int(item.get("width", 0))
        ph = int(item.get("height", 0))
        pw = (w - 8) // 2            # one panel (render_side_by_side's gap: 8)
        again = cmd.format(w=pw, h=ph) + item["camera"]
        return (f'<figure><img src="{_e(_src(item))}" alt="{_e(item.get("alt"))}" width="{w}" height="{ph}">'
                f'<figcaption>{title}<br><code>{_e(again)}</code></figcaption></figure>')

    if n:
        parts.append(f"<{h}>Close-ups of the fills</{h}>")
        parts.append(f"<p>{n} filled region{'s' if n != 1 else ''} (a tube or band joining two holes is one); "
                     + (f"the {len(regions)} largest by area " if more else "each ")
                     + "seen from the side that sees it best, before (left) | after (right) with one camera; "
                     "under each, the command that renders it again. Up: <code>"
                     + _e(_up_label(pics.get("up"))) + "</code>.</p>")
        parts.append('<div class="closeups">' + "".join(
            fig_html(r, f"<b>{r['region']}</b>: {_e(_holes_of(r))}, {r['faces']} faces, area {r['area']:.4g}, "
                        f"centre {_e(_xyz(r['center']))}") for r in regions) + "</div>")
    if more:
        parts.append(f"<{h}>Other filled regions</{h}>")
        parts.append('<table class="sortable regions"><thead><tr><th>region</th><th class="t">holes</th>'
                     "<th>faces</th><th>area</th><th>x</th><th>y</th><th>z</th></tr></thead><tbody>"
                     + "".join(f'<tr><td>{r["region"]}</td><td class="t">{_e(", ".join(map(str, r["holes"])))}'
                               f'</td><td>{r["faces"]}</td><td data-v="{r["area"]}">{r["area"]:.4g}</td>'
                               + "".join(f"<td>{float(x):.6g}</td>" for x in r["center"]) + "</tr>"
                               for r in more) + "</tbody></table>")
    if failed:
        parts.append(f'<{h} class="failed">Holes that could not be filled</{h}>')
        parts.append(f'<p>Their rims are drawn in <span class="sw" style="background:rgb{tuple(FAILED_COLOR)}">'
                     "</span> here and ringed in the picture above.</p>")
        figs = []
        for f in failed:
            title = (f'<span class="failed">hole {f["id"]}</span>: {f.get("edges")} edges, centre '
                     f'{_e(_xyz(f.get("center")))}; {_e(f.get("reason"))}')
            figs.append(fig_html(f, title) if f.get("camera") else
                        f"<figure><figcaption>{title} (not located on the scan as read)</figcaption></figure>")
        parts.append('<div class="closeups">' + "".join(figs) + "</div>")
    return "\n".join(parts)


def _up_label(up):
    from shellrepair.report.upaxis import up_text

    return "y" if up is None else up_text(up)


def _tint():
    from shellrepair.appearance.render import FILLED_TINT

    t = np.asarray(FILLED_TINT, np.float64)
    if t.max() <= 1.0:
        t = t * 255.0
    return [int(round(x)) for x in t[:3]]


def options_text(options):
    """The repair options as the command line spells them: ``--closed auto``,
    not ``closed=None``; per-hole requests and limits only where given.

    Parameters
    ----------
    options : dict
        :meth:`RepairOptions.as_dict <shellrepair.options.RepairOptions.as_dict>`.

    Returns
    -------
    text : str
    """
    out = []
    for k, v in sorted(options.items()):
        if k == "expect" or v in ((), [], {}, None) and k != "closed":
            continue                 # a plan's loops, requests not made, limits not set
        if k == "closed":
            v = {None: "auto", True: "yes", False: "no"}.get(v, v)
        elif k == "max_hole_size":
            v = f"{v[0]:g}{v[1]}"
        elif k == "order_for":
            v = ",".join(f"{i}={o}" for i, o in sorted(v.items()))
        elif isinstance(v, (list, tuple)):
            v = ",".join(map(str, v))
        elif isinstance(v, bool):
            if not v:
                continue
            v = ""
        flag = "--max-hole" if k == "max_hole_size" else f"--{k.replace('_', '-')}"
        out.append(flag + (f" {v}" if v != "" else ""))
    return " ".join(out)


def _provenance(report, options, sha256, version):
    items = [("shellrepair", version), ("input", report.get("file")), ("input SHA-256", sha256),
             ("output", report.get("output"))]
    if options:
        items.append(("options", options_text(options)))
    return "<dl>" + "".join(f"<dt>{_e(k)}</dt><dd><code>{_e(v)}</code></dd>" for k, v in items) + "</dl>"


def scan_section(report, fig=None, *, image_src=None, options=None, sha256=None, anchor=None, level=2,
                 closeups=None, view=None, view_src=None):
    """The HTML of one scan's repair (a ``<section>``).

    Parameters
    ----------
    report : dict
        The repair report (``shellrepair repair --report``).
    fig : dict, optional
        From :func:`figure`; embedded as a ``data:`` URI unless
        ``image_src`` names a file to link instead.
    image_src : str, optional
        Relative path of the picture written beside the page.
    options : dict, optional
        The repair options, for the provenance block.
    sha256 : str, optional
        The input file's hash.
    anchor : str, optional
        The section's id.
    level : int
        Heading level of the scan's title.
    closeups : dict, optional
        From :func:`shellrepair.report.closeups.closeups`: shown after the picture
        (:func:`closeups_html`).
    view : dict, optional
        A 3D view's payload (:func:`shellrepair.report.webview.view_payload`),
        embedded; shown below the picture.
    view_src : str, optional
        Instead of ``view``: the relative path of the view's script file
        (:func:`shellrepair.report.webview.payload_script`), loaded when shown.

    Returns
    -------
    html : str
    """
    from shellrepair import __version__
    from shellrepair.report.table import loops_phrase

    name = Path(str(report.get("file", "scan"))).name
    h, h2 = f"h{level}", f"h{level + 1}"
    parts = [f'<section id="{_e(anchor)}">' if anchor else "<section>", f"<{h}>{_e(name)}</{h}>"]
    parts.append(_table1(report))
    left = (report.get("boundary_edges_after") or 0) + (report.get("nonmanifold_edges_after") or 0)
    if report.get("holes_after"):
        parts.append(f'<p class="warn">{_e(report["holes_after"])} holes left open (listed first below, '
                     "with their reason).</p>")
    elif left:
        parts.append(f'<p class="warn">{_e(left)} boundary or non-manifold edges remain.</p>')
    if fig is not None:
        src = image_src or "data:image/png;base64," + base64.b64encode(fig["png"]).decode("ascii")
        parts.append(_figure_html(fig, src))
    if closeups:
        parts.append(closeups_html(closeups, level=level + 1, scan=report.get("file"), output=report.get("output")))
    if view is not None or view_src is not None:
        from shellrepair.report.webview import viewer_html

        parts.append(viewer_html(view, f"view-{anchor}" if anchor else "view", src=view_src))
    parts.append(f"<{h2}>Holes</{h2}>")
    parts.append(_hole_rows(report) if report.get("holes") else "<p>No hole found.</p>")
    parts.append(f"<{h2}>Borders left open</{h2}>")
    parts.append(_border_rows(report))
    bridges = report.get("bridges") or []
    if bridges:
        parts.append(f"<{h2}>Bands</{h2}><ul>" + "".join(
            f"<li>loops {_e(loops_phrase(b['loops']))}: {_e(b.get('shape') or b.get('chosen'))} "
            f"({_e(b.get('reason'))})</li>"
            for b in bridges) + "</ul>")
    notes = report.get("notes") or []
    parts.append(f"<{h2}>Loading notes</{h2}>")
    parts.append("<ul>" + "".join(f"<li>{_e(n)}</li>" for n in notes) + "</ul>" if notes else "<p>None.</p>")
    parts.append(f"<{h2}>Provenance</{h2}>")
    parts.append(_provenance(report, options, sha256, __version__))
    parts.append("</section>")
    return "\n".join(parts)


def _page(title, body):
    if 'class="srv"' in body:     # a 3D view: its style and script, once
        from shellrepair.report.webview import viewer_assets

        body += "\n" + viewer_assets()
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">"
            f"<title>{_e(title)}</title><style>{_CSS}</style></head><body>\n"
            f"{body}\n<p><small>Written by shellrepair on {stamp}.</small></p>\n"
            f"<script>{_JS}</script>\n</body></html>\n")


def scan_page(report, fig=None, *, options=None, sha256=None, closeups=None, view=None):
    """A self-contained page for one repaired scan (pictures and 3D view embedded).

    Parameters
    ----------
    report : dict
    fig : dict, optional
        From :func:`figure`.
    options : dict, optional
    sha256 : str, optional
    closeups : dict, optional
        From :func:`shellrepair.report.closeups.closeups`.
    view : dict, optional
        From :func:`shellrepair.report.webview.view_payload`: the page gets a 3D view.

    Returns
    -------
    html : str
    """
    name = Path(str(report.get("file", "scan"))).name
    body = ("<h1>Repair of " + _e(name) + "</h1>\n"
            + scan_section(report, fig, options=options, sha256=sha256, level=2, closeups=closeups,
                           view=view))
    return _page(f"shellrepair: {name}", body)


def collection_page(summary, sections):
    """The page of a whole folder (``OUTDIR/index.html`` of ``batch``).

    Parameters
    ----------
    summary : dict
        :func:`shellrepair.batch.repair_folder`'s summary.
    sections : list of str
        One :func:`scan_section` per repaired scan, in the summary's order
        (failed scans have none: pass ``None``).

    Returns
    -------
    html : str
    """
    rows = []
    for i, r in enumerate(summary.get("scans", [])):
        link = f'<a href="#scan-{i}">{_e(r["file"])}</a>' if sections[i] else _e(r["file"])
        status = r["status"] if repaired(r) else f"error: {r.get('error')}"
        cls = ' class="open"' if r["status"] != "ok" or (r.get("holes_after") or 0) > 0 else ""
        rows.append(f'<tr{cls}><td class="t">{link}</td><td data-v="{_e(r.get("vertices") or "")}">'
                    f'{_num(r.get("vertices"), ",")}</td><td data-v="{_e(r.get("faces") or "")}">'
                    f'{_num(r.get("faces"), ",")}</td><td>{_e(r.get("holes_before"))}</td>'
                    f'<td>{_e(r.get("holes_after"))}</td><td>{_num(r.get("rate"), ".1f")}</td>'
                    f'<td>{_num(r.get("seconds"), ".1f")}</td><td class="t">{_e(status)}</td></tr>')
    tot = (f'<tr class="total"><td class="t">all {summary.get("n_scans", len(rows))} scans</td><td></td><td></td>'
           f'<td>{_e(summary.get("holes_before"))}</td><td>{_e(summary.get("holes_after"))}</td>'
           f'<td>{_num(summary.get("rate"), ".1f")}</td><td>{_num(summary.get("seconds"), ".1f")}</td>'
           f'<td class="t">{_e(status_counts(summary))}</td></tr>')
    table = ('<table class="sortable scans"><thead><tr><th class="t">scan</th><th>vertices</th><th>faces</th>'
             "<th>holes before</th><th>after</th><th>rate %</th><th>seconds</th><th class=\"t\">status</th>"
             "</tr></thead><tbody>\n" + "\n".join(rows) + "\n</tbody><tfoot>" + tot + "</tfoot></table>")
    opts = summary.get("options") or {}
    body = [f"<h1>Repair of {_e(summary.get('folder'))}</h1>",
            "<p>Table 1 for the whole collection (last row) and for each scan; the scans follow, each with "
            "its picture, its holes and its provenance.</p>", table,
            "<p>Options: <code>" + _e(options_text(opts)) + "</code></p>"]
    body += [s for s in sections if s]
    return _page(f"shellrepair: {summary.get('folder')}", "\n".join(body))


def write_page(path, html):
    """Write a page atomically (see :func:`shellrepair.mesh.io.atomic_write`)."""
    from shellrepair.mesh.io import atomic_write

    atomic_write(Path(path), html)


def report_json(path):
    """A report read back from its JSON file."""
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)
