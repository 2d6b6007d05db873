"""Boundary loops of a scan, their measurements, and hole / border classing.

A *loop* is a closed chain of boundary half-edges (edges with one face),
listed in the direction of those half-edges, so the faces of the scan lie to
the left of the loop when walking along it (seen from outside a closed
surface). Two holes touching at one vertex are two loops: at such a pinch
vertex the loop continues along the fan of faces it came from. A loop that
still visits a vertex twice is split there into simple loops.

Hole or border
--------------
Not every opening is a hole: a single-view scan is an open sheet whose outer
edge is meant to stay open, and so is a floating island of scan data; but a
statue scanned all round whose base was never seen is a closed object with
a (large) hole. Which of the two a *piece* (faces joined across edges) is,
is read from the piece itself, from its face normals:

*View ratio.* Seen along a direction ``d``, the faces turned towards ``d``
have projected area ``P+(d) = Σ A_f max(n_f·d, 0)`` and those turned away
``P−(d) = Σ A_f max(−n_f·d, 0)``. A scanner records only surface that faces
it, so a single view has ``P− ≈ 0`` along its viewing direction
(perspective and noise on steep faces add a little: the real dragon range
scan in ../shared/data has exactly 0 on all its 42 pieces, 500 noisy
synthetic range scans of the closed figures there at most 0.0104). On a closed surface ``P+ = P−`` from every direction
(the projections of a closed surface cancel), and cutting a part off lowers
the ratio only gradually: a sphere missing a cap of a fraction ``p`` of its
area has ``min_d P−/P+ = (1 − 2p)²``, 0.25 with a quarter gone; the real
closed figures in ../shared/data cut 5–25 % up their extent at random
tilts, with random occlusion holes, kept at least 0.17 in 500 cases (the
threshold below was set from the sphere, not from these; the numbers are
from seeds not looked at while designing, see tests/test_border_classes.py).

1. ``max_hole``: a loop with more edges than this is a *border*
   ("larger than max_hole"); ``max_size``: one wider than this length.
2. *Wraps around*: when ``min_d P−/P+ ≥ WRAP_RATIO`` (0.05: a sphere
   missing less than 39 % of its area) the piece's normals cover clearly
   more than a hemisphere; it is part of a closed object and every loop of
   it is a *hole*, the unscanned base of a bust included.
3. *Seen edge-on*: a view records only surface turned towards it, and
   none seen at grazing incidence: when ``EDGE_ON_SHARE`` (half) or more of
   the piece's area is turned within ``EDGE_ON_DEGREES`` (10°) of edge-on
   from every direction that reads it as one view (back ratio below
   ``WRAP_RATIO``; :func:`edge_on_share`), no single view recorded it. Such
   a piece was scanned from several sides: a closed object with holes,
   like rule 2. A capped tube (a thin arm cut off by a missing band: its walls
   stand along the view that sees its tip) or a can with its lid is read
   so; a bowl, a dome or a flat island of debris is not (a hemisphere has
   17 % of its area within 10° of edge-on). Single-view range scans of the
   closed figures in ../shared/data ray-cast without an incidence limit
   reach 35 % (design seeds 0–11), the real dragon range scan 3.2 %.
4. *Single view*: otherwise the piece is a height field seen from the best
   direction ``d`` (a range scan, an island of scan data, a lone triangle,
   a bowl seen from above, a dome, and so a sphere missing more than 39 %
   of its area). Seen along ``d``, its outer rim is the loop whose outline
   holds most of the piece's area (``inside_fraction`` ≈ 1 for the rim of a
   height field, ≈ 0 for its holes): that loop is a *border*, every other
   loop of the piece is a *hole*.
5. *Across a band*: a single-view piece's outer rim that faces a hole of
   another piece across a gap is the far side of a missing band, and a
   *hole*: the tip of a thin arm beyond a band the scanner missed is a
   short dome that rules 2-4 read as one view. The test is the one by
   which a repair pairs two holes across a band
   (:func:`shellrepair.bridge.loop_sights`): the rim and the hole each
   send a strict majority of their continuation arcs to the other. The
   rims of one range scan do not pass it (the real dragon scan's 42, the
   synthetic torus scans'); a rim facing a hole of its own piece (a torus
   seen from above) keeps rule 4's reading.

A bowl (normals in a closed hemisphere, few of them edge-on) is read as
one view: its rim a border. ``closed=True`` (``--closed yes``)
reads every piece as closed, ``closed=False`` (``--closed no``) every piece
as a single view; ``fill_borders=True`` turns every loop into a hole (rule
1 still applies).
"""

from __future__ import annotations

import math
import sys
from dataclasses import asdict, dataclass, field

import numpy as np

from .geometry import cross, plane_frame, points_in_polygon, uniq
from . import compiled, fastmesh
from .topology import components_of_pieces, edge_topology, face_areas, face_pieces

__all__ = ["Loop", "HoleScan", "boundary_loops", "detect_holes", "loop_stats", "piece_views", "edge_on_share",
           "WRAP_RATIO", "EDGE_ON_SHARE"]

#: Least ratio of back-facing to front-facing projected area, from the best
#: single view, at which a piece wraps around (rule 2 of the module docstring).
WRAP_RATIO = 0.05
#: Rule 3 of the module docstring: a piece with at least this share of its
#: area within ``EDGE_ON_DEGREES`` of edge-on from its best view was seen
#: from several sides ("most of it": single views reach 0.35 without an
#: incidence limit, see the module docstring).
EDGE_ON_SHARE = 0.5
EDGE_ON_DEGREES = 10.0
#: Faces per piece read for rule 3 (a larger piece: a fixed hashed subset).
EDGE_ON_SAMPLES = 5000
#: Faces sampled per single-view piece to find its outer rim.
OUTER_SAMPLES = 20000
#: Cells per axis of the cube over normal space in which a piece's normals
#: are summed for the search of its best view (~7° wide).
NORMAL_BINS = 16
#: Faces per piece on which its best view is measured (a larger piece: a
#: fixed pseudo-random subset).
VIEW_SAMPLES = 50000
#: Evenly spread directions the search of a best view starts from (~10° apart).
VIEW_CANDIDATES = 400


@dataclass
class Loop:
    """One boundary loop and what was measured on it.

    Attributes
    ----------
    id : int
    vertices : (k,) int64 array
        Loop vertices in boundary half-edge order.
    edges : int
    perimeter, mean_edge, area, diameter : float
        ``area`` is the norm of the loop's vector area: the area a flat
        filling would have (a lower bound for a curved one).
    planarity : float
        RMS distance of the loop to its best-fit plane over its diameter
        (0 for a planar loop).
    component : int
        Connected component the loop belongs to (faces joined by vertices).
    piece_area : float or None
        Area of the loop's piece (faces joined across edges); None when
        not measured (``detect_holes(measure=False)``, a repair's call).
    inside_fraction : float
        Fraction of the piece's area inside the loop's outline seen along
        the piece's best view (measured for single-view pieces only, else 0).
    kind : str
        ``'hole'`` or ``'border'``.
    reason : str
        Why it was classed so.
    back_ratio : float or None
        ``min_d P−/P+`` of the loop's piece (module docstring); None when
        not measured (``closed=True`` or ``fill_borders``).
    reading : str
        ``'closed'`` or ``'single view'``: how the loop's piece was read
        (``''`` when not read, under ``fill_borders``).
    edge_on : float or None
        Share of the piece's area within ``EDGE_ON_DEGREES`` of edge-on
        from its best view (rule 3; measured only where rule 2 does not
        already read the piece closed, else 0); None when not read.
    center : tuple of 3 float or None
        The mean of the rim's vertices, in the scan's units (where to look
        for the loop); None for a loop made otherwise.
    """

    id: int
    vertices: np.ndarray
    edges: int
    perimeter: float
    mean_edge: float
    area: float
    diameter: float
    planarity: float
    component: int
    piece_area: float | None
    inside_fraction: float = 0.0
    kind: str = "hole"
    reason: str = ""
    back_ratio: float = None
    reading: str = ""
    edge_on: float = None
    center: tuple = None

    def reclass(self, kind, reason):
        """Class the loop again (a user's request to fill a border): ``kind`` and why."""
        self.kind, self.reason = kind, reason

    @property
    def axis(self):
        """(3,) unit normal of the loop's best-fit plane, as :func:`loop_stats`
        measured it when the loop was found (None for a loop made otherwise)."""
        return getattr(self, "_axis", None)

    def as_dict(self):
        d = asdict(self)
        d.pop("vertices")
        d["first_vertex"] = int(self.vertices[0])
        return d


@dataclass
class HoleScan:
    """Result of :func:`detect_holes`.

    Attributes
    ----------
    loops : list of Loop
    open_chains : list of (k,) int64 arrays
        Boundary chains that do not close (next to non-manifold edges or
        inconsistently oriented faces); reported, never filled.
    n_components : int
    n_boundary_edges, n_nonmanifold_edges : int
    euler : int
        V − E + F over the vertices that faces use.
    """

    loops: list
    open_chains: list = field(default_factory=list)
    n_components: int = 0
    n_boundary_edges: int = 0
    n_nonmanifold_edges: int = 0
    euler: int = 0

    @property
    def holes(self):
        return [lp for lp in self.loops if lp.kind == "hole"]

    @property
    def borders(self):
        return [lp for lp in self.loops if lp.kind == "border"]


# --------------------------------------------------------------------------
# loops
# --------------------------------------------------------------------------
#: :func:`boundary_loops` numbers the boundary vertices among themselves
#: when the mesh has more than this many vertices per boundary vertex (a
#: small face set of a large scan); the loops are the same either way.
COMPACT_RATIO = 4


def boundary_loops(F, n_vertices, topo=None):
    """Boundary loops of a triangle mesh.

    Parameters
    ----------
    F : (m,3) int64 array
    n_vertices : int
    topo : EdgeTopology, optional
        Reused if already computed.

    Returns
    -------
    loops : list of (k,) int64 arrays
        Simple closed loops, vertices in boundary half-edge order.
    open_chains : list of (k,) int64 arrays
        Chains of boundary half-edges that do not close.
    """
    F = np.asarray(F, np.int64)
    if topo is None:
        topo = edge_topology(F, n_vertices)
    bhe = topo.boundary_he
    if bhe.size == 0:
        return [], []
    ends = topo.ends(bhe)
    src = ends[:, 0]
    dst = ends[:, 1]
    n = int(n_vertices)
    if COMPACT_RATIO * 2 * bhe.size < n:
        # few boundary vertices on many: number them among themselves (an
        # increasing map, so every order below is the same), O(b log b)
        # instead of O(n) per call
        keys = uniq(np.concatenate([src, dst]))
        sc, dc, n = np.searchsorted(keys, src), np.searchsorted(keys, dst), len(keys)
    else:
        sc, dc = src, dst
    out_count = np.bincount(sc, minlength=n)
    order = np.argsort(sc, kind="stable")
    start = np.zeros(n + 1, np.int64)          # sc[order][start[v]:start[v+1]] == v
    np.cumsum(out_count, out=start[1:])

    nxt = np.full(bhe.size, -1, dtype=np.int64)
    single = out_count[dc] == 1
    nxt[single] = order[start[dc[single]]]
    multi = np.flatnonzero(out_count[dc] > 1)
    if multi.size:
        _resolve_pinches(F, topo, bhe, src, dst, order, start, multi, nxt, dc)

    loops, chains = [], []
    # has_prev: chains must start at a half-edge nobody points to
    has_prev = np.zeros(bhe.size, bool)
    has_prev[nxt[nxt >= 0]] = True
    visited = [False] * bhe.size          # the walk on Python lists: no NumPy scalar per step
    nxt_l = nxt.tolist()
    for begin in np.flatnonzero(~has_prev).tolist() + list(range(bhe.size)):
        if visited[begin]:
            continue
        seq = []
        cur = begin
        closed = False
        while cur >= 0 and not visited[cur]:
            visited[cur] = True
            seq.append(cur)
            cur = nxt_l[cur]
            if cur == begin:
                closed = True
                break
        verts = src[np.array(seq, dtype=np.int64)]
        if closed:
            loops.extend(_split_simple(verts))
        else:
            chains.append(np.append(verts, dst[seq[-1]]).astype(np.int64))
    return loops, chains


def _resolve_pinches(F, topo, bhe, src, dst, order, start, multi, nxt, dc):
    """At vertices with several outgoing boundary half-edges, continue along
    the fan of faces the incoming half-edge belongs to (``dc``: ``dst`` in
    the numbering ``start`` is indexed by)."""
    pinch = np.unique(dst[multi])
    near = np.flatnonzero(np.isin(F, pinch).any(axis=1))
    he_face = {}
    for f, (a, b, c) in zip(near.tolist(), F[near].tolist()):
        he_face[(a, b)] = f
        he_face[(b, c)] = f
        he_face[(c, a)] = f
    pinch_set = set(pinch.tolist())
    bset = {(s, d): i for i, (s, d) in enumerate(zip(src.tolist(), dst.tolist())) if s in pinch_set}
    taken = set()
    unresolved = []
    for i in multi:
        a, v = int(src[i]), int(dst[i])
        f = int(bhe[i] // 3)
        found = -1
        for _ in range(len(near) + 1):
            tri = F[f]
            k = int(np.flatnonzero(tri == v)[0])
            w = int(tri[(k + 1) % 3])  # half-edge v -> w leaves v in face f
            if (v, w) in bset:
                found = bset[(v, w)]
                break
            g = he_face.get((w, v))
            if g is None or g == f:
                break
            f = g
        if found >= 0 and found not in taken:
            nxt[i] = found
            taken.add(found)
        else:
            unresolved.append(i)
    for i in unresolved:
        v = int(dc[i])
        for j in order[start[v]:start[v + 1]]:
            if int(j) not in taken:
                nxt[i] = j
                taken.add(int(j))
                break


def _split_simple(verts):
    """Split a closed vertex sequence that repeats a vertex into simple loops."""
    if np.unique(verts).size == verts.size:
        return [verts.astype(np.int64)]
    out = []
    stack = []
    pos = {}
    for v in verts.tolist():
        if v in pos:
            i = pos[v]
            sub = stack[i:]
            for u in sub[1:]:
                del pos[u]
            del stack[i + 1:]
            if len(sub) >= 3:
                out.append(np.array(sub, dtype=np.int64))
        else:
            pos[v] = len(stack)
            stack.append(v)
    if len(stack) >= 3:
        out.append(np.array(stack, dtype=np.int64))
    return out


# --------------------------------------------------------------------------
# measurements
# --------------------------------------------------------------------------
def loop_stats(V, loop):
    """Perimeter, mean edge, vector area, diameter, planarity and axis of a loop.

    Parameters
    ----------
    V : (n,3) float64 array
    loop : (k,) int64 array

    Returns
    -------
    stats : dict
        ``perimeter, mean_edge, area, diameter, planarity`` (floats),
        ``center`` (3,), ``axis`` (3,) unit normal of the best-fit plane,
        oriented along the vector area.
    """
    P = np.asarray(V, np.float64)[np.asarray(loop, np.int64)]
    # NumPy's own steps without their Python set-up (a scan has thousands
    # of loops): mean = the column sums over the count, norm = the square
    # root of the summed squares (of the dot product for one vector)
    c = P.sum(axis=0) / len(P)
    Q = P - c
    Qn = np.concatenate([Q[1:], Q[:1]])          # the next vertex of each (np.roll by -1)
    E = Qn - Q
    lengths = np.sqrt(np.add.reduce(E * E, axis=1))
    perimeter = float(lengths.sum())
    vec_area = 0.5 * cross(Q, Qn).sum(axis=0)    # np.cross's products, without its set-up
    area = math.sqrt(vec_area.dot(vec_area))
    diameter = _diameter(Q)
    _, s, vt = np.linalg.svd(Q, full_matrices=False)
    axis = vt[-1]
    if np.dot(axis, vec_area) < 0:
        axis = -axis
    rms = float(s[-1] / np.sqrt(len(P))) if len(s) == 3 else 0.0
    return {
        "perimeter": perimeter,
        "mean_edge": perimeter / len(P),
        "area": area,
        "diameter": diameter,
        "planarity": rms / diameter if diameter > 0 else 0.0,
        "center": c,
        "axis": axis,
    }


def _diameter(Q, chunk=2048):
    """Largest distance between two rows of ``Q``: by the compiled loop
    (:func:`shellrepair.common_kernels.max_sq_distance`, the same value bit for
    bit) when the kernels are loaded already (a repair loads them; hole
    detection alone does not), else in chunks of rows."""
    k = sys.modules.get("shellrepair.common_kernels")
    if k is not None and compiled.ENABLED and len(Q) > 1 and np.isfinite(Q).all():
        return float(np.sqrt(k.max_sq_distance(Q)))
    return _diameter_numpy(Q, chunk)


def _diameter_numpy(Q, chunk=2048):
    """:func:`_diameter` in NumPy (the kernel's test oracle)."""
    best = 0.0
    for i in range(0, len(Q), chunk):
        d = ((Q[i:i + chunk, None, :] - Q[None, :, :]) ** 2).sum(axis=2)
        best = max(best, float(d.max()))
    return float(np.sqrt(best))


def _inside_fractions(V, loops, axes, centers, cent, w, chunk=64):
    """Area fraction of sample points (face centroids ``cent`` with areas
    ``w``) inside each loop's outline seen along its axis; the projections
    of the samples are made for ``chunk`` loops at a time, by one product."""
    out = np.zeros(len(loops))
    tot = float(w.sum())
    if not len(loops) or tot <= 0:
        return out
    U, W = plane_frame(np.asarray(axes, np.float64))
    C = np.asarray(centers, np.float64)
    for s in range(0, len(loops), chunk):
        sl = slice(s, s + chunk)
        PU = U[sl] @ cent.T - np.sum(U[sl] * C[sl], axis=1)[:, None]   # (c, N)
        PW = W[sl] @ cent.T - np.sum(W[sl] * C[sl], axis=1)[:, None]
        for j, i in enumerate(range(s, min(s + chunk, len(loops)))):
            P = V[loops[i]] - C[i]
            poly = np.column_stack([P @ U[i], P @ W[i]])
            lo, hi = poly.min(axis=0), poly.max(axis=0)
            box = np.flatnonzero((PU[j] >= lo[0]) & (PU[j] <= hi[0]) & (PW[j] >= lo[1]) & (PW[j] <= hi[1]))
            if box.size:  # only these can be inside
                inside = points_in_polygon(np.column_stack([PU[j, box], PW[j, box]]), poly)
                out[i] = float(w[box[inside]].sum() / tot)
    return out


def _fibonacci_directions(n):
    """``n`` unit vectors spread evenly over the sphere (a Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    phi = np.pi * (1.0 + np.sqrt(5.0)) * i
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


_CANDIDATES = _fibonacci_directions(VIEW_CANDIDATES)


def _back_front(D, S):
    """P−/P+ of normals ``S`` (rows: vector areas) seen along each row of ``D``."""
    s = D @ S.T
    front = np.maximum(s, 0.0).sum(axis=1)
    back = np.maximum(-s, 0.0).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = back / front
    r[front <= 0] = np.inf
    r[(front <= 0) & (back <= 0)] = 0.0  # no area at all
    return r


def _best_view(S):
    """The direction from which the normals ``S`` (rows: summed vector areas
    of a piece's faces, binned by direction) show the least back-facing
    area relative to the front-facing one: the best of an even spread of
    directions (and the mean normal), then a pattern search around the four
    best, the step halving from half the spread's spacing to ~0.1°."""
    m = S.sum(axis=0)
    D = _CANDIDATES
    nm = np.linalg.norm(m)
    if nm > 0:
        D = np.vstack([D, m / nm])
    r = _back_front(D, S)
    keep = np.argsort(r, kind="stable")[:4]
    best, rb = D[keep], r[keep]
    step = 0.5 * np.sqrt(4 * np.pi / VIEW_CANDIDATES)
    ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    ring = np.column_stack([np.cos(ang), np.sin(ang)])  # (8,2)
    U, W = plane_frame(best)
    while step > 2e-3:
        P = (best[:, None, :] + step * (ring[None, :, :1] * U[:, None, :] + ring[None, :, 1:] * W[:, None, :]))
        P = P.reshape(-1, 3)
        P /= np.linalg.norm(P, axis=1)[:, None]
        rp = _back_front(P, S)
        C = np.vstack([best, P])
        rc = np.concatenate([rb, rp])
        keep = np.argsort(rc, kind="stable")[:4]
        moved = not np.array_equal(np.sort(keep), np.arange(4))
        best, rb = C[keep], rc[keep]
        U, W = plane_frame(best)
        if not moved:
            step *= 0.5
    return best[0]


def _sample_plan(F, fpiece, which, max_faces):
    """Which faces :func:`_sampled_normals` reads, as a rule per face: face
    ``f`` is read when ``row[f] >= 0`` (its row in ``which``) and the hash of
    its index ``(f · 2654435761) mod 2³²`` is below ``thresh[row[f]]``."""
    k = which.size
    if k == 1 and which[0] == 0 and int(fpiece.max(initial=0)) == 0:
        row = np.zeros(len(F), np.int64)
        count = np.array([len(F)])
    else:
        rank = np.full(int(fpiece.max()) + 1 if fpiece.size else 1, -1, np.int64)
        rank[which] = np.arange(k)
        row = rank[fpiece]
        count = np.bincount(row[row >= 0], minlength=k)
    if count.max(initial=0) > max_faces:
        return row, np.minimum(1.0, max_faces / np.maximum(count, 1)) * 2.0 ** 32
    return row, np.full(k, np.inf)


def _sampled_normals(V, F, fpiece, which, max_faces):
    """The faces of the pieces ``which`` that are read to measure them.

    A piece of more than ``max_faces`` faces is read on a fixed
    pseudo-random subset of about ``max_faces`` of them (a hash of the face
    index, so the same faces every run); a one-piece scan skips the
    per-face piece lookups.

    Returns
    -------
    fr : (s,) int64
        Row in ``which`` of each face read.
    n : (s,3) float64
        Its normal, of length twice its area.
    ln : (s,) float64
        That length.
    """
    k = which.size
    whole = k == 1 and which[0] == 0 and int(fpiece.max(initial=0)) == 0
    if whole:  # the usual scan: one piece, every face in it (no per-face lookups)
        count = np.array([len(F)])
        sel = None
    else:
        rank = np.full(int(fpiece.max()) + 1 if fpiece.size else 1, -1, np.int64)
        rank[which] = np.arange(k)
        fr = rank[fpiece]
        sel = fr >= 0
        count = np.bincount(fr[sel], minlength=k)
    if count.max(initial=0) > max_faces:  # large pieces: a fixed hashed subset of their faces
        keep = np.minimum(1.0, max_faces / np.maximum(count, 1))
        h = np.arange(len(F), dtype=np.uint64)   # the hash of each face's index, in place
        h *= np.uint64(2654435761)
        h &= np.uint64(0xFFFFFFFF)
        if sel is None:
            sel = h < keep[0] * 2.0 ** 32
        else:
            sel &= h < (keep[np.maximum(fr, 0)] * 2.0 ** 32)
        del h
    F = np.asarray(F, np.int64)
    if sel is None:   # every face, in order: no copy of F
        fr, T = np.zeros(len(F), np.int64), np.asarray(V, np.float64)[F]
    else:
        sel = np.flatnonzero(sel)
        fr = np.zeros(sel.size, np.int64) if whole else rank[fpiece[sel]]
        T = np.asarray(V, np.float64)[F[sel]]
    n = cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    del T
    return fr, n, np.sqrt(np.einsum("ij,ij->i", n, n))


def piece_views(V, F, fpiece, which, *, max_faces=None):
    """Best single view of each piece and how much of it faces away from it.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    fpiece : (m,) int64
        Piece of every face.
    which : (k,) int64
        The pieces to measure.
    max_faces : int, optional
        Faces read per piece (default ``VIEW_SAMPLES``); a larger piece is
        measured on a fixed pseudo-random subset of its faces (a hash of
        the face index), an estimate whose error is far below the margins
        of ``WRAP_RATIO``.

    Returns
    -------
    view : (k,3) float64
        Unit direction towards the viewer from which the piece shows the
        least surface turned away, relative to the surface turned towards it.
    back_ratio : (k,) float64
        ``P−/P+`` along ``view``: the projected area of the faces turned away
        over that of the faces turned towards it; 0 for a height field seen
        from ``view``, 1 for a closed surface (from any direction).

    Notes
    -----
    The search runs on the normals binned into ``NORMAL_BINS``³ cells of
    normal space (summed per cell and piece, one sort for all pieces); the
    ratio along the direction found is then measured on the faces. A piece
    whose normals all face its mean normal has ratio 0 from it and needs no
    search.
    """
    view, ratio, _ = _piece_views(V, F, fpiece, which, max_faces=max_faces)
    return view, ratio


def _piece_views(V, F, fpiece, which, *, max_faces=None, certify=False):
    """:func:`piece_views`, and with ``certify`` no search for the pieces
    whose normals alone prove that they wrap around (:func:`_wraps`): their
    view and ratio are NaN. Returns ``view, ratio, certified``."""
    which = np.asarray(which, np.int64)
    k = which.size
    view = np.zeros((k, 3))
    if k == 0:
        return view, np.zeros(0), np.zeros(0, bool)
    max_faces = VIEW_SAMPLES if max_faces is None else int(max_faces)
    certified = None
    if certify and fastmesh.enabled(len(F)):   # the certificate in one compiled pass, no per-face arrays
        certified = _wrap_bound(*fastmesh.normal_moments(V, F, *_sample_plan(F, fpiece, which, max_faces), k))
        if certified.all():
            return np.full((k, 3), np.nan), np.full(k, np.nan), certified
    fr, n, ln = _sampled_normals(V, F, fpiece, which, max_faces)
    ok = ln > 0
    if certified is None:
        certified = _wraps(fr, n, ln, k) if certify else np.zeros(k, bool)
    if certified.all():
        return np.full((k, 3), np.nan), np.full(k, np.nan), certified
    G = NORMAL_BINS
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(ok[:, None], n / np.where(ok, ln, 1.0)[:, None], 0.0)
    cell = np.clip(np.floor((u + 1.0) * (0.5 * G)).astype(np.int64), 0, G - 1)
    key = fr * G ** 3 + (cell[:, 0] * G + cell[:, 1]) * G + cell[:, 2]
    key[~ok] = -1
    uk, inv = np.unique(key, return_inverse=True)
    inv = inv.ravel()
    S = np.column_stack([np.bincount(inv, weights=n[:, j], minlength=uk.size) for j in range(3)])
    valid = uk >= 0
    S, cpiece = S[valid], uk[valid] // G ** 3
    bounds = np.searchsorted(cpiece, np.arange(k + 1))
    mean = np.column_stack([np.bincount(cpiece, weights=S[:, j], minlength=k) for j in range(3)])
    nm = np.linalg.norm(mean, axis=1)
    unit = np.divide(mean, nm[:, None], out=np.zeros_like(mean), where=nm[:, None] > 0)
    # faces (not cells) on the far side of the mean normal: only those pieces need a search
    s_face = np.einsum("ij,ij->i", n, unit[fr])
    far = np.bincount(fr, weights=(s_face < 0) & ok, minlength=k) > 0
    view[:] = unit
    for j in np.flatnonzero((far | (nm <= 0)) & ~certified):
        view[j] = _best_view(S[bounds[j]:bounds[j + 1]])
    s = np.einsum("ij,ij->i", n, view[fr])
    front = np.bincount(fr, weights=np.maximum(s, 0.0), minlength=k)
    back = np.bincount(fr, weights=np.maximum(-s, 0.0), minlength=k)
    ratio = np.divide(back, front, out=np.where(back > 0, np.inf, 0.0), where=front > 0)
    view[certified] = np.nan
    ratio[certified] = np.nan
    return view, ratio, certified


def _wraps(fr, n, ln, k):
    """Pieces whose face normals prove ``P−/P+ ≥ WRAP_RATIO`` from every
    direction, without a search.

    Along a unit ``d``, with ``a = Σ n_f`` the piece's total vector area
    (doubled, as ``n``), ``P+ − P− = a·d ≤ |a|`` and
    ``P+ + P− = Σ |n_f·d| ≥ Σ (n_f·d)² / |n_f| = dᵀMd ≥ λ_min(M)``
    (``|x| ≥ x²`` for ``|x| ≤ 1``), ``M = Σ n_f n_fᵀ / |n_f|``. As
    ``(T − x)/(T + x)`` falls with ``x`` and rises with ``T``,
    ``λ_min(M) ≥ |a| (1 + w)/(1 − w)`` gives ``P−/P+ ≥ w`` along every
    ``d``, so along the view :func:`piece_views` would find too: the piece
    is read as closed either way. A closed surface has ``a = 0``; a few
    small holes leave ``|a|`` small, while ``λ_min`` is a third of the
    (doubled) area on a sphere. The bound is asked with a margin of 10⁻⁶
    (and 10⁻⁹ of ``trace M``) over the rounding of the sums.

    Parameters
    ----------
    fr, n, ln : as :func:`_sampled_normals` returns them
    k : int
        Number of pieces.

    Returns
    -------
    certified : (k,) bool
    """
    ok = ln > 0
    w = np.where(ok, 1.0 / np.where(ok, ln, 1.0), 0.0)
    if k == 1:   # one piece (the usual scan): plain sums
        a = n.sum(axis=0)[None]
        M = ((n * w[:, None]).T @ n)[None]
    else:
        a = np.column_stack([np.bincount(fr, weights=n[:, j], minlength=k) for j in range(3)])
        M = np.empty((k, 3, 3))
        for i in range(3):
            wi = n[:, i] * w
            for j in range(i, 3):
                M[:, i, j] = M[:, j, i] = np.bincount(fr, weights=wi * n[:, j], minlength=k)
    return _wrap_bound(a, M)


def _wrap_bound(a, M):
    """:func:`_wraps` from the sums ``a`` (k,3) and ``M`` (k,3,3)."""
    lam = np.linalg.eigvalsh(M)[:, 0]
    need = np.linalg.norm(a, axis=1) * (1.0 + WRAP_RATIO) / (1.0 - WRAP_RATIO)
    slack = 1e-9 * np.trace(M, axis1=1, axis2=2)   # the eigenvalue's and the sums' rounding, with room
    return (lam > 0) & (lam >= need * (1.0 + 1e-6) + slack)


def edge_on_share(V, F, fpiece, which, views, *, max_faces=EDGE_ON_SAMPLES):
    """Least share of each piece's area turned within ``EDGE_ON_DEGREES`` of
    edge-on, over the directions from which the piece looks like one view.

    A piece without back-facing surface has a whole cone of best views (a
    range scan: every direction near the camera's); from an arbitrary one of
    them a narrow strip seen at a slant would look edge-on. So the share is
    taken from every direction that reads the piece as a single view (back
    ratio ``P−/P+`` below ``WRAP_RATIO``: the ~10° spread of
    ``VIEW_CANDIDATES`` directions, and ``views``), and the least is kept: a
    capped tube is edge-on from all of them (tilting the view off its axis
    turns its walls away at once), a strip is not.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    fpiece : (m,) int64
        Piece of every face.
    which : (k,) int64
        The pieces to measure.
    views : (k,3) float64
        Unit best view of each (:func:`piece_views`); always counted.
    max_faces : int
        Faces read per piece (a larger piece: a fixed hashed subset, as in
        :func:`piece_views`).

    Returns
    -------
    share : (k,) float64
        Area of the faces whose normal ``n`` has ``|n·d| < sin(EDGE_ON_DEGREES) |n|``
        over the piece's area, the least over those directions ``d`` (0 for
        a piece without area). A piece below ``EDGE_ON_SHARE`` from its best
        view is not searched further: its share from there is given.
    """
    import scipy.sparse as sp

    which = np.asarray(which, np.int64)
    k = which.size
    if k == 0:
        return np.zeros(0)
    fr, n, ln = _sampled_normals(V, F, fpiece, which, int(max_faces))   # ln: twice the area
    sin_e = np.sin(np.radians(EDGE_ON_DEGREES))
    tot = np.bincount(fr, weights=ln, minlength=k)
    s_view = np.abs(np.einsum("ij,ij->i", n, np.asarray(views, np.float64)[fr]))
    share = np.bincount(fr, weights=np.where(s_view < sin_e * ln, ln, 0.0), minlength=k)
    # only pieces edge-on enough from their best view can be so from every view
    look = share >= EDGE_ON_SHARE * tot
    rows = np.flatnonzero(look[fr])
    if rows.size:
        sub = np.cumsum(look) - 1                      # piece -> row among those looked at
        fl, nl, ll = sub[fr[rows]], n[rows], ln[rows]
        kl = int(look.sum())
        M = sp.csr_matrix((np.ones(len(fl)), (fl, np.arange(len(fl)))), shape=(kl, len(fl)))
        D = _CANDIDATES
        front, back, edge = (np.zeros((kl, len(D))) for _ in range(3))
        for s0 in range(0, len(fl), 8192):             # faces in chunks: (chunk, directions) at a time
            sl = slice(s0, s0 + 8192)
            S = nl[sl] @ D.T
            Ms = M[:, sl]
            front += Ms @ np.maximum(S, 0.0)
            back += Ms @ np.maximum(-S, 0.0)
            edge += Ms @ np.where(np.abs(S) < sin_e * ll[sl, None], ll[sl, None], 0.0)
        single = back < WRAP_RATIO * front             # directions that read the piece as one view
        share[look] = np.minimum(share[look], np.where(single, edge, np.inf).min(axis=1))
    return np.divide(share, tot, out=np.zeros(k), where=tot > 0)


def detect_holes(V: np.ndarray, F: np.ndarray, *, max_hole: int | None = None, fill_borders: bool = False,
                 closed: bool | None = None, topo=None, pieces=None, areas=None, measure: bool = True,
                 max_size: float | None = None, size_label: str = "") -> HoleScan:
    """Find every boundary loop, measure it and class it hole or border.

    Parameters
    ----------
    V : (n,3) float64 array
    F : (m,3) int64 array
    max_hole : int, optional
        Loops with more edges than this are borders.
    max_size : float, optional
        Loops wider than this (rim diameter, in the scan's units) are
        borders; ``size_label`` says it in the reason (``"20 mm"``).
    fill_borders : bool
        Class every loop (within ``max_hole``) as a hole.
    closed : bool, optional
        How to read each piece (see the module docstring): ``None`` infers
        it from the piece's normals; ``True`` reads every piece as part of
        a closed object (every loop a hole); ``False`` reads every piece as
        a single view (its outer rim a border, its other loops holes).
    topo : EdgeTopology, optional
    pieces : (int, (m,) int64), optional
        :func:`shellrepair.topology.face_pieces` of ``topo``.
    areas : (m,) float64, optional
        :func:`shellrepair.topology.face_areas` of ``V, F``.
        (These three are built here when not given; :func:`read_mesh`
        keeps them on the mesh, see :meth:`Mesh.cached`.)
    measure : bool
        True (default): every piece's best view and back ratio are measured
        and reported. False (what a repair needs, the kinds only; the
        loops' ``piece_area`` is then None): a piece
        whose normals alone prove that it wraps around (rule 2 from every
        direction, :func:`_wraps`) is read closed without the search of its
        best view; its loops get ``back_ratio`` None and a reason that says
        so. The kinds are the same either way.

    Returns
    -------
    scan : HoleScan
    """
    if closed not in (None, True, False):
        raise ValueError(f"closed must be None, True or False, got {closed!r}")
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    n = V.shape[0]
    if topo is None:
        topo = edge_topology(F, n)
    loops, chains = boundary_loops(F, n, topo)
    n_piece, fpiece = face_pieces(topo, len(F)) if pieces is None else pieces
    n_comp, vcomp, fcomp = components_of_pieces(F, n, fpiece, n_piece)
    # face areas: for the pieces' areas (reported when measuring) and the
    # outer rim of a single-view piece; a repair of a closed scan needs neither
    A = areas if areas is not None else face_areas(V, F) if measure else None
    piece_area = np.bincount(fpiece, weights=A, minlength=n_piece) if measure else None
    bhe = topo.boundary_he
    he_face = dict(zip(map(tuple, topo.ends(bhe).tolist()), (bhe // 3).tolist()))
    nv_used = int(np.count_nonzero(vcomp >= 0))
    scan = HoleScan(loops=[], open_chains=chains, n_components=n_comp,
                    n_boundary_edges=topo.n_boundary_edges,
                    n_nonmanifold_edges=int(topo.nonmanifold_edges.shape[0]),
                    euler=int(nv_used - topo.edges.shape[0] + F.shape[0]))
    stats, pieces = [], []
    for i, lp in enumerate(loops):
        st = loop_stats(V, lp)
        comp = int(vcomp[lp[0]])
        piece = int(fpiece[he_face[(int(lp[0]), int(lp[1]))]])
        stats.append(st)
        pieces.append(piece)
        scan.loops.append(Loop(id=i, vertices=lp, edges=int(lp.size), perimeter=st["perimeter"],
                               mean_edge=st["mean_edge"], area=st["area"], diameter=st["diameter"],
                               planarity=st["planarity"], component=comp,
                               piece_area=None if piece_area is None else float(piece_area[piece]),
                               center=tuple(float(x) for x in st["center"])))
        scan.loops[-1]._axis = st["axis"]   # (not a field: kept for the fill, see Loop.axis)
    if not scan.loops:
        return scan
    loops_of = {}
    for i, p in enumerate(pieces):
        loops_of.setdefault(p, []).append(i)
    which = np.array(sorted(loops_of), np.int64)
    # the reading of each piece: wraps around (closed) or a single view
    # (not needed when every loop is a hole anyway)
    if closed is True or fill_borders:
        views, ratio = np.zeros((which.size, 3)), np.full(which.size, np.nan)
        is_closed = np.ones(which.size, bool)
    else:
        views, ratio, certified = _piece_views(V, F, fpiece, which, certify=not measure and closed is None)
        edge_on = np.zeros(which.size)
        if closed is not False:
            low = np.flatnonzero(ratio < WRAP_RATIO)   # rule 3 for the pieces rule 2 leaves
            edge_on[low] = edge_on_share(V, F, fpiece, which[low], views[low])
        is_closed = np.zeros(which.size, bool) if closed is False else \
            (ratio >= WRAP_RATIO) | (edge_on >= EDGE_ON_SHARE) | certified
    # a single view's outer rim: the loop whose outline, seen along the
    # view, holds most of the piece (the piece is sampled once)
    by_piece = None
    if np.count_nonzero(~is_closed) > 4:  # many pieces (debris): group the faces by piece once
        by_piece = np.argsort(fpiece, kind="stable")
        bounds = np.searchsorted(fpiece[by_piece], np.arange(n_piece + 1))
    rim = {}
    for j, piece in enumerate(which.tolist()):
        idx = loops_of[piece]
        for i in idx:
            scan.loops[i].back_ratio = None if np.isnan(ratio[j]) else round(float(ratio[j]), 6)
            scan.loops[i].edge_on = round(float(edge_on[j]), 4) if closed is not True and not fill_borders else None
            scan.loops[i].reading = "" if fill_borders else "closed" if is_closed[j] else "single view"
        if is_closed[j]:
            continue
        if A is None:
            A = face_areas(V, F)
        fidx = np.flatnonzero(fpiece == piece) if by_piece is None else by_piece[bounds[piece]:bounds[piece + 1]]
        if fidx.size > OUTER_SAMPLES:
            rng = np.random.default_rng(piece)
            fidx = np.sort(rng.choice(fidx, OUTER_SAMPLES, replace=False))
        frac = _inside_fractions(V, [loops[i] for i in idx], [views[j]] * len(idx),
                                 [stats[i]["center"] for i in idx], V[F[fidx]].mean(axis=1), A[fidx])
        for i, f in zip(idx, frac):
            scan.loops[i].inside_fraction = float(f)
        rim[piece] = idx[int(np.argmax(frac))]  # first of equals: the lowest id
    for L, p in zip(scan.loops, pieces):
        wraps = L.reading == "closed"
        how = "--closed yes" if closed is True else "" if L.back_ratio is None and not wraps else \
            (f"its normals show that from every direction at least {100 * WRAP_RATIO:g}% as much surface faces "
             f"away as towards it") if L.back_ratio is None else (
            f"from its best view {100 * L.back_ratio:.1f}% as much surface faces away as towards it"
            + ("; --closed no" if closed is False else ""))
        if max_hole is not None and L.edges > int(max_hole):
            L.kind, L.reason = "border", f"larger than max_hole ({int(max_hole)} edges)"
        elif max_size is not None and L.diameter > max_size:
            L.kind, L.reason = "border", (f"wider than max_hole ({L.diameter:.4g} across, over "
                                          f"{size_label or f'{max_size:.4g}'})")
        elif fill_borders:
            L.kind, L.reason = "hole", "--fill-borders"
        elif wraps:
            L.kind = "hole"
            L.reason = ("closed by the surrounding surface: --closed yes" if closed is True else
                        f"closed by the surrounding surface: its piece wraps around ({how})"
                        if L.back_ratio is None or L.back_ratio >= WRAP_RATIO else
                        f"closed by the surrounding surface: its piece was seen from several sides "
                        f"({how}, but {100 * L.edge_on:.0f}% of it is within {EDGE_ON_DEGREES:g}° of edge-on "
                        f"from there, which no single view records)")
        elif rim[p] == L.id:
            L.kind = "border"
            L.reason = (f"outer edge of a single-view piece ({how}): {100 * L.inside_fraction:.0f}% of the "
                        f"piece lies within it")
        else:
            L.kind = "hole"
            L.reason = (f"closed by the surrounding surface: inside the outer edge (loop {rim[p]}) "
                        f"of a single-view piece ({how})")
    if closed is None and not fill_borders and rim:
        _band_rims(V, F, scan, [scan.loops[i] for i in rim.values() if scan.loops[i].kind == "border"], pieces)
    return scan


def _band_rims(V, F, scan, rims, piece_of):
    """Rule 5 of the module docstring: the outer rim of a single-view piece
    that faces a hole of another piece across a missing band is a hole.
    Changes ``scan`` in place.

    ``rims``: the outer rims classed border by rule 4 (not by ``max_hole``);
    ``piece_of``: each loop's piece. A rim and a hole of another piece that
    each send a strict majority of their continuation arcs to the other
    (:func:`shellrepair.bridge.loop_sights`, the test by which a repair
    pairs two holes across a band) are the two sides of one missing band;
    loops that share a vertex are not paired. Each hole is the partner of
    one rim at most (the rim sending it the larger share of its arcs).
    """
    from .bridge import MAX_REACH, SELF_SKIP, loop_sights

    # loop_sights follows no loop shorter than this (a lone triangle's rim)
    rims = [R for R in rims if len(R.vertices) >= 2 * SELF_SKIP + 2]
    holes = [L for L in scan.loops if L.kind == "hole" and len(L.vertices) >= 2 * SELF_SKIP + 2]
    if not rims or not holes:
        return

    def centre(L):
        return V[L.vertices].mean(axis=0)

    # the pairs to test: a rim and a hole of another piece, sharing no vertex,
    # within reach of one another's arcs
    hc = np.array([centre(L) for L in holes])
    hr = np.array([0.5 * L.diameter for L in holes])
    pairs = []
    for R in rims:
        r = 0.5 * R.diameter
        d = np.linalg.norm(hc - centre(R), axis=1)
        for j in np.flatnonzero(d <= (r + 2 * MAX_REACH * r) + hr + (2 * MAX_REACH * hr)).tolist():
            if piece_of[holes[j].id] != piece_of[R.id] and np.intersect1d(R.vertices, holes[j].vertices).size == 0:
                pairs.append((R.id, holes[j].id))
    if not pairs:
        return
    from .io import Mesh
    from .context import ScanContext

    ctx = ScanContext(Mesh(V=np.asarray(V, np.float64), F=np.asarray(F, np.int64)))
    sights = loop_sights(ctx.V, scan.loops, lambda lp: ctx.F[ctx.ring_faces(lp, 3)],
                         candidates=sorted({x for p in pairs for x in p}))

    def share(a, b):
        counts, m = sights.get(a, (None, 0))
        return counts[b] / m if m and 2 * counts[b] > m else 0.0

    best = {}
    for r, h in pairs:        # rims in their order, each one's holes by id: the first of equal shares wins
        if share(r, h) and share(h, r) and share(r, h) > best.get(h, (0.0, None))[0]:
            best[h] = (share(r, h), r)
    for h, (f, r) in sorted(best.items()):
        R = scan.loops[r]
        R.kind = "hole"
        R.reason = (f"closed by the surrounding surface: it and hole {h} face each other across a missing band "
                    f"(each sends most of its continuation arcs to the other: {100 * f:.0f}% and "
                    f"{100 * share(h, r):.0f}%), though its piece reads as a single view")


def _pinched_parts(A, B):
    """The loops bounding the parts of one band pinched where loops ``A``
    and ``B`` (vertex arrays in boundary half-edge order) share vertices,
    or None when they do not share at least two in opposite cyclic orders.

    Between consecutive shared vertices ``p`` and ``q`` (in A's order) the
    missing region is bounded by A from ``p`` to ``q`` and by B from ``q``
    back to ``p``: both run with the scan on their left, so the part lies
    on their right like a hole's.
    """
    A, B = np.asarray(A, np.int64), np.asarray(B, np.int64)
    shared = np.intersect1d(A, B)
    if shared.size < 2:
        return None
    ia = np.sort(np.flatnonzero(np.isin(A, shared)))
    pa = A[ia]                                   # shared vertices in A's order
    posb = {int(v): i for i, v in enumerate(B.tolist())}
    jb = np.array([posb[int(v)] for v in pa])
    m = len(pa)
    # B must meet them in the reverse cyclic order
    steps = (jb - np.roll(jb, -1)) % len(B)
    if steps.sum() != len(B):
        return None
    parts = []
    for k in range(m):
        i0, i1 = ia[k], ia[(k + 1) % m]
        seg_a = A[np.arange(i0, i0 + ((i1 - i0) % len(A) or len(A))) % len(A)]       # p .. before q
        j1, j0 = jb[(k + 1) % m], jb[k]
        seg_b = B[np.arange(j1, j1 + ((j0 - j1) % len(B) or len(B))) % len(B)]       # q .. before p
        part = np.concatenate([seg_a, seg_b])
        if len(part) < 3 or np.unique(part).size != len(part):
            return None
        parts.append(part)
    if sum(len(p) for p in parts) != len(A) + len(B):
        return None
    return parts


def split_pinched(V, F, topo, scan, pieces=None):
    """Two ``hole`` loops that share vertices bound one band pinched there:
    the band is as many discs as the loops share vertices, each bounded by
    a stretch of each loop between two shared vertices. Those discs replace
    the two loops as holes (their ``kind`` becomes ``'split'``); they keep
    the loops' measurements of the piece and get ids after the scan's.

    Not when a part would bound scan all round: two holes that touch at
    two vertices with a lens of scan between them give a part that is the
    lens's whole boundary (filling it would close the lens into a bubble),
    so a part whose scan side (the pieces left of its edges) has no other
    boundary edge leaves the two loops as they are.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    topo : EdgeTopology
    scan : HoleScan
    pieces : (int, (m,) int64), optional
        :func:`shellrepair.topology.face_pieces` of ``topo``.

    Returns
    -------
    scan : HoleScan
        A new one when a pair was split, else ``scan`` itself.
    splits : list of (int, int, list of int)
        The two loop ids and the ids of the parts that replace them.
    """
    from dataclasses import replace

    holes = [L for L in scan.loops if L.kind == "hole"]
    owner = {}
    for L in holes:
        for v in L.vertices.tolist():
            owner.setdefault(v, []).append(L.id)
    touching = sorted({tuple(sorted(o)) for o in owner.values() if len(o) == 2})
    loops = list(scan.loops)
    used, splits = set(), []
    if not touching:
        return scan, []
    n_piece, fpiece = face_pieces(topo, len(F)) if pieces is None else pieces
    bhe = topo.boundary_he
    bface = bhe // 3
    bd_count = np.bincount(fpiece[bface], minlength=n_piece)     # boundary edges per piece
    he_face = dict(zip(map(tuple, topo.ends(bhe).tolist()), bface.tolist()))   # not the whole mesh's he

    def bounds_scan_all_round(part):
        ps = {int(fpiece[he_face[(int(u), int(v))]]) for u, v in zip(part.tolist(), np.roll(part, -1).tolist())}
        return int(bd_count[sorted(ps)].sum()) == len(part)

    for a, b in touching:
        if a in used or b in used:
            continue
        parts = _pinched_parts(loops[a].vertices, loops[b].vertices)
        if parts is None or any(bounds_scan_all_round(p) for p in parts):
            continue
        used.update((a, b))
        ids = []
        for part in parts:
            st = loop_stats(V, part)
            i = len(loops)
            loops.append(replace(loops[a], id=i, vertices=part, edges=int(len(part)), perimeter=st["perimeter"],
                                 mean_edge=st["mean_edge"], area=st["area"], diameter=st["diameter"],
                                 planarity=st["planarity"],
                                 reason=f"part of loops {a} and {b} between two of the {len(parts)} vertices "
                                        f"they share (a band pinched there)"))
            ids.append(i)
        for j in (a, b):
            loops[j] = replace(loops[j], kind="split", reason=f"split into loops {ids[0]}-{ids[-1]} "
                                                              f"at the vertices it shares with loop {a + b - j}")
        splits.append((a, b, ids))
    if not splits:
        return scan, []
    return replace(scan, loops=loops), splits
