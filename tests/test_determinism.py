"""The same scan and options give the same bytes, however slow the machine.

No decision of the fill may depend on the wall clock: a slow or loaded
machine must write the file a fast idle one writes. These tests repair
cases whose holes need retries (re-routed chords, pinned rounds, the last
layer) once normally and once under a clock that races ahead by
``RACE_SECONDS`` at every read, as if each step had taken minutes, and
compare the written files byte for byte. Before the fill's budget was made
counted-only (a wall-clock backstop of 3 s + 4 ms per rim edge), the raced
run gave up retries after the first round and wrote a different file.
"""

import time

import numpy as np
import pytest

from eval import stress
from shellrepair import Mesh, read_mesh, write_mesh
from shellrepair.repair import repair_mesh

#: Seconds the raced clock advances at every read: past any time budget at once.
RACE_SECONDS = 1000.0


class _RacingClock:
    """A ``perf_counter`` / ``monotonic`` / ``time`` that advances
    ``RACE_SECONDS`` every time it is read."""

    def __init__(self):
        self.t = time.perf_counter()
        self.reads = 0

    def __call__(self):
        self.reads += 1
        self.t += RACE_SECONDS
        return self.t


def _written(tmp_path, name, mesh):
    path = tmp_path / f"{name}.ply"
    write_mesh(path, mesh)
    return path.read_bytes()


def _repair_bytes(tmp_path, name, V, F, raced, monkeypatch, **options):
    clock = None
    if raced:
        clock = _RacingClock()
        monkeypatch.setattr(time, "perf_counter", clock)
        monkeypatch.setattr(time, "monotonic", clock)
        monkeypatch.setattr(time, "time", clock)
    try:
        out, report = repair_mesh(Mesh(np.array(V, np.float64), np.array(F, np.int64)), **options)
    finally:
        monkeypatch.undo()
    if raced:
        assert clock.reads > 0, "the raced clock was never read: the test would prove nothing"
    return _written(tmp_path, name + ("-raced" if raced else ""), out), report


def _stress_case(index, seed):
    case = stress.stress_case(index, seed, quick=True)
    return case.V, case.F


#: Stress cases (design seeds, ``quick``): a band on a thin torus whose
#: caps take several rounds (the old wall-clock backstop changed its bytes
#: under the raced clock), a scanner's occlusion and a slit.
CASES = [(5, 4), (1, 4), (3, 1)]


@pytest.mark.parametrize("index,seed", CASES)
@pytest.mark.slow
def test_a_repair_under_a_racing_clock_writes_the_same_bytes(tmp_path, monkeypatch, index, seed):
    V, F = _stress_case(index, seed)
    calm, report = _repair_bytes(tmp_path, f"s{seed}-{index}", V, F, False, monkeypatch)
    raced, _ = _repair_bytes(tmp_path, f"s{seed}-{index}", V, F, True, monkeypatch)
    assert calm == raced, "the written mesh depends on how fast the clock ran"


def test_the_bundled_scan_under_a_racing_clock_writes_the_same_bytes(tmp_path, monkeypatch):
    from pathlib import Path
    scan = read_mesh(Path(__file__).resolve().parents[1] / "data" / "bunny_zipper.ply")
    calm, _ = _repair_bytes(tmp_path, "bunny", scan.V, scan.F, False, monkeypatch)
    raced, _ = _repair_bytes(tmp_path, "bunny", scan.V, scan.F, True, monkeypatch)
    assert calm == raced


def test_the_last_layer_under_a_racing_clock_writes_the_same_bytes(tmp_path, monkeypatch):
    # a window round a pipe, a bore through it: every earlier layer fails
    # (re-routed chords, mending) and the Steiner layer cuts it in pieces;
    # the budget of all of it is counted, so the bytes are the same
    import cad_parts

    V, F, _ = cad_parts.pipe_with_wrapped_window(bore=(1.5, 0.35, 1.6))
    calm, report = _repair_bytes(tmp_path, "pipe", V, F, False, monkeypatch, closed=True)
    raced, _ = _repair_bytes(tmp_path, "pipe", V, F, True, monkeypatch, closed=True)
    assert report["holes"][0]["option"].startswith("Steiner points")
    assert calm == raced
