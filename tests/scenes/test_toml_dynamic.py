"""TOML scene files with ``[analysis] type = "dynamic"``: initial spin, hub, gravity, outputs, errors."""

import copy
import json
from pathlib import Path
import textwrap

from hypothesis import HealthCheck, given, settings
import numpy as np
import pytest

from flexbody.cli import main
from flexbody.scenes import build, load_toml_scene, run_scene
from flexbody.scenes.sources import SceneError
from flexbody.scenes.toml_scene import read_toml, scene_from_document
from tests.scenes.mutations import mutate, mutations

REPO = Path(__file__).resolve().parents[2]

PLATE = textwrap.dedent("""
    name = "spinning_plate_toml"
    [mesh]
    generator = "strip"
    length = 1.0
    width = 1.0
    nx = 2
    ny = 2
    [material]
    young = 1e6
    poisson = 0.3
    thickness = 0.01
    density = 1000.0
    [analysis]
    type = "dynamic"
    dt = 2e-3
    end_time = 0.02
    [analysis.initial]
    angular_velocity = [0.0, 0.0, 10.0]      # about the centre of mass (the default center)
    [[output]]
    name = "u_r_corner"
    type = "radial"
    near = [1.0, 1.0, 0.0]
    center = [0.5, 0.5, 0.0]
    [[output]]
    name = "omega_z"
    type = "angular_velocity"
    component = "z"
""")


def write(tmp_path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_example_file_is_the_builtin_hub_membrane():
    toml_scene = load_toml_scene(REPO / "examples" / "spinning_membrane.toml")
    builtin_scene = build("spinning_membrane")
    # the reference CSV holds the analytic values (11 digits) at the built-in scene's times
    np.testing.assert_allclose(toml_scene.reference.times, builtin_scene.reference.times, rtol=1e-12)
    for name in ("u_r_mid", "u_r_outer"):
        np.testing.assert_allclose(toml_scene.reference.values[name], builtin_scene.reference.values[name], rtol=1e-9)
    # the same model and motion: the same trajectory (through the ramp and 10 ms beyond, to save time)
    toml = run_scene(load_toml_scene(REPO / "examples" / "spinning_membrane.toml", {"end_time": 0.06}))
    builtin = run_scene(build("spinning_membrane", end_time=0.06))
    assert toml.steps == builtin.steps == 60
    for name in ("u_r_mid", "u_r_outer"):
        np.testing.assert_allclose(toml.history[name], builtin.history[name], rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(toml.energies["total"], builtin.energies["total"], rtol=1e-12)


def test_an_initial_spin_about_the_centre_of_mass_is_the_builtin_plate(tmp_path):
    toml = run_scene(load_toml_scene(write(tmp_path, PLATE)))
    builtin = run_scene(build("spinning_plate", nx=2, ny=2, end_time=0.02))
    np.testing.assert_allclose(toml.history["u_r_corner"], builtin.history["u_r_corner"], rtol=1e-9, atol=1e-15)
    # the fitted spin rate starts at the given one; the plate stretches (its inertia grows) and, with its
    # angular momentum kept, it spins slower: measured 9.77 rad/s at 0.02 s
    assert toml.history["omega_z"][0] == pytest.approx(10.0, rel=1e-12)
    assert 9.5 < toml.history["omega_z"][-1] < 9.99
    L = np.array(toml.energies["angular_momentum"])[:, 2]
    assert np.abs(L - L[0]).max() < 5e-4 * L[0]                    # measured 1.6e-4 (8 elements, 10 steps)


def test_gravity_and_an_initial_velocity_give_the_free_fall(tmp_path):
    text = PLATE.replace('angular_velocity = [0.0, 0.0, 10.0]      # about the centre of mass (the default center)',
                         'velocity = [0.0, 0.0, 2.0]')
    text = text.replace('end_time = 0.02', 'end_time = 0.5\ngravity = [0.0, 0.0, -9.81]\nrho_inf = 0.7')
    text = text.replace('dt = 2e-3', 'dt = 0.05')
    text += '[[output]]\nname = "w"\nnear = [0.0, 0.0, 0.0]\ncomponent = "z"\n'
    s = run_scene(load_toml_scene(write(tmp_path, text)))
    t = np.array(s.history["time"])
    np.testing.assert_allclose(s.history["w"], 2.0 * t - 0.5 * 9.81 * t**2, atol=1e-10)   # exact for the scheme
    d = s.as_dict()
    assert d["energy"]["total"]["max_rel_drift"] < 1e-10 and not d["momentum"]["isolated"]
    assert d["energy"]["conservative"]                             # gravity is conservative


def test_bench_of_a_dynamic_toml_scene_sweeps_dt(tmp_path):
    pytest.importorskip("matplotlib")
    path = write(tmp_path, PLATE.replace("nx = 2", "nx = 1").replace("ny = 2", "ny = 1"))
    assert main(["bench", str(path), "--out", str(tmp_path / "b"), "--quiet"]) == 0
    text = (tmp_path / "b" / "report.md").read_text()
    assert "| dt=0.002 |" in text and "| dt=0.001 |" in text and "| dt=0.0005 |" in text
    data = json.loads((tmp_path / "b" / "bench.json").read_text())
    assert [r["summary"]["steps"] for r in data] == [10, 20, 40]


@pytest.mark.parametrize("edit, message", [
    (("dt = 2e-3\n", ""), "missing key analysis.dt"),
    (('type = "dynamic"', 'type = "dynamics"'), "analysis.type must be one of 'static', 'dynamic', got 'dynamics'"),
    (("[analysis.initial]\n", "[analysis.initial]\nspin = 3\n"), "unknown key 'analysis.initial.spin'"),
    (('type = "dynamic"\n', 'type = "dynamic"\nrho_inf = 2.0\n'), "rho_inf must lie in [0, 1], got 2.0"),
    (("density = 1000.0", "density = 0.0"), "material.density must be > 0 for a dynamic analysis, got 0.0"),
    (('component = "z"', 'component = "w"'), "output.1.component must be one of 'x', 'y', 'z', got 'w'"),
    (('type = "dynamic"\n', 'type = "dynamic"\nadaptive = 1\n'), "analysis.adaptive must be true or false, got 1"),
    (("[analysis.initial]\n", "[analysis.integrator]\nerror_tolerance = 2.0\n[analysis.initial]\n"),
     "error_tolerance must lie in (0, 1)"),
    (("[analysis.initial]\n", "[analysis.integrator]\nmin_step = 1.0\nmax_step = 0.1\n[analysis.initial]\n"),
     "min_step must not exceed max_step, got 1.0 > 0.1"),
    (("[analysis.initial]\n", "[analysis.integrator]\nsafety = 1.5\n[analysis.initial]\n"),
     "safety must lie in (0, 1], got 1.5"),
])
def test_bad_dynamic_toml_is_one_line(tmp_path, edit, message):
    path = write(tmp_path, PLATE.replace(*edit))
    with pytest.raises(SceneError) as exc:
        load_toml_scene(path)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_an_angular_velocity_output_needs_a_dynamic_analysis(tmp_path):
    text = (REPO / "examples" / "clamped_plate.toml").read_text()
    text += '\n[[output]]\nname = "spin"\ntype = "angular_velocity"\ncomponent = "z"\n'
    with pytest.raises(SceneError, match="'angular_velocity' needs a dynamic analysis"):
        load_toml_scene(write(tmp_path, text))


def test_set_overrides_the_time_step_of_a_scene_file(tmp_path):
    scene = load_toml_scene(write(tmp_path, PLATE), {"dt": 1e-3, "end_time": 0.01})
    assert scene.analysis.time_step == 1e-3 and scene.analysis.n_steps == 10


def test_adaptive_steps_in_a_scene_file_land_on_the_output_times(tmp_path):
    """``adaptive = true``: records at every output_every-th multiple of dt, the step counts in the JSON."""
    text = PLATE.replace('type = "dynamic"\n', 'type = "dynamic"\nadaptive = true\noutput_every = 2\n')
    scene = load_toml_scene(write(tmp_path, text))
    assert scene.analysis.is_adaptive and scene.analysis.alpha_settings().adaptive
    s = run_scene(scene)
    assert s.result.converged, s.result.message
    np.testing.assert_allclose(s.history["time"], scene.analysis.output_times(), rtol=0, atol=1e-15)
    d = s.as_dict()
    steps = d["time_steps"]
    assert steps["adaptive"] and steps["accepted"] == s.steps == sum(r.substeps for r in s.records)
    assert 0 < steps["min"] <= steps["max"] <= 2 * 2e-3 and d["time"] == 0.02
    # the fixed step: the same file without the key (and ``--set adaptive=false``)
    assert not load_toml_scene(write(tmp_path, text), {"adaptive": False}).analysis.is_adaptive
    assert not load_toml_scene(write(tmp_path, PLATE)).analysis.is_adaptive
    # the built-in dynamic scenes take it too (``flexbody run spinning_plate --set adaptive=true``)
    assert build("spinning_plate", nx=1, ny=1, adaptive=True).analysis.is_adaptive
    assert not build("spinning_plate", nx=1, ny=1).analysis.is_adaptive


# -- fuzz: a mutated dynamic scene document builds or fails with one SceneError line ---------------------
EXAMPLE = REPO / "examples" / "spinning_membrane.toml"
DOC = read_toml(EXAMPLE)


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutations(DOC))
def test_a_mutated_dynamic_scene_builds_or_says_why(changes):
    doc = copy.deepcopy(DOC)
    doc["mesh"]["n_circ"] = 5                     # keep every valid build cheap
    doc = mutate(doc, changes)
    try:
        scene = scene_from_document(doc, EXAMPLE)
    except SceneError as exc:
        assert str(exc) and "\n" not in str(exc)
    else:
        assert scene.kind in ("static", "dynamic")
