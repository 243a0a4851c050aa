"""The error figures against a reference: only at converged steps, and geometric on paths through a snap.

``flexbody.scenes.scene.compare_with_reference`` used to interpolate the computed path linearly at every
tabulated load level (the first crossing on a path whose load factor is not monotonic); the numbers quoted
"before" are what that version gave on the same data.
"""

import math

import numpy as np
import pytest

from flexbody.scenes import build, run_scene
from flexbody.scenes.scene import Reference, StaticAnalysis, compare_with_reference, nearest_on_polyline


def snap_back(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A path (u, lambda)(s), s in [0, 1], through a snap-back: both u and lambda fall on part of it."""
    return 3.0 * (s + 0.3 * np.sin(2 * np.pi * s)), s + 0.35 * np.sin(2 * np.pi * s + 0.5) - 0.35 * math.sin(0.5)


def test_nearest_on_polyline():
    line = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    dist, foot = nearest_on_polyline(np.array([[0.5, 0.2], [2.0, 0.5], [-1.0, 0.0]]), line)
    assert dist == pytest.approx([0.2, 1.0, 1.0])
    assert foot == pytest.approx(np.array([[0.5, 0.0], [1.0, 0.5], [0.0, 0.0]]))


def test_a_snap_back_path_on_its_reference_has_a_small_error():
    """Steps that lie on the reference path, at other stations than the table's: before, 0.33 (33 %) at
    the load levels (the first crossing of a level is often on another branch); now the distance to the path."""
    s_ref = np.linspace(0.0, 1.0, 201)
    u_ref, lam_ref = snap_back(s_ref)
    assert np.any(np.diff(lam_ref) < 0) and np.any(np.diff(u_ref) < 0)       # snap-through and snap-back
    s = (np.arange(30) + 0.37) / 30
    u, lam = snap_back(s)
    errors = compare_with_reference({"load_factor": list(lam), "u": list(u)}, Reference(lam_ref, {"u": u_ref}))
    assert max(e["rel_error"] for e in errors) < 1e-3                       # measured 4.7e-5 (the chords' sag)
    assert len(errors) == 30 and {e["measure"] for e in errors} == {"path"}
    off = compare_with_reference({"load_factor": list(lam), "u": list(1.05 * u)},
                                 Reference(lam_ref, {"u": u_ref}))
    assert max(e["rel_error"] for e in off) > 0.02                           # a path 5 % off is seen: 3.4e-2


def test_a_monotonic_path_is_compared_at_its_steps_without_interpolation():
    """Steps at every other tabulated level of a curved path and between them: compared at the levels they
    step onto, exactly (measure "load_level"; the steps between are not compared: that would interpolate
    the table); before, the interpolation between the steps gave 4.9e-3."""
    lam_ref = np.linspace(0.0, 2.0, 41)
    lam = np.sort(np.concatenate([lam_ref[2::2], lam_ref[2::2] - 0.03]))
    errors = compare_with_reference({"load_factor": list(lam), "w": list(np.sin(np.pi * lam))},
                                    Reference(lam_ref, {"w": np.sin(np.pi * lam_ref)}))
    assert max(e["rel_error"] for e in errors) < 1e-12
    assert len(errors) == 20 and {e["measure"] for e in errors} == {"load_level"}
    assert [e["load_factor"] for e in errors] == list(lam_ref[2::2])        # the tabulated levels


def test_a_monotonic_path_off_the_tabulated_levels_is_measured_by_its_distance():
    """No step on a tabulated level (7 steps against a table every 0.05): every step by its distance to
    the reference path."""
    lam_ref = np.linspace(0.0, 1.0, 21)
    lam = np.arange(1, 8) / 7
    lam[-1] = 1.0 + 1e-3                                                  # beyond the table: not compared
    errors = compare_with_reference({"load_factor": list(lam), "w": list(np.sin(lam) * 1.01)},
                                    Reference(lam_ref, {"w": np.sin(lam_ref)}))
    assert len(errors) == 6 and {e["measure"] for e in errors} == {"path"}
    assert 1e-3 < max(e["rel_error"] for e in errors) < 1.01e-2           # 1 % off in value, less in distance


def rolled_twice(steps: int):
    """The end-moment strip (2 x 32 x 1) rolled twice into a circle (2 M_max), load levels every 2 / ``steps``
    M_max, with the exact elastica tabulated every 0.05 M_max."""
    from dataclasses import replace
    scene = build("cantilever_end_moment", nx=32)
    L = 12.0
    lf = np.linspace(0.0, 2.0, 41)
    theta = 2 * np.pi * np.where(lf > 0, lf, 1.0)
    exact = {"minus_U_tip": np.where(lf > 0, L * (1 - np.sin(theta) / theta), 0.0),
             "W_tip": np.where(lf > 0, L * (1 - np.cos(theta)) / theta, 0.0)}
    return replace(scene, analysis=StaticAnalysis("load_control", tuple(np.linspace(0.0, 2.0, steps + 1)[1:])),
                   reference=Reference(lf, exact, "exact elastica"))


def test_the_strip_rolled_twice_in_coarse_steps_reports_its_true_error():
    """Load levels 0.2 M_max apart (72 degrees of the tip; load control cuts some steps in two): before,
    8.3e-2 from the linear interpolation between the steps at the tabulated levels; at the steps themselves
    7.1e-5."""
    summary = run_scene(rolled_twice(10))
    assert summary.result.converged and summary.result.load_factor == 2.0
    assert summary.max_rel_error < 1e-3
    steps = len(summary.result.records)
    assert len(summary.errors) == 2 * steps and {e["measure"] for e in summary.errors} == {"load_level"}
    d = summary.as_dict()
    assert set(np.round(np.linspace(0.2, 2.0, 10), 9)) <= set(np.round(d["history"]["load_factor"], 9))
    assert len(d["history"]["W_tip"]) == len(d["history"]["minus_U_tip"]) == d["steps"] == steps


def test_the_json_summary_carries_the_path_history(tmp_path):
    """Load factor and every tracked output at every converged step (before: only the last values)."""
    import json

    from flexbody.cli import main
    path = tmp_path / "run.json"
    assert main(["run", "cantilever_end_shear", "--set", "nx=4", "--set", "steps=4", "--json", str(path),
                 "--quiet"]) == 0
    d = json.loads(path.read_text())
    assert d["history"]["load_factor"] == pytest.approx([0.25, 0.5, 0.75, 1.0])
    assert set(d["history"]) == {"load_factor", "minus_U_tip", "W_tip"}
    assert d["history"]["W_tip"][-1] == d["outputs"]["W_tip"] and len(d["history"]["W_tip"]) == d["steps"]
    assert len(d["errors"]) == 8 and {e["measure"] for e in d["errors"]} == {"load_level"}
