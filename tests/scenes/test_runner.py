"""One runner for both kinds of scene: ``run_scene`` sets up, compiles, solves and compares the same way for a
static path and a motion, and returns a :class:`RunSummary` either way."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from flexbody.scenes import build, run_scene
from flexbody.scenes.compare import compare, compare_in_time, compare_with_reference
from flexbody.scenes.reference import Reference
from flexbody.scenes.runner import StaticRun
from flexbody.scenes.summary import DynamicRunSummary, RunSummary, StaticRunSummary


@pytest.mark.parametrize("name, params, kind, abscissa, cls", [
    ("cantilever_end_shear", dict(nx=2, steps=2), "static", "load_factor", StaticRunSummary),
    ("spinning_membrane", dict(n_circ=8, dt=0.01, end_time=0.06, ramp_time=0.02), "dynamic", "time",
     DynamicRunSummary),
])
def test_both_kinds_run_through_one_runner(name, params, kind, abscissa, cls):
    scene = build(name, **params)
    notices = []
    summary = run_scene(scene, notify=notices.append)
    assert isinstance(summary, RunSummary) and type(summary) is cls
    assert summary.kind == scene.kind == kind == summary.as_dict()["kind"]
    assert summary.abscissa == abscissa and list(summary.history)[0] == abscissa
    assert set(summary.final_outputs()) == {o.name for o in scene.outputs}
    assert summary.as_dict()["outputs"] == summary.final_outputs()
    assert [n.stage for n in notices][-1] in ("compiled", "loaded")
    assert summary.errors and summary.errors == compare(summary.history, scene.reference)
    assert min(summary.wall_time_s, summary.setup_time_s, summary.compile_time_s) >= 0


def test_compare_picks_the_measure_by_the_abscissa():
    ref = Reference(np.array([0.5, 1.0]), {"w": np.array([1.0, 2.0])})
    static = {"load_factor": [0.5, 1.0], "w": [1.1, 2.0]}
    dynamic = {"time": [0.0, 0.5, 1.0], "w": [0.0, 1.1, 2.0]}
    assert compare(static, ref) == compare_with_reference(static, ref)
    assert compare(dynamic, ref) == compare_in_time(dynamic, ref)
    assert [e["measure"] for e in compare(static, ref)] == ["load_level"] * 2
    assert [e["measure"] for e in compare(dynamic, ref)] == ["recorded"] * 2
    assert compare(static, ref)[0]["rel_error"] == pytest.approx(0.05)


def test_a_bad_method_fails_before_the_kernels_are_compiled():
    scene = build("cantilever_end_shear", nx=2, steps=2)
    scene.analysis = dataclasses.replace(scene.analysis, method="newton")
    notices = []
    with pytest.raises(ValueError, match="analysis method must be 'load_control' or 'arc_length', got 'newton'"):
        run_scene(scene, notify=notices.append)
    assert notices == []
    with pytest.raises(ValueError, match="got 'newton'"):
        StaticRun(scene)


def test_the_summary_base_is_abstract():
    with pytest.raises(TypeError):
        RunSummary("s", 1, 1, None, {}, [], 0.0)
