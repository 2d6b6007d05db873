"""Rust coverage per vertex: how much of the surface is corroded.

A coverage c in [0, 1] per vertex drives the roughness and the corrosion
layers' thickness (:mod:`shellrepair.appearance.materials`).  It is read from the
scan's vertex colours when they carry a cue (green-blue hues read as
patina) and otherwise estimated from ambient occlusion (recesses corrode
first, in the spirit of Dorsey & Hanrahan's exposure maps).  Both are
heuristics, not measurements.

References
----------
.. [1] J. Dorsey and P. Hanrahan, "Modeling and Rendering of Metallic
   Patinas", SIGGRAPH 1996.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "rust_coverage_from_colors",
    "rust_coverage_from_occlusion",
    "rust_coverage",
    "vertex_normals",
]

_PATINA_HUE = (75.0, 105.0, 200.0, 250.0)
#: Saturation at which the hue is fully trusted (greys carry no rust cue).
_SAT_FULL = 0.25
#: Median saturation below which vertex colours are treated as uninformative.
_SAT_UNINFORMATIVE = 0.05


def _smoothstep(a, b, x):
    t = np.clip((x - a) / (b - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _hue_sat(rgb):
    rgb = np.asarray(rgb, dtype=np.float64)
    mx = rgb.max(axis=-1)
    mn = rgb.min(axis=-1)
    d = mx - mn
    sat = np.where(mx > 0.0, d / np.where(mx > 0.0, mx, 1.0), 0.0)
    ds = np.where(d > 0.0, d, 1.0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    h = np.where(mx == r, ((g - b) / ds) % 6.0, np.where(mx == g, (b - r) / ds + 2.0, (r - g) / ds + 4.0))
    return np.where(d > 0.0, 60.0 * h, 0.0), sat


def rust_coverage_from_colors(vertex_colors):
    """Rust coverage from scanned vertex colours.

    Parameters
    ----------
    vertex_colors : (n,3) numpy uint8 array (or floats in [0, 1])

    Returns
    -------
    c : (n,) float64 array in [0, 1]

    Notes
    -----
    A heuristic, not a measurement: green-blue hues (about 90-230 degrees)
    read as green patina (c -> 1), red-yellow hues (gold leaf, bronze) as
    exposed metal (c -> 0); the hue is trusted in proportion to the
    saturation (full at 0.25) and unsaturated colours give 0.5.
    """
    col = np.asarray(vertex_colors)
    if col.ndim != 2 or col.shape[1] != 3:
        raise ValueError("vertex_colors must be (n,3), got shape %s" % (col.shape,))
    rgb = col.astype(np.float64) / 255.0 if col.dtype == np.uint8 else col.astype(np.float64)
    hue, sat = _hue_sat(np.clip(rgb, 0.0, 1.0))
    a0, a1, b0, b1 = _PATINA_HUE
    green = _smoothstep(a0, a1, hue) * (1.0 - _smoothstep(b0, b1, hue))
    w = np.clip(sat / _SAT_FULL, 0.0, 1.0)
    return w * green + (1.0 - w) * 0.5


def _fibonacci_sphere(n):
    i = np.arange(n, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def vertex_normals(V, F):
    """Area-weighted unit vertex normals.

    Parameters
    ----------
    V : (n,3) numpy float array
    F : (m,3) numpy int array

    Returns
    -------
    N : (n,3) float64 array; (0, 0, 1) at isolated or degenerate vertices.
    """
    from shellrepair.mesh.topology import face_normals

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fn = face_normals(V, F)
    N = np.empty_like(V)
    idx = F.ravel()
    for k in range(3):  # bincount is much faster than np.add.at
        N[:, k] = np.bincount(idx, np.repeat(fn[:, k], 3), minlength=len(V))
    ln = np.linalg.norm(N, axis=1)
    ok = ln > 0.0
    N[ok] /= ln[ok, None]
    N[~ok] = (0.0, 0.0, 1.0)
    return N


def rust_coverage_from_occlusion(V, F, *, n_dirs=16, radius=0.1, base=0.2, gain=1.6, subset=None, normals=None,
                                 scene=None):
    """Rust coverage from an ambient-occlusion estimate.

    Parameters
    ----------
    V : (n,3) numpy float array
    F : (m,3) numpy int array
    n_dirs : int, optional
        Ray directions on a fixed Fibonacci sphere (deterministic); those in
        each vertex's upper hemisphere are used.
    radius : float, optional
        Rays longer than ``radius`` x bounding-box diagonal count as open sky.
    base, gain : float, optional
        ``c = clip(base + gain * occlusion, 0, 1)``.
    subset : (k,) int array or None, optional
        Only these vertices are estimated (e.g. those a render can see);
        the others get ``base``.
    normals : (n,3) float array or None, optional
        :func:`vertex_normals` of the mesh, when the caller has them.
    scene : open3d.t.geometry.RaycastingScene or None, optional
        A scene holding exactly this mesh, when the caller has built one
        (building it is a large part of the time on big meshes).

    Returns
    -------
    c : (n,) float64 array in [0, 1]

    Notes
    -----
    A heuristic in the spirit of Dorsey & Hanrahan's exposure maps:
    recesses keep moisture and dirt and corrode first, exposed convex parts
    keep their gilding.  Occlusion is the cosine-weighted fraction of
    directions whose ray hits the mesh within the radius.
    """
    import open3d as o3d

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    N = vertex_normals(V, F) if normals is None else np.asarray(normals, np.float64)
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if len(V) else 1.0
    diag = diag if diag > 0.0 else 1.0
    if scene is None:
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    dirs = _fibonacci_sphere(int(n_dirs))
    idx = np.arange(len(V)) if subset is None else np.unique(np.asarray(subset, dtype=np.int64))
    out = np.full(len(V), float(np.clip(base, 0.0, 1.0)))
    N = N[idx]
    occ = np.zeros(len(idx))
    wsum = np.zeros(len(idx))
    origin = V[idx] + (1e-4 * diag) * N
    for d in dirs:
        w = N @ d
        up = w > 0.05
        if not np.any(up):
            continue
        rays = np.concatenate([origin[up], np.broadcast_to(d, (int(up.sum()), 3))], axis=1)
        t = scene.cast_rays(o3d.core.Tensor(rays.astype(np.float32)))["t_hit"].numpy()
        hit = t < radius * diag
        occ[up] += w[up] * hit
        wsum[up] += w[up]
    occlusion = occ / np.maximum(wsum, 1e-12)
    out[idx] = np.clip(base + gain * occlusion, 0.0, 1.0)
    return out


def rust_coverage(V, F, vertex_colors=None, *, subset=None, normals=None, scene=None,
                  colors_only=False):
    """Per-vertex rust coverage: from colours when informative, else occlusion.

    Parameters
    ----------
    V : (n,3) numpy float array
    F : (m,3) numpy int array
    vertex_colors : (n,3) numpy uint8 array or None
    subset : (k,) int array or None
        Vertices that need the occlusion estimate (see
        :func:`rust_coverage_from_occlusion`).
    normals : (n,3) float array or None
        :func:`vertex_normals`, when the caller has them.
    scene : open3d RaycastingScene or None
        See :func:`rust_coverage_from_occlusion`.

    Returns
    -------
    c : (n,) float64 array in [0, 1]
    source : str
        ``"colors"`` or ``"occlusion"`` (colours that are nearly grey, median
        saturation below 0.05, carry no rust cue and are ignored).
    colors_only : bool
        Return ``(None, None)`` instead of estimating occlusion when the
        colours carry no cue (the renderer then uses
        :func:`shellrepair.appearance.aging.aging_maps`).
    """
    if vertex_colors is not None:
        col = np.asarray(vertex_colors)
        rgb = col.astype(np.float64) / 255.0 if col.dtype == np.uint8 else col.astype(np.float64)
        _, sat = _hue_sat(np.clip(rgb, 0.0, 1.0))
        if len(sat) and np.median(sat) >= _SAT_UNINFORMATIVE:
            return rust_coverage_from_colors(col), "colors"
    if colors_only:
        return None, None
    return rust_coverage_from_occlusion(V, F, subset=subset, normals=normals, scene=scene), "occlusion"
