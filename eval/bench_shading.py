"""Benchmark of the aged-metal shading and the renderer (not a test).

Measures, in one run on this machine:

1. shading evaluations per second for 1e6 random points with the full
   model (conductor lobe + dielectric lobe + rho_dt R_KM rho_dt / pi,
   coverage-driven m and X), for
   - ``MaterialShader`` (the library's fast path),
   - ``shade_reference`` (the library's term-by-term composition), and
   - a straightforward NumPy transcription written below (arccos/tan
     Beckmann, complex Fresnel, eq 5 verbatim, scipy's
     RegularGridInterpolator on the rho_dt table),
   with the largest relative difference between them;
2. the rho_dt table: build time and its largest error against the
   reference quadrature over the required range;
3. render time of a ~1M-face mesh at 1024 x 1024 (2 x 2 rays per pixel),
   and the cost of that antialiasing (one ray per pixel against 2 x 2) on
   the bundled bunny;
4. the aging map (shellrepair.appearance.aging) on a ~1M-vertex mesh: wall and CPU
   seconds;
5. the numbers docs/shading.md quotes: the footprint where the model
   switches to the dipole, how far rho_dt at m = 0.005 is from its smooth
   limit 1 - F by angle, the table's error for eta < 1 and the worst
   white-furnace albedo.

6. each public shading function and ``MaterialShader`` on 1e6 random
   points against a plain vectorised NumPy version of it (written below:
   the formulas as array expressions, the rho_dt table read by a
   vectorised trilinear lookup) and against the library's own NumPy
   version (the kernels' test oracle): times, the ratio plain / ours
   (goal >= 10x, issue 14 item 4) and the largest relative difference from
   the oracle.  ``--functions-only`` runs just this part (~2 minutes).
   ``--one-thread-cpu`` times both sides on one thread by the thread's
   CPU time (``SHELLREPAIR_THREADS=1``, ``time.thread_time``): a ratio
   that other jobs on a shared machine disturb much less than wall time
   (it leaves out what a second thread adds).

Prints a table and writes eval/results/bench_shading.json
(eval/results/bench_shading_functions.json with ``--functions-only``,
eval/results/bench_shading_functions_1thread_cpu.json with ``--one-thread-cpu``).

7. ``--ceilings [NAME ...]``: what bounds each function.  Our CPU time on
   one thread and the plain version's, a bare kernel streaming the same
   input and output bytes (one thread CPU time, two threads wall), our
   kernel's arithmetic alone (ns a point with the data in L2), the ratio
   these allow, the output allocation's page-fault cost and a pool round
   trip.  Writes eval/results/bench_shading_ceilings.json.

Usage: ``python eval/bench_shading.py [--points N] [--faces N] [--quick] [--functions-only] [--one-thread-cpu]
[--ceilings [NAME ...]]``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

sys.path.insert(0, os.path.abspath(os.path.join(os.path.dirname(__file__), "..")))

from shellrepair.appearance import materials as mt  # noqa: E402
from shellrepair.appearance import shader as sd  # noqa: E402
from shellrepair.appearance import render as rd  # noqa: E402
from shellrepair.appearance import shading as sh  # noqa: E402
from shellrepair.appearance.reflectance import albedo  # noqa: E402

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")


# --------------------------------------------------------------------------
# A straightforward NumPy implementation of the same model
# --------------------------------------------------------------------------


def naive_shade(wi, wo, n, c, mat, interp, gild=1.0, crust=0.0):
    """The full model transcribed formula by formula, no precomputation."""
    wi = wi / np.linalg.norm(wi, axis=-1, keepdims=True)
    wo = wo / np.linalg.norm(wo, axis=-1, keepdims=True)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    ni = np.sum(n * wi, axis=-1)
    no = np.sum(n * wo, axis=-1)
    nh = np.sum(n * h, axis=-1)
    oh = np.sum(wo * h, axis=-1)
    m = mat.m_exposed + (mat.m_rust - mat.m_exposed) * c
    th = np.arccos(np.clip(nh, -1, 1))
    D = np.exp(-(np.tan(th) / m) ** 2) / (np.pi * m ** 2 * np.cos(th) ** 4)
    # grazing guard: eq 8's cosines floored at MU_FLOOR, G with the same cosines
    nfi = np.maximum(ni, sh.MU_FLOOR)
    nfo = np.maximum(no, sh.MU_FLOOR)
    G = np.minimum(1.0, np.minimum(2 * nh * nfo / oh, 2 * nh * nfi / oh))

    def complex_fresnel(metal):
        eta_c = np.asarray(metal.n) + 1j * np.asarray(metal.k)
        cc = oh[:, None] + 0j
        ct = np.sqrt(eta_c ** 2 - (1 - cc ** 2))
        rs = (cc - ct) / (cc + ct)
        rp = (eta_c ** 2 * cc - ct) / (eta_c ** 2 * cc + ct)
        return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)

    gl = np.broadcast_to(np.asarray(gild, float), c.shape)[:, None]
    Fm = gl * complex_fresnel(mat.exposed) + (1 - gl) * complex_fresnel(mat.substrate)
    # dielectric Fresnel, eq 12
    eta = mat.eta_top
    g = np.sqrt(eta ** 2 + oh ** 2 - 1)
    Ft = 0.5 * (g - oh) ** 2 / (g + oh) ** 2 * (1 + (oh * (g + oh) - 1) ** 2 / (oh * (g - oh) + 1) ** 2)
    base = D * G / (4 * nfi * nfo)
    f_metal = base[:, None] * Fm
    f_spec = base * Ft
    # rho_dt by interpolation in the library's table
    lm = np.log(m)
    kap = np.full_like(m, np.sqrt(eta ** 2 - 1))
    rho_i = interp(np.stack([np.sqrt(np.clip(ni, 0, 1)), lm, kap], axis=-1))
    rho_o = interp(np.stack([np.sqrt(np.clip(no, 0, 1)), lm, kap], axis=-1))
    # Kubelka-Munk, eq 5 verbatim, bottom layer first
    Rg = mt.substrate_reflectance(mat)
    R = np.broadcast_to(Rg, (len(c), 3))
    for li, (L, xmax, c0, c1) in enumerate(mat.layers):
        K = np.asarray(L.K)
        S = np.asarray(L.S)
        if li == len(mat.layers) - 1 and mat.crust is not None:  # eq 7: dark crust in the top layer
            p = (np.broadcast_to(np.asarray(crust, float), c.shape) * mat.crust[1])[:, None]
            K = (1 - p) * K + p * np.asarray(mat.crust[0].K)
            S = (1 - p) * S + p * np.asarray(mat.crust[0].S)
        X = (xmax * np.clip((c - c0) / (c1 - c0), 0, 1))[:, None]
        Ri = (1 + K / S) - np.sqrt((K / S) ** 2 + 2 * K / S)
        E = np.exp(S * X * (1 / Ri - Ri))
        R = ((1 / Ri) * (R - Ri) - Ri * (R - 1 / Ri) * E) / ((R - Ri) - (R - 1 / Ri) * E)
    # internal reflection at the interface (Saunderson-type): 1 - r_i = rho_bar / eta^2
    rho_bar = sh.mean_transmittance(m, eta)[:, None]
    r_i = 1 - rho_bar / eta ** 2
    f_rust = f_spec[:, None] + (rho_i * rho_o / np.pi)[:, None] * R * (1 - r_i) / (rho_bar * (1 - r_i * R))
    f = (1 - c)[:, None] * f_metal + c[:, None] * f_rust
    ok = (ni > 0) & (no > 0)
    return np.where(ok[:, None], f, 0.0)


# --------------------------------------------------------------------------
# Plain vectorised NumPy versions of each public function (the baseline of
# issue 14 item 4): the formulas written as a user would, one array
# expression per term, the rho_dt table read by a vectorised trilinear
# lookup.  No guards beyond what the formula needs on the benchmark's
# inputs (all strictly inside the valid ranges), no chunking.
# --------------------------------------------------------------------------


def plain_dot(a, b):
    return np.sum(a * b, axis=-1)


def plain_beckmann(c, m):
    c2 = c * c
    return np.exp(-(1.0 - c2) / (c2 * m * m)) / (np.pi * m * m * c2 * c2)


def plain_G(nh, ni, no, oh):
    return np.minimum(1.0, np.minimum(2.0 * nh * no / oh, 2.0 * nh * ni / oh))


def plain_fresnel_dielectric(c, eta):
    g = np.sqrt(np.maximum(eta * eta + c * c - 1.0, 0.0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return 0.5 * a * a * (1.0 + b * b)


def plain_fresnel_conductor(c, n, k):
    c2 = c * c
    s2 = 1.0 - c2
    t = n * n - k * k - s2
    a2b2 = np.sqrt(t * t + 4.0 * n * n * k * k)
    a = np.sqrt(0.5 * (a2b2 + t))
    Rs = (a2b2 - 2.0 * a * c + c2) / (a2b2 + 2.0 * a * c + c2)
    Rp = Rs * (c2 * a2b2 - 2.0 * a * c * s2 + s2 * s2) / (c2 * a2b2 + 2.0 * a * c * s2 + s2 * s2)
    return 0.5 * (Rs + Rp)


def plain_geometry(wi, wo, n):
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    return plain_dot(n, wi), plain_dot(n, wo), plain_dot(n, h), plain_dot(wo, h)


def plain_torrance_sparrow(wi, wo, n, m, eta):
    ni, no, nh, oh = plain_geometry(wi, wo, n)
    f = plain_beckmann(nh, m) * plain_G(nh, ni, no, oh) * plain_fresnel_dielectric(oh, eta) / (4.0 * ni * no)
    return np.where((ni > 0) & (no > 0), f, 0.0)


def plain_torrance_sparrow_conductor(wi, wo, n, m, n_metal, k_metal):
    ni, no, nh, oh = plain_geometry(wi, wo, n)
    base = plain_beckmann(nh, m) * plain_G(nh, ni, no, oh) / (4.0 * ni * no)
    F = plain_fresnel_conductor(oh[:, None], n_metal, k_metal)
    return np.where(((ni > 0) & (no > 0))[:, None], base[:, None] * F, 0.0)


def plain_km_r_inf(K, S):
    a = K / S
    return 1.0 + a - np.sqrt(a * a + 2.0 * a)  # eq 6


def plain_km_reflectance(K, S, X, Rg):
    Ri = plain_km_r_inf(K, S)
    E = np.exp(S * X * (1.0 / Ri - Ri))  # eq 5
    return ((1.0 / Ri) * (Rg - Ri) - Ri * (Rg - 1.0 / Ri) * E) / ((Rg - Ri) - (Rg - 1.0 / Ri) * E)


class PlainTable:
    """The library's rho_dt table read by a plain vectorised trilinear lookup."""

    def __init__(self, table):
        self.t = table
        self.v = table.values

    def _cell(self, x, ax):
        f = np.clip((x - ax[0]) / (ax[1] - ax[0]), 0.0, ax.size - 1.0)
        i = np.minimum(f.astype(np.intp), ax.size - 2)
        return i, f - i

    def rho(self, cos_theta, m, eta):
        i, a = self._cell(np.sqrt(np.clip(cos_theta, 0.0, 1.0)), self.t.u)
        j, b = self._cell(np.log(m), self.t.log_m)
        e2 = eta * eta - 1.0
        k, c = self._cell(np.sign(e2) * np.sqrt(np.abs(e2)), self.t.kappa)
        v = self.v
        return ((1 - a) * ((1 - b) * ((1 - c) * v[i, j, k] + c * v[i, j, k + 1])
                           + b * ((1 - c) * v[i, j + 1, k] + c * v[i, j + 1, k + 1]))
                + a * ((1 - b) * ((1 - c) * v[i + 1, j, k] + c * v[i + 1, j, k + 1])
                       + b * ((1 - c) * v[i + 1, j + 1, k] + c * v[i + 1, j + 1, k + 1])))

    def mean(self, m, eta):
        j, b = self._cell(np.log(m), self.t.log_m)
        e2 = eta * eta - 1.0
        k, c = self._cell(np.sign(e2) * np.sqrt(np.abs(e2)), self.t.kappa)
        M = self.t.mean_values
        return ((1 - b) * ((1 - c) * M[j, k] + c * M[j, k + 1])
                + b * ((1 - c) * M[j + 1, k] + c * M[j + 1, k + 1]))


def plain_layered_diffuse(ci, co, m, eta, R, pt):
    rho_bar = pt.mean(m, eta)
    r_i = 1.0 - rho_bar / (eta * eta)
    f = (pt.rho(ci, m, eta) * pt.rho(co, m, eta) * (1.0 - r_i) / (np.pi * rho_bar))[:, None] * R / (
        1.0 - r_i[:, None] * R)
    return np.where(((ci > 0) & (co > 0))[:, None], f, 0.0)


def plain_local_brdf(wi, wo, n, m, eta, R, pt):
    spec = plain_torrance_sparrow(wi, wo, n, m, eta)
    return spec[:, None] + plain_layered_diffuse(plain_dot(n, wi), plain_dot(n, wo), m, eta, R, pt)


def plain_dipole_A(eta):
    F = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
    return (1.0 + F) / (1.0 - F)


def plain_dipole_rd(a, eta):
    s = np.sqrt(3.0 * (1.0 - a))
    return 0.5 * a * (1.0 + np.exp(-(4.0 / 3.0) * plain_dipole_A(eta) * s)) * np.exp(-s)


def plain_dipole_poles(r, sa, ss, eta):
    st = sa + ss
    s_tr = np.sqrt(3.0 * sa * st)
    zr = 1.0 / st
    zv = zr * (1.0 + 4.0 / 3.0 * plain_dipole_A(eta))
    return ss / st, s_tr, zr, zv, np.sqrt(r * r + zr * zr), np.sqrt(r * r + zv * zv)


def plain_dipole_tail_fraction(r, sa, ss, eta):
    _, s, zr, zv, dr, dv = plain_dipole_poles(r, sa, ss, eta)
    return ((zr * np.exp(-s * dr) / dr + zv * np.exp(-s * dv) / dv)
            / (np.exp(-s * zr) + np.exp(-s * zv)))


def plain_dipole_profile(r, sa, ss, eta):
    al, s, zr, zv, dr, dv = plain_dipole_poles(r, sa, ss, eta)
    return al / (4.0 * np.pi) * (zr * (1.0 + s * dr) * np.exp(-s * dr) / dr ** 3
                                 + zv * (1.0 + s * dv) * np.exp(-s * dv) / dv ** 3)


def plain_shade(wi, wo, n, c, mat, pt, gild, crust):
    """The full aged-metal model, plain vectorised NumPy with the table lookup."""
    ni, no, nh, oh = plain_geometry(wi, wo, n)
    m = mat.m_exposed + (mat.m_rust - mat.m_exposed) * c
    nfi = np.maximum(ni, sh.MU_FLOOR)
    nfo = np.maximum(no, sh.MU_FLOOR)
    base = plain_beckmann(nh, m) * plain_G(nh, nfi, nfo, oh) / (4.0 * nfi * nfo)
    Fg = plain_fresnel_conductor(oh[:, None], np.asarray(mat.exposed.n), np.asarray(mat.exposed.k))
    Fb = plain_fresnel_conductor(oh[:, None], np.asarray(mat.substrate.n), np.asarray(mat.substrate.k))
    f_metal = base[:, None] * (gild[:, None] * Fg + (1.0 - gild[:, None]) * Fb)
    eta = np.full_like(m, mat.eta_top)
    f_spec = base * plain_fresnel_dielectric(oh, eta)
    R = np.broadcast_to(mt.substrate_reflectance(mat), (len(c), 3))
    for li, (L, xmax, c0, c1) in enumerate(mat.layers):
        K = np.asarray(L.K)
        S = np.asarray(L.S)
        if li == len(mat.layers) - 1 and mat.crust is not None:  # eq 7: dark crust in the top layer
            p = (crust * mat.crust[1])[:, None]
            K = (1 - p) * K + p * np.asarray(mat.crust[0].K)
            S = (1 - p) * S + p * np.asarray(mat.crust[0].S)
        X = (xmax * np.clip((c - c0) / (c1 - c0), 0, 1))[:, None]
        R = plain_km_reflectance(K, S, X, R)
    f_rust = f_spec[:, None] + plain_layered_diffuse(ni, no, m, eta, R, pt)
    f = (1 - c)[:, None] * f_metal + c[:, None] * f_rust
    return np.where(((ni > 0) & (no > 0))[:, None], f, 0.0)


def function_cases(N):
    """(name, ours, oracle, plain, args) of each public function on N random points (seeded)."""
    from shellrepair.appearance.reflectance import albedo as al, dipole as dp, km, layered as ly
    from shellrepair.appearance.reflectance import microfacet as mf
    from shellrepair.appearance import shader as sd

    rng = np.random.default_rng(42)
    wi, wo, n, cov, gild, crust = random_points(N, seed=7)
    m = np.exp(rng.uniform(np.log(0.02), 0.0, N))
    eta = rng.uniform(1.1, 2.5, N)
    c = rng.uniform(0.01, 1.0, N)
    c2 = rng.uniform(0.01, 1.0, N)
    K, S = rng.uniform(0.01, 3.0, N), rng.uniform(0.01, 3.0, N)
    X, Rg = rng.uniform(0.0, 100.0, N), rng.uniform(0.0, 1.0, N)
    R3 = rng.uniform(0.0, 1.0, (N, 3))
    nm, km_ = np.asarray(mt.BRONZE.n), np.asarray(mt.BRONZE.k)
    nh, ni, no, oh = plain_geometry(wi, wo, n)
    pt = PlainTable(sh.rho_dt_table())
    mat = mt.get_material("aged-bronze")
    shader = sd.MaterialShader(mat)
    cases = [
        ("beckmann_D", sh.beckmann_D, mf._beckmann_D_np, plain_beckmann, (c, m)),
        ("v_cavity_G", sh.v_cavity_G, mf._v_cavity_G_np, plain_G, (nh, ni, no, oh)),
        ("fresnel_dielectric", sh.fresnel_dielectric, mf._fresnel_dielectric_np, plain_fresnel_dielectric, (c, eta)),
        ("fresnel_conductor", sh.fresnel_conductor, mf._fresnel_conductor_np, plain_fresnel_conductor,
         (c, eta, K)),
        ("torrance_sparrow", sh.torrance_sparrow, mf._torrance_sparrow_np, plain_torrance_sparrow,
         (wi, wo, n, m, eta)),
        ("torrance_sparrow_conductor", sh.torrance_sparrow_conductor, mf._torrance_sparrow_conductor_np,
         plain_torrance_sparrow_conductor, (wi, wo, n, m, nm, km_)),
        ("diffuse_transmittance", sh.diffuse_transmittance, al._diffuse_transmittance_np, pt.rho, (c, m, eta)),
        ("mean_transmittance", sh.mean_transmittance, al._mean_transmittance_np, pt.mean, (m, eta)),
        ("internal_reflectance", sh.internal_reflectance, al._internal_reflectance_np,
         lambda m_, e_: 1.0 - pt.mean(m_, e_) / (e_ * e_), (m, eta)),
        ("layered_diffuse", sh.layered_diffuse, ly._layered_diffuse_np,
         lambda *a: plain_layered_diffuse(*a, pt), (c, c2, m, eta, R3)),
        ("local_brdf", sh.local_brdf, ly._local_brdf_np, lambda *a: plain_local_brdf(*a, pt),
         (wi, wo, n, m, eta, R3)),
        ("km_r_inf", sh.km_r_inf, km._km_r_inf_np, plain_km_r_inf, (K, S)),
        ("km_reflectance", sh.km_reflectance, km._km_reflectance_np, plain_km_reflectance, (K, S, X, Rg)),
        ("dipole_rd", sh.dipole_rd, dp._dipole_rd_np, plain_dipole_rd, (Rg, eta)),
        ("dipole_tail_fraction", sh.dipole_tail_fraction, dp._dipole_tail_fraction_np,
         plain_dipole_tail_fraction, (X, K, S, eta)),
        ("dipole_profile", sh.dipole_profile, dp._dipole_profile_np, plain_dipole_profile, (X, K, S, eta)),
        ("MaterialShader", lambda *a: shader(*a), lambda *a: shader.evaluate_numpy(*a),
         lambda wi_, wo_, n_, c_, g_, d_: plain_shade(wi_, wo_, n_, c_, mat, pt, g_, d_),
         (wi, wo, n, cov, gild, crust)),
    ]
    return cases


def bench_functions(N, repeat, clock=time.perf_counter):
    """Each public function and MaterialShader against its plain NumPy version, on N points.

    Returns per function: our seconds, the plain version's, the library's
    NumPy version's (the kernels' test oracle), the ratio plain / ours and
    the largest relative difference from the oracle and from the plain
    version.
    """
    from shellrepair.appearance.reflectance import dispatch

    cases = function_cases(N)
    for _, fn, _, _, args in cases:  # compile (or load the cache) outside the timing
        fn(*[a[:64] if isinstance(a, np.ndarray) and a.ndim and a.shape[0] == N else a for a in args])
    out = {}
    for name, fn, oracle, plain, args in cases:
        with np.errstate(all="ignore"):
            t_ours, f = best_of(lambda: fn(*args), repeat, clock)
            t_plain, fp = best_of(lambda: plain(*args), repeat, clock)
            t_oracle, fo = best_of(lambda: oracle(*args), max(1, repeat // 2), clock)
        ok = np.isfinite(fo) & np.isfinite(fp)
        out[name] = {
            "ours_ms": 1e3 * t_ours, "plain_numpy_ms": 1e3 * t_plain, "numpy_oracle_ms": 1e3 * t_oracle,
            "ratio_plain_over_ours": t_plain / t_ours,
            # values below 1e-250 are compared absolutely: the kernels flush subnormals to 0
            "max_rel_diff_vs_oracle": float(np.max(np.abs(f[ok] - fo[ok]) / np.maximum(np.abs(fo[ok]), 1e-250))),
            "max_abs_diff_vs_plain": float(np.max(np.abs(f[ok] - fp[ok]))),
        }
    on = dispatch.kernels("microfacet") is not None
    return {"points": N, "threads": dispatch.n_threads() if on else 0, "jit": on, "functions": out}



# --------------------------------------------------------------------------
# Ceilings: what bounds each kernel (--ceilings)
# --------------------------------------------------------------------------

_STREAM = {}


def _stream_kernel(n_in, n_out):
    """A bare kernel streaming n_in input columns into n_out output columns:
    ``o_c[i] = a_0[i] + ... + a_{n_in-1}[i]`` (Numba; the sum of the arrays
    written out, as a kernel that does no arithmetic would stream them)."""
    key = (n_in, n_out)
    if key not in _STREAM:
        import numba

        a = ["a%d" % j for j in range(n_in)]
        o = ["o%d" % j for j in range(n_out)]
        src = "def stream(lo, hi, %s):\n" % ", ".join(a + o)
        src += "".join("    %s = %s[lo:hi]\n" % (v, v) for v in a + o)
        src += "    for i in range(hi - lo):\n        s = %s\n" % " + ".join(v + "[i]" for v in a)
        src += "".join("        %s[i] = s\n" % v for v in o)
        ns = {}
        exec(src, ns)  # noqa: S102 - a generated benchmark kernel
        _STREAM[key] = numba.njit(nogil=True)(ns["stream"])
    return _STREAM[key]


def _columns(a, N):
    """A contiguous (N, ...) array as its bytes in (N,) slices: what a kernel streams of it."""
    flat = np.ascontiguousarray(a).reshape(-1)
    return [flat[k * N:(k + 1) * N] for k in range(flat.size // N)]


def _kernel_call(fn, args):
    """The compiled kernel and its arguments that one call of the public function runs."""
    from shellrepair.appearance.reflectance import dispatch

    seen = []
    real = dispatch.run
    dispatch.run = lambda kernel, P, *a: (seen.append((kernel, P, a)), real(kernel, P, *a))[-1]
    try:
        fn(*args)
    finally:
        dispatch.run = real
    return seen[0] if len(seen) == 1 else None


def bench_ceilings(N, repeat, names=None):
    """What bounds each function: bytes streamed, IEEE divisions, or neither.

    For each public function on N points: our CPU time on one thread
    (``time.thread_time``, SHELLREPAIR_THREADS=1) and two (wall), the plain
    NumPy version's CPU time (one thread), a bare streaming kernel over the
    same input and output bytes (one thread CPU, two threads wall) and our
    kernel's arithmetic alone: ns a point with 32768 points in L2, the
    kernel called directly.  The ratio plain / ours cannot exceed plain /
    max(stream floor, arithmetic); with two threads, at best twice the
    arithmetic's share.  Also the cost of the output allocation (np.empty
    of N floats: first touch of fresh pages against reused ones, and the
    page faults one call of each function takes) and of a pool round trip.
    """
    import resource

    from shellrepair.appearance.reflectance import dispatch

    if dispatch.kernels("microfacet") is None:
        raise SystemExit("--ceilings needs the compiled kernels")
    cases = [c for c in function_cases(N) if names is None or c[0] in names]
    env = os.environ.get("SHELLREPAIR_THREADS")
    res = {}

    def threads(k):
        os.environ["SHELLREPAIR_THREADS"] = str(k)

    try:
        for name, fn, _, plain, args in cases:
            fn(*[a[:64] if isinstance(a, np.ndarray) and a.ndim and a.shape[0] == N else a for a in args])
            f = fn(*args)
            ins = tuple(col for a in args if isinstance(a, np.ndarray) and a.ndim and a.shape[0] == N
                        for col in _columns(a, N))
            C = f.size // N
            stream = _stream_kernel(len(ins), C)
            outs_cols = lambda: _columns(np.empty((N, C)), N)  # noqa: E731
            stream(0, 8, *ins, *outs_cols())
            threads(1)
            r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
            t1, _ = best_of(lambda: fn(*args), repeat, time.thread_time)
            faults = (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - r0) / repeat
            s1, _ = best_of(lambda: dispatch.run(stream, N, *ins, *outs_cols()), repeat, time.thread_time)
            with np.errstate(all="ignore"):
                p1, _ = best_of(lambda: plain(*args), max(1, repeat // 2), time.thread_time)
            threads(2)
            t2, _ = best_of(lambda: fn(*args), repeat)
            s2, _ = best_of(lambda: dispatch.run(stream, N, *ins, *outs_cols()), repeat)
            n_l2 = 32768
            small = [a[:n_l2] if isinstance(a, np.ndarray) and a.ndim and a.shape[0] == N else a for a in args]
            call = _kernel_call(fn, small)
            l2 = np.nan
            if call is not None:
                kernel, P, kargs = call
                l2, _ = best_of(lambda: [kernel(0, P, *kargs) for _ in range(20)], repeat, time.thread_time)
                l2 = l2 / 20 / P * 1e9
            res[name] = {
                "ours_1thread_cpu_ms": 1e3 * t1, "ours_2threads_wall_ms": 1e3 * t2,
                "plain_cpu_ms": 1e3 * p1, "stream_1thread_cpu_ms": 1e3 * s1, "stream_2threads_wall_ms": 1e3 * s2,
                "arithmetic_ns_per_point_in_L2": l2, "bytes_streamed_per_point": 8 * (len(ins) + C),
                "page_faults_per_call": faults,
                "ceiling_by_bytes_1thread": p1 / s1,
                "ceiling_1thread": p1 / max(s1, l2 * N * 1e-9),
                "ratio_1thread_cpu": p1 / t1,
            }
        # the output allocation and a pool round trip
        import mmap

        import numba

        threads(1)
        fresh = best_of(lambda: _touch(np.frombuffer(mmap.mmap(-1, 8 * N), dtype=np.float64)), repeat)[0]
        reused = best_of(lambda: _touch(np.empty(N)), repeat)[0]

        nop = numba.njit(nogil=True)(lambda lo, hi, x: None)
        x = np.zeros(1)
        nop(0, 0, x)
        threads(2)
        trip = best_of(lambda: dispatch.run(nop, 2 * dispatch.MIN_POINTS_PER_THREAD, x), 50)[0]  # two ranges, no work
    finally:
        if env is None:
            os.environ.pop("SHELLREPAIR_THREADS", None)
        else:
            os.environ["SHELLREPAIR_THREADS"] = env
    return {"points": N, "functions": res,
            "output_first_touch_fresh_pages_ms": 1e3 * fresh, "output_first_touch_np_empty_ms": 1e3 * reused,
            "pool_round_trip_ms": 1e3 * trip}


def _touch(a):
    a[::512] = 0.0  # one write per 4 KiB page
    return a


def print_ceilings(res):
    print("ceilings, %d points: CPU ms on one thread (thread_time), wall ms on two; stream = a bare kernel"
          " over the same bytes; arithmetic = ns a point in L2" % res["points"])
    print("  %-26s %7s %7s %7s %7s %7s %6s %5s %5s %7s %7s %7s" % (
        "function", "ours1", "ours2w", "plain1", "strm1", "strm2w", "ns/pt", "B/pt", "flt", "ratio1", "ceilB1",
        "ceil1"))
    for name, r in res["functions"].items():
        print("  %-26s %7.2f %7.2f %7.1f %7.2f %7.2f %6.2f %5d %5.0f %6.1fx %6.1fx %6.1fx" % (
            name, r["ours_1thread_cpu_ms"], r["ours_2threads_wall_ms"], r["plain_cpu_ms"],
            r["stream_1thread_cpu_ms"], r["stream_2threads_wall_ms"], r["arithmetic_ns_per_point_in_L2"],
            r["bytes_streamed_per_point"], r["page_faults_per_call"], r["ratio_1thread_cpu"], r["ceiling_by_bytes_1thread"],
            r["ceiling_1thread"]))
    print("  output of %d floats: first touch of fresh pages %.2f ms, of np.empty's (reused) %.2f ms;"
          " a two-thread pool round trip %.3f ms" % (res["points"], res["output_first_touch_fresh_pages_ms"],
                                                     res["output_first_touch_np_empty_ms"],
                                                     res["pool_round_trip_ms"]))

def print_functions(res):
    print("per function, %d points, %s (%d threads) vs plain vectorised NumPy (goal >= 10x)"
          % (res["points"], "compiled kernels" if res["jit"] else "NumPy (no JIT)", res["threads"]))
    print("  %-28s %9s %9s %9s %8s %11s" % ("function", "ours ms", "plain ms", "oracle ms", "ratio",
                                          "vs oracle"))
    for name, r in res["functions"].items():
        print("  %-28s %9.2f %9.2f %9.2f %7.1fx %11.1e" % (name, r["ours_ms"], r["plain_numpy_ms"],
                                                      r["numpy_oracle_ms"], r["ratio_plain_over_ours"],
                                                      r["max_rel_diff_vs_oracle"]))


def random_points(N, seed=0):
    rng = np.random.default_rng(seed)

    def hemi(k):
        v = rng.normal(size=(k, 3))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    n = rng.normal(size=(N, 3)) * 0.15 + [0, 0, 1]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return (hemi(N), hemi(N), n, rng.uniform(0.0, 1.0, N), rng.uniform(0.0, 1.0, N),
            rng.uniform(0.0, 1.0, N))


def best_of(fn, repeat, clock=time.perf_counter):
    best = np.inf
    out = None
    for _ in range(repeat):
        t = clock()
        out = fn()
        best = min(best, clock() - t)
    return best, out


def bench_shading(N, repeat):
    from scipy.interpolate import RegularGridInterpolator

    mat = mt.get_material("aged-bronze")
    table = sh.rho_dt_table()
    interp = RegularGridInterpolator((table.u, table.log_m, table.kappa), table.values,
                                     bounds_error=False, fill_value=None)
    wi, wo, n, c, g, d = random_points(N)
    shader = sd.MaterialShader(mat)
    shader(wi[:1000], wo[:1000], n[:1000], c[:1000], g[:1000], d[:1000])  # warm up
    t_fast, f_fast = best_of(lambda: shader(wi, wo, n, c, g, d), repeat)
    t_ref, f_ref = best_of(lambda: sd.shade_reference(wi, wo, n, c, mat, g, d), repeat)
    with np.errstate(all="ignore"):
        t_naive, f_naive = best_of(lambda: naive_shade(wi, wo, n, c, mat, interp, g, d), repeat)

    def rel(a, b):
        ok = np.isfinite(b)
        return float(np.max(np.abs(a[ok] - b[ok]) / np.maximum(np.abs(b[ok]), 1e-3)))

    return {
        "points": N,
        "fast_seconds": t_fast,
        "reference_seconds": t_ref,
        "naive_seconds": t_naive,
        "fast_evals_per_s": N / t_fast,
        "reference_evals_per_s": N / t_ref,
        "naive_evals_per_s": N / t_naive,
        "speedup_vs_naive": t_naive / t_fast,
        "speedup_vs_reference": t_ref / t_fast,
        "max_rel_diff_fast_vs_reference": rel(f_fast, f_ref),
        "max_rel_diff_naive_vs_reference": rel(f_naive, f_ref),
        "naive_nonfinite": int(np.sum(~np.isfinite(f_naive))),
        "fast_nonfinite": int(np.sum(~np.isfinite(f_fast))),
    }


def bench_table(n_samples):
    # build: what `python -m shellrepair.appearance.reflectance.table` spends; load: the shipped file read
    t = time.perf_counter()
    albedo._build_table()
    build = time.perf_counter() - t
    albedo._TABLE = None
    t = time.perf_counter()
    sh.rho_dt_table()
    load = time.perf_counter() - t
    rng = np.random.default_rng(1)
    th = rng.uniform(0.0, 89.0, n_samples)
    th[: n_samples // 5] = rng.uniform(85.0, 89.0, n_samples // 5)
    m = np.exp(rng.uniform(np.log(0.02), 0.0, n_samples))
    eta = rng.uniform(1.1, 2.5, n_samples)
    corners = np.array([(a, b, e) for a in (0.0, 60.0, 89.0) for b in (0.02, 1.0) for e in (1.1, 2.5)])
    th = np.concatenate([corners[:, 0], th])
    m = np.concatenate([corners[:, 1], m])
    eta = np.concatenate([corners[:, 2], eta])
    c = np.cos(np.radians(th))
    ref = 1.0 - sh.specular_albedo(c, m, eta, n_t=48, n_phi=80)
    err = np.abs(sh.diffuse_transmittance(c, m, eta) - ref)
    i = int(np.argmax(err))
    return {
        "build_seconds": build,
        "load_seconds": load,
        "samples": int(len(th)),
        "max_abs_error": float(err.max()),
        "p99_abs_error": float(np.percentile(err, 99)),
        "worst_point": {"theta_deg": float(th[i]), "m": float(m[i]), "eta": float(eta[i])},
        "stated_bound": sh.RHO_DT_MAX_ERROR,
    }


def bumpy_sphere(target_faces):
    import open3d as o3d

    res = int(round(np.sqrt(target_faces / 4.0)))  # open3d: ~4 res^2 faces
    mesh = o3d.geometry.TriangleMesh.create_sphere(100.0, res)
    V = np.asarray(mesh.vertices).copy()
    F = np.asarray(mesh.triangles).astype(np.int64)
    u = V / 100.0
    bump = 1.0 + 0.06 * np.sin(7 * u[:, 0]) * np.sin(5 * u[:, 1]) * np.sin(6 * u[:, 2] + 1.0)
    return V * bump[:, None], F


def bench_render(faces, size):
    V, F = bumpy_sphere(faces)
    filled = V[F].mean(axis=1)[:, 1] > 60.0
    info = {}
    t = time.perf_counter()
    rd.render_mesh(V, F, size=size, filled=filled, highlight_filled=True, info=info)
    total = time.perf_counter() - t
    return {
        "faces": int(len(F)),
        "vertices": int(len(V)),
        "size": list(size),
        "seconds_total": total,
        "seconds_breakdown": info["seconds"],
        "coverage_source": info["coverage_source"],
        "hit_pixels": info["hit_pixels"],
        "model": info["model"].model,
        "model_error_estimate": info["model"].error_estimate,
    }


def bench_aging(target_faces):
    from shellrepair.appearance import aging as ag

    V, F = bumpy_sphere(target_faces)
    from eval import shapes

    ag.aging_maps(*shapes.icosphere(1))  # imports
    t, c = time.perf_counter(), time.process_time()
    maps = ag.aging_maps(V, F)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    return {"vertices": int(len(V)), "faces": int(len(F)), "seconds_wall": wall, "seconds_cpu": cpu,
            "corroded_area_fraction": float(np.mean(maps.coverage))}


def bench_antialiasing(size):
    from shellrepair.mesh.io import read_mesh

    bunny = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "bunny_zipper.ply")
    mesh = read_mesh(bunny)
    out = {}
    for ss in (1, 2):
        info = {}
        t = time.perf_counter()
        rd.render_mesh(mesh.V, mesh.F, size=size, supersample=ss, info=info)
        out["ss%d_seconds" % ss] = time.perf_counter() - t
        out["ss%d_breakdown" % ss] = info["seconds"]
    out["size"] = list(size)
    out["cost_ratio"] = out["ss2_seconds"] / out["ss1_seconds"]
    return out


def bench_doc_numbers():
    """Numbers docs/shading.md quotes, printed from the code."""
    mat = mt.get_material("aged-bronze")
    switch = sd.model_switch_footprint_um(mat)
    choice = sd.choose_model(1000.0, mat)
    th = np.array([0.0, 60.0, 80.0, 85.0, 87.0, 89.0])
    c = np.cos(np.radians(th))
    smooth = {}
    for eta in (1.5, 1.75):
        d = np.abs(sh.diffuse_transmittance(c, 0.005, eta) - (1.0 - sh.fresnel_dielectric(c, eta)))
        smooth["eta=%g" % eta] = {"%g deg" % a: float(v) for a, v in zip(th, d)}
    rng = np.random.default_rng(3)
    N = 300
    tt = rng.uniform(0, 89, N)
    m = np.exp(rng.uniform(np.log(0.02), 0.0, N))
    eta = rng.uniform(0.3, 1.0, N)
    cc = np.cos(np.radians(tt))
    err = np.abs(sh.diffuse_transmittance(cc, m, eta) - (1.0 - sh.specular_albedo(cc, m, eta, n_t=48,
                                                                                    n_phi=80)))
    rough = m >= 0.1
    # white furnace: directional albedo of a white stack over a grid with eta < 1 and grazing
    x, w = np.polynomial.legendre.leggauss(400)
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    worst = {"below_1": 0.0, "at_or_above_1": 0.0}
    for e in (0.5, 0.67, 0.8, 0.95, 1.0, 1.2, 1.5, 1.75, 2.5, 3.0):
        for mm in (0.02, 0.1, 0.3, 1.0, 1.5):
            co = np.cos(np.radians([0.0, 30.0, 60.0, 80.0, 85.0, 88.0, 89.0, 89.5, 89.9]))
            A = sh.specular_albedo(co, mm, e, n_t=64, n_phi=96)
            fd = sh.layered_diffuse(mu[None, :], co[:, None], mm, e, np.ones(1))[..., 0]
            A = A + 2.0 * np.pi * np.sum(fd * mu * w, axis=1)
            key = "below_1" if e < 1.0 else "at_or_above_1"
            worst[key] = max(worst[key], float(A.max()))
    return {
        "dipole_switch_footprint_um": switch,
        "diffusion_length_um": choice.diffusion_length_um,
        "rho_dt_m0.005_minus_smooth_limit": smooth,
        "rho_dt_eta_below_1_max_error_m>=0.02": float(err.max()),
        "rho_dt_eta_below_1_max_error_m>=0.1": float(err[rough].max()),
        "rho_dt_eta_below_1_median_error": float(np.median(err)),
        "white_furnace_max_albedo": worst,
        "internal_reflectance_eta1.75_m0.45": float(sh.internal_reflectance(0.45, 1.75)),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--faces", type=int, default=1_000_000)
    ap.add_argument("--size", default="1024x1024")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="small sizes, for a smoke run")
    ap.add_argument("--functions-only", action="store_true",
                    help="only the per-function ratios against plain NumPy (1e6 points by default)")
    ap.add_argument("--one-thread-cpu", action="store_true",
                    help="with --functions-only: one thread, timed by its CPU time (for a shared machine)")
    ap.add_argument("--ceilings", nargs="*", metavar="NAME",
                    help="what bounds each function (or the NAMEd ones): stream floor, arithmetic in L2,"
                         " one-thread CPU ratios (~1 minute)")
    args = ap.parse_args(argv)
    if args.ceilings is not None:
        res = bench_ceilings(args.points, max(args.repeat, 5), args.ceilings or None)
        print_ceilings(res)
        os.makedirs(RESULTS, exist_ok=True)
        with open(os.path.join(RESULTS, "bench_shading_ceilings.json"), "w") as fh:
            json.dump(res, fh, indent=2)
        return 0
    if args.functions_only:
        name = "bench_shading_functions.json"
        clock = time.perf_counter
        if args.one_thread_cpu:
            os.environ["SHELLREPAIR_THREADS"] = "1"  # read by the kernels on every call
            name, clock = "bench_shading_functions_1thread_cpu.json", time.thread_time
        res = bench_functions(args.points, args.repeat, clock)
        res["clock"] = "thread CPU time, one thread" if args.one_thread_cpu else "wall time"
        print_functions(res)
        os.makedirs(RESULTS, exist_ok=True)
        with open(os.path.join(RESULTS, name), "w") as fh:
            json.dump(res, fh, indent=2)
        return 0
    if args.quick:
        args.points, args.faces, args.size, args.repeat = 100_000, 50_000, "256x256", 1
    size = tuple(int(x) for x in args.size.lower().split("x"))

    functions = bench_functions(1_000_000, args.repeat)
    table = bench_table(400 if not args.quick else 60)
    shading = bench_shading(args.points, args.repeat)
    render = bench_render(args.faces, size)
    aging = bench_aging(2 * args.faces)
    aa = bench_antialiasing((256, 192) if args.quick else (512, 384))
    numbers = bench_doc_numbers()
    result = {
        "machine": {"python": platform.python_version(), "numpy": np.__version__,
                    "processor": platform.processor() or platform.machine(),
                    "cpus": os.cpu_count()},
        "shading": shading,
        "functions": functions,
        "rho_dt_table": table,
        "render": render,
        "aging_map": aging,
        "antialiasing": aa,
        "doc_numbers": numbers,
    }
    os.makedirs(RESULTS, exist_ok=True)
    path = os.path.join(RESULTS, "bench_shading.json")
    with open(path, "w") as fh:
        json.dump(result, fh, indent=2)

    s = shading
    print("shading, %d points, full aged-bronze model (best of %d)" % (s["points"], args.repeat))
    print("  %-34s %12s %14s %12s" % ("implementation", "seconds", "evals/s", "max rel diff"))
    print("  %-34s %12.3f %14.3g %12s" % ("MaterialShader (fast)", s["fast_seconds"],
                                          s["fast_evals_per_s"], "%.1e" % s["max_rel_diff_fast_vs_reference"]))
    print("  %-34s %12.3f %14.3g %12s" % ("shade_reference (term by term)", s["reference_seconds"],
                                          s["reference_evals_per_s"], "0 (ref)"))
    print("  %-34s %12.3f %14.3g %12s" % ("straightforward NumPy", s["naive_seconds"],
                                          s["naive_evals_per_s"], "%.1e" % s["max_rel_diff_naive_vs_reference"]))
    print("  speedup: %.1fx vs straightforward, %.1fx vs term-by-term (goal 10x)"
          % (s["speedup_vs_naive"], s["speedup_vs_reference"]))
    print_functions(functions)
    t = table
    print("rho_dt table: built in %.2f s, loaded in %.3f s; max |error| %.2e (p99 %.1e) over %d samples,"
          " stated bound %.0e; worst at theta=%.1f m=%.3f eta=%.2f"
          % (t["build_seconds"], t["load_seconds"], t["max_abs_error"], t["p99_abs_error"],
             t["samples"], t["stated_bound"], t["worst_point"]["theta_deg"], t["worst_point"]["m"],
             t["worst_point"]["eta"]))
    r = render
    b = r["seconds_breakdown"]
    print("render: %d faces at %dx%d in %.2f s (cast %.2f, coverage %.2f [%s], shade+shadows %.2f);"
          " model %s (error %.1e)"
          % (r["faces"], size[0], size[1], r["seconds_total"], b["cast"], b["coverage"],
             r["coverage_source"], b["shade"], r["model"], r["model_error_estimate"]))
    a = aging
    print("aging map: %d vertices in %.2f s wall, %.2f s CPU" % (a["vertices"], a["seconds_wall"],
                                                              a["seconds_cpu"]))
    print("antialiasing (bunny at %dx%d): 1 ray/pixel %.2f s, 2x2 rays %.2f s (x%.2f)"
          % (aa["size"][0], aa["size"][1], aa["ss1_seconds"], aa["ss2_seconds"], aa["cost_ratio"]))
    print("doc numbers:", json.dumps(numbers, indent=1))
    print("wrote %s" % os.path.relpath(path))
    return 0


if __name__ == "__main__":
    sys.exit(main())
