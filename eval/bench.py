"""The benchmark: every case x every tool, measured against the true surface.

Run ``make bench`` (or ``.venv/bin/python eval/bench.py [options]``). It
writes, under ``eval/results/``:

* ``bench.json``: the machine, the command, every case and every
  (case, tool) row with all metrics (see :mod:`eval.metrics`), a summary per
  tool, and the shading benchmark's JSON when ``eval/bench_shading.py``
  exists;
* ``bench.md``: the same as tables a person reads;
* ``speed_vs_error.png``: fill time against RMS error, per case and per tool.

Each tool runs in its own child process (:mod:`eval.worker`) with a per-case
timeout, warm: the child loaded the tool (and ran it once on a tiny sphere)
before the first case, and the time is its fill call alone. Ours is also run
as a user runs it, cold (the ``ours-cold`` rows, unless ``--no-cold``): a
fresh ``python -m shellrepair.cli repair CASE.ply -o OUT.ply --report R.json``
process per case, timed both by the report's ``seconds`` (detection, fill
and merge, imports excluded) and by the process's wall time from exec to
exit (``process_seconds``: interpreter start, imports, kernels loaded,
reading and writing the PLY included, so that loading moved to a thread
does not count as gained); its output is measured like every tool's. a tool that is not installed, fails, crashes or times out is a row
saying so, never a missing row. Tools run one at a time, so their timings do
not compete for the two cores. Ratios (``x ours``) are against ``ours-auto`` (the default)
in the same run.

The benchmark is not a test: it asserts nothing and exits 0 unless it could
not run at all.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from eval import cases as casemod  # noqa: E402
from eval import metrics, peers  # noqa: E402
from eval.worker import ToolRunner  # noqa: E402

RESULTS = ROOT / "eval" / "results"
DEFAULT_TIMEOUT = 90.0
SHADING_SCRIPT = ROOT / "eval" / "bench_shading.py"
SHADING_TIMEOUT = 300.0
#: The pseudo-tool of the cold runs: our command line, one fresh process per case.
COLD = "ours-cold"


# --------------------------------------------------------------------------
# machine
# --------------------------------------------------------------------------
def machine_info():
    """CPU model, cores, memory, OS, Python and the versions of the tools."""
    from importlib import metadata

    cpu = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem_gb = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                mem_gb = round(int(line.split()[1]) / 1024 ** 2, 1)
    except OSError:
        pass
    versions = {}
    for pkg in ("numpy", "scipy", "open3d-cpu", "open3d", "pymeshlab", "meshlib", "cgal", "pymeshfix",
                "libigl", "matplotlib", "shellrepair"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            pass
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                                text=True, timeout=10).stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {"cpu": cpu, "nproc": os.cpu_count(), "memory_gb": mem_gb,
            "os": f"{platform.system()} {platform.release()}", "python": platform.python_version(),
            "versions": versions, "commit": commit,
            "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}


# --------------------------------------------------------------------------
# one case
# --------------------------------------------------------------------------
ROW_METRICS = ("holes_before", "holes_after", "rate", "rms_permille", "mean_permille", "max_permille",
               "bias_permille", "normal_dev_deg", "flipped_pct", "watertight", "edge_manifold", "oriented",
               "self_intersections_added", "edge_ratio", "area_ratio", "faces_added", "vertices_added",
               "input_faces_missing", "orig_exact_pct", "orig_max_shift_permille", "open_chains",
               "nonmanifold_edges", "boundary_edges")


def run_case(case, tools, runners, tmp, *, n_samples, seed, log=print, cold_timeout=None):
    """Run every tool on one case; returns the rows.

    ``COLD`` among ``tools`` is our command line in a fresh process
    (:func:`run_cold`, ``cold_timeout`` seconds at most), not a worker."""
    from shellrepair.mesh.topology import face_areas

    case_npz = tmp / f"{case.name}.npz"
    np.savez(case_npz, V=case.V, F=case.F)
    truth = metrics.TruthSurface(case.V_true, case.F_true)
    facts = metrics.input_facts(case.V, case.F)
    removed_area = float(face_areas(case.V_true, case.F_true[case.removed]).sum())
    rows = []
    for tool in tools:
        row = {"case": case.name, "family": case.family, "tool": tool}
        if tool == COLD:
            res = run_cold(case, tmp, cold_timeout or DEFAULT_TIMEOUT)
            out_npz = None
        else:
            ok, why = peers.tool_available(tool)
            if not ok:
                row.update(status="missing", error=why, holes_before=facts["loops"])
                rows.append(row)
                log(f"  {tool:17s} missing: {why}")
                continue
            out_npz = tmp / f"{case.name}.{tool}.out.npz"
            res = runners[tool].run(case_npz, out_npz)
        row["status"] = res["status"]
        row["wall_seconds"] = res.get("wall_seconds")
        if res["status"] != "ok":
            row["error"] = res.get("error")
            row["holes_before"] = facts["loops"]
            rows.append(row)
            log(f"  {tool:17s} {res['status']}: {res.get('error')}")
            continue
        info = res["info"]
        row["seconds"] = float(info.get("seconds", res["wall_seconds"]))
        row["convert_seconds"] = info.get("convert_seconds")
        row["peak_mb"] = res.get("peak_mb")
        row["memory_method"] = res.get("memory_method")
        row["process_seconds"] = res.get("process_seconds")
        row["info"] = {k: v for k, v in info.items() if k not in ("seconds", "convert_seconds")}
        data = res["output"] if out_npz is None else np.load(out_npz)
        try:
            m = metrics.evaluate(case.V, case.F, data["V"], data["F"], truth, removed_area=removed_area,
                                 n_samples=n_samples, seed=seed, facts=facts)
        except Exception as exc:  # a surface the metrics cannot read is that tool's failure
            row.update(status="failed", error=f"output not measurable: {type(exc).__name__}: {exc}"[:300],
                       holes_before=facts["loops"])
            rows.append(row)
            log(f"  {tool:17s} failed: {row['error']}")
            continue
        finally:
            if out_npz is not None:
                os.unlink(out_npz)
        row.update({k: m.get(k) for k in ROW_METRICS})
        if tool.startswith("ours") and row["info"].get("face_filled") is not None \
                and row["info"]["face_filled"] != m["faces_added"]:
            row["note"] = (f"face_filled flags {row['info']['face_filled']} faces, "
                           f"geometry says {m['faces_added']} were added")
        rows.append(row)
        log(f"  {tool:17s} holes {m['holes_before']:>4}->{m['holes_after']:<4} "
            f"rms {_f(m['rms_permille'], 3):>8}‰ max {_f(m['max_permille'], 2):>7}‰ "
            f"ndev {_f(m['normal_dev_deg'], 1):>6}° wt {'y' if m['watertight'] else 'n'} "
            f"si {m.get('self_intersections_added')} {row['seconds']:.3f}s {_f(row['peak_mb'], 0)}MB"
            + (f" (process {row['process_seconds']:.3f}s)" if row.get("process_seconds") is not None else ""))
    os.unlink(case_npz)
    return rows


def run_cold(case, tmp, timeout):
    """Our command line as a user runs it: one fresh process on the case's PLY.

    Parameters
    ----------
    case : eval.cases.Case
        The perforated mesh is written as binary PLY (float64 coordinates,
        read back bit for bit).
    tmp : Path
        Folder for the PLY, the output and the report (removed after).
    timeout : float
        Seconds before the process is killed (status ``timeout``).

    Returns
    -------
    res : dict
        ``status``; when ok, ``info`` (``seconds``: the report's, holes
        before and after), ``process_seconds`` (wall time from before exec
        to after exit), ``wall_seconds`` (the same) and ``output`` (the
        repaired ``{"V", "F"}`` as read back); else ``error``.
    """
    from eval.cold_start import user_env
    from shellrepair.mesh.io import read_mesh, write_mesh
    from shellrepair.mesh.core import Mesh

    ply, out, rep = (tmp / f"{case.name}.cold{suffix}" for suffix in (".ply", ".out.ply", ".report.json"))
    write_mesh(ply, Mesh(V=case.V, F=case.F))
    cmd = [sys.executable, "-m", "shellrepair.cli", "repair", str(ply), "-o", str(out), "--report", str(rep)]
    try:
        t0 = time.perf_counter()
        try:
            p = subprocess.run(cmd, cwd=ROOT, env=user_env(), capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"status": "timeout", "error": f"no exit in {timeout:g} s"}
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            return {"status": "failed", "error": f"exit {p.returncode}: {p.stderr.strip()[-300:]}"}
        report = json.loads(rep.read_text())
        got = read_mesh(out, clean=False, orient=False)
        return {"status": "ok", "wall_seconds": wall, "process_seconds": wall,
                "info": {"seconds": float(report["seconds"]), "holes_before": report.get("holes_before"),
                         "holes_after": report.get("holes_after")},
                "output": {"V": np.asarray(got.V, np.float64), "F": np.asarray(got.F, np.int64)}}
    finally:
        for f in (ply, out, rep):
            f.unlink(missing_ok=True)


def _f(x, nd):
    return "-" if x is None else f"{x:.{nd}f}"


# --------------------------------------------------------------------------
# summary and tables
# --------------------------------------------------------------------------
def add_ratios(rows, reference=peers.REFERENCE):
    """``seconds_x_ours`` and ``rms_x_ours``: this tool over the reference, same case."""
    ref = {r["case"]: r for r in rows if r["tool"] == reference and r.get("status") == "ok"}
    for r in rows:
        q = ref.get(r["case"])
        r["seconds_x_ours"] = (r["seconds"] / q["seconds"]) if (q and r.get("status") == "ok"
                                                               and q["seconds"] > 0) else None
        r["rms_x_ours"] = (r["rms_permille"] / q["rms_permille"]) if (
            q and r.get("rms_permille") is not None and q.get("rms_permille")) else None


def best_peer(rows, case):
    """The peer row with the lowest RMS among peers that filled every hole
    (or, if none did, among all peers that returned a surface)."""
    cand = [r for r in rows if r["case"] == case and r["tool"] in peers.PEERS and r.get("status") == "ok"
            and r.get("rms_permille") is not None]
    full = [r for r in cand if r.get("holes_after") == 0]
    pool = full or cand
    return min(pool, key=lambda r: r["rms_permille"]) if pool else None


def summarize(rows, tools, case_names):
    """One line per tool over all cases."""
    out = []
    for t in tools:
        rs = [r for r in rows if r["tool"] == t]
        ok = [r for r in rs if r.get("status") == "ok"]
        rms = [r["rms_permille"] for r in ok if r.get("rms_permille") is not None]
        before = sum(int(r.get("holes_before") or 0) for r in rs)
        after = sum(int(r["holes_after"]) if r.get("status") == "ok" else int(r.get("holes_before") or 0)
                    for r in rs)
        sx = [r["seconds_x_ours"] for r in ok if r.get("seconds_x_ours")]
        rx = [r["rms_x_ours"] for r in ok if r.get("rms_x_ours")]
        out.append({
            "tool": t,
            "cases": len(rs),
            "ok": len(ok),
            "not_ok": {s: sum(1 for r in rs if r.get("status") == s)
                       for s in ("failed", "timeout", "crashed", "missing") if any(r.get("status") == s for r in rs)},
            "holes_before": before,
            "holes_after": after,
            "rate": 100.0 * (before - after) / before if before else None,
            "all_filled_cases": sum(1 for r in ok if r.get("holes_after") == 0),
            "median_rms_permille": float(np.median(rms)) if rms else None,
            "worst_rms_permille": float(np.max(rms)) if rms else None,
            "median_max_permille": float(np.median([r["max_permille"] for r in ok if r.get("max_permille") is not None]))
            if rms else None,
            "median_normal_dev_deg": float(np.median([r["normal_dev_deg"] for r in ok
                                                      if r.get("normal_dev_deg") is not None])) if rms else None,
            "flipped_cases": sum(1 for r in ok if (r.get("flipped_pct") or 0) > 50),
            "watertight_cases": sum(1 for r in ok if r.get("watertight")),
            "self_intersections_added": sum(int(r.get("self_intersections_added") or 0) for r in ok),
            "total_seconds": float(sum(r["seconds"] for r in ok)),
            "total_process_seconds": float(sum(r["process_seconds"] for r in ok))
            if ok and all(r.get("process_seconds") is not None for r in ok) else None,
            "geomean_seconds_x_ours": float(np.exp(np.mean(np.log(sx)))) if sx else None,
            "median_rms_x_ours": float(np.median(rx)) if rx else None,
            "median_peak_mb": float(np.median(peaks)) if (peaks := [r["peak_mb"] for r in ok
                                                                    if r.get("peak_mb") is not None]) else None,
        })
    return out


def _fmt(x, nd=2, dash="–"):
    if x is None:
        return dash
    if isinstance(x, bool):
        return "yes" if x else "**no**"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if abs(x) >= 1000:
        return f"{x:.0f}"
    return f"{x:.{nd}f}"


def _sig(x, dash="–"):
    """Three significant figures, for values spanning decades."""
    if x is None:
        return dash
    if x == 0:
        return "0"
    if abs(x) >= 100:
        return f"{x:.0f}"
    return f"{x:.{max(0, 2 - int(np.floor(np.log10(abs(x)))))}f}"


def markdown(result):
    """bench.md text."""
    mi = result["machine"]
    rows = result["rows"]
    lines = ["# shellrepair benchmark", "",
             f"Command: `{result['command']}`  ",
             f"Machine: {mi['cpu']}, {mi['nproc']} cores, {mi['memory_gb']} GB RAM, {mi['os']}, "
             f"Python {mi['python']}  ",
             f"Date: {mi['date']}, commit {mi['commit']}, seed {result['seed']}, "
             f"{result['n_samples']} samples per filled surface, timeout {result['timeout']:g} s per tool and case, "
             f"total {result['total_seconds']:.0f} s  ",
             "Versions: " + ", ".join(f"{k} {v}" for k, v in mi["versions"].items()), "",
             "Distances are to the closed ground truth, sampled by area on the faces each tool added, in ‰ "
             "of the bounding-box diagonal. `× ours` is this tool's value over `ours-auto`'s (the default call) on the same case "
             "in this run. Seconds are the fill call only; ours runs with its compiled (Numba) kernels "
             "loaded before the call, as a peer's import loads its native library (the loading a user's "
             "first run pays is measured by eval/bench_scale.py: first and second `make repair`). "
             f"`{COLD}` is ours as a user runs it: one fresh `python -m shellrepair.cli repair CASE.ply -o OUT.ply "
             "--report R.json` process per case (the command line's defaults, as `ours-cli`); its `s` is the "
             "report's `seconds` (imports excluded) and its `process s` the process's wall time from exec to "
             "exit.", "",
             "## Summary per tool", "",
             "| tool | cases ok | holes before → after | rate % | all filled | median RMS ‰ | worst RMS ‰ "
             "| median max ‰ | median normal dev ° | flipped | watertight | self-int. added | total s "
             "| total process s | time × ours (geomean) | RMS × ours (median) | median peak MB | not ok |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in result["summary"]:
        lines.append(
            f"| {s['tool']} | {s['ok']}/{s['cases']} | {s['holes_before']} → {s['holes_after']} | {_fmt(s['rate'], 1)} "
            f"| {s['all_filled_cases']} | {_sig(s['median_rms_permille'])} | {_sig(s['worst_rms_permille'])} "
            f"| {_sig(s['median_max_permille'])} | {_fmt(s['median_normal_dev_deg'], 1)} | {s['flipped_cases']} "
            f"| {s['watertight_cases']} | {s['self_intersections_added']} | {_fmt(s['total_seconds'], 1)} "
            f"| {_fmt(s.get('total_process_seconds'), 1)} | {_sig(s['geomean_seconds_x_ours'])} | {_sig(s['median_rms_x_ours'])} | {_fmt(s['median_peak_mb'], 0)} "
            f"| {', '.join(f'{k} {v}' for k, v in s['not_ok'].items()) or '–'} |")
    for tool, title in ((peers.REFERENCE, "Ours (the default: --order auto)"), ("ours-o2", "Ours (--order 2)")):
        if not any(r["tool"] == tool for r in rows):
            continue
        lines += ["", f"## {title} against the best peer, per case", "",
                  "Best peer: lowest RMS among peers that filled every hole (among all peers if none did).", "",
                  f"| case | {tool} RMS ‰ | holes after | best peer | its RMS ‰ | holes after | ours / best | verdict |",
                  "|---|---|---|---|---|---|---|---|"]
        tally = {}
        for c in result["cases"]:
            ours = next((r for r in rows if r["case"] == c["name"] and r["tool"] == tool), None)
            bp = best_peer(rows, c["name"])
            o = ours.get("rms_permille") if ours and ours.get("status") == "ok" else None
            b = bp["rms_permille"] if bp else None
            ratio = o / b if (o is not None and b) else None
            verdict = "–" if ratio is None else ("better" if ratio < 0.95 else ("worse" if ratio > 1.05 else "same"))
            if ours and ours.get("status") != "ok":
                verdict = ours["status"]
            elif ours and bp and (ours.get("holes_after") or 0) > (bp.get("holes_after") or 0):
                verdict += (f" RMS, but {ours['holes_after'] - (bp.get('holes_after') or 0)} more holes left open "
                            "(RMS is over the holes each tool filled)")
            tally[verdict.split(" ")[0]] = tally.get(verdict.split(" ")[0], 0) + 1
            lines.append(f"| {c['name']} | {_sig(o)} | {_fmt(ours.get('holes_after') if ours else None)} "
                         f"| {bp['tool'] if bp else '–'} | {_sig(b)} | {_fmt(bp.get('holes_after') if bp else None)} "
                         f"| {_sig(ratio)} | {verdict} |")
        lines += ["", "Tally: " + ", ".join(f"{k} {v}" for k, v in sorted(tally.items())) + "."]
    lines += speed_table(result)
    lines += ["", "## Every case and tool", ""]
    head = ("| tool | status | holes | rate % | RMS ‰ | max ‰ | mean ‰ | bias ‰ | normal dev ° | flipped % "
            "| watertight | manifold | self-int. | edge ratio | area ratio | orig. exact % | s | process s | MB "
            "| s × ours | RMS × ours |")
    sep = "|" + "|".join(["---"] * (head.count("|") - 1)) + "|"
    for c in result["cases"]:
        lines += [f"### {c['name']}", "",
                  f"{c['description']}; truth {c['truth']} ({c['faces_true']} faces), input {c['faces']} faces, "
                  f"{c['holes']} holes." + (" " + " ".join(c["notes"]) if c["notes"] else ""), "", head, sep]
        for r in rows:
            if r["case"] != c["name"]:
                continue
            if r.get("status") != "ok":
                lines.append(f"| {r['tool']} | **{r['status']}** | {r.get('holes_before')} → – | – "
                             + "| – " * 16 + f"| {str(r.get('error', ''))[:60]} |")
                continue
            lines.append(
                f"| {r['tool']} | ok | {r['holes_before']} → {r['holes_after']} | {_fmt(r['rate'], 1)} "
                f"| {_sig(r['rms_permille'])} | {_sig(r['max_permille'])} | {_sig(r['mean_permille'])} "
                f"| {_sig(r['bias_permille'])} | {_fmt(r['normal_dev_deg'], 1)} | {_fmt(r['flipped_pct'], 1)} "
                f"| {_fmt(r['watertight'])} | {_fmt(r['edge_manifold'])} | {_fmt(r['self_intersections_added'])} "
                f"| {_fmt(r['edge_ratio'])} | {_fmt(r['area_ratio'])} | {_fmt(r['orig_exact_pct'], 1)} "
                f"| {_sig(r['seconds'])} | {_sig(r.get('process_seconds'))} | {_fmt(r.get('peak_mb'), 0)} "
                f"| {_sig(r.get('seconds_x_ours'))} "
                f"| {_sig(r.get('rms_x_ours'))} |")
        lines.append("")
    notes = [r for r in rows if r.get("note")]
    if notes:
        lines += ["## Notes", ""] + [f"- {r['case']} / {r['tool']}: {r['note']}" for r in notes] + [""]
    sh = result.get("shading")
    if sh is not None:
        lines += ["## Shading benchmark (eval/bench_shading.py)", "", "```",
                  json.dumps(sh, indent=1)[:4000], "```", ""]
    return "\n".join(lines)


#: The peers issue 38 measures our cold run against (geometric means under the speed table).
SPEED_PEERS = ("meshlib-nicely", "cgal")


def speed_table(result):
    """bench.md lines: per case, ours warm and cold beside the best peer, with the RMS of each.

    The best peer is :func:`best_peer`'s (lowest RMS among the peers that
    filled every hole). Under the table, the geometric mean over the cases
    of our cold times over each of :data:`SPEED_PEERS`' fill times."""
    rows = result["rows"]
    if not any(r["tool"] == COLD for r in rows):
        return []

    def get(case, tool):
        r = next((r for r in rows if r["case"] == case and r["tool"] == tool), None)
        return r if r and r.get("status") == "ok" else None

    lines = ["", "## Speed and error per case: ours warm and cold, the best peer", "",
             f"Warm: the fill call in a process that loaded the tool before (`{peers.REFERENCE}`, and `ours-cli`, "
             f"the command line's defaults). Cold (`{COLD}`): a fresh command-line process per case, the "
             "report's `seconds` and the process's wall time from exec to exit. A peer's time is its "
             "hole-filling calls alone. Best peer: lowest RMS among peers that filled every hole.", "",
             f"| case | faces | holes | {peers.REFERENCE} warm s | ours-cli warm s | cold: report s "
             "| cold: process s | cold RMS ‰ | best peer | its s | its RMS ‰ | cold report s × peer "
             "| cold process s × peer |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in result["cases"]:
        name = c["name"]
        auto, cli, cold = get(name, peers.REFERENCE), get(name, "ours-cli"), get(name, COLD)
        peer = best_peer(rows, name)
        rr = rp = None
        if cold and peer and peer["seconds"] > 0:
            rr, rp = cold["seconds"] / peer["seconds"], cold["process_seconds"] / peer["seconds"]
        lines.append(f"| {name} | {c['faces']} | {c['holes']} | {_sig(auto and auto['seconds'])} "
                     f"| {_sig(cli and cli['seconds'])} | {_sig(cold and cold['seconds'])} "
                     f"| {_sig(cold and cold['process_seconds'])} | {_sig(cold and cold.get('rms_permille'))} "
                     f"| {peer['tool'] if peer else '–'} | {_sig(peer and peer['seconds'])} "
                     f"| {_sig(peer and peer.get('rms_permille'))} | {_sig(rr)} | {_sig(rp)} |")
    lines.append("")
    for tool in SPEED_PEERS:
        pairs = [(get(c["name"], COLD), get(c["name"], tool)) for c in result["cases"]]
        pairs = [(o, q) for o, q in pairs if o and q and q["seconds"] > 0]
        if not pairs:
            continue
        g = [float(np.exp(np.mean(np.log([o[k] / q["seconds"] for o, q in pairs]))))
             for k in ("seconds", "process_seconds")]
        lines.append(f"Cold over {tool}'s fill time, geometric mean over {len(pairs)} cases: report "
                     f"`seconds` {_sig(g[0])}×, process wall time {_sig(g[1])}×.  ")
    return lines


# --------------------------------------------------------------------------
# shading
# --------------------------------------------------------------------------
def run_shading(out_dir, timeout=SHADING_TIMEOUT, log=print):
    """Run eval/bench_shading.py if it exists and return its JSON (or why not)."""
    if not SHADING_SCRIPT.exists():
        return None
    log(f"shading benchmark: {SHADING_SCRIPT.relative_to(ROOT)}")
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, str(SHADING_SCRIPT)], cwd=ROOT, capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"status": "timeout", "timeout": timeout}
    res = {"status": "ok" if p.returncode == 0 else "failed", "exit_code": p.returncode,
           "seconds": round(time.perf_counter() - t0, 2)}
    for cand in (out_dir / "bench_shading.json", RESULTS / "bench_shading.json"):
        if cand.exists():
            try:
                res["results"] = json.loads(cand.read_text())
                res["json"] = str(cand.relative_to(ROOT)) if cand.is_relative_to(ROOT) else str(cand)
                break
            except (ValueError, OSError):
                pass
    if "results" not in res:
        try:
            res["results"] = json.loads(p.stdout)
        except ValueError:
            res["stdout_tail"] = p.stdout[-2000:]
    if p.returncode != 0:
        res["stderr_tail"] = p.stderr[-2000:]
    return res


# --------------------------------------------------------------------------
# main
# --------------------------------------------------------------------------
def parse_args(argv):
    ap = argparse.ArgumentParser(prog="eval/bench.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0, help="seed of every perforation and sample (default 0)")
    ap.add_argument("--quick", action="store_true", help="small meshes (a smoke run, not for BENCHMARKS.md)")
    ap.add_argument("--cases", default=None, help="comma-separated case names (default: all)")
    ap.add_argument("--tools", default=None, help="comma-separated tools (default: all)")
    ap.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT, help="seconds per tool and case")
    ap.add_argument("--samples", type=int, default=metrics.N_SAMPLES, help="samples per filled surface")
    ap.add_argument("--out", default=str(RESULTS), help="output folder (default eval/results)")
    ap.add_argument("--no-shading", action="store_true", help="skip eval/bench_shading.py")
    ap.add_argument("--no-cold", action="store_true",
                    help=f"leave out {COLD}: ours in a fresh command-line process per case")
    ap.add_argument("--list", action="store_true", help="list cases and tools and exit")
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite bench.md and the plot from the bench.json in --out, running nothing")
    return ap.parse_args(argv)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    names = casemod.case_names() if not args.cases else [s.strip() for s in args.cases.split(",") if s.strip()]
    tools = [*peers.TOOLS, COLD] if not args.tools else [s.strip() for s in args.tools.split(",") if s.strip()]
    if args.no_cold:
        tools = [t for t in tools if t != COLD]
    if args.list:
        print("cases:", ", ".join(casemod.case_names()))
        print("tools:", ", ".join([*peers.TOOLS, COLD]))
        return 0
    bad = [n for n in names if n not in casemod.SUITE] + [t for t in tools if t not in peers.TOOLS and t != COLD]
    if bad:
        print(f"error: unknown case or tool: {', '.join(bad)} (see --list)", file=sys.stderr)
        return 2
    out = Path(args.out)
    if args.report_only:
        return write_reports(json.loads((out / "bench.json").read_text()), out)
    tmp = out / "tmp"
    tmp.mkdir(parents=True, exist_ok=True)
    command = "python eval/bench.py" + ("" if argv is None and len(sys.argv) == 1 else
                                         " " + " ".join(shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)))
    result = {"command": command, "seed": args.seed, "quick": args.quick, "timeout": args.timeout,
              "n_samples": args.samples, "machine": machine_info(), "tools": tools, "reference": peers.REFERENCE,
              "cases": [], "rows": []}
    t_start = time.perf_counter()
    print(f"shellrepair benchmark: {len(names)} cases x {len(tools)} tools, seed {args.seed}"
          + (" (quick)" if args.quick else ""), flush=True)
    runners = {t: ToolRunner(t, tmp, args.timeout) for t in tools if t != COLD}
    try:
        for name in names:
            t0 = time.perf_counter()
            case = casemod.build_case(name, args.seed, args.quick)
            cs = case.summary()
            cs["holes"] = case.n_loops
            result["cases"].append(cs)
            print(f"{name}: {cs['faces']} faces, {cs['holes']} holes ({case.description})"
                  + (f" [{'; '.join(case.notes)}]" if case.notes else ""), flush=True)
            rows = run_case(case, tools, runners, tmp, n_samples=args.samples, seed=args.seed,
                            log=lambda s: print(s, flush=True), cold_timeout=args.timeout)
            result["rows"].extend(rows)
            cs["seconds"] = round(time.perf_counter() - t0, 2)
            result["total_seconds"] = time.perf_counter() - t_start
            _write_json(out / "bench.json", result)  # partial results survive an interruption
    finally:
        for r in runners.values():
            r.close()
    if not args.no_shading:
        result["shading"] = run_shading(out)
    result["total_seconds"] = time.perf_counter() - t_start
    return write_reports(result, out)


def write_reports(result, out):
    """Write bench.json, bench.md and the plot from a result dict."""
    from eval.plot import speed_vs_error

    add_ratios(result["rows"])
    result["summary"] = summarize(result["rows"], result["tools"], [c["name"] for c in result["cases"]])
    _write_json(out / "bench.json", result)
    (out / "bench.md").write_text(markdown(result))
    backend = speed_vs_error(result["rows"], result["tools"], out / "speed_vs_error.png",
                             title=f"shellrepair benchmark, seed {result['seed']}")
    print()
    print(summary_text(result))
    print(f"\nwrote {out / 'bench.json'}, {out / 'bench.md'}, {out / 'speed_vs_error.png'} ({backend}) "
          f"in {result['total_seconds']:.0f} s")
    return 0


def summary_text(result):
    lines = [f"{'tool':17s} {'ok':>5} {'holes':>11} {'rate%':>6} {'medRMS‰':>8} {'worst‰':>8} {'flip':>4} "
             f"{'wt':>3} {'si':>4} {'total s':>8} {'t×ours':>7} {'RMS×ours':>8}"]
    for s in result["summary"]:
        lines.append(f"{s['tool']:17s} {s['ok']:>2}/{s['cases']:<2} {s['holes_before']:>5}→{s['holes_after']:<5} "
                     f"{_fmt(s['rate'], 1):>6} {_sig(s['median_rms_permille']):>8} {_sig(s['worst_rms_permille']):>8} "
                     f"{s['flipped_cases']:>4} {s['watertight_cases']:>3} {s['self_intersections_added']:>4} "
                     f"{_fmt(s['total_seconds'], 1):>8} {_sig(s['geomean_seconds_x_ours']):>7} "
                     f"{_sig(s['median_rms_x_ours']):>8}")
    return "\n".join(lines)


def _write_json(path, obj):
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(obj, indent=1, default=_json_default))
    os.replace(tmp, path)


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.bool_,)):
        return bool(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))


if __name__ == "__main__":
    sys.exit(main())
