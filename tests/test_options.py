"""One options object for the library, the batch and the command line."""

import numpy as np
import pytest

from shellrepair import MeshError
from shellrepair.options import RepairOptions
from shellrepair.repair import repair_mesh
from eval.shapes import icosphere


@pytest.mark.parametrize("bad, word", [(dict(order=4), "order"), (dict(order=True), "order"),
                                       (dict(smooth=-1), "smooth"), (dict(smooth=1.5), "smooth"),
                                       (dict(max_hole=0), "max_hole"), (dict(jobs=0), "jobs"),
                                       (dict(method="x"), "method"), (dict(bridge="x"), "bridge"),
                                       (dict(closed="yes"), "closed"), (dict(fill_borders=1), "fill_borders")])
def test_a_bad_option_is_one_error_that_names_the_option_not_a_flag(bad, word):
    with pytest.raises(MeshError) as exc:
        RepairOptions(**bad)
    assert str(exc.value).startswith(word + " must") and "--" not in str(exc.value)


def test_options_and_keywords_give_the_same_repair_bit_for_bit():
    V, F = icosphere(3)
    F = F[12:]
    a, ra = repair_mesh((V, F), RepairOptions(order="auto", jobs=1))
    b, rb = repair_mesh((V, F), order="auto")
    c, rc = repair_mesh((V, F), RepairOptions(order=2), order="auto")   # keywords over options
    for m in (b, c):
        assert np.array_equal(a.V, m.V) and np.array_equal(a.F, m.F)
    drop = lambda rows: [{k: v for k, v in h.items() if k != "seconds"} for h in rows]
    assert drop(ra["holes"]) == drop(rb["holes"])


def test_unknown_options_and_numpy_integers():
    with pytest.raises(MeshError, match="unknown repair option"):
        RepairOptions().replace(colour="red")
    o = RepairOptions(jobs=np.int64(2), max_hole=np.int32(50))
    assert type(o.jobs) is int and type(o.max_hole) is int and o.as_dict()["jobs"] == 2


def test_batch_and_the_command_line_take_order_auto_and_refuse_bad_values(tmp_path, capsys):
    from shellrepair.cli import main
    from shellrepair.mesh.io import Mesh, write_mesh

    V, F = icosphere(2)
    (tmp_path / "in").mkdir()
    write_mesh(tmp_path / "in" / "s.ply", Mesh(V=V, F=F[4:]))
    assert main(["batch", str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--order", "auto", "--no-html"]) == 0
    capsys.readouterr()
    # the messages name the options as the command line spells them
    with pytest.raises(SystemExit) as exit_:
        main(["holes", str(tmp_path / "in" / "s.ply"), "--max-hole", "-5"])
    assert exit_.value.code == 2 and "--max-hole: must be at least 1 edge" in capsys.readouterr().err
    assert main(["repair", str(tmp_path / "in" / "s.ply"), "--jobs", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --jobs must be") and err.count("\n") == 1


def test_order_flat_is_an_option_of_the_library_and_the_command_line(tmp_path, capsys):
    from shellrepair.cli import main
    from shellrepair.mesh.io import Mesh, read_mesh, write_mesh

    assert RepairOptions(order="flat").order == "flat"
    assert RepairOptions(order_for={3: "flat"}).order_for == {3: "flat"}
    V, F = icosphere(2)
    write_mesh(tmp_path / "s.ply", Mesh(V=V, F=F[4:]))
    assert main(["repair", str(tmp_path / "s.ply"), "-o", str(tmp_path / "o.ply"), "--order", "flat", "-q"]) == 0
    assert len(read_mesh(tmp_path / "o.ply").V) == len(V)          # no new vertex


def test_every_option_of_every_command_says_what_it_does_and_its_default():
    from shellrepair.cli import build_parser

    p = build_parser()
    subs = next(a for a in p._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, sub in subs.choices.items():
        for a in sub._actions:
            if a.dest == "help":
                continue
            assert a.help, (name, a.dest)
            if a.option_strings and not a.required:
                assert "default" in a.help, (name, a.option_strings)
