"""The fill's local region (context._Region): on a large scan with few holes,
vertex-face lists and near faces come from the faces around the loops,
not from whole-mesh structures, and the repair is the same to the bit."""

import numpy as np
import pytest

from eval import shapes
from shellrepair import compiled
from shellrepair.mesh import index as context
from shellrepair.mesh import index_kernels as context_kernels
from shellrepair.mesh import topology_kernels
from shellrepair.mesh.io import Mesh
from shellrepair.mesh.index import ScanContext
from shellrepair.mesh.topology import edge_topology

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="the region needs the compiled kernels")


def _holed(sub=6, n_holes=3, radius=0.12, seed=1):
    V, F = shapes.bumpy_sphere(sub, amplitude=0.03, frequency=5)
    V2, F2, _, _ = shapes.perforate_discs(V, F, n_holes=n_holes, radius=radius, seed=seed)
    return V2, F2


def _ctx(V, F):
    ctx = ScanContext(Mesh(V=V, F=F), topo=edge_topology(F, len(V)))
    return ctx


@pytest.mark.parametrize("seed", range(3))
def test_faces_in_boxes_equal_the_brute_force_test(seed):
    rng = np.random.default_rng(seed)
    V, F = shapes.bumpy_sphere(3)
    V = V * 100 + 1e6 if seed == 2 else V          # far from the origin
    V[5] = np.nan if seed == 1 else V[5]           # a NaN vertex counts as meeting
    c = V[rng.integers(10, len(V), size=1 + seed)]    # boxes around surface points
    lo = c - rng.uniform(0.05, 0.5, size=c.shape) * np.nanstd(V, axis=0)
    hi = c + rng.uniform(0.05, 0.5, size=c.shape) * np.nanstd(V, axis=0)
    faces, fmin, fmax, inside = context_kernels.faces_in_boxes(V, F, lo, hi)
    T = V[F]
    tmin, tmax = T.min(axis=1), T.max(axis=1)
    meets = np.zeros(len(F), bool)
    for a, b in zip(lo, hi):
        meets |= np.all((tmax >= a) & (tmin <= b), axis=1)
    meets |= np.isnan(T).any(axis=(1, 2))
    assert np.array_equal(faces, np.flatnonzero(meets)) and faces.size
    ok = ~np.isnan(T[faces]).any(axis=(1, 2))
    assert np.array_equal(fmin[ok], tmin[faces][ok]) and np.array_equal(fmax[ok], tmax[faces][ok])
    vin = np.zeros(len(V), bool)
    for a, b in zip(lo, hi):
        vin |= np.all((V >= a) & (V <= b), axis=1)
    assert np.array_equal(inside, vin)


def test_the_region_lists_are_the_whole_mesh_lists_where_complete(monkeypatch):
    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    V, F = _holed()
    ctx = _ctx(V, F)
    reg = ctx.region()
    assert reg is not None and 0 < reg.faces.size < len(F)
    order, start = topology_kernels.vertex_faces(F, len(V))
    for v in np.flatnonzero(reg.covered)[::7]:
        assert np.array_equal(reg.vf_order[reg.vf_start[v]:reg.vf_start[v + 1]], order[start[v]:start[v + 1]])
    loops = np.unique(ctx.topo.ends(ctx.topo.boundary_he))
    assert reg.covered[loops].all()
    # ring walks from the loops: the region's, then (their lists read) the whole mesh's
    got = [ctx.ring_faces(loops, r) for r in (1, 2, 6)]
    assert ctx._vf is None                         # answered from the region
    assert ctx.faces_of(loops[:5]).size and ctx._vf is None
    far = np.flatnonzero(~reg.covered)[:3]
    ctx.faces_of(far)                              # outside it: the whole-mesh lists
    assert ctx._vf is not None
    assert all(np.array_equal(g, ctx.ring_faces(loops, r)) for g, r in zip(got, (1, 2, 6)))


def test_near_faces_of_the_region_hold_every_face_meeting_the_box(monkeypatch):
    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    V, F = _holed()
    ctx = _ctx(V, F)
    local, whole = ctx.index, ctx.whole_index()
    assert isinstance(local, context.LocalIndex)
    assert np.array_equal(local.origin, whole.origin)
    T = V[F]
    tmin, tmax = T.min(axis=1), T.max(axis=1)
    reg = ctx.region()
    rng = np.random.default_rng(0)
    for k in range(len(reg.lo)):
        c = 0.5 * (reg.lo[k] + reg.hi[k])
        h = 0.2 * (reg.hi[k] - reg.lo[k]) * rng.uniform(0.2, 1)
        lo, hi = c - h, c + h
        meets = np.flatnonzero(np.all((tmax >= lo) & (tmin <= hi), axis=1))
        a = local.faces_near(lo, hi)
        assert np.all(np.diff(a) > 0) and np.isin(meets, a).all() and np.isin(meets, whole.faces_near(lo, hi)).all()
    lo, hi = V.min(axis=0), V.max(axis=0)          # beyond the region: the whole-mesh index answers
    assert np.array_equal(local.faces_near(lo, hi), whole.faces_near(lo, hi))


@pytest.mark.parametrize("grow, rings", [(context.LOCAL_GROW, context.LOCAL_RING_EDGES), (0.0, 0)])
@pytest.mark.slow
def test_a_repair_from_the_region_equals_the_whole_mesh_repair(grow, rings, monkeypatch):
    """Bit for bit, with the region as built and with boxes so tight that
    queries fall outside them (the whole-mesh structures answer those)."""
    from shellrepair.repair import repair_mesh

    V, F = _holed(n_holes=4, radius=0.1, seed=3)
    out = {}
    real = context.region_of
    for local in (False, True):
        monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0 if local else 10 ** 12)
        monkeypatch.setattr(context, "LOCAL_GROW", grow)
        monkeypatch.setattr(context, "LOCAL_RING_EDGES", rings)
        built = []
        monkeypatch.setattr(context, "region_of", lambda V, F, topo: built.append(real(V, F, topo)) or built[-1])
        out[local] = repair_mesh(Mesh(V=V, F=F))
        assert (built[0] is not None) == local
    (a, ra), (b, rb) = out[False], out[True]
    assert ra["holes_after"] == rb["holes_after"] == 0 and ra["holes_before"] == 4
    assert np.array_equal(a.F, b.F) and np.array_equal(a.V, b.V)
    assert np.array_equal(a.face_filled, b.face_filled)


def test_no_region_for_many_loops_or_a_small_mesh(monkeypatch):
    V, F = _holed(sub=4, n_holes=12, radius=0.12, seed=2)
    assert _ctx(V, F).region() is None             # small mesh (LOCAL_MIN_FACES)
    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    assert _ctx(V, F).region() is None             # more loops than boxes
    ctx = ScanContext(Mesh(V=V, F=F))
    assert ctx.region() is None                    # no edge topology given


def test_a_repair_from_the_region_with_two_processes_equals_one(monkeypatch):
    from shellrepair.repair import repair_mesh

    V, F = _holed(n_holes=4, radius=0.1, seed=3)
    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    (a, _), (b, _) = repair_mesh(Mesh(V=V, F=F)), repair_mesh(Mesh(V=V, F=F), jobs=2)
    assert np.array_equal(a.F, b.F) and np.array_equal(a.V, b.V) and len(a.F) > len(F)


def test_the_index_built_in_the_background_is_the_index_built_in_line(monkeypatch):
    """repair_mesh with jobs > 1 builds the whole-mesh index on two workers
    while the order test reads the vertex-face lists: those come from the
    lists' own worker (once), and the index answers as one built in line."""
    from concurrent.futures import ThreadPoolExecutor

    V, F = _holed(sub=5, n_holes=12, radius=0.08, seed=2)   # more loops than a region takes
    line = _ctx(V, F)
    calls = []
    real = topology_kernels.vertex_faces
    monkeypatch.setattr(topology_kernels, "vertex_faces", lambda *a: calls.append(1) or real(*a))
    bg = _ctx(V, F)
    with ThreadPoolExecutor(2) as ex:
        done = bg.index_in_background(ex)
        assert bg._vf_future is not None            # the lists are on their way
        order, start = bg.vf                        # waits for them, builds nothing
        index = done.result()
    assert index is bg.index is bg.whole_index() and len(calls) == 1
    want = line.index
    assert np.array_equal(order, line.vf[0]) and np.array_equal(start, line.vf[1])
    rng = np.random.default_rng(3)
    for c in V[rng.integers(0, len(V), 20)]:
        lo, hi = c - 0.05, c + 0.05
        assert np.array_equal(index.faces_near(lo, hi), want.faces_near(lo, hi))


def test_a_region_is_built_once_when_two_threads_ask(monkeypatch):
    from concurrent.futures import ThreadPoolExecutor

    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    V, F = _holed()
    ctx = _ctx(V, F)
    built = []
    real = context.region_of
    monkeypatch.setattr(context, "region_of", lambda V, F, topo: built.append(1) or real(V, F, topo))
    with ThreadPoolExecutor(2) as ex:
        regs = list(ex.map(lambda _: ctx.region(), range(4)))
    assert len(built) == 1 and all(r is regs[0] for r in regs) and regs[0] is not None


def test_a_region_started_early_is_taken_only_for_the_contexts_own_arrays(monkeypatch):
    """take_region accepts a region on its way only for the very arrays and
    topology the context holds; region() then returns it."""
    from concurrent.futures import Future

    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    V, F = _holed()
    ctx = _ctx(V, F)
    fut = Future()
    fut.set_result(context.region_of(V, F, ctx.topo))
    assert not ctx.take_region(fut, V.copy(), F, ctx.topo)                  # equal, not the same array
    assert not ctx.take_region(fut, V, F.copy(), ctx.topo)
    assert not ctx.take_region(fut, V, F, edge_topology(F, len(V)))          # another topology object
    assert ctx.take_region(fut, V, F, ctx.topo)
    assert ctx.region() is fut.result() and ctx.region() is not None


@pytest.mark.parametrize("fixed", [False, True])
def test_two_jobs_build_the_region_once_and_repair_as_one_job_does(fixed, monkeypatch):
    """With two jobs the region is started before the mesh is made manifold
    (a (V, F) pair) or at once (a mesh read_mesh prepared); it is built once
    and the repair is the one a single job gives, to the bit."""
    from shellrepair.mesh.io import manifold_mesh
    from shellrepair.repair import repair_mesh

    import threading

    from shellrepair import repair

    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    V, F = _holed(n_holes=4, radius=0.1, seed=3)
    real = context.region_of
    real_manifold = repair.manifold_mesh
    out = {}
    for jobs in (1, 2):
        built = []
        started = threading.Event()
        overlapped = []

        def region_of(V_, F_, t):
            started.set()
            built.append(real(V_, F_, t))
            return built[-1]

        def manifold(*a, **k):       # the region is on its way while the mesh is made manifold
            overlapped.append(started.wait(timeout=60 if jobs > 1 else 0))
            return real_manifold(*a, **k)

        monkeypatch.setattr(context, "region_of", region_of)
        monkeypatch.setattr(repair, "manifold_mesh", manifold)
        mesh = real_manifold(Mesh(V=V, F=F), orient=False) if fixed else Mesh(V=V, F=F)
        if fixed:
            mesh.fixes = dict(mesh.fixes) or {"vertices_joined": 0}
        out[jobs] = repair_mesh(mesh, jobs=jobs, order=2)
        assert len(built) == 1 and built[0] is not None
        assert overlapped == ([] if fixed else [jobs > 1])
    (a, ra), (b, rb) = out[1], out[2]
    assert ra["holes_before"] == 4 and ra["holes_after"] == rb["holes_after"] == 0
    assert np.array_equal(a.F, b.F) and np.array_equal(a.V, b.V) and np.array_equal(a.face_filled, b.face_filled)


def test_without_a_region_two_jobs_start_the_whole_mesh_lists_early_and_build_them_once(monkeypatch):
    """Where there is no region (here: a mesh below LOCAL_MIN_FACES), the
    whole-mesh vertex-face lists are started with the region's attempt,
    built once, and the repair is the one a single job gives."""
    from shellrepair.repair import repair_mesh

    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 10 ** 12)
    V, F = _holed(n_holes=4, radius=0.1, seed=3)
    real = topology_kernels.vertex_faces
    out = {}
    for jobs in (1, 2):
        whole = []
        monkeypatch.setattr(topology_kernels, "vertex_faces", lambda F_, n: (whole.append(len(F_)) if len(F_) == len(F)
                                                                    else None) or real(F_, n))
        out[jobs] = repair_mesh(Mesh(V=V, F=F), jobs=jobs, order="auto")
        assert whole == [len(F)]
    (a, ra), (b, rb) = out[1], out[2]
    assert ra["holes_after"] == rb["holes_after"] == 0
    assert np.array_equal(a.F, b.F) and np.array_equal(a.V, b.V) and np.array_equal(a.face_filled, b.face_filled)


def test_a_mesh_made_manifold_on_its_way_drops_the_early_region_and_repairs_as_one_job(monkeypatch):
    """A (V, F) pair whose making manifold changes the arrays (a triangle
    touching the surface at one vertex: the vertex is split): the region
    started on the pair is not used, the context builds its own, and two
    jobs repair as one does."""
    from shellrepair.repair import repair_mesh

    monkeypatch.setattr(context, "LOCAL_MIN_FACES", 0)
    V, F = _holed(n_holes=3, radius=0.1, seed=5)
    V = np.vstack([V, V[0] + [0.1, 0.0, 0.0], V[0] + [0.0, 0.1, 0.0]])
    F = np.vstack([F, [[0, len(V) - 2, len(V) - 1]]])
    real = context.region_of
    out = {}
    for jobs in (1, 2):
        seen = []
        monkeypatch.setattr(context, "region_of", lambda V_, F_, t: seen.append(len(V_)) or real(V_, F_, t))
        out[jobs] = repair_mesh(Mesh(V=V, F=F), jobs=jobs, order=2)
        assert seen[-1] == len(V) + 1                 # the context's region: of the mesh with the split vertex
        assert seen[:-1] == ([len(V)] if jobs > 1 else [])   # the early one, on the pair as given
    (a, ra), (b, rb) = out[1], out[2]
    assert ra["holes_before"] == rb["holes_before"] and ra["holes_after"] == rb["holes_after"]
    assert np.array_equal(a.F, b.F) and np.array_equal(a.V, b.V) and np.array_equal(a.face_filled, b.face_filled)
