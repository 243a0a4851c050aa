"""The key tables of docs/scenes.md, rendered from the table specs (:mod:`flexbody.scenes.toml_spec`).

docs/scenes.md marks each generated table by ``<!-- generated: scene keys NAME -->`` ...
``<!-- end generated -->``; :func:`rewrite` replaces what lies between by :func:`render` of the table group
``NAME`` (:data:`GROUPS`). ``tools/scene_key_tables.py`` writes the file (or, with ``--check``, says whether it
lags the specs).
"""

from __future__ import annotations

import re
from typing import Any, Callable

from flexbody.scenes import toml_spec as spec
from flexbody.scenes.toml_spec import REQUIRED, Key, TableSpec, toml_text

#: the generated tables of docs/scenes.md: name -> the specs they show, in order
GROUPS: dict[str, Callable[[], tuple[TableSpec, ...]]] = {
    "static": lambda: (spec.TOP, spec.MESH, spec.MATERIAL, spec.ELEMENT, spec.BC, spec.LOAD, spec.ANALYSIS,
                       spec.newton_spec(), spec.OUTPUT, spec.REFERENCE),
    "dynamic": lambda: (spec.DYNAMIC, spec.INITIAL, spec.HUB, spec.POLYGON,
                        spec.integrator_spec(), spec.DAMPING, spec.TIME_FUNCTION, spec.POINT_MASS),
    "selections": lambda: (spec.SELECTION, spec.RING, spec.PLANE),
    "velocity_field": lambda: (spec.VELOCITY_FIELD,),
}

HEADER = "| table | key | value | default | meaning |\n|---|---|---|---|---|"
_BEGIN = re.compile(r"<!-- generated: scene keys (\w+) -->\n")
_END = "<!-- end generated -->"


def render_value(value: Any) -> str:
    """A default value as TOML writes it, in backticks (``"lumped"``, ``[0, 0, 0]``; numbers and booleans
    bare)."""
    text = toml_text(value)
    return f"`{text}`" if isinstance(value, (str, list, tuple)) else text


def default_cell(key: Key) -> str:
    """The default column: empty for a required key or a key without a default."""
    if key.shown is not None:
        return key.shown
    if key.default is REQUIRED or key.default is None or key.kind in ("table", "tables"):
        return ""
    return render_value(key.default)


def value_cell(key: Key) -> str:
    """The value column: the key's type and its allowed values or range."""
    if key.choices:
        choices = ", ".join(render_value(c) for c in key.choices)
        return f"true, false, {choices}" if key.kind == "any" and isinstance(key.default, bool) else choices
    if key.kind == "number":
        return {"": "number", ">0": "number > 0", ">=0": "number >= 0"}[key.bound]
    if key.kind == "integer":
        return f"integer >= {key.minimum}" if key.maximum is None else f"integer {key.minimum}..{key.maximum}"
    return {"boolean": "true or false", "string": "string", "vector": "[x, y, z]", "numbers": "list of numbers",
            "table": "table", "tables": "array of tables", "any": key.form or "", "selection": ""}[key.kind]


def key_cell(key: Key) -> str:
    """The key column: the key, and the variants it belongs to."""
    name = "a node selection (below)" if key.kind == "selection" else f"`{key.name}`"
    return f"{name} ({', '.join(key.only)})" if key.only else name


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _settings_row(table: TableSpec) -> str:
    """One row for a table of settings fields: every field with its type and default."""
    keys = ", ".join(f"`{k.name}` ({value_cell(k)}, {default_cell(k)})" for k in table.keys)
    return f"| {table.heading} | {keys} | | | {_cell(table.doc)} |"


def rows(table: TableSpec) -> list[str]:
    """The rows of one table: its heading and doc first, then one row per key."""
    if table.path in ("analysis.newton", "analysis.integrator"):
        return [_settings_row(table)]
    out = [f"| {table.heading} | | | | {_cell(table.doc)} |"]
    for key in table.keys:
        if table is spec.TOP and key.kind in ("table", "tables"):
            continue                                   # the sections have tables of their own
        out.append(f"| | {key_cell(key)} | {_cell(value_cell(key))} | {_cell(default_cell(key))} | "
                   f"{_cell(key.doc)} |")
    return out


def render(group: str) -> str:
    """The markdown table of the table group ``group`` (:data:`GROUPS`)."""
    return "\n".join([HEADER, *(row for table in GROUPS[group]() for row in rows(table))]) + "\n"


def rewrite(text: str) -> str:
    """``text`` (docs/scenes.md) with every generated region rendered anew.

    Raises
    ------
    ValueError
        If a region names no table group or has no end marker.
    """
    out, pos = [], 0
    for match in _BEGIN.finditer(text):
        if match.start() < pos:
            raise ValueError(f"generated region {match.group(1)!r} starts inside the previous one")
        name = match.group(1)
        if name not in GROUPS:
            raise ValueError(f"generated region {name!r} names no table group; groups: {', '.join(GROUPS)}")
        end = text.find(_END, match.end())
        if end < 0:
            raise ValueError(f"generated region {name!r} has no {_END!r}")
        out += [text[pos:match.end()], render(name)]
        pos = end
    out.append(text[pos:])
    return "".join(out)


def regions(text: str) -> list[str]:
    """The names of the generated regions of ``text``, in order."""
    return [m.group(1) for m in _BEGIN.finditer(text)]
