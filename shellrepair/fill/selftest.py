"""Choose a hole's fairing order by what the scan says at the hole's own size (``order="auto"``).

Which fairing order continues a scan best depends on the surface and on
the hole's size against it: order 1 (harmonic, a membrane) is truest on a
planar cut or a CAD face, order 2 (thin plate) where the scan carries
relief or noise that a higher order would carry on into the hole, order 3
(curvature continuous) on smooth curved surfaces and large holes in them.
Instead of rules on the rim's bends, the opening's plane or a band of scan
next to the rim, one measured criterion decides (:func:`choose_order`):

1. Cut test holes of the hole's own outline and size into intact scan
   near it (:func:`shellrepair.fill.probe.probe_errors`: up to ``PROBES``,
   spread around the hole; where the outline does not fit, a disc as wide
   as the hole across its narrow axis, then a disc of its area; half the
   size only where fewer than two of the full size fit; where the scan
   stands across the hole, each stopped at the creases it crosses, the
   relief it encloses cut with it, :mod:`shellrepair.fill.creases`), their
   rims given the real rim's noise
   (:func:`shellrepair.fill.roughness.rim_noise`: a ragged rim is noise that a
   higher order carries on into the hole; the surface's curvature, which
   differs between the real rim and a test rim, is not counted).
2. Fill each with every candidate order exactly as a hole is filled
   (:func:`shellrepair.fill.probe._refined`: triangulate, refine; then
   :func:`shellrepair.fill.fair.fair_patch_orders`), order 3 as the fill
   would keep it (step 5: order 2's patch where order 3's does not
   converge, :func:`shellrepair.fill.probe.as_filled`).
3. Measure each fill against the scan that was cut away: the RMS
   distance of the removed vertices to the filled surface
   (:func:`shellrepair.mesh.distance.point_mesh_distance`), per test hole;
   over the test holes, the geometric mean of their RMS (each weighs alike).
4. The order with the lowest error fills the real hole; equal errors go
   to ``DEFAULT_ORDER``, then to the lower order (a test hole too small
   for new vertices fills alike at every order and is not counted).
5. Where order 3 wins, it is kept only where its patch on the real hole
   departs from the order-2 patch less than the order-1 patch does (the
   orders converge there); else order 2 (:func:`shellrepair.fill.hole.fill_hole`).

Where fewer than two test holes fit at the hole's size and at half of it
(the hole is as large as the intact scan around it; one test hole alone is
not repeated evidence, and a test hole of a quarter of the size does not
predict the hole: ``probe.SCALES``), the scan cannot tell: the hole takes
``DEFAULT_ORDER`` and the report says so. Holes with fewer than ``MIN_EDGES`` rim edges are not tested (a
patch of a few triangles, where the orders differ by less than the scan's
own noise). A tube (the band between two loops) is tested by its own
kind: test bands beside its loops, refilled as tubes
(:func:`shellrepair.fill.band_test.tube_errors`, :func:`shellrepair.fill.hole.band_order`).

Judged by its regret (the default's RMS over the best forced order's,
``eval/regret.py``) on stress cases of seeds never used while developing
it: BENCHMARKS.md, "The order test".
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from shellrepair.fill.probe import FLAT as _probe_flat

__all__ = ["choose_order", "choose_order_beside", "best_candidate", "OrderTest", "CANDIDATES", "DEFAULT_ORDER",
           "FLAT", "WITH_FLAT", "label"]

#: Candidate fairing orders (ties go to ``DEFAULT_ORDER``, then the lower order).
CANDIDATES = (1, 2, 3)
#: The rim's triangulation with no new vertex (``order="flat"``): the
#: test's own name for it, :data:`shellrepair.fill.probe.FLAT`.
FLAT = _probe_flat
#: The orders and the flat triangulation, for :func:`choose_order`'s
#: ``candidates``. Not the default: measured as a candidate of ``auto``
#: (eval/results/order-test/flat-candidate/), it helped on the design
#: seeds' fandisk occlusions (regret 1.463 -> 1.242) and on fresh seed
#: 910875920 (1.0599 -> 1.0580), and lost on fresh fandisk seed 609833624
#: (15 cases, 1.023x worse: a disc its test holes gave the flat
#: triangulation, 2.95 where order 3 is truest).
WITH_FLAT = CANDIDATES + (FLAT,)
#: The order of holes that are not tested, or where the scan cannot tell.
DEFAULT_ORDER = 2
#: Holes with fewer rim edges are not tested.
MIN_EDGES = 8


def label(o):
    """How the report names candidate ``o``: "order 2", "flat"."""
    return FLAT if o == FLAT else f"order {o}"


def _value(o):
    return o if o == FLAT else int(o)


@dataclass(frozen=True)
class OrderTest:
    """What :func:`choose_order` found for one hole.

    Attributes
    ----------
    order : int or "flat"
        The chosen order (or the flat triangulation).
    errors : dict of (int or "flat") -> float
        Each candidate's error on the test holes, in the scan's units: the
        geometric mean over the test holes of the RMS distance of the scan
        each cut away to the candidate's fill (empty when not tested).
    probes : int
        Test holes filled (0 when not tested).
    scale : float
        Their size over the hole's (1 or 0.5; 0 when not tested).
    why : str
        Why the hole was not tested, or ''.
    """

    order: int
    errors: dict = field(default_factory=dict)
    probes: int = 0
    scale: float = 0.0
    why: str = ""

    @property
    def runner_up(self):
        """The candidate with the next lowest error, or None."""
        rest = sorted(((e, str(o)), o) for o, e in self.errors.items() if o != self.order)
        return rest[0][1] if rest else None

    def as_dict(self):
        """The report's ``choice`` field of a hole: the chosen order, the
        runner-up, each candidate's test RMS (scan units), how many test
        holes and at which scale, and ``untold`` where the scan could not
        tell (or the hole was too small to test) and the default was taken."""
        return {"by": "test holes" if self.errors else "default",
                "order": _value(self.order),
                "runner_up": None if self.runner_up is None else _value(self.runner_up),
                "test_rms": {str(o): float(e) for o, e in sorted(self.errors.items(), key=lambda t: str(t[0]))},
                "probes": int(self.probes), "scale": float(self.scale),
                "untold": not self.errors, "why": self.why}

    def describe(self):
        """One line for the report: the choice, its evidence and the runner-up."""
        if not self.errors:
            return f"auto: {label(self.order)}, {self.why}"
        size = "its size" if self.scale == 1.0 else f"{self.scale:g} its size"
        errs = ", ".join(f"{label(o)} {e:.3g}" for o, e in sorted(self.errors.items(), key=lambda t: str(t[0])))
        line = f"auto: {label(self.order)}, by {self.probes} test holes of {size}, RMS {errs}"
        ru = self.runner_up
        if ru is not None:
            line += f"; runner-up {label(ru)}"
        return line


def choose_order(ctx, hole_id, loop, candidates=None):
    """Pick the fairing order of one hole by test holes of its size (module docstring).

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
        The scan (read only).
    hole_id : int
    loop : (k,) int64
        The hole's rim.
    candidates : sequence of (int or "flat"), optional
        Default :data:`CANDIDATES` (:data:`WITH_FLAT`: the flat triangulation too).

    Returns
    -------
    test : OrderTest
    """
    from shellrepair.fill.probe import probe_errors

    candidates = CANDIDATES if candidates is None else tuple(candidates)
    loop = np.asarray(loop, np.int64)
    k = len(loop)
    if k < MIN_EDGES:
        return OrderTest(DEFAULT_ORDER, why=f"{k} rim edges, not tested")
    errors, n, scale = probe_errors(ctx, loop, candidates)
    if not errors:
        return OrderTest(DEFAULT_ORDER, why="fewer than two test holes of its size or half of it fit in the intact "
                                            "scan around it (or those that fit have no vertex of their own): "
                                            "the scan cannot tell")
    best = best_candidate({o: errors[o] for o in candidates})
    return OrderTest(_value(best), errors=errors, probes=n, scale=scale)


def choose_order_beside(ctx, loops, candidates=None):
    """The fairing order of a patch spanning several loops (a pants, or a
    tube where no test band fits beside its loops): test holes of each
    loop's size cut beside it (:func:`shellrepair.fill.probe.probe_errors`,
    the test of a single hole), their squared errors pooled over the
    loops (weighted by each loop's test holes); the lowest wins
    (:func:`best_candidate`). Where no test hole fits beside any loop, the
    scan cannot tell: ``DEFAULT_ORDER``.

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
    loops : sequence of shellrepair.holes.loops.Loop
    candidates : sequence of int, optional
        Default :data:`CANDIDATES`.

    Returns
    -------
    test : OrderTest
        ``scale`` is the largest of the loops' test scales.
    """
    from shellrepair.fill.probe import probe_errors

    candidates = CANDIDATES if candidates is None else tuple(candidates)
    sq, count, scale = dict.fromkeys(candidates, 0.0), 0, 0.0
    for L in loops:
        loop = np.asarray(L.vertices, np.int64)
        if len(loop) < MIN_EDGES:
            continue
        errors, n, s = probe_errors(ctx, loop, candidates)
        if not errors:
            continue
        for o in candidates:
            sq[o] += errors[o] ** 2 * n
        count += n
        scale = max(scale, s)
    if not count:
        return OrderTest(DEFAULT_ORDER, why="no test hole fits beside its loops: the scan cannot tell")
    rms = {o: float(np.sqrt(sq[o] / count)) for o in candidates}
    return OrderTest(int(best_candidate(rms)), errors=rms, probes=count, scale=scale)


def best_candidate(errors):
    """The candidate with the lowest error; equal errors go to
    ``DEFAULT_ORDER``, then to the lower order (the fairing orders come
    before ``band_test.HELD``).

    Parameters
    ----------
    errors : dict of (int or str) -> float

    Returns
    -------
    candidate : int or str
    """
    return min(errors, key=lambda o: (errors[o], o != DEFAULT_ORDER, str(o)))
