"""Where a gilt-bronze statue corrodes and where its gilding survives.

A map per vertex from the causes of aging, after Dorsey & Hanrahan (1996),
who grow, erode and polish patina layers according to how exposed and how
accessible each point of the surface is:

- **exposure** e: upward-facing surface open to the sky takes rain and
  deposits (wet-dry cycles; rain-washed outdoor bronze turns to green
  basic sulphates, Graedel 1987);
- **cavity** k: concave places hold moisture and dirt and corrode first
  (Dorsey & Hanrahan's accessibility; Miller 1994);
- **wear** w: convex edges are rubbed: the gilding goes first and the bronze
  under it is polished free of corrosion;
- **blotch** z: corrosion spreads in patches (pits, drips, local alloy and
  gilding defects), modelled as seeded value noise sampled on the surface.

Where rain does not wash the patina -- under overhangs, in cavities -- soot
and sulphate deposits build a dark crust (Graedel 1987; Scott 2002):
``crust = clip(D_K k + D_S (1 - sky) max(n.up, 0) + D_Z z'' - D_0, 0, 1)``,
mixed into the green layer by the paper's eq 7
(:data:`shellrepair.appearance.materials.DARK_CRUST`).

Outdoors (``setting="outdoor"``) they combine into a corrosion potential
``P = A_E e + A_K k - A_W w + A_Z z``
and a gilding-loss potential ``Q = B_W w + B_E e + B_Z z'``.  The ``age`` in
[0, 1] sets how much area has turned: the rust coverage c is 1 on the
fraction ``age`` of the area where P is highest and falls smoothly to 0
across a band of :data:`AgingParams.band` of the area around it (there the
patina is thin and shows cuprite); of the area left uncorroded, the
fraction ``LOSS * age`` where Q is highest has lost its gilding (bare
bronze), and the rest, the sheltered and unworn part, keeps its gold.
Thresholds are area-weighted quantiles, so the fractions hold on any mesh
resolution.

Indoors (the default: a temple or museum statue, as the paper's
Buddhas) no rain comes: dust, moisture and corrosion products collect in
recesses and folds while raised, touched places keep their gold, so the
**occlusion** o (the fraction of hemisphere rays that hit the scan,
:func:`ambient_occlusion`; Miller 1994's accessibility) and the broad
convexity take the place of exposure (:class:`AgingParams`, ``setting``).

All measures are computed on a regular grid around the object (cell size a
fraction of its bounding diagonal), so they depend on the shape at the
stated scales, not on the mesh's resolution, and cost O(n) with a small
constant: splat face samples (area-weighted positions and normals) into
their cells, blur (``scipy.ndimage.gaussian_filter``), read back at the
vertices trilinearly.

References
----------
.. [1] J. Dorsey and P. Hanrahan, "Modeling and Rendering of Metallic
   Patinas", SIGGRAPH 1996, 387-396.
.. [2] G. Miller, "Efficient Algorithms for Local and Global Accessibility
   Shading", SIGGRAPH 1994.
.. [3] T. E. Graedel, "Copper patinas formed in the atmosphere - II. A
   qualitative assessment of mechanisms", Corrosion Science 27(7), 1987.
.. [4] D. A. Scott, Copper and Bronze in Art: Corrosion, Colorants,
   Conservation, Getty Publications, 2002 (cuprite next to the metal, basic
   copper salts above it; sheltered vs rain-washed surfaces).
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["AgingParams", "AgingMaps", "aging_maps", "value_noise", "ambient_occlusion", "recess_ratio",
           "AgingField",
           "SETTINGS", "DEFAULT_AGE"]

#: Age of the default render: half the area corroded.
DEFAULT_AGE = 0.5
#: Where the statue stands, which decides what corrodes it (see AgingParams).
SETTINGS = ("indoor", "outdoor")


@dataclasses.dataclass(frozen=True)
class AgingParams:
    """Parameters of :func:`aging_maps` (lengths as fractions of the bounding diagonal).

    Attributes
    ----------
    edge_scale : float
        Scale of the convexity that decides wear (0.015; sensible 0.005-0.03):
        features narrower than a few times this are "edges".
    cavity_scale : float
        Scale of the concavity that decides cavities (0.05; 0.03-0.1).
    patch_scale : float
        Wavelength of the coarsest blotch octave (0.12; 0.05-0.3).
    octaves : int
        Octaves of value noise (3), each half the wavelength and amplitude.
    wear_start, wear_full : float
        Convexity at the edge scale at which wear starts and is complete
        (0.30, 0.70).  On a sphere of radius R >> s the convexity at scale
        s is 1.25 s / R (measured, tests/test_aging.py), so wear starts on
        curvature radii below ~4 edge scales and is complete below ~1.8.
    cavity_full : float
        Concavity (minus the convexity, at the edge or the cavity scale) at
        which a cavity holds water fully (0.15; 0.05-0.3): a hollow of
        radius ~9 scales.
    a_exposure, a_cavity, a_wear, a_blotch : float
        Weights of the corrosion potential (1, 1, 1, 0.35).  The blotch
        weight multiplies unit-variance noise; 0.2-0.6 gives patches from
        coherent to scattered.
    b_wear, b_exposure, b_blotch : float
        Weights of the gilding-loss potential (1.5, 0.7, 0.35).
    loss : float
        Fraction of the uncorroded area that has lost its gilding at age 1
        (0.5; 0-1).
    band : float
        Area fraction of the transition from bare to fully corroded, where
        the patina is thin and cuprite shows (0.2; 0.02-0.3).
    d_cavity, d_shelter, d_blotch, d_offset : float
        Dark crust outdoors ``clip(d_cavity k + d_shelter (1 - sky) max(n.up, 0)
        + d_blotch z'' - d_offset, 0, 1)`` (0.8, 0.6, 0.3, 0.3): cavities
        and upward surfaces under an overhang are not washed by rain; z''
        breaks it into patches.  0 everywhere with all weights 0.
    setting : {"indoor", "outdoor"}
        What drives the corrosion ("indoor").  Indoors (a temple or museum
        statue) dust, moisture and corrosion products collect where the air
        is still -- recesses, folds, under overhangs, measured by the
        occlusion o -- while raised, touched places keep their gold:
        ``P = a_occlusion o + a_cavity k - a_wear w - a_raised r
        + a_blotch_indoor z`` with r the convexity at the cavity scale over
        ``raised_full`` (clipped to [0, 1]); gilding is lost by
        ``Q = b_occlusion o + b_blotch z' - b_wear w`` and the dark deposit is
        ``clip(d_cavity k + d_occlusion o + d_blotch z'' - d_offset, 0, 1)``.
        Outdoors rain decides, as described above.
    a_occlusion, a_raised, a_blotch_indoor : float
        Indoor weights of the corrosion potential (3, 2.5, 0.2): the noise
        only moves the patches' edges, it does not make them.
    raised_full : float
        Convexity at the cavity scale at which a bulge counts as fully
        raised (0.3: a sphere of radius ~4 cavity scales).
    b_occlusion, d_occlusion : float
        Indoor weights of occlusion in gilding loss (1) and dark deposit (2.5).
    occlusion_rays : int
        Hemisphere rays per vertex for the occlusion (64; fewer on large
        scans, so that about ``occlusion_ray_budget`` rays are cast in all,
        but at least 16 per vertex: beyond ``budget / 16`` vertices a
        subset of them, hashed from the index and the seed, casts rays).
    occlusion_ray_budget : int
        Rays cast in all (2**21; about 1 s on one core).
    occlusion_reach : float or None
        Rays hitting farther than this fraction of the diagonal do not count
        (0.2: a recess is a local thing; None counts any hit).
    occlusion_scale : float
        Width of the Gaussian the occlusion is blurred with (0.015 of the
        diagonal), so it is as smooth on a coarse mesh as on a dense one.
    """

    edge_scale: float = 0.015
    cavity_scale: float = 0.05
    patch_scale: float = 0.12
    octaves: int = 3
    wear_start: float = 0.30
    wear_full: float = 0.70
    cavity_full: float = 0.15
    a_exposure: float = 1.0
    a_cavity: float = 1.0
    a_wear: float = 1.0
    a_blotch: float = 0.35
    b_wear: float = 1.5
    b_exposure: float = 0.7
    b_blotch: float = 0.35
    loss: float = 0.5
    band: float = 0.2
    d_cavity: float = 0.8
    d_shelter: float = 0.6
    d_blotch: float = 0.3
    d_offset: float = 0.3
    setting: str = "indoor"
    a_occlusion: float = 3.0
    b_occlusion: float = 1.0
    d_occlusion: float = 2.5
    occlusion_rays: int = 64
    occlusion_reach: float = 0.2
    occlusion_ray_budget: int = 1 << 21
    occlusion_scale: float = 0.015
    a_raised: float = 2.5
    a_blotch_indoor: float = 0.2
    raised_full: float = 0.3


@dataclasses.dataclass(frozen=True)
class AgingMaps:
    """Per-vertex aging state and the causes it came from.

    Attributes
    ----------
    coverage : (n,) float64 array in [0, 1]
        Rust coverage (area fraction corroded; also sets the patina
        thickness, :func:`shellrepair.appearance.materials.layer_thicknesses`).
    gild : (n,) float64 array in [0, 1]
        Fraction of the uncorroded area still gilded.
    exposure, cavity, wear : (n,) float64 arrays in [0, 1]
    blotch : (n,) float64 array
        Unit-variance noise of the corrosion potential.
    convexity_edge, convexity_cavity : (n,) float64 arrays
        The convexity kappa at the edge and cavity scales (see
        :func:`aging_maps`), positive where convex.
    crust : (n,) float64 array in [0, 1]
        Dark deposit on the patina where rain does not wash it (outdoors),
        or in still, occluded places (indoors).
    occlusion : (n,) float64 array in [0, 1]
        The blurred ambient occlusion of the scan's own faces (indoors; 0
        outdoors).
    field : AgingField or None
        The same map, readable at any point of the surface (None for an
        empty or degenerate mesh).
    """

    coverage: np.ndarray
    gild: np.ndarray
    exposure: np.ndarray
    cavity: np.ndarray
    wear: np.ndarray
    blotch: np.ndarray
    convexity_edge: np.ndarray
    convexity_cavity: np.ndarray
    crust: np.ndarray
    occlusion: np.ndarray = None
    field: "AgingField" = None


# --------------------------------------------------------------------------
# Value noise
# --------------------------------------------------------------------------

_M1 = np.uint64(0x9E3779B185EBCA87)
_M2 = np.uint64(0xC2B2AE3D27D4EB4F)
_M3 = np.uint64(0x165667B19E3779F9)
_MIX1 = np.uint64(0xFF51AFD7ED558CCD)
_MIX2 = np.uint64(0xC4CEB9FE1A85EC53)


def _hash01(ix, iy, iz, seed):
    """Deterministic hash of integer lattice points to [0, 1)."""
    with np.errstate(over="ignore"):
        h = (ix.astype(np.uint64) * _M1) ^ (iy.astype(np.uint64) * _M2) ^ (iz.astype(np.uint64) * _M3)
        h ^= np.uint64(seed & 0xFFFFFFFF) * _MIX2
        h ^= h >> np.uint64(33)
        h *= _MIX1
        h ^= h >> np.uint64(33)
        h *= _MIX2
        h ^= h >> np.uint64(33)
    return (h >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def value_noise(P, wavelength, *, seed=0, octaves=3, normalize=True):
    """Seeded fractal value noise at points, zero mean and unit variance.

    Parameters
    ----------
    P : (n,3) float array
        Points (e.g. vertices): the noise is a solid texture sampled on the
        surface, so it does not depend on the mesh's parametrisation.
    wavelength : float
        Lattice spacing of the coarsest octave (world units), > 0.
    seed : int, optional
    octaves : int, optional
        Each further octave has half the wavelength and half the amplitude.
    normalize : bool, optional
        Shift and scale to mean 0 and variance 1 over the points given.

    Returns
    -------
    z : (n,) float64 array
        Deterministic for a given seed: lattice values are a hash of the
        integer lattice point and the seed, blended with smoothstep weights.
    """
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError("value_noise: points must be (n,3), got shape %s" % (P.shape,))
    if not wavelength > 0.0:
        raise ValueError("value_noise: wavelength must be > 0, got %r" % (wavelength,))
    out = np.zeros(len(P))
    rng = np.random.default_rng(seed)
    amp = 1.0
    for o in range(int(octaves)):
        q = P / (wavelength * 0.5 ** o) + rng.uniform(0.0, 1000.0, 3)  # decorrelate octaves
        i0 = np.floor(q)
        f = q - i0
        s = f * f * (3.0 - 2.0 * f)  # smoothstep blend
        i0 = i0.astype(np.int64)
        lo = i0.min(axis=0)
        ext = i0.max(axis=0) - lo + 2
        if np.prod(ext.astype(np.float64)) <= 4 * len(P) + 64:
            # hash each lattice point of the box once, then gather
            ax = [lo[k] + np.arange(ext[k]) for k in range(3)]
            X, Y, Z = np.meshgrid(*ax, indexing="ij")
            lat = _hash01(X.ravel(), Y.ravel(), Z.ravel(), seed * 131 + o)
            base = ((i0[:, 0] - lo[0]) * ext[1] + (i0[:, 1] - lo[1])) * ext[2] + (i0[:, 2] - lo[2])

            def corner(dx, dy, dz):
                return lat[base + (dx * ext[1] + dy) * ext[2] + dz]
        else:
            def corner(dx, dy, dz):
                return _hash01(i0[:, 0] + dx, i0[:, 1] + dy, i0[:, 2] + dz, seed * 131 + o)
        acc = 0.0
        for dx in (0, 1):
            wx = s[:, 0] if dx else 1.0 - s[:, 0]
            for dy in (0, 1):
                wy = s[:, 1] if dy else 1.0 - s[:, 1]
                for dz in (0, 1):
                    wz = s[:, 2] if dz else 1.0 - s[:, 2]
                    acc = acc + wx * wy * wz * corner(dx, dy, dz)
        out += amp * acc
        amp *= 0.5
    if len(out) == 0 or not normalize:
        return out
    out -= out.mean()
    sd = out.std()
    return out / sd if sd > 0.0 else out


# --------------------------------------------------------------------------
# Ambient occlusion
# --------------------------------------------------------------------------

#: Offset of an occlusion ray's origin along the normal, as a fraction of the
#: bounding diagonal (lifts it off its own face at float32 precision).
AO_EPS = 1e-4


def _hemisphere(rays):
    """``rays`` directions spread evenly over the hemisphere about +z (a
    Fibonacci spiral: equal solid angle per ray, uniform in cos theta)."""
    i = np.arange(rays, dtype=np.float64) + 0.5
    z = 1.0 - i / rays
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _occluded_fraction(scene, X, N, keys, rays, seed, eps, max_distance, chunk=1 << 20):
    """Fraction of ``rays`` hemisphere rays about N from X + eps N that hit ``scene``.

    Each point turns the spiral about its normal by an angle hashed from its
    integer key (q, 3) and the seed (so neighbouring points do not share the spiral's
    pattern, and a point's rays do not depend on the other points).
    """
    import open3d as o3d

    H = _hemisphere(rays)
    out = np.zeros(len(X))
    per = max(1, chunk // rays)
    for s in range(0, len(X), per):
        x, n = X[s:s + per], N[s:s + per]
        k = keys[s:s + per]
        ref = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        t1 = np.cross(n, ref)
        t1 /= np.maximum(np.linalg.norm(t1, axis=1, keepdims=True), 1e-300)
        t2 = np.cross(n, t1)
        ang = 2.0 * np.pi * _hash01(k[:, 0], k[:, 1], k[:, 2], seed)
        c, si = np.cos(ang)[:, None], np.sin(ang)[:, None]
        a, b = c * t1 + si * t2, c * t2 - si * t1   # the tangent frame turned by ang
        D = (H[None, :, 0, None] * a[:, None, :] + H[None, :, 1, None] * b[:, None, :]
             + H[None, :, 2, None] * n[:, None, :])
        O = np.broadcast_to((x + eps * n)[:, None, :], D.shape)
        R = np.concatenate([O, D], axis=2).reshape(-1, 6).astype(np.float32)
        hit = scene.test_occlusions(o3d.core.Tensor(R), tfar=float(max_distance)).numpy()
        out[s:s + per] = hit.reshape(len(x), rays).mean(axis=1)
    return out


def _scene(V, F):
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.ascontiguousarray(V, dtype=np.float32)),
                        o3d.core.Tensor(np.ascontiguousarray(F, dtype=np.uint32)))
    return scene


def _mesh_arrays(V, F, who):
    """``V`` (n,3) float64 and ``F`` (m,3) int64, or one ValueError naming
    ``who`` (a shape that is not a triangle mesh, a face outside the vertices)."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise ValueError("%s: V must be (n,3) and F (m,3), got %s and %s" % (who, V.shape, F.shape))
    if len(F) and (F.min() < 0 or F.max() >= len(V)):
        bad = int(np.argmax((F < 0).any(axis=1) | (F >= len(V)).any(axis=1)))
        raise ValueError("%s: face %d refers to a vertex outside 0..%d" % (who, bad, len(V) - 1))
    return V, F


def ambient_occlusion(V, F, *, rays=64, seed=0, max_distance=None):
    """Fraction of hemisphere rays per vertex that hit the mesh.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    rays : int, optional
        Rays per vertex (64), spread evenly over the hemisphere about the
        vertex's area-weighted normal (equal solid angle each), the spiral
        turned about the normal by an angle hashed from the vertex index and
        the seed.
    seed : int, optional
    max_distance : float or None, optional
        Rays hitting farther than this do not count (None: any hit counts).

    Returns
    -------
    ao : (n,) float64 array in [0, 1]
        0 where the whole hemisphere is open (a convex solid), about 0.5 at
        the bottom of a right-angled crease, near 1 deep in a hollow;
        deterministic (the same V, F, rays and seed give the same bytes).
        Vertices no face uses get 0.

    Notes
    -----
    Origins are lifted ``AO_EPS`` x the bounding diagonal along the normal, so
    a ray does not hit the faces around its own vertex.  The normal is the
    mesh's own orientation: an inward-wound mesh is seen from inside.
    """
    from shellrepair.appearance.coverage import vertex_normals

    V, F = _mesh_arrays(V, F, "ambient_occlusion")
    if int(rays) < 1:
        raise ValueError("ambient_occlusion: rays must be >= 1, got %r" % (rays,))
    ao = np.zeros(len(V))
    used = np.zeros(len(V), bool)
    used[F.ravel()] = True
    if not used.any():
        return ao
    diag = float(np.linalg.norm(V[used].max(axis=0) - V[used].min(axis=0)))
    N = vertex_normals(V, F)
    idx = np.flatnonzero(used)
    keys = np.stack([idx, np.zeros_like(idx), np.ones_like(idx)], axis=1).astype(np.int64)
    ao[idx] = _occluded_fraction(_scene(V, F), V[idx], N[idx], keys, int(rays), seed,
                                 AO_EPS * diag, np.inf if max_distance is None else max_distance)
    return ao


def recess_ratio(ao, coverage, *, tenth=0.1):
    """Mean coverage of the most occluded tenth of the vertices over that of the least occluded tenth.

    Parameters
    ----------
    ao : (n,) float array
        Ambient occlusion per vertex (:func:`ambient_occlusion`).
    coverage : (n,) float array
        Rust coverage per vertex.
    tenth : float, optional
        The fraction at each end (0.1).

    Returns
    -------
    ratio : float
        >= 2 where the patina gathers in recesses (the issue's bar); inf when
        the least occluded tenth is bare and the most occluded is not, nan
        when both are bare.  Vertices tied with the tenth's last one are all
        counted in (a convex region often has many at 0), so the ratio does
        not depend on the vertices' order.
    """
    ao = np.asarray(ao, dtype=np.float64)
    coverage = np.asarray(coverage, dtype=np.float64)
    if ao.shape != coverage.shape or ao.ndim != 1:
        raise ValueError("recess_ratio: ao and coverage must be (n,) arrays of one length, got %s and %s"
                         % (ao.shape, coverage.shape))
    k = max(1, int(round(tenth * len(ao))))
    if len(ao) < 2 * k:
        raise ValueError("recess_ratio: need at least %d vertices, got %d" % (2 * k, len(ao)))
    srt = np.sort(ao)
    low = coverage[ao <= srt[k - 1]].mean()
    high = coverage[ao >= srt[-k]].mean()
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.float64(high) / np.float64(low))


# --------------------------------------------------------------------------
# The grid
# --------------------------------------------------------------------------


class _Grid:
    """A regular grid over points: nearest-cell splatting, trilinear reading."""

    def __init__(self, P, h, pad=4, anchor=None):
        self.h = float(h)
        self.lo = P.min(axis=0) - pad * self.h
        if anchor is not None:
            # nodes on the lattice through anchor - pad h, extended by whole
            # cells to hold every point: points added beyond the anchor's
            # box (a fill) do not move the nodes
            base = np.asarray(anchor, np.float64) - pad * self.h
            self.lo = base - self.h * np.ceil(np.maximum(base - self.lo, 0.0) / self.h)
        self.shape = tuple(int(x) for x in np.ceil((P.max(axis=0) + pad * self.h - self.lo) / self.h) + 1)
        self.size = int(np.prod(self.shape))
        self.n = len(P)
        self.idx, self.w = self.corners(P)

    def corners(self, X):
        """Linear indices and trilinear weights (8 of each) of the nodes around points X (q, 3)."""
        nx, ny, nz = self.shape
        g = (X - self.lo) / self.h
        i0 = np.clip(np.floor(g).astype(np.int64), 0, np.array(self.shape) - 2)
        f = np.clip(g - i0, 0.0, 1.0)
        idx, w = [], []  # float32 weights: the fields read are smooth, 7 digits are plenty
        for dx in (0, 1):
            for dy in (0, 1):
                for dz in (0, 1):
                    idx.append(((i0[:, 0] + dx) * ny + (i0[:, 1] + dy)) * nz + (i0[:, 2] + dz))
                    w.append(((f[:, 0] if dx else 1.0 - f[:, 0]) * (f[:, 1] if dy else 1.0 - f[:, 1])
                              * (f[:, 2] if dz else 1.0 - f[:, 2])).astype(np.float32))
        return idx, w

    def nodes(self):
        """Coordinates (size, 3) of the grid nodes."""
        axes = [self.lo[k] + self.h * np.arange(self.shape[k]) for k in range(3)]
        X, Y, Z = np.meshgrid(*axes, indexing="ij")
        return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)

    def splat(self, Q, values):
        """Sum values (q, k) at points Q (q, 3) into their nearest cells: (k, nx, ny, nz)."""
        values = np.asarray(values, dtype=np.float64).reshape(len(Q), -1)
        near = np.clip(np.rint((Q - self.lo) / self.h).astype(np.int64), 0, np.array(self.shape) - 1)
        idx = (near[:, 0] * self.shape[1] + near[:, 1]) * self.shape[2] + near[:, 2]
        return np.stack([np.bincount(idx, values[:, j], minlength=self.size).reshape(self.shape)
                         for j in range(values.shape[1])])

    def read(self, G, X=None):
        """Trilinear read of grid arrays (k, nx, ny, nz) -> (q, k) at points X (default: the grid's own)."""
        idx, ws = (self.idx, self.w) if X is None else self.corners(X)
        G = np.asarray(G)
        flat = np.ascontiguousarray(G.reshape(G.shape[0] if G.ndim == 4 else 1, -1).T)  # (size, k)
        out = np.zeros((len(idx[0]), flat.shape[1]), dtype=flat.dtype)
        for i, w in zip(idx, ws):
            out += w[:, None] * np.take(flat, i, axis=0)
        return out


def _surface_samples(P, F, h, cr):
    """Points sampling every face at least once per cell: (Q, area weights, area-weighted normals,
    face index, barycentric coordinates).

    A face whose longest edge is up to ``k h`` long is cut into k^2 similar
    triangles and sampled at their centroids, so a coarse mesh and a dense
    one of the same shape splat the same surface (a scan's faces are far
    below a cell: one sample, its centroid, per face).
    """
    A, B, C = P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]
    area = 0.5 * np.sqrt(np.einsum("ij,ij->i", cr, cr))
    d = B - A
    l2 = np.einsum("ij,ij->i", d, d)
    d = C - B
    np.maximum(l2, np.einsum("ij,ij->i", d, d), out=l2)
    d = A - C
    np.maximum(l2, np.einsum("ij,ij->i", d, d), out=l2)
    k = np.clip(np.ceil(np.sqrt(l2) / h), 1, 32).astype(np.int64)
    one = k == 1
    Qs = [(A[one] + B[one] + C[one]) * (1.0 / 3.0)]  # the usual case: one sample, the centroid
    Ws = [area[one]]
    Ns = [0.5 * cr[one]]
    Fi = [np.flatnonzero(one)]
    Bs = [np.full((int(one.sum()), 3), 1.0 / 3.0)]
    for kk in np.unique(k[~one]):
        sel = np.flatnonzero(k == kk)
        # barycentric centroids of the kk^2 sub-triangles
        bc = []
        for i in range(kk):
            for j in range(kk - i):
                bc.append(((i + 1 / 3) / kk, (j + 1 / 3) / kk))
                if i + j < kk - 1:
                    bc.append(((i + 2 / 3) / kk, (j + 2 / 3) / kk))
        bc = np.asarray(bc)
        a, b = bc[:, 0], bc[:, 1]
        Q = (A[sel, None, :] * (1.0 - a - b)[None, :, None] + B[sel, None, :] * a[None, :, None]
             + C[sel, None, :] * b[None, :, None])
        Qs.append(Q.reshape(-1, 3))
        Ws.append(np.repeat(area[sel] / len(bc), len(bc)))
        Ns.append(np.repeat(0.5 * cr[sel] / len(bc), len(bc), axis=0))
        Fi.append(np.repeat(sel, len(bc)))
        Bs.append(np.tile(np.stack([1.0 - a - b, a, b], axis=1), (len(sel), 1)))
    return (np.concatenate(Qs), np.concatenate(Ws), np.concatenate(Ns), np.concatenate(Fi),
            np.concatenate(Bs))


#: Bins of the histogram behind the area-weighted quantiles.
_QUANTILE_BINS = 1 << 14


def _weighted_quantile(x, w, q):
    """Area-weighted quantile(s) q in [0, 1] of x.

    From a histogram of ``_QUANTILE_BINS`` bins over [min x, max x] with
    linear interpolation inside a bin (O(n), no sort): within
    (max - min) / 16384 of the exact weighted quantile.
    """
    x = np.asarray(x, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    q = np.clip(np.asarray(q, dtype=np.float64), 0.0, 1.0)
    if len(x) == 0:
        return np.zeros(q.shape)
    lo, hi = float(x.min()), float(x.max())
    total = float(w.sum())
    if not hi > lo or not total > 0.0:
        return np.full(q.shape, lo)
    nb = _QUANTILE_BINS
    b = np.minimum(((x - lo) * (nb / (hi - lo))).astype(np.int64), nb - 1)
    cw = np.concatenate([[0.0], np.cumsum(np.bincount(b, w, minlength=nb))])
    t = q * total
    k = np.clip(np.searchsorted(cw, t, side="left") - 1, 0, nb - 1)
    frac = np.clip((t - cw[k]) / np.maximum(cw[k + 1] - cw[k], 1e-300), 0.0, 1.0)
    return lo + (k + frac) * ((hi - lo) / nb)


def _smoothstep(a, b, x):
    t = np.clip((x - a) / np.maximum(b - a, 1e-300), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _turn_thresholds(x, w, fraction, band):
    """Where :func:`_apply_turn` steps: ("zero" | "one" | "step" | "smooth", lo, mid, hi).

    The step puts 1 on the top ``fraction`` of the area by x and 0 below,
    smooth over ``band`` of the area.  The band shrinks near the ends so the
    fractions 0 and 1 are exact.
    """
    if fraction <= 0.0:
        return ("zero", 0.0, 0.0, 0.0)
    if fraction >= 1.0:
        return ("one", 0.0, 0.0, 0.0)
    b = band * min(1.0, 2.0 * fraction, 2.0 * (1.0 - fraction))
    lo, mid, hi = _weighted_quantile(x, w, [1.0 - fraction - 0.5 * b, 1.0 - fraction,
                                              1.0 - fraction + 0.5 * b])
    if hi <= lo:  # flat potential: a step at the quantile
        return ("step", float(lo), float(mid), float(hi))
    return ("smooth", float(lo), float(mid), float(hi))


def _apply_turn(t, x):
    kind, lo, mid, hi = t
    if kind == "zero":
        return np.zeros(len(x))
    if kind == "one":
        return np.ones(len(x))
    if kind == "step":
        return (x > mid).astype(np.float64)
    return _smoothstep(lo, hi, x)


class AgingField:
    """The smooth fields behind an aging map, readable at any point of the surface.

    Made by :func:`aging_maps` (``maps.field``).  The fields (convexity,
    normals, rain shelter, occlusion, blotch noise) are trilinear reads of
    blurred grids in the scan's own frame, and the thresholds that turn
    them into coverage and gilding were set once on the scan's vertices, so
    reading the field at a shaded point gives the map there, with patch
    edges as soft at any mesh resolution as on a dense one.
    """

    def __init__(self, grid, fields, R, center, diag, params):
        self._grid = grid
        self._fields = fields      # (k, nx, ny, nz) float32
        self._R = R
        self._center = center
        self._diag = diag
        self._p = params
        self._stats = None         # blotch means and deviations
        self._cov_t = self._loss_t = None

    def _raw(self, X, normals=None):
        """Every per-point quantity at points X (q,3) in world coordinates."""
        p = self._p
        P = (np.asarray(X, np.float64) - self._center) @ self._R.T
        r = self._grid.read(self._fields, P).astype(np.float64)
        n_e = r[:, 4:7]
        ln = np.sqrt(np.einsum("ij,ij->i", n_e, n_e))
        n_e /= np.maximum(ln, 1e-300)[:, None]
        bad = ln <= 0.0
        if np.any(bad) and normals is not None:
            nn = np.asarray(normals, dtype=np.float64)[bad] @ self._R.T
            n_e[bad] = nn / np.maximum(np.linalg.norm(nn, axis=1, keepdims=True), 1e-300)

        def convexity(rw, scale):
            cen = rw[:, 1:4] / np.maximum(rw[:, :1], 1e-300)
            return np.einsum("ij,ij->i", P - cen, n_e) / scale

        kappa_e = convexity(r[:, 0:4], p.edge_scale * self._diag)
        kappa_c = convexity(r[:, 7:11], p.cavity_scale * self._diag)
        sky = np.clip(1.0 - r[:, 11], 0.0, 1.0)
        exposure = sky * np.clip(n_e[:, 2], 0.0, 1.0)
        cavity = np.maximum(np.clip(-kappa_c / p.cavity_full, 0.0, 1.0),
                            np.clip(-kappa_e / p.cavity_full, 0.0, 1.0))
        wear = _smoothstep(p.wear_start, p.wear_full, kappa_e)
        # the splatted occlusion, normalised by the splatted weight
        occlusion = np.clip(np.where(r[:, 16] > 0.0, r[:, 15] / np.where(r[:, 16] > 0.0, r[:, 16], 1.0), 0.0),
                            0.0, 1.0)
        sheltered = (1.0 - sky) * np.clip(n_e[:, 2], 0.0, 1.0)  # facing up, under an overhang
        return dict(exposure=exposure, cavity=cavity, wear=wear, occlusion=occlusion, sheltered=sheltered,
                    kappa_e=kappa_e, kappa_c=kappa_c, noise=r[:, 12:15])

    def _potentials(self, q):
        p = self._p
        m, s = self._stats
        z = (q["noise"] - m) / s
        if p.setting == "indoor":
            # dust, moisture and corrosion products collect where the air is
            # still and hands do not reach; raised, touched places stay gilt
            raised = np.clip(q["kappa_c"] / p.raised_full, 0.0, 1.0)
            P = p.a_occlusion * q["occlusion"] + p.a_cavity * q["cavity"] - p.a_wear * q["wear"] \
                - p.a_raised * raised + p.a_blotch_indoor * z[:, 0]
            Q = p.b_occlusion * q["occlusion"] + p.b_blotch * z[:, 1] - p.b_wear * q["wear"]
            crust = p.d_cavity * q["cavity"] + p.d_occlusion * q["occlusion"]
        else:
            P = p.a_exposure * q["exposure"] + p.a_cavity * q["cavity"] - p.a_wear * q["wear"] \
                + p.a_blotch * z[:, 0]
            Q = p.b_wear * q["wear"] + p.b_exposure * q["exposure"] + p.b_blotch * z[:, 1]
            crust = p.d_cavity * q["cavity"] + p.d_shelter * q["sheltered"]
        crust = np.clip(crust + p.d_blotch * z[:, 2] - p.d_offset, 0.0, 1.0)
        return P, Q, crust, z

    def at(self, X, normals=None):
        """Rust coverage, gilding and crust at points of the surface.

        Parameters
        ----------
        X : (q,3) float array
            Points on (or within a grid cell of) the surface, world coordinates.
        normals : (q,3) float array or None, optional
            Used only where the grid has no normal (far from the surface).

        Returns
        -------
        coverage, gild, crust : (q,) float64 arrays in [0, 1]
        """
        P, Q, crust, _ = self._potentials(self._raw(X, normals))
        return _apply_turn(self._cov_t, P), 1.0 - _apply_turn(self._loss_t, Q), crust


def aging_maps(V, F, *, age=DEFAULT_AGE, up=(0.0, 1.0, 0.0), seed=0, params=None, normals=None, scan=None,
               setting=None):
    """Rust coverage and gilding per vertex from the causes of aging.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array
    age : float, optional
        In [0, 1]: 0 new (all gilt), 1 fully corroded.
    up : (3,) sequence, optional
        World up (where rain comes from).  Scans are usually y-up.
    seed : int, optional
        Seed of the blotch noise and of the occlusion rays' turn; the map is a
        deterministic function of (V, F, age, up, seed, params).
    params : AgingParams or None, optional
    normals : (n,3) float array or None, optional
        Unit vertex normals, when the caller has them (only used for
        vertices the grid leaves without a normal).
    scan : (m,) bool array or None, optional
        The faces of the scan itself (a repaired mesh: ``~face_filled``);
        default all. The frame (centre, diagonal, hence every length
        scale), the surface the fields are made of (convexity, normals,
        shelter from rain, occlusion) and the area weights of the quantiles
        and of the noise's normalisation are the scan's alone: the scan's
        own vertices get the map they get without the fill (to the bit
        while the fill stays inside the scan's bounding box), and the filled
        vertices read the same fields at their positions (tests/test_aging.py).
    setting : {"indoor", "outdoor"} or None, optional
        Overrides ``params.setting`` (default "indoor"): what drives the
        corrosion (see :class:`AgingParams`).

    Returns
    -------
    AgingMaps
        With ``field``, the same map readable at any surface point
        (:class:`AgingField`).

    Raises
    ------
    ValueError
        For an age outside [0, 1], a zero up vector, an unknown setting or
        malformed V, F.

    Notes
    -----
    Convexity at scale s: ``kappa_s = (v - c_s(v)) . n_s(v) / s`` with c_s
    the area-weighted centroid of the surface around v and n_s its mean
    normal, both Gaussian-weighted with width s (grid of cell
    ``edge_scale`` x diagonal).  On a sphere of radius R >> s,
    kappa_s = 1.25 s/R (measured in tests/test_aging.py).  Exposure is ``max(n_s . up, 0)``
    times the fraction of the rain columns above v (a 3x3-cell cone) that
    no surface blocks.  Occlusion: in each grid cell the scan's surface
    passes through, the surface point nearest the cell's centroid casts
    ``occlusion_rays`` hemisphere rays (as :func:`ambient_occlusion`, reach
    ``occlusion_reach`` x diagonal) at the scan's own faces; the fractions
    that hit are blurred over ``occlusion_scale`` (normalised convolution)
    and read back where wanted.
    """
    p = AgingParams() if params is None else params
    if setting is not None:
        p = dataclasses.replace(p, setting=setting)
    if p.setting not in SETTINGS:
        raise ValueError("aging_maps: setting must be one of %s, got %r" % (", ".join(SETTINGS), p.setting))
    V, F = _mesh_arrays(V, F, "aging_maps")
    age = float(age)
    if not 0.0 <= age <= 1.0:
        raise ValueError("aging_maps: age must be in [0, 1], got %r" % age)
    up = np.asarray(up, dtype=np.float64)
    if not np.linalg.norm(up) > 0.0:
        raise ValueError("aging_maps: up must be a non-zero vector")
    up = up / np.linalg.norm(up)
    n = len(V)
    zero = np.zeros(n)
    if n == 0 or len(F) == 0:
        return AgingMaps(zero, np.ones(n), zero, zero, zero, zero, zero, zero, zero, zero)
    from scipy.ndimage import gaussian_filter

    # frame with z along up (rain columns are grid columns)
    ref = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    a = ref - up * (ref @ up)
    a /= np.linalg.norm(a)
    b = np.cross(up, a)
    R = np.stack([a, b, up])  # rows: new axes
    if scan is not None:
        scan = np.asarray(scan, bool)
        if scan.shape != (len(F),):
            raise ValueError("aging_maps: scan must have one flag per face (%d), got shape %s"
                             % (len(F), scan.shape))
        if not scan.any():
            scan = None
    used = np.zeros(n, bool)               # the frame: the vertices the scan's faces use
    used[(F if scan is None else F[scan]).ravel()] = True
    own = V[used]
    lo, hi = own.min(axis=0), own.max(axis=0)
    center = 0.5 * (lo + hi)
    P = (V - center) @ R.T
    diag = float(np.linalg.norm(hi - lo))
    if not diag > 0.0:
        return AgingMaps(zero, np.ones(n), zero, zero, zero, zero, zero, zero, zero, zero)
    fn = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])  # 2 x area x normal
    fidx = F.ravel()
    fa = np.sqrt(np.einsum("ij,ij->i", fn, fn)) / 6.0
    if scan is not None:
        fa = np.where(scan, fa, 0.0)      # the weights: the scan's own area
    area = np.bincount(fidx, np.repeat(fa, 3), minlength=n)
    Nw = np.stack([np.bincount(fidx, np.repeat(fn[:, k], 3), minlength=n) for k in range(3)], axis=1)

    h = p.edge_scale * diag
    grid = _Grid(P, h, anchor=P[used].min(axis=0))
    # the fields (convexity, normals, shelter, occlusion) are the scan's own surface's
    shown = slice(None) if scan is None else scan
    Q, wq, nq, fq, bq = _surface_samples(P, F[shown], h, fn[shown])
    # channels: area, area-weighted position (3), area-weighted normal (3)
    G = grid.splat(Q, np.concatenate([wq[:, None], wq[:, None] * Q, nq], axis=1))

    # occlusion: each of the scan's vertices (on a large scan, a hashed
    # subset) casts hemisphere rays at the scan's own faces (as
    # ambient_occlusion); the fractions, interpolated to the surface samples,
    # are splatted and blurred (a normalised convolution), so the field is as
    # smooth on a coarse mesh as on a dense one
    O = np.zeros((2,) + grid.shape)
    if p.setting == "indoor":
        Fs = F[shown]
        Ns = np.stack([np.bincount(Fs.ravel(), np.repeat(fn[shown][:, k], 3), minlength=n) for k in range(3)],
                      axis=1)
        vid = np.flatnonzero(used)
        rays = int(np.clip(p.occlusion_ray_budget // len(vid), 16, p.occlusion_rays))
        reach = np.inf if p.occlusion_reach is None else p.occlusion_reach * diag
        scene = _scene(P, Fs)
        if len(vid) * rays <= p.occlusion_ray_budget:
            sub = vid       # every vertex; interpolated to the samples of large faces
        else:               # a large scan: a hashed subset of its vertices, splatted as points
            sub = vid[_hash01(vid, np.full_like(vid, 2), np.full_like(vid, 3), seed)
                      < p.occlusion_ray_budget / (rays * len(vid))]
        nrm = Ns[sub] / np.maximum(np.linalg.norm(Ns[sub], axis=1, keepdims=True), 1e-300)
        keys = np.stack([sub, np.zeros_like(sub), np.ones_like(sub)], axis=1).astype(np.int64)
        occl = np.zeros(n)
        occl[sub] = _occluded_fraction(scene, P[sub], nrm, keys, rays, seed, AO_EPS * diag, reach)
        if len(sub) == len(vid):
            val = np.einsum("qk,qk->q", bq, occl[Fs[fq]])
            O = grid.splat(Q, np.stack([wq * val, wq], axis=1))
        else:
            O = grid.splat(P[sub], np.stack([area[sub] * occl[sub], area[sub]], axis=1))
        O = gaussian_filter(O, (0.0,) + (p.occlusion_scale * diag / h,) * 3, mode="constant")
    del Q, wq, nq, fq, bq

    # every grid quantity is read back in one trilinear pass: edge scale
    # (area, moment, normal: 7), cavity scale (area, moment: 4), rain
    # shelter (1), three noise fields (3) and occlusion (weighted, weight: 2)
    sig_e = p.edge_scale * diag / h
    sig_c = p.cavity_scale * diag / h
    # rain: a column is blocked above a cell if any surface lies >= 3 cells higher
    occ = G[0] > 0.0
    above = np.flip(np.logical_or.accumulate(np.flip(occ, axis=2), axis=2), axis=2)
    blocked = np.zeros(occ.shape)
    blocked[:, :, :-3] = above[:, :, 3:]
    blocked = gaussian_filter(blocked, (1.0, 1.0, 0.0), mode="nearest")  # a narrow cone of rain
    # blotches: value noise at the grid nodes (world coordinates), read at the vertices
    nodes_world = grid.nodes() @ R + center
    noise = [value_noise(nodes_world, p.patch_scale * diag, seed=sd, octaves=p.octaves,
                         normalize=False).reshape(grid.shape) for sd in (seed, seed + 7919, seed + 104729)]
    fields = ([gaussian_filter(g, sig_e, mode="constant") for g in G]
              + [gaussian_filter(g, sig_c, mode="constant") for g in G[:4]] + [blocked] + noise
              + list(O))
    field = AgingField(grid, np.stack([f.astype(np.float32) for f in fields]), R, center, diag, p)
    del fields, G, O

    # vertices the grid leaves without a normal take the given one, else their faces'
    q = field._raw(V, normals if normals is not None else Nw @ R)
    wsum = area.sum()
    m = (area[:, None] * q["noise"]).sum(axis=0) / wsum
    s = np.sqrt((area[:, None] * (q["noise"] - m) ** 2).sum(axis=0) / wsum)
    field._stats = (m, np.where(s > 0.0, s, 1.0))
    P_rust, Q_loss, crust, z = field._potentials(q)
    field._cov_t = _turn_thresholds(P_rust, area, age, p.band)
    coverage = _apply_turn(field._cov_t, P_rust)
    # gilding is lost on the top LOSS*age of the uncorroded area by Q
    field._loss_t = _turn_thresholds(Q_loss, area * (1.0 - coverage), p.loss * age, p.band)
    gild = 1.0 - _apply_turn(field._loss_t, Q_loss)
    return AgingMaps(coverage, gild, q["exposure"], q["cavity"], q["wear"], z[:, 0], q["kappa_e"],
                     q["kappa_c"], crust, q["occlusion"], field)

