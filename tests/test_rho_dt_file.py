"""The rho_dt table shipped with the package: read, not built; the values its rule gives."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from shellrepair.appearance import shading as sh
from shellrepair.appearance.reflectance import albedo
from shellrepair.appearance.reflectance.table import write_table

ROOT = Path(__file__).resolve().parents[1]


def shipped():
    with np.load(albedo.SHIPPED_TABLE) as z:
        return albedo.decode_table(z)


def test_the_shipped_file_is_small_and_made_for_the_current_parameters():
    # a changed _TABLE_* constant without `python -m shellrepair.appearance.reflectance.table` fails here
    assert os.path.getsize(albedo.SHIPPED_TABLE) < 1_000_000
    table = shipped()
    assert table is not None, "the shipped rho_dt table was made for other parameters: remake it"
    assert np.array_equal(table.values, sh.rho_dt_table().values)


def test_a_fresh_process_reads_the_table_and_builds_nothing(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    env = dict(os.environ, SHELLREPAIR_CACHE_DIR=str(cache),
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    code = ("from shellrepair.appearance.shading import rho_dt_table, diffuse_transmittance;"
            "print(rho_dt_table().values.shape, float(diffuse_transmittance(0.5, 0.3, 1.5)))")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.split(")")[0] + ")" == str(shipped().values.shape)
    assert list(cache.iterdir()) == []          # nothing built, nothing cached


def test_the_shipped_values_lie_below_the_rule_and_within_the_stated_error_of_the_converged_integral():
    """At 60 nodes drawn from the part of the grid where the stated error
    holds (incidence up to 89 deg, m in [0.02, 1], eta in [1.1, 2.5], as
    test_rho_dt_table_within_stated_error_of_quadrature): at most the
    table's own rule (a lower envelope) and within RHO_DT_MAX_ERROR of a
    finer quadrature."""
    T = shipped()
    rng = np.random.default_rng(3)
    eta_nodes = np.sqrt(1.0 + T.kappa * np.abs(T.kappa))
    pick = [np.flatnonzero(ok) for ok in (T.u ** 2 >= np.cos(np.radians(89.0)),
                                          (T.log_m >= np.log(0.02)) & (T.log_m <= 0.0),
                                          (eta_nodes >= 1.1) & (eta_nodes <= 2.5))]
    i, j, k = (rng.choice(p, 60) for p in pick)
    cos, m, eta = T.u[i] ** 2, np.exp(T.log_m[j]), eta_nodes[k]
    got = T.values[i, j, k]
    rule = np.array([1.0 - sh.rule_albedo(c[None], mm[None], np.array([e]))[0, 0]
                     for c, mm, e in zip(cos, m, eta)])
    converged = 1.0 - sh.specular_albedo(cos, m, eta, n_t=48, n_phi=80)
    assert np.all(got <= rule)
    assert np.max(np.abs(got - converged)) <= sh.RHO_DT_MAX_ERROR


def test_encoding_rounds_down_by_less_than_its_step():
    T = sh.rho_dt_table()
    values = np.random.default_rng(5).random(T.values.shape)
    values[0, 0, 0], values[1, 0, 0] = 0.0, 1.0
    back = albedo.decode_table(albedo.encode_table(albedo.RhoDtTable(T.u, T.log_m, T.kappa, values)))
    step = 2.0 ** -albedo.SHIPPED_BITS
    assert np.all(back.values <= values) and np.all(values - back.values < step)
    assert back.values[0, 0, 0] == 0.0 and back.values[1, 0, 0] == 1.0


def test_a_file_for_other_parameters_is_not_read():
    arrays = dict(albedo.encode_table(sh.rho_dt_table()))
    arrays["key"] = np.array("(5, 2.0, 65, 49, 81)")
    assert albedo.decode_table(arrays) is None
    arrays = albedo.encode_table(sh.rho_dt_table())
    arrays["d2"] = arrays["d2"][:-1]
    assert albedo.decode_table(arrays) is None


@pytest.mark.slow
def test_remaking_the_table_gives_the_shipped_values(tmp_path):
    # `python -m shellrepair.appearance.reflectance.table` (about 40 s of CPU)
    made = write_table(tmp_path / "rho_dt_table.npz")
    with np.load(tmp_path / "rho_dt_table.npz") as z:
        again = albedo.decode_table(z)
    assert np.array_equal(made.values, shipped().values)
    assert np.array_equal(again.values, made.values)
