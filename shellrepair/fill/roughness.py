"""How noisy a hole's rim is, and the same noise given to a test's rim.

The order test (:mod:`shellrepair.fill.probe`) cuts test holes into intact
scan beside a hole and refills them at each fairing order; a tube's test
(:mod:`shellrepair.fill.band_test`) cuts test bands beside its loops. A
scan's rim often carries the scanner's noise (a ragged fringe) that a
higher order carries on into the hole; the tests' rims, cut through clean
scan, would not. So the real rim's noise (:func:`rim_noise`) is measured
once per hole or loop, and each test's rim is given what the real rim has
beyond its own (:func:`add_noise`); a test hole's only where the real rim
is clearly the noisier (:data:`SIGNIFICANCE`).

The noise is read from the umbrella offsets along the normal (each rim
vertex's offset from the mean of its neighbours). Those hold the surface's
curvature term (about κh², changing slowly along the rim) and the noise
(independent from one vertex to the next). The offsets' differences from one
rim vertex to the next cancel the first. A test's rim lies elsewhere on the
scan, where the curvature term is not the real rim's, so the offsets
themselves would count a difference in curvature as noise.

- A clean genus-2 arm's real rims (0.00113) read rougher by their offsets
  than its test bands' (0.00095-0.00112). Given to the test rims as noise,
  that difference turned the tube's choice from order 3 (0.068 per mille
  from the truth) to order 2 (0.282). Compared by their noise (0.00029
  against 0.00023-0.00037) they are alike. With a ragged fringe of 0.1 edge,
  the real rims' noise is 0.0031.
- Test holes were compared by the offsets until 2026-12-07. On five discs
  of a fat torus (case 8 of seed 162639851) the discs' test holes lay on
  less curved scan. The difference given to them as noise ranked order 3
  after order 2 on every disc: 4.95 per mille, where order 3 gives 0.577
  (eval/results/order-test/probe-noise/).
"""

from __future__ import annotations

import numpy as np

from shellrepair.mesh.geometry import cross, uniq

__all__ = ["rim_noise", "add_noise", "SIGNIFICANCE"]

#: A test hole's rim is given the real rim's noise only where the real
#: rim's noise variance exceeds the test rim's by more than this many
#: sampling errors of the difference (:func:`add_noise`): the usual two
#: standard errors, set before it was screened, not fitted.
SIGNIFICANCE = 2.0


def _rim_normals(V, F, loop):
    """For each rim vertex: the mean of its neighbours along the faces
    around it and its unit normal (area-weighted face normals summed);
    ``F`` holds at least the faces that touch the rim."""
    loop = np.asarray(loop, np.int64)
    k = len(loop)
    order = np.argsort(loop, kind="stable")
    srt = loop[order]

    def at(v):          # position of v in the loop, or -1
        i = np.minimum(np.searchsorted(srt, v), k - 1)
        return np.where(srt[i] == v, order[i], -1)

    F = np.asarray(F, np.int64)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E.sort(axis=1)
    # the edges once each, in (low, high) order: np.unique(E, axis=0)'s rows
    # by one key per edge (its row-wise unique cost 0.16 ms a call)
    n = max(len(V), int(E.max()) + 1) if len(E) else 1
    key = uniq(E[:, 0] * np.int64(n) + E[:, 1])
    E = np.column_stack([key // n, key % n])
    E = np.concatenate([E, E[:, ::-1]])          # both ways: (rim vertex, neighbour)
    E = E[at(E[:, 0]) >= 0]
    i = at(E[:, 0])
    nb = np.zeros((k, 3))
    cnt = np.zeros(k)
    np.add.at(nb, i, V[E[:, 1]])
    np.add.at(cnt, i, 1.0)
    N = cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    vn = np.zeros((k, 3))
    for c in range(3):
        j = at(F[:, c])
        ok = j >= 0
        np.add.at(vn, j[ok], N[ok])
    ln = np.linalg.norm(vn, axis=1)
    good = (cnt > 0) & (ln > 0)
    mean = np.where(cnt[:, None] > 0, nb / np.maximum(cnt, 1.0)[:, None], V[loop])
    unit = np.where(good[:, None], vn / np.where(ln > 0, ln, 1.0)[:, None], 0.0)
    return mean, unit, good


def _touching(Vl, Fl, ploop):
    """The faces of ``Fl`` that touch the rim ``ploop``, in their order
    (the sums over them come out the same)."""
    on = np.zeros(len(Vl), bool)
    on[ploop] = True
    return Fl[on[Fl].any(axis=1)]


def rim_noise(V, F, loop):
    """A rim's noise along its normal, apart from the surface's curvature.

    The umbrella offsets along the normal (each rim vertex's offset from
    the mean of its neighbours) hold the surface's curvature term (about
    κh², changing slowly along the rim) and the scanner's noise
    (independent from one vertex to the next). The
    offsets' differences from each rim vertex to the next cancel the first;
    their RMS over √2 is the noise's standard deviation.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
        At least the faces that touch the rim.
    loop : (k,) int64
        The rim, in order around it.

    Returns
    -------
    sigma : float
        0 where no two neighbours along the rim have a normal.
    """
    V = np.asarray(V, np.float64)
    loop = np.asarray(loop, np.int64)
    return _umbrella_noise(V, loop, *_rim_normals(V, F, loop))


def _umbrella_noise(V, loop, mean, unit, good):
    """:func:`rim_noise` from the rim's :func:`_rim_normals`."""
    off = ((V[loop] - mean) * unit).sum(axis=1)
    ok = good & np.roll(good, -1)
    if not ok.any():
        return 0.0
    d = (np.roll(off, -1) - off)[ok]
    return float(np.sqrt(np.mean(d * d) / 2.0))


def add_noise(Vl, Fl, ploop, noise, seed, count=None):
    """A test rim given a real rim's noise (:func:`rim_noise`).

    Its vertices are moved along their normals by normal offsets of
    standard deviation ``sqrt(noise² − own²)``, ``own`` being the test
    rim's own noise, where the real rim is the noisier.

    With ``count`` (the real rim's vertices), only where it is clearly
    the noisier: ``noise² − own²`` over ``SIGNIFICANCE`` times its
    sampling error. Each is estimated from its rim's vertex-to-vertex
    differences, a variance over k of them with a sampling variance of
    about 2σ⁴/k. Two clean rims read alike within that error (a fat
    torus's disc rims 0.000172, their test rims 0.000153-0.000186: the
    grid's own jags). Given as noise, such a difference ranked order 3
    after order 2 on discs where order 3 is truest. A ragged fringe
    reads 10-20 times a clean rim's noise, far beyond it.

    Parameters
    ----------
    Vl : (n,3) float64
        The test's scan (local).
    Fl : (m,3) int64
    ploop : (k,) int64
        The test rim, in order around it.
    noise : float
        The real rim's :func:`rim_noise`.
    seed : int
        Seeds the offsets (the same offsets for the same scan).
    count : int, optional
        The real rim's vertex count (None: any excess is added).

    Returns
    -------
    V : (n,3) float64
        A copy of ``Vl`` with the rim moved, or ``Vl`` itself where the
        test rim is as noisy already.
    """
    ploop = np.asarray(ploop, np.int64)
    mean, unit, good = _rim_normals(Vl, _touching(Vl, Fl, ploop), ploop)
    own = _umbrella_noise(np.asarray(Vl, np.float64), ploop, mean, unit, good)
    if count is not None:
        error = np.sqrt(2.0 * noise ** 4 / max(int(count), 1) + 2.0 * own ** 4 / max(len(ploop), 1))
        if noise * noise - own * own <= SIGNIFICANCE * error:
            return Vl
    extra = float(np.sqrt(max(noise * noise - own * own, 0.0)))
    if extra <= 0.0:
        return Vl
    z = np.random.default_rng(seed).standard_normal(len(ploop))
    out = Vl.copy()
    out[ploop] += (extra * z)[:, None] * unit
    return out
