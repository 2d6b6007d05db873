"""The compiled shading kernels against their NumPy versions (the oracles:
:mod:`shellrepair.appearance.reflectance.reference`, :meth:`shellrepair.appearance.shader.MaterialShader.evaluate_numpy`).

Stated tolerances (each asserted below):

- every public function of shellrepair.appearance.reflectance: ``|f - f_np| <= 1e-12 |f_np| + 1e-250``.
  The kernels apply the same operations in the same order; exp and log
  are our own vectorisable versions (within 1 ulp of libm's,
  :func:`test_exp_expm1_log_within_one_ulp_of_libm`).  The 1e-250 floor
  is for subnormals, which the kernels flush to zero (FTZ/DAZ): a value
  NumPy gives as 1e-310 is 0 here, and at most a factor ~1e48 (1/cos^4
  of the smallest cosine) can lift such a value before it is returned.
- MaterialShader: ``rtol 1e-11``.  Its dot products are summed in another
  order than ``np.einsum``'s, and the Beckmann exponent (up to ~745 in
  magnitude) multiplies an ulp of the cosine by that much.
- the NumPy versions stay exactly what they were: with
  the kernels off (``shellrepair.compiled.ENABLED`` False, as
  ``SHELLREPAIR_NO_NUMBA=1`` sets it) the public functions return the oracle's arrays
  bit for bit, and tests/test_reflectance_split.py pins those values.
"""

import numpy as np
import pytest

from shellrepair import compiled
from shellrepair.appearance import shader as sd
from shellrepair.appearance.reflectance import albedo as al
from shellrepair.appearance.reflectance import dipole as dp
from shellrepair.appearance.reflectance import dispatch, km
from shellrepair.appearance.reflectance import layered as ly
from shellrepair.appearance.reflectance import microfacet as mf
from shellrepair.appearance.reflectance import reference as ref

KERNELS_ON = all(dispatch.kernels(name) is not None for name in dispatch.KERNEL_MODULES)
pytestmark = pytest.mark.skipif(not KERNELS_ON, reason="Numba kernels off (SHELLREPAIR_NO_NUMBA or numba missing)")

RTOL, ATOL = 1e-12, 1e-250
RTOL_SHADER = 1e-11


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def hard_inputs(N=3000, seed=3):
    """Random points plus the cases each guard is for."""
    rng = np.random.default_rng(seed)
    wi = unit(rng.normal(size=(N, 3)))
    wo = unit(rng.normal(size=(N, 3)))
    n = unit(rng.normal(size=(N, 3)) * 0.3 + [0, 0, 1])
    g = unit(np.array([1.0, 0.0, 1e-9]))
    wi[0], wo[0], n[0] = g, g * [-1, 1, 1], (0, 0, 1)  # mirror pair grazing the horizon
    wi[1], wo[1], n[1] = (0, 0, 1), (0, 0, 1), (0, 0, 1)  # normal incidence
    wi[2], wo[2] = unit([1, 0, 1]), unit([-1, 0, -1])  # i = -o: no half vector
    wi[3], wo[3], n[3] = unit([1, 0, 1e-13]), unit([0, 1, 1e-13]), (0, 0, 1)  # at the horizon
    c = rng.uniform(-0.1, 1.1, N)
    c[:6] = (0.0, 1e-13, 1e-12, 1.0, 0.5, -0.3)
    m = np.exp(rng.uniform(np.log(1e-4), np.log(2.0), N))
    m[:4] = (0.0, 1e-9, 1e-3, 1.5)  # m -> 0
    eta = rng.uniform(0.2, 3.5, N)
    eta[:5] = (1.0, 0.5, 1.75, 0.3, 3.0)
    Kc, S = rng.uniform(0, 3, N), rng.uniform(0, 3, N)
    X, Rg = rng.uniform(0, 100, N), rng.uniform(0, 1, N)
    Kc[:4] = 0.0  # conservative layer
    S[4:8] = 0.0  # pure absorption
    Kc[8:10], S[8:10] = 0.0, 0.0  # empty layer
    X[10:14], X[14:18] = np.inf, 0.0
    S[18:24], X[18:24], Kc[18:21] = 1e4, 1e3, 0.0  # huge S X, conservative and not
    X[24:26], Kc[24:26], S[24:26] = 1e-9, 1e-9, 1e-9  # tiny z: the series branches
    R3 = rng.uniform(0, 1, (N, 3))
    R3[:3] = (0.0, 1.0, 0.5)
    return dict(wi=wi, wo=wo, n=n, c=c, m=m, eta=eta, K=Kc, S=S, X=X, Rg=Rg, R3=R3)


def cases():
    p = hard_inputs()
    wi, wo, n, c, m, eta = p["wi"], p["wo"], p["n"], p["c"], p["m"], p["eta"]
    Kc, S, X, Rg, R3 = p["K"], p["S"], p["X"], p["Rg"], p["R3"]
    nk = (np.array([0.22, 1.02, 1.24]), np.array([3.747, 2.577, 2.397]))
    up = np.array([0.0, 0.0, 1.0])
    eta_pole = np.random.default_rng(5).uniform(3.8, 3.95, len(c))
    return {
        "beckmann_D": (mf.beckmann_D, ref.beckmann_D, (c, m)),
        "beckmann_D broadcast": (mf.beckmann_D, ref.beckmann_D, (c[:40, None], m[None, :50])),
        "v_cavity_G": (mf.v_cavity_G, ref.v_cavity_G, (c, c[::-1], np.abs(c), c - 0.2)),
        "fresnel_dielectric": (mf.fresnel_dielectric, ref.fresnel_dielectric, (c, eta)),
        "fresnel_conductor": (mf.fresnel_conductor, ref.fresnel_conductor, (c, eta, Kc)),
        "fresnel_conductor per channel": (mf.fresnel_conductor, ref.fresnel_conductor, (c[:, None],) + nk),
        "torrance_sparrow": (mf.torrance_sparrow, ref.torrance_sparrow, (wi, wo, n, m, eta)),
        "torrance_sparrow one normal, scalars": (mf.torrance_sparrow, ref.torrance_sparrow,
                                                 (wi, wo, up, 0.3, 1.75)),
        "torrance_sparrow_conductor": (mf.torrance_sparrow_conductor, ref.torrance_sparrow_conductor,
                                       (wi, wo, n, m) + nk),
        "diffuse_transmittance": (al.diffuse_transmittance, ref.diffuse_transmittance, (c, m, eta)),
        "diffuse_transmittance one index": (al.diffuse_transmittance, ref.diffuse_transmittance,
                                            (c, m, 0.8)),
        "mean_transmittance": (al.mean_transmittance, ref.mean_transmittance, (m, eta)),
        "internal_reflectance": (al.internal_reflectance, ref.internal_reflectance, (m, eta)),
        "layered_diffuse": (ly.layered_diffuse, ref.layered_diffuse, (c, c[::-1], m, eta, R3)),
        "layered_diffuse one stack": (ly.layered_diffuse, ref.layered_diffuse, (c, c[::-1], m, 1.75, R3[5])),
        "local_brdf": (ly.local_brdf, ref.local_brdf, (wi, wo, n, m, eta, R3)),
        "local_brdf scalars": (ly.local_brdf, ref.local_brdf, (wi, wo, up, 0.3, 1.75, R3[7])),
        "km_r_inf": (km.km_r_inf, ref.km_r_inf, (Kc, S)),
        "km_reflectance": (km.km_reflectance, ref.km_reflectance, (Kc, S, X, Rg)),
        "km_reflectance per channel": (km.km_reflectance, ref.km_reflectance,
                                       (Kc[:, None], S[:, None], X[:, None], R3)),
        "dipole_rd": (dp.dipole_rd, ref.dipole_rd, (Rg, eta)),
        "dipole_tail_fraction": (dp.dipole_tail_fraction, ref.dipole_tail_fraction, (X, Kc, S, eta)),
        "dipole_profile": (dp.dipole_profile, ref.dipole_profile, (X, Kc + 1e-3, S, eta)),
        # eta ~ 3.86: F_dr -> 1, where A = (1 + F_dr) / (1 - F_dr) magnifies an ulp of F_dr
        # g > 1e150: the kernel's one reciprocal of (g + c)(c (g - c) + 1) is taken on scaled operands
        "fresnel_dielectric huge index": (mf.fresnel_dielectric, ref.fresnel_dielectric,
                                          (c, np.exp(np.random.default_rng(6).uniform(345, 354.85, len(c))))),
        # r^2 overflows (dr = inf) for most points, r = 0 and r = inf for some
        "dipole_tail_fraction huge r": (dp.dipole_tail_fraction, ref.dipole_tail_fraction,
                                        (X * 1e160, Kc + 1e-3, S, eta)),
        "dipole_rd near the F_dr pole": (dp.dipole_rd, ref.dipole_rd, (Rg, eta_pole)),
        "dipole_tail_fraction near the F_dr pole": (dp.dipole_tail_fraction, ref.dipole_tail_fraction,
                                                    (X, Kc + 1e-3, S, eta_pole)),
    }


CASES = cases()


@pytest.mark.parametrize("name", sorted(CASES))
def test_kernel_matches_numpy_oracle(name):
    fast, oracle, args = CASES[name]
    with np.errstate(all="ignore"):
        a = fast(*args)
        b = oracle(*args)
    assert a.shape == b.shape and a.dtype == np.float64
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    np.testing.assert_array_equal(np.isinf(a), np.isinf(b))
    ok = np.isfinite(b)
    np.testing.assert_allclose(a[ok], b[ok], rtol=RTOL, atol=ATOL)


def test_scalar_inputs_give_0d_arrays_like_numpy():
    for f, g, args in [(mf.beckmann_D, ref.beckmann_D, (1.0, 0.5)),
                       (km.km_reflectance, ref.km_reflectance, (0.0, 1.0, 1.0, 0.0)),
                       (al.diffuse_transmittance, ref.diffuse_transmittance, (0.5, 0.3, 1.0))]:
        a, b = f(*args), g(*args)
        assert np.shape(a) == np.shape(b) == ()
        assert float(a) == pytest.approx(float(b), rel=RTOL)


def test_empty_inputs():
    assert mf.torrance_sparrow(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), 0.3, 1.5).shape == (0,)
    assert km.km_reflectance(np.zeros(0), 1.0, 1.0, 0.5).shape == (0,)


@pytest.mark.parametrize("name", ["aged-bronze", "gilt", "bronze"])
def test_material_shader_matches_numpy_oracle(name):
    p = hard_inputs(seed=11)
    rng = np.random.default_rng(2)
    g, d = rng.uniform(-0.2, 1.2, len(p["c"])), rng.uniform(-0.2, 1.2, len(p["c"]))
    shader = sd.MaterialShader(name)
    args = (p["wi"], p["wo"], p["n"], p["c"], g, d)
    f = shader(*args)
    f_np = shader.evaluate_numpy(*args)
    assert f.shape == f_np.shape == (len(p["c"]), 3) and np.all(np.isfinite(f))
    np.testing.assert_allclose(f, f_np, rtol=RTOL_SHADER, atol=ATOL)
    spec, diff = shader(*args, parts=True)
    spec_np, diff_np = shader.evaluate_numpy(*args, parts=True)
    np.testing.assert_allclose(spec, spec_np, rtol=RTOL_SHADER, atol=ATOL)
    np.testing.assert_allclose(diff, diff_np, rtol=RTOL_SHADER, atol=ATOL)
    # one light for all points, scalar coverage (the renderer's call)
    one = shader(p["wi"][5], p["wo"], p["n"], 0.4, 0.7, 0.2, parts=True)
    one_np = shader.evaluate_numpy(p["wi"][5], p["wo"], p["n"], 0.4, 0.7, 0.2, parts=True)
    for a, b in zip(one, one_np):
        np.testing.assert_allclose(a, b, rtol=RTOL_SHADER, atol=ATOL)


def test_exp_expm1_log_within_one_ulp_of_libm():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-745, 709, 200000), rng.uniform(-1, 1, 100000),
                        rng.uniform(-1e-6, 1e-6, 10000), [0.0, -0.0, 1e-300, 0.3465, 0.3466, -0.3466, 709.7]])
    e, em1, lg = np.empty_like(x), np.empty_like(x), np.empty_like(x)
    from shellrepair.appearance.reflectance import common_kernels

    common_kernels.exp_expm1_log(x, e, em1, lg)
    with np.errstate(all="ignore"):
        ref_e, ref_m, ref_l = np.exp(x), np.expm1(x), np.log(np.abs(x))
    ulp = np.finfo(np.float64).eps
    normal = ref_e > np.finfo(np.float64).tiny
    assert np.all(np.abs(e[normal] - ref_e[normal]) <= 2 * ulp * ref_e[normal])
    assert np.all(np.abs(em1 - ref_m) <= 2 * ulp * np.abs(ref_m))
    pos = np.abs(x) >= np.finfo(np.float64).tiny
    assert np.all(np.abs(lg[pos] - ref_l[pos]) <= 2 * ulp * np.maximum(np.abs(ref_l[pos]), 1.0))
    assert e[x == 709.7][0] == pytest.approx(np.exp(709.7), rel=2 * ulp)


def test_kernels_off_give_the_numpy_versions_bit_for_bit(monkeypatch):
    monkeypatch.setattr(compiled, "ENABLED", False)
    assert all(dispatch.kernels(name) is None for name in dispatch.KERNEL_MODULES)
    for name in ("torrance_sparrow", "km_reflectance", "diffuse_transmittance", "local_brdf"):
        fast, oracle, args = CASES[name]
        with np.errstate(all="ignore"):
            np.testing.assert_array_equal(fast(*args), oracle(*args))
    shader = sd.MaterialShader("aged-bronze")
    p = hard_inputs(N=500)
    args = (p["wi"], p["wo"], p["n"], p["c"], 1.0, 0.0)
    np.testing.assert_array_equal(shader(*args), shader.evaluate_numpy(*args))


def test_threads_give_the_same_bits_as_one(monkeypatch):
    p = hard_inputs(N=20000, seed=5)
    args = (p["wi"], p["wo"], p["n"], p["m"], p["eta"])
    monkeypatch.setenv("SHELLREPAIR_THREADS", "1")
    one = mf.torrance_sparrow(*args)
    shader = sd.MaterialShader("aged-bronze")
    s_one = shader(p["wi"], p["wo"], p["n"], p["c"])
    monkeypatch.setenv("SHELLREPAIR_THREADS", "3")
    monkeypatch.setattr(dispatch, "MIN_POINTS_PER_THREAD", 1000)
    np.testing.assert_array_equal(mf.torrance_sparrow(*args), one)
    np.testing.assert_array_equal(shader(p["wi"], p["wo"], p["n"], p["c"]), s_one)


def test_flush_to_zero_does_not_leak_out_of_the_kernels():
    mf.beckmann_D(np.linspace(0.0, 1.0, 1000), 0.01)  # results underflow inside the kernel
    tiny = np.float64(1e-300) * np.float64(1e-10)  # NumPy after the call: still subnormal
    assert 0.0 < tiny < np.finfo(np.float64).tiny


def test_warm_up_compiles_every_kernel():
    from shellrepair.appearance.shader import warm_up

    n = warm_up()
    kernels = [getattr(dispatch.kernels(name), k) for name in dispatch.KERNEL_MODULES
               for k in dispatch.kernels(name).KERNELS]
    assert n >= len(kernels) == 17
    assert all(len(k.signatures) >= 1 for k in kernels)
