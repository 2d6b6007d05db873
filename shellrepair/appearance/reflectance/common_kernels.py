"""What the compiled kernels of the reflectance functions share (Numba).

Each public per-point function of :mod:`shellrepair.appearance.reflectance` and
:class:`shellrepair.appearance.shader.MaterialShader` evaluates in a fused kernel, one
pass over the points: no array temporaries, every guard of the NumPy
version applied in the same order, and the NumPy version kept as the test
oracle (:mod:`.reference`).  Results agree with the oracle within 1e-12
relative (the shader 1e-11); see tests/test_reflectance_kernels.py.

The kernels sit beside the code they speed up, one module each:
:mod:`.microfacet_kernels` (:mod:`.microfacet`), :mod:`.albedo_kernels`
(the rho_dt table reads of :mod:`.albedo`), :mod:`.layered_kernels`
(:mod:`.layered`), :mod:`.km_kernels` (:mod:`.km`), :mod:`.dipole_kernels`
(:mod:`.dipole`) and :mod:`.shader_kernels` (:mod:`shellrepair.appearance.shader`).
This module holds what they all use: the subnormal flush (FTZ/DAZ), the
vectorisable ``exp``, ``expm1`` and ``log``, the scalar-or-array accessors
(:func:`_at`, :func:`_slp`, ...), the row copy of directions
(:func:`_to_rows`, :data:`BLOCK`) and the decorators (:data:`jit`,
``_inline``).  :mod:`.dispatch` passes the public functions' arguments to
them and splits large calls over threads.

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
- Large inputs are split into contiguous ranges run by a thread pool
  (:func:`.dispatch.run`); the kernels release the GIL (``nogil``).
  Chosen over ``prange``: in a quick measurement on this 2-core machine
  (shared with other jobs) the OpenMP ``prange`` loop ran slower than
  one thread and did not vectorise, while threads over vectorised ranges
  keep the vector loop.  The pool is remade after a fork.

Compiled code is cached (``cache=True``: in ``__pycache__`` beside each
kernel module, or Numba's per-user cache directory when that is not
writable); :func:`shellrepair.appearance.shader.warm_up` compiles every specialisation
the library uses, and ``make setup`` calls it.  The kernel modules are
imported on the first call of a shading function (:func:`.dispatch.kernels`),
so importing the package does not import Numba.  Numba checks a cached
kernel against its own file only: after editing a helper here (or in
another kernel module) that a kernel inlines, delete
``shellrepair/appearance/reflectance/__pycache__/*.nb[ic]`` so that the kernels which
inline it are compiled again.

Set ``SHELLREPAIR_NO_NUMBA=1`` to use the NumPy versions everywhere, and
``SHELLREPAIR_THREADS`` to cap the threads (default: the CPUs this process
may use).
"""


from __future__ import annotations

import math
import platform

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic, overload

# the NumPy versions' constants, repeated as plain floats for the kernels
from shellrepair.appearance.reflectance._constants import COS_EPS

_OPTS = dict(cache=True, nogil=True, error_model="numpy")
#: A kernel called from Python (one specialisation per argument types, cached on disk).
jit = numba.njit(**_OPTS)
#: A helper inlined into the kernels that call it (across the kernel modules too).
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
def exp_expm1_log(x, out_exp, out_expm1, out_log):
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
