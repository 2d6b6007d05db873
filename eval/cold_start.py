"""A user's first ``make repair`` after ``make setup``, against the second (issue 14).

``make setup`` compiles the Numba kernels (``cache=True``: machine code in
``__pycache__`` beside each module; the shading's rho_dt table ships with
the package), so that no user run waits on the compiler. This measures whether that
holds: on a fresh copy of the checkout it runs ``make setup``, then times
``make repair`` (the bundled scan, the Makefile's defaults) twice, each in
its own process (wall time of the whole command: make, interpreter start,
imports, the kernels loaded from their cache, the repair, the write).

What is fresh and what is reused
--------------------------------
* The checkout: ``git archive`` of the commit (of the working tree's state
  when it has uncommitted changes: ``git stash create``) unpacked into a
  temporary folder, so it has no ``__pycache__`` at all: no ``.pyc`` of
  the package, no Numba cache.
* The virtual environment: a new ``.venv`` in the copy (the same base
  interpreter), into which ``make setup`` installs the package (editable,
  as for a user) and runs the warm-ups. The third-party packages (NumPy,
  SciPy, Open3D, Numba, ...) are not downloaded again: a ``.pth`` file
  puts the running environment's ``site-packages`` on the new
  environment's path (their ``.pyc`` were written when they were
  installed, as for a user's ``pip install``).
* The rho_dt table is in the copy (``shellrepair/appearance/reflectance/rho_dt_table.npz``,
  package data): nothing builds it.
* The environment of the commands: a user's (``NUMBA_CACHE_DIR``,
  ``NUMBA_DISABLE_JIT``, ``SHELLREPAIR_NO_NUMBA``, ``PYTHONDONTWRITEBYTECODE``,
  ``PYTHONPATH`` and the calling make's ``MAKEFLAGS`` removed).

Measurement
-----------
The first pair (first, second) is the literal one. The machine is shared
and a 3 s command varies by more than 20 % under load, so the state just
after ``make setup`` (every ``__pycache__`` folder of the copy) is saved
and put back before each further pair: each pair's first run starts from
the disk state a user's first run starts from (the files are in the page
cache in all runs, as they are right after ``make setup``). ``ratio`` is
first / second wall time per pair; the target is judged on the median
over the pairs. ``cpu`` (user + system seconds of the command and its
children) is less disturbed by other load and is given beside it.

Where the first run's extra time would go, recorded for each run:

* ``written``: files the run wrote in the copy (outside ``data/``). A
  kernel compiled at run time writes its ``.nbi`` / ``.nbc`` (Numba saves
  every compilation of a ``cache=True`` function), a module never imported
  during setup its ``.pyc``; both lists are empty when setup did its job.
* a diagnostic pair after the timed ones (state put back again), run with
  ``NUMBA_DEBUG_CACHE=1`` (each kernel index / machine code loaded or
  saved) and ``python -X importtime`` (``PYTHONPROFILEIMPORTTIME=1``): the
  kernels compiled at run time by name, and the import time of each run
  (the sum of the top-level imports, and the largest ones). These two runs
  are slower by the instrumentation and not used for the ratio.

Run it alone with ``python eval/cold_start.py [--pairs 3] [--out f.json]``;
``eval/bench_scale.py`` runs it as its ``cold`` step (once, not per case).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import sysconfig
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The issue's bound: the first run at most this much slower than the second.
BOUND = 0.20
#: Environment variables removed from the commands' environment (see the docstring).
_CLEAR = ("NUMBA_CACHE_DIR", "NUMBA_DISABLE_JIT", "NUMBA_DEBUG_CACHE", "SHELLREPAIR_NO_NUMBA",
          "PYTHONDONTWRITEBYTECODE", "PYTHONPATH", "PYTHONPROFILEIMPORTTIME", "PYTHONPYCACHEPREFIX", "MAKEFLAGS",
          "MFLAGS", "MAKELEVEL", "MAKEOVERRIDES", "VIRTUAL_ENV")
#: The interpreter of the copy's environment, passed to make explicitly so a
#: ``PY=`` given to the calling make can never reach the copy's setup.
PY = ".venv/bin/python"


def fresh_copy(repo, dest):
    """Unpack the repository's current state into ``dest`` (no ``__pycache__``).

    Returns the commit archived (a ``git stash create`` commit when the
    working tree has uncommitted changes to tracked files) and whether it
    was such a snapshot.
    """
    def git(*a):
        return subprocess.run(["git", *a], cwd=repo, capture_output=True, text=True, check=True).stdout.strip()

    snap = git("stash", "create")
    commit = snap or git("rev-parse", "HEAD")
    dest.mkdir(parents=True)
    arch = subprocess.run(["git", "archive", commit], cwd=repo, capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=arch, check=True)
    return commit, bool(snap)


def make_venv(dest):
    """A new ``.venv`` in ``dest`` on this interpreter's base Python, seeing
    this environment's third-party packages through a ``.pth`` file."""
    base = getattr(sys, "_base_executable", None) or sys.executable
    subprocess.run([base, "-m", "venv", str(dest / ".venv")], check=True, capture_output=True)
    py = dest / PY
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                          capture_output=True, text=True, check=True).stdout.strip()
    ours = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    Path(site, "_shellrepair_bench_reuse.pth").write_text("".join(p + "\n" for p in sorted(ours)))
    return sorted(ours)


def user_env(**extra):
    env = {k: v for k, v in os.environ.items() if k not in _CLEAR}
    env.update(extra)
    return env


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(cmd, cwd, env, timeout, stream=None):
    """Run ``cmd``; wall and CPU seconds (the command and every child it
    waited for), status, and its output (each line with the seconds at which
    it came when ``stream`` is true)."""
    c0, t0 = _children_cpu(), time.perf_counter()
    lines = []
    try:
        p = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT if stream
                             else subprocess.PIPE, text=True)
        if stream:
            for line in p.stdout:
                lines.append((round(time.perf_counter() - t0, 2), line.rstrip("\n")))
            p.wait(timeout=timeout)
            out, err = "\n".join(s for _, s in lines), ""
        else:
            out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        return {"status": "timeout", "seconds": time.perf_counter() - t0}
    res = {"status": "ok" if p.returncode == 0 else f"exit {p.returncode}",
           "seconds": time.perf_counter() - t0, "cpu_seconds": _children_cpu() - c0, "stdout": out, "stderr": err}
    if stream:
        res["lines"] = lines
    return res


def file_state(dest):
    """Size and modification time of every file of the copy outside ``data/``."""
    out = {}
    for d, dirs, files in os.walk(dest):
        if Path(d) == dest:
            dirs[:] = [x for x in dirs if x != "data"]
        for f in files:
            p = os.path.join(d, f)
            try:
                st = os.stat(p)
            except OSError:
                continue
            out[os.path.relpath(p, dest)] = (st.st_size, st.st_mtime_ns)
    return out


def written(before, after):
    """Files created or changed between two :func:`file_state` calls."""
    return sorted(k for k, v in after.items() if before.get(k) != v)


def save_caches(dest, tar_path):
    """Every ``__pycache__`` folder of the copy into ``tar_path``."""
    dirs = [os.path.relpath(d, dest) for d, _, _ in os.walk(dest) if os.path.basename(d) == "__pycache__"]
    with tarfile.open(tar_path, "w") as t:
        for d in dirs:
            t.add(dest / d, arcname=d)
    return dirs


def restore_caches(dest, tar_path):
    """Put the ``__pycache__`` folders saved by :func:`save_caches` back
    (folders made since are removed)."""
    for d, _, _ in list(os.walk(dest)):
        if os.path.basename(d) == "__pycache__" and os.path.isdir(d):
            shutil.rmtree(d)
    with tarfile.open(tar_path) as t:
        try:
            t.extractall(dest, filter="tar")
        except TypeError:   # Python without extraction filters
            t.extractall(dest)


_IMPORT = re.compile(r"import time:\s+(\d+)\s+\|\s+(\d+)\s+\|( *)(\S+)")


def import_times(stderr, top=6):
    """Total import seconds (the top-level imports' cumulative times) and
    the largest top-level imports, from ``-X importtime`` output."""
    tops = []
    for line in stderr.splitlines():
        m = _IMPORT.match(line)
        if m and len(m.group(3)) == 1:   # top level: one space after the bar
            tops.append((m.group(4), int(m.group(2)) / 1e6))
    return {"total": sum(s for _, s in tops), "largest": sorted(tops, key=lambda x: -x[1])[:top]}


_NB = re.compile(r"\[cache\] (index|data) (loaded from|saved to) '([^']+)'")


def numba_cache(stdout):
    """Counts of Numba cache loads and saves (``NUMBA_DEBUG_CACHE`` lines);
    a save is a compilation at run time."""
    loads, saves = 0, []
    for kind, what, path in _NB.findall(stdout):
        if what == "saved to":
            if kind == "index":
                saves.append(os.path.basename(path).rsplit(".py", 1)[0])
        elif kind == "data":
            loads += 1
    return {"loaded": loads, "compiled": sorted(set(saves))}


def measure(repo=ROOT, tmp=None, pairs=3, setup_timeout=1800.0, run_timeout=600.0, log=print):
    """Set up a fresh copy and time its first and second ``make repair``.

    Parameters
    ----------
    repo : path
        The checkout to copy.
    tmp : path, optional
        Folder in which the work folder is made (default: the system's
        temporary folder); the copy is removed after.
    pairs : int
        Timed (first, second) pairs; the first is the literal one, the
        others start from the saved post-setup state.

    Returns
    -------
    result : dict
        ``setup`` (status, seconds, per-step lines), ``runs`` (each timed
        run), ``pairs`` (ratios), ``diagnosis`` and the target's verdict
        (see the module docstring). Never raises for a failed step: its
        status says what failed.
    """
    repo = Path(repo)
    work = Path(tempfile.mkdtemp(prefix="cold_start.", dir=tmp))
    dest = work / "shellrepair"
    res = {"bound": BOUND, "pairs_requested": pairs, "runs": [], "pairs": []}
    try:
        res["commit"], res["uncommitted"] = fresh_copy(repo, dest)
        res["reused_site_packages"] = make_venv(dest)
        log(f"cold start: fresh copy of {res['commit'][:10]} in {dest}; make setup ...")
        env = user_env()
        s = run(["make", "--no-print-directory", "setup", f"PY={PY}"], dest, env, setup_timeout, stream=True)
        res["setup"] = {k: s.get(k) for k in ("status", "seconds", "cpu_seconds")}
        res["setup"]["steps"] = [(t, line) for t, line in s.get("lines", []) if line and not line[0].isspace()]
        log(f"  make setup: {s['status']} in {s['seconds']:.0f} s")
        if s["status"] != "ok":
            res["setup"]["output_tail"] = s.get("stdout", "")[-2000:]
            res["status"] = "setup failed"
            return res
        tar = work / "post_setup_caches.tar"
        save_caches(dest, tar)
        cmd = ["make", "--no-print-directory", "repair", f"PY={PY}"]
        for i in range(pairs):
            if i:
                restore_caches(dest, tar)
            pair = []
            for which in ("first", "second"):
                before = file_state(dest)
                r = run(cmd, dest, env, run_timeout)
                row = {"pair": i, "run": which, "status": r["status"], "seconds": r["seconds"],
                       "cpu_seconds": r.get("cpu_seconds"), "written": written(before, file_state(dest))}
                if r["status"] != "ok":
                    row["error"] = (r.get("stderr") or r.get("stdout") or "")[-500:]
                res["runs"].append(row)
                pair.append(row)
                log(f"  pair {i} {which:6s} make repair: {r['status']} {r['seconds']:.2f} s wall, "
                    f"{r.get('cpu_seconds') or 0:.2f} s cpu, {len(row['written'])} files written")
            if all(r["status"] == "ok" for r in pair):
                res["pairs"].append({"pair": i, "ratio": pair[0]["seconds"] / pair[1]["seconds"],
                                     "cpu_ratio": pair[0]["cpu_seconds"] / pair[1]["cpu_seconds"]})
        restore_caches(dest, tar)
        diag = []
        for which in ("first", "second"):
            r = run(cmd, dest, user_env(NUMBA_DEBUG_CACHE="1", PYTHONPROFILEIMPORTTIME="1"), run_timeout)
            diag.append({"run": which, "status": r["status"], "seconds": r["seconds"],
                         "cpu_seconds": r.get("cpu_seconds"), "imports": import_times(r.get("stderr", "")),
                         "numba": numba_cache(r.get("stdout", ""))})
            log(f"  diagnosis {which:6s}: {r['seconds']:.2f} s, imports {diag[-1]['imports']['total']:.2f} s, "
                f"{diag[-1]['numba']['loaded']} kernels loaded, {len(diag[-1]['numba']['compiled'])} compiled")
        res["diagnosis"] = diag
        res["status"] = "ok" if res["pairs"] else "runs failed"
        res.update(verdict(res))
        return res
    except (OSError, subprocess.SubprocessError) as e:
        res["status"] = f"error: {e}"
        return res
    finally:
        shutil.rmtree(work, ignore_errors=True)


def verdict(res):
    """The target, judged on the median pair ratio, with what the first runs wrote."""
    if not res.get("pairs"):
        return {}
    med = statistics.median(p["ratio"] for p in res["pairs"])
    cpu = statistics.median(p["cpu_ratio"] for p in res["pairs"])
    firsts = [r for r in res["runs"] if r["run"] == "first"]
    wrote = sorted({f for r in firsts for f in r["written"]})
    return {"median_ratio": med, "median_cpu_ratio": cpu, "first_runs_wrote": wrote,
            "target_met": med <= 1.0 + BOUND and not [f for f in wrote if f.endswith((".nbi", ".nbc"))]}


def target(res):
    """``(met, why)`` for the scale benchmark's target list."""
    if res.get("status") != "ok":
        return False, res.get("status", "not run")
    r0 = [r for r in res["runs"] if r["pair"] == 0]
    per = ", ".join(f"{p['ratio']:.2f}" for p in res["pairs"])
    return res["target_met"], (f"first {r0[0]['seconds']:.2f} s, second {r0[1]['seconds']:.2f} s; first/second "
                               f"per pair {per}, median {res['median_ratio']:.2f} "
                               f"(cpu {res['median_cpu_ratio']:.2f}); kernels compiled at run time: "
                               f"{_compiled(res) or 'none'}")


def _compiled(res):
    names = sorted({n for d in res.get("diagnosis", []) for n in d["numba"]["compiled"]}
                   | {Path(f).name for f in res.get("first_runs_wrote", []) if f.endswith(".nbi")})
    return ", ".join(names)


def markdown(res):
    """The benchmark report's section (a list of lines)."""
    L = ["## First and second `make repair` after `make setup` (issue 14)", "",
         "A fresh copy of the checkout (no `__pycache__`), its own `.venv` set up by `make setup` (the "
         "third-party packages reused from the running environment, not downloaded; how: "
         "`eval/cold_start.py`'s docstring), then `make repair` (the bundled scan) timed twice, each a new "
         "process, wall time of the whole command. Pairs after the first start again from the saved "
         "post-setup state.", ""]
    if res.get("status") != "ok":
        return L + [f"Not measured: {res.get('status')}.", ""]
    st = res["setup"]
    L += [f"`make setup` {st['seconds']:.0f} s.", "",
          "| pair | first s | second s | first / second | first cpu s | second cpu s | cpu ratio | "
          "files the first run wrote |", "|---:|---:|---:|---:|---:|---:|---:|---|"]
    for p in res["pairs"]:
        a, b = [r for r in res["runs"] if r["pair"] == p["pair"]]
        L.append(f"| {p['pair']} | {a['seconds']:.2f} | {b['seconds']:.2f} | {p['ratio']:.2f} | "
                 f"{a['cpu_seconds']:.2f} | {b['cpu_seconds']:.2f} | {p['cpu_ratio']:.2f} | "
                 f"{', '.join(a['written']) or 'none'} |")
    L += ["", f"Median first / second {res['median_ratio']:.2f} (cpu {res['median_cpu_ratio']:.2f}); "
          f"bound {1 + BOUND:.2f}: {'met' if res['target_met'] else '**not met**'}."]
    d = res.get("diagnosis")
    if d and len(d) == 2:
        f, s = d
        top = lambda x: ", ".join(f"{n} {t:.2f}" for n, t in x["imports"]["largest"][:4])  # noqa: E731
        L += ["", f"Diagnosis pair (`NUMBA_DEBUG_CACHE=1`, `-X importtime`; slower by the instrumentation): "
              f"first {f['seconds']:.2f} s, imports {f['imports']['total']:.2f} s ({top(f)}), "
              f"{f['numba']['loaded']} kernels loaded from the cache, {len(f['numba']['compiled'])} compiled; "
              f"second {s['seconds']:.2f} s, imports {s['imports']['total']:.2f} s, "
              f"{s['numba']['loaded']} loaded, {len(s['numba']['compiled'])} compiled."
              + (f" Compiled at run time: {_compiled(res)}." if _compiled(res) else "")]
    return L + [""]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--tmp", default=None)
    ap.add_argument("--out", default=None, help="write the result as JSON here")
    args = ap.parse_args(argv)
    res = measure(tmp=args.tmp, pairs=args.pairs, log=lambda *a: print(*a, flush=True))
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1, default=float) + "\n")
    print("\n".join(markdown(res)))
    ok, why = target(res)
    print(f"target first make repair within {BOUND:.0%} of the second: {'met' if ok else 'NOT met'} ({why})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
