"""With more than one job, a second thread works beside the fills of
``order="auto"``: it runs the holes' order tests and builds the order-3
patches the tests ask for. The meshes and reports are the same, to the bit,
as one thread's."""

import threading

import numpy as np
import pytest

import shellrepair.repair as repair
import shellrepair.fill.selftest as selftest
from eval import shapes
from shellrepair import repair_mesh
from shellrepair.fill.beside import Beside
from shellrepair.mesh.io import Mesh
from shellrepair.fill.patch import HoleUnit


@pytest.fixture(scope="module")
def smooth_holes():
    """A smooth sphere with holes of several sizes; the largest takes order 3."""
    V, F = shapes.icosphere(5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[int(np.argmax(V[:, 2])), int(np.argmin(V[:, 0])),
                                                         int(np.argmax(V[:, 1])), int(np.argmin(V[:, 2]))],
                                          radius=0.6)
    V3, F3, _, _ = shapes.perforate_discs(V2, F2, n_holes=3, radius=0.15, seed=4)
    return Mesh(V=V3, F=F3)


def _record_threads(monkeypatch):
    """The thread each order test runs on."""
    seen = []
    real = selftest.choose_order

    def recording(*args, **kwargs):
        seen.append(threading.current_thread().name)
        return real(*args, **kwargs)

    monkeypatch.setattr(selftest, "choose_order", recording)
    return seen


def _same(a, b):
    return (np.array_equal(a.V, b.V) and np.array_equal(a.F, b.F)
            and np.array_equal(a.face_filled, b.face_filled))


def _without_times(report):
    return [{k: v for k, v in h.items() if k != "seconds"} for h in report["holes"]]


@pytest.mark.slow
def test_the_helper_tests_and_builds_order_3_and_changes_no_bit(smooth_holes, monkeypatch):
    seen = _record_threads(monkeypatch)
    taken = []
    real_take = Beside.take_o3

    def take(self, hole_id, T):
        got = real_take(self, hole_id, T)
        taken.append(got[0])
        return got

    monkeypatch.setattr(Beside, "take_o3", take)
    one, rep1 = repair_mesh(smooth_holes, jobs=1)
    on_main = list(seen)
    seen.clear()
    two, rep2 = repair_mesh(smooth_holes, jobs=2)
    assert on_main and all(name == "MainThread" for name in on_main)
    assert len(seen) == len(on_main)                         # the same tests, some on the helper
    assert any(name.startswith("shellrepair-beside") for name in seen)
    assert sum("faired order 3" in h["option"] for h in rep2["holes"]) >= 1
    assert True in taken                                     # an order-3 patch built by the helper
    assert _same(one, two)
    assert _without_times(rep1) == _without_times(rep2)
    assert rep2["holes_after"] == 0


@pytest.mark.slow
def test_work_the_helper_has_not_begun_is_done_by_the_fill(smooth_holes, monkeypatch):
    """The fill takes back what the helper has not begun (it cancels it)
    and does it itself: the same output."""
    one, _ = repair_mesh(smooth_holes, jobs=1)
    gate = threading.Event()
    real_init, real_chunk = Beside.__init__, repair.run_chunk

    def held(self, ctx, chunk, pool, *args):
        pool.submit((-1,), gate.wait, 60)       # the helper is busy until the run's fills are done
        real_init(self, ctx, chunk, pool, *args)

    def run_then_open(*args, **kwargs):
        try:
            return real_chunk(*args, **kwargs)
        finally:
            gate.set()

    monkeypatch.setattr(Beside, "__init__", held)
    monkeypatch.setattr(repair, "run_chunk", run_then_open)
    seen = _record_threads(monkeypatch)
    try:
        two, rep = repair_mesh(smooth_holes, jobs=2)
    finally:
        gate.set()
    assert seen and all(name == "MainThread" for name in seen)
    assert _same(one, two) and rep["holes_after"] == 0


def test_the_helper_takes_the_largest_holes_first(monkeypatch):
    """The helper's queue holds each hole's order test, then its order-3
    patch, the longest rims first (ties in hole order): the fill's thread
    runs the small holes' tests it reaches first, instead of waiting at the
    end for a large hole the helper began late."""
    from concurrent.futures import Future

    class Queue:                      # records what is submitted, runs nothing
        def __init__(self):
            self.keys = []

        def submit(self, key, f, *args):
            self.keys.append((key, args[2]))       # (key, hole id)
            return Future()

    class Context:                    # a scan context whose helper copy is itself
        def for_helper(self):
            return self

    rims = {0: 12, 1: 300, 2: 40, 3: 300, 4: 9, 5: 41}          # hole id -> rim edges, not in size order
    chunk = [HoleUnit(h, np.arange(k), "auto", None) for h, k in rims.items()]
    chunk.insert(2, HoleUnit(9, np.arange(500), 2, None))   # a fixed order: no test, no place
    pool = Queue()
    beside = Beside(Context(), chunk, pool)
    assert sorted(beside.place, key=beside.place.get) == [1, 3, 5, 2, 0, 4]
    assert sorted(pool.keys) == [((0, 0), 1), ((1, 0), 3), ((2, 0), 5), ((3, 0), 2), ((4, 0), 0), ((5, 0), 4)]
    assert list(beside.tests) == [0, 1, 2, 3, 4, 5]             # the fill steals tests in hole order


def _repair_in_a_daemon(mesh, queue):
    from shellrepair import repair_mesh as repair

    R, rep = repair(mesh, jobs=2)
    queue.put((R.V, R.F, rep["holes_after"]))


@pytest.mark.slow
def test_a_daemonic_process_fills_its_runs_itself():
    """A worker of a multiprocessing pool may not start processes: with
    more runs of holes than one, ``jobs=2`` there fills them in its own
    process (the helper thread beside), the same bits as ``jobs=1``."""
    import multiprocessing as mp

    V, F = shapes.icosphere(4)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=30, radius=0.09, seed=5)
    mesh = Mesh(V=V2, F=F2)
    one, rep = repair_mesh(mesh, jobs=1)
    assert rep["holes_before"] > repair.BATCH
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_repair_in_a_daemon, args=(mesh, queue), daemon=True)
    child.start()
    V3, F3, left = queue.get(timeout=120)
    child.join(30)
    assert child.exitcode == 0
    assert left == 0 and np.array_equal(one.V, V3) and np.array_equal(one.F, F3)
