"""The reflectance package and the materials split behind their façades.

``shellrepair.appearance.shading`` and ``shellrepair.appearance.materials`` are façades over
``shellrepair.appearance.reflectance`` (microfacet, albedo, km, dipole, layered),
``shellrepair.appearance.coverage`` and ``shellrepair.appearance.shader``.  These tests pin that

- every public name of a façade IS the package's object (not a copy or a
  wrapper), so the rest of the code and the existing reference tests in
  tests/test_shading.py exercise the package itself;
- the shader reads the materials one way: materials never imports the
  shader, and any module may be imported first;
- the NumPy reference implementations give the values they gave before the
  split: ``tests/data/reflectance_pins.npz`` holds the outputs of
  :func:`pin_outputs` computed by the single-file modules of commit f4b9ef4
  (``np.savez_compressed(path, **pin_outputs(shading, materials))`` with that
  commit's package imported).  They must agree to 1e-12 relative (ulps of libm's
  exp/log/sqrt may differ between CPUs; any change of a formula or a guard
  moves them by far more).

  The outputs that read the rho_dt table (:data:`TABLE_READERS`) were
  re-recorded on 2026-12-06, when the table began to ship with the package
  with its values rounded down to multiples of 2**-20 (docs/cost.md): they
  moved by at most 1.9e-6.  Their f4b9ef4 values are kept in the same file
  as ``f4b9ef4/NAME``, and the outputs must stay within
  :data:`TABLE_ROUNDING_ATOL` of them.
"""

import pathlib
import subprocess
import sys

import numpy as np
import pytest

from shellrepair import compiled
from shellrepair.appearance import coverage
from shellrepair.appearance import materials
from shellrepair.appearance import reflectance
from shellrepair.appearance import shader
from shellrepair.appearance import shading
from shellrepair.appearance.reflectance import albedo, dipole, km, layered, microfacet

PINS = pathlib.Path(__file__).parent / "data" / "reflectance_pins.npz"

SUBMODULES = (microfacet, albedo, km, dipole, layered)
#: The pinned outputs that read the rho_dt table (re-recorded when it began to ship rounded).
TABLE_READERS = ("diffuse_transmittance", "mean_transmittance", "internal_reflectance", "layered_diffuse",
                 "local_brdf", "shade_reference/aged-bronze", "MaterialShader.diffuse/aged-bronze",
                 "MaterialShader.ambient/aged-bronze")
#: How far the shipped table's rounding (2**-20 ~ 9.5e-7 in rho_dt) may move them from the f4b9ef4 values.
TABLE_ROUNDING_ATOL = 4e-6


def test_shading_facade_names_are_the_package_objects():
    assert sorted(shading.__all__) == sorted(reflectance.__all__)
    for name in shading.__all__:
        obj = getattr(shading, name)
        assert obj is getattr(reflectance, name), name
        homes = [m for m in SUBMODULES if name in m.__all__]
        assert len(homes) == 1, (name, homes)  # exported by exactly one module
        assert obj is vars(homes[0])[name]
        if callable(obj):
            assert obj.__module__ == homes[0].__name__, name


def test_shading_facade_module_names_resolve_to_their_module():
    # names the modules define beyond the package's __all__ (functions and constants)
    assert "rule_albedo" not in shading.__all__ and "SHIPPED_BITS" not in shading.__all__
    assert shading.rule_albedo is albedo.rule_albedo
    assert shading.albedo_geometry is albedo.albedo_geometry
    assert shading.dipole_A is dipole.dipole_A
    assert shading.SHIPPED_BITS == albedo.SHIPPED_BITS
    with pytest.raises(AttributeError):
        shading.no_such_name  # noqa: B018


def test_materials_facade_names_are_the_split_modules_objects():
    for name in materials.__all__:
        obj = getattr(materials, name)
        assert name not in shader.__all__, name      # the shader's names live in the shader only
        if name in coverage.__all__:
            assert obj is getattr(coverage, name), name
        else:
            assert name in vars(materials), name
    assert materials.vertex_normals is coverage.vertex_normals
    assert shader.MaterialShader.__module__ == "shellrepair.appearance.shader"
    assert coverage.rust_coverage.__module__ == "shellrepair.appearance.coverage"


@pytest.mark.parametrize("first", ["shellrepair.appearance.shader", "shellrepair.appearance.materials", "shellrepair.appearance.coverage",
                                   "shellrepair.appearance.shading", "shellrepair.appearance.reflectance.layered"])
@pytest.mark.slow
def test_any_module_can_be_imported_first(first):
    code = ("import %s; from shellrepair.appearance.materials import *; from shellrepair.appearance.shading import *; "
            "from shellrepair.appearance.shader import *; import shellrepair.appearance.shader as s; "
            "assert MaterialShader is s.MaterialShader and get_material is s.get_material" % first)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def pin_inputs(seed=20261130, N=64):
    """Seeded inputs with the hard cases each guard is for."""
    rng = np.random.default_rng(seed)

    def unit(v):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    wi = unit(rng.normal(size=(N, 3)))
    wo = unit(rng.normal(size=(N, 3)))
    n = unit(rng.normal(size=(N, 3)) * 0.3 + [0, 0, 1])
    wi[0], wo[0], n[0] = unit([1, 0, 1e-9]), unit([-1, 0, 1e-9]), (0, 0, 1)  # grazing mirror pair
    wi[1], wo[1], n[1] = (0, 0, 1), (0, 0, 1), (0, 0, 1)  # normal incidence
    wi[2], wo[2] = unit([1, 0, 1]), unit([-1, 0, -1])  # i = -o: no half vector
    c = rng.uniform(-0.1, 1.1, N)
    c[:4] = (0.0, 1e-13, 1.0, 0.5)
    m = np.exp(rng.uniform(np.log(1e-4), np.log(2.0), N))
    m[:3] = (0.0, 1e-6, 0.3)  # m -> 0
    eta = rng.uniform(0.2, 3.5, N)
    eta[:3] = (1.0, 0.5, 1.75)
    K = rng.uniform(0, 3, N)
    S = rng.uniform(0, 3, N)
    X = rng.uniform(0, 100, N)
    Rg = rng.uniform(0, 1, N)
    K[:4], S[4:8], X[8:12], X[12:16] = 0.0, 0.0, np.inf, 0.0  # K -> 0, S -> 0, X = inf, X = 0
    S[16:20], X[16:20], K[16:18] = 1e4, 1e3, 0.0  # huge S X, conservative and not
    cov = rng.uniform(-0.1, 1.1, N)
    gild = rng.uniform(0, 1, N)
    crust = rng.uniform(0, 1, N)
    R3 = rng.uniform(0, 1, (N, 3))
    return dict(wi=wi, wo=wo, n=n, c=c, m=m, eta=eta, K=K, S=S, X=X, Rg=Rg, cov=cov, gild=gild,
                crust=crust, R3=R3)


def pin_outputs(sh, mt, sd=None):
    """The NumPy reference outputs that the split must not change (``sd``:
    the module with the shader's names, ``mt`` where they were once)."""
    sd = mt if sd is None else sd
    p = pin_inputs()
    wi, wo, n, c, m, eta = p["wi"], p["wo"], p["n"], p["c"], p["m"], p["eta"]
    K, S, X, Rg, R3 = p["K"], p["S"], p["X"], p["Rg"], p["R3"]
    nk = (np.array([0.22, 1.02, 1.24]), np.array([3.747, 2.577, 2.397]))
    out = {
        "beckmann_D": sh.beckmann_D(c, m),
        "v_cavity_G": sh.v_cavity_G(c, c[::-1], np.abs(c), c - 0.2),
        "fresnel_dielectric": sh.fresnel_dielectric(c, eta),
        "fresnel_conductor": sh.fresnel_conductor(c, eta, K),
        "torrance_sparrow": sh.torrance_sparrow(wi, wo, n, m, eta),
        "torrance_sparrow_conductor": sh.torrance_sparrow_conductor(wi, wo, n, m, *nk),
        "specular_albedo": sh.specular_albedo(np.abs(c[:16]), m[:16], eta[:16], n_t=16, n_phi=24),
        "diffuse_transmittance": sh.diffuse_transmittance(c, m, eta),
        "mean_transmittance": sh.mean_transmittance(m, eta),
        "internal_reflectance": sh.internal_reflectance(m, eta),
        "layered_diffuse": sh.layered_diffuse(c, c[::-1], m, eta, R3),
        "local_brdf": sh.local_brdf(wi, wo, n, m, eta, R3),
        "km_r_inf": sh.km_r_inf(K, S),
        "km_reflectance": sh.km_reflectance(K, S, X, Rg),
        "km_layers": sh.km_layers([(K, S, X), (S, K, X[::-1])], Rg),
        "km_mix": np.array(sh.km_mix(np.stack([K, S]), np.stack([S, K]), [0.3, 0.7])),
        "dipole_rd": sh.dipole_rd(Rg, eta),
        "dipole_tail_fraction": sh.dipole_tail_fraction(X[20:], K[20:] + 0.01, S[20:], eta[20:]),
        "dipole_profile": sh.dipole_profile(X[20:], K[20:] + 0.01, S[20:], eta[20:]),
        "km_to_transport": np.array(sh.km_to_transport(K, S)),
    }
    for name in ("aged-bronze", "gilt", "bronze"):
        out["shade_reference/" + name] = sd.shade_reference(wi, wo, n, p["cov"], name, p["gild"], p["crust"])
        spec, diff = sd.MaterialShader(name)(wi, wo, n, p["cov"], p["gild"], p["crust"], parts=True)
        out["MaterialShader.spec/" + name] = spec
        out["MaterialShader.diffuse/" + name] = diff
        out["MaterialShader.ambient/" + name] = np.concatenate(
            sd.MaterialShader(name).ambient(np.abs(c), np.clip(p["cov"], 0, 1), p["gild"], p["crust"]))
    out["choose_model"] = np.array([sd.choose_model(f, "aged-bronze").error_estimate
                                    for f in (10.0, 100.0, 1000.0)])
    out["rust_coverage_from_colors"] = mt.rust_coverage_from_colors(
        np.random.default_rng(1).integers(0, 256, (64, 3)).astype(np.uint8))
    return out


def test_reference_outputs_unchanged_by_the_split(monkeypatch):
    monkeypatch.setattr(compiled, "ENABLED", False)  # the NumPy versions; the kernels are held to them elsewhere
    pins = np.load(PINS)
    with np.errstate(all="ignore"):
        now = pin_outputs(shading, materials, shader)
    before = {name[len("f4b9ef4/"):]: pins[name] for name in pins.files if name.startswith("f4b9ef4/")}
    assert sorted(before) == sorted(TABLE_READERS)
    assert sorted(now) == sorted(name for name in pins.files if not name.startswith("f4b9ef4/"))
    for name, a in before.items():
        ok = np.isfinite(a)
        np.testing.assert_allclose(now[name][ok], a[ok], rtol=0, atol=TABLE_ROUNDING_ATOL, err_msg=name)
    for name in now:
        a, b = pins[name], now[name]
        assert a.shape == b.shape, name
        np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b), err_msg=name)
        ok = np.isfinite(a)
        # 1e-12: NumPy's vectorised exp and log differ in the last bits from
        # one CPU to another (the pins were written on an Intel Xeon; on an AMD
        # EPYC layered_diffuse's near-zero entries differ by 4.3e-13); any
        # change to a formula moves them by far more
        np.testing.assert_allclose(b[ok], a[ok], rtol=1e-12, atol=1e-300, err_msg=name)

