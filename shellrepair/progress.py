"""Progress: the callback the library reports to, and the bar the command line draws.

The protocol
------------
Every long library call takes ``progress=None``: a callable, called as

    progress(label, done, total)

* ``label`` (str): what is being done, e.g. ``"loading bunny.ply"``,
  ``"finding holes"``, ``"filling holes"``, ``"writing out.ply"``;
* ``done`` (int): items of this label finished, ``0 <= done <= total``;
  ``0`` (when sent) announces the start, ``done == total`` the end;
* ``total`` (int): items of this label, ``>= 1``.

The calls come from the thread that called the library function, in order;
``done`` never goes down within one label. One call may start a new label
(a new loop) at any time. The library draws nothing, ends no line and
ignores what the callback returns; an exception the callback raises stops
the work and reaches the caller (a way to cancel). ``None`` (or ``False``)
reports nothing. ``True`` is kept for older callers: that call gets its own
:func:`terminal_bar` (nothing when stderr is not a terminal).

>>> seen = []
>>> from shellrepair.progress import as_callback
>>> report = as_callback(lambda label, done, total: seen.append((label, done, total)))
>>> report("loading a.ply", 0, 4); report("loading a.ply", 4, 4)
>>> seen
[('loading a.ply', 0, 4), ('loading a.ply', 4, 4)]
>>> as_callback(None) is None and as_callback(False) is None
True

The bar
-------
The command line (:mod:`shellrepair.cli`) is the one place that draws: it
makes one :func:`terminal_bar` per command (``None`` with ``-q`` or when
stderr is not a terminal) and passes it as the callback. The bar is tqdm's,
drawn on stderr, one label at a time on one line::

    filling holes [############............]  120/240  50%  12.3 s

redrawn at most every :data:`MIN_INTERVAL` seconds, and always at the end
of a label. The command line wipes the line (:meth:`TerminalBar.clear`)
before printing one of its own, and ends it (:func:`end_line`) before a
table or an error. The bar holds no state outside its own object.
"""

from __future__ import annotations

import sys
from typing import Callable, Optional, Union

__all__ = ["ProgressCallback", "ProgressArg", "as_callback", "terminal_bar", "TerminalBar", "progress_enabled",
           "end_line"]

#: The type of a progress callback: ``progress(label, done, total)``.
ProgressCallback = Callable[[str, int, int], None]
#: What a library function's ``progress`` argument accepts.
ProgressArg = Union[None, bool, ProgressCallback]

#: Seconds between two redraws; updates in between only count (tqdm's ``mininterval``).
MIN_INTERVAL = 0.1
#: Characters of the bar itself.
BAR_WIDTH = 24
#: What one bar shows: label, bar, count, percentage, seconds since the label started.
BAR_FORMAT = "{desc} [{bar:%d}] {n_fmt}/{total_fmt} {percentage:3.0f}%%  {elapsed_s:.1f} s" % BAR_WIDTH


def as_callback(progress: ProgressArg) -> Optional[ProgressCallback]:
    """The callback a library function reports to, from its ``progress`` argument.

    Parameters
    ----------
    progress : None, bool or callable
        ``None`` / ``False``: nothing; a callable ``(label, done, total)``:
        itself; ``True`` (older callers): a new :func:`terminal_bar`, drawn
        on stderr when it is a terminal (else a callback that does nothing).

    Returns
    -------
    callback : callable or None

    Raises
    ------
    TypeError
        For anything else (a number, a string).
    """
    if progress is None or progress is False:
        return None
    if progress is True:
        return terminal_bar() or _silent
    if callable(progress):
        return progress
    raise TypeError(f"progress must be None, True, False or a callable (label, done, total), "
                    f"not {type(progress).__name__}")


def progress_enabled(stream=None):
    """True when ``stream`` (default ``sys.stderr``) is an interactive terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or replaced stream
        return False


def terminal_bar(quiet=False):
    """A :class:`TerminalBar` on stderr when it is a terminal and not ``quiet``, else None.

    Parameters
    ----------
    quiet : bool
        The command line's ``-q``.

    Returns
    -------
    bar : TerminalBar or None
    """
    return None if quiet or not progress_enabled() else TerminalBar()


class TerminalBar:
    """A progress callback that tqdm draws: one bar per label, on one line.

    A new label (or a new total, or a count that goes down: a new loop)
    replaces the bar on the same line; :meth:`clear` wipes the line,
    :meth:`end` draws the last state and ends the line. A bar that is
    dropped without :meth:`end` wipes its line.

    Parameters
    ----------
    stream : file, optional
        Where to draw; default the ``sys.stderr`` of the moment the bar is made.
    """

    def __init__(self, stream=None):
        self.stream = sys.stderr if stream is None else stream
        self._bar = None

    def __call__(self, label, done, total):
        bar = self._bar
        if bar is None or bar.desc != label or bar.total != total or done < bar.n:
            self._drop()
            bar = self._bar = _tqdm()(total=total, initial=done, desc=label, file=self.stream, leave=False,
                                      ascii=".#", bar_format=BAR_FORMAT, mininterval=MIN_INTERVAL)
        else:
            bar.update(done - bar.n)
        if done >= total:
            bar.refresh()  # the end of a label is always drawn

    def clear(self):
        """Wipe the bar's line, so that a line printed now starts at column 0
        (the next call draws the bar again, below it)."""
        if self._bar is not None:
            self._bar.clear()

    def end(self):
        """Draw the last state and end the bar's line, if a bar is drawn, so
        that what follows (a table, an error) starts on a line of its own."""
        bar, self._bar = self._bar, None
        if bar is not None:
            bar.leave = True
            bar.close()

    def _drop(self):
        bar, self._bar = self._bar, None
        if bar is not None:
            bar.close()  # leave=False: wipes its line


def end_line(bar):
    """End the line of ``bar`` (a :class:`TerminalBar`; None: nothing)."""
    if bar is not None and hasattr(bar, "end"):
        bar.end()


def _silent(label, done, total):
    """The callback of ``progress=True`` when stderr is not a terminal."""


def _tqdm():
    """tqdm's bar, without its monitor thread (our redraws come with our calls)."""
    from tqdm import tqdm

    class Bar(tqdm):
        monitor_interval = 0

    return Bar
