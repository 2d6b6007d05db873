"""Fill a missing region bounded by three loops with one pair of pants.

On a figure with handles (two tori joined, an arm that forks) a scan can
miss a whole region bounded by three loops: the crotch where two tubes meet
a third. Capping each loop closes every hole but cuts the handles (the
Euler characteristic rises by 3 where the region's own is -1); a tube
between two loops and a cap on the third still cuts one. The right fill is
a pair of pants: the *waist* (the loop whose continuation arcs land on the
two others) joined by one surface to both *legs* (each landing on the
waist).

Which loops bound one region
----------------------------
Loops B and C are the legs of waist A when (by :func:`loop_sights`):

* a strict majority of B's arcs land on A, and of C's arcs on A;
* a strict majority of A's arcs land on B and C together, and some on
  each (A's arcs may favour one leg: its split between the two follows
  their sizes and where the arcs start).

How the pants is built
----------------------
The two legs are joined into one loop by a strip of zero width along the
segment between their nearest vertices (vertices on it about the rim's
edge length apart): B walked from its vertex ``b`` all round, the strip to
C's vertex ``c``, C walked all round, the strip back. The tube of
:func:`shellrepair.fill.tube.guide_tube` between A and that loop (the legs'
arcs, the strip's vertices borrowing theirs) sews the strip's two sides
together: the strip's vertices become free vertices of one patch over the
three loops, which is then refined and faired with the three loops' rings
fixed and checked like a cap or a tube (:func:`shellrepair.fill.checks.check_patch`,
and here also: a manifold surface with exactly the three loops as its
boundary and Euler characteristic -1). The faired pants, the pants held on
its guide and the plain zip are tried in that order; if none passes, the
three loops are filled as before (the band the arcs pair, and a cap).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from shellrepair.lazyscipy import cKDTree

__all__ = ["pants_initial", "pants_is_manifold", "PantsUnit", "PantsResult", "fill_pants", "with_fallback", "expand", "pants_unit"]


def pants_initial(PA, PB, PC, arcs, spacing, reach):
    """A first pants over the loops ``[PA; PB; PC]``.

    Parameters
    ----------
    PA, PB, PC : (ka,3), (kb,3), (kc,3) float64
        Waist and legs, each in its boundary half-edge order.
    arcs : list of 3 tuples
        :func:`shellrepair.fill.bridge.continuation_arcs` of each loop.
    spacing : float
        The rim's edge length (strip vertices and tube rings this far apart).
    reach : float
        As for :func:`shellrepair.fill.tube.guide_tube`.

    Returns
    -------
    P : (q,3) float64
        New vertices: the strip's, then the tube's rings.
    T : (t,3) int64
        Triangles over ``[PA; PB; PC; P]``, oriented like the loops' scan
        faces (each loop edge reversed).
    """
    from shellrepair.fill.tube import guide_tube

    ka, kb, kc = len(PA), len(PB), len(PC)
    k = ka + kb + kc
    d, j = cKDTree(PC).query(PB)
    ib = int(np.argmin(d))
    ic = int(j[ib])
    m = max(0, int(round(float(d[ib]) / max(spacing, 1e-300))) - 1)
    S = PB[ib] + (np.arange(1, m + 1) / (m + 1))[:, None] * (PC[ic] - PB[ib])
    ob = (ib + np.arange(kb + 1)) % kb
    oc = (ic + np.arange(kc + 1)) % kc
    # the legs joined: B from b round to b, the strip to c, C round to c, the strip back
    ids = np.concatenate([ka + ob, k + np.arange(m), ka + kb + oc, k + np.arange(m)[::-1]])
    PD = np.vstack([PB[ob], S, PC[oc], S[::-1]])
    ab, ac = arcs[1], arcs[2]
    arcs_d = []
    for x, y in zip(ab, ac):
        x, y = np.asarray(x), np.asarray(y)
        fill = np.zeros((m,) + x.shape[1:], x.dtype)
        arcs_d.append(np.concatenate([x[ob], fill, y[oc], fill]))
    arcs_d[5] = arcs_d[5].astype(bool)
    Pg, Tg = guide_tube(PA, PD, arcs[0], tuple(arcs_d), spacing=spacing, reach=reach)
    local = np.concatenate([np.arange(ka), ids, k + m + np.arange(len(Pg))])
    T = local[Tg]
    # (a triangle on two copies of one vertex is no triangle)
    T = T[(T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 2] != T[:, 0])]
    return np.vstack([S, Pg]) if m or len(Pg) else np.zeros((0, 3)), T


def pants_is_manifold(T, k, sizes):
    """The triangles ``T`` over ``k`` loop vertices and new ones make one
    oriented manifold surface whose boundary is exactly the loops (``sizes``
    consecutive loops of the first ``k`` indices, each edge reversed) and
    whose Euler characteristic is ``2 - len(sizes)`` (genus 0).

    Returns
    -------
    ok : bool
    """
    T = np.asarray(T, np.int64)
    if len(T) == 0:
        return False
    he = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    # no directed edge twice (orientation and manifoldness)
    if len(np.unique(he, axis=0)) != len(he):
        return False
    und = np.sort(he, axis=1)
    u, cnt = np.unique(und, axis=0, return_counts=True)
    if (cnt > 2).any():
        return False
    bd = u[cnt == 1]
    # expected boundary: each loop edge, reversed, once
    want = []
    base = 0
    for s in sizes:
        i = base + np.arange(s)
        want.append(np.column_stack([i, base + (np.arange(s) + 1) % s]))
        base += s
    want = np.vstack(want)
    heset = {tuple(e) for e in he.tolist()}
    if len(bd) != len(want) or any((int(b), int(a)) not in heset for a, b in want.tolist()):
        return False
    if {tuple(e) for e in np.sort(want, axis=1).tolist()} != {tuple(e) for e in bd.tolist()}:
        return False
    nv = len(np.unique(T))
    if nv != T.max() + 1 or nv < k:
        return False
    chi = nv - len(u) + len(T)
    return chi == 2 - len(sizes)


class PantsUnit(NamedTuple):
    """Three ``hole`` loops bounding one missing region (a unit of the
    fill's work): waist ``A``, legs ``B`` and ``C``; ``fallback`` the units
    that fill them as before (the band their arcs pair, and the caps)."""
    A: object
    B: object
    C: object
    order: object
    smooth: int
    mode: str
    fallback: tuple

    @property
    def first_id(self):
        return min(self.A.id, self.B.id, self.C.id)


class PantsResult(NamedTuple):
    """What filling a :class:`PantsUnit` gave: ``(unit, (outcomes,
    record))`` per unit to merge, the pants itself (outcomes per loop A, B,
    C) or its fallback units; ``parts`` None when the pants failed, why in
    ``failed`` (the fill then fills the fallback units:
    :func:`with_fallback`)."""
    parts: list | None
    failed: str = ""


def with_fallback(unit, why, parts):
    """The :class:`PantsResult` of a pants that failed (``why``): the
    fallback units' ``parts`` as the fill filled them, each band's record
    saying what the pants tried."""
    for u, (outs, record) in parts:
        if record is not None:
            record["pants"] = "pants of loops %d, %d, %d failed: %s" % (unit.A.id, unit.B.id, unit.C.id, why)
    return PantsResult(parts)


def pants_unit(A, B, C, pairs, order, smooth, mode):
    """The :class:`PantsUnit` of waist A and legs B, C; ``pairs`` the bands
    among them the arcs pair (:class:`shellrepair.fill.bands.Band`; its
    fallback, with caps on the other loops)."""
    from shellrepair.fill.patch import BandUnit, HoleUnit

    fb = [BandUnit(b.A, b.B, order, smooth, mode, b.mutual) for b in pairs]
    done = {L.id for b in pairs for L in (b.A, b.B)}
    fb += [HoleUnit(L.id, L.vertices, order, smooth) for L in (A, B, C) if L.id not in done]
    return PantsUnit(A, B, C, order, smooth, mode, tuple(sorted(fb, key=lambda u: u.first_id)))


def expand(units, results):
    """The units and results to merge, a pants unit's replaced by its parts."""
    u2, r2 = [], []
    for u, r in zip(units, results):
        if isinstance(r, PantsResult):
            for su, sr in r.parts:
                u2.append(su)
                r2.append(sr)
        else:
            u2.append(u)
            r2.append(r)
    return u2, r2


def fill_pants(ctx, unit):
    """Fill a :class:`PantsUnit`: the pants if one passes its checks, else
    a result saying why not (its fallback units are then filled as they
    were before: :func:`with_fallback`).

    The pants (:func:`pants_initial`) is faired (order as the unit's;
    ``"auto"``: the order test holes beside its three loops choose,
    :func:`shellrepair.fill.selftest.choose_order_beside`; before, a pants
    under ``auto`` was always faired at order 2: on a genus-2 part seen
    from four views, development seed 731 case 9, order 2 gave 4.57 per
    mille where order 3, which the test chooses, gives 1.82) and, if it fails its checks, held on its guide; then
    the failed attempts are mended (:func:`shellrepair.fill.checks.mend_last`).
    Every option must pass :func:`shellrepair.fill.checks.check_patch`, repeat no
    edge of the scan and be a genus-0 surface bounded by exactly the three
    loops (:func:`pants_is_manifold`).

    Returns
    -------
    PantsResult
    """
    import time

    from shellrepair.fill import checks as _checks
    from shellrepair.fill.bridge import MAX_REACH, continuation_arcs
    from shellrepair.fill.patch import PatchError, build_patch
    from shellrepair.fill.selftest import choose_order_beside
    from shellrepair.mesh.index import rim_data

    t0 = time.perf_counter()
    A, B, C = unit.A, unit.B, unit.C
    loop = np.concatenate([A.vertices, B.vertices, C.vertices])
    sizes = [len(A.vertices), len(B.vertices), len(C.vertices)]
    k = len(loop)
    choice = choose_order_beside(ctx, (A, B, C)) if unit.order == "auto" else None
    order = unit.order if choice is None else choice.order
    budget = _checks.WorkBudget(k)
    scan_edges = _checks.edges_across(ctx, (A, B, C))
    why = []

    def check(ctx_, p):
        w, bad = _checks.check_joining(ctx_, p, scan_edges, "pants")
        if w is None and not pants_is_manifold(p.T, k, sizes):
            w = "the pants is not one surface bounded by the three loops"
        return w, bad

    faults, pants = [], None
    try:
        arcs = [continuation_arcs(ctx.V, ctx.F[ctx.ring_faces(L.vertices, 3)], L.vertices) for L in (A, B, C)]
        spacing = float(np.mean(rim_data(ctx, loop)[0]))
        reach = MAX_REACH * max(A.diameter, B.diameter, C.diameter)
        P0, T0 = pants_initial(ctx.V[A.vertices], ctx.V[B.vertices], ctx.V[C.vertices], arcs, spacing, reach)
        init = (P0, T0) if np.isfinite(P0).all() and pants_is_manifold(T0, k, sizes) else None
        if init is None:
            why.append("no first pants")
    except (ValueError, IndexError, FloatingPointError) as exc:
        init = None
        why.append(f"no first pants ({exc})")
    if init is not None:
        for how, pinned in (("faired", None), ("held on its guide", "all")):
            if not budget.affords(len(P0)):
                why.append("work budget")
                break
            try:
                p = build_patch(ctx, A.id, loop, order=order, smooth=unit.smooth, initial=init, energy=True,
                                pinned=None if pinned is None else np.arange(len(P0)),
                                max_vertices=budget.left() if pinned is None else None)
            except PatchError as exc:
                why.append(f"{how}: {exc}")
                continue
            budget.spend(p)
            w, bad = check(ctx, p)
            p = p.with_(option=f"pants joining loops {B.id} and {C.id} to loop {A.id}, "
                               + (f"faired order {order}" if pinned is None else "refined, held on its guide")
                               + ("" if choice is None else f" ({choice.describe()})"), choice=choice, kind="pants",
                       pinned=0 if pinned is None else len(p.P))
            if w is None:
                pants = p
                break
            why.append(f"{how}: {w}")
            faults.append((p, bad, p.option))
        if pants is None and faults:
            notes = []
            pants = _checks.mend_last(ctx, faults, notes, check=check, what="pants")
            why += notes
    secs = time.perf_counter() - t0
    if pants is not None:
        pants = pants.with_(hole_id=A.id, choice=pants.choice or choice)   # (a mended pants keeps the choice)
        e = pants.energy[_checks.ENERGY] if pants.energy is not None else None
        record = {"loops": [int(A.id), int(B.id), int(C.id)], "kinds": [A.kind, B.kind, C.kind],
                  "tube_energy": None if e is None else round(float(e), 6), "caps_energy": None,
                  "chosen": "tube", "shape": "pants", "reason": f"pants: the arcs of loops {B.id} and {C.id} land on loop {A.id}, "
                                              f"and loop {A.id}'s on the two"}
        outs = [_checks.Outcome(pants, "", secs, []),
                _checks.Outcome(None, f"joined with loop {A.id} by a pants", secs, []),
                _checks.Outcome(None, f"joined with loop {A.id} by a pants", secs, [])]
        return PantsResult([(unit, (outs, record))])
    return PantsResult(None, "; ".join(why))
