#!/bin/bash
# deprun.sh VARIANT ENV... : autoonly over the seeds
v=$1; shift
cd /tmp/s43/dep
R=/work/main/eval/results/order-test
for s in 882160276 283926182 640995685 955912095 705794754 302007265 569393493 708919061 604846971; do
  b=$(ls $R/rim-density/seed$s/regret-seed$s.json $R/regret-dd2f910/regret-seed$s.json 2>/dev/null | head -1)
  env "$@" /work/main/.venv/bin/python $R/auto-rerun-14913b1/autoonly.py $b $s /tmp/s43/dep-$v-$s.json 2>&1 | tail -1 | sed "s/^/$v $s /"
done
