"""The documentation runs: docs/example.md's code and the package's docstring examples."""

import doctest
import importlib
import os
import pkgutil
import re
from pathlib import Path

import pytest

import shellrepair

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "example.md"


def python_blocks(markdown):
    """The ```python fenced blocks of a Markdown text, in order."""
    return re.findall(r"^```python\n(.*?)^```", markdown, flags=re.S | re.M)


def test_python_blocks_are_found_in_markdown():
    text = "x\n```python\na = 1\n```\n```\nnot python\n```\n```python\nb = a\n```\n"
    assert python_blocks(text) == ["a = 1\n", "b = a\n"]


@pytest.mark.slow
def test_worked_example_runs_as_written(tmp_path, monkeypatch):
    blocks = python_blocks(EXAMPLE.read_text())
    assert len(blocks) >= 5
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "bunny_zipper.ply").symlink_to(ROOT / "data" / "bunny_zipper.ply")
    monkeypatch.chdir(tmp_path)
    scope = {"__name__": "example"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{EXAMPLE.name} block {i + 1}", "exec"), scope)  # one namespace, as a reader types it
    assert (tmp_path / "bunny.repaired.ply").stat().st_size > 0
    assert (tmp_path / "bunny.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _modules():
    return sorted(m.name for m in pkgutil.walk_packages(shellrepair.__path__, "shellrepair."))


def test_the_package_has_docstring_examples_to_run():
    n = sum(len(t.examples) for name in ["shellrepair"] + _modules()
            for t in doctest.DocTestFinder().find(importlib.import_module(name)))
    assert n >= 5


@pytest.mark.parametrize("name", ["shellrepair", "shellrepair.options", "shellrepair.progress"])
def test_docstring_examples_of_the_api_pass(name, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    res = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS, verbose=False)
    assert res.attempted > 0 and res.failed == 0
