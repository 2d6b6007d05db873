"""Fused compiled kernels of the reflectance functions (Numba).

Each public per-point function of :mod:`shellrepair.reflectance` and
:class:`shellrepair.shader.MaterialShader` evaluates here in one pass over
the points: no array temporaries, every guard of the NumPy version applied
in the same order, and the NumPy version kept beside it as the test oracle
(``_<name>_np`` in each module).  Results agree with the oracle within
1e-12 relative (the shader 1e-11); see tests/test_reflectance_kernels.py.

Why it is fast
--------------
- One loop per point instead of ~30 array temporaries.
- ``exp``, ``expm1`` and ``log`` are written out below (range reduction to
  a short polynomial, the power of two built from its bits) so that LLVM
  vectorises the loops; libm's scalar ``exp`` cost ~10 ns a call here.
  Each is within 1.2 ulp of libm's (tested).  Their polynomials use FMA
  (``llvm.fmuladd``, :func:`_fma`) and exp rounds k by the 1.5 * 2^52
  shifter instead of a float-to-int conversion: a vectorised exp loop
  2.50 -> 1.47 ms on 1e6 points (a plain copy of the same arrays 1.1).
- On AVX-512 CPUs the kernels ask LLVM for 512-bit vectors
  (:func:`_prefer_wide_vectors`; LLVM's default there is 256): the loops
  are arithmetic-bound, and 8 lanes halve the instructions.  With the
  above, one thread, 1e6 points: beckmann_D 4.9 -> 2.2 ms CPU,
  dipole_rd 8.4 -> 4.0, dipole_tail_fraction 17.7 -> 10.0,
  km_reflectance 8.0 -> 5.3, mean_transmittance 12.4 -> 7.8.
- Divisions and square roots stay true IEEE operations (~16 cycles per 8
  lanes: 0.8 ns a point for a division here, 1.2 for a sqrt, against
  0.25 for a copy in L2); a Newton reciprocal (FMA only) with a per-block
  exact fallback was tried on the dipole kernels and was no faster (more
  FMAs, register spills), nor was a bit-trick rsqrt or reciprocal with
  Newton steps on km_r_inf (measured again), so they are not used.  What
  can go is a division the formula does not need: v_cavity_G takes one
  (min(G1, G2) bit for bit), fresnel_dielectric one reciprocal for its two
  quotients, dipole_tail_fraction one quotient for three.  Where the
  function is ill-conditioned (km_reflectance near R -> 0, the rho_dt
  reads through internal_reflectance's 1 - rho_bar / eta^2, dipole_A near
  its pole) the kernels keep the oracle's operations: an ulp moved there
  costs 1e-11 relative, past the 1e-12 the tests state.
  ``python eval/bench_shading.py --ceilings`` prints what bounds each
  function (bytes streamed, the arithmetic in L2, one-thread ratios).
- Loops vectorise only when they have no gather and no wraparound branch:
  directions (P, 3) are first copied per block of :data:`BLOCK` points
  into rows, table reads are split into an index stage (vectorised) and a
  read stage, the kappa nodes are formed arithmetically, and array indices
  start at 0 (slices).  Measured, one thread: torrance_sparrow 43 -> 21 ns
  a point, diffuse_transmittance 56 -> 27, mean_transmittance 57 -> 12.
- Subnormals are flushed to zero inside a kernel (FTZ/DAZ, restored on
  exit): they cost a microcode assist per vector instruction (5x on the
  Beckmann kernel with random inputs).
- Scalar parameters (``m``, ``eta`` of one material) are passed as
  scalars and arrays as arrays; Numba compiles one specialisation per
  combination (:func:`_at`), so a constant is never expanded to an array.
- Large inputs are split into contiguous ranges run by a thread pool; the
  kernels release the GIL (``nogil``).  Chosen over ``prange``: in a quick
  measurement on this 2-core machine (shared with other jobs) the OpenMP
  ``prange`` loop ran slower than one thread and did not vectorise, while
  threads over vectorised ranges keep the vector loop.  The pool is
  remade after a fork.

Compiled code is cached (``cache=True``: in ``__pycache__`` beside this
file, or Numba's per-user cache directory when that is not writable);
:func:`shellrepair.shader.warm_up` compiles every specialisation the
library uses, and ``make setup`` calls it.  This module is imported on the
first call of a shading function, so importing the package does not
import Numba.

Set ``SHELLREPAIR_NO_NUMBA=1`` to use the NumPy versions everywhere, and
``SHELLREPAIR_THREADS`` to cap the threads (default: the CPUs this process
may use).
"""

from __future__ import annotations

import math
import os
import platform
import threading

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

# the NumPy versions' constants, repeated as plain floats for the kernels
from ._constants import COS_EPS, M_MIN, MU_FLOOR, _TINY

_OPTS = dict(cache=True, nogil=True, error_model="numpy")
jit = numba.njit(**_OPTS)
_inline = numba.njit(inline="always", **_OPTS)

PI = math.pi
EPS2 = COS_EPS * COS_EPS

# --------------------------------------------------------------------------
# Subnormals flushed to zero inside a kernel
# --------------------------------------------------------------------------
# A product or an exp that lands below 2.2e-308 (e.g. the Beckmann D of a
# half vector far from the normal) is subnormal, and every vector
# instruction touching one takes a microcode assist: 5x on the Beckmann
# kernel with random inputs.  Each kernel sets FTZ and DAZ in MXCSR on
# entry and restores the caller's MXCSR on exit, so values below the
# smallest normal float64 become 0 there (x86-64 only; elsewhere a no-op).

_X86 = platform.machine().lower() in ("x86_64", "amd64")
_FTZ_DAZ = 0x8040


@intrinsic
def _mxcsr_get(typingctx):
    sig = types.uint32()

    def codegen(context, builder, signature, args):
        ptr = cgutils.alloca_once(builder, ir.IntType(32))
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [ptr.type]),
                                            "llvm.x86.sse.stmxcsr")
        builder.call(fn, [ptr])
        return builder.load(ptr)

    return sig, codegen


@intrinsic
def _mxcsr_set(typingctx, value):
    sig = types.void(types.uint32)

    def codegen(context, builder, signature, args):
        ptr = cgutils.alloca_once(builder, ir.IntType(32))
        builder.store(args[0], ptr)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [ptr.type]),
                                            "llvm.x86.sse.ldmxcsr")
        builder.call(fn, [ptr])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def _prefer_wide_vectors(typingctx):
    """Let LLVM vectorise the calling kernel with the widest registers (512-bit on AVX-512).

    On AVX-512 CPUs LLVM's default is 256-bit vectors ("prefer-256-bit"
    tuning); these kernels are arithmetic-bound loops, where 8 lanes do
    the same work in about half the instructions.  Sets the function
    attributes of the kernel being compiled (this intrinsic is inlined
    into it through :func:`_ftz_enter`); a no-op where there is no AVX-512.
    """
    sig = types.void()

    def codegen(context, builder, signature, args):
        try:  # llvmlite's attribute set checks names against its list; these are LLVM's string attributes
            attrs = builder.function.attributes
            set.add(attrs, '"prefer-vector-width"="512"')
            set.add(attrs, '"min-legal-vector-width"="512"')
        except (AttributeError, TypeError):  # another llvmlite: keep LLVM's default width, same results
            pass
        return context.get_dummy_value()

    return sig, codegen


if _X86:

    @_inline
    def _ftz_enter():
        _prefer_wide_vectors()
        old = _mxcsr_get()
        _mxcsr_set(old | np.uint32(_FTZ_DAZ))
        return old

    @_inline
    def _ftz_exit(old):
        _mxcsr_set(old)

else:  # pragma: no cover - not x86

    @jit
    def _ftz_enter():
        return np.uint32(0)

    @jit
    def _ftz_exit(old):
        pass


# --------------------------------------------------------------------------
# Vectorisable exp, expm1, log (within 1 ulp of libm, tested)
# --------------------------------------------------------------------------


@intrinsic
def _bits_to_float(typingctx, x):
    """Reinterpret an int64 as the float64 with the same bits."""
    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))

    return sig, codegen


@intrinsic
def _float_to_bits(typingctx, x):
    """Reinterpret a float64 as the int64 with the same bits."""
    sig = types.int64(types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int64))

    return sig, codegen


_INV_LN2 = 1.4426950408889634
#: ln 2 split so that k * _LN2_HI is exact for |k| < 2^11 (Cody & Waite)
_LN2_HI = 0.6931471803691238
_LN2_LO = 1.9082149292705877e-10
_SQRT2 = 1.4142135623730951


@intrinsic
def _fma(typingctx, a, b, c):
    """a * b + c, fused where the CPU has FMA (``llvm.fmuladd``: one rounding
    there, two elsewhere; LLVM vectorises it like a multiply and an add)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        f64 = context.get_value_type(types.float64)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(f64, [f64, f64, f64]),
                                            "llvm.fmuladd.f64")
        return builder.call(fn, list(args))

    return sig, codegen


#: 1.5 * 2^52: adding it rounds a float below 2^51 in magnitude to an integer,
#: which then sits in the low bits of the sum's mantissa
_SHIFTER = 6755399441055744.0


@_inline
def _exp_parts(x):
    """exp(x) = (1 + em1) f1 f2 with x = k ln2 + r, |r| <= ~ln2/2, f1 f2 = 2^k.

    k = round(x / ln2) by the shifter (no float-to-int conversion), r by
    Cody & Waite with FMA, exp(r) - 1 = r + r^2 q(r) by Taylor to degree 13
    (truncation < 4e-18) in Horner form with FMA.  2^k is built from its
    bits as two normal factors, so that subnormal results and k = 1024
    (overflow to inf) come out right.  x is clamped to [-746, 710] first.
    """
    x = min(max(x, -746.0), 710.0)
    t = _fma(x, _INV_LN2, _SHIFTER)
    k = t - _SHIFTER
    ki = _float_to_bits(t) - _float_to_bits(_SHIFTER)
    r = _fma(-k, _LN2_HI, x)  # exact: k * _LN2_HI has at most 53 bits for |k| < 2^11
    r = _fma(-k, _LN2_LO, r)
    q = _fma(1.0 / 6227020800.0, r, 1.0 / 479001600.0)
    q = _fma(q, r, 1.0 / 39916800.0)
    q = _fma(q, r, 1.0 / 3628800.0)
    q = _fma(q, r, 1.0 / 362880.0)
    q = _fma(q, r, 1.0 / 40320.0)
    q = _fma(q, r, 1.0 / 5040.0)
    q = _fma(q, r, 1.0 / 720.0)
    q = _fma(q, r, 1.0 / 120.0)
    q = _fma(q, r, 1.0 / 24.0)
    q = _fma(q, r, 1.0 / 6.0)
    q = _fma(q, r, 0.5)
    em1 = _fma(q, r * r, r)  # exp(r) - 1
    k1 = ki >> 1
    k2 = ki - k1
    return em1, _bits_to_float((k1 + 1023) << 52), _bits_to_float((k2 + 1023) << 52)


@_inline
def vexp(x):
    """exp(x): 0 below -746, inf above 709.78, branch-free in between."""
    em1, f1, f2 = _exp_parts(x)
    return (1.0 + em1) * f1 * f2


@_inline
def vexpm1(x):
    """exp(x) - 1 without cancellation: (2^k - 1) + 2^k (exp(r) - 1), x = k ln2 + r.

    One polynomial for both branches: above x = 700 (where 2^k may overflow
    and the -1 is lost anyway) it returns vexp's value, bit for bit.
    """
    em1, f1, f2 = _exp_parts(x)
    s = f1 * f2  # 2^k
    small = (s - 1.0) + s * em1
    big = (1.0 + em1) * f1 * f2  # vexp(x)
    return big if x > 700.0 else small


@_inline
def vlog(x):
    """log(x) for positive normal x (callers floor x at M_MIN or more)."""
    b = _float_to_bits(x)
    e = (b >> 52) - 1023
    f = _bits_to_float((b & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000)  # mantissa in [1, 2)
    hi = f > _SQRT2
    f = f * 0.5 if hi else f
    ef = np.float64(e + 1) if hi else np.float64(e)
    s = (f - 1.0) / (f + 1.0)  # log f = 2 atanh(s), |s| <= 0.1716
    s2 = s * s
    p = _fma(1.0 / 21.0, s2, 1.0 / 19.0)
    p = _fma(p, s2, 1.0 / 17.0)
    p = _fma(p, s2, 1.0 / 15.0)
    p = _fma(p, s2, 1.0 / 13.0)
    p = _fma(p, s2, 1.0 / 11.0)
    p = _fma(p, s2, 1.0 / 9.0)
    p = _fma(p, s2, 1.0 / 7.0)
    p = _fma(p, s2, 1.0 / 5.0)
    p = _fma(p, s2, 1.0 / 3.0)
    return ef * _LN2_HI + (ef * _LN2_LO + 2.0 * s * (1.0 + s2 * p))


@jit
def _math_check(x, out_exp, out_expm1, out_log):
    """The three functions on an array (for the accuracy test)."""
    for i in range(x.shape[0]):
        out_exp[i] = vexp(x[i])
        out_expm1[i] = vexpm1(x[i])
        out_log[i] = vlog(abs(x[i]))


# --------------------------------------------------------------------------
# Scalars and arrays alike: _at(a, i)
# --------------------------------------------------------------------------


def _at(a, i):  # pragma: no cover - replaced by the overload in compiled code
    return a[i] if np.ndim(a) else a


@overload(_at, inline="always")
def _at_overload(a, i):
    if isinstance(a, types.Array):
        return lambda a, i: a[i]
    return lambda a, i: a


def _vec(v, i, k):  # pragma: no cover
    return v[i, k] if np.ndim(v) == 2 else v[k]


@overload(_vec, inline="always")
def _vec_overload(v, i, k):
    if isinstance(v, types.Array) and v.ndim == 2:
        return lambda v, i, k: v[i, k]
    return lambda v, i, k: v[k]


def _slp(a, lo, hi):  # pragma: no cover
    return a[lo:hi] if np.ndim(a) else a


@overload(_slp, inline="always")
def _slp_overload(a, lo, hi):
    """A per-point parameter's rows [lo, hi) (a scalar is every point's)."""
    if isinstance(a, types.Array):
        return lambda a, lo, hi: a[lo:hi]
    return lambda a, lo, hi: a


def _slv(v, lo, hi):  # pragma: no cover
    return v[lo:hi] if np.ndim(v) == 2 else v


@overload(_slv, inline="always")
def _slv_overload(v, lo, hi):
    """A (P, C) argument's rows [lo, hi); one shared (C,) row stays as it is."""
    if isinstance(v, types.Array) and v.ndim == 2:
        return lambda v, lo, hi: v[lo:hi]
    return lambda v, lo, hi: v


@_inline
def _clip(x, lo, hi):
    return min(max(x, lo), hi)


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


#: Points per block: the directions of a block are copied into rows (structure
#: of arrays, in cache) so that the arithmetic loop over the block runs on
#: contiguous rows and vectorises; on the interleaved (P, 3) input LLVM did
#: not vectorise it (43 against 18 ns a point for torrance_sparrow).
BLOCK = 256


@_inline
def _to_rows(v, i0, bn, a, row):
    """Copy directions i0 .. i0 + bn - 1 of v ((P, 3), or one (3,)) into rows row .. row + 2 of a."""
    for t in range(bn):
        a[row, t] = _vec(v, i0 + t, 0)
        a[row + 1, t] = _vec(v, i0 + t, 1)
        a[row + 2, t] = _vec(v, i0 + t, 2)


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


# --------------------------------------------------------------------------
# rho_dt table reads (eq 3): albedo._stencil / _trilinear, mean_transmittance
# --------------------------------------------------------------------------


@_inline
def _axis(x, x0, dx, n):
    f = _clip((x - x0) / dx, 0.0, n - 1.0)
    i = min(np.int64(f), n - 2)
    return i, f - i


@_inline
def _kappa_1(eta):
    e2 = eta * eta - 1.0
    s = np.float64(e2 > 0.0) - np.float64(e2 < 0.0)  # np.sign, without a branch
    return s * math.sqrt(abs(e2))


@_inline
def _next_to_one_1(kap_c, lo, up, wk):
    """albedo._next_to_one with the cell's nodes lo = Kp[k], up = Kp[min(k + 1, Nk - 1)]."""
    wk = 0.0 if ((kap_c < 0.0) & (up == 0.0)) else wk
    wk = 1.0 if ((kap_c > 0.0) & (lo == 0.0)) else wk
    wk = 1.0 if ((kap_c == 0.0) & (up == 0.0)) else wk
    return 0.0 if ((kap_c == 0.0) & (lo == 0.0)) else wk


@_inline
def _edge_aligned_1(x, c_query, c_node):
    lo = x * c_node / max(c_query, _TINY)
    hi = c_node + (x - c_query) * (1.0 - c_node) / max(1.0 - c_query, _TINY)
    return lo if x < c_query else hi


@_inline
def _node(dk0, k0, k):
    """Kp[k] formed as the grid was (albedo._grid: dk * arange(-k0, Nk)), bit for bit.

    Arithmetic instead of a load: LLVM does not vectorise a loop with a
    gather, and the index part of a table read is most of its arithmetic.
    """
    return dk0 * np.float64(k - k0)


@_inline
def _slice_cell(dk0, k0, U0, dU, NU, x, kap_c, k):
    """Cell (iu, wu) in u of kappa slice k, read at the cosine aligned to its critical angle."""
    kn = _node(dk0, k0, k)
    tir = (kap_c < 0.0) & (kn < 0.0)
    xe = _edge_aligned_1(x, -min(kap_c, 0.0), -min(kn, 0.0))
    xk = xe if tir else x
    return _axis(math.sqrt(xk), U0, dU, NU)


@_inline
def rho_index(x, m, eta, K_first, K_step, K_last, NK, dk0, k0, U0, dU, NU, L0, dL, NL):
    """The trilinear read of albedo._stencil as two base indices and four weights.

    Returns ``(i0, i1, wu0, wu1, wj, wk)``: node (iu, j, k) of slice k at
    flat index i0 and (iu', j, k + 1) at i1, the weights along u in each
    slice, along log m and along kappa.
    """
    x = _clip(x, 0.0, 1.0)
    lm = vlog(max(m, M_MIN))
    kap = _kappa_1(max(eta, _TINY))
    j, wj = _axis(lm, L0, dL, NL)
    k, wk = _axis(kap, K_first, K_step, NK)  # kappa axis as _stencil forms it: Kp[0], Kp[1] - Kp[0]
    kap_c = _clip(kap, K_first, K_last)
    wk = _next_to_one_1(kap_c, _node(dk0, k0, k), _node(dk0, k0, min(k + 1, NK - 1)), wk)
    iu0, wu0 = _slice_cell(dk0, k0, U0, dU, NU, x, kap_c, k)
    iu1, wu1 = _slice_cell(dk0, k0, U0, dU, NU, x, kap_c, k + 1)
    return (iu0 * NL + j) * NK + k, (iu1 * NL + j) * NK + k + 1, wu0, wu1, wj, wk


@_inline
def rho_combine(vals, NL, NK, i0, i1, wu0, wu1, wj, wk):
    """The 8 terms of the read, summed in NumPy's pairwise order (albedo._trilinear)."""
    sj = NK  # next m node
    su = NL * NK  # next u node
    a0 = 1.0 - wu0
    c0 = 1.0 - wu1
    ak0 = 1.0 - wk
    aj0 = 1.0 - wj
    t0 = a0 * aj0 * ak0 * vals[i0]
    t1 = a0 * wj * ak0 * vals[i0 + sj]
    t2 = wu0 * aj0 * ak0 * vals[i0 + su]
    t3 = wu0 * wj * ak0 * vals[i0 + su + sj]
    t4 = c0 * aj0 * wk * vals[i1]
    t5 = c0 * wj * wk * vals[i1 + sj]
    t6 = wu1 * aj0 * wk * vals[i1 + su]
    t7 = wu1 * wj * wk * vals[i1 + su + sj]
    return ((t0 + t1) + (t2 + t3)) + ((t4 + t5) + (t6 + t7))


@jit
def diffuse_transmittance(lo, hi, c, m, eta, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, out):
    """Per block: indices and weights (arithmetic, vectorised), then the 8 reads per point."""
    ix = np.empty((2, BLOCK), dtype=np.int64)
    wt = np.empty((4, BLOCK))
    NK = Kp.shape[0]
    K_first, K_step, K_last = Kp[0], Kp[1] - Kp[0], Kp[NK - 1]
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        cb = _slp(c, b0, b0 + bn)
        mb = _slp(m, b0, b0 + bn)
        eb = _slp(eta, b0, b0 + bn)
        for t in range(bn):
            i0, i1, wu0, wu1, wj, wk = rho_index(_at(cb, t), _at(mb, t), _at(eb, t), K_first, K_step, K_last, NK,
                                                 dk0, k0, U0, dU, NU, L0, dL, NL)
            ix[0, t] = i0
            ix[1, t] = i1
            wt[0, t] = wu0
            wt[1, t] = wu1
            wt[2, t] = wj
            wt[3, t] = wk
        for t in range(bn):
            r = rho_combine(vals, NL, NK, ix[0, t], ix[1, t], wt[0, t], wt[1, t], wt[2, t], wt[3, t])
            out[b0 + t] = _clip(r, 0.0, 1.0)
    _ftz_exit(old)


@_inline
def mean_index(m, eta, K_first, K_step, K_last, NK, dk0, k0, L0, dL, NL):
    """Cell and weights of albedo.mean_transmittance's bilinear read: (j, k, wj, wk, cq, kap_c)."""
    j, wj = _axis(vlog(max(m, M_MIN)), L0, dL, NL)
    kap = _kappa_1(max(eta, _TINY))
    k, wk = _axis(kap, K_first, K_step, NK)
    kap_c = _clip(kap, K_first, K_last)
    wk = _next_to_one_1(kap_c, _node(dk0, k0, k), _node(dk0, k0, min(k + 1, NK - 1)), wk)
    return j, k, wj, wk, -min(kap_c, 0.0), kap_c


@_inline
def mean_combine(j, k, wj, wk, cq, kap_c, dk0, k0, M, P, Q0, Q1):
    """The four node means (shifted to the query's critical angle for eta < 1), in NumPy's sum order."""
    if not kap_c < 0.0:  # eta >= 1: no slice is read shifted, the plain bilinear read of the means
        ak0 = 1.0 - wk
        aj0 = 1.0 - wj
        out = aj0 * ak0 * M[j, k]
        out = out + wj * ak0 * M[j + 1, k]
        out = out + aj0 * wk * M[j, k + 1]
        out = out + wj * wk * M[j + 1, k + 1]
        return _clip(out, 0.0, 1.0)
    out = 0.0
    for dk in range(2):
        ak = 1.0 - wk if dk == 0 else wk
        kk = k + dk
        kn = _node(dk0, k0, kk)
        cn = -min(kn, 0.0)
        tir = (kap_c < 0.0) & (kn < 0.0)
        cns = cn if tir else 1.0
        cqs = cq if tir else 1.0
        r = (1.0 - cqs) / max(1.0 - cns, _TINY)
        for dj in range(2):
            aj = 1.0 - wj if dj == 0 else wj
            jj = j + dj
            ratio = cqs / cns
            p, q0, q1, mv = P[jj, kk], Q0[jj, kk], Q1[jj, kk], M[jj, kk]
            shifted = ratio * ratio * p + 2.0 * r * cqs * q0 + 2.0 * r * r * (q1 - cns * q0)
            v = shifted if tir else mv
            out = out + aj * ak * v
    return _clip(out, 0.0, 1.0)


@_inline
def _mean_block(m, eta, b0, bn, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, ix, wt, res):
    """albedo.mean_transmittance of points b0 .. b0 + bn - 1 into res[:bn]: indices (vectorised), then the reads."""
    NK = Kp.shape[0]
    K_first, K_step, K_last = Kp[0], Kp[1] - Kp[0], Kp[NK - 1]
    mb = _slp(m, b0, b0 + bn)
    eb = _slp(eta, b0, b0 + bn)
    for t in range(bn):
        j, k, wj, wk, cq, kap_c = mean_index(_at(mb, t), _at(eb, t), K_first, K_step, K_last, NK, dk0, k0,
                                             L0, dL, NL)
        ix[0, t] = j
        ix[1, t] = k
        wt[0, t] = wj
        wt[1, t] = wk
        wt[2, t] = cq
        wt[3, t] = kap_c
    for t in range(bn):
        res[t] = mean_combine(ix[0, t], ix[1, t], wt[0, t], wt[1, t], wt[2, t], wt[3, t], dk0, k0, M, P, Q0, Q1)


@jit
def mean_transmittance(lo, hi, m, eta, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, out):
    ix = np.empty((2, BLOCK), dtype=np.int64)
    wt = np.empty((4, BLOCK))
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        _mean_block(m, eta, b0, bn, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, ix, wt, out[b0:b0 + bn])
    _ftz_exit(old)


@jit
def internal_reflectance(lo, hi, m, eta, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi, out):
    ix = np.empty((2, BLOCK), dtype=np.int64)
    wt = np.empty((4, BLOCK))
    res = np.empty(BLOCK)
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        _mean_block(m, eta, b0, bn, Kp, dk0, k0, L0, dL, NL, M, P, Q0, Q1, ix, wt, res)
        eb = _slp(eta, b0, b0 + bn)
        for t in range(bn):
            e = _clip(_at(eb, t), e_lo, e_hi)
            out[b0 + t] = _clip(1.0 - res[t] / (e * e), 0.0, 1.0 - 1e-9)
    _ftz_exit(old)


@_inline
def _layered_block(ci, co, m, eta, bn, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi,
                   ix, wt, sc):
    """layered_diffuse's per-point factors of a block into sc[0] (scale) and sc[1] (r_i).

    ci, co, m, eta: the block's values (rows of length bn, or scalars).
    Indices and weights of the two rho_dt reads and the rho_bar read
    first (vectorised), then the reads.
    """
    NK = Kp.shape[0]
    K_first, K_step, K_last = Kp[0], Kp[1] - Kp[0], Kp[NK - 1]
    for t in range(bn):
        mt = _at(m, t)
        et = _at(eta, t)
        i0, i1, wu0, wu1, wj, wk = rho_index(_at(ci, t), mt, et, K_first, K_step, K_last, NK, dk0, k0, U0, dU,
                                             NU, L0, dL, NL)
        ix[0, t] = i0
        ix[1, t] = i1
        wt[0, t] = wu0
        wt[1, t] = wu1
        wt[2, t] = wj
        wt[3, t] = wk
        i0, i1, wu0, wu1, wj, wk = rho_index(_at(co, t), mt, et, K_first, K_step, K_last, NK, dk0, k0, U0, dU,
                                             NU, L0, dL, NL)
        ix[2, t] = i0
        ix[3, t] = i1
        wt[4, t] = wu0
        wt[5, t] = wu1
        wt[6, t] = wj
        wt[7, t] = wk
        j, k, wj, wk, cq, kap_c = mean_index(mt, et, K_first, K_step, K_last, NK, dk0, k0, L0, dL, NL)
        ix[4, t] = j
        ix[5, t] = k
        wt[8, t] = wj
        wt[9, t] = wk
        wt[10, t] = cq
        wt[11, t] = kap_c
    for t in range(bn):
        t_i = _clip(rho_combine(vals, NL, NK, ix[0, t], ix[1, t], wt[0, t], wt[1, t], wt[2, t], wt[3, t]),
                    0.0, 1.0)  # eq 3 at wi
        t_o = _clip(rho_combine(vals, NL, NK, ix[2, t], ix[3, t], wt[4, t], wt[5, t], wt[6, t], wt[7, t]),
                    0.0, 1.0)  # eq 3 at wo
        rho_bar = mean_combine(ix[4, t], ix[5, t], wt[8, t], wt[9, t], wt[10, t], wt[11, t], dk0, k0,
                               M, P, Q0, Q1)
        e = _clip(_at(eta, t), e_lo, e_hi)
        r_i = _clip(1.0 - rho_bar / (e * e), 0.0, 1.0 - 1e-9)
        above = (_at(ci, t) > COS_EPS) & (_at(co, t) > COS_EPS)
        sc[0, t] = t_i * t_o * (1.0 - r_i) / (PI * max(rho_bar, _TINY)) if above else 0.0
        sc[1, t] = r_i


@jit
def layered_diffuse(lo, hi, ci, co, m, eta, R, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi,
                    out):
    C = out.shape[1]
    ix = np.empty((6, BLOCK), dtype=np.int64)
    wt = np.empty((12, BLOCK))
    sc = np.empty((2, BLOCK))
    old = _ftz_enter()
    for b0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - b0)
        _layered_block(_slp(ci, b0, b0 + bn), _slp(co, b0, b0 + bn), _slp(m, b0, b0 + bn), _slp(eta, b0, b0 + bn),
                       bn, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi, ix, wt, sc)
        for t in range(bn):
            for ch in range(C):
                Rc = _vec(R, b0 + t, ch)
                out[b0 + t, ch] = sc[0, t] * Rc / (1.0 - sc[1, t] * Rc)  # eq 2 with internal reflections
    _ftz_exit(old)


@jit
def local_brdf(lo, hi, wi, wo, n, m, eta, R, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1, e_lo, e_hi,
               out):
    C = out.shape[1]
    a = np.empty((9, BLOCK))
    g = np.empty((3, BLOCK))
    ix = np.empty((6, BLOCK), dtype=np.int64)
    wt = np.empty((12, BLOCK))
    sc = np.empty((2, BLOCK))
    old = _ftz_enter()
    for i0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - i0)
        _to_rows(wi, i0, bn, a, 0)
        _to_rows(wo, i0, bn, a, 3)
        _to_rows(n, i0, bn, a, 6)
        mb = _slp(m, i0, i0 + bn)
        eb = _slp(eta, i0, i0 + bn)
        for t in range(bn):
            DG4, oh, ni, no = _mf_row(a, t, _at(mb, t))
            g[0, t] = DG4 * fresnel_dielectric_1(oh, _at(eb, t))  # eq 8
            g[1, t] = ni
            g[2, t] = no
        _layered_block(g[1, :bn], g[2, :bn], mb, eb, bn, vals, Kp, dk0, k0, U0, dU, NU, L0, dL, NL, M, P, Q0, Q1,
                       e_lo, e_hi, ix, wt, sc)
        for t in range(bn):
            for ch in range(C):
                Rc = _vec(R, i0 + t, ch)
                out[i0 + t, ch] = g[0, t] + sc[0, t] * Rc / (1.0 - sc[1, t] * Rc)
    _ftz_exit(old)


# --------------------------------------------------------------------------
# Kubelka-Munk (eqs 4-7)
# --------------------------------------------------------------------------


@_inline
def km_core_1(K, S):
    beta = math.sqrt(K * (K + 2.0 * S))
    T = S + K + beta
    pos = T > 0.0
    Ts = T if pos else 1.0
    R_inf = S / Ts if pos else 0.0
    delta = (K + beta) / Ts if pos else 1.0
    return beta, T, R_inf, delta


@_inline
def km_reflectance_1(K, S, X, Rg):
    Rg = _clip(Rg, 0.0, 1.0)
    beta, T, Ri, delta = km_core_1(K, S)
    finite_X = math.isfinite(X)
    Xf = X if finite_X else 0.0
    z = 2.0 * beta * Xf
    y = Xf * T * (1.0 + Ri)  # = z / delta, finite at delta = 0
    e1 = -vexpm1(-z)  # 1 - exp(-z)
    # q = e1 / delta, or y phi1(z) with phi1 = e1 / z (km._phi1) near delta = 0:
    # one division serves both branches (same operations as the oracle's)
    big_d = delta > 1e-8
    big_z = z > 1e-8
    qd = e1 / (max(delta, 1e-300) if big_d else (z if big_z else 1.0))
    q = qd if big_d else (y * qd if big_z else y * (1.0 - 0.5 * z))
    d = Ri - Rg
    num = Rg * (1.0 + Ri) + q * d
    den = (1.0 + Ri) + Ri * q * d
    R = num / den
    R = R if (math.isfinite(q) & math.isfinite(R)) else Ri  # q overflowed: R -> R_inf
    R = Rg if X == 0.0 else R  # no layer
    R = Ri if math.isinf(X) else R  # infinitely thick: eq 6
    R = R if T > 0.0 else Rg  # empty layer
    return _clip(R, 0.0, 1.0)


@jit
def km_r_inf(lo, hi, K, S, out):
    K = _slp(K, lo, hi)
    S = _slp(S, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        _, _, Ri, _ = km_core_1(_at(K, i), _at(S, i))
        out[i] = Ri
    _ftz_exit(old)


@jit
def km_reflectance(lo, hi, K, S, X, Rg, out):
    K = _slp(K, lo, hi)
    S = _slp(S, lo, hi)
    X = _slp(X, lo, hi)
    Rg = _slp(Rg, lo, hi)
    out = out[lo:hi]
    old = _ftz_enter()
    for i in range(hi - lo):
        out[i] = km_reflectance_1(_at(K, i), _at(S, i), _at(X, i), _at(Rg, i))
    _ftz_exit(old)


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


# --------------------------------------------------------------------------
# MaterialShader (shader.MaterialShader._eval fused)
# --------------------------------------------------------------------------


@_inline
def _rho_cj_1(u, j, b, rho4, nu, nc):
    fu = u * (nu - 1)
    i = min(np.int64(fu), nu - 2)
    a = fu - i
    row = i * (nc - 1) + j
    r0 = rho4[row, 0] + b * (rho4[row, 1] - rho4[row, 0])
    r1 = rho4[row, 2] + b * (rho4[row, 3] - rho4[row, 2])
    return r0 + a * (r1 - r0)


@_inline
def _spec_ch(Fpack, li, w, ch, gl, c, Ft, DG4, corrodes):
    """Specular f of one channel: the metals' Fresnel mixed by gilding, the patina's by coverage."""
    Fm = Fpack[li, ch] + w * Fpack[li, 7 + ch]  # gold
    Fb = Fpack[li, 3 + ch] + w * Fpack[li, 10 + ch]  # bronze
    Fmetal = gl * Fm + (1.0 - gl) * Fb
    return DG4 * ((1.0 - c) * Fmetal + c * Ft) if corrodes else DG4 * Fmetal


@jit
def material_shader(lo, hi, wi, wo, n, cov, gild, crust, m0, dm, n_lut, Fpack, corrodes, rho4, nu, nc,
                    R4, nrc, nrd, spec_out, diff_out, add):
    """One pass of MaterialShader._eval per point.

    Writes f_spec to spec_out and f_diffuse to diff_out, or their sum to
    spec_out when ``add`` is true (diff_out is then not touched).  Per
    block: the directions into rows, the microfacet arithmetic over the
    rows (vectorised), then the table lookups.
    """
    a = np.empty((9, BLOCK))
    g = np.empty((6, BLOCK))
    old = _ftz_enter()
    for i0 in range(lo, hi, BLOCK):
        bn = min(BLOCK, hi - i0)
        _to_rows(wi, i0, bn, a, 0)
        _to_rows(wo, i0, bn, a, 3)
        _to_rows(n, i0, bn, a, 6)
        cb = _slp(cov, i0, i0 + bn)
        for t in range(bn):
            w0, w1, w2, v0, v1, v2 = a[0, t], a[1, t], a[2, t], a[3, t], a[4, t], a[5, t]
            n0, n1, n2 = a[6, t], a[7, t], a[8, t]
            c = _clip(_at(cb, t), 0.0, 1.0)
            ni = n0 * w0 + n1 * w1 + n2 * w2
            no = n0 * v0 + n1 * v1 + n2 * v2
            io = w0 * v0 + w1 * v1 + w2 * v2
            hl2 = max(2.0 + 2.0 * io, 0.0)
            valid = (ni > COS_EPS) & (no > COS_EPS) & (hl2 > EPS2)
            nis = ni if valid else 1.0
            nos = no if valid else 1.0
            hls = hl2 if valid else 1.0
            inv_hl = 1.0 / math.sqrt(hls)
            nh = min((nis + nos) * inv_hl, 1.0)
            nfi = max(nis, MU_FLOOR)  # grazing guard of eq 8's denominator
            nfo = max(nos, MU_FLOOR)
            oh = min(0.5 * hls * inv_hl, 1.0)
            m = max(m0 + dm * c, M_MIN)
            inv_m2 = 1.0 / (m * m)
            nh2 = nh * nh
            D = vexp((nh2 - 1.0) / nh2 * inv_m2) * inv_m2 / (PI * nh2 * nh2)  # eq 13
            gg = min(1.0 / (nfi * nfo), 2.0 * nh / (max(oh, COS_EPS) * max(nfi, nfo)))  # eq 11 / (4 ni no)
            g[0, t] = 0.25 * D * gg if valid else 0.0  # DG4
            g[1, t] = oh
            g[2, t] = c
            g[3, t] = math.sqrt(nis)
            g[4, t] = math.sqrt(nos)
            g[5, t] = 1.0 if valid else 0.0
        gb = _slp(gild, i0, i0 + bn)
        db = _slp(crust, i0, i0 + bn)
        for t in range(bn):
            DG4 = g[0, t]
            c = g[2, t]
            # Fresnel: gold (3), bronze (3), dielectric (1), linear in o.h
            f = g[1, t] * (n_lut - 1)
            li = min(np.int64(f), n_lut - 1)
            w = f - li
            gl = _clip(_at(gb, t), 0.0, 1.0)
            Ft = Fpack[li, 6] + w * Fpack[li, 13]
            s0 = _spec_ch(Fpack, li, w, 0, gl, c, Ft, DG4, corrodes)
            s1 = _spec_ch(Fpack, li, w, 1, gl, c, Ft, DG4, corrodes)
            s2 = _spec_ch(Fpack, li, w, 2, gl, c, Ft, DG4, corrodes)
            d0 = 0.0
            d1 = 0.0
            d2 = 0.0
            if corrodes:
                fc = c * (nc - 1)
                j = min(np.int64(fc), nc - 2)
                b = fc - j
                rho = _rho_cj_1(g[3, t], j, b, rho4, nu, nc) * _rho_cj_1(g[4, t], j, b, rho4, nu, nc)
                diff = c * rho * (1.0 / PI) if g[5, t] > 0.0 else 0.0
                # R_eff(c, crust), bilinear
                fr = c * (nrc - 1)
                ri = min(np.int64(fr), nrc - 2)
                aa = fr - ri
                fd = _clip(_at(db, t), 0.0, 1.0) * (nrd - 1)
                rj = min(np.int64(fd), nrd - 2)
                bb = fd - rj
                row = ri * (nrd - 1) + rj
                r00 = R4[row, 0] + bb * (R4[row, 3] - R4[row, 0])
                r10 = R4[row, 6] + bb * (R4[row, 9] - R4[row, 6])
                r01 = R4[row, 1] + bb * (R4[row, 4] - R4[row, 1])
                r11 = R4[row, 7] + bb * (R4[row, 10] - R4[row, 7])
                r02 = R4[row, 2] + bb * (R4[row, 5] - R4[row, 2])
                r12 = R4[row, 8] + bb * (R4[row, 11] - R4[row, 8])
                d0 = diff * (r00 + aa * (r10 - r00))
                d1 = diff * (r01 + aa * (r11 - r01))
                d2 = diff * (r02 + aa * (r12 - r02))
            i = i0 + t
            if add:
                spec_out[i, 0] = s0 + d0
                spec_out[i, 1] = s1 + d1
                spec_out[i, 2] = s2 + d2
            else:
                spec_out[i, 0] = s0
                spec_out[i, 1] = s1
                spec_out[i, 2] = s2
                diff_out[i, 0] = d0
                diff_out[i, 1] = d1
                diff_out[i, 2] = d2
    _ftz_exit(old)


#: The kernels, by name (for warm_up's count and the tests).
KERNELS = ("beckmann_D", "v_cavity_G", "fresnel_dielectric", "fresnel_conductor", "torrance_sparrow",
           "torrance_sparrow_conductor", "diffuse_transmittance", "mean_transmittance",
           "internal_reflectance", "layered_diffuse", "local_brdf", "km_r_inf", "km_reflectance",
           "dipole_rd", "dipole_tail_fraction", "dipole_profile", "material_shader")


# --------------------------------------------------------------------------
# Running a kernel over P points on the threads
# --------------------------------------------------------------------------

#: Fewest points given to one thread; below 2x this a call runs inline
#: (a pool round trip costs ~50 us, a kernel ~3-10 ns a point).
MIN_POINTS_PER_THREAD = 1 << 15

_POOL = None
_POOL_PID = None
_POOL_LOCK = threading.Lock()


def n_threads():
    """Threads a large call uses: ``SHELLREPAIR_THREADS`` or the CPUs there are."""
    env = os.environ.get("SHELLREPAIR_THREADS")
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            pass
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _pool(k):
    """A thread pool of k workers, remade after a fork (a forked child has no threads)."""
    global _POOL, _POOL_PID
    from concurrent.futures import ThreadPoolExecutor

    with _POOL_LOCK:
        if _POOL is None or _POOL_PID != os.getpid() or _POOL._max_workers != k:
            _POOL = ThreadPoolExecutor(k, thread_name_prefix="shellrepair-shade")
            _POOL_PID = os.getpid()
        return _POOL


def run(kernel, P, *args):
    """``kernel(lo, hi, *args)`` over [0, P), split over the threads when P is large."""
    k = min(n_threads(), P // MIN_POINTS_PER_THREAD)
    if k <= 1 or threading.current_thread().name.startswith("shellrepair-shade"):
        kernel(0, P, *args)
        return
    # k - 1 ranges to the pool, the first one on this thread (it releases the
    # GIL inside the kernel): one hand-off fewer, and no thread sits idle
    edges = [P * t // k for t in range(k + 1)]
    pool = _pool(k - 1)
    futures = [pool.submit(kernel, edges[t], edges[t + 1], *args) for t in range(1, k)]
    try:
        kernel(edges[0], edges[1], *args)
    finally:
        for f in futures:
            f.result()
