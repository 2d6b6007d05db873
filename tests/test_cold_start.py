"""After ``make setup``, no repair waits on the Numba compiler (issue 14).

``make setup`` runs :func:`shellrepair.warmup.warm_up` and
:func:`shellrepair.mesh.fastmesh.warm_up`, which compile each kernel for the
argument types they pass and save the machine code (``cache=True``). A
later process loads a kernel from that cache only for those types: a call
with other types (an int32 array, a float where the warm-up gave an int,
None in place of an array) compiles at run time, seconds per kernel, in
the user's first run (and in no later one, which is why it is easy to
miss).

Here one interpreter does what ``make setup`` does (the warm-ups) and
records each kernel's compiled signatures; a second interpreter does what
``make repair`` does and records every compilation Numba starts (its
``numba:compile`` event fires on a cache miss only) and, at the end, every
kernel's signatures. The repair passes when nothing was compiled and no
kernel holds a signature the warm-ups did not make. The signature check
matters because the on-disk cache can hold more than the warm-ups put
there (the other tests call the kernels with their own inputs).

Cost: a few seconds when the cache is current; after an edit of a kernel's
file the first interpreter compiles that file's kernels once (about a
minute on two busy cores), as ``make setup`` would; they are cached for
every later run and for the other tests that load them.
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from conftest import shared_scan

pytest.importorskip("numba")

ROOT = Path(__file__).resolve().parents[1]
BUNNY = ROOT / "data" / "bunny_zipper.ply"

# The listener and the signature table, shared by both interpreters.
_COMMON = """
import json, sys
from numba.core import event as ev
from numba.core.registry import CPUDispatcher

compiled = []

class _Compiles(ev.Listener):
    def on_start(self, event):
        d = event.data["dispatcher"]
        compiled.append(f"{d.py_func.__module__}.{d.py_func.__qualname__}"
                        f"({', '.join(str(a) for a in event.data['args'])})")

    def on_end(self, event):
        pass

ev.register("numba:compile", _Compiles())

from shellrepair import warmup; from shellrepair.fill import cholesky; from shellrepair.mesh import fastmesh
from shellrepair import compiled as built


def signatures():
    # the fill's kernels: their JIT dispatchers, where a call fell back to the JIT
    table = {f"{m.rsplit('.', 1)[1]}.{k}": v.jit for m, ks in built.REGISTRY.items() for k, v in ks.items()
             if v.jit is not None}
    if fastmesh._K is not None:
        table.update({f"fastmesh.{k}": v for k, v in vars(fastmesh._K).items()})
    return {k: sorted(str(s) for s in d.signatures) for k, d in table.items()}
"""

_SETUP = _COMMON + """
assert warmup.warm_up() and cholesky.warm_up() and fastmesh.warm_up()
print(json.dumps({"signatures": signatures(), "compiled": compiled}))
"""

_REPAIR = _COMMON + """
import contextlib, io
from shellrepair import cli; from shellrepair.mesh import index as context
from shellrepair.repair import repair_mesh
from eval import shapes

out, log = sys.argv[1], []


def step(name, f):
    n = len(compiled)
    with contextlib.redirect_stdout(io.StringIO()):
        f()
    log.append([name, compiled[n:]])


def cli_repair(scan):
    def f():
        try:
            cli.main(["repair", scan, "-o", out + "/out.ply", "--report", out + "/out.json"])
        except SystemExit as e:
            assert not e.code, e.code
    return f


scans = json.loads(sys.argv[2])
for scan in scans:
    step("make repair " + scan, cli_repair(scan))
# the paths of a scan of millions of faces: whole-mesh kernels (fastmesh)
# and the local region of each hole (patch), here on small meshes
fastmesh.MIN_FACES = 0
context.LOCAL_MIN_FACES = 0
for scan in scans:
    step("large-scan paths " + scan, cli_repair(scan))
if sys.argv[3] == "shapes":
    V, F = shapes.bumpy_sphere(4)
    V, F = shapes.perforate_discs(V, F, n_holes=5, radius=0.25, seed=3)[:2]
    for opts in ({}, {"order": 1}, {"order": 3}, {"method": "seed"}, {"bridge": "always"}, {"smooth": 2}):
        step(f"sphere with 5 holes {opts}", lambda: repair_mesh((V, F), **opts))
    T, G = shapes.torus()
    T, G = shapes.perforate_discs(T, G, n_holes=2, radius=0.6, seed=1)[:2]
    step("torus, holes across the tube", lambda: repair_mesh((T, G)))
    V, F = shapes.grid(12, 12)
    step("open grid, border filled", lambda: repair_mesh((V, F), fill_borders=True))
print(json.dumps({"signatures": signatures(), "compiled": compiled, "log": log,
                  "aot": built.aot_loaded(), "jit": built.jit_loaded()}))
"""


def _run(code, *args, **extra):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_DISABLE_JIT", "SHELLREPAIR_NO_NUMBA", "SHELLREPAIR_NO_AOT")}
    env.update(extra)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    p = subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def warm():
    """What the JIT warm-ups compile (``make setup``'s build where the
    ahead-of-time one fails; ``fastmesh.warm_up`` always): kernel -> signatures."""
    if os.environ.get("SHELLREPAIR_NO_NUMBA"):
        pytest.skip("SHELLREPAIR_NO_NUMBA is set: the kernels are off")
    return _run(_SETUP, SHELLREPAIR_NO_AOT="1")["signatures"]


def _beyond_warm_up(run, warm):
    """Compilations during the repair (the package's kernels first, then
    Numba's own helpers they pulled in), and signatures the warm-ups did not
    make."""
    extra = {k: [s for s in sigs if s not in warm.get(k, [])] for k, sigs in run["signatures"].items()}
    compiled = sorted(run["compiled"], key=lambda c: not c.startswith("shellrepair."))
    return compiled, {k: v for k, v in extra.items() if v}


@pytest.mark.slow
def test_warm_up_compiles_each_kernel_for_some_types(warm):
    # every kernel a Python function calls has a signature after the warm-ups
    # (the helpers only other kernels call have none: their code is inside
    # their callers' cached machine code)
    called = {"topology_kernels._vf_count", "topology_kernels._vf_scatter", "topology_kernels._vf_buckets",
              "fair_kernels._fair_small", "refine_kernels._relax_apply", "intersect_kernels._box_pairs",
              "fastmesh.edge_count", "fastmesh.edge_scatter", "fastmesh.edge_bucket", "fastmesh.edge_list",
              "fastmesh.single", "fastmesh.pieces", "fastmesh.volumes", "fastmesh.moments"}
    assert called <= {k for k, v in warm.items() if v}
    assert all(v for k, v in warm.items() if k.startswith("fastmesh."))


@pytest.mark.slow
def test_make_repair_compiles_nothing_after_setup(warm, tmp_path):
    run = _run(_REPAIR, str(tmp_path), json.dumps([str(BUNNY)]), "shapes")
    compiled, extra = _beyond_warm_up(run, warm)
    assert [name for name, _ in run["log"]][:2] == [f"make repair {BUNNY}", f"large-scan paths {BUNNY}"]
    assert compiled == [], f"compiled at run time: {compiled} (steps: {run['log']})"
    assert extra == {}, f"signatures the warm-ups do not compile: {extra}"
    # where the ahead-of-time kernels are built, no call fell back to the JIT
    # (shellrepair/aot_types.json covers every type these repairs pass)
    assert run["jit"] is not run["aot"], ("aot", run["aot"], "jit", run["jit"])


@pytest.mark.parametrize("name", ["real_rangescan_dragon_000.ply", "real_bunny_pymeshfix_decimated.ply"])
@pytest.mark.slow
def test_real_scans_compile_nothing_after_setup(warm, tmp_path, name):
    # an open sheet with islands and pinched holes; a dirty mesh with
    # non-manifold edges: the cleaning and border paths of other scans
    # (each as a small scan, then through the large-scan paths)
    scan = str(shared_scan(name))
    run = _run(_REPAIR, str(tmp_path), json.dumps([scan]), "scans only")
    compiled, extra = _beyond_warm_up(run, warm)
    assert compiled == [], f"compiled at run time: {compiled}"
    assert extra == {}, f"signatures the warm-ups do not compile: {extra}"
    assert run["jit"] is not run["aot"], ("aot", run["aot"], "jit", run["jit"])


_NEEDS_MAKE = pytest.mark.skipif(
    not (ROOT / "Makefile").exists() or subprocess.run(["which", "make"], capture_output=True).returncode,
    reason="needs make and the checkout's Makefile")
#: The build steps: the fill's (stamp .venv/.shellrepair-built), then the
#: shading's (.venv/.shellrepair-built-shading), which no repair uses.
_FILL_STEPS = ("compileall", "shellrepair.aot build --part 0", "shellrepair.aot build --part 1",
               "warmup.warm_up(share=1)", "warmup.warm_up(share=2)", "cholesky.warm_up()", "fastmesh.warm_up()")
_SHADING_STEPS = ("from shellrepair.appearance.shader import warm_up",)
#: The rho_dt table ships with the package (shellrepair/appearance/reflectance/rho_dt_table.npz): no build step makes it.
_NEVER_BUILT = "rho_dt_table"


def _plan(module, *goal):
    # after a git pull that changes a module (here: make told it is new, by
    # -W, so no file is touched), what `make GOAL` would run
    plan = subprocess.run(["make", "-n", "-W", module, *goal], cwd=ROOT, capture_output=True, text=True,
                          timeout=60)
    assert plan.returncode == 0, plan.stderr
    return plan.stdout.splitlines()


@_NEEDS_MAKE
@pytest.mark.parametrize("module", ["shellrepair/fill/refine_kernels.py", "shellrepair/mesh/fastmesh.py",
                                    "shellrepair/appearance/reflectance/common_kernels.py", "shellrepair/repair.py"])
@pytest.mark.parametrize("goal, run", [(("repair",), "shellrepair.cli repair"),
                                       (("holes",), "shellrepair.cli holes"),
                                       (("batch", "ARGS=--no-html"), "shellrepair.cli batch")])
@pytest.mark.slow
def test_a_changed_module_is_built_before_the_next_run(module, goal, run):
    # `make repair` first remakes the fill's build stamp, whose recipe
    # byte-compiles the package and runs the fill's warm-ups, and builds
    # nothing of the shading (the rho_dt table, its kernels: minutes on a
    # fresh clone, and no repair uses them)
    stamp = ".venv/.shellrepair-built"
    lines = _plan(module, *goal)
    assert f"touch {stamp}" in lines
    build = lines[:lines.index(f"touch {stamp}")]
    for step in _FILL_STEPS:
        assert any(step in x for x in build), f"{step} missing from the build: {build}"
    for step in _SHADING_STEPS:
        assert not any(step in x for x in lines), f"{step} in the plan of make {' '.join(goal)}: {lines}"
    assert any(run in x for x in lines[lines.index(f"touch {stamp}"):])


@_NEEDS_MAKE
@pytest.mark.parametrize("module", ["shellrepair/mesh/index_kernels.py", "shellrepair/appearance/reflectance/common_kernels.py"])
@pytest.mark.parametrize("goal, run", [(("render",), "shellrepair.cli render"), (("test",), "-m pytest"),
                                       (("batch",), "shellrepair.cli batch"),
                                       (("repair", "ARGS=--html x.html"), "shellrepair.cli repair")])
@pytest.mark.slow
def test_what_draws_builds_the_shading_after_the_fill(module, goal, run):
    # render, the pictures of batch's and repair --html's pages, and the
    # tests use the shading: the fill's build, then the shading's, then the run
    lines = _plan(module, *goal)
    fill, shading = "touch .venv/.shellrepair-built", "touch .venv/.shellrepair-built-shading"
    assert fill in lines and shading in lines and lines.index(fill) < lines.index(shading)
    for step in _FILL_STEPS:
        assert any(step in x for x in lines[:lines.index(fill)]), f"{step} missing from the fill's build: {lines}"
    for step in _SHADING_STEPS:
        assert any(step in x for x in lines[lines.index(fill):lines.index(shading)]), \
            f"{step} missing from the shading's build: {lines}"
    assert not any(_NEVER_BUILT in x for x in lines), f"a build step makes the shipped table: {lines}"
    assert any(run in x for x in lines[lines.index(shading):])


_NO_SHADING = """
import json, sys
from pathlib import Path
from shellrepair import cli

scan, out = sys.argv[1], Path(sys.argv[2])
(out / "in").mkdir()
(out / "in" / "scan.ply").write_bytes(Path(scan).read_bytes())
for args in (["holes", scan], ["repair", scan, "-o", str(out / "r.ply"), "--report", str(out / "r.json")],
             ["batch", str(out / "in"), "-o", str(out / "batch"), "--no-html", "--jobs", "1"]):
    try:
        code = cli.main(args + ["-q"])
    except SystemExit as e:
        code = e.code
    assert not code, (args, code)
print(json.dumps(sorted(m for m in sys.modules if m.startswith("shellrepair"))))
"""


@pytest.mark.slow
def test_a_repair_uses_nothing_of_the_shading(tmp_path):
    # what `make repair` (and holes, batch --no-html) leave unbuilt must not
    # be needed: the run imports no module of the shading and so neither
    # builds the rho_dt table (nothing is written to the cache folder) nor
    # compiles a shading kernel
    cache = tmp_path / "cache"
    cache.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_DISABLE_JIT", "SHELLREPAIR_NO_NUMBA")}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env["SHELLREPAIR_CACHE_DIR"] = str(cache)
    p = subprocess.run([sys.executable, "-c", _NO_SHADING, str(BUNNY), str(tmp_path)], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    loaded = json.loads(p.stdout.strip().splitlines()[-1])
    assert "shellrepair.repair" in loaded
    drawing = [m for m in loaded if (m + ".").split(".")[1] in ("reflectance", "shading", "shader", "materials", "render",
                                                        "aging", "htmlreport")]
    assert drawing == [], f"a repair imported the shading: {drawing}"
    assert list(cache.iterdir()) == []
