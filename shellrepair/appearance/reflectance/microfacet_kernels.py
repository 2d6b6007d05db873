"""Compiled kernels of the microfacet terms (Numba): :mod:`.microfacet` (eqs 8-13).

Beckmann D, the V-cavity G, the dielectric and conductor Fresnel factors
and the Torrance-Sparrow lobe, one pass over the points each; the per-point
helpers (``beckmann_1``, ``fresnel_dielectric_1``, ``microfacet_1``, ...)
are inlined into :mod:`.layered_kernels` and :mod:`.shader_kernels` too.
How they are made fast, and the switch that turns them off:
:mod:`.common_kernels`.  Their NumPy versions (the test oracles):
:mod:`.reference`.
"""

from __future__ import annotations

import math

import numpy as np

from shellrepair.appearance.reflectance._constants import COS_EPS, M_MIN, MU_FLOOR, _TINY
from shellrepair.appearance.reflectance.common_kernels import BLOCK, PI, _at, _clip, _ftz_enter, _ftz_exit, _inline, _slp, _to_rows, jit, vexp


# --------------------------------------------------------------------------
# Microfacet terms (eqs 8-13)
# --------------------------------------------------------------------------


@_inline
def beckmann_1(c, m):
    c = _clip(c, 0.0, 1.0)
    m = max(m, M_MIN)
    ok = c > COS_EPS
    cs = c if ok else 1.0
    c2 = cs * cs
    m2 = m * m
    # eq 13 with the 1/pi, one division: inv = 1 / (m^2 c^2) gives both
    # -tan^2 / m^2 = (c^2 - 1) inv and 1 / (pi m^2 c^4) = inv (inv m^2) / pi
    # (inv <= 1e30 for c > COS_EPS, m >= M_MIN: no overflow)
    inv = 1.0 / (c2 * m2)
    D = vexp((c2 - 1.0) * inv) * inv * (inv * m2) * (1.0 / PI)
    return D if ok else 0.0


@_inline
def fresnel_dielectric_1(c, eta):
    c = _clip(abs(c), 0.0, 1.0)
    g2 = eta * eta + c * c - 1.0
    tir = g2 < 0.0
    g = math.sqrt(0.0 if tir else g2)
    # a = na / da, b = nb / db (eq 12) by one reciprocal t = 1 / (da db):
    # a = na db t, b = nb da t, within 3 ulp of the two quotients.  The
    # operands are scaled by 2^-4 where g > 1e150 (exact) so that da db
    # cannot overflow below the g at which the oracle's eta^2 does; they
    # cannot both be tiny (da -> 0 needs c -> 0, where db -> 1), so
    # da db >= ~_TINY / 2 and t stays finite
    s = 0.0625 if g > 1e150 else 1.0
    na = (g - c) * s
    da = max(g + c, _TINY) * s
    nb = (c * (g + c) - 1.0) * s
    db = max(c * (g - c) + 1.0, _TINY) * s
    t = 1.0 / (da * db)
    a = na * (db * t)
    b = nb * (da * t)
    F = 0.5 * a * a * (1.0 + b * b)  # eq 12
    return 1.0 if tir else _clip(F, 0.0, 1.0)


@_inline
def fresnel_conductor_1(c, n, k):
    c = _clip(abs(c), 0.0, 1.0)
    c2 = c * c
    s2 = 1.0 - c2
    t = n * n - k * k - s2
    a2b2 = math.sqrt(t * t + 4.0 * n * n * k * k)  # |(n+ik)^2 - s^2|
    a = math.sqrt(max(0.5 * (a2b2 + t), 0.0))
    rs_num = a2b2 - 2.0 * a * c + c2
    rs_den = a2b2 + 2.0 * a * c + c2
    Rs = rs_num / max(rs_den, _TINY)
    p1 = c2 * a2b2 + s2 * s2
    p2 = 2.0 * a * c * s2
    Rp = Rs * (p1 - p2) / max(p1 + p2, _TINY)
    return _clip(0.5 * (Rs + Rp), 0.0, 1.0)


@_inline
def v_cavity_1(nh, ni, no, oh):
    nh = _clip(nh, 0.0, 1.0)
    ni = _clip(ni, 0.0, 1.0)
    no = _clip(no, 0.0, 1.0)
    front = oh > 0.0
    ohs = oh if front else 1.0
    # eq 11, min(1, G1, G2) with G1 = 2 nh no / oh (eq 9), G2 = 2 nh ni / oh
    # (eq 10), by one division: x -> (2 nh) x / oh is monotone in each
    # rounding (nh >= 0, oh > 0), so min(G1, G2) = (2 nh) min(no, ni) / oh
    # bit for bit; two divisions of 8 lanes cost ~32 cycles, more than the
    # 40 bytes a point streams
    G = min(1.0, 2.0 * nh * min(no, ni) / ohs)
    return G if front else 0.0


@jit
def beckmann_D(lo, hi, c, m, out):
    c = _slp(c, lo, hi)
    m = _slp(m, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        out[i] = beckmann_1(_at(c, i), _at(m, i))
    _ftz_exit(old)


@jit
def v_cavity_G(lo, hi, nh, ni, no, oh, out):
    nh = _slp(nh, lo, hi)
    ni = _slp(ni, lo, hi)
    no = _slp(no, lo, hi)
    oh = _slp(oh, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        out[i] = v_cavity_1(_at(nh, i), _at(ni, i), _at(no, i), _at(oh, i))
    _ftz_exit(old)


@jit
def fresnel_dielectric(lo, hi, c, eta, out):
    c = _slp(c, lo, hi)
    eta = _slp(eta, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        out[i] = fresnel_dielectric_1(_at(c, i), _at(eta, i))
    _ftz_exit(old)


@jit
def fresnel_conductor(lo, hi, c, n, k, out):
    c = _slp(c, lo, hi)
    n = _slp(n, lo, hi)
    k = _slp(k, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        out[i] = fresnel_conductor_1(_at(c, i), _at(n, i), _at(k, i))
    _ftz_exit(old)


@_inline
def microfacet_1(w0, w1, w2, v0, v1, v2, n0, n1, n2, m):
    """(DG4, oh, n.i, n.o) of one point, as ``microfacet._microfacet_geometry``."""
    ni = n0 * w0 + n1 * w1 + n2 * w2
    no = n0 * v0 + n1 * v1 + n2 * v2
    h0 = w0 + v0
    h1 = w1 + v1
    h2 = w2 + v2
    hlen = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
    valid = (ni > COS_EPS) & (no > COS_EPS) & (hlen > COS_EPS)
    hs = hlen if valid else 1.0
    h0 = h0 / hs
    h1 = h1 / hs
    h2 = h2 / hs
    nh = _clip(n0 * h0 + n1 * h1 + n2 * h2, 0.0, 1.0)
    oh = _clip(v0 * h0 + v1 * h1 + v2 * h2, 0.0, 1.0)
    # grazing guard: the cosines of eq 8's denominator floored at MU_FLOOR
    nis = max(ni if valid else 1.0, MU_FLOOR)
    nos = max(no if valid else 1.0, MU_FLOOR)
    ohs = max(oh, COS_EPS)
    g_over = min(1.0 / (nis * nos), 2.0 * nh / (ohs * max(nis, nos)))  # G / (ni no), eq 11
    D = beckmann_1(nh, m)  # eq 13
    DG4 = 0.25 * D * g_over if valid else 0.0  # eq 8 without F
    return DG4, oh, ni, no


@_inline
def _mf_row(a, t, m):
    return microfacet_1(a[0, t], a[1, t], a[2, t], a[3, t], a[4, t], a[5, t], a[6, t], a[7, t], a[8, t], m)


@jit
def torrance_sparrow(lo, hi, wi, wo, n, m, eta, out):
    a = np.empty((9, BLOCK))
    old = _ftz_enter()
    for i0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - i0)
        _to_rows(wi, i0, bn, a, 0)
        _to_rows(wo, i0, bn, a, 3)
        _to_rows(n, i0, bn, a, 6)
        mb = _slp(m, i0, i0 + bn)
        eb = _slp(eta, i0, i0 + bn)
        ob = out[i0:i0 + bn]
        for t in range(bn):
            DG4, oh, _, _ = _mf_row(a, t, _at(mb, t))
            ob[t] = DG4 * fresnel_dielectric_1(oh, _at(eb, t))  # eq 8
    _ftz_exit(old)


@jit
def torrance_sparrow_conductor(lo, hi, wi, wo, n, m, n_metal, k_metal, out):
    C = n_metal.shape[0]
    a = np.empty((9, BLOCK))
    g = np.empty((2, BLOCK))
    old = _ftz_enter()
    for i0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - i0)
        _to_rows(wi, i0, bn, a, 0)
        _to_rows(wo, i0, bn, a, 3)
        _to_rows(n, i0, bn, a, 6)
        mb = _slp(m, i0, i0 + bn)
        for t in range(bn):
            DG4, oh, _, _ = _mf_row(a, t, _at(mb, t))
            g[0, t] = DG4
            g[1, t] = oh
        for ch in range(C):
            nc = n_metal[ch]
            kc = k_metal[ch]
            for t in range(bn):
                out[i0 + t, ch] = g[0, t] * fresnel_conductor_1(g[1, t], nc, kc)
    _ftz_exit(old)


#: The kernels of this module, by name (for warm_up's count and the tests).
KERNELS = ("beckmann_D", "v_cavity_G", "fresnel_dielectric", "fresnel_conductor", "torrance_sparrow",
           "torrance_sparrow_conductor")
