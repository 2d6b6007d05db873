"""Two hole loops that share vertices: one band pinched there, split into discs.

:func:`split_pinched` replaces such a pair of loops of a
:class:`~shellrepair.holes.loops.HoleScan` by the loops of the parts of the band
between the shared vertices (:func:`pinched_parts`).
"""

from __future__ import annotations

import numpy as np

from shellrepair.holes.loops import loop_stats
from shellrepair.mesh.topology import face_pieces

__all__ = ["split_pinched", "pinched_parts"]


def pinched_parts(A, B):
    """The loops bounding the parts of one band pinched where loops ``A``
    and ``B`` (vertex arrays in boundary half-edge order) share vertices,
    or None when they do not share at least two in opposite cyclic orders.

    Between consecutive shared vertices ``p`` and ``q`` (in A's order) the
    missing region is bounded by A from ``p`` to ``q`` and by B from ``q``
    back to ``p``: both run with the scan on their left, so the part lies
    on their right like a hole's.

    Parameters
    ----------
    A, B : (ka,), (kb,) int64
        The two loops' vertices, each in boundary half-edge order.

    Returns
    -------
    parts : list of (k,) int64, or None
        Each part's loop; together they use every edge of ``A`` and ``B``
        once.
    """
    A, B = np.asarray(A, np.int64), np.asarray(B, np.int64)
    shared = np.intersect1d(A, B)
    if shared.size < 2:
        return None
    ia = np.sort(np.flatnonzero(np.isin(A, shared)))
    pa = A[ia]                                   # shared vertices in A's order
    posb = {int(v): i for i, v in enumerate(B.tolist())}
    jb = np.array([posb[int(v)] for v in pa])
    m = len(pa)
    # B must meet them in the reverse cyclic order
    steps = (jb - np.roll(jb, -1)) % len(B)
    if steps.sum() != len(B):
        return None
    parts = []
    for k in range(m):
        i0, i1 = ia[k], ia[(k + 1) % m]
        seg_a = A[np.arange(i0, i0 + ((i1 - i0) % len(A) or len(A))) % len(A)]       # p .. before q
        j1, j0 = jb[(k + 1) % m], jb[k]
        seg_b = B[np.arange(j1, j1 + ((j0 - j1) % len(B) or len(B))) % len(B)]       # q .. before p
        part = np.concatenate([seg_a, seg_b])
        if len(part) < 3 or np.unique(part).size != len(part):
            return None
        parts.append(part)
    if sum(len(p) for p in parts) != len(A) + len(B):
        return None
    return parts


def split_pinched(V, F, topo, scan, pieces=None):
    """Two ``hole`` loops that share vertices bound one band pinched there:
    the band is as many discs as the loops share vertices, each bounded by
    a stretch of each loop between two shared vertices. Those discs replace
    the two loops as holes (their ``kind`` becomes ``'split'``); they keep
    the loops' measurements of the piece and get ids after the scan's.

    Not when a part would bound scan all round: two holes that touch at
    two vertices with a lens of scan between them give a part that is the
    lens's whole boundary (filling it would close the lens into a bubble),
    so a part whose scan side (the pieces left of its edges) has no other
    boundary edge leaves the two loops as they are.

    Parameters
    ----------
    V : (n,3) float64
    F : (m,3) int64
    topo : EdgeTopology
    scan : HoleScan
    pieces : (int, (m,) int64), optional
        :func:`shellrepair.mesh.topology.face_pieces` of ``topo``.

    Returns
    -------
    scan : HoleScan
        A new one when a pair was split, else ``scan`` itself.
    splits : list of (int, int, list of int)
        The two loop ids and the ids of the parts that replace them.
    """
    from dataclasses import replace

    holes = [L for L in scan.loops if L.kind == "hole"]
    owner = {}
    for L in holes:
        for v in L.vertices.tolist():
            owner.setdefault(v, []).append(L.id)
    touching = sorted({tuple(sorted(o)) for o in owner.values() if len(o) == 2})
    loops = list(scan.loops)
    used, splits = set(), []
    if not touching:
        return scan, []
    n_piece, fpiece = face_pieces(topo, len(F)) if pieces is None else pieces
    bhe = topo.boundary_he
    bface = bhe // 3
    bd_count = np.bincount(fpiece[bface], minlength=n_piece)     # boundary edges per piece
    he_face = dict(zip(map(tuple, topo.ends(bhe).tolist()), bface.tolist()))   # not the whole mesh's he

    def bounds_scan_all_round(part):
        ps = {int(fpiece[he_face[(int(u), int(v))]]) for u, v in zip(part.tolist(), np.roll(part, -1).tolist())}
        return int(bd_count[sorted(ps)].sum()) == len(part)

    for a, b in touching:
        if a in used or b in used:
            continue
        parts = pinched_parts(loops[a].vertices, loops[b].vertices)
        if parts is None or any(bounds_scan_all_round(p) for p in parts):
            continue
        used.update((a, b))
        ids = []
        for part in parts:
            st = loop_stats(V, part)
            i = len(loops)
            loops.append(replace(loops[a], id=i, vertices=part, edges=int(len(part)), perimeter=st["perimeter"],
                                 mean_edge=st["mean_edge"], area=st["area"], diameter=st["diameter"],
                                 planarity=st["planarity"],
                                 reason=f"part of loops {a} and {b} between two of the {len(parts)} vertices "
                                        f"they share (a band pinched there)"))
            ids.append(i)
        for j in (a, b):
            loops[j] = replace(loops[j], kind="split", reason=f"split into loops {ids[0]}-{ids[-1]} "
                                                              f"at the vertices it shares with loop {a + b - j}")
        splits.append((a, b, ids))
    if not splits:
        return scan, []
    return replace(scan, loops=loops), splits
