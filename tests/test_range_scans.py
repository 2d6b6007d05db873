"""Single-view range scans: every hole closed, nothing crossed, the file kept.

A range scan seen from one side is an open sheet with an outer border,
holes where something in front hid the surface, islands, and pieces that
meet at single vertices. The promise on such a scan, checked on the files
a user gets (written by the command line, read back as bytes):

* the file's own vertices and faces come first in the output, bit for bit
  (a vertex where two pieces meet is one vertex in the output as in the
  input, not two at one position);
* no face is added that meets a face it shares no vertex with (MeshLab's
  per-face self-intersection test, the count users run), and the exact
  count of crossing pairs does not grow;
* every loop classed ``hole`` is filled, the outer border is kept.

The scans are made by ray-casting one view of closed meshes
(:func:`eval.shapes.range_scan`): an in-repository scene (a bumpy sphere
behind a ball and a ring) and the closed real meshes of ../shared/data,
beside the real range scan of the Stanford dragon.
"""

import json

import numpy as np
import pytest

from eval import shapes
from shellrepair import Mesh, read_mesh, write_mesh
from shellrepair.cli import main
from shellrepair.mesh.formats.ply import read_ply
from shellrepair.mesh.intersect import self_intersections

from conftest import shared_scan

pymeshlab = pytest.importorskip("pymeshlab", reason="the test extra's MeshLab counts self-intersecting faces")


def _scene():
    """A bumpy sphere, a ball and a ring in front of it (towards -y)."""
    V1, F1 = shapes.bumpy_sphere(4, amplitude=0.05, seed=3)
    V2, F2 = shapes.icosphere(3, radius=0.3)
    V3, F3 = shapes.torus(0.5, 0.12, 48, 16)
    V = np.vstack([V1, V2 + [0.0, -1.6, 0.3], V3 + [0.6, -1.3, -0.5]])
    F = np.vstack([F1, F2 + len(V1), F3 + len(V1) + len(V2)])
    return V, F


def _meshlab_self_intersecting(path):
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    ms.compute_selection_by_self_intersections_per_face()
    return int(ms.current_mesh().selected_face_number())


def assert_range_scan_repaired(src, tmp_path):
    """Repair the file ``src`` with the command line; check the promises above."""
    out = tmp_path / "out.ply"
    before = src.read_bytes()
    assert main(["repair", str(src), "-o", str(out)]) == 0
    report = json.loads((tmp_path / "out.report.json").read_text())
    raw_in, raw_out = read_ply(before), read_ply(out.read_bytes())
    n, m = len(raw_in.V), len(raw_in.F)
    assert np.array_equal(raw_out.V[:n].view(np.uint64), raw_in.V.view(np.uint64))
    assert np.array_equal(raw_out.F[:m], raw_in.F)
    assert not raw_out.face_filled[:m].any() and raw_out.face_filled[m:].all()
    assert _meshlab_self_intersecting(out) == _meshlab_self_intersecting(src)
    assert self_intersections(raw_out.V, raw_out.F) == self_intersections(raw_in.V, raw_in.F)
    assert report["failed"] == 0 and report["holes_after"] == 0, [h["reason"] for h in report["holes"]]
    assert src.read_bytes() == before
    return report


@pytest.mark.parametrize("view", [(0.3, 1.0, 0.1), (0.0, 1.0, -0.4), (-0.4, 1.0, 0.3)])
@pytest.mark.slow
def test_a_range_scan_of_a_scene_is_filled_without_crossing(tmp_path, view):
    P, T = shapes.range_scan(*_scene(), view=view, resolution=160)
    src = tmp_path / "scan.ply"
    write_mesh(src, Mesh(V=P, F=T))
    report = assert_range_scan_repaired(src, tmp_path)
    # the ball and the ring hide part of the sphere: there are holes to fill
    assert report["filled"] >= 1


@pytest.mark.parametrize("name", ["armadillo", "rocker_arm_genus1", "nefertiti_bust", "cheburashka", "fandisk_cad"])
@pytest.mark.slow
def test_range_scans_of_real_meshes_are_filled_without_crossing(tmp_path, name):
    m = read_mesh(shared_scan(f"closed_{name}.ply"))
    for k, view in enumerate([(0.3, -1.0, 0.4), (-0.5, 0.5, 1.0)]):
        P, T = shapes.range_scan(m.V, m.F, view=view, resolution=200)
        d = tmp_path / str(k)
        d.mkdir()
        write_mesh(d / "scan.ply", Mesh(V=P, F=T))
        assert_range_scan_repaired(d / "scan.ply", d)


@pytest.mark.slow
def test_the_real_dragon_range_scan_gains_no_self_intersecting_face(tmp_path):
    src = tmp_path / "dragon.ply"
    src.write_bytes(shared_scan("real_rangescan_dragon_000.ply").read_bytes())
    report = assert_range_scan_repaired(src, tmp_path)
    # its 16 vertices where pieces meet at a point are one vertex each in the output too
    assert report["nonmanifold_vertices_split"] == 16


def test_a_vertex_where_two_pieces_meet_is_written_once(tmp_path):
    # two triangles meeting at one vertex (a bow tie): the reader splits the
    # vertex for the topology, the written file has it once, as read
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], np.float64)
    F = np.array([[0, 1, 2], [0, 3, 4]], np.int64)
    write_mesh(tmp_path / "a.ply", Mesh(V=V, F=F))
    m = read_mesh(tmp_path / "a.ply")
    assert len(m.V) == 6 and m.fixes["nonmanifold_vertices_split"] == 1
    write_mesh(tmp_path / "b.ply", m)
    again = read_ply((tmp_path / "b.ply").read_bytes())
    assert np.array_equal(again.V, V) and np.array_equal(again.F, F)
