"""Typed, checked access to the tables of a scene file: every bad value is one :class:`SceneError` line naming
the file, the dotted key and the value (:class:`Table`); :func:`read_table` reads a table by its spec
(:mod:`flexbody.scenes.toml_spec`); :func:`call_checked` turns a flexbody constructor's ValueError into the same
kind of line."""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from flexbody.scenes.toml_spec import MAX_STEPS, REQUIRED, Key, TableSpec

__all__ = ["SceneError", "Table", "read_table", "read_value", "finish", "call_checked", "MAX_STEPS", "REQUIRED"]


class SceneError(ValueError):
    """A scene that cannot be built as given; the message is one line naming the key and value."""


class Table:
    """A TOML table read key by key; :meth:`done` reports the keys nobody asked for."""

    def __init__(self, data: Any, path: str, where: str):
        if not isinstance(data, dict):
            raise SceneError(f"{where}: {path} must be a table, got {data!r}")
        self.data, self.path, self.where = data, path, where
        self.used: set[str] = set()

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, message: str) -> SceneError:
        return SceneError(f"{self.where}: {self.key(name)} {message}")

    def has(self, name: str) -> bool:
        return name in self.data

    def raw(self, name: str, default: Any = REQUIRED) -> Any:
        self.used.add(name)
        if name not in self.data:
            if default is REQUIRED:
                raise SceneError(f"{self.where}: missing key {self.key(name)}")
            return default
        return self.data[name]

    def number(self, name: str, default: Any = REQUIRED, *, positive: bool = False) -> float:
        value = self.raw(name, default)
        if value is None and default is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(name, f"must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.error(name, f"must be > 0, got {value!r}")
        return float(value)

    def integer(self, name: str, default: Any = REQUIRED, *, minimum: int = 1, maximum: int | None = None) -> int:
        value = self.raw(name, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(name, f"must be an integer >= {minimum}, got {value!r}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be an integer in {minimum}..{maximum}, got {value!r}")
        return value

    def boolean(self, name: str, default: Any = REQUIRED) -> bool:
        value = self.raw(name, default)
        if not isinstance(value, bool):
            raise self.error(name, f"must be true or false, got {value!r}")
        return value

    def string(self, name: str, default: Any = REQUIRED, *, choices: tuple[str, ...] | None = None) -> str:
        value = self.raw(name, default)
        if not isinstance(value, str) or not value:
            raise self.error(name, f"must be a non-empty string, got {value!r}")
        if choices is not None and value not in choices:
            raise self.error(name, f"must be one of {', '.join(map(repr, choices))}, got {value!r}")
        return value

    def vector(self, name: str, default: Any = REQUIRED) -> np.ndarray:
        value = self.raw(name, default)
        ok = (isinstance(value, list) and len(value) == 3
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
        if not ok:
            raise self.error(name, f"must be a list of three finite numbers, got {value!r}")
        return np.array(value, dtype=float)

    def direction(self, name: str, vector: np.ndarray) -> np.ndarray:
        """The unit vector of the direction ``vector`` read from key ``name`` (a nonzero vector, any size)."""
        from flexbody.frames import unit_vector
        try:
            return unit_vector(vector, "direction")
        except ValueError:
            raise self.error(name, f"must be a nonzero vector, got {vector.tolist()}") from None

    def numbers(self, name: str, default: Any = REQUIRED) -> list[float]:
        value = self.raw(name, default)
        ok = (isinstance(value, list) and len(value) > 0
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
        if not ok:
            raise self.error(name, f"must be a non-empty list of finite numbers, got {value!r}")
        return [float(v) for v in value]

    def table(self, name: str, default: Any = REQUIRED) -> "Table":
        return Table(self.raw(name, default), self.key(name), self.where)

    def tables(self, name: str) -> list["Table"]:
        value = self.raw(name, [])
        if isinstance(value, dict):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error(name, f"must be an array of tables ([[{name}]]), got {value!r}")
        return [Table(v, f"{self.key(name)}.{i}", self.where) for i, v in enumerate(value)]

    def reject_unknown(self, known: tuple[str, ...]) -> None:
        """Report a key that is not in ``known`` before anything is built."""
        unknown = [k for k in self.data if k not in known]
        if unknown:
            where = f"[{self.path}]" if self.path else "the top level"
            raise SceneError(f"{self.where}: unknown key {self.key(unknown[0])!r}; "
                             f"keys allowed in {where}: {', '.join(known)}")

    def done(self, known: tuple[str, ...] | list[str] | None = None) -> None:
        unknown = [k for k in self.data if k not in self.used]
        if unknown:
            allowed = list(dict.fromkeys(known)) if known is not None else sorted(self.used)
            where = f"[{self.path}]" if self.path else "the top level"
            raise SceneError(f"{self.where}: unknown key {self.key(unknown[0])!r}; "
                             f"keys allowed in {where}: {', '.join(allowed)}")


_OWN = object()       # the key's own default


def read_value(key: Key, t: Table, default: Any = _OWN) -> Any:
    """The value of ``key`` in ``t``, checked against the key's kind, choices and range (``default``: the
    key's own unless given; :data:`REQUIRED`: required here). An absent key whose default is None is None."""
    name = key.name
    default = key.default if default is _OWN else default
    if default is None and not t.has(name):
        t.used.add(name)
        return None
    if key.kind == "number":
        value = t.number(name, default, positive=key.bound == ">0")
        if key.bound == ">=0" and value < 0:
            raise t.error(name, f"must be >= 0, got {value!r}")
        return value
    if key.kind == "integer":
        return t.integer(name, default, minimum=key.minimum, maximum=key.maximum)
    if key.kind == "string":
        return t.string(name, default, choices=key.choices or None)
    if key.kind == "tables":
        return t.tables(name)
    read = {"boolean": t.boolean, "vector": t.vector, "numbers": t.numbers, "any": t.raw, "table": t.table}
    return read[key.kind](name, default)


def read_table(spec: TableSpec, t: Table, variant: str | None = None, *, defaults: dict[str, Any] | None = None,
               done: bool = True) -> dict[str, Any]:
    """The values of the keys of ``spec`` in ``t``, in the spec's order, by :func:`read_value`.

    The variant is the value of the spec's ``switch`` key (read first), or ``variant``: only its keys are read
    and allowed. Node selections are left to the caller. ``defaults``: defaults that depend on the scene
    (``name``: the file's name). ``done``: report a key the variant does not allow (else call :func:`finish`).
    """
    values: dict[str, Any] = {}
    defaults = defaults or {}
    if spec.switch is not None and variant is None:
        variant = values[spec.switch] = read_value(spec[spec.switch], t, defaults.get(spec.switch, _OWN))
    for key in spec.keys:
        if key.kind != "selection" and key.name not in values and key.belongs_to(variant):
            values[key.name] = read_value(key, t, defaults.get(key.name, _OWN))
    if done:
        finish(spec, t, variant)
    return values


def finish(spec: TableSpec, t: Table, variant: str | None = None) -> None:
    """Report the first key of ``t`` that no one read, with the keys the ``variant`` of ``spec`` allows."""
    t.done(spec.names(variant))


def call_checked(where: str, key: str, func: Callable, *args, **kwargs):
    """Call a flexbody constructor and turn its ValueError into a one-line SceneError naming ``key``."""
    try:
        return func(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if message.lower().startswith(key.lower() + " "):  # "material: material thickness ..." -> once
            raise SceneError(f"{where}: {message}") from None
        raise SceneError(f"{where}: {key}: {message}") from None
