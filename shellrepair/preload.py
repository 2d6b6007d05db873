"""Load the fill's code while a scan is read.

A command that reads a scan and then repairs it calls :func:`preload_fill`
first. A background thread then imports the fill's modules and makes the
first kernel call: it loads the kernels compiled ahead of time
(:mod:`shellrepair.compiled`, milliseconds), or, where they are not built,
sets up Numba (its import and compiler, 2-3 s on a 2-core machine, paid
by whichever kernel comes first), which then overlaps the reading, whose
large steps run without the GIL. Loading changes no output (the same
machine code either way; the work budget is counted, not timed), so a
repair that starts before the loading ends gives the same mesh.
"""

from __future__ import annotations

import threading

__all__ = ["preload_fill"]


def _load():
    import numpy as np

    from shellrepair import compiled, repair
    from shellrepair.mesh import common_kernels  # noqa: F401  (the fill's modules, imported here)

    if compiled.ENABLED:
        common_kernels.max_sq_distance(np.zeros((1, 3)))   # the compiled modules' loading (or Numba's set-up), with the first kernel the repair calls


def preload_fill():
    """Start importing the fill's modules and Numba's set-up in a
    background thread; returns the thread at once."""
    t = threading.Thread(target=_load, name="shellrepair-fill-kernels", daemon=True)
    t.start()
    return t
