"""NumPy versions of compiled kernels, kept as the kernels' test oracles.

Each function here computes, in plain NumPy (SciPy's sparse products for
one), what a kernel of a ``shellrepair/*_kernels.py`` module computes, by
the same operations in the same order, so that the tests can ask for
equality to the bit. This module imports no kernel module.

Two of them are also what the package runs where the kernels are not
loaded: :func:`loop_diameter` (hole detection's diameters) and
:func:`ring_sums` (the continuation arcs'). Other such oracles stay beside
their callers as public ``*_reference`` functions (for example
:func:`shellrepair.fill.refine.relax_reference` or
:func:`shellrepair.fill.intrinsic.flip_to_delaunay_reference`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["loop_diameter", "ring_sums"]


def loop_diameter(Q, chunk=2048):
    """Largest distance between two rows of ``Q``, in chunks of rows.

    The oracle of :func:`shellrepair.mesh.common_kernels.max_sq_distance` (its
    square root): each squared distance summed over the last axis as NumPy
    sums it, then the largest.

    Parameters
    ----------
    Q : (k,3) float64
    chunk : int
        Rows compared with all others at once.

    Returns
    -------
    float
        0.0 for fewer than two rows.
    """
    best = 0.0
    for i in range(0, len(Q), chunk):
        d = ((Q[i:i + chunk, None, :] - Q[None, :, :]) ** 2).sum(axis=2)
        best = max(best, float(d.max()))
    return float(np.sqrt(best))


def ring_sums(E, li, level, X, Nv):
    """Per rim vertex ``li[i]``: the sums of ``X`` and ``Nv`` over its
    neighbours at level 1, their count, and the same over the level-2
    neighbours of those.

    The oracle of :func:`shellrepair.fill.bridge_kernels.ring_sums`: the rows of
    ``R1 = A[li]`` and ``R2 = R1 A`` restricted to those levels, ``A`` the
    all-ones adjacency of the edges ``E``, as SciPy's sparse products (each
    row summed in column order from zero).

    Parameters
    ----------
    E : (e,2) int64
        Edges (repeats and self-loops allowed).
    li : (p,) int64
        The rim vertices (a vertex may be listed twice).
    level : (n,) int64
        Each vertex's ring: 0 on the rim, 1 and 2 the rings around it.
    X, Nv : (n,3) float64
        Positions and normals.

    Returns
    -------
    s1 : (p,3) float64, c1 : (p,) float64, n1 : (p,3) float64
    s2 : (p,3) float64, c2 : (p,) float64, n2 : (p,3) float64
    """
    import scipy.sparse as sp

    nv = len(level)
    A = sp.csr_matrix((np.ones(2 * len(E)), (np.concatenate([E[:, 0], E[:, 1]]), np.concatenate([E[:, 1], E[:, 0]]))),
                      shape=(nv, nv))
    A.data[:] = 1.0
    R1 = A[li].multiply((level == 1)[None]).tocsr()
    R1.eliminate_zeros()
    R2 = (R1 @ A).multiply((level == 2)[None]).tocsr()
    R2.eliminate_zeros()
    R2.data[:] = 1.0
    return R1 @ X, R1.sum(axis=1).A1, R1 @ Nv, R2 @ X, R2.sum(axis=1).A1, R2 @ Nv
