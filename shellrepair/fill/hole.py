"""Fill one hole: attempts, checks and retries (step 4).

:func:`fill_hole` builds a patch with :func:`~shellrepair.fill.patch.build_patch`,
checks it against the scan, itself and the edges the mesh has
(:func:`checks.check_patch`) and, when it crosses, re-routes chords near the
crossing, pins vertices near it to the flat triangulation, then tries the
harmonic patch and the checked flat triangulation, within a counted work
budget (:data:`HOLE_VERTICES` + :data:`HOLE_VERTICES_PER_EDGE` per rim
edge, in patch vertices; no clock is read); where no
triangulation passes, the harmonic patch on the first one, mended
(:mod:`~shellrepair.fill.mend`) where it crosses; where that fails too, a patch
with Steiner points lifted over the scan that crosses the opening
(:mod:`~shellrepair.fill.steiner`). :func:`_seed_patches` is the paper's simple
shape model (``method="seed"``). Two loops facing each other across a band
are filled by :mod:`shellrepair.fill.band_fill`; a run of units (their first
attempts batched) by :mod:`shellrepair.fill.runs`.
"""

from __future__ import annotations

import copy
import time

import numpy as np

from shellrepair.fill import checks
from shellrepair.fill.checks import Outcome
from shellrepair.fill.fair import umbrella_smooth
from shellrepair.fill.patch import PatchError, _meets_edge_on, build_patch, corners
from shellrepair.lazyscipy import cKDTree

__all__ = ["fill_hole", "fill_hole_at_order", "band_order", "pooled_with_band", "refair_on_harmonic",
           "SEED_SMOOTH_PASSES", "REFAIR_ROUNDS"]

#: Smoothing passes of the paper's seed method when ``smooth`` is not given.
SEED_SMOOTH_PASSES = 10


def _chords_near(ctx, patch, bad):
    """Chords of the unrefined triangulation nearest to the faulty triangles."""
    k = len(patch.loop)
    C, _ = corners(ctx, patch)
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
#: Rounds of :func:`refair_on_harmonic`, each holding two more rings around
#: the new faults on the harmonic patch (a work bound: at most this many
#: fairings of the patch's own size, no refinement; a scanner-hidden torus
#: band needed 6).
REFAIR_ROUNDS = 6
#: New vertices the Steiner layer (:mod:`~shellrepair.fill.steiner`) may build
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
                                  f"{len(free)} vertices where rim faces slant across it", kind="flat cap",
                           pinned=len(pinned))
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


def fill_hole(ctx, hole_id, loop, order, smooth, energy=False, budget=None, defer=None):
    """Fill one hole; ``order="auto"`` picks order 1, 2 or 3 by test holes
    of its size cut into the scan beside it (:mod:`~shellrepair.fill.selftest`).

    Parameters
    ----------
    ctx : ScanContext
        The scan (:class:`shellrepair.mesh.index.ScanContext`).
    hole_id : int
        The loop's id in the scan's hole detection.
    loop : (k,) int64
        The rim's vertex indices, in boundary half-edge order.
    order : 1, 2, 3 or "auto"
        Fairing order of the first option.
    smooth : int
        Smoothing passes of the patch (0: none).
    energy : bool
        Measure each patch's energies (for the report).
    budget : checks.WorkBudget, optional
        The work allowed (default: the hole's own, from its rim length).
    defer : list, optional
        Where the failed attempts the last layer would mend are put, for
        the caller to mend later (a band's caps, after the tube); None:
        mended here.

    Returns
    -------
    Outcome
        ``(patch or None, reason, seconds, reasons tried, failure)``
        (:class:`shellrepair.fill.checks.Outcome`).
    """
    if order == "flat":
        t0 = time.perf_counter()
        flat = _flat_patch(ctx, hole_id, loop)
        if flat is not None:
            return Outcome(flat.with_(option="flat triangulation"), "", time.perf_counter() - t0, [])
        out = fill_hole_at_order(ctx, hole_id, loop, 1, smooth, energy, budget, defer)
        if out.patch is not None:
            out = out._replace(patch=out.patch.with_(option=out.patch.option + " (the flat triangulation crosses "
                                                                                 "the scan)"))
        return out
    if order != "auto":
        return fill_hole_at_order(ctx, hole_id, loop, order, smooth, energy, budget, defer)
    from shellrepair.fill.selftest import DEFAULT_ORDER, FLAT, OrderTest, choose_order

    t0 = time.perf_counter()
    beside = getattr(ctx, "beside", None)
    budget = budget or checks.WorkBudget(len(loop))
    fresh = copy.copy(budget)      # what an order-1 fill would start from
    # the order-2 fill first: a faired patch with no vertex of its own is
    # the same at every order (there is nothing to fair), so the candidates
    # agree and no test is needed
    deferred = None if defer is None else []     # the order-2 fill's, kept only if it is the one used
    patch, reason, secs, reasons, failure = fill_hole_at_order(ctx, hole_id, loop, 2, smooth, energy, budget,
                                                               deferred)
    if patch is not None and patch.kind in ("steiner", "flat cap"):
        # the last layer's patch, and a flat cap (a CAD face's outline, or
        # an opening the user called a flat base), are not faired: no order
        # to choose, none tested (an order-1 choice would replace the cap by
        # a faired patch, off its plane by round-off)
        if beside is not None:
            beside.drop_test(hole_id)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)
    if patch is not None and len(patch.P) == 0 and patch.kind == "faired" and patch.order == 2 and patch.plain:
        if defer is not None:
            defer.extend(deferred)
        if beside is not None:
            beside.drop_test(hole_id)
        test = OrderTest(DEFAULT_ORDER, why="no new vertex: every order gives this patch, not tested")
        patch = patch.with_(option=patch.option + f" ({test.describe()})", choice=test)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)
    test = beside.take_test(hole_id, loop) if beside is not None else None
    if test is None:
        test = choose_order(ctx, hole_id, loop)
    if test.order == FLAT:
        flat = _flat_patch(ctx, hole_id, loop)
        if flat is not None:
            budget.take_over(fresh)
            flat = flat.with_(option=f"flat triangulation ({test.describe()})", choice=test)
            return Outcome(flat, "", time.perf_counter() - t0, [])
        if patch is not None:
            patch = patch.with_(option=patch.option + f" ({test.describe()}; the flat triangulation crosses the "
                                                      f"scan: order 2 kept)", choice=test)
        if defer is not None:
            defer.extend(deferred)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)
    if test.order == 1:
        patch, reason, secs, reasons, failure = fill_hole_at_order(ctx, hole_id, loop, 1, smooth, energy, fresh,
                                                                   defer)
        if patch is not None:
            patch = patch.with_(option=patch.option + f" ({test.describe()})", choice=test)
        budget.take_over(fresh)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)
    if defer is not None:
        defer.extend(deferred)
    if patch is None or patch.order != 2 or len(patch.P) == 0 or patch.pinned:
        if patch is not None and test.order == 3:
            # (order 3 is built on a plain order-2 patch only)
            why = ("the order-2 patch holds vertices where it crossed" if patch.pinned
                   else "the order-2 fill gave another patch")
            patch = patch.with_(option=patch.option + f" ({test.describe()}; order 3 not tried: {why})",
                                choice=test)
        elif patch is not None:
            patch = patch.with_(option=patch.option + f" ({test.describe()})", choice=test)
        return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)
    if test.order == 3:
        try:
            if patch.kind == "faired" and patch.plain:
                # the first option as built: its refined triangulation is the one
                # order 3 would refine again (the fairing's first solve does not
                # read the new vertices' starting positions)
                done, p3 = beside.take_o3(hole_id, patch.T) if beside is not None and not energy else (False, None)
                if not done:
                    p3 = build_patch(ctx, hole_id, loop, order=3, smooth=smooth, initial=(patch.P, patch.T),
                                     refine=False, energy=energy)
                if p3 is not None:
                    p3 = p3.with_(T0=patch.T0, disc=patch.disc, kind="faired")
            else:
                p3 = build_patch(ctx, hole_id, loop, order=3, smooth=smooth, initial=patch.T0, energy=energy,
                                 max_vertices=max(budget.left(), len(patch.P)), chords=True).with_(kind="faired")
        except PatchError:
            p3 = None
        departs = _departs(ctx, hole_id, loop, smooth, patch, p3) if p3 is not None else None
        if departs is not None:
            patch = patch.with_(option=patch.option + f" ({test.describe()}; order 3 departs from order 2 more than "
                                                      f"order 1 does, {departs[1]:.3g} > {departs[0]:.3g}: "
                                                      f"order 2 kept)", choice=test)
            return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)
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
            return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)
    patch = patch.with_(option=patch.option + f" ({test.describe()})", choice=test)
    return Outcome(patch, reason, time.perf_counter() - t0, reasons, failure)


def _flat_patch(ctx, hole_id, loop):
    """The rim's flat triangulation (no new vertex, kind "flat"): its
    minimum-weight triangulation (``build_patch(..., minimal=True)``; the
    patch is the triangulation, so not the projection's Delaunay the faired
    fills start from), where it passes the fill's checks, else None."""
    try:
        flat = build_patch(ctx, hole_id, loop, order=1, smooth=0, refine=False, fair=False, minimal=True)
    except PatchError:
        return None
    if checks.check_patch(ctx, flat)[0] is not None:
        return None
    return flat.with_(kind="flat")


def _departs(ctx, hole_id, loop, smooth, p2, p3):
    """Whether the order-3 patch departs from the order-2 one more than the
    order-1 patch does, on the same vertices: (RMS |P2 - P1|, RMS |P3 - P2|)
    where it does, else None.

    Orders 1, 2 and 3 carry the rim on into the hole to ever higher
    derivatives; where the scan at the rim is smooth at the hole's size,
    each order corrects the one before by less than that one corrected its
    own predecessor (on the unseen strip under a torus's tube, hole 1 of
    case 6 of design seed 12, order 2 lies 0.066 from order 1 and order 3
    0.0063 from order 2, and order 3 is 11x truer).
    Where order 3 moves further from order 2 than order 2 from order 1, it
    carries third derivatives of the rim's scan far beyond it, whatever test
    holes elsewhere said: on a disc of 188 rim edges in a Nefertiti
    (case 1 of seed 270074373) the test holes rated order 3 first (9.61
    against order 2's 11.2), and its patch bulged 23.9 from order 2's against
    order 1's 8.06 from it, 30.4 per mille from the truth where order 2 gives
    0.838. Measured on the patches alone, no constant: the comparison
    follows the hole, not a threshold.
    """
    if len(p3.P) != len(p2.P) or not len(p2.P):
        return None
    try:
        p1 = build_patch(ctx, hole_id, loop, order=1, smooth=smooth, initial=(p2.P, p2.T), refine=False)
    except PatchError:
        return None
    if len(p1.P) != len(p2.P):
        return None
    d12 = float(np.sqrt(((p1.P - p2.P) ** 2).sum(axis=1).mean()))
    d23 = float(np.sqrt(((p3.P - p2.P) ** 2).sum(axis=1).mean()))
    return (d12, d23) if d23 > d12 else None


def band_order(ctx, loops):
    """How a tube joining two loops is faired under ``order="auto"``.

    First by test bands of the tube's own kind beside each loop
    (:func:`shellrepair.fill.band_test.tube_errors`): the candidates are the
    fairing orders and the first tube held on its continuation arcs
    (``band_test.HELD``); the lowest error wins (equal errors: the default
    order, then the lower); the verdict needs a test band beside each loop
    (``band_test.MIN_BANDS``). Where one test band can be cut and no test
    hole fits beside the loops, that band's verdict is taken, as a hole
    whose scales give one test hole takes its (on a thin torus's unseen
    band, case 15 of design seed 14, the one band rated order 3 4x truer
    than order 2; order 3 gives 1.20 per mille there, order 2 12.2). Where
    fewer can be cut otherwise (the band is as long as
    the intact scan beside it, or meets another hole or a border), the scan
    cannot tell: :data:`shellrepair.fill.selftest.DEFAULT_ORDER`, and
    the held tube against the faired one by their energies, as with a
    forced order; where those energies keep the faired tube, it is faired
    again at the order that test holes of each loop's size beside it
    choose (``refair``, :func:`shellrepair.fill.selftest.choose_order_beside`);
    where one test band was cut, it is pooled with those test holes
    (:func:`pooled_with_band`): each test weighs alike, so a band that
    tells the orders far apart is not outvoted by test holes that rate them
    alike, and a band that rates them alike leaves the verdict to the test
    holes (on a star's band, case 12 of seed 717865330, the one band rated
    order 3 7x truer than order 2, 0.00098 against 0.0068, and five test
    holes rated the two alike, 0.00171 and 0.00173: the test holes alone
    took order 2, 3.42 per mille, where order 3 gives 0.506).
    The test holes do not judge the held tube: on a torus seen from a ring
    of views they chose order 3, 3.2 ‰, where order 2's energies hold the
    tube, 0.55 ‰ (tests/test_bands.py, ring 3); on a fat torus's unseen
    band (development seed 733 case 14) order 2's faired tube gave 21.8 ‰,
    the test holes' order 3 10.1.

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
    refair : int or None
        The order to fair the tube at again where the energies keep the
        faired one (None: ``order``'s faired tube stays).
    """
    from shellrepair.fill.band_test import HELD, MIN_BANDS, tube_errors
    from shellrepair.fill.selftest import CANDIDATES, DEFAULT_ORDER, best_candidate, choose_order_beside

    n = 0
    if len(loops) == 2:
        errs, n = tube_errors(ctx, loops[0], loops[1], tuple(CANDIDATES) + (HELD,))
        if errs and n >= MIN_BANDS:
            best = best_candidate(errs)     # (the held tube is among them only where both test bands were made)
            faired = best_candidate({o: e for o, e in errs.items() if o != HELD})
            desc = ", ".join(f"{'held' if o == HELD else f'order {o}'} {e:.3g}" for o, e in errs.items())
            return int(faired), best == HELD, f"auto: by {n} test bands beside the loops, RMS {desc}", None
    test = choose_order_beside(ctx, loops)
    if n and errs and not test.errors:
        # one test band, and no test hole beside the loops: the band's
        # verdict, as a hole whose scales give one test hole takes its
        # verdict (probe.probe_errors), rather than the default
        faired = best_candidate({o: e for o, e in errs.items() if o != HELD})
        desc = ", ".join(f"order {o} {e:.3g}" for o, e in errs.items() if o != HELD)
        return int(faired), None, (f"auto: order {int(faired)}, by {n} test band beside the loops (fewer than "
                                   f"{MIN_BANDS}, and no test hole beside them), RMS {desc}: held or faired by "
                                   f"energy"), None
    pooled = bool(n and errs and test.errors)
    if pooled:
        test = pooled_with_band(errs, test)
    refair = int(test.order) if test.errors and test.order != DEFAULT_ORDER else None
    why = "no test band fits beside the loops" if n == 0 else \
        f"{n} test band beside the loops, fewer than {MIN_BANDS}"
    return DEFAULT_ORDER, None, (f"auto: order {DEFAULT_ORDER}, {why}: held or "
                                 f"faired by energy" + ("" if refair is None else f"; faired, at the order of "
                                                        f"{_tests_beside(test, pooled)}, {refair}")), refair


def pooled_with_band(band, test):
    """One test band's errors pooled with those of the test holes beside a
    tube's loops: per candidate, the geometric mean over every test of its
    RMS (each test weighs alike, as :class:`shellrepair.fill.probe.Pooled`
    pools test holes), the band counting as one test and the test holes'
    pooled errors as ``test.probes`` tests; only the candidates both rate
    (one band does not judge the held tube).

    Parameters
    ----------
    band : dict of (int or str) -> float
        The band's RMS per candidate (:func:`shellrepair.fill.band_test.tube_errors`).
    test : shellrepair.fill.selftest.OrderTest
        The test holes beside the loops, with errors
        (:func:`shellrepair.fill.selftest.choose_order_beside`).

    Returns
    -------
    test : shellrepair.fill.selftest.OrderTest
        The order of lowest pooled error, the pooled errors, and
        ``probes`` counting the band too.
    """
    from shellrepair.fill.selftest import OrderTest, best_candidate

    k = int(test.probes)
    # (an error of exactly 0, a refill that restores the scan, counts as
    # 1e-300, as Pooled counts it: no log of 0)
    pooled = {o: float(np.exp((np.log(max(band[o], 1e-300)) + k * np.log(max(e, 1e-300))) / (1 + k)))
              for o, e in test.errors.items() if o in band}
    return OrderTest(int(best_candidate(pooled)), errors=pooled, probes=k + 1, scale=test.scale)


def _tests_beside(test, pooled):
    """What decided a tube's refairing, for the report: the test holes
    beside its loops, and the test band where it was pooled with them."""
    if pooled:
        return f"{test.probes - 1} test holes beside them pooled with the test band"
    return f"{test.probes} test holes beside them"


def fill_hole_at_order(ctx, hole_id, loop, order, smooth, energy=False, budget=None, defer=None):
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
       :mod:`~shellrepair.fill.steiner`); only then does the hole stay open.

    The first faired attempt and the harmonic patch (tried at most once:
    in step 2, or else in step 4) are always made; each later one only
    within ``budget`` (a :class:`checks.WorkBudget`, default the hole's own): a
    faired retry only if a patch of the first one's size still fits the
    work budget; the rounds are counted (no clock is read). Past the
    budget the hole keeps the checked flat triangulation, or its harmonic
    patch (mended), or fails saying so.

    Parameters
    ----------
    ctx : ScanContext
        The scan (:class:`shellrepair.mesh.index.ScanContext`).
    hole_id : int
        The loop's id in the scan's hole detection.
    loop : (k,) int64
        The rim's vertex indices, in boundary half-edge order.
    order : 1, 2, 3
        Fairing order of the first option.
    smooth : int
        Smoothing passes of the patch (0: none).
    energy : bool
        Measure each patch's energies (for the report).
    budget : checks.WorkBudget, optional
        The work allowed (default: the hole's own, from its rim length).
    defer : list, optional
        Where the failed attempts the last layer would mend are put, for
        the caller to mend later (a band's caps, after the tube); None:
        mended here.

    Returns
    -------
    Outcome
        ``(patch or None, reason, seconds, reasons tried, failure)``
        (:class:`shellrepair.fill.checks.Outcome`; ``failure`` one of
        :data:`shellrepair.fill.checks.FAILURES` where no patch passed).
    """
    out = _fill_by_options(ctx, hole_id, loop, order, smooth, energy, budget, defer)
    if out.patch is not None and order != 1 and getattr(ctx, "base", "auto") == "flat":
        # --base flat asked for a cap the opening cannot take: the row says why
        from shellrepair.fill.patch import edge_on_verdict

        capped, why = edge_on_verdict(ctx, loop, hole_id)
        if not capped:
            out = out._replace(patch=out.patch.with_(option=out.patch.option + f" (--base flat does not apply: {why})"))
    return out


def _fill_by_options(ctx, hole_id, loop, order, smooth, energy=False, budget=None, defer=None):
    """The options of :func:`fill_hole_at_order` tried in turn (its steps 0-5)."""
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
    # the first attempt, when the chunk built and checked it already (first_attempts)
    done = pre.first if pre is not None and pre.first is not None \
        and pre.first.key == (options[0], smooth, energy) else None
    faired_rounds = 0
    faulty = []            # (patch, faulty triangles, option) of the attempts that failed their checks
    tried = set()          # the options built (or refused by build_patch) on some triangulation
    first_flat = None      # the first round's triangulation
    blocked = False
    first = True
    scan_aware = False
    over_budget = False    # an option not tried for the work budget
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
                                        energy=energy, chords=name0 == "faired")
                patch = patch.with_(kind=name0)
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
                over_budget = True
                continue
            tried.add(name)
            try:
                patch = build_patch(ctx, hole_id, loop, order=o, smooth=smooth, initial=flat.T0, avoid=avoid,
                                    energy=energy, chords=name == "faired",
                                    max_vertices=None if size is None or last_option else budget.left())
            except PatchError as exc:
                reasons.append(f"{name}: {exc}")
                continue
            patch = patch.with_(kind=name, rerouted=len(avoid))
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
                                     energy=energy, pinned=pinned, max_vertices=budget.left(),
                                     chords=name == "faired").with_(kind=name, rerouted=len(avoid),
                                                                    pinned=len(pinned))
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
                return Outcome(refair_on_harmonic(ctx, patch.with_(option=option), order, smooth, energy=energy), "",
                               time.perf_counter() - t0, reasons)
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
            return Outcome(refair_on_harmonic(ctx, mended, order, smooth, energy=energy), "", time.perf_counter() - t0,
                           reasons)
        flat_ok = flat_ok.with_(option="flat triangulation" + (f", {len(avoid)} chords re-routed" if avoid else ""),
                                kind="flat", rerouted=len(avoid))
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
                return Outcome(refair_on_harmonic(ctx, patch, order, smooth, energy=energy), "",
                               time.perf_counter() - t0, reasons)
            faulty.append((patch, bad, patch.option))
    if defer is not None:   # the caller runs the last layer later (a band's cap: after the tube)
        defer.extend(faulty)
        return Outcome(None, "; ".join(reasons), time.perf_counter() - t0, reasons,
                       checks.WORK_BUDGET if over_budget else checks.NO_PATCH_PASSES)
    mended = checks.mend_last(ctx, faulty, reasons)
    if mended is not None:
        return Outcome(refair_on_harmonic(ctx, mended, order, smooth, energy=energy), "", time.perf_counter() - t0,
                       reasons)
    patch, failure = _steiner_last(ctx, hole_id, loop, budget, reasons)
    if patch is not None:
        return Outcome(patch, "", time.perf_counter() - t0, reasons)
    if failure == checks.NO_PATCH_PASSES and over_budget:
        failure = checks.WORK_BUDGET
    return Outcome(None, "; ".join(reasons), time.perf_counter() - t0, reasons, failure)


def refair_on_harmonic(ctx, patch, order, smooth, check=None, energy=True):
    """A harmonic patch, kept where the hole's order failed, faired again at that order.

    Where the patch faired at ``order`` crosses the scan or itself (often a
    few triangles at a spike of the rim, which no re-triangulation of their
    surroundings mends), the hole falls back on the harmonic patch (order
    1), which keeps to the rim's plane: a membrane. On a torus whose
    underside a scanner missed, the harmonic tube ran straight across the
    missing arc of the torus's section, 29.1 per mille from the truth, where
    the order-2 tube that failed its checks by one triangle lay 5.5 from it.
    So the harmonic patch's own mesh (mended where the last layer mended it)
    is faired again at ``order``; where that fairing fails its checks, the
    vertices of its faulty triangles and two rings around them are held
    where the harmonic patch has them, the region growing by two rings a
    round (:data:`REFAIR_ROUNDS`). The first fairing that passes is kept;
    if none does, the harmonic patch is.

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
    patch : shellrepair.fill.patch.Patch or None
        Only a harmonic patch or tube (``patch.order`` 1) with new vertices is faired again.
    order : int
        The order the hole's faired attempts were made at (1: nothing to do).
    smooth : int
    check : callable, optional
        ``check(ctx, patch) -> (why or None, faulty triangles)``; default
        :func:`shellrepair.fill.checks.check_patch`.
    energy : bool
        Measure the new patch's energies.

    Returns
    -------
    patch : shellrepair.fill.patch.Patch or None
        Faired again (kind ``faired``, or ``tube``), or ``patch`` itself.
    """
    if (patch is None or order not in (2, 3) or patch.order != 1 or patch.kind not in ("harmonic", "tube")
            or not len(patch.P)):
        return patch
    check = checks.check_patch if check is None else check
    kind = "tube" if patch.kind == "tube" else "faired"
    region = None
    for _ in range(REFAIR_ROUNDS):
        try:
            again = build_patch(ctx, patch.hole_id, patch.loop, order=order, smooth=smooth,
                                initial=(patch.P, patch.T), refine=False, energy=energy, pinned=region)
        except PatchError:
            return patch
        again = again.with_(kind=kind, T0=patch.T0, disc=patch.disc, pinned=0 if region is None else len(region),
                            mended=patch.mended, rerouted=patch.rerouted)
        why, bad = check(ctx, again)
        if why is None:
            held = "" if region is None else f", {len(region)} vertices held on it around its faults"
            return again.with_(option=f"{patch.option}; faired again at order {order} on its mesh{held}")
        if not bad.size:
            return patch
        region = _pin_region(again, bad, region)
    return patch


def _steiner_last(ctx, hole_id, loop, budget, reasons):
    """The last layer for a single hole no other option closed: a patch
    with Steiner points lifted over the scan that crosses the opening
    (:mod:`~shellrepair.fill.steiner`), within what is left of the hole's work
    budget. Returns ``(patch, "")``, or ``(None, failure)`` where it fails
    (one of :data:`shellrepair.fill.checks.FAILURES`; the cause appended
    to ``reasons``)."""
    from shellrepair.fill.steiner import steiner_patch

    try:
        res = steiner_patch(ctx, hole_id, loop, max_vertices=max(budget.left(), STEINER_VERTICES))
    except (ValueError, IndexError, FloatingPointError, np.linalg.LinAlgError) as exc:
        # a degenerate outline the layer's arithmetic cannot take: the hole
        # stays open as it would without the layer, saying so
        reasons.append(f"last layer: Steiner points: {type(exc).__name__}: {exc}")
        return None, checks.NO_PATCH_PASSES
    budget.count(res.spent)
    if res.patch is not None:
        return res.patch, ""
    reasons.append(f"last layer: {res.reason}")
    return None, (checks.DEGENERATE_RIM if res.degenerate else checks.WORK_BUDGET if res.over_budget
                  else checks.NO_PATCH_PASSES)


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
    patch = patch.with_(option=f"{name} on the first triangulation", kind="harmonic")
    if why is not None:
        reasons.append(f"{patch.option}: {why}")
    return patch, why, bad


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
            out[p.hole_id] = p.with_(option=f"seed, {passes} smoothing passes", kind="seed")
        else:
            results[p.hole_id] = f"seed: {why}"
    return out
