"""Shared by the readers: tokens of the text formats, numbers, colours.

The text readers (ascii PLY, OBJ, OFF) split the whole body into tokens at
once with NumPy instead of line by line; :func:`parse_numbers` parses them
in one pass and only walks token by token to name the first bad one.
"""

from __future__ import annotations

import numpy as np

from shellrepair.errors import MeshError

__all__ = ["WS", "token_starts", "token_counts", "parse_numbers", "to_numbers", "colors_to_uint8"]


#: Bytes that separate tokens in the text formats (those ``bytes.split()`` splits on).
WS = np.zeros(256, bool)
WS[[9, 10, 11, 12, 13, 32]] = True


def token_starts(x):
    """Where each token of the bytes ``x`` (uint8 array) starts, as ``bytes.split()`` splits."""
    ws = x <= 32
    if np.count_nonzero(ws) != np.count_nonzero(x == 32) + np.count_nonzero((x - np.uint8(9)) <= 4):
        ws = WS[x]  # control bytes that do not separate tokens: look each byte up
    first = ~ws
    first[1:] &= ws[:-1]
    return first


def token_counts(text, starts=None):
    """Tokens on each line of ``text`` (bytes, lines ended by ``\\n``), as ``bytes.split()`` finds them.

    Parameters
    ----------
    text : bytes
    starts : (k,) int64 array, optional
        Where the tokens start (``np.flatnonzero(token_starts(x))``), if known.

    Returns
    -------
    counts : (text.count(b"\\n") + 1,) int64 array
    """
    x = np.frombuffer(text, np.uint8)
    at = np.concatenate([[0], np.flatnonzero(x == 10) + 1, [x.size]])
    if starts is None:
        starts = np.flatnonzero(token_starts(x)) if x.size else np.zeros(0, np.int64)
    return np.diff(np.searchsorted(starts, at)).astype(np.int64)


def parse_numbers(text, dtype, n, where):
    """The ``n`` whitespace-separated numbers of ``text`` (bytes) as a ``dtype`` array.

    Parsed in one pass when every token is one number; otherwise token by
    token, and the first bad token raises :class:`MeshError` with the message
    ``where(i, token)`` (``i`` counts tokens from 0). Returns an array of
    another length only when ``n`` is not the number of tokens.
    """
    try:
        vals = np.fromstring(text, dtype=dtype, sep=" ")
        if vals.size == n:
            return vals
    except ValueError:  # a token that is not a number
        pass
    return to_numbers(text.split(), dtype, where)


def to_numbers(tokens, dtype, where):
    """``tokens`` (list of bytes) as a ``dtype`` array; a bad token raises MeshError(``where(i, token)``)."""
    try:
        return np.array(tokens, dtype=dtype)
    except (ValueError, OverflowError):
        conv = float if np.dtype(dtype).kind == "f" else int
        for i, t in enumerate(tokens):
            try:
                v = conv(t)
                if conv is int and not -2**63 <= v < 2**63:
                    raise OverflowError
            except (ValueError, OverflowError):
                raise MeshError(where(i, t.decode("utf-8", errors="replace")[:40])) from None
        raise


def colors_to_uint8(C, notes, what, unit=None):
    """Vertex colours as uint8, whatever the file stored.

    Parameters
    ----------
    C : (n,k) array
        k = 3 (RGB) or 4 (RGBA), any numeric dtype.
    notes : list of str
        Gets one line per conversion that is not the identity.
    what : str
        Names the source in the notes (``"PLY"``, ``"OBJ"``, ``"OFF"``).
    unit : bool or None
        True: floats are in 0..1 (the PLY convention for float colours);
        None: floats are 0..1 when none exceeds 1, else 0..255.

    Returns
    -------
    colors : (n,k) uint8 array
        NaN or infinite channels become 0 (alpha 255), with a note.
    """
    C = np.asarray(C)
    if C.dtype == np.uint8:
        return C
    k = C.shape[1]
    X = C.astype(np.float64)
    bad = ~np.isfinite(X)
    if bad.any():
        X[bad] = 0.0
        notes.append(f"{what}: {int(bad.any(axis=1).sum())} vertex colours with NaN or infinite "
                     "channels: those channels set to 0 (alpha to 255)")
    if C.dtype.kind == "f":
        if unit or (unit is None and X.max(initial=0.0) <= 1.0):
            X = X * 255.0
            notes.append(f"{what}: vertex colours stored as floats 0..1 converted to 8 bits")
        else:
            notes.append(f"{what}: vertex colours stored as floats 0..255 rounded to 8 bits")
    elif C.dtype.itemsize > 1 and X.max(initial=0.0) > 255:
        X = X / 257.0  # 16-bit channels
        notes.append(f"{what}: 16-bit vertex colours reduced to 8 bits")
    X = np.rint(X)
    out_of_range = (X < 0) | (X > 255)
    if out_of_range.any():
        notes.append(f"{what}: {int(out_of_range.any(axis=1).sum())} vertex colours outside 0..255 clipped")
    out = np.clip(X, 0, 255).astype(np.uint8)
    if k == 4:
        out[bad[:, 3], 3] = 255
    return out
