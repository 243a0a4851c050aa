"""The values given on the command line: ``--set KEY=VALUE`` and the lists ``KEY=V1,V2,...`` of
``--refine``, ``--grid`` and ``--sweep``, and ``--load-factor``."""

from __future__ import annotations

import ast
import math

from flexbody.cli.errors import CliError


def parse_value(text: str):
    """A ``--set`` value: a Python/TOML-style literal (numbers, lists, true/false), else the text itself."""
    lowered = text.lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def value_list(text: str) -> list:
    """``V1,V2,...`` -> [parse_value(V1), parse_value(V2), ...] (empty items left out)."""
    return [parse_value(v.strip()) for v in text.split(",") if v.strip()]


def parse_sets(items: list[str]) -> dict:
    """``--set KEY=VALUE`` items -> {KEY: value} (:func:`parse_value`); a later KEY wins."""
    out = {}
    for item in items:
        if "=" not in item:
            raise CliError(f"--set expects KEY=VALUE, got {item!r}")
        key, value = item.split("=", 1)
        if not key.strip():
            raise CliError(f"--set expects KEY=VALUE, got {item!r}")
        out[key.strip()] = parse_value(value.strip())
    return out


def parse_refine(items: list[str]) -> list[dict]:
    """``--refine nx=4,8,16 --refine ny=1,2,4`` -> [{nx: 4, ny: 1}, {nx: 8, ny: 2}, {nx: 16, ny: 4}]."""
    columns: dict[str, list] = {}
    for item in items:
        if "=" not in item:
            raise CliError(f"--refine expects KEY=V1,V2,..., got {item!r}")
        key, values = item.split("=", 1)
        columns[key.strip()] = value_list(values)
        if not columns[key.strip()]:
            raise CliError(f"--refine {key.strip()} has no values")
    lengths = {len(v) for v in columns.values()}
    if len(lengths) > 1:
        raise CliError(f"--refine lists must have the same length, got "
                       f"{', '.join(f'{k}: {len(v)}' for k, v in columns.items())}")
    n = lengths.pop() if lengths else 0
    return [{k: v[i] for k, v in columns.items()} for i in range(n)]


def parse_grid(items: list[str]) -> dict[str, list]:
    """``--grid nx=2,4 --grid thickness=0.01,0.02`` -> {nx: [2, 4], thickness: [0.01, 0.02]}."""
    grids: dict[str, list] = {}
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key.strip():
            raise CliError(f"--grid expects KEY=V1,V2,..., got {item!r}")
        if key.strip() in grids:
            raise CliError(f"--grid {key.strip()} is given twice")
        grids[key.strip()] = value_list(values)
        if not grids[key.strip()]:
            raise CliError(f"--grid {key.strip()} has no values")
    return grids


def parse_sweep(text: str) -> tuple[str, list]:
    """``--sweep KEY=V1,V2,...`` of ``flexbody modes`` -> (KEY, values); the spin rates of ``omega`` must be
    finite numbers >= 0."""
    if "=" not in text:
        raise CliError(f"--sweep expects KEY=V1,V2,..., got {text!r}")
    key, values = text.split("=", 1)
    key = key.strip()
    parsed = value_list(values)
    if not key or not parsed:
        raise CliError(f"--sweep expects KEY=V1,V2,..., got {text!r}")
    if key == "omega":
        for v in parsed:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise CliError(f"--sweep omega values must be finite numbers >= 0 (rad/s), got {v!r}")
    return key, parsed


def parse_load_factor(text: str | None) -> float | str | None:
    """``--load-factor L|end`` -> a finite float, "end", or None (not given)."""
    if text is None or text == "end":
        return text
    try:
        value = float(text)
    except ValueError:
        raise CliError(f"--load-factor must be a number or 'end', got {text!r}") from None
    if not math.isfinite(value):
        raise CliError(f"--load-factor must be finite, got {text!r}")
    return value
