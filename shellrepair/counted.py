"""A process-wide setting held while any of several blocks is open.

Two fills in two threads of one caller may each hold a setting of the
whole process for their time (:func:`shellrepair.blas.one_thread_everywhere`,
the fill's short switch interval beside its helper thread). Their blocks
overlap, so the setting is made when the first block opens and put back
when the last one closes, in whatever thread: a :class:`CountedSetting`.
"""

from __future__ import annotations

import contextlib
import threading

__all__ = ["CountedSetting"]


class CountedSetting:
    """Calling it gives a context manager; the setting holds while any
    such block is open.

    Parameters
    ----------
    apply : callable
        ``apply()`` makes the setting and returns what it replaced; called
        when the first block opens.
    restore : callable
        ``restore(saved)`` puts back what ``apply`` returned; called when
        the last open block closes (also after an exception in it).
    """

    def __init__(self, apply, restore):
        self._apply = apply
        self._restore = restore
        self._lock = threading.Lock()
        self._open = 0
        self._saved = None

    @contextlib.contextmanager
    def __call__(self):
        with self._lock:
            if self._open == 0:
                self._saved = self._apply()
            self._open += 1
        try:
            yield
        finally:
            with self._lock:
                self._open -= 1
                if self._open == 0:
                    saved, self._saved = self._saved, None
                    self._restore(saved)
