"""Stability along static paths (negative eigenvalues, limit and bifurcation points) and linear buckling
(issue 16, items 3 and 4). Reference values: docs/stability.md."""

import argparse
import dataclasses
import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.buckling import geometric_stiffness, linear_buckling, nodal_translations
from flexbody.cli.buckling import cmd_buckling
from flexbody.cli.summary import stability_lines
from flexbody.constraints import Fix
from flexbody.loads import NodalLoad
from flexbody.mesh import generators
from flexbody.scenes.scene import stability_summary
from flexbody.scenes.sources import open_scene
from flexbody.shell.material import ShellMaterial
from integrators.static import arc_length, load_control, stability_matrix
from tests.integrators.test_thin_arc_length import THIN_ARCH_LIMIT, thin_half_arch

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PLATE, CYLINDER = str(EXAMPLES / "compressed_plate_scene.py"), str(EXAMPLES / "compressed_cylinder_scene.py")


def _example(path):
    spec = importlib.util.spec_from_file_location(Path(path).stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _dense_negative(model, state, lam) -> int:
    """The dense count, of D A D with D = diag(dof_scale) (a congruence: the same inertia), so that the
    eigenvalues of translations and rotations have comparable sizes in any units."""
    A, _ = stability_matrix(model, state, lam)
    D = np.diag(model.dof_scale)
    return int(np.sum(np.linalg.eigvalsh(D @ A.toarray() @ D) < 0))


def column(scale=1.0, load_ratio=1.0):
    """A cantilever strip (L = 1, b = 0.1, h = 0.01, nu = 0; lengths times ``scale``) under an axial dead tip
    force of ``load_ratio`` times Euler's P_cr = pi^2 E I / (4 L^2)."""
    L, b, h, E = scale, 0.1 * scale, 0.01 * scale, 1.0e6
    mesh = generators.strip(L, b, 8, 1)
    body = ShellBody(mesh, ShellMaterial(E, 0.0, h))
    tip = mesh.node_sets["tip"]
    p_cr = math.pi**2 * E * b * h**3 / 12 / (4 * L**2)
    return Model(body, [Fix(mesh.node_sets["clamped"], "all")], [NodalLoad(tip, force=(-load_ratio * p_cr / len(tip), 0, 0))])


def test_arch_snap_through_counts_and_limit_points():
    """Arc length through the thin arch's snap-through: the count of negative eigenvalues (LDL^T inertia)
    equals the dense count at every step, and the two points where the load factor turns are reported as
    limit points there."""
    model = thin_half_arch()
    path = []
    result = arc_length(model, lam_max=4.0, on_step=lambda rec, q: path.append((rec, q)))
    assert result.converged, result.message
    for rec, q in path[::4] + path[-1:]:
        assert rec.negative_eigenvalues == _dense_negative(model, q, rec.load_factor)
    lams = np.array([rec.load_factor for rec, _ in path])
    points = result.critical_points
    assert [c.kind for c in points] == ["limit point", "limit point"]
    top, bottom = int(np.argmax(lams[:len(lams) // 2])), int(np.argmin(lams))
    # the maximum and the minimum of the load factor are the records at or just before the points
    assert points[0].step - 1 in (top, top + 1) and points[1].step - 1 in (bottom, bottom + 1)
    assert points[0].load_factor_before == pytest.approx(THIN_ARCH_LIMIT, abs=0.02)
    assert (points[0].negative_before, points[0].negative_after) == (0, 1)
    # the second energy variation along the softest mode past the first limit point is negative
    rec, q = path[points[0].step]
    A, _ = stability_matrix(model, q, rec.load_factor)
    w, V = np.linalg.eigh(A.toarray())
    F = model.loads[0]
    q = dataclasses.replace(q, stress=None)

    def energy(s):
        qs = model.update(q, s * V[:, 0])
        return model.body.strain_energy(qs) - rec.load_factor * np.sum(F.force * qs.x[F.nodes])
    s = 1e-4
    assert (energy(s) - 2 * energy(0) + energy(-s)) / s**2 == pytest.approx(w[0], rel=1e-4)
    assert w[0] < 0
    lines = stability_lines(stability_summary(result))
    assert lines[0].startswith("stability        UNSTABLE") and "limit point between load factors" in lines[1]


@pytest.mark.parametrize("scale", [1e-6, 1e3])
def test_column_past_euler_reports_a_bifurcation_in_any_units(scale):
    """Load control along the straight path of a compressed cantilever strip to 1.5 x Euler's load: the count
    goes 0 -> 1 between the levels around the buckling factor (a bifurcation: the load keeps increasing),
    the same in micro-units and in kilometres."""
    model = column(scale)
    lam1 = linear_buckling(model, 1).load_factors[0]
    assert lam1 == pytest.approx(1.0, abs=0.02)
    result = load_control(model, [0.4, 0.8, 0.95, 1.1, 1.5])
    assert result.converged, result.message
    assert [r.negative_eigenvalues for r in result.records] == [0, 0, 0, 1, 1]
    (point,) = result.critical_points
    assert point.kind == "bifurcation" and point.load_factor_before < lam1 < point.load_factor_after
    assert result.records[-1].negative_eigenvalues == _dense_negative(model, result.state, 1.5)


def test_plate_buckling_against_the_classical_value_under_refinement():
    """Simply supported plate a/b = 2 in uniaxial compression: k = 4 with m = 2 half-waves (Timoshenko &
    Gere 9.2); the lowest factor converges to it (errors 8.9 % and 3.6 %, docs/stability.md)."""
    plate = _example(PLATE)
    exact, m = plate.classical_factor()
    errors = []
    for nx, ny in ((4, 2), (8, 4)):
        model = open_scene(PLATE).build(dict(nx=nx, ny=ny)).model
        result = linear_buckling(model, 2)
        errors.append(abs(result.load_factors[0] / exact - 1))
        w = nodal_translations(model, model.initial_state(), result.modes[0])[:, 2]
        x = model.body.mesh.nodes
        line = np.flatnonzero(np.abs(x[:, 1] - 0.5) < 1e-9)
        ww = w[line][np.argsort(x[line, 0])][1:-1]
        assert 1 + np.count_nonzero(np.diff(np.sign(ww)) != 0) == m == 2
    assert errors[1] < 0.04 and errors[1] < 0.5 * errors[0]


@pytest.mark.parametrize("scale", [1e-6, 1e3])
def test_plate_buckling_factor_is_scale_free(scale):
    """Lengths times s, the line load times s (N_cr ~ E h^3 / b^2): the same factor to round-off."""
    base = linear_buckling(open_scene(PLATE).build(dict(nx=4, ny=2)).model, 1).load_factors[0]
    scaled = open_scene(PLATE).build(dict(nx=4, ny=2, length=2 * scale, width=scale, thickness=0.01 * scale,
                                          line_load=scale)).model
    assert linear_buckling(scaled, 1).load_factors[0] == pytest.approx(base, rel=1e-7)


def test_cylinder_sector_buckling_against_the_classical_stress():
    """Axially compressed cylinder (R/h = 50, L = 2R, nu = 0), a 1/16 sector between symmetry planes:
    the lowest factor within 2 % of E h / (R sqrt(3(1 - nu^2))) (1.6 % low on this mesh)."""
    exact = _example(CYLINDER).classical_factor()
    model = open_scene(CYLINDER).build(dict(sectors=16, n_circ=4, n_axial=32)).model
    lam = linear_buckling(model, 2).load_factors
    assert lam[0] / exact == pytest.approx(1.0, abs=0.02)


def test_geometric_stiffness_is_the_derivative_of_the_forces_of_fixed_stresses():
    """K_G(sigma) = d/dq [B(q)^T sigma] at fixed sigma, by central differences under the group update
    q o exp(eps e_i), at a random deformed state and random stresses."""
    model = open_scene(PLATE).build(dict(nx=1, ny=1)).model
    rng = np.random.default_rng(3)
    state = model.update(model.initial_state(), 0.02 * rng.standard_normal(model.n_dof) * model.dof_scale)
    sigma = rng.standard_normal((model.body.mesh.n_elements, 7, 8))
    KG = geometric_stiffness(model, state, sigma, 0.0).toarray()

    def forces(q):
        return model.assemble_element_forces(q, model.body.stress_forces(q, sigma))
    eps = 1e-6
    fd = np.column_stack([(forces(model.update(state, eps * e)) - forces(model.update(state, -eps * e))) / (2 * eps)
                          for e in np.eye(model.n_dof)])
    assert np.abs(KG - fd).max() <= 1e-6 * np.abs(KG).max()


def test_cmd_buckling_prints_the_table_and_writes_json(tmp_path, capsys):
    out = tmp_path / "b.json"
    args = argparse.Namespace(scene=PLATE, set=["nx=4", "ny=2"], count=3, json=str(out))
    assert cmd_buckling(args) == 0
    text = capsys.readouterr().out
    d = json.loads(out.read_text())
    assert len(d["load_factors"]) == 3 and d["load_factors"] == sorted(d["load_factors"])
    assert f"{d['load_factors'][0]:.6g}" in text
    from flexbody.cli import CliError
    with pytest.raises(CliError, match="--count must be an integer >= 1, got 0"):
        cmd_buckling(argparse.Namespace(scene=PLATE, set=[], count=0, json=None))


def test_hdf5_static_stats_carry_the_count(tmp_path):
    from flexbody.outputs.hdf5 import read_hdf5
    from flexbody.outputs.recording import RunRecorder
    from flexbody.scenes.scene import Scene, StaticAnalysis, run_scene
    scene = Scene("column", "strip past Euler", column(), StaticAnalysis("load_control", (0.5, 1.2)), [])
    with RunRecorder(scene, h5=str(tmp_path / "c.h5")) as rec:
        summary = run_scene(scene, on_step=rec.on_step)
    d = read_hdf5(str(tmp_path / "c.h5"))
    assert d["stats"]["negative_eigenvalues"].tolist() == [0.0, 1.0]
    assert d["stats"]["critical_point"].tolist() == [0.0, 2.0]
    assert summary.as_dict()["stability"]["critical_points"][0]["kind"] == "bifurcation"


def test_stability_count_can_be_switched_off_in_python_and_toml(tmp_path):
    from flexbody.scenes.scene import Scene, StaticAnalysis, run_scene
    from flexbody.scenes.toml_scene import load_toml_scene
    scene = Scene("column", "strip past Euler", column(),
                  StaticAnalysis("load_control", (0.5, 1.2), stability=False), [])
    summary = run_scene(scene)
    assert all(r.negative_eigenvalues is None for r in summary.result.records)
    stability = summary.as_dict()["stability"]
    assert stability["final_negative_eigenvalues"] is None and stability["critical_points"] == []
    toml = load_toml_scene("examples/cantilever_end_shear.toml", {"analysis.stability": False})
    assert toml.analysis.stability is False
    with pytest.raises(Exception, match="stability"):
        load_toml_scene("examples/cantilever_end_shear.toml", {"analysis.stability": "maybe"})


def test_flexbody_modes_buckling_runs_the_buckling_analysis(tmp_path, capsys):
    from flexbody.cli import main
    out = tmp_path / "b.json"
    assert main(["modes", PLATE, "--buckling", "--count", "2", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert len(data["load_factors"]) == 2 and data["load_factors"][0] > 0
    assert "critical load factor" in capsys.readouterr().out
    with pytest.raises(SystemExit, match="--buckling takes --set, --count and --json only, not --omega"):
        main(["modes", PLATE, "--buckling", "--omega", "3"])
