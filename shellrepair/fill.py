"""Fill one hole or one band: attempts, checks and retries (step 4).

:func:`_fill_one` builds a patch with :func:`~shellrepair.patch.build_patch`,
checks it against the scan, itself and the edges the mesh has
(:func:`checks.check_patch`) and, when it crosses, re-routes chords near the
crossing, pins vertices near it to the flat triangulation, then tries the
harmonic patch and the checked flat triangulation, within a counted work
budget (:data:`HOLE_VERTICES` + :data:`HOLE_VERTICES_PER_EDGE` per rim
edge, in patch vertices; no clock is read); where no
triangulation passes, the harmonic patch on the first one, mended
(:mod:`~shellrepair.mend`) where it crosses; where that fails too, a patch
with Steiner points lifted over the scan that crosses the opening
(:mod:`~shellrepair.steiner`). :func:`_fill_pair`
offers two loops facing each other across a band a tube
(:mod:`~shellrepair.bridge`) and keeps the tube or the two caps by their
curvature-variation energy. :func:`_run_chunk` fills a run of holes (their
first attempts batched); :func:`_seed_patches` is the paper's simple shape
model (``method="seed"``).
"""

from __future__ import annotations

import contextlib
import copy
import sys
import threading
import time
from typing import NamedTuple

import numpy as np
from .lazyscipy import cKDTree

from . import checks
from .counted import CountedSetting
from .fair import umbrella_smooth

from .checks import Outcome
from .merge import _Accepted
from .context import rim_data
from .pants import PantsUnit, fill_pants, with_fallback
from .patch import HoleUnit, PatchError, _corners, _meets_edge_on, _prefill, build_patch


#: Smoothing passes of the paper's seed method when ``smooth`` is not given.
SEED_SMOOTH_PASSES = 10


def _chords_near(ctx, patch, bad):
    """Chords of the unrefined triangulation nearest to the faulty triangles."""
    k = len(patch.loop)
    C, _ = _corners(ctx, patch)
    P0 = ctx.V[patch.loop]
    c0 = P0[patch.T0].mean(axis=1)
    near = np.unique(cKDTree(c0).query(C[bad].mean(axis=1))[1])
    out = set()
    for t in patch.T0[near]:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            a, b = int(min(a, b)), int(max(a, b))
            if b - a > 1 and not (a == 0 and b == k - 1):
                out.add((a, b))
    return out


#: Rounds of re-triangulation when the flat triangulation crosses the scan.
FLAT_RETRIES = 12
#: Rounds of re-triangulation when the faired patch crosses the scan.
FAIRED_RETRIES = 3
#: Rounds of growing the region held on the flat triangulation around a crossing.
PIN_ROUNDS = 3
#: New vertices the Steiner layer (:mod:`~shellrepair.steiner`) may build
#: for a hole whose work budget the earlier options spent: it is the last
#: chance before the hole stays open, and its rounds are counted.
STEINER_VERTICES = 20_000
#: How each option is named in the report.
OPTION_NAMES = {"faired": "faired order {order}", "harmonic": "harmonic (order 1)",
                "flat cap": "flat cap: a planar opening the scan meets edge-on (order 1)"}


def _roll_rim(ctx, hole_id, loop, T0, patch, bad, smooth, budget):
    """A flat cap that crosses slanting rim faces: let the cap bend (order
    2) only near the crossing, the rest held flat; grow that region up to
    ``PIN_ROUNDS`` times."""
    free = None
    n_new = len(patch.P)
    for _ in range(PIN_ROUNDS):
        if not budget.affords(n_new):
            return None
        free = _pin_region(patch, bad, free)
        pinned = np.setdiff1d(np.arange(n_new), free)
        try:
            p = build_patch(ctx, hole_id, loop, order=2, smooth=smooth, initial=T0, pinned=pinned,
                            max_vertices=budget.left())
        except PatchError:
            return None
        budget.spend(p)
        why, b2 = checks.check_patch(ctx, p)
        if why is None:
            return p.with_(option=f"flat cap: a planar opening the scan meets edge-on, bent (order 2) along "
                                  f"{len(free)} vertices where rim faces slant across it")
        if len(p.T) == len(patch.T):
            bad = np.union1d(bad, b2)
    return None


def _pin_region(patch, bad, pinned):
    """New vertices of the faulty triangles and two rings around them
    (grown by two more rings each call), 0-based among the new vertices."""
    k = len(patch.loop)
    T = patch.T
    mark = np.zeros(k + len(patch.P), bool)
    if pinned is not None:
        mark[k + np.asarray(pinned)] = True
    mark[T[bad].ravel()] = True
    for _ in range(2):
        mark[T[mark[T].any(axis=1)].ravel()] = True
    return np.flatnonzero(mark[k:])


def _fill_one(ctx, hole_id, loop, order, smooth, energy=False, budget=None, defer=None):
    """Fill one hole; ``order="auto"`` picks order 1, 2 or 3 by test holes
    of its size cut into the scan beside it (:mod:`~shellrepair.selftest`).
    ``budget``: a :class:`checks.WorkBudget` (default: the hole's own)."""
    if order != "auto":
        return _fill_one_order(ctx, hole_id, loop, order, smooth, energy, budget, defer)
    from .selftest import DEFAULT_ORDER, OrderTest, choose_order

    t0 = time.perf_counter()
    beside = getattr(ctx, "beside", None)
    budget = budget or checks.WorkBudget(len(loop))
    fresh = copy.copy(budget)      # what an order-1 fill would start from
    # the order-2 fill first: a faired patch with no vertex of its own is
    # the same at every order (there is nothing to fair), so the candidates
    # agree and no test is needed
    deferred = None if defer is None else []     # the order-2 fill's, kept only if it is the one used
    patch, reason, secs, reasons = _fill_one_order(ctx, hole_id, loop, 2, smooth, energy, budget, deferred)
    if patch is not None and patch.steiner:
        # the last layer's patch is not faired: no order to choose, none tested
        if beside is not None:
            beside.drop_test(hole_id)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons)
    if patch is not None and len(patch.P) == 0 and patch.option == OPTION_NAMES["faired"].format(order=2):
        if defer is not None:
            defer.extend(deferred)
        if beside is not None:
            beside.drop_test(hole_id)
        test = OrderTest(DEFAULT_ORDER, why="no new vertex: every order gives this patch, not tested")
        patch = patch.with_(option=patch.option + f" ({test.describe()})", choice=test)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons)
    test = beside.take_test(hole_id, loop) if beside is not None else None
    if test is None:
        test = choose_order(ctx, hole_id, loop)
    if test.order == 1:
        patch, reason, secs, reasons = _fill_one_order(ctx, hole_id, loop, 1, smooth, energy, fresh, defer)
        if patch is not None:
            patch = patch.with_(option=patch.option + f" ({test.describe()})", choice=test)
        budget.take_over(fresh)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons)
    if defer is not None:
        defer.extend(deferred)
    if patch is None or patch.order != 2 or len(patch.P) == 0 or "held" in patch.option:
        return Outcome(patch, reason, time.perf_counter() - t0, reasons)
    if test.order == 3:
        try:
            if patch.option == OPTION_NAMES["faired"].format(order=2):
                # the first option as built: its refined triangulation is the one
                # order 3 would refine again (the fairing's first solve does not
                # read the new vertices' starting positions)
                done, p3 = beside.take_o3(hole_id, patch.T) if beside is not None and not energy else (False, None)
                if not done:
                    p3 = build_patch(ctx, hole_id, loop, order=3, smooth=smooth, initial=(patch.P, patch.T),
                                     refine=False, energy=energy)
                if p3 is not None:
                    p3 = p3.with_(T0=patch.T0, disc=patch.disc)
            else:
                p3 = build_patch(ctx, hole_id, loop, order=3, smooth=smooth, initial=patch.T0, energy=energy,
                                 max_vertices=max(budget.left(), len(patch.P)))
        except PatchError:
            p3 = None
        if p3 is not None:
            if checks.check_patch(ctx, p3)[0] is None:
                # the merge falls back on order 2 where order 3 and another hole's patch cross
                kept = patch.with_(option=patch.option + f" ({test.describe()}; order 3 and another hole's "
                                                         f"patch would cross: order 2 kept)", choice=test)
                p3 = p3.with_(option=patch.option.replace("order 2", "order 3") + f" ({test.describe()})",
                              fallback=kept, choice=test)
                return Outcome(p3, reason, time.perf_counter() - t0, reasons)
            patch = patch.with_(option=patch.option + f" ({test.describe()}; order 3 crosses the scan: order 2 kept)",
                                choice=test)
            return Outcome(patch, reason, time.perf_counter() - t0, reasons)
    patch = patch.with_(option=patch.option + f" ({test.describe()})", choice=test)
    return Outcome(patch, reason, time.perf_counter() - t0, reasons)


def band_order(ctx, loops):
    """How a tube joining two loops is faired under ``order="auto"``.

    First by test bands of the tube's own kind beside each loop
    (:func:`shellrepair.probe.tube_errors`): the candidates are the
    fairing orders and the first tube held on its continuation arcs
    (``probe.HELD``); the lowest error wins (equal errors: the default
    order, then the lower). Where no test band can be cut (the band is as
    long as the intact scan beside it, or meets another hole or a border),
    the scan cannot tell: :data:`shellrepair.selftest.DEFAULT_ORDER`, and
    the held tube against the faired one by their energies, as with a
    forced order (disc-shaped test holes beside the loops chose worse
    there: on a torus seen from a ring of views, order 3, 3.2 ‰, against
    order 2's held tube, 0.55 ‰).

    Returns
    -------
    order : int
        The fairing order (of the faired tube, and of the caps if the band
        takes caps).
    held : bool or None
        True: try the held tube first; False: the faired one; None: the
        one of lower energy first.
    note : str
        For the report.
    """
    from .probe import HELD, tube_errors
    from .selftest import CANDIDATES, DEFAULT_ORDER, best_candidate

    if len(loops) == 2:
        errs, n = tube_errors(ctx, loops[0], loops[1], tuple(CANDIDATES) + (HELD,))
        if errs:
            best = best_candidate(errs)     # (the held tube is among them only where both test bands were made)
            faired = best_candidate({o: e for o, e in errs.items() if o != HELD})
            desc = ", ".join(f"{'held' if o == HELD else f'order {o}'} {e:.3g}" for o, e in errs.items())
            return int(faired), best == HELD, f"auto: by {n} test bands beside the loops, RMS {desc}"
    return DEFAULT_ORDER, None, (f"auto: order {DEFAULT_ORDER}, no test band fits beside the loops: the scan "
                                 f"cannot tell (held or faired by energy)")


def _fill_one_order(ctx, hole_id, loop, order, smooth, energy=False, budget=None, defer=None):
    """Fill one hole, trying the options in turn.

    0. Triangulate, refine and fair; done if the patch crosses nothing.
    1. Otherwise check the flat triangulation against the
       scan; where it crosses (a peninsula of scan next to the rim),
       triangulate again with only triangles that cross no scan face
       (``scan_aware``: the search over the loop's Delaunay triangles drops
       each triangle the scan rejects); if that still crosses, forbid the
       chords near the crossing and triangulate again.
    2. Refine and fair that triangulation (order ``order``, then harmonic);
       if the faired patch crosses the scan, re-route the chords near the
       crossing and go back to 1 (at most ``FAIRED_RETRIES`` times).
    3. Otherwise, when a flat triangulation passed, the last layer first
       mends the failed faired and harmonic attempts with the fewest faults
       (as in 4: a refined, faired surface re-triangulated around its
       faults); only where that fails is the checked flat triangulation
       kept (a large opening's flat triangulation has no new vertex).
    4. If no triangulation passed (re-routing ran out of chords, rounds or
       budget), the harmonic patch on the first triangulation
       (:func:`_harmonic_last`); then the last layer mends the attempts
       with the fewest faults (:func:`checks.mend_last`).
    5. If that fails too, a patch with vertices of its own, lifted over
       the scan that crosses the opening (:func:`_steiner_last`,
       :mod:`~shellrepair.steiner`); only then does the hole stay open.

    The first faired attempt and the harmonic patch (tried at most once:
    in step 2, or else in step 4) are always made; each later one only
    within ``budget`` (a :class:`checks.WorkBudget`, default the hole's own): a
    faired retry only if a patch of the first one's size still fits the
    work budget; the rounds are counted (no clock is read). Past the
    budget the hole keeps the checked flat triangulation, or its harmonic
    patch (mended), or fails saying so.

    Returns (patch or None, reason, seconds, reasons tried).
    """
    out = _fill_by_options(ctx, hole_id, loop, order, smooth, energy, budget, defer)
    if out.patch is not None and order != 1 and getattr(ctx, "base", "auto") == "flat":
        # --base flat asked for a cap the opening cannot take: the row says why
        from .patch import edge_on_verdict

        capped, why = edge_on_verdict(ctx, loop, hole_id)
        if not capped:
            out = out._replace(patch=out.patch.with_(option=out.patch.option + f" (--base flat does not apply: {why})"))
    return out


def _fill_by_options(ctx, hole_id, loop, order, smooth, energy=False, budget=None, defer=None):
    """The options of :func:`_fill_one_order` tried in turn (its steps 0-5)."""
    t0 = time.perf_counter()
    budget = budget or checks.WorkBudget(len(loop))
    reasons = []
    avoid = set()
    flat_ok = None
    options = [("faired", order)] + ([("harmonic", 1)] if order != 1 else [])
    pre = ctx.pre_for(hole_id, loop)
    edge_on = pre.edge_on if pre is not None and pre.edge_on is not None \
        else (order != 1 and _meets_edge_on(ctx, loop, hole_id))
    if order != 1 and edge_on:
        options = [("flat cap", 1)] + options
    # the first attempt, when the chunk built and checked it already (_first_attempts)
    done = pre.first if pre is not None and pre.first is not None \
        and pre.first.key == (options[0], smooth, energy) else None
    faired_rounds = 0
    faulty = []            # (patch, faulty triangles, option) of the attempts that failed their checks
    tried = set()          # the options built (or refused by build_patch) on some triangulation
    first_flat = None      # the first round's triangulation
    blocked = False
    first = True
    scan_aware = False
    size = None            # new vertices of the first faired patch: what a faired retry costs
    # a counted number of rounds; each faired attempt after the first asks
    # the work budget (no clock: the same attempts on any machine)
    for _ in range(FLAT_RETRIES + FAIRED_RETRIES + 2):
        try:
            flat = done.flat if first and done is not None else \
                build_patch(ctx, hole_id, loop, order=1, smooth=0, refine=False, fair=False, avoid=avoid,
                            scan_aware=scan_aware)
        except PatchError as exc:
            if avoid:
                reasons.append(f"no triangulation avoids crossing the scan ({len(avoid)} chords re-routed)")
            else:
                reasons.append(f"triangulation: {exc}")
            break
        if first:  # the common case: the first option on the first triangulation is fine
            first = False
            first_flat = flat
            name0, order0 = options[0]
            tried.add(name0)
            try:
                if done is not None:
                    if done.patch is None:
                        raise PatchError(done.error)
                    patch = done.patch
                else:
                    patch = build_patch(ctx, hole_id, loop, order=order0, smooth=smooth, initial=flat.T0,
                                        energy=energy)
                size = len(patch.P)
                budget.spend(patch)
                why0, bad0 = done.check if done is not None else checks.check_patch(ctx, patch)
                faulty.append((patch, bad0, OPTION_NAMES[name0].format(order=order0)))
                if why0 is None:
                    return Outcome(patch.with_(option=OPTION_NAMES[name0].format(order=order0)), "",
                                   time.perf_counter() - t0, reasons)
                if name0 == "flat cap" and bad0.size:
                    rolled = _roll_rim(ctx, hole_id, loop, flat.T0, patch, bad0, smooth, budget)
                    if rolled is not None:
                        return Outcome(rolled, "", time.perf_counter() - t0, reasons)
                    reasons.append(f"flat cap: {why0}")
            except PatchError:
                pass
        why, bad = checks.check_patch(ctx, flat)
        if why is not None and not scan_aware:
            scan_aware = True  # again, with only triangles that cross no scan face
            continue
        if why is not None:
            blocked = checks.blocked_in_plane(ctx, hole_id, flat, bad)
            if blocked:
                reasons.append(f"flat: {why}; {blocked} scan faces cross the opening's own plane inside it, "
                               f"so no flat triangulation avoids them")
                faulty = []     # a plane region the scan crosses: no last layer (it would bend the face)
                blocked = True
                break
            more = _chords_near(ctx, flat, bad) - avoid if bad.size else set()
            if not more:
                reasons.append(f"flat: {why}")
                break
            avoid |= more
            continue
        flat_ok = flat
        retry = False
        for name, o in options:
            # the harmonic patch, the last option, is tried at most once per
            # hole (no re-routing follows it): always, like the first attempt
            last_option = name == "harmonic"
            if size is not None and not last_option and not budget.affords(size):
                reasons.append(f"{name}: not tried, {budget.describe()}")
                continue
            tried.add(name)
            try:
                patch = build_patch(ctx, hole_id, loop, order=o, smooth=smooth, initial=flat.T0, avoid=avoid,
                                    energy=energy,
                                    max_vertices=None if size is None or last_option else budget.left())
            except PatchError as exc:
                reasons.append(f"{name}: {exc}")
                continue
            size = len(patch.P) if size is None else size
            budget.spend(patch)
            why, bad = checks.check_patch(ctx, patch)
            faulty.append((patch, bad, OPTION_NAMES[name].format(order=o)))
            pinned = None
            for _grow in range(PIN_ROUNDS if why is not None and bad.size else 0):
                if not budget.affords(size):
                    break
                # hold the new vertices around the crossing on the flat triangulation
                pinned = _pin_region(patch, bad, pinned)
                try:
                    pp = build_patch(ctx, hole_id, loop, order=o, smooth=smooth, initial=flat.T0, avoid=avoid,
                                     energy=energy, pinned=pinned, max_vertices=budget.left())
                except PatchError:
                    break
                budget.spend(pp)
                w2, b2 = checks.check_patch(ctx, pp)
                if w2 is None:
                    patch, why = pp, None
                    break
                bad = np.union1d(bad, b2) if len(pp.T) == len(patch.T) else bad
            if why is None:
                option = OPTION_NAMES[name].format(order=o)
                if avoid:
                    option += f", {len(avoid)} chords re-routed"
                if pinned is not None:
                    option += f", {len(pinned)} vertices held on the flat triangulation"
                return Outcome(patch.with_(option=option), "", time.perf_counter() - t0, reasons)
            more = _chords_near(ctx, patch, bad) - avoid if bad.size else set()
            if name == "faired" and more and faired_rounds < FAIRED_RETRIES:
                faired_rounds += 1
                avoid |= more
                retry = True
                break
            reasons.append(f"{name}: {why}")
        if not retry:
            break
    else:
        reasons.append(f"the triangulation still crosses the scan after re-routing {len(avoid)} chords")
    if flat_ok is not None:
        mended = checks.mend_last(ctx, faulty, reasons) if faulty and defer is None else None
        if mended is not None:
            return Outcome(mended, "", time.perf_counter() - t0, reasons)
        flat_ok = flat_ok.with_(option="flat triangulation" + (f", {len(avoid)} chords re-routed" if avoid else ""))
        return Outcome(flat_ok, "", time.perf_counter() - t0, reasons)
    if first_flat is not None and not blocked and ("harmonic", 1) in options and "harmonic" not in tried:
        # no triangulation passed its checks, so the harmonic patch (the last
        # option, always made) was not built on one: build it on the first
        # triangulation. It bends least away from the rim, so on a large
        # opening whose flat triangulation cuts through the scan it often
        # crosses it in a few places only, which the last layer mends.
        harmonic = _harmonic_last(ctx, hole_id, loop, first_flat, smooth, energy, budget, reasons)
        if harmonic is not None:
            patch, why, bad = harmonic
            if why is None:
                return Outcome(patch, "", time.perf_counter() - t0, reasons)
            faulty.append((patch, bad, patch.option))
    if defer is not None:   # the caller runs the last layer later (a band's cap: after the tube)
        defer.extend(faulty)
        return Outcome(None, "; ".join(reasons), time.perf_counter() - t0, reasons)
    mended = checks.mend_last(ctx, faulty, reasons)
    if mended is not None:
        return Outcome(mended, "", time.perf_counter() - t0, reasons)
    patch = _steiner_last(ctx, hole_id, loop, budget, reasons)
    if patch is not None:
        return Outcome(patch, "", time.perf_counter() - t0, reasons)
    return Outcome(None, "; ".join(reasons), time.perf_counter() - t0, reasons)


def _steiner_last(ctx, hole_id, loop, budget, reasons):
    """The last layer for a single hole no other option closed: a patch
    with Steiner points lifted over the scan that crosses the opening
    (:mod:`~shellrepair.steiner`), within what is left of the hole's work
    budget; None (the cause appended to ``reasons``) where it fails."""
    from .steiner import steiner_patch

    try:
        res = steiner_patch(ctx, hole_id, loop, max_vertices=max(budget.left(), STEINER_VERTICES))
    except (ValueError, IndexError, FloatingPointError, np.linalg.LinAlgError) as exc:
        # a degenerate outline the layer's arithmetic cannot take: the hole
        # stays open as it would without the layer, saying so
        reasons.append(f"last layer: Steiner points: {type(exc).__name__}: {exc}")
        return None
    budget.count(res.spent)
    if res.patch is None:
        reasons.append(f"last layer: {res.reason}")
    return res.patch


def _harmonic_last(ctx, hole_id, loop, flat, smooth, energy, budget, reasons):
    """The harmonic patch on ``flat``'s triangulation, for a hole none of
    whose triangulations passed its checks: ``(patch, why, faulty
    triangles)`` (``why`` None when it passes), or None when it cannot be
    built (the cause appended to ``reasons``)."""
    name = OPTION_NAMES["harmonic"]
    try:
        patch = build_patch(ctx, hole_id, loop, order=1, smooth=smooth, initial=flat.T0, energy=energy)
    except PatchError as exc:
        reasons.append(f"harmonic on the first triangulation: {exc}")
        return None
    budget.spend(patch)
    why, bad = checks.check_patch(ctx, patch)
    patch = patch.with_(option=f"{name} on the first triangulation")
    if why is not None:
        reasons.append(f"{patch.option}: {why}")
    return patch, why, bad


#: Share of a band's budget the two caps get when they are filled before
#: the tube (the rest is the tube's).
CAPS_SHARE = 0.7


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
    (:func:`~shellrepair.bridge.resample_tube`): a first tube the size of
    the surface it spans. Returns ``(P, T)`` as ``guide_tube``.
    """
    from .bridge import guide_tube, resample_tube

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
    edge-on, :func:`shellrepair.patch._meets_edge_on`): a CAD part's face, a
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
    from .holes import loop_stats
    from .patch import EDGE_ON_CAD_PLANARITY, EDGE_ON_PLANARITY
    from .probe import inside_polygon

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


def _fill_pair(ctx, A, B, order, smooth, mode, mutual=False, wrapped=False):
    """A missing region bounded by loops A and B: a tube, or a cap on each.

    The tube starts from :func:`~shellrepair.bridge.guide_tube` (rings
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

    Returns (outcomes, record): outcomes as for :func:`_fill_one` per loop
    (the tube patch is given with A, B refers to it), record for the report.
    """
    from .bridge import MAX_REACH, continuation_arcs, guide_tube, tube_triangles

    t0 = time.perf_counter()
    loop = np.concatenate([A.vertices, B.vertices])
    # one budget for the band (both loops' edges): the tube's attempts after
    # its first are made only while it lasts, the caps get their shares
    budget = checks.WorkBudget(len(loop))
    # a pair found only as wrapping one tube (bridge.wrapped_pairs) may be
    # two holes that merely wrap a thin part: its caps are filled as those
    # holes would be alone (``order`` as given, "auto" included)
    cap_order = order if wrapped else None
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
                               "edge-on around another (order 1)", hole_id=A.id)
            secs = time.perf_counter() - t0
            record = {"loops": [int(A.id), int(B.id)], "kinds": [A.kind, B.kind], "tube_energy": None,
                      "caps_energy": None, "chosen": "tube", "shape": "flat face with a hole",
                      "reason": "the two loops outline one flat face with a hole, met edge-on"}
            return [Outcome(p, "", secs, []), Outcome(None, f"bridged with loop {A.id} by a flat face", secs, [])], \
                record
    held_first, note = None, ""
    if order == "auto":
        order, held_first, note = band_order(ctx, (A, B))
    cap_order = order if cap_order is None else cap_order
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
            acc = _Accepted()
            acc.add(caps[0][0], *_corners(ctx, caps[0][0]))
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
            out.append(_fill_one(ctx, L.id, L.vertices, cap_order, smooth, energy=True, budget=part,
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
            why_tube, built = str(exc), None
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
        over = built is None and "work budget" in why_tube    # the first tube alone was over: so is this
        if tube is None and mutual and order != 1 and not over:
            # the harmonic tube (order 1, as caps fall back to): it keeps to
            # the rim's own plane at a spike of the rim (a scan face with
            # two rim edges), where order 2 overshoots across the spike;
            # always tried once (as the first tube, at most the whole budget)
            with budget.whole():
                tube, _, _ = attempt(first, init, 1)
    if tube is None and not lean:
        tube, _, _ = attempt("zipped", tube_triangles(PA, PB), order)
    if tube is None and mutual and mode != "always" and tube_faults:
        # each loop's arcs land on the other: the surface continues as a
        # tube, so its last layer (the failed tubes mended where they
        # cross) comes before the caps, not only after them
        notes = []
        tube = checks.mend_last(ctx, [(p, b, f"tube to loop {B.id} ({how})") for p, b, how in tube_faults], notes,
                          check=check_tube, what="tube")
        if notes:
            why_tube += "; " + "; ".join(notes)
        tube_faults = [] if tube is None else tube_faults   # (not mended again after the caps)
    seen_both_ways = tube is not None and mutual and mode != "always"
    if caps is None and not seen_both_ways:   # (seen both ways: the tube continues the surface)
        if tube is not None:    # one attempt per cap
            caps = []
            for L in (A, B):
                t1 = time.perf_counter()
                try:
                    c = build_patch(ctx, L.id, L.vertices, order=order, smooth=smooth, energy=True)
                    why, _ = checks.check_patch(ctx, c)
                except PatchError as exc:
                    c, why = None, str(exc)
                if why is not None:
                    c = None
                else:
                    c = c.with_(option=OPTION_NAMES["faired"].format(order=order))
                caps.append(Outcome(c, why or "", time.perf_counter() - t1, []))
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
                mended = checks.mend_last(ctx, cap_faults[L.id], notes)
                caps[n] = Outcome(mended, "" if mended is not None else "; ".join([c.reason] + notes),
                                  c.seconds, c.reasons + notes)
        if caps_crossing(caps) and tube_faults:
            notes = []
            tube = checks.mend_last(ctx, [(p, b, f"tube to loop {B.id} ({first})") for p, b, first in tube_faults],
                              notes, check=check_tube, what="tube")
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


_WORKER_CTX = None


@contextlib.contextmanager
def worker_context(ctx):
    """The scan the worker processes forked within this block fill from
    (:func:`_worker` reads it: a fork shares it, nothing is pickled)."""
    global _WORKER_CTX
    _WORKER_CTX = ctx
    try:
        yield
    finally:
        _WORKER_CTX = None


def _run_unit(ctx, unit):
    if isinstance(unit, HoleUnit):
        return [_fill_one(ctx, *unit)], None
    if isinstance(unit, PantsUnit):      # three loops bounding one region
        res = fill_pants(ctx, unit)
        if res.parts is None:
            return with_fallback(unit, res.failed, [(u, _run_unit(ctx, u)) for u in unit.fallback])
        return res
    return _fill_pair(ctx, *unit)


class _First(NamedTuple):
    """A hole's first attempt, built and checked with the rest of its chunk."""
    key: tuple             # (first option, smooth, energy) it was made for
    flat: object           # the flat triangulation (Patch)
    patch: object          # the first option's patch, or None when building it failed
    error: str             # why it failed
    check: tuple           # checks.check_patch(patch)


def _first_attempts(ctx, chunk):
    """The first attempt of every single hole of the chunk, as
    :func:`_fill_one_order` makes it (flat triangulation, then the first
    option's patch), their checks against the scan batched
    (:func:`checks.check_patches`); stored in ``ctx.pre`` where
    :func:`_fill_one_order` takes them instead of making them again."""
    made = []
    for unit in chunk:
        if not isinstance(unit, HoleUnit):
            continue
        hole_id, loop = unit.hole_id, np.asarray(unit.loop, np.int64)
        pre = ctx.pre_for(hole_id, loop)
        if pre is None:
            continue
        order = 2 if unit.order == "auto" else unit.order     # "auto" starts with order 2 (_fill_one)
        first = ("faired", order)
        if order != 1 and (pre.edge_on if pre.edge_on is not None else _meets_edge_on(ctx, loop, hole_id)):
            first = ("flat cap", 1)
        try:
            flat = build_patch(ctx, hole_id, loop, order=1, smooth=0, refine=False, fair=False, avoid=set(),
                               scan_aware=False)
        except PatchError:
            continue           # _fill_one_order meets the same error
        beside = getattr(ctx, "beside", None)
        if beside is not None and unit.order == "auto" and first == ("faired", 2):
            beside.start_o3(pre, hole_id, loop, unit.smooth, flat.T0)
        try:
            patch, error = build_patch(ctx, hole_id, loop, order=first[1], smooth=unit.smooth, initial=flat.T0,
                                       energy=False), ""
        except PatchError as exc:
            patch, error = None, str(exc)
        made.append((pre, _First((first, unit.smooth, False), flat, patch, error, None)))
    verdicts = iter(checks.check_patches(ctx, [f.patch for _, f in made if f.patch is not None]))
    for pre, f in made:
        pre.keep_first(f._replace(check=next(verdicts)) if f.patch is not None else f)


#: The interpreter's thread switch interval (seconds) while a helper thread
#: works beside the fill. Both threads spend most of their time in compiled
#: kernels and solves that release the GIL, but take it back between them;
#: a thread asking for it back waits until the holder drops it, at most
#: this long. Measured beside a thread running Python code, on the 1.3M
#: two-disc case's large hole (11,847 unknowns, order 3): its factorisation
#: took 1.44x its time alone at Python's default of 5 ms and 1.03x at
#: 0.2 ms; its energy's assembly 1.76x and 1.19x.
SWITCH_SECONDS = 2e-4
def _short_interval():
    before = sys.getswitchinterval()
    sys.setswitchinterval(min(before, SWITCH_SECONDS))
    return before


#: Within a block ``with _short_switch_interval():``, the interpreter's
#: switch interval at most ``SWITCH_SECONDS``; put back when the last open
#: block ends (the helpers of overlapping fills, in any thread).
_short_switch_interval = CountedSetting(_short_interval, sys.setswitchinterval)


class HelperThread:
    """One thread that runs the calls submitted to it, the lowest key first
    (a context manager: leaving it waits for what was submitted, skipping
    what was cancelled, and puts the interpreter's switch interval and the
    BLAS libraries' global thread counts back,
    :func:`~shellrepair.blas.one_thread_everywhere`).
    The fill's helper beside a run (:class:`_Beside`)."""

    def __init__(self, name="shellrepair-beside"):
        import itertools
        import queue

        from .blas import one_thread_everywhere

        self._queue = queue.PriorityQueue()
        self._serial = itertools.count()       # ties in submission order
        self._settings = contextlib.ExitStack()
        self._settings.enter_context(_short_switch_interval())
        self._settings.enter_context(one_thread_everywhere())   # two threads' BLAS calls side by side, not in turn
        self._thread = threading.Thread(target=self._serve, name=name, daemon=True)
        self._thread.start()

    def submit(self, key, f, *args):
        """Run ``f(*args)`` on the thread, before every call of a larger
        ``key`` (a tuple) not begun; returns its
        :class:`concurrent.futures.Future`."""
        from concurrent.futures import Future

        future = Future()
        self._queue.put((tuple(key), next(self._serial), future, f, args))
        return future

    def _serve(self):
        while True:
            _, _, future, f, args = self._queue.get()
            if future is None:
                return
            if not future.set_running_or_notify_cancel():
                continue                               # cancelled before it began
            try:
                future.set_result(f(*args))
            except BaseException as exc:               # handed to whoever takes the result
                future.set_exception(exc)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._queue.put(((float("inf"),), next(self._serial), None, None, None))
        self._thread.join()
        self._settings.close()


class _Stolen:
    """A result computed on the fill's thread in place of the helper's
    (:meth:`_Beside._steal`): its value, or the exception it raised, given
    back when taken, as a future's."""

    def __init__(self, f, *args):
        try:
            self.value, self.error = f(*args), None
        except Exception as exc:
            self.value, self.error = None, exc

    def cancel(self):
        return False

    def result(self):
        if self.error is not None:
            raise self.error
        return self.value


class _Failed:
    """A build on the helper thread raised :class:`PatchError`."""


class _Beside:
    """Work a helper thread does beside a run's fills, for its
    ``order="auto"`` holes (:func:`_run_chunk` with a ``pool``):

    * each hole's order test (:func:`~shellrepair.selftest.choose_order`),
      all queued at once, the longest rims first (ties in hole order);
    * each hole's order-3 patch, started by :func:`_first_attempts` as soon
      as the hole's first triangulation is refined (:meth:`start_o3`),
      built only where the hole's test asks for order 3. :func:`_fill_one`
      builds that same patch from the order-2 fill's triangulation, which
      is this refined one where the first option passed (the fairing's
      first solve does not read the new vertices' starting positions).

    The fill takes each result (:meth:`take_test`, :meth:`take_o3`), or
    cancels what the helper has not begun and does it itself: the output
    is the same bits with or without the helper (the helper's work reads
    only the scan and the batch's first-attempt work; its compiled
    kernels and solves release the GIL, and its BLAS calls run on its own
    thread as the fill's do)."""

    def __init__(self, ctx, chunk, pool, memo=None):
        from .selftest import choose_order

        self.pool = pool
        self.ctx = ctx
        self.memo = memo
        self.helper = ctx.for_helper()
        self.tests = {}        # hole id -> (loop, future of its OrderTest)
        self.o3 = {}           # hole id -> (refined T, future of its order-3 Patch, None or _Failed)
        self.place = {}        # hole id -> its place in the helper's queue: a hole's test, then its
        # order-3 patch, before the next hole's test; the largest rims first
        # (their tests and order-3 patches are the longest work: the fill's
        # thread runs the small holes' tests itself when it reaches them,
        # :meth:`take_test`, instead of waiting at the end for a large one)
        auto = [(i, u) for i, u in enumerate(chunk) if isinstance(u, HoleUnit) and u.order == "auto"]
        ranked = sorted(auto, key=lambda iu: (-len(iu[1].loop), iu[0]))
        self.place.update((u.hole_id, rank) for rank, (_, u) in enumerate(ranked))
        for _, u in auto:
            loop = np.asarray(u.loop, np.int64)
            self.tests[u.hole_id] = (loop, pool.submit((self.place[u.hole_id], 0), self._on_helper, choose_order,
                                                       self.helper, u.hole_id, loop))

    def _on_helper(self, f, *args):
        from .blas import one_thread
        from .fair import first_solve_memo

        first_solve_memo(self.memo)     # the run's first solves, as the fill's thread sees them
        try:
            with one_thread():          # this thread's BLAS calls on this thread, as the fill's are
                return f(*args)
        finally:
            first_solve_memo(False)

    def drop_test(self, hole_id):
        """The hole needs no order test: cancel it if the helper has not begun it."""
        got = self.tests.pop(hole_id, None)
        if got is not None and not isinstance(got[1], _Stolen):
            got[1].cancel()

    def take_test(self, hole_id, loop):
        """The hole's order test, or None where it has not begun (cancelled:
        the caller runs it) or was made for another loop. While the helper
        is still on it, the caller runs the next tests the helper has not
        begun (:meth:`_steal`)."""
        got = self.tests.pop(hole_id, None)
        if got is None:
            return None
        made_for, future = got
        if not np.array_equal(made_for, loop):
            future.cancel()
            return None
        if isinstance(future, _Stolen):
            return future.result()
        if future.cancel():
            return None
        while not future.done() and self._steal():
            pass
        return future.result()

    def _steal(self):
        """Run here (the fill's thread) the first test the helper has not
        begun, kept for :meth:`take_test`; False when there is none."""
        from .selftest import choose_order

        for hole_id, (loop, future) in self.tests.items():    # in hole order
            if not isinstance(future, _Stolen) and future.cancel():
                self.tests[hole_id] = (loop, _Stolen(choose_order, self.ctx, hole_id, loop))
                return True
        return False

    def start_o3(self, pre, hole_id, loop, smooth, T0):
        """Start the order-3 patch of a hole whose first option is the
        order-2 fairing of ``T0``: refine ``T0`` here, as
        :func:`~shellrepair.patch.build_patch` would (kept in ``pre``, which
        the order-2 build then reads), and fair it at order 3 on the
        helper once the hole's test asks for order 3."""
        from .patch import refine_patch

        got = self.tests.get(hole_id)
        if got is None or pre.T0 is None or not np.array_equal(T0, pre.T0):
            return
        sigma, _, forbidden = pre.rim
        origin, scale, Pl0 = pre.frame
        Pl, T = pre.refined_once(lambda: refine_patch(Pl0, pre.T0, sigma / scale, len(loop), forbidden))
        P = origin + scale * Pl[len(loop):]
        test = got[1]

        def build():
            if test.cancelled() or test.exception() is not None or test.result().order != 3:
                return None
            try:
                return build_patch(self.helper, hole_id, loop, order=3, smooth=smooth, initial=(P, T), refine=False)
            except PatchError:
                return _Failed

        self.o3[hole_id] = (T, self.pool.submit((self.place[hole_id], 1), self._on_helper, build))

    def take_o3(self, hole_id, T):
        """(True, the order-3 patch or None where building it failed), or
        (False, None) where the caller builds it (not begun, not asked
        for, or made from another triangulation)."""
        got = self.o3.pop(hole_id, None)
        if got is None:
            return False, None
        made_from, future = got
        if future.cancel() or not np.array_equal(made_from, T):
            return False, None
        p3 = future.result()
        if p3 is None:
            return False, None
        return True, (None if p3 is _Failed else p3)

    def cancel(self):
        """Cancel what has not begun (a unit raised, or a result not taken)."""
        for _, future in list(self.tests.values()) + list(self.o3.values()):
            future.cancel()
        self.tests, self.o3 = {}, {}


def _run_chunk(ctx, chunk, on_unit=None, pool=None):
    """Fill a run of consecutive units (their first attempts batched);
    ``on_unit()`` is called after each. ``pool``: a thread pool whose
    thread works beside the fills on the ``order="auto"`` holes
    (:class:`_Beside`; the same output as without)."""
    from .fair import first_solve_memo

    try:
        memo = first_solve_memo(True)     # an order-3 fill of order="auto" repeats its order-2 fill's first solve
        ctx.start_run(_Beside(ctx, chunk, pool, memo) if pool is not None else None)
        _prefill(ctx, chunk)
        _first_attempts(ctx, chunk)
        out = []
        for u in chunk:
            out.append(_run_unit(ctx, u))
            if on_unit is not None:
                on_unit()
        return out
    finally:
        ctx.end_run()
        first_solve_memo(False)


def _worker(chunk):
    return _run_chunk(_WORKER_CTX, chunk)


def _seed_patches(ctx, holes, passes, results):
    """The paper's method: close, smooth a duplicate of the whole mesh, take the filled region."""
    built = []
    for h in holes:
        try:
            p = build_patch(ctx, h.id, h.vertices, order=1, smooth=0, refine=True, fair=False)
            built.append(p)
        except PatchError as exc:
            results[h.id] = f"seed: {exc}"
    n = ctx.n
    newP = [p.P for p in built]
    base = n
    Fs = [ctx.F]
    for p in built:
        Fs.append(p.global_faces(base))
        base += len(p.P)
    X = np.vstack([ctx.V] + newP) if newP else ctx.V.copy()
    Fall = np.vstack(Fs)
    if base > n:
        origin = ctx.V.mean(axis=0)
        X = umbrella_smooth(X - origin, Fall, passes, (0.5,)) + origin  # the whole duplicate
    out = {}
    base = n
    for p in built:
        p = p.with_(P=X[base:base + len(p.P)])
        base += len(p.P)
        why, _ = checks.check_patch(ctx, p)
        if why is None:
            out[p.hole_id] = p.with_(option=f"seed, {passes} smoothing passes")
        else:
            results[p.hole_id] = f"seed: {why}"
    return out
