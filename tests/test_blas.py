"""The fill runs its BLAS calls on one thread (shellrepair.blas): set for
the process while any block is open, put back when the last ends, and the
output does not depend on what the caller had set."""

import threading

import numpy as np
import pytest

from shellrepair import blas
from shellrepair.repair import repair_mesh


@pytest.fixture
def counts_at_3():
    """The bundled libraries' thread counts set to 3 (put back after); their (get, set) pairs."""
    gs = blas.global_setters()
    if not gs:
        pytest.skip("no bundled OpenBLAS with a thread-count setter (NumPy/SciPy linked to another BLAS)")
    before = blas.counts()
    for _, put in gs:
        put(3)
    yield gs
    for (_, put), b in zip(gs, before):
        put(b)


def test_one_thread_sets_the_counts_and_puts_them_back(counts_at_3):
    gs = counts_at_3
    with blas.one_thread():
        assert blas.counts() == [1] * len(gs)
    assert blas.counts() == [3] * len(gs)
    with pytest.raises(RuntimeError):
        with blas.one_thread():
            assert blas.counts() == [1] * len(gs)
            raise RuntimeError("a failed fill")
    assert blas.counts() == [3] * len(gs)


def test_overlapping_blocks_put_the_counts_back_when_the_last_ends(counts_at_3):
    """Two fills with helpers in two threads of one caller: the blocks
    overlap, and the first to end must not give the other back its
    libraries' threads."""
    gs = counts_at_3
    first, second = blas.one_thread(), blas.one_thread_everywhere()
    first.__enter__()
    second.__enter__()
    first.__exit__(None, None, None)
    assert blas.counts() == [1] * len(gs)
    second.__exit__(None, None, None)
    assert blas.counts() == [3] * len(gs)


def test_blocks_overlapping_in_two_threads(counts_at_3):
    """The fill and its helper thread: A enters, B enters, A leaves, B
    leaves. B keeps one thread after A left, and the counts are the caller's
    again after both (a setter restored per block, as before, gave B two
    threads back and left the process at one)."""
    gs = counts_at_3
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def a():
        with blas.one_thread():
            a_in.set()
            b_in.wait(30)
        a_out.set()

    def b():
        a_in.wait(30)
        with blas.one_thread():
            b_in.set()
            a_out.wait(30)
            seen["b after a left"] = blas.counts()

    threads = [threading.Thread(target=a), threading.Thread(target=b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert seen["b after a left"] == [1] * len(gs)
    assert blas.counts() == [3] * len(gs)


def test_the_helper_thread_puts_the_switch_interval_and_blas_counts_back():
    import sys

    from shellrepair.fill.beside import SWITCH_SECONDS, HelperThread

    gs = blas.global_setters()
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


def test_output_does_not_depend_on_the_counts_the_caller_left(counts_at_3):
    """Two OpenBLAS threads change the last bits of the fill's products
    (measured on hard-30pct); repair_mesh runs on one whatever the caller
    set, and gives the counts back."""
    V, F = perforated_sphere()
    many, rep = repair_mesh((V, F), order=3)
    assert rep["holes_after"] == 0 and rep["holes_before"] == 2
    assert blas.counts() == [3] * len(counts_at_3)
    for _, put in counts_at_3:
        put(1)
    one, _ = repair_mesh((V, F), order=3)
    assert np.array_equal(many.V, one.V) and np.array_equal(many.F, one.F)
