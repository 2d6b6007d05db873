"""Build the tube of a missing band: the triangles between two loops.

The tube's rings, and the plain zip used when no guide can be built, are
matched by arc length from the cyclic shift of the second loop (walked
backwards) that best matches the first, so loops of very different vertex
counts or with unrelated start vertices zip without a twist
(:func:`tube_triangles`). :func:`guide_tube` lays rings along both loops'
continuation arcs (:func:`shellrepair.fill.bridge.continuation_arcs`), and
:func:`resample_tube` puts a coarse faired tube's shape on finer rings.
Which loops get a tube, and whether it is kept, is
:mod:`shellrepair.fill.bridge`'s and :mod:`shellrepair.fill.band_fill`'s.
"""

from __future__ import annotations

import numpy as np

from shellrepair.fill.bridge import arc_points

__all__ = ["tube_triangles", "guide_tube", "resample_tube", "loop_parameters", "zip_rings", "zip_rings_reference",
           "lerp_loop", "lerp_arcs"]


def loop_parameters(P):
    """Normalised arc length of each vertex of a closed loop.

    Parameters
    ----------
    P : (k,3) float64
        The loop's vertex positions, in order (the last joins the first).

    Returns
    -------
    t : (k,) float64
        Arc length from ``P[0]`` to each vertex over the loop's perimeter:
        ``t[0] = 0``, increasing, below 1.
    """
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    t = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    return t / max(seg.sum(), 1e-300)


def _facing_order(PA, PB):
    """Indices of PB walked backwards from the cyclic shift that best matches
    PA by arc length (the second loop's vertices in the first loop's sense)."""
    kb = len(PB)
    rev = np.arange(kb)[::-1]
    ta = loop_parameters(PA)
    best = (np.inf, 0)
    shifts = range(kb) if kb <= 512 else np.linspace(0, kb - 1, 512).astype(int)
    for s in shifts:
        order = np.roll(rev, -s)
        Q = PB[order]
        tb = loop_parameters(Q)
        j = np.minimum(np.searchsorted(tb, ta), kb - 1)
        cost = np.linalg.norm(PA - Q[j], axis=1).sum()
        if cost < best[0]:
            best = (cost, s)
    return np.roll(rev, -best[1])


def zip_rings(ta, tc, ia, ic):
    """Triangles zipping two rings walked the same way round, advancing the
    side whose next vertex comes first by (normalised) arc length ``ta``,
    ``tc``; ``ia``, ``ic`` are the rings' vertex indices.

    The walk is a merge of the two rings' next parameters (ties to ``ia``):
    where both run upwards, each step's place comes from one
    ``searchsorted``; else (round-off past 1, NaN) :func:`zip_rings_reference`
    takes the steps one by one. The triangles are the same either way.

    Parameters
    ----------
    ta, tc : (ka,), (kc,) float64
        Each ring's vertex parameters (:func:`loop_parameters`).
    ia, ic : (ka,), (kc,) int64
        Each ring's vertex indices.

    Returns
    -------
    T : (ka+kc,3) int64
        The strip's triangles.
    """
    ka, kc = len(ia), len(ic)
    na = np.append(np.asarray(ta, np.float64)[1:ka], 1.0)   # A's next parameter at each A step
    nc = np.append(np.asarray(tc, np.float64)[1:kc], 1.0)
    if not (na.size == ka and nc.size == kc and np.all(na[1:] >= na[:-1]) and np.all(nc[1:] >= nc[:-1])):
        return zip_rings_reference(ta, tc, ia, ic)
    ia, ic = np.asarray(ia, np.int64), np.asarray(ic, np.int64)
    ca = np.searchsorted(nc, na, side="left")    # C steps taken before A step i
    cc = np.searchsorted(na, nc, side="right")   # A steps taken before C step t
    i, t = np.arange(ka), np.arange(kc)
    tris = np.empty((ka + kc, 3), np.int64)
    tris[i + ca] = np.column_stack([ia, ic[ca % kc], ia[(i + 1) % ka]])
    tris[t + cc] = np.column_stack([ia[cc % ka], ic, ic[(t + 1) % kc]])
    return tris


def zip_rings_reference(ta, tc, ia, ic):
    """:func:`zip_rings` one step at a time (any parameters): the reference
    the merge is held to.

    Parameters
    ----------
    ta, tc, ia, ic
        As for :func:`zip_rings`.

    Returns
    -------
    T : (ka+kc,3) int64
    """
    ka, kc = len(ia), len(ic)
    tris = []
    i = t = 0
    while i < ka or t < kc:
        a0, a1 = ia[i % ka], ia[(i + 1) % ka]
        c0, c1 = ic[t % kc], ic[(t + 1) % kc]
        if i == ka:
            adv_a = False
        elif t == kc:
            adv_a = True
        else:
            na = ta[i + 1] if i + 1 < ka else 1.0
            nc = tc[t + 1] if t + 1 < kc else 1.0
            adv_a = na <= nc
        if adv_a:
            tris.append((a0, c0, a1))
            i += 1
        else:
            tris.append((a0, c0, c1))
            t += 1
    return np.array(tris, np.int64)


def tube_triangles(PA, PB):
    """Zip two facing loops into a closed strip of triangles.

    Parameters
    ----------
    PA : (ka,3) float64
        First loop, in its boundary half-edge order.
    PB : (kb,3) float64
        Second loop, in its own boundary half-edge order.

    Returns
    -------
    T : (ka+kb,3) int64
        Triangles over the concatenated positions ``[PA; PB]``, oriented
        consistently with both loops' scan faces (each loop edge appears
        reversed).
    """
    ka = len(PA)
    order = _facing_order(PA, PB)
    return zip_rings(loop_parameters(PA), loop_parameters(PB[order]), np.arange(ka), order + ka)


def lerp_loop(t, X, u):
    """Values given at a loop's vertices, interpolated linearly between
    them at other parameters, cyclically.

    Parameters
    ----------
    t : (k,) float64
        The vertices' parameters, increasing from 0 (:func:`loop_parameters`).
    X : (k,...) float64
        A value per vertex.
    u : (n,) float64
        Where to interpolate, in [0, 1).

    Returns
    -------
    (n,...) float64
    """
    k = len(t)
    tt = np.concatenate([t, [1.0]])
    j = np.clip(np.searchsorted(tt, u, side="right") - 1, 0, k - 1)
    f = (u - tt[j]) / np.maximum(tt[j + 1] - tt[j], 1e-300)
    f = f.reshape((-1,) + (1,) * (X.ndim - 1))
    return (1 - f) * X[j] + f * X[(j + 1) % k]


def lerp_arcs(t, arcs, u):
    """:func:`lerp_loop` of each of the arrays ``arcs`` at ``u``, in one
    call on their columns side by side (the same numbers: every column is
    interpolated by itself).

    Parameters
    ----------
    t : (k,) float64
    arcs : sequence of (k,) or (k,3) float64
    u : (n,) float64

    Returns
    -------
    list of (n,) or (n,3) float64
        One per array of ``arcs``.
    """
    X = np.column_stack(arcs)
    L = lerp_loop(t, X, u)
    out, c = [], 0
    for a in arcs:
        w = 1 if a.ndim == 1 else a.shape[1]
        out.append(L[:, c] if a.ndim == 1 else L[:, c:c + w])
        c += w
    return out


def _landing(arcs, P, targets, reach, n=128):
    """Per vertex: arc length along its continuation arc to the point
    nearest its target, and whether the arc gets nearer to it than half the
    straight chord (else the arc is replaced by the chord)."""
    U, T, N, kap, s0, ok = arcs
    chord = np.linalg.norm(targets - P, axis=1)
    turn = np.where(np.abs(kap) > 0, 2 * np.pi / np.maximum(np.abs(kap), 1e-300), np.inf)
    length = np.minimum(np.maximum(reach, 2 * chord), turn)
    s = s0[:, None] + length[:, None] * (np.arange(1, n + 1) / n)[None]
    X = arc_points(U, T, N, kap, s)
    d = np.linalg.norm(X - targets[:, None], axis=2)
    j = np.argmin(d, axis=1)
    S = s[np.arange(len(P)), j] - s0
    good = ok & (d[np.arange(len(P)), j] <= 0.5 * chord)
    return S, good


def guide_tube(PA, PB, arcs_a, arcs_b, spacing, reach, rings=False):
    """A first tube between two loops that follows both loops' continuation
    arcs, with rings of vertices about ``spacing`` apart.

    Parameters
    ----------
    PA, PB : (ka,3), (kb,3) float64
        The loops, each in its boundary half-edge order.
    arcs_a, arcs_b : tuple
        :func:`continuation_arcs` of each loop.
    spacing : float
        Target distance between rings (the rim's edge length).
    reach : float
        How far arcs are followed looking for the other loop.
    rings : bool
        Also return the rings' parameters (for :func:`resample_tube`).

    Returns
    -------
    P : (q,3) float64
        Positions of the new ring vertices.
    T : (t,3) int64
        Triangles over ``[PA; PB; P]``, oriented like :func:`tube_triangles`.
    params : list of arrays, only with ``rings``
        Arc-length parameter in [0, 1) of each vertex of each ring, from
        loop A (its own) through the new rings (in the order of ``P``) to
        loop B walked in A's sense; None when the tube has no new rings.
    order : (kb,) int64, only with ``rings``
        Loop B's vertices in that sense (:func:`_facing_order`).

    Notes
    -----
    Rim vertex ``a`` whose zip partner on the other loop is ``b`` (same
    arc-length parameter) gets its arc length ``S_a`` to the arc's point
    nearest ``b`` (a straight chord where its arc misses ``b``). The ring at
    ``τ ∈ (0, 1)`` is the blend ``(1 - w) x_a(τ S_a) + w x_b((1 - τ) S_b)``,
    ``w = 3τ² - 2τ³``: exact for a cylinder (straight arcs) and for a torus
    (both arcs the same circle).
    """
    ka, kb = len(PA), len(PB)
    order = _facing_order(PA, PB)
    C = PB[order]
    arcs_c = tuple(x[order] for x in arcs_b)
    ta, tc = loop_parameters(PA), loop_parameters(C)
    to_c = lerp_loop(tc, C, ta)                    # partner of each A vertex on C
    to_a = lerp_loop(ta, PA, tc)
    Sa, ga = _landing(arcs_a, PA, to_c, reach)
    Sc, gc = _landing(arcs_c, C, to_a, reach)

    def repair(arcs, t, P, Q, S, good):
        """Arcs that miss their partner take the direction, normal,
        curvature and length of the nearest arcs that do (by arc-length
        parameter); if none does, the straight chord."""
        U, T, N, kap, s0, ok = (np.array(x, copy=True) for x in arcs)
        S = np.array(S, copy=True)
        bad = ~good
        if not bad.any():
            return U, T, N, kap, s0, S
        if good.sum() >= 2:
            g = np.flatnonzero(good)
            tg = np.concatenate([t[g] - 1.0, t[g], t[g] + 1.0])
            for X in (T, N, kap, S):
                Y = np.concatenate([X[g]] * 3)
                if X.ndim == 1:
                    X[bad] = np.interp(t[bad], tg, Y)
                else:
                    for c in range(X.shape[1]):
                        X[bad, c] = np.interp(t[bad], tg, Y[:, c])
            N[bad] /= np.maximum(np.linalg.norm(N[bad], axis=1, keepdims=True), 1e-300)
            T[bad] -= np.sum(T[bad] * N[bad], axis=1)[:, None] * N[bad]
            T[bad] /= np.maximum(np.linalg.norm(T[bad], axis=1, keepdims=True), 1e-300)
            # the borrowed arc starts at the rim vertex itself, turned by
            # the borrowed curvature over the borrowed base-to-rim length
            s0g = np.interp(t[bad], tg, np.concatenate([s0[g]] * 3))
            ang = (kap[bad] * s0g)[:, None]
            Tb, Nb = T[bad].copy(), N[bad].copy()
            T[bad] = np.cos(ang) * Tb + np.sin(ang) * Nb
            N[bad] = -np.sin(ang) * Tb + np.cos(ang) * Nb
            U[bad], s0[bad] = P[bad], 0.0
            S[bad] = np.maximum(S[bad] - s0g, 0.0)
            return U, T, N, kap, s0, S
        D = Q - P
        ln = np.maximum(np.linalg.norm(D, axis=1), 1e-300)
        return P, D / ln[:, None], np.zeros_like(P), np.zeros(len(P)), np.zeros(len(P)), ln

    Ua, Ta, Na, Ka, S0a, Sa = repair(arcs_a, ta, PA, to_c, Sa, ga)
    Uc, Tc, Nc, Kc, S0c, Sc = repair(arcs_c, tc, C, to_a, Sc, gc)
    length = 0.5 * (float(np.mean(Sa)) + float(np.mean(Sc)))
    M = int(max(0, round(length / max(spacing, 1e-300)) - 1))
    if M == 0:
        T = zip_rings(ta, tc, np.arange(ka), order + ka)     # tube_triangles(PA, PB)
        return (np.zeros((0, 3)), T, None, order) if rings else (np.zeros((0, 3)), T)
    want_rings, rings, params, ids = rings, [], [ta], [np.arange(ka)]
    base = ka + kb
    side_a, side_c = (Ua, Ta, Na, Ka, S0a, Sa), (Uc, Tc, Nc, Kc, S0c, Sc)

    def at(u):
        """Both sides' arcs interpolated at ring parameters ``u``."""
        return lerp_arcs(ta, side_a, u), lerp_arcs(tc, side_c, u)

    def ring(tau, arcs_u):
        (U, T, N, K, S0, S), (Uo, To, No, Ko, S0o, So) = arcs_u
        w = 3 * tau ** 2 - 2 * tau ** 3
        XA = arc_points(U, T, N, K, (S0 + tau * S)[:, None])[:, 0]
        XC = arc_points(Uo, To, No, Ko, (S0o + (1 - tau) * So)[:, None])[:, 0]
        return (1 - w) * XA + w * XC

    fine = max(ka, kb)
    at_fine = at(np.arange(fine) / fine)   # the same parameters for every ring's first try
    for r in range(1, M + 1):
        tau = r / (M + 1)
        # as many vertices as the ring's length holds at ``spacing`` (at
        # most the finer loop's count): triangles stay about as long as wide
        X = ring(tau, at_fine)
        m = _ring_count(X, spacing, fine)
        u = np.arange(m) / m
        rings.append(X if m == fine else ring(tau, at(u)))
        params.append(u)
        ids.append(base + np.arange(m))
        base += m
    params.append(tc)
    ids.append(order + ka)
    T = np.vstack([zip_rings(params[r], params[r + 1], ids[r], ids[r + 1]) for r in range(M + 1)])
    if want_rings:
        return np.vstack(rings), T, params, order
    return np.vstack(rings), T


def _ring_count(X, spacing, fine):
    """Vertices of a tube ring through the closed polyline ``X``: as many as
    its length holds at ``spacing``, at least 3 and at most ``fine``."""
    length = float(np.linalg.norm(np.roll(X, -1, axis=0) - X, axis=1).sum())
    return int(np.clip(round(length / max(spacing, 1e-300)), 3, fine))


def resample_tube(PA, PB, params, order, P, spacing):
    """A tube over the surface of another one, with rings ``spacing`` apart.

    The tube ``P`` (positions of a :func:`guide_tube` built with a coarser
    spacing, typically faired) is read as a surface swept from loop A to
    loop B: along each of ``max(ka, kb)`` evenly spaced loop parameters
    ``u`` the rings are joined by a polyline, and the new rings are placed
    at equal fractions of its length, as many as the mean length holds at
    ``spacing``; each new ring gets as many vertices as its length holds
    (at most the finer loop's count), as :func:`guide_tube` does. The new
    tube follows the coarse one's shape, not the arcs: its size is that of
    the surface it spans.

    Parameters
    ----------
    PA, PB : (ka,3), (kb,3) float64
        The loops, each in its boundary half-edge order.
    params, order
        As :func:`guide_tube` returns them with ``rings=True`` (``params``
        not None).
    P : (q,3) float64
        Positions of that tube's new vertices (in its order).
    spacing : float
        Target distance between rings (the rim's edge length).

    Returns
    -------
    P2 : (q2,3) float64
    T2 : (t2,3) int64
        Triangles over ``[PA; PB; P2]``, oriented like :func:`guide_tube`'s.
    """
    ka = len(PA)
    C = np.asarray(PB, np.float64)[order]
    fine = max(ka, len(C))
    us = np.arange(fine) / fine
    sizes = [len(p) for p in params[1:-1]]
    Xr = np.split(np.asarray(P, np.float64), np.cumsum(sizes)[:-1])
    Y = np.stack([lerp_loop(params[0], PA, us)] + [lerp_loop(p, X, us) for p, X in zip(params[1:-1], Xr)]
                 + [lerp_loop(params[-1], C, us)])            # (rings, fine, 3): the sweep
    seg = np.linalg.norm(np.diff(Y, axis=0), axis=2)
    cum = np.vstack([np.zeros(fine), np.cumsum(seg, axis=0)])  # length along each sweep line
    M = int(max(0, round(float(cum[-1].mean()) / max(spacing, 1e-300)) - 1))
    if M == 0:
        return np.zeros((0, 3)), zip_rings(params[0], params[-1], np.arange(ka), order + ka)
    cols = np.arange(fine)
    rings, ps, ids = [], [params[0]], [np.arange(ka)]
    base = ka + len(C)
    for r in range(1, M + 1):
        s = (r / (M + 1)) * cum[-1]
        j = np.minimum((cum[1:] <= s[None]).sum(axis=0), len(Y) - 2)  # segment of each line holding s
        w = np.clip((s - cum[j, cols]) / np.maximum(seg[j, cols], 1e-300), 0.0, 1.0)
        Z = (1 - w)[:, None] * Y[j, cols] + w[:, None] * Y[j + 1, cols]
        m = _ring_count(Z, spacing, fine)
        u = np.arange(m) / m
        rings.append(Z if m == fine else lerp_loop(us, Z, u))
        ps.append(u)
        ids.append(base + np.arange(m))
        base += m
    ps.append(params[-1])
    ids.append(order + ka)
    T = np.vstack([zip_rings(ps[r], ps[r + 1], ids[r], ids[r + 1]) for r in range(M + 1)])
    return np.vstack(rings), T
