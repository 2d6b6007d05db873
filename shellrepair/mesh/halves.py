"""Run a kernel's two halves side by side: the whole-mesh kernels
(:mod:`~shellrepair.mesh.fastmesh`, :func:`shellrepair.mesh.topology_kernels.vertex_faces`)
split each step of a large mesh in two and run the halves on two threads,
the same arrays as one pass.

Imports nothing of the package, so the compiled kernels and the modules
that call them can both read it.
"""

from __future__ import annotations

import threading

__all__ = ["both", "in_turn"]


def both(fn, a, b):
    """``fn(*a)`` on a second thread and ``fn(*b)`` on this one; both results
    (a kernel's exception is raised here)."""
    box = {}

    def run():
        try:
            box["r"] = fn(*a)
        except BaseException as exc:   # raised again below, in the caller's thread
            box["e"] = exc

    t = threading.Thread(target=run, name="shellrepair-half")
    t.start()
    try:
        rb = fn(*b)
    finally:
        t.join()
    if "e" in box:
        raise box["e"]
    return box["r"], rb


def in_turn(fn, a, b):
    """:func:`both` on one thread: ``fn(*a)`` then ``fn(*b)``."""
    return fn(*a), fn(*b)
