# shellrepair: `make setup` then `make test`. See README.md.
PY      ?= .venv/bin/python
SCAN    ?= data/bunny_zipper.ply
OUT     ?= $(basename $(SCAN)).repaired.ply
REPORT  ?= $(basename $(SCAN)).report.json
DIR     ?= data
OUTDIR  ?= $(DIR)/repaired
JOBS    ?= 1
SYSLIBS  = libusb-1.0-0 libgomp1 libgl1

.PHONY: setup syslibs test holes repair render batch bench bench-scale bench-scale-profile table1 clean stress

setup: syslibs
	test -x $(PY) || python3 -m venv .venv
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'

# open3d's wheel needs libusb (and libgomp); install them from Debian if missing.
syslibs:
	@missing=""; for p in $(SYSLIBS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing system libraries:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO=sudo; fi; \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq $$missing; \
	fi

test:
	$(PY) -m pytest

holes:
	$(PY) -m shellrepair.cli holes $(SCAN)

repair:
	$(PY) -m shellrepair.cli repair $(SCAN) -o $(OUT) --report $(REPORT)

# every scan of a folder: make batch DIR=scans OUTDIR=scans/repaired JOBS=2
batch:
	$(PY) -m shellrepair.cli batch $(DIR) -o $(OUTDIR) --jobs $(JOBS)

render:
	test -f $(OUT) || $(MAKE) repair SCAN=$(SCAN)
	$(PY) -m shellrepair.cli render $(OUT) --before $(SCAN) --highlight-filled -o $(basename $(SCAN)).before_after.png

# accuracy and speed against the peers on the 19 cases, then the scale
# benchmark (about 7 minutes in all)
bench:
	$(PY) -m pip install -q -e '.[bench]' || echo "some peer tools did not install; the benchmark records them as missing"
	$(PY) eval/bench.py
	$(PY) eval/bench_scale.py

# the scale benchmark alone: time and peak memory of read / detect / fill /
# write at ~1M, ~4M, ~10M faces, and ours vs MeshLib and CGAL at 1M
bench-scale:
	$(PY) -m pip install -q -e '.[bench]' || echo "some peer tools did not install; the benchmark records them as missing"
	$(PY) eval/bench_scale.py

# where the time goes, per step, on the 1M and 4M cases (cProfile)
bench-scale-profile:
	$(PY) eval/bench_scale.py --sizes 1M,4M --profile --no-peers

table1:
	$(PY) eval/table1.py

clean:
	rm -rf .pytest_cache .hypothesis build *.egg-info data/*.repaired.ply data/*.report.json data/*.png data/repaired

# randomized stress: N cases drawn from SEED (seeds < 1000 for development,
# >= 1000 kept for validation), ours against CGAL and MeshLib when installed
N    ?= 12
SEED ?= 1000
stress:
	$(PY) -m pip install -q -e '.[bench]' || echo "some peer tools did not install; the stress suite records them as missing"
	$(PY) eval/stress.py --n $(N) --seed $(SEED)
