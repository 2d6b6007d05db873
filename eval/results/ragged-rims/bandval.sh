#!/bin/bash
# usage: bandval.sh RAGGED TAG ; runs the three seeds' band cases, two at a time
rag=$1; tag=$2
run() { RAGGED_CASES=$rag /work/main/.venv/bin/python /tmp/s45/exp/simexp_r.py $1 $2 /tmp/s45/exp/$tag-$1.json BAND_ROUGH=1 BAND_ROUGH=2 > /tmp/s45/exp/$tag-$1.log 2>&1; }
run 581494271 2,8,14,20,26,32,38,44 &
run 490954791 5,11,17,23,29,35,41,47
wait
run 946901298 0,6,12,18,24,30,36,42
