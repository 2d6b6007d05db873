"""The connected pieces of an undirected graph, in NumPy.

:func:`connected_components` labels the nodes as
``scipy.sparse.csgraph.connected_components(A, directed=False)`` does for
the graph ``A`` with the edges given (each piece numbered by the order of
its lowest node: the piece of node 0 is 0, the piece of the lowest node not
in it is 1, and so on), without importing SciPy's sparse graphs: on a small
scan their import (``scipy.sparse.csgraph`` loads ``scipy.sparse.linalg``
and ``scipy.linalg``) costs more than the whole search. The labels are the
same integers, so every result built on them is the same
(``tests/test_components.py`` compares the two on random graphs).
"""

from __future__ import annotations

import numpy as np

__all__ = ["connected_components"]


def connected_components(n, a, b):
    """Pieces of the undirected graph on nodes ``0..n-1`` with edges ``(a[i], b[i])``.

    Each node starts as its own root; every round, the root of each edge's
    larger label is hooked under the smaller label, then every node's
    pointer is followed to its root (pointer jumping). A node's pointer only
    ever goes down and stays in its piece, so when no edge joins two labels
    each piece points at its lowest node. Every round joins each piece still
    split with another of its parts, so there are at most about log2(n)
    rounds.

    Parameters
    ----------
    n : int
        Number of nodes.
    a, b : (e,) int
        The edges' ends (self-loops and repeated edges allowed).

    Returns
    -------
    n_pieces : int
    labels : (n,) int32
        The piece of each node, numbered by the order of the pieces' lowest
        nodes (as SciPy numbers them).

    Examples
    --------
    >>> connected_components(5, np.array([3, 1]), np.array([4, 2]))
    (3, array([0, 1, 1, 2, 2], dtype=int32))
    """
    n = int(n)
    lab = np.arange(n, dtype=np.int64)
    a = np.asarray(a, np.int64).ravel()
    b = np.asarray(b, np.int64).ravel()
    while a.size:
        la, lb = lab[a], lab[b]
        split = la != lb
        if not split.any():
            break
        a, b, la, lb = a[split], b[split], la[split], lb[split]   # joined edges stay joined
        lo, hi = np.minimum(la, lb), np.maximum(la, lb)
        np.minimum.at(lab, hi, lo)       # hi is a root: it now points lower, into its piece
        while True:
            up = lab[lab]
            if np.array_equal(up, lab):
                break
            lab = up
    root = lab == np.arange(n)
    rank = np.cumsum(root, dtype=np.int64) - 1
    return int(root.sum()), rank[lab].astype(np.int32)
