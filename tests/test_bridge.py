"""Bridging a missing band: a tube where the surface continues, caps where it closes."""

import numpy as np
import open3d as o3d
import pytest

from shellrepair import Mesh, detect_holes
from eval import shapes
from shellrepair.fill.tube import tube_triangles
from shellrepair.repair import repair_mesh
from shellrepair.mesh.topology import edge_topology


def torus_without_inner_band(cut=-0.6, r=0.35):
    V, F = shapes.torus(R=1.0, r=r, nu=96, nv=36)
    C = V[F].mean(axis=1)
    cosw = (np.linalg.norm(C[:, :2], axis=1) - 1.0) / r
    V2, F2, _ = shapes.remove_faces(V, F, cosw < cut)
    return V, F, V2, F2


def rel_error_permille(V, F, R):
    """RMS and max distance of the filled surface to the true mesh, ‰ of the box diagonal."""
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    T = R.V[R.F[R.face_filled]]
    u = np.random.default_rng(0).random((len(T), 8, 2))
    u[u.sum(axis=2) > 1] = 1 - u[u.sum(axis=2) > 1]
    P = (T[:, None, 0] + u[..., :1] * (T[:, None, 1] - T[:, None, 0])
         + u[..., 1:] * (T[:, None, 2] - T[:, None, 0])).reshape(-1, 3)
    d = scene.compute_distance(o3d.core.Tensor(P.astype(np.float32))).numpy()
    diag = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    return 1000 * np.sqrt(np.mean(d ** 2)) / diag, 1000 * d.max() / diag


def test_tube_triangles_close_a_strip_consistently():
    t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    A = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])        # counter-clockwise
    s = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    B = np.column_stack([np.cos(-s), np.sin(-s), np.ones_like(s)])       # clockwise, above
    T = tube_triangles(A, B)
    assert len(T) == 12 + 9
    topo = edge_topology(T, 21)
    # the two loops are the strip's only boundary, each loop edge reversed
    he = {(int(a), int(b)) for a, b in topo.he[topo.boundary_he]}
    assert len(he) == 21
    assert all(((i + 1) % 12, i) in he for i in range(12))
    assert all((12 + (i + 1) % 9, 12 + i) in he for i in range(9))


@pytest.mark.parametrize("cut,r", [(-0.6, 0.35), (-0.3, 0.35), (-0.6, 0.2)])
def test_torus_missing_its_inner_band_gets_a_tube(cut, r):
    V, F, V2, F2 = torus_without_inner_band(cut, r)
    assert len(detect_holes(V2, F2).holes) == 2
    R, rep = repair_mesh(Mesh(V=V2, F=F2))
    assert [b["chosen"] for b in rep["bridges"]] == ["tube"]
    assert rep["holes_after"] == 0 and rep["boundary_edges_after"] == 0
    assert rep["nonmanifold_edges_after"] == 0
    assert rep["euler_before"] == 0 and rep["euler_after"] == 0      # genus 1 again
    rms, mx = rel_error_permille(V, F, R)
    assert rms <= 10.0, rms


def test_an_order_3_cap_crossing_another_falls_back_on_its_order_2_fill(monkeypatch):
    # at the default order both caps of this band choose order 3; the first
    # one's order-3 cap bulges into the second's: the merge puts the first
    # hole's checked order-2 fill in its place and both close (before,
    # the second hole stayed open). (The first cap's order 3 also departs
    # from its order 2 a little more than its order 1 does, 0.137 against
    # 0.134, which keeps order 2 before the merge; that guard is set aside
    # here, so that the merge's own fallback is what is tested.)
    from shellrepair.fill import hole

    monkeypatch.setattr(hole, "_departs", lambda *a: None)
    V, F, V2, F2 = torus_without_inner_band()
    R, rep = repair_mesh(Mesh(V=V2, F=F2), bridge="never")
    assert rep["holes_after"] == 0
    assert rep["boundary_edges_after"] == 0 and rep["nonmanifold_edges_after"] == 0
    assert np.array_equal(R.V[:len(V2)], V2)
    first = rep["holes"][0]["option"]
    assert first.startswith("faired order 2") and "would cross: order 2 kept" in first


def test_never_caps_the_band_and_gets_the_shape_wrong():
    # at order 2: at order 3 the two caps bulge into each other and the
    # second is refused, and the default order's choice sits on its
    # threshold here (order 3 lay 0.159 from order 2 against errors summing
    # to 0.147 before order 3 started from the thin-plate solve, just under
    # since; at cut -0.7, or r 0.3 or 0.4, the second cap was refused before)
    V, F, V2, F2 = torus_without_inner_band()
    R, rep = repair_mesh(Mesh(V=V2, F=F2), bridge="never", order=2)
    assert rep["bridges"] == [] and rep["holes_after"] == 0
    assert rep["euler_after"] == 2                                   # two caps: a sphere
    assert rel_error_permille(V, F, R)[0] > 20.0


def test_two_distant_holes_on_a_sphere_get_caps():
    V, F = shapes.icosphere(4)
    a, b = int(np.argmax(V[:, 2])), int(np.argmin(V[:, 2]))
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[a, b], radius=0.5)
    for mode in ("auto", "always"):
        R, rep = repair_mesh(Mesh(V=V2, F=F2), bridge=mode)
        assert rep["bridges"] == []          # not even a candidate pair
        assert rep["holes_after"] == 0 and rep["euler_after"] == 2


def test_cylinder_missing_a_ring_gets_a_tube():
    V, F = shapes.cylinder(0.5, 2.0, 48, 40)
    gap = np.abs(V[F].mean(axis=1)[:, 2]) < 0.15
    V2, F2, _ = shapes.remove_faces(V, F, gap)
    R, rep = repair_mesh(Mesh(V=V2, F=F2))
    tubes = [b for b in rep["bridges"] if b["chosen"] == "tube"]
    assert len(tubes) == 1
    # the tube's new vertices lie on the cylinder
    P = R.V[R.vertex_filled]
    band = np.abs(P[:, 2]) < 0.2
    assert band.sum() > 0
    assert np.abs(np.linalg.norm(P[band, :2], axis=1) - 0.5).max() < 0.02


def test_arc_points_are_exact_circles_and_lines():
    from shellrepair.fill.bridge import arc_points

    U = np.zeros((3, 3))
    T = np.tile([1.0, 0.0, 0.0], (3, 1))
    N = np.tile([0.0, 0.0, 1.0], (3, 1))
    kappa = np.array([2.0, -0.5, 0.0])
    s = np.linspace(0.0, 3.0, 31)[None].repeat(3, 0)
    X = arc_points(U, T, N, kappa, s)
    # on the circle of radius 1/|κ| centred at N/κ, at arc length s
    for i in range(2):
        c = N[i] / kappa[i]
        assert np.allclose(np.linalg.norm(X[i] - c, axis=1), 1 / abs(kappa[i]), atol=1e-12)
        chord = np.linalg.norm(X[i] - U[i], axis=1)
        assert np.allclose(chord, 2 / abs(kappa[i]) * np.abs(np.sin(kappa[i] * s[i] / 2)), atol=1e-12)
    assert np.allclose(X[2], s[2][:, None] * T[2], atol=1e-15)     # κ = 0: the tangent line
    tiny = arc_points(U[:1], T[:1], N[:1], np.array([1e-12]), s[:1])
    assert np.allclose(tiny, X[2:], atol=1e-9)                     # continuous as κ -> 0


def test_ring_masks_are_the_columns_the_adjacency_rows_meet():
    """The rings around a loop in the continuation arcs: the vertices an
    edge joins to a marked vertex are exactly the columns where the marked
    rows of the all-ones adjacency sum above zero (repeated edges and
    self-loops included)."""
    import scipy.sparse as sp

    from shellrepair.fill.bridge import next_to

    rng = np.random.default_rng(3)
    nv = 60
    E = rng.integers(0, nv, (150, 2))
    E = np.vstack([E, E[:10], [[7, 7], [8, 8]]])
    A = sp.csr_matrix((np.ones(2 * len(E)), (np.concatenate([E[:, 0], E[:, 1]]), np.concatenate([E[:, 1], E[:, 0]]))),
                      shape=(nv, nv))
    A.data[:] = 1.0
    for _ in range(5):
        mark = rng.random(nv) < 0.1
        want = A[np.flatnonzero(mark)].sum(axis=0).A1 > 0
        assert np.array_equal(next_to(E, mark), want)
    assert not next_to(E, np.zeros(nv, bool)).any()
