"""Which way is up in a scan: inferred once from the scan as read, and
used by every picture of it (the camera's up, where the aging's rain comes
from).

The rule, in order (the first that applies decides):

1. **The base.** A boundary loop (hole or border) is a base when its rim
   is planar (RMS distance to its plane at most :data:`BASE_PLANARITY` of
   its diameter) and wide (diameter at least :data:`BASE_MIN_SIZE` of the
   scan's bounding-box diagonal), the scan's walls stand across its plane
   (the faces along the rim, area-weighted, meet the plane at
   :data:`BASE_WALL_DEGREES` or more: a neck or a plinth cut, not a hole in
   a statue's side, whose rim lies along the plane), and the scan lies on
   one side of the plane (at most :data:`BASE_BELOW` of the vertices more
   than :data:`BASE_TOLERANCE` of the diagonal below it) and stands away from
   it (the farthest vertex at least :data:`BASE_MIN_HEIGHT` of the diagonal
   above it). Up is the plane's normal, towards the scan. With several, the
   loop of the largest area (then the lowest id) decides. (An open vessel
   looks the same: it stands on its mouth, and needs ``--up``.)
2. **The longest axis.** Where the scan is clearly longer along one
   coordinate axis (the area-weighted spread of its faces along it at least
   :data:`ELONGATION` times that along the next), up is that axis, positive
   (files are rarely stored upside down): a statue lying along x stands up
   again. The coordinate axes, not the principal axes: scans are stored
   aligned with their axes, and the first principal axis of a
   bunny-shaped scan is its body's diagonal, never its up.
3. **The file's y axis**, the usual convention of scanners' files.

An axis within :data:`SNAP_DEGREES` of a coordinate axis is snapped to it;
any other is rounded to three decimals, so the axis the report records and
the pictures use is the one ``--up X,Y,Z`` gives back.

    up = infer_up(mesh.V, mesh.F)   # {"axis": [0.0, 0.0, 1.0], "name": "z", "rule": "base", "how": ...}
"""

from __future__ import annotations

import numpy as np

from shellrepair.errors import MeshError
from shellrepair.mesh.geometry import cross

__all__ = ["infer_up", "mesh_up", "scan_up", "given_up", "parse_up", "up_text", "BASE_PLANARITY", "BASE_MIN_SIZE", "BASE_WALL_DEGREES", "BASE_BELOW",
           "BASE_TOLERANCE", "BASE_MIN_HEIGHT", "ELONGATION", "SNAP_DEGREES", "BLOCK"]

#: A base's rim: RMS distance to its best-fit plane over its diameter, at most.
BASE_PLANARITY = 0.03
#: A base's rim diameter over the scan's bounding-box diagonal, at least.
BASE_MIN_SIZE = 0.1
#: The scan's walls along a base's rim meet its plane at this angle (degrees) or more,
#: area-weighted mean of the rim faces' |cos| to the plane's normal at most cos(90 - this).
BASE_WALL_DEGREES = 45.0
#: Share of the scan's vertices that may lie below a base's plane.
BASE_BELOW = 0.02
#: How far below the plane (over the diagonal) a vertex counts as below.
BASE_TOLERANCE = 0.02
#: The scan's farthest vertex above a base's plane, over the diagonal, at least.
BASE_MIN_HEIGHT = 0.2
#: Spread along the longest coordinate axis over that along the next, at least.
ELONGATION = 1.5
#: An inferred axis this close (degrees) to a coordinate axis becomes it.
SNAP_DEGREES = 10.0

_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def up_text(axis):
    """The ``--up`` argument that gives ``axis`` back: ``x``, ``-z`` or ``0.5,0.866,0``."""
    a = [float(x) for x in axis]
    for name, e in _AXES.items():
        if a == list(e):
            return name
        if a == [-x for x in e]:
            return "-" + name
    return ",".join(f"{x:.10g}" for x in a)


def parse_up(text):
    """An ``--up`` value as a vector: an axis name (``y``, ``-z``) or ``X,Y,Z``.

    Parameters
    ----------
    text : str

    Returns
    -------
    axis : tuple of 3 float
        As given (not normalised: the cameras normalise it).

    Raises
    ------
    MeshError
        For anything else, or the zero vector.
    """
    t = str(text).strip().lower()
    if t.lstrip("-") in _AXES and t.count("-") <= 1:
        e = _AXES[t.lstrip("-")]
        return tuple(-x for x in e) if t.startswith("-") else e
    try:
        a = tuple(float(x) for x in t.split(","))
    except ValueError:
        a = ()
    if len(a) != 3 or not all(np.isfinite(a)) or not any(a):
        raise MeshError(f"--up must be auto, an axis (x, y, z, -x, -y, -z) or a vector X,Y,Z, not {text!r}")
    return a


def given_up(text):
    """The record of an up axis given on the command line (``--up``),
    as :func:`infer_up` records an inferred one."""
    a = parse_up(text)
    return {"axis": [float(x) for x in a], "name": up_text(a), "rule": "given", "how": f"given (--up {text})"}


def _snap(axis):
    """(axis, name): a coordinate axis within SNAP_DEGREES, else rounded to 3 decimals."""
    axis = np.asarray(axis, np.float64)
    axis = axis / np.linalg.norm(axis)
    k = int(np.argmax(np.abs(axis)))
    if abs(axis[k]) >= np.cos(np.radians(SNAP_DEGREES)):
        e = np.zeros(3)
        e[k] = np.sign(axis[k])
        return [float(x) + 0.0 for x in e], up_text(e)
    r = [float(x) + 0.0 for x in np.round(axis, 3)]
    return r, up_text(r)


def _base(V, F, used, diag, topo=None):
    """The base loop's (axis, loop id, wall angle in degrees), or None (rule 1)."""
    from shellrepair.holes.loops import boundary_loops, loop_stats
    from shellrepair.mesh.topology import edge_topology

    topo = edge_topology(F, len(V)) if topo is None else topo
    loops, _ = boundary_loops(F, len(V), topo)
    if not loops:
        return None
    bhe = topo.boundary_he
    face_of = dict(zip(map(tuple, topo.ends(bhe).tolist()), (bhe // 3).tolist()))
    P = V[used]
    best = None
    for i, lp in enumerate(loops):
        if len(lp) < 3:
            continue
        st = loop_stats(V, lp)
        if st["planarity"] > BASE_PLANARITY or st["diameter"] < BASE_MIN_SIZE * diag:
            continue
        n = np.asarray(st["axis"], np.float64)
        faces = [face_of.get((int(a), int(b)), face_of.get((int(b), int(a))))
                 for a, b in zip(lp.tolist(), np.roll(lp, -1).tolist())]
        T = V[F[np.array([f for f in faces if f is not None], np.int64)]]
        cr = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
        a = np.linalg.norm(cr, axis=1)
        if a.sum() <= 0:
            continue
        cos = float(np.abs(cr @ n).sum() / a.sum())          # area-weighted mean |cos| to the normal
        if cos > np.sin(np.radians(BASE_WALL_DEGREES)):
            continue                                          # the rim lies along the plane: a hole in a side
        d = (P - st["center"]) @ n
        if np.count_nonzero(d > BASE_TOLERANCE * diag) < np.count_nonzero(d < -BASE_TOLERANCE * diag):
            n, d = -n, -d        # the scan's side
        below = np.count_nonzero(d < -BASE_TOLERANCE * diag) / len(P)
        if below > BASE_BELOW or d.max() < BASE_MIN_HEIGHT * diag:
            continue
        if best is None or st["area"] > best[0]:
            best = (st["area"], n, i, float(np.degrees(np.arccos(min(cos, 1.0)))))
    return None if best is None else best[1:]


#: Faces per block of :func:`_longest` (its corners are gathered a block at
#: a time: at 10M faces the whole gather was 700 MB at once; a block's
#: corners and products are 50 MB at this size, 200 MB at 1 << 20).
BLOCK = 1 << 18


def _longest(V, F):
    """(coordinate axis index, elongation) of the faces' area-weighted spread (rule 2)."""
    C = np.empty((len(F), 3))
    A = np.empty(len(F))
    for s in range(0, len(F), BLOCK):      # each face's centroid and area alone: the same bits by blocks
        Fb = F[s:s + BLOCK]
        P0, P1, P2 = V[Fb[:, 0]], V[Fb[:, 1]], V[Fb[:, 2]]
        # T.mean(axis=1) and np.cross term by term, in their order (the
        # same bits; at 10M faces the strided mean and np.cross's axis
        # moves took 2.0 of the 3.4 s)
        C[s:s + len(Fb)] = (P0 + P1 + P2) / 3
        A[s:s + len(Fb)] = 0.5 * np.linalg.norm(cross(P1 - P0, P2 - P0), axis=1)
    total = A.sum()
    if total > 0:
        A /= total                 # the weights, in A's own memory (A / A.sum(), the same bits)
        w = A
    else:
        w = np.full(len(F), 1.0 / len(F))
    # sqrt(w @ (C - w @ C) ** 2), the centring and squaring done in C's own
    # memory (the same bits; at 10M faces the two temporaries were 480 MB,
    # the whole repair's peak)
    C -= w @ C
    np.multiply(C, C, out=C)
    spread = np.sqrt(w @ C)
    order = np.argsort(-spread, kind="stable")
    k, j = int(order[0]), int(order[1])
    elong = float(spread[k] / spread[j]) if spread[j] > 0 else float("inf")
    return k, elong


def scan_up(before, report=None):
    """The up axis of a scan's pictures: the report's (``report["up"]``,
    recorded when the repair's pictures were made), else inferred from the
    scan as read.

    Parameters
    ----------
    before : shellrepair.mesh.io.Mesh
    report : dict, optional

    Returns
    -------
    axis : tuple of 3 float
    """
    rec = (report or {}).get("up")
    if rec and rec.get("axis") is not None:
        return tuple(float(x) for x in rec["axis"])
    return tuple(mesh_up(before)["axis"])


def mesh_up(mesh):
    """:func:`infer_up` of a mesh, with the edge topology :func:`read_mesh`
    kept for its arrays (:meth:`shellrepair.mesh.io.Mesh.cached`) where it
    has one.

    Parameters
    ----------
    mesh : shellrepair.mesh.io.Mesh

    Returns
    -------
    up : dict
        As :func:`infer_up` gives it.
    """
    topo = mesh.cached("topology") if hasattr(mesh, "cached") else None
    return infer_up(mesh.V, mesh.F, topo)


def infer_up(V, F, topo=None):
    """The scan's up axis by the module's rule.

    Parameters
    ----------
    V : (n,3) float64 array
    F : (m,3) int64 array
        The scan as read (its open base is what rule 1 looks for).
    topo : EdgeTopology, optional
        ``F``'s edge topology where the caller has it
        (:meth:`shellrepair.mesh.io.Mesh.cached`, as :func:`read_mesh`
        built it): not built again (3-4 s at 10M faces).

    Returns
    -------
    up : dict
        ``axis`` (3 floats, unit length or rounded to 3 decimals), ``name``
        (the ``--up`` argument that gives it back), ``rule`` (``"base"``,
        ``"longest axis"`` or ``"default"``) and ``how`` (a sentence).

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0, 0, 0], [4, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> infer_up(V, np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))["name"]
    'x'
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        return {"axis": [0.0, 1.0, 0.0], "name": "y", "rule": "default", "how": "the file's y axis: no faces"}
    mark = np.zeros(len(V), bool)
    mark[F] = True
    used = np.flatnonzero(mark)           # np.unique(F), without its sort of 3m ids
    lo, hi = V[used].min(axis=0), V[used].max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    if not diag > 0 or not np.isfinite(diag):
        return {"axis": [0.0, 1.0, 0.0], "name": "y", "rule": "default", "how": "the file's y axis: a flat point"}
    base = _base(V, F, used, diag, topo)
    if base is not None:
        n, i, wall = base
        axis, name = _snap(n)
        return {"axis": axis, "name": name, "rule": "base", "loop": int(i),
                "how": f"the normal of loop {i}, a planar opening the scan's walls meet at {wall:.0f} degrees, "
                       "with the scan on one side (its base)"}
    k, elong = _longest(V, F)
    if elong >= ELONGATION:
        name = "xyz"[k]
        return {"axis": list(_AXES[name]), "name": name, "rule": "longest axis", "elongation": round(elong, 3),
                "how": f"the scan's longest axis, {name} ({elong:.2f} times the spread along the next)"}
    return {"axis": [0.0, 1.0, 0.0], "name": "y", "rule": "default", "elongation": round(elong, 3),
            "how": f"the file's y axis: no planar base and no clearly longest axis ({elong:.2f} < {ELONGATION})"}
