"""Whole-mesh connectivity, built once and vectorised.

Everything here is NumPy / SciPy over all faces at once (no Python loop over
faces or vertices), so it scales to scans of tens of millions of triangles.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shellrepair.lazyscipy import connected_components
from shellrepair.lazyscipy import sparse as sp
from shellrepair.mesh import fastmesh
from shellrepair.mesh.geometry import cross, uniq, vertex_faces_scipy

#: Faces per chunk in per-face geometry over the whole mesh.
CHUNK = 1 << 16

__all__ = ["EdgeTopology", "edge_topology", "edge_topology_reference", "boundary_half_edges", "half_edge_ends", "edge_count_delta", "face_components", "face_pieces", "face_areas",
           "face_normals",
           "euler_characteristic", "vertex_faces", "components_of_pieces", "manifold_pairs",
           "coincident_vertices", "corner_fans"]


@dataclass
class EdgeTopology:
    """Half-edge facts of a triangle mesh.

    Half-edge ``3f+c`` runs ``F[f,c] -> F[f,(c+1)%3]``.

    Attributes
    ----------
    edges : (e,2) int64
        Undirected edges, ``edges[:,0] < edges[:,1]``, sorted by
        ``(edges[:,0], edges[:,1])``.
    edge_count : (e,) int64
        How many faces use each undirected edge (1 boundary, 2 manifold,
        more: non-manifold).
    boundary_he : (b,) int64
        Half-edge ids whose undirected edge has exactly one face, sorted.
    nonmanifold_edges : (k,2) int64
        Edges used by three or more faces.
    he_order : (3m,) int64
        Half-edge ids ordered by their undirected edge (within an edge, by
        increasing id).
    faces : (m,3) int64
        The faces it was built on (the caller's array, not a copy: it must
        not be edited in place while the topology is in use).
    edge_of_he : (3m,) int64
        Undirected edge id of each half-edge (built on first use).
    consistent : bool or None
        True when no edge with two faces has both its half-edges in one
        direction (every face agrees with its neighbours), False when one
        has; None when not found on the way (the NumPy path).
    he : (3m,2) int64
        Directed half-edges (tail, head), built from ``faces`` on first use;
        most callers need only a few (:meth:`ends`).
    """

    edges: np.ndarray
    edge_count: np.ndarray
    boundary_he: np.ndarray
    nonmanifold_edges: np.ndarray
    he_order: np.ndarray
    faces: np.ndarray
    consistent: bool | None = None
    _edge_of_he: np.ndarray | None = field(default=None, repr=False)
    _he: np.ndarray | None = field(default=None, repr=False)

    @property
    def edge_of_he(self):
        if self._edge_of_he is None:
            if fastmesh.enabled(self.he_order.size // 3):
                self._edge_of_he = fastmesh.edge_ids(self.he_order, self.edge_count)
            else:
                e = np.empty(self.he_order.size, np.int64)
                e[self.he_order] = np.repeat(np.arange(self.edge_count.size), self.edge_count)
                self._edge_of_he = e
        return self._edge_of_he

    @property
    def n_boundary_edges(self):
        return int(self.boundary_he.size)

    @property
    def he(self):
        if self._he is None:
            F = self.faces
            m = F.shape[0]
            he = np.empty((3 * m, 2), np.int64)
            he[:, 0].reshape(m, 3)[:] = F
            nxt = he[:, 1].reshape(m, 3)
            nxt[:, :2] = F[:, 1:]
            nxt[:, 2] = F[:, 0]
            self._he = he
        return self._he

    def ends(self, h):
        """(k,2) int64: tail and head of the half-edges ``h`` (ids ``3f+c``)."""
        return half_edge_ends(self.faces, h)


def half_edge_ends(F, h):
    """(k,2) int64: tail and head of the half-edges ``h`` (ids ``3f+c``,
    from corner ``c`` of face ``f`` to the next) of the faces ``F``."""
    h = np.asarray(h, np.int64)
    flat = np.asarray(F).reshape(-1)
    nxt = h + 1
    nxt[h % 3 == 2] -= 3
    return np.column_stack([flat[h], flat[nxt]])


def edge_topology(F, n_vertices=None):
    """Half-edges, undirected edges and their face counts.

    Parameters
    ----------
    F : (m,3) int64 array
    n_vertices : int, optional
        Number of vertices (default ``F.max()+1``).

    Returns
    -------
    topo : EdgeTopology
    """
    F = np.ascontiguousarray(F, dtype=np.int64)
    n = int(F.max()) + 1 if n_vertices is None else int(n_vertices)
    if n > COMPACT_RATIO * F.size and F.size:
        return _edge_topology_compact(F, n)
    got = fastmesh.edge_topology_arrays(F, n) if fastmesh.enabled(len(F)) else None
    if got is not None:
        order, edges, count, boundary_he, consistent = got
        edge_of_he = None   # built when asked for
    else:
        order, edge_of_he, edges, count, boundary_he = edge_topology_reference(F, n)
        consistent = None
    return EdgeTopology(edges=edges, edge_count=count, boundary_he=boundary_he, nonmanifold_edges=edges[count > 2],
                        he_order=order, faces=F, consistent=consistent, _edge_of_he=edge_of_he)


#: :func:`edge_topology` numbers the vertices of faces among themselves when
#: there are more than this many vertices per face corner (a few faces of a
#: large mesh: its work is then that of the faces, not O(n)).
COMPACT_RATIO = 4


def _edge_topology_compact(F, n):
    """:func:`edge_topology` of faces using few of ``n`` vertices: built on
    the vertices renumbered in increasing order (every order and grouping
    is the same), the edges numbered back."""
    if F.min() < 0 or F.max() >= n:
        raise ValueError("a face refers to a vertex outside [0, n_vertices)")
    keys = uniq(F)
    topo = edge_topology(np.searchsorted(keys, F), len(keys))
    edges = keys[topo.edges]
    return EdgeTopology(edges=edges, edge_count=topo.edge_count, boundary_he=topo.boundary_he,
                        nonmanifold_edges=edges[topo.edge_count > 2], he_order=topo.he_order, faces=F,
                        consistent=topo.consistent, _edge_of_he=topo._edge_of_he)


def edge_topology_reference(F, n):
    """:func:`edge_topology`'s arrays by one stable argsort of packed edge
    keys, in NumPy: the fallback, and the reference for
    :func:`shellrepair.mesh.fastmesh.edge_topology_arrays`.

    Parameters
    ----------
    F : (m,3) int64, C-contiguous
    n : int
        Vertex count.

    Returns
    -------
    he_order, edge_of_he, edges, edge_count, boundary_he
        The fields of :class:`EdgeTopology` of the same names.
    """
    nn = np.int64(max(n, 1))
    m = F.shape[0]
    m3 = 3 * m
    if m and (F.min() < 0 or F.max() >= n):
        raise ValueError("a face refers to a vertex outside [0, n_vertices)")
    # Large fresh arrays cost as much to fault in as to compute, so each
    # scratch array below is reused once its content is no longer needed.
    he = np.empty((m3, 2), np.int64)
    he[:, 0].reshape(m, 3)[:] = F
    nxt = he[:, 1].reshape(m, 3)
    nxt[:, :2] = F[:, 1:]
    nxt[:, 2] = F[:, 0]
    key = np.minimum(he[:, 0], he[:, 1])
    key *= nn
    buf = np.maximum(he[:, 0], he[:, 1])
    key += buf
    del he, nxt
    # one stable argsort gives the unique edges, their counts and the inverse
    order = np.argsort(key, kind="stable")
    ks = np.take(key, order, out=buf)
    first = np.empty(m3, bool)
    first[:1] = True
    np.not_equal(ks[1:], ks[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    ukey = ks[starts]
    count = np.empty(starts.size, np.int64)
    np.subtract(starts[1:], starts[:-1], out=count[:-1])
    count[-1:] = m3 - starts[-1:]
    group = np.cumsum(first, out=key)     # 1 + the edge id of each sorted half-edge
    group -= 1
    del first
    edge_of_he = buf                      # ks is done with
    edge_of_he[order] = group
    del key, group, ks
    edges = np.empty((ukey.size, 2), np.int64)
    np.floor_divide(ukey, nn, out=edges[:, 0])
    np.remainder(ukey, nn, out=edges[:, 1])
    # an edge with one face has its one half-edge at the head of its group
    boundary_he = np.sort(order[starts[count == 1]])
    return order, edge_of_he, edges, count, boundary_he


def boundary_half_edges(F, n_vertices):
    """The half-edges (ids ``3f+c``, from corner ``c`` of face ``f`` to the
    next) whose edge has one face, ascending: :func:`edge_topology`'s
    ``boundary_he`` from one sort of the edge keys, without the rest of its
    arrays (on the small regions the order test walks, 1980 calls for 150
    holes, its whole topology cost 0.27 s).

    Parameters
    ----------
    F : (m,3) int64 array
    n_vertices : int

    Returns
    -------
    boundary_he : (b,) int64
    """
    F = np.ascontiguousarray(F, dtype=np.int64)
    n = int(n_vertices)
    if not len(F):
        return np.zeros(0, np.int64)
    if F.min() < 0 or F.max() >= n:
        raise ValueError("a face refers to a vertex outside [0, n_vertices)")
    a = F.ravel()
    b = F[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * np.int64(max(n, 1)) + np.maximum(a, b)
    s = np.sort(key)
    once = np.ones(len(s), bool)
    same = s[1:] == s[:-1]
    once[1:] &= ~same
    once[:-1] &= ~same
    single = s[once]
    if not len(single):
        return np.zeros(0, np.int64)
    i = np.minimum(np.searchsorted(single, key), len(single) - 1)
    return np.flatnonzero(single[i] == key)


def manifold_pairs(topo):
    """The two half-edges of every edge with exactly two faces.

    Parameters
    ----------
    topo : EdgeTopology
        With ``he_order`` (as :func:`edge_topology` builds it).

    Returns
    -------
    h1, h2 : (p,) int64
        Half-edge ids; ``h1[k]`` and ``h2[k]`` run along the same edge.
    """
    # he_order groups the half-edges by edge, in edge order: a manifold
    # edge's two half-edges are the two entries of its group
    start = np.cumsum(topo.edge_count)
    start -= topo.edge_count
    two = start[topo.edge_count == 2]
    return topo.he_order[two], topo.he_order[two + 1]


def edge_count_delta(topo, F_new, n_vertices, n_before=None):
    """How appending faces changes the boundary, non-manifold and edge counts.

    Only the edges the new faces use are looked at, so checking a repair
    costs O(p log e) for p new faces instead of rebuilding the topology.

    Parameters
    ----------
    topo : EdgeTopology
        Of the mesh before (its ``edges`` sorted, as built).
    F_new : (p,3) int64
        Faces appended.
    n_vertices : int
        Vertex count after appending (new vertices have the highest ids).
    n_before : int, optional
        Vertex count before appending, when known: an edge with a vertex
        at or past it is new without a look-up.

    Returns
    -------
    d : dict
        ``boundary_edges``, ``nonmanifold_edges``, ``edges``: the changes
        (after − before).
    """
    F_new = np.asarray(F_new, np.int64)
    if len(F_new) == 0:
        return {"boundary_edges": 0, "nonmanifold_edges": 0, "edges": 0}
    n = int(n_vertices)
    he = np.stack([F_new, np.roll(F_new, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    ukey, add = np.unique(key, return_counts=True)
    c0 = np.zeros(len(ukey), np.int64)
    found = np.zeros(len(ukey), bool)
    ask = np.arange(len(ukey)) if n_before is None else np.flatnonzero(ukey % n < int(n_before))
    E = topo.edges
    if ask.size and len(E):
        a, b = ukey[ask] // n, ukey[ask] % n
        if ask.size * 64 < len(E) and E.dtype == np.int64 and E.flags.c_contiguous:
            # few edges asked of many: a binary search of the (a, b) rows as
            # records, in place, instead of a key for every edge of the mesh
            rec = np.dtype([("a", "<i8"), ("b", "<i8")])
            S = E.view(rec).ravel()
            q = np.empty(ask.size, rec)
            q["a"], q["b"] = a, b
            pos = np.minimum(np.searchsorted(S, q), len(E) - 1)
            hit = (E[pos, 0] == a) & (E[pos, 1] == b)
        else:
            old_keys = E[:, 0] * n + E[:, 1]   # sorted: edges are in key order
            pos = np.minimum(np.searchsorted(old_keys, ukey[ask]), len(E) - 1)
            hit = old_keys[pos] == ukey[ask]
        found[ask] = hit
        c0[ask] = np.where(hit, topo.edge_count[pos], 0)
    c1 = c0 + add
    return {"boundary_edges": int(np.sum(c1 == 1) - np.sum(c0 == 1)),
            "nonmanifold_edges": int(np.sum(c1 > 2) - np.sum(c0 > 2)),
            "edges": int(np.sum(~found))}


def face_components(F, n_vertices):
    """Connected components of the faces (faces sharing a vertex are joined).

    Parameters
    ----------
    F : (m,3) int64 array
    n_vertices : int

    Returns
    -------
    n_comp : int
        Number of components that have at least one face.
    vertex_comp : (n,) int64
        Component of each vertex; -1 for vertices no face uses.
    face_comp : (m,) int64
        Component of each face.
    """
    F = np.asarray(F, dtype=np.int64)
    n = int(n_vertices)
    rows = np.concatenate([F[:, 0], F[:, 1]])
    cols = np.concatenate([F[:, 1], F[:, 2]])
    A = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(n, n))
    _, lab = connected_components(A, directed=False)
    used = np.zeros(n, bool)
    used[F.ravel()] = True
    # relabel so that components with faces are 0..k-1 in order of first face
    face_lab = lab[F[:, 0]]
    _, first = np.unique(face_lab, return_index=True)
    order = face_lab[np.sort(first)]
    remap = np.full(lab.max() + 1, -1, dtype=np.int64)
    remap[order] = np.arange(order.size)
    vertex_comp = np.where(used, remap[lab], -1)
    return int(order.size), vertex_comp, remap[face_lab]


def components_of_pieces(F, n_vertices, face_piece, n_pieces):
    """:func:`face_components` from the pieces: pieces that share a vertex
    are joined, on a graph of pieces rather than of all vertices.

    Parameters
    ----------
    F : (m,3) int64 array
    n_vertices : int
    face_piece : (m,) int64
        From :func:`face_pieces`.
    n_pieces : int

    Returns
    -------
    As :func:`face_components` (same labels).
    """
    F = np.asarray(F, np.int64)
    n = int(n_vertices)
    m = len(F)
    flat = F.ravel()
    if n_pieces == 1:  # one piece (the usual scan): one component
        used = np.zeros(n, bool)
        used[flat] = True                   # one byte a vertex: the scatter stays in cache
        vertex_comp = used.astype(np.int64)
        vertex_comp -= 1
        return 1, vertex_comp, np.zeros(m, np.int64)
    corner_piece = np.repeat(np.asarray(face_piece, np.int64), 3)
    some_piece = np.full(n, -1, np.int64)
    some_piece[flat] = corner_piece          # one piece per vertex (any)
    other = some_piece[flat]
    cross_ = np.flatnonzero(corner_piece != other)   # corners where two pieces meet
    if cross_.size:
        A = sp.csr_matrix((np.ones(cross_.size, np.int8), (corner_piece[cross_], other[cross_])),
                          shape=(n_pieces, n_pieces))
        _, lab = connected_components(A, directed=False)
    else:
        lab = np.arange(n_pieces)
    face_lab = lab[face_piece]
    # number components in order of their first face
    first = np.full(int(lab.max(initial=-1)) + 1, m, np.int64)
    np.minimum.at(first, face_lab, np.arange(m))
    have = np.flatnonzero(first < m)
    order = have[np.argsort(first[have], kind="stable")]
    remap = np.full(first.size, -1, np.int64)
    remap[order] = np.arange(order.size)
    face_comp = remap[face_lab]
    vertex_comp = np.full(n, -1, np.int64)
    vertex_comp[flat] = np.repeat(face_comp, 3)
    return int(order.size), vertex_comp, face_comp


def vertex_faces(F, n_vertices):
    """Vertex-to-face lists.

    Parameters
    ----------
    F : (m,3) int64 array
    n_vertices : int

    Returns
    -------
    order : (3m,) int64
        Positions in ``F.ravel()`` grouped by vertex (in order within a
        vertex); ``order // 3`` are the faces.
    start : (n+1,) int64
        Vertex v's entries are ``order[start[v]:start[v+1]]``.
    """
    if fastmesh.enabled(len(F)):
        return fastmesh.vertex_faces(F, n_vertices)
    return vertex_faces_scipy(F, n_vertices)


def face_pieces(topo, n_faces):
    """Pieces: faces joined across shared edges (not across lone vertices).

    Parameters
    ----------
    topo : EdgeTopology
    n_faces : int

    Returns
    -------
    n_pieces : int
    face_piece : (m,) int64
    """
    if fastmesh.enabled(n_faces):   # union-find, labels as SciPy numbers them
        n, lab, _, _ = fastmesh.face_pieces_labels(topo, topo.faces, n_faces, manifold_only=False)
        return n, lab
    order = topo.he_order  # half-edges grouped by edge (in edge order), from edge_topology
    # 32-bit face ids where they fit: half the memory traffic, and SciPy's graph code works in 32 bits
    f = (order // 3).astype(np.int32 if n_faces < 2 ** 31 - 1 else np.int64)
    # consecutive entries of one edge's group: every position but a group's last
    last = np.cumsum(topo.edge_count) - 1
    keep = np.ones(max(order.size - 1, 0), bool)
    keep[last[:-1]] = False
    same = np.flatnonzero(keep)
    A = sp.coo_matrix((np.ones(same.size, np.int8), (f[same], f[same + 1])), shape=(n_faces, n_faces)).tocsr()
    del f, same, keep
    n, lab = connected_components(A, directed=False)
    return int(n), lab.astype(np.int64)


def _face_cross_chunks(V, F):
    """(start, c) per chunk of faces: ``c`` the cross products (b − a) × (c − a)
    of the chunk's triangles, twice their vector areas. In chunks:
    temporaries that stay in cache cost half of whole-mesh ones."""
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    for s in range(0, len(F), CHUNK):
        T = V[F[s:s + CHUNK]]
        yield s, cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])


def face_areas(V, F):
    """Triangle areas, (m,) float64: ``0.5 |(b - a) × (c - a)|``."""
    if fastmesh.enabled(len(F)):
        return fastmesh.face_areas(V, F)
    out = np.empty(len(F))
    for s, c in _face_cross_chunks(V, F):
        out[s:s + len(c)] = 0.5 * np.sqrt(np.einsum("ij,ij->i", c, c))
    return out


def face_normals(V, F):
    """Unnormalised triangle normals (b − a) × (c − a), (m,3) float64
    (length twice the area)."""
    out = np.empty((len(F), 3))
    for s, c in _face_cross_chunks(V, F):
        out[s:s + len(c)] = c
    return out


def euler_characteristic(F, n_vertices=None):
    """V − E + F counted over the vertices faces use."""
    F = np.asarray(F, np.int64)
    topo = edge_topology(F, n_vertices)
    nv = np.unique(F).size
    return int(nv - topo.edges.shape[0] + F.shape[0])


def coincident_vertices(V, verts=None):
    """Join vertices with bit-identical positions (``-0.0`` read as ``0.0``).

    Parameters
    ----------
    V : (n,3) float64 array
    verts : (k,) int64 array, optional
        Only these vertices are compared with each other (default all).

    Returns
    -------
    rep : (n,) int64 array or None
        ``rep[v]`` is the lowest-numbered vertex among ``verts`` at the
        position of ``v`` (``v`` itself for a vertex with no twin, and for
        every vertex outside ``verts``); None when no two vertices coincide.

    Notes
    -----
    Vectorised: a 64-bit hash of the three coordinate words is sorted once
    (stable, so each run of equal hashes is in vertex order) and neighbours
    in that order are compared bit for bit; only if two different positions
    share a hash are the vertices ordered by their coordinate bits instead
    (one ``lexsort``).

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [-0., 0, 0]])
    >>> coincident_vertices(V).tolist()
    [0, 1, 0]
    """
    V = np.asarray(V, np.float64)
    n = len(V)
    if verts is None:
        verts = np.arange(n, dtype=np.int64)
    else:
        mark = np.zeros(n, bool)
        mark[np.asarray(verts, np.int64)] = True
        verts = np.flatnonzero(mark)
    if verts.size < 2:
        return None
    P = V[verts]
    P += 0.0  # -0.0 + 0.0 == +0.0: the two zeros are one position
    bits = np.ascontiguousarray(P).view(np.uint64)
    del P
    h = _mix64(bits[:, 0].copy())
    h ^= bits[:, 1]
    h = _mix64(h)
    h ^= bits[:, 2]
    h = _mix64(h)
    # equal hashes next to each other, in vertex order within a run (stable)
    order = np.argsort(h, kind="stable")
    hs = h[order]
    same = hs[1:] == hs[:-1]
    del h, hs
    if not same.any():
        return None
    B = bits[order]
    equal = (B[1:] == B[:-1]).all(axis=1)
    if (same & ~equal).any():
        # two positions share a hash (rare): order those runs by their bits exactly
        B_order = np.lexsort((order, B[:, 2], B[:, 1], B[:, 0]))
        order = order[B_order]
        B = B[B_order]
        same = (B[1:] == B[:-1]).all(axis=1)
    else:
        same &= equal
    if not same.any():
        return None
    start = np.ones(order.size, bool)
    start[1:] = ~same
    head = np.maximum.accumulate(np.where(start, np.arange(order.size), 0))
    rep = np.arange(n, dtype=np.int64)
    rep[verts[order]] = verts[order[head]]
    return rep


def _mix64(w):
    """The splitmix64 finaliser, in place on a uint64 array: every input bit
    reaches every output bit (float32 values widened to float64 have 29
    zero bits that a plain product would keep zero)."""
    w ^= w >> np.uint64(30)
    w *= np.uint64(0xBF58476D1CE4E5B9)
    w ^= w >> np.uint64(27)
    w *= np.uint64(0x94D049BB133111EB)
    w ^= w >> np.uint64(31)
    return w


def corner_fans(F, verts, links):
    """Fans of faces around some vertices.

    Parameters
    ----------
    F : (m,3) int64 array
    verts : (k,) int64 array
        The vertices whose fans are wanted.
    links : (p,2) int64 array
        Pairs of half-edge ids ``3f + c`` (half-edge ``F[f,c] -> F[f,c+1]``)
        that run along the same edge and join their two faces across it.
        Only the faces a link joins are in one fan across that edge.

    Returns
    -------
    corners : (q,) int64
        The corner ids ``3f + c`` with ``F[f,c]`` in ``verts``, sorted.
    fan : (q,) int64
        A fan label per corner: corners of one vertex joined through links
        at that vertex share it.
    """
    F = np.asarray(F, np.int64)
    flat = F.ravel()
    mark = np.zeros(int(flat.max(initial=-1)) + 1, bool)
    mark[np.asarray(verts, np.int64)] = True
    corners = np.flatnonzero(mark[flat])
    q = corners.size
    if q == 0:
        return corners, np.zeros(0, np.int64)
    links = np.asarray(links, np.int64).reshape(-1, 2)
    h1, h2 = links[:, 0], links[:, 1]
    nxt = lambda h: h - h % 3 + (h % 3 + 1) % 3  # noqa: E731 - the corner at the half-edge's head
    same_dir = flat[h1] == flat[h2]
    a1, b1 = h1, nxt(h1)                        # corners of face(h1) at the edge's tail and head
    a2 = np.where(same_dir, h2, nxt(h2))       # corners of face(h2) at those same vertices
    b2 = np.where(same_dir, nxt(h2), h2)
    u = np.concatenate([a1, b1])
    w = np.concatenate([a2, b2])
    keep = mark[flat[u]]
    u, w = u[keep], w[keep]
    iu, iw = np.searchsorted(corners, u), np.searchsorted(corners, w)
    A = sp.csr_matrix((np.ones(iu.size, np.int8), (iu, iw)), shape=(q, q))
    _, fan = connected_components(A, directed=False)
    return corners, fan.astype(np.int64)
