"""Fuzz the TOML scene builder: a mutated scene document either builds or fails with a SceneError.

Mutations of the example scene: a key deleted, a value replaced by a value of another type or out of range
(NaN, inf, negative, zero, empty, strings, nested tables), an unknown key added. Nothing but the documented
``SceneError`` (one line naming the key) may come out.
"""

import copy
from pathlib import Path

from hypothesis import HealthCheck, given, settings

from flexbody.scenes.toml_scene import SceneError, read_toml, scene_from_document
from tests.scenes.mutations import mutate, mutations

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "cantilever_end_shear.toml"
DOC = copy.deepcopy(read_toml(EXAMPLE))
DOC["mesh"]["nx"], DOC["analysis"]["steps"] = 2, 1  # keep every valid build cheap


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutations(DOC))
def test_mutated_scene_builds_or_says_why(changes):
    try:
        scene_from_document(mutate(DOC, changes), EXAMPLE)
    except SceneError as exc:
        message = str(exc)
        assert message and "\n" not in message
