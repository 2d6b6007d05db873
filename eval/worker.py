"""Run fill functions in a child process, with a timeout, and measure them.

One child process per tool serves the cases one after another (importing a
C++ library once, not per case). For each case the parent sends the path of
the case's ``.npz`` (``V``, ``F``) and where to write the result; the child
runs the fill, writes ``V``, ``F`` to the result ``.npz`` and answers with
the tool's ``info``, the wall seconds of the whole call and the peak memory.

* A call that does not answer within ``timeout`` seconds is recorded as
  ``timeout``; the child is killed and a fresh one serves the next case.
* A child that dies (segfault, abort, out of memory) is recorded as
  ``crashed`` with its exit code, and replaced.
* A Python exception in the tool is ``failed`` with its message.
* A tool whose package is missing is ``missing``.

Peak memory is the growth of the child's resident set during the call
above what was live before it (the input arrays): before the call the
child collects garbage and hands freed heap pages back to the system
(``malloc_trim``, which also releases free pages inside the heap, so
memory reused from an earlier case counts again when touched), then resets
the kernel's high-water mark (``VmHWM``) by writing ``5`` to
``/proc/self/clear_refs`` (Linux >= 4.0). Where that is not possible,
``ru_maxrss`` is used, which is the peak over the child's life, and
``memory_method`` says so.

Children run with the allocator's and NumPy's settings as a user's
process has them, except that NumPy's huge-page advice is off in every
child, as the command line turns it off (see
:func:`shellrepair.cli.quiet_hugepages`). (An earlier version forced
glibc's mmap threshold to 1 MB in the children, so every large temporary
array was mapped afresh: on a 1M-face case that cost our fill and
MeshLib's alike about a quarter of their time, which no user pays, so it
is gone.)

Before serving, the child runs the tool once on a tiny perforated sphere,
so one-time start-up is not charged to the first case.

The child's stdout and stderr (C++ libraries print there) go to
``<tmp>/<tool>.log``, so the benchmark's own output stays readable.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import time
import traceback
from pathlib import Path

import numpy as np

__all__ = ["ToolRunner", "peak_memory_reset", "peak_memory_mb"]



def _status_kb(key):
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def _release_free_memory():
    import gc

    gc.collect()
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def peak_memory_reset():
    """Reset the high-water mark of resident memory; returns the method used."""
    _release_free_memory()
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return "VmHWM"
    except OSError:
        return "ru_maxrss"


def peak_memory_mb(method, rss0_kb):
    """Peak resident memory above ``rss0_kb`` since the reset, in MB."""
    if method == "VmHWM":
        hwm = _status_kb("VmHWM")
        if hwm is not None:
            return max(0.0, (hwm - rss0_kb) / 1024.0)
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _warm_up(peers, tool):
    """Run the tool once on a tiny perforated sphere, so one-time start-up
    (library loading, thread pools) is not charged to the first case."""
    from eval import shapes

    try:
        V, F = shapes.icosphere(2)
        V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=1, radius=0.4, seed=0)
        peers.run_tool(tool, V2, F2)
    except Exception:  # the real call will report it
        pass


def _serve(conn, tool, log_path):
    """Child main loop: receive (case_npz, out_npz), run, answer."""
    fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    from eval import peers
    from shellrepair.cli import quiet_hugepages

    quiet_hugepages()  # as the command line does; the same for every tool's child

    _warm_up(peers, tool)
    while True:
        try:
            msg = conn.recv()
        except EOFError:
            return
        if msg is None:
            return
        case_npz, out_npz = msg
        try:
            data = np.load(case_npz)
            V, F = data["V"], data["F"]
            method = peak_memory_reset()
            rss0 = _status_kb("VmRSS") or 0
            t0 = time.perf_counter()
            Vo, Fo, info = peers.run_tool(tool, V, F)
            wall = time.perf_counter() - t0
            mem = peak_memory_mb(method, rss0)
            np.savez(out_npz, V=np.asarray(Vo, np.float64), F=np.asarray(Fo, np.int64))
            conn.send({"status": "ok", "info": info, "wall_seconds": wall, "peak_mb": mem,
                       "memory_method": method})
        except peers.ToolMissing as exc:
            conn.send({"status": "missing", "error": str(exc)})
        except Exception as exc:  # the tool failed on this case
            tb = traceback.format_exc(limit=6)
            conn.send({"status": "failed", "error": f"{type(exc).__name__}: {exc}"[:500], "traceback": tb})


class ToolRunner:
    """A child process serving one tool; restarted after a timeout or crash.

    Parameters
    ----------
    tool : str
        A name in :data:`eval.peers.TOOLS`.
    tmp : Path
        Folder for the log and the result files.
    timeout : float
        Seconds per case.
    """

    def __init__(self, tool, tmp, timeout=120.0):
        self.tool = tool
        self.tmp = Path(tmp)
        self.timeout = float(timeout)
        self.proc = None
        self.conn = None
        self._ctx = mp.get_context("spawn")

    def _start(self):
        parent, child = self._ctx.Pipe()
        log = str(self.tmp / f"{self.tool}.log")
        self.proc = self._ctx.Process(target=_serve, args=(child, self.tool, log), daemon=True)
        self.proc.start()
        child.close()
        self.conn = parent

    def _stop(self, kill=False):
        if self.proc is None:
            return
        if kill:
            self.proc.kill()
        else:
            try:
                self.conn.send(None)
            except (BrokenPipeError, OSError):
                pass
        self.proc.join(5)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join(5)
        self.conn.close()
        self.proc = self.conn = None

    def run(self, case_npz, out_npz):
        """Run the tool on one case.

        Returns
        -------
        res : dict
            ``status`` (ok / failed / missing / timeout / crashed) and, when
            ok, ``info``, ``wall_seconds``, ``peak_mb``; the result arrays
            are in ``out_npz``.
        """
        if self.proc is None or not self.proc.is_alive():
            self._start()
        t0 = time.perf_counter()
        try:
            self.conn.send((str(case_npz), str(out_npz)))
            if not self.conn.poll(self.timeout):
                self._stop(kill=True)
                return {"status": "timeout", "error": f"no answer within {self.timeout:g} s",
                        "wall_seconds": time.perf_counter() - t0}
            return self.conn.recv()
        except (EOFError, BrokenPipeError, ConnectionResetError, OSError):
            self.proc.join(5)
            code = self.proc.exitcode
            self._stop(kill=True)
            return {"status": "crashed", "error": f"the process died (exit code {code})",
                    "wall_seconds": time.perf_counter() - t0}

    def close(self):
        self._stop()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
