"""Append accepted patches to the scan (step 5): originals untouched.

:class:`Accepted` keeps the patches accepted so far so that a later patch
can be checked against them; :func:`_merge` appends their vertices and faces
after the scan's own (original indices and values bit-identical), flags them
``filled`` and interpolates vertex properties harmonically from the rim.
"""

from __future__ import annotations

import numpy as np

from shellrepair import compiled
from shellrepair.fill.patch import corners as corners_of
from shellrepair.lazyscipy import cKDTree
from shellrepair.mesh import intersect_kernels
from shellrepair.mesh.geometry import bounding_spheres, bounds, triangle_boxes
from shellrepair.mesh.intersect import _pairs_cross, ball_pairs, pair_intersections
from shellrepair.mesh.io import Mesh


def edges_of(T):
    """Every triangle's three edges, each as (low, high).

    Parameters
    ----------
    T : (m, 3) int64 triangles

    Returns
    -------
    (3m, 2) int64: the triangles' first edges, then their second and third ones, each sorted.
    """
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    return np.sort(E, axis=1)


def scan_edges(patch):
    """Edges the patch creates between scan vertices, as (a, b) with a < b
    (in :func:`edges_of`'s order: the triangles' first edges, then their
    second and third ones).

    Parameters
    ----------
    patch : Patch
        Its ``loop`` (k,) (the rim's scan vertices) and ``T`` (m,3), whose
        indices below k are the rim's.

    Returns
    -------
    list of (int, int)
        The scan vertex pairs, one per triangle edge with both ends on the
        rim, repeats kept.
    """
    k = len(patch.loop)
    T = np.asarray(patch.T)
    A, B = T.T, T[:, [1, 2, 0]].T    # row e: every triangle's edge e, so the mask reads edge by edge
    m = (A < k) & (B < k)            # both corners at loop (scan) vertices
    x, y = patch.loop[A[m]], patch.loop[B[m]]
    return list(zip(np.minimum(x, y).tolist(), np.maximum(x, y).tolist()))


class Accepted:
    """Patches accepted so far, with their corners and boxes cached.

    ``items`` holds ``(patch, C, oid)`` per accepted patch; the per-triangle
    spheres, tree and boxes a later patch's check reads are built the first
    time a patch's box meets this one's (most patches are never near
    another). Made empty; :meth:`add` accepts a patch, :meth:`conflict`
    says whether a new one crosses those accepted.
    """

    def __init__(self):
        self.items = []
        self._near = []    # per item: (c, r, tree, lo, hi) once built, else None
        self._boxes = []   # per item: its triangles' boxes (lo, hi) once built, else None
        self._own = []     # per item: its scan edges once listed, else None
        self._last = None  # (patch, its scan edges) of the last conflict check
        self.crossed = None  # after place() refused a patch: the hole whose accepted patch it crosses
        self.lo = np.zeros((0, 3))
        self.hi = np.zeros((0, 3))
        self.edges = set()

    def add(self, patch, C, ids):
        oid = np.where(ids < 0, ids - 10 ** 12 * (len(self.items) + 1), ids)  # new vertices differ per patch
        self.items.append((patch, C, oid))
        self._near.append(None)
        self._boxes.append(None)
        self._own.append(None)
        lo, hi = bounds(C.reshape(-1, 3))
        self.lo = np.vstack([self.lo, lo])
        self.hi = np.vstack([self.hi, hi])
        self.edges.update(self._edges(patch))

    def _edges(self, patch):
        """:func:`scan_edges` of ``patch``, taken from the last conflict check when it was this patch's."""
        if self._last is not None and self._last[0] is patch:
            return self._last[1]
        return scan_edges(patch)

    def _item_edges(self, j):
        """Item ``j``'s scan edges, listed once."""
        if self._own[j] is None:
            self._own[j] = set(scan_edges(self.items[j][0]))
        return self._own[j]

    def _item_boxes(self, j):
        """Item ``j``'s triangles' boxes (lo, hi), built once."""
        if self._boxes[j] is None:
            C = self.items[j][1]
            self._boxes[j] = triangle_boxes(C)
        return self._boxes[j]

    def _spheres(self, j):
        """Item ``j``'s triangle spheres, their tree and the triangles' boxes."""
        if self._near[j] is None:
            C = self.items[j][1]
            c, r = bounding_spheres(C)
            self._near[j] = (c, r, cKDTree(c), C.min(axis=1), C.max(axis=1))
        return self._near[j]

    def conflict(self, ctx, patch, skip=None):
        """Why the patch clashes with an accepted one, or None (and the
        patch's corners); ``self.clash`` is then the clashing item's index
        (None for an edge clash). ``skip``: an item left out of the check
        (the one the patch would replace)."""
        self.clash = None
        own = self._item_edges(skip) if skip is not None else ()
        mine = scan_edges(patch)
        self._last = (patch, mine)
        if any(e in self.edges and e not in own for e in mine):
            return "an earlier patch already created an edge this patch needs", None
        C, ids = corners_of(ctx, patch)
        if self.items:
            lo, hi = bounds(C.reshape(-1, 3))
            near = np.flatnonzero(np.all((self.lo <= hi) & (lo <= self.hi), axis=1))
            if near.size:
                lo1, hi1 = triangle_boxes(C)
                finite = compiled.ENABLED and bool(np.isfinite(C).all())
                if not compiled.ENABLED:
                    c1, r1 = bounding_spheres(C)
            for j in near:
                if j == skip:
                    continue
                other, D, oid = self.items[j]
                # triangles that cross have overlapping boxes: only those get the exact tests
                if compiled.ENABLED:
                    lo2, hi2 = self._item_boxes(j)
                    # the boxes directly (a grid, intersect_kernels.box_pairs): the spheres'
                    # reach is the largest triangle's, so a patch with a few long
                    # triangles made every nearby patch's query return thousands
                    sel = np.flatnonzero(np.all((lo2 <= hi) & (lo <= hi2), axis=1))   # within this patch's box
                    ai, bi = intersect_kernels.box_pairs(lo1, hi1, lo2[sel], hi2[sel])
                    bi = sel[bi]
                else:
                    c2, r2, tree, lo2, hi2 = self._spheres(j)
                    ai, bi = ball_pairs(tree, c1, r1 + r2.max())
                    box = np.all((lo1[ai] <= hi2[bi]) & (lo2[bi] <= hi1[ai]), axis=1)
                    ai, bi = ai[box], bi[box]
                if ai.size and (_pairs_cross(C, ids, ai, D, oid, bi) if finite and np.isfinite(D).all()
                                else pair_intersections(C[ai], ids[ai], D[bi], oid[bi])).any():
                    self.clash = int(j)
                    return f"patch would cross the patch of hole {other.hole_id}", None
        return None, (C, ids)

    def replace(self, j, patch, C, ids):
        """Put ``patch`` (the same hole, the same scan edges) in item ``j``'s place."""
        self._set(j, (patch, C, np.where(ids < 0, ids - 10 ** 12 * (j + 1), ids)))

    def exchange(self, j, patch, C, ids):
        """Put ``patch`` in item ``j``'s place where it joins other loops than
        the item's (a tube in place of one of its loops' caps): the scan edges
        the item created go, the patch's come."""
        self.edges.difference_update(scan_edges(self.items[j][0]))
        self.edges.update(scan_edges(patch))
        self.replace(j, patch, C, ids)

    def restore(self, j, item):
        """Put back ``item`` (as :attr:`items` held it) in item ``j``'s place
        after a :meth:`replace` that was not kept."""
        self._set(j, item)

    def _set(self, j, item):
        """Item ``j`` becomes ``item`` (patch, corners, ids); its box follows."""
        self.items[j] = item
        self._near[j] = None
        self._boxes[j] = None
        self._own[j] = None
        self.lo[j], self.hi[j] = bounds(item[1].reshape(-1, 3))

    def place(self, ctx, patch):
        """Accept ``patch`` if it clashes with no accepted patch; where it
        does and an order-3 patch of ``--order auto`` is involved, its
        order-2 fill (``Patch.fallback``) is tried in its place: first this
        patch's, then the clashing earlier one's (kept only if this patch,
        or its own fallback, then fits).

        Returns
        -------
        placed : Patch or None
            The patch accepted for this hole (``patch`` or its fallback).
        reason : str
            Why none fitted ('' when one did).
        swapped : Patch or None
            The earlier hole's order-2 patch that replaced its order-3 one.

        After a refusal, ``self.crossed`` is the hole whose accepted patch
        this one crosses (None when it was refused for another reason).
        """
        tries = [patch] + ([patch.fallback] if patch.fallback is not None else [])
        self.crossed = None
        first = None
        for p in tries:
            why, corners = self.conflict(ctx, p)
            if why is None:
                self.add(p, *corners)
                return p, "", None
            first = first or (why, self.clash)
        why, j = first
        self.crossed = None if j is None else int(self.items[j][0].hole_id)
        if j is None or self.items[j][0].fallback is None:
            return None, why, None
        old = self.items[j]
        alt = old[0].fallback
        why_alt, corners_alt = self.conflict(ctx, alt, skip=j)
        if why_alt is not None:
            return None, why, None
        self.replace(j, alt, *corners_alt)
        for p in tries:
            why2, corners = self.conflict(ctx, p)
            if why2 is None:
                self.add(p, *corners)
                return p, "", alt
        self._set(j, old)          # neither fits: the earlier hole keeps its order 3
        return None, why, None


def _merge(mesh, V, F, patches):
    """Append patches; originals unchanged, additions flagged."""
    n = len(V)
    newP, newF, newC = [], [], []
    props = {k: [] for k in mesh.vertex_props}
    base = n
    for p in patches:
        newP.append(p.P)
        newF.append(p.global_faces(base))
        if mesh.vertex_colors is not None:
            newC.append(p.colors if p.colors is not None else
                        np.zeros((len(p.P), mesh.vertex_colors.shape[1]), np.uint8))
        for name in props:
            arr = np.asarray(mesh.vertex_props[name])
            props[name].append(p.props.get(name, np.zeros(len(p.P), arr.dtype)))
        base += len(p.P)
    q = base - n
    V2 = np.vstack([V] + newP) if newP else V.copy()
    F2 = np.vstack([F] + newF) if newF else F.copy()
    vf = np.zeros(n + q, bool)
    vf[n:] = True
    if mesh.vertex_filled is not None:
        vf[:n] = mesh.vertex_filled
    ff = np.zeros(len(F2), bool)
    ff[len(F):] = True
    if mesh.face_filled is not None:
        ff[:len(F)] = mesh.face_filled
    colors = None if mesh.vertex_colors is None else np.vstack([mesh.vertex_colors] + newC).astype(np.uint8)
    return Mesh(V=V2, F=F2.astype(np.int64, copy=False), vertex_colors=colors, vertex_filled=vf, face_filled=ff,
                vertex_props={k: np.concatenate([np.asarray(mesh.vertex_props[k])] + v) for k, v in props.items()},
                vertex_dtype=mesh.vertex_dtype, path=mesh.path, notes=list(mesh.notes),
                F_out=getattr(mesh, "F_out", None), joins=getattr(mesh, "joins", None),
                fixes=dict(getattr(mesh, "fixes", {})), comments=list(getattr(mesh, "comments", [])),
                texture=getattr(mesh, "texture", None))


def crossings_after_merge(ctx, patches):
    """The check of the merged output, once, against the scan and all patches.

    Every patch was checked when it was built (against the scan) and when it
    was accepted (against the patches accepted before it). This check runs
    once more on what is about to be written, so that a crossing no earlier
    step saw (a stage's bug, a patch swapped in later) is found and its patch
    left open rather than written: each patch's triangles against the scan
    (exact predicates, :func:`~shellrepair.mesh.intersect.patch_vs_index_many`),
    and all patches' triangles against each other and themselves
    (:func:`~shellrepair.mesh.intersect.crossing_pairs`; corners that are the
    same vertex may touch).

    Parameters
    ----------
    ctx : ScanContext
        The scan's index.
    patches : list of Patch
        The accepted patches, in the order they were accepted.

    Returns
    -------
    crossed : dict
        ``{patch position: why}`` for every patch that crosses something:
        ``"the scan"``, ``"itself"`` or ``"the patch of hole N"`` (a pair of
        patches names the later one, which is left open).
    """
    from shellrepair.mesh.intersect import crossing_pairs, patch_vs_index_many

    crossed = {}
    if not patches:
        return crossed
    corners = [corners_of(ctx, p) for p in patches]
    for k, bad in enumerate(patch_vs_index_many(corners, ctx.index)):
        if len(bad):
            crossed[k] = "the scan"
    Cs, Is, owner, off = [], [], [], 0
    for k, (p, (C, ids)) in enumerate(zip(patches, corners)):
        Cs.append(C)
        Is.append(np.where(ids < 0, ids - off, ids))     # new vertices: ids of their own across patches
        owner.append(np.full(len(C), k, np.int64))
        off += len(p.P)
    C, ids, owner = np.concatenate(Cs), np.concatenate(Is), np.concatenate(owner)
    for i, j in crossing_pairs(C - ctx.index.origin, ids).tolist():
        a, b = sorted((int(owner[i]), int(owner[j])))
        why = "itself" if a == b else f"the patch of hole {patches[a].hole_id}"
        crossed.setdefault(b, why)
    return crossed
