"""Dirty but valid geometry: consistent orientation, and what is left open.

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
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components

from .geometry import cross, dot
from .topology import CHUNK, edge_topology, manifold_pairs

__all__ = ["OrientResult", "orient_faces", "describe_open_chains"]


@dataclass
class OrientResult:
    """Result of :func:`orient_faces`.

    Attributes
    ----------
    F : (m,3) int64 array
        The faces, same order, some with corners 1 and 2 swapped.
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
        Each face's piece, labelled as :func:`shellrepair.topology.face_pieces`
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
    tail = F.ravel()  # the tails of the half-edges (topo.he[:, 0]), a denser gather
    differ = tail[h1] == tail[h2]
    return h1 // 3, h2 // 3, differ


def orient_faces(F, V=None):
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
    topo = edge_topology(F, n)
    f, g, differ = _manifold_face_pairs(F, topo)

    # pieces: faces joined across manifold edges
    A = sp.csr_matrix((np.ones(f.size, np.int8), (f, g)), shape=(m, m))
    n_pieces, piece = connected_components(A, directed=False)
    first = np.full(n_pieces, m, np.int64)
    np.minimum.at(first, piece, np.arange(m))

    if not differ.any():  # already consistent (the usual case): no search needed
        flip = np.zeros(m, bool)
        nonorientable_pieces = np.zeros(0, np.int64)
        return _finish(F, V, topo, f, g, piece, first, n_pieces, flip, nonorientable_pieces)

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
    return _finish(F, V, topo, f, g, piece, first, n_pieces, flip, nonorientable_pieces)


def _finish(F, V, topo, f, g, piece, first, n_pieces, flip, nonorientable_pieces):
    """Choose each piece's overall winding and apply the flips."""
    # choose each piece's overall winding
    count = np.bincount(piece, minlength=n_pieces)
    n_flip = np.bincount(piece, weights=flip.astype(np.float64), minlength=n_pieces)
    invert = n_flip > count - n_flip  # the majority rule: fewest flips
    tie = n_flip == count - n_flip
    invert &= ~tie
    if V is not None:
        V = np.asarray(V, np.float64)
        bface = topo.boundary_he // 3
        has_boundary = np.zeros(n_pieces, bool)
        has_boundary[piece[bface]] = True
        nm_face = np.flatnonzero(topo.edge_count[topo.edge_of_he] > 2) // 3
        has_boundary[piece[nm_face]] = True
        closed = ~has_boundary
        closed[nonorientable_pieces] = False
        if closed.any():
            vol = _signed_volumes(V, F, flip, piece, n_pieces)
            decided = closed & (vol != 0)
            invert[decided] = vol[decided] < 0
    flip ^= invert[piece]

    out = F.copy()
    out[flip, 1], out[flip, 2] = F[flip, 2], F[flip, 1]
    res = OrientResult(F=out, flipped=flip, n_pieces=int(n_pieces),
                       nonorientable=[int(first[p]) for p in nonorientable_pieces],
                       topo=None if flip.any() else topo,
                       piece=None if len(topo.nonmanifold_edges) else piece.astype(np.int64))
    if res.n_flipped:
        res.notes.append(f"{res.n_flipped} faces flipped for consistent orientation")
    if res.nonorientable:
        res.notes.append(f"{len(res.nonorientable)} non-orientable pieces (Möbius-like; first faces "
                         f"{', '.join(map(str, res.nonorientable[:5]))}{', ...' if len(res.nonorientable) > 5 else ''})"
                         f": their boundary is reported, not filled")
    return res


def _signed_volumes(V, F, flip, piece, n_pieces):
    """Signed volume of each piece with ``flip`` applied, about its own centroid.

    Taking each piece about the mean of its face centroids keeps the triple
    products small for scans far from the origin (millimetres at 1e6).
    """
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
        From :func:`shellrepair.holes.boundary_loops`.
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
