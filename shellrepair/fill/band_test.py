"""Which tube continues the scan best across a missing band, asked of test bands beside its loops.

A tube (the band missing between two loops, :mod:`shellrepair.fill.band_fill`)
does not fill like a disc, so its test is a band too: :func:`tube_errors`
cuts a band of intact scan beside each loop, as long as the missing band,
refills it as a tube at each fairing order and held on its continuation
arcs (:data:`HELD`), and measures the removed scan against each fill, the
errors combined as the test holes' are (:class:`shellrepair.fill.probe.Pooled`:
the geometric mean over the test bands of each one's RMS).
:func:`shellrepair.fill.hole.band_order` reads the verdict.

A test band's rims are given the real loops' noise
(:func:`shellrepair.fill.roughness.rim_noise`), as test holes' rims are
(those only where the real rim is clearly the noisier): a tube faired to a ragged rim carries its
noise across the whole band, and a test band cut through clean scan does
not show it. With every rim given a scanner's fringe (``eval/regret.py
--ragged 0.1``), on the band cases of three seeds drawn for the check
(581494271, 490954791, 946901298; 8 bands each), the regret went from
1.667, 1.406 and 1.798 to 1.262, 1.208 and 1.076 (cases over 1.5: 10 to
2); on the same seeds' clean rims it is unchanged (1.026, 1.000, 1.044).
One ragged torus band had been filled at order 2 20.96 per mille from the
truth where the held tube lies at 1.70 (BENCHMARKS.md, "Ragged rims").
"""

from __future__ import annotations

import numpy as np

from shellrepair.fill.probe import ROUGHNESS_SEED, Pooled
from shellrepair.fill.roughness import add_noise, rim_noise
from shellrepair.mesh.geometry import mean_edge

__all__ = ["tube_errors", "HELD", "MIN_BANDS", "TUBE_GAP_RINGS", "TUBE_MARGIN_RINGS", "TUBE_MEASURE_POINTS"]

#: The tube's candidate that is not a fairing order: the first tube (along
#: the continuation arcs) refined and held, not faired.
HELD = "held"
#: Rings of intact scan left between a tube's real loop and its test band.
TUBE_GAP_RINGS = 3
#: Rings of scan kept beyond the test band (the fairing reads up to 3).
TUBE_MARGIN_RINGS = 4
#: Test bands a tube's verdict needs: one beside each loop. One band alone
#: is not repeated evidence (as for test holes, ``probe.MIN_PROBES``): on a
#: torus seen from a ring of views, the one band that fitted beside its
#: unseen inner band rated order 2 and 3 alike (0.041 and 0.043), where
#: order 3 fills the real band six times closer (1.05 against 6.44 per
#: mille, case 7 of seed 1538843172). On the development seeds (731, 733,
#: 735, 920328247, 508373691, 213891280, 408096311: five tubes with one
#: band) the RMS moved on one case only, 16.357 -> 16.361 per mille.
MIN_BANDS = 2
#: A test band's removed scan is measured at this many of its vertices at
#: most (every k-th, in the order of their ids): each measure finds the 8
#: fill triangles nearest a point, and where the test tube lies far from
#: the band (two far-apart loops) that search visits every triangle. On
#: an armadillo's discs, 31k removed vertices against test tubes of 32k
#: triangles took 6 of the repair's 9.8 s (5.7 s after); on 96
#: development cases (seeds 731, 733, 735, 408096311, 213891280,
#: 920328247) every output is the same either way.
TUBE_MEASURE_POINTS = 4096


def tube_errors(ctx, A, B, candidates):
    """RMS error of each candidate order on test bands of a tube's own kind.

    A tube (the missing band between loops ``A`` and ``B``) does not fill
    like a disc: its patch runs round the part from loop to loop. So the
    test is a band too: beside each loop, ``TUBE_GAP_RINGS`` rings out, a
    band of intact scan as many rings wide as the missing band is long in
    the loop's edges (:func:`_band_length`: along the continuation arcs
    from loop to loop) is cut away, refilled as a tube is (its two
    rims joined along their continuation arcs,
    :func:`shellrepair.fill.tube.guide_tube`, then refined and faired at each
    order, :func:`shellrepair.fill.patch.build_patch`), and the removed scan is
    measured against each fill. A test band that is not a clean band (it
    meets another hole or a border, or its rims are not two loops) is
    skipped; the held tube is judged only where both test bands were made
    (it follows both loops' arcs: on an arm missing a band between its
    stump and a domed fingertip, the stump's test band alone ranked the
    held tube first, 0.0026 against order 3's 0.0055, where on the real
    band it lies 7x further from the arm than order 3).

    Parameters
    ----------
    ctx : shellrepair.mesh.index.ScanContext
    A, B : shellrepair.holes.loops.Loop
    candidates : sequence of int or HELD
        Fairing orders, and :data:`HELD` for the tube held on its arcs.

    Returns
    -------
    errors : dict of (int or str) -> float
        Pooled over the test bands; empty when none could be cut and filled.
    tests : int
    """
    from shellrepair.errors import MeshError
    from shellrepair.fill.patch import PatchError, build_patch
    from shellrepair.holes.loops import boundary_loops
    from shellrepair.mesh.distance import point_mesh_distance
    from shellrepair.mesh.index import ScanContext
    from shellrepair.mesh.io import Mesh

    V, F = ctx.V, ctx.F
    pool = Pooled(candidates)
    gap = _band_length(ctx, A, B)     # how far the missing band runs from loop to loop
    if not np.isfinite(gap):
        return {}, 0
    # the real loops' noise, given to each test band's rims (pooled: a test
    # band stands for the whole missing band, both its rims)
    real = [np.asarray(L.vertices, np.int64) for L in (A, B)]
    noise = float(np.sqrt(np.mean([rim_noise(V, F[ctx.ring_faces(x, 1)], x) ** 2 for x in real])))
    given = 0
    for L in (A, B):
        loop = np.asarray(L.vertices, np.int64)
        h = mean_edge(V, loop)
        if not h > 0:
            continue
        w = max(2, int(round(gap / h)))
        m = TUBE_GAP_RINGS
        band = np.setdiff1d(ctx.ring_faces(loop, m + w), ctx.ring_faces(loop, m))
        keep = np.setdiff1d(ctx.ring_faces(loop, m + w + TUBE_MARGIN_RINGS), band)
        if band.size == 0 or keep.size == 0:
            continue
        g, Fl = np.unique(F[keep], return_inverse=True)
        Fl = Fl.reshape(-1, 3).astype(np.int64)
        bverts = np.unique(F[band])
        removed = np.setdiff1d(bverts, g)
        if removed.size == 0:
            continue
        loops, chains = boundary_loops(Fl, len(g))
        if chains:
            continue
        on_band = np.isin(g, bverts)
        rims = [np.asarray(lp, np.int64) for lp in loops if on_band[lp].all()]
        if len(rims) != 2:
            continue
        origin = V[g].mean(axis=0)
        try:
            Vl = V[g] - origin
            for rim in rims:
                Vl = add_noise(Vl, Fl, rim, noise, ROUGHNESS_SEED + given)
                given += 1
            lctx = ScanContext(Mesh(V=Vl, F=Fl))
            LA, LB = rims
            Pg, Tg, _ = _first_tube(lctx, LA, LB)
            if not (len(Pg) and np.isfinite(Pg).all()):
                continue
            tl = np.concatenate([LA, LB])
            Q = V[removed] - origin
            if len(Q) > TUBE_MEASURE_POINTS:
                Q = Q[::-(-len(Q) // TUBE_MEASURE_POINTS)]

            def fills():
                q = None          # the refined tube's new vertices (the same at every order)
                for o in candidates:
                    if o == HELD:     # the first tube refined, every vertex held where the arcs put it
                        if q is None:
                            q = len(build_patch(lctx, 0, tl, order=2, initial=(Pg, Tg)).P)
                        p = build_patch(lctx, 0, tl, order=2, initial=(Pg, Tg), pinned=np.arange(q))
                    else:
                        p = build_patch(lctx, 0, tl, order=o, initial=(Pg, Tg))
                        q = len(p.P)
                    yield o, point_mesh_distance(Q, np.vstack([lctx.V[tl], p.P]), p.T)

            pool.add(fills())
        except (MeshError, PatchError, ValueError, IndexError, FloatingPointError):
            continue
    # the held tube follows both loops' arcs: a test beside one loop only
    # does not see the other's, so it is not judged there
    return pool.rms(keep=lambda o: o != HELD or pool.tests == 2), pool.tests


def _band_length(ctx, A, B):
    """The length of the missing band between loops ``A`` and ``B`` along
    the surface: the first tube's rings (:func:`_first_tube`), about one
    rim edge apart, counted, times their spacing; inf where no first tube
    is made."""
    LA, LB = (np.asarray(L.vertices, np.int64) for L in (A, B))
    try:
        Pg, _, spacing = _first_tube(ctx, LA, LB)
    except (ValueError, IndexError, FloatingPointError):
        return float("inf")
    if not np.isfinite(Pg).all():
        return float("inf")
    return (len(Pg) / max(len(LA), 1) + 1.0) * spacing


def _first_tube(ctx, LA, LB):
    """The first tube between loops ``LA`` and ``LB`` of ``ctx`` along
    their continuation arcs (:func:`shellrepair.fill.tube.guide_tube`, rings
    at the rim's mean edge, arcs followed up to ``MAX_REACH`` times the
    larger loop's diameter): (new vertices, triangles, ring spacing).
    (:func:`shellrepair.fill.band_fill._fill_pair` builds the real band's the same
    way, with the loops' diameters as detect_holes measured them.)"""
    from shellrepair.fill.bridge import MAX_REACH, continuation_arcs
    from shellrepair.fill.tube import guide_tube
    from shellrepair.holes.loops import _diameter
    from shellrepair.mesh.index import rim_data

    PA, PB = ctx.V[LA], ctx.V[LB]
    arcs = [continuation_arcs(ctx.V, ctx.F[ctx.ring_faces(x, 3)], x) for x in (LA, LB)]
    spacing = float(np.mean(rim_data(ctx, np.concatenate([LA, LB]))[0]))
    Pg, Tg = guide_tube(PA, PB, *arcs, spacing=spacing, reach=MAX_REACH * max(_diameter(PA), _diameter(PB)))
    return Pg, Tg, spacing
