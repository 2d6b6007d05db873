"""Command line: a thin layer over the library.

    shellrepair holes SCAN [--json] [--max-hole N] [--fill-borders] [--closed auto|yes|no]
    shellrepair repair SCAN [-o OUT] [--report R.json] [--order 1|2|3|flat|auto] [--smooth N]
                       [--max-hole N] [--fill-borders] [--method fair|seed] [--jobs N]
                       [--bridge auto|never|always] [--base auto|flat|faired]
                       [--leave-open ID,...] [--order-for ID=N,...] [--cap-flat ID,...] [--fill ID,...]
                       [--plan PLAN.json] [--html PAGE.html] [--gltf OUT.glb] [--up auto|AXIS|X,Y,Z]
    shellrepair batch DIR -o OUTDIR [--jobs N] [--scheduler ADDRESS] [--order 1|2|3|flat|auto] [--max-hole N]
                      [--fill-borders] [--bridge auto|never|always] [--base auto|flat|faired] [--json]
    shellrepair render MESH -o OUT.png [--size WxH] [--material M] [--highlight-filled] [--view AZ,EL]
                       [--look-at X,Y,Z] [--radius R] [--before MESH] [--unit mm|cm|m] [--age A]
                       [--up auto|AXIS|X,Y,Z] [--setting indoor|outdoor] [--gltf OUT.glb]

Bad input gives one line ``error: <file>: <what is wrong>`` on stderr and
exit status 2; no traceback, no output file. ``batch`` goes on past a bad
scan, lists it in the summary and exits 2 at the end.

Every subcommand takes ``-q/--quiet``: no progress bar, and nothing on
stdout but the JSON that ``--json`` asks for; errors and warnings still go
to stderr, one line each, and the exit status is the same. Without it, the
progress bars are drawn on stderr when it is a terminal: this module is the
only place that draws them (the library reports to a callback, see
:mod:`shellrepair.progress`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import re
import sys
import time
from pathlib import Path

from shellrepair.errors import MeshError
from shellrepair.progress import end_line, terminal_bar

__all__ = ["main", "parse_args", "build_parser", "signed_values", "quiet_hugepages"]


def quiet_hugepages():
    """Stop NumPy advising the kernel to back large arrays with huge pages.

    Where transparent huge pages are in ``madvise`` mode (Ubuntu's default,
    and the machine our benchmarks run on) the first touch of each advised
    array can wait for the kernel to compact memory (BENCHMARKS.md, the
    ``fill-j1-hp`` rows of the scale benchmark: a fifth to a quarter of a
    large repair's time on our machine). The command line
    turns the advice off for its own process; a script can set
    ``NUMPY_MADVISE_HUGEPAGE=0`` before importing NumPy. Harmless where
    the private NumPy switch is missing.
    """
    try:
        from numpy._core.multiarray import _set_madvise_hugepage
    except ImportError:  # older or newer NumPy: leave it
        return
    _set_madvise_hugepage(False)


def build_parser():
    """The command line's argument parser.

    Returns
    -------
    argparse.ArgumentParser
        The ``shellrepair`` parser with its commands (holes, repair, batch,
        render) and their options.
    """
    from shellrepair import __version__

    p = argparse.ArgumentParser(prog="shellrepair", description="Fill the holes of 3D scans with smooth shells.")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors (default: one line)")
    p.add_argument("--version", action="version", version=f"shellrepair {__version__}")
    sub = p.add_subparsers(dest="cmd", required=True)

    h = sub.add_parser("holes", help="list the boundary loops of a scan, classed hole or border")
    h.add_argument("scan", help="the scan: PLY, OBJ, OFF or STL")
    h.add_argument("--json", action="store_true", help="print JSON instead of a table (default: the table)")
    _hole_options(h)
    _quiet(h)

    r = sub.add_parser("repair", help="fill the holes and write the repaired scan and a report")
    r.add_argument("scan", help="the scan: PLY, OBJ, OFF or STL (never modified)")
    r.add_argument("-o", "--output", help="output mesh (default: SCAN.repaired.ply)")
    r.add_argument("--report", help="JSON report (default: beside the output, .report.json)")
    _repair_options(r)
    r.add_argument("--leave-open", type=_ids, default=(), metavar="ID,...",
                   help="hole ids (as `shellrepair holes` lists them) to leave open on purpose (default: none)")
    r.add_argument("--order-for", type=_id_orders, default={}, metavar="ID=N,...",
                   help="a fairing order (1, 2, 3, flat or auto) for single holes, over --order (default: none)")
    r.add_argument("--cap-flat", type=_ids, default=(), metavar="ID,...",
                   help="hole ids to cap on their own with the harmonic patch (order 1: flat where the rim is "
                        "planar, a cut you know is flat), never bridged to another loop (default: none)")
    r.add_argument("--fill", type=_ids, default=(), metavar="ID,...",
                   help="loop ids to fill although they are classed border (an open base, an outer edge, "
                        "a loop over --max-hole) (default: none)")
    r.add_argument("--plan", metavar="PLAN.json", default=None,
                   help="per-hole requests from a file: the lists leave_open, cap_flat, fill and the map "
                        "order_for, or `shellrepair holes --json` with an \"action\" added to loops "
                        "(leave open, cap flat, fill, order N); added to the options above (default: none)")
    r.add_argument("--json", action="store_true", help="print the JSON report instead of the table (default: the table)")
    r.add_argument("--html", metavar="PAGE.html", default=None,
                   help="also write a self-contained HTML page: Table 1, a before | after picture, a close-up "
                        "of each filled region (the 24 largest) and of each hole that could not be filled, the "
                        "holes, provenance (default: none)")
    r.add_argument("--gltf", metavar="OUT.glb", default=None,
                   help="also write the repaired mesh with its aged look as binary glTF 2.0: the scan and "
                        "the filled part as two meshes, metallic-roughness materials (default: none)")
    r.add_argument("--up", default="auto", type=_up_arg, metavar="auto|AXIS|X,Y,Z",
                   help="world up axis of the scan, for the pictures of --html and the aged look of --gltf: "
                        "x, y, z, -x, -y, -z or a vector; auto (default): inferred from the scan (a planar "
                        "base's normal, else an axis 1.5 times longer than the others, else y), said in the "
                        "report")
    _hole_options(r)
    _quiet(r)

    b = sub.add_parser(
        "batch", help="repair every scan of a folder; a report per scan and a summary table",
        description="Repair every *.ply, *.obj, *.off and *.stl file directly in DIR (sorted by name). "
                    "Writes OUTDIR/<stem>.repaired.ply and OUTDIR/<stem>.report.json per scan and "
                    "OUTDIR/summary.json, and prints a table: holes before / after and rate per scan. "
                    "A scan that fails is reported (status error, one line) and the others go on.",
        epilog="exit status: 0 when every scan was repaired, 2 when any scan failed (or DIR / OUTDIR "
               "cannot be used, or the scheduler cannot be reached).",
        conflict_handler="resolve")  # --jobs below replaces the repair's
    b.add_argument("dir", metavar="DIR", help="folder of scans (not searched recursively)")
    b.add_argument("-o", "--outdir", metavar="OUTDIR", required=True,
                   help="output folder, created if missing (its parent must exist)")
    _repair_options(b)
    from shellrepair.batch import default_jobs

    b.add_argument("--jobs", type=int, default=default_jobs(), metavar="N",
                   help="cores to use: N scans at once in local worker processes (with Dask, "
                        "shellrepair[cluster]), else one scan on N cores; the same output for any N "
                        f"(default: the cores there are, {default_jobs()})")
    b.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="run one task per scan on an existing Dask cluster (tcp://host:8786; --jobs is then "
                        "not used); its workers must import shellrepair and see DIR and OUTDIR at the same "
                        "paths (default: local processes)")
    b.add_argument("--json", action="store_true", help="print the JSON summary instead of the table (default: the table)")
    b.add_argument("--no-html", dest="html", action="store_false",
                   help="do not write OUTDIR/index.html and the pictures beside it (default: write them)")
    _hole_options(b)
    _quiet(b)

    v = sub.add_parser("render", help="render a mesh with the aged-metal shading")
    v.add_argument("mesh", help="the mesh to render (a repaired PLY shows its filled faces)")
    v.add_argument("-o", "--output", required=True,
                   help="the image: .png, .jpg or .tif, its format from the extension")
    v.add_argument("--size", default="1024x768", help="WIDTHxHEIGHT of each panel in pixels (default: 1024x768)")
    v.add_argument("--material", default="aged-bronze", choices=("aged-bronze", "gilt", "bronze"),
                   help="the material (default: aged-bronze)")
    v.add_argument("--highlight-filled", action="store_true",
                   help="tint the faces the repair synthesized and face the camera to them (default: off)")
    v.add_argument("--view", default=None,
                   help="AZ,EL in degrees about the up axis: azimuth 0 looks along -z (along -x when up is z), "
                        "elevation 90 looks down (default: 25,15, or facing the filled faces with "
                        "--highlight-filled)")
    v.add_argument("--look-at", default=None, metavar="X,Y,Z",
                   help="the point the camera looks at, in the mesh's units (default: the centre of the "
                        "meshes' bounding box)")
    v.add_argument("--radius", type=float, default=None, metavar="R",
                   help="frame the sphere of radius R about that point (default: the farthest vertex)")
    v.add_argument("--before", default=None,
                   help="also render this mesh (the scan as read) on the left, with one camera (default: none)")
    v.add_argument("--unit", choices=("mm", "cm", "m"), default=None,
                   help="length unit of the mesh (default: inferred from its size, said in the output); "
                        "sets the pixel footprint and so the reflectance model")
    v.add_argument("--age", type=_age, default=None, metavar="A",
                   help="aging in [0, 1]: 0 all gilt, 1 all corroded (default 0.5)")
    v.add_argument("--up", default="auto", type=_up_arg, metavar="auto|AXIS|X,Y,Z",
                   help="world up axis: camera up and where rain comes from; x, y, z, -x, -y, -z or a vector; "
                        "auto (default): the one the repair recorded (X.report.json beside X.repaired.ply), "
                        "else inferred from the --before scan, else from the mesh (see repair --up)")
    v.add_argument("--setting", default="indoor", choices=("indoor", "outdoor"),
                   help="what ages the statue: indoor, patina in recesses and gold on raised, touched areas; "
                        "outdoor, rain greening the washed faces and a dark crust on sheltered ones "
                        "(default: indoor)")
    v.add_argument("--gltf", metavar="OUT.glb", default=None,
                   help="also write the mesh with this look (material, age, up) as binary glTF 2.0 "
                        "(default: none)")
    _quiet(v)
    return p


def _quiet(p):
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress bar and nothing on stdout but what --json asks for; errors and warnings "
                        "still on stderr, exit status unchanged (default: off)")


def _up_arg(text):
    """--up: auto, an axis name or a vector (checked here, used as given)."""
    from shellrepair.report.upaxis import parse_up

    if text == "auto":
        return text
    try:
        parse_up(text)
    except MeshError:
        raise argparse.ArgumentTypeError(f"must be auto, an axis (x, y, z, -x, -y, -z) or a vector X,Y,Z, "
                                         f"not {text!r}") from None
    return text


def _age(text):
    try:
        a = float(text)
    except ValueError:
        a = float("nan")
    if not 0.0 <= a <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a number in [0, 1], not {text!r}")
    return a


def _order(text):
    from shellrepair.options import NAMED_ORDERS

    if text in NAMED_ORDERS:
        return text
    if text in ("1", "2", "3"):
        return int(text)
    raise argparse.ArgumentTypeError(f"must be 1, 2, 3, flat or auto, not {text!r}")


def _ids(text):
    try:
        ids = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        ids = None
    if not ids or any(i < 0 for i in ids):
        raise argparse.ArgumentTypeError(f"must be hole ids separated by commas, such as 3,7, not {text!r}")
    return tuple(ids)


def _max_hole(text):
    """--max-hole: a whole number of edges, or a length with its unit (value, unit)."""
    from shellrepair.mesh.units import parse_length

    try:
        n = int(text)
    except ValueError:
        try:
            return parse_length(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a number of edges (such as 200) or a length with its "
                                             f"unit (such as 20mm), not {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1 edge, not {text!r}")
    return n


def _hole_limits(args):
    """--max-hole as RepairOptions takes it: max_hole (edges) and max_hole_size (a length)."""
    m = args.max_hole
    return dict(max_hole=m if isinstance(m, int) else None, max_hole_size=m if isinstance(m, tuple) else None,
                unit=args.unit)


def _id_orders(text):
    out = {}
    for item in text.split(","):
        hid, _, o = item.partition("=")
        try:
            out[int(hid)] = _order(o.strip())
        except (ValueError, argparse.ArgumentTypeError):
            raise argparse.ArgumentTypeError(f"must be ID=ORDER pairs separated by commas, such as 3=1,7=auto "
                                             f"(ORDER 1, 2, 3, flat or auto), not {text!r}") from None
    return out


def _repair_options(p):
    p.add_argument("--order", type=_order, default="auto", metavar="{1,2,3,flat,auto}",
                   help="fairing order: 1 harmonic, 2 bilaplacian, 3 curvature-continuous, flat: the rim's "
                        "triangulation with no new vertex; auto (default): per hole, the order whose fills of "
                        "test holes of the hole's size, cut into the scan beside it, lie closest to the scan "
                        "cut away")
    p.add_argument("--smooth", type=int, default=0, help="non-shrinking smoothing passes of each patch (default: 0)")
    p.add_argument("--method", choices=("fair", "seed"), default="fair",
                   help="fair: local faired shells (default); seed: the paper's smoothed-copy method")
    from shellrepair.batch import default_jobs

    p.add_argument("--jobs", type=int, default=default_jobs(), metavar="N",
                   help=f"fill holes on N processes (one run of holes: a helper thread), same output for any N "
                        f"(default: the cores there are, {default_jobs()})")
    p.add_argument("--bridge", choices=("auto", "never", "always"), default="auto",
                   help="two facing loops bounding a missing band: tube or caps (default auto: lower energy)")
    p.add_argument("--base", choices=("auto", "flat", "faired"), default="auto",
                   help="a planar opening the scan's walls stand across (an unscanned base, or a cut): "
                        "flat cap, faired fill continuing the walls, or auto (default): flat where the scan "
                        "turns into the opening along most of its rim")


def _hole_options(p):
    p.add_argument("--max-hole", type=_max_hole, default=None, metavar="N|LENGTH",
                   help="loops with more edges than N, or wider than LENGTH (20mm, 2cm, 0.02m: the rim's "
                        "diameter), are left open as borders (default: no limit)")
    p.add_argument("--unit", choices=("mm", "cm", "m"), default=None,
                   help="the scan's length unit, for --max-hole LENGTH (default: inferred from its size, "
                        "said in the report)")
    p.add_argument("--fill-borders", action="store_true", help="treat borders (outer edges) as holes too (default: off)")
    p.add_argument("--closed", choices=("auto", "yes", "no"), default="auto",
                   help="how to read each piece: auto (default) from its normals, yes: part of a closed "
                        "object (every loop a hole, its base included), no: a single view (its outer rim "
                        "a border)")


#: Options whose value may start with a minus sign (``--view -46,12``), which
#: argparse would take for an option of its own.
_SIGNED = ("--view", "--look-at", "--up")


def signed_values(argv):
    """``--view -46,12`` as ``--view=-46,12``: argparse reads a value that
    starts with ``-`` (and is not one plain number) as an option.

    Parameters
    ----------
    argv : list of str
        The command line's words (without the program name).

    Returns
    -------
    list of str
        The same words, each value of a signed option joined to its option.
    """
    out, i = [], 0
    while i < len(argv):
        a = argv[i]
        if a in _SIGNED and i + 1 < len(argv) and re.match(r"^-([\d.]|[xyz]$)", argv[i + 1]):
            out.append(f"{a}={argv[i + 1]}")
            i += 2
        else:
            out.append(a)
            i += 1
    return out


def parse_args(argv):
    """The command line's arguments, read as :func:`main` reads them.

    Parameters
    ----------
    argv : list of str
        The command line's words (without the program name).

    Returns
    -------
    argparse.Namespace
        The command (``cmd``) and its options.
    """
    return build_parser().parse_args(signed_values(list(argv)))


def main(argv=None):
    """Run the command line; returns the exit status."""
    args = parse_args(sys.argv[1:] if argv is None else argv)
    quiet_hugepages()
    bar = terminal_bar(args.quiet)  # the one progress bar of this command (None: nothing drawn)
    try:
        return {"holes": _holes, "repair": _repair, "batch": _batch, "render": _render}[args.cmd](args, bar)
    except MeshError as exc:
        end_line(bar)  # a bar left open by the interrupted work
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        end_line(bar)
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except MemoryError:
        end_line(bar)
        print(f"error: {getattr(args, 'scan', None) or getattr(args, 'mesh', None) or getattr(args, 'dir', '')}: "
              "out of memory",
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        end_line(bar)
        print("error: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # an internal bug: still one line unless --debug
        end_line(bar)
        if args.debug:
            raise
        print(f"error: internal error: {type(exc).__name__}: {exc} (run with --debug for a traceback)",
              file=sys.stderr)
        return 1


def _options(args):
    """The repair options of the command line, checked once
    (:class:`shellrepair.options.RepairOptions`)."""
    from shellrepair.options import RepairOptions

    plan = {"leave_open": [], "cap_flat": [], "fill": [], "order_for": {}, "expect": {}}
    if getattr(args, "plan", None):
        from shellrepair.plan import read_plan

        plan = read_plan(args.plan)
    try:
        return RepairOptions(order=args.order, smooth=args.smooth, **_hole_limits(args),
                             fill_borders=args.fill_borders, method=args.method, jobs=args.jobs,
                             bridge=args.bridge, closed=_closed(args), base=args.base,
                             leave_open=plan["leave_open"] + list(getattr(args, "leave_open", ())),
                             order_for={**plan["order_for"], **getattr(args, "order_for", {})},
                             cap_flat=plan["cap_flat"] + list(getattr(args, "cap_flat", ())),
                             fill=plan["fill"] + list(getattr(args, "fill", ())), expect=plan["expect"])
    except MeshError as exc:   # named as the command line names it: --max-hole, not max_hole
        raise MeshError(_as_flag(str(exc))) from None


#: RepairOptions' names that the command line spells otherwise.
_FLAGS = {"max_hole_size": "--max-hole", "expect": "--plan"}


def _as_flag(message):
    """A RepairOptions message with its option named as the command line names it."""
    m = re.match(r"^(\w+) must ", message)
    if m is None:
        return message
    name = m.group(1)
    return _FLAGS.get(name, "--" + name.replace("_", "-")) + message[len(name):]


@contextlib.contextmanager
def _for_flag(flag):
    """A :class:`MeshError` raised inside names the command-line flag it
    concerns: ``<file>: <flag>: <what is wrong>``."""
    try:
        yield
    except MeshError as exc:
        raise MeshError(f"{flag}: {exc.message}", exc.path) from None


def _closed(args):
    """--closed as detect_holes takes it."""
    return {"auto": None, "yes": True, "no": False}[args.closed]


def _holes(args, bar):
    from shellrepair.holes.loops import detect_holes
    from shellrepair.mesh.io import read_mesh
    from shellrepair.mesh.units import in_scan_units
    from shellrepair.options import RepairOptions
    from shellrepair.report.table import holes_dict, holes_table

    opts = RepairOptions(**_hole_limits(args), fill_borders=args.fill_borders, closed=_closed(args))  # checked first
    mesh = read_mesh(args.scan, progress=bar)
    max_size, size_label, _ = in_scan_units(opts.max_hole_size, opts.unit, mesh.V)
    topo, pieces, areas = mesh.cached("topology", "pieces", "face_areas")
    scan = detect_holes(mesh.V, mesh.F, max_hole=opts.max_hole, fill_borders=args.fill_borders,
                        closed=_closed(args), max_size=max_size, size_label=size_label,
                        topo=topo, pieces=pieces, areas=areas)
    end_line(bar)  # the loading bar's
    d = holes_dict(scan, path=args.scan, n_vertices=mesh.n_vertices, n_faces=mesh.n_faces, notes=mesh.notes)
    if args.json:
        print(json.dumps(d, indent=1))
    elif not args.quiet:
        print(holes_table(d))
    return 0


def _default_output(scan):
    p = Path(scan)
    return p.with_name(p.stem + ".repaired.ply")


def _same_file(a, b):
    """True when two paths name the same file (existing or not)."""
    a, b = Path(a), Path(b)
    try:
        if a.exists() and b.exists():
            return a.samefile(b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def _repair(args, bar):
    from shellrepair.mesh.io import (
        SUPPORTED,
        atomic_write_many,
        check_output_path,
        format_losses,
        mesh_bytes,
        read_mesh,
    )
    from shellrepair.preload import preload_fill
    from shellrepair.report.table import table1_text

    out = Path(args.output) if args.output else _default_output(args.scan)
    report_path = Path(args.report) if args.report else out.with_name(
        (out.stem[:-9] if out.stem.endswith(".repaired") else out.stem) + ".report.json")
    # every check that needs no reading happens before the work; each error names its flag
    with _for_flag("-o"):
        if out.suffix.lower() not in SUPPORTED:
            raise MeshError(f"unknown output extension '{out.suffix}' (expected one of {', '.join(SUPPORTED)})",
                            out)
        check_output_path(out, what="output")
        if _same_file(out, args.scan):
            raise MeshError("output would overwrite the input scan", out)
    with _for_flag("--report"):
        check_output_path(report_path, what="report")
        if _same_file(report_path, args.scan):
            raise MeshError("report would overwrite the input scan", report_path)
        if _same_file(out, report_path):
            raise MeshError("the report and the output mesh are the same file", out)
    page = Path(args.html) if args.html else None
    if page is not None:
        with _for_flag("--html"):
            check_output_path(page, what="page")
            if any(_same_file(page, p) for p in (args.scan, out, report_path)):
                raise MeshError("the page would overwrite the scan, the output or the report", page)
    with _for_flag("--gltf"):
        glb = _glb_path(args.gltf, (args.scan, out, report_path, page),
                        "the scan, the output, the report or the page")
    opts = _options(args)  # every check that needs no reading happens before the work
    t0 = time.perf_counter()
    preload_fill()    # the fill's modules and kernels load while the scan is read
    mesh = read_mesh(args.scan, progress=bar)
    from shellrepair.repair import repair_mesh

    repaired, report = repair_mesh(mesh, opts, progress=bar)
    report["file"] = str(args.scan)
    report["output"] = str(out)
    if args.plan:
        report["plan"] = str(args.plan)
    report["notes"] = list(mesh.notes) + format_losses(out, repaired)
    report["up"] = up = _scan_up(args.up, mesh)     # the one axis of every picture of this scan
    # what reading the scan kept for the repair and the up axis (its edge
    # topology: 0.5 GB at 10M faces) is not kept while the output is written
    mesh.forget()
    if bar is not None:
        bar(f"writing {out.name}", 0, 2)
    payload = mesh_bytes(out, repaired)
    if bar is not None:
        bar(f"writing {out.name}", 1, 2)
    html = None
    if page is not None:
        from shellrepair.report.closeups import closeups, pictures_record
        from shellrepair.report.html import figure, file_sha256, scan_page
        from shellrepair.report.webview import view_payload

        if bar is not None:
            bar("pictures", 0, 1)
        fig = figure(mesh, repaired, report, up=up["axis"])
        pics = closeups(mesh, repaired, report, up=up["axis"])
        report["pictures"] = pictures_record(fig, pics)
        html = scan_page(report, fig, options=opts.as_dict(), sha256=file_sha256(args.scan), closeups=pics,
                         view=view_payload(repaired, up=up["axis"]))
        if bar is not None:
            bar("pictures", 1, 1)
    report["seconds_total"] = round(time.perf_counter() - t0, 4)
    items = [(out, payload), (report_path, json.dumps(report, indent=1) + "\n")]
    if html is not None:
        items.append((page, html))
    if glb is not None:
        from shellrepair.appearance.gltf import gltf_bytes

        items.append((glb, gltf_bytes(repaired, up=up["axis"])))
    # mesh, report (and page, glTF) appear together or not at all
    atomic_write_many(items)
    if bar is not None:
        bar(f"writing {out.name}", 2, 2)
    end_line(bar)
    if args.json:
        print(json.dumps(report, indent=1))
    elif not args.quiet:
        print(table1_text(report))
        for n in report["notes"]:
            print(f"  note: {n}")
        if "pictures" in report:
            pr = report["pictures"]
            print(f"  up: {up['name']} ({up['how']})")
            print(f"  pictures: overview {pr['overview']}; {len(pr['regions'])} close-ups of "
                  f"{len(pr['regions']) + len(pr['more'])} filled regions"
                  + (f"; holes {', '.join(str(f['id']) for f in pr['failed'])} could not be filled (ringed)"
                     if pr["failed"] else ""))
        print(f"  wrote {out} and {report_path}" + (f" and {page}" if page is not None else "")
              + (f" and {glb}" if glb is not None else ""))
    return 0


def _recorded_up(mesh_path):
    """The up axis a repair recorded for the scan a repaired mesh came from:
    ``X.report.json`` beside ``X.repaired.ply`` (the repair's default names),
    or None."""
    p = Path(mesh_path)
    stem = p.stem[:-len(".repaired")] if p.stem.endswith(".repaired") else None
    if stem is None:
        return None
    try:
        with open(p.with_name(stem + ".report.json"), encoding="utf-8") as fh:
            rec = json.load(fh).get("up")
        axis = [float(x) for x in rec["axis"]]
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return None
    if len(axis) != 3 or not any(axis):
        return None
    return dict(rec, how=f"{rec.get('how', rec.get('rule', 'recorded'))}; read from {stem}.report.json")


def _triple(text, flag):
    """Three numbers X,Y,Z of a flag, or a one-line error naming it."""
    try:
        t = tuple(float(x) for x in text.split(","))
    except ValueError:
        t = ()
    if len(t) != 3 or not all(x == x and abs(x) != float("inf") for x in t):
        raise MeshError(f"{flag} must be three numbers X,Y,Z, got '{text}'")
    return t


def _glb_path(arg, others, what):
    """The ``--gltf`` output as a Path (None when not asked), checked before
    any work: a ``.glb`` name, a writable place, none of ``others``
    (paths, None for those not given)."""
    from shellrepair.mesh.io import check_output_path

    if not arg:
        return None
    glb = Path(arg)
    if glb.suffix.lower() != ".glb":
        raise MeshError("the glTF output must end in .glb (binary glTF)", glb)
    check_output_path(glb, what="glTF")
    if any(p is not None and _same_file(glb, p) for p in others):
        raise MeshError(f"the glTF file would overwrite {what}", glb)
    return glb


def _scan_up(arg, mesh):
    """The up axis record of ``--up`` for a scan: given, or inferred from it
    (:mod:`shellrepair.report.upaxis`)."""
    from shellrepair.report.upaxis import given_up, mesh_up

    return mesh_up(mesh) if arg == "auto" else given_up(arg)




def _batch(args, bar):
    from shellrepair.batch import repair_folder, repaired, summary_table

    def line(row):  # one line per finished scan, unless the JSON is wanted or -q
        if not args.json and not args.quiet:
            if bar is not None:
                bar.clear()  # the line starts at column 0, the bars go on below it
            what = (f"{row['holes_before']} -> {row['holes_after']} holes"
                    + (f", {row['holes_failed']} could not be closed" if row["status"] == "partial" else "")
                    if repaired(row) else f"error: {row['error']}")
            print(f"{row['file']}: {what} ({row['seconds']:.1f} s)", flush=True)

    from shellrepair.files import check_output_folder

    with _for_flag("-o"):   # before any work (repair_folder creates it)
        check_output_folder(args.outdir)
    summary = repair_folder(args.dir, args.outdir, _options(args), jobs=args.jobs, scheduler=args.scheduler,
                            on_scan=line, html=args.html, progress=bar or False)
    end_line(bar)
    if summary["runner"].get("note") and not args.quiet:
        print(f"note: {summary['runner']['note']}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary, indent=1))
    elif not args.quiet:
        print()
        print(summary_table(summary, errors=False))  # the errors go to stderr below
        print(f"  wrote {summary['n_ok'] + summary.get('n_partial', 0)} repaired scans with their reports, and "
              f"{Path(summary['outdir']) / 'summary.json'}"
              + (f" and {Path(summary['outdir']) / 'index.html'}" if args.html else ""))
    for r in summary["scans"]:
        if not repaired(r):  # also on stderr, one line each, as for a single scan
            print(f"error: {Path(args.dir) / r['file']}: {r['error']}", file=sys.stderr)
    return 0 if summary["n_failed"] == 0 else 2


def _render(args, bar):
    import numpy as np

    from shellrepair.appearance import render as rd
    from shellrepair.mesh.io import read_mesh

    try:
        w, h = (int(x) for x in args.size.lower().split("x"))
    except ValueError:
        raise MeshError(f"--size must be WIDTHxHEIGHT, got '{args.size}'") from None
    view = None
    if args.view:
        try:
            view = tuple(float(x) for x in args.view.split(","))
            assert len(view) == 2
        except (ValueError, AssertionError):
            raise MeshError(f"--view must be AZ,EL in degrees, got '{args.view}'") from None
    out = Path(args.output)
    from shellrepair.mesh.io import check_output_path

    with _for_flag("-o"):
        rd.image_format(out)  # an unknown image extension is refused before the work
        check_output_path(out, what="output")
        if _same_file(out, args.mesh) or (args.before and _same_file(out, args.before)):
            raise MeshError("output would overwrite an input mesh", out)
    target = _triple(args.look_at, "--look-at") if args.look_at else None
    if args.radius is not None and not (args.radius > 0 and args.radius < float("inf")):
        raise MeshError(f"--radius must be a positive length, got {args.radius:g}")
    with _for_flag("--gltf"):
        glb = _glb_path(args.gltf, (args.mesh, out, args.before), "an input mesh or the picture")
    mesh = read_mesh(args.mesh, progress=bar)
    end_line(bar)
    before = None
    if args.before:
        before = read_mesh(args.before, progress=bar)
        end_line(bar)
    if args.highlight_filled and (mesh.face_filled is None or not mesh.face_filled.any()):
        print(f"warning: {args.mesh}: no face is flagged filled, so --highlight-filled shows nothing "
              "(render the output of shellrepair repair)", file=sys.stderr)
    up_rec = _recorded_up(args.mesh) if args.up == "auto" else None
    if up_rec is None:
        up_rec = _scan_up(args.up, before if before is not None else mesh)
    up = tuple(up_rec["axis"])
    how = "given"
    if view is None and args.highlight_filled and mesh.face_filled is not None and mesh.face_filled.any():
        view = rd.view_towards(mesh.V, mesh.F, mesh.face_filled, up=up)  # face the filled region
        how = "picked to face the filled faces"
    if view is None:
        how = "the default" if how == "given" else "the default: the filled faces' normals cancel out"
        view = rd.DEFAULT_VIEW
    unit, unit_reason = (args.unit, "given") if args.unit else rd.infer_unit(mesh.V)
    kw = dict(size=(w, h), material=args.material, view=view, unit=unit, age=args.age, up=up,
              setting=args.setting)
    if target is not None or args.radius is not None:   # a close-up: the camera framed on the sphere given
        V = mesh.V if before is None else np.concatenate([before.V, mesh.V])
        kw["camera"] = rd.frame_camera(V, (w, h), view, up=up, center=target, radius=args.radius)
    info = {}
    if before is not None:  # one camera for both panels
        img = rd.render_side_by_side(before.V, before.F, mesh.V, mesh.F, filled=mesh.face_filled,
                                     highlight_filled=args.highlight_filled,
                                     vertex_colors_before=before.vertex_colors,
                                     vertex_colors_after=mesh.vertex_colors, info=info, **kw)
        info = info["after"]
    else:
        legend = ("filled by the repair" if args.highlight_filled and mesh.face_filled is not None
                  and mesh.face_filled.any() else None)
        img = rd.render_mesh(mesh.V, mesh.F, filled=mesh.face_filled, highlight_filled=args.highlight_filled,
                             vertex_colors=mesh.vertex_colors, legend=legend, info=info, **kw)
    rd.save_image(out, img)
    if glb is not None:
        from shellrepair.appearance.gltf import gltf_bytes
        from shellrepair.mesh.io import atomic_write

        atomic_write(glb, gltf_bytes(mesh, age=args.age, up=up, material=args.material))
    if args.quiet:
        return 0
    choice = info["model"]
    print(f"unit: {unit} ({unit_reason})")
    print(f"up: {up_rec['name']} ({up_rec['how']})")
    az, el = f"{float(view[0]):.10g}", f"{float(view[1]):.10g}"
    print(f"view: {az},{el} ({how}; --view {az},{el} renders the same camera again)")
    again = f"--up {up_rec['name']} --view {az},{el}"
    if target is not None:
        again += " --look-at " + ",".join(f"{x:.10g}" for x in target)
    if args.radius is not None:
        again += f" --radius {args.radius:.10g}"
    print(f"camera: {again}")
    print(f"pixel footprint {info['footprint_um']:.3g} um: {choice.model} model ({choice.reason})")
    print(f"wrote {out}" + (f" and {glb}" if glb is not None else ""))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
