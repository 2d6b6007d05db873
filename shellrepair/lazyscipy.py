"""SciPy's parts the package uses, imported on their first use.

``import scipy.sparse`` costs 0.2-0.4 s on this project's 2-core machine
(SciPy's array-API layer touches ``numpy.testing`` and ``numpy.f2py``;
``scipy.sparse.csgraph`` pulls ``scipy.sparse.linalg`` and ``scipy.linalg``,
whose decorators parse docstrings), ``scipy.spatial`` another 0.1-0.2 s
(it loads ``scipy.special``). A small repair uses none of them, so a module
names them through this one instead of importing SciPy at its top::

    from .lazyscipy import sparse as sp          # for ``import scipy.sparse as sp``
    from .lazyscipy import cKDTree               # for ``from scipy.spatial import cKDTree``

The first attribute read (``sp.csr_matrix``) or call (``cKDTree(P)``)
imports the SciPy module; every later one is an ordinary attribute read or
a call through one wrapper. The objects returned are SciPy's own, so the
results are the same to the bit.
"""

from __future__ import annotations

import importlib

__all__ = ["sparse", "sparse_linalg", "cKDTree", "connected_components", "breadth_first_order"]


class LazyModule:
    """Stands for the module ``name``: imports it on the first attribute
    read, then keeps each attribute read (a later read is a plain one)."""

    def __init__(self, name):
        self.__dict__["_name"] = name

    def __getattr__(self, attr):
        value = getattr(importlib.import_module(self._name), attr)
        self.__dict__[attr] = value
        return value

    def __repr__(self):
        return f"<{self._name}, imported on first use>"


#: ``scipy.sparse``
sparse = LazyModule("scipy.sparse")
#: ``scipy.sparse.linalg``
sparse_linalg = LazyModule("scipy.sparse.linalg")


def cKDTree(*args, **kwargs):
    """``scipy.spatial.cKDTree(*args, **kwargs)`` (imported on the first call)."""
    from scipy.spatial import cKDTree as tree

    return tree(*args, **kwargs)


def connected_components(*args, **kwargs):
    """``scipy.sparse.csgraph.connected_components`` (imported on the first call)."""
    from scipy.sparse.csgraph import connected_components as f

    return f(*args, **kwargs)


def breadth_first_order(*args, **kwargs):
    """``scipy.sparse.csgraph.breadth_first_order`` (imported on the first call)."""
    from scipy.sparse.csgraph import breadth_first_order as f

    return f(*args, **kwargs)
