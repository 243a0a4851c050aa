"""Scene vocabulary for spinning-membrane studies (issue #15, item 5): velocity fields, loads with time
functions (load groups), point masses, a hub by radius or polygon; in Python and in TOML."""

from pathlib import Path
import textwrap

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel
from flexbody.loads import FollowerPressure, NodalLoad
from flexbody.mesh import generators
from flexbody.scenes import load_toml_scene, run_scene
from flexbody.scenes.dynamic_run import modal_velocity_field, polar_coordinates
from flexbody.scenes.sources import SceneError
from flexbody.shell.inertia import PointMass
from flexbody.shell.material import ShellMaterial
from flexbody.spinning import steady_spin
from flexbody.time_functions import GroupFactors, Pulse, Ramp, Table
from tests.test_assembly import cylinder_model, random_state

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "kicked_spinning_annulus.toml"
A, B, E, NU, RHO = 0.2, 1.0, 1e9, 0.3, 1000.0


def hub_annulus(n_radial=1, n_circ=8, loads=(), load_groups=None, **kwargs) -> DynamicModel:
    mesh = generators.annulus(A, B, n_radial, n_circ)
    body = ShellBody(mesh, ShellMaterial(E, NU, 1e-3, density=RHO))
    return DynamicModel(Model(body, [Fix(mesh.node_set("inner"), "all")], list(loads), load_groups=load_groups),
                        **kwargs)


# -- loads with their own time functions -------------------------------------------------------------------
def test_time_functions():
    assert [Ramp(2.0)(t) for t in (-1.0, 0.5, 2.0, 5.0)] == [0.0, 0.25, 1.0, 1.0]
    sin2 = Pulse(1.0, 2.0)
    assert [sin2(t) for t in (0.5, 1.0, 2.0, 3.0)] == pytest.approx([0.0, 0.0, 1.0, 0.0], abs=1e-15)
    assert sin2(1.5) == pytest.approx(0.5)
    rect = Pulse(1.0, 2.0, "rect")
    assert [rect(t) for t in (0.99, 1.0, 2.99, 3.0)] == [0.0, 1.0, 1.0, 0.0]
    table = Table([0.0, 1.0, 3.0], [0.0, 2.0, -1.0])
    assert [table(t) for t in (-1.0, 0.5, 2.0, 9.0)] == [0.0, 1.0, 0.5, -1.0]      # held at the ends
    for bad, match in ((lambda: Ramp(0.0), "ramp time must be > 0"), (lambda: Pulse(0, -1), "duration"),
                       (lambda: Pulse(0, 1, "tri"), "shape"), (lambda: Table([0, 0], [1, 2]), "increasing"),
                       (lambda: Table([0, 1], [1]), "values")):
        with pytest.raises(ValueError, match=match):
            bad()


def test_two_load_groups_with_their_own_factors_residual_and_exact_tangent():
    """Dead, follower and pressure loads in two groups with different factors lambda_k(t): the dynamic residual
    is f_int - sum_k lambda_k f_ext,k (the groups' Models added), and its tangent on the group is exact."""
    rng = np.random.default_rng(5)
    base = cylinder_model(kernel="numba")
    base = Model(ShellBody(base.body.mesh, ShellMaterial(1e4, 0.3, 0.05, density=1.0)), base.constraints, base.loads)
    loads, groups = base.loads, (0, 1, 1, 0)          # dead force, dead moment | follower load, pressure
    model = Model(base.body, base.constraints, loads, load_groups=groups)
    factors = GroupFactors((Ramp(1.0), Pulse(0.1, 1.0)))
    dyn = DynamicModel(model, load_factor=factors)
    t = 0.35
    lam = factors(t)
    assert lam[0] == pytest.approx(0.35) and lam[1] == pytest.approx(np.sin(0.25 * np.pi) ** 2)
    state = random_state(model, rng, scale=0.05)
    vdot = rng.normal(size=dyn.n_dof)
    v = np.zeros(dyn.n_dof)                          # undamped: the velocity does not enter
    alone = [Model(base.body, base.constraints, [ld for ld, g in zip(loads, groups) if g == k]) for k in (0, 1)]
    internal = Model(base.body, base.constraints, []).residual(state, 0.0)
    expected = dyn.mass_matrix() @ vdot + sum(m.residual(state, lam[k]) - internal for k, m in enumerate(alone)) + internal
    r, K = dyn.residual_and_tangent(state, v, vdot, t)
    assert np.abs(r - expected).max() < 1e-12 * np.abs(expected).max()
    assert np.abs(r - dyn.residual(state, v, vdot, t)).max() < 1e-12 * np.abs(r).max()
    # against one shared factor lambda_0 the difference is (lambda_0 - lambda_1) f_ext,1: the groups have their own
    shared = dyn.mass_matrix() @ vdot + model.residual(state, lam[0])
    f1 = alone[1].external_force(state)
    assert np.abs(r - shared - (lam[0] - lam[1]) * f1).max() < 1e-12 * np.abs(r).max()
    assert abs(lam[0] - lam[1]) * np.abs(f1).max() > 1e-4 * np.abs(r).max()
    K = K.toarray()
    eps = 1e-6
    fd = np.column_stack([(dyn.residual(dyn.update(state, eps * e), v, vdot, t)
                           - dyn.residual(dyn.update(state, -eps * e), v, vdot, t)) / (2 * eps) for e in np.eye(dyn.n_dof)])
    assert np.abs(K - fd).max() < 1e-6 * np.abs(K).max()
    # the pressure's tangent is in: without it the check would fail
    assert any(isinstance(ld, FollowerPressure) for ld in loads)


def test_load_groups_refuse_a_wrong_count_of_factors_or_groups():
    model = cylinder_model(kernel="numba")
    grouped = Model(model.body, model.constraints, model.loads, load_groups=(0, 1, 1, 0))
    with pytest.raises(ValueError, match="2 factors"):
        grouped.residual(grouped.initial_state(), [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="load_groups"):
        Model(model.body, model.constraints, model.loads, load_groups=(0, 1))
    with pytest.raises(FloatingPointError, match="non-finite load factor"):
        grouped.residual(grouped.initial_state(), [1.0, np.nan])


def test_loads_that_cancel_at_factor_one_may_sit_in_different_groups():
    """Equal and opposite forces on a free node with different time functions do not cancel in time: the
    model's check of loads on constrained DoFs takes each group on its own."""
    dyn = hub_annulus()
    tip = dyn.model.body.mesh.nearest_node([B, 0.0, 0.0])
    loads = [NodalLoad([tip], force=[0, 0, 1.0]), NodalLoad([tip], force=[0, 0, -1.0])]
    model = Model(dyn.model.body, dyn.model.constraints, loads, load_groups=(0, 1))
    assert np.abs(model.external_force(model.initial_state(), [1.0, 0.0])).max() == 1.0


# -- point masses ----------------------------------------------------------------------------------------
def test_a_tip_mass_on_a_spinning_annulus_is_its_centrifugal_force():
    """The steady spin includes the point mass: its rim stretch is that of the same annulus without it under the
    point-mass centrifugal force M Omega^2 r (at the node's spun position) as a nodal load, and larger than
    without; the rotary inertia adds to the director inertia."""
    omega = np.array([0.0, 0.0, 20.0])
    probe = hub_annulus(2, 16)
    tip = probe.model.body.mesh.nearest_node([B, 0.0, 0.0])
    M, J = 0.05 * probe.inertia.total_mass, 1e-4
    with_mass = hub_annulus(2, 16, point_masses=[PointMass([tip], M, J)])
    assert with_mass.inertia.mass[tip] == pytest.approx(probe.inertia.mass[tip] + M)
    assert with_mass.inertia.rotary[tip] == pytest.approx(probe.inertia.rotary[tip] + J)
    spun = steady_spin(with_mass, omega, [0.0, 0.0, 0.0]).state
    x = spun.x[tip]
    force = M * 400.0 * np.array([x[0], x[1], 0.0])                        # M Omega^2 r, radial
    loaded = steady_spin(hub_annulus(2, 16, loads=[NodalLoad([tip], force=force)]), omega, [0, 0, 0]).state
    bare = steady_spin(probe, omega, [0.0, 0.0, 0.0]).state
    u = lambda s: np.linalg.norm(s.x[tip, :2]) - B
    assert u(spun) > 1.5 * u(bare)
    assert abs(u(spun) - u(loaded)) < 1e-6 * u(spun)
    assert np.abs(spun.x - loaded.x).max() < 1e-6 * u(spun)
    # the angular momentum of a rigid rotation sees M and the rotary inertia about the axes normal to the
    # director (the tip's director is z): L_with - L_without = M r x (w x r) + J (w - t (t . w))
    state = probe.model.initial_state()
    r = state.x[tip]
    for w in ([0.0, 0.0, 3.0], [2.0, 0.0, 0.0], [0.5, -1.0, 2.0]):
        w = np.array(w)
        added = (with_mass.momenta(state, with_mass.rigid_velocity(state, w))[1]
                 - probe.momenta(state, probe.rigid_velocity(state, w))[1])
        expected = M * np.cross(r, np.cross(w, r)) + J * np.array([w[0], w[1], 0.0])
        assert np.allclose(added, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


def test_bad_point_masses_are_refused():
    with pytest.raises(ValueError, match="mass must be a finite number >= 0"):
        PointMass([0], -1.0)
    with pytest.raises(ValueError, match="rotary"):
        PointMass([0], 1.0, np.inf)
    with pytest.raises(ValueError, match="node 999"):
        hub_annulus(point_masses=[PointMass([999], 1.0)])


# -- velocity fields -------------------------------------------------------------------------------------
def test_the_modal_velocity_field_is_the_kick_of_the_issue():
    x = generators.annulus(A, B, 2, 16).nodes
    r, theta = np.hypot(x[:, 0], x[:, 1]), np.arctan2(x[:, 1], x[:, 0])
    v = modal_velocity_field(x, [0, 0, 2.0], 0.05, "linear", modes=[0, 1, 2, 3])
    expected = 0.05 * (r - A) / (B - A) * sum(np.cos(n * theta) for n in range(4))
    assert np.allclose(v[:, 2], expected, atol=1e-15) and not np.any(v[:, :2])
    q = modal_velocity_field(x, [1, 0, 0], 1.0, "quadratic", modes=[2], phase=0.3, inner_radius=0.5)
    s = np.clip((r - 0.5) / 0.5, 0, 1)
    assert np.allclose(q[:, 0], s**2 * np.cos(2 * (theta - 0.3)))
    u = modal_velocity_field(x, [0, 0, 1], 1.0, "uniform", modes=[0])
    assert np.all(u[:, 2] == 1.0)
    tab = modal_velocity_field(x, [0, 0, 1], 1.0, [[0.5, 1.0], [1.0, 3.0]], modes=[0])
    assert np.allclose(tab[:, 2], np.interp(r, [0.5, 1.0], [1.0, 3.0]))
    # about a tilted axis through a centre: r and theta are the polar coordinates in its plane
    rr, _ = polar_coordinates(x + [1, 2, 3], [1, 2, 3], [0, 0, 5])
    assert np.allclose(rr, r)
    for kwargs, match in ((dict(direction=[0, 0, 0]), "direction"), (dict(radial="cubic"), "radial"),
                          (dict(modes=[-1]), "modes"), (dict(inner_radius=2.0, outer_radius=1.0), "outer_radius"),
                          (dict(radial=[[1.0, 0.5], [0, 1]]), "radial table"), (dict(amplitude=np.nan), "amplitude")):
        args = dict(direction=[0, 0, 1], amplitude=1.0) | kwargs
        with pytest.raises(ValueError, match=match):
            modal_velocity_field(x, **args)


# -- TOML ------------------------------------------------------------------------------------------------
def write(tmp_path, text: str) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(textwrap.dedent(text))
    return path


SMALL = """
    name = "small_annulus"
    [mesh]
    generator = "annulus"
    inner_radius = 0.2
    outer_radius = 1.0
    n_radial = 1
    n_circ = 8
    [material]
    young = 1e9
    poisson = 0.3
    thickness = 1e-3
    density = 1000.0
    [analysis]
    type = "dynamic"
    dt = 1e-3
    end_time = 6e-3
    load_ramp_time = 0.004
    [analysis.hub]
    radius = 0.2
    angular_velocity = [0.0, 0.0, 0.0]
    [[load]]
    type = "nodal"
    near = [1.0, 0.0, 0.0]
    force = [0.0, 0.0, 1e-3]
    time_function = { type = "pulse", start = 0.003, duration = 0.004, shape = "rect" }
    [[load]]
    type = "nodal"
    near = [-1.0, 0.0, 0.0]
    force = [0.0, 0.0, 2e-3]
    [[load]]
    type = "nodal"
    near = [0.0, 1.0, 0.0]
    force = [0.0, 0.0, 1e-3]
    time_function = { type = "table", time = [0.0, 0.002, 0.004], value = [0.0, 1.0, 0.5] }
    [[point_mass]]
    near = [0.0, -1.0, 0.0]
    mass = 0.01
    rotary = 1e-6
    [[output]]
    name = "w_0"
    near = [1.0, 0.0, 0.0]
    component = "z"
    [[output]]
    name = "w_90"
    near = [0.0, 1.0, 0.0]
    component = "z"
"""


def test_toml_vocabulary_round_trips_into_the_python_objects(tmp_path):
    scene = load_toml_scene(write(tmp_path, SMALL))
    model, a = scene.model, scene.analysis
    mesh = model.body.mesh
    assert model.load_groups == (1, 0, 2)
    assert isinstance(a.load_factor, GroupFactors)
    assert a.load_factor(0.002).tolist() == pytest.approx([0.5, 0.0, 1.0])      # ramp | pulse | table
    assert a.load_factor(0.003).tolist() == pytest.approx([0.75, 1.0, 0.75])
    assert a.load_factor(0.009).tolist() == pytest.approx([1.0, 0.0, 0.5])      # the table held at its end
    (pm,) = a.point_masses
    assert pm.nodes.tolist() == [mesh.nearest_node([0, -1, 0])] and (pm.mass, pm.rotary) == (0.01, 1e-6)
    hub = a.prescribed[0].nodes
    assert sorted(hub.tolist()) == sorted(mesh.node_set("inner").tolist())
    # the example's kick is the Python helper's field
    kicked = load_toml_scene(EXAMPLE)
    expected = modal_velocity_field(kicked.model.body.mesh.nodes, [0, 0, 1], 0.05, "linear", modes=[0, 1, 2, 3])
    assert np.array_equal(kicked.analysis.initial_velocity, expected)
    assert kicked.analysis.initial_state.angular_velocity == (0.0, 0.0, 20.0)
    # without a time function the loads keep one shared factor (the global load ramp)
    plain = load_toml_scene(write(tmp_path, SMALL.replace(
        '    time_function = { type = "pulse", start = 0.003, duration = 0.004, shape = "rect" }\n', "").replace(
        '    time_function = { type = "table", time = [0.0, 0.002, 0.004], value = [0.0, 1.0, 0.5] }\n', "")))
    assert plain.model.load_groups is None and plain.analysis.load_factor(0.002) == pytest.approx(0.5)


def test_a_hub_by_polygon_selects_the_nodes_inside_it(tmp_path):
    text = SMALL.replace('generator = "annulus"\n    inner_radius = 0.2\n    outer_radius = 1.0\n    n_radial = 1\n'
                         '    n_circ = 8', 'generator = "regular_polygon"\n    n_sides = 6\n    radius = 1.0\n'
                         '    n_rings = 2').replace("radius = 0.2\n    angular_velocity",
                                               "polygon = { sides = 6, circumradius = 0.5 }\n    angular_velocity")
    scene = load_toml_scene(write(tmp_path, text))
    hub = scene.analysis.prescribed[0].nodes
    assert hub.size == 19                                     # centre + 6 + 12 lattice points of the inner hexagon
    assert np.linalg.norm(scene.model.body.mesh.nodes[hub], axis=1).max() == pytest.approx(0.5)
    turned = load_toml_scene(write(tmp_path, text.replace("circumradius = 0.5 }", "circumradius = 0.5, angle = 0.5236 }")))
    assert turned.analysis.prescribed[0].nodes.size < 19      # a hexagon turned by 30 degrees cuts the lattice


def test_loads_follow_their_time_functions_in_a_run(tmp_path):
    """The rect pulse starts at t = 3 ms: the pulse-only scene is at rest until then (the step to t_{n+1}
    sees the load at t_{n+1}) and moves from the step that ends at 3 ms; with the table's load (from t = 0)
    the other node moves from the first step."""
    only_pulse = SMALL.split("    [[load]]")
    text = "    [[load]]".join(only_pulse[:2]) + SMALL[SMALL.index("    [[point_mass]]"):]
    summary = run_scene(load_toml_scene(write(tmp_path, text)))
    assert summary.result.converged
    t, w = np.asarray(summary.history["time"]), np.asarray(summary.history["w_0"])
    assert np.all(w[t < 0.003 - 1e-9] == 0.0) and np.all(w[t > 0.003 - 1e-9] > 0)
    both = run_scene(load_toml_scene(write(tmp_path, SMALL)))
    assert both.result.converged and np.asarray(both.history["w_90"])[1] > 0     # the table's load from t = 0


BAD = [
    ('shape = "rect" }', 'shape = "tri" }', "load.0.time_function.shape must be one of"),
    ('type = "pulse"', 'type = "step"', "load.0.time_function.type must be one of"),
    ("duration = 0.004", "duration = 0", "load.0.time_function.duration must be > 0"),
    ("value = [0.0, 1.0, 0.5]", "value = [0.0, 1.0]", "load.2.time_function.value must have one value per time"),
    ("time = [0.0, 0.002, 0.004]", "time = [0.0, 0.004, 0.002]", "load.2.time_function.time must be increasing"),
    ("start = 0.003,", "start = 0.003, amplitude = 2,", "unknown key 'load.0.time_function.amplitude'"),
    ("mass = 0.01", "mass = -0.01", "point_mass.0.mass must be >= 0"),
    ("rotary = 1e-6", "rotary = [1e-6, 2e-6]", "point_mass.0.rotary must be one number"),
    ("rotary = 1e-6", "rotary = 1e-6\n    inertia = 1", "unknown key 'point_mass.0.inertia'"),
    ("radius = 0.2\n    angular", "radius = 0.1\n    angular", "analysis.hub.radius selects no nodes"),
    ("radius = 0.2\n    angular", "radius = 0.2\n    set = \"inner\"\n    angular", "exactly one node selection"),
    ("radius = 0.2\n    angular", "polygon = { sides = 2, circumradius = 0.2 }\n    angular",
     "analysis.hub.polygon.sides must be an integer >= 3"),
    ("radius = 0.2\n    angular", "radius = -0.2\n    angular", "analysis.hub.radius must be > 0"),
]
KICK = """
    [analysis.initial]
    [[analysis.initial.velocity_field]]
    direction = [0.0, 0.0, 1.0]
    amplitude = 0.05
"""
BAD_KICK = [
    ("amplitude = 0.05", "amplitude = 0.05\n    radial = \"cubic\"", "velocity_field.0: radial must be one of"),
    ("amplitude = 0.05", "amplitude = 0.05\n    radial = [1, 2]", "velocity_field.0.radial must be one of"),
    ("amplitude = 0.05", "amplitude = 0.05\n    radial = [[1.0, 0.5], [0, 1]]", "radial table"),
    ("amplitude = 0.05", "amplitude = 0.05\n    modes = [0, -1]", "velocity_field.0.modes must be"),
    ("direction = [0.0, 0.0, 1.0]", "direction = [0.0, 0.0, 0.0]", "velocity_field.0: direction must be"),
    ("amplitude = 0.05", "amplitude = 0.05\n    mode = [2]", "unknown key 'analysis.initial.velocity_field.0.mode'"),
    ("amplitude = 0.05", "amplitude = 0.05\n    inner_radius = 2.0", "outer_radius must exceed inner_radius"),
]


@pytest.mark.parametrize("old, new, message", BAD + BAD_KICK)
def test_bad_vocabulary_is_one_line_naming_the_key(tmp_path, old, new, message):
    text = SMALL + KICK
    assert text.count(old) == 1
    with pytest.raises(SceneError) as exc:
        load_toml_scene(write(tmp_path, text.replace(old, new, 1)))
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_static_scenes_refuse_time_functions_and_point_masses(tmp_path):
    text = (REPO / "examples" / "clamped_plate.toml").read_text()
    path = tmp_path / "static.toml"
    path.write_text(text.replace('[[load]]\n', '[[load]]\ntime_function = { type = "ramp", time = 1.0 }\n', 1))
    with pytest.raises(SceneError, match="load.0.time_function needs a dynamic analysis"):
        load_toml_scene(path)
    path.write_text(text + '\n[[point_mass]]\nnodes = [0]\nmass = 1.0\n')
    with pytest.raises(SceneError, match=r"\[\[point_mass\]\] needs a dynamic analysis"):
        load_toml_scene(path)


def test_the_kicked_example_runs_a_few_steps_and_moves_out_of_plane():
    summary = run_scene(load_toml_scene(EXAMPLE, {"end_time": 5 * 0.0031415926535897933}))
    assert summary.result.converged
    w = np.asarray(summary.history["w_rim_0"])
    assert w[0] == 0.0 and abs(w[-1]) > 0.5 * 0.05 * 4 * summary.history["time"][1]   # moving at ~4 x 0.05 m/s
    assert np.ptp(summary.history["u_r_rim"]) < 0.05 * abs(summary.history["u_r_rim"][0])   # the spin's stretch


def test_the_exudyn_adapter_refuses_point_masses(tmp_path):
    """The ANCF counterpart has no point masses: a free spinning plate with one is refused, not run without it."""
    from dataclasses import replace

    from flexbody.adapters.exudyn import _rigid_field
    from flexbody.scenes import build
    scene = build("spinning_plate")
    _rigid_field(scene)                                       # the plain plate has a counterpart
    heavy = replace(scene, analysis=replace(scene.analysis, point_masses=(PointMass([0], 1.0),)))
    with pytest.raises(ValueError, match="without point masses"):
        _rigid_field(heavy)
