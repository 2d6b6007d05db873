"""Dirty but valid geometry: topology by position, manifold edges and
vertices, consistent orientation, and what is left open.

Topology by position (:func:`make_manifold`, :func:`split_piece_junctions`)
------------------------------------------------------------------------
Files often say less about connectivity than their geometry does: a
triangle soup gives every face its own three vertices, a textured export
cuts the surface at its UV seams, a decimation leaves faces folded over the
surface, and a CAD export glues three faces on one edge. So, before any
hole is looked for:

* vertices on open edges at bit-identical positions are one vertex;
* a face folded over a surface that is closed without it is dropped;
* at a non-manifold edge one pair of faces keeps the edge (two faces of one
  piece, consistently oriented, flattest) and the others get copies of its
  vertices;
* pieces that meet at a single vertex get a copy each.

Copies are appended after the original vertices (same position, same
attributes) and faces re-pointed: no vertex moves, none is renumbered.

Hole loops are chains of boundary half-edges, and a patch is wound like the
faces around its rim, so both rely on every piece of the scan being wound
one way. Scans exported by other tools often are not (a few faces flipped by
a stitching step, a whole view turned inside out). :func:`orient_faces`
makes each piece consistent by flipping faces; it never moves or renumbers a
vertex and keeps the faces in their order.

Pieces
------
Here a *piece* is a set of faces joined across manifold edges (edges with
exactly two faces). A non-manifold edge (three or more faces) does not say
which of its faces belong together, so orientation does not propagate across
it. Two faces across a manifold edge are consistent when they use the edge
in opposite directions (``a -> b`` in one, ``b -> a`` in the other).

Which way round
---------------
* A closed piece (no boundary edge) is wound so that its signed volume is
  positive: normals point outward.
* An open piece keeps the winding of the majority of its faces (fewest
  flips); a tie keeps the winding of its first face.
* A non-orientable piece (a Möbius band: some cycle of faces cannot be made
  consistent) is reported; it is wound along a spanning tree of its faces,
  so only the faces along one seam disagree, and its faces keep the
  majority winding.

Repeated and duplicate faces (:func:`clean_faces`)
--------------------------------------------------
Before all of this, reading drops faces that repeat a vertex and faces
that repeat another face's three vertices (in any order), keeping the
first, in file order.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shellrepair.lazyscipy import breadth_first_order
from shellrepair.lazyscipy import sparse as sp
from shellrepair.mesh import fastmesh
from shellrepair.mesh.components import connected_components
from shellrepair.mesh.geometry import concat_ranges, cross, dot
from shellrepair.mesh.topology import CHUNK, corner_fans, edge_topology, manifold_pairs

__all__ = ["OrientResult", "orient_faces", "describe_open_chains", "ManifoldResult", "make_manifold",
           "split_piece_junctions", "signed_volumes",
           "triple_hash_reference", "FIX_COUNTS"]


@dataclass
class OrientResult:
    """Result of :func:`orient_faces`.

    Attributes
    ----------
    F : (m,3) int64 array
        The faces, same order, some with corners 1 and 2 swapped (the
        input array itself when no face is flipped).
    flipped : (m,) bool array
        Which faces were flipped.
    n_pieces : int
        Pieces (faces joined across manifold edges).
    nonorientable : list of int
        Index of the first face of each piece that cannot be oriented
        consistently.
    notes : list of str
        One line per thing done, for the load report.
    topo : EdgeTopology or None
        The edge topology of the returned ``F`` when no face was flipped
        (it was built for the input), for callers to reuse; else None.
    piece : (m,) int64 array or None
        Each face's piece, labelled as :func:`shellrepair.mesh.topology.face_pieces`
        labels them, when no edge has more than two faces (then the two
        agree); else None.
    """

    F: np.ndarray
    flipped: np.ndarray
    n_pieces: int
    nonorientable: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    topo: object = None
    piece: np.ndarray | None = None

    @property
    def n_flipped(self):
        return int(self.flipped.sum())


def _manifold_face_pairs(F, topo):
    """Face pairs across manifold edges and whether they need opposite flips.

    Returns
    -------
    f, g : (p,) int64
        The two faces of each manifold edge (``f < g`` not guaranteed).
    differ : (p,) bool
        True when both faces use the edge in the same direction, so exactly
        one of them must be flipped.
    """
    h1, h2 = manifold_pairs(topo)
    tail = F.ravel()  # the tails of the half-edges (half-edge 3f+c leaves F[f,c])
    differ = tail[h1] == tail[h2]
    return h1 // 3, h2 // 3, differ


def orient_faces(F, V=None, topo=None):
    """Wind every piece of a triangle mesh consistently by flipping faces.

    Parameters
    ----------
    F : (m,3) int64 array
        Triangles; not changed.
    V : (n,3) float64 array, optional
        Vertex positions. When given, closed pieces are wound outward
        (positive signed volume); without it every piece keeps its majority
        winding.

    Returns
    -------
    result : OrientResult
        ``result.F[i]`` is ``F[i]`` or ``F[i][[0, 2, 1]]``.

    Notes
    -----
    Vectorised: the flip parity of each face relative to its piece's first
    face is found on a breadth-first spanning forest of the face adjacency
    graph (one search from a virtual root joined to the first face of every
    piece), accumulated to the root by pointer jumping in O(m log depth).
    Every manifold edge is then checked; a piece with an edge still used
    twice in one direction is not orientable.

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [1, 2, 3]])        # the second face is flipped
    >>> orient_faces(F).F.tolist()
    [[0, 1, 2], [1, 3, 2]]
    """
    F = np.asarray(F, dtype=np.int64)
    m = F.shape[0]
    if m == 0:
        return OrientResult(F=F.copy(), flipped=np.zeros(0, bool), n_pieces=0)
    n = int(F.max()) + 1 if V is None else max(int(F.max()) + 1, len(V))
    if topo is None:
        topo = edge_topology(F, n)
    if fastmesh.enabled(m):
        # the usual case, consistent already, in one union-find pass; else the search below
        n_pieces, piece, first, differ_any = fastmesh.face_pieces_labels(topo, F, m, manifold_only=True)
        if not differ_any:
            return _finish(F, V, topo, piece, first, n_pieces, np.zeros(m, bool), np.zeros(0, np.int64))
    f, g, differ = _manifold_face_pairs(F, topo)

    # pieces: faces joined across manifold edges
    n_pieces, piece = connected_components(m, f, g)
    first = np.full(n_pieces, m, np.int64)
    np.minimum.at(first, piece, np.arange(m))

    if not differ.any():  # already consistent (the usual case): no search needed
        flip = np.zeros(m, bool)
        nonorientable_pieces = np.zeros(0, np.int64)
        return _finish(F, V, topo, piece, first, n_pieces, flip, nonorientable_pieces)

    # spanning forest from a virtual root (node m) joined to each piece's first face
    rows = np.concatenate([f, g, np.full(n_pieces, m)])
    cols = np.concatenate([g, f, first])
    G = sp.csr_matrix((np.ones(rows.size, np.int8), (rows, cols)), shape=(m + 1, m + 1))
    _, pred = breadth_first_order(G, m, directed=True, return_predecessors=True)
    pred = pred[:m].astype(np.int64)
    pred[pred == m] = -1  # first faces of pieces are roots

    # parity of each tree edge (pred -> face): look the pair up among (f, g)
    key = np.concatenate([f * m + g, g * m + f])
    val = np.concatenate([differ, differ])
    srt = np.argsort(key, kind="stable")
    key, val = key[srt], val[srt]
    child = np.flatnonzero(pred >= 0)
    pos = np.searchsorted(key, pred[child] * m + child)
    par = np.zeros(m, bool)
    par[child] = val[pos]

    # pointer jumping: parity of every face relative to its piece's root
    anc = np.where(pred >= 0, pred, np.arange(m))
    while True:
        if (anc == anc[anc]).all():
            break
        par, anc = par ^ par[anc], anc[anc]
    flip = par.copy()

    # consistency check per piece: both faces of a manifold edge, after flipping
    bad = differ ^ (flip[f] ^ flip[g])
    nonorientable_pieces = np.unique(piece[f[bad]])
    return _finish(F, V, topo, piece, first, n_pieces, flip, nonorientable_pieces)


def _finish(F, V, topo, piece, first, n_pieces, flip, nonorientable_pieces):
    """Choose each piece's overall winding and apply the flips."""
    # choose each piece's overall winding
    if flip.any():
        count = np.bincount(piece, minlength=n_pieces)
        n_flip = np.bincount(piece, weights=flip.astype(np.float64), minlength=n_pieces)
        invert = n_flip > count - n_flip  # the majority rule: fewest flips
        tie = n_flip == count - n_flip
        invert &= ~tie
    else:
        invert = np.zeros(n_pieces, bool)
    if V is not None:
        V = np.asarray(V, np.float64)
        bface = topo.boundary_he // 3
        has_boundary = np.zeros(n_pieces, bool)
        has_boundary[piece[bface]] = True
        nm = np.flatnonzero(topo.edge_count > 2)
        if nm.size:
            start = np.cumsum(topo.edge_count) - topo.edge_count
            has_boundary[piece[topo.he_order[concat_ranges(start[nm], topo.edge_count[nm])] // 3]] = True
        closed = ~has_boundary
        closed[nonorientable_pieces] = False
        if closed.any():
            vol = signed_volumes(V, F, flip, piece, n_pieces)
            decided = closed & (vol != 0)
            invert[decided] = vol[decided] < 0
    if invert.any():
        flip ^= invert[piece]

    if flip.any():
        out = F.copy()
        out[flip, 1], out[flip, 2] = F[flip, 2], F[flip, 1]
    else:
        out = F  # nothing to flip: the faces as given
    res = OrientResult(F=out, flipped=flip, n_pieces=int(n_pieces),
                       nonorientable=[int(first[p]) for p in nonorientable_pieces],
                       topo=None if flip.any() else topo,
                       piece=None if len(topo.nonmanifold_edges) else piece.astype(np.int64, copy=False))
    if res.n_flipped:
        res.notes.append(f"{res.n_flipped} faces flipped for consistent orientation")
    if res.nonorientable:
        res.notes.append(f"{len(res.nonorientable)} non-orientable pieces (Möbius-like; first faces "
                         f"{', '.join(map(str, res.nonorientable[:5]))}{', ...' if len(res.nonorientable) > 5 else ''})"
                         f": their boundary is reported, not filled")
    return res


def signed_volumes(V, F, flip, piece, n_pieces):
    """Signed volume of each piece with ``flip`` applied, about its own centroid.

    Taking each piece about the mean of its face centroids keeps the triple
    products small for scans far from the origin (millimetres at 1e6).
    Compiled (:func:`shellrepair.mesh.fastmesh.piece_signed_volumes`, the same
    sums) when the whole-mesh kernels are used.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    flip : (m,) bool
        Faces to count reversed.
    piece : (m,) int64
        Each face's piece.
    n_pieces : int

    Returns
    -------
    (n_pieces,) float64
    """
    if fastmesh.enabled(len(F)):
        return fastmesh.piece_signed_volumes(V, F, flip, piece, n_pieces)
    m = len(F)
    cnt = np.maximum(np.bincount(piece, minlength=n_pieces), 1)
    C = np.empty((m, 3))
    for s in range(0, m, CHUNK):  # face by face, in chunks (no (m,3,3) array)
        C[s:s + CHUNK] = V[F[s:s + CHUNK]].mean(axis=1)
    cen = np.column_stack([np.bincount(piece, weights=C[:, j], minlength=n_pieces) for j in range(3)])
    del C
    cen /= cnt[:, None]
    det = np.empty(m)
    for s in range(0, m, CHUNK):
        T = V[F[s:s + CHUNK]]
        T -= cen[piece[s:s + CHUNK]][:, None, :]
        det[s:s + CHUNK] = dot(T[:, 0], cross(T[:, 1], T[:, 2])) / 6.0
    det[flip] = -det[flip]  # swapping two corners negates the triple product
    return np.bincount(piece, weights=det, minlength=n_pieces)


def describe_open_chains(F, chains, n_vertices, topo=None):
    """Why each boundary chain that does not close was left open.

    Parameters
    ----------
    F : (m,3) int64 array
    chains : list of (k,) int64 arrays
        From :func:`shellrepair.holes.loops.boundary_loops`.
    n_vertices : int
    topo : EdgeTopology, optional

    Returns
    -------
    rows : list of dict
        ``{"id", "edges", "first_vertex", "last_vertex", "reason"}`` per chain.
    """
    F = np.asarray(F, np.int64)
    if topo is None:
        topo = edge_topology(F, n_vertices)
    nm_vertex = np.zeros(int(n_vertices), bool)
    nm_vertex[topo.nonmanifold_edges.ravel()] = True
    rows = []
    for i, c in enumerate(chains):
        c = np.asarray(c, np.int64)
        if nm_vertex[c].any():
            reason = "boundary chain does not close: it runs into a non-manifold edge"
        else:
            reason = "boundary chain does not close: the faces along it are not consistently oriented"
        rows.append({"id": i, "edges": int(len(c) - 1), "first_vertex": int(c[0]),
                     "last_vertex": int(c[-1]), "reason": reason})
    return rows


# --------------------------------------------------------------------------
# topology by position, and non-manifold edges and vertices made manifold
# --------------------------------------------------------------------------
@dataclass
class ManifoldResult:
    """Result of :func:`make_manifold` and :func:`split_piece_junctions`.

    Attributes
    ----------
    F : (k,3) int64 array
        Faces for the topology: coincident vertices joined (each corner
        points to the lowest-numbered vertex at its position), split corners
        re-pointed to new vertices.
    kept : (k,) int64 array
        Index into the input ``F`` of each returned face (faces that repeat
        a position, duplicates by position and folded faces are dropped).
    rep : (n,) int64 array or None
        The position weld: ``rep[v]`` the vertex ``v`` was joined to; None
        when nothing was joined.
    src : (q,) int64 array
        New vertex ``n + j`` is a copy of vertex ``src[j]`` (same position,
        same attributes).
    counts : dict
        ``vertices_joined``, ``nonmanifold_edges_found`` (after joining),
        ``folded_faces_dropped``, ``nonmanifold_edges_split``,
        ``nonmanifold_vertices_split``, ``vertices_added``.
    notes : list of str
    topo : EdgeTopology or None
        The edge topology of ``F`` when it was built on the way.
    """

    F: np.ndarray
    kept: np.ndarray
    rep: np.ndarray | None = None
    src: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    counts: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    topo: object = None

    @property
    def changed(self):
        return self.rep is not None or self.src.size > 0 or len(self.kept) != len(self.F) or \
            any(self.counts.values())


#: Keys of :attr:`ManifoldResult.counts`, all zero for a clean manifold mesh.
FIX_COUNTS = ("vertices_joined", "nonmanifold_edges_found", "folded_faces_dropped", "nonmanifold_edges_split",
              "nonmanifold_vertices_split", "vertices_added")


def make_manifold(V, F, topo=None):
    """Join coincident open vertices, drop folded faces, split non-manifold edges.

    Parameters
    ----------
    V : (n,3) float64 array
        Never changed; new vertices are copies of old ones (``src``).
    F : (m,3) int64 array
        Faces with no repeated vertex and no duplicate (as
        :func:`clean_faces` leaves them).
    topo : EdgeTopology, optional
        Of ``F``, if already built.

    Returns
    -------
    result : ManifoldResult

    Notes
    -----
    1. *Coincident vertices.* Vertices on open edges (edges with one face)
       whose positions are bit-identical (``-0.0`` read as ``0.0``) are one
       vertex for the topology: a triangle soup or a surface cut at texture
       seams becomes the surface it stands for. Only open-edge vertices are
       compared: a vertex whose fan is closed could only be split off again.
       Faces that then repeat a vertex or duplicate another face are dropped.
    2. *Folded faces.* A face with two or more non-manifold edges, left out
       of the manifold pair kept at each of them, whose other edge is open,
       lies over a surface that is closed without it (a fold left by
       decimation: it shows as a one-edge opening). It is dropped and
       counted.
    3. *Non-manifold edges.* At an edge with three or more faces one pair is
       kept together: two faces of one piece (joined across manifold edges)
       if there are such, then consistently oriented if any pair is, then
       the pair whose faces have the fewest open or non-manifold edges, then
       the flattest pair (normals closest). The other faces are cut from the
       edge. At each end of every such edge the faces are grouped into fans
       (joined across the edges at that vertex that still join them); the
       largest fan keeps the vertex, each other fan gets a copy of it
       (appended, same position and attributes). Nothing is moved.
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    n = len(V)
    counts = dict.fromkeys(FIX_COUNTS, 0)
    notes = []
    kept = np.arange(len(F), dtype=np.int64)
    if topo is None:
        topo = edge_topology(F, n)

    # 1. coincident open vertices
    rep = None
    if topo.boundary_he.size:
        from shellrepair.mesh.topology import coincident_vertices

        rep = coincident_vertices(V, topo.ends(topo.boundary_he).ravel())
    if rep is not None:
        used = np.zeros(n, bool)
        used[F.ravel()] = True
        counts["vertices_joined"] = int(np.count_nonzero((rep != np.arange(n)) & used))
        F = rep[F]
        F, k2, cn = clean_faces(F)
        kept = kept[k2]
        notes.append(f"{counts['vertices_joined']} vertices joined to a coincident vertex for the topology "
                     "(same position, bit for bit)")
        notes.extend(f"{c} after joining coincident vertices" for c in cn)
        topo = edge_topology(F, n)

    # 2. folded faces
    counts["nonmanifold_edges_found"] = int(topo.nonmanifold_edges.shape[0])
    if topo.nonmanifold_edges.size:
        pairs, left = _nonmanifold_pairs(V, F, topo)
        fold = _folded_faces(F, topo, left)
        if fold.size:
            keep = np.ones(len(F), bool)
            keep[fold] = False
            F, kept = F[keep], kept[keep]
            counts["folded_faces_dropped"] = int(fold.size)
            notes.append(f"{fold.size} folded faces dropped: each lay over faces that close the surface without "
                         "it (two or more of its edges non-manifold, the other open: a one-edge opening)")
            topo = edge_topology(F, n)

    # 3. non-manifold edges
    src = np.zeros(0, np.int64)
    n_nm = int(topo.nonmanifold_edges.shape[0])
    if n_nm:
        pairs, _ = _nonmanifold_pairs(V, F, topo)
        h1, h2 = manifold_pairs(topo)
        links = np.concatenate([np.column_stack([h1, h2]), pairs])
        verts = np.unique(topo.nonmanifold_edges)
        F, src = _split_groups(F, n, *corner_fans(F, verts, links))
        topo = edge_topology(F, n + src.size)
        left = int(topo.nonmanifold_edges.shape[0])
        counts["nonmanifold_edges_split"] = n_nm - left
        counts["nonmanifold_vertices_split"] = int(np.unique(src).size)
        counts["vertices_added"] = int(src.size)
        notes.append(f"{n_nm - left} non-manifold edges split: {np.unique(src).size} vertices copied "
                     f"({src.size} new vertices at the same positions, appended)")
        if left:
            notes.append(f"{left} non-manifold edges could not be split (their faces form one fan at both ends)")
    return ManifoldResult(F=F, kept=kept, rep=rep, src=src, counts=counts, notes=notes, topo=topo)


def split_piece_junctions(F, n_vertices, piece):
    """Give each piece meeting others at a vertex its own copy of the vertex.

    Parameters
    ----------
    F : (m,3) int64 array
    n_vertices : int
    piece : (m,) int64 array
        Each face's piece (faces joined across manifold edges, as
        :func:`shellrepair.mesh.topology.face_pieces` labels them).

    Returns
    -------
    F_new : (m,3) int64 array
        ``F`` with the corners of every piece but one re-pointed at each
        junction vertex (the piece with the most corners there keeps it).
    src : (q,) int64 array
        New vertex ``n_vertices + j`` copies vertex ``src[j]``.

    Notes
    -----
    Two closed surfaces touching at a vertex, or two triangles meeting at a
    corner (a bowtie), are pieces that share only a vertex. Several fans of
    one piece at a vertex (two holes touching at a corner) are not split:
    filling the holes joins the fans into one.
    """
    F = np.asarray(F, np.int64)
    n = int(n_vertices)
    piece = np.asarray(piece, np.int64)
    if piece.size == 0 or piece.max() == piece.min():   # one piece: no junction (the usual scan)
        return F, np.zeros(0, np.int64)
    flat = F.ravel()
    cp = np.repeat(piece.astype(np.int32) if piece.max() < 2 ** 31 else piece, 3)   # 32 bits: half the traffic
    some = np.empty(n, cp.dtype)
    some[flat] = cp                                      # one piece per vertex (the last written)
    cross_ = np.flatnonzero(cp != some[flat])
    if cross_.size == 0:
        return F, np.zeros(0, np.int64)
    junction = np.unique(flat[cross_])
    if junction.size == 0:
        return F, np.zeros(0, np.int64)
    mark = np.zeros(n, bool)
    mark[junction] = True
    corners = np.flatnonzero(mark[flat])
    key = flat[corners] * (int(cp.max()) + 1) + cp[corners].astype(np.int64)
    _, group = np.unique(key, return_inverse=True)
    return _split_groups(F, n, corners, group.astype(np.int64))


def _split_groups(F, n, corners, group):
    """Re-point corners so that each group of a vertex's corners but the
    largest gets a new vertex; returns (F_new, src)."""
    flat = F.ravel()
    if corners.size == 0:
        return F, np.zeros(0, np.int64)
    size = np.bincount(group)
    first = np.full(size.size, corners.size, np.int64)
    np.minimum.at(first, group, np.arange(corners.size))
    gv = flat[corners[first]]                                 # the vertex of each group
    order = np.lexsort((first, -size, gv))                    # per vertex: largest group first
    head = np.ones(order.size, bool)
    head[1:] = gv[order[1:]] != gv[order[:-1]]
    extra = order[~head]
    if extra.size == 0:
        return F, np.zeros(0, np.int64)
    extra = extra[np.lexsort((first[extra], gv[extra]))]      # new vertices in vertex order
    new_id = np.full(size.size, -1, np.int64)
    new_id[extra] = n + np.arange(extra.size)
    out = flat.copy()
    moved = new_id[group] >= 0
    out[corners[moved]] = new_id[group[moved]]
    return out.reshape(-1, 3), gv[extra]


def _nonmanifold_pairs(V, F, topo):
    """The pair of half-edges kept together at each non-manifold edge.

    Returns
    -------
    pairs : (p,2) int64
        Two half-edges per non-manifold edge.
    left : (r,) int64
        The other half-edges of those edges.
    """
    count = topo.edge_count
    start = np.cumsum(count) - count
    nm = np.flatnonzero(count > 2)
    ec = count[topo.edge_of_he].reshape(-1, 3)
    bad = (ec != 2).sum(axis=1)                           # open or non-manifold edges per face
    flat = F.ravel()
    # faces joined across manifold edges: a pair from one such piece (the two
    # faces of one closed part, the surface under a fold) belongs together
    h1, h2 = manifold_pairs(topo)
    m = len(F)
    _, piece = connected_components(m, h1 // 3, h2 // 3)
    pairs, left = [], []
    for e in nm.tolist():
        hs = topo.he_order[start[e]:start[e] + count[e]]
        fs = hs // 3
        T = V[F[fs]]
        N = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
        ln = np.linalg.norm(N, axis=1, keepdims=True)
        N = np.divide(N, ln, out=np.zeros_like(N), where=ln > 0)
        best, best_key = None, None
        for i in range(len(hs)):
            for j in range(i + 1, len(hs)):
                consistent = flat[hs[i]] != flat[hs[j]]
                d = float(N[i] @ N[j]) if consistent else -float(N[i] @ N[j])
                key = (piece[fs[i]] != piece[fs[j]], not consistent, int(bad[fs[i]] + bad[fs[j]]), -d,
                       int(fs[i]), int(fs[j]))
                if best_key is None or key < best_key:
                    best, best_key = (i, j), key
        pairs.append((hs[best[0]], hs[best[1]]))
        left.extend(int(h) for k, h in enumerate(hs) if k not in best)
    return np.array(pairs, np.int64).reshape(-1, 2), np.array(left, np.int64)


def _folded_faces(F, topo, left):
    """Faces left out at two or more non-manifold edges whose other edges are open."""
    if left.size == 0:
        return np.zeros(0, np.int64)
    m = len(F)
    n_left = np.bincount(left // 3, minlength=m)
    ec = topo.edge_count[topo.edge_of_he].reshape(-1, 3)
    n_open = (ec == 1).sum(axis=1)
    return np.flatnonzero((n_left >= 2) & (n_left + n_open == 3))


def clean_faces(F):
    """Drop faces that repeat a vertex and exact duplicate faces.

    Parameters
    ----------
    F : (m,3) int64 array

    Returns
    -------
    F_clean : (k,3) int64 array
        Kept faces, in their original order (``F`` itself when none is
        dropped).
    kept : (k,) int64 array
        Indices into ``F`` of the kept faces.
    notes : list of str
        One line per kind of face dropped.
    """
    F = np.asarray(F, dtype=np.int64)
    notes = []
    ok = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])
    n_degen = int((~ok).sum())
    idx = np.flatnonzero(ok)
    # duplicates share their sorted vertex triple, hence its hash; only the
    # faces whose hash value repeats (all duplicates, and rare collisions)
    # are grouped exactly, so a scan without duplicates sorts one array
    G = F if n_degen == 0 else F[idx]
    h = fastmesh.triple_hash(G) if fastmesh.enabled(len(G)) else triple_hash_reference(G)
    del G
    hs = np.sort(h)
    rep = np.unique(hs[1:][hs[1:] == hs[:-1]])
    del hs
    keep = np.ones(len(idx), bool)
    if rep.size:
        cand = np.flatnonzero(rep[np.minimum(np.searchsorted(rep, h), rep.size - 1)] == h)
        S = np.sort(F[idx[cand]], axis=1)
        # stable: the first face of a group of duplicates comes first
        order = np.lexsort((S[:, 2], S[:, 1], S[:, 0]))
        Ss = S[order]
        later = np.zeros(len(Ss), bool)
        later[1:] = (Ss[1:] == Ss[:-1]).all(axis=1)
        keep[cand[order[later]]] = False
    kept = idx[keep] if rep.size or n_degen else idx
    n_dup = len(idx) - len(kept)
    if n_degen:
        notes.append(f"{n_degen} faces with a repeated vertex dropped")
    if n_dup:
        notes.append(f"{n_dup} duplicate faces dropped")
    if len(kept) == len(F):   # nothing dropped (the usual scan): no copy of F
        return F, kept, notes
    return F[kept], kept, notes


def triple_hash_reference(F):
    """A 64-bit hash of each row's vertex set (equal for equal sets in any
    order), in NumPy: the fallback, and the oracle of
    :func:`shellrepair.mesh.fastmesh.triple_hash`.

    Parameters
    ----------
    F : (m,3) int64

    Returns
    -------
    (m,) uint64
    """
    x, y, z = F[:, 0], F[:, 1], F[:, 2]
    a = np.minimum(x, y)
    np.minimum(a, z, out=a)
    c = np.maximum(x, y)
    np.maximum(c, z, out=c)
    b = x + y
    b += z
    b -= a
    b -= c
    # in place, as unsigned 64-bit words (products wrap around)
    h, b, c = a.view(np.uint64), b.view(np.uint64), c.view(np.uint64)
    h *= np.uint64(0x9E3779B97F4A7C15)
    b *= np.uint64(0xC2B2AE3D27D4EB4F)
    h ^= b
    c *= np.uint64(0x165667B19E3779F9)
    h ^= c
    del b, c
    h ^= h >> np.uint64(29)
    return h
