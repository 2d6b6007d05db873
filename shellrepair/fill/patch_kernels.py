"""Compiled kernels of a patch's checks (:mod:`shellrepair.fill.patch`, Numba).

* :func:`patch_corners`: a patch's triangle corners
  (:func:`shellrepair.fill.patch.corners`);
* :func:`face_cross`: faces' cross products, gathered and computed in one
  pass (:func:`shellrepair.fill.patch._meets_edge_on`; the bridge's corner
  normal sums call it too).

Each gives what its NumPy version gives, to the bit (tests/test_kernels.py).
How the kernels are compiled and switched off: :mod:`shellrepair.compiled`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["patch_corners", "face_cross"]

from shellrepair import compiled

njit = compiled.kernel


@njit(cache=True, nogil=True)
def _patch_corners(V, loop, P, T):
    k = loop.size
    t = T.shape[0]
    C = np.empty((t, 3, 3))
    ids = np.empty((t, 3), np.int64)
    for i in range(t):
        for c in range(3):
            j = T[i, c]
            if j < k:
                v = loop[j]
                ids[i, c] = v
                for d in range(3):
                    C[i, c, d] = V[v, d]
            else:
                ids[i, c] = k - 1 - j
                for d in range(3):
                    C[i, c, d] = P[j - k, d]
    return C, ids


def patch_corners(V, loop, P, T):
    """A patch's triangle corners and their ids (as
    :func:`shellrepair.fill.patch.corners`).

    Parameters
    ----------
    V : (n,3) float64
    loop : (k,) int64
    P : (q,3) float64
        The patch's new vertices.
    T : (t,3) int64
        Index i < k is ``loop[i]``, index k + j is ``P[j]``.

    Returns
    -------
    C : (t,3,3) float64
    ids : (t,3) int64
        The scan vertex, or ``-(1 + j)`` for new vertex j.
    """
    c = lambda x, d: np.ascontiguousarray(x, d)  # noqa: E731
    return _patch_corners(c(V, np.float64), c(loop, np.int64), c(P, np.float64).reshape(-1, 3), c(T, np.int64))


@njit(cache=True, nogil=True)
def _face_cross(faces, F, V):
    n = np.empty((faces.size, 3))
    for r in range(faces.size):
        f = faces[r]
        x0, x1, x2 = V[F[f, 0], 0], V[F[f, 0], 1], V[F[f, 0], 2]
        a0, a1, a2 = V[F[f, 1], 0] - x0, V[F[f, 1], 1] - x1, V[F[f, 1], 2] - x2
        b0, b1, b2 = V[F[f, 2], 0] - x0, V[F[f, 2], 1] - x1, V[F[f, 2], 2] - x2
        n[r, 0] = a1 * b2 - a2 * b1
        n[r, 1] = a2 * b0 - a0 * b2
        n[r, 2] = a0 * b1 - a1 * b0
    return n


def face_cross(faces, F, V):
    """``cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])`` of the
    faces ``T = F[faces]`` (:func:`shellrepair.mesh.geometry.cross`), in one pass.

    Parameters
    ----------
    faces : (m,) int64
    F : (f,3) int64
    V : (n,3) float64

    Returns
    -------
    n : (m,3) float64
        Twice the area-weighted face normals.
    """
    return _face_cross(np.ascontiguousarray(faces, np.int64), np.ascontiguousarray(F, np.int64),
                       np.ascontiguousarray(V, np.float64))
