#!/bin/bash
# usage: runpair.sh TAG SEEDA SEEDB VARIANTS...
tag=$1; a=$2; b=$3; shift 3
cd ${TREE:-/tmp/s44/X}
/work/main/.venv/bin/python /tmp/s44/exp/simexp.py $a 16 /tmp/s44/exp/$tag-$a.json "$@" > /tmp/s44/exp/$tag-$a.log 2>&1 &
/work/main/.venv/bin/python /tmp/s44/exp/simexp.py $b 16 /tmp/s44/exp/$tag-$b.json "$@" > /tmp/s44/exp/$tag-$b.log 2>&1 &
wait
