"""Triangle–triangle tests and the local triangle index.

Crossing means the relative interiors of two triangles meet; touching at
shared (or merely coincident) vertices and edges, or at any boundary
point, is contact. The reference for random pairs is an oracle in exact
rational arithmetic (``fractions.Fraction``) that builds the intersection
of the two triangles and asks whether its centre lies inside both.
"""

from fractions import Fraction

import numpy as np
import pytest

from eval import shapes
from shellrepair.mesh.topology import edge_topology
from shellrepair.mesh.intersect import (NearFaces, TriangleIndex, crossing_pairs, embeds_by_projection,
                                   pair_intersections, patch_vs_index, self_intersections, triangles_cross)
from shellrepair.mesh.predicates import orient2d, orient3d


# --------------------------------------------------------------------------
# the exact oracle
# --------------------------------------------------------------------------
def _sub(a, b):
    return [x - y for x, y in zip(a, b)]


def _crs(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dt(a, b):
    return sum(x * y for x, y in zip(a, b))


def _strictly_inside(T, x):
    """x (in T's plane) has all three barycentric coordinates > 0."""
    n = _crs(_sub(T[1], T[0]), _sub(T[2], T[0]))
    return all(_dt(_crs(_sub(T[(i + 1) % 3], x), _sub(T[(i + 2) % 3], x)), n) > 0 for i in range(3))


def _clip(poly, a, b, n):
    """The part of a planar polygon on the inner side of the directed edge a→b."""
    side = lambda x: _dt(_crs(_sub(b, a), _sub(x, a)), n)
    out = []
    for P, Q in zip(poly, poly[1:] + poly[:1]):
        fp, fq = side(P), side(Q)
        if fp >= 0:
            out.append(P)
        if fp * fq < 0:
            t = fp / (fp - fq)
            out.append([p + t * (q - p) for p, q in zip(P, Q)])
    return out


def oracle_cross(A, B):
    """Do the interiors of two non-degenerate triangles meet, in exact
    rationals? The intersection A ∩ B is built (clipped polygon when
    coplanar, otherwise the overlap of the two segments cut from the
    planes' common line); when the interiors meet, the centre of that
    intersection lies strictly inside both (Rockafellar, Thm 6.5)."""
    A = [[Fraction(float(x)) for x in p] for p in A]
    B = [[Fraction(float(x)) for x in p] for p in B]
    nA = _crs(_sub(A[1], A[0]), _sub(A[2], A[0]))
    nB = _crs(_sub(B[1], B[0]), _sub(B[2], B[0]))
    assert any(nA) and any(nB), "the oracle takes non-degenerate triangles"
    dB = [_dt(nA, _sub(p, A[0])) for p in B]
    if all(d == 0 for d in dB):
        poly = A
        for i in range(3):
            poly = _clip(poly, B[i], B[(i + 1) % 3], nB)
            if not poly:
                return False
        c = [sum(p[k] for p in poly) / len(poly) for k in range(3)]
        return _strictly_inside(A, c) and _strictly_inside(B, c)
    dA = [_dt(nB, _sub(p, B[0])) for p in A]

    def cut(T, d):   # T ∩ the other plane, as points on the common line
        pts = [T[i] for i in range(3) if d[i] == 0]
        for i in range(3):
            j = (i + 1) % 3
            if d[i] * d[j] < 0:
                t = d[i] / (d[i] - d[j])
                pts.append([p + t * (q - p) for p, q in zip(T[i], T[j])])
        return sorted(pts, key=lambda p: _dt(L, p))

    L = _crs(nA, nB)
    pa, pb = cut(A, dA), cut(B, dB)
    if not pa or not pb:
        return False
    lo = max(pa[0], pb[0], key=lambda p: _dt(L, p))
    hi = min(pa[-1], pb[-1], key=lambda p: _dt(L, p))
    if _dt(L, lo) > _dt(L, hi):
        return False
    c = [(x + y) / 2 for x, y in zip(lo, hi)]
    return _strictly_inside(A, c) and _strictly_inside(B, c)


def tri(*p):
    return np.array(p, float)[None]


def crosses(a, b):
    return bool(triangles_cross(tri(*a), tri(*b))[0])


# --------------------------------------------------------------------------
# contact is not crossing: the cases one by one
# --------------------------------------------------------------------------
A0 = ([0, 0, 0], [2, 0, 0], [0, 2, 0])          # in z = 0


def test_piercing_crosses_and_far_apart_does_not():
    assert crosses(A0, ([0.5, 0.5, -1], [0.5, 0.5, 1], [1.5, 0.2, 0]))
    assert not crosses(A0, ([5, 5, 5], [6, 5, 5], [5, 6, 5]))
    # a corner resting on the interior, the rest above: touching
    assert not crosses(A0, ([0.5, 0.5, 0], [0.5, 0.5, 1], [1.5, 0.2, 1]))
    # an edge lying on the interior, the triangle standing on it: touching
    assert not crosses(A0, ([0.2, 0.2, 0], [1.2, 0.4, 0], [0.5, 0.5, 1]))


def test_a_shared_vertex_is_contact_unless_the_interiors_meet_beyond_it():
    # standing on the shared corner, out of A's plane
    assert not crosses(A0, ([0, 0, 0], [-1, 0.5, 1], [-0.5, -1, 1]))
    # the opposite edge pierces A
    assert crosses(A0, ([0, 0, 0], [1, 0.5, -1], [0.5, 1, 1]))
    # in A's plane, on the far side of the shared corner: touching
    assert not crosses(A0, ([0, 0, 0], [-2, 0, 0], [0, -2, 0]))
    # in A's plane, overlapping A beyond the shared corner: crossing
    assert crosses(A0, ([0, 0, 0], [1, 0.2, 0], [0.2, 1, 0]))
    # in A's plane, sharing the corner and the line of one edge, outside: touching
    assert not crosses(A0, ([0, 0, 0], [1, 0, 0], [1, -1, 0]))


def test_a_shared_edge_is_contact_unless_folded_flat_onto_the_other():
    assert not crosses(A0, ([0, 0, 0], [2, 0, 0], [1, -1, 1]))          # at an angle
    assert not crosses(A0, ([0, 0, 0], [2, 0, 0], [1, -1, 0]))          # flat, unfolded
    assert crosses(A0, ([2, 0, 0], [0, 0, 0], [0.5, 1, 0]))             # folded flat onto A
    assert crosses(A0, ([2, 0, 0], [0, 0, 0], [3, 1, 0]))               # folded, poking out past A
    # folded to within a hair but not flat: the two meet along the edge only
    assert not crosses(A0, ([2, 0, 0], [0, 0, 0], [0.5, 1, 1e-300]))
    assert not crosses(A0, ([2, 0, 0], [0, 0, 0], [0.5, 1, -2.0 ** -1074]))
    # the same face twice
    assert crosses(A0, A0)


def test_coplanar_triangles_cross_only_when_they_overlap_in_area():
    assert crosses(A0, ([0.5, 0.5, 0], [3, 0.5, 0], [0.5, 3, 0]))       # overlapping
    assert crosses(A0, ([-1, 0.5, 0], [3, 0.5, 0], [1, 0.7, 0]))        # a thin band across
    assert not crosses(A0, ([0, 2, 0], [2, 0, 0], [2, 2, 0]))           # along the whole hypotenuse
    assert not crosses(A0, ([0.5, 1.5, 0], [1.5, 0.5, 0], [2, 2, 0]))   # along part of it
    assert not crosses(A0, ([2, 0, 0], [3, -1, 0], [3, 1, 0]))          # at a point
    assert not crosses(A0, ([1, 1, 0], [3, 1, 0], [1, 3, 0]))           # at a point of an edge
    assert not crosses(A0, ([3, 3, 0], [4, 3, 0], [3, 4, 0]))           # apart
    assert crosses(A0, ([0.1, 0.1, 0], [0.5, 0.1, 0], [0.1, 0.5, 0]))   # inside


def test_vertices_at_one_position_are_contact_whatever_their_ids():
    # the shared-edge and shared-vertex cases again, with ids all different
    ids_a, ids_b = np.array([[0, 1, 2]]), np.array([[3, 4, 5]])
    cases = [(([0, 0, 0], [2, 0, 0], [1, -1, 1]), False), (([2, 0, 0], [0, 0, 0], [0.5, 1, 0]), True),
             (([0, 0, 0], [-1, 0.5, 1], [-0.5, -1, 1]), False), (([0, 0, 0], [1, 0.5, -1], [0.5, 1, 1]), True)]
    for b, want in cases:
        assert pair_intersections(tri(*A0), ids_a, tri(*b), ids_b)[0] == want


def test_zero_area_triangles_are_the_segments_they_cover():
    seg = ([0.5, 0.5, -1], [0.5, 0.5, 0], [0.5, 0.5, 1])          # a needle through A
    assert crosses(A0, seg) and crosses(seg, A0)
    assert not crosses(A0, ([0.5, 0.5, 0], [0.5, 0.5, 1], [0.5, 0.5, 2]))   # standing on A
    assert crosses(A0, ([-1, 0.5, 0], [0, 0.5, 0], [1, 0.5, 0]))    # lying across A in its plane
    assert not crosses(A0, ([-1, 0, 0], [0, 0, 0], [3, 0, 0]))      # along A's edge
    assert not crosses(A0, ([1, 1, 1], [1, 1, 1], [1, 1, 1]))       # a point
    # two needles: crossing in a point of both, touching end to middle, overlapping on a line
    assert crosses(([0, 0, 0], [1, 1, 0], [2, 2, 0]), ([0, 2, 0], [1, 1, 0], [2, 0, 0])) is True
    assert crosses(([-1, 1, 0], [0, 1, 0], [1, 1, 0]), ([0, 0, 0], [1, 0, 0], [2, 0, 0])) is False
    assert crosses(([0, 0, 0], [1, 0, 0], [2, 0, 0]), ([1.5, 0, 0], [2, 0, 0], [3, 0, 0]))
    assert not crosses(([0, 0, 0], [1, 0, 0], [1, 0, 0]), ([1, 0, 0], [1, 1, 0], [1, 2, 0]))


def test_slivers_are_decided_exactly_not_by_a_tolerance():
    # a sliver 1e-300 wide (not zero): its long edge passes through A's
    # interior just above and below the plane
    s = ([0.5, 0.5, -1], [0.5, 0.5, 1], [0.5, 0.5 + 1e-300, 1])
    assert crosses(A0, s)
    # the same sliver moved to touch A's edge x = 0 with its long edge: touching only
    t = ([0, 0.5, -1], [0, 0.5, 1], [-1e-300, 0.5, 1])
    assert not crosses(A0, t)
    # and moved a hair (one ulp of 0.5) inside: crossing
    u = ([2.0 ** -54, 0.5, -1], [2.0 ** -54, 0.5, 1], [0, 0.5, 1])
    assert crosses(A0, u)
    # nearly coplanar, overlapping in projection: decided by the exact side of each corner
    v = ([0.5, 0.5, 1e-17], [1.5, 0.2, 1e-17], [0.2, 1.5, -1e-17])
    assert crosses(A0, v) == oracle_cross(A0, v)
    w = ([0.5, 0.5, 1e-17], [1.5, 0.2, 1e-17], [0.2, 1.5, 1e-17])
    assert not crosses(A0, w) and not oracle_cross(A0, w)


@pytest.mark.parametrize("offset", [0.0, 1e6, -3e6, 2.0 ** 40])
def test_answers_do_not_change_under_large_offsets(offset):
    # corners on a grid of 1/8: exact at every offset here, so the geometry,
    # and the answer, are the same
    rng = np.random.default_rng(4)
    n = 3000
    A = rng.integers(-8, 9, size=(n, 3, 3)) / 8.0
    B = rng.integers(-8, 9, size=(n, 3, 3)) / 8.0
    B[: n // 3, 0] = A[: n // 3, 0]
    B[: n // 6, 1] = A[: n // 6, 2]
    A[n // 2:, :, 2] = 0.25
    B[n // 2:, :, 2] = 0.25
    ref = triangles_cross(A, B)
    assert np.array_equal(ref, triangles_cross(A + offset, B + offset))
    assert ref.sum() > 200 and (~ref).sum() > 200


def _random_pairs(rng, n, grid):
    """Pairs on a small integer grid (shared corners, coplanar pairs and
    corners on the other's plane are frequent), non-degenerate."""
    A = rng.integers(-grid, grid + 1, size=(n, 3, 3)).astype(float)
    B = rng.integers(-grid, grid + 1, size=(n, 3, 3)).astype(float)
    m = rng.random(n) < 0.3
    B[m, 0] = A[m, 1]
    m = rng.random(n) < 0.15
    B[m, 1] = A[m, 2]
    m = rng.random(n) < 0.3
    A[m, :, 2] = 0
    B[m, :, 2] = 0
    area = lambda T: np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1)
    ok = (area(A) > 0) & (area(B) > 0)
    return A[ok], B[ok]


@pytest.mark.parametrize("seed", [0, 1])
def test_random_pairs_agree_with_the_exact_rational_oracle(seed):
    rng = np.random.default_rng(seed)
    A, B = _random_pairs(rng, 1000, 2)
    got = triangles_cross(A, B)
    ref = np.array([oracle_cross(a, b) for a, b in zip(A, B)])
    assert ref.sum() > 150 and (~ref).sum() > 150        # both kinds drawn
    assert np.array_equal(got, ref)
    assert np.array_equal(got, triangles_cross(B, A))    # symmetric
    # ids naming the shared corners only save arithmetic: the same answers
    ida = np.arange(3 * len(A)).reshape(-1, 3)
    idb = ida + 3 * len(A)
    same = (B[:, :, None, :] == A[:, None, :, :]).all(axis=3)      # (p, corner of B, corner of A)
    r, j, i = np.nonzero(same)
    idb[r, j] = ida[r, i]
    assert np.array_equal(pair_intersections(A, ida, B, idb), ref)


def test_near_coplanar_float_pairs_agree_with_the_oracle():
    # B squeezed towards A's plane at every scale down to round-off, some
    # sharing a corner, some at a 1e6 offset
    rng = np.random.default_rng(7)
    n = 800
    A = rng.normal(size=(n, 3, 3))
    B = rng.normal(size=(n, 3, 3))
    nA = np.cross(A[:, 1] - A[:, 0], A[:, 2] - A[:, 0])
    nA /= np.linalg.norm(nA, axis=1)[:, None]
    off = np.einsum("pij,pj->pi", B - A[:, :1], nA)
    squeeze = 10.0 ** rng.uniform(-18, 0, size=(n, 1))
    B -= ((1 - squeeze) * off)[:, :, None] * nA[:, None, :]
    m = rng.random(n) < 0.3
    B[m, 0] = A[m, 0]
    m = rng.random(n) < 0.3
    A[m] += 1e6
    B[m] += 1e6
    got = triangles_cross(A, B)
    ref = np.array([oracle_cross(a, b) for a, b in zip(A, B)])
    assert ref.sum() > 50 and (~ref).sum() > 50
    assert np.array_equal(got, ref)


def test_orientation_predicates_are_exact_where_floats_round():
    # d on the plane of a, b, c up to one rounding; the sign from exact rationals
    rng = np.random.default_rng(2)
    n = 2000
    P = rng.normal(size=(n, 4, 3)) + rng.choice([0.0, 1e6], size=(n, 1, 1))
    w = rng.random((n, 2))
    P[:, 3] = P[:, 0] + w[:, :1] * (P[:, 1] - P[:, 0]) + w[:, 1:] * (P[:, 2] - P[:, 0])
    q = n // 4                                                   # exactly coplanar ones
    P[:q] = np.round(P[:q] * 4)
    P[:q, 3] = P[:q, 1] + P[:q, 2] - P[:q, 0]
    F = [[[Fraction(float(x)) for x in p] for p in q] for q in P]

    def det3(a, b, c, d):
        u, v, t = _sub(a, d), _sub(b, d), _sub(c, d)
        return _dt(u, _crs(v, t))

    ref = np.array([np.sign(det3(*q)) for q in F])
    assert np.array_equal(orient3d(P[:, 0], P[:, 1], P[:, 2], P[:, 3]), ref)
    assert (ref == 0).sum() > 100 and (ref != 0).sum() > 100
    a, b = P[:, 0, :2], P[:, 1, :2]
    c = a + 0.3 * (b - a)
    ref2 = [np.sign((Fraction(q[1][0]) - Fraction(q[0][0])) * (Fraction(r[1]) - Fraction(q[0][1]))
                    - (Fraction(q[1][1]) - Fraction(q[0][1])) * (Fraction(r[0]) - Fraction(q[0][0])))
            for q, r in zip(P[:, :2, :2].tolist(), c.tolist())]
    assert np.array_equal(orient2d(a, b, c), np.array(ref2))


# --------------------------------------------------------------------------
# pairs within a set, the whole-mesh count, the local index
# --------------------------------------------------------------------------
def test_crossing_pairs_are_exactly_the_crossing_pairs_among_all_pairs():
    # a soup of small triangles in a box, a few huge ones through it, some
    # corners shared; every pair tested by brute force is the reference
    rng = np.random.default_rng(5)
    t = 400
    c = rng.uniform(0, 4, size=(t, 1, 3))
    C = c + rng.normal(scale=0.25, size=(t, 3, 3))
    C[:3] = rng.uniform(-2, 6, size=(3, 3, 3))            # huge triangles
    ids = np.arange(3 * t).reshape(t, 3)
    ids[10:40, 0] = ids[40:70, 0]                        # shared corners ...
    C[10:40, 0] = C[40:70, 0]                            # ... at one position
    i, j = np.triu_indices(t, 1)
    ref = pair_intersections(C[i], ids[i], C[j], ids[j])
    got = crossing_pairs(C, ids)
    assert ref.sum() > 50
    assert (got[:, 0] < got[:, 1]).all()
    assert {tuple(p) for p in got} == set(zip(i[ref], j[ref]))


def test_closed_sphere_has_no_self_intersections_and_a_dent_through_it_has():
    V, F = shapes.icosphere(3)
    assert self_intersections(V, F) == 0
    V2 = V.copy()
    V2[0] = -1.5 * V[0]          # pull one vertex through to the other side
    assert self_intersections(V2, F) > 0


def test_near_faces_finds_what_the_whole_mesh_index_finds_and_looks_only_nearby():
    V, F = shapes.grid(60, 60)   # a flat sheet in z = 0 on [0, 1]^2
    full = TriangleIndex(V, F)
    tree = NearFaces(V, F)
    tree.BRUTE = 0   # pairs through its k-d tree path, not the brute-force product
    nears = (NearFaces(V, F), NearFaces(V, F, topo=edge_topology(F, len(V))), tree)
    for near in nears:
        assert near.faces_near([0.0, 0.0, -0.1], [0.1, 0.1, 0.1]).size < len(F) / 10
    rng = np.random.default_rng(3)
    ids = np.array([[-1, -2, -3]])
    hits = 0
    for _ in range(40):
        c = np.append(rng.uniform(0, 1, 2), rng.uniform(-0.05, 0.05))
        probe = c + rng.normal(scale=0.03, size=(3, 3, 3))
        ids = -1 - np.arange(9).reshape(3, 3)
        n = patch_vs_index(probe, ids, full)
        assert all(patch_vs_index(probe, ids, near) == n for near in nears)
        hits += n
    assert hits > 0   # some probes pierce the sheet


def test_near_faces_keeps_a_long_triangle_reaching_in_from_far_away():
    V, F = shapes.grid(30, 30)
    # one sliver from far outside the sheet whose tip passes under the middle
    V = np.vstack([V, [[5.0, 0.5, -0.01], [5.0, 0.52, -0.01], [0.5, 0.51, -0.01]]])
    F = np.vstack([F, [[len(V) - 3, len(V) - 2, len(V) - 1]]])
    for near in (NearFaces(V, F), NearFaces(V, F, topo=edge_topology(F, len(V)))):
        assert near.big.tolist() == [len(F) - 1]         # kept apart, not growing every box
        assert len(F) - 1 in near.faces_near([0.45, 0.45, -0.1], [0.55, 0.55, 0.1])
        probe = np.array([[[0.7, 0.505, -0.05], [0.7, 0.515, 0.05], [0.72, 0.51, 0.05]]])
        assert patch_vs_index(probe, np.array([[-1, -2, -3]]), near, return_faces=True).size == 1


class _SpheresOnly:
    """A TriangleIndex seen without faces_near: patch_vs_index then pairs by
    bounding spheres and tests in NumPy (its path before the compiled one)."""

    def __init__(self, index):
        self.V, self.F, self.origin = index.V, index.F, index.origin
        self.candidate_pairs = index.candidate_pairs


@pytest.mark.parametrize("offset", [0.0, 1e6])
def test_a_small_index_finds_the_same_crossings_by_boxes_as_by_spheres(offset):
    """TriangleIndex (the mender's index of kept patch triangles) gives
    patch_vs_index its faces by box, for the compiled pairs and tests: the
    same crossing triangles and the same counts as by sphere pairs, for fans
    whose apex lies far off (long triangles: big spheres), probes sharing
    corner ids with the indexed faces, and at a large offset."""
    V, F = shapes.grid(25, 25)
    rng = np.random.default_rng(5)
    V = V + rng.normal(scale=0.004, size=V.shape) + offset
    index = TriangleIndex(V, F, origin=V.mean(axis=0))
    spheres = _SpheresOnly(index)
    hits = shared = 0
    for trial in range(60):
        c = np.append(rng.uniform(0.1, 0.9, 2), 0.0) + offset
        m = int(rng.integers(3, 12))
        t = np.sort(rng.uniform(0, 2 * np.pi, m))
        rim = c + np.column_stack([0.08 * np.cos(t), 0.08 * np.sin(t), rng.normal(scale=0.02, size=m)])
        apex = c + [0.0, 0.0, rng.choice([-0.5, -0.01, 0.01, 0.5, 2.0])]
        Pt = np.stack([np.roll(rim, -1, axis=0), rim, np.broadcast_to(apex, rim.shape)], axis=1)
        ids = np.column_stack([-2 - np.roll(np.arange(m), -1), -2 - np.arange(m), np.full(m, -1)])
        if trial % 3 == 0:      # one fan corner on a grid vertex, with its id: touching there is contact
            v = int(np.argmin(np.linalg.norm(V - rim[0], axis=1)))
            Pt[0, 1] = Pt[m - 1, 0] = V[v]
            ids[0, 1] = ids[m - 1, 0] = v
            shared += 1
        got = patch_vs_index(Pt, ids, index, return_faces=True)
        want = patch_vs_index(Pt, ids, spheres, return_faces=True)
        assert np.array_equal(got, want)
        assert patch_vs_index(Pt, ids, index) == patch_vs_index(Pt, ids, spheres)
        hits += got.size
    assert hits > 20 and shared == 20
    lo, hi = index.V.min(axis=0), index.V.max(axis=0)
    assert np.array_equal(index.faces_near(lo, hi), np.arange(len(F)))
    assert index.faces_near(hi + 1.0, hi + 2.0).size == 0


def test_near_face_pairs_are_the_same_by_tree_and_by_product_with_huge_faces_about():
    # a sheet with a few long triangles lying across it (a scan's flat base
    # seen from its wall): the tree path pairs them apart, the set of
    # sphere-meeting pairs is the one the all-pairs product finds
    V, F = shapes.grid(40, 40)
    rng = np.random.default_rng(8)
    extra = []
    for _ in range(6):
        a = rng.uniform(0, 1, 3) * [1, 1, 0.02]
        extra.append([a, a + [0.9, 0.1, 0], a + [0.1, 0.8, 0.01]])
    V = np.vstack([V, np.reshape(extra, (-1, 3))])
    F = np.vstack([F, len(V) - 18 + np.arange(18).reshape(6, 3)])
    by_tree, by_product = NearFaces(V, F), NearFaces(V, F)
    by_tree.BRUTE, by_product.BRUTE = 0, 10 ** 12
    for _ in range(10):
        C = np.column_stack([rng.uniform(0.2, 0.8, (50, 2)), rng.uniform(-0.02, 0.02, 50)])
        R = rng.uniform(0.005, 0.03, 50)
        a = set(zip(*by_tree.candidate_pairs(C, R)))
        b = set(zip(*by_product.candidate_pairs(C, R)))
        assert a == b and any(j >= len(F) - 6 for _, j in a)


def test_projection_certificate_accepts_a_dome_and_refuses_a_fold():
    k = 24
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    loop = np.column_stack([np.cos(t), np.sin(t), np.zeros(k)])
    inner = np.column_stack([0.5 * np.cos(t), 0.5 * np.sin(t), np.full(k, 0.3)])
    P = np.vstack([loop, inner, [[0, 0, 0.4]]])
    T = []
    for i in range(k):
        j = (i + 1) % k
        # loop edges appear reversed (i+1 -> i) in the patch, as in a repair
        T += [[j, i, k + i], [j, k + i, k + j], [k + j, k + i, 2 * k]]
    T = np.array(T)
    assert embeds_by_projection(P, T, k)                 # a dome over a circle
    bad = P.copy()
    bad[2 * k] = [0.9, 0.0, 0.4]                         # the apex pulled over the rim: triangles flip
    assert not embeds_by_projection(bad, T, k)
    assert not embeds_by_projection(P, T[:, ::-1], k)    # wound the wrong way round
    eight = P.copy()
    eight[:k // 2, 1] *= -1                              # a loop whose outline crosses itself
    assert not embeds_by_projection(eight, T, k)


def test_projection_certificate_never_covers_a_patch_that_crosses_itself():
    k = 24
    t = np.linspace(0, 2 * np.pi, k, endpoint=False)
    rings = [np.column_stack([r * np.cos(t + 0.1 * r), r * np.sin(t + 0.1 * r), np.full(k, 1 - r * r)])
             for r in (1.0, 0.7, 0.4)]
    P0 = np.vstack(rings + [[[0, 0, 1.0]]])
    T = []
    for ring in range(2):
        a, b = ring * k, (ring + 1) * k
        for i in range(k):
            j = (i + 1) % k
            T += [[a + j, a + i, b + i], [a + j, b + i, b + j]]
    T += [[2 * k + (i + 1) % k, 2 * k + i, 3 * k] for i in range(k)]
    T = np.array(T)
    rng = np.random.default_rng(11)
    certified = crossing = 0
    for trial in range(150):
        P = P0.copy()
        P[k:] += rng.normal(scale=0.01 * (1 + trial // 15), size=(len(P) - k, 3))
        ok = embeds_by_projection(P, T, k)
        n = self_intersections(P, T)
        assert not (ok and n > 0)
        certified += ok
        crossing += n > 0
    assert certified > 20 and crossing > 5   # both kinds were drawn


@pytest.mark.parametrize("scale", [2.0 ** -1000, 2.0 ** -1060, 2.0 ** 500])
def test_predicates_keep_their_signs_at_extreme_scales(scale):
    # scaling by a power of two keeps every sign; near underflow and past
    # overflow the float filter cannot be trusted, so those rows go exact
    rng = np.random.default_rng(9)
    P = np.round(rng.normal(size=(500, 4, 3)) * 8)
    P[:100, 3] = P[:100, 1] + P[:100, 2] - P[:100, 0]     # exactly coplanar
    ref = orient3d(P[:, 0], P[:, 1], P[:, 2], P[:, 3])
    Q = P * scale
    assert np.array_equal(orient3d(Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 3]), ref)
    ref2 = orient2d(P[:, 0, :2], P[:, 1, :2], P[:, 2, :2])
    assert np.array_equal(orient2d(Q[:, 0, :2], Q[:, 1, :2], Q[:, 2, :2]), ref2)
    assert (ref == 0).sum() >= 100 and (ref != 0).sum() > 300
