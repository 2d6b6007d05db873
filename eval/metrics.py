"""What a reviewer measures on a filled mesh, against the known true surface.

Every tool is measured the same way, whatever it returns:

* **Added faces** are found by geometry, not by trusting a tool's labels:
  output vertices are matched to input vertices (exact coordinates, or
  within ``match_tol`` of the bounding-box diagonal for tools that store
  float32), and an output face is *original* when its three corners match
  input vertices that form an input face. Every other face was added.
* **Distance to the truth**: ``n_samples`` points are drawn on the added
  faces, uniformly by area, and their distance to the closed ground-truth
  surface is computed (open3d ``RaycastingScene`` finds the nearest
  triangle; the distance to it is recomputed in float64). Reported in ‰
  (per mille) of the ground truth's bounding-box diagonal: mean, RMS, max
  (the max also over the added vertices), and the mean *signed* distance
  (positive outside) so a fill that sinks in shows.
* **Normal deviation**: the angle between each sample's face normal, as
  oriented in the output, and the true normal at its nearest point;
  area-weighted mean in degrees (0 is perfect, 180 is a flipped patch), and
  the percentage of the patch area facing the wrong way (``flipped_pct``).
* **Topology**: holes (boundary loops) before and after and the
  interpolation rate, watertight (no boundary and no non-manifold edge),
  edge-manifold, consistently oriented, and self-intersecting faces added
  (pymeshlab's per-face self-intersection selection, output minus input).
* **Shape of the patch**: mean edge length of the added faces over the
  mean rim edge length of the input's holes, and added area over the true
  area removed.
* **Originals unchanged**: the share of input vertices present bit for bit
  in the output, the largest shift of an input vertex, and the input faces
  missing from the output.

Distances use the *whole* true surface, not only the removed part, so a
patch that lies on the true surface elsewhere is not penalised; a patch
that caps a band (the true surface is a tube) is.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from shellrepair.holes.loops import boundary_loops
from shellrepair.report.table import interpolation_rate
from shellrepair.mesh.topology import edge_topology, face_areas

__all__ = ["TruthSurface", "closest_point_on_triangles", "sample_faces", "match_vertices",
           "added_faces", "mesh_checks", "self_intersecting_faces", "rim_edge_length", "evaluate",
           "PERMILLE"]

PERMILLE = 1000.0
#: Default number of area-weighted samples on the added faces.
N_SAMPLES = 20000
#: Output vertices within this fraction of the bounding-box diagonal of an
#: input vertex are that vertex (float32 storage moves them by ~1e-8).
MATCH_TOL = 1e-6
#: Area below which a face's normal is undefined (relative to diag^2).
AREA_EPS = 1e-18


def closest_point_on_triangles(P, A, B, C):
    """Closest point of triangle ``(A[i], B[i], C[i])`` to ``P[i]``, in float64.

    Parameters
    ----------
    P, A, B, C : (k,3) float64 arrays

    Returns
    -------
    Q : (k,3) float64
        Closest points.

    Notes
    -----
    The Voronoi-region walk of Ericson, *Real-Time Collision Detection*
    (2005), 5.1.5, vectorised: vertex regions, edge regions, then the
    interior by barycentric coordinates.
    """
    P, A, B, C = (np.asarray(x, np.float64) for x in (P, A, B, C))
    ab, ac, ap = B - A, C - A, P - A
    d1 = (ab * ap).sum(1)
    d2 = (ac * ap).sum(1)
    bp = P - B
    d3 = (ab * bp).sum(1)
    d4 = (ac * bp).sum(1)
    cp = P - C
    d5 = (ab * cp).sum(1)
    d6 = (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    denom = va + vb + vc
    tiny = np.finfo(float).tiny
    with np.errstate(divide="ignore", invalid="ignore"):
        v = vb / np.where(np.abs(denom) > tiny, denom, 1.0)
        w = vc / np.where(np.abs(denom) > tiny, denom, 1.0)
        Q = A + ab * v[:, None] + ac * w[:, None]  # interior
        # edge BC
        t_bc = (d4 - d3) / np.where((d4 - d3) + (d5 - d6) != 0, (d4 - d3) + (d5 - d6), 1.0)
        m = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
        Q[m] = (B + (C - B) * t_bc[:, None])[m]
        # edge AC
        t_ac = d2 / np.where(d2 - d6 != 0, d2 - d6, 1.0)
        m = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        Q[m] = (A + ac * t_ac[:, None])[m]
        # edge AB
        t_ab = d1 / np.where(d1 - d3 != 0, d1 - d3, 1.0)
        m = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        Q[m] = (A + ab * t_ab[:, None])[m]
    # vertex regions
    m = (d6 >= 0) & (d5 <= d6)
    Q[m] = C[m]
    m = (d3 >= 0) & (d4 <= d3)
    Q[m] = B[m]
    m = (d1 <= 0) & (d2 <= 0)
    Q[m] = A[m]
    return Q


class TruthSurface:
    """The closed ground truth, ready for distance queries.

    Parameters
    ----------
    V : (n,3) float64, F : (m,3) int64
        The true surface (closed and outward-oriented for signed distances).

    Attributes
    ----------
    diag : float
        Bounding-box diagonal, the unit of the ‰ figures.
    """

    def __init__(self, V, F):
        import open3d as o3d

        self.V = np.asarray(V, np.float64)
        self.F = np.asarray(F, np.int64)
        lo, hi = self.V.min(axis=0), self.V.max(axis=0)
        self.center = 0.5 * (lo + hi)
        self.diag = float(np.linalg.norm(hi - lo))
        N = np.cross(self.V[self.F[:, 1]] - self.V[self.F[:, 0]], self.V[self.F[:, 2]] - self.V[self.F[:, 0]])
        self.N = N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)
        self._o3d = o3d
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.core.Tensor((self.V - self.center).astype(np.float32)),
                                 o3d.core.Tensor(self.F.astype(np.uint32)))

    def closest(self, P):
        """Nearest true triangle and the float64 distance to it.

        Returns
        -------
        d : (k,) float64
        tri : (k,) int64
        normal : (k,3) float64
            Unit normal of the nearest true triangle.
        """
        P = np.asarray(P, np.float64)
        if len(P) == 0:
            return np.zeros(0), np.zeros(0, np.int64), np.zeros((0, 3))
        q = self._o3d.core.Tensor((P - self.center).astype(np.float32))
        tri = self.scene.compute_closest_points(q)["primitive_ids"].numpy().astype(np.int64)
        T = self.V[self.F[tri]]
        Q = closest_point_on_triangles(P, T[:, 0], T[:, 1], T[:, 2])
        return np.linalg.norm(P - Q, axis=1), tri, self.N[tri]

    def signed_distance(self, P):
        """Distance with the sign of the inside test (positive outside)."""
        P = np.asarray(P, np.float64)
        d, _, _ = self.closest(P)
        if len(P) == 0:
            return d
        q = self._o3d.core.Tensor((P - self.center).astype(np.float32))
        occ = self.scene.compute_occupancy(q).numpy() > 0.5
        return np.where(occ, -d, d)


def sample_faces(V, F, n, rng):
    """``n`` points uniformly distributed by area on the faces ``F``.

    Returns
    -------
    P : (n,3) float64
    face : (n,) int64
        Which face each point is on. Empty when the faces have no area.
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    A = face_areas(V, F)
    tot = A.sum()
    if len(F) == 0 or tot <= 0:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    face = rng.choice(len(F), size=int(n), p=A / tot)
    r1 = np.sqrt(rng.random(int(n)))
    r2 = rng.random(int(n))
    T = V[F[face]]
    P = (1 - r1)[:, None] * T[:, 0] + (r1 * (1 - r2))[:, None] * T[:, 1] + (r1 * r2)[:, None] * T[:, 2]
    return P, face


def match_vertices(V_in, V_out, tol):
    """Which input vertex each output vertex is.

    Parameters
    ----------
    V_in : (n,3), V_out : (p,3) float64
    tol : float
        Absolute distance within which an output vertex is an input vertex.

    Returns
    -------
    out_to_in : (p,) int64
        Input index, or -1 for a new vertex.
    shift : (n,) float64
        Distance from each input vertex to its nearest output vertex.
    exact : (n,) bool
        The input vertex is present bit for bit.
    """
    V_in = np.asarray(V_in, np.float64)
    V_out = np.asarray(V_out, np.float64)
    tree = cKDTree(V_in)
    d, j = tree.query(V_out, k=1)
    out_to_in = np.where(d <= tol, j, -1).astype(np.int64)
    dback, k = cKDTree(V_out).query(V_in, k=1)
    exact = np.all(V_out[k] == V_in, axis=1)
    return out_to_in, dback, exact


def _face_keys(F, n):
    S = np.sort(np.asarray(F, np.int64), axis=1)
    n = np.int64(max(int(n), 1))
    return (S[:, 0] * n + S[:, 1]) * n + S[:, 2]


def added_faces(V_in, F_in, V_out, F_out, tol):
    """Faces of the output that are not faces of the input.

    Returns
    -------
    added : (m_out,) bool
    missing : int
        Input faces not present in the output.
    out_to_in, shift, exact : see :func:`match_vertices`
    """
    out_to_in, shift, exact = match_vertices(V_in, V_out, tol)
    F_out = np.asarray(F_out, np.int64)
    n = len(V_in)
    G = out_to_in[F_out]
    known = (G >= 0).all(axis=1)
    keys_in = np.unique(_face_keys(F_in, n))
    added = np.ones(len(F_out), bool)
    if known.any():
        k = _face_keys(G[known], n)
        added[np.flatnonzero(known)] = ~np.isin(k, keys_in)
        present = np.isin(keys_in, k)
    else:
        present = np.zeros(len(keys_in), bool)
    return added, int((~present).sum()), out_to_in, shift, exact


def mesh_checks(V, F):
    """Topology of a mesh: holes, watertight, edge-manifold, oriented.

    Returns
    -------
    d : dict
        ``loops`` (boundary loops), ``open_chains``, ``boundary_edges``,
        ``nonmanifold_edges``, ``watertight``, ``edge_manifold``,
        ``oriented`` (every two-face edge is used once in each direction).
    """
    F = np.asarray(F, np.int64)
    n = len(V)
    if len(F) == 0:
        return {"loops": 0, "open_chains": 0, "boundary_edges": 0, "nonmanifold_edges": 0,
                "watertight": False, "edge_manifold": True, "oriented": True}
    topo = edge_topology(F, n)
    loops, chains = boundary_loops(F, n, topo)
    # orientation: a two-face edge must be used as (a,b) once and (b,a) once
    he = topo.he
    two = topo.edge_count[topo.edge_of_he] == 2
    fwd = he[:, 0] < he[:, 1]
    e2 = topo.edge_of_he[two]
    nf = np.bincount(e2, weights=fwd[two].astype(float), minlength=len(topo.edges))
    oriented = bool(np.all(nf[topo.edge_count == 2] == 1))
    nb = int(topo.n_boundary_edges)
    nm = int(len(topo.nonmanifold_edges))
    return {"loops": len(loops), "open_chains": len(chains), "boundary_edges": nb,
            "nonmanifold_edges": nm, "watertight": nb == 0 and nm == 0, "edge_manifold": nm == 0,
            "oriented": oriented}


def self_intersecting_faces(V, F):
    """Number of faces that intersect a non-adjacent face (pymeshlab)."""
    import pymeshlab

    F = np.asarray(F, np.int64)
    if len(F) == 0:
        return 0
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=np.asarray(V, np.float64), face_matrix=F.astype(np.int32)))
    ms.compute_selection_by_self_intersections_per_face()
    return int(ms.current_mesh().selected_face_number())


def rim_edge_length(V, F):
    """Mean length of the boundary edges of a mesh (its holes' rims)."""
    F = np.asarray(F, np.int64)
    topo = edge_topology(F, len(V))
    he = topo.he[topo.boundary_he]
    if len(he) == 0:
        return float("nan")
    return float(np.linalg.norm(V[he[:, 0]] - V[he[:, 1]], axis=1).mean())


def _unique_edge_lengths(V, F):
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    E = np.unique(E, axis=0)
    return np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)


def input_facts(V_in, F_in):
    """What :func:`evaluate` needs to know about the perforated input once."""
    checks = mesh_checks(V_in, F_in)
    return {"loops": checks["loops"], "rim_edge": rim_edge_length(V_in, F_in),
            "self_intersecting": self_intersecting_faces(V_in, F_in)}


def evaluate(V_in, F_in, V_out, F_out, truth, *, removed_area=None, n_samples=N_SAMPLES, seed=0,
             facts=None, match_tol=MATCH_TOL, self_intersections=True):
    """Measure a filled mesh against the ground truth.

    Parameters
    ----------
    V_in : (n,3) float64, F_in : (m,3) int64
        The perforated mesh the tool was given.
    V_out : (p,3) float64, F_out : (q,3) int64
        What the tool returned.
    truth : TruthSurface
    removed_area : float, optional
        True area that was cut away (for ``area_ratio``).
    n_samples : int
    seed : int
        Seeds the samples, so two runs measure the same points.
    facts : dict, optional
        :func:`input_facts` of the input, if already computed.
    match_tol : float
        Vertex matching tolerance, relative to the truth's diagonal.
    self_intersections : bool
        Count self-intersecting faces (the slowest check).

    Returns
    -------
    m : dict
        See the module docstring; distances in ‰ of ``truth.diag``.
    """
    V_in = np.asarray(V_in, np.float64)
    F_in = np.asarray(F_in, np.int64)
    V_out = np.asarray(V_out, np.float64)
    F_out = np.asarray(F_out, np.int64)
    facts = facts or input_facts(V_in, F_in)
    diag = truth.diag
    added, missing, out_to_in, shift, exact = added_faces(V_in, F_in, V_out, F_out, match_tol * diag)
    Fa = F_out[added]
    checks = mesh_checks(V_out, F_out)
    m = {
        "holes_before": int(facts["loops"]),
        "holes_after": int(checks["loops"]),
        "rate": interpolation_rate(facts["loops"], min(checks["loops"], facts["loops"])),
        "open_chains": checks["open_chains"],
        "watertight": checks["watertight"],
        "edge_manifold": checks["edge_manifold"],
        "oriented": checks["oriented"],
        "boundary_edges": checks["boundary_edges"],
        "nonmanifold_edges": checks["nonmanifold_edges"],
        "faces_added": int(added.sum()),
        "vertices_added": int((out_to_in < 0).sum()),
        "input_faces_missing": int(missing),
        "orig_exact_pct": 100.0 * float(exact.mean()) if len(exact) else 100.0,
        "orig_max_shift_permille": PERMILLE * float(shift.max()) / diag if len(shift) else 0.0,
    }
    if self_intersections:
        m["self_intersections_added"] = self_intersecting_faces(V_out, F_out) - int(facts["self_intersecting"])
    A = face_areas(V_out, Fa)
    m["area_added"] = float(A.sum())
    m["area_ratio"] = float(A.sum() / removed_area) if removed_area else None
    if len(Fa) == 0 or A.sum() <= AREA_EPS * diag ** 2:
        m.update({k: None for k in ("rms_permille", "mean_permille", "max_permille", "bias_permille",
                                    "normal_dev_deg", "flipped_pct", "edge_ratio")})
        return m
    rng = np.random.default_rng(seed)
    P, fi = sample_faces(V_out, Fa, n_samples, rng)
    d, _, Nt = truth.closest(P)
    sd = truth.signed_distance(P)
    new_v = np.unique(Fa)
    dv, _, _ = truth.closest(V_out[new_v])
    Nf = np.cross(V_out[Fa[:, 1]] - V_out[Fa[:, 0]], V_out[Fa[:, 2]] - V_out[Fa[:, 0]])
    Nf = Nf / np.maximum(np.linalg.norm(Nf, axis=1, keepdims=True), 1e-300)
    cosang = np.clip((Nf[fi] * Nt).sum(axis=1), -1.0, 1.0)
    ang = np.degrees(np.arccos(cosang))
    m.update({
        "rms_permille": PERMILLE * float(np.sqrt(np.mean(d ** 2))) / diag,
        "mean_permille": PERMILLE * float(d.mean()) / diag,
        "max_permille": PERMILLE * float(max(d.max(), dv.max())) / diag,
        "bias_permille": PERMILLE * float(sd.mean()) / diag,
        "normal_dev_deg": float(ang.mean()),
        "flipped_pct": 100.0 * float((cosang < 0).mean()),
        "edge_ratio": float(_unique_edge_lengths(V_out, Fa).mean() / facts["rim_edge"])
        if np.isfinite(facts["rim_edge"]) else None,
    })
    return m
