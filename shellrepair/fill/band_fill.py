"""Fill one band: two loops facing each other across a missing band.

:func:`_fill_pair` offers the two loops a tube (:mod:`~shellrepair.fill.tube`,
along their continuation arcs, :mod:`~shellrepair.fill.bridge`) and the two
caps (:func:`shellrepair.fill.hole.fill_hole` each), and keeps the tube or the
caps by their curvature-variation energy (see :mod:`shellrepair.fill.bridge`
for which option is kept when); :func:`flat_face_with_hole` is the flat
face of a CAD part with a hole through it.
"""

from __future__ import annotations

import time

import numpy as np

from shellrepair.fill import checks
from shellrepair.fill.checks import Outcome
from shellrepair.fill.hole import OPTION_NAMES, PIN_ROUNDS, _pin_region, band_order, fill_hole, refair_on_harmonic
from shellrepair.fill.merge import Accepted
from shellrepair.fill.patch import OverBudget, PatchError, _meets_edge_on, build_patch, corners
from shellrepair.mesh.index import rim_data

__all__ = ["flat_face_with_hole", "seam_loop", "CAPS_SHARE", "GUIDE_SHARE", "COARSE_SPACING", "SEAM"]


#: Share of a band's budget the two caps get when they are filled before
#: the tube (the rest is the tube's).
CAPS_SHARE = 0.7
#: Where every tube fails, the band is cut open along a seam and filled as
#: one hole (:func:`seam_loop`); False leaves such a band to its caps, as
#: before 2026-12-08 (tests of what comes after use it).
SEAM = True


#: Largest share of a band's work budget the guide tube's own vertices may
#: take (refinement only adds to them): past it, the tube refined from the
#: guide and one more attempt of its size (the tube held on its first
#: positions, a retry) cannot both be afforded, and the first tube is built
#: by :func:`_coarse_tube` instead.
GUIDE_SHARE = 0.5
#: Ring spacing of the coarse tube of :func:`_coarse_tube`, in rim edge
#: lengths: about 1/16 of the vertices of the tube at the rim's spacing.
COARSE_SPACING = 4.0


def _coarse_tube(ctx, A, B, PA, PB, arcs, spacing, reach, order, budget):
    """The first tube of a band whose arcs' guide is too large for the band's
    budget, or None.

    The guide follows each loop's continuation arcs; where they miss their
    partners (a wide band, the inner side of a fat torus) the blend of the
    two loops' arcs crumples, and refinement to the rim's edge length then
    spends its vertices on the folds (about twice the vertices the faired
    tube's area needs, on the stress suite's tori). So the guide is built
    with rings ``COARSE_SPACING`` rim edges apart, faired (its vertices
    counted against ``budget``) and resampled at the rim's spacing
    (:func:`~shellrepair.fill.tube.resample_tube`): a first tube the size of
    the surface it spans. Returns ``(P, T)`` as ``guide_tube``.
    """
    from shellrepair.fill.tube import guide_tube, resample_tube

    loop = np.concatenate([A.vertices, B.vertices])
    try:
        Pc, Tc, params, facing = guide_tube(PA, PB, *arcs, spacing=COARSE_SPACING * spacing, reach=reach,
                                            rings=True)
        if params is None or not np.isfinite(Pc).all():
            return None
        pc = build_patch(ctx, A.id, loop, order=order, initial=(Pc, Tc), refine=False)
        budget.spend(pc)
        P, T = resample_tube(PA, PB, params, facing, pc.P, spacing)
    except (PatchError, ValueError, IndexError, FloatingPointError):
        return None
    return (P, T) if np.isfinite(P).all() else None


def flat_face_with_hole(ctx, A, B):
    """Two loops that outline one flat face with a hole in it: a triangulation
    of that face, or None.

    The single-hole form is the flat cap (a planar opening the scan meets
    edge-on, :func:`shellrepair.fill.patch._meets_edge_on`): a CAD part's face, a
    statue's base. The same face with a hole through it (a plate around a
    bore, a base around a tenon) is two loops, and a tube between them,
    faired, bulges out of the face's plane (a 1-high box's missing top
    around a round bore: 1.1 above it). The two loops are such a face when
    each meets the scan edge-on by the flat cap's own test, both lie on one
    plane (the flat cap's planarity bound for the two together:
    ``EDGE_ON_CAD_PLANARITY`` where both are exactly planar CAD outlines,
    else ``EDGE_ON_PLANARITY``) and one lies inside the other in that
    plane. The face is triangulated in the plane by ear clipping of a
    polygon with a hole (mapbox_earcut), using the loops' own vertices.

    Parameters
    ----------
    ctx : ScanContext
    A, B : Loop

    Returns
    -------
    T : (ka+kb,3) int64 or None
        Triangles over the concatenated positions ``[A; B]``, each loop edge
        reversed (as the scan's faces have it), or None when the loops are
        not such a face.
    """
    from shellrepair.fill.patch import EDGE_ON_CAD_PLANARITY, EDGE_ON_PLANARITY
    from shellrepair.fill.placement import inside_polygon
    from shellrepair.holes.loops import loop_stats

    if not (_meets_edge_on(ctx, A.vertices, A.id) and _meets_edge_on(ctx, B.vertices, B.id)):
        return None
    loop = np.concatenate([A.vertices, B.vertices])
    ka = len(A.vertices)
    st = loop_stats(ctx.V, loop)      # the two loops' plane: its RMS distance over the diameter, its normal
    cad = max(A.planarity, B.planarity) <= EDGE_ON_CAD_PLANARITY
    if not np.isfinite(st["planarity"]) or st["planarity"] > (EDGE_ON_CAD_PLANARITY if cad else EDGE_ON_PLANARITY):
        return None
    P = ctx.V[loop] - st["center"]
    # the plane's normal as the SVD gives it (st["axis"] is it, turned along
    # the loops' vector area): its sign sets the frame, hence the triangulation
    normal = np.linalg.svd(P, full_matrices=False)[2][-1]
    u = np.cross(normal, np.eye(3)[int(np.argmin(np.abs(normal)))])
    u /= np.linalg.norm(u)
    Q = np.column_stack([P @ u, P @ np.cross(normal, u)]) / st["diameter"]
    QA, QB = Q[:ka], Q[ka:]

    def inside(X, poly):
        return inside_polygon(X[:, 0], X[:, 1], poly)

    if inside(QB, QA).all() and not inside(QA, QB).any():
        outer, inner = np.arange(ka), ka + np.arange(len(QB))
    elif inside(QA, QB).all() and not inside(QB, QA).any():
        outer, inner = ka + np.arange(len(QB)), np.arange(ka)
    else:
        return None
    import mapbox_earcut

    ring = np.concatenate([outer, inner])
    T = mapbox_earcut.triangulate_float64(np.ascontiguousarray(Q[ring]),
                                          np.array([len(outer), len(ring)], np.uint32))
    T = _restore_collinear(np.asarray(T, np.int64).reshape(-1, 3), [np.arange(len(outer)),
                                                                    len(outer) + np.arange(len(inner))])
    if T is None:
        return None
    T = ring[T]
    if len(T) != len(loop) or np.unique(np.sort(T, axis=1), axis=0).shape[0] != len(T):
        return None
    # each loop edge reversed (as the scan's faces have it): all of them, or
    # all after one flip; loops that run the same way round are no such face
    kb = len(loop) - ka
    rim = np.concatenate([np.column_stack([np.arange(ka), np.roll(np.arange(ka), -1)]),
                          ka + np.column_stack([np.arange(kb), np.roll(np.arange(kb), -1)])])
    directed = {(int(a), int(b)) for t in T for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    if all((int(q), int(p)) in directed for p, q in rim):
        return T
    if all((int(p), int(q)) in directed for p, q in rim):
        return T[:, ::-1].copy()
    return None


def _restore_collinear(T, rings):
    """Ear clipping drops a polygon's vertices that lie on the segment between
    their neighbours (mapbox_earcut does): put each back, splitting the
    triangle on that segment into a fan from its third corner (the dropped
    vertices lie on its edge, so the fan's triangles are the triangle's
    parts). ``T`` indexes the rings' concatenated vertices; returns the
    triangles using every vertex, or None where a dropped vertex's segment
    is no triangle's edge."""
    used = np.zeros(sum(len(r) for r in rings), bool)
    used[T.ravel()] = True
    if used.all():
        return T
    T = [list(t) for t in T]
    for r in rings:
        if not used[r].any():
            return None
        start = int(np.flatnonzero(used[r])[0])
        walk = np.roll(r, -start)
        kept = np.flatnonzero(used[walk])
        for i, j in zip(kept, np.append(kept[1:], len(walk))):
            if j - i < 2:
                continue
            a, b, between = int(walk[i]), int(walk[j % len(walk)]), [int(v) for v in walk[i + 1:j]]
            for n, t in enumerate(T):
                at = [t.index(a) if a in t else -1, t.index(b) if b in t else -1]
                if min(at) < 0:
                    continue
                c = t[3 - at[0] - at[1]]
                chain = [a] + between + [b]
                if (at[0] + 1) % 3 != at[1]:      # the triangle runs b -> a: keep its winding
                    chain = chain[::-1]
                T[n:n + 1] = [[chain[m], chain[m + 1], c] for m in range(len(chain) - 1)]
                break
            else:
                return None
    return np.array(T, np.int64)


def _fill_pair(ctx, A, B, order, smooth, mode, mutual=False):
    """A missing region bounded by loops A and B: a tube, or a cap on each.

    The tube starts from :func:`~shellrepair.fill.tube.guide_tube` (rings
    along both loops' continuation arcs; the plain zip of the two loops if
    that fails), is refined and faired like a cap with both loops' rings
    fixed, and is checked against the scan and itself; the faired tube and
    the tube held on the arcs are both tried and the valid one with the
    lower energy (``checks.ENERGY``) is kept. A guide too large for the band's
    budget (``GUIDE_SHARE``) is replaced by its faired coarse version
    resampled at the rim's spacing (:func:`_coarse_tube`). Only for loops
    that see each other both ways are crossings retried (vertices held
    around them) and, if every tube still fails, the failed tubes mended
    (the last layer) before any cap is built. The caps
    are checked against the scan and against each other. When each loop's
    arcs land on the other the valid tube is kept without building caps;
    otherwise an option that fails its checks loses, and if both pass the
    lower energy wins. While a valid tube is in hand each cap gets one
    attempt (no re-routing): a cap that crosses something there is not
    needed.

    Returns (outcomes, record): outcomes as for :func:`~shellrepair.fill.hole.fill_hole` per loop
    (the tube patch is given with A, B refers to it), record for the report.
    """
    from shellrepair.fill.bridge import MAX_REACH, continuation_arcs
    from shellrepair.fill.tube import guide_tube, tube_triangles

    t0 = time.perf_counter()
    loop = np.concatenate([A.vertices, B.vertices])
    # one budget for the band (both loops' edges): the tube's attempts after
    # its first are made only while it lasts, the caps get their shares
    budget = checks.WorkBudget(len(loop))
    # the caps are filled as the holes would be alone (``order`` as given,
    # "auto" included: each cap's own order test), not at the order the
    # tube's test chose: on a torus seen by a scanner (validation seed
    # 134226128, case 0) a 484-edge cap took the tube's default order 2
    # where its own test holes chose order 3 (the case 9.61 -> 8.74 per
    # mille). Before, only a pair found as wrapping one tube
    # (bands.wrapped_pairs) had its caps filled so.
    cap_order = order
    scan_edges = checks.edges_across(ctx, (A, B))
    face = flat_face_with_hole(ctx, A, B)
    if face is not None:
        # one flat face with a hole (the flat cap's two-loop form): harmonic
        # over the face's triangulation, hence in its plane; when it fails its
        # checks the band is filled as any other
        try:
            p = build_patch(ctx, A.id, loop, order=1, smooth=0, initial=face, energy=True,
                            max_vertices=budget.left())
            budget.spend(p)
            why = checks.check_joining(ctx, p, scan_edges, "tube")[0]
        except PatchError as exc:
            p, why = None, str(exc)
        if why is None:
            p = p.with_(option=f"flat face with a hole: with loop {B.id}, a planar opening the scan meets "
                               "edge-on around another (order 1)", hole_id=A.id, kind="flat face")
            secs = time.perf_counter() - t0
            record = {"loops": [int(A.id), int(B.id)], "kinds": [A.kind, B.kind], "tube_energy": None,
                      "caps_energy": None, "chosen": "tube", "shape": "flat face with a hole",
                      "reason": "the two loops outline one flat face with a hole, met edge-on"}
            return [Outcome(p, "", secs, []), Outcome(None, f"bridged with loop {A.id} by a flat face", secs, [])], \
                record
    held_first, note, refair = None, "", None
    if order == "auto":
        order, held_first, note, refair = band_order(ctx, (A, B))
    PA, PB = ctx.V[A.vertices], ctx.V[B.vertices]
    arcs = [continuation_arcs(ctx.V, ctx.F[ctx.ring_faces(L.vertices, 3)], L.vertices) for L in (A, B)]
    first = "along the continuation arcs"
    try:
        sigma = rim_data(ctx, loop)[0]      # the rim's edge length, as refinement reads it
        spacing, reach = float(np.mean(sigma)), MAX_REACH * max(A.diameter, B.diameter)
        Pg, Tg = guide_tube(PA, PB, *arcs, spacing=spacing, reach=reach)
    except (ValueError, IndexError, FloatingPointError):   # degenerate rims: the plain zip below
        Pg, Tg = np.zeros((0, 3)), None
    tube, why_tube = None, ""
    over = False           # the first tube alone was over the band's whole work budget
    if not (len(Pg) and np.isfinite(Pg).all()):
        # (said in the record where no other attempt says why the tube failed)
        why_tube = "the loops' continuation arcs gave no tube to start from"
    tube_faults = []       # (tube, faulty triangles, how it was started) of the tubes that failed their checks

    def attempt(first, init, o, fair=True, pinned=None, built=None):
        """(the patch if it passes its checks, the faulty triangles, the patch built);
        ``built``: a patch already built with these arguments, only checked"""
        nonlocal why_tube
        p = built
        if p is None:
            try:
                p = build_patch(ctx, A.id, loop, order=o, smooth=smooth if fair else 0, initial=init,
                                energy=fair, fair=fair, pinned=pinned, max_vertices=budget.left())
            except PatchError as exc:
                why_tube = str(exc)
                return None, np.zeros(0, np.int64), None
            budget.spend(p)
        p = p.with_(kind="tube", pinned=0 if pinned is None else len(pinned))
        why, bad = checks.check_joining(ctx, p, scan_edges, "tube")
        if why is None:
            how = f"faired order {o}" if fair else "refined, not faired"
            if pinned is not None:
                how += f", {len(pinned)} vertices held on the first tube"
            p = p.with_(option=f"tube to loop {B.id} ({first}), {how}")
            return p, bad, p
        why_tube = f"{first}: {why}"
        tube_faults.append((p, bad, first))
        return None, bad, p

    def check_tube(ctx_, p):
        return checks.check_joining(ctx_, p, scan_edges, "tube")   # (a repeated edge: no triangles to blame, not mended)

    def caps_crossing(caps):
        """Why the two caps cannot both be used, or ''."""
        why = "; ".join(f"cap of loop {L.id}: {c[1] or 'failed'}" for L, c in zip((A, B), caps) if c[0] is None)
        if not why:
            acc = Accepted()
            acc.add(caps[0][0], *corners(ctx, caps[0][0]))
            if acc.conflict(ctx, caps[1][0])[0]:
                why = "the two caps cross each other"
        return why

    # loops that see each other one way only (an island and its surround, or
    # a loop whose arcs happen to reach a neighbour): the caps first; while
    # they stand, the tube gets one attempt, for the energy comparison
    cap_faults = {}        # loop id -> failed attempts of its cap, for the last layer

    def fill_caps(share):
        """Each loop filled as a hole, within its share of the budget left
        (the last layer left for the end: only if no tube closes the band)."""
        out = []
        for L in (A, B):
            part = budget.part(share * len(L.vertices) / len(loop))
            cap_faults[L.id] = []
            out.append(fill_hole(ctx, L.id, L.vertices, cap_order, smooth, energy=True, budget=part,
                                 defer=cap_faults[L.id]))
            budget.absorb(part)
        return out

    caps = None
    lean = False
    if not mutual and mode != "always":
        caps = fill_caps(CAPS_SHARE)
        lean = not caps_crossing(caps)
    coarse = None
    if len(Pg) and np.isfinite(Pg).all() and len(Pg) > GUIDE_SHARE * budget.vertices:
        # (built here, after the caps that come first: they keep their share)
        coarse = _coarse_tube(ctx, A, B, PA, PB, arcs, spacing, reach, order, budget)
        if coarse is not None:
            Pg, Tg = coarse
            first = "along the continuation arcs, resampled on their faired coarse tube"
    if len(Pg) and np.isfinite(Pg).all():
        init = (Pg, Tg)
        # the faired tube, and the first tube itself (refined, every vertex
        # held): the arcs carry the scan's curvature across the gap, which
        # fairing can flatten; the fairer valid option is kept, so the two
        # are checked in order of energy and the second only if the first fails
        try:
            # the first tube: at most the band's whole work budget
            built = build_patch(ctx, A.id, loop, order=order, smooth=smooth, initial=init, energy=True,
                                max_vertices=int(budget.vertices))
            budget.spend(built)
        except PatchError as exc:
            why_tube, built, over = str(exc), None, isinstance(exc, OverBudget)
        faired, bad, held, hbad, hp = None, np.zeros(0, np.int64), None, np.zeros(0, np.int64), None
        q = len(built.P) if built is not None and (not lean or held_first) else 0
        if q and budget.affords(q):
            try:
                hp = build_patch(ctx, A.id, loop, order=order, smooth=smooth, initial=init, energy=True,
                                 pinned=np.arange(q))
                budget.spend(hp)
            except PatchError as exc:
                why_tube = str(exc)
        energy_of = (lambda p: p.energy[checks.ENERGY] if p.energy is not None else np.inf)
        if held_first is not None:     # the test bands' choice first, then the other
            energy_of = (lambda p: 0 if (p is hp) == held_first else 1)
        for p in sorted([x for x in (built, hp) if x is not None], key=energy_of):
            if p is built:
                faired, bad, _ = attempt(first, init, order, built=built)
                if faired is not None:
                    break
            else:
                held, hbad, _ = attempt(first, init, order, pinned=np.arange(q), built=hp)
                if held is not None:
                    break
        if q:
            free = None
            for _ in range(PIN_ROUNDS if mutual and faired is None and held is None and hbad.size and hp is not None
                           else 0):
                if not budget.affords(q):
                    break
                # a fold of the arcs (at a jag of a rim): fair only around it
                free = _pin_region(hp, hbad, free)
                held, b2, _ = attempt(first, init, order, pinned=np.setdiff1d(np.arange(q), free))
                if held is not None:
                    break
                hbad = np.union1d(hbad, b2) if b2.size else hbad
            if held is not None:
                on = "the arcs" if coarse is None else "the coarse tube"
                held = held.with_(option=f"tube to loop {B.id} ({first}), refined, held on {on}" + (
                    f" except {len(free)} vertices faired (order {order}) around a fold" if free is not None else ""))
        valid = [p for p in (faired, held) if p is not None]
        if valid:
            tube = min(valid, key=(lambda p: 0 if (p is held) == held_first else 1) if held_first is not None
                       else (lambda p: p.energy[checks.ENERGY] if p.energy is not None else np.inf))
            if refair is not None and tube is faired:
                # the energies keep the faired tube: its refined mesh faired
                # again at the order the test holes beside the loops chose
                # (band_order), kept if it passes the same checks (one
                # attempt of the tube's own size, outside the budget: the
                # tube is built already)
                try:
                    again = build_patch(ctx, A.id, loop, order=refair, smooth=smooth,
                                        initial=(faired.P, faired.T), refine=False, energy=True)
                except PatchError:
                    again = None
                if again is not None and checks.check_joining(ctx, again, scan_edges, "tube")[0] is None:
                    tube = again.with_(option=faired.option.replace(f"faired order {order}", f"faired order {refair}"),
                                       kind="tube")
        elif mutual and bad.size and built is not None:
            # hold the vertices near the crossing on the arcs (as for a cap)
            pinned = None
            for _ in range(PIN_ROUNDS):
                if not budget.affords(len(built.P)):
                    break
                pinned = _pin_region(built, bad, pinned)
                tube, b2, _ = attempt(first, init, order, pinned=pinned)
                if tube is not None:
                    break
                bad = np.union1d(bad, b2) if b2.size else bad
        if tube is None and mutual and order != 1 and not over:     # (over: so would the harmonic tube be)
            # the harmonic tube (order 1, as caps fall back to): it keeps to
            # the rim's own plane at a spike of the rim (a scan face with
            # two rim edges), where order 2 overshoots across the spike;
            # always tried once (as the first tube, at most the whole budget)
            with budget.whole():
                tube, _, _ = attempt(first, init, 1)
            tube = refair_on_harmonic(ctx, tube, order if refair is None else refair, smooth, check_tube)
    if tube is None and not lean:
        tube, _, _ = attempt("zipped", tube_triangles(PA, PB), order)
    if tube is None and mutual and mode != "always" and tube_faults:
        # each loop's arcs land on the other: the surface continues as a
        # tube, so its last layer (the failed tubes mended where they
        # cross) comes before the caps, not only after them
        notes = []
        tube = refair_on_harmonic(ctx, checks.mend_last(ctx, [(p, b, f"tube to loop {B.id} ({how})")
                                                            for p, b, how in tube_faults], notes,
                                                        check=check_tube, what="tube"),
                                  order if refair is None else refair, smooth, check_tube)
        if notes:
            why_tube += "; " + "; ".join(notes)
        tube_faults = [] if tube is None else tube_faults   # (not mended again after the caps)
    if tube is None and SEAM and not over and (caps is None or caps_crossing(caps)
                                               or not all(_stands(c.patch) for c in caps)):
        # every tube from the loops' arcs or their zip failed: the band cut
        # open along a seam and filled as one hole (seam_loop). Not where
        # the caps came first (loops that see each other one way only) and
        # stand as a hole's own patches: two disc holes of an ellipsoid,
        # paired one way, were joined by the seam's sheet, whose energy
        # beat their caps' (caps with no vertex of their own have none;
        # tests/test_fill_pictures.py). Nor where the first tube alone was
        # over the band's work budget: the seam's fill is as large.
        tube, why_seam = _seam_patch(ctx, A, B, order, smooth, scan_edges)
        if tube is None:
            why_tube += f"; cut open along a seam and filled as one hole: {why_seam}"
    seen_both_ways = tube is not None and mutual and mode != "always"
    if caps is None and not seen_both_ways:   # (seen both ways: the tube continues the surface)
        if tube is not None:    # one attempt per cap
            caps = []
            for L in (A, B):
                t1 = time.perf_counter()
                try:
                    co, test = cap_order, None
                    if co == "auto":
                        from shellrepair.fill.selftest import CANDIDATES, choose_order
                        test = choose_order(ctx, L.id, L.vertices, CANDIDATES)     # a cap is faired
                        co = int(test.order)
                    c = build_patch(ctx, L.id, L.vertices, order=co, smooth=smooth, energy=True)
                    why, _ = checks.check_patch(ctx, c)
                except PatchError as exc:
                    c, why = None, str(exc)
                if why is not None:
                    c = None
                else:
                    c = c.with_(option=OPTION_NAMES["faired"].format(order=co)
                                + ("" if test is None else f" ({test.describe()})"), choice=test, kind="faired")
                caps.append(Outcome(c, why or "", time.perf_counter() - t1, [],
                                    "" if c is not None else checks.NO_PATCH_PASSES))
        else:
            caps = fill_caps(1.0)
    if caps is None:
        secs = time.perf_counter() - t0
        e_tube = tube.energy[checks.ENERGY] if tube.energy is not None else None
        record = {"loops": [int(A.id), int(B.id)], "kinds": [A.kind, B.kind],
                  "tube_energy": None if e_tube is None else round(float(e_tube), 6), "caps_energy": None,
                  "chosen": "tube", "reason": "each loop's continuation arcs land on the other"}
        tube = tube.with_(hole_id=A.id, option=tube.option + (f" ({note})" if note else ""))
        return [Outcome(tube, "", secs, []), Outcome(None, f"bridged with loop {A.id} by a tube", secs, [])], record
    if tube is None and caps_crossing(caps):
        # the last layer, where every other option left the band open: each
        # failed cap mended, then (if a cap still fails) the failed tube
        caps = list(caps)
        for n, L in enumerate((A, B)):
            c = caps[n]
            if c.patch is None and cap_faults.get(L.id):
                notes = []
                # (faired again at the order of the cap's failed faired
                # attempts: none where the test chose order 1)
                mended = refair_on_harmonic(ctx, checks.mend_last(ctx, cap_faults[L.id], notes),
                                            max((f[0].order or 1 for f in cap_faults[L.id]), default=1), smooth)
                caps[n] = Outcome(mended, "" if mended is not None else "; ".join([c.reason] + notes),
                                  c.seconds, c.reasons + notes,
                                  "" if mended is not None else c.failure or checks.NO_PATCH_PASSES)
        if caps_crossing(caps) and tube_faults:
            notes = []
            tube = refair_on_harmonic(ctx, checks.mend_last(ctx, [(p, b, f"tube to loop {B.id} ({first})")
                                                                for p, b, first in tube_faults],
                                                            notes, check=check_tube, what="tube"),
                                      order if refair is None else refair, smooth, check_tube)
            if notes:
                why_tube += "; " + "; ".join(notes)
    why_caps = caps_crossing(caps)
    e_tube = tube.energy[checks.ENERGY] if tube is not None and tube.energy is not None else np.inf
    caps_ok = not why_caps
    e_caps = sum(c[0].energy[checks.ENERGY] if c[0] is not None and c[0].energy is not None else np.inf
                 for c in caps) if caps_ok else np.inf
    record = {"loops": [int(A.id), int(B.id)], "kinds": [A.kind, B.kind],
              "tube_energy": None if not np.isfinite(e_tube) else round(float(e_tube), 6),
              "caps_energy": None if not np.isfinite(e_caps) else round(float(e_caps), 6)}
    use_tube = tube is not None and (mode == "always" or not caps_ok or e_tube < e_caps)
    secs = time.perf_counter() - t0
    if use_tube:
        record["chosen"] = "tube"
        record["reason"] = ("--bridge always" if mode == "always" else
                            f"caps failed: {why_caps}" if not caps_ok else
                            f"tube energy {e_tube:.4g} < caps energy {e_caps:.4g}")
        tube = tube.with_(hole_id=A.id, option=tube.option + (f" ({note})" if note else ""))
        return [Outcome(tube, "", secs, []), Outcome(None, f"bridged with loop {A.id} by a tube", secs, [])], record
    record["chosen"] = "caps"
    if tube is None:
        record["reason"] = f"tube failed: {why_tube}"
    elif not np.isfinite(e_tube):
        record["reason"] = "no faired tube energy to compare (tube without interior vertices)"
    else:
        record["reason"] = f"caps energy {e_caps:.4g} <= tube energy {e_tube:.4g}"
    out = []
    for L, c in zip((A, B), caps):
        if L.kind != "hole":
            out.append(Outcome(None, "border", secs, []))
        else:
            out.append(c)
    return out, record


def _stands(patch):
    """Whether a cap stands as the hole's own patch: faired (also with no
    vertex of its own), or a flat cap on a planar opening. Not a fallback
    (the flat triangulation or the harmonic patch where the faired one
    failed, the last layer's Steiner points): on a fat torus's ragged band
    the 649-edge loop's cap was a flat triangulation, 1703 chords
    re-routed, 34.9 per mille from the truth."""
    return patch is not None and patch.kind in ("faired", "flat cap")


def seam_loop(ctx, A, B):
    """The band between loops A and B cut open into a disc: one loop that
    runs round A from its vertex nearest to B (the first such pair, so the
    same for the same scan), across the seam to that vertex of B, round B
    and back across the seam. Both seam ends appear twice; the seam is an
    edge of two of the patch's triangles, one on each side.

    Where the missing band is ragged, its loops wander round the surface
    (on a fat torus 29 % unseen by a scanner, stress seed 524575295 case
    6, the 649-edge loop's vertices span the whole section while the band
    lies within a third of it) and every tube zipped ring by ring between
    them runs into the scan (the faired one crossed 204 scan triangles,
    the one held on the arcs 4-7, mended, 33.7 per mille from the truth;
    the caps 34.9). Filled as one hole, with the hole's own layers, the
    same band is 3.84 per mille from the truth, of the truth's genus.

    Parameters
    ----------
    ctx : ScanContext
    A, B : shellrepair.holes.loops.Loop

    Returns
    -------
    loop : (len(A) + len(B) + 2,) int64
    """
    from scipy.spatial import cKDTree

    a, b = np.asarray(A.vertices, np.int64), np.asarray(B.vertices, np.int64)
    d, j = cKDTree(ctx.V[b]).query(ctx.V[a])
    i = int(np.argmin(d))
    k = int(np.asarray(j)[i])
    return np.concatenate([np.roll(a, -i), a[i:i + 1], np.roll(b, -k), b[k:k + 1]])


def _seam_patch(ctx, A, B, order, smooth, scan_edges):
    """The band filled as one hole along :func:`seam_loop` (the hole's own
    layers, at the band's order), checked as a tube; (patch, "") or
    (None, why)."""
    from shellrepair.errors import MeshError

    loop = seam_loop(ctx, A, B)
    try:
        # (the last layer's mending and Steiner points left out: their
        # failures on a pair of small loops took seconds each, and the caps
        # are there for such a pair)
        out = fill_hole(ctx, A.id, loop, order, smooth, energy=True, defer=[])
    except (MeshError, PatchError, ValueError, IndexError, FloatingPointError) as exc:
        return None, str(exc) or type(exc).__name__
    if out.patch is None:
        return None, out.reason or "no patch"
    p = out.patch.with_(kind="tube", hole_id=A.id)
    why, _ = checks.check_joining(ctx, p, scan_edges, "tube")
    if why is not None:
        return None, why
    return p.with_(option=f"the band cut open along a seam to loop {B.id} and filled as one hole: {p.option}"), ""
