"""Shared fixtures: synthetic meshes and the real scans in ../shared/data."""

from pathlib import Path

import numpy as np
import pytest

from eval import shapes
from shellrepair import cachelock

# `make test` runs the tests in parallel processes (pytest-xdist), which
# compile kernels for the types the tests pass into one on-disk cache: one
# process at a time reads and writes it (see shellrepair.cachelock)
cachelock.install()

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def shared_scan(name):
    """Path of a real scan in ../shared/data, or skip the test saying why."""
    p = SHARED / name
    if not p.exists():
        pytest.skip(f"real scan {name} not available: ../shared/data is only present in the project's CI")
    return p


def auto_and_forced_rms(case, order):
    """A stress case (:func:`eval.stress.stress_case`) repaired with the
    defaults and with ``order`` forced: (the default's RMS, the forced
    RMS, in per mille of the truth's diagonal, and the default's report)."""
    from eval import stress
    from shellrepair import Mesh
    from shellrepair.repair import repair_mesh

    facts = stress.input_facts(case)
    M = Mesh(V=case.V, F=case.F)
    R, rep = repair_mesh(M)
    Rf, _ = repair_mesh(M, order=order)
    return (stress.measure(case, facts, R.V, R.F)["rms_permille"],
            stress.measure(case, facts, Rf.V, Rf.F)["rms_permille"], rep)


@pytest.fixture
def sphere():
    return shapes.icosphere(3)


@pytest.fixture
def two_pinched_holes():
    """A 6x6 grid with two cells removed that touch at one corner vertex."""
    V, F = shapes.grid(6, 6)
    ny = 6
    cell_faces = lambda i, j: [i * 5 + j, 25 + i * 5 + j]  # both triangles of cell (i, j)
    remove = np.zeros(len(F), bool)
    remove[cell_faces(2, 2) + cell_faces(3, 3)] = True
    return V, F[~remove], (3 * ny + 3)


#: The shapes eval.stress draws from when ../shared is there: a stress case
#: built with this list is the same case with or without ../shared.
STRESS_SHAPES = ["torus-0.15", "torus-0.3", "torus-0.5", "torus-0.7", "genus2", "dumbbell", "star", "bumpy",
                 "nefertiti", "armadillo", "cheburashka", "rocker", "fandisk"]
