"""exudyn reference models of the built-in scenes, and the flexbody-vs-exudyn comparison.

Coarse meshes and few steps keep the file fast; the tolerances state what each exudyn model reaches there
(measured values in the comments, docs/exudyn.md has the default meshes).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("exudyn")

from flexbody.adapters import exudyn as fx  # noqa: E402
from flexbody.scenes import build  # noqa: E402


def reference_run(name: str, **params):
    run = fx.run_reference(name, params)
    assert run.converged, run.message
    assert run.history["load_factor"][-1] == pytest.approx(1.0)
    return run


def elastica(lf):
    theta = 2 * math.pi * np.asarray(lf)
    return 12.0 * (1 - np.sin(theta) / theta), 12.0 * (1 - np.cos(theta)) / theta


def test_se3_beam_rolls_the_strip_into_the_exact_circle():
    """Constant curvature is exact for the two-node SE(3) beam: the elastica to round-off (measured 5e-15)."""
    run = reference_run("cantilever_end_moment", nx=4, steps=10)
    u, w = elastica(run.history["load_factor"])
    assert np.max(np.abs(np.array(run.history["minus_U_tip"]) - u)) < 1e-8 * 12
    assert np.max(np.abs(np.array(run.history["W_tip"]) - w)) < 1e-8 * 12
    assert len(run.errors) == 20 and run.max_rel_error < 1e-8


def test_planar_beam_end_moment_within_0p2_percent_of_the_elastica():
    """ObjectBeamGeometricallyExact2D, 16 elements: measured max error 1.55e-3 of max |ref|, closed circle."""
    run = reference_run("cantilever_end_moment", nx=8, steps=10, exudyn_model="beam2d")
    assert run.max_rel_error < 2e-3
    assert run.history["minus_U_tip"][-1] == pytest.approx(12.0, abs=1e-3)


def test_ancf_plate_strip_end_moment_within_0p3_percent_of_the_elastica():
    """ObjectANCFThinPlate 8 x 1: measured max error 2.47e-3; the tip is back at the root within 0.04."""
    run = reference_run("cantilever_end_moment", nx=8, steps=10, exudyn_model="plate")
    assert run.max_rel_error < 3e-3
    assert abs(run.history["minus_U_tip"][-1] - 12.0) < 0.05


def tip_load_elastica(k: float) -> tuple[float, float]:
    """Inextensible, shear-rigid cantilever under a dead tip force, k = P L^2 / (E I): (-u/L, w/L) by shooting."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    def end(curvature0):
        rhs = lambda s, y: [y[1], -k * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])]
        return solve_ivp(rhs, [0, 1], [0, curvature0, 0, 0], rtol=1e-12, atol=1e-14).y[:, -1]

    y = end(brentq(lambda c: end(c)[1], 0.5, k))
    return 1 - y[2], y[3]


@pytest.mark.parametrize("model, tol", [("beam2d", 3e-4), ("beam3d", 3e-4), ("plate", 1e-4)])
def test_end_shear_strip_matches_the_exact_elastica(model, tol):
    """P L^2/EI = 4: -U/L = 0.328941, W/L = 0.669964. Measured relative errors (-U, W) at the default mesh
    (32 beam elements, 16 x 1 plates): beam2d 2.2e-4, 1e-6; beam3d 1.8e-4, 9e-5; plate 6e-5, 2e-5."""
    run = reference_run("cantilever_end_shear", exudyn_model=model)
    u, w = tip_load_elastica(4.0)
    assert u == pytest.approx(0.328941, abs=1e-6) and w == pytest.approx(0.669964, abs=1e-6)
    assert run.history["minus_U_tip"][-1] == pytest.approx(10 * u, rel=tol)
    assert run.history["W_tip"][-1] == pytest.approx(10 * w, rel=tol)


@pytest.mark.parametrize("model", ["beam3d", "plate"])
def test_end_shear_strip_within_0p2_percent_of_sze(model):
    """16 beam elements / 8 x 1 plates, 20 steps (the table's load levels), against the S4R table."""
    run = reference_run("cantilever_end_shear", nx=8, steps=20, exudyn_model=model)
    assert len(run.errors) == 40
    assert run.max_rel_error < 2e-3


def test_slit_annular_plate_ancf_within_6_percent_on_a_4x12_mesh():
    """ANCF 4 x 12 (coarse): W_A, W_B within 6 % of the S4R table (measured max 5.5e-2, low at every level)."""
    run = reference_run("slit_annular_plate", n_radial=4, n_circ=12, steps=10)
    assert run.max_rel_error < 0.06
    final = {e["quantity"]: e for e in run.errors if e["load_factor"] == 1.0}
    assert final["W_A"]["value"] == pytest.approx(13.891, rel=0.06)
    assert final["W_B"]["value"] == pytest.approx(17.528, rel=0.06)


def test_hemisphere_ancf_converges_towards_the_table():
    """Quarter hemisphere, ANCF 6 x 6 then 10 x 10, at P_max: both radial displacements approach the table.

    Measured: U_pulled 3.269 -> 3.865 (table 4.067), -U_pushed 5.625 -> 7.470 (table 8.178).
    """
    coarse = reference_run("hemisphere", n_meridian=6, n_circ=6, steps=5)
    fine = reference_run("hemisphere", n_meridian=10, n_circ=10, steps=5)
    for name, ref in (("U_pulled", 4.067), ("minus_U_pushed", 8.178)):
        e_coarse = abs(coarse.history[name][-1] - ref)
        e_fine = abs(fine.history[name][-1] - ref)
        assert e_fine < 0.4 * e_coarse
        assert e_fine < 0.1 * ref


def test_pullout_cylinder_ancf_passes_the_snap_under_load_control():
    """Octant, ANCF 6 x 4, 20 load steps: exudyn's load control jumps over the snap near 0.5 P_max."""
    run = reference_run("pullout_cylinder", n_circ=6, n_axial=4, exudyn_steps=20)
    lam = np.array(run.history["load_factor"])
    u_b = np.array(run.history["minus_U_B"])
    before, after = u_b[np.argmin(np.abs(lam - 0.5))], u_b[np.argmin(np.abs(lam - 0.525))]
    assert after - before > 0.25                       # the table: 3.653 -> 4.061; measured 3.623 -> 3.984
    final = {e["quantity"]: e for e in run.errors if e["load_factor"] == 1.0}
    for name, tol in (("W_A", 0.08), ("minus_U_B", 0.03), ("minus_U_C", 0.05)):
        assert final[name]["rel_error"] < tol, (name, final[name])


def test_symmetry_coordinates_of_the_ancf_node():
    # plane y = 0 on an edge along the parametric y direction: u_y, slope_y . e_y, slope_x . e_x, slope_x . e_z
    assert sorted(fx.symmetry_coordinates(1, "y")) == [1, 3, 5, 7]
    # plane z = 0 on an edge along the parametric x direction: u_z, slope_x . e_z, slope_y . e_x, slope_y . e_y
    assert sorted(fx.symmetry_coordinates(2, "x")) == [2, 5, 6, 7]


def test_outputs_sit_at_the_flexbody_output_points():
    scene = build("hemisphere", n_meridian=4, n_circ=4, steps=2)
    model = fx.build_model(scene)
    positions = {n: np.array(model.mbs.GetNodeParameter(n, "referenceCoordinates")[:3])
                 for out in model.outputs for n in out.nodes}
    mesh = scene.model.body.mesh
    for out, ours in zip(model.outputs, scene.outputs):
        assert out.name == ours.name and len(out.nodes) == 1
        assert np.allclose(positions[out.nodes[0]], mesh.nodes[ours.node], atol=1e-9)


COMPARE_KEYS = {"scene", "parameters", "exudyn_options", "flexbody", "exudyn", "outputs", "reference_source",
                "wall_time_ratio", "cpu_time_ratio", "ok"}
RUN_KEYS = {"model", "dofs", "elements", "steps", "newton_iterations", "converged", "message", "load_factor",
            "build_time_s", "wall_time_s", "cpu_time_s", "outputs", "errors", "max_rel_error", "history"}
ROW_KEYS = {"name", "flexbody", "exudyn", "difference", "rel_difference", "reference", "flexbody_ref_error",
            "exudyn_ref_error"}


@pytest.fixture(scope="module")
def small_comparison():
    return fx.compare("cantilever_end_shear", {"nx": 8, "steps": 5, "exudyn_model": "beam2d"})


def test_compare_returns_the_documented_keys(small_comparison):
    r = small_comparison
    assert set(r) == COMPARE_KEYS
    assert RUN_KEYS <= set(r["flexbody"]) and RUN_KEYS <= set(r["exudyn"])
    assert {"kind", "coordinates", "constraints", "newton_rtol"} <= set(r["exudyn"])
    assert r["ok"] and r["parameters"]["nx"] == 8 and r["exudyn_options"] == {"model": "beam2d"}
    assert [row["name"] for row in r["outputs"]] == ["minus_U_tip", "W_tip"]
    for row in r["outputs"]:
        assert set(row) == ROW_KEYS
        assert row["difference"] == pytest.approx(row["exudyn"] - row["flexbody"])
        assert row["flexbody_ref_error"] is not None and row["exudyn_ref_error"] is not None
    # the shell and the planar beam agree at P_max (measured 1.6e-3 and 7e-4 of the largest value)
    assert max(row["rel_difference"] for row in r["outputs"]) < 5e-3
    assert r["outputs"][1]["exudyn"] == pytest.approx(6.698, rel=2e-3)   # W_tip, the S4R table
    assert r["flexbody"]["wall_time_s"] > 0 and r["exudyn"]["wall_time_s"] > 0


def test_compare_cli_prints_the_table_and_writes_json(tmp_path, capsys):
    path = tmp_path / "cmp.json"
    rc = fx.compare_cli("cantilever_end_shear", {"nx": 2, "steps": 4, "exudyn_model": "beam2d"}, str(path), False)
    out = capsys.readouterr().out
    assert rc == 0
    assert "minus_U_tip" in out and "solve time [s]" in out and "ObjectBeamGeometricallyExact2D" in out
    data = json.loads(path.read_text())
    assert set(data) == COMPARE_KEYS and data["ok"] is True


@pytest.mark.parametrize("scene, params, fragment", [
    ("no_such_scene", {}, "no exudyn model for scene 'no_such_scene'"),
    ("cantilever_end_moment", {"exudyn_mesh": 3}, "unknown exudyn option 'exudyn_mesh'"),
    ("hemisphere", {"n_meridian": 2, "n_circ": 2, "exudyn_model": "beam3d"},
     "exudyn_model for 'hemisphere' must be one of"),
])
def test_compare_cli_fails_with_one_line(scene, params, fragment, capsys):
    assert fx.compare_cli(scene, params, None, True) == 2
    err = capsys.readouterr().err
    assert fragment in err and err.count("\n") == 1


def test_core_and_scenes_do_not_import_exudyn():
    code = ("import sys, flexbody, flexbody.scenes, flexbody.adapters, flexbody.cli; "
            "from flexbody.scenes import build, run_scene; run_scene(build('cantilever_end_shear', nx=1, steps=1)); "
            "bad = sorted(m for m in sys.modules if m == 'exudyn' or m.startswith('exudyn.')); "
            "print(bad); sys.exit(1 if bad else 0)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_flexbody_run_of_the_default_scene_does_not_import_exudyn(tmp_path):
    """``flexbody run`` (the default scene, in a fresh process) loads neither exudyn nor the adapter."""
    code = ("import sys; from flexbody.cli import main; rc = main(['run', '--quiet']); "
            "bad = sorted(m for m in sys.modules if m.split('.')[0] == 'exudyn' "
            "or m.startswith('flexbody.adapters.exudyn')); "
            "print(rc, bad); sys.exit(1 if rc != 0 or bad else 0)")
    repo = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [repo, os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=tmp_path,
                          env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "0 []"


# ----------------------------------------------------------------------------------------------------------
# our shell inside an exudyn system (ObjectGenericODE2, statics)
# ----------------------------------------------------------------------------------------------------------

def test_shell_ode2_jacobian_matches_finite_differences_of_its_force():
    """At a committed deformed state the wrapper's Jacobian is -d(force)/dq (central differences)."""
    import exudyn as exu
    from flexbody.scenes import run_scene

    scene = build("cantilever_end_shear", nx=2, steps=4)
    deformed = run_scene(scene).result.state
    mbs = exu.SystemContainer().AddSystem()
    shell = fx.ShellODE2(mbs, scene.model)
    shell.state_n = deformed
    n = scene.model.n_dof
    q0, lam, eps = np.zeros(n), 0.7, 1e-6
    J = np.asarray(shell._jacobian(mbs, lam, 0, q0.tolist(), q0.tolist(), 1.0, 0.0).Convert2DenseMatrix())
    fd = np.empty((n, n))
    for k in range(n):
        e = np.zeros(n)
        e[k] = eps
        plus, minus = shell._force(mbs, lam, 0, q0 + e, q0), shell._force(mbs, lam, 0, q0 - e, q0)
        fd[:, k] = -(np.array(plus) - np.array(minus)) / (2 * eps)
    assert np.max(np.abs(J - fd)) < 1e-5 * np.max(np.abs(fd))


@pytest.mark.parametrize("name, params", [("cantilever_end_shear", {"nx": 4, "steps": 5}),
                                          ("cantilever_end_moment", {"nx": 4, "steps": 20})])
def test_shell_inside_exudyn_reproduces_flexbody(name, params):
    """exudyn's static solver on the wrapped shell, with the same load steps, lands on flexbody's solution.

    Measured: end shear 8e-7 / 4e-7 (relative), end moment 1.8e-6 / 1e-5 (the strip rolled to 4/3 pi
    at this coarse mesh).
    """
    from flexbody.scenes import run_scene

    ours = run_scene(build(name, **params))
    theirs = fx.solve_scene_in_exudyn(build(name, **params))
    assert theirs["converged"], theirs["message"]
    assert theirs["calls"]["commit"] == params["steps"]          # no step halving: the same load path
    for out, value in theirs["outputs"].items():
        ref = ours.history[out][-1]
        assert value == pytest.approx(ref, rel=3e-5, abs=3e-5 * max(abs(v) for v in ours.history[out]))


def test_clamp_given_by_exudyn_coordinate_constraints():
    """The strip without flexbody's Fix, clamped by exudyn CoordinateConstraints on the wrapped coordinates."""
    import exudyn.itemInterface as eii
    from flexbody.assembly import Model
    from flexbody.scenes.scene import Scene

    scene = build("cantilever_end_shear", nx=4, steps=5)
    clamped = scene.model.body.mesh.node_set("clamped")
    free = Scene(scene.name, scene.description, Model(scene.model.body, [], scene.model.loads), scene.analysis,
                 scene.outputs, scene.reference, scene.parameters)

    def clamp(mbs, shell):
        ground_node = mbs.AddNode(eii.NodePointGround())
        ground = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
        for node in clamped:
            for c in range(5):
                m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=shell.node,
                                                           coordinate=shell.coordinate_index(int(node), c)))
                mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[ground, m]))

    joined = fx.solve_scene_in_exudyn(free, clamp)
    fixed = fx.solve_scene_in_exudyn(scene)
    assert joined["converged"] and joined["dofs"] == fixed["dofs"] + 5 * len(clamped)
    for name, value in joined["outputs"].items():
        assert value == pytest.approx(fixed["outputs"][name], rel=1e-9)


def test_compare_cli_reports_an_exudyn_failure(tmp_path, capsys, monkeypatch):
    """exu.SolverError becomes converged = False: the table and JSON are written, the exit code is 2."""
    from flexbody.adapters.exudyn import references_static

    settings = references_static._settings

    def one_iteration(model):
        s = settings(model)
        s.staticSolver.newton.maxIterations = 1
        s.staticSolver.adaptiveStep = False
        return s

    monkeypatch.setattr(references_static, "_settings", one_iteration)
    path = tmp_path / "failed.json"
    rc = fx.compare_cli("cantilever_end_shear", {"nx": 2, "steps": 2, "exudyn_model": "beam2d"}, str(path), True)
    err = capsys.readouterr().err
    assert rc == 2 and "exudyn SolverError" in err and err.count("\n") == 1
    data = json.loads(path.read_text())
    assert data["ok"] is False and data["exudyn"]["converged"] is False and data["flexbody"]["converged"] is True


# ----------------------------------------------------------------------------------------------------------
# the wrapped shell in exudyn's dynamic solver (needs flexbody.dynamics for the lumped mass)
# ----------------------------------------------------------------------------------------------------------

def _dynamic_exudyn_run(mbs, shell, t_end: float, h: float, pre=None):
    import exudyn as exu

    mbs.SetPreStepUserFunction(pre or shell.commit)
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.timeIntegration.numberOfSteps = int(round(t_end / h))
    s.timeIntegration.endTime = t_end
    s.timeIntegration.generalizedAlpha.spectralRadius = 0.9
    s.timeIntegration.verboseMode = 0
    s.timeIntegration.newton.relativeTolerance = 1e-10
    s.solution.file.write = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    mbs.SolveDynamic(s, solverType=exu.DynamicSolverType.GeneralizedAlpha)


def test_exudyn_generalized_alpha_on_the_wrapped_shell_equals_ours():
    """A strip under a suddenly applied tip force (0.1 P_max, 1.5 s, a quarter period): exudyn's
    generalized-alpha on the wrapped shell and flexbody's Lie-group generalized-alpha (rho_inf 0.9, same
    steps) give the same tip history (measured: max difference 2e-11 over 3 s, deflection up to 2.5)."""
    import dataclasses

    import exudyn as exu
    dynamics = pytest.importorskip("flexbody.dynamics")
    alpha = pytest.importorskip("integrators.generalized_alpha")
    from flexbody.assembly import Model
    from flexbody.body import ShellBody

    scene = build("cantilever_end_shear", nx=4)
    old = scene.model.body
    body = ShellBody(old.mesh, dataclasses.replace(old.material, density=1.0))
    model = Model(body, scene.model.constraints, scene.model.loads)
    dyn = dynamics.DynamicModel(model, load_factor=lambda t: 0.1)
    tip = next(o for o in scene.outputs if o.name == "W_tip")
    t_end, h = 1.5, 0.05

    ours = {}

    def observe(step):                                    # every step after the start (the start is t = 0)
        if not step.initial:
            ours[round(step.time, 9)] = tip.value(model, step.state)

    # both schemes iterated to their tolerances (no local-error test): the comparison is of the discrete solutions
    result = alpha.generalized_alpha(dyn, t_end, h, observers=[observe],
                                     settings=alpha.AlphaSettings(rho_inf=0.9, policy="full", local_error_fraction=0.0))
    assert result.converged, result.message

    theirs = {}
    mbs = exu.SystemContainer().AddSystem()
    shell = fx.ShellODE2(mbs, model, lambda t: 0.1, mass=dyn.mass_matrix(),
                         on_commit=lambda t, state: theirs.__setitem__(round(t, 9), tip.value(model, state)))
    _dynamic_exudyn_run(mbs, shell, t_end, h)
    theirs[round(t_end, 9)] = tip.value(model, shell.state(shell.coordinates()))
    common = sorted(set(ours) & set(theirs))
    assert len(common) == int(round(t_end / h))
    diff = max(abs(ours[t] - theirs[t]) for t in common)
    assert diff < 1e-8, diff
    assert max(abs(v) for v in ours.values()) > 1.0                # it did move: a real comparison


def test_stiff_free_shell_tumbles_like_an_exudyn_rigid_body():
    """A free 2 x 1 plate (E = 1e8, rho = 1000, h = 0.02) spun about its intermediate axis, in exudyn as the
    wrapped shell and as ObjectRigidBody with the shell's mass and inertia: a corner point's paths agree
    to 1e-3 over 1 s while it moves by up to 1.7 (measured 3.8e-4; over 2 s 8.4e-4, and 3.4e-4 with
    h = 0.005)."""
    import exudyn as exu
    from exudyn.utilities import RigidBodyInertia

    dynamics = pytest.importorskip("flexbody.dynamics")
    from flexbody.assembly import Model
    from flexbody.body import ShellBody
    from flexbody.mesh import generators
    from flexbody.shell.material import ShellMaterial

    mesh = generators.strip(2.0, 1.0, 4, 2)
    model = Model(ShellBody(mesh, ShellMaterial(1e8, 0.3, 0.02, density=1000.0)), [], [])
    dyn = dynamics.DynamicModel(model)
    start = model.initial_state()
    centre, inertia = dyn.rigid_inertia_tensor(start)
    omega = np.array([0.3, 2.0, 0.4])
    corner = mesh.nearest_node([2.0, 1.0, 0.0])

    mbs = exu.SystemContainer().AddSystem()
    shell = fx.ShellODE2(mbs, model, lambda t: 0.0, mass=dyn.mass_matrix(),
                         velocity=dyn.rigid_velocity(start, omega, center=centre))
    rigid = mbs.CreateRigidBody(referencePosition=list(centre), initialAngularVelocity=list(omega),
                                inertia=RigidBodyInertia(mass=dyn.inertia.total_mass, inertiaTensor=inertia,
                                                         inertiaTensorAtCOM=True), returnDict=True)["nodeNumber"]
    gaps, moves = [], []

    def pre(mbs_, t):
        shell.commit(mbs_, t)
        p = mbs_.GetNodeOutput(rigid, exu.OutputVariableType.Position)
        R = np.asarray(mbs_.GetNodeOutput(rigid, exu.OutputVariableType.RotationMatrix)).reshape(3, 3)
        x = shell.state_n.x[corner]
        gaps.append(np.linalg.norm(x - (p + R @ (mesh.nodes[corner] - centre))))
        moves.append(np.linalg.norm(x - mesh.nodes[corner]))
        return True

    _dynamic_exudyn_run(mbs, shell, 1.0, 0.01, pre)
    assert len(gaps) == 100 and max(moves) > 1.0
    assert max(gaps) < 1e-3


# ----------------------------------------------------------------------------------------------------------
# dynamics: the spinning plate, flexbody against the ANCF plate in exudyn's generalized-alpha
# ----------------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def spinning_comparison():
    pytest.importorskip("flexbody.dynamics")
    return fx.compare("spinning_plate", {"nx": 4, "ny": 4, "end_time": 0.2, "exudyn_reference": "rk4",
                                         "exudyn_reference_end_time": 0.1})


def test_spinning_plate_starts_with_the_exact_rigid_spin_in_exudyn(spinning_comparison):
    """ANCF interpolates rigid motion exactly: with positions and slopes moving rigidly, the consistent mass
    gives T(0) = I_z omega^2 / 2 and L_z(0) = I_z omega with I_z = m (a^2 + b^2) / 12 = 1000 * 0.01 / 6."""
    ex = spinning_comparison["exudyn"]
    I_z = 10.0 * 2.0 / 12.0
    assert ex["momentum"]["angular"]["initial"] == pytest.approx([0.0, 0.0, 10.0 * I_z], abs=1e-10)
    assert ex["energy_history"]["kinetic"][0] == pytest.approx(0.5 * I_z * 100.0, rel=1e-12)
    assert ex["energy_history"]["strain"][0] == pytest.approx(0.0, abs=1e-12)


def test_spinning_plate_conserves_angular_momentum_and_agrees_with_exudyn(spinning_comparison):
    """4 x 4 cells, dt 2e-3, rho_inf 0.9, 0.2 s (about four breathing periods, 19 Hz).

    Measured: angular momentum drift 1.95e-4 in both codes (generalized-alpha's, not the mesh's: exudyn's
    RK4 at dt 1e-4 keeps it to 4e-14), total energy drift 3.9e-4 in both; the radial corner displacement
    histories (amplitude 9.7e-3) differ by at most 6.3e-4 = 6.5 % of the amplitude, the edge midpoint's by
    8.6 % (a phase drift: quadratic triangles with a lumped mass against cubic ANCF quads with a
    consistent mass); the largest strain energies 2.3465 and 2.3106 (1.5 %).
    """
    r = spinning_comparison
    assert r["ok"] and r["kind"] == "dynamic"
    fb, ex, ref = r["flexbody"], r["exudyn"], r["reference"]
    for run in (fb, ex):
        assert run["steps"] == 100 and run["time_step"] == pytest.approx(2e-3)
        assert run["momentum"]["angular"]["max_rel_drift"] < 4e-4
        assert run["energy"]["total"]["max_rel_drift"] < 1e-3
    assert ref["momentum"]["angular"]["max_rel_drift"] < 1e-10              # RK4 at dt 1e-4
    corner = next(row for row in r["outputs"] if row["name"] == "u_r_corner")
    assert max(abs(v) for v in fb["history"]["u_r_corner"]) > 5e-3      # it breathes: a real comparison
    assert corner["rel_history_difference"] < 0.1
    assert corner["exudyn_vs_rk4"] < 0.1                                 # measured 3.2e-2 over 0.1 s
    assert fb["energy"]["strain"]["max"] == pytest.approx(ex["energy"]["strain"]["max"], rel=0.04)


def test_exudyn_potential_energy_output_equals_the_work_of_its_elastic_forces():
    """The strain energy read from exudyn (element PotentialEnergy outputs) against the integral of its
    elastic forces along the path from the reference (4 Gauss points): measured 8.7e-13 absolute, W up to 2.3."""
    pytest.importorskip("flexbody.dynamics")
    model = fx.build_dynamic_model(build("spinning_plate", end_time=0.06))
    run = fx.solve_dynamic(model)
    assert run["converged"] and len(model.records) == 31
    states = [rec[1] for rec in model.records[::3]]
    ours, theirs = fx.strain_energies(model, states, "forces"), fx.strain_energies(model, states)
    assert max(theirs) > 1.0
    assert np.max(np.abs(ours - theirs)) < 1e-9


def test_spinning_plate_table_and_json(spinning_comparison):
    lines = "\n".join(fx.table_lines(spinning_comparison))
    for text in ("angular momentum drift", "strain (potential) energy history", "u_r_corner", "exudyn RK4",
                 "solve time [s]"):
        assert text in lines
    data = json.loads(json.dumps(fx._json_ready(spinning_comparison)))
    assert len(data["strain_energy_samples"]["time"]) == 11 and data["exudyn"]["converged"] is True


# ----------------------------------------------------------------------------------------------------------
# the hub demo: the wrapped membrane clamped to an exudyn rigid hub on a driven revolute joint
# ----------------------------------------------------------------------------------------------------------

def test_membrane_on_an_exudyn_driven_hub_matches_flexbody_alone():
    """``spinning_membrane`` (2 x 8 annulus, 400 DoFs, dt 1e-3, 0.15 s: spin-up to 20 rad/s in 0.05 s, then
    0.1 s steady): the hub an exudyn rigid body on a revolute joint driven through its rotation coordinate,
    the inner nodes tied to it by a user-function ``ObjectConnectorCoordinateVector``, against flexbody's
    own run with the ``PrescribedMotion`` hub.

    Measured (rtol 1e-8): u_r_outer 3.526700e-5 (exudyn) vs 3.526700e-5 (flexbody), rel. difference 6.5e-9
    at the end (u_r_mid 5.8e-9); histories (151 common times) differ by at most 8.8e-4 of their maximum
    (exudyn halved its first 10 steps); the analytic steady value 3.470339e-5 is 1.6 % below both (the
    coarse mesh: 1.06 % at 2 x 16). Hub angle = prescribed 2.5 rad, rate 20 rad/s, tie residual 6e-17.
    Wall time 0.9 s (exudyn) + 0.3 s (flexbody).
    """
    pytest.importorskip("flexbody.dynamics")
    r = fx.hub_driven_membrane_in_exudyn({"n_radial": 2, "n_circ": 8, "end_time": 0.15})
    assert r["converged"], r["message"]
    assert r["hub_angle"] == pytest.approx(r["hub_angle_prescribed"], abs=1e-9)
    assert r["hub_angle_prescribed"] == pytest.approx(20.0 * (0.025 + 0.1), rel=1e-12)
    assert r["hub_angular_velocity"] == pytest.approx(20.0, rel=1e-8)
    assert r["tie_residual"] < 1e-12
    ex, fb, ref = r["exudyn"], r["flexbody"], r["reference"]
    assert ex["u_r_outer"] > 3e-5                                          # it stretched: a real comparison
    for name in ("u_r_mid", "u_r_outer"):
        assert ex[name] == pytest.approx(fb[name], rel=1e-6)
        assert r["rel_history_difference"][name] < 5e-3
        assert ex[name] == pytest.approx(ref[name], rel=0.03)
    assert r["common_times"] > 100
