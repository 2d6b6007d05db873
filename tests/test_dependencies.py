"""The package requires what it imports, and nothing else.

Read from pyproject.toml's ``[project].dependencies`` and from every import
statement under shellrepair/ (imports inside functions included): each
required distribution is imported somewhere in the package, and each
third-party module the package imports is required, or belongs to an extra
of the library's own (``cluster``: Dask, imported only when asked for), never
to the test, bench or docs extras.
"""

import ast
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "shellrepair"

#: Distributions whose import name is not their name (lower case, "-" as "_").
MODULE_OF = {"open3d-cpu": "open3d", "libigl": "igl", "pillow": "PIL", "scikit-image": "skimage",
             "fast-simplification": "fast_simplification", "mapbox-earcut": "mapbox_earcut"}
#: Extras that add library features (the package imports them when asked for).
LIBRARY_EXTRAS = {"cluster"}


def _pyproject():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        tomllib = pytest.importorskip("tomli")
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def modules_of(requirement):
    """The top-level modules a requirement string provides: its
    distribution's, and its extras' (``dask[distributed]``: dask and distributed)."""
    m = re.match(r"\s*([A-Za-z0-9_.\-]+)\s*(?:\[([^\]]*)\])?", requirement)
    name = m.group(1).lower().replace("_", "-")
    mods = {MODULE_OF.get(name, name.replace("-", "_"))}
    if m.group(2):
        mods |= {e.strip().replace("-", "_") for e in m.group(2).split(",") if e.strip()}
    return mods


def imported_modules():
    """``{top-level module: files importing it}`` of every absolute import
    under shellrepair/ that is neither the standard library nor the package."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for n in names:
                top = n.split(".")[0]
                if top != "shellrepair" and top not in sys.stdlib_module_names and top != "__future__":
                    found.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return found


def test_every_required_distribution_is_imported_by_the_package():
    imported = imported_modules()
    unused = [r for r in _pyproject()["project"]["dependencies"] if not modules_of(r) & imported.keys()]
    assert unused == [], f"required but imported nowhere in shellrepair/: {unused}"


def test_every_third_party_module_the_package_imports_is_required():
    project = _pyproject()["project"]
    required = set().union(*(modules_of(r) for r in project["dependencies"]))
    extras = project.get("optional-dependencies", {})
    library = set().union(set(), *(modules_of(r) for e in LIBRARY_EXTRAS for r in extras.get(e, [])))
    undeclared = {m: sorted(f) for m, f in imported_modules().items() if m not in required | library}
    assert undeclared == {}, f"imported by shellrepair/ but not required: {undeclared}"


def test_the_requirement_names_map_to_their_modules():
    assert modules_of("open3d-cpu>=0.18") == {"open3d"}
    assert modules_of("libigl>=2.5") == {"igl"}
    assert modules_of("dask[distributed]>=2023.1") == {"dask", "distributed"}
    assert modules_of("mapbox_earcut>=1.0") == {"mapbox_earcut"}
    assert modules_of("fast-simplification>=0.1.7") == {"fast_simplification"}
