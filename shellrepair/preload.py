"""Load the fill's code while a scan is read.

A command that reads a scan and then repairs it calls :func:`preload_fill`
first. A background thread then imports the fill's modules and loads its
compiled kernels from the on-disk cache (:func:`shellrepair.kernels.warm_up`,
:func:`shellrepair.cholesky.warm_up`): about a second and a half of mostly
Python work, which then overlaps the reading, whose large steps run without
the GIL. A repair that starts before the loading ends waits for it (the
warm-ups hold a lock); nothing is loaded twice, and the output is the same.
"""

from __future__ import annotations

import threading

__all__ = ["preload_fill"]


def _load():
    from . import cholesky, kernels, repair  # noqa: F401  (the fill's modules, imported here)

    if kernels.ENABLED:
        kernels.warm_up()
        cholesky.warm_up()


def preload_fill():
    """Start importing the fill's modules and loading its compiled kernels
    in a background thread; returns the thread at once."""
    t = threading.Thread(target=_load, name="shellrepair-fill-kernels", daemon=True)
    t.start()
    return t
