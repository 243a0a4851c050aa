"""Build the API reference of flexbody's public API (``import flexbody as fb``) from the docstrings, with pdoc.

Usage::

    python tools/api_reference.py [--out DIR]      # default DIR: build/api; then open DIR/index.html

The reference has one page for ``flexbody`` (every public name, with its signature and docstring, numpy
docstring format) and a page per module of ``EXTRA_MODULES`` that the public names' docstrings refer to.
The build fails (exit code 1, one line per problem) on any warning of pdoc (a name that does not resolve, a
docstring it cannot convert) and on a docstring cross-reference that names nothing (:func:`broken_references`;
pdoc itself renders such a reference as plain code without saying so). The generated HTML is not committed.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
from pathlib import Path
import re
import sys
import warnings

ROOT = Path(__file__).resolve().parents[1]
#: modules rendered next to ``flexbody`` (their pages are the targets of the docstrings' references)
EXTRA_MODULES = ("flexbody.scenes", "flexbody.energy", "integrators.static", "integrators.generalized_alpha",
                 "integrators.newton", "integrators.protocols")
#: a role reference (``:func:`name```) or a backticked dotted name of the package (```flexbody.x.y```)
_ROLE = re.compile(r":(?:py:)?(?:mod|func|data|const|class|meth|attr|exc|obj):`~?([^`<>]+?)`")
_DOTTED = re.compile(r"(?<![:\w])``?((?:flexbody|integrators)(?:\.\w+)+)(?:\(\))?``?")


def public_objects() -> dict[str, object]:
    """Every name of ``flexbody.__all__`` resolved (the lazy names are loaded here)."""
    import flexbody
    return {name: getattr(flexbody, name) for name in flexbody.__all__ if name != "__version__"}


def _documented(obj: object) -> list[tuple[str, object, object]]:
    """(qualified name, the object, its namespace for bare references) of ``obj`` and its public members."""
    out = [(getattr(obj, "__qualname__", repr(obj)), obj, obj)]
    if inspect.isclass(obj):
        for name, member in vars(obj).items():
            if name.startswith("_") and name != "__init__":
                continue
            target = member.fget if isinstance(member, property) else member
            if isinstance(target, (staticmethod, classmethod)):
                target = target.__func__
            if inspect.isfunction(target):
                out.append((f"{obj.__qualname__}.{name}", target, obj))
    return out


def _resolves(name: str, obj: object, owner: object) -> bool:
    """Whether a reference ``name`` from the docstring of ``obj`` names something."""
    import flexbody
    name = name.strip().removesuffix("()")
    first, _, rest = name.partition(".")
    if first in ("flexbody", "integrators"):
        parts = name.split(".")
        for k in range(len(parts), 0, -1):
            try:
                value = importlib.import_module(".".join(parts[:k]))
            except ImportError:
                continue
            try:
                for part in parts[k:]:
                    value = getattr(value, part)
                return True
            except AttributeError:
                return False
        return False
    module = sys.modules.get(getattr(obj, "__module__", "") or "")
    spaces = [getattr(owner, "__dict__", {}), vars(module) if module else {}, flexbody.__dict__]
    for space in spaces:
        if first in space or (space is flexbody.__dict__ and first in flexbody.__all__):
            value = space[first] if first in space else getattr(flexbody, first)
            try:
                for part in rest.split(".") if rest else []:
                    value = getattr(value, part)
                return True
            except AttributeError:
                return False
    if inspect.isclass(owner) and any(hasattr(base, first) for base in owner.__mro__):
        return True
    return False


def broken_references() -> list[str]:
    """The docstring cross-references of the public API that name nothing, as "where: reference" lines."""
    out = []
    for public in public_objects().values():
        for where, obj, owner in _documented(public):
            doc = inspect.getdoc(obj) or ""
            for ref in [*_ROLE.findall(doc), *_DOTTED.findall(doc)]:
                if not _resolves(ref, obj, owner):
                    out.append(f"{where}: {ref}")
    return sorted(set(out))


def build(out: Path) -> list[str]:
    """Render the reference into ``out``; the problems found (empty: a clean build)."""
    import pdoc
    import pdoc.render
    public_objects()                     # load the lazy names so that pdoc finds them in the module
    pdoc.render.configure(docformat="numpy", show_source=False, search=True,
                          footer_text="flexbody public API (import flexbody as fb)")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pdoc.pdoc("flexbody", *EXTRA_MODULES, output_directory=Path(out))
    problems = [f"pdoc: {str(w.message).splitlines()[0]}" for w in caught]
    return problems + [f"broken reference in {line}" for line in broken_references()]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "build" / "api"), help="output directory (default build/api)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    problems = build(Path(args.out))
    for line in problems:
        print(line, file=sys.stderr)
    if not problems:
        print(f"API reference written to {Path(args.out) / 'index.html'}")
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main())
