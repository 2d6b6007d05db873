"""Faster whole-mesh structures and batched per-hole steps give exactly
what their straightforward versions give."""

import numpy as np
import pytest

from shellrepair import compiled
from eval import shapes
from shellrepair.fill.refine import (FLIP_EPS, angle_between, in_sorted, independent_flips, refine_patch, refine_patches,
                                relax, unfolded)
from shellrepair.mesh.index import ScanContext, local_frame, rim_data
from shellrepair.mesh.io import Mesh, read_mesh, write_mesh
from shellrepair.report.table import holes_dict
from shellrepair.holes.loops import detect_holes
from shellrepair.mesh.topology import (components_of_pieces, edge_topology, face_areas, face_components, face_pieces,
                                  vertex_faces)
from shellrepair.fill.triangulate import triangulate_loop


def _pieces_and_pinches():
    """Three spheres: two touching at one vertex (one component, two
    pieces), one apart; plus a fan glued to a sphere by a lone vertex."""
    V, F = shapes.icosphere(2)
    Vs, Fs = [], []
    for k, shift in enumerate([0.0, 2.0, 6.0]):
        W = V + [shift, 0, 0]
        Vs.append(W)
        Fs.append(F + k * len(V))
    V3, F3 = np.vstack(Vs), np.vstack(Fs)
    # glue sphere 1 to sphere 0: the vertex of sphere 1 nearest sphere 0 is replaced by sphere 0's
    a = int(np.argmax(V3[:len(V), 0]))
    b = len(V) + int(np.argmin(V3[len(V):2 * len(V), 0]))
    F3[F3 == b] = a
    fan = np.array([[a, len(V3), len(V3) + 1]])
    V3 = np.vstack([V3, [[1.0, 1.0, 0.0], [1.0, 1.0, 1.0]]])
    return V3, np.vstack([fan, F3])


def test_components_from_pieces_equal_the_vertex_graph_components():
    V, F = _pieces_and_pinches()
    rng = np.random.default_rng(0)
    for trial in range(4):
        G = F[rng.permutation(len(F))] if trial else F
        topo = edge_topology(G, len(V))
        n_piece, fpiece = face_pieces(topo, len(G))
        got = components_of_pieces(G, len(V), fpiece, n_piece)
        want = face_components(G, len(V))
        assert got[0] == want[0] == 2 and n_piece == 4
        assert np.array_equal(got[1], want[1]) and np.array_equal(got[2], want[2])
    # one piece, with holes and two vertices no face uses
    V, F = shapes.icosphere(2)
    F = F[5:]
    n_piece, fpiece = face_pieces(edge_topology(F, len(V) + 2), len(F))
    got = components_of_pieces(F, len(V) + 2, fpiece, n_piece)
    want = face_components(F, len(V) + 2)
    assert n_piece == got[0] == want[0] == 1
    assert np.array_equal(got[1], want[1]) and np.array_equal(got[2], want[2])


def test_what_loading_keeps_on_the_mesh_is_what_detection_would_build(tmp_path):
    V, F = _pieces_and_pinches()
    keep = np.ones(len(F), bool)
    keep[[5, 40, 41, 200]] = False                  # some holes
    F = F[keep]
    flipped = F.copy()
    flipped[7] = flipped[7][[0, 2, 1]]              # loading will flip it back
    e = F[10]                                       # a third face on an edge of face 10
    nonmanifold = np.vstack([F, [[e[0], e[1], len(V)]]])
    V2 = np.vstack([V, [[0.3, 0.3, 3.0]]])
    for name, G, W in (("plain", F, V), ("flipped", flipped, V), ("nonmanifold", nonmanifold, V2)):
        path = tmp_path / f"{name}.ply"
        write_mesh(path, Mesh(V=W, F=G))
        m = read_mesh(path)
        topo = edge_topology(m.F, len(m.V))
        pieces = face_pieces(topo, len(m.F))
        kept = {k: m.cached(k) for k in ("topology", "pieces", "face_areas")}
        # the pieces are kept in every case (the non-manifold edge is split on
        # reading); the topology is not rebuilt on reading after flips (nor
        # after pieces meeting at a vertex are split)
        assert kept["pieces"] is not None
        if name == "flipped":
            assert kept["topology"] is None
        if kept["topology"] is not None:
            assert np.array_equal(kept["topology"].edge_of_he, topo.edge_of_he)
        if kept["pieces"] is not None:
            assert kept["pieces"][0] == pieces[0] and np.array_equal(kept["pieces"][1], pieces[1])
        assert np.array_equal(kept["face_areas"], face_areas(m.V, m.F))
        fresh = holes_dict(detect_holes(m.V, m.F))
        reused = holes_dict(detect_holes(m.V, m.F, topo=kept["topology"], pieces=kept["pieces"],
                                         areas=kept["face_areas"]))
        assert fresh == reused and fresh["holes"] >= 3
        m.F = m.F.copy()                            # a new array: nothing kept applies to it
        assert all(m.cached(k) is None for k in kept)
    # edits in place: a unit conversion is noticed, the same values are not a change
    m = read_mesh(tmp_path / "plain.ply")
    m.V[:] = m.V
    assert m.cached("face_areas") is not None
    m.V *= 1000.0                                   # metres to millimetres, in place
    assert m.cached("face_areas") is None and m.cached("topology") is None
    # any single row edited in place is noticed, of V or of F, on a mesh of
    # many more rows than a sample would look at
    V, F = shapes.icosphere(6)
    write_mesh(tmp_path / "sphere.ply", Mesh(V=V, F=F))
    for edit in ("V", "F"):
        m = read_mesh(tmp_path / "sphere.ply")
        assert all(v is not None for v in m.cached("pieces", "face_areas"))
        a = getattr(m, edit)
        row = len(a) // 2 + 1
        a[row] = a[row][::-1] if edit == "F" else a[row] + 1e-9
        assert m.cached("pieces", "face_areas") == (None, None), edit
    # forgotten (the command line, once the up axis is found): nothing kept, the arrays free
    m = read_mesh(tmp_path / "sphere.ply")
    assert m.cached("face_areas") is not None
    m.forget()
    assert m.cached("pieces", "face_areas") == (None, None)


def test_vertex_face_lists_equal_a_stable_sort():
    V, F = _pieces_and_pinches()
    order, start = vertex_faces(F, len(V) + 3)   # three vertices no face uses
    flat = F.ravel()
    ref = np.argsort(flat, kind="stable")
    assert np.array_equal(order, ref)
    assert np.array_equal(start, np.searchsorted(flat[ref], np.arange(len(V) + 4)))


def test_ring_faces_are_the_faces_within_k_edges():
    V, F = shapes.icosphere(3)
    ctx = ScanContext(Mesh(V=V, F=F))
    seed = np.array([0, 5])
    for rings in (1, 2, 4):
        # reference: grow a vertex set ring by ring
        vs = set(seed.tolist())
        faces = set()
        for _ in range(rings):
            new = {f for f in range(len(F)) if vs & set(F[f].tolist())}
            faces |= new
            vs |= {int(v) for f in new for v in F[f]}
        assert ctx.ring_faces(seed, rings).tolist() == sorted(faces)
    assert not ctx._vmark.any() and not ctx._fmark.any()   # scratch marks are left clean


def _first_triangulations(centers, radius):
    """refine_patch's inputs for each hole of a perforated bumpy sphere:
    (loop positions, triangulation, sigma, loop size, forbidden chords), as
    a repair makes them."""
    V, F = shapes.bumpy_sphere(4, amplitude=0.05, frequency=5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=centers, radius=radius)
    ctx = ScanContext(Mesh(V=V2, F=F2))
    items = []
    for L in detect_holes(V2, F2).holes:
        sigma, normals, forbidden = rim_data(ctx, L.vertices)
        _, scale, Pl = local_frame(ctx, L.vertices, sigma)
        items.append((Pl, triangulate_loop(Pl, normals, forbidden), sigma / scale, len(L.vertices), forbidden))
    return items


def test_batched_refinement_equals_refining_each_patch_alone():
    items = _first_triangulations([0, 40, 90, 130, 200, 260], 0.25)
    assert len(items) >= 4
    together = refine_patches(items)
    for item, (P2, T2) in zip(items, together):
        P1, T1 = refine_patch(*item)
        assert len(T1) > 2 * len(item[1])          # refinement did split
        assert np.array_equal(P1, P2) and np.array_equal(T1, T2)


def _relax_full_pass(P, T, is_loop, forb, max_rounds=100):
    """The plain version: every round re-pairs all half-edges by a sort and
    judges every interior edge (the specification of ``refine.relax``)."""
    n = len(P)
    nt = len(T)
    if nt < 2:
        return T
    forb = np.sort(forb[:, 0] * n + forb[:, 1]) if len(forb) else np.zeros(0, np.int64)
    for _ in range(max_rounds):
        he = np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2)
        opp = np.roll(T, -2, axis=1).reshape(-1)          # corner opposite to half-edge 3f+c
        lo = np.minimum(he[:, 0], he[:, 1])
        hi = np.maximum(he[:, 0], he[:, 1])
        key = lo * n + hi
        order = np.argsort(key, kind="stable")
        ks = key[order]
        pair = np.flatnonzero(ks[1:] == ks[:-1])
        if pair.size == 0:
            break
        h1, h2 = order[pair], order[pair + 1]
        # orient: h1 is a -> b, h2 is b -> a
        a, b = he[h1, 0], he[h1, 1]
        c, d = opp[h1], opp[h2]
        pa, pb, pc, pd = P[a], P[b], P[c], P[d]
        excess = angle_between(pa - pc, pb - pc) + angle_between(pa - pd, pb - pd) - np.pi
        cand = np.flatnonzero((excess > FLIP_EPS) & (c != d))
        if cand.size == 0:
            break
        cc, dd = c[cand], d[cand]
        ncd_c = np.minimum(cc, dd) * n + np.maximum(cc, dd)
        ok = ~in_sorted(ncd_c, ks)                     # the new edge must not exist
        if forb.size:
            ok &= ~(is_loop[cc] & is_loop[dd] & in_sorted(ncd_c, forb))
        ok &= unfolded(pa[cand], pb[cand], pc[cand], pd[cand])
        ncd_c, cand = ncd_c[ok], cand[ok]
        if cand.size == 0:
            break
        # the same choice of flips as refine makes (what differs is how the
        # candidates are found: all edges, re-paired by a sort, every round)
        cand = independent_flips(cand, h1[cand] // 3, h2[cand] // 3, excess[cand], ncd_c, nt)
        f1, f2 = h1[cand] // 3, h2[cand] // 3
        if cand.size == 0:
            break
        T[f1] = np.column_stack([c[cand], a[cand], d[cand]])
        T[f2] = np.column_stack([d[cand], b[cand], c[cand]])
    return T


def test_incremental_relaxation_flips_exactly_as_a_full_pass_each_round():
    """The relaxation pairs half-edges once and updates the pairing as it
    flips; it must end with the very triangulation a full pass per round
    gives, on patches that need many rounds of flips."""
    rng = np.random.default_rng(4)
    for trial in range(12):
        k = 40
        t = np.linspace(0, 2 * np.pi, k, endpoint=False)
        loop = np.column_stack([np.cos(t), np.sin(t), np.zeros(k)])
        inner = rng.uniform(-0.7, 0.7, size=(60, 2))
        P = np.vstack([loop, np.column_stack([inner, 0.2 * rng.normal(size=60)])])
        # a bad triangulation to start from: a fan from loop vertex 0, then
        # every inner point split into the triangle around it
        T = np.array([[0, i + 1, i] for i in range(1, k - 1)])[:, [0, 2, 1]]
        for j in range(k, len(P)):
            # the triangle containing the point in the plane (or the nearest one)
            A, B, C = P[T[:, 0], :2], P[T[:, 1], :2], P[T[:, 2], :2]
            q = P[j, :2]
            def side(u, v):
                return (v[:, 0] - u[:, 0]) * (q[1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (q[0] - u[:, 0])
            s1, s2, s3 = side(A, B), side(B, C), side(C, A)
            inside = ((s1 <= 0) & (s2 <= 0) & (s3 <= 0)) | ((s1 >= 0) & (s2 >= 0) & (s3 >= 0))
            f = int(np.flatnonzero(inside)[0]) if inside.any() else int(np.argmin(np.abs(s1) + np.abs(s2) + np.abs(s3)))
            a, b, c = T[f]
            T = np.vstack([np.delete(T, f, axis=0), [[a, b, j], [b, c, j], [c, a, j]]])
        is_loop = np.arange(len(P)) < k
        forb = np.array([[0, k // 2], [3, 20]]) if trial % 2 else np.zeros((0, 2), np.int64)
        for rounds in (1, 2, 4, 100):                # round by round, and to the end
            want = _relax_full_pass(P, T.copy(), is_loop, forb, max_rounds=rounds)
            got = relax(P, T.copy(), is_loop, forb, max_rounds=rounds)[0]
            assert np.array_equal(got, want)
        assert not np.array_equal(_relax_full_pass(P, T.copy(), is_loop, forb, max_rounds=4),
                                  _relax_full_pass(P, T.copy(), is_loop, forb, max_rounds=2))  # many rounds


def _refine_plain(P, T, sigma, n_loop, forbidden, alpha=np.sqrt(2.0)):
    """Liepa's refinement the plain way: every round tests every triangle
    and relaxes every edge to the end (the specification of refine_patch)."""
    P = np.array(P, np.float64)
    T = np.array(T, np.int64)
    s = np.asarray(sigma, np.float64).copy()
    is_loop = np.ones(len(P), bool)
    forb = np.array(sorted(forbidden or ()), np.int64).reshape(-1, 2)
    T = _relax_full_pass(P, T, is_loop, forb)
    for _ in range(64):
        C = P[T].mean(axis=1)
        sc = s[T].mean(axis=1)
        d = np.linalg.norm(C[:, None, :] - P[T], axis=2) * alpha
        split = np.all((d > sc[:, None]) & (d > s[T]), axis=1)
        if not split.any():
            break
        ids = np.flatnonzero(split)
        new = len(P) + np.arange(ids.size)
        P = np.vstack([P, C[ids]])
        s = np.concatenate([s, sc[ids]])
        is_loop = np.concatenate([is_loop, np.zeros(ids.size, bool)])
        a, b, c = T[ids, 0], T[ids, 1], T[ids, 2]
        keep = np.ones(len(T), bool)
        keep[ids] = False
        T = np.vstack([T[keep], np.column_stack([a, b, new]), np.column_stack([b, c, new]),
                       np.column_stack([c, a, new])])
        T = _relax_full_pass(P, T, is_loop, forb)
    return P, T


def test_refinement_that_tests_only_what_changed_equals_the_plain_one():
    sizes = []
    for item in _first_triangulations([0, 60, 150, 230], 0.45):
        want = _refine_plain(*item)
        got = refine_patch(*item)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        sizes.append(len(got[1]))
    assert len(sizes) >= 3 and max(sizes) > 300   # holes large enough for many split rounds


# --------------------------------------------------------------------------
# compiled whole-mesh kernels (shellrepair.mesh.fastmesh) against the NumPy versions
# --------------------------------------------------------------------------
def _kernel_meshes():
    """Seeded meshes of every kind the kernels meet: a closed sphere, one with
    holes and flipped faces, random triangle soups (repeated edges, edges with
    three or more faces, vertices no face uses), a fan of 100 faces on one
    edge, two spheres apart."""
    rng = np.random.default_rng(5)
    V, F = shapes.icosphere(3)
    out = [("sphere", V, F), ("sphere, holes", V, F[rng.random(len(F)) > 0.05])]
    G = F.copy()
    flip = rng.random(len(G)) < 0.2
    G[flip] = G[flip][:, [0, 2, 1]]
    out.append(("sphere, flipped faces", V, G))
    for k in range(12):
        n = int(rng.integers(4, 5000 if k % 2 else 40))
        T = rng.integers(0, n, (int(rng.integers(1, 400)), 3))
        T = T[(T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 0] != T[:, 2])]
        if len(T):
            out.append((f"soup {k}", rng.normal(size=(n + 3, 3)), T))
    fan = np.column_stack([np.zeros(100, np.int64), np.ones(100, np.int64), np.arange(2, 102)])
    out.append(("fan on one edge", rng.normal(size=(102, 3)), fan))
    out.append(("two spheres", np.vstack([V, V + 3.0]), np.vstack([F, F + len(V)])))
    return out


def _numpy_only(monkeypatch):
    from shellrepair import compiled

    monkeypatch.setattr(compiled, "ENABLED", False)   # the one switch: every kernel off


def test_kernels_give_the_numpy_topology_pieces_areas_and_vertex_faces(monkeypatch):
    pytest.importorskip("numba")
    from scipy.sparse.csgraph import connected_components
    import scipy.sparse as sp

    from shellrepair.mesh import clean
    from shellrepair.mesh import fastmesh
    from shellrepair.mesh.topology import edge_topology_reference

    triple_hash_numpy = clean.triple_hash_reference    # clean_faces' hash without the kernels

    for name, V, F in _kernel_meshes():
        n = len(V)
        order, edges, count, bhe, consistent = fastmesh.edge_topology_arrays(F, n)
        want = edge_topology_reference(np.ascontiguousarray(F, np.int64), n)
        got = (order, fastmesh.edge_ids(order, count), edges, count, bhe)
        for g, w, what in zip(got, want, ("he_order", "edge_of_he", "edges", "edge_count", "boundary_he")):
            assert g.dtype == np.int64 and np.array_equal(g, w), (name, what)
        # consistent: no edge with two faces used twice in one direction
        tail = np.asarray(F, np.int64).ravel()
        start = np.cumsum(count) - count
        two = start[count == 2]
        assert consistent == (not (tail[order[two]] == tail[order[two + 1]]).any()), name
        # the duplicate-face hash of clean_faces (the hash of each face's vertex set)
        assert np.array_equal(fastmesh.triple_hash(F), triple_hash_numpy(np.asarray(F, np.int64))), name
        # pieces: SciPy's connected components of the faces joined across edges
        topo = edge_topology(F, n)
        for manifold_only in (True, False):
            k, lab, first, _ = fastmesh.face_pieces_labels(topo, F, len(F), manifold_only=manifold_only)
            start = np.cumsum(count) - count
            pairs = [(order[s + i] // 3, order[s + i + 1] // 3) for s, c in zip(start, count)
                     if c == 2 or (c > 2 and not manifold_only) for i in range(c - 1)]
            P = np.array(pairs, np.int64).reshape(-1, 2)
            A = sp.csr_matrix((np.ones(len(P)), (P[:, 0], P[:, 1])), shape=(len(F), len(F)))
            k_ref, lab_ref = connected_components(A, directed=False)
            assert k == k_ref and np.array_equal(lab, lab_ref), (name, manifold_only)
            assert np.array_equal(first, [np.flatnonzero(lab == p)[0] for p in range(k)])
        # the same results through the public functions, kernels on and off
        monkeypatch.setattr(fastmesh, "MIN_FACES", 0)
        fast = (face_pieces(topo, len(F)), face_areas(V, F), vertex_faces(F, n + 2))
        with monkeypatch.context() as mp:
            _numpy_only(mp)
            slow = (face_pieces(topo, len(F)), face_areas(V, F), vertex_faces(F, n + 2))
        assert fast[0][0] == slow[0][0] and np.array_equal(fast[0][1], slow[0][1]), name
        # areas: the same three products summed in einsum's order here; at most 1 ulp on other CPUs
        np.testing.assert_array_max_ulp(fast[1], slow[1], maxulp=1)
        assert all(np.array_equal(a, b) for a, b in zip(fast[2], slow[2])), name


def test_orientation_with_kernels_equals_the_numpy_search(monkeypatch):
    pytest.importorskip("numba")
    from shellrepair.mesh import fastmesh
    from shellrepair.mesh.clean import signed_volumes, orient_faces

    monkeypatch.setattr(fastmesh, "MIN_FACES", 0)
    rng = np.random.default_rng(11)
    for name, V, F in _kernel_meshes():
        fast = orient_faces(F, V)
        with monkeypatch.context() as mp:
            _numpy_only(mp)
            slow = orient_faces(F, V)
            piece = face_pieces(edge_topology(F, len(V)), len(F))
            flip = rng.random(len(F)) < 0.3
            vol_ref = signed_volumes(V, F, flip, piece[1], piece[0])
        assert np.array_equal(fast.F, slow.F) and np.array_equal(fast.flipped, slow.flipped), name
        assert (fast.n_pieces, fast.nonorientable, fast.notes) == (slow.n_pieces, slow.nonorientable, slow.notes)
        assert (fast.piece is None) == (slow.piece is None)
        assert fast.piece is None or np.array_equal(fast.piece, slow.piece)
        # the volumes decide closed pieces' winding: the same sums in the same order
        assert np.array_equal(signed_volumes(V, F, flip, piece[1], piece[0]), vol_ref), name
    # the sphere with flipped faces is wound outward again, with either path
    V, F = shapes.icosphere(3)
    G = F.copy()
    G[::3] = G[::3][:, [0, 2, 1]]
    assert np.array_equal(orient_faces(G, V).F, F)


def test_a_read_scan_is_the_same_with_kernels_and_without(tmp_path, monkeypatch):
    pytest.importorskip("numba")
    from shellrepair.mesh import fastmesh

    V, F = _pieces_and_pinches()
    keep = np.ones(len(F), bool)
    keep[[5, 40, 41, 200]] = False
    F = F[keep].copy()
    F[7] = F[7][[0, 2, 1]]
    path = tmp_path / "scan.ply"
    write_mesh(path, Mesh(V=V, F=F))
    monkeypatch.setattr(fastmesh, "MIN_FACES", 0)
    fast = read_mesh(path)
    d_fast = holes_dict(detect_holes(fast.V, fast.F))
    with monkeypatch.context() as mp:
        _numpy_only(mp)
        slow = read_mesh(path)
        d_slow = holes_dict(detect_holes(slow.V, slow.F))
    assert np.array_equal(fast.F, slow.F) and np.array_equal(fast.V, slow.V) and fast.notes == slow.notes
    assert d_fast == d_slow and d_fast["holes"] >= 3


def test_kernels_refuse_a_face_outside_the_vertices():
    pytest.importorskip("numba")
    from shellrepair.mesh import fastmesh

    with pytest.raises(ValueError, match="outside"):
        fastmesh.edge_topology_arrays(np.array([[0, 1, 5]]), 4)
    # warmed where the kernels run; with SHELLREPAIR_NO_NUMBA there is nothing to warm
    assert fastmesh.warm_up() is compiled.ENABLED


def test_row_kernels_on_two_threads_give_the_same_values(monkeypatch):
    """Face areas and edge lengths run in two halves on two threads on a
    large mesh: the same bits as one pass (each row is its own)."""
    pytest.importorskip("numba")
    from shellrepair.mesh import fastmesh

    V, F = shapes.bumpy_sphere(5)
    V = V * 1000 + 5e5                          # millimetres, far from the origin
    E = edge_topology(F, len(V)).edges
    monkeypatch.setattr(fastmesh, "HALVES_MIN_ROWS", 10 ** 12)
    one = (fastmesh.face_areas(V, F), fastmesh.edge_sq_lengths(V, E))
    monkeypatch.setattr(fastmesh, "HALVES_MIN_ROWS", 0)
    monkeypatch.setattr(fastmesh.os, "cpu_count", lambda: 2)
    started = []
    real = fastmesh.threading.Thread

    def counted(*a, **k):
        started.append(k.get("name"))
        return real(*a, **k)

    monkeypatch.setattr(fastmesh.threading, "Thread", counted)
    two = (fastmesh.face_areas(V, F), fastmesh.edge_sq_lengths(V, E))
    assert started == ["shellrepair-half"] * 2
    assert np.array_equal(one[0], two[0]) and np.array_equal(one[1], two[1])
    np.testing.assert_array_max_ulp(two[0], face_areas(V, F), maxulp=1)   # NumPy's, as above


@pytest.mark.parametrize("shift", [1, 3, 12])
def test_the_topology_on_two_threads_equals_it_on_one(shift):
    """Faces in halves for the filing, buckets in halves for the sorting and
    the edge list: the same arrays on two threads as on one, on every mesh
    kind (shift 1 and 3: many small buckets, so the halves fall between
    vertex runs the steps must keep whole), and NumPy's edges and counts."""
    pytest.importorskip("numba")
    from shellrepair.mesh import fastmesh
    from shellrepair.mesh.topology import edge_topology_reference

    for name, V, F in _kernel_meshes():
        F = np.ascontiguousarray(F, np.int64)
        two = fastmesh.edge_topology_steps(F, len(V), shift, two=True)
        turn = fastmesh.edge_topology_steps(F, len(V), shift)
        assert all(np.array_equal(a, b) for a, b in zip(turn[:4], two[:4])) and turn[4] == two[4], name
        order, _, edges, count, boundary = edge_topology_reference(F, len(V))
        assert np.array_equal(two[0], order) and np.array_equal(two[1], edges), name
        assert np.array_equal(two[2], count) and np.array_equal(two[3], boundary), name
    with pytest.raises(ValueError, match="outside"):
        fastmesh.edge_topology_steps(np.array([[0, 1, 2], [0, 1, 5]], np.int64), 4, 1, two=True)


def test_a_large_mesh_takes_the_two_thread_topology(monkeypatch):
    pytest.importorskip("numba")
    from shellrepair.mesh import fastmesh
    from shellrepair.mesh import halves

    V, F = shapes.icosphere(3)
    calls = []
    real = halves.both
    monkeypatch.setattr(halves, "both", lambda *a: calls.append(1) or real(*a))
    monkeypatch.setattr(fastmesh.os, "cpu_count", lambda: 2)
    small = fastmesh.edge_topology_arrays(F, len(V))
    monkeypatch.setattr(fastmesh, "HALVES_MIN_ROWS", 10)
    large = fastmesh.edge_topology_arrays(F, len(V))
    assert calls == [1] * 4 and all(np.array_equal(a, b) for a, b in zip(small[:4], large[:4]))
