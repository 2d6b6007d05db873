"""The fairing's sparse solver against the libraries that do the same job.

Run ``.venv/bin/python eval/bench_solvers.py`` (CHOLMOD needs the bench
extra's ``scikit-sparse`` and Debian's ``libsuitesparse-dev``; a solver
that does not import is left out and said so).

The systems are the fill's own: every Q_uu the fairing factorises while
repairing real and synthetic scans (``shellrepair.fill.cholesky.factor`` is
wrapped to keep a copy), with the right-hand side it solves (three
coordinates). Each system is then factorised and solved by

* ``ours``: :func:`shellrepair.fill.cholesky.factor` (nested dissection,
  dense fronts, Numba), then ``.solve``;
* ``cholmod``: scikit-sparse's ``cholesky`` (CHOLMOD, supernodal, its own
  AMD/METIS ordering), then the solve;
* ``splu``: SciPy's ``splu`` (SuperLU, COLAMD), then the solve;
* ``igl``: libigl's ``min_quad_with_fixed`` (Eigen's simplicial LLᵀ,
  AMD): the path the fill takes without Numba.

in one warm process, BLAS on one thread (as the fill runs it), each the
fastest of ``--repeat`` runs. The residual ‖Q z − r‖ / ‖r‖ of each is
recorded beside its time. The cold cost is measured apart: a fresh
interpreter that has already loaded one of the fill's Numba kernels (as
every repair has by the time it fairs a hole) imports the solver and
solves one 300-unknown system: what the solver adds to a run.

Writes ``eval/results/solvers/solvers.json`` and ``solvers.md``; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

OUT = ROOT / "eval" / "results" / "solvers"
SHARED = ROOT.parent / "shared" / "data"


def _cases():
    """(name, Mesh, repair options): what the systems are collected from."""
    from eval import shapes
    from shellrepair import Mesh, read_mesh

    out = [("bunny (bundled, 5 holes)", read_mesh(ROOT / "data" / "bunny_zipper.ply"), {})]
    V, F = shapes.bumpy_sphere(6, amplitude=0.03, seed=1)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=4, radius=0.35, seed=4)
    out.append(("bumpy sphere, 4 discs r=0.35", Mesh(V=V2, F=F2), {}))
    V, F = shapes.icosphere(7)
    top = int(np.argmax(V[:, 2]))
    V2, F2, _, _ = shapes.perforate_discs(V, F, centers=[top], radius=0.6)
    out.append(("sphere (7 subdivisions), one disc r=0.6", Mesh(V=V2, F=F2), {"order": 3}))
    for name in ("real_rangescan_dragon_000.ply", "real_bunny_pymeshfix_decimated.ply"):
        if (SHARED / name).exists():
            out.append((name, read_mesh(SHARED / name), {}))
    return out


def collect():
    """Every Q_uu the fairing factorises on the cases, with a right-hand side."""
    from shellrepair.fill import cholesky
    from shellrepair.repair import repair_mesh

    systems = []
    real = cholesky.factor

    def keep(Q, *a, **k):
        f = real(Q, *a, **k)
        systems.append((case, sp.csc_matrix(Q, copy=True)))
        return f

    cholesky.factor = keep
    try:
        for case, mesh, opts in _cases():
            repair_mesh(mesh, jobs=1, **opts)
    finally:
        cholesky.factor = real
    return systems


def _solvers():
    from shellrepair.fill import cholesky

    out = {"ours": lambda Q: cholesky.factor(Q).solve}
    try:
        from sksparse.cholmod import cholesky as cholmod

        out["cholmod"] = lambda Q: cholmod(Q)
    except ImportError as e:
        print(f"cholmod left out: {e}")
    import scipy.sparse.linalg as spla

    out["splu"] = lambda Q: spla.splu(Q).solve
    try:
        import igl

        def igl_factor(Q):
            data = igl.min_quad_with_fixed_data()
            igl.min_quad_with_fixed_precompute(Q, np.zeros(0, np.int64), sp.csc_matrix((0, Q.shape[0])), True, data)
            z0 = np.zeros((0, 3))
            return lambda R: igl.min_quad_with_fixed_solve(data, np.ascontiguousarray(-R), z0, z0)

        out["igl"] = igl_factor
    except ImportError as e:
        print(f"igl left out: {e}")
    return out


def time_systems(systems, repeat):
    from shellrepair import blas

    solvers = _solvers()
    rows = []
    rng = np.random.default_rng(0)
    with blas.one_thread():
        for case, Q in systems:
            R = rng.standard_normal((Q.shape[0], 3))
            row = {"case": case, "unknowns": int(Q.shape[0]), "nnz": int(Q.nnz)}
            for name, make in solvers.items():
                best = np.inf
                for _ in range(repeat):
                    t = time.perf_counter()
                    Z = make(Q)(R)
                    best = min(best, time.perf_counter() - t)
                res = float(np.linalg.norm(Q @ Z - R) / np.linalg.norm(R))
                row[name] = {"seconds": best, "residual": res}
            rows.append(row)
    return rows


COLD = {
    "ours": "from shellrepair.fill import cholesky; f = cholesky.factor(Q); z = f.solve(R)",
    "cholmod": "from sksparse.cholmod import cholesky; z = cholesky(Q)(R)",
    "splu": "import scipy.sparse.linalg as spla; z = spla.splu(Q).solve(R)",
    "igl": ("import igl; d = igl.min_quad_with_fixed_data(); "
            "igl.min_quad_with_fixed_precompute(Q, np.zeros(0, np.int64), sp.csc_matrix((0, Q.shape[0])), True, d); "
            "z = igl.min_quad_with_fixed_solve(d, -R, np.zeros((0, 3)), np.zeros((0, 3)))"),
}


def cold(repeat=3):
    """Seconds a fresh interpreter spends importing each solver and solving a
    300-unknown fairing system (the system built, and one of the fill's
    Numba kernels loaded, before the clock starts)."""
    setup = ("import sys, time; sys.path.insert(0, %r); import numpy as np, scipy.sparse as sp; "
             "from eval import shapes; from shellrepair.fill.fair import uniform_laplacian; "
             "from shellrepair.mesh import common_kernels; common_kernels.max_sq_distance(np.zeros((3, 3))); "
             "V, F = shapes.icosphere(3); K = uniform_laplacian(F, len(V)); "
             "u = np.arange(300); Q = sp.csc_matrix((K @ K)[u][:, u] + sp.identity(300) * 1e-3); "
             "R = np.ones((300, 3)); t = time.perf_counter(); ") % str(ROOT)
    out = {}
    for name, code in COLD.items():
        times = []
        for _ in range(repeat):
            p = subprocess.run([sys.executable, "-c", setup + code + "; print(time.perf_counter() - t)"],
                               capture_output=True, text=True, cwd=ROOT)
            if p.returncode:
                break
            times.append(float(p.stdout.split()[-1]))
        if times:
            out[name] = min(times)
    return out


def summary(rows, names):
    by = {}
    for n in names:
        r = np.array([row[n]["seconds"] / row["ours"]["seconds"] for row in rows])
        by[n] = {"total_seconds": float(sum(row[n]["seconds"] for row in rows)),
                 "geomean_ratio_to_ours": float(np.exp(np.log(r).mean())),
                 "max_residual": float(max(row[n]["residual"] for row in rows))}
        big = [row for row in rows if row["unknowns"] >= 1000]
        if big:
            by[n]["seconds_systems_over_1000_unknowns"] = float(sum(row[n]["seconds"] for row in big))
    return by


def markdown(rows, by, cold_s, names):
    lines = ["# The fairing's sparse solver against CHOLMOD, SuperLU and libigl", "",
             f"{len(rows)} systems the fill factorised (its own Q_uu), factorised and solved "
             "(three right-hand sides) in one warm process, BLAS on one thread, fastest of the repeats.", "",
             "| solver | total s | s on systems ≥1000 unknowns | geomean time / ours | max residual | cold: load + one solve, s |",
             "|---|---|---|---|---|---|"]
    for n in names:
        b = by[n]
        lines.append(f"| {n} | {b['total_seconds']:.3f} | {b.get('seconds_systems_over_1000_unknowns', 0):.3f} "
                     f"| {b['geomean_ratio_to_ours']:.2f} | {b['max_residual']:.1e} | {cold_s.get(n, float('nan')):.3f} |")
    cases = {}
    for row in rows:
        c = cases.setdefault(row["case"], {"systems": 0, "unknowns": 0, **{n: 0.0 for n in names}})
        c["systems"] += 1
        c["unknowns"] = max(c["unknowns"], row["unknowns"])
        for n in names:
            c[n] += row[n]["seconds"]
    lines += ["", "Per case (seconds in the solver over all its systems; a fresh run adds the cold column once):", "",
              "| case | systems | largest | " + " | ".join(names) + " |", "|---|---|---|" + "---|" * len(names)]
    for name, c in cases.items():
        lines.append(f"| {name} | {c['systems']} | {c['unknowns']} | " + " | ".join(f"{c[n]:.3f}" for n in names) + " |")
    lines += ["", "Largest systems:", "", "| case | unknowns | nnz | " + " | ".join(names) + " |",
              "|---|---|---|" + "---|" * len(names)]
    for row in sorted(rows, key=lambda r: -r["unknowns"])[:12]:
        lines.append(f"| {row['case']} | {row['unknowns']} | {row['nnz']} | "
                     + " | ".join(f"{row[n]['seconds'] * 1e3:.1f} ms" for n in names) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    systems = collect()
    print(f"{len(systems)} systems collected, {max(Q.shape[0] for _, Q in systems)} unknowns at most")
    rows = time_systems(systems, args.repeat)
    names = [n for n in ("ours", "cholmod", "splu", "igl") if n in rows[0]]
    by = summary(rows, names)
    cold_s = cold()
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "solvers.json").write_text(json.dumps({"rows": rows, "summary": by, "cold_seconds": cold_s}, indent=1))
    md = markdown(rows, by, cold_s, names)
    (OUT / "solvers.md").write_text(md)
    print(md)


if __name__ == "__main__":
    main()
