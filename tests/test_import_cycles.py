"""No import cycles in ``flexbody/`` and ``integrators/``, found by parsing the imports with ``ast``.

Every import counts, at module level or inside a function (a function-local import is a cycle that only
shows at run time), except those under ``if TYPE_CHECKING:`` (never executed). ``from a.b import c`` is an
edge to ``a.b.c`` when that is a module of the package, else to ``a.b``; a package's ``__init__`` is not an
implicit dependency of its submodules. A cycle is a strongly connected component of more than one module.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("flexbody", "integrators")

#: cycles that another piece of work removes; each entry must still be a cycle (the test says when to drop it)
KNOWN_CYCLES: tuple[frozenset[str], ...] = ()


def module_files(root: Path, packages=PACKAGES) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` file of the packages under ``root``."""
    modules = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join(parts)] = path
    return modules


def _type_checking_only(tree: ast.AST) -> set[int]:
    """ids of the nodes under ``if TYPE_CHECKING:`` (or ``typing.TYPE_CHECKING``)."""
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and ast.unparse(node.test) in ("TYPE_CHECKING", "typing.TYPE_CHECKING"):
            skipped.update(id(sub) for stmt in node.body for sub in ast.walk(stmt))
    return skipped


def imported_modules(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The modules of ``modules`` that module ``name`` (file ``path``) imports."""
    tree = ast.parse(path.read_text(), str(path))
    skipped = _type_checking_only(tree)
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                found.add(sub if sub in modules else source)
    return {m for m in found if m in modules and m != name}


def import_graph(root: Path, packages=PACKAGES) -> dict[str, set[str]]:
    modules = module_files(root, packages)
    return {name: imported_modules(name, path, modules) for name, path in modules.items()}


def import_cycles(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(frozenset(component))
    return cycles


def test_no_import_cycles():
    cycles = import_cycles(import_graph(REPO))
    new = [sorted(c) for c in cycles if c not in KNOWN_CYCLES]
    assert not new, f"import cycles: {new}"
    gone = [sorted(c) for c in KNOWN_CYCLES if c not in cycles]
    assert not gone, f"no longer a cycle, remove it from KNOWN_CYCLES: {gone}"


def test_the_scenes_modules_import_each_other_without_a_cycle():
    """The cycle this test was written for (the scene data and the dynamic runner) stays broken."""
    graph = import_graph(REPO)
    scenes = {m for m in graph if m.startswith("flexbody.scenes")}
    assert {"flexbody.scenes.scene", "flexbody.scenes.runner", "flexbody.scenes.dynamic_run"} <= scenes
    assert not [c for c in import_cycles(graph) if c & scenes]


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


@pytest.mark.parametrize("files, cycle", [
    # a module-level cycle through a relative import
    ({"pkg/__init__.py": "", "pkg/a.py": "from pkg import b\n", "pkg/b.py": "from . import a\n"},
     {"pkg.a", "pkg.b"}),
    # a three-module cycle closed by a function-local import (the kind scene.py <-> dynamic_run.py had)
    ({"pkg/__init__.py": "", "pkg/a.py": "import pkg.b\n", "pkg/b.py": "from pkg.c import f\n",
      "pkg/c.py": "def f():\n    from pkg.a import x\n"}, {"pkg.a", "pkg.b", "pkg.c"}),
    # through a package __init__ that re-exports a submodule
    ({"pkg/__init__.py": "", "pkg/sub/__init__.py": "from pkg.sub.x import y\n",
      "pkg/sub/x.py": "from pkg import z\n", "pkg/z.py": "from pkg.sub import y\n"},
     {"pkg.sub", "pkg.sub.x", "pkg.z"}),
])
def test_the_finder_reports_a_cycle(tmp_path, files, cycle):
    _write(tmp_path, files)
    assert import_cycles(import_graph(tmp_path, ("pkg",))) == [frozenset(cycle)]


def test_the_finder_ignores_type_checking_imports_and_outside_modules(tmp_path):
    _write(tmp_path, {"pkg/__init__.py": "", "pkg/a.py": "import numpy\nfrom pkg.b import f\n",
                      "pkg/b.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.a import g\n"
                                  "def f():\n    import os\n"})
    graph = import_graph(tmp_path, ("pkg",))
    assert graph["pkg.a"] == {"pkg.b"} and graph["pkg.b"] == set()
    assert import_cycles(graph) == []
