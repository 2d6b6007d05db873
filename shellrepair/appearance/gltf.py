"""The repaired mesh with its aged look as glTF 2.0 (``.glb``), for Blender, Sketchfab or a web viewer.

glTF's metallic-roughness material is an approximation of the shading
of :mod:`shellrepair.appearance.reflectance` (Torrance-Sparrow over Kubelka-Munk
layers); per vertex, from the aging maps of :func:`shellrepair.appearance.aging.aging_maps`
(made from the scan's own faces, so the filled part does not move the
scan's look):

- metal colour: the normal-incidence Fresnel reflectance
  ``((n-1)² + k²) / ((n+1)² + k²)`` of the exposed metal (gold leaf) where
  the gilding holds, of the substrate (bronze) where it is worn;
- corrosion colour: the Kubelka-Munk reflectance of an opaque layer of
  the outermost corrosion product, ``R∞ = 1 + K/S - sqrt((K/S)² + 2 K/S)``
  (paper, eq. 9 as the layer's thickness grows; 0 where S = 0), darkened
  by the crust where rain never washes it;
- base colour ``(1 - c) metal + c corrosion`` and metallic ``1 - c`` with
  ``c`` the rust coverage; roughness ``sqrt(m)`` from the Beckmann slope
  ``m`` of :func:`shellrepair.appearance.materials.surface_params` (glTF's roughness
  is the square root of its GGX alpha, which Beckmann's m approximates).

Core glTF has one metallic and one roughness per material: the file's two
materials (the scan, and the filled part) carry their area-weighted means,
and each vertex's own values go in the application attributes
``_METALLIC``, ``_ROUGHNESS`` and ``_COVERAGE`` beside ``COLOR_0`` (linear,
as glTF reads vertex colours). The scan and the filled faces are two
meshes of the scene, named ``scan`` and ``filled``. Written through
trimesh's glTF exporter.
"""

from __future__ import annotations

import numpy as np

__all__ = ["gltf_bytes", "pbr_approximation"]


def _f0(conductor):
    n, k = np.asarray(conductor.n, np.float64), np.asarray(conductor.k, np.float64)
    return ((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k)


def _r_infinity(layer):
    """Kubelka-Munk reflectance of an opaque layer (3,); 0 where S = 0."""
    K, S = np.asarray(layer.K, np.float64), np.asarray(layer.S, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(S > 0, K / S, np.inf)
        r = 1.0 + a - np.sqrt(a * a + 2.0 * a)
    r = np.where(np.isfinite(a), r, 0.0)
    return np.clip(r, 0.0, 1.0)


def pbr_approximation(coverage, gild, crust, material="aged-bronze"):
    """Per-vertex glTF metallic-roughness values of the aged material.

    Parameters
    ----------
    coverage, gild, crust : (n,) float arrays in [0, 1]
        From :func:`shellrepair.appearance.aging.aging_maps`.
    material : str or Material

    Returns
    -------
    base : (n,3) float64
        Linear base colour.
    metallic, roughness : (n,) float64
    """
    from shellrepair.appearance.materials import get_material, surface_params

    mat = get_material(material)
    c = np.clip(np.asarray(coverage, np.float64), 0.0, 1.0)
    g = np.clip(np.asarray(gild, np.float64), 0.0, 1.0)
    d = np.clip(np.asarray(crust, np.float64), 0.0, 1.0)
    metal = g[:, None] * _f0(mat.exposed) + (1.0 - g[:, None]) * _f0(mat.substrate)
    if mat.layers:
        top = _r_infinity(mat.layers[-1][0])
        if mat.crust is not None:
            layer, p_max = mat.crust
            mix = (d * p_max)[:, None]
            top = (1.0 - mix) * top + mix * _r_infinity(layer)
        corr = np.broadcast_to(top, metal.shape)
    else:
        c = np.zeros_like(c)
        corr = metal
    base = (1.0 - c[:, None]) * metal + c[:, None] * corr
    m, _ = surface_params(c, mat)
    return base, 1.0 - c, np.sqrt(np.clip(m, 0.0, 1.0))


def origin_of(V):
    """The point a glTF file stores positions about: the centre of the
    points' bounding box (zero for no points), float64.

    Parameters
    ----------
    V : (n,3) float64

    Returns
    -------
    centre : (3,) float64
    """
    V = np.asarray(V, np.float64)
    if len(V) == 0 or not np.isfinite(V).all():
        return np.zeros(3)
    return 0.5 * (V.min(axis=0) + V.max(axis=0))


def gltf_bytes(mesh, *, age=None, up=(0.0, 1.0, 0.0), seed=0, material="aged-bronze"):
    """The mesh as a binary glTF 2.0 file (``.glb``) with its aged look.

    Parameters
    ----------
    mesh : Mesh
        A repaired mesh (its ``face_filled`` flags split the scene into
        ``scan`` and ``filled``), or any mesh (all ``scan``).
    age : float, optional
        In [0, 1]; default :data:`shellrepair.appearance.aging.DEFAULT_AGE`.
    up : (3,) sequence
        The scan's up direction (the aging's rain).
    seed : int
        Seed of the aging's blotch noise.
    material : str
        A preset of :data:`shellrepair.appearance.materials.MATERIALS`.

    Returns
    -------
    data : bytes
    """
    import trimesh

    from shellrepair.appearance import aging as ag
    from shellrepair.mesh.core import as_written, written_faces

    out = as_written(mesh)
    V = np.asarray(out.V, np.float64)
    F = written_faces(out)
    filled = np.zeros(len(F), bool) if out.face_filled is None else np.asarray(out.face_filled, bool)
    maps = ag.aging_maps(V, F, age=ag.DEFAULT_AGE if age is None else float(age), up=up, seed=seed,
                         scan=~filled if filled.any() else None)
    base, metallic, rough = pbr_approximation(maps.coverage, maps.gild, maps.crust, material)
    area = np.zeros(len(V))
    fa = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    # positions are float32 in glTF: stored about the centre of the scan's box,
    # the centre (float64, exact in the JSON) on each node, so a scan in
    # millimetres far from its origin keeps float32's precision of its own size
    # (~6e-8 of it), not of the offset (0.06 mm at 1e6 mm)
    centre = origin_of(V[np.unique(F)] if len(F) else V)
    move = np.eye(4)
    move[:3, 3] = centre
    scene = trimesh.Scene()
    for name, sel in (("scan", ~filled), ("filled", filled)):
        if not sel.any():
            continue
        used, Fl = np.unique(F[sel], return_inverse=True)
        Fl = Fl.reshape(-1, 3)
        area[:] = 0.0
        np.add.at(area, F[sel].ravel(), np.repeat(fa[sel], 3) / 3.0)
        w = area[used] / max(area[used].sum(), 1e-300)
        pbr = trimesh.visual.material.PBRMaterial(
            name=f"shellrepair_{name}", baseColorFactor=[1.0, 1.0, 1.0, 1.0],
            metallicFactor=float(w @ metallic[used]), roughnessFactor=float(w @ rough[used]))
        visual = trimesh.visual.TextureVisuals(material=pbr)
        rgba = np.empty((len(used), 4), np.uint8)
        rgba[:, :3] = np.round(np.clip(base[used], 0.0, 1.0) * 255.0)
        rgba[:, 3] = 255
        visual.vertex_attributes["color"] = rgba
        part = trimesh.Trimesh(vertices=V[used] - centre, faces=Fl, visual=visual, process=False, validate=False)
        part.vertex_attributes["_METALLIC"] = metallic[used].astype(np.float32)
        part.vertex_attributes["_ROUGHNESS"] = rough[used].astype(np.float32)
        part.vertex_attributes["_COVERAGE"] = maps.coverage[used].astype(np.float32)
        scene.add_geometry(part, geom_name=name, node_name=name, transform=move)
    return scene.export(file_type="glb")
