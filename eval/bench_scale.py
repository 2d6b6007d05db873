"""Scale benchmark: time and peak memory of each step at ~1M, ~4M and ~10M faces.

Run ``make bench-scale`` (or ``.venv/bin/python eval/bench_scale.py [options]``).
It writes ``eval/results/bench_scale.json`` and ``eval/results/bench_scale.md``.

Cases
-----
A geodesic sphere of frequency ``n`` (each icosahedron face split into
``n²`` triangles, so ``20 n²`` faces: n = 224, 448, 708 give 1.00M, 4.01M
and 10.03M faces) with smooth radial relief (:func:`eval.shapes.bump_field`,
the bumpy sphere of the main benchmark), coordinates rounded to float32 as a
scan's PLY stores them, perforated by ``HOLES`` = 200 holes: the faces whose
centroid lies within a Euclidean ball around seeded surface points.
Radii are log-uniform in ``RADII`` (the same physical sizes at every
resolution, as a finer scan of the same statue has the same occlusions, so
holes have more rim edges at higher resolution); centres are kept
apart so no two holes merge. The case is written as a binary PLY.

Steps
-----
Each step runs in its own child process (``--child``), so one step's
memory does not hide the next one's, and a step that runs out of memory or
time is recorded as such and the rest go on:

* ``read``: :func:`shellrepair.mesh.io.read_mesh` of the PLY (parse, validate,
  clean, orient);
* ``detect``: :func:`shellrepair.holes.loops.detect_holes` on the arrays;
* ``fill-j1``, ``fill-j2``: :func:`shellrepair.repair.repair_mesh` with
  ``jobs`` 1 and 2 (includes its own detection, setup and merge);
* ``fill-j1-hp``: ``fill-j1`` with NumPy's default huge-page advice left
  on (every other step turns it off, as the command line does: see
  :func:`shellrepair.cli.quiet_hugepages`);
* ``write``: :func:`shellrepair.mesh.io.write_mesh` of the repaired mesh (binary PLY);
* ``cli``: the command line end to end, ``shellrepair repair scan.ply -o
  out.ply`` (read to write, with its defaults), in a fresh interpreter:
  ``seconds`` is the whole child process (start-up and imports included;
  the output's hash is taken by the parent afterwards), ``peak_rss_mb``
  its peak. Inside it, the whole-mesh steps are timed as
  they run: ``load`` (:func:`shellrepair.mesh.io.read_mesh`: parse, clean,
  topology, orientation, areas), ``topology`` (the
  :func:`shellrepair.mesh.topology.edge_topology` call within it), ``detection``
  (:func:`shellrepair.holes.loops.detect_holes`), ``merge`` (the patches appended
  to the scan) and ``write`` (the output's bytes built and written).
* ``cold`` (once, not per case): a user's first ``make repair`` after
  ``make setup`` against the second, on a fresh copy of the checkout set up
  by ``make setup`` (issue 14's "within 20 %"; :mod:`eval.cold_start` says
  what is fresh and what is reused; about 5-8 minutes, most of it the
  setup's compiling). ``--steps cold`` runs it alone.

Bandwidth ratio
---------------
Each whole-mesh step of ``cli`` is set against the time this machine takes
to touch the bytes the step must touch at the least, measured in the same
run (in the parent, after the step): ``np.copyto`` of ``bytes / 2`` into an
already touched buffer of ``bytes / 2`` (so ``bytes`` are read or written
in all), best of five. The bytes a step must touch:

* load: the file, read once, plus ``V`` and ``F`` written once
  (``24 n + 24 m``);
* topology: ``F`` read (``24 m``), the half-edges grouped by edge written
  (``he_order``, ``24 m``), the edges and their counts written (``24 e``);
* detection: ``F`` read once (``24 m``) and one 8-byte value per face read
  (the face's piece) and per vertex written (its component);
* merge: ``V`` and ``F`` copied into the output (read and written:
  ``2 (24 n' + 24 m')``, the output sizes) and one flag per vertex and face;
* write: ``V`` and ``F`` read (``24 n + 24 m``) and the output file written.

``ratio`` is ``step seconds / reference seconds``: 1 would be a step that
runs at memory speed.

Per step: ``seconds`` is the wall time of the call alone (not the
interpreter start or the loading of the step's input); ``peak_rss_mb`` is
the child's whole peak resident memory (``ru_maxrss`` from ``wait4``:
Python, the loaded input and the step; what the machine must have);
``step_mb`` is how much the step added above what was resident before it
(the kernel's ``VmHWM`` reset through ``/proc/self/clear_refs``);
``workers_peak_mb`` is the largest pool worker's peak (``jobs`` > 1;
forked, so shared pages count in both).

Peers
-----
On the smallest case (and on ``1M-large``, the same surface with 20
larger holes), ours (``repair_mesh``, order 2, one job), MeshLib's
``fillHoleNicely`` and CGAL's ``triangulate_refine_and_fair_hole`` run in
the same run through :mod:`eval.worker` (one child per tool, the same
timeout) and are measured against the unperforated surface with
:func:`eval.metrics.evaluate`. Ratios are peer seconds over ours (the fill
call; each tool's conversion from and to arrays excluded) and peer RMS over
ours.

The benchmark is not a test: it asserts nothing, records every failure
(``timeout``, ``out of memory``, ``crashed``) as a row, and exits 0 unless
it could not run at all.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

RESULTS = ROOT / "eval" / "results"
#: Case name -> geodesic frequency (20 n² faces).
SIZES = {"1M": 224, "4M": 448, "10M": 708}
#: Holes per case.
HOLES = 200
#: Hole radius range on the unit sphere (log-uniform): ~2-7 rim-edge radii
#: at 1M faces, ~6-24 at 10M.
RADII = (0.012, 0.04)
#: Relief of the surface (see shapes.bumpy_sphere).
AMPLITUDE, FREQUENCY = 0.03, 6
SEED = 7
#: Default per-step timeout (seconds) and per-peer timeout.
STEP_TIMEOUT = 420.0
PEER_TIMEOUT = 300.0
#: Tools compared on the smallest case.
COMPARE = ("ours-auto", "ours-o2", "meshlib-nicely", "cgal")
#: A second peer case: the 1M surface with fewer, larger holes (about
#: 15-37 rim edges in radius, loops of 100-230 edges), closer to a scan's
#: occlusions than the 200 small ones; not one of the issue's targets.
LARGE_CASE, LARGE_HOLES, LARGE_RADII = "1M-large", 20, (0.08, 0.2)
MB = 1024.0


# --------------------------------------------------------------------------
# cases
# --------------------------------------------------------------------------
def geodesic_sphere(freq):
    """Unit geodesic sphere: each icosahedron face split into ``freq²`` triangles.

    Parameters
    ----------
    freq : int
        Frequency ``n`` >= 1.

    Returns
    -------
    V : (10 n² + 2, 3) float64
        Unit vectors.
    F : (20 n², 3) int64
        Outward-wound triangles.

    Notes
    -----
    Lattice points ``(k A + i B + j C) / n`` (``i + j + k = n``) of every
    icosahedron face; a point on an edge shared by two faces has a zero
    weight, so both faces compute it bit for bit alike and welding on exact
    coordinates joins them. Projected onto the sphere after welding.
    """
    from eval import shapes

    n = int(freq)
    if n < 1:
        raise ValueError(f"freq must be at least 1, got {freq}")
    V0, F0 = shapes.icosphere(0)
    I, J = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = I + J <= n
    I, J = I[keep], J[keep]
    K = n - I - J
    loc = np.full((n + 1, n + 1), -1, np.int64)
    loc[I, J] = np.arange(I.size)
    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up = a + b <= n - 1
    dn = a + b <= n - 2
    T = np.vstack([np.column_stack([loc[a[up], b[up]], loc[a[up] + 1, b[up]], loc[a[up], b[up] + 1]]),
                   np.column_stack([loc[a[dn] + 1, b[dn]], loc[a[dn] + 1, b[dn] + 1], loc[a[dn], b[dn] + 1]])])
    A, B, C = V0[F0[:, 0]], V0[F0[:, 1]], V0[F0[:, 2]]
    P = (K[None, :, None] * A[:, None] + I[None, :, None] * B[:, None] + J[None, :, None] * C[:, None]).reshape(-1, 3)
    U, inv = np.unique(P, axis=0, return_inverse=True)
    del P
    inv = inv.ravel()
    F = inv[(np.arange(len(F0))[:, None, None] * I.size + T[None]).reshape(-1, 3)]
    return U / np.linalg.norm(U, axis=1, keepdims=True), F.astype(np.int64)


def ball_centres(V, n_holes, radii, seed):
    """``n_holes`` seeded vertex positions and radii, balls kept apart.

    Two centres are at least ``2.5 (r1 + r2)`` apart, so the holes never
    merge and each has a ring of scan around it."""
    rng = np.random.default_rng(seed)
    lo, hi = np.log(radii[0]), np.log(radii[1])
    cs, rs = [], []
    for _ in range(200 * n_holes):
        if len(cs) == n_holes:
            break
        c = V[int(rng.integers(len(V)))]
        r = float(np.exp(rng.uniform(lo, hi)))
        if cs and (np.linalg.norm(np.asarray(cs) - c, axis=1) < 2.5 * (np.asarray(rs) + r)).any():
            continue
        cs.append(c)
        rs.append(r)
    return np.asarray(cs), np.asarray(rs)


def make_case(freq, n_holes=HOLES, seed=SEED, radii=None):
    """The bumpy, perforated geodesic sphere of one size.

    Returns
    -------
    V_true, F_true : the closed surface (float32-exact coordinates)
    V, F : the perforated mesh (vertices no face uses removed)
    removed : (m,) bool
    centres, radii : the balls
    """
    from scipy.spatial import cKDTree

    from eval import shapes

    U, F = geodesic_sphere(freq)
    r = 1.0 + AMPLITUDE * shapes.bump_field(U, FREQUENCY, seed=0)
    V = (U * r[:, None]).astype(np.float32).astype(np.float64)
    del U, r
    cs, rs = ball_centres(V, n_holes, RADII if radii is None else radii, seed)
    C = (V[F[:, 0]] + V[F[:, 1]] + V[F[:, 2]]) / 3.0
    d, j = cKDTree(cs).query(C, k=1)
    del C
    removed = d < rs[j]
    V2, F2, _ = shapes.remove_faces(V, F, removed)
    return V, F, V2, F2, removed, cs, rs


def build_cases(names, tmp, *, truth=False, log=print):
    """Write each case's PLY (and the arrays the steps load) into ``tmp``;
    with ``truth``, also the closed surface (for the peer comparison)."""
    from shellrepair.mesh.io import Mesh, write_mesh

    out = {}
    for name in names:
        t0 = time.perf_counter()
        if name == LARGE_CASE:
            Vt, Ft, V, F, removed, cs, rs = make_case(SIZES["1M"], n_holes=LARGE_HOLES, radii=LARGE_RADII)
        else:
            Vt, Ft, V, F, removed, cs, rs = make_case(SIZES[name])
        d = Path(tmp) / name
        d.mkdir(parents=True, exist_ok=True)
        write_mesh(d / "scan.ply", Mesh(V=V, F=F, vertex_dtype="f4"))
        np.save(d / "V.npy", V)
        np.save(d / "F.npy", F)
        if truth:
            np.savez(d / "truth.npz", V=Vt, F=Ft, removed=removed)
        info = {"name": name, "frequency": SIZES.get(name, SIZES["1M"]), "faces_true": int(len(Ft)),
                "vertices": int(len(V)), "faces": int(len(F)), "faces_removed": int(removed.sum()),
                "holes_cut": int(len(cs)), "hole_radius_range": [float(rs.min()), float(rs.max())],
                "mean_edge": float(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()),
                "ply_mb": round((d / "scan.ply").stat().st_size / MB ** 2, 1),
                "build_seconds": round(time.perf_counter() - t0, 2), "dir": str(d)}
        out[name] = info
        log(f"case {name}: {info['faces']:,} faces, {info['vertices']:,} vertices, {len(cs)} holes cut, "
            f"PLY {info['ply_mb']} MB, built in {info['build_seconds']:.1f} s")
        del Vt, Ft, V, F, removed
    return out


# --------------------------------------------------------------------------
# one step, in a child process
# --------------------------------------------------------------------------
from eval.worker import _release_free_memory, _status_kb  # noqa: E402


def _reset_peak():
    """Hand freed heap back and reset VmHWM; True when the reset worked."""
    _release_free_memory()
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def _load_arrays(d):
    from shellrepair.mesh.io import Mesh

    return Mesh(V=np.load(d / "V.npy"), F=np.load(d / "F.npy"), vertex_dtype="f4", path=str(d / "scan.ply"))


def run_child(step, case_dir, out_json, profile=None):
    """Body of ``--child``: load the step's input, run it, write the result JSON."""
    import resource

    from shellrepair.cli import quiet_hugepages
    from shellrepair.mesh.io import Mesh

    res = {"step": step}
    if step.endswith("-hp"):  # NumPy's default: large arrays advised for huge pages
        step = step[:-3]
    else:
        quiet_hugepages()  # as the command line does

    d = Path(case_dir)
    if step == "cli":
        Path(out_json).write_text(json.dumps(_run_cli_step(d)))
        return
    if step == "read":
        pass
    elif step == "detect":
        mesh = _load_arrays(d)
    elif step.startswith("fill"):
        mesh = _load_arrays(d)
    elif step == "write":
        z = np.load(d / "repaired.npz")
        rep = Mesh(V=z["V"], F=z["F"], vertex_filled=z["vf"], face_filled=z["ff"], vertex_dtype="f4")
        del z
    else:
        raise ValueError(f"unknown step {step}")
    reset = _reset_peak()
    rss0 = _status_kb("VmRSS") or 0
    prof = None
    if profile:
        import cProfile

        prof = cProfile.Profile()
        prof.enable()
    t0 = time.perf_counter()
    if step == "read":
        from shellrepair.mesh.io import read_mesh

        m = read_mesh(d / "scan.ply")
        secs = time.perf_counter() - t0
        res.update(vertices=m.n_vertices, faces=m.n_faces, notes=m.notes)
    elif step == "detect":
        from shellrepair.holes.loops import detect_holes

        scan = detect_holes(mesh.V, mesh.F)
        secs = time.perf_counter() - t0
        res.update(loops=len(scan.loops), holes=len(scan.holes), borders=len(scan.borders))
    elif step.startswith("fill"):
        from shellrepair.repair import repair_mesh

        jobs = int(step.split("-j")[1])
        rep, report = repair_mesh(mesh, jobs=jobs)
        secs = time.perf_counter() - t0
        res.update(holes_before=report["holes_before"], holes_after=report["holes_after"],
                   rate=report["interpolation_rate"], faces_after=report["faces_after"],
                   failed=[f"{h['id']}: {h['reason']}" for h in report["holes"] if h["status"] != "filled"][:10])
        if jobs > 1:
            # pool workers are waited for, so their peak is in RUSAGE_CHILDREN
            res["workers_peak_mb"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / MB
        # the output of every jobs count, for the identity check
        import hashlib

        h = hashlib.sha256()
        for a in (rep.V, rep.F, rep.vertex_filled, rep.face_filled):
            h.update(np.ascontiguousarray(a).tobytes())
        res["output_sha256"] = h.hexdigest()[:16]
    elif step == "write":
        from shellrepair.mesh.io import write_mesh

        write_mesh(d / "repaired.ply", rep)
        secs = time.perf_counter() - t0
        res["ply_mb"] = round((d / "repaired.ply").stat().st_size / MB ** 2, 1)
    res["seconds"] = secs
    if prof is not None:
        prof.disable()
        res["profile"] = _profile_rows(prof)
    hwm = _status_kb("VmHWM")
    if reset and hwm is not None:
        res["step_mb"] = max(0.0, (hwm - rss0) / MB)
    if step == "fill-j1":  # the write step's input (after the measurement)
        np.savez(d / "repaired.npz", V=rep.V, F=rep.F, vf=rep.vertex_filled, ff=rep.face_filled)
    res["rss_before_mb"] = rss0 / MB
    Path(out_json).write_text(json.dumps(res))


def _run_cli_step(d):
    """``shellrepair repair`` on the case's scan, in this (fresh) process,
    with the whole-mesh steps timed as they run and their sizes recorded."""
    import functools

    from shellrepair import cli, repair
    from shellrepair.holes import loops as holes
    from shellrepair.mesh import io
    from shellrepair.mesh import topology

    steps = {}
    depth = {"topology": 0}

    def timed(mod, name, label, sizes=None):
        f = getattr(mod, name, None)
        if f is None:   # moved by a refactoring: that step goes unreported (the run still counts)
            return None

        @functools.wraps(f)
        def g(*a, **k):
            t = time.perf_counter()
            out = f(*a, **k)
            dt = time.perf_counter() - t
            row = steps.setdefault(label, {"seconds": 0.0, "calls": 0})
            row["seconds"] += dt
            row["calls"] += 1
            if sizes is not None:
                row.update(sizes(a, k, out))
            return out
        setattr(mod, name, g)
        return f

    def first_topology(f):
        @functools.wraps(f)
        def g(F, *a, **k):       # the whole mesh's topology: the call inside read_mesh
            if depth["topology"]:
                return f(F, *a, **k)
            depth["topology"] = 1
            t = time.perf_counter()
            out = f(F, *a, **k)
            steps["topology"] = {"seconds": time.perf_counter() - t, "calls": 1, "faces": int(len(F)),
                                 "edges": int(len(out.edges))}
            return out
        return g

    timed(io, "read_mesh", "load", lambda a, k, m: {"faces": m.n_faces, "vertices": m.n_vertices,
                                                     "file_bytes": Path(a[0]).stat().st_size})
    topology.edge_topology = first_topology(topology.edge_topology)
    io.edge_topology = topology.edge_topology   # read_mesh's own name for it
    # the names repair_mesh calls them by, in the module it calls them from
    timed(repair, "detect_holes", "detection", lambda a, k, scan: {"faces": int(len(a[1])),
                                                                     "vertices": int(len(a[0]))})
    timed(repair, "_merge", "merge", lambda a, k, m: {"faces": m.n_faces, "vertices": m.n_vertices})
    timed(io, "mesh_bytes", "write", lambda a, k, b: {"faces": int(len(a[1].F)), "vertices": int(len(a[1].V)),
                                                       "file_bytes": len(b)})
    timed(io, "atomic_write_many", "write")
    out = d / "cli_out.ply"
    t0 = time.perf_counter()
    rc = cli.main(["repair", str(d / "scan.ply"), "-o", str(out), "--report", str(d / "cli_out.report.json")])
    secs = time.perf_counter() - t0
    # the output's hash and the report are read by the parent, after this
    # process has ended: the child's time is the command line's alone
    return {"step": "cli", "exit_code": rc, "main_seconds": secs, "whole_mesh": steps}


def _cli_outputs(d):
    """What the ``cli`` step wrote: holes before and after (its report), the
    output's hash and size."""
    import hashlib

    out = Path(d) / "cli_out.ply"
    h = hashlib.sha256()
    with open(out, "rb") as fh:
        for blk in iter(lambda: fh.read(1 << 24), b""):
            h.update(blk)
    rep = json.loads((Path(d) / "cli_out.report.json").read_text())
    return {"holes_before": rep.get("holes_before"), "holes_after": rep.get("holes_after"),
            "output_sha256": h.hexdigest()[:16], "ply_mb": round(out.stat().st_size / MB ** 2, 1)}


def step_bytes(name, row):
    """The bytes a whole-mesh step must touch at the least (the module docstring)."""
    n, m = row.get("vertices", 0), row.get("faces", 0)
    if name == "load":
        return row.get("file_bytes", 0) + 24 * n + 24 * m
    if name == "topology":
        return 24 * m + 24 * m + 24 * row.get("edges", 0)
    if name == "detection":
        return 24 * m + 8 * m + 8 * n
    if name == "merge":
        return 2 * (24 * n + 24 * m) + n + m
    if name == "write":
        return 24 * n + 24 * m + row.get("file_bytes", 0)
    return 0


def touch_seconds(nbytes, repeat=5):
    """Best time of ``np.copyto`` of ``nbytes / 2`` bytes between two
    buffers already touched: the time to read or write ``nbytes`` here."""
    half = max(int(nbytes) // 2 // 8, 1)
    a = np.ones(half, np.int64)
    b = np.zeros(half, np.int64)
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        np.copyto(b, a)
        best = min(best, time.perf_counter() - t)
    return best


def bandwidth_rows(row):
    """Per whole-mesh step of a ``cli`` result: seconds, bytes, reference seconds, ratio."""
    out = []
    for name in ("load", "topology", "detection", "merge", "write"):
        st = row.get("whole_mesh", {}).get(name)
        if not st:
            continue
        nb = step_bytes(name, st)
        ref = touch_seconds(nb) if nb else None
        out.append({"step": name, "seconds": round(st["seconds"], 3), "bytes": int(nb),
                    "touch_seconds": round(ref, 4) if ref else None,
                    "gb_per_s": round(nb / ref / 1e9, 2) if ref else None,
                    "ratio": round(st["seconds"] / ref, 1) if ref else None})
    return out


def _profile_rows(prof, n=25):
    """The top functions by own time and by cumulative time."""
    import pstats

    st = pstats.Stats(prof)
    rows = []
    for (fn, line, name), (cc, nc, tt, ct, _) in st.stats.items():
        where = fn.replace(str(ROOT) + "/", "")
        if "site-packages/" in where:
            where = where.split("site-packages/", 1)[1]
        rows.append({"function": f"{where}:{line}({name})", "calls": nc, "tottime": round(tt, 3),
                     "cumtime": round(ct, 3)})
    own = sorted(rows, key=lambda r: -r["tottime"])[:n]
    cum = sorted(rows, key=lambda r: -r["cumtime"])[:n]
    return {"by_tottime": own, "by_cumtime": cum}


def run_step(step, case_dir, timeout, *, profile=False, log=print):
    """Run one step in a fresh interpreter; time it, take its peak, honour the timeout."""
    out_json = Path(case_dir) / f"{step}.result.json"
    if out_json.exists():
        out_json.unlink()
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", step, "--case-dir", str(case_dir),
           "--child-out", str(out_json)] + (["--profile"] if profile else [])
    errf = tempfile.TemporaryFile()
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=errf, start_new_session=True)
    status, ru = None, None
    while True:
        pid, st, ru = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            status = st
            break
        if time.perf_counter() - t0 > timeout:
            os.killpg(proc.pid, signal.SIGKILL)  # the child and its pool workers
            _, status, ru = os.wait4(proc.pid, 0)
            proc.returncode = -9
            errf.close()
            return {"step": step, "status": "timeout", "error": f"no result within {timeout:g} s",
                    "wall_seconds": round(time.perf_counter() - t0, 1),
                    "peak_rss_mb": ru.ru_maxrss / MB}
        time.sleep(0.05)
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    errf.seek(0)
    err = errf.read().decode("utf-8", "replace").strip().splitlines()
    errf.close()
    row = {"step": step, "wall_seconds": round(wall, 2), "peak_rss_mb": round(ru.ru_maxrss / MB, 1)}
    if proc.returncode == 0 and out_json.exists():
        row.update(json.loads(out_json.read_text()))
        row["status"] = "ok"
    elif proc.returncode in (-9, 137) or any("MemoryError" in ln for ln in err):
        row.update(status="out of memory" if proc.returncode in (-9, 137) or err else "crashed",
                   error=(err[-1] if err else f"killed (exit {proc.returncode}), likely the out-of-memory killer"))
    else:
        row.update(status="failed", error=(err[-1] if err else f"exit code {proc.returncode}")[:300])
    return row


# --------------------------------------------------------------------------
# peers on the smallest case
# --------------------------------------------------------------------------
def compare_peers(case_dir, tools, timeout, *, n_samples=20000, log=print):
    """Ours and the peers on one case, measured against the true surface."""
    from eval import metrics, peers
    from eval.worker import ToolRunner
    from shellrepair.mesh.topology import face_areas

    d = Path(case_dir)
    V, F = np.load(d / "V.npy"), np.load(d / "F.npy")
    z = np.load(d / "truth.npz")
    Vt, Ft, removed = z["V"], z["F"], z["removed"]
    case_npz = d / "case.npz"
    np.savez(case_npz, V=V, F=F)
    t0 = time.perf_counter()
    truth = metrics.TruthSurface(Vt, Ft)
    facts = metrics.input_facts(V, F)
    removed_area = float(face_areas(Vt, Ft[removed]).sum())
    log(f"  truth and input facts in {time.perf_counter() - t0:.1f} s ({facts['loops']} holes)")
    rows = []
    for tool in tools:
        row = {"tool": tool}
        ok, why = peers.tool_available(tool)
        if not ok:
            row.update(status="missing", error=why)
            rows.append(row)
            log(f"  {tool:15s} missing: {why}")
            continue
        out_npz = d / f"{tool}.out.npz"
        with ToolRunner(tool, d, timeout=timeout) as runner:
            res = runner.run(case_npz, out_npz)
        row["status"] = res["status"]
        row["wall_seconds"] = res.get("wall_seconds")
        if res["status"] != "ok":
            row["error"] = res.get("error")
            rows.append(row)
            log(f"  {tool:15s} {res['status']}: {res.get('error')}")
            continue
        info = res["info"]
        row.update(seconds=float(info.get("seconds", res["wall_seconds"])),
                   convert_seconds=info.get("convert_seconds"), peak_mb=res.get("peak_mb"))
        out = np.load(out_npz)
        t1 = time.perf_counter()
        try:
            m = metrics.evaluate(V, F, out["V"], out["F"], truth, removed_area=removed_area,
                                 n_samples=n_samples, seed=0, facts=facts)
        except Exception as exc:  # an output the metrics cannot read is that tool's failure
            row.update(status="failed", error=f"output not measurable: {type(exc).__name__}: {exc}"[:300])
            rows.append(row)
            continue
        finally:
            os.unlink(out_npz)
        row["metrics_seconds"] = round(time.perf_counter() - t1, 1)
        row.update({k: m.get(k) for k in ("holes_before", "holes_after", "rate", "rms_permille", "max_permille",
                                          "normal_dev_deg", "watertight", "self_intersections_added",
                                          "faces_added", "orig_exact_pct")})
        rows.append(row)
        log(f"  {tool:15s} {row['seconds']:7.2f} s fill (+{row['convert_seconds'] or 0:.1f} s convert), "
            f"peak +{row['peak_mb'] or 0:.0f} MB, holes {m['holes_before']}->{m['holes_after']}, "
            f"rms {m['rms_permille']:.4f}‰, max {m['max_permille']:.3f}‰, si {m.get('self_intersections_added')}")
    os.unlink(case_npz)
    ref = next((r for r in rows if r["tool"] == "ours-auto" and r["status"] == "ok"), None)
    for r in rows:
        if ref and r["status"] == "ok" and r is not ref:
            r["seconds_x_ours"] = r["seconds"] / ref["seconds"] if ref["seconds"] > 0 else None
            both = lambda q: q["seconds"] + (q.get("convert_seconds") or 0.0)  # noqa: E731
            r["total_x_ours"] = both(r) / both(ref) if both(ref) > 0 else None
            r["rms_x_ours"] = (r["rms_permille"] / ref["rms_permille"]
                               if r.get("rms_permille") is not None and ref.get("rms_permille") else None)
    return rows


# --------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------
def _f(x, nd=1):
    if x is None:
        return "–"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, (int, np.integer)):
        return f"{int(x):,}"
    return f"{x:,.{nd}f}"


def markdown(result):
    mi = result["machine"]
    L = ["# shellrepair scale benchmark", "",
         f"Command: `{result['command']}`  ",
         f"Machine: {mi.get('cpu')}, {mi.get('nproc')} cores, {mi.get('memory_gb')} GB RAM, {mi.get('os')}, "
         f"Python {mi.get('python')}, commit {mi.get('commit')}, {mi.get('date')}  ",
         f"Total time {result['seconds']:.0f} s. How it is measured: `eval/bench_scale.py`'s docstring.", "",
         "## Cases", "",
         "| case | faces | vertices | holes cut | hole radius (× mean edge) | PLY MB | build s |",
         "|---|---:|---:|---:|---|---:|---:|"]
    for c in result["cases"].values():
        lo, hi = c["hole_radius_range"]
        L.append(f"| {c['name']} | {_f(c['faces'])} | {_f(c['vertices'])} | {c['holes_cut']} | "
                 f"{lo / c['mean_edge']:.1f}–{hi / c['mean_edge']:.1f} | {c['ply_mb']} | {c['build_seconds']:.1f} |")
    L += ["", "## Steps", "",
          "`seconds`: the call alone; `peak RSS`: the whole child process at its peak (what the machine "
          "needs); `step +MB`: added by the step above its loaded input; `workers`: largest pool worker.", "",
          "| case | step | status | seconds | peak RSS MB | step +MB | workers MB | result |",
          "|---|---|---|---:|---:|---:|---:|---|"]
    for r in result["steps"]:
        if r["status"] == "ok":
            if r["step"] == "read":
                what = f"{_f(r.get('faces'))} faces"
            elif r["step"] == "detect":
                what = f"{r.get('loops')} loops, {r.get('holes')} holes"
            elif r["step"].startswith("fill"):
                what = (f"holes {r.get('holes_before')} → {r.get('holes_after')} ({_f(r.get('rate'))} %), "
                        f"output {r.get('output_sha256')}")
            elif r["step"] == "cli":
                what = (f"holes {r.get('holes_before')} → {r.get('holes_after')}, {r.get('ply_mb')} MB written, "
                        f"output {r.get('output_sha256')}")
            else:
                what = f"{r.get('ply_mb')} MB"
        else:
            what = r.get("error", "")
        L.append(f"| {r['case']} | {r['step']} | {r['status']} | {_f(r.get('seconds'), 2)} | "
                 f"{_f(r.get('peak_rss_mb'), 0)} | {_f(r.get('step_mb'), 0)} | {_f(r.get('workers_peak_mb'), 0)} | "
                 f"{what} |")
    bw = [r for r in result["steps"] if r.get("bandwidth")]
    if bw:
        L += ["", "## Whole-mesh steps against memory speed", "",
              "Timed inside the `cli` run; `touch s`: `np.copyto` moving the bytes the step must touch at the "
              "least, on this machine in the same run (how: `eval/bench_scale.py`'s docstring); "
              "`ratio` = step s / touch s.", "",
              "| case | step | seconds | bytes touched (MB) | touch s | GB/s | ratio |",
              "|---|---|---:|---:|---:|---:|---:|"]
        for r in bw:
            for b in r["bandwidth"]:
                L.append(f"| {r['case']} | {b['step']} | {b['seconds']:.3f} | {b['bytes'] / 1e6:,.0f} | "
                         f"{b['touch_seconds']:.3f} | {b['gb_per_s']:.1f} | {b['ratio']:.1f} |")
    same = result.get("jobs_identical")
    if same:
        L += ["", "Output identical for jobs 1 and 2: " + ", ".join(f"{k}: {'yes' if v else '**no**'}"
                                                                  for k, v in same.items())]
    if result.get("peers"):
        L += ["", f"## Against peers on the {result['peer_case']} case", "",
              "Seconds: the fill call(s) only (conversion to and from each tool's mesh structure apart); "
              "ours includes its hole detection. RMS and max: distance of the added surface to the "
              "unperforated mesh, ‰ of the bounding-box diagonal.", ""]
        L += _peer_table(result["peers"])
        if result.get("peers_large"):
            c = result["cases"].get(LARGE_CASE, {})
            L += ["", f"## Against peers on {LARGE_HOLES} larger holes in the 1M surface ({LARGE_CASE})", "",
                  f"{c.get('faces', 0):,} faces, {c.get('holes_cut')} holes of radius "
                  f"{LARGE_RADII[0]}–{LARGE_RADII[1]} (about {LARGE_RADII[0] / c.get('mean_edge', 1):.0f}–"
                  f"{LARGE_RADII[1] / c.get('mean_edge', 1):.0f} mean edges); not a target case.", ""]
            L += _peer_table(result["peers_large"])
        v = result.get("targets")
        if v:
            L += ["", "Targets (issue 7): " + "; ".join(f"{k}: {'met' if ok else '**not met**'} ({why})"
                                                        for k, (ok, why) in v.items())]
    if result.get("cold_start"):
        from eval import cold_start

        L += [""] + cold_start.markdown(result["cold_start"])
    return "\n".join(L) + "\n"


def _peer_table(rows):
    L = ["| tool | status | fill s | × ours (time) | convert s | fill+convert × ours | peak +MB | holes after "
         "| faces added | RMS ‰ | × ours (RMS) | max ‰ | self-int. added | watertight |",
         "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        if r["status"] != "ok":
            L.append(f"| {r['tool']} | {r['status']}: {r.get('error', '')} | | | | | | | | | | | | |")
            continue
        L.append(f"| {r['tool']} | ok | {_f(r['seconds'], 2)} | {_f(r.get('seconds_x_ours'), 2)} | "
                 f"{_f(r.get('convert_seconds'), 1)} | {_f(r.get('total_x_ours'), 2)} | "
                 f"{_f(r.get('peak_mb'), 0)} | {r.get('holes_after')} | {_f(r.get('faces_added'))} | "
                 f"{_f(r.get('rms_permille'), 4)} | {_f(r.get('rms_x_ours'), 2)} | {_f(r.get('max_permille'), 3)} | "
                 f"{r.get('self_intersections_added')} | {_f(r.get('watertight'))} |")
    return L


def targets(result):
    """The issue's targets, judged on this run."""
    out = {}
    pr = {r["tool"]: r for r in result.get("peers", []) if r.get("status") == "ok"}
    ours = pr.get("ours-auto")
    if ours:
        ml, cg = pr.get("meshlib-nicely"), pr.get("cgal")
        if ml:
            x = ml["seconds"] / ours["seconds"]
            out["no slower than MeshLib fillHoleNicely"] = (x >= 1.0, f"MeshLib takes {x:.2f}× our time")
        if cg:
            x = cg["seconds"] / ours["seconds"]
            out["≥ 5× faster than CGAL"] = (x >= 5.0, f"CGAL takes {x:.2f}× our time")
        acc = [p for p in (ml, cg) if p and p.get("rms_permille") is not None]
        if acc and ours.get("rms_permille") is not None:
            better = all(ours["rms_permille"] < p["rms_permille"] for p in acc)
            out["more accurate than both"] = (better, ", ".join(
                f"{p['tool']} RMS {p['rms_permille'] / ours['rms_permille']:.2f}× ours" for p in acc))
    e2e = [r for r in result["steps"] if r["case"] == "10M" and r["step"] == "cli"]
    if e2e:
        r = e2e[0]
        ok = r["status"] == "ok"
        out["10M end to end (shellrepair repair) within 15 s and 3 GB (issue 14)"] = (
            ok and r["seconds"] <= 15.0 and r["peak_rss_mb"] <= 3 * 1024,
            f"{r.get('seconds', 0):.1f} s, peak {r.get('peak_rss_mb', 0) / 1024:.2f} GB" if ok else r["status"])
    big = [r for r in result["steps"] if r["case"] == "10M"]
    if big:
        ok = all(r["status"] == "ok" for r in big)
        peak = max((r.get("peak_rss_mb") or 0) for r in big)
        out["10M faces within 24 GB"] = (ok and peak < 24 * 1024,
                                         f"largest step peak {peak / 1024:.1f} GB" + ("" if ok else
                                                                                       ", some step did not finish"))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default=",".join(SIZES), help=f"cases, comma-separated from {', '.join(SIZES)}")
    ap.add_argument("--steps", default="read,detect,fill-j1,fill-j2,fill-j1-hp,write,cli,cold")
    ap.add_argument("--timeout", type=float, default=STEP_TIMEOUT, help="seconds per step")
    ap.add_argument("--peer-timeout", type=float, default=PEER_TIMEOUT)
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--profile", action="store_true",
                    help="profile each step (cProfile; slower) and write bench_scale_profile.json instead")
    ap.add_argument("--out", default=str(RESULTS))
    ap.add_argument("--tmp", default=None, help="work folder (default: a temporary one, removed after)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--case-dir", help=argparse.SUPPRESS)
    ap.add_argument("--child-out", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        run_child(args.child, args.case_dir, args.child_out, profile=args.profile)
        return 0

    from eval.bench import machine_info

    names = [s.strip() for s in args.sizes.split(",") if s.strip()]
    bad = [s for s in names if s not in SIZES]
    if bad:
        ap.error(f"unknown size(s) {', '.join(bad)}; known: {', '.join(SIZES)}")
    steps = [s.strip() for s in args.steps.split(",") if s.strip()]
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    own_tmp = args.tmp is None
    tmp = Path(tempfile.mkdtemp(prefix="bench_scale.")) if own_tmp else Path(args.tmp)
    tmp.mkdir(parents=True, exist_ok=True)
    log = lambda *a: print(*a, flush=True)  # noqa: E731
    result = {"command": "python eval/bench_scale.py " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:])),
              "machine": machine_info(), "settings": {"holes": HOLES, "radii": RADII, "amplitude": AMPLITUDE,
                                                      "frequency": FREQUENCY, "seed": SEED,
                                                      "step_timeout": args.timeout},
              "cases": {}, "steps": [], "peers": []}
    try:
        if "cold" in steps:   # once, before the cases load the disk; not profiled
            from eval import cold_start

            steps.remove("cold")
            names = names if steps else []
            if not args.profile:
                result["cold_start"] = cold_start.measure(tmp=tmp, log=log)
        for name in names:  # one case at a time, so the disk holds one 10M case at most
            result["cases"].update(build_cases([name], tmp, truth=name == names[0], log=log))
            d = Path(result["cases"][name]["dir"])
            for step in steps:
                if step == "write" and not (d / "repaired.npz").exists():
                    result["steps"].append({"case": name, "step": step, "status": "skipped",
                                            "error": "no repaired mesh (fill-j1 did not finish)"})
                    continue
                row = {"case": name, **run_step(step, d, args.timeout, profile=args.profile, log=log)}
                if step == "cli" and row["status"] == "ok":
                    row["seconds"] = row["wall_seconds"]   # the whole process: start-up to exit
                    row.update(_cli_outputs(d))
                    row["bandwidth"] = bandwidth_rows(row)
                result["steps"].append(row)
                msg = (f"{row.get('seconds', 0):8.2f} s  peak {row.get('peak_rss_mb', 0):7.0f} MB  "
                       f"step +{row.get('step_mb') or 0:6.0f} MB" if row["status"] == "ok"
                       else f"{row['status']}: {row.get('error')}")
                log(f"  {name:4s} {step:8s} {msg}")
                for b in row.get("bandwidth", []):
                    log(f"         {b['step']:10s} {b['seconds']:7.3f} s  touches {b['bytes'] / 1e6:7.0f} MB "
                        f"(memcpy speed here: {b['touch_seconds']:.3f} s, {b['gb_per_s']:.1f} GB/s)  "
                        f"ratio {b['ratio']:5.1f}")
                if args.profile and row.get("profile"):
                    for p in row["profile"]["by_tottime"][:8]:
                        log(f"      {p['tottime']:7.2f} s own {p['cumtime']:7.2f} s cum  {p['function']}")
            if not args.no_peers and not args.profile and name == names[0]:
                log(f"peers on {name}:")
                result["peer_case"] = name
                result["peers"] = compare_peers(d, COMPARE, args.peer_timeout, log=log)
                if name == "1M":
                    result["cases"].update(build_cases([LARGE_CASE], tmp, truth=True, log=log))
                    dl = Path(result["cases"][LARGE_CASE]["dir"])
                    log(f"peers on {LARGE_CASE}:")
                    result["peers_large"] = compare_peers(dl, COMPARE, args.peer_timeout, log=log)
                    for f in dl.iterdir():
                        if f.suffix in (".ply", ".npy", ".npz"):
                            f.unlink()
            for f in d.iterdir():  # free the disk before the next size
                if f.suffix in (".ply", ".npy", ".npz"):
                    f.unlink()
        fills = {}
        for r in result["steps"]:
            if r["step"].startswith("fill") and r["status"] == "ok":
                fills.setdefault(r["case"], set()).add(r["output_sha256"])
        result["jobs_identical"] = {k: len(v) == 1 for k, v in fills.items()}
        result["targets"] = targets(result)
        if "cold_start" in result:
            from eval import cold_start

            result["targets"]["first make repair within 20 % of the second (issue 14)"] = cold_start.target(
                result["cold_start"])
    finally:
        if own_tmp:
            import shutil

            shutil.rmtree(tmp, ignore_errors=True)
    result["seconds"] = time.perf_counter() - t_all
    stem = "bench_scale_profile" if args.profile else "bench_scale"
    (out_dir / f"{stem}.json").write_text(json.dumps(result, indent=1, default=float) + "\n")
    if not args.profile:
        (out_dir / f"{stem}.md").write_text(markdown(result))
    log(f"wrote {out_dir / (stem + '.json')}" + ("" if args.profile else f" and {out_dir / (stem + '.md')}")
        + f" in {result['seconds']:.0f} s")
    for k, (ok, why) in result.get("targets", {}).items():
        log(f"  target {k}: {'met' if ok else 'NOT met'} ({why})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
