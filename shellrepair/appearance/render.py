"""CPU ray-cast renderer for repaired scans with the aged-metal reflectance.

2 x 2 primary rays per pixel (averaged in linear light) through an
auto-framed pinhole camera are cast with open3d's ``RaycastingScene`` (an
Embree BVH); each hit is shaded by
:class:`shellrepair.sd.MaterialShader` under two directional lights
with soft ray-traced shadows (each light a small disc, 8 fixed shadow rays
per point), plus a warm room with a soft box seen in mirror
reflections, then tone mapped to sRGB.  Rust coverage and gilding come from
the scan's colours when informative, else from the aging map
(:func:`shellrepair.appearance.aging.aging_maps`).  Faces flagged ``filled``
(synthesised by the repair) can be tinted so a viewer sees what was added;
side-by-side renders share one camera and carry labels and a legend.

The model is chosen per render (:func:`shellrepair.sd.choose_model`)
from the pixel footprint on the statue, which needs the mesh's length unit
(given, or inferred from its size by :func:`infer_unit`): at ordinary statue
scales the corrosion layers' diffusion length (~5 um) is far below a pixel
and the local form is used; if a close-up makes it visible (below ~38 um a
pixel), the diffuse term is spread in screen space by the dipole profile.

Everything is deterministic: no random sampling.
"""

from __future__ import annotations

import dataclasses
import os
import time

import numpy as np

from shellrepair.appearance import materials as mt
from shellrepair.appearance import shader as sd
from shellrepair.appearance import shading as sh
from shellrepair.mesh.units import STATUE_HEIGHT_M, UNITS_UM, infer_unit  # noqa: F401  (render.infer_unit: the render's own name for it)

try:  # the package's input error, when the foundation provides it
    from shellrepair.errors import MeshError as _InputError
except ImportError:  # pragma: no cover - only before errors.py exists
    _InputError = ValueError

__all__ = [
    "Camera",
    "frame_camera",
    "render_mesh",
    "render_side_by_side",
    "save_png",
    "save_image",
    "downsample",
    "infer_unit",
    "draw_label",
    "draw_legend",
    "UNITS_UM",
    "FILLED_TINT",
]

#: Linear RGB tint mixed into filled faces when highlighting.
FILLED_TINT = np.array([0.95, 0.10, 0.75])
#: Fraction of the tint in a highlighted pixel.
FILLED_TINT_WEIGHT = 0.55
#: Background colour (sRGB, 0-255).
BACKGROUND = np.array([38, 40, 46], dtype=np.uint8)
#: Lights in camera coordinates (x right, y up, z towards the viewer) and
#: their irradiance (linear RGB, arbitrary units): a museum-like warm key
#: (tungsten-halogen, ~3200 K) and a weaker neutral fill.
_LIGHTS = (
    (np.array([-0.55, 0.75, 0.65]), np.array([2.5, 2.15, 1.65])),  # key, warm
    (np.array([0.75, 0.15, 0.55]), np.array([0.5, 0.5, 0.52])),  # fill, neutral
)
#: Environment radiance above and below the horizon (linear RGB): a warm
#: room, bright above, dark floor.  Metals show what they mirror, so this
#: is what makes gold read as gold rather than as a grey-khaki.
_SKY = np.array([0.30, 0.25, 0.18])
_GROUND = np.array([0.05, 0.045, 0.04])
#: A soft box seen in mirror reflections, around the key light: radiance
#: added to the environment (linear RGB) and its angular width (radians).
_SOFTBOX = np.array([2.6, 2.2, 1.7])
_SOFTBOX_WIDTH = 0.35
#: Exposure applied before tone mapping.
_EXPOSURE = 1.0
#: Offset of shadow-ray origins, as a fraction of the bounding radius.
_SHADOW_EPS = 1e-4
#: The lights are discs seen from the statue at this angular radius
#: (radians; ~9 degrees, a museum spot or soft box a few metres away), so
#: shadow edges are soft, not lines across a face.
_LIGHT_ANGULAR_RADIUS = 0.15
#: Shadow rays per light and shaded point, on a fixed spiral over the disc.
_SHADOW_SAMPLES = 8


@dataclasses.dataclass(frozen=True)
class Camera:
    """A pinhole camera.

    Attributes
    ----------
    eye, target, up : (3,) float64 arrays
        Position, look-at point and approximate up vector (world units).
    fov_y_deg : float
        Vertical field of view (degrees).
    width, height : int
        Image size in pixels.
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov_y_deg: float
    width: int
    height: int

    def basis(self):
        """Unit (right, up, back) vectors; back points from target to eye."""
        back = self.eye - self.target
        back = back / np.linalg.norm(back)
        right = np.cross(self.up, back)
        if np.linalg.norm(right) < 1e-9:  # looking along up: pick another
            right = np.cross(np.array([0.0, 0.0, 1.0]), back)
        right = right / np.linalg.norm(right)
        up = np.cross(back, right)
        return right, up, back

    def rays(self):
        """Primary rays ``(H, W, 6)`` float32: origin, unit direction."""
        right, up, back = self.basis()
        W, H = self.width, self.height
        ty = np.tan(0.5 * np.radians(self.fov_y_deg))
        tx = ty * W / H
        xs = ((np.arange(W) + 0.5) / W * 2.0 - 1.0) * tx
        ys = (1.0 - (np.arange(H) + 0.5) / H * 2.0) * ty
        d = (xs[None, :, None] * right + ys[:, None, None] * up - back)
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        o = np.broadcast_to(self.eye, d.shape)
        return np.concatenate([o, d], axis=-1).astype(np.float32)

    def footprint(self, distance):
        """Width (world units) of one pixel at ``distance`` from the eye."""
        return 2.0 * distance * np.tan(0.5 * np.radians(self.fov_y_deg)) / self.height


#: Azimuth and elevation (degrees) of the camera when no view is given.
DEFAULT_VIEW = (25.0, 15.0)


def frame_camera(V, size=(1024, 768), view=None, *, fov_y_deg=30.0, up=(0.0, 1.0, 0.0),
                 margin=1.08, center=None, radius=None):
    """Camera that frames the points V.

    Parameters
    ----------
    V : (n,3) numpy float array
        Points to frame (vertices of one or several meshes).
    size : (int, int)
        Image (width, height) in pixels.
    view : (float, float) or None
        (azimuth, elevation) in degrees around the ``up`` axis; azimuth 0
        looks along -z (camera on the +z side).  Default (25, 15).
    fov_y_deg : float
        Vertical field of view.
    up : (3,) sequence
        World up axis (scans are usually y-up).
    margin : float
        Bounding sphere is scaled by this before fitting.
    center : (3,) sequence or None
        The point looked at (a close-up's target); default the centre of
        V's bounding box.
    radius : float or None
        Radius of the sphere about ``center`` to frame; default the
        farthest point of V from ``center``.

    Returns
    -------
    Camera

    Raises
    ------
    ValueError
        For an empty or non-finite V, or a non-positive size.
    """
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3 or len(V) == 0:
        raise _InputError("cannot frame a camera on vertices of shape %s" % (V.shape,))
    if not np.all(np.isfinite(V)):
        bad = int(np.argmax(~np.all(np.isfinite(V), axis=1)))
        raise _InputError("vertex %d has a non-finite coordinate" % bad)
    W, H = (int(size[0]), int(size[1]))
    if W <= 0 or H <= 0:
        raise _InputError("image size must be positive, got %dx%d" % (W, H))
    az, el = DEFAULT_VIEW if view is None else (float(view[0]), float(view[1]))
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    center = 0.5 * (V.min(axis=0) + V.max(axis=0)) if center is None else np.asarray(center, np.float64)
    if center.shape != (3,) or not np.all(np.isfinite(center)):
        raise _InputError("the camera's target must be 3 finite numbers, got %s" % (center,))
    if radius is None:
        radius = float(np.sqrt(np.max(np.sum((V - center) ** 2, axis=1))))
    elif not (np.isfinite(radius) and radius > 0.0):
        raise _InputError("the radius to frame must be a positive number, got %r" % (radius,))
    radius = float(radius) if radius > 0.0 else 1.0
    # an orthonormal frame around up: a = "front" axis, b = "side" axis
    ref = np.array([0.0, 0.0, 1.0]) if abs(up[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    a = ref - up * (ref @ up)
    a /= np.linalg.norm(a)
    b = np.cross(up, a)
    azr, elr = np.radians(az), np.radians(el)
    direction = np.cos(elr) * (np.cos(azr) * a + np.sin(azr) * b) + np.sin(elr) * up
    half = 0.5 * np.radians(fov_y_deg)
    half_min = min(half, np.arctan(np.tan(half) * W / H))
    dist = margin * radius / np.sin(half_min)
    return Camera(center + dist * direction, center, up, float(fov_y_deg), W, H)


def view_towards(V, F, mask, *, up=(0.0, 1.0, 0.0), max_elevation=75.0):
    """(azimuth, elevation) of a camera that looks at the faces ``mask``.

    The camera sits on the side the faces face: along their area-weighted
    mean normal, in the frame of :func:`frame_camera`. The elevation is
    clamped to ±``max_elevation`` degrees, away from the up axis.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    mask : (m,) bool array
        The faces to show (e.g. the filled ones).

    Returns
    -------
    view : (float, float) or None
        None when no face is selected or their normals cancel out.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)[np.asarray(mask, bool)]
    if len(F) == 0:
        return None
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(axis=0)
    ln = np.linalg.norm(n)
    if not np.isfinite(ln) or ln == 0.0:
        return None
    n /= ln
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    ref = np.array([0.0, 0.0, 1.0]) if abs(up[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    a = ref - up * (ref @ up)
    a /= np.linalg.norm(a)
    b = np.cross(up, a)
    el = float(np.degrees(np.arcsin(np.clip(n @ up, -1.0, 1.0))))
    az = float(np.degrees(np.arctan2(n @ b, n @ a)))
    return az, float(np.clip(el, -max_elevation, max_elevation))


def _validate(V, F):
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3 or len(V) == 0:
        raise _InputError("V must be a non-empty (n,3) array, got shape %s" % (V.shape,))
    if F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise _InputError("F must be a non-empty (m,3) array, got shape %s" % (F.shape,))
    if not np.issubdtype(F.dtype, np.integer):
        raise _InputError("F must hold integers, got dtype %s" % F.dtype)
    F = F.astype(np.int64)
    if F.min() < 0 or F.max() >= len(V):
        bad = int(np.argmax((F < 0).any(axis=1) | (F >= len(V)).any(axis=1)))
        raise _InputError("face %d refers to a vertex outside 0..%d" % (bad, len(V) - 1))
    if not np.all(np.isfinite(V)):
        bad = int(np.argmax(~np.all(np.isfinite(V), axis=1)))
        raise _InputError("vertex %d has a non-finite coordinate" % bad)
    return V, F


def _srgb(linear):
    x = np.clip(linear, 0.0, None)
    x = x / (1.0 + 0.25 * x)  # gentle highlight roll-off
    x = np.clip(x * 1.25, 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.round(np.clip(s, 0.0, 1.0) * 255.0).astype(np.uint8)


def _environment(r, up, box=None):
    """Room radiance for unit directions r (..., 3); with ``box`` (a unit
    direction) a soft box around it is added (for mirror lookups)."""
    t = np.clip(0.5 * (1.0 + r @ up), 0.0, 1.0)
    t = t * t * (3.0 - 2.0 * t)
    L = _GROUND + (_SKY - _GROUND) * t[..., None]
    if box is not None:
        a = np.exp(-(1.0 - np.clip(r @ box, -1.0, 1.0)) / (0.5 * _SOFTBOX_WIDTH ** 2))
        L = L + _SOFTBOX * a[..., None]
    return L


def _smooth_points(p, bw, Vt, Nt, ng):
    """The points of the smooth surface a coarse mesh's shading pretends.

    Each hit point is moved to the barycentric mix of its projections on
    the tangent planes of its triangle's three vertices (their smooth
    normals): Phong tessellation (Boubekeur & Alexa 2008), which passes
    through the vertices and bulges over convex triangles.  Returns that
    point, where the aging map is read (so a map's patches do not follow the
    flat triangles), and the shadow-ray origin: the same mix with each point
    only lifted up to a tangent plane, kept where it is above the triangle
    (Hanika 2021), so a lit, curved-looking face is not shadowed in steps by
    its own neighbouring triangles (the "shadow terminator").

    Parameters
    ----------
    p : (q,3) hit points; bw : (q,3) barycentric weights; Vt, Nt : (q,3,3)
    the triangles' corners and unit vertex normals; ng : (q,3) the
    geometric normals, facing the viewer.

    Returns
    -------
    smooth, origin : (q,3) float64 arrays

    References
    ----------
    T. Boubekeur and M. Alexa, "Phong Tessellation", SIGGRAPH Asia 2008.
    J. Hanika, "Hacking the Shadow Terminator", Ray Tracing Gems II, 2021.
    """
    # vertex normals turned to the side the geometric normal faces
    s = np.sign(np.einsum("pkj,pj->pk", Nt, ng))
    s[s == 0.0] = 1.0
    Nt = Nt * s[:, :, None]
    d = np.einsum("pkj,pkj->pk", p[:, None, :] - Vt, Nt)  # height above each tangent plane
    smooth = np.einsum("pk,pkj->pj", bw, p[:, None, :] - d[:, :, None] * Nt)
    lifted = np.einsum("pk,pkj->pj", bw, p[:, None, :] - np.minimum(d, 0.0)[:, :, None] * Nt)
    origin = np.where((np.einsum("ij,ij->i", lifted - p, ng) > 0.0)[:, None], lifted, p)
    return smooth, origin


def _light_visibility(scene, origin, ldir, mask, sel):
    """Fraction of a disc light seen from each origin (``_SHADOW_SAMPLES`` rays).

    The samples lie on a Fibonacci spiral over the disc of angular radius
    ``_LIGHT_ANGULAR_RADIUS`` about ``ldir``, turned per pixel by a fixed
    hashed angle (from the pixel's index), so neighbouring pixels sample it
    differently and the supersampling averages the steps away; nothing is
    random, the picture is the same bytes every time.
    """
    import open3d as o3d

    if len(origin) == 0:
        return np.zeros(0)
    ref = np.array([1.0, 0.0, 0.0]) if abs(ldir[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(ldir, ref)
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(ldir, t1)
    k = np.arange(_SHADOW_SAMPLES) + 0.5
    rad = np.tan(_LIGHT_ANGULAR_RADIUS) * np.sqrt(k / _SHADOW_SAMPLES)  # equal area on the disc
    pix = np.flatnonzero(mask.ravel())[sel].astype(np.uint64)
    with np.errstate(over="ignore"):
        h = (pix * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(40)
    turn = h.astype(np.float64) * (2.0 * np.pi / float(1 << 24))
    seen = np.zeros(len(origin))
    for j in range(_SHADOW_SAMPLES):
        a = np.pi * (3.0 - np.sqrt(5.0)) * j + turn
        d = ldir[None, :] + rad[j] * (np.cos(a)[:, None] * t1 + np.sin(a)[:, None] * t2)
        rays = np.concatenate([origin, d], axis=1).astype(np.float32)
        seen += ~scene.test_occlusions(o3d.core.Tensor(rays)).numpy().astype(bool)
    return seen / _SHADOW_SAMPLES


def _dipole_spread(diffuse_img, mask, choice, material, footprint_um):
    """Spread the diffuse radiance by the dipole profile (screen space)."""
    from scipy.signal import fftconvolve

    mat = mt.get_material(material)
    Ks = np.array([L[0].K for L in mat.layers])
    Ss = np.array([L[0].S for L in mat.layers])
    X = np.array(mt.layer_thicknesses(1.0, mat))
    K, S = sh.km_mix(Ks, Ss, X)
    sa, ssp = sh.km_to_transport(K, S)
    rad_px = int(min(64, max(2, np.ceil(4.0 * choice.diffusion_length_um / footprint_um))))
    yy, xx = np.mgrid[-rad_px:rad_px + 1, -rad_px:rad_px + 1]
    r_um = np.hypot(xx, yy) * footprint_um
    out = np.empty_like(diffuse_img)
    m = mask.astype(np.float64)
    for ch in range(3):
        k = sh.dipole_profile(r_um, sa[ch], ssp[ch], mat.eta_top)
        k = k / k.sum()
        num = fftconvolve(diffuse_img[..., ch] * m, k, mode="same")
        den = fftconvolve(m, k, mode="same")
        out[..., ch] = np.where(mask, num / np.maximum(den, 1e-12), 0.0)
    return out


def _unit_um(unit, V):
    """(micrometres per mesh unit, unit name, reason) from a unit name, number or None."""
    if unit is None:
        name, reason = infer_unit(V)
        return UNITS_UM[name], name, reason
    if isinstance(unit, str):
        if unit not in UNITS_UM:
            raise _InputError("unit must be one of %s, got %r" % (", ".join(UNITS_UM), unit))
        return UNITS_UM[unit], unit, "given"
    um = float(unit)
    if not um > 0.0 or not np.isfinite(um):
        raise _InputError("unit must be a positive length in micrometres, got %r" % (unit,))
    return um, "%g um" % um, "given"


def _srgb_to_linear(u8):
    x = np.asarray(u8, dtype=np.float64) / 255.0
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def _linear_to_srgb8(x):
    x = np.clip(x, 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


def downsample(img, s):
    """Average s x s blocks of an sRGB uint8 image in linear light.

    How :func:`render_mesh` turns its supersampled image (``supersample=s``)
    into the output: each output pixel is the mean of s x s rendered ones,
    taken in linear light and encoded back to sRGB.

    Parameters
    ----------
    img : (H*s, W*s, 3) uint8 array
        sRGB image whose sides are multiples of s.
    s : int
        Block side (>= 1; 1 returns ``img`` itself).

    Returns
    -------
    (H, W, 3) uint8 array
    """
    if s == 1:
        return img
    H, W = img.shape[0] // s, img.shape[1] // s
    lin = _srgb_to_linear(img).reshape(H, s, W, s, 3).mean(axis=(1, 3))
    return _linear_to_srgb8(lin)


def _scaled_camera(cam, s):
    return dataclasses.replace(cam, width=cam.width * s, height=cam.height * s)


def render_mesh(V, F, *, size=(1024, 768), material="aged-bronze", filled=None,
                highlight_filled=False, view=None, vertex_colors=None, coverage=None,
                gild=None, crust=None, camera=None, unit=None, unit_um=None, age=None, up=(0.0, 1.0, 0.0),
                seed=0, supersample=2, legend=None, info=None, scene=None, setting=None, aging_field=None):
    """Render a triangle mesh with the aged-metal shading.

    Parameters
    ----------
    V : (n,3) numpy float array
    F : (m,3) numpy int array
    size : (int, int)
        Image (width, height) in pixels.
    material : str or Material
        ``"aged-bronze"``, ``"gilt"`` or ``"bronze"``.
    filled : (m,) bool array or None
        Faces synthesised by the repair.
    highlight_filled : bool
        Tint pixels of filled faces with :data:`FILLED_TINT`.
    view : (float, float) or None
        (azimuth, elevation) in degrees; see :func:`frame_camera`.
    vertex_colors : (n,3) uint8 array or None
        Scanned colours; used for the rust coverage when informative.
    coverage, gild : (n,) float arrays or None
        Rust coverage and gilding per vertex; override ``vertex_colors`` and
        the aging map (:func:`shellrepair.appearance.aging.aging_maps`).  ``gild``
        defaults to 1 (all gilt) when only ``coverage`` is given.
    crust : (n,) float array or None
        Dark crust on the patina per vertex (0 when ``coverage`` is given
        without it).
    camera : Camera or None
        Use this camera instead of auto-framing (``size`` is then ignored).
    unit : {"mm", "cm", "m"}, float or None
        Length of one mesh unit (a name, or micrometres); None infers it
        from the size (:func:`infer_unit`).  Sets the pixel footprint for
        the model choice.  ``unit_um`` is the older spelling of a number.
    age : float or None
        Aging level in [0, 1] of the aging map (None: its default).
    up : (3,) sequence
        World up: the camera's up and where the rain comes from.
    seed : int
        Seed of the aging map's blotches.
    supersample : int
        Rays per pixel along each axis (2: 2 x 2 rays, averaged in linear
        light; 1: one ray per pixel).
    legend : str or None
        Text drawn at the bottom-left (e.g. what the tint means).
    info : dict or None
        If given, filled with the camera, the :class:`ModelChoice`, the unit,
        the coverage source, the aging maps and timings.
    scene : open3d.t.geometry.RaycastingScene or None
        The ray-casting scene of exactly ``V, F`` when several pictures of
        one mesh are made (its BVH is built once); default: built here.
    setting : {"indoor", "outdoor"} or None
        What drives the aging map's corrosion (None: indoor; see
        :func:`shellrepair.appearance.aging.aging_maps`).
    aging_field : shellrepair.appearance.aging.AgingField or None
        Read coverage, gilding and crust from this field at each shaded
        point (with ``coverage`` etc. given for the model choice): how a
        before | after pair shows one map on two meshes.  The aging map this
        function computes itself is always read so.

    Returns
    -------
    image : (H,W,3) numpy uint8 array

    Raises
    ------
    ValueError (shellrepair.errors.MeshError)
        For malformed V, F, filled or vertex_colors, an unknown material or
        unit, an age outside [0, 1] or an unknown setting.
    """
    import open3d as o3d

    from shellrepair.appearance import aging as ag

    t0 = time.perf_counter()
    V, F = _validate(V, F)
    mat = mt.get_material(material)
    if filled is not None:
        filled = np.asarray(filled, dtype=bool)
        if filled.shape != (len(F),):
            raise _InputError("filled must have one flag per face (%d), got shape %s"
                              % (len(F), filled.shape))
    if vertex_colors is not None:
        vertex_colors = np.asarray(vertex_colors)
        if vertex_colors.shape != (len(V), 3):
            raise _InputError("vertex_colors must be (%d,3), got shape %s"
                              % (len(V), vertex_colors.shape))
    if age is not None and not 0.0 <= float(age) <= 1.0:
        raise _InputError("age must be in [0, 1], got %r" % (age,))
    if setting is not None and setting not in ag.SETTINGS:
        raise _InputError("setting must be one of %s, got %r" % (", ".join(ag.SETTINGS), setting))
    ss = int(supersample)
    if ss < 1:
        raise _InputError("supersample must be >= 1, got %r" % (supersample,))
    um_per_unit, unit_name, unit_reason = _unit_um(unit_um if unit_um is not None else unit, V)
    cam = camera if camera is not None else frame_camera(V, size, view, up=up)
    cam_s = _scaled_camera(cam, ss)
    W, H = cam_s.width, cam_s.height

    if scene is None:
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)),
                            o3d.core.Tensor(F.astype(np.uint32)))
    rays_all = cam_s.rays()
    hit = scene.cast_rays(o3d.core.Tensor(rays_all))
    t_hit = hit["t_hit"].numpy().reshape(H, W)
    mask = np.isfinite(t_hit)
    image = np.broadcast_to(BACKGROUND, (H, W, 3)).copy()
    t1 = time.perf_counter()

    # rust coverage and gilding per vertex
    maps = None
    ones = np.ones(len(V))
    crust_v = np.zeros(len(V)) if crust is None else np.clip(np.asarray(crust, np.float64), 0.0, 1.0)
    if not mat.corrodes and coverage is None:
        cov_v, cov_src = np.zeros(len(V)), "none"
        gild_v = ones if gild is None else np.clip(np.asarray(gild, np.float64), 0.0, 1.0)
    elif coverage is not None:
        cov_v = np.clip(np.asarray(coverage, dtype=np.float64), 0.0, 1.0)
        if cov_v.shape != (len(V),):
            raise _InputError("coverage must have one value per vertex (%d), got shape %s"
                              % (len(V), cov_v.shape))
        gild_v = ones if gild is None else np.clip(np.asarray(gild, np.float64), 0.0, 1.0)
        cov_src = "given"
    else:
        cov_src = None
        if vertex_colors is not None:
            cov_v, cov_src = mt.rust_coverage(V, F, vertex_colors, colors_only=True)
            gild_v = ones
        if cov_src is None:
            maps = ag.aging_maps(V, F, age=ag.DEFAULT_AGE if age is None else float(age), up=up,
                                 seed=seed, scan=None if filled is None else ~filled, setting=setting)
            cov_v, gild_v, cov_src = maps.coverage, maps.gild, "aging"
            if crust is None:
                crust_v = maps.crust
    for name, arr in (("gild", gild_v), ("crust", crust_v)):
        if arr.shape != (len(V),):
            raise _InputError("%s must have one value per vertex (%d), got shape %s"
                              % (name, len(V), arr.shape))
    t2 = time.perf_counter()

    right, upv, back = cam_s.basis()
    radius = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) * 0.5 or 1.0
    dist_c = float(np.linalg.norm(cam.eye - cam.target))
    footprint_um = cam.footprint(dist_c) * um_per_unit  # of an output pixel
    choice = sd.choose_model(footprint_um, mat, coverage=float(cov_v.max()) if len(cov_v) else 0.0)

    if np.any(mask):
        pid = hit["primitive_ids"].numpy().reshape(H, W)[mask].astype(np.int64)
        uv = hit["primitive_uvs"].numpy().reshape(H, W, 2)[mask].astype(np.float64)
        rays = rays_all[mask].astype(np.float64)
        d = rays[:, 3:]
        p = rays[:, :3] + t_hit[mask][:, None].astype(np.float64) * d
        tri = F[pid]
        bw = np.stack([1.0 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]], axis=1)
        Nv = mt.vertex_normals(V, F)
        n = np.einsum("pk,pkj->pj", bw, Nv[tri])
        ng = np.cross(V[tri[:, 1]] - V[tri[:, 0]], V[tri[:, 2]] - V[tri[:, 0]])
        ngl = np.linalg.norm(ng, axis=1, keepdims=True)
        ng = np.where(ngl > 0, ng / np.where(ngl > 0, ngl, 1.0), -d)
        nl = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.where(nl > 1e-12, n / np.where(nl > 1e-12, nl, 1.0), ng)
        wo = -d
        # two-sided: scans are not always consistently oriented
        flip_g = np.einsum("ij,ij->i", ng, wo) < 0.0
        ng[flip_g] *= -1.0
        n = np.where((np.einsum("ij,ij->i", n, ng) < 0.0)[:, None], -n, n)
        # keep the shading normal facing the viewer (avoid black silhouettes)
        ndo = np.einsum("ij,ij->i", n, wo)
        n = np.where((ndo < 0.02)[:, None], ng, n)
        p_smooth, origin = _smooth_points(p, bw, V[tri], Nv[tri], ng)
        field = aging_field if aging_field is not None else (maps.field if maps is not None else None)
        if field is not None:
            # the map read at the shaded point of the smooth surface (soft
            # patch edges at any mesh resolution), not its vertex values
            # interpolated over a triangle
            c, g, dk = field.at(p_smooth, normals=n)
            if aging_field is None and crust is not None:  # a crust given with our own map
                dk = np.einsum("pk,pk->p", bw, crust_v[tri])
        else:
            c = np.einsum("pk,pk->p", bw, cov_v[tri])
            g = np.einsum("pk,pk->p", bw, gild_v[tri])
            dk = np.einsum("pk,pk->p", bw, crust_v[tri])
        shader = sd.MaterialShader(mat)
        origin = origin + (_SHADOW_EPS * radius) * ng
        spec_sum = np.zeros((len(p), 3))
        diff_sum = np.zeros((len(p), 3))
        for ldir_cam, E in _LIGHTS:
            ldir = ldir_cam[0] * right + ldir_cam[1] * upv + ldir_cam[2] * back
            ldir = ldir / np.linalg.norm(ldir)
            cos_i = n @ ldir
            lit = (cos_i > 0.0) & (ng @ ldir > -0.05)
            seen = _light_visibility(scene, origin[lit], ldir, mask, lit)
            vis = lit.copy()
            vis[lit] = seen > 0.0
            cos_i = cos_i.copy()
            cos_i[lit] *= seen  # the visible fraction of the area light
            if not np.any(vis):
                continue
            spec, diff = shader(ldir, wo[vis], n[vis], c[vis], g[vis], dk[vis], parts=True)
            w = (cos_i[vis])[:, None] * E
            spec_sum[vis] += spec * w
            diff_sum[vis] += diff * w
        # environment: metals mirror the room, the patina sees it diffusely
        no = np.clip(np.einsum("ij,ij->i", n, wo), 0.0, 1.0)
        refl = 2.0 * no[:, None] * n - wo
        env_spec, env_diff = shader.ambient(no, c, g, dk)
        key = _LIGHTS[0][0]
        key = key[0] * right + key[1] * upv + key[2] * back
        spec_sum += env_spec * _environment(refl, cam.up, key / np.linalg.norm(key))
        diff_sum += env_diff * _environment(n, cam.up)
        if choice.model == "dipole":
            dimg = np.zeros((H, W, 3))
            dimg[mask] = diff_sum
            diff_sum = _dipole_spread(dimg, mask, choice, mat, footprint_um / ss)[mask]
        rgb = _EXPOSURE * (spec_sum + diff_sum)
        if highlight_filled and filled is not None:
            fsel = filled[pid]
            rgb[fsel] = (1.0 - FILLED_TINT_WEIGHT) * rgb[fsel] + FILLED_TINT_WEIGHT * FILLED_TINT * (
                0.35 + 0.65 * no[fsel, None])
        image[mask] = _srgb(rgb)
    image = downsample(image, ss)
    if legend:
        image = draw_legend(image, legend, FILLED_TINT if highlight_filled else None)
    t3 = time.perf_counter()
    if info is not None:
        info.update(camera=cam, model=choice, coverage_source=cov_src, unit=unit_name,
                    unit_reason=unit_reason, footprint_um=footprint_um, maps=maps,
                    seconds={"cast": t1 - t0, "coverage": t2 - t1, "shade": t3 - t2,
                             "total": t3 - t0},
                    hit_pixels=int(mask.sum()) // (ss * ss), supersample=ss)
    return image


# --------------------------------------------------------------------------
# Text on images
# --------------------------------------------------------------------------

#: Text colour (sRGB) and the shade behind it.
_TEXT = (235, 235, 235)
_TEXT_SHADE = (20, 21, 24)


def _font(px):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=px)  # Pillow >= 10.1: a scalable font
    except TypeError:  # pragma: no cover - older Pillow: the fixed bitmap font
        return ImageFont.load_default()


def _text_px(image):
    return int(np.clip(round(image.shape[0] / 22), 10, 40))


def _text_box(image, text):
    """What drawing ``text`` on ``image`` needs: a Pillow image and its
    drawing context, the font, its pixel size, the padding, and the text's
    box ``(x0, y0, width, height)``."""
    from PIL import Image, ImageDraw

    im = Image.fromarray(np.ascontiguousarray(image), "RGB")
    dr = ImageDraw.Draw(im)
    px = _text_px(image)
    font = _font(px)
    x0, y0, x1, y1 = dr.textbbox((0, 0), text, font=font)
    return im, dr, font, px, max(2, px // 3), (x0, y0, x1 - x0, y1 - y0)


def draw_label(image, text, *, where="top-left"):
    """Write a short label on an image (on a dark box), returning a new image.

    Parameters
    ----------
    image : (H,W,3) uint8 array
    text : str
    where : {"top-left", "bottom-left"}

    Returns
    -------
    image : (H,W,3) uint8 array
    """
    im, dr, font, px, pad, (x0, y0, w, h) = _text_box(image, text)
    x = pad
    y = pad if where == "top-left" else image.shape[0] - h - 3 * pad
    dr.rectangle([x - pad // 2, y - pad // 2, x + w + pad, y + h + pad + y0], fill=_TEXT_SHADE)
    dr.text((x - x0 + pad // 4, y), text, fill=_TEXT, font=font)
    return np.asarray(im).copy()


def draw_legend(image, text, swatch=None):
    """A legend at the bottom-left: a colour swatch (linear RGB) and its meaning.

    Parameters
    ----------
    image : (H,W,3) uint8 array
    text : str
    swatch : (3,) float array (linear RGB) or None

    Returns
    -------
    image : (H,W,3) uint8 array
    """
    im, dr, font, px, pad, (x0, y0, w, h) = _text_box(image, text)
    sw = px if swatch is not None else 0
    y = image.shape[0] - h - 3 * pad
    dr.rectangle([pad // 2, y - pad // 2, pad + sw + pad + w + pad, y + h + pad + y0], fill=_TEXT_SHADE)
    if swatch is not None:
        col = tuple(int(v) for v in _linear_to_srgb8(np.asarray(swatch, np.float64)))
        dr.rectangle([pad, y + y0, pad + sw, y + y0 + h], fill=col)
    dr.text((pad + sw + pad - x0, y), text, fill=_TEXT, font=font)
    return np.asarray(im).copy()


def render_side_by_side(V_before, F_before, V_after, F_after, *, size=(1024, 768),
                        material="aged-bronze", filled=None, highlight_filled=False, view=None,
                        vertex_colors_before=None, vertex_colors_after=None, gap=8,
                        unit=None, unit_um=None, age=None, up=(0.0, 1.0, 0.0), seed=0,
                        supersample=2, labels=("before", "after"), legend="filled by the repair",
                        info=None, camera=None, maps=None, scenes=(None, None), setting=None):
    """Before and after renders with one shared camera, side by side.

    Parameters
    ----------
    V_before, F_before : arrays
        The scan as read.
    V_after, F_after : arrays
        The repaired mesh.
    size : (int, int)
        Size (width, height) of each panel.
    filled : (m_after,) bool array or None
        Filled faces of the repaired mesh.
    highlight_filled : bool
        Tint the filled faces in the right panel (a legend says so).
    gap : int
        Pixels of background between the panels.
    labels : (str, str) or None
        Written at the top-left of each panel.
    legend : str or None
        With ``highlight_filled``, the meaning of the tint, written next to a
        swatch of it at the bottom-left of the right panel.
    info : dict or None
        Filled with ``{"before": {...}, "after": {...}}`` as in
        :func:`render_mesh`.
    camera : Camera or None
        Use this camera for both panels (``size`` and ``view`` are then
        ignored); default: framed on both meshes.
    maps : shellrepair.appearance.aging.AgingMaps or None
        The aging maps of the repaired mesh, when already computed (several
        pictures of one repair); default: computed here.
    scenes : (scene, scene)
        The ray-casting scenes of the scan and of the repaired mesh, when
        already built (see :func:`render_mesh`); default: built here.
    Other parameters are as in :func:`render_mesh`.

    Returns
    -------
    image : (H, 2W + gap, 3) numpy uint8 array

    Notes
    -----
    Both panels use one camera, framed on both meshes, one unit (inferred
    from the repaired mesh when not given) and one aging map: it is computed
    on the repaired mesh and each vertex of the scan takes the values of the
    nearest repaired vertex (the original vertices are kept by the repair, so
    these are the same points), so the two panels differ only where the
    repair added surface.
    """
    from scipy.spatial import cKDTree

    from shellrepair.appearance import aging as ag

    Vb, Fb = _validate(V_before, F_before)
    Va, Fa = _validate(V_after, F_after)
    cam = camera if camera is not None else frame_camera(np.concatenate([Vb, Va]), size, view, up=up)
    um, _, _ = _unit_um(unit_um if unit_um is not None else unit, Va)
    mat = mt.get_material(material)
    cov = {"before": None, "after": None}
    gld = {"before": None, "after": None}
    crs = {"before": None, "after": None}
    field = None
    if mat.corrodes and vertex_colors_before is None and vertex_colors_after is None:
        scan = None
        if filled is not None and np.shape(filled) == (len(Fa),):
            scan = ~np.asarray(filled, bool)
        if maps is None:
            maps = ag.aging_maps(Va, Fa, age=ag.DEFAULT_AGE if age is None else float(age), up=up, seed=seed,
                                 scan=scan, setting=setting)
        field = maps.field
        if len(Va) >= len(Vb) and np.array_equal(Va[:len(Vb)], Vb):
            near = np.arange(len(Vb))       # a repair keeps the scan's vertices first: the same points
        else:
            _, near = cKDTree(Va).query(Vb)
        cov = {"before": maps.coverage[near], "after": maps.coverage}
        gld = {"before": maps.gild[near], "after": maps.gild}
        crs = {"before": maps.crust[near], "after": maps.crust}
    if not (highlight_filled and filled is not None and np.any(filled)):
        legend = None
    panels = {}
    common = dict(material=material, camera=cam, unit=um, age=age, up=up, seed=seed,
                  supersample=supersample)
    for key, (V, F, vc, fl, hl, lg, sc) in {
            "before": (Vb, Fb, vertex_colors_before, None, False, None, scenes[0]),
            "after": (Va, Fa, vertex_colors_after, filled, highlight_filled, legend, scenes[1])}.items():
        sub = {}
        img = render_mesh(V, F, vertex_colors=vc, filled=fl, highlight_filled=hl, coverage=cov[key],
                          gild=gld[key], crust=crs[key], legend=lg, info=sub, scene=sc, aging_field=field,
                          **common)
        if labels:
            img = draw_label(img, labels[0] if key == "before" else labels[1])
        panels[key] = img
        if info is not None:
            info[key] = sub
    sep = np.broadcast_to(BACKGROUND, (cam.height, int(gap), 3))
    return np.concatenate([panels["before"], sep, panels["after"]], axis=1)


#: Image formats by file extension (Pillow's names).
IMAGE_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".tif": "TIFF", ".tiff": "TIFF"}


def image_format(path):
    """Pillow's format name for an image path, from its extension.

    Raises
    ------
    MeshError
        For an extension that is not PNG, JPEG or TIFF.
    """
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in IMAGE_FORMATS:
        raise _InputError("unknown image extension '%s' (expected one of %s)"
                          % (ext, ", ".join(sorted(IMAGE_FORMATS))))
    return IMAGE_FORMATS[ext]


def save_image(path, image):
    """Write an RGB image atomically, in the format its extension names
    (PNG, JPEG at quality 92, TIFF).

    Parameters
    ----------
    path : str or os.PathLike
    image : (H,W,3) numpy uint8 array

    Notes
    -----
    The image is encoded in memory and written by the package's one atomic
    write (:func:`shellrepair.files.atomic_write`: a temporary file in the
    target folder, renamed into place), so a failure leaves no partial file.

    Raises
    ------
    ValueError
        If image is not (H,W,3) uint8, or the extension is unknown.
    OSError
        If the folder does not exist or is not writable.
    """
    import io

    from PIL import Image

    from shellrepair.files import atomic_write

    fmt = image_format(path)
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError("image must be an (H,W,3) uint8 array, got %s %s" % (img.shape, img.dtype))
    buf = io.BytesIO()
    kw = {"quality": 92} if fmt == "JPEG" else {}
    Image.fromarray(img, "RGB").save(buf, format=fmt, **kw)
    atomic_write(path, buf.getvalue(), os_errors=True)


def save_png(path, image):
    """Write an RGB image (the format from the extension; see :func:`save_image`)."""
    save_image(path, image)