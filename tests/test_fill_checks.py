"""The checks every patch passes before it is kept (shellrepair.fill.checks.check_patch).

Besides crossing the scan or itself, a patch must not fold back onto its
neighbour across an edge: two triangles on one edge whose far corners,
seen along the edge, are within ``FOLD_DEGREES`` are one sheet doubled.
The exact crossing tests see such a fold only when the two are exactly
coplanar; a float32 flat part (a CAD face, the stress suite's fandisk) is
not, and a cap that closes a spike of its rim with one triangle over the
spike's two scan faces passed them (seed 8, case 14: 2 pairs added).
"""

import numpy as np
import pytest

from shellrepair import Mesh
from eval import shapes
from shellrepair.fill.checks import FOLD_DEGREES, check_patch
from shellrepair.holes.loops import boundary_loops
from shellrepair.mesh.index import ScanContext
from shellrepair.fill.patch import Patch


def _sheet_with_a_square_hole():
    V, F = shapes.grid(7, 7)
    c = V[F].mean(axis=1)
    gone = (np.abs(c[:, 0] - 0.5) < 0.2) & (np.abs(c[:, 1] - 0.5) < 0.2)
    V2, F2, _ = shapes.remove_faces(V, F, gone)
    loops, _ = boundary_loops(F2, len(V2))
    return V2, F2, min(loops, key=len)   # the hole (the other loop is the sheet's edge)


def _fan(V, loop, centre):
    """A fan around one new vertex; triangles on the reversed loop edges."""
    k = len(loop)
    T = np.column_stack([(np.arange(k) + 1) % k, np.arange(k), np.full(k, k)])
    return Patch(hole_id=0, loop=loop, P=np.asarray([centre], float), T=T, disc=False)


def test_a_flat_fan_over_a_flat_hole_passes():
    V, F, loop = _sheet_with_a_square_hole()
    ctx = ScanContext(Mesh(V=V, F=F))
    why, bad = check_patch(ctx, _fan(V, loop, V[loop].mean(axis=0)))
    assert why is None and bad.size == 0


def test_a_fan_whose_centre_lies_over_the_scan_folds_onto_it():
    """The centre moved past a rim edge onto the scan, a hair above its
    plane (0.01 % of an edge: not coplanar, so not an exact crossing):
    the fan's triangle on that edge lies back over the scan face."""
    V, F, loop = _sheet_with_a_square_hole()
    ctx = ScanContext(Mesh(V=V, F=F))
    P = V[loop]
    e = 1 / 6
    edge_mid = 0.5 * (P[0] + P[1])
    out = edge_mid - V[loop].mean(axis=0)
    out[2] = 0.0
    centre = edge_mid + 0.5 * e * out / np.linalg.norm(out) + [0, 0, 1e-4 * e]
    why, bad = check_patch(ctx, _fan(V, loop, centre))
    assert why is not None and "fold" in why and 0 in bad.tolist()


def test_a_fold_is_measured_in_degrees_along_the_edge():
    """A triangle hinged on a scan face's edge: folded back to within
    FOLD_DEGREES of the face it is a fold, opened further it is not."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0]], float)        # the scan: one face
    F = np.array([[0, 1, 2]])
    ctx = ScanContext(Mesh(V=V, F=F))
    loop = np.array([1, 0, 2])  # unused by the check beyond its first edge's faces
    for deg, folded in ((FOLD_DEGREES / 2, True), (2 * FOLD_DEGREES, False), (90.0, False)):
        a = np.radians(deg)
        tip = [0.5, np.cos(a), np.sin(a)]     # the far corner turned by ``deg`` from the face's
        T = np.array([[0, 1, 3]])             # the loop's edge 1 -> 0 reversed, as a patch has it
        p = Patch(hole_id=0, loop=loop, P=np.array([tip], float), T=T)
        why, _ = check_patch(ctx, p)
        assert (why is not None and "fold" in why) == folded, (deg, why)


def test_checks_of_many_patches_at_once_are_those_of_each():
    """checks.check_patches (one batched crossing query) answers as
    check_patch does patch by patch: fans over a hole next to a ramp of
    the scan, one that passes, one folded onto the scan, two through the
    ramp, one with a NaN corner."""
    from shellrepair.fill.checks import check_patches

    V, F, loop = _sheet_with_a_square_hole()
    V = V.copy()
    V[:, 2] = np.where(V[:, 0] > 0.75, 0.8 * (V[:, 0] - 0.75), 0.0)    # the scan rises past x = 0.75
    ctx = ScanContext(Mesh(V=V, F=F))
    centres = [[0.5, 0.5, -0.3], [0.9, 0.5, 0.0], [0.95, 0.5, 0.05], [1.0, 0.5, 0.1], [np.nan, 0.5, 0.0],
               [0.95, 0.5, -0.1]]
    patches = [_fan(V, loop, np.array(c, float)) for c in centres]
    one = [check_patch(ctx, p) for p in patches]
    many = check_patches(ctx, patches)
    assert [w for w, _ in one] == [w for w, _ in many]
    assert all(np.array_equal(a, b) for (_, a), (_, b) in zip(one, many))
    kinds = [w.split(" (")[0] if w else None for w, _ in one]
    assert kinds == [None, "patch would fold onto itself or the scan", "patch would cross the scan",
                     "patch would cross the scan", "non-finite patch positions", None]


@pytest.mark.slow
def test_a_hole_whose_patch_crosses_an_earlier_holes_is_filled_again_around_it(monkeypatch):
    # a random scanner case (stress seed 61803, case 15: a genus-2 solid
    # 28 % unseen from 9 views): hole 3's patch crossed hole 2's and the
    # hole stayed open; it is now filled again on the scan with the
    # accepted patches appended, so its checks keep it off them. (Loops 2,
    # 3 and 6 bound one region, now filled by one pants: the triples are
    # turned off here to keep the refill tested on this case.)
    import numpy as np

    import shellrepair.fill.bands

    monkeypatch.setattr(shellrepair.fill.bands, "pants_triples", lambda *a, **k: [])
    import shellrepair.repair   # (crossed caps are first tried as a tube: off too, to test the refill)

    monkeypatch.setattr(shellrepair.repair, "tube_crossed_caps", lambda *a, **k: None)
    from shellrepair.fill import band_fill    # (nor a band cut open along a seam)

    monkeypatch.setattr(band_fill, "SEAM", False)

    from conftest import STRESS_SHAPES
    from eval import stress
    from shellrepair.mesh.io import Mesh
    from shellrepair.repair import repair_mesh

    shapes = STRESS_SHAPES
    c = stress.stress_case(15, 61803, shapes_ok=shapes)
    assert "genus2" in c.name
    R, rep = repair_mesh(Mesh(V=c.V, F=c.F))
    assert rep["holes_after"] == 0
    assert rep["boundary_edges_after"] == 0 and rep["nonmanifold_edges_after"] == 0
    assert np.array_equal(R.V[:len(c.V)], c.V)
    again = [h for h in rep["holes"] if "filled again around the patches accepted before it" in (h["option"] or "")]
    assert len(again) == 1


@pytest.mark.slow
def test_a_hole_that_crosses_a_neighbours_order_3_cap_even_when_filled_again_closes_beside_its_order_2_fill(
        monkeypatch):
    """A fat torus (r/R 0.7) seen by five views near its equator, 26 % of
    it unseen (seed 318614305, case 10, drawn after the session's changes):
    the 552-edge hole's fill crossed hole 0's order-3 cap, and again when
    filled around the accepted patches; the hole stayed open under the
    default while every forced order closed all four. Hole 0 now gives way
    to its order-2 fill, the hole is filled around that, and every hole
    closes with nothing crossing and no original vertex moved. (Since the
    seam, the band of that hole and another is one patch, 0.35 per mille
    from the truth with its genus, where the caps lay 7.82: the seam is
    left out here to test the refill; with it, below.)"""
    from eval import stress
    from shellrepair.fill import band_fill
    from shellrepair.repair import repair_mesh

    c = stress.stress_case(10, 318614305)
    facts = stress.input_facts(c)
    R, rep = repair_mesh(Mesh(V=c.V, F=c.F))
    m = stress.measure(c, facts, R.V, R.F)
    assert m["holes_closed"] == m["holes"] and m["topology_ok"] and m["si_added"] == 0 and m["rms_permille"] < 1.0
    assert any("cut open along a seam" in (h["option"] or "") for h in rep["holes"])
    monkeypatch.setattr(band_fill, "SEAM", False)
    R, rep = repair_mesh(Mesh(V=c.V, F=c.F))
    assert rep["holes_after"] == 0
    assert rep["boundary_edges_after"] == 0 and rep["nonmanifold_edges_after"] == 0
    assert np.array_equal(R.V[:len(c.V)], c.V)
    rows = {h["id"]: h for h in rep["holes"]}
    assert "hole 0's order-2 fill in place of its order-3 patch" in rows[2]["option"]
    assert rows[0]["order"] == 2 and rows[0]["choice"]["order"] == 3
    assert stress.measure(c, facts, R.V, R.F)["si_added"] == 0


def test_scan_answers_about_a_holes_triangles_are_kept_and_equal_fresh_ones(monkeypatch):
    """The triangulation's ``allowed`` test (a triangle of loop positions
    crosses no scan face) answers a triangle asked before, in any corner
    order and from another ``allowed`` of the same loop, without asking the
    scan again, and the answers are those of a fresh ask."""
    import shellrepair.fill.patch as patch_mod
    from shellrepair.mesh.intersect import patch_vs_index

    V, F = shapes.bumpy_sphere(3, amplitude=0.2, seed=4)
    c = V[F].mean(axis=1)
    V2, F2, _ = shapes.remove_faces(V, F, np.linalg.norm(c - c[0], axis=1) < 0.5)
    loops, _ = boundary_loops(F2, len(V2))
    loop = np.asarray(loops[0], np.int64)
    ctx = ScanContext(Mesh(V=V2, F=F2))
    k = len(loop)
    rng = np.random.default_rng(0)
    T = np.array([rng.choice(k, 3, replace=False) for _ in range(300)])
    fresh = np.ones(len(T), bool)
    fresh[patch_vs_index(V2[loop[T]], loop[T], ctx.index, return_faces=True)] = False
    assert 0 < fresh.sum() < len(T)          # some chords cut through the bumps, some do not
    asked = []
    real = patch_mod.patch_vs_index
    monkeypatch.setattr(patch_mod, "patch_vs_index", lambda Pt, *a, **kw: asked.append(len(Pt)) or real(Pt, *a, **kw))
    first = patch_mod.scan_allowed(ctx, loop)
    assert np.array_equal(first(T[:200]), fresh[:200]) and sum(asked) <= 200
    n = sum(asked)
    again = patch_mod.scan_allowed(ctx, loop)
    assert np.array_equal(again(T[:, ::-1]), fresh)        # corners reversed, from a new allowed()
    known = {tuple(t) for t in np.sort(T[:200], axis=1).tolist()}
    new = [i for i, t in enumerate(np.sort(T, axis=1).tolist()) if tuple(t) not in known]
    assert sum(asked) - n == len(new) < 100                # only the triangles not asked before
