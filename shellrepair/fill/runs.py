"""Fill a run of units: holes, bands and pants, one after the other.

:func:`run_chunk` fills a chunk of consecutive units of a repair: each
hole's first attempt made for the whole chunk at once, its checks against
the scan batched (:func:`first_attempts`), then each unit by its kind
(:func:`shellrepair.fill.hole.fill_hole`, :func:`shellrepair.fill.band_fill._fill_pair`,
:func:`shellrepair.fill.pants.fill_pants`), with a helper thread beside when
given one (:mod:`shellrepair.fill.beside`). :func:`_worker` is the same in a
forked worker process (:func:`worker_context`).
"""

from __future__ import annotations

import contextlib
from typing import NamedTuple

import numpy as np

from shellrepair.fill import checks
from shellrepair.fill.band_fill import _fill_pair
from shellrepair.fill.beside import Beside
from shellrepair.fill.hole import fill_hole
from shellrepair.fill.pants import PantsUnit, fill_pants, with_fallback
from shellrepair.fill.patch import HoleUnit, PatchError, _meets_edge_on, _prefill, build_patch

__all__ = ["run_chunk", "first_attempts", "worker_context"]

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
        return [fill_hole(ctx, *unit)], None
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


def first_attempts(ctx, chunk):
    """The first attempt of every single hole of the chunk, as
    :func:`~shellrepair.fill.hole.fill_hole_at_order` makes it (flat
    triangulation, then the first option's patch), their checks against the
    scan batched (:func:`checks.check_patches`); stored in ``ctx.pre`` where
    :func:`~shellrepair.fill.hole.fill_hole_at_order` takes them instead of
    making them again.

    Parameters
    ----------
    ctx : ScanContext
        The scan; its ``pre`` (per-hole work kept for the run) receives the
        attempts.
    chunk : sequence of HoleUnit, BandUnit or PantsUnit
        The run's units; only the single holes (``HoleUnit``) get a first
        attempt here.

    Returns
    -------
    None
    """
    made = []
    for unit in chunk:
        if not isinstance(unit, HoleUnit):
            continue
        hole_id, loop = unit.hole_id, np.asarray(unit.loop, np.int64)
        if unit.order == "flat":
            continue           # (fill_hole builds the flat triangulation itself)
        pre = ctx.pre_for(hole_id, loop)
        if pre is None:
            continue
        order = 2 if unit.order == "auto" else unit.order     # "auto" starts with order 2 (fill_hole)
        first = ("faired", order)
        if order != 1 and (pre.edge_on if pre.edge_on is not None else _meets_edge_on(ctx, loop, hole_id)):
            first = ("flat cap", 1)
        try:
            flat = build_patch(ctx, hole_id, loop, order=1, smooth=0, refine=False, fair=False, avoid=set(),
                               scan_aware=False)
        except PatchError:
            continue           # fill_hole_at_order meets the same error
        beside = getattr(ctx, "beside", None)
        if beside is not None and unit.order == "auto" and first == ("faired", 2):
            beside.start_o3(pre, hole_id, loop, unit.smooth, flat.T0)
        try:
            patch, error = build_patch(ctx, hole_id, loop, order=first[1], smooth=unit.smooth, initial=flat.T0,
                                       energy=False, chords=first[0] == "faired"), ""
        except PatchError as exc:
            patch, error = None, str(exc)
        made.append((pre, _First((first, unit.smooth, False), flat, patch, error, None)))
    verdicts = iter(checks.check_patches(ctx, [f.patch for _, f in made if f.patch is not None]))
    for pre, f in made:
        pre.keep_first(f._replace(check=next(verdicts)) if f.patch is not None else f)


def run_chunk(ctx, chunk, on_unit=None, pool=None):
    """Fill a run of consecutive units (their first attempts batched).

    Parameters
    ----------
    ctx : ScanContext
        The scan.
    chunk : sequence of HoleUnit, BandUnit or PantsUnit
        The units, filled in this order.
    on_unit : callable, optional
        Called with no argument after each unit.
    pool : HelperThread, optional
        A thread that works beside the fills on the ``order="auto"`` holes
        (:class:`~shellrepair.fill.beside.Beside`; the same output as without).

    Returns
    -------
    list
        Per unit: ``([Outcome], None)`` for a hole, ``(outcomes, record)``
        for a band, :func:`~shellrepair.fill.pants.fill_pants`' result for a
        pants.
    """
    from shellrepair.fill.fair import first_solve_memo

    try:
        memo = first_solve_memo(True)     # an order-3 fill of order="auto" repeats its order-2 fill's first solve
        ctx.start_run(Beside(ctx, chunk, pool, memo) if pool is not None else None)
        _prefill(ctx, chunk)
        first_attempts(ctx, chunk)
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
    return run_chunk(_WORKER_CTX, chunk)
