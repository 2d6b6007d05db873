"""Lines drawn over a render: the edges a mesh leaves open, the rims of holes.

An edge is sampled about every pixel and a sample drawn only where the
surface seen along its ray is the sample itself, so edges behind the
statue stay hidden. Used by the report's pictures
(:mod:`shellrepair.report.html`) and the close-ups of each fill
(:mod:`shellrepair.report.closeups`); it needs open3d's ray casting, not the shading.
"""

from __future__ import annotations

import numpy as np

__all__ = ["project", "draw_edges", "draw_open_edges", "OPEN_EDGE_COLOR"]

#: Colour (sRGB) the edges left open (borders and holes not filled) are drawn in.
OPEN_EDGE_COLOR = (40, 110, 235)
#: Pixels between samples of a drawn edge.
_EDGE_STEP = 0.75


def project(cam, P):
    """Pixel coordinates (col, row) and depth of points P seen by ``cam``."""
    right, up, back = cam.basis()
    d = P - cam.eye
    z = -(d @ back)
    ty = np.tan(0.5 * np.radians(cam.fov_y_deg))
    tx = ty * cam.width / cam.height
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (d @ right) / (z * tx)
        y = (d @ up) / (z * ty)
    col = (x + 1.0) * 0.5 * cam.width - 0.5
    row = (1.0 - y) * 0.5 * cam.height - 0.5
    return col, row, z


def draw_open_edges(image, cam, V, F, color=OPEN_EDGE_COLOR, width=2):
    """Draw the visible open edges of a mesh onto its render, in place
    (:func:`draw_edges` of the edges one face uses).

    Returns
    -------
    n_edges : int
        Open edges found (drawn where visible).
    """
    from shellrepair.mesh.topology import edge_topology

    topo = edge_topology(np.asarray(F, np.int64), len(V))
    E = topo.edges[topo.edge_count == 1]   # the boundary left open
    draw_edges(image, cam, V, F, E, color=color, width=width)
    return int(len(E))


def draw_edges(image, cam, V, F, E, color=OPEN_EDGE_COLOR, width=2, scene=None):
    """Draw the visible edges ``E`` of a mesh onto its render, in place.

    An edge is sampled about every pixel; a sample is drawn when the first
    surface hit on the ray from the eye to it is the sample itself (within
    a thousandth of the mesh's size), so edges behind the surface stay
    hidden.

    Parameters
    ----------
    image : (H,W,3) uint8 array
        The render made with ``cam``.
    cam : shellrepair.appearance.render.Camera
    V : (n,3) float64 array
    F : (m,3) int64 array
    E : (k,2) int array
        The edges (vertex pairs) to draw.
    color : (3,) ints
    width : int
        Line width in pixels.
    scene : open3d RaycastingScene of V, F, optional
        Reused across calls (several pictures of one mesh).

    Returns
    -------
    n_edges : int
        ``len(E)``.
    """
    import open3d as o3d

    V = np.asarray(V, np.float64)
    E = np.asarray(E, np.int64).reshape(-1, 2)
    if len(E) == 0:
        return 0
    a, b = V[E[:, 0]], V[E[:, 1]]
    ca, ra, _ = project(cam, a)
    cb, rb, _ = project(cam, b)
    px = np.hypot(cb - ca, rb - ra)
    n = np.clip(np.nan_to_num(np.ceil(px / _EDGE_STEP), nan=1.0), 1, 4096).astype(np.int64)
    e = np.repeat(np.arange(len(E)), n)
    t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + 0.5) / np.repeat(n, n)
    P = a[e] + t[:, None] * (b[e] - a[e])
    col, row, z = project(cam, P)
    ok = (z > 0) & np.isfinite(col) & np.isfinite(row)
    ok &= (col > -1) & (col < cam.width) & (row > -1) & (row < cam.height)
    P, col, row = P[ok], col[ok], row[ok]
    if len(P) == 0:
        return int(len(E))
    if scene is None:
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)),
                            o3d.core.Tensor(np.asarray(F, np.uint32)))
    d = P - cam.eye
    dist = np.linalg.norm(d, axis=1)
    rays = np.concatenate([np.broadcast_to(cam.eye, P.shape), d / dist[:, None]], axis=1).astype(np.float32)
    hit = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(np.float64)
    size = float(np.linalg.norm(np.ptp(V, axis=0))) or 1.0
    seen = ~(hit < dist - 1e-3 * size)
    col, row = col[seen], row[seen]
    H, W = image.shape[:2]
    r0 = np.rint(row).astype(np.int64)
    c0 = np.rint(col).astype(np.int64)
    for dr in range(-(width // 2), width - width // 2):
        for dc in range(-(width // 2), width - width // 2):
            rr, cc = r0 + dr, c0 + dc
            m = (rr >= 0) & (rr < H) & (cc >= 0) & (cc < W)
            image[rr[m], cc[m]] = color
    return int(len(E))
