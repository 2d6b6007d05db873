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
   ``WRAP_RATIO``; :func:`~shellrepair.holes.hole_or_border.edge_on_share`), no single view recorded it. Such
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
   (:func:`shellrepair.fill.bridge.loop_sights`): the rim and the hole each
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

from shellrepair import compiled
from shellrepair.holes.hole_or_border import (
    EDGE_ON_DEGREES,
    EDGE_ON_SHARE,
    OUTER_SAMPLES,
    WRAP_RATIO,
    _band_rims,
    _inside_fractions,
    _piece_views,
    edge_on_share,
)
from shellrepair.mesh.geometry import cross, uniq
from shellrepair.mesh import fastmesh
from shellrepair.mesh.topology import (boundary_half_edges, components_of_pieces, edge_topology, face_areas, face_pieces,
                                       half_edge_ends)
from shellrepair.reference import loop_diameter

__all__ = ["Loop", "HoleScan", "boundary_loops", "detect_holes", "loop_stats"]


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
    if topo is None and not fastmesh.enabled(len(F)):
        # the boundary half-edges alone (the same ones as the topology's)
        bhe = boundary_half_edges(F, n_vertices)
        if bhe.size == 0:
            return [], []
        ends = half_edge_ends(F, bhe)
    else:
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
        _resolve_pinches(F, bhe, src, dst, order, start, multi, nxt, dc)

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


def _resolve_pinches(F, bhe, src, dst, order, start, multi, nxt, dc):
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
    (:func:`shellrepair.mesh.common_kernels.max_sq_distance`, the same value bit for
    bit) when the kernels are loaded already (a repair loads them; hole
    detection alone does not), else in chunks of rows."""
    k = sys.modules.get("shellrepair.mesh.common_kernels")
    if k is not None and compiled.ENABLED and len(Q) > 1 and np.isfinite(Q).all():
        return float(np.sqrt(k.max_sq_distance(Q)))
    return loop_diameter(Q, chunk)


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
        :func:`shellrepair.mesh.topology.face_pieces` of ``topo``.
    areas : (m,) float64, optional
        :func:`shellrepair.mesh.topology.face_areas` of ``V, F``.
        (These three are built here when not given; :func:`read_mesh`
        keeps them on the mesh, see :meth:`Mesh.cached`.)
    measure : bool
        True (default): every piece's best view and back ratio are measured
        and reported. False (what a repair needs, the kinds only; the
        loops' ``piece_area`` is then None): a piece
        whose normals alone prove that it wraps around (rule 2 from every
        direction, :func:`~shellrepair.holes.hole_or_border.wrap_certificate`) is
        read closed without the search of its best view; its loops get ``back_ratio`` None and a reason that says
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
