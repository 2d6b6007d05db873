# shellrepair: `make repair` and `make test` set up what they need on first use. See README.md.
PY      ?= .venv/bin/python
# written when .venv holds the package; remade when pyproject.toml changes
INSTALLED = .venv/.shellrepair-installed
# written when .venv holds the test tools too (the test extra: pytest, pymeshlab, dask, ...)
TESTTOOLS = .venv/.shellrepair-installed-test
# written when the package is byte-compiled and the fill's kernels compiled
# ahead of time (all that holes / repair / batch --no-html run); remade when a
# module changes (after a git pull), so no run pays the compiler
STAMP    = .venv/.shellrepair-built
# written when the shading is built too: its Numba kernels (minutes; its
# rho_dt table ships with the package, shellrepair/appearance/reflectance/rho_dt_table.npz);
# what render, the HTML pictures of batch and repair --html, the tests and the
# benchmarks add to the fill's build
SHADING  = .venv/.shellrepair-built-shading
SOURCES  = $(wildcard shellrepair/*.py shellrepair/*/*.py shellrepair/*/*/*.py)
SCAN    ?= data/bunny_zipper.ply
OUT     ?= $(basename $(SCAN)).repaired.ply
REPORT  ?= $(basename $(SCAN)).report.json
DIR     ?= data
OUTDIR  ?= $(DIR)/repaired
JOBS    ?=
SCHEDULER ?=
SYSLIBS  = libusb-1.0-0 libgomp1 libgl1
# python3 -m venv needs ensurepip, which Debian ships apart
VENVLIB  = $(shell python3 -c 'import ensurepip' >/dev/null 2>&1 || python3 -c 'import sys; print("python%d.%d-venv" % sys.version_info[:2])')

.PHONY: setup syslibs browser test test-all holes repair render batch bench bench-scale bench-scale-profile bench-solvers table1 clean appearance stress regret docs

# `make setup` forces the install and both builds; every target that runs the
# package depends on the build stamp it needs (the fill's, or the shading's
# on top of it), so a fresh clone installs on its first command, a pulled
# change of a module is compiled before the run that needs it, and later
# commands skip both (make compares timestamps).
setup: syslibs
	rm -f $(INSTALLED) $(TESTTOOLS) $(STAMP) $(SHADING)
	$(MAKE) --no-print-directory $(SHADING) $(TESTTOOLS)

# The installed modules are byte-compiled once, on both cores, after pip
# (pip's own compile is one process): where PYTHONDONTWRITEBYTECODE is set
# (containers, CI) Python never writes a .pyc, and every command would parse
# NumPy and SciPy from source again: a cold `shellrepair repair` of a small
# scan took 1.7 s of wall time, 0.77 s with them compiled; a render 11.8 s
# against 8.1 s (measured 2026-12-03 on this 2-core machine). A module that
# does not compile still runs, from source.
BYTECOMPILE = $(PY) -m compileall -q -j 0 "$$($(PY) -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')" \
	>/dev/null || echo "(some installed modules were not byte-compiled: they run from source)"

$(INSTALLED): pyproject.toml
	@$(MAKE) --no-print-directory syslibs
	@echo "setting up .venv (first use, or pyproject.toml changed)"
	test -x $(PY) || python3 -m venv .venv
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q --no-compile -e .
	@echo "byte-compiling the installed modules (once; so no command parses NumPy and SciPy again)"
	$(BYTECOMPILE)
	touch $(INSTALLED)

# the tests' tools, which no repair needs (pymeshlab alone is ~280 MB)
$(TESTTOOLS): $(INSTALLED)
	@echo "installing the test tools (the test extra)"
	$(PY) -m pip install -q --no-compile -e '.[test]'
	$(BYTECOMPILE)
	touch $(TESTTOOLS)

$(STAMP): $(INSTALLED) $(SOURCES) shellrepair/aot_types.json
	@echo "building the package (first use, or a module changed since the last build)"
	@echo "byte-compiling the package (an editable install does not; else the first run writes its .pyc)"
	$(PY) -m compileall -q shellrepair
	@# the compiled modules are named by a hash of the kernels' sources: a change elsewhere
	@# (a docstring, the report) finds them built and costs nothing here
	@if $(PY) -c "from shellrepair import compiled; raise SystemExit(0 if compiled.aot_built() else 1)"; then \
	  echo "the fill's kernels are compiled already for these sources (shellrepair/_aot_*)"; else \
	echo "compiling the fill's kernels ahead of time (numba.pycc, two processes side by side;"; \
	echo "a run loads them in milliseconds and never imports Numba: shellrepair/compiled.py)"; \
	$(PY) -m shellrepair.aot build --part 0 & first=$$!; \
	$(PY) -m shellrepair.aot build --part 1; second=$$?; wait $$first && [ $$second = 0 ] || { \
	  echo "the ahead-of-time build failed: compiling the kernels with Numba's JIT instead (cached beside the package)"; \
	  $(PY) -c "from shellrepair import warmup; warmup.warm_up(share=1)" & first=$$!; \
	  $(PY) -c "from shellrepair import warmup; from shellrepair.fill import cholesky; warmup.warm_up(share=2); cholesky.warm_up()" \
	    || { wait $$first; exit 1; }; wait $$first; }; fi
	@echo "compiling the whole-mesh kernels (Numba, once, cached beside the package; used from 400k faces)"
	$(PY) -c "from shellrepair.mesh import fastmesh; fastmesh.warm_up()"
	touch $(STAMP)

# the shading, which no repair uses: only rendering does (render, the
# pictures of batch's and repair --html's pages, the tests, the benchmarks)
$(SHADING): $(STAMP) $(SOURCES)
	@echo "building the shading (first use, or a module changed since the last build)"
	@# Numba checks a cached kernel against its own file only: a kernel that inlines a helper of another
	@# kernel module would load stale machine code after that helper changed, so a change to any of the
	@# reflectance modules drops their whole cache
	@if [ -f $(SHADING) ] && [ -n "$$(find shellrepair/appearance/reflectance -name '*.py' -newer $(SHADING))" ]; then \
	  echo "a reflectance module changed: recompiling all its kernels"; rm -f shellrepair/appearance/reflectance/__pycache__/*.nb[ic]; fi
	@echo "compiling the shading kernels (Numba, once; cached in shellrepair/appearance/reflectance/__pycache__)"
	$(PY) -c "from shellrepair.appearance.shader import warm_up; warm_up()"
	touch $(SHADING)

# open3d's wheel needs libusb (and libgomp); install them from Debian if missing.
syslibs:
	@missing=""; for p in $(SYSLIBS) $(VENVLIB); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing system libraries:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO=sudo; fi; \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq $$missing; \
	fi

# the tests on every core (pytest-xdist; tests/conftest.py locks Numba's cache
# for the workers); one process: .venv/bin/python -m pytest -n 0.
# `make test` leaves out the tests marked slow (fresh processes, whole
# batches, a browser, the JIT fallback: about a tenth of them, half the
# time); `make test-all` runs every test, as CI does (.ci/run)
test: $(SHADING) $(TESTTOOLS)
	$(PY) -m pytest -n auto -m "not slow"

test-all: $(SHADING) $(TESTTOOLS) browser
	$(PY) -m pytest -n auto

# the HTML report's tests open its pages (and their 3D views: WebGL on
# SwiftShader) in Debian's headless chromium; installed here when apt can,
# else those tests skip and say why
browser:
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || { \
	  echo "installing chromium for the HTML report's browser test"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO=sudo; fi; \
	  ($$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq chromium >/dev/null) \
	    || echo "chromium could not be installed: the browser test will skip"; }

holes: $(STAMP)
	$(PY) -m shellrepair.cli holes $(SCAN)

# any repair option through ARGS: make repair SCAN=bust.ply ARGS="--base flat"
# (ARGS="--html PAGE.html" draws a picture: then the shading is built first)
repair: $(STAMP) $(if $(findstring --html,$(ARGS)),$(SHADING))
	$(PY) -m shellrepair.cli repair $(SCAN) -o $(OUT) --report $(REPORT) $(ARGS)

# every scan of a folder, on all cores (Dask worker processes; installed here
# when missing): make batch DIR=scans OUTDIR=scans/repaired [JOBS=2]
# [SCHEDULER=tcp://host:8786 for an existing Dask cluster]; its index.html
# has a picture of each scan, drawn by the shading (built first unless
# ARGS=--no-html)
batch: $(STAMP) $(if $(findstring --no-html,$(ARGS)),,$(SHADING))
	@$(PY) -c 'import distributed' 2>/dev/null || $(PY) -m pip install -q -e '.[cluster]' \
	  || echo "Dask did not install: scans run one at a time"
	$(PY) -m shellrepair.cli batch $(DIR) -o $(OUTDIR) $(if $(JOBS),--jobs $(JOBS)) $(if $(SCHEDULER),--scheduler $(SCHEDULER)) $(ARGS)

render: $(SHADING)
	test -f $(OUT) || $(MAKE) repair SCAN=$(SCAN)
	$(PY) -m shellrepair.cli render $(OUT) --before $(SCAN) --highlight-filled -o $(basename $(SCAN)).before_after.png

# accuracy and speed against the peers on the 19 cases, then the scale
# benchmark (about 7 minutes in all)
bench: $(SHADING)
	$(PY) -m pip install -q -e '.[bench]' || echo "some peer tools did not install; the benchmark records them as missing"
	$(PY) eval/bench.py
	$(PY) eval/bench_scale.py

# the scale benchmark alone: time and peak memory of read / detect / fill /
# write at ~1M, ~4M, ~10M faces, `shellrepair repair` end to end with its
# whole-mesh steps against memory speed, and ours vs MeshLib and CGAL at 1M
bench-scale: $(STAMP)
	$(PY) -m pip install -q -e '.[bench]' || echo "some peer tools did not install; the benchmark records them as missing"
	$(PY) eval/bench_scale.py

# where the time goes, per step, on the 1M and 4M cases (cProfile)
bench-scale-profile: $(STAMP)
	$(PY) eval/bench_scale.py --sizes 1M,4M --profile --no-peers

# the fairing's sparse Cholesky against CHOLMOD (scikit-sparse, built here
# against Debian's SuiteSparse 5, hence 0.4.15), SuperLU and libigl on the
# fill's own systems (eval/results/solvers/)
bench-solvers: $(STAMP)
	@dpkg -s libsuitesparse-dev >/dev/null 2>&1 || { if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO=sudo; fi; \
	  $$SUDO apt-get install -y -qq libsuitesparse-dev || echo "libsuitesparse-dev did not install: CHOLMOD is left out"; }
	$(PY) -m pip install -q "scikit-sparse==0.4.15" || echo "scikit-sparse did not build: CHOLMOD is left out"
	$(PY) eval/bench_solvers.py

table1: $(STAMP)
	$(PY) eval/table1.py

# the API reference from the docstrings (pdoc, the docs extra) into docs/api/
# (not committed); every module and subpackage, found by walking the package
# (its __all__ would hide the submodules from pdoc). The worked example is
# docs/example.md; tests/test_docs.py runs its code.
docs: $(STAMP)
	$(PY) -c "import pdoc" 2>/dev/null || $(PY) -m pip install -q -e '.[docs]'
	rm -rf docs/api
	$(PY) -m pdoc --docformat numpy -o docs/api shellrepair \
	  $$($(PY) -c "import pkgutil, shellrepair; print(' '.join(m.name for m in pkgutil.walk_packages(shellrepair.__path__, 'shellrepair.')))")
	@echo "wrote docs/api/index.html (start at docs/api/shellrepair.html)"

clean:
	rm -rf .pytest_cache .hypothesis build *.egg-info data/*.repaired.ply data/*.report.json data/*.png data/repaired

# appearance error of the filled regions: truth and each tool rendered with
# the same cameras, material and aging map; SSIM and CIEDE2000 over the
# filled pixels (eval/results/appearance.{json,md}, appearance_worst.png;
# about 10 minutes on 7 cases x 4 tools)
appearance: $(SHADING)
	$(PY) -m pip install -q -e '.[bench]' || echo "some peer tools did not install; the run records them as missing"
	$(PY) eval/appearance.py

# randomized stress: N cases drawn from SEED (seeds < 1000 for development,
# >= 1000 kept for validation), ours against CGAL and MeshLib when installed
N    ?= 12
SEED ?= 1000
stress: $(STAMP)
	$(PY) -m pip install -q -e '.[bench]' || echo "some peer tools did not install; the stress suite records them as missing"
	$(PY) eval/stress.py --n $(N) --seed $(SEED)

# the default's regret on the same cases: its RMS over the best of --order 1, 2, 3
# forced, per case, and what the choice costs (eval/results/regret-seed$(SEED).md)
regret: $(STAMP)
	$(PY) eval/regret.py --n $(N) --seed $(SEED)
