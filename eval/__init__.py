"""Benchmark of shellrepair against a known true surface and against peer tools.

Not imported by the library. ``make bench`` runs :mod:`eval.bench`;
``make table1`` runs :mod:`eval.table1`. The tests import the pieces
(``from eval import cases, metrics``) after putting the repository root on
``sys.path``.

Modules
-------
cases    closed ground truths and seeded perforations (discs, scanner occlusion,
         many tiny holes, hard cases)
metrics  what a reviewer measures on a filled mesh against the ground truth
peers    one fill function per tool (ours and the peers), same signature
worker   runs a fill function in a child process with a timeout and records
         seconds and peak memory
bench    the whole run: cases x tools -> JSON, markdown table, plot
plot     speed-versus-error picture (matplotlib when installed, else Pillow)
table1   the paper's Table 1 on an occlusion-perforated statue scan
"""
