"""Hole or border: what the normals of a scan's piece say about it.

The measures by which :func:`shellrepair.holes.loops.detect_holes` classes each
loop *hole* or *border* (its module docstring states the rules 1-5): the
best single view of a piece and its back ratio (rule 2: a piece that wraps
around), the share of it seen edge-on from there (rule 3), the area inside
each loop's outline (rule 4: a single view's outer rim), and rims that face
a hole across a missing band (rule 5).
"""

from __future__ import annotations

import numpy as np

from shellrepair.mesh import fastmesh
from shellrepair.mesh.geometry import cross, plane_frame, points_in_polygon

__all__ = ["piece_views", "edge_on_share", "sampled_normals", "sample_plan", "wrap_certificate",
           "wrap_certificate_of_sums", "VIEW_DIRECTIONS", "WRAP_RATIO", "EDGE_ON_SHARE"]

#: Least ratio of back-facing to front-facing projected area, from the best
#: single view, at which a piece wraps around (rule 2 of :mod:`shellrepair.holes.loops`' docstring).
WRAP_RATIO = 0.05
#: Rule 3 of :mod:`shellrepair.holes.loops`' docstring: a piece with at least this share of its
#: area within ``EDGE_ON_DEGREES`` of edge-on from its best view was seen
#: from several sides ("most of it": single views reach 0.35 without an
#: incidence limit, see :mod:`shellrepair.holes.loops`' docstring).
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


#: The ``VIEW_CANDIDATES`` unit directions (rows) the search of a best view
#: starts from.
VIEW_DIRECTIONS = _fibonacci_directions(VIEW_CANDIDATES)


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
    D = VIEW_DIRECTIONS
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


def sample_plan(F, fpiece, which, max_faces):
    """Which faces :func:`sampled_normals` reads, as a rule per face: face
    ``f`` is read when ``row[f] >= 0`` (its row in ``which``) and the hash of
    its index ``(f · 2654435761) mod 2³²`` is below ``thresh[row[f]]`` (the
    form the compiled :func:`shellrepair.mesh.fastmesh.normal_moments` reads).

    Parameters
    ----------
    F : (m,3) int64
    fpiece : (m,) int64
        Each face's piece.
    which : (k,) int64
        The pieces measured.
    max_faces : int
        Faces read per piece at most (about).

    Returns
    -------
    row : (m,) int64
        Each face's row in ``which``, -1 for a face of another piece.
    thresh : (k,) float64
        Per piece, the hash below which a face is read (inf: every face).
    """
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


def sampled_normals(V, F, fpiece, which, max_faces):
    """The faces of the pieces ``which`` that are read to measure them.

    A piece of more than ``max_faces`` faces is read on a fixed
    pseudo-random subset of about ``max_faces`` of them (a hash of the face
    index, so the same faces every run); a one-piece scan skips the
    per-face piece lookups.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    fpiece : (m,) int64
        Each face's piece.
    which : (k,) int64
        The pieces measured.
    max_faces : int

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
    whose normals alone prove that they wrap around (:func:`wrap_certificate`): their
    view and ratio are NaN. Returns ``view, ratio, certified``."""
    which = np.asarray(which, np.int64)
    k = which.size
    view = np.zeros((k, 3))
    if k == 0:
        return view, np.zeros(0), np.zeros(0, bool)
    max_faces = VIEW_SAMPLES if max_faces is None else int(max_faces)
    certified = None
    if certify and fastmesh.enabled(len(F)):   # the certificate in one compiled pass, no per-face arrays
        moments = fastmesh.normal_moments(V, F, *sample_plan(F, fpiece, which, max_faces), k)
        certified = wrap_certificate_of_sums(*moments)
        if certified.all():
            return np.full((k, 3), np.nan), np.full(k, np.nan), certified
    fr, n, ln = sampled_normals(V, F, fpiece, which, max_faces)
    ok = ln > 0
    if certified is None:
        certified = wrap_certificate(fr, n, ln, k) if certify else np.zeros(k, bool)
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


def wrap_certificate(fr, n, ln, k):
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
    fr, n, ln : as :func:`sampled_normals` returns them
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
    return wrap_certificate_of_sums(a, M)


def wrap_certificate_of_sums(a, M):
    """:func:`wrap_certificate` from the sums it reads.

    Parameters
    ----------
    a : (k,3) float64
        Per piece, the sum of its faces' (doubled) vector areas.
    M : (k,3,3) float64
        Per piece, ``Σ n_f n_fᵀ / |n_f|``.

    Returns
    -------
    certified : (k,) bool
    """
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
    fr, n, ln = sampled_normals(V, F, fpiece, which, int(max_faces))   # ln: twice the area
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
        D = VIEW_DIRECTIONS
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


def _band_rims(V, F, scan, rims, piece_of):
    """Rule 5 of :mod:`shellrepair.holes.loops`' docstring: the outer rim of a single-view piece
    that faces a hole of another piece across a missing band is a hole.
    Changes ``scan`` in place.

    ``rims``: the outer rims classed border by rule 4 (not by ``max_hole``);
    ``piece_of``: each loop's piece. A rim and a hole of another piece that
    each send a strict majority of their continuation arcs to the other
    (:func:`shellrepair.fill.bridge.loop_sights`, the test by which a repair
    pairs two holes across a band) are the two sides of one missing band;
    loops that share a vertex are not paired. Each hole is the partner of
    one rim at most (the rim sending it the larger share of its arcs).
    """
    from shellrepair.fill.bridge import MAX_REACH, SELF_SKIP, loop_sights

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
    from shellrepair.mesh.index import ScanContext
    from shellrepair.mesh.io import Mesh

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
        R.reclass("hole", f"closed by the surrounding surface: it and hole {h} face each other across a missing band "
                          f"(each sends most of its continuation arcs to the other: {100 * f:.0f}% and "
                          f"{100 * share(h, r):.0f}%), though its piece reads as a single view")
