"""Mutations of scene documents for the scene-parser fuzz tests: delete a key, replace a value by one of
another type or out of range, add an unknown key."""

import copy
import math

from hypothesis import strategies as st


def document_paths(doc, prefix=()):
    """Every key path in a nested document of tables and arrays of tables."""
    for key, value in doc.items():
        here = prefix + (key,)
        yield here
        if isinstance(value, dict):
            yield from document_paths(value, here)
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for i, v in enumerate(value):
                yield from document_paths(v, here + (i,))


ODD_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-10, 10), st.sampled_from([0.0, -1.0, math.nan, math.inf, 1e300, -1e-300]),
    st.text(max_size=5), st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)


def mutations(doc):
    """A strategy of 1-3 (path, action, value) mutations of ``doc``."""
    return st.lists(st.tuples(st.sampled_from(list(document_paths(doc))),
                              st.sampled_from(["delete", "replace", "extra"]), ODD_VALUES), min_size=1, max_size=3)


def mutate(doc: dict, changes) -> dict:
    """A deep copy of ``doc`` with the mutations applied (those whose path an earlier one removed are skipped)."""
    doc = copy.deepcopy(doc)
    for path, action, value in changes:
        try:
            parent = doc
            for p in path[:-1]:
                parent = parent[p]
            if action == "delete":
                del parent[path[-1]]
            elif action == "replace":
                parent[path[-1]] = value
            elif isinstance(parent, dict):
                parent["unknown_key_x"] = value
        except (KeyError, IndexError, TypeError):
            continue
    return doc
