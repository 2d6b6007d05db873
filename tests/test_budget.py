"""A hole's work is bounded (shellrepair.fill.checks.WorkBudget, issue #13 item 5).

The budget counts new patch vertices built over all attempts
(``HOLE_VERTICES + HOLE_VERTICES_PER_EDGE * edges``): the first attempt is
always made, and so is the harmonic patch (the last option, tried at most
once); a later faired one only while a patch of the first one's size still
fits, and refinement stops an attempt that grows past what is left before
its costly fairing. Past the budget the hole keeps what is already checked
(the flat triangulation). These tests count attempts and vertices, not
seconds.
"""

import numpy as np
import pytest

import shellrepair.fill.checks as checks
import shellrepair.fill.hole as fill
from shellrepair import Mesh
from eval import shapes
from shellrepair.holes.loops import boundary_loops
from shellrepair.mesh.index import ScanContext
from shellrepair.fill.patch import OverBudget, PatchError, build_patch


def _sheet_with_a_hole(n=25):
    V, F = shapes.grid(n, n)
    c = V[F].mean(axis=1)
    gone = np.linalg.norm(c[:, :2] - 0.5, axis=1) < 0.3
    V2, F2, _ = shapes.remove_faces(V, F, gone)
    loops, _ = boundary_loops(F2, len(V2))
    return ScanContext(Mesh(V=V2, F=F2)), min(loops, key=len)


def test_refinement_past_the_vertices_left_stops_before_fairing():
    ctx, loop = _sheet_with_a_hole()
    full = build_patch(ctx, 0, loop, order=2)
    assert len(full.P) > 10
    with pytest.raises(OverBudget, match="work budget") as over:       # a kind of PatchError callers can tell
        build_patch(ctx, 0, loop, order=2, max_vertices=len(full.P) - 1)
    assert isinstance(over.value, PatchError)
    same = build_patch(ctx, 0, loop, order=2, max_vertices=len(full.P))
    assert np.array_equal(same.P, full.P) and np.array_equal(same.T, full.T)


class _Spy:
    """build_patch counting refined builds; patches with new vertices
    are made to fail their checks (as a faired patch crossing the scan)."""

    def __init__(self, monkeypatch):
        self.refined = 0
        real_build, real_check = fill.build_patch, checks.check_patch

        def build(*a, **k):
            p = real_build(*a, **k)
            if k.get("refine", True):
                self.refined += 1
            return p

        def check(ctx, patch):
            if len(patch.P):
                return "patch would cross the scan (test)", np.arange(min(3, len(patch.T)))
            return real_check(ctx, patch)

        monkeypatch.setattr(fill, "build_patch", build)
        monkeypatch.setattr(checks, "check_patch", check)


def test_a_spent_budget_stops_the_retries_and_keeps_the_checked_flat_triangulation(monkeypatch):
    ctx, loop = _sheet_with_a_hole()
    spy = _Spy(monkeypatch)
    budget = checks.WorkBudget(len(loop))
    budget.vertices = 0          # nothing left after the first attempt
    patch, reason, _, reasons, failure = fill.fill_hole_at_order(ctx, 0, loop, 2, 0, budget=budget)
    assert spy.refined == 2                      # the first attempt and the harmonic patch only
    assert patch is not None and len(patch.P) == 0 and patch.kind == "flat" and failure == ""
    assert patch.option.startswith("flat triangulation")
    assert any("not tried" in r and "work budget" in r for r in reasons)
    assert budget.spent > 0                      # the first attempt was counted


def test_a_budget_of_two_and_a_half_patches_allows_one_faired_retry(monkeypatch):
    """The same failing hole: the first attempt, one faired retry (2 x its
    size fit in 2.5, 3 do not), the harmonic patch; the flat triangulation
    is kept."""
    ctx, loop = _sheet_with_a_hole()
    size = len(build_patch(ctx, 0, loop, order=2).P)
    spy = _Spy(monkeypatch)
    budget = checks.WorkBudget(len(loop))
    budget.vertices = 2.5 * size
    patch, *_ = fill.fill_hole_at_order(ctx, 0, loop, 2, 0, budget=budget)
    assert spy.refined == 3
    assert budget.spent == 3 * size
    assert patch is not None and len(patch.P) == 0


def test_with_the_default_budget_the_same_hole_retries_more(monkeypatch):
    """The control: the bound above is what cut the retries."""
    ctx, loop = _sheet_with_a_hole()
    spy = _Spy(monkeypatch)
    fill.fill_hole_at_order(ctx, 0, loop, 2, 0)
    assert spy.refined > 3


def test_a_part_gets_its_share_of_what_is_left_and_is_counted_back():
    b = checks.WorkBudget(1000)
    b.spent = 10_000
    part = b.part(0.5)
    assert part.vertices == pytest.approx(0.5 * (b.vertices - 10_000))
    part.spent = 123
    b.absorb(part)
    assert b.spent == 10_123
    assert checks.WorkBudget(1000).vertices == checks.HOLE_VERTICES + 1000 * checks.HOLE_VERTICES_PER_EDGE


def test_a_band_whose_tube_is_over_the_budget_falls_back_without_adding_a_crossing(monkeypatch):
    """The torus's inner band is one tube with the default budget
    (tests/test_bands.py); with a budget below the tube's size the tube is
    refused at refinement (before fairing and checking) and the band falls
    back to its caps: whatever they close adds no crossing, no
    non-manifold edge, and leaves the original vertices bit-identical.
    (Here the two caps bulge into each other, so one loop stays open: the
    default budget is 25k new vertices + 30 per rim edge, 15x this tube.)"""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_bands import self_intersections, torus_inner_band
    from shellrepair.repair import repair_mesh

    _, _, V2, F2, _ = torus_inner_band(3)
    M = Mesh(V=V2, F=F2)
    R, rep = repair_mesh(M)
    (b,) = rep["bridges"]
    assert b["chosen"] == "tube" and rep["holes_after"] == 0
    tube_vertices = len(R.V) - len(M.V)
    assert checks.HOLE_VERTICES + checks.HOLE_VERTICES_PER_EDGE * 320 > 15 * tube_vertices
    monkeypatch.setattr(checks, "HOLE_VERTICES", tube_vertices // 2)
    monkeypatch.setattr(checks, "HOLE_VERTICES_PER_EDGE", 0)
    R2, rep2 = repair_mesh(M)
    (b2,) = rep2["bridges"]
    assert b2["chosen"] == "caps" and "work budget" in b2["reason"]
    assert rep2["holes_after"] < rep2["holes_before"]
    assert rep2["nonmanifold_edges_after"] == 0
    assert np.array_equal(R2.V[:len(M.V)], M.V)
    assert self_intersections(R2.V, R2.F) == self_intersections(M.V, M.F)


def test_failed_faired_attempts_are_mended_before_the_flat_triangulation_is_kept(monkeypatch):
    """Every faired and harmonic attempt fails its check (as if it crossed
    the scan next to three triangles) while a flat triangulation passes: the
    last layer mends the attempt with the fewest faults first, so the hole
    gets a refined, faired surface, not a flat triangulation without one
    new vertex (a large opening of a scan: RMS 10.7 -> 3.9 per mille on
    eval/big_holes.py's b37663-07)."""
    import shellrepair.fill.mend as mend

    ctx, loop = _sheet_with_a_hole()
    real_check, real_mend = checks.check_patch, mend.mend_patch
    mending = []

    def mend_patch(*a, **k):
        mending.append(True)
        try:
            return real_mend(*a, **k)
        finally:
            mending.pop()

    def check(ctx, patch):
        if len(patch.P) and not mending:
            return "patch would cross the scan (test)", np.arange(min(3, len(patch.T)))
        return real_check(ctx, patch)

    monkeypatch.setattr(mend, "mend_patch", mend_patch)
    monkeypatch.setattr(checks, "check_patch", check)
    patch, *_ = fill.fill_hole_at_order(ctx, 0, loop, 2, 0)
    assert patch is not None and patch.mended > 0 and "mended" in patch.option and len(patch.P) > 0
    assert real_check(ctx, patch)[0] is None
