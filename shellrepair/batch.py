"""Repair every scan of a folder: one repaired mesh and one report per scan,
and a summary of the whole folder.

    summary = repair_folder("scans/", "repaired/", jobs=2)

For each ``*.ply``, ``*.obj``, ``*.off`` and ``*.stl`` file directly in the
folder (not in sub-folders; names starting with ``.`` are skipped), in
sorted name order:

1. read it (:func:`shellrepair.io.read_mesh`);
2. fill its holes (:func:`shellrepair.repair.repair_mesh`, the same options
   for every scan; ``jobs`` processes per scan);
3. write ``OUTDIR/<stem>.repaired.ply`` and ``OUTDIR/<stem>.report.json``
   together, atomically (both or neither).

A scan that cannot be read or repaired, or whose outputs cannot be written,
gets ``status: "error"`` and its one-line message; the others go on.
``OUTDIR/summary.json`` is rewritten after every scan (``"complete":
false`` until the last one), so an interrupted run still says what it did.

Naming: two scans with the same stem (``bust.ply`` and ``bust.obj``) would
write the same outputs, so for them the whole file name is used
(``bust.obj.repaired.ply``). When ``OUTDIR`` is the scan folder itself,
earlier outputs (``*.repaired.*``) are not taken for scans.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from .errors import MeshError

__all__ = ["repair_folder", "list_scans", "summary_table", "SUMMARY_NAME"]

#: The folder summary written into OUTDIR.
SUMMARY_NAME = "summary.json"
#: Extensions taken for scans (lower case).
SCAN_EXTENSIONS = (".ply", ".obj", ".off", ".stl")
#: Longest error message kept in a summary row (characters).
MAX_MESSAGE = 300


def list_scans(folder, *, skip_outputs=False):
    """The scan files directly in ``folder``, sorted by name.

    Parameters
    ----------
    folder : str or Path
    skip_outputs : bool
        Also leave out ``*.repaired.*`` files (earlier outputs of a batch
        written into the same folder).

    Returns
    -------
    paths : list of Path

    Raises
    ------
    MeshError
        If ``folder`` is not a directory.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise MeshError("not a directory" if folder.exists() else "no such directory", folder)
    out = []
    for p in sorted(folder.iterdir(), key=lambda q: q.name):
        if p.name.startswith(".") or p.suffix.lower() not in SCAN_EXTENSIONS:
            continue
        if skip_outputs and Path(p.stem).suffix == ".repaired":
            continue
        if p.is_dir():
            continue
        out.append(p)
    return out


def _output_names(scans):
    """Output base name of each scan: its stem, or its whole name when the
    stem is shared by another scan of the folder."""
    stems = {}
    for p in scans:
        stems[p.stem] = stems.get(p.stem, 0) + 1
    return [p.stem if stems[p.stem] == 1 else p.name for p in scans]


def _prepare_outdir(outdir):
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise MeshError("output folder exists and is not a directory", outdir)
    if not outdir.parent.is_dir():
        raise MeshError("the output folder's parent does not exist", outdir)
    try:
        outdir.mkdir(exist_ok=True)
    except OSError as exc:
        raise MeshError(f"cannot create the output folder: {exc.strerror or exc}", outdir) from None
    return outdir


def _message(exc):
    """One line for a failed scan."""
    if isinstance(exc, MeshError):
        msg = exc.message
    elif isinstance(exc, MemoryError):
        msg = "out of memory"
    elif isinstance(exc, OSError):
        msg = exc.strerror or str(exc)
    else:  # an internal bug: still one line, the run goes on
        msg = f"internal error: {type(exc).__name__}: {exc}"
    msg = " ".join(str(msg).split())
    return msg[:MAX_MESSAGE]


def _repair_one(scan, out, report_path, options, progress, picture=None):
    """Read, repair and write one scan; returns its summary row fields.
    With ``picture`` (a path), also its before | after picture there."""
    from .io import atomic_write_many, mesh_bytes, read_mesh
    from .repair import repair_mesh

    t0 = time.perf_counter()
    mesh = read_mesh(scan, progress=progress)
    row = {"vertices": mesh.n_vertices, "faces": mesh.n_faces}
    repaired, report = repair_mesh(mesh, progress=progress, **options)  # options: RepairOptions.as_dict()
    report["file"] = str(scan)
    report["output"] = str(out)
    report["notes"] = list(repaired.notes)
    items = []
    if picture is not None:
        from .htmlreport import figure, file_sha256

        fig = figure(mesh, repaired, report)
        report["input_sha256"] = file_sha256(scan)
        report["picture"] = {"file": Path(picture).name, "alt": fig["alt"], "width": fig["width"],
                             "height": fig["height"]}
        items.append((picture, fig["png"]))
    del mesh  # a large scan: free what is no longer needed before writing
    payload = mesh_bytes(out, repaired)
    del repaired
    report["seconds_total"] = round(time.perf_counter() - t0, 4)
    atomic_write_many([(out, payload), (report_path, json.dumps(report, indent=1) + "\n")] + items)
    row.update(holes_before=int(report["holes_before"]), holes_after=int(report["holes_after"]),
               rate=report["interpolation_rate"], borders=int(report.get("borders", 0) or 0),
               vertices_after=int(report.get("vertices_after", 0)), faces_after=int(report.get("faces_after", 0)),
               report=str(report_path), output=str(out))
    return row


def _totals(rows):
    from .report import interpolation_rate

    ok = [r for r in rows if r["status"] == "ok"]
    before = sum(r["holes_before"] for r in ok)
    after = sum(r["holes_after"] for r in ok)
    return {"n_scans": len(rows), "n_ok": len(ok), "n_failed": len(rows) - len(ok),
            "holes_before": before, "holes_after": after,
            "rate": interpolation_rate(before, after) if before else None}


def repair_folder(folder, outdir, options=None, *, progress=None, on_scan=None, html=False, **changes):
    """Repair every scan of ``folder`` into ``outdir``.

    Parameters
    ----------
    folder : str or Path
        Where the scans are (not searched recursively).
    outdir : str or Path
        Where outputs go; created if missing (its parent must exist).
    options : RepairOptions, optional
        The repair options for every scan
        (:class:`shellrepair.options.RepairOptions`); default: the defaults.
    **changes
        Any option by name, applied over ``options``.
    progress : bool, optional
        Draw progress bars on stderr; default: when stderr is a terminal.
    on_scan : callable, optional
        Called with each finished summary row (the CLI prints a line).
    html : bool
        Also write ``outdir/index.html`` (:func:`shellrepair.htmlreport.collection_page`):
        Table 1 of the collection and of each scan, each scan's holes,
        notes and provenance, and its before | after picture
        (``outdir/<name>.view.png``, linked from the page). Rewritten after
        every scan, like the summary.

    Returns
    -------
    summary : dict
        ``folder``, ``outdir``, ``options``, ``scans`` (one row per scan:
        ``file``, ``status`` ok / error, ``error``, ``vertices``, ``faces``,
        ``holes_before``, ``holes_after``, ``rate``, ``seconds``, ``output``,
        ``report``), the totals ``n_scans``, ``n_ok``, ``n_failed``,
        ``holes_before``, ``holes_after``, ``rate``, and ``seconds``.
        Also written to ``outdir/summary.json``.

    Raises
    ------
    MeshError
        Only for problems with the folders themselves (missing folder, no
        scans in it, output folder cannot be made) and bad options; a bad
        scan is a row, not an exception.
    """
    from .io import atomic_write
    from .progress import Progress, prefix, progress_enabled

    from .options import RepairOptions

    opts = RepairOptions.make(options, **changes)  # checked once, before any scan
    folder = Path(folder)
    same = False
    if Path(outdir).is_dir() and folder.is_dir():
        same = Path(outdir).resolve() == folder.resolve()
    scans = list_scans(folder, skip_outputs=same)
    if not scans:
        raise MeshError(f"no scans ({', '.join('*' + e for e in SCAN_EXTENSIONS)}) in the folder", folder)
    outdir = _prepare_outdir(outdir)
    options = opts.as_dict()
    draw = progress_enabled() if progress is None else bool(progress)
    summary = {"folder": str(folder), "outdir": str(outdir), "options": options, "complete": False,
               "scans": []}
    summary_path = outdir / SUMMARY_NAME
    t_all = time.perf_counter()
    rows = summary["scans"]
    bar = Progress("scans", len(scans), enabled=draw)
    try:
        for i, (scan, name) in enumerate(zip(scans, _output_names(scans))):
            out = outdir / f"{name}.repaired.ply"
            report_path = outdir / f"{name}.report.json"
            row = {"file": scan.name, "status": "ok", "error": None, "vertices": None, "faces": None,
                   "holes_before": None, "holes_after": None, "rate": None, "seconds": None}
            bar.update(0, note=f"reading {scan.name}", force=True)
            t0 = time.perf_counter()
            try:
                with prefix(f"{i + 1}/{len(scans)} {scan.name}"):
                    row.update(_repair_one(scan, out, report_path, options, draw,
                                           picture=outdir / f"{name}.view.png" if html else None))
            except Exception as exc:  # noqa: BLE001 - one bad scan is a row, the rest go on
                row.update(status="error", error=_message(exc))
            row["seconds"] = round(time.perf_counter() - t0, 3)
            rows.append(row)
            if on_scan is not None:
                bar.clear()  # the caller's line starts at column 0, the bar follows it
                on_scan(row)
            bar.update(1, note=f"{scan.name} {row['status']}", force=True)
            summary.update(_totals(rows), seconds=round(time.perf_counter() - t_all, 3))
            atomic_write(summary_path, json.dumps(summary, indent=1) + "\n")
            if html:
                _write_index(summary, outdir)
    finally:
        bar.close()
    summary["complete"] = True
    summary.update(_totals(rows), seconds=round(time.perf_counter() - t_all, 3))
    atomic_write(summary_path, json.dumps(summary, indent=1) + "\n")
    if html:
        _write_index(summary, outdir)
    return summary


#: The collection page written into OUTDIR.
INDEX_NAME = "index.html"


def _write_index(summary, outdir):
    """OUTDIR/index.html from the summary and the reports written so far."""
    from .htmlreport import collection_page, report_json, scan_section, write_page

    sections = []
    for i, r in enumerate(summary["scans"]):
        if r["status"] != "ok":
            sections.append(None)
            continue
        rep = report_json(r["report"])
        pic = rep.get("picture")
        fig = None
        if pic:
            fig = {"png": b"", "alt": pic["alt"], "width": pic["width"], "height": pic["height"]}
        sections.append(scan_section(rep, fig, image_src=pic["file"] if pic else None, options=summary["options"],
                                     sha256=rep.get("input_sha256"), anchor=f"scan-{i}", level=2))
    write_page(Path(outdir) / INDEX_NAME, collection_page(summary, sections))


def _fmt(v, spec=""):
    if v is None:
        return "-"
    return format(v, spec)


def summary_table(summary, *, errors=True):
    """The summary as a fixed-width text table; with ``errors``, the failed
    scans' messages below it."""
    head = ("file", "vertices", "faces", "holes before", "after", "rate %", "seconds", "status")
    body = []
    for r in summary["scans"]:
        body.append((r["file"], _fmt(r["vertices"], ","), _fmt(r["faces"], ","), _fmt(r["holes_before"]),
                     _fmt(r["holes_after"]), _fmt(r["rate"], ".1f"), _fmt(r["seconds"], ".1f"), r["status"]))
    tot = ("total", "", "", _fmt(summary.get("holes_before")), _fmt(summary.get("holes_after")),
           _fmt(summary.get("rate"), ".1f"), _fmt(summary.get("seconds"), ".1f"),
           f"{summary.get('n_ok', 0)} ok, {summary.get('n_failed', 0)} failed")
    allrows = [head] + body + [tot]
    w = [max(len(str(r[j])) for r in allrows) for j in range(len(head))]

    def line(r):
        return "  ".join(str(c).ljust(w[j]) if j in (0, 7) else str(c).rjust(w[j])
                         for j, c in enumerate(r)).rstrip()

    out = [line(head), "  ".join("-" * x for x in w)] + [line(r) for r in body]
    out += ["  ".join("-" * x for x in w), line(tot)]
    errs = [r for r in summary["scans"] if r["status"] != "ok"]
    if errs and errors:
        out.append("")
        out += [f"error: {r['file']}: {r['error']}" for r in errs]
    return "\n".join(out)
