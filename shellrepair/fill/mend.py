"""Mend a hole's patch where it crosses the scan or itself (the fill's last layer).

A patch that fails its checks (:func:`shellrepair.fill.checks.check_patch`)
usually fails in a few small places: at a spike or a flap of the scan's rim
that folds back into the opening, where two parts of a long loop run close
together, at a sharp jag of the rim. Everywhere else it is a good surface.
:func:`mend_patch` keeps it there and cuts the loop's filling into simpler
sub-loops around the faults:

1. the faulty triangles, grown by ``MEND_RINGS`` rings, form regions; each
   region that is a disc is cut out of the patch, leaving a hole whose
   loop runs over patch vertices and rim vertices (a sub-loop, tens of
   edges);
2. each sub-loop is triangulated by Liepa's minimum-weight search
   (:func:`shellrepair.fill.triangulate.restricted_dp`) over candidate triangles
   that cross neither the scan nor the patch kept around it, repeat no edge
   the two already have, and are not degenerate: the triangles of the
   sub-loop's 3D Delaunay tetrahedralization first (they never cross each
   other), then every triangle of its vertices (``MEND_ALL_MAX``); where
   none avoids the scan, a fan around one new vertex (a Steiner point: one
   of the region's own patch vertices, or a point on the sub-loop's axis)
   whose triangles cross nothing (:func:`_fan`);
3. the mended patch is checked whole; regions whose sub-loop has no such
   triangulation, and new faults, are grown and cut again, at most
   ``MEND_ROUNDS`` times.

A region is never larger than ``MEND_MAX_LOOP`` boundary edges, so one
round costs a few candidate tests per sub-loop: the layer adds well under a
second to a hole of a thousand edges. When it cannot mend the patch it says
why (:class:`MendResult`): a fault whose region grew past the limit (the
scan passes through the patch far from the rim, where only a differently
shaped surface avoids it), a sub-loop with no triangulation that crosses
nothing, or faults left after the last round.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from shellrepair.errors import MeshError
from shellrepair.fill.triangulate import delaunay_faces, restricted_dp, with_loop_edges
from shellrepair.mesh.geometry import cross, dot
from shellrepair.mesh.intersect import TriangleIndex, patch_vs_index

#: Rings of patch triangles added around the faulty ones before cutting.
MEND_RINGS = 1
#: Rounds of cutting, re-triangulating and checking.
MEND_ROUNDS = 6
#: Longest sub-loop re-triangulated (boundary edges of one region).
MEND_MAX_LOOP = 120
#: Sub-loops up to this many edges also try every triangle of their
#: vertices (C(m,3) candidates) when the Delaunay ones have no answer.
MEND_ALL_MAX = 30
#: Triangles with less area than this fraction of their longest edge
#: squared are degenerate candidates (slivers fold onto neighbours).
MEND_MIN_ASPECT = 1e-6


class MendResult(NamedTuple):
    """What mending one patch gave."""
    patch: object      # the mended Patch, or None
    reason: str        # why it could not be mended ("" when it was)
    regions: int       # regions cut out and re-triangulated
    rounds: int


def _grow(T, mark, rings):
    """Triangles sharing a vertex with the marked ones, ``rings`` times."""
    mark = mark.copy()
    n = int(T.max()) + 1
    for _ in range(rings):
        vm = np.zeros(n, bool)
        vm[T[mark].ravel()] = True
        mark |= vm[T].any(axis=1)
    return mark


def _components(T, sel):
    """Edge-connected components of the triangles ``sel`` (indices into T)."""
    sel = np.asarray(sel, np.int64)
    if sel.size == 0:
        return []
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    E = np.concatenate([T[sel][:, [0, 1]], T[sel][:, [1, 2]], T[sel][:, [2, 0]]])
    E = np.sort(E, axis=1)
    owner = np.tile(np.arange(sel.size), 3)
    order = np.lexsort((E[:, 1], E[:, 0]))
    E, owner = E[order], owner[order]
    same = (E[1:] == E[:-1]).all(axis=1)
    a, b = owner[:-1][same], owner[1:][same]
    g = coo_matrix((np.ones(a.size), (a, b)), shape=(sel.size, sel.size))
    n, lab = connected_components(g, directed=False)
    return [sel[lab == c] for c in range(n)]


def _boundary_loop(T, comp):
    """The region's boundary as one loop in the patch's loop convention
    (the kept side to the left), or None when it is not one simple loop
    (an annulus around kept triangles, a region pinched at a vertex)."""
    he = np.concatenate([T[comp][:, [0, 1]], T[comp][:, [1, 2]], T[comp][:, [2, 0]]])
    key = {(int(a), int(b)) for a, b in he.tolist()}
    bd = [(a, b) for a, b in key if (b, a) not in key]
    if len(bd) < 3:
        return None
    nxt = {}
    for a, b in bd:
        if a in nxt:          # two boundary edges leave one vertex: pinched
            return None
        nxt[a] = b
    start = bd[0][0]
    chain = [start]
    v = nxt[start]
    while v != start:
        if v not in nxt or len(chain) > len(bd):
            return None
        chain.append(v)
        v = nxt[v]
    if len(chain) != len(bd):   # more than one loop
        return None
    return np.array(chain[::-1], np.int64)   # the region's half-edges run a -> b: the loop runs b -> a


def _unit_normals(X, T):
    n = cross(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]])
    ln = np.sqrt(dot(n, n))
    return np.divide(n, ln[:, None], out=np.zeros_like(n), where=ln[:, None] > 0)


def _candidates(m, Q):
    """Candidate triangles (sorted corners) of a sub-loop of m vertices:
    its Delaunay faces, then (when small) every other triple."""
    out = []
    D = delaunay_faces(Q)
    if D is not None:
        out.append(with_loop_edges(D, m))
    if m <= MEND_ALL_MAX:
        a, b, c = np.meshgrid(np.arange(m), np.arange(m), np.arange(m), indexing="ij")
        sel = (a < b) & (b < c)
        A = np.column_stack([a[sel], b[sel], c[sel]]).astype(np.int64)
        if out:
            n = np.int64(m)
            A = A[~np.isin((A[:, 0] * n + A[:, 1]) * n + A[:, 2], (out[0][:, 0] * n + out[0][:, 1]) * n + out[0][:, 2])]
            A = np.concatenate([out[0], A])   # the second search: every triple
        out.append(A)
    return out


class _Region(NamedTuple):
    """What one round knows about the patch around its regions."""
    X: np.ndarray          # patch positions: loop vertices, then new ones
    gid: np.ndarray        # scan ids (new vertices negative)
    T: np.ndarray
    keep: np.ndarray       # (t,) bool: triangles kept
    vt_order: np.ndarray   # vertex -> triangles (CSR)
    vt_start: np.ndarray
    lo: np.ndarray         # (t,3) triangle boxes
    hi: np.ndarray
    forbidden: set         # loop-position pairs the scan joins
    rim_normals: np.ndarray  # (k,3) scan normal across loop edge (i, i+1)
    k: int


def _region_context(X, gid, T, keep, forbidden, rim_normals, k):
    n = len(X)
    owner = np.repeat(np.arange(len(T)), 3)
    order = np.argsort(T.ravel(), kind="stable")
    start = np.searchsorted(T.ravel()[order], np.arange(n + 1))
    C = X[T]
    return _Region(X, gid, T, keep, owner[order], start, C.min(axis=1), C.max(axis=1), forbidden, rim_normals, k)


def _fill_region(ctx, R, L, comp):
    """Triangles (patch numbering) closing the sub-loop ``L``, or None."""
    m = len(L)
    X, T, k = R.X, R.T, R.k
    Q = X[L]
    origin = Q.mean(axis=0)
    # kept triangles at the sub-loop's vertices: the edges they have
    s, e = R.vt_start[L], R.vt_start[L + 1]
    near = np.unique(np.concatenate([R.vt_order[a:b] for a, b in zip(s.tolist(), e.tolist())]))
    near = near[R.keep[near]]
    pos = np.full(len(X), -1, np.int64)
    pos[L] = np.arange(m)
    forb = set()
    en = np.zeros((m, 3))
    Tn = T[near]
    Nn = _unit_normals(X, Tn)
    for j in range(3):
        a, b = pos[Tn[:, j]], pos[Tn[:, (j + 1) % 3]]
        both = (a >= 0) & (b >= 0)
        # the half-edge L[i] -> L[i+1] of a kept triangle: its normal is across sub-loop edge i
        across = both & (b == (a + 1) % m)
        en[a[across]] = Nn[across]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        chord = both & (hi - lo > 1) & ~((lo == 0) & (hi == m - 1))
        forb.update(zip(lo[chord].tolist(), hi[chord].tolist()))
    # rim edges (loop positions i -> i+1, both below k) and the scan's own edges
    ga, gb = L, np.roll(L, -1)
    rim = (ga < k) & (gb < k) & (gb == (ga + 1) % k) & ~en.any(axis=1)
    en[rim] = R.rim_normals[ga[rim]]
    onloop = np.flatnonzero(L < k)
    if onloop.size > 1:
        for x, y in R.forbidden:
            i, j = pos[x], pos[y]
            if i >= 0 and j >= 0:
                i, j = min(i, j), max(i, j)
                if j - i > 1 and not (i == 0 and j == m - 1):
                    forb.add((int(i), int(j)))
    # the kept triangles in the sub-loop's box: what a candidate must not cross
    lo, hi = Q.min(axis=0), Q.max(axis=0)
    Tk = np.flatnonzero(R.keep & np.all((R.hi >= lo) & (R.lo <= hi), axis=1))
    kept_index = TriangleIndex(X, T[Tk], origin=origin) if Tk.size else None
    for cand in _candidates(m, Q):
        T_ = _lazy_search(ctx, R, L, Q - origin, cand, en, forb, kept_index)
        if T_ is not None:
            return L[T_], np.zeros((0, 3))
    return _fan(ctx, R, L, comp, en)


def _fan(ctx, R, L, comp, en):
    """The sub-loop closed by a fan around one new vertex (a Steiner point),
    where no triangulation of its own vertices avoids the scan: the apex is
    tried at the region's own patch vertices and along the sub-loop's axis
    through its centre; the allowed fan with the smallest worst dihedral
    cost wins. (triangles, (1,3) apex) with the apex numbered ``len(X)``,
    or None."""
    X, m = R.X, len(L)
    if m > MEND_FAN_MAX:
        return None
    Q = X[L]
    c = Q.mean(axis=0)
    va = -0.5 * cross(Q - c, np.roll(Q - c, -1, axis=0)).sum(axis=0)
    ln = float(np.sqrt(dot(va, va)))
    rad = float(np.max(np.sqrt(dot(Q - c, Q - c))))
    if not np.isfinite(rad) or rad <= 0:
        return None
    axis = va / ln if ln > 0 else np.zeros(3)
    inner = np.setdiff1d(np.unique(R.T[comp].ravel()), L)
    inner = inner[inner >= R.k]
    if inner.size > MEND_FAN_CANDIDATES:
        inner = inner[np.linspace(0, inner.size - 1, MEND_FAN_CANDIDATES).astype(np.int64)]
    A = np.vstack([X[inner].reshape(-1, 3)] + [c + t * rad * axis for t in MEND_FAN_OFFSETS])
    # fan triangle i: (L[i+1], L[i], apex), for each apex candidate
    nxt = np.roll(np.arange(m), -1)
    C = np.empty((len(A), m, 3, 3))
    C[:, :, 0] = Q[nxt][None]
    C[:, :, 1] = Q[None]
    C[:, :, 2] = A[:, None]
    C = C.reshape(-1, 3, 3)
    ok = _not_degenerate(C).reshape(len(A), m).all(axis=1)
    N = _unit_normals(C.reshape(-1, 3), np.arange(3 * len(C)).reshape(-1, 3)).reshape(len(A), m, 3)
    has = en.any(axis=1)
    worst = np.max(np.where(has[None], 1.0 - np.einsum("amj,mj->am", N, en), 0.0), axis=1)
    worst = np.maximum(worst, np.max(1.0 - np.einsum("amj,amj->am", N, np.roll(N, -1, axis=1)), axis=1))
    if not ok.any():
        return None
    # every candidate fan tested at once: against the scan, then the kept patch in their box
    C4 = C.reshape(len(A), m, 3, 3)
    G = np.column_stack([L[nxt], L, np.full(m, len(X))])
    gid = np.column_stack([R.gid[L[nxt]], R.gid[L], np.full(m, -(1 << 40))])
    live = np.flatnonzero(ok)
    tri = C4[live].reshape(-1, 3, 3)
    hit = np.zeros(len(tri), bool)
    hit[patch_vs_index(tri, np.tile(gid, (live.size, 1)), ctx.index, return_faces=True)] = True
    lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
    Tk = np.flatnonzero(R.keep & np.all((R.hi >= lo) & (R.lo <= hi), axis=1))
    if Tk.size:
        Gt = np.tile(G, (live.size, 1))
        Gt[:, 2] = len(X) + np.repeat(np.arange(live.size), m)      # each apex its own id
        hit[patch_vs_index(tri, Gt, TriangleIndex(X, R.T[Tk], origin=c), return_faces=True)] = True
    clear = live[~hit.reshape(live.size, m).any(axis=1)]
    if clear.size == 0:
        return None
    a = int(clear[np.argmin(worst[clear])])
    return G, A[a][None]


#: Longest sub-loop closed by a fan (:func:`_fan`).
MEND_FAN_MAX = 60
#: Apex candidates of a fan: at most this many of the region's own vertices ...
MEND_FAN_CANDIDATES = 48
#: ... and these points on the sub-loop's axis, in units of its radius from its centre.
MEND_FAN_OFFSETS = (0.0, 0.25, -0.25, 0.5, -0.5, 1.0, -1.0)


def _lazy_search(ctx, R, L, Q, cand, en, forb, kept_index):
    """The minimum-weight triangulation among the allowed candidates: the
    tests are asked only about each answer's triangles, the rejected ones
    leave and the search runs again (as ``triangulate._restricted``)."""
    m = len(L)
    ok = _not_degenerate(Q[cand])
    verdict = np.zeros(len(cand), np.int8)
    n = np.int64(m)
    key = (cand[:, 0] * n + cand[:, 1]) * n + cand[:, 2]
    order = np.argsort(key)
    for rnd in range(MEND_LAZY_ROUNDS + 1):
        if rnd == MEND_LAZY_ROUNDS:       # the last round: ask about every candidate left
            if len(cand) > MEND_TEST_ALL:
                return None
            ask = np.flatnonzero(ok & (verdict == 0))
            if ask.size:
                verdict[ask] = np.where(_allowed(ctx, R, L, cand[ask], kept_index), 1, -1)
                ok &= verdict >= 0
        if not ok.any():
            return None
        try:
            S = restricted_dp(Q, cand[ok], en, forb, None)
        except MeshError:
            return None
        Ss = np.sort(S, axis=1)
        at = order[np.searchsorted(key[order], (Ss[:, 0] * n + Ss[:, 1]) * n + Ss[:, 2])]
        ask = at[verdict[at] == 0]
        if ask.size:
            verdict[ask] = np.where(_allowed(ctx, R, L, cand[ask], kept_index), 1, -1)
        if (verdict[at] > 0).all():
            return S
        ok[at[verdict[at] < 0]] = False
    return None


#: Rounds of the lazy search before every candidate is tested at once.
MEND_LAZY_ROUNDS = 16
#: Candidate sets up to this size are tested whole after the lazy rounds.
MEND_TEST_ALL = 2000


def _not_degenerate(C):
    e = np.stack([C[:, 1] - C[:, 0], C[:, 2] - C[:, 1], C[:, 0] - C[:, 2]], axis=1)
    longest = np.max(np.sum(e * e, axis=2), axis=1)
    n = cross(C[:, 1] - C[:, 0], C[:, 2] - C[:, 0])
    return np.sqrt(dot(n, n)) > MEND_MIN_ASPECT * longest


def _allowed(ctx, R, L, cand, kept_index):
    """Which candidates (sub-loop positions) cross neither the scan nor the kept patch."""
    G = L[cand]                       # patch numbering
    C = R.X[G]
    ok = np.ones(len(cand), bool)
    bad = patch_vs_index(C, R.gid[G], ctx.index, return_faces=True)
    ok[bad] = False
    idx = np.flatnonzero(ok)
    if idx.size and kept_index is not None:
        bad = patch_vs_index(C[idx], G[idx], kept_index, return_faces=True)
        ok[idx[bad]] = False
    return ok


def _with_apexes(ctx, patch, loop, extra, new_T, k):
    """The patch's new vertices with the fans' apexes appended, and their
    colours and properties (an apex takes the mean over its fan's rim)."""
    if not extra:
        return patch.P, patch.colors, dict(patch.props)
    A = np.vstack(extra)
    first = k + len(patch.P)
    rims = []
    for S in new_T:
        top = S.max()
        if top >= first:
            rims.append(np.unique(S[S < first]))
    def per_vertex(loop_vals, new_vals):
        allv = np.concatenate([loop_vals, new_vals]).astype(np.float64)
        return np.array([allv[r].mean(axis=0) for r in rims])
    colors = None
    if patch.colors is not None and ctx.colors is not None:
        c = per_vertex(ctx.colors[loop], patch.colors)
        colors = np.vstack([patch.colors, np.clip(np.round(c), 0, 255).astype(patch.colors.dtype)])
    props = {}
    for n, v in patch.props.items():
        if n in ctx.props:
            a = per_vertex(np.asarray(ctx.props[n])[loop], v)
            props[n] = np.concatenate([v, a.astype(v.dtype) if np.issubdtype(v.dtype, np.floating)
                                       else np.round(a).astype(v.dtype)])
    return np.vstack([patch.P, A]), colors, props


def mend_patch(ctx, patch, bad, check, rings=MEND_RINGS, rounds=MEND_ROUNDS):
    """Cut the faulty regions out of a patch and re-triangulate them.

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
    patch : shellrepair.fill.patch.Patch
        A patch that failed its checks (a disc bounded by ``patch.loop``).
    bad : (b,) int64
        Its faulty triangles (indices into ``patch.T``).
    check : callable
        ``check(ctx, patch) -> (reason or None, faulty triangles)``, the
        fill's own checks.
    rings, rounds : int
        ``MEND_RINGS``, ``MEND_ROUNDS``.

    Returns
    -------
    MendResult
    """
    from shellrepair.fill.patch import Patch

    loop = np.asarray(patch.loop, np.int64)
    k = len(loop)
    q = len(patch.P)
    X = np.vstack([ctx.V[loop], patch.P])
    gid = np.concatenate([loop, -1 - np.arange(q)])        # scan ids; new vertices negative
    T = np.asarray(patch.T, np.int64)
    from shellrepair.mesh.index import rim_data

    _, edge_normals, forbidden = rim_data(ctx, loop)       # loop positions = patch numbering
    rim_normals = np.asarray(edge_normals, np.float64)
    fault = np.zeros(len(T), bool)
    fault[np.asarray(bad, np.int64)] = True
    region = _grow(T, fault, rings)
    memo = {}
    why = f"faults left after {rounds} rounds"
    regions = 0
    for rnd in range(1, rounds + 1):
        comps = _components(T, np.flatnonzero(region))
        keep = ~region
        loops = []
        grow = np.zeros(len(T), bool)
        for comp in comps:
            L = _boundary_loop(T, comp)
            if L is not None and len(L) > MEND_MAX_LOOP:
                return MendResult(None, f"the region around a fault grew to {len(L)} boundary edges, past "
                                        f"{MEND_MAX_LOOP}: {why}", regions, rnd)
            if L is None:       # not a disc yet (an annulus, a pinch): grown by a ring
                grow[comp] = True
            else:
                loops.append((comp, L))
        if grow.any():
            region = _grow(T, region & grow, 1) | region
            why = (f"{int(np.count_nonzero([grow[c[0]] for c in comps]))} region(s) around the faults are "
                   f"not discs (they surround kept triangles or pinch at a vertex) after {rnd} growth(s)")
            continue
        R = _region_context(X, gid, T, keep, forbidden, rim_normals, k)
        new_T = []
        extra = []             # apexes of fans, numbered from len(X) on
        failed = []
        widest = 0
        for comp, L in loops:
            key = tuple(L.tolist())
            if key not in memo:       # the same sub-loop of the same patch: the same answer
                memo[key] = _fill_region(ctx, R, L, comp)
            got = memo[key]
            if got is None:
                failed.append(comp)
                widest = max(widest, len(L))
            else:
                S, apex = got
                if len(apex):      # the fan's apex: numbered after the apexes already taken
                    S = np.where(S >= len(X), len(X) + sum(len(a) for a in extra) + S - len(X), S)
                    extra.append(apex)
                new_T.append(S)
        if failed:
            for c in failed:
                grow[c] = True
            region = _grow(T, region & grow, 1) | region
            why = (f"{len(failed)} region(s) around the faults (up to {widest} edges round) have no "
                   f"triangulation that crosses neither the scan nor the rest of the patch")
            continue
        regions += len(loops)
        T2 = np.vstack([T[keep]] + new_T)
        P_all, colors, props = _with_apexes(ctx, patch, loop, extra, new_T, k)
        # drop the new vertices no triangle uses any more; renumber
        used = np.zeros(k + len(P_all), bool)
        used[T2.ravel()] = True
        used[:k] = True
        remap = np.cumsum(used) - 1
        keep_new = np.flatnonzero(used[k:])
        cand = Patch(hole_id=patch.hole_id, loop=loop, P=P_all[keep_new], T=remap[T2],
                     colors=None if colors is None else colors[keep_new],
                     props={n: v[keep_new] for n, v in props.items()}, T0=patch.T0, energy=None,
                     order=patch.order, disc=patch.disc, kind=patch.kind, rerouted=patch.rerouted,
                     pinned=patch.pinned)
        w, b2 = check(ctx, cand)
        if w is None:
            return MendResult(cand, "", regions, rnd)
        why = f"after re-triangulating {len(loops)} region(s): {w}"
        if b2.size == 0:
            break
        # carry on with the mended patch: its faults, grown, are the next regions
        X = np.vstack([ctx.V[loop], cand.P])
        q = len(cand.P)
        gid = np.concatenate([loop, -1 - np.arange(q)])
        patch = cand
        T = cand.T
        memo = {}
        fault = np.zeros(len(T), bool)
        fault[b2] = True
        region = _grow(T, fault, rings)
    return MendResult(None, why, regions, rounds)
