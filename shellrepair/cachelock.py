"""One writer at a time in Numba's on-disk cache, across processes.

Numba's cache (``cache=True``: an index file per kernel beside its machine
code files) has no lock: two processes that save the same kernel for
different argument types at the same moment both take the next free file
number, and the index one of them writes can name the machine code the
other wrote (numba/numba#10128 is this family of race). A later load then
runs code compiled for other types. A single process, as a repair is, never
races; the build's parallel warm-ups (:func:`shellrepair.warmup.warm_up`
with ``share``) and the tests' parallel workers (tests/conftest.py) can.

:func:`install` wraps the cache file's load and save in an exclusive
``flock`` on one lock file per cache folder, so a save's read of the index,
its choice of a file number, and both writes happen with no other process
loading or saving in that folder. It changes nothing else (the files are
the same); where ``fcntl`` or Numba's class is missing it does nothing.
"""

from __future__ import annotations

import functools
import os

LOCK_NAME = "shellrepair-numba-cache.lock"


def install():
    """Lock Numba's cache index updates across processes (idempotent).

    Returns
    -------
    installed : bool
        False where there is nothing to lock (no Numba, no ``fcntl``, or a
        Numba whose cache class has changed).
    """
    try:
        import fcntl

        from numba.core import caching
    except ImportError:
        return False
    cls = getattr(caching, "IndexDataCacheFile", None)
    if cls is None or not all(hasattr(cls, a) for a in ("save", "load")):
        return False
    if getattr(cls, "_shellrepair_locked", False):
        return True

    def locked(method):
        @functools.wraps(method)
        def wrapper(self, *args, **kwargs):
            folder = getattr(self, "_cache_path", None)
            if folder is None:
                return method(self, *args, **kwargs)
            try:
                os.makedirs(folder, exist_ok=True)
                fh = open(os.path.join(folder, LOCK_NAME), "a")
            except OSError:          # an unwritable cache folder: Numba copes, as without the lock
                return method(self, *args, **kwargs)
            with fh:
                fcntl.flock(fh, fcntl.LOCK_EX)
                return method(self, *args, **kwargs)
        return wrapper

    cls.save = locked(cls.save)
    cls.load = locked(cls.load)
    cls._shellrepair_locked = True
    return True
