"""The top-level API takes the meshes users hold and hands them back."""

import numpy as np
import pytest

import shellrepair
from shellrepair import MeshError, as_mesh, to_open3d
from eval.shapes import icosphere


def _open_sphere():
    V, F = icosphere(2)
    return V, F[5:]          # a few faces missing: one hole


def test_repair_mesh_takes_a_pair_and_an_open3d_mesh_alike():
    V, F = _open_sphere()
    _, from_pair = shellrepair.repair_mesh((V, F))
    o3 = to_open3d(shellrepair.Mesh(V=V, F=F))
    _, from_legacy = shellrepair.repair_mesh(o3)
    _, from_tensor = shellrepair.repair_mesh(to_open3d((V, F), tensor=True))
    assert from_pair["holes_before"] == 1 and from_pair["holes_after"] == 0
    assert from_legacy["faces_after"] == from_pair["faces_after"]
    # the tensor mesh holds float32 positions: same topology, same count
    assert from_tensor["holes_before"] == 1 and from_tensor["holes_after"] == 0


def test_open3d_round_trip_keeps_positions_and_faces():
    V, F = _open_sphere()
    m = as_mesh(to_open3d((V, F)))
    assert np.array_equal(m.V, V) and np.array_equal(m.F, F)


@pytest.mark.parametrize("bad", [np.zeros((3, 3)), (np.zeros((3, 2)), np.zeros((1, 3), int)),
                                 (np.zeros((3, 3)), np.array([[0, 1, 5]]))])
def test_what_is_not_a_mesh_is_one_clear_error(bad):
    with pytest.raises(MeshError):
        as_mesh(bad)


def test_version_on_the_command_line(capsys):
    from shellrepair.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"shellrepair {shellrepair.__version__}"


@pytest.mark.parametrize("ext, magic", [(".jpg", b"\xff\xd8\xff"), (".png", b"\x89PNG"), (".tiff", b"II*\x00")])
def test_render_writes_the_format_its_extension_names(tmp_path, ext, magic):
    from shellrepair.cli import main

    V, F = _open_sphere()
    scan = tmp_path / "s.ply"
    shellrepair.write_mesh(scan, shellrepair.Mesh(V=V, F=F))
    out = tmp_path / ("view" + ext)
    assert main(["render", str(scan), "-o", str(out), "--size", "64x48"]) == 0
    assert out.read_bytes()[:len(magic)] == magic


def test_render_refuses_an_unknown_image_extension_before_the_work(tmp_path, capsys):
    from shellrepair.cli import main

    V, F = _open_sphere()
    scan = tmp_path / "s.ply"
    shellrepair.write_mesh(scan, shellrepair.Mesh(V=V, F=F))
    assert main(["render", str(scan), "-o", str(tmp_path / "view.gif")]) == 2
    assert "unknown image extension '.gif'" in capsys.readouterr().err
    assert not (tmp_path / "view.gif").exists()


def test_a_mesh_prints_as_one_short_line():
    V, F = icosphere(5)
    text = repr(shellrepair.Mesh(V=V, F=F))
    assert text == f"Mesh({len(V):,} vertices, {len(F):,} faces)" and "\n" not in text


def test_highlight_filled_on_a_mesh_without_flags_says_so(tmp_path, capsys):
    from shellrepair.cli import main

    V, F = _open_sphere()
    scan = tmp_path / "s.ply"
    shellrepair.write_mesh(scan, shellrepair.Mesh(V=V, F=F))
    assert main(["render", str(scan), "-o", str(tmp_path / "v.png"), "--size", "48x32", "--highlight-filled"]) == 0
    assert "no face is flagged filled" in capsys.readouterr().err


def test_the_top_level_functions_carry_type_hints_that_resolve():
    import typing

    for name in ("read_mesh", "write_mesh", "repair_mesh", "detect_holes", "as_mesh", "to_open3d", "to_trimesh"):
        hints = typing.get_type_hints(getattr(shellrepair, name))  # raises if a name does not resolve
        assert "return" in hints, name
    assert typing.get_type_hints(shellrepair.repair_mesh)["return"] == tuple[shellrepair.Mesh, dict]
