"""A scene file as a document: reading it, and the ``--set`` overrides by dotted key (``mesh.nx``,
``load.0.value``) or by the last part of a key when that is unambiguous. The bare keys that may be set although
the file does not write them come from the table specs (:func:`flexbody.scenes.toml_spec.settable_keys`) and the
mesh generator's parameters."""

from __future__ import annotations

import copy
import inspect
from pathlib import Path
import tomllib
from typing import Any, Callable

from flexbody.scenes.toml_spec import GENERATOR_NAMES, settable_keys
from flexbody.scenes.toml_values import SceneError


# ----------------------------------------------------------------------------------------------------------
# Reading and overriding
# ----------------------------------------------------------------------------------------------------------

def read_toml(path: str | Path) -> dict:
    """The parsed TOML document of a scene file.

    Raises
    ------
    SceneError
        If the file is missing or not valid TOML (the message carries tomllib's line and column).
    """
    path = Path(path)
    if not path.is_file():
        raise SceneError(f"scene file {str(path)!r} does not exist")
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene file {str(path)!r} is not valid TOML: {exc}") from None
    except OSError as exc:
        raise SceneError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}") from None


def flatten(doc: dict, prefix: str = "") -> dict[str, Any]:
    """The leaves of a TOML document by dotted key; arrays of tables are indexed (``load.0.value``)."""
    out: dict[str, Any] = {}
    for key, value in doc.items():
        path = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, path + "."))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for i, item in enumerate(value):
                out.update(flatten(item, f"{path}.{i}."))
        else:
            out[path] = value
    return out


def section_keys(doc: dict) -> dict[str, str]:
    """Bare keys that may be set although the document does not write them: key -> dotted key."""
    keys = settable_keys()
    generator = doc.get("mesh", {}).get("generator") if isinstance(doc.get("mesh"), dict) else None
    if generator in GENERATOR_NAMES:
        for k in inspect.signature(generator_function(generator)).parameters:
            keys[k] = f"mesh.{k}"
    return keys


def resolve_key(doc: dict, key: str, where: str) -> str:
    """The dotted key that ``--set key=...`` addresses in ``doc`` (see the module docstring)."""
    leaves = flatten(doc)
    if "." in key or key in leaves:
        return key
    matches = [k for k in leaves if k.rsplit(".", 1)[-1] == key]
    if len(matches) == 1:
        return matches[0]
    if len(matches) > 1:
        raise SceneError(f"{where}: --set key {key!r} is ambiguous; use one of {', '.join(matches)}")
    known = section_keys(doc)
    if key in known:
        return known[key]
    raise SceneError(f"{where}: unknown parameter {key!r}; documented keys: {', '.join(sorted(leaves))} "
                     "(or any dotted key of the format, see docs/scenes.md)")


def apply_overrides(doc: dict, overrides: dict[str, Any], where: str) -> dict:
    """A copy of ``doc`` with the ``--set`` overrides applied (keys as in :func:`resolve_key`)."""
    doc = copy.deepcopy(doc)
    for key, value in overrides.items():
        parts = resolve_key(doc, key, where).split(".")
        node: Any = doc
        for depth, part in enumerate(parts[:-1]):
            here = ".".join(parts[:depth + 1])
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise SceneError(f"{where}: --set {key}: {'.'.join(parts[:depth])} has no entry {part!r} "
                                     f"({len(node)} entries, numbered from 0)")
                node = node[int(part)]
            elif isinstance(node, dict):
                node = node.setdefault(part, {})  # a new table; the format check rejects unknown ones
            else:
                raise SceneError(f"{where}: --set {key}: {here!r} is a value, not a table")
        if not isinstance(node, dict):
            raise SceneError(f"{where}: --set {key}: {'.'.join(parts[:-1])!r} is not a table")
        node[parts[-1]] = value
    return doc


def generator_function(name: str) -> Callable:
    """The mesh generator of :mod:`flexbody.mesh.generators` named ``name``."""
    from flexbody.mesh import generators
    return getattr(generators, name)
