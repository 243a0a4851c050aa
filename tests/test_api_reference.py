"""The API reference builds from the docstrings of the public API (tools/api_reference.py, pdoc) without
a warning, and every docstring cross-reference of the public API names something."""

import importlib.util
import inspect
from pathlib import Path

import pytest

import flexbody as fb

ROOT = Path(__file__).resolve().parents[1]


def reference_tool():
    spec = importlib.util.spec_from_file_location("api_reference", ROOT / "tools" / "api_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_api_reference_builds_without_problems(tmp_path):
    pytest.importorskip("pdoc")
    tool = reference_tool()
    assert tool.build(tmp_path) == []
    page = (tmp_path / "flexbody.html").read_text()
    missing = [name for name in fb.__all__ if name != "__version__" and f'id="{name}"' not in page]
    assert missing == [], f"public names without an entry in the reference: {missing}"
    assert "Parameters" in page and (tmp_path / "index.html").is_file()
    for module in tool.EXTRA_MODULES:
        assert (tmp_path / (module.replace(".", "/") + ".html")).is_file()


def test_broken_cross_references_are_found():
    tool = reference_tool()

    def documented() -> None:
        """See :func:`solve_static`, :class:`flexbody.loads.NodalLoad`, ``flexbody.solve.StaticSolution.state``,
        :func:`no_such_function` and ``flexbody.loads.no_such_load``."""

    doc = inspect.getdoc(documented)
    refs = [*tool._ROLE.findall(doc), *tool._DOTTED.findall(doc)]
    assert sorted(refs) == sorted(["solve_static", "flexbody.loads.NodalLoad", "no_such_function",
                                   "flexbody.solve.StaticSolution.state", "flexbody.loads.no_such_load"])
    broken = [r for r in refs if not tool._resolves(r, documented, documented)]
    assert sorted(broken) == ["flexbody.loads.no_such_load", "no_such_function"]
    assert tool.broken_references() == []
