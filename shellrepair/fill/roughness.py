"""How ragged a hole's rim is, and the same raggedness given to a test hole's rim.

The order test (:mod:`shellrepair.fill.probe`) cuts test holes into intact
scan beside a hole and refills them at each fairing order. A scan's rim
often carries the scanner's noise (a ragged fringe) that a higher order
carries on into the hole; the test holes' rims, cut through clean scan,
would not. So the real rim's roughness (:func:`rim_roughness`, the RMS
umbrella offset along the normal) is measured once per hole and each test
hole's rim is given as much (:func:`roughen`), the two compared at the real
rim's density: a smooth surface's umbrella offset grows as the edge length
squared, so a test rim on finer scan is not taken for a smoother one.

The tube's test bands (:mod:`shellrepair.fill.band_test`) are given the
real loops' noise instead (:func:`rim_noise`, :func:`add_noise`): the
offsets' differences from one rim vertex to the next, where the surface's
curvature term, which changes slowly along a rim, cancels. A test band's
rims lie rings away from the real loops, where the curvature term is not
the real rim's: compared by their roughness, a clean genus-2 arm's real
rims (0.00113) read rougher than its test bands' (0.00095-0.00112), and
the difference, given to the test rims as noise, turned the tube's choice
from order 3 (0.068 per mille from the truth) to order 2 (0.282). Compared
by their noise (0.00029 against 0.00023-0.00037) they are alike; with a
ragged fringe of 0.1 edge the real rims' noise is 0.0031.
"""

from __future__ import annotations

import numpy as np

from shellrepair.mesh.geometry import cross, mean_edge, uniq

__all__ = ["rim_roughness", "roughen", "rim_noise", "add_noise"]


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


def rim_roughness(V, F, loop):
    """How far a rim's vertices stand off the surface of their neighbours.

    The umbrella operator along the normal: each rim vertex's offset from
    the mean of its neighbours, along its normal; the RMS over the rim. On
    a smooth scan sampled at edge h with curvature κ it is of the order of
    κh²; a rim carrying a scanner's noise (a ragged fringe) adds the
    noise's amplitude.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
        At least the faces that touch the rim.
    loop : (k,) int64

    Returns
    -------
    r : float
    """
    V = np.asarray(V, np.float64)
    return _umbrella_rms(V, loop, *_rim_normals(V, F, loop))


def _umbrella_rms(V, loop, mean, unit, good):
    """:func:`rim_roughness` from the rim's :func:`_rim_normals`."""
    if not good.any():
        return 0.0
    off = ((V[np.asarray(loop, np.int64)] - mean) * unit).sum(axis=1)[good]
    return float(np.sqrt(np.mean(off * off)))


def roughen(Vl, Fl, ploop, rough, seed, edge=None):
    """The test hole's rim given the real rim's roughness: its vertices
    moved along their normals by normal offsets of RMS
    ``sqrt(rough² − own²)`` (``own``: the test rim's own roughness), where
    the real rim is rougher.

    The two are compared at the real rim's density: on a smooth surface the
    umbrella offset grows as the edge length squared (κh²), so ``own`` is
    taken times ``(edge / h)²`` (``h``: the test rim's mean edge length).
    Otherwise a test hole laid where the scan is finer than at the real rim
    reads as smoother, and its rim is given noise the real rim does not
    have: on a fat torus (r/R 0.7, its grid finer on the inner side) the
    discs' test rims had 0.5-0.8 times the real rims' roughness from their
    shorter edges alone, and the noise added to them ranked order 3 last
    on holes where it is truest (order 2 0.0026, order 3 0.0136 where
    without the noise order 3 gives 0.0031).

    Parameters
    ----------
    Vl : (n,3) float64
        The test hole's scan (local).
    Fl : (m,3) int64
    ploop : (k,) int64
        The test hole's rim.
    rough : float
        The real rim's :func:`rim_roughness`.
    seed : int
        Seeds the offsets (the same offsets for the same scan).
    edge : float, optional
        The real rim's mean edge length (None: the two rims' roughness
        compared as they are).

    Returns
    -------
    V : (n,3) float64
        A copy of ``Vl`` with the rim moved, or ``Vl`` itself where the
        test rim is as rough already.
    """
    mean, unit, good = _rim_normals(Vl, _touching(Vl, Fl, ploop), ploop)
    own = _umbrella_rms(Vl, ploop, mean, unit, good)
    if edge is not None:
        h = mean_edge(Vl, np.asarray(ploop, np.int64))
        if h > 0.0 and np.isfinite(edge) and edge > 0.0:
            own *= (edge / h) ** 2
    return _offset(Vl, ploop, unit, rough, own, seed)


def _touching(Vl, Fl, ploop):
    """The faces of ``Fl`` that touch the rim ``ploop``, in their order
    (the sums over them come out the same)."""
    on = np.zeros(len(Vl), bool)
    on[ploop] = True
    return Fl[on[Fl].any(axis=1)]


def _offset(Vl, ploop, unit, real, own, seed):
    """``Vl`` with the rim ``ploop`` moved along ``unit`` by normal
    offsets of standard deviation ``sqrt(real² − own²)`` drawn from
    ``seed``; ``Vl`` itself where ``own`` is as large already (the shared
    step of :func:`roughen` and :func:`add_noise`)."""
    extra = float(np.sqrt(max(real * real - own * own, 0.0)))
    if extra <= 0.0:
        return Vl
    z = np.random.default_rng(seed).standard_normal(len(ploop))
    out = Vl.copy()
    out[ploop] += (extra * z)[:, None] * unit
    return out


def rim_noise(V, F, loop):
    """A rim's noise along its normal, apart from the surface's curvature.

    The umbrella offsets along the normal (:func:`rim_roughness`'s) hold
    the surface's curvature term (about κh², changing slowly along the rim)
    and the scanner's noise (independent from one vertex to the next). The
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


def add_noise(Vl, Fl, ploop, noise, seed):
    """A test rim given a real rim's noise (:func:`rim_noise`).

    Its vertices are moved along their normals by normal offsets of
    standard deviation ``sqrt(noise² − own²)``, ``own`` being the test
    rim's own noise, where the real rim is the noisier.

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

    Returns
    -------
    V : (n,3) float64
        A copy of ``Vl`` with the rim moved, or ``Vl`` itself where the
        test rim is as noisy already.
    """
    ploop = np.asarray(ploop, np.int64)
    mean, unit, good = _rim_normals(Vl, _touching(Vl, Fl, ploop), ploop)
    return _offset(Vl, ploop, unit, noise, _umbrella_noise(np.asarray(Vl, np.float64), ploop, mean, unit, good), seed)
