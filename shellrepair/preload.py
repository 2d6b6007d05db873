"""Load the fill's code while a scan is read.

A command that reads a scan and then repairs it calls :func:`preload_fill`
first. A background thread then imports the fill's modules and makes
Numba's first call (its compiler's set-up, some 0.4 s once per process,
paid by whichever kernel comes first), which then overlaps the reading,
whose large steps run without the GIL. The kernels themselves load from
the on-disk cache when first called, so a repair loads only those it uses
(before, every kernel was loaded up front: 0.5 s on a small scan). Loading
changes no output (the same machine code either way; the work budget is
counted, not timed), so a repair that starts before the loading ends gives
the same mesh.
"""

from __future__ import annotations

import threading

__all__ = ["preload_fill"]


def _load():
    import numpy as np

    from . import kernels, repair  # noqa: F401  (the fill's modules, imported here)

    if kernels.ENABLED:
        kernels.max_sq_distance(np.zeros((1, 3)))   # Numba's set-up, with the first kernel the repair calls


def preload_fill():
    """Start importing the fill's modules and Numba's set-up in a
    background thread; returns the thread at once."""
    t = threading.Thread(target=_load, name="shellrepair-fill-kernels", daemon=True)
    t.start()
    return t
