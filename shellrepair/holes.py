"""Boundary loops of a scan, their measurements, and hole / border classing.

A *loop* is a closed chain of boundary half-edges (edges with one face),
listed in the direction of those half-edges, so the faces of the scan lie to
the left of the loop when walking along it (seen from outside a closed
surface). Two holes touching at one vertex are two loops: at such a pinch
vertex the loop continues along the fan of faces it came from. A loop that
still visits a vertex twice is split there into simple loops.

Hole or border
--------------
Not every opening is a hole. A single-view scan is an open sheet whose outer
edge is meant to stay open, and a floating island of scan data has only an
outer edge. The rule, in order:

1. ``max_hole``: a loop with more edges than this is a *border*
   ("larger than --max-hole").
2. *Outer edge*: look at the loop's piece (the faces connected to it
   across edges) along the loop's own axis (the normal of its best-fit
   plane). If at least ``OUTER_FRACTION`` (60 %) of the piece's area lies
   inside the loop's outline, the scan is a sheet seen through this opening
   and the loop is its rim: a *border*. A hole in a closed surface has only
   the far side behind it (for a hole of 30 % of a sphere about 43 %, for
   small holes almost nothing). A lone triangle hanging on by its corners
   is a piece of its own, and its outline a border.
3. *Too large*: if the loop's spanning area (the norm of its vector area)
   exceeds the area of its whole piece, filling it would invent most of
   the piece: a *border*.
4. Otherwise a *hole*.

``fill_borders=True`` turns every border into a hole (rule 1 still applies).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from .geometry import plane_frame
from .topology import components_of_pieces, edge_topology, face_areas, face_pieces

__all__ = ["Loop", "HoleScan", "boundary_loops", "detect_holes", "loop_stats", "OUTER_FRACTION"]

#: Fraction of a component's area inside an opening's outline above which the
#: opening is that component's outer edge (rule 2 of the module docstring).
OUTER_FRACTION = 0.6
#: Faces sampled per component for the outer-edge test.
OUTER_SAMPLES = 20000


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
    piece_area : float
        Area of the loop's piece (faces joined across edges), which the
        classification rules use.
    inside_fraction : float
        Fraction of the piece's area inside the loop's outline seen along
        its axis (rule 2).
    kind : str
        ``'hole'`` or ``'border'``.
    reason : str
        Why it was classed so.
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
    piece_area: float
    inside_fraction: float = 0.0
    kind: str = "hole"
    reason: str = ""

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
    src = topo.he[bhe, 0]
    dst = topo.he[bhe, 1]
    n = int(n_vertices)
    out_count = np.bincount(src, minlength=n)
    order = np.argsort(src, kind="stable")
    start = np.searchsorted(src[order], np.arange(n + 1))

    nxt = np.full(bhe.size, -1, dtype=np.int64)
    single = out_count[dst] == 1
    nxt[single] = order[start[dst[single]]]
    multi = np.flatnonzero(out_count[dst] > 1)
    if multi.size:
        _resolve_pinches(F, topo, bhe, src, dst, order, start, multi, nxt)

    loops, chains = [], []
    visited = np.zeros(bhe.size, bool)
    # has_prev: chains must start at a half-edge nobody points to
    has_prev = np.zeros(bhe.size, bool)
    has_prev[nxt[nxt >= 0]] = True
    for begin in list(np.flatnonzero(~has_prev)) + list(range(bhe.size)):
        if visited[begin]:
            continue
        seq = []
        cur = begin
        closed = False
        while cur >= 0 and not visited[cur]:
            visited[cur] = True
            seq.append(cur)
            cur = nxt[cur]
            if cur == begin:
                closed = True
                break
        verts = src[np.array(seq, dtype=np.int64)]
        if closed:
            loops.extend(_split_simple(verts))
        else:
            chains.append(np.append(verts, dst[seq[-1]]).astype(np.int64))
    return loops, chains


def _resolve_pinches(F, topo, bhe, src, dst, order, start, multi, nxt):
    """At vertices with several outgoing boundary half-edges, continue along
    the fan of faces the incoming half-edge belongs to."""
    pinch = np.unique(dst[multi])
    near = np.flatnonzero(np.isin(F, pinch).any(axis=1))
    he_face = {}
    for f in near:
        a, b, c = F[f]
        he_face[(a, b)] = f
        he_face[(b, c)] = f
        he_face[(c, a)] = f
    bset = {(int(s), int(d)): i for i, (s, d) in enumerate(zip(src, dst)) if int(s) in set(pinch.tolist())}
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
        v = int(dst[i])
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
    c = P.mean(axis=0)
    Q = P - c
    E = np.roll(Q, -1, axis=0) - Q
    lengths = np.linalg.norm(E, axis=1)
    perimeter = float(lengths.sum())
    vec_area = 0.5 * np.cross(Q, np.roll(Q, -1, axis=0)).sum(axis=0)
    area = float(np.linalg.norm(vec_area))
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
    best = 0.0
    for i in range(0, len(Q), chunk):
        d = ((Q[i:i + chunk, None, :] - Q[None, :, :]) ** 2).sum(axis=2)
        best = max(best, float(d.max()))
    return float(np.sqrt(best))


def _inside_fractions(V, loops, axes, centers, cent, w, chunk=64):
    """Area fraction of sample points (face centroids ``cent`` with areas
    ``w``) inside each loop's outline seen along its axis; the projections
    of the samples are made for ``chunk`` loops at a time, by one product."""
    from skimage.measure import points_in_poly

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
                inside = points_in_poly(np.column_stack([PU[j, box], PW[j, box]]), poly)
                out[i] = float(w[box[inside]].sum() / tot)
    return out


def detect_holes(V, F, *, max_hole=None, fill_borders=False, outer_fraction=OUTER_FRACTION, topo=None,
                 pieces=None, areas=None):
    """Find every boundary loop, measure it and class it hole or border.

    Parameters
    ----------
    V : (n,3) float64 array
    F : (m,3) int64 array
    max_hole : int, optional
        Loops with more edges than this are borders.
    fill_borders : bool
        Class every loop (within ``max_hole``) as a hole.
    outer_fraction : float
        Threshold of rule 2 (see module docstring).
    topo : EdgeTopology, optional
    pieces : (int, (m,) int64), optional
        :func:`shellrepair.topology.face_pieces` of ``topo``.
    areas : (m,) float64, optional
        :func:`shellrepair.topology.face_areas` of ``V, F``.
        (These three are built here when not given; :func:`read_mesh`
        keeps them on the mesh, see :meth:`Mesh.cached`.)

    Returns
    -------
    scan : HoleScan
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    n = V.shape[0]
    if topo is None:
        topo = edge_topology(F, n)
    loops, chains = boundary_loops(F, n, topo)
    n_piece, fpiece = face_pieces(topo, len(F)) if pieces is None else pieces
    n_comp, vcomp, fcomp = components_of_pieces(F, n, fpiece, n_piece)
    A = face_areas(V, F) if areas is None else areas
    piece_area = np.bincount(fpiece, weights=A, minlength=n_piece)
    bhe = topo.boundary_he
    he_face = dict(zip(map(tuple, topo.he[bhe].tolist()), (bhe // 3).tolist()))
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
                               planarity=st["planarity"], component=comp, piece_area=float(piece_area[piece])))
    # rule 2 needs each loop's piece seen along its axis: sample the piece once
    loops_of = {}
    for i, p in enumerate(pieces):
        loops_of.setdefault(p, []).append(i)
    by_piece = None
    if len(loops_of) > 4:  # many pieces (debris): group the faces by piece once
        by_piece = np.argsort(fpiece, kind="stable")
        bounds = np.searchsorted(fpiece[by_piece], np.arange(n_piece + 1))
    for piece in sorted(loops_of):
        idx = loops_of[piece]
        fidx = np.flatnonzero(fpiece == piece) if by_piece is None else by_piece[bounds[piece]:bounds[piece + 1]]
        if fidx.size > OUTER_SAMPLES:
            rng = np.random.default_rng(piece)
            fidx = np.sort(rng.choice(fidx, OUTER_SAMPLES, replace=False))
        frac = _inside_fractions(V, [loops[i] for i in idx], [stats[i]["axis"] for i in idx],
                                 [stats[i]["center"] for i in idx], V[F[fidx]].mean(axis=1), A[fidx])
        for i, f in zip(idx, frac):
            scan.loops[i].inside_fraction = float(f)
    for L in scan.loops:
        if max_hole is not None and L.edges > int(max_hole):
            L.kind, L.reason = "border", f"larger than --max-hole {int(max_hole)} edges"
        elif fill_borders:
            L.kind, L.reason = "hole", "--fill-borders"
        elif L.inside_fraction >= outer_fraction:
            L.kind = "border"
            L.reason = (f"outer edge of its piece: {100 * L.inside_fraction:.0f}% of the piece "
                        f"lies within the opening")
        elif L.area > L.piece_area:
            L.kind = "border"
            L.reason = "filling would invent more surface than its piece has"
        else:
            L.kind, L.reason = "hole", "closed by the surrounding surface"
    return scan
