"""Fuzz the TOML scene builder: a mutated scene document either builds or fails with a SceneError.

Mutations of the example scene: a key deleted, a value replaced by a value of another type or out of range
(NaN, inf, negative, zero, empty, strings, nested tables), an unknown key added. Nothing but the documented
``SceneError`` (one line naming the key) may come out.
"""

import copy
import math
from pathlib import Path

from hypothesis import HealthCheck, given, settings, strategies as st

from flexbody.scenes.toml_scene import SceneError, read_toml, scene_from_document

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "cantilever_end_shear.toml"
DOC = read_toml(EXAMPLE)


def paths(doc, prefix=()):
    """Every (path, value) in a nested document of tables and arrays of tables."""
    for key, value in doc.items():
        here = prefix + (key,)
        yield here
        if isinstance(value, dict):
            yield from paths(value, here)
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for i, v in enumerate(value):
                yield from paths(v, here + (i,))


PATHS = list(paths(DOC))

odd_values = st.one_of(
    st.none(), st.booleans(), st.integers(-10, 10), st.sampled_from([0.0, -1.0, math.nan, math.inf, 1e300, -1e-300]),
    st.text(max_size=5), st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)


def container(doc, path):
    node = doc
    for p in path[:-1]:
        node = node[p]
    return node


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.sampled_from(PATHS), st.sampled_from(["delete", "replace", "extra"]), odd_values),
                min_size=1, max_size=3))
def test_mutated_scene_builds_or_says_why(mutations):
    doc = copy.deepcopy(DOC)
    doc["mesh"]["nx"], doc["analysis"]["steps"] = 2, 1  # keep every valid build cheap
    for path, action, value in mutations:
        try:
            parent = container(doc, path)
            key = path[-1]
            if action == "delete":
                del parent[key]
            elif action == "replace":
                parent[key] = value
            elif isinstance(parent, dict):
                parent["unknown_key_x"] = value
        except (KeyError, IndexError, TypeError):
            continue  # an earlier mutation removed or replaced the path
    try:
        scene_from_document(doc, EXAMPLE)
    except SceneError as exc:
        message = str(exc)
        assert message and "\n" not in message
