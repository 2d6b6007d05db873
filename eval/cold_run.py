"""The cost of one cold run: a small repair in a fresh process, as a user runs it (issue 38).

A unit sphere (``shapes.icosphere(5)``, 20 480 faces) with one geodesic disc
of radius 0.15 cut at its top (a 28-edge rim) is repaired by the command
line, ``shellrepair repair SCAN.ply -o OUT.ply --report R.json -q``, each
run in a new interpreter. Each run gives

* ``wall``: the process's wall time from exec to exit, timed by this
  script around the child (interpreter start, imports, the kernels loaded,
  the read, the repair and the write: loading moved to a background thread
  counts);
* ``cpu``: the child's user + system CPU seconds (its threads' work
  summed; less disturbed by other load than the wall time);
* ``seconds``: the report's ``seconds`` (detection, fill and merge, timed by
  :func:`shellrepair.repair.repair_mesh`, imports before it excluded);
* ``seconds_total``: the report's ``seconds_total`` (the command's own
  timer, from before the read to before the write).

and, once per tree and round, ``import``: the wall time of
``python -X importtime -c "import shellrepair.repair"`` summed over its
top-level imports (the interpreter's own start-up modules excluded).

Several source trees (``--tree``, default: this checkout) are measured in
one run, interleaved run by run (tree A, tree B, tree A, ...), so that the
other load on a shared machine falls on all of them alike; each figure is
the median over ``--runs`` runs. Each tree is byte-compiled first
(``compileall``), so no run pays for writing ``.pyc`` files. The load
average is printed before and after. The written mesh and the report
(without its timings and file names) are hashed per tree: a change meant to
cost less must leave both the same.

The children run the tree's code through ``PYTHONPATH`` with the calling
interpreter (``sys.executable``, the checkout's ``.venv``): a tree needs
its compiled kernels (``shellrepair/_aot_*.so``) beside its sources, as
``make setup`` leaves them, or its runs fall back to Numba's JIT.

Run: ``python eval/cold_run.py [--runs 7] [--tree DIR ...] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The targets of issue 38 for this case.
TARGET_SECONDS = 0.1
TARGET_WALL = 0.6
#: Report keys that hold a timing or a path: left out of the report's hash.
_VOLATILE = {"seconds", "seconds_total", "file", "output"}
#: The command line's entry point, as the installed ``shellrepair`` script runs it.
_ENTRY = "import sys; from shellrepair.cli import main; sys.exit(main())"
_CLEAR = ("PYTHONPATH", "PYTHONPROFILEIMPORTTIME", "PYTHONDONTWRITEBYTECODE", "NUMBA_DISABLE_JIT",
          "SHELLREPAIR_NO_NUMBA", "SHELLREPAIR_NO_AOT")


def make_scan(path, radius=0.15):
    """Write the case: the icosphere with one disc of ``radius`` cut at its top."""
    sys.path.insert(0, str(ROOT))
    import numpy as np

    from eval import shapes
    from shellrepair import Mesh, write_mesh

    V, F = shapes.icosphere(5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[int(np.argmax(V[:, 2]))], radius=radius)
    write_mesh(path, Mesh(V=V2, F=F2))
    return len(V2), len(F2)


def env_for(tree, **extra):
    env = {k: v for k, v in os.environ.items() if k not in _CLEAR}
    env["PYTHONPATH"] = str(tree)
    env.update(extra)
    return env


def _strip(x):
    if isinstance(x, dict):
        return {k: _strip(v) for k, v in x.items() if k not in _VOLATILE}
    if isinstance(x, list):
        return [_strip(v) for v in x]
    return x


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def repair_once(tree, scan, work):
    """One cold ``repair`` with ``tree``'s code: wall, the report's timings, output hashes."""
    out, rep = work / "out.ply", work / "out.report.json"
    for p in (out, rep):
        p.unlink(missing_ok=True)
    cmd = [sys.executable, "-c", _ENTRY, "repair", str(scan), "-o", str(out), "--report", str(rep), "-q"]
    c0, t0 = _children_cpu(), time.perf_counter()
    p = subprocess.run(cmd, cwd=work, env=env_for(tree), capture_output=True, text=True)
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - c0
    if p.returncode:
        raise RuntimeError(f"{tree}: repair failed ({p.returncode}): {p.stderr[-800:]}")
    report = json.loads(rep.read_text())
    return {"wall": wall, "cpu": cpu, "seconds": report["seconds"], "seconds_total": report["seconds_total"],
            "mesh_sha256": hashlib.sha256(out.read_bytes()).hexdigest(),
            "report_sha256": hashlib.sha256(json.dumps(_strip(report), sort_keys=True).encode()).hexdigest()}


_IMPORT = re.compile(r"import time:\s+(\d+)\s+\|\s+(\d+)\s+\|( *)(\S+)")


def import_once(tree, work, module="shellrepair.repair"):
    """Seconds of ``import module`` in a fresh interpreter (``-X importtime``,
    the top-level imports after ``site``), and its largest top-level imports."""
    p = subprocess.run([sys.executable, "-X", "importtime", "-c", f"import {module}"], cwd=work,
                       env=env_for(tree), capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(f"{tree}: import failed: {p.stderr[-800:]}")
    tops, after_site = [], False
    for line in p.stderr.splitlines():
        m = _IMPORT.match(line)
        if not m or len(m.group(3)) != 1:
            continue
        if after_site:
            tops.append((m.group(4), int(m.group(2)) / 1e6))
        elif m.group(4) == "site":
            after_site = True
    third = {}
    for line in p.stderr.splitlines():     # every package loaded, by its top name (self times summed)
        m = _IMPORT.match(line)
        if m:
            root = m.group(4).split(".")[0]
            third[root] = third.get(root, 0.0) + int(m.group(1)) / 1e6
    return {"import": sum(s for _, s in tops), "packages": third}


def loadavg():
    try:
        return os.getloadavg()
    except OSError:
        return None


def measure(trees, runs=7, radius=0.15, log=print):
    """Interleaved cold runs of every tree; the per-tree medians and hashes."""
    work = Path(tempfile.mkdtemp(prefix="cold_run."))
    scan = work / "sphere_disc.ply"
    nv, nf = make_scan(scan, radius)
    for t in trees:
        subprocess.run([sys.executable, "-m", "compileall", "-q", str(Path(t) / "shellrepair")],
                       capture_output=True, check=False)
    res = {"case": f"icosphere(5), one disc of radius {radius} at the top: {nv} vertices, {nf} faces",
           "runs": runs, "python": sys.executable, "load_before": loadavg(), "trees": {}}
    rows = {t: [] for t in trees}
    imports = {t: [] for t in trees}
    for t in trees:                        # one untimed run each: the files in the page cache
        repair_once(t, scan, work)
    for i in range(runs):
        for t in trees:
            r = repair_once(t, scan, work)
            rows[t].append(r)
            log(f"run {i} {t}: wall {r['wall']:.3f} s, cpu {r['cpu']:.3f} s, seconds {r['seconds']:.4f}, "
                f"seconds_total {r['seconds_total']:.4f}")
        for t in trees:
            imports[t].append(import_once(t, work))
    res["load_after"] = loadavg()
    for t in trees:
        rs = rows[t]
        pk = {}
        for x in imports[t]:
            for k, v in x["packages"].items():
                pk.setdefault(k, []).append(v)
        res["trees"][str(t)] = {
            "commit": _commit(t),
            "wall": statistics.median(r["wall"] for r in rs),
            "cpu": statistics.median(r["cpu"] for r in rs),
            "seconds": statistics.median(r["seconds"] for r in rs),
            "seconds_total": statistics.median(r["seconds_total"] for r in rs),
            "import": statistics.median(x["import"] for x in imports[t]),
            "import_by_package": {k: statistics.median(v) for k, v in
                                  sorted(pk.items(), key=lambda kv: -statistics.median(kv[1]))[:8]},
            "all_wall": [r["wall"] for r in rs], "all_seconds": [r["seconds"] for r in rs],
            "mesh_sha256": sorted({r["mesh_sha256"] for r in rs}),
            "report_sha256": sorted({r["report_sha256"] for r in rs}),
        }
    return res


def _commit(tree):
    p = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=tree, capture_output=True, text=True)
    if p.returncode:
        return None
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=tree,
                           capture_output=True, text=True).stdout.strip()
    return p.stdout.strip() + ("+uncommitted" if dirty else "")


def text(res):
    L = [f"case: {res['case']}; median of {res['runs']} runs per tree, interleaved",
         f"load average before {res['load_before']}, after {res['load_after']}", ""]
    L.append(f"{'tree':40s} {'wall s':>7s} {'cpu s':>6s} {'seconds':>8s} {'s_total':>8s} {'import s':>9s}  largest imports")
    for t, r in res["trees"].items():
        top = ", ".join(f"{k} {v:.3f}" for k, v in list(r["import_by_package"].items())[:4])
        L.append(f"{t:40s} {r['wall']:7.3f} {r['cpu']:6.3f} {r['seconds']:8.4f} {r['seconds_total']:8.4f} {r['import']:9.3f}  {top}")
    L.append("")
    for t, r in res["trees"].items():
        L.append(f"{t} ({r['commit']}): wall {', '.join(f'{x:.3f}' for x in r['all_wall'])}; seconds "
                 f"{', '.join(f'{x:.4f}' for x in r['all_seconds'])}")
        L.append(f"  mesh sha256 {', '.join(r['mesh_sha256'])}; report sha256 {', '.join(r['report_sha256'])}")
        L.append(f"  targets: seconds < {TARGET_SECONDS}: {'met' if r['seconds'] < TARGET_SECONDS else 'NOT met'}; "
                 f"wall < {TARGET_WALL}: {'met' if r['wall'] < TARGET_WALL else 'NOT met'}")
    same = len({tuple(r["mesh_sha256"]) + tuple(r["report_sha256"]) for r in res["trees"].values()}) == 1
    L.append(f"outputs identical across trees and runs: {same and all(len(r['mesh_sha256']) == 1 for r in res['trees'].values())}")
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--tree", action="append", default=None,
                    help="a source tree to measure (repeat to interleave several; default: this checkout)")
    ap.add_argument("--radius", type=float, default=0.15)
    ap.add_argument("--out", default=None, help="folder to write result.json and result.txt into")
    args = ap.parse_args(argv)
    trees = [str(Path(t).resolve()) for t in (args.tree or [ROOT])]
    res = measure(trees, runs=args.runs, radius=args.radius, log=lambda s: print(s, flush=True))
    out = text(res)
    print(out)
    if args.out:
        d = Path(args.out)
        d.mkdir(parents=True, exist_ok=True)
        (d / "result.json").write_text(json.dumps(res, indent=1) + "\n")
        (d / "result.txt").write_text(out + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
