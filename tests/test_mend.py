"""The fill's last layer (shellrepair.fill.mend): a patch that crosses the scan
in a few places is cut there, and each cut-out region is triangulated again
with triangles that cross neither the scan nor the rest of the patch.

* a patch whose vertices near one side of the rim were pushed through the
  scan comes back crossing nothing: a disc on the same loop that keeps the
  patch away from the fault, its new vertices among the old ones;
* a region no triangulation of its own vertices clears (a scan fin
  through a flat opening) is closed by a fan around one lifted vertex;
* a scan pillar standing through a curved opening cannot be mended: the
  mending finds no triangulation that avoids the scan, within a bounded
  number of rounds and region sizes; through a plane opening it is not
  asked (it would bend what is a flat face). The pillar is a closed piece,
  not linked with the loop, so the layer after it (Steiner points,
  :mod:`shellrepair.fill.steiner`) closes the opening over the pillar's top;
* a hole round a scan tongue twisted by 270° defeats every earlier layer
  and is closed by mending;
* the fill keeps every answer the earlier layers give (the last layer runs
  only where they all fail).
"""

import numpy as np

from eval import shapes
from shellrepair import Mesh
from shellrepair.fill.checks import check_patch
from shellrepair.fill.hole import fill_hole
from shellrepair.holes.loops import boundary_loops
from shellrepair.fill.mend import mend_patch
from shellrepair.mesh.index import ScanContext
from shellrepair.fill.patch import build_patch


def _sheet_with_a_hole(n=25, half=0.2):
    """A unit sheet (z = 0) with a square hole of side ``2 * half`` in its middle."""
    V, F = shapes.grid(n, n)
    c = V[F].mean(axis=1)
    gone = (np.abs(c[:, 0] - 0.5) < half) & (np.abs(c[:, 1] - 0.5) < half)
    V2, F2, _ = shapes.remove_faces(V, F, gone)
    loops, _ = boundary_loops(F2, len(V2))
    return V2, F2, min(loops, key=len)   # the hole (the other loop is the sheet's edge)


def _is_disc_on(T, loop):
    """Every rim edge once (reversed), every inner edge twice, Euler characteristic 1."""
    k = len(loop)
    he = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    keys = set(map(tuple, he.tolist()))
    if len(keys) != len(he):
        return False
    rim = {((i + 1) % k, i) for i in range(k)}
    if not rim <= keys:
        return False
    if any((b, a) not in keys for a, b in keys - rim):
        return False
    edges = {tuple(sorted(e)) for e in keys}
    return int(T.max()) + 1 - len(edges) + len(T) == 1


def test_a_patch_pushed_through_the_scan_near_its_rim_is_mended():
    V, F, loop = _sheet_with_a_hole()
    ctx = ScanContext(Mesh(V=V, F=F))
    patch = build_patch(ctx, 0, loop, order=1, smooth=0, fair=False)    # the flat refined patch
    assert check_patch(ctx, patch)[0] is None
    # push the new vertices next to the side x = 0.3 out over the scan,
    # every other one above and below it: their triangles cut through it
    h = float(np.linalg.norm(V[loop[1]] - V[loop[0]]))
    near = np.flatnonzero(patch.P[:, 0] < 0.3 + 1.2 * h)
    assert near.size >= 3
    patch.P[near, 0] -= 2.0 * h
    patch.P[near, 2] += np.where(np.arange(near.size) % 2, 0.3, -0.3) * h
    why, bad = check_patch(ctx, patch)
    assert why is not None and "cross the scan" in why
    res = mend_patch(ctx, patch, bad, check_patch)
    assert res.patch is not None, res.reason
    assert res.reason == ""
    assert check_patch(ctx, res.patch)[0] is None
    assert np.array_equal(res.patch.loop, loop)
    assert _is_disc_on(res.patch.T, loop)
    # away from the fault the patch is the one it was: its new vertices are old ones
    assert all((np.abs(patch.P - p).sum(axis=1) == 0).any() for p in res.patch.P)
    assert len(res.patch.P) >= len(patch.P) - 3 * near.size
    assert res.regions >= 1


def test_a_region_no_flat_triangulation_clears_is_closed_by_a_fan_over_the_obstacle():
    """A small scan fin stands through the middle of a flat opening (it does
    not reach the rim): every triangulation of a sub-loop around it lies
    in the opening's plane and cuts the fin; the region is closed by a fan
    around one new vertex lifted off the plane, which clears it."""
    V, F, loop = _sheet_with_a_hole()
    h = float(np.linalg.norm(V[loop[1]] - V[loop[0]]))
    # (askew to the patch's edges, so none of them can run along the cut)
    fin = 0.5 + h * np.array([[-0.7, -0.3, -0.2], [0.6, 0.35, -0.2], [0.05, 0.11, 0.2]]) - [0, 0, 0.5]
    V2 = np.vstack([V, fin])
    F2 = np.vstack([F, [[len(V), len(V) + 1, len(V) + 2]]])
    ctx = ScanContext(Mesh(V=V2, F=F2))
    patch = build_patch(ctx, 0, loop, order=1, smooth=0, fair=False)     # flat: cuts the fin
    why, bad = check_patch(ctx, patch)
    assert why is not None and "cross the scan" in why
    res = mend_patch(ctx, patch, bad, check_patch)
    assert res.patch is not None, res.reason
    assert check_patch(ctx, res.patch)[0] is None
    assert _is_disc_on(res.patch.T, loop)
    lifted = np.abs(res.patch.P[:, 2]) > 0.2 * h          # the fan's apex, off the plane
    assert np.count_nonzero(lifted) == 1


def _pillar(x, y, z0, z1, r, n=6):
    """A closed n-sided prism around the vertical line (x, y), from z0 to z1."""
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.column_stack([x + r * np.cos(th), y + r * np.sin(th)])
    V = np.vstack([np.column_stack([ring, np.full(n, z0)]), np.column_stack([ring, np.full(n, z1)]),
                   [[x, y, z0], [x, y, z1]]])
    F = []
    for i in range(n):
        j = (i + 1) % n
        F += [[i, j, n + j], [i, n + j, n + i], [2 * n, j, i], [2 * n + 1, n + i, n + j]]
    return V, np.asarray(F, np.int64)


def _passes_over_the_pillar(ctx, out, z1):
    """The Steiner layer's patch: it passes its checks, and over the
    pillar's axis it is above the pillar's top ``z1``."""
    assert out.patch is not None, out.reason
    assert out.patch.kind == "steiner" and out.patch.option.startswith("Steiner points")
    assert check_patch(ctx, out.patch)[0] is None
    assert out.patch.P[:, 2].max() > z1


def test_a_pillar_through_a_curved_opening_defeats_mending_and_is_passed_over():
    V, F, loop = _sheet_with_a_hole()
    V = V.copy()
    V[:, 2] = 0.5 * (V[:, 0] - 0.5) ** 2          # bent: the opening is not a plane region
    Vp, Fp = _pillar(0.5, 0.5, -0.3, 0.3, 0.03)
    ctx = ScanContext(Mesh(V=np.vstack([V, Vp]), F=np.vstack([F, Fp + len(V)])))
    out = fill_hole(ctx, 0, loop, 2, 0)
    said = "; ".join(out.reasons)
    assert "last layer, mending" in said
    assert "crosses neither the scan" in said or "grew to" in said or "not discs" in said
    _passes_over_the_pillar(ctx, out, 0.3)


def test_a_pillar_through_a_plane_opening_is_not_mended_and_is_passed_over():
    """A plane region the scan crosses inside its plane: no flat
    triangulation avoids it, and the mending is not asked (it would bend
    what is a flat face); the Steiner layer lifts the patch over the pillar."""
    V, F, loop = _sheet_with_a_hole()
    Vp, Fp = _pillar(0.5, 0.5, -0.3, 0.3, 0.03)
    ctx = ScanContext(Mesh(V=np.vstack([V, Vp]), F=np.vstack([F, Fp + len(V)])))
    out = fill_hole(ctx, 0, loop, 2, 0)
    said = "; ".join(out.reasons)
    assert "cross the opening's own plane inside it" in said
    assert "last layer, mending" not in said
    _passes_over_the_pillar(ctx, out, 0.3)
    # flat (on the sheet's plane, z = 0) where the pillar is not under it
    assert (out.patch.P[:, 2] == 0).any()


def test_a_pillar_is_given_up_within_the_rounds_and_the_region_bound():
    """The bounded work behind a fast failure: at most ``MEND_ROUNDS`` rounds,
    no region past ``MEND_MAX_LOOP`` edges is searched."""
    from shellrepair.fill.mend import MEND_MAX_LOOP, MEND_ROUNDS

    V, F, loop = _sheet_with_a_hole()
    Vp, Fp = _pillar(0.5, 0.5, -0.3, 0.3, 0.03)
    ctx = ScanContext(Mesh(V=np.vstack([V, Vp]), F=np.vstack([F, Fp + len(V)])))
    patch = build_patch(ctx, 0, loop, order=2, smooth=0)
    why, bad = check_patch(ctx, patch)
    assert why is not None and "cross the scan" in why
    res = mend_patch(ctx, patch, bad, check_patch)
    assert res.patch is None
    assert res.rounds <= MEND_ROUNDS
    assert "crosses neither the scan" in res.reason or f"past {MEND_MAX_LOOP}" in res.reason


def test_the_last_layer_leaves_a_hole_the_earlier_layers_fill_alone():
    V, F, loop = _sheet_with_a_hole()
    ctx = ScanContext(Mesh(V=V, F=F))
    out = fill_hole(ctx, 0, loop, 2, 0)
    assert out.patch is not None
    assert out.patch.mended == 0 and "mended" not in out.patch.option


def _sheet_with_a_twisted_tongue(twist, dip, n=21, width=2, length=0.28):
    """A unit sheet (z = 0) with a square hole (side 0.6) and a tongue of
    scan, ``width`` cells wide, reaching from the hole's side x = 0.2 a
    length ``length`` into it, twisted about its axis by up to ``twist``
    (radians, at its tip) and dipped by up to ``dip`` below the sheet
    halfway along: the rim runs along both sides of the tongue, its scan
    faces turning over and back."""
    V, F = shapes.grid(n, n)
    h = 1.0 / (n - 1)
    c = V[F].mean(axis=1)
    hole = (np.abs(c[:, 0] - 0.5) < 0.3) & (np.abs(c[:, 1] - 0.5) < 0.3)
    tongue = (c[:, 0] < 0.2 + length + 1e-9) & (np.abs(c[:, 1] - 0.5) < width * h / 2 + 1e-9)
    V = V.copy()
    t = np.clip((V[:, 0] - 0.2) / length, 0, 1)
    on = (V[:, 0] > 0.2 + 1e-9) & (np.abs(V[:, 1] - 0.5) <= width * h / 2 + 1e-9)
    y = V[on, 1] - 0.5
    V[on, 1] = 0.5 + y * np.cos(twist * t[on])
    V[on, 2] = y * np.sin(twist * t[on]) - dip * np.sin(np.pi * t[on])
    V2, F2, _ = shapes.remove_faces(V, F, hole & ~tongue)
    loops, _ = boundary_loops(F2, len(V2))
    return V2, F2, min(loops, key=len)


def test_a_hole_round_a_twisted_tongue_the_earlier_layers_leave_open_is_mended(monkeypatch):
    """Twisted by 270° and dipped by 0.1: every faired patch and every flat
    triangulation the earlier layers try crosses the tongue ("the
    triangulation still crosses the scan after re-routing N chords"); the
    last layer mends the faired patch where it crosses, and the result
    passes every check."""
    from shellrepair.fill import hole as fill

    V, F, loop = _sheet_with_a_twisted_tongue(1.5 * np.pi, 0.1)
    ctx = ScanContext(Mesh(V=V, F=F))
    out = fill_hole(ctx, 0, loop, 2, 0)
    assert any("still crosses the scan after re-routing" in r for r in out.reasons)
    assert out.patch is not None, out.reason
    assert out.patch.mended > 0 and out.patch.kind == "faired" and "mended" in out.patch.option
    assert check_patch(ctx, out.patch)[0] is None
    assert _is_disc_on(out.patch.T, loop)
