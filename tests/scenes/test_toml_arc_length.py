"""Every arc-length setting can be set from a scene file ([analysis]) and is checked with a one-line error."""

import pytest

from flexbody.scenes.scene import run_scene
from flexbody.scenes.toml_scene import SceneError, load_toml_scene
from tests.scenes.test_toml_scene import EXAMPLES

OPTIONS = {"max_steps": 3, "min_increment_ratio": 0.01, "max_increment_ratio": 8.0, "desired_iterations": 4}


def test_arc_length_options_reach_the_solver():
    scene = load_toml_scene(EXAMPLES / "pullout_cylinder.toml", {"n_circ": 3, "n_axial": 2, **OPTIONS})
    assert scene.analysis.arc_options == OPTIONS
    summary = run_scene(scene)
    assert not summary.result.converged and len(summary.result.records) == 3
    assert "arc-length reached max_steps=3" in summary.result.message


@pytest.mark.parametrize("key, value, message", [
    ("max_steps", 0, "analysis.max_steps must be an integer >= 1, got 0"),
    ("desired_iterations", 2.5, "analysis.desired_iterations must be an integer >= 1, got 2.5"),
    ("min_increment_ratio", 1.5, "arc-length min_increment_ratio must lie in (0, 1), got 1.5"),
    ("max_increment_ratio", 0.5, "arc-length max_increment_ratio must be >= 1, got 0.5"),
])
def test_bad_arc_length_options_are_one_line_errors(key, value, message):
    with pytest.raises(SceneError) as info:
        load_toml_scene(EXAMPLES / "pullout_cylinder.toml", {key: value})
    assert message in str(info.value) and "\n" not in str(info.value)
