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
4. the aging map (shellrepair.aging) on a ~1M-vertex mesh: wall and CPU
   seconds;
5. the numbers docs/shading.md quotes: the footprint where the model
   switches to the dipole, how far rho_dt at m = 0.005 is from its smooth
   limit 1 - F by angle, the table's error for eta < 1 and the worst
   white-furnace albedo.

Prints a table and writes eval/results/bench_shading.json.

Usage: ``python eval/bench_shading.py [--points N] [--faces N] [--quick]``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.abspath(os.path.join(os.path.dirname(__file__), "..")))

from shellrepair import materials as mt  # noqa: E402
from shellrepair import render as rd  # noqa: E402
from shellrepair import shading as sh  # noqa: E402
from shellrepair.reflectance import albedo  # noqa: E402

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


def best_of(fn, repeat):
    best = np.inf
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def bench_shading(N, repeat):
    from scipy.interpolate import RegularGridInterpolator

    mat = mt.get_material("aged-bronze")
    table = sh.rho_dt_table()
    interp = RegularGridInterpolator((table.u, table.log_m, table.kappa), table.values,
                                     bounds_error=False, fill_value=None)
    wi, wo, n, c, g, d = random_points(N)
    shader = mt.MaterialShader(mat)
    shader(wi[:1000], wo[:1000], n[:1000], c[:1000], g[:1000], d[:1000])  # warm up
    t_fast, f_fast = best_of(lambda: shader(wi, wo, n, c, g, d), repeat)
    t_ref, f_ref = best_of(lambda: mt.shade_reference(wi, wo, n, c, mat, g, d), repeat)
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
    with tempfile.TemporaryDirectory() as d:
        old = os.environ.get("SHELLREPAIR_CACHE_DIR")
        os.environ["SHELLREPAIR_CACHE_DIR"] = d
        albedo._TABLE = None
        t = time.perf_counter()
        sh.rho_dt_table()
        build = time.perf_counter() - t
        albedo._TABLE = None
        t = time.perf_counter()
        sh.rho_dt_table()
        load = time.perf_counter() - t
        if old is None:
            del os.environ["SHELLREPAIR_CACHE_DIR"]
        else:
            os.environ["SHELLREPAIR_CACHE_DIR"] = old
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
    from shellrepair import aging as ag

    V, F = bumpy_sphere(target_faces)
    from shellrepair import shapes

    ag.aging_maps(*shapes.icosphere(1))  # imports
    t, c = time.perf_counter(), time.process_time()
    maps = ag.aging_maps(V, F)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    return {"vertices": int(len(V)), "faces": int(len(F)), "seconds_wall": wall, "seconds_cpu": cpu,
            "corroded_area_fraction": float(np.mean(maps.coverage))}


def bench_antialiasing(size):
    from shellrepair.io import read_mesh

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
    switch = mt.model_switch_footprint_um(mat)
    choice = mt.choose_model(1000.0, mat)
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
    args = ap.parse_args(argv)
    if args.quick:
        args.points, args.faces, args.size, args.repeat = 100_000, 50_000, "256x256", 1
    size = tuple(int(x) for x in args.size.lower().split("x"))

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
