"""A helper thread beside a run's fills (``jobs`` > 1 with one process).

:class:`HelperThread` runs the calls submitted to it on one thread, the
lowest key first; :class:`Beside` is the work it does for a run's
``order="auto"`` holes (each hole's order test and order-3 patch), taken
by the fill (:mod:`shellrepair.fill.hole`) or cancelled and done there: the
output is the same bits with or without the helper.
"""

from __future__ import annotations

import contextlib
import sys
import threading

import numpy as np

from shellrepair.counted import CountedSetting
from shellrepair.fill.patch import HoleUnit, PatchError, build_patch

__all__ = ["HelperThread", "Beside", "SWITCH_SECONDS"]


#: The interpreter's thread switch interval (seconds) while a helper thread
#: works beside the fill. Both threads spend most of their time in compiled
#: kernels and solves that release the GIL, but take it back between them;
#: a thread asking for it back waits until the holder drops it, at most
#: this long. Measured beside a thread running Python code, on the 1.3M
#: two-disc case's large hole (11,847 unknowns, order 3): its factorisation
#: took 1.44x its time alone at Python's default of 5 ms and 1.03x at
#: 0.2 ms; its energy's assembly 1.76x and 1.19x.
SWITCH_SECONDS = 2e-4
def _short_interval():
    before = sys.getswitchinterval()
    sys.setswitchinterval(min(before, SWITCH_SECONDS))
    return before


#: Within a block ``with _short_switch_interval():``, the interpreter's
#: switch interval at most ``SWITCH_SECONDS``; put back when the last open
#: block ends (the helpers of overlapping fills, in any thread).
_short_switch_interval = CountedSetting(_short_interval, sys.setswitchinterval)


class HelperThread:
    """One thread that runs the calls submitted to it, the lowest key first
    (a context manager: leaving it waits for what was submitted, skipping
    what was cancelled, and puts the interpreter's switch interval and the
    BLAS libraries' global thread counts back,
    :func:`~shellrepair.blas.one_thread_everywhere`).
    The fill's helper beside a run (:class:`Beside`)."""

    def __init__(self, name="shellrepair-beside"):
        import itertools
        import queue

        from shellrepair.blas import one_thread_everywhere

        self._queue = queue.PriorityQueue()
        self._serial = itertools.count()       # ties in submission order
        self._settings = contextlib.ExitStack()
        self._settings.enter_context(_short_switch_interval())
        self._settings.enter_context(one_thread_everywhere())   # two threads' BLAS calls side by side, not in turn
        self._thread = threading.Thread(target=self._serve, name=name, daemon=True)
        self._thread.start()

    def submit(self, key, f, *args):
        """Run ``f(*args)`` on the thread, before every call of a larger
        ``key`` (a tuple) not begun; returns its
        :class:`concurrent.futures.Future`."""
        from concurrent.futures import Future

        future = Future()
        self._queue.put((tuple(key), next(self._serial), future, f, args))
        return future

    def _serve(self):
        while True:
            _, _, future, f, args = self._queue.get()
            if future is None:
                return
            if not future.set_running_or_notify_cancel():
                continue                               # cancelled before it began
            try:
                future.set_result(f(*args))
            except BaseException as exc:               # handed to whoever takes the result
                future.set_exception(exc)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._queue.put(((float("inf"),), next(self._serial), None, None, None))
        self._thread.join()
        self._settings.close()


class _Stolen:
    """A result computed on the fill's thread in place of the helper's
    (:meth:`Beside._steal`): its value, or the exception it raised, given
    back when taken, as a future's."""

    def __init__(self, f, *args):
        try:
            self.value, self.error = f(*args), None
        except Exception as exc:
            self.value, self.error = None, exc

    def cancel(self):
        return False

    def result(self):
        if self.error is not None:
            raise self.error
        return self.value


class _Failed:
    """A build on the helper thread raised :class:`PatchError`."""


class Beside:
    """Work a helper thread does beside a run's fills, for its
    ``order="auto"`` holes (:func:`~shellrepair.fill.runs.run_chunk` with a ``pool``):

    * each hole's order test (:func:`~shellrepair.fill.selftest.choose_order`),
      all queued at once, the longest rims first (ties in hole order);
    * each hole's order-3 patch, started by :func:`~shellrepair.fill.runs.first_attempts` as soon
      as the hole's first triangulation is refined (:meth:`start_o3`),
      built only where the hole's test asks for order 3. :func:`~shellrepair.fill.hole.fill_hole`
      builds that same patch from the order-2 fill's triangulation, which
      is this refined one where the first option passed (the fairing's
      first solve does not read the new vertices' starting positions).

    The fill takes each result (:meth:`take_test`, :meth:`take_o3`), or
    cancels what the helper has not begun and does it itself: the output
    is the same bits with or without the helper (the helper's work reads
    only the scan and the batch's first-attempt work; its compiled
    kernels and solves release the GIL, and its BLAS calls run on its own
    thread as the fill's do).

    Parameters
    ----------
    ctx : ScanContext
        The scan the run fills.
    chunk : sequence of HoleUnit, BandUnit or PantsUnit
        The run's units; its ``order="auto"`` holes get the helper's work.
    pool : HelperThread
        The thread that does it.
    memo : optional
        The run's first-solve memo (:func:`shellrepair.fill.fair.first_solve_memo`),
        shared with the helper.
    """

    def __init__(self, ctx, chunk, pool, memo=None):
        from shellrepair.fill.selftest import choose_order

        self.pool = pool
        self.ctx = ctx
        self.memo = memo
        self.helper = ctx.for_helper()
        self.tests = {}        # hole id -> (loop, future of its OrderTest)
        self.o3 = {}           # hole id -> (refined T, future of its order-3 Patch, None or _Failed)
        self.place = {}        # hole id -> its place in the helper's queue: a hole's test, then its
        # order-3 patch, before the next hole's test; the largest rims first
        # (their tests and order-3 patches are the longest work: the fill's
        # thread runs the small holes' tests itself when it reaches them,
        # :meth:`take_test`, instead of waiting at the end for a large one)
        auto = [(i, u) for i, u in enumerate(chunk) if isinstance(u, HoleUnit) and u.order == "auto"]
        ranked = sorted(auto, key=lambda iu: (-len(iu[1].loop), iu[0]))
        self.place.update((u.hole_id, rank) for rank, (_, u) in enumerate(ranked))
        for _, u in auto:
            loop = np.asarray(u.loop, np.int64)
            self.tests[u.hole_id] = (loop, pool.submit((self.place[u.hole_id], 0), self._on_helper, choose_order,
                                                       self.helper, u.hole_id, loop))

    def _on_helper(self, f, *args):
        from shellrepair.blas import one_thread
        from shellrepair.fill.fair import first_solve_memo

        first_solve_memo(self.memo)     # the run's first solves, as the fill's thread sees them
        try:
            with one_thread():          # this thread's BLAS calls on this thread, as the fill's are
                return f(*args)
        finally:
            first_solve_memo(False)

    def drop_test(self, hole_id):
        """The hole needs no order test: cancel it if the helper has not begun it."""
        got = self.tests.pop(hole_id, None)
        if got is not None and not isinstance(got[1], _Stolen):
            got[1].cancel()

    def take_test(self, hole_id, loop):
        """The hole's order test, or None where it has not begun (cancelled:
        the caller runs it) or was made for another loop. While the helper
        is still on it, the caller runs the next tests the helper has not
        begun (:meth:`_steal`)."""
        got = self.tests.pop(hole_id, None)
        if got is None:
            return None
        made_for, future = got
        if not np.array_equal(made_for, loop):
            future.cancel()
            return None
        if isinstance(future, _Stolen):
            return future.result()
        if future.cancel():
            return None
        while not future.done() and self._steal():
            pass
        return future.result()

    def _steal(self):
        """Run here (the fill's thread) the first test the helper has not
        begun, kept for :meth:`take_test`; False when there is none."""
        from shellrepair.fill.selftest import choose_order

        for hole_id, (loop, future) in self.tests.items():    # in hole order
            if not isinstance(future, _Stolen) and future.cancel():
                self.tests[hole_id] = (loop, _Stolen(choose_order, self.ctx, hole_id, loop))
                return True
        return False

    def start_o3(self, pre, hole_id, loop, smooth, T0):
        """Start the order-3 patch of a hole whose first option is the
        order-2 fairing of ``T0``: refine ``T0`` here, as
        :func:`~shellrepair.fill.patch.build_patch` would (kept in ``pre``, which
        the order-2 build then reads), and fair it at order 3 on the
        helper once the hole's test asks for order 3."""
        from shellrepair.fill.patch import refine_patch, split_chords

        got = self.tests.get(hole_id)
        if got is None or pre.T0 is None or not np.array_equal(T0, pre.T0):
            return
        sigma, _, forbidden = pre.rim
        origin, scale, Pl0 = pre.frame
        Pl, T = pre.refined_once(lambda: refine_patch(Pl0, pre.T0, sigma / scale, len(loop), forbidden))
        if len(pre.T0) == len(loop) - 2:    # a disc: its chords split as the faired fill's (build_patch)
            Pl, T = split_chords(Pl, T, sigma / scale, len(loop), forbidden)
        P = origin + scale * Pl[len(loop):]
        test = got[1]

        def build():
            if test.cancelled() or test.exception() is not None or test.result().order != 3:
                return None
            try:
                return build_patch(self.helper, hole_id, loop, order=3, smooth=smooth, initial=(P, T), refine=False)
            except PatchError:
                return _Failed

        self.o3[hole_id] = (T, self.pool.submit((self.place[hole_id], 1), self._on_helper, build))

    def take_o3(self, hole_id, T):
        """(True, the order-3 patch or None where building it failed), or
        (False, None) where the caller builds it (not begun, not asked
        for, or made from another triangulation)."""
        got = self.o3.pop(hole_id, None)
        if got is None:
            return False, None
        made_from, future = got
        if future.cancel() or not np.array_equal(made_from, T):
            return False, None
        p3 = future.result()
        if p3 is None:
            return False, None
        return True, (None if p3 is _Failed else p3)

    def cancel(self):
        """Cancel what has not begun (a unit raised, or a result not taken)."""
        for _, future in list(self.tests.values()) + list(self.o3.values()):
            future.cancel()
        self.tests, self.o3 = {}, {}
