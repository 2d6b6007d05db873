"""Progress: the callback the library reports to, and the bar the command line draws.

The bar (:class:`TerminalBar`, about a hundred lines) is what the command
line draws; tqdm would do the same for one more runtime dependency, and the
library itself draws nothing, so it is kept.

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
reports nothing. ``True`` is kept for older callers: it draws the bar below
on stderr when that is a terminal, as ``progress=True`` always did.

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
The command line (:mod:`shellrepair.cli`) is the one place that draws:
it passes :func:`terminal_bar` (``None`` with ``-q`` or when stderr is not a
terminal) as the callback. A tiny progress bar for long work, drawn on
stderr only when it is a terminal.

    with Progress("filling holes", total=len(units)) as bar:
        for u in units:
            ...
            bar.update()

draws, at most every ``min_interval`` seconds and once at the end::

    filling holes [##########..........]  120/240  50%  12.3 s

When stderr is not a terminal (a pipe, a log file, a test), nothing is
written at all, so logs and captured output stay clean. No dependency.
"""

from __future__ import annotations

import sys
import time
from typing import Callable, Optional, Union

__all__ = ["ProgressCallback", "ProgressArg", "as_callback", "terminal_bar", "TerminalBar", "Progress", "progress_enabled",
           "step", "end_line"]

#: The type of a progress callback: ``progress(label, done, total)``.
ProgressCallback = Callable[[str, int, int], None]
#: What a library function's ``progress`` argument accepts.
ProgressArg = Union[None, bool, ProgressCallback]


def as_callback(progress: Union[None, bool, ProgressCallback]) -> Optional[ProgressCallback]:
    """The callback a library function reports to, from its ``progress`` argument.

    Parameters
    ----------
    progress : None, bool or callable
        ``None`` / ``False``: nothing; a callable ``(label, done, total)``:
        itself; ``True`` (older callers): :func:`step`, the bar drawn on
        stderr when it is a terminal.

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
        return step
    if callable(progress):
        return progress
    raise TypeError(f"progress must be None, True, False or a callable (label, done, total), "
                    f"not {type(progress).__name__}")


class TerminalBar:
    """The drawn callback: a bar per label on stderr (:func:`step`).

    Calling it reports progress (the protocol above); :meth:`end` ends the
    bars' line so that a table or an error starts on a line of its own.
    """

    def __call__(self, label, done, total):
        step(label, done, total)

    def clear(self):
        """Wipe the bar's line, so that a line printed now starts at column 0
        (the next call draws the bar again, below it)."""
        global _open
        if not _open:
            return
        _open = False
        try:
            sys.stderr.write("\r" + CLEAR_EOL)
            sys.stderr.flush()
        except (OSError, ValueError):
            pass

    def end(self):
        """End the bars' line (:func:`end_line`)."""
        end_line()


def terminal_bar(quiet=False):
    """A :class:`TerminalBar` when stderr is a terminal and not ``quiet``, else None."""
    return None if quiet or not progress_enabled() else TerminalBar()


#: Seconds between two redraws; updates in between only count.
MIN_INTERVAL = 0.1
#: ANSI "erase to end of line": wipes what a longer earlier line left.
CLEAR_EOL = "\x1b[K"
#: Characters of the bar itself.
BAR_WIDTH = 24


def progress_enabled(stream=None):
    """True when ``stream`` (default ``sys.stderr``) is an interactive terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or replaced stream
        return False


class Progress:
    """Count/total progress of one long step, with a label and elapsed time.

    Parameters
    ----------
    label : str
        What is being done ("filling holes", "scans").
    total : int
        How many items; 0 or less draws a count without a bar.
    enabled : bool, optional
        Draw at all; default: stderr is a terminal (:func:`progress_enabled`).
    stream : file, optional
        Where to draw; default ``sys.stderr``.
    min_interval : float
        Seconds between redraws (throttling).
    clock : callable
        Time source, ``time.monotonic`` by default (tests pass their own).
    """

    def __init__(self, label, total, *, enabled=None, stream=None, min_interval=MIN_INTERVAL,
                 clock=time.monotonic):
        self.label = str(label)
        self.total = int(total)
        self.stream = sys.stderr if stream is None else stream
        self.enabled = progress_enabled(self.stream) if enabled is None else bool(enabled)
        self.min_interval = float(min_interval)
        self.clock = clock
        self.count = 0
        self.t0 = clock()
        self._last = None
        self.draws = 0

    def update(self, n=1, *, note="", force=False):
        """Count ``n`` more items done; redraw if enough time has passed
        (or ``force``, or the last item is done)."""
        self.count += int(n)
        if not self.enabled:
            return
        now = self.clock()
        done = self.total > 0 and self.count >= self.total
        if self._last is not None and now - self._last < self.min_interval and not (done or force):
            return
        self._draw(now, note)

    def clear(self):
        """Wipe the bar's line, so that other output can start at column 0;
        the next update draws it again."""
        if not self.enabled or self._last is None:
            return
        try:
            self.stream.write("\r" + CLEAR_EOL)
            self.stream.flush()
        except (OSError, ValueError):
            self.enabled = False

    def set(self, count, *, note=""):
        """Set the count to ``count`` (for callers that know i/n)."""
        self.update(int(count) - self.count, note=note)

    def line(self, now=None, note=""):
        """The text of the bar (without the carriage return)."""
        now = self.clock() if now is None else now
        el = now - self.t0
        if self.total > 0:
            f = min(max(self.count / self.total, 0.0), 1.0)
            fill = int(round(f * BAR_WIDTH))
            bar = "#" * fill + "." * (BAR_WIDTH - fill)
            w = len(str(self.total))
            s = f"{self.label} [{bar}] {self.count:>{w}}/{self.total} {100 * f:3.0f}%  {el:.1f} s"
        else:
            s = f"{self.label}: {self.count}  {el:.1f} s"
        return s + (f"  {note}" if note else "")

    def _draw(self, now, note=""):
        s = self.line(now, note)
        try:  # carriage return, the line, then clear what a longer earlier line left (ANSI EL)
            self.stream.write("\r" + s + CLEAR_EOL)
            self.stream.flush()
        except (OSError, ValueError):
            self.enabled = False
            return
        self._last = now
        self.draws += 1

    def close(self):
        """Draw the final state and end the line (only if anything was drawn)."""
        if not self.enabled:
            return
        if self._last is None or self.draws == 0 or self._last != self.clock():
            self._draw(self.clock())
        try:
            self.stream.write("\n")
            self.stream.flush()
        except (OSError, ValueError):
            pass
        self.enabled = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


# --------------------------------------------------------------------------
# the hook repair_mesh calls once per filled unit, and a label prefix
# --------------------------------------------------------------------------
_prefix = []
_current = None
_open = False  # a bar drawn by step() whose line nobody has ended yet


class prefix:
    """Context manager: prefix every bar's label while inside (``batch``
    puts the scan being repaired in front of ``filling holes``)."""

    def __init__(self, text):
        self.text = str(text)

    def __enter__(self):
        _prefix.append(self.text)
        return self

    def __exit__(self, *exc):
        _prefix.pop()
        return False


def full_label(label):
    """``label`` behind the active prefixes."""
    return ": ".join(_prefix + [label]) if _prefix else label


def step(label, i, n, *, stream=None):
    """Report item ``i`` of ``n`` of a loop that calls this once per item.

    A new bar starts when ``i <= 1`` or the label or total changes; at
    ``i == n`` the final state is drawn and the bar is dropped. The line is
    not ended here: the caller ends it (``repair_mesh`` prints the newline
    after its loop). Silent unless stderr is a terminal.
    """
    global _current, _open
    lab = full_label(label)
    b = _current
    if b is None or i <= 1 or b.total != n or b.label != lab:
        b = _current = Progress(lab, n, stream=stream)
    b.set(i)
    _open = _open or b.draws > 0
    if n > 0 and i >= n:
        _current = None


def end_line(stream=None):
    """End the line that :func:`step` bars were drawn on, if any was, so
    that what follows (a table, an error) starts on a line of its own."""
    global _current, _open
    _current = None
    if not _open:
        return
    _open = False
    try:
        (sys.stderr if stream is None else stream).write("\n")
    except (OSError, ValueError):
        pass
