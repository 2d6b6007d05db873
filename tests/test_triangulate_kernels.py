"""The compiled minimum-weight search over candidate triangles gives the
NumPy search's triangulation to the bit.

:func:`shellrepair.fill.triangulate.restricted_dp` runs
:func:`shellrepair.fill.triangulate_kernels.restricted_prepare` and
:func:`shellrepair.fill.triangulate_kernels.restricted_search` when the kernels are on; its
NumPy form :func:`shellrepair.fill.triangulate.restricted_dp_reference` is the
oracle. Both are run on seeded random loops, planar and nearly planar
loops (where whole families of triangulations tie, so the first-of-equals
rule decides), loops with forbidden chords, degenerate (zero-area)
candidates, unknown and NaN rim normals, and candidate sets with no
triangulation; the answers are compared with ``np.array_equal`` and the
errors by their message.
"""

import numpy as np
import pytest

from shellrepair import compiled
from shellrepair.fill import triangulate_kernels
from shellrepair.fill import triangulate as tr
from shellrepair.errors import MeshError
from test_triangulate import all_triples, assert_disc, rim_normals, wavy_loop

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="numba is not installed")


def _answer(f, *args):
    try:
        return f(*args)
    except MeshError as e:
        return str(e)


def _same(P, cand, en, forbidden, axis):
    """Both searches' answers, asserted equal; the answer (or the error text)."""
    got = _answer(tr.restricted_dp, P, cand, en, forbidden, axis)
    want = _answer(tr.restricted_dp_reference, P, cand, en, forbidden, axis)
    if isinstance(want, str) or isinstance(got, str):
        assert got == want
    else:
        assert got.dtype == want.dtype == np.int64
        assert np.array_equal(got, want)
    return got


def _axis(P):
    C = P - P.mean(axis=0)
    return -np.cross(C, np.roll(C, -1, axis=0)).sum(axis=0)


def _rectangle(w, h):
    """The integer points around a w×h rectangle in the plane z = 0: every
    side's points collinear (zero-area candidates), many equal areas."""
    pts = ([(x, 0) for x in range(w)] + [(w, y) for y in range(h)] + [(x, h) for x in range(w, 0, -1)]
           + [(0, y) for y in range(h, 0, -1)])
    return np.array([(x, y, 0.0) for x, y in pts])


@pytest.mark.parametrize("seed", range(12))
def test_restricted_search_equals_numpy_on_random_wavy_loops(seed):
    rng = np.random.default_rng(seed)
    solved = 0
    for _ in range(12):
        k = int(rng.integers(4, 70))
        P = wavy_loop(k, rng, noise=0.2, wave=float(rng.uniform(0.0, 0.6)))
        D = tr.delaunay_faces(P)
        if D is None:
            continue
        for cand in (D, tr.with_loop_edges(D, k)):
            for en in (rim_normals(P), np.zeros((k, 3))):
                for axis in (None, _axis(P)):
                    T = _same(P, cand, en, set(), axis)
                    if not isinstance(T, str):
                        assert_disc(T, k)
                        solved += 1
    assert solved > 20   # triangulations compared, not only errors


@pytest.mark.parametrize("seed", range(8))
def test_restricted_search_equals_numpy_with_forbidden_chords_and_partial_rims(seed):
    rng = np.random.default_rng(100 + seed)
    errors = solved = 0
    for _ in range(10):
        k = int(rng.integers(5, 40))
        P = wavy_loop(k, rng)
        en = rim_normals(P)
        en[rng.integers(0, k, 3)] = 0.0                 # unknown rim faces
        if seed % 2:
            en[k - 1] = 0.0                             # no scan face across the closing edge
        forb = set()
        for _ in range(int(rng.integers(1, 8))):
            i, j = sorted(int(x) for x in rng.integers(0, k, 2))
            if j - i > 1:
                forb.add((i, j))
        forb.add((0, k // 2))
        for cand in (all_triples(k), tr.with_loop_edges(tr.delaunay_faces(P), k)):
            for axis in (None, _axis(P), -_axis(P)):
                T = _same(P, cand, en, forb, axis)
                if isinstance(T, str):
                    errors += 1
                else:
                    solved += 1
                    he = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [0, 2]]]), axis=1)
                    chords = {(i, j) for i, j in forb if (i, j) != (0, k - 1)}   # a loop edge is no chord
                    assert not ({tuple(e) for e in he.tolist()} & chords)
    assert solved > 0 and errors > 0   # the axis against the loop has no answer


def test_restricted_search_equals_numpy_where_areas_and_costs_tie():
    """Planar integer rectangles: every triangulation has cost 0 and most
    share their area; in shuffled candidate orders the first of equals
    decides, and the answers (which differ between orders) stay equal."""
    differ = 0
    rng = np.random.default_rng(7)
    for w in range(1, 6):
        for h in range(1, 5):
            P = _rectangle(w, h)
            k = len(P)
            if k < 4:
                continue
            for en in (np.zeros((k, 3)), np.tile([0.0, 0.0, 1.0], (k, 1))):
                for axis in (None, _axis(P)):
                    answers = set()
                    C = all_triples(k)
                    for _ in range(3):
                        T = _same(P, C, en, set(), axis)
                        answers.add(tuple(map(tuple, np.sort(T, axis=1).tolist())))
                        C = C[rng.permutation(len(C))]
                    differ += len(answers) > 1
    assert differ > 5   # the order of equals decides: the tie rule is exercised


@pytest.mark.parametrize("seed", range(6))
def test_restricted_search_equals_numpy_on_nearly_planar_and_degenerate_loops(seed):
    """Costs within ANGLE_TIE of each other (z noise of 1e-9), repeated
    positions and collinear runs (zero-area candidates, cost 2 at their
    neighbours), NaN and tiny rim normals."""
    rng = np.random.default_rng(200 + seed)
    for _ in range(6):
        k = int(rng.integers(5, 30))
        th = np.sort(rng.uniform(0, 2 * np.pi, k))
        P = np.column_stack([np.cos(th), np.sin(th), 1e-9 * rng.normal(size=k)])
        j = int(rng.integers(1, k - 1))
        P[j] = P[j - 1]                                   # a repeated position
        P[(j + 2) % k] = 0.5 * (P[(j + 1) % k] + P[(j + 3) % k])   # a collinear corner
        en = np.tile([0.0, 0.0, 1.0], (k, 1)) + 1e-13 * rng.normal(size=(k, 3))
        en[int(rng.integers(0, k))] = np.nan
        en[int(rng.integers(0, k))] = 1e-300
        for cand in (all_triples(k), tr.with_loop_edges(tr.delaunay_faces(P), k) if tr.delaunay_faces(P) is not None
                     else all_triples(k)):
            for axis in (None, np.array([0.0, 0.0, 1.0])):
                _same(P, cand, en, set(), axis)
                _same(P, np.concatenate([cand, cand[::3]]), en, {(0, k // 2)}, axis)   # duplicate candidates


def test_restricted_search_raises_the_same_error_without_a_triangulation():
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.1]], float)
    for cand in (np.array([[0, 1, 2]]), np.zeros((0, 3), np.int64), np.array([[2, 1, 0], [0, 0, 3]])):
        with pytest.raises(MeshError, match="no triangulation"):
            tr.restricted_dp(P, cand, np.zeros((4, 3)), set())
        with pytest.raises(MeshError, match="no triangulation"):
            tr.restricted_dp_reference(P, cand, np.zeros((4, 3)), set())
    # every triangulation needs the forbidden chord (0, 2) or (1, 3)
    for forb in ({(0, 2), (1, 3)},):
        assert isinstance(_same(P, all_triples(4), np.zeros((4, 3)), forb, None), str)


def _kernel_calls(run):
    """The (name, argument types) of every compiled-kernel call ``run()``
    makes, and whether each is one the install compiles ahead of time."""
    compiled.start_recording()
    try:
        run()
    finally:
        rows = compiled.stop_recording()
    built = {(m, n, a) for m, n, a in compiled.read_types()}
    return {(n, (m, n, a) in built) for m, n, a in rows}


@pytest.mark.skipif(not compiled.ENABLED, reason="compiled kernels are off")
def test_restricted_search_runs_compiled_for_every_input_type():
    """Whatever dtypes the caller gives, restricted_dp hands its kernels the
    types the install compiles ahead of time: no call waits on the JIT."""
    rng = np.random.default_rng(1)
    P = wavy_loop(12, rng)

    def run():
        tr.restricted_dp(P, all_triples(12), rim_normals(P), {(0, 5)}, _axis(P))
        tr.restricted_dp(P, all_triples(12).astype(np.int32), np.zeros((12, 3), np.float32), set(), None)

    calls = _kernel_calls(run)
    assert {n for n, _ in calls} >= {"_restricted_prepare", "_restricted_search"}
    assert all(ok for _, ok in calls), sorted(calls)


def test_candidates_outside_the_loop_are_left_to_numpy():
    """A corner index NumPy would wrap (-1) or reject (k) is not read by the
    compiled search: the answer (or error) is NumPy's."""
    rng = np.random.default_rng(3)
    P = wavy_loop(8, rng)
    C = all_triples(8)
    for extra in ([-1, 0, 3], [-8, 2, 5]):
        _same(P, np.vstack([C, extra]), rim_normals(P), set(), None)
    with pytest.raises(IndexError):
        tr.restricted_dp(P, np.vstack([C, [2, 5, 8]]), rim_normals(P), set(), None)


# --------------------------------------------------------------------------
# Liepa's full dynamic program (the layer for loops the restricted search
# cannot triangulate): compiled tables against the vectorised NumPy ones
# --------------------------------------------------------------------------
def _dp_inputs(rng, k, kind):
    """A sub-loop's positions, rim normals (some unknown or zero), forbidden
    chords and axis, of one of five kinds: planar, wavy, on a coarse grid
    (collinear runs, equal areas: ties), with coincident points (zero-area
    candidates), and with zero rim normals on known rim edges."""
    th = np.sort(rng.uniform(0, 2 * np.pi, k))
    Q = np.column_stack([np.cos(th), np.sin(th), rng.normal(0.0, 0.0 if kind == 0 else 0.3, k)])
    if kind == 2:
        Q = np.round(Q * 4) / 4
    if kind == 3:
        Q[rng.integers(0, k, 3)] = Q[0]
    rim = rng.normal(size=(k, 3))
    rim /= np.linalg.norm(rim, axis=1, keepdims=True)
    has = rng.random(k) < 0.8
    rim[~has] = 0.0
    if kind == 4:
        rim[rng.integers(0, k, 2)] = 0.0
    forb = np.zeros((k, k), bool)
    for _ in range(int(rng.integers(0, k))):
        a, b = sorted(rng.integers(0, k, 2).tolist())
        if b - a > 1 and not (a == 0 and b == k - 1):
            forb[a, b] = True
    return Q, rim, has, forb


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.slow
def test_liepa_tables_equal_numpys(seed):
    """Every interval's apex and the loop's worst cost, to the bit: with and
    without an axis (some loops have no triangulation facing along it, or
    none avoiding the forbidden chords: worst is then inf in both), on
    every kind of loop of _dp_inputs."""
    rng = np.random.default_rng(700 + seed)
    infinite = finite = 0
    for trial in range(40):
        k = int(rng.integers(4, 90))
        Q, rim, has, forb = _dp_inputs(rng, k, trial % 5)
        for axis in (None, rng.normal(size=3), np.array([0.0, 0.0, 1.0])):
            O, worst = triangulate_kernels.liepa_tables(Q, rim, has, forb, axis, tr.ANGLE_TIE)
            O_np, worst_np = tr.dp_tables_reference(Q, rim, has, forb, axis)
            assert O.dtype == np.int64 and np.array_equal(O, O_np)
            assert worst == worst_np
            finite += bool(np.isfinite(worst))
            infinite += not np.isfinite(worst)
    assert finite > 20 and infinite > 20


def test_full_dp_is_the_same_with_and_without_the_kernels(monkeypatch):
    """tr.liepa_dp's triangles (or its error) on sub-loops of a larger loop, with
    rim normals only where a sub-loop edge is a loop edge: the same either
    way."""
    rng = np.random.default_rng(11)
    P = wavy_loop(60, rng, noise=0.3, wave=0.5)
    en = rim_normals(P)
    errors = 0
    for idx in (np.arange(60), np.arange(10, 45), np.r_[50:60, 0:12], np.array([3, 9, 20, 21, 22, 40])):
        for forb in (set(), {(int(idx[0]), int(idx[len(idx) // 2]))}):
            for axis in (None, _axis(P[idx]), -_axis(P[idx])):
                got = _answer(tr.liepa_dp, P, idx, en, forb, axis)
                monkeypatch.setattr(compiled, "ENABLED", False)
                want = _answer(tr.liepa_dp, P, idx, en, forb, axis)
                monkeypatch.setattr(compiled, "ENABLED", True)
                if isinstance(want, str) or isinstance(got, str):
                    assert got == want
                    errors += 1
                else:
                    assert got.dtype == want.dtype == np.int64 and np.array_equal(got, want)
                    if len(idx) == len(P):
                        assert_disc(got, len(P))
    assert errors >= 1     # the reversed axis: no triangulation faces along it


@pytest.mark.parametrize("seed", range(4))
def test_compiled_chord_search_is_the_row_by_row_one(seed):
    """The long sub-loop's cutting chord (the nearest allowed pair at least
    a quarter of the loop apart): triangulate_kernels.chord_rows gives the row-by-row
    search's answer or error, on wavy loops, loops on a coarse grid (equal
    distances: the row's pick is NumPy's argsort's), repeated positions,
    many forbidden chords, and loop ids that are not 0..k-1."""
    rng = np.random.default_rng(900 + seed)
    tied = 0
    for trial in range(40):
        k = int(rng.integers(8, 400))
        P = wavy_loop(k, rng, noise=0.3, wave=0.4)
        if trial % 4 == 1:
            P = np.round(P * 3) / 3
        if trial % 4 == 2:
            P[::7] = P[0]
        idx = np.arange(k) if trial % 2 else np.sort(rng.choice(3 * k, k, replace=False))
        Pfull = np.zeros((3 * k, 3))
        Pfull[idx] = P
        forb = {tuple(sorted(rng.choice(idx, 2, replace=False).tolist())) for _ in range(int(rng.integers(0, 3 * k)))}
        got = _answer(tr.best_chord, Pfull, idx, forb)
        assert got == _answer(tr.best_chord_rows, Pfull, idx, forb)
        if not isinstance(got, str):
            i, j = got
            d = np.linalg.norm(P[i + max(3, k // 4):min(k, i + k - max(3, k // 4) + 1)] - P[i], axis=1)
            tied += int((d == d.min()).sum() > 1)
    assert tied >= 1
    # every chord forbidden: the same error
    k = 12
    P = wavy_loop(k, rng)
    everything = {(a, b) for a in range(k) for b in range(a + 1, k)}
    assert _answer(tr.best_chord, P, np.arange(k), everything) == \
        _answer(tr.best_chord_rows, P, np.arange(k), everything)


@pytest.mark.skipif(not compiled.ENABLED, reason="compiled kernels are off")
def test_liepa_tables_run_compiled_with_and_without_an_axis():
    """The tables liepa_dp passes (with and without an axis) are among the types
    the install compiles ahead of time."""
    rng = np.random.default_rng(2)
    P = wavy_loop(12, rng)

    def run():
        for axis in (None, _axis(P)):
            _answer(tr.liepa_dp, P, np.arange(12), rim_normals(P), {(0, 5)}, axis)

    calls = _kernel_calls(run)
    assert "_liepa_tables" in {n for n, _ in calls}
    assert all(ok for _, ok in calls), sorted(calls)


# --------------------------------------------------------------------------
# the projected Delaunay layer's compiled steps
# --------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(4))
def test_centred_loop_and_vector_area_equal_numpys_sums(seed):
    """NumPy sums a C-ordered (k,3) array's columns row after row from 0.0;
    the kernel does the same: equal to the bit for small and long loops,
    at huge offsets, and for columns of negative zeros (0.0 + -0.0 = 0.0)."""
    from shellrepair.mesh.geometry import cross

    rng = np.random.default_rng(seed)
    for k in (3, 4, 7, 8, 9, 100, 129, 1000, 4097):
        for offset in (0.0, 1e6):
            P = rng.normal(size=(k, 3)) * 10.0 ** rng.integers(-3, 3) + offset
            if k == 9:
                P[:, 1] = -0.0
            C, va = triangulate_kernels.centred_area(P)
            Cn = P - P.mean(axis=0)
            van = -0.5 * cross(Cn, np.roll(Cn, -1, axis=0)).sum(axis=0)
            assert np.array_equal(C, Cn) and np.array_equal(va, van)
            assert np.array_equal(np.signbit(C), np.signbit(Cn))


def _outline_loops(rng):
    """Star-shaped and wavy loops (accepted by the projection), loops that
    fold over themselves (rejected), and loops with collinear runs."""
    out = []
    for _ in range(6):
        k = int(rng.integers(3, 40))
        out.append(wavy_loop(k, rng, noise=0.3, wave=0.4))
        th = np.sort(rng.uniform(0, 2 * np.pi, k))
        out.append(np.column_stack([np.cos(3 * th) * np.cos(th), np.cos(3 * th) * np.sin(th), 0.1 * rng.normal(size=k)]))
    R = _rectangle(3, 2)
    out.append(R)
    out.append(R + 1e6)
    return out


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.slow
def test_triangulate_loop_is_the_same_with_and_without_the_kernels(seed, monkeypatch):
    """The whole first layer (and, where it declines, the search) with the
    compiled centring, outline, normal, cover and forbidden-edge steps, and
    with NumPy's: the same triangles in the same order, or the same error."""
    rng = np.random.default_rng(300 + seed)
    accepted = rejected = 0
    for P in _outline_loops(rng):
        k = len(P)
        forbs = [set(), {(0, k // 2)}, {(0, 1), (k - 1, 0), (1, k - 1)}]
        if k > 4:
            forbs.append({(i, j) for i in range(k) for j in range(i + 2, k) if (i + j) % 3 == 0})
        for Pin in (P, np.asfortranarray(P)):
            for forb in forbs:
                for axis in ("auto", np.array([0.0, 0.0, 1.0])):
                    got = _answer(tr.triangulate_loop, Pin, None, forb, axis)
                    direct = tr.delaunay_in_projection(Pin, _axis(Pin) if isinstance(axis, str) else axis, forb)
                    monkeypatch.setattr(compiled, "ENABLED", False)
                    want = _answer(tr.triangulate_loop, Pin, None, forb, axis)
                    direct_np = tr.delaunay_in_projection(Pin, _axis(Pin) if isinstance(axis, str) else axis, forb)
                    monkeypatch.setattr(compiled, "ENABLED", True)
                    if isinstance(want, str) or isinstance(got, str):
                        assert got == want
                    else:
                        assert got.dtype == want.dtype and np.array_equal(got, want)
                    assert (direct is None) == (direct_np is None)
                    if direct is not None:
                        assert np.array_equal(direct, direct_np)
                        accepted += 1
                    else:
                        rejected += 1
    assert accepted > 10 and rejected > 10


def test_cover_free_finds_a_forbidden_edge_in_either_direction():
    S = np.array([[0, 1, 2], [0, 2, 3]], np.int64)     # the fan of a square, chord (0, 2)
    n = np.array([-1.0, -1.0])
    for fk, status in (([], 0), ([0 * 4 + 2], 2), ([1 * 4 + 3], 0), ([0 * 4 + 1], 2)):
        out, st = triangulate_kernels.cover_free(S, n, 4, np.array(fk, np.int64))
        assert st == status
        assert np.array_equal(out, S[:, [0, 2, 1]])
    assert triangulate_kernels.cover_free(S, np.array([-1.0, 1.0]), 4, np.zeros(0, np.int64))[1] == 1   # not a cover


@pytest.mark.parametrize("seed", range(4))
def test_tetrahedralization_faces_and_missing_loop_edges_equal_numpys(seed, monkeypatch):
    """delaunay_faces (sorted corners, sorted unique keys) and
    with_loop_edges (the loop edges the faces lack, each completed with
    every apex) give the same arrays with the kernels and without, on
    wavy and folded loops (which miss loop edges) and on rows holding a
    corner outside the loop (left to NumPy)."""
    rng = np.random.default_rng(400 + seed)
    missing = 0
    for _ in range(8):
        k = int(rng.integers(4, 120))
        th = np.sort(rng.uniform(0, 2 * np.pi, k))
        folded = np.column_stack([np.cos(th), np.sin(2 * th) * 0.6, 0.8 * np.sin(3 * th)]) + 0.02 * rng.normal(size=(k, 3))
        for P in (wavy_loop(k, rng), folded):
            got = tr.delaunay_faces(P)
            W = tr.with_loop_edges(got, k) if got is not None else None
            monkeypatch.setattr(compiled, "ENABLED", False)
            want = tr.delaunay_faces(P)
            Wn = tr.with_loop_edges(want, k) if want is not None else None
            monkeypatch.setattr(compiled, "ENABLED", True)
            assert (got is None) == (want is None)
            if want is None:
                continue
            assert got.dtype == want.dtype == np.int64 and np.array_equal(got, want)
            assert np.array_equal(W, Wn)
            missing += len(W) > len(got)
    assert missing > 0   # some loops lacked a loop edge: the completion ran
    D = np.array([[0, 1, 2], [1, 2, 3], [0, 2, 3], [2, 3, 4]], np.int64)   # corner 4 outside a 4-loop
    assert not triangulate_kernels.loop_edges_present(D, 4)[1]
    got = tr.with_loop_edges(D, 4)
    monkeypatch.setattr(compiled, "ENABLED", False)
    assert np.array_equal(got, tr.with_loop_edges(D, 4))


def test_the_axis_length_is_numpys_norm():
    """_length (the axis normalisation's) equals np.linalg.norm to the bit
    on float64 vectors of every scale, and defers to it otherwise."""
    rng = np.random.default_rng(9)
    for _ in range(2000):
        x = rng.normal(size=3) * 10.0 ** rng.integers(-150, 150)
        assert tr.vector_length(x) == np.linalg.norm(x)
    for x in (np.zeros(3), np.array([np.inf, 1.0, 0.0]), np.array([3, 4, 0]), np.ones((2, 3))):
        got, want = tr.vector_length(x), np.linalg.norm(x)
        assert got == want or (np.isnan(got) and np.isnan(want))
