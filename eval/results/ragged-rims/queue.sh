#!/bin/bash
# usage: queue.sh TAG RAGGED "SEEDS" VARIANTS... : two at a time
tag=$1; rag=$2; seeds=$3; shift 3
cd /tmp/s45/X
printf "%s\n" $seeds | xargs -P 2 -I{} sh -c "RAGGED_CASES=$rag /work/main/.venv/bin/python /tmp/s45/exp/simexp_r.py {} 16 /tmp/s45/exp/$tag-{}.json $* > /tmp/s45/exp/$tag-{}.log 2>&1"
