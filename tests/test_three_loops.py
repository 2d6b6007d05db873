"""A region bounded by three loops is filled by one pair of pants.

The genus-2 shape (two tori joined) missing its bottom below a plane: the
scan is the top with the two tori's holes, the missing region the bottom,
bounded by the outline (the waist) and the two holes' inner rims (the
legs). Capping the three loops (or a tube and a cap) cuts the handles; one
pants (:mod:`shellrepair.fill.pants`) keeps the genus.
"""

import numpy as np
import pytest

from eval import shapes
from eval.stress import _genus2
from shellrepair import Mesh, detect_holes
from shellrepair.fill.bridge import pants_triples
from shellrepair.fill.pants import pants_is_manifold
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import euler_characteristic

from test_bands import assert_closed_and_clean, filled_rms_permille


@pytest.fixture(scope="module")
def genus2():
    V, F, _ = _genus2(True)
    assert euler_characteristic(F, len(V)) == -2
    return V, F


@pytest.mark.parametrize("z_cut", [-0.1, -0.2])
def test_the_bottom_of_a_genus_2_shape_is_one_pants_and_keeps_the_genus(genus2, z_cut):
    """At main's 2b26b10 the loops got a tube and a cap: chi 0, genus 1."""
    V, F = genus2
    V2, F2, _ = shapes.remove_faces(V, F, V[F].mean(axis=1)[:, 2] < z_cut)
    assert [L.kind for L in detect_holes(V2, F2).loops] == ["hole"] * 3
    M = Mesh(V=V2, F=F2)
    R, rep = repair_mesh(M)
    assert [(len(b["loops"]), b["chosen"]) for b in rep["bridges"]] == [(3, "tube")]
    legs = rep["bridges"][0]["loops"][1:]
    assert [h["option"] for h in rep["holes"] if h["id"] in legs] == ["pants", "pants"]
    assert_closed_and_clean(M, R, rep)
    assert rep["euler_after"] == euler_characteristic(R.F, len(R.V)) == -2
    assert filled_rms_permille(V, F, R) < 6.0


def test_triples_need_both_legs_to_land_on_the_waist():
    counts = {0: (np.array([0, 25, 22, 1]), 48), 1: (np.array([41, 0, 2, 0]), 48),
              2: (np.array([42, 1, 0, 0]), 48), 3: (np.array([1, 0, 0, 40]), 48)}
    eligible = np.ones(4, bool)
    assert pants_triples(counts, eligible) == [(0, 1, 2)]
    lonely = dict(counts)
    lonely[2] = (np.array([20, 1, 27, 0]), 48)          # most of leg 2's arcs land on itself
    assert pants_triples(lonely, eligible) == []
    assert pants_triples(counts, np.array([True, True, False, True])) == []
    assert pants_triples(counts, eligible, touching={(1, 2), (2, 1)}) == []


def test_pants_manifold_check_counts_boundaries_and_genus():
    # a triangle strip pants is hard to write by hand: a tube (2 loops) is
    # not a pants, and a pants with one face flipped is not oriented
    k = 3 + 3
    tube = np.array([[1, 0, 3], [1, 3, 5], [2, 1, 5], [2, 5, 4], [0, 2, 4], [0, 4, 3]])
    assert pants_is_manifold(tube, k, [3, 3])
    assert not pants_is_manifold(tube, k, [3, 2, 1])
    flipped = tube.copy()
    flipped[0] = flipped[0][::-1]
    assert not pants_is_manifold(flipped, k, [3, 3])


@pytest.mark.slow
def test_a_pants_that_cannot_be_built_falls_back_to_the_old_fill_bit_for_bit(genus2, monkeypatch):
    """No first pants: the band the arcs pair and the cap, as without triples."""
    import shellrepair.fill.bands as bands
    import shellrepair.fill.pants as pants

    V, F = genus2
    V2, F2, _ = shapes.remove_faces(V, F, V[F].mean(axis=1)[:, 2] < -0.2)
    M = Mesh(V=V2, F=F2)

    def no_pants(*args, **kwargs):
        raise ValueError("forced")

    monkeypatch.setattr(pants, "pants_initial", no_pants)
    R, rep = repair_mesh(M)
    assert "forced" in rep["bridges"][0]["pants"]
    monkeypatch.setattr(bands, "pants_triples", lambda *a, **k: [])
    R0, rep0 = repair_mesh(M)
    assert np.array_equal(R.V, R0.V) and np.array_equal(R.F, R0.F)
    assert rep["holes_after"] == rep0["holes_after"] == 0
    assert [b["chosen"] for b in rep["bridges"]] == [b["chosen"] for b in rep0["bridges"]]


def _failed_pants_case():
    """The checks of the test below, on stress case s42424-02."""
    from conftest import STRESS_SHAPES
    from eval import stress
    from shellrepair.fill import band_fill

    c = stress.stress_case(2, 42424, shapes_ok=STRESS_SHAPES)
    assert "genus2" in c.name
    M = Mesh(V=c.V, F=c.F)
    # (the pants and the refill, not the order's choice, are under test; nor
    # the seam, which now gives the band of 3 and 14 a tube: 35.98 -> 27.8
    # per mille under the defaults; set, not restored: this runs in its own
    # interpreter, the test below)
    band_fill.SEAM = False
    R, rep = repair_mesh(M, order=2)
    pants = [b.get("pants") for b in rep["bridges"] if b.get("pants")]
    assert any("pants of loops 3, 7, 14 failed" in p for p in pants), pants
    row = {h["id"]: h for h in rep["holes"]}[7]
    assert row["status"] == "filled" and "filled again around the patches accepted before it" in row["option"]
    assert [b["chosen"] for b in rep["bridges"] if sorted(b["loops"]) == [3, 14]] == ["caps"]
    row = {h["id"]: h for h in rep["holes"]}[14]
    assert row["status"] == "filled" and "filled again around the patches accepted before it" in row["option"]
    assert np.array_equal(R.F[:len(c.F)], c.F)
    assert_closed_and_clean(M, R, rep)


@pytest.mark.slow
def test_a_failed_pants_leaves_its_capped_loop_to_the_refill_like_any_hole():
    """Stress case s42424-02 (a genus-2 shape 39 % unseen): the pants of
    loops 3, 7, 14 crosses the scan everywhere it is tried and falls back to
    the band of 3 and 14 (capped) and a cap on 7, whose cap crosses hole 3's.
    Loop 7 is then a hole like any other and is filled again around the
    patches accepted before it. (Before this was fixed the fallback's loops
    all counted as a band's and loop 7 stayed open.) So is loop 14: its
    band's tube failed, the band took caps, and 14's cap crosses 3's (at
    e950432 it stayed open).

    Run in a fresh interpreter: inside a long-lived pytest worker of a
    clean-clone CI run this case twice came out otherwise (2026-12-04 and
    2026-12-06: no pants failed), never alone, in a loop of repairs in one
    process, under six hash seeds, with the compiled kernels loaded or not,
    or with the cached truths read-only; the cause is not found (see the
    closing notes)."""
    import subprocess
    import sys
    from pathlib import Path

    here = Path(__file__).resolve().parent
    code = ("import sys; sys.path[:0] = [%r, %r]; import test_three_loops as t; t._failed_pants_case()"
            % (str(here), str(here.parent)))
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=here.parent)
    assert run.returncode == 0, run.stderr[-3000:]


def test_the_text_and_html_reports_name_all_three_loops_of_a_pants(genus2):
    from shellrepair.report.html import scan_section
    from shellrepair.report.table import table1_text

    V, F = genus2
    V2, F2, _ = shapes.remove_faces(V, F, V[F].mean(axis=1)[:, 2] < -0.2)
    R, rep = repair_mesh(Mesh(V=V2, F=F2))
    a, b, c = rep["bridges"][0]["loops"]
    assert f"  loops {a}, {b} and {c}: pants (pants: " in table1_text(rep)
    assert f"<li>loops {a}, {b} and {c}: pants (pants: " in scan_section(rep)


def test_a_pants_under_auto_takes_the_order_its_loops_test_holes_choose_and_is_as_true_as_the_best(genus2):
    """Before, a pants under ``auto`` was faired at order 2 whatever the scan said."""
    V, F = genus2
    V2, F2, _ = shapes.remove_faces(V, F, V[F].mean(axis=1)[:, 2] < -0.1)
    M = Mesh(V=V2, F=F2)
    R, rep = repair_mesh(M)
    waist = rep["bridges"][0]["loops"][0]
    row = next(h for h in rep["holes"] if h["id"] == waist)
    choice = row["choice"]
    assert choice["by"] == "test holes" and choice["probes"] >= 2 and not choice["untold"]
    assert choice["test_rms"][str(choice["order"])] == min(choice["test_rms"].values())
    assert f"faired order {choice['order']}" in row["option"]
    forced = {o: filled_rms_permille(V, F, repair_mesh(M, order=o)[0]) for o in (1, 2, 3)}
    auto = filled_rms_permille(V, F, R)
    assert auto <= 1.05 * min(forced.values()), forced
