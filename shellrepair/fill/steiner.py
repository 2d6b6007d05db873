"""The fill's last layer: a patch with vertices of its own off the rim.

Where no triangulation of a ``hole`` loop's own vertices passes the
checks (the scan crosses the opening's plane inside it, a blind bore or
a boss rising through it; a tooth split off a gear body, whose opening
lies on the body's wall), the patch needs vertices placed off the rim
(Steiner points). :func:`steiner_patch` builds it as a height field over
a plane:

1. **Project** the loop on a plane where its outline is a simple
   polygon (:func:`_axes`: normal to its best-fit plane, to its vector
   area, to the scan's mean normal at its rim, tried in turn).
2. **Triangulate** that polygon by ear clipping (mapbox_earcut; the
   collinear rim vertices it drops are put back as fans) and **refine**
   it in the plane (Liepa's splits and flips,
   :func:`~shellrepair.fill.refine.refine_patch`): the Steiner points.
3. **Lift** each vertex off the plane: its base height is the harmonic
   interpolation of the rim's own heights (0 on a planar rim, so the
   patch is flat there). A patch triangle whose footprint in the plane
   overlaps a scan face's footprint (interiors; a wall standing on the
   rim only touches) and whose heights overlap that face's has its
   corners raised above the face's highest point by :data:`LIFT` of the
   opening's diameter, on one side of the plane, until no face is met (a
   triangle above every point of the scan under it cannot meet it; a face
   wholly above the patch is passed under). The patch is a tent over what
   crosses the plane, exactly flat elsewhere; the rim never moves.
4. **Check** each side's patch with the project's exact checks
   (:func:`~shellrepair.fill.checks.check_patch`); the passing one that
   leaves its base least wins (within :data:`TIE`: the side the patch
   faces, out of the part), the runner-up recorded in the option.
5. Where both fail, the next **round** makes the Steiner points denser
   where this one raised or crossed (the target edge length halved
   there) and puts a row of them beside the rim edges of the triangles at
   fault (:data:`BESIDE_RIM`: a rim triangle's rim corners cannot rise,
   so it must be thin enough to pass beside scan close to the rim); at
   most :data:`ROUNDS` rounds, within the hole's work budget.
6. Where the outline folds over itself in every plane (a window wrapped
   most of the way round a pipe), the loop is **cut** along a chord
   between two of its vertices (:func:`_chords`: a waist that runs along
   the missing surface) into two loops, each closed as above or cut again
   (:func:`_cut_patch`); the pieces are joined along their chords and the
   whole checked again.

Nothing here reads a clock: the rounds are counted, the same scan gives
the same bytes.

References
----------
P. Liepa, "Filling holes in meshes", SGP 2003 (the refinement).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from shellrepair.fill.checks import check_patch
from shellrepair.fill.fair import harmonic_interpolate, uniform_laplacian
from shellrepair.fill.patch import Patch
from shellrepair.fill.refine import DENSITY_ALPHA, MAX_PATCH_FACES, _forbidden_pairs, _refine, refine_patch, relax_edges
from shellrepair.mesh.geometry import plane_frame
from shellrepair.mesh.index import rim_data
from shellrepair.mesh.intersect import outline_is_simple

#: How far above (or below) the highest (lowest) scan point under it a
#: raised patch triangle's corners are put, in opening diameters.
LIFT = 0.01
#: The scan faces read around an opening: its box grown by this many of
#: its diameters across its plane (and as far as the scan goes along the
#: plane's normal, where a tent may have to climb).
REACH = 2.0
#: Passes of raising patch triangles over the scan faces they meet.
LIFT_PASSES = 64
#: Rounds of denser Steiner points (target edge length halved each round).
ROUNDS = 4
#: Lifts closer than this (in opening diameters) are a tie: the side the
#: patch faces (out of the part) wins.
TIE = 1e-9
#: Where a round found triangles at the rim raised or crossing, the next
#: puts Steiner points along their rim edges at this share of the rim
#: triangle's height, to the power of the round (1/3, 1/9, ...).
BESIDE_RIM = 1.0 / 3.0
#: At most this many such points per rim edge and round.
RIM_LAYER_POINTS = 256
#: Two footprints that overlap by less than this (in units of the
#: opening's diameter) only touch (a wall standing on the rim projects
#: onto the rim edge): the exact checks judge what is left.
TOUCH = 1e-9


class SteinerResult(NamedTuple):
    """What the last layer gave for one loop."""
    patch: object          # Patch, or None
    reason: str            # why not ("" when a patch passed)
    spent: int             # new vertices built and checked
    over_budget: bool = False   # a round was not made: over the work budget left
    degenerate: bool = False    # the loop has fewer than three vertices or no extent


def steiner_patch(ctx, hole_id, loop, max_vertices=None, rounds=ROUNDS):
    """A patch for ``loop`` with Steiner points, lifted over the scan that
    crosses its plane (module notes), or None and why. Where the loop's
    outline folds over itself in every plane tried, the loop is cut into
    pieces along chords between its own vertices (:func:`_cut_patch`).

    Parameters
    ----------
    ctx : ScanContext
    hole_id : int
    loop : (k,) int64
        The loop's vertices, in boundary order.
    max_vertices : int, optional
        New vertices the rounds may build in all (a work budget); a round
        that would pass it is not made.
    rounds : int
        Rounds of Steiner points, each denser than the last where it
        raised the patch or crossed the scan (module notes, step 5).

    Returns
    -------
    SteinerResult
    """
    loop = np.asarray(loop, np.int64)
    k = len(loop)
    if k < 3:
        return SteinerResult(None, "a loop of fewer than three vertices", 0, degenerate=True)
    P = ctx.V[loop]
    diameter = float(np.ptp(P, axis=0).max())
    if not np.isfinite(diameter) or diameter <= 0:
        return SteinerResult(None, "the loop has no extent", 0, degenerate=True)
    patch, why, spent, folded, stopped = _over_planes(ctx, hole_id, loop, max_vertices, rounds)
    if patch is None and folded:
        left = None if max_vertices is None else max_vertices - spent
        patch, cut_why, cut_spent, cut_stopped = _cut_patch(ctx, hole_id, loop, left, rounds, 0)
        spent += cut_spent
        stopped = stopped or cut_stopped
        why = f"{why}; {cut_why}"
    if patch is None:
        return SteinerResult(None, "Steiner points: " + why, spent, over_budget=stopped)
    return SteinerResult(_interpolate_attributes(ctx, patch, k + len(patch.P)), "", spent)


def _over_planes(ctx, hole_id, loop, max_vertices, rounds):
    """The patch over the first plane (:func:`_axes`) that gives one that
    passes (module notes, steps 1 to 5), its attributes not yet
    interpolated. Returns ``(patch or None, why, spent, folded, stopped)``:
    ``folded`` when the outline is not simple in any plane tried,
    ``stopped`` when a round was not made for the work budget."""
    k = len(loop)
    P = ctx.V[loop]
    centre = P.mean(axis=0)
    C = P - centre
    diameter = float(np.ptp(P, axis=0).max())
    if not np.isfinite(diameter) or diameter <= 0:
        return None, "the loop has no extent", 0, False, False
    sigma, _, forbidden = rim_data(ctx, loop)
    spent = 0
    why = []
    folded = True
    stopped = False          # a round not made: over the work budget left
    for name, axis in _axes(ctx, loop, C):
        u, v = plane_frame(axis)
        Q = np.column_stack([C @ u, C @ v]) / diameter
        if not outline_is_simple(Q):
            why.append(f"its outline seen along {name} is not a simple polygon")
            continue
        folded = False
        T0 = _ear_clip(Q, k)
        if T0 is None or _repeats_scan_edge(T0, forbidden):
            why.append(f"seen along {name}, its outline's triangulation "
                       + ("failed" if T0 is None else "would repeat an edge of the scan"))
            continue
        H = C @ axis / diameter                    # the rim's heights off the plane
        face = _scan_footprints(ctx, centre, u, v, axis, diameter, P)
        X3, T = refine_patch(np.column_stack([Q, np.zeros(k)]), T0, np.asarray(sigma) / diameter, k, forbidden)
        scale = np.concatenate([np.asarray(sigma, np.float64) / diameter,
                                np.full(len(X3) - k, float(np.mean(sigma)) / diameter)])
        tried = []
        for r in range(rounds):
            capped = False      # stopped at the work budget's size (not at the safety cap)
            if r:   # denser Steiner points where the last round raised or crossed
                scale = scale.copy()
                scale[_ring(T, near, len(X3))] /= 2
                X3, T, scale = _rim_layer(X3, T, scale, near, k, forbidden, BESIDE_RIM ** r)
                cap = round_faces(k, max_vertices, spent)
                X3, T, _, capped = _refine(X3, T, scale, np.arange(len(X3)) < k, _forbidden_pairs(forbidden),
                                           DENSITY_ALPHA, cap)
                capped = capped and cap < MAX_PATCH_FACES
                scale = _scales_after(scale, X3, T)
            n_new = len(X3) - k
            if max_vertices is not None and (capped or spent + 2 * n_new > max_vertices):
                why.append(f"seen along {name}, round {r + 1}: " + (f"over {n_new}" if capped else f"{n_new}")
                           + " Steiner points, over the work budget left")
                stopped = True
                break
            X = X3[:, :2]
            base = _harmonic(T, X, H, k)
            best, near = None, np.zeros(0, np.int64)
            for side in _sides(X, T):
                h = lift_heights(X, T, base, face, side, k)
                new = centre + diameter * (X[k:, :1] * u + X[k:, 1:] * v + h[k:, None] * axis)
                patch = Patch(hole_id=hole_id, loop=loop, P=new, T=T, T0=T0, disc=True, kind="steiner")
                spent += n_new
                bad_why, bad = check_patch(ctx, patch)
                lifted = float(np.abs(h - base).max()) * diameter
                tried.append((bad_why, lifted, side))
                raised = np.flatnonzero((h != base)[T].any(axis=1))
                near = np.union1d(near, np.union1d(bad, raised))
                if bad_why is None and (best is None or lifted < best[1] - TIE * diameter):
                    best = (patch, lifted, side)
            if best is not None:
                patch, lifted, side = best
                other = [t for t in tried[-2:] if t[2] is not side]
                runner = (f"; the other side {'passes' if other[0][0] is None else 'fails'} "
                          f"(lifted {other[0][1]:.3g})" if other else "")
                patch = patch.with_(option=f"Steiner points: {len(patch.P)} vertices off the rim (plane normal to "
                                           f"{name}, round {r + 1}), lifted {lifted:.3g} off it {side[0]} the part{runner}")
                return patch, "", spent, False, stopped
        if tried:
            why.append(f"seen along {name}, {len(tried) // 2} rounds: "
                       + "; ".join(f"{t[2][0]} the part, {t[0]}" for t in tried[-2:]))
    return None, "; ".join(why), spent, folded, stopped


def round_faces(k, max_vertices, spent):
    """The most triangles a round's refinement may make: where it would
    make more, the round is over the work budget anyway, so it stops there
    instead of refining on.

    A round's patch is a triangulated disc: ``k`` rim vertices and ``n``
    new ones make ``k + 2n - 2`` triangles. The round is over the budget
    where its two sides' checks would spend more than what is left,
    ``2n > max_vertices - spent``, so a refinement that passes
    ``k - 2 + 2 floor((max_vertices - spent) / 2)`` triangles is over it.
    Below that cap the refinement is the one an uncapped refinement makes
    (the cap only stops it), so the outputs are the same (where the safety
    cap ``MAX_PATCH_FACES`` is the lower, it stays as before); a 4-edge hole
    whose refusal once came after refining to 991,132 Steiner points (128 s
    of a ragged scan's repair) is refused at the budget's size.

    Parameters
    ----------
    k : int
        Rim vertices.
    max_vertices : int or None
        The work budget (None: none).
    spent : int
        New vertices already built and checked.

    Returns
    -------
    faces : int
    """
    if max_vertices is None:
        return MAX_PATCH_FACES
    return int(min(MAX_PATCH_FACES, k - 2 + 2 * ((max_vertices - spent) // 2)))


def _cut_patch(ctx, hole_id, loop, max_vertices, rounds, depth):
    """A patch for a loop whose outline folds over itself in every plane
    (an opening wrapped most of the way round a pipe or a corner): the loop
    cut along a chord between two of its vertices (:func:`_chords`: the
    shortest against the shorter of the two rim paths it cuts off, a waist)
    into two loops, each closed by :func:`_over_planes` or cut again (at
    most :data:`CUT_DEPTH` times deep), the pieces joined along their
    chords and the whole checked again (:func:`~shellrepair.fill.checks.check_patch`:
    the pieces against each other, the folds across the chords). The next
    chord (at most :data:`CUT_TRIES` a level) where a piece fails. The
    chords are rim edges of both pieces: never split, never lifted.
    Returns ``(patch or None, why, spent, stopped)`` (``stopped``: a round
    or a cut was not made for the work budget)."""
    k = len(loop)
    spent = 0
    why = []
    stopped = False
    _, _, forbidden = rim_data(ctx, loop)
    for i, j in _chords(ctx, loop, forbidden):
        sides = [np.arange(i, j + 1), np.concatenate([np.arange(j, k), np.arange(0, i + 1)])]
        parts = []
        for s in sides:
            left = None if max_vertices is None else max_vertices - spent
            patch, w, used, folded, hit = _over_planes(ctx, hole_id, loop[s], left, rounds)
            spent += used
            stopped = stopped or hit
            if patch is None and folded and depth + 1 < CUT_DEPTH and len(s) >= 4:
                left = None if max_vertices is None else max_vertices - spent
                patch, w, used, hit = _cut_patch(ctx, hole_id, loop[s], left, rounds, depth + 1)
                spent += used
                stopped = stopped or hit
            if patch is None:
                why.append(f"cut between rim vertices {i} and {j}: the piece of {len(s)} vertices fails ({w})")
                break
            parts.append((s, patch))
        else:
            whole = _joined(hole_id, loop, parts)
            bad_why, _ = check_patch(ctx, whole)
            if bad_why is None:
                return whole, "", spent, stopped
            why.append(f"cut between rim vertices {i} and {j}: the pieces together fail ({bad_why})")
        if max_vertices is not None and spent >= max_vertices:
            why.append("the work budget is spent")
            stopped = True
            break
    if not why:
        why.append("no chord to cut it along")
    return None, "cut into pieces along chords: " + "; ".join(why), spent, stopped


#: Chords tried, at each level of cutting (:func:`_cut_patch`).
CUT_TRIES = 4
#: Levels of cutting: a loop is cut into at most 2 ** CUT_DEPTH pieces.
CUT_DEPTH = 3
#: A chord tried after another has both its ends at least this many rim
#: edges from the ends of every chord tried before it.
CUT_SPREAD = 1
#: A chord that leaves the scan's surface at its ends (its direction's
#: cosine with the scan's normal there) scores this much worse per unit
#: of that cosine: a chord across the part's inside is a poor path over
#: the missing surface.
CUT_OFF_SURFACE = 4.0


def _chords(ctx, loop, forbidden):
    """Chords (i, j), i < j, between the loop's vertices to cut it along,
    best first (at most :data:`CUT_TRIES`): each is at least two edges from
    either end, joins two distinct vertices the scan does not join, and
    scores its length over the shorter of the two rim paths between its
    ends (a waist: short across, long around), times ``1 +``
    :data:`CUT_OFF_SURFACE` times the larger cosine between it and the
    scan's normal at its ends (it should run along the missing surface,
    not across the part); ties go to the lower (i, j). Each chord after
    the first keeps its ends :data:`CUT_SPREAD` rim edges from the ends of
    those before it."""
    P = ctx.V[loop]
    k = len(P)
    run = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1))])
    total = run[-1]
    normal = _vertex_normals(ctx, loop)
    ranked = []
    for i in range(k - 2):
        j = np.arange(i + 2, k - (1 if i == 0 else 0))
        if not j.size:
            continue
        d = P[j] - P[i]
        length = np.linalg.norm(d, axis=1)
        t = d / np.maximum(length, 1e-300)[:, None]
        off = np.maximum(np.abs(t @ normal[i]), np.abs(np.einsum("ij,ij->i", t, normal[j])))
        around = run[j] - run[i]
        score = length / np.maximum(np.minimum(around, total - around), 1e-300) * (1 + CUT_OFF_SURFACE * off)
        ok = (loop[j] != loop[i]) & (length > 0)
        for m in np.flatnonzero(ok)[np.argsort(score[ok], kind="stable")][:4 * CUT_TRIES]:
            jj = int(j[m])
            if (i, jj) not in forbidden and (jj, i) not in forbidden:
                ranked.append((float(score[m]), i, jj))
    ranked.sort()
    out = []
    for _, i, j in ranked:
        ends = [e for c in out for e in c]
        if all(min((i - e) % k, (e - i) % k) >= CUT_SPREAD and min((j - e) % k, (e - j) % k) >= CUT_SPREAD
               for e in ends):
            out.append((i, j))
            if len(out) == CUT_TRIES:
                break
    return out


def _vertex_normals(ctx, loop):
    """Unit normals of the scan at the loop's vertices (the sum of its
    faces' area vectors there; zero where they cancel)."""
    f = np.asarray(ctx.faces_of(loop), np.int64)
    T = ctx.F[f]
    A = np.cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]])
    ids, pos = np.unique(loop, return_inverse=True)
    acc = np.zeros((len(ids), 3))
    for c in range(3):
        at = np.searchsorted(ids, T[:, c])
        hit = (at < len(ids)) & (ids[np.minimum(at, len(ids) - 1)] == T[:, c])
        np.add.at(acc, at[hit], A[hit])
    n = acc[pos]
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)


def _joined(hole_id, loop, parts):
    """One patch over ``loop`` from the pieces' patches ``(positions in
    loop, patch)``: their triangles on the loop's positions, their new
    vertices one after another."""
    k = len(loop)
    Ps, Ts, T0s, options = [], [], [], []
    n = 0
    for s, p in parts:
        ks = len(s)
        idx = np.concatenate([s, k + n + np.arange(len(p.P))])
        Ts.append(idx[p.T])
        T0s.append(s[p.T0])
        Ps.append(p.P)
        n += len(p.P)
        options.append(p.option.removeprefix("Steiner points: "))
    option = (f"Steiner points: {n} vertices off the rim, in {len(parts)} pieces cut along chords between rim "
              f"vertices (its outline is not simple in any plane): " + " | ".join(options))
    return Patch(hole_id=hole_id, loop=loop, P=np.vstack(Ps), T=np.vstack(Ts), T0=np.vstack(T0s), disc=True,
                 kind="steiner", option=option)


def _axes(ctx, loop, C):
    """Planes to project the opening on, by their normals: the loop's
    best-fit plane, its vector area, the mean normal of the scan faces at
    its rim (each once)."""
    out = [("its best-fit plane's normal", np.linalg.svd(C, full_matrices=False)[2][-1])]
    area = 0.5 * np.cross(C, np.roll(C, -1, axis=0)).sum(axis=0)
    T = ctx.F[ctx.faces_of(loop)]
    rim = np.cross(ctx.V[T[:, 1]] - ctx.V[T[:, 0]], ctx.V[T[:, 2]] - ctx.V[T[:, 0]]).sum(axis=0)
    for name, a in (("its vector area", area), ("the scan's mean normal at its rim", rim)):
        ln = float(np.linalg.norm(a))
        if ln > 0 and np.isfinite(ln) and all(abs(float(a @ b)) / ln < 1 - 1e-6 for _, b in out):
            out.append((name, a / ln))
    return out


def _rim_layer(X3, T, scale, near, k, forbidden, share):
    """Steiner points along the rim edges of the triangles ``near`` (those
    the last round raised or found crossing), on the line ``share`` of the
    rim triangle's height inside the edge, about twice that apart: the
    triangles at the rim, whose rim corners cannot be raised, become thin
    enough to pass beside scan that comes close to the rim. Inserted one per
    triangle at a time (split in three), the edges then flipped to the
    Delaunay criterion (rim edges stay). Returns ``X3, T, scale``."""
    k_edges = T[near]
    rim_tris = []
    for t, tri in zip(near.tolist(), k_edges.tolist()):
        for m in range(3):
            a, b = tri[m], tri[(m + 1) % 3]
            if a < k and b < k and (a - b) % k == 1:     # rim edge (b, a): reversed in the patch
                rim_tris.append((b, a, tri[(m + 2) % 3]))
    if not rim_tris:
        return X3, T, scale
    pts, sc = [], []
    X = X3[:, :2]
    for a, b, c in rim_tris:
        e = X[b] - X[a]
        L = float(np.hypot(*e))
        if L <= 0:
            continue
        inward = np.array([-e[1], e[0]]) / L
        height = float((X[c] - X[a]) @ inward)
        if height <= 0:
            inward, height = -inward, -height
        d = share * height
        if not d > 0:
            continue
        m = int(min(RIM_LAYER_POINTS, max(1, np.ceil(L / (2 * d)))))
        t = (np.arange(m) + 0.5) / m
        pts.append(X[a] + t[:, None] * e + d * inward)
        sc.append(np.full(m, 2 * d))
    if not pts:
        return X3, T, scale
    pts, sc = np.vstack(pts), np.concatenate(sc)
    X3, T, added = _insert(X3, T, pts, k, forbidden)
    return X3, T, np.concatenate([scale, sc[added]])


def _insert(X3, T, pts, k, forbidden, batches=64):
    """Insert the 2-D points ``pts`` into the planar triangulation (``X3``
    with z = 0): each into the triangle that strictly contains it, at most
    one per triangle per batch, then the edges flipped to the Delaunay
    criterion (:func:`~shellrepair.fill.refine.relax_edges`); points in no
    triangle's interior are skipped. Returns ``X3, T`` and which points
    were added (in the order added)."""
    X = X3[:, :2]
    sign = 1.0 if _turning(X, T) > 0 else -1.0
    todo = np.arange(len(pts))
    added = []
    span = float(np.ptp(X, axis=0).max()) or 1.0
    for _ in range(batches):
        if not todo.size:
            break
        p = pts[todo]
        A = X[T]
        tj, pi = _box_pairs(A.min(axis=1), A.max(axis=1), p, p)     # (triangle, point) by a grid
        a, b, c, q = A[tj, 0], A[tj, 1], A[tj, 2], p[pi]

        def orient(P0, P1):
            return sign * ((P1[:, 0] - P0[:, 0]) * (q[:, 1] - P0[:, 1]) - (P1[:, 1] - P0[:, 1]) * (q[:, 0] - P0[:, 0]))

        tol = 1e-12 * span * span
        inside = (orient(a, b) > tol) & (orient(b, c) > tol) & (orient(c, a) > tol)
        tj, pi = tj[inside], pi[inside]
        order = np.lexsort((tj, pi))                     # each point's first triangle, then
        tj, pi = tj[order], pi[order]                    # each triangle's first point
        first = np.ones(pi.size, bool)
        first[1:] = pi[1:] != pi[:-1]
        tj, pi = tj[first], pi[first]
        has = np.zeros(todo.size, bool)
        has[pi] = True
        tri = np.zeros(todo.size, np.int64)
        tri[pi] = tj
        order = np.lexsort((pi, tj))
        tj_s, pi_s = tj[order], pi[order]
        once = np.ones(tj_s.size, bool)
        once[1:] = tj_s[1:] != tj_s[:-1]
        take = np.sort(pi_s[once])
        if not take.size:
            break
        ids = tri[take]
        new = len(X3) + np.arange(take.size)
        X3 = np.vstack([X3, np.column_stack([p[take], np.zeros(take.size)])])
        X = X3[:, :2]
        a, b, c = T[ids, 0], T[ids, 1], T[ids, 2]
        keep = np.ones(len(T), bool)
        keep[ids] = False
        T = np.vstack([T[keep], np.column_stack([a, b, new]), np.column_stack([b, c, new]),
                       np.column_stack([c, a, new])])
        T = relax_edges(X3, T, k, forbidden)
        added.extend(todo[take].tolist())
        rest = np.ones(todo.size, bool)
        rest[take] = False
        rest &= has
        todo = todo[rest]
    return X3, T, np.asarray(added, np.int64)


def _turning(X, T):
    """Twice the signed area the triangles cover in the plane."""
    a, b, c = X[T[:, 0]], X[T[:, 1]], X[T[:, 2]]
    return float(np.sum((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])))


def _ring(T, tris, n):
    """Vertices of the triangles ``tris`` and of the triangles around them."""
    mark = np.zeros(n, bool)
    mark[T[tris].ravel()] = True
    mark[T[mark[T].any(axis=1)].ravel()] = True
    return np.flatnonzero(mark)


def _scales_after(scale, X, T):
    """Per-vertex scales after a refinement that added vertices: the old
    ones kept, each new one the mean of its neighbours' known ones."""
    n = len(X)
    if len(scale) == n:
        return scale
    out = np.concatenate([scale, np.full(n - len(scale), np.nan)])
    for _ in range(64):
        todo = np.isnan(out)
        if not todo.any():
            break
        E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
        E = np.vstack([E, E[:, ::-1]])
        ok = ~np.isnan(out[E[:, 1]]) & todo[E[:, 0]]
        tot = np.bincount(E[ok, 0], out[E[ok, 1]], n)
        cnt = np.bincount(E[ok, 0], None, n)
        fill = todo & (cnt > 0)
        out[fill] = tot[fill] / cnt[fill]
    return np.where(np.isnan(out), np.nanmean(out), out)


def _ear_clip(Q, k):
    """Triangles over the polygon ``Q`` (k,2) by ear clipping, every vertex
    used (the collinear ones mapbox_earcut drops put back as fans), or None."""
    import mapbox_earcut

    T = np.asarray(mapbox_earcut.triangulate_float64(np.ascontiguousarray(Q), np.array([k], np.uint32)),
                   np.int64).reshape(-1, 3)
    used = np.zeros(k, bool)
    used[T.ravel()] = True
    if not used.any():
        return None
    tris = [list(t) for t in T.tolist()]
    start = int(np.flatnonzero(used)[0])
    i = 0
    while i < k:
        a = (start + i) % k
        j = 1
        while not used[(a + j) % k]:
            j += 1
        if j > 1:                       # a run of dropped vertices between a and b
            b = (a + j) % k
            run = [(a + t) % k for t in range(1, j)]
            for ti, t in enumerate(tris):
                pos = [(t[m], t[(m + 1) % 3]) for m in range(3)]
                if (a, b) in pos or (b, a) in pos:
                    m = pos.index((a, b)) if (a, b) in pos else pos.index((b, a))
                    c = t[(m + 2) % 3]
                    chain = [a] + run + [b] if (a, b) in pos else [b] + run[::-1] + [a]
                    tris[ti:ti + 1] = [[chain[q], chain[q + 1], c] for q in range(len(chain) - 1)]
                    break
            else:
                return None
        i += j
    T = np.array(tris, np.int64)
    if len(T) != k - 2:
        return None
    # loop edges reversed in the patch (as the scan's faces have them)
    directed = {(int(t[m]), int(t[(m + 1) % 3])) for t in T for m in range(3)}
    if (0, 1) in directed:
        T = T[:, ::-1].copy()
    return T


def _repeats_scan_edge(T, forbidden):
    """Does the triangulation join two loop vertices the scan joins already?"""
    if not forbidden:
        return False
    E = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    return any((int(a), int(b)) in forbidden or (int(b), int(a)) in forbidden for a, b in E.tolist())


def _scan_footprints(ctx, centre, u, v, axis, diameter, P):
    """The scan faces in the column over and under the opening (its box
    grown by :data:`REACH` diameters across, as far as the scan goes along
    ``axis``), in the plane's frame: their 2-D corners (m,3,2) and their
    lowest and highest heights (m,), in opening diameters."""
    index = ctx.index
    reach = diameter * REACH
    lo, hi = P.min(axis=0) - reach, P.max(axis=0) + reach
    vlo, vhi = ctx.V.min(axis=0), ctx.V.max(axis=0)
    along = float(np.linalg.norm(vhi - vlo)) * np.abs(axis)      # the scan's extent, along the axis
    lo, hi = np.maximum(lo - along, vlo), np.minimum(hi + along, vhi)
    f = np.asarray(index.faces_near(lo, hi), np.int64)
    Tc = index.V[index.F[f]] - centre
    xy = np.stack([Tc @ u, Tc @ v], axis=-1) / diameter
    h = (Tc @ axis) / diameter
    return xy, h.min(axis=1), h.max(axis=1)


def _harmonic(T, X, H, k):
    """Heights of the vertices ``X`` (rim first) interpolated harmonically
    from the rim's ``H``; exactly the rim's where every rim height is 0."""
    out = np.zeros(len(X))
    out[:k] = H
    if len(X) > k and np.any(H != 0):
        K = uniform_laplacian(T, len(X))
        out[k:] = harmonic_interpolate(K, H[:, None], k)[:, 0]
    return out


def _sides(X, T):
    """The two sides to lift to, the one the patch faces first: ``(name,
    sign)``, sign +1 along the plane's normal."""
    a, b, c = X[T[:, 0]], X[T[:, 1]], X[T[:, 2]]
    turn = np.sum((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    facing = 1.0 if turn > 0 else -1.0        # (u, v, normal) is right-handed
    return [("out of", facing), ("into", -facing)]


def lift_heights(X, T, base, face, side, k):
    """Heights of the patch vertices lifted to ``side`` (module notes, step
    3): a patch triangle whose footprint overlaps a scan face's, and whose
    heights overlap that face's, has its corners raised above the face;
    repeated (at most :data:`LIFT_PASSES` times) until no face is met, so
    a scan face wholly above the patch (the far wall of a part) is passed
    under, not climbed. The rim stays where it is.

    Parameters
    ----------
    X : (q,2) float64
        The patch's vertices in the plane (rim first), in opening diameters.
    T : (t,3) int64
    base : (q,) float64
        Their heights before lifting (the rim's are kept).
    face : tuple
        The scan faces' footprints (m,3,2) and lowest and highest heights
        (m,), (m,) (:func:`_scan_footprints`).
    side : (str, float)
        The side to lift to (:func:`_sides`): its name and sign.
    k : int
        Rim vertices.

    Returns
    -------
    h : (q,) float64
        The lifted heights.
    """
    xy, hmin, hmax = face
    sign = side[1]
    fmin, fmax = (hmin, hmax) if sign > 0 else (-hmax, -hmin)   # the faces' heights up that side
    g = sign * base
    # a face wholly below the patch's lowest base height, up that side, is
    # never met; one wholly above its highest height is not met until the
    # patch is raised that high, so faces are paired with the patch's
    # triangles as the patch rises to them (the footprints of a tiny
    # opening's column through a whole statue, 26 s of a ragged scan's
    # 3-edge hole, are mostly never reached; the pairs met are the same)
    near = np.flatnonzero(fmax >= g.min() - TOUCH)
    near = near[np.argsort(fmin[near], kind="stable")]
    low = fmin[near]
    A = X[T]
    reached = 0
    pt, pf = np.zeros(0, np.int64), np.zeros(0, np.int64)
    rim = np.arange(len(X)) < k
    for _ in range(LIFT_PASSES):
        top = int(np.searchsorted(low, g.max(), side="right"))   # faces that may meet the patch now
        if top > reached:
            i, j = overlapping_triangles(A, xy[near[reached:top]])
            pt, pf = np.concatenate([pt, i]), np.concatenate([pf, near[reached:top][j]])
            reached = top
        if not pt.size:
            break
        gc = g[T]
        meet = (fmin[pf] <= gc.max(axis=1)[pt]) & (fmax[pf] >= gc.min(axis=1)[pt])
        need = np.full(len(T), -np.inf)
        np.maximum.at(need, pt[meet], fmax[pf[meet]] + LIFT)
        corner = np.full(len(X), -np.inf)
        np.maximum.at(corner, T.ravel(), np.repeat(need, 3))
        raised = ~rim & (corner > g)
        if not raised.any():
            break
        g = np.where(raised, corner, g)
    return sign * g


def overlapping_triangles(A, B):
    """Pairs (i, j) of 2-D triangles ``A[i]`` and ``B[j]`` (a face seen
    edge-on is a segment) whose interiors overlap by more than ``TOUCH``:
    their boxes first (:func:`_box_pairs`), then separating axes (the edge
    normals of both).

    Parameters
    ----------
    A : (a,3,2) float64
    B : (b,3,2) float64

    Returns
    -------
    i, j : (p,) int64
        Each overlapping pair once.
    """
    alo, ahi = A.min(axis=1), A.max(axis=1)
    blo, bhi = B.min(axis=1), B.max(axis=1)
    pi, pj = _box_pairs(alo, ahi, blo, bhi)
    hit = np.all((blo[pj] < ahi[pi] - TOUCH) & (bhi[pj] > alo[pi] + TOUCH), axis=1)
    pi, pj = pi[hit], pj[hit]
    keep = np.ones(pi.size, bool)
    for S, other, first in ((A, B, True), (B, A, False)):
        own, oth = (S[pi], other[pj]) if first else (S[pj], other[pi])
        for e in range(3):
            d = own[:, (e + 1) % 3] - own[:, e]
            nrm = np.column_stack([-d[:, 1], d[:, 0]])
            ln = np.linalg.norm(nrm, axis=1)
            ok = ln > 0
            nrm[ok] /= ln[ok, None]
            p_own = np.einsum("nij,nj->ni", own, nrm)
            p_oth = np.einsum("nij,nj->ni", oth, nrm)
            apart = (p_own.max(axis=1) <= p_oth.min(axis=1) + TOUCH) | (p_oth.max(axis=1) <= p_own.min(axis=1) + TOUCH)
            keep &= ~(apart & ok)
    return pi[keep], pj[keep]


#: A scan face whose box covers more grid cells than this is paired with
#: every patch triangle by boxes directly (:func:`_box_pairs`).
BIG_FACE_CELLS = 64


def _box_pairs(alo, ahi, blo, bhi):
    """Candidate pairs (i, j) of 2-D boxes ``[alo, ahi]`` (patch triangles)
    and ``[blo, bhi]`` (scan faces) that may meet: both put in a grid of
    cells twice the median patch box, joined by cell; a face covering more
    than :data:`BIG_FACE_CELLS` cells (a large CAD face) is paired with
    every triangle, a triangle covering more with every face. A superset,
    each pair once."""
    if not len(alo) or not len(blo):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    origin = np.minimum(alo.min(axis=0), blo.min(axis=0))
    size = 2.0 * float(np.median((ahi - alo).max(axis=1)))
    span = float(np.maximum(ahi.max(axis=0), bhi.max(axis=0)).max() - origin.min())
    if not size > 0:
        size = span or 1.0
    a0, a1 = np.floor((alo - origin) / size).astype(np.int64), np.floor((ahi - origin) / size).astype(np.int64)
    b0, b1 = np.floor((blo - origin) / size).astype(np.int64), np.floor((bhi - origin) / size).astype(np.int64)
    big = np.prod(b1 - b0 + 1, axis=1) > BIG_FACE_CELLS
    small = np.flatnonzero(~big)
    wide = int(max(a1[:, 1].max(), b1[small, 1].max() if small.size else 0)) + 2
    # a patch triangle far larger than the median (a piece seen nearly
    # edge-on) is paired with every face by boxes too, not spread over cells
    big_a = np.prod(a1 - a0 + 1, axis=1) > BIG_FACE_CELLS
    small_a = np.flatnonzero(~big_a)
    ai, ak = _cells(a0[small_a], a1[small_a], wide)
    ai = small_a[ai]
    bi, bk = _cells(b0[small], b1[small], wide)
    bi = small[bi]
    order = np.argsort(bk, kind="stable")
    bk, bi = bk[order], bi[order]
    lo, hi = np.searchsorted(bk, ak, "left"), np.searchsorted(bk, ak, "right")
    cnt = hi - lo
    pi = np.repeat(ai, cnt)
    pj = bi[np.repeat(lo, cnt) + np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt)]
    key = np.unique(pi * len(blo) + pj)             # a pair met in several cells, once
    pi, pj = key // len(blo), key % len(blo)
    fb = np.flatnonzero(big)
    if fb.size:
        pi = np.concatenate([pi, np.repeat(np.arange(len(alo)), fb.size)])
        pj = np.concatenate([pj, np.tile(fb, len(alo))])
    ab = np.flatnonzero(big_a)
    if ab.size and small.size:      # (a big triangle and a big face: paired above)
        pi = np.concatenate([pi, np.repeat(ab, small.size)])
        pj = np.concatenate([pj, np.tile(small, ab.size)])
    return pi, pj


def _cells(c0, c1, wide):
    """(item, cell key) for every grid cell each box ``[c0, c1]`` covers."""
    nx, ny = c1[:, 0] - c0[:, 0] + 1, c1[:, 1] - c0[:, 1] + 1
    total = nx * ny
    item = np.repeat(np.arange(len(c0)), total)
    local = np.arange(int(total.sum())) - np.repeat(np.cumsum(total) - total, total)
    ix = c0[item, 0] + local // ny[item]
    iy = c0[item, 1] + local % ny[item]
    return item, ix * wide + iy


def _interpolate_attributes(ctx, patch, n):
    """``patch`` (``n`` vertices, rim first) with colours and per-vertex
    properties on its new vertices, harmonic from the rim's (as
    :func:`~shellrepair.fill.patch.build_patch` gives them)."""
    if ctx.colors is None and not ctx.props:
        return patch
    k = len(patch.loop)
    K = uniform_laplacian(patch.T, n)
    colors = patch.colors
    if ctx.colors is not None:
        c = harmonic_interpolate(K, ctx.colors[patch.loop].astype(np.float64), k)
        colors = np.clip(np.round(c), 0, 255).astype(np.uint8)
    props = dict(patch.props)
    for name, arr in ctx.props.items():
        arr = np.asarray(arr)
        vals = harmonic_interpolate(K, arr[patch.loop].astype(np.float64)[:, None], k)[:, 0]
        props[name] = vals.astype(arr.dtype) if np.issubdtype(arr.dtype, np.floating) \
            else np.round(vals).astype(arr.dtype)
    return patch.with_(colors=colors, props=props)
