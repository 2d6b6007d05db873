"""Compiled kernels of the dipole diffusion (Numba): :mod:`.dipole` (Jensen et al. 2001).

:func:`dipole_rd`, :func:`dipole_tail_fraction` and :func:`dipole_profile`,
one pass over the points each.  How they are made fast:
:mod:`.common_kernels`; their NumPy versions: :mod:`.reference`.
"""

from __future__ import annotations

import math

from shellrepair.appearance.reflectance._constants import _TINY
from shellrepair.appearance.reflectance.common_kernels import PI, _at, _bits_to_float, _clip, _float_to_bits, _ftz_enter, _ftz_exit, _inline, _slp, jit, vexp


# --------------------------------------------------------------------------
# Dipole (Jensen et al. 2001)
# --------------------------------------------------------------------------


@_inline
def dipole_A_1(eta):
    # the oracle's operations exactly: near eta ~ 3.86, where F_dr -> 1, A
    # magnifies an ulp of F_dr without bound (one reciprocal of eta for both
    # terms gave 2.6e-10 relative there)
    F_dr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
    return (1.0 + F_dr) / (1.0 - F_dr)


@jit
def dipole_rd(lo, hi, alpha, eta, out):
    alpha = _slp(alpha, lo, hi)
    eta = _slp(eta, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        a = _clip(_at(alpha, i), 0.0, 1.0)
        A = dipole_A_1(_at(eta, i))
        s = math.sqrt(3.0 * (1.0 - a))
        out[i] = 0.5 * a * (1.0 + vexp(-(4.0 / 3.0) * A * s)) * vexp(-s)
    _ftz_exit(old)


#: the exponent field of a float64; EXP_MASK - (bits(x) & EXP_MASK) are the bits of 2^(1 - E), x = 2^E f
_EXP_MASK = 0x7FF0000000000000


@_inline
def _dipole_geometry(r, sa, ss, eta):
    sa = max(sa, _TINY)
    ss = max(ss, 0.0)
    r = max(r, 0.0)
    st = sa + ss  # sigma_t'
    s_tr = math.sqrt(3.0 * sa * st)
    zr = 1.0 / st
    zv = zr * (1.0 + 4.0 / 3.0 * dipole_A_1(eta))
    dr = math.sqrt(r * r + zr * zr)
    dv = math.sqrt(r * r + zv * zv)
    return ss * zr, s_tr, zr, zv, dr, dv  # alpha' = ss / st by the reciprocal already formed


@jit
def dipole_tail_fraction(lo, hi, r, sa, ss, eta, out):
    r = _slp(r, lo, hi)
    sa = _slp(sa, lo, hi)
    ss = _slp(ss, lo, hi)
    eta = _slp(eta, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        _, s_tr, zr, zv, dr, dv = _dipole_geometry(_at(r, i), _at(sa, i), _at(ss, i), _at(eta, i))
        # (zr e_r / dr + zv e_v / dv) / total as one quotient, both sides
        # times dr dv: three divisions -> one (0.8 ns a point each here).
        # dr, dv, zr, zv are first scaled by sc = 2^(1 - E), dr = 2^E f
        # (exact), so that dr lands in [2, 4) and dr dv neither overflows nor
        # underflows (|zv| <= dv, zr <= dr); dr = inf (r or zr beyond ~1e154,
        # where r^2 overflows) is the oracle's e^-inf / inf
        sc = _bits_to_float(_EXP_MASK - (_float_to_bits(dr) & _EXP_MASK))
        drs = dr * sc
        dvs = dv * sc
        e_r = vexp(-s_tr * dr)
        tail = (zr * sc) * e_r * dvs + (zv * sc) * vexp(-s_tr * dv) * drs
        total = vexp(-s_tr * zr) + vexp(-s_tr * zv)
        q = tail / (drs * dvs * max(total, _TINY))
        q = e_r * 0.0 if dr == math.inf else q  # 0, or NaN where s_tr dr is (s_tr = 0), as the oracle
        out[i] = _clip(q, 0.0, 1.0)
    _ftz_exit(old)


@jit
def dipole_profile(lo, hi, r, sa, ss, eta, out):
    r = _slp(r, lo, hi)
    sa = _slp(sa, lo, hi)
    ss = _slp(ss, lo, hi)
    eta = _slp(eta, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        alpha, s_tr, zr, zv, dr, dv = _dipole_geometry(_at(r, i), _at(sa, i), _at(ss, i), _at(eta, i))
        pole_r = zr * (1.0 + s_tr * dr) * vexp(-s_tr * dr) / (dr * dr * dr)  # real source
        pole_v = zv * (1.0 + s_tr * dv) * vexp(-s_tr * dv) / (dv * dv * dv)  # virtual source
        out[i] = alpha / (4.0 * PI) * (pole_r + pole_v)
    _ftz_exit(old)


#: The kernels of this module, by name (for warm_up's count and the tests).
KERNELS = ("dipole_rd", "dipole_tail_fraction", "dipole_profile")
