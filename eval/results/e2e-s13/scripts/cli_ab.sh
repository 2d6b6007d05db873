#!/bin/bash
# $1 root, $2 ply
cd /tmp
s=$(date +%s.%N)
PYTHONPATH=$1 /work/main/.venv/bin/python -c "import sys; sys.path.insert(0, '$1'); import shellrepair; assert shellrepair.__file__.startswith('$1'); from shellrepair import cli; sys.exit(cli.main(['repair', '$2', '-o', '/tmp/s13/cli_out.ply', '--report', '/tmp/s13/cli_out.json']))" > /tmp/s13/cli_log.txt 2>&1
rc=$?
e=$(date +%s.%N)
echo "$(basename $1) rc=$rc $(echo "$e - $s" | bc) s  $(md5sum /tmp/s13/cli_out.ply | cut -c1-12)"
