"""Repair every scan of a folder: one repaired mesh and one report per scan,
and a summary of the whole folder.

    summary = repair_folder("scans/", "repaired/", jobs=2)

For each ``*.ply``, ``*.obj``, ``*.off`` and ``*.stl`` file directly in the
folder (not in sub-folders; names starting with ``.`` are skipped), in
sorted name order:

1. read it (:func:`shellrepair.mesh.io.read_mesh`);
2. fill its holes (:func:`shellrepair.repair.repair_mesh`, the same options
   for every scan);
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

Where the scans run
-------------------
Each scan is one task: a function of its file paths that reads, repairs and
writes the scan and returns its summary row (a few numbers), so only paths
and rows travel, never the mesh arrays. The tasks run

- **in this process**, one scan after another, when one scan runs at a time
  (``jobs=1``, a folder of one scan, or Dask not installed): the scan then
  gets the ``jobs`` cores itself, its holes filled by ``jobs`` processes
  (:class:`~shellrepair.options.RepairOptions` ``jobs``). This is the path
  that needs nothing beyond the package.
- **on a local Dask cluster** when ``jobs > 1``, the folder has more than one
  scan and ``dask.distributed`` is installed (``pip install
  'shellrepair[cluster]'``): ``min(jobs, scans)`` worker processes of one
  thread each, each scan filled by one process.
- **on an existing Dask cluster** with ``scheduler="tcp://host:8786"``: its
  workers must import ``shellrepair`` and see the scan and output folders at
  the same paths as this machine (a shared file system); paths are sent
  absolute. Each scan is filled by one process.

The outputs do not depend on where the scans ran: meshes, pictures and
reports are the same bytes, except the timing fields (``seconds``,
``seconds_total``) and a report's ``jobs`` (the hole processes its scan had).
This process writes ``summary.json`` and ``index.html`` as scans finish,
the rows always in sorted name order. A worker that dies (a crash, the
kernel's out-of-memory killer) makes its scan a failed row, not a failed
batch.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from shellrepair.errors import MeshError
from shellrepair.files import check_output_folder
from shellrepair.report.table import repaired, status_counts

__all__ = ["repair_folder", "list_scans", "summary_table", "default_jobs", "write_index", "SUMMARY_NAME"]

#: The folder summary written into OUTDIR.
SUMMARY_NAME = "summary.json"
#: Extensions taken for scans (lower case).
SCAN_EXTENSIONS = (".ply", ".obj", ".off", ".stl")
#: Longest error message kept in a summary row (characters).
MAX_MESSAGE = 300
#: Seconds to wait for an existing Dask scheduler to answer, and for it to
#: have at least one worker.
CONNECT_TIMEOUT = 10.0
#: Times the local cluster runs a scan again after its worker died (a
#: transient death gets one more chance; a scan that kills every worker it
#: meets is not tried over and over).
RETRIES_AFTER_DEATH = 1
#: What to install for the Dask paths.
CLUSTER_EXTRA = "pip install 'shellrepair[cluster]'"


def default_jobs():
    """The cores this process may run on (its CPU affinity where the system
    says, else ``os.cpu_count()``), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # no affinity on this system
        return max(1, os.cpu_count() or 1)


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
    """The output folder, created if missing, after checking files can be written in it."""
    outdir = Path(outdir)
    check_output_folder(outdir)
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


def _repair_one(task, options, progress):
    """Read, repair and write one scan; returns its summary row fields.
    With ``task["picture"]`` (a path), also its before | after picture there,
    and its 3D view's script beside it (``.js`` for ``.png``)."""
    from shellrepair.mesh.io import atomic_write_many, mesh_bytes, read_mesh
    from shellrepair.preload import preload_fill

    scan, out, report_path, picture = task["scan"], task["out"], task["report"], task["picture"]
    t0 = time.perf_counter()
    preload_fill()    # the fill's modules and kernels load while the scan is read
    mesh = read_mesh(scan, progress=progress)
    from shellrepair.repair import repair_mesh

    row = {"vertices": mesh.n_vertices, "faces": mesh.n_faces}
    repaired, report = repair_mesh(mesh, progress=progress, **options)  # options: RepairOptions.as_dict()
    report["file"] = task["shown_scan"]
    report["output"] = task["shown_out"]
    report["notes"] = list(repaired.notes)
    items = []
    if picture is not None:
        from shellrepair.report.closeups import closeups, pictures_record
        from shellrepair.report.html import figure, file_sha256
        from shellrepair.report.upaxis import mesh_up

        report["up"] = up = mesh_up(mesh)   # the one axis of every picture of this scan
        fig = figure(mesh, repaired, report, up=up["axis"])
        report["input_sha256"] = file_sha256(scan)
        report["picture"] = {"file": Path(picture).name, "alt": fig["alt"], "width": fig["width"],
                             "height": fig["height"]}
        items.append((picture, fig["png"]))
        pics = closeups(mesh, repaired, report, up=up["axis"])
        stem = Path(picture).name[:-len(".view.png")] if Path(picture).name.endswith(".view.png") \
            else Path(picture).stem
        files = {}
        for kind, key, rows in (("fill", "region", pics["regions"]), ("failed", "id", pics["failed"])):
            for r in rows:
                if "png" in r:
                    name = f"{stem}.{kind}-{r[key]}.png"
                    files[("region" if kind == "fill" else "failed", r[key])] = name
                    items.append((Path(picture).with_name(name), r["png"]))
        report["pictures"] = pictures_record(fig, pics, files)
        from shellrepair.report.webview import payload_script, view_payload

        view = view_payload(repaired, up=up["axis"])
        if view is not None:   # the 3D view's mesh, loaded by the page when shown
            script = Path(picture).with_suffix(".js")
            report["view"] = {"file": script.name, "faces_shown": view["faces_shown"],
                              "faces_total": view["faces_total"]}
            items.append((script, payload_script(view, script.name)))
            del view
    del mesh  # a large scan: free what is no longer needed before writing
    payload = mesh_bytes(out, repaired)
    del repaired
    report["seconds_total"] = round(time.perf_counter() - t0, 4)
    atomic_write_many([(out, payload), (report_path, json.dumps(report, indent=1) + "\n")] + items)
    failed = int(report.get("failed", 0) or 0)
    # some holes the fill could not close (not those left open on purpose): not "ok"
    row.update(status="partial" if failed else "ok", holes_failed=failed,
               holes_before=int(report["holes_before"]), holes_after=int(report["holes_after"]),
               rate=report["interpolation_rate"], borders=int(report.get("borders", 0) or 0),
               vertices_after=int(report.get("vertices_after", 0)), faces_after=int(report.get("faces_after", 0)),
               report=task["shown_report"], output=task["shown_out"])
    return row


def _empty_row(name):
    return {"file": name, "status": "ok", "error": None, "vertices": None, "faces": None,
            "holes_before": None, "holes_after": None, "rate": None, "seconds": None}


def repair_scan_task(task, options, progress=None):
    """One scan, start to end: the task a worker runs.

    Parameters
    ----------
    task : dict
        ``name`` (the scan's file name), ``scan``, ``out``, ``report``,
        ``picture`` (absolute paths; ``picture`` None for none) and
        ``shown_scan``, ``shown_out``, ``shown_report`` (the paths as the
        reports and the summary give them).
    options : dict
        :meth:`RepairOptions.as_dict <shellrepair.options.RepairOptions.as_dict>`.
    progress : callable, optional
        This scan's progress callback ``(label, done, total)`` (in-process
        runs; see :mod:`shellrepair.progress`); None or False: nothing.

    Returns
    -------
    row : dict
        The scan's summary row, plain JSON values; a scan that failed has
        ``status`` ``"error"`` and ``error`` its one-line message (the
        function itself raises only on KeyboardInterrupt and the like).
    """
    row = _empty_row(task["name"])
    t0 = time.perf_counter()
    try:
        row.update(_repair_one(task, options, progress))
    except Exception as exc:  # noqa: BLE001 - one bad scan is a row, the rest go on
        row.update(status="error", error=_message(exc))
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row


def _lost_row(name, exc):
    """The row of a scan whose task did not come back (its worker died, the
    scheduler went away, the worker could not run the function)."""
    kind = type(exc).__name__
    if kind == "KilledWorker":
        msg = "a worker died repairing it (a crash, or out of memory), also when tried again"
    elif kind in ("CancelledError", "FutureCancelledError"):
        msg = "its task was cancelled (the Dask scheduler or its worker went away)"
    else:
        msg = f"its task failed on the cluster: {kind}: {exc}"
    row = _empty_row(name)
    row.update(status="error", error=" ".join(msg.split())[:MAX_MESSAGE])
    return row


def _totals(rows):
    from shellrepair.report.table import interpolation_rate

    done = [r for r in rows if repaired(r)]
    before = sum(r["holes_before"] for r in done)
    after = sum(r["holes_after"] for r in done)
    n_ok = sum(r["status"] == "ok" for r in done)
    return {"n_scans": len(rows), "n_ok": n_ok, "n_partial": len(done) - n_ok, "n_failed": len(rows) - len(done),
            "holes_before": before, "holes_after": after,
            "rate": interpolation_rate(before, after) if before else None}


def _import_distributed():
    """``dask.distributed``, or None when it is not installed."""
    try:
        import distributed
    except ImportError:
        return None
    return distributed


def _runner(n_scans, jobs, scheduler):
    """Where the scans run: (kind, workers, hole processes per scan, note)."""
    if scheduler is not None:
        return "scheduler", None, 1, None
    workers = min(jobs, n_scans)
    if workers > 1:
        if _import_distributed() is not None:
            return "local-cluster", workers, 1, None
        return "in-process", 1, jobs, f"dask.distributed is not installed, so scans run one at a time " \
                                      f"(each on {jobs} cores); for {workers} at once: {CLUSTER_EXTRA}"
    return "in-process", 1, jobs, None


def repair_folder(folder, outdir, options=None, *, jobs=None, scheduler=None, progress=None, on_scan=None,
                  html=False, connect_timeout=None, **changes):
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
        Its ``jobs`` is set by the batch (below).
    **changes
        Any option by name, applied over ``options``.
    jobs : int, optional
        Cores to use (default: :func:`default_jobs`, the cores there are).
        More than one scan: ``min(jobs, scans)`` scans at once on a local
        Dask cluster, one process each (in this process, one at a time, when
        Dask is not installed). One scan at a time: its holes on ``jobs``
        processes. The meshes are the same bytes for any ``jobs``.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``): one task
        per scan on its workers (``jobs`` is then not used).
    progress : callable, optional
        Called as ``progress(label, done, total)`` (the protocol of
        :mod:`shellrepair.progress`): ``"scans"`` 0..n, and, for scans
        repaired in this process, each scan's reading and repair stages with
        ``"<i>/<n> <file>: "`` in front of their labels. Default None:
        nothing is reported or drawn; ``True`` draws the terminal bars.
        Scans run in this process draw their own bars too.
    on_scan : callable, optional
        Called with each finished summary row, in the order scans finish
        (the CLI prints a line).
    html : bool
        Also write ``outdir/index.html`` (:func:`shellrepair.report.html.collection_page`):
        Table 1 of the collection and of each scan, each scan's holes,
        notes and provenance, its before | after picture
        (``outdir/<name>.view.png``, linked from the page), a close-up of
        each filled region (``<name>.fill-<k>.png``, the 24 largest) and of
        each hole that could not be filled (``<name>.failed-<id>.png``),
        all with the scan's inferred up axis (:mod:`shellrepair.report.upaxis`,
        recorded in its report), and its 3D view (``outdir/<name>.view.js``,
        loaded when scrolled to). Rewritten after every scan, like the summary.
    connect_timeout : float, optional
        Seconds to wait for ``scheduler`` to answer and to have a worker
        (default :data:`CONNECT_TIMEOUT`).

    Returns
    -------
    summary : dict
        ``folder``, ``outdir``, ``options`` (those of each scan), ``runner``
        (``kind`` in-process / local-cluster / scheduler, ``workers``,
        ``scheduler``, ``jobs_per_scan``, and a ``note`` when Dask was
        wanted but missing), ``scans`` (one row per scan, in name order:
        ``file``, ``status`` ok / error, ``error``, ``vertices``, ``faces``,
        ``holes_before``, ``holes_after``, ``rate``, ``seconds``, ``output``,
        ``report``), the totals ``n_scans``, ``n_ok``, ``n_failed``,
        ``holes_before``, ``holes_after``, ``rate``, and ``seconds``.
        Also written to ``outdir/summary.json``.

    Raises
    ------
    MeshError
        Only for problems with the folders themselves (missing folder, no
        scans in it, output folder cannot be made), bad options, and a
        ``scheduler`` that cannot be used (Dask not installed, not reached
        within ``connect_timeout``, no workers); a bad scan is a row, not an
        exception.
    """
    from shellrepair.mesh.io import atomic_write
    from shellrepair.options import RepairOptions
    from shellrepair.progress import as_callback

    opts = RepairOptions.make(options, **changes)  # checked once, before any scan
    if jobs is None:
        jobs = default_jobs()
    RepairOptions(jobs=jobs)  # the same check and message as the option's
    jobs = int(jobs)
    folder = Path(folder)
    same = False
    if Path(outdir).is_dir() and folder.is_dir():
        same = Path(outdir).resolve() == folder.resolve()
    scans = list_scans(folder, skip_outputs=same)
    if not scans:
        raise MeshError(f"no scans ({', '.join('*' + e for e in SCAN_EXTENSIONS)}) in the folder", folder)
    kind, workers, per_scan, note = _runner(len(scans), jobs, scheduler)
    if kind == "scheduler":  # before any output
        client = _connect(scheduler, CONNECT_TIMEOUT if connect_timeout is None else float(connect_timeout))
    else:
        client = None
    try:
        outdir = _prepare_outdir(outdir)
    except MeshError:
        if client is not None:
            client.close()
        raise
    options = opts.replace(jobs=per_scan).as_dict()
    report = as_callback(progress)
    tasks = []
    for scan, name in zip(scans, _output_names(scans)):
        out = outdir / f"{name}.repaired.ply"
        picture = outdir / f"{name}.view.png" if html else None
        tasks.append({"name": scan.name, "scan": str(scan.resolve()), "out": str(out.resolve()),
                      "report": str((outdir / f"{name}.report.json").resolve()),
                      "picture": None if picture is None else str(picture.resolve()),
                      "shown_scan": str(scan), "shown_out": str(out),
                      "shown_report": str(outdir / f"{name}.report.json")})
    if client is not None:
        workers = len(client.scheduler_info().get("workers", {}))
    runner = {"kind": kind, "workers": workers, "scheduler": scheduler, "jobs_per_scan": per_scan}
    if note:
        runner["note"] = note
    summary = {"folder": str(folder), "outdir": str(outdir), "options": options, "runner": runner,
               "complete": False, "scans": []}
    summary_path = outdir / SUMMARY_NAME
    t_all = time.perf_counter()
    done = {}  # scan index -> row
    sections = {}  # index.html sections built so far
    if report is not None:
        report("scans", 0, len(scans))

    def finished(i, row):
        done[i] = row
        if on_scan is not None:
            on_scan(row)
        if report is not None:
            report("scans", len(done), len(scans))
        summary["scans"] = [done[k] for k in sorted(done)]  # name order, whatever order they finish in
        summary.update(_totals(summary["scans"]), seconds=round(time.perf_counter() - t_all, 3))
        atomic_write(summary_path, json.dumps(summary, indent=1) + "\n")
        if html:
            write_index(summary, outdir, sections)

    try:
        if kind == "in-process":
            for i, task in enumerate(tasks):
                row = repair_scan_task(task, options, _prefixed(report, f"{i + 1}/{len(tasks)} {task['name']}: "))
                finished(i, row)
        else:
            _run_on_dask(tasks, options, finished, client=client, workers=workers)
    finally:
        if client is not None:
            client.close()
    summary["complete"] = True
    summary.update(_totals(summary["scans"]), seconds=round(time.perf_counter() - t_all, 3))
    atomic_write(summary_path, json.dumps(summary, indent=1) + "\n")
    if html:
        write_index(summary, outdir, sections)
    return summary


def _prefixed(report, text):
    """``report`` with ``text`` in front of every label (None stays None)."""
    if report is None:
        return None
    return lambda label, done, total: report(text + label, done, total)


def _connect(address, timeout):
    """A Dask client of the scheduler at ``address`` with at least one
    worker, or a one-line MeshError."""
    distributed = _import_distributed()
    if distributed is None:
        raise MeshError(f"a Dask scheduler needs dask.distributed, which is not installed ({CLUSTER_EXTRA})")
    try:
        client = distributed.Client(address, timeout=timeout, set_as_default=False)
    except Exception as exc:  # noqa: BLE001 - a refused, unknown or silent address: one line
        why = " ".join(str(exc).split())[:MAX_MESSAGE // 2] or type(exc).__name__
        raise MeshError(f"cannot reach the Dask scheduler at {address} within {timeout:g} s ({why})") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except Exception:  # noqa: BLE001 - dask raises TimeoutError
        client.close()
        raise MeshError(f"the Dask scheduler at {address} has no workers (waited {timeout:g} s)") from None
    return client


def _run_on_dask(tasks, options, finished, *, client=None, workers=None):
    """Run one :func:`repair_scan_task` per scan on ``client``'s cluster, or on
    a local cluster of ``workers`` processes made here; ``finished(i, row)``
    as each comes back."""
    import contextlib
    import logging
    import uuid

    import dask

    distributed = _import_distributed()
    with contextlib.ExitStack() as stack:
        if client is None:
            with dask.config.set({"distributed.scheduler.allowed-failures": RETRIES_AFTER_DEATH}):
                # memory_limit=0: a scan may use the memory it would use in this process;
                # dashboard on a free port, so that a second batch does not warn
                cluster = stack.enter_context(distributed.LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                    memory_limit=0, silence_logs=logging.ERROR))
            client = stack.enter_context(distributed.Client(cluster, set_as_default=False))
        # the biggest files first, so that a big scan does not start last
        order = sorted(range(len(tasks)), key=lambda i: (-_size(tasks[i]["scan"]), i))
        futures = {}
        for i in order:
            key = f"shellrepair-scan-{i}-{uuid.uuid4().hex}"  # names the scan in Dask's dashboard
            futures[client.submit(repair_scan_task, tasks[i], options, key=key)] = i
        for fut in distributed.as_completed(list(futures), loop=client.loop):
            i = futures[fut]
            try:
                row = fut.result()
            except Exception as exc:  # noqa: BLE001 - the task did not come back: a row, the rest go on
                row = _lost_row(tasks[i]["name"], exc)
            finished(i, row)
            fut.release()


def _size(path):
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


#: The collection page written into OUTDIR.
INDEX_NAME = "index.html"


def write_index(summary, outdir, cache=None):
    """OUTDIR/index.html from the summary and the reports written so far.

    Parameters
    ----------
    summary : dict
        The batch summary; its ``scans`` rows in name order.
    outdir : Path
        The output folder.
    cache : dict, optional
        Sections already built, by position, scan file, report and status: the page is
        rewritten after every scan, and each scan's report is read once
        rather than once per later scan.
    """
    from shellrepair.report.html import collection_page, write_page

    sections = []
    for i, r in enumerate(summary["scans"]):
        key = (i, r.get("file"), r.get("report"), r["status"])  # scans finish in any order: position and file
        if cache is not None and key in cache:
            sections.append(cache[key])
            continue
        section = _index_section(i, r, summary["options"])
        if cache is not None:
            cache[key] = section
        sections.append(section)
    write_page(Path(outdir) / INDEX_NAME, collection_page(summary, sections))


def _index_section(i, r, options):
    """One scan's section of the collection page (None for a failed scan)."""
    from shellrepair.report.html import report_json, scan_section

    if not repaired(r):
        return None
    rep = report_json(r["report"])
    pic = rep.get("picture")
    fig = None
    if pic:
        shots = rep.get("pictures") or {}
        fig = {"png": b"", "alt": pic["alt"], "width": pic["width"], "height": pic["height"],
               "camera": shots.get("overview"), "failed": [f["id"] for f in shots.get("failed", [])]}
    view = rep.get("view")
    return scan_section(rep, fig, image_src=pic["file"] if pic else None, options=options,
                        sha256=rep.get("input_sha256"), anchor=f"scan-{i}", level=2,
                        closeups=rep.get("pictures"), view_src=view["file"] if view else None)


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
           status_counts(summary))
    allrows = [head] + body + [tot]
    w = [max(len(str(r[j])) for r in allrows) for j in range(len(head))]

    def line(r):
        return "  ".join(str(c).ljust(w[j]) if j in (0, 7) else str(c).rjust(w[j])
                         for j, c in enumerate(r)).rstrip()

    out = [line(head), "  ".join("-" * x for x in w)] + [line(r) for r in body]
    out += ["  ".join("-" * x for x in w), line(tot)]
    errs = [r for r in summary["scans"] if not repaired(r)]
    if errs and errors:
        out.append("")
        out += [f"error: {r['file']}: {r['error']}" for r in errs]
    return "\n".join(out)
