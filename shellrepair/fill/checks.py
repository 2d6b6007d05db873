"""Whether a patch may be kept, and how much work one hole may take.

Every patch the fill builds (a cap, a tube, a pants, a mended patch) passes
:func:`check_patch` before it is kept: it must not cross the scan
(exact predicates, :mod:`~shellrepair.mesh.intersect`), fold onto itself or the
scan (:data:`FOLD_DEGREES`), or cross itself; a patch joining loops must
also not repeat an edge the scan has (:func:`check_joining`). A planar
opening that scan crosses inside its outline is told apart at once
(:func:`blocked_in_plane`): no flat triangulation avoids it.

:class:`WorkBudget` bounds one hole's attempts in counted units (new patch
vertices), never in seconds, so that the same scan gives the same bytes on
any machine. :func:`mend_last` is the last layer: the failed attempts with
the fewest faults, mended where they fail (:mod:`~shellrepair.fill.mend`).

This module imports no fill stage above it: :mod:`~shellrepair.fill.hole` and
:mod:`~shellrepair.fill.pants` read it (tests/test_layout.py).
"""

from __future__ import annotations

import contextlib
from typing import NamedTuple

import numpy as np

from shellrepair import compiled
from shellrepair.fill import checks_kernels
from shellrepair.fill.merge import edges_of
from shellrepair.fill.merge import scan_edges as patch_scan_edges
from shellrepair.fill.patch import corners as corners_of
from shellrepair.mesh.intersect import crossing_pairs, embeds_by_projection, patch_vs_index, patch_vs_index_many


#: Why a hole stays open, as data (a failed row's ``failure`` in the
#: report; ``reason`` says it in words): no patch built for it passed the
#: checks (it crosses the scan or itself, or folds), the last layer
#: included; the last layer stopped at the hole's work budget before one
#: passed; its rim has no extent (fewer than three vertices, or all on one
#: point); its patch crosses a patch accepted before it (``crosses_hole``
#: names that hole) or needs an edge one of them made, also when filled
#: again around them; the check of the merged output found its patch
#: crossing.
NO_PATCH_PASSES = "no patch passes"
WORK_BUDGET = "work budget"
DEGENERATE_RIM = "degenerate rim"
CLASHES = "clashes with a patch"
MERGED_CHECK = "merged check"
FAILURES = (NO_PATCH_PASSES, WORK_BUDGET, DEGENERATE_RIM, CLASHES, MERGED_CHECK)


class Outcome(NamedTuple):
    """What filling one loop gave."""
    patch: object          # the accepted-so-far Patch, or None when the loop stays open
    reason: str            # why it stays open ("" when filled, or what a band's partner did)
    seconds: float
    reasons: list          # the reasons of the attempts that failed on the way
    failure: str = ""      # one of FAILURES where the loop stays open and its fill said why ("" otherwise)


#: Two triangles on one edge whose far corners, seen along the edge, are
#: less than this apart (degrees) are folded onto each other, one sheet
#: doubled: the exact crossing tests count a fold only when the two are
#: exactly coplanar, and a float32 flat part is not (its round-off tilts
#: faces by ~1e-4°). The stress suite's measure counts the same folds.
#: Real scans do have creases sharper than a few degrees (5° failed 11
#: holes of a Nefertiti case whose scan faces fold that sharply).
FOLD_DEGREES = 0.1


def _folds(ctx, patch, C, ids):
    """Patch triangles folded onto a neighbour across an edge (``FOLD_DEGREES``):
    another patch triangle, or the scan face across a rim edge (sorted)."""
    Fr = ctx.F[ctx.faces_of(patch.loop)]
    if compiled.ENABLED:
        return checks_kernels.folds(C, ids, ctx.V[Fr], Fr, np.cos(np.radians(FOLD_DEGREES)))
    return folds_reference(C, ids, ctx.V[Fr], Fr)


def folds_reference(C, ids, Cs, Fr):
    """The patch triangles folded onto a neighbour (``FOLD_DEGREES``), in
    NumPy: the fallback when kernels are off, and the oracle of
    :func:`shellrepair.fill.checks_kernels.folds`.

    Parameters
    ----------
    C : (t,3,3) float64
        The patch's triangle corners.
    ids : (t,3) int64
        Their ids (:func:`shellrepair.fill.patch.corners`).
    Cs : (r,3,3) float64
        The corners of the scan faces at the patch's rim.
    Fr : (r,3) int64
        Those faces.

    Returns
    -------
    (f,) int64
        The folded patch triangles, sorted.
    """
    T = np.concatenate([C, Cs])                          # patch triangles, then scan faces at the rim
    I = np.concatenate([ids, Fr])
    tri = np.concatenate([np.arange(len(C)), -1 - np.arange(len(Fr))])
    j = np.arange(3)
    a, b = I[:, j].ravel(), I[:, (j + 1) % 3].ravel()
    t = np.repeat(tri, 3)
    P, Q, R = T[:, j].reshape(-1, 3), T[:, (j + 1) % 3].reshape(-1, 3), T[:, (j + 2) % 3].reshape(-1, 3)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    order = np.lexsort((hi, lo))
    lo, hi = lo[order], hi[order]
    same = (lo[1:] == lo[:-1]) & (hi[1:] == hi[:-1])
    x, y = order[:-1][same], order[1:][same]             # the two half-edges of one edge
    keep = (t[x] >= 0) | (t[y] >= 0)                     # not two scan faces
    x, y = x[keep], y[keep]
    if x.size == 0:
        return np.zeros(0, np.int64)
    e = Q[x] - P[x]
    e /= np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-300)
    u, w = R[x] - P[x], R[y] - P[x]
    u -= np.sum(u * e, axis=1)[:, None] * e
    w -= np.sum(w * e, axis=1)[:, None] * e
    den = np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1)
    fold = np.sum(u * w, axis=1) > np.cos(np.radians(FOLD_DEGREES)) * den
    fold &= den > 0
    hit = np.concatenate([t[x][fold], t[y][fold]])
    return np.unique(hit[hit >= 0])


def check_patch(ctx, patch):
    """Why the patch cannot be used (or None), and the patch triangles at fault."""
    C, ids = corners_of(ctx, patch)
    if not np.isfinite(C).all():
        return "non-finite patch positions", np.zeros(0, np.int64)
    return _check_rest(ctx, patch, C, ids, patch_vs_index(C, ids, ctx.index, return_faces=True))


def check_patches(ctx, patches):
    """:func:`check_patch` of each patch, their crossing queries against
    the scan in one batch (:func:`~shellrepair.mesh.intersect.patch_vs_index_many`);
    the same answers."""
    corners = [corners_of(ctx, p) for p in patches]
    finite = [bool(np.isfinite(C).all()) for C, _ in corners]
    bads = iter(patch_vs_index_many([c for c, ok in zip(corners, finite) if ok], ctx.index))
    return [_check_rest(ctx, p, C, ids, next(bads)) if ok else ("non-finite patch positions", np.zeros(0, np.int64))
            for p, (C, ids), ok in zip(patches, corners, finite)]


def _check_rest(ctx, patch, C, ids, bad):
    """:func:`check_patch` from the patch triangles that cross the scan."""
    if bad.size:
        return f"patch would cross the scan ({bad.size} triangles)", bad
    bad = _folds(ctx, patch, C, ids)
    if bad.size:
        return f"patch would fold onto itself or the scan ({bad.size} triangles)", bad
    # the patch against itself: a disc that projects one-to-one cannot
    # cross itself; otherwise test its triangles pair by pair
    if len(C) > 1 and not (patch.disc and embeds_by_projection(
            np.vstack([ctx.V[patch.loop], patch.P]), patch.T, len(patch.loop))):
        pairs = crossing_pairs(C - ctx.index.origin, ids)
        if len(pairs):
            return f"patch would cross itself ({len(pairs)} triangle pairs)", np.unique(pairs.ravel())
    return None, np.zeros(0, np.int64)


#: A loop at most this planar (RMS distance to its plane over its diameter;
#: float32 round-off of a flat CAD face is ~1e-7) whose flat triangulation
#: covers its outline one-to-one is a plane region: every flat
#: triangulation covers the same region, so scan faces crossing it away
#: from the loop cross them all, and re-routing chords is futile.
BLOCKED_PLANARITY = 1e-6


def blocked_in_plane(ctx, hole_id, flat, bad):
    """How many scan faces cross a planar opening's region away from its
    loop (so that every flat triangulation crosses them), or 0 when that
    cannot be shown (the loop is not planar, its outline not simple, or
    every crossing face touches the loop, where another chord may help)."""
    from shellrepair.holes.loops import loop_stats

    loop = flat.loop
    if not flat.disc or len(flat.P) or bad.size == 0:
        return 0
    planarity = ctx.planarity.get(hole_id)
    if planarity is None:
        planarity = loop_stats(ctx.V, loop)["planarity"]
    if planarity > BLOCKED_PLANARITY or not embeds_by_projection(ctx.V[loop], flat.T, len(loop)):
        return 0
    C, ids = corners_of(ctx, flat)
    pairs = patch_vs_index(C[bad], ids[bad], ctx.index, return_pairs=True)
    faces = np.unique(pairs[:, 1])
    touching = np.isin(ctx.F[faces], loop).any(axis=1)
    return int(faces.size) if faces.size and not touching.any() else 0


#: Work budget of one hole (or one band, both loops' edges counted), in new
#: patch vertices built and checked over all attempts:
#: ``HOLE_VERTICES + HOLE_VERTICES_PER_EDGE * edges``. A hole's first
#: attempt and its last option (the harmonic patch or tube, tried at most
#: once) are always built; a later one (a retry, a tube, a rival tube)
#: starts only if a patch of its expected size still fits, and refinement
#: stops it (``build_patch(max_vertices=...)``) if it grows past what is
#: left, before fairing. One new vertex costs ~0.1 ms to refine, fair and
#: check (2 cores, order 2), so the budget is ~2.5 s + 3 ms per edge of
#: work. The rounds themselves are counted too (:data:`~shellrepair.fill.hole.FLAT_RETRIES`,
#: :data:`~shellrepair.fill.hole.FAIRED_RETRIES`, :data:`~shellrepair.fill.hole.PIN_ROUNDS`), and the last layer has
#: bounds of its own (:mod:`~shellrepair.fill.mend`). Nothing here reads a
#: clock: the same scan and options give the same attempts, so the same
#: bytes, on a slow or busy machine and with any ``--jobs``
#: (tests/test_determinism.py repairs under a clock that races ahead).
HOLE_VERTICES = 25_000
HOLE_VERTICES_PER_EDGE = 30


class WorkBudget:
    """What one hole (or band) may still spend, in work units: new patch
    vertices built and checked (:data:`HOLE_VERTICES`). Counted, never
    timed, so that no decision depends on the machine's speed or load.

    Parameters
    ----------
    edges : int
        Rim edges.
    share : float
        Fraction of the budget (a cap of a band gets its share).
    """

    def __init__(self, edges, share=1.0):
        self.edges = int(edges)
        self.vertices = share * (HOLE_VERTICES + HOLE_VERTICES_PER_EDGE * edges)
        self.spent = 0

    def left(self):
        """New vertices still affordable (>= 0)."""
        return max(0, int(self.vertices - self.spent))

    def spend(self, patch):
        """Count a patch built and checked."""
        if patch is not None:
            self.spent += len(patch.P)

    def affords(self, vertices):
        """Whether an attempt of about this many new vertices still fits."""
        return self.spent + vertices <= self.vertices

    def part(self, share):
        """A budget for part of the work (a cap of a band): ``share`` of what
        is left here; count what it spent back with :meth:`absorb`."""
        b = WorkBudget(self.edges)
        b.vertices = share * self.left()
        return b

    def absorb(self, part):
        """Count what ``part`` (from :meth:`part`) spent."""
        self.spent += part.spent

    def count(self, vertices):
        """Count ``vertices`` new vertices built and checked elsewhere."""
        self.spent += int(vertices)

    def take_over(self, other):
        """Stand for ``other`` (a copy of this budget that another attempt
        spent from instead): what it spent is what this one has spent."""
        self.spent = other.spent

    @contextlib.contextmanager
    def whole(self):
        """Within the block, the whole budget is left (an attempt that is
        always made once); afterwards what was spent before is counted back
        on top of what the block spent."""
        before, self.spent = self.spent, 0
        try:
            yield self
        finally:
            self.spent += before

    def describe(self):
        return (f"work budget: {self.spent} of {int(self.vertices)} patch vertices "
                f"for {self.edges} edges")


#: Failed attempts the last layer (:func:`~shellrepair.fill.mend.mend_patch`)
#: tries to mend, those with the fewest faulty triangles first.
MEND_ATTEMPTS = 2


def mend_last(ctx, faulty, reasons, check=None, what="patch"):
    """The last layer: the failed attempts with the fewest faults, mended
    where they fail (:mod:`~shellrepair.fill.mend`); the mended patch, or None
    (each failure's cause appended to ``reasons``). ``faulty``: (patch,
    faulty triangles, option) per failed attempt; ``check`` as
    :func:`check_patch` (default: it)."""
    from shellrepair.fill.mend import mend_patch

    check = check_patch if check is None else check

    tried = 0
    for patch, bad, option in sorted((f for f in faulty if f[1].size), key=lambda f: f[1].size):
        if tried == MEND_ATTEMPTS:
            break
        tried += 1
        res = mend_patch(ctx, patch, bad, check)
        if res.patch is not None:
            return res.patch.with_(option=f"{option}, mended: {res.regions} region(s) around {bad.size} faulty "
                                          f"triangles re-triangulated", mended=int(res.regions))
        reasons.append(f"last layer, mending the {option} {what} ({bad.size} faulty triangles): {res.reason}")
    return None


#: Which energy decides tube against caps: 0 thin plate ∫(2H)², 1 curvature
#: variation ∫|∇(2Hn)|². The thin-plate energy of a thin torus's inner band is
#: higher than that of two flat caps, so it picks caps where the band is
#: missing; the curvature variation measures how well each option continues
#: the surrounding surface's curvature and picks the tube (tested on tori of
#: tube radius 0.2–0.5 and cut angles 70–150°).
ENERGY = 1


def edges_across(ctx, loops):
    """Edges the scan has between the ``loops``' vertices, other than the
    loops' own edges (sorted pairs): a patch joining the loops (a tube, a
    pants) that made one again would be non-manifold."""
    verts = np.concatenate([L.vertices for L in loops])
    edges = {tuple(e) for e in edges_of(ctx.F[ctx.faces_of(verts)]).tolist()}
    return edges - {tuple(sorted(e)) for L in loops
                    for e in zip(L.vertices.tolist(), np.roll(L.vertices, -1).tolist())}


def check_joining(ctx, patch, scan_edges, what):
    """:func:`check_patch` of a patch joining loops, which also must not
    repeat one of their ``scan_edges`` (:func:`edges_across`; ``what``
    names the patch in the reason)."""
    why, bad = check_patch(ctx, patch)
    if why is None and any(e in scan_edges for e in patch_scan_edges(patch)):
        why = f"the {what} would repeat an edge of the scan"
    return why, bad
