"""The merged output is checked once more, as a whole, before it is written
(issue 37): a patch that crosses the scan, itself or another patch is found
there and left open, whatever the steps before it let through."""

import numpy as np

from shellrepair.fill.merge import crossings_after_merge
from shellrepair.fill.patch import Patch
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext


def _plate_with_two_holes():
    """A flat 8 x 4 grid of unit squares in z = 0 with two square holes (one
    grid cell each, at x in [1, 2] and [5, 6], y in [1, 2])."""
    n, m = 9, 5
    xs, ys = np.meshgrid(np.arange(n, dtype=float), np.arange(m, dtype=float), indexing="ij")
    V = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(n * m)])
    vid = lambda i, j: i * m + j
    F = []
    for i in range(n - 1):
        for j in range(m - 1):
            if (i, j) in ((1, 1), (5, 1)):
                continue
            a, b, c, d = vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)
            F += [[a, b, c], [a, c, d]]
    loops = [np.array([vid(i, 1), vid(i + 1, 1), vid(i + 1, 2), vid(i, 2)]) for i in (1, 5)]
    return Mesh(V=V, F=np.array(F, np.int64)), loops


def _cap(loop, hole_id, apex=None):
    """The hole's cap: two triangles on its rim, or a fan to one new vertex ``apex``."""
    if apex is None:
        return Patch(hole_id=hole_id, loop=loop, P=np.zeros((0, 3)), T=np.array([[0, 1, 2], [0, 2, 3]]))
    return Patch(hole_id=hole_id, loop=loop, P=np.asarray([apex], float),
                 T=np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]))


def test_flat_caps_of_two_holes_cross_nothing():
    mesh, (A, B) = _plate_with_two_holes()
    ctx = ScanContext(mesh)
    assert crossings_after_merge(ctx, [_cap(A, 0), _cap(B, 1)]) == {}
    assert crossings_after_merge(ctx, []) == {}


def test_a_cap_whose_apex_pokes_through_the_scan_is_found():
    mesh, (A, B) = _plate_with_two_holes()
    ctx = ScanContext(mesh)
    # the first hole's flat cap with one more triangle, from a rim corner to
    # two new vertices above and below the plate beside the hole: its edge
    # between them passes through a scan face
    poke = Patch(hole_id=0, loop=A, P=np.asarray([[3.5, 1.5, 0.5], [3.5, 1.5, -0.5]]),
                 T=np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5]]))
    assert crossings_after_merge(ctx, [_cap(B, 1), poke]) == {1: "the scan"}


def test_of_two_patches_that_cross_the_later_one_is_named():
    mesh, (A, B) = _plate_with_two_holes()
    ctx = ScanContext(mesh)
    # two domes over the first hole's rim would touch only at the rim; here the
    # second hole's tall fan leans over onto the first hole's dome
    dome = _cap(A, 0, apex=(1.5, 1.5, 1.0))
    lean = Patch(hole_id=1, loop=B, P=np.asarray([[1.5, 1.5, 0.5]]),
                 T=np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]))
    got = crossings_after_merge(ctx, [dome, lean])
    assert got == {1: "the patch of hole 0"}
