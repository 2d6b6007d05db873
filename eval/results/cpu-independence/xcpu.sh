#!/bin/bash
# usage: xcpu.sh TREE LABEL PLY...
tree=$1; label=$2; shift 2
cd $tree
for f in "$@"; do
  b=$(basename $f .ply); line="$b"
  for v in 1 2 3; do
    case $v in
      1) e="OPENBLAS_CORETYPE=SkylakeX";;
      2) e="OPENBLAS_CORETYPE=Haswell NPY_DISABLE_CPU_FEATURES=X86_V4,AVX512_ICL,AVX512_SPR";;
      3) e="OPENBLAS_CORETYPE=Prescott NPY_DISABLE_CPU_FEATURES=X86_V3,X86_V4,AVX512_ICL,AVX512_SPR";;
    esac
    env $e /work/main/.venv/bin/python -m shellrepair.cli repair $f -o /tmp/s43/xcpu/$label-$b-$v.ply --report /tmp/s43/xcpu/$label-$b-$v.json -q 2>/tmp/s43/xcpu/$label-$b-$v.err
    line="$line $(sha256sum < /tmp/s43/xcpu/$label-$b-$v.ply | cut -c1-12)"
  done
  echo $line
done
