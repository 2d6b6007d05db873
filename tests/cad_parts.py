"""CAD-like closed parts built from planar polygons, coarsely triangulated.

Each part is a list of planar faces (an outer ring, optionally one inner
ring, and the outward normal), triangulated the way CAD exporters do: a
convex face as a fan from one corner (long thin triangles), a face with a
hole by zipping its two rings. Corners at the same position are one
vertex, so the part is closed. Every builder returns ``V, F, groups``:
``groups[name]`` are the faces of one named planar face, for cutting
openings.
"""

import numpy as np


class _Builder:
    def __init__(self):
        self.key = {}
        self.V = []
        self.F = []
        self.W = []          # wanted normal per face
        self.group = []

    def vid(self, p):
        k = tuple(np.round(np.asarray(p, float), 12))
        if k not in self.key:
            self.key[k] = len(self.V)
            self.V.append(np.asarray(p, float))
        return self.key[k]

    def tri(self, a, b, c, normal, name):
        self.F.append([a, b, c])
        self.W.append(normal)
        self.group.append(name)

    def fan(self, ring, normal, name, inner=None):
        """A planar ring (optionally with one ``inner`` ring cut out), turning
        counter-clockwise about ``normal``, by ear clipping: the first clean
        ear each time, so corners get fans of long thin triangles, and no
        zero-area triangle is made. A hole is joined to the outer ring by a
        cut between their closest corners first."""
        nrm = np.asarray(normal, float)
        u = np.cross(nrm, [1.0, 0, 0] if abs(nrm[0]) < 0.9 else [0, 1.0, 0])
        u /= np.linalg.norm(u)
        v = np.cross(nrm, u)
        ring = np.asarray(ring, float)
        flat = lambda R: np.column_stack([R @ u, R @ v])
        area = lambda Q: 0.5 * np.sum(Q[:, 0] * np.roll(Q[:, 1], -1) - np.roll(Q[:, 0], -1) * Q[:, 1])
        if area(flat(ring)) < 0:
            ring = ring[::-1]
        pts = list(ring)
        if inner is not None:
            inner = np.asarray(inner, float)
            if area(flat(inner)) > 0:
                inner = inner[::-1]          # the hole turns the other way
            d = np.linalg.norm(ring[:, None] - inner[None], axis=2)
            k, m = np.unravel_index(np.argmin(d), d.shape)
            hole = [inner[(m + t) % len(inner)] for t in range(len(inner) + 1)]
            pts = list(ring[:k + 1]) + hole + list(ring[k:])
        ids = [self.vid(p) for p in pts]
        Q = flat(np.array(pts))
        poly = list(range(len(pts)))

        def o2(a, b, c):
            return (Q[b, 0] - Q[a, 0]) * (Q[c, 1] - Q[a, 1]) - (Q[b, 1] - Q[a, 1]) * (Q[c, 0] - Q[a, 0])

        while len(poly) > 3:
            for i in range(len(poly)):
                a, b, c = poly[i - 1], poly[i], poly[(i + 1) % len(poly)]
                if o2(a, b, c) <= 1e-12:
                    continue
                if any(o2(a, b, d) >= -1e-12 and o2(b, c, d) >= -1e-12 and o2(c, a, d) >= -1e-12
                       for d in poly if ids[d] not in (ids[a], ids[b], ids[c])):
                    continue
                self.tri(ids[a], ids[b], ids[c], normal, name)
                poly.pop(i)
                break
            else:
                raise ValueError("no ear")
        self.tri(*[ids[p] for p in poly], normal, name)

    def zip(self, outer, inner, normal, name):
        """The planar ring between ``outer`` and ``inner``."""
        self.fan(outer, normal, name, inner=inner)

    def strip(self, ring0, ring1, outward, name, closed=True):
        """Walls between two rings of equal length, each quad split in two
        long triangles; ``outward(p)`` is the wall's outward normal at p."""
        a, b = [self.vid(p) for p in ring0], [self.vid(p) for p in ring1]
        n = len(a)
        for i in range(n if closed else n - 1):
            j = (i + 1) % n
            c = (np.asarray(ring0[i]) + np.asarray(ring0[j]) + np.asarray(ring1[i]) + np.asarray(ring1[j])) / 4
            w = outward(c)
            self.tri(a[i], a[j], b[j], w, name)
            self.tri(a[i], b[j], b[i], w, name)

    def mesh(self):
        V = np.array(self.V, float)
        F = np.array(self.F, np.int64)
        W = np.array(self.W, float)
        n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
        flip = np.einsum("ij,ij->i", n, W) < 0
        F[flip] = F[flip][:, ::-1]
        names = np.array(self.group)
        groups = {g: np.flatnonzero(names == g) for g in dict.fromkeys(self.group)}
        return V, F, groups


def _rect(x0, y0, x1, y1, z, n=1):
    """Counter-clockwise rectangle at height z, each side in n segments."""
    c = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float)
    pts = []
    for i in range(4):
        a, b = c[i], c[(i + 1) % 4]
        for t in np.arange(n) / n:
            pts.append([*(a + t * (b - a)), z])
    return np.array(pts)


def _circle(cx, cy, r, z, k):
    t = 2 * np.pi * np.arange(k) / k
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t), np.full(k, float(z))])


def _with_z(ring, z):
    R = np.array(ring, float)
    R[:, 2] = z
    return R


def _side_walls(b, ring0, ring1, name, centre, inward=False):
    """Vertical walls of a prism ring; rectangle sides get one group each."""
    sgn = -1.0 if inward else 1.0

    def out(p):
        d = np.array([p[0] - centre[0], p[1] - centre[1], 0.0])
        return sgn * d / np.linalg.norm(d)

    b.strip(ring0, ring1, out, name)


def coarse_cube(n=1, size=1.0):
    """A cube whose six faces are fans (each side in ``n`` segments)."""
    b = _Builder()
    s = size
    r = lambda z: _rect(0, 0, s, s, z, n)
    b.fan(r(s), [0, 0, 1], "top")
    b.fan(r(0.0), [0, 0, -1], "bottom")
    for name, (axis, val, nrm) in {"x0": (0, 0.0, -1), "x1": (0, s, 1), "y0": (1, 0.0, -1),
                                   "y1": (1, s, 1)}.items():
        # the side face as a ring: its 4 corners, each side in n segments
        o = [a for a in range(3) if a != axis]
        c2 = np.array([[0, 0], [s, 0], [s, s], [0, s]], float)
        ring = []
        for i in range(4):
            a, c = c2[i], c2[(i + 1) % 4]
            for t in np.arange(n) / n:
                p = np.zeros(3)
                p[axis] = val
                p[o] = a + t * (c - a)
                ring.append(p)
        w = np.zeros(3)
        w[axis] = nrm
        b.fan(ring, w, name)
    return b.mesh()


def capsule(segments=24, radius=0.5, length=6.0, rings=3):
    """A cylinder (one segment along its axis: long thin walls) with a
    hemispherical end at z = 0 side and a flat fan cap at z = length."""
    b = _Builder()
    c0 = _circle(0, 0, radius, 0.0, segments)
    c1 = _circle(0, 0, radius, length, segments)
    b.strip(c0, c1, lambda p: np.array([p[0], p[1], 0.0]), "wall")
    prev = c0
    for i in range(1, rings):
        phi = 0.5 * np.pi * i / rings
        cur = _circle(0, 0, radius * np.cos(phi), -radius * np.sin(phi), segments)
        b.strip(prev, cur, lambda p: p / np.linalg.norm(p), "dome")
        prev = cur
    tip = b.vid([0, 0, -radius])
    ids = [b.vid(p) for p in prev]
    for i in range(segments):
        b.tri(ids[i], ids[(i + 1) % segments], tip, [0, 0, -1], "dome")
    b.fan(c1, [0, 0, 1], "cap")
    return b.mesh()


def box_with_through_hole(round_hole=False, segments=20, n=1):
    """A 4 x 3 x 1 box with a hole through it along z: rectangular
    (1.5..2.5 x 1..2) or round (radius 0.6). Groups: ``top``, ``bottom``,
    the outer walls ``wall``, the tunnel ``tunnel`` (round) or its four
    sides ``tunnel0``..``tunnel3`` (rectangular)."""
    b = _Builder()
    outer = lambda z: _rect(0, 0, 4, 3, z, n)
    if round_hole:
        inner = lambda z: _circle(2, 1.5, 0.6, z, segments)
    else:
        inner = lambda z: _rect(1.5, 1, 2.5, 2, z, n)
    b.zip(outer(1.0), inner(1.0), [0, 0, 1], "top")
    b.zip(outer(0.0), inner(0.0), [0, 0, -1], "bottom")
    # outer walls, one group per side
    for side in range(4):
        o0, o1 = outer(0.0), outer(1.0)
        idx = [(side * n + t) % (4 * n) for t in range(n + 1)]
        centre = (2.0, 1.5)
        b.strip(o0[idx], o1[idx], lambda p: np.array([p[0] - 2, p[1] - 1.5, 0]) * (
            np.abs([p[0] - 2, p[1] - 1.5, 0]) / np.array([2, 1.5, 1]) > 0.999), f"wall{side}", closed=False)
    if round_hole:
        b.strip(inner(0.0), inner(1.0), lambda p: -np.array([p[0] - 2, p[1] - 1.5, 0]), "tunnel")
    else:
        for side in range(4):
            i0, i1 = inner(0.0), inner(1.0)
            idx = [(side * n + t) % (4 * n) for t in range(n + 1)]
            b.strip(i0[idx], i1[idx], lambda p: -np.array([p[0] - 2, p[1] - 1.5, 0]) * (
                np.abs([p[0] - 2, p[1] - 1.5, 0]) / np.array([0.5, 0.5, 1]) > 0.999), f"tunnel{side}",
                closed=False)
    return b.mesh()


def plate_with_pocket(n=1, depth=0.5):
    """A 4 x 4 x 1 plate with a 2 x 2 pocket ``depth`` deep in its top;
    groups ``top``, ``pocket_walls``, ``pocket_bottom``, ``walls``, ``bottom``."""
    b = _Builder()
    outer = lambda z: _rect(0, 0, 4, 4, z, n)
    pocket = lambda z: _rect(1, 1, 3, 3, z, 2 * n)
    b.zip(outer(1.0), pocket(1.0), [0, 0, 1], "top")
    _side_walls(b, pocket(1.0 - depth), pocket(1.0), "pocket_walls", (2, 2), inward=True)
    b.fan(pocket(1.0 - depth), [0, 0, 1], "pocket_bottom")
    _side_walls(b, outer(0.0), outer(1.0), "walls", (2, 2))
    b.fan(outer(0.0), [0, 0, -1], "bottom")
    return b.mesh()


def plate_with_boss(segments=32, n=2, height=0.6):
    """A 4 x 3 x 1 plate with a round boss (radius 0.6, ``height`` tall)
    rising from its top: groups ``top`` (the plate's top, a ring around the
    boss), ``boss_wall``, ``boss_top``, ``walls``, ``bottom``."""
    b = _Builder()
    outer = lambda z: _rect(0, 0, 4, 3, z, n)
    boss = lambda z: _circle(2, 1.5, 0.6, z, segments)
    b.zip(outer(1.0), boss(1.0), [0, 0, 1], "top")
    b.strip(boss(1.0), boss(1.0 + height), lambda p: np.array([p[0] - 2, p[1] - 1.5, 0]), "boss_wall")
    b.fan(boss(1.0 + height), [0, 0, 1], "boss_top")
    _side_walls(b, outer(0.0), outer(1.0), "walls", (2, 1.5))
    b.fan(outer(0.0), [0, 0, -1], "bottom")
    return b.mesh()


def slab_with_grid_top(nx=7, ny=5, size=(3.5, 2.0), height=0.4):
    """A slab whose top is a grid of thin cells (coplanar neighbours around
    any opening cut in it); top cell (i, j) is group ``cell i j``."""
    b = _Builder()
    X = np.linspace(0, size[0], nx + 1)
    Y = np.linspace(0, size[1], ny + 1)
    for i in range(nx):
        for j in range(ny):
            p = [[X[i], Y[j], height], [X[i + 1], Y[j], height], [X[i + 1], Y[j + 1], height],
                 [X[i], Y[j + 1], height]]
            ids = [b.vid(q) for q in p]
            diag = (i + j) % 2
            if diag:
                b.tri(ids[0], ids[1], ids[2], [0, 0, 1], f"cell {i} {j}")
                b.tri(ids[0], ids[2], ids[3], [0, 0, 1], f"cell {i} {j}")
            else:
                b.tri(ids[0], ids[1], ids[3], [0, 0, 1], f"cell {i} {j}")
                b.tri(ids[1], ids[2], ids[3], [0, 0, 1], f"cell {i} {j}")
    # the top's rim, counter-clockwise, with every grid vertex on it
    rim = ([[x, Y[0]] for x in X[:-1]] + [[X[-1], y] for y in Y[:-1]]
           + [[x, Y[-1]] for x in X[::-1][:-1]] + [[X[0], y] for y in Y[::-1][:-1]])
    rim = np.array(rim)
    top = np.column_stack([rim, np.full(len(rim), height)])
    bot = np.column_stack([rim, np.zeros(len(rim))])
    centre = (size[0] / 2, size[1] / 2)
    b.strip(bot, top, lambda p: np.array([p[0] - centre[0], p[1] - centre[1], 0]) * (
        np.abs([p[0] - centre[0], p[1] - centre[1], 0]) / np.array([centre[0], centre[1], 1]) > 0.999),
        "walls")
    b.fan(bot, [0, 0, -1], "bottom")
    return b.mesh()


def remove(V, F, faces):
    """The mesh without ``faces`` (vertices kept: originals stay in place)."""
    keep = np.ones(len(F), bool)
    keep[np.asarray(faces, np.int64)] = False
    return V, F[keep]


def box_with_bore_through_top(radius=0.4, rise=0.5, segments=24, n=2, at=(2.0, 1.5)):
    """A 4 x 3 x 1 box without its top, a blind bore from below (a round
    hole in the bottom, its wall and its end) running up through the
    missing top's plane, ``rise`` above it: scan crossing the opening's
    plane inside it, joined to the rim only through the bottom and the
    walls; its axis at ``at``. Groups ``bottom``, ``walls``, ``bore_wall``,
    ``bore_end``."""
    b = _Builder()
    outer = lambda z: _rect(0, 0, 4, 3, z, n)
    bore = lambda z: _circle(at[0], at[1], radius, z, segments)
    b.zip(outer(0.0), bore(0.0), [0, 0, -1], "bottom")
    b.strip(bore(0.0), bore(1.0 + rise), lambda p: -np.array([p[0] - at[0], p[1] - at[1], 0]), "bore_wall")
    b.fan(bore(1.0 + rise), [0, 0, -1], "bore_end")
    _side_walls(b, outer(0.0), outer(1.0), "walls", (2, 1.5))
    return b.mesh()


def gear_prism(teeth=12, r_root=1.0, r_tip=1.4, height=0.5, split=False):
    """A gear's blank: the prism of a toothed outline (``teeth`` square
    teeth between radii ``r_root`` and ``r_tip``). Groups ``top``,
    ``bottom``, ``walls``. ``split``: each tooth a prism of its own,
    standing against the body along its root edge, and the root edges the
    teeth and the body share split apart (duplicate vertices), as a
    repair of non-manifold edges leaves them."""
    b = _Builder()
    ang = 2 * np.pi / teeth
    prof = []
    for i in range(teeth):
        a0, a1, a2, a3 = i * ang, (i + 0.25) * ang, (i + 0.5) * ang, (i + 0.75) * ang
        prof += [[r_root * np.cos(a0), r_root * np.sin(a0)], [r_root * np.cos(a1), r_root * np.sin(a1)],
                 [r_tip * np.cos(a1), r_tip * np.sin(a1)], [r_tip * np.cos(a2), r_tip * np.sin(a2)],
                 [r_root * np.cos(a2), r_root * np.sin(a2)], [r_root * np.cos(a3), r_root * np.sin(a3)]]
    prof = np.array(prof)
    ring = lambda z: np.column_stack([prof, np.full(len(prof), z)])
    out = lambda p: np.array([p[0], p[1], 0.0]) / np.hypot(p[0], p[1])
    b.fan(ring(height), [0, 0, 1], "top")
    b.fan(ring(0.0), [0, 0, -1], "bottom")
    # each wall quad's outward normal from its own edge
    R0, R1 = ring(0.0), ring(height)
    m = len(prof)
    for i in range(m):
        j = (i + 1) % m
        d = prof[j] - prof[i]
        nrm = np.array([d[1], -d[0], 0.0])
        nrm /= np.linalg.norm(nrm)
        b.strip(R0[[i, j]], R1[[i, j]], lambda p, nrm=nrm: nrm, "walls", closed=False)
    return b.mesh()


def gear_split_teeth(teeth=8, r_root=1.0, r_tip=1.4, height=0.5):
    """A gear exported as a body and teeth that share non-manifold edges,
    with those edges split apart: the body a closed prism (a regular
    ``2 * teeth``-gon of radius ``r_root``), each tooth a box standing on
    one of the body's side faces, open where it stands (its own vertices,
    at the same positions as the body's corners). Groups ``top``,
    ``bottom``, ``walls`` (body) and ``tooth i``."""
    b = _Builder()
    m = 2 * teeth
    t = 2 * np.pi * np.arange(m) / m
    prof = np.column_stack([r_root * np.cos(t), r_root * np.sin(t)])
    ring = lambda z: np.column_stack([prof, np.full(m, z)])
    b.fan(ring(height), [0, 0, 1], "top")
    b.fan(ring(0.0), [0, 0, -1], "bottom")
    b.strip(ring(0.0), ring(height), lambda p: np.array([p[0], p[1], 0.0]), "walls")
    V, F, groups = b.mesh()
    parts = [(V, F, groups)]
    for i in range(teeth):
        a, c = prof[2 * i], prof[2 * i + 1]
        nrm = np.array([*(a + c) / 2, 0.0])
        nrm /= np.linalg.norm(nrm)
        d = (r_tip - r_root) * nrm[:2]
        tb = _Builder()
        base = lambda z: np.array([[*a, z], [*c, z]])
        tip = lambda z: np.array([[*(c + d), z], [*(a + d), z]])
        quad = lambda z: np.vstack([base(z), tip(z)])
        tb.fan(quad(height), [0, 0, 1], f"tooth {i}")
        tb.fan(quad(0.0), [0, 0, -1], f"tooth {i}")
        q0, q1 = quad(0.0), quad(height)
        for s in (1, 2, 3):       # the three faces off the body (the fourth is open)
            e = q0[(s + 1) % 4, :2] - q0[s, :2]
            w = np.array([e[1], -e[0], 0.0])
            if w[:2] @ (q0[s, :2] - (a + c) / 2 - d / 2) < 0:
                w = -w
            tb.strip(q0[[s, (s + 1) % 4]], q1[[s, (s + 1) % 4]], lambda p, w=w: w, f"tooth {i}", closed=False)
        parts.append(tb.mesh())
    Vs, Fs, out, n = [], [], {}, 0
    for Vp, Fp, gp in parts:
        for name, faces in gp.items():
            out[name] = faces + sum(len(x) for x in Fs)
        Vs.append(Vp)
        Fs.append(Fp + n)
        n += len(Vp)
    return np.vstack(Vs), np.vstack(Fs), out


def plate_with_shaped_pocket(outline, depth=0.5, size=(4.0, 4.0), n=1, pin=None, segments=16):
    """A plate ``size`` x 1 with a pocket ``depth`` deep whose outline is
    the counter-clockwise polygon ``outline`` (k,2) (a rib in the pocket is
    a notch in it); groups ``top``, ``pocket_walls`` (one group per outline
    edge: ``pocket_wall i``), ``pocket_bottom``, ``walls``, ``bottom``.
    ``pin=(x, y, radius, height)``: a blind bore from below, its end at
    ``height`` (above the pocket's bottom, which it then crosses: a part
    to take the pocket's bottom away from), groups ``bore_wall``,
    ``bore_end``."""
    b = _Builder()
    outer = lambda z: _rect(0, 0, size[0], size[1], z, n)
    ring = lambda z: np.column_stack([outline, np.full(len(outline), z)])
    b.zip(outer(1.0), ring(1.0), [0, 0, 1], "top")
    R0, R1 = ring(1.0 - depth), ring(1.0)
    m = len(outline)
    for i in range(m):
        j = (i + 1) % m
        d = outline[j] - outline[i]
        w = np.array([d[1], -d[0], 0.0])
        w = -w / np.linalg.norm(w)            # into the pocket (the outline turns counter-clockwise)
        b.strip(R0[[i, j]], R1[[i, j]], lambda p, w=w: w, f"pocket_wall {i}", closed=False)
    b.fan(ring(1.0 - depth), [0, 0, 1], "pocket_bottom")
    _side_walls(b, outer(0.0), outer(1.0), "walls", (size[0] / 2, size[1] / 2))
    if pin is None:
        b.fan(outer(0.0), [0, 0, -1], "bottom")
    else:
        x, y, r, top = pin
        bore = lambda z: _circle(x, y, r, z, segments)
        b.zip(outer(0.0), bore(0.0), [0, 0, -1], "bottom")
        b.strip(bore(0.0), bore(top), lambda p: -np.array([p[0] - x, p[1] - y, 0]), "bore_wall")
        b.fan(bore(top), [0, 0, -1], "bore_end")
    return b.mesh()


def octagon_with_rib(cx=2.0, cy=2.0, r=1.4, rib=0.08, reach=1.0):
    """A regular octagon's outline (counter-clockwise) with a thin rib
    (width ``rib``) running in from the middle of one side, ``reach`` long:
    a notch in the outline."""
    t = 2 * np.pi * (np.arange(8) + 0.5) / 8
    O = np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])
    # the side between corners 7 and 0 faces +x: notch it at its middle
    x_side = O[0, 0]
    notch = [[x_side, cy - rib / 2], [x_side - reach, cy - rib / 2], [x_side - reach, cy + rib / 2],
             [x_side, cy + rib / 2]]
    return np.vstack([O[7:8], notch, O[0:7]])


def cup_with_linked_ring(n=8):
    """A coarse cube without its top (a cup), and a closed thin ring (a
    torus) round the top of its wall ``x = 0``: it runs down through the
    opening and out through the wall, so it is linked with the opening's
    rim; every surface the rim bounds crosses it, the cup itself included
    (the input crosses itself where the ring goes through the wall)."""
    from eval import shapes

    V, F, g = coarse_cube(n)
    V, F = remove(V, F, g["top"])
    Vt, Ft = shapes.torus(R=0.3, r=0.03, nu=32, nv=8)
    Vt = Vt[:, [0, 2, 1]] + [0.0131, 0.5, 1.0173]      # its axis along y, off the grid's round values
    return np.vstack([V, Vt]), np.vstack([F, Ft + len(V)])


def pipe_with_wrapped_window(window=(6, 7, 0, 1, 2, 3), apothem=1.1, cavity=0.4, length=3.0, band=(1.0, 2.0),
                             bore=(1.5, 0.2, 1.5), segments=16):
    """An octagonal pipe (outer faces ``apothem`` from its axis, face 0
    facing +x; a square cavity ``cavity`` from the axis running its whole
    ``length``) with a window cut in its outer wall: the band of faces
    ``window`` between heights ``band``. Over 270 degrees, the window's
    outline folds over itself seen along any direction. A blind bore
    ``bore=(z, radius, reach)`` runs from the cavity's +x wall along +x
    out through the window's plane to x = ``reach``: scan crossing the
    opening inside it, joined to its rim only through the pipe. Groups
    ``window`` (not built: the opening), ``outer``, ``ends``, ``cavity``,
    ``bore_wall``, ``bore_end``."""
    b = _Builder()
    corner = apothem / np.cos(np.pi / 8)
    ang = np.radians(-22.5 + 45.0 * np.arange(8))
    octagon = np.column_stack([corner * np.cos(ang), corner * np.sin(ang)])
    heights = [0.0, band[0], band[1], length]
    for i in range(8):
        j = (i + 1) % 8
        mid = (octagon[i] + octagon[j]) / 2
        w = np.array([*mid, 0.0]) / np.linalg.norm(mid)
        for s in range(3):
            if s == 1 and i in window:
                continue
            lo = np.array([[*octagon[i], heights[s]], [*octagon[j], heights[s]]])
            hi = np.array([[*octagon[i], heights[s + 1]], [*octagon[j], heights[s + 1]]])
            b.strip(lo, hi, lambda p, w=w: w, "outer", closed=False)
    c = cavity
    square = np.array([[c, -c], [c, c], [-c, c], [-c, -c]])
    ring = lambda R, z: np.column_stack([R, np.full(len(R), z)])
    b.zip(ring(octagon, length), ring(square, length), [0, 0, 1], "ends")
    b.zip(ring(octagon, 0.0), ring(square, 0.0), [0, 0, -1], "ends")
    z0, r, reach = bore
    t = 2 * np.pi * np.arange(segments) / segments
    mouth = lambda x: np.column_stack([np.full(segments, x), r * np.cos(t), z0 + r * np.sin(t)])
    for i in range(4):
        a, d = square[i], square[(i + 1) % 4]
        wall = np.array([[*a, 0.0], [*d, 0.0], [*d, length], [*a, length]])
        inward = -np.array([*(a + d) / 2, 0.0]) / np.linalg.norm((a + d) / 2)
        if i == 0:          # the +x wall, the bore's mouth in it
            b.zip(wall, mouth(c), inward, "cavity")
        else:
            b.fan(wall, inward, "cavity")
    b.strip(mouth(c), mouth(reach), lambda p: -np.array([0.0, p[1], p[2] - z0]), "bore_wall")
    b.fan(mouth(reach), [-1.0, 0, 0], "bore_end")
    return b.mesh()
