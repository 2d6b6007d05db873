"""A stand-in terminal for the progress tests: a stream that says it is a
terminal, and what a terminal would show after a text was written to it."""

import io
import re


class Tty(io.StringIO):
    """A StringIO that answers yes to ``isatty()``."""

    def isatty(self):
        return True


def screen(text):
    """The lines a terminal shows after ``text`` (carriage returns, newlines
    and the erase-to-end-of-line escape), and the cursor's column.

    Parameters
    ----------
    text : str

    Returns
    -------
    lines : list of str
        Every line, trailing blanks removed; the last is the cursor's.
    column : int
        The cursor's column in the last line.
    """
    lines, line, col = [], [], 0
    for part in re.split(r"(\r|\n|\x1b\[K)", text):
        if part == "\r":
            col = 0
        elif part == "\n":
            lines.append("".join(line).rstrip())
            line, col = [], 0
        elif part == "\x1b[K":
            del line[col:]
        else:
            for ch in part:
                if col < len(line):
                    line[col] = ch
                else:
                    line.append(ch)
                col += 1
    lines.append("".join(line).rstrip())
    return lines, col


def at_empty_line(text):
    """True when, after ``text``, the cursor is at the start of an empty
    line: what is printed next starts at column 0 with nothing beside it."""
    lines, column = screen(text)
    return lines[-1] == "" and column == 0
