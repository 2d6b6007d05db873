"""A harmonic patch kept where the hole's order failed is faired again at that order.

The harmonic patch (order 1) is a hole's and a band's last option before
the last layer: it keeps to the rim's plane, so it passes where order 2
crosses the scan, but it is a membrane, flat across a round opening.
:func:`shellrepair.fill.hole.refair_on_harmonic` fairs its own mesh again
at the hole's order and holds the harmonic positions only around the
faults that fairing makes:

* on a sphere's cap the patch faired again is rounder than the membrane,
  on the same triangles, and passes the checks;
* where the fairing fails somewhere, the vertices there keep the harmonic
  positions and the rest is faired;
* nothing else is touched: a patch at order 1 by request, a faired patch,
  a flat cap.
"""

import numpy as np

from eval import shapes
from shellrepair import Mesh
from shellrepair.fill.checks import check_patch
from shellrepair.fill.hole import refair_on_harmonic
from shellrepair.fill.patch import build_patch
from shellrepair.holes.loops import boundary_loops
from shellrepair.mesh.index import ScanContext


def _sphere_with_a_cap_cut():
    V, F = shapes.icosphere(4)
    c = V[F].mean(axis=1)
    V2, F2, _ = shapes.remove_faces(V, F, c[:, 2] > 0.6)
    loops, _ = boundary_loops(F2, len(V2))
    return ScanContext(Mesh(V=V2, F=F2)), loops[0]


def _off_sphere(P):
    return float(np.abs(np.linalg.norm(P, axis=1) - 1.0).mean())


def test_a_harmonic_cap_faired_again_is_rounder_on_the_same_triangles():
    ctx, loop = _sphere_with_a_cap_cut()
    harmonic = build_patch(ctx, 0, loop, order=1).with_(kind="harmonic", option="harmonic (order 1)")
    assert check_patch(ctx, harmonic)[0] is None
    again = refair_on_harmonic(ctx, harmonic, 2, 0)
    assert again.kind == "faired" and again.order == 2 and again.pinned == 0
    assert np.array_equal(again.T, harmonic.T) and np.array_equal(again.loop, harmonic.loop)
    assert check_patch(ctx, again)[0] is None
    assert _off_sphere(again.P) < 0.25 * _off_sphere(harmonic.P)
    assert again.option.startswith("harmonic (order 1); faired again at order 2")


def test_the_vertices_around_a_fault_of_the_new_fairing_keep_the_harmonic_positions():
    ctx, loop = _sphere_with_a_cap_cut()
    harmonic = build_patch(ctx, 0, loop, order=1).with_(kind="harmonic")
    k = len(loop)
    inner = int(np.flatnonzero((harmonic.T >= k).all(axis=1))[0])      # a triangle of new vertices only
    calls = []

    def fails_once(ctx_, p):
        calls.append(p)
        return ("a fault", np.array([inner])) if len(calls) == 1 else (None, np.zeros(0, np.int64))

    again = refair_on_harmonic(ctx, harmonic, 2, 0, check=fails_once)
    assert len(calls) == 2 and again.P is calls[1].P      # the second fairing, which passed
    held = harmonic.T[inner] - k
    assert again.pinned > len(held)                         # the fault's vertices and two rings around them
    assert np.allclose(again.P[held], harmonic.P[held])
    free = np.setdiff1d(np.arange(len(harmonic.P)), held)
    assert not np.allclose(again.P[free], harmonic.P[free])
    assert "vertices held on it around its faults" in again.option


def test_only_a_harmonic_patch_below_the_holes_order_is_faired_again():
    ctx, loop = _sphere_with_a_cap_cut()
    harmonic = build_patch(ctx, 0, loop, order=1).with_(kind="harmonic")
    faired = build_patch(ctx, 0, loop, order=2).with_(kind="faired")
    flat_cap = harmonic.with_(kind="flat cap")
    assert refair_on_harmonic(ctx, harmonic, 1, 0) is harmonic          # order 1 was asked for
    assert refair_on_harmonic(ctx, faired, 3, 0) is faired
    assert refair_on_harmonic(ctx, flat_cap, 2, 0) is flat_cap          # a flat cap stays flat
    assert refair_on_harmonic(ctx, None, 2, 0) is None
