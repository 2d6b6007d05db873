#!/bin/bash
SETS=stress:1434622212:24,stress:2631639849:32,big:745285506:8,big:1614967854:12
PY=/work/main/.venv/bin/python
for r in 1 2; do
  PYTHONPATH=/tmp/s14/base $PY /tmp/s14/run_cases.py /tmp/s14/base $SETS /tmp/s14/ab_base_$r.json > /tmp/s14/ab_base_$r.log 2>&1
  PYTHONPATH=/work/main $PY /tmp/s14/run_cases.py /work/main $SETS /tmp/s14/ab_main_$r.json > /tmp/s14/ab_main_$r.log 2>&1
done
echo done > /tmp/s14/ab.done
