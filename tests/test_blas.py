"""The fill runs its BLAS calls on one thread (shellrepair.blas): set for
the calling thread, put back afterwards, and the output does not depend on it."""

import numpy as np
import pytest

from shellrepair import blas
from shellrepair.repair import _repair_mesh, repair_mesh


def needs_openblas():
    fs = blas.setters()
    if not fs:
        pytest.skip("no bundled OpenBLAS with a per-thread setting (NumPy/SciPy linked to another BLAS)")
    return fs


def test_one_thread_inside_and_the_count_put_back():
    fs = needs_openblas()
    before = [f(3) for f in fs]
    try:
        with blas.one_thread():
            assert [f(1) for f in fs] == [1] * len(fs)
        assert [f(3) for f in fs] == [3] * len(fs)
        with pytest.raises(RuntimeError):
            with blas.one_thread():
                raise RuntimeError("a failed fill")
        assert [f(3) for f in fs] == [3] * len(fs)
    finally:
        for f, b in zip(fs, before):
            f(b)


@pytest.fixture
def counts_at_3():
    """The bundled libraries' global thread counts set to 3 (put back
    after); their (get, set) pairs."""
    gs = blas._global_setters()
    if not gs:
        pytest.skip("no bundled OpenBLAS with a global thread-count setter")
    before = [get() for get, _ in gs]
    for _, put in gs:
        put(3)
    yield gs
    for (_, put), b in zip(gs, before):
        put(b)


def test_one_thread_everywhere_sets_the_global_counts_and_puts_them_back(counts_at_3):
    gs = counts_at_3
    with pytest.raises(RuntimeError):
        with blas.one_thread_everywhere():
            assert [get() for get, _ in gs] == [1] * len(gs)
            raise RuntimeError("a failed fill")
    assert [get() for get, _ in gs] == [3] * len(gs)


def test_overlapping_blocks_put_the_counts_back_when_the_last_ends(counts_at_3):
    """Two fills with helpers in two threads of one caller: the blocks
    overlap, and the first to end must not give the other back its
    libraries' threads."""
    gs = counts_at_3
    first, second = blas.one_thread_everywhere(), blas.one_thread_everywhere()
    first.__enter__()
    second.__enter__()
    first.__exit__(None, None, None)
    assert [get() for get, _ in gs] == [1] * len(gs)
    second.__exit__(None, None, None)
    assert [get() for get, _ in gs] == [3] * len(gs)


def test_the_helper_thread_puts_the_switch_interval_and_blas_counts_back():
    import sys

    from shellrepair.fill import SWITCH_SECONDS, HelperThread

    gs = blas._global_setters()
    interval = sys.getswitchinterval()
    counts = [get() for get, _ in gs]
    with HelperThread() as helper:
        assert sys.getswitchinterval() == pytest.approx(min(interval, SWITCH_SECONDS), rel=1e-6)
        assert [get() for get, _ in gs] == [1] * len(gs)
        got = helper.submit((1,), lambda: 2)
        first = helper.submit((0,), lambda: 1)
        assert (first.result(), got.result()) == (1, 2)
    assert sys.getswitchinterval() == pytest.approx(interval, rel=1e-6)
    assert [get() for get, _ in gs] == counts
    # overlapping helpers (two fills in two threads of one caller): the last to end puts them back
    a, b = HelperThread(), HelperThread()
    a.__enter__()
    b.__enter__()
    a.__exit__(None, None, None)
    assert sys.getswitchinterval() == pytest.approx(min(interval, SWITCH_SECONDS), rel=1e-6)
    b.__exit__(None, None, None)
    assert sys.getswitchinterval() == pytest.approx(interval, rel=1e-6)
    assert [get() for get, _ in gs] == counts


def perforated_sphere(n=40, holes=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)), radius=0.45):
    """A UV sphere with two disc holes, large enough for the sparse fairing path."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 2 * n, endpoint=False), np.linspace(0, np.pi, n + 1)[1:-1])
    V = np.column_stack([np.cos(u).ravel() * np.sin(v).ravel(), np.sin(u).ravel() * np.sin(v).ravel(),
                         np.cos(v).ravel()])
    V = np.vstack([V, [[0, 0, 1.0], [0, 0, -1.0]]])
    m, w = n - 1, 2 * n
    idx = np.arange(m * w).reshape(m, w)
    F = []
    for i in range(m - 1):
        for j in range(w):
            a, b, c, d = idx[i, j], idx[i, (j + 1) % w], idx[i + 1, j], idx[i + 1, (j + 1) % w]
            F += [[a, c, b], [b, c, d]]
    top, bot = len(V) - 2, len(V) - 1
    for j in range(w):
        F += [[top, idx[0, j], idx[0, (j + 1) % w]], [bot, idx[m - 1, (j + 1) % w], idx[m - 1, j]]]
    F = np.array(F, np.int64)
    C = V[F].mean(axis=1)
    C /= np.linalg.norm(C, axis=1, keepdims=True)
    keep = np.ones(len(F), bool)
    for d in holes:
        keep &= np.linalg.norm(C - np.asarray(d), axis=1) > radius
    return V, F[keep]


def test_output_does_not_depend_on_the_blas_thread_count():
    fs = needs_openblas()
    V, F = perforated_sphere()
    ours, rep = repair_mesh((V, F), order=3)
    assert rep["holes_after"] == 0 and rep["holes_before"] == 2
    before = [f(2) for f in fs]            # two threads, as OpenBLAS's default on two cores
    try:
        two, _ = _repair_mesh((V, F), order=3)
    finally:
        for f, b in zip(fs, before):
            f(b)
    assert np.array_equal(ours.V, two.V) and np.array_equal(ours.F, two.F)
