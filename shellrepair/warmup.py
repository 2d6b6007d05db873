"""Compile (or load from the on-disk cache) every fill kernel on tiny inputs.

The kernel modules (``shellrepair/*_kernels.py``) are built ahead of time by the
install (``python -m shellrepair.aot build``); where that build fails, the
Makefile runs :func:`warm_up` instead, in two halves side by side
(``share=1`` and ``share=2``), so that no repair waits for Numba's JIT.
``python -m shellrepair.aot record`` watches :func:`warm_up` and a small
repair to list the argument types the ahead-of-time build compiles.

This module sits above the kernels and the modules whose kernels it calls
(:mod:`~shellrepair.fill.refine`, :mod:`~shellrepair.fill.triangulate`), so the
kernels themselves import none of them.
"""

from __future__ import annotations

import threading

import numpy as np

from shellrepair import compiled
from shellrepair.fill import (
    bridge_kernels,
    checks_kernels,
    fair_kernels,
    intrinsic_kernels,
    patch_kernels,
    probe_kernels,
    refine_kernels,
    triangulate_kernels,
)
from shellrepair.fill.refine import FLIP_EPS, angle_between, unfolded
from shellrepair.fill.triangulate import restricted_dp
from shellrepair.mesh import common_kernels, distance_kernels, intersect_kernels, topology_kernels
from shellrepair.mesh import index_kernels as context_kernels

__all__ = ["warm_up"]

_WARM = False
_WARM_LOCK = threading.Lock()


def warm_up(share=None):
    """Compile (or load from the on-disk cache) every kernel on tiny inputs.

    Called by ``make setup`` where the ahead-of-time build fails (the
    compile, once per machine), by ``python -m shellrepair.aot record``
    and by the benchmarks before they time a tool. A repair does not call
    it. With the ahead-of-time modules built, the calls here run those
    (nothing compiles). Returns whether the kernels are in use.

    ``share`` 1 or 2 compiles only that half of the kernels (about 55 and
    35 s of compiling on a fresh checkout): the build runs the two in
    parallel processes, then ``warm_up()`` finds all in the cache. No kernel
    is compiled for different types in the two halves, directly or inside
    another kernel (two processes that cache one kernel for different types
    at the same moment can leave its cache index naming the other's machine
    code), and a share takes :mod:`shellrepair.cachelock`'s lock too.
    """
    global _WARM
    if not compiled.ENABLED:
        return False
    if share is not None:
        from shellrepair import cachelock

        cachelock.install()
        (_warm_first, _warm_second)[int(share) - 1]()
        return True
    if _WARM:
        return True
    with _WARM_LOCK:   # a second caller (the background load, a fill) waits for the first
        if _WARM:
            return True
        _warm_first()
        _warm_second()
        _WARM = True
    return True


def _warm_first():
    """The first half of :func:`warm_up`: the region, index and fairing kernels."""
    T = np.array([[0, 1, 2], [2, 1, 3]], np.int64)
    order, start = topology_kernels.vertex_faces(T, 4)
    context_kernels.faces_in_boxes(np.zeros((4, 3)), T, np.zeros((1, 3)), np.ones((1, 3)))
    context_kernels.ring_faces(np.array([0], np.int64), 2, order, start, T, np.zeros(4, np.bool_), np.zeros(2, np.bool_))
    context_kernels.submesh(np.array([0, 1], np.int64), T, np.array([0, 1, 2], np.int64), np.array([[0, 2, 1], [0, 3, 2]], np.int64), np.full(4, -1, np.int64))
    triangulate_kernels.loop_cover(triangulate_kernels.inside_outline(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), T[:1]), np.ones(1), 3)
    patch_kernels.patch_corners(np.zeros((4, 3)), np.array([0, 1, 2], np.int64), np.zeros((1, 3)), T)
    context_kernels.rim_sigma(np.zeros((4, 3)), np.array([0, 1, 2], np.int64), np.ones(3), np.array([1.0, 0.0, 2.0]))
    L = np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
    intrinsic_kernels.intrinsic_flips(T.copy(), L, 4, 3, 1e-12)
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    context_kernels.rim_edges(np.array([0, 1, 3, 2], np.int64), E, np.ones(len(E)), np.zeros((2, 3)))
    intersect_kernels.box_pairs(np.zeros((2, 3)), np.ones((2, 3)))
    P = np.array([[0.0, 0, 0], [1, 2, 3], [0, 1, 0], [1, 1, 1]])
    lo2, h, vorder, vkey, ny = intersect_kernels.grid_sort(P, grow=0.5)
    intersect_kernels._faces_in_box(vkey, vorder, P, order, start, np.zeros(0, np.int64), lo2, h, ny, np.zeros(3), np.ones(3),
                  np.zeros(2, np.bool_))
    intersect_kernels.box_pairs(np.zeros((2, 3)), np.ones((2, 3)), np.zeros((1, 3)), np.ones((1, 3)))
    Tr = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    intersect_kernels.separated(Tr, np.array([[0, 1, 2]]), np.zeros(1, np.int64), Tr + 1.0, np.array([[3, 4, 5]]),
              np.zeros(1, np.int64), 1e-15, 1e-280)
    X = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]])
    refine_kernels.relax(X * [1.0, 1.0, 0.0] + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [-0.6, -0.6, 0]], T, np.ones(4, np.bool_),
          np.zeros((0, 2), np.int64), 5, None, angle_between, unfolded, FLIP_EPS)
    for order in (1, 2, 3):
        fair_kernels.fair_small(X, T, np.array([True, True, False, True]), order, 2, 1e-10, 1e-12, 100)
    # beside the fairing: these call kernels it calls too (_box_pairs, laplacian_rows) with other types
    intersect_kernels.patch_pairs(Tr + 0.25, np.array([[-1, 1, -2]]), np.array([0, 1], np.int64), X, T, np.zeros(3), 1e-15, 1e-15, 1e-280)
    ptr4, col4, val4 = intrinsic_kernels.laplacian_rows(T, np.zeros((0, 3)), 4, True)
    fair_kernels.energy_blocks(ptr4, col4, val4, np.ones(4), 3, np.array([2], np.int64), np.array([0, 1, 3], np.int64))


def _warm_second():
    """The second half of :func:`warm_up`: the crossing, band, order-test and triangulation kernels."""
    T = np.array([[0, 1, 2], [2, 1, 3]], np.int64)
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    Tr = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    X = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]])
    intersect_kernels.cross_status(Tr, np.array([[0, 1, 2]]), np.zeros(1, np.int64), Tr + 0.25, np.array([[3, 4, 5]]),
                 np.zeros(1, np.int64), 1e-15, 1e-15, 1e-280)
    intersect_kernels.projection_embeds(X[:, :2], T, 4, 1.0, 1e-9)
    refine_kernels.relax_round_parts(X, np.array([[0, 1, 1, 2, 0, 3, 0, 1]], np.int64))
    common_kernels.max_sq_distance(X)
    context_kernels.boxes_meeting(X[:2], X[2:], np.zeros(3), np.ones(3))
    intersect_kernels.outline_simple(X[:3, :2], 1e-12)
    checks_kernels.folds(X[T], T, X[T[:1]], T[:1] + 4, 0.5)
    patch_kernels.face_cross(np.array([1], np.int64), T, X)
    bridge_kernels.ring_sums(E, np.array([0], np.int64), np.array([0, 1, 1, 2], np.int64), X, X)
    _, Lb, _ = bridge_kernels.block_ids(T, np.array([2], np.int64), np.array([0, 1, 3], np.int64), np.array([3], np.int64), 4)
    bridge_kernels.block_ids(T, np.array([2], np.int64), np.array([0, 1, 3], np.int64), np.array([3], np.int64), 4, scratch=False)
    bridge_kernels.corner_normal_sums(Lb, T, X, 4)
    loops4 = np.array([0, 0, 1, 1], np.int64)
    bridge_kernels.arc_landings(X[:2], X[1:3], X[2:], np.ones(2), np.ones(2), np.ones(2), 4, 0.15, np.array([0, 1], np.int64), 2,
                 X, loops4, np.array([0, 1, 0, 1], np.int64), np.ones(2), np.array([0, 1], np.int64),
                 np.array([2, 2], np.int64), np.array([0, 1], np.int64), 2, rank_of=lambda P: np.arange(len(P)))
    refine_kernels.angle_parts(X[:2], X[2:])
    refine_kernels.unfolded(X[:1], X[1:2], X[2:3], X[3:])
    refine_kernels.split_test(X, T, np.ones(4), 1.5)
    vo, vs = topology_kernels.vertex_faces(T, 4)
    context_kernels.ring_walk(np.array([0], np.int64), 2, vo, vs, T, np.zeros(4, np.bool_), np.zeros(2, np.bool_))
    context_kernels.ring_walk_within(np.array([0], np.int64), 2, vo, vs, T, X, X[0], 1.0, np.zeros(4, np.bool_),
                                     np.zeros(2, np.bool_))
    distance_kernels.centroids(X, T)
    distance_kernels.nearest_triangle_distances(X[:2], X, T, np.zeros((2, 2), np.int64))
    context_kernels.rim_walk(np.array([0, 1, 3, 2], np.int64), *topology_kernels.vertex_faces(T, 4), T, X)
    restricted_dp(X, np.array([[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]], np.int64), np.eye(4, 3), {(0, 2)})
    for ax in (None, np.ones(3)):
        triangulate_kernels.liepa_tables(X, np.eye(4, 3), np.ones(4, np.bool_), np.zeros((4, 4), np.bool_), ax, 1e-12)
    triangulate_kernels.chord_rows(X, 1, np.zeros(0, np.int64))
    C, _ = triangulate_kernels.centred_area(X)
    S, raw = triangulate_kernels.outline_cross(C[:, :2], T, X)
    triangulate_kernels.cover_free(S, raw[:, 2], 4, np.array([3], np.int64))
    triangulate_kernels.loop_edges_present(triangulate_kernels.tet_faces(np.array([[3, 1, 0, 2]], np.int32), 4), 4)
    start, fpos, across, _ = probe_kernels.near_adjacency(T, 4)
    probe_kernels.placement(X, T, across, start, fpos, 1, X[1], 2.0, 0.5)
    probe_kernels.placement_statuses(X, T, across, start, fpos, np.array([1], np.int64), np.array([1], np.int64),
                                     2.0, 0.5)
    probe_kernels.within_distance(X, np.array([0, 1], np.int64), X[0], 1.0)
    probe_kernels.component_within(across, np.array([0, 1], np.int64), np.array([0], np.int64))
    probe_kernels.inside_polygon(X[:, 0], X[:, 1], X[:3, :2])
