"""Steady spin (relative equilibrium): tangent on the group, the rotating disk, and the discrete equilibrium."""

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix, FixDirection
from flexbody.dynamics import DynamicModel
from flexbody.loads import NodalLoad
from flexbody.mesh import generators
from flexbody.scenes.builtin import rotating_annulus_displacement
from flexbody.shell.material import ShellMaterial
from flexbody.spinning import SpinningModel, gauge_supports, steady_spin
from tests.test_assembly import fd_check, random_state

A, B, E, NU, RHO = 0.2, 1.0, 1e9, 0.3, 1000.0


def annulus_dynamic(n_radial=2, n_circ=16, hub=True, thickness=1e-3, scale=1.0, loads=()):
    mesh = generators.annulus(A * scale, B * scale, n_radial, n_circ)
    cons = [Fix(mesh.node_set("inner"), "all")] if hub else []
    body = ShellBody(mesh, ShellMaterial(E, NU, thickness * scale, density=RHO))
    return DynamicModel(Model(body, cons, list(loads)))


@pytest.mark.parametrize("hub", [True, False])
def test_spin_tangent_against_group_finite_differences(hub):
    """Tilted spin axis (director moments and a full 3 x 3 centrifugal block), a deformed state, and the gauge
    supports of the free body (nodes with a fixed translation basis)."""
    rng = np.random.default_rng(3)
    dyn = annulus_dynamic(1, 6, hub=hub, thickness=0.05)
    omega = np.array([3.0, -2.0, 20.0])
    if not hub:
        gauged = Model(dyn.model.body, gauge_supports(dyn, omega, np.zeros(3)))
        dyn = DynamicModel(gauged)
        assert dyn.model.has_basis.sum() == 2
    spin = SpinningModel(dyn, omega, [0.1, 0.05, 0.0])
    state = random_state(spin.model, rng, scale=0.05)
    assert fd_check(spin, state, 0.7) < 1e-6
    # the spin load's own tangent, block by block (its director part is small against the membrane stiffness)
    K = spin.spin_load_tangent(state).toarray()
    eps = 1e-6
    fd = np.column_stack([(spin.spin_load(spin.update(state, eps * e)) - spin.spin_load(spin.update(state, -eps * e)))
                          / (2 * eps) for e in np.eye(spin.n_dof)])
    rot = spin.model.free % 6 >= 3
    for rows in (~rot, rot):
        assert np.abs(K[rows] - fd[rows]).max() < 1e-7 * np.abs(K[rows]).max()
    gauge = np.repeat(dyn.model.has_basis, 6)[spin.model.free]
    if gauge.any():
        assert np.abs(K[np.ix_(gauge, gauge)] - fd[np.ix_(gauge, gauge)]).max() < 1e-7 * np.abs(K[gauge]).max()
    # the director moments are there and are what the 5-DoF dynamics needs: j (t . Omega) (Omega x t)
    t = state.directors
    expected = dyn.inertia.rotary[:, None] * (t @ omega)[:, None] * np.cross(omega, t)
    from flexbody.spinning import director_spin_moments
    local = director_spin_moments(dyn.inertia.rotary, state.frames, omega)
    assert np.allclose(np.einsum("nij,nj->ni", state.frames[:, :, :2], local), expected, atol=1e-12 * np.abs(expected).max())
    assert np.abs(expected).max() > 0
    # the translational rows: the compiled operator against the readable nodal forces, in the model's row layout
    from flexbody.spinning import centrifugal_forces
    f = dyn.body_mass.scalar @ centrifugal_forces(spin._turning, state.x, omega, spin.center)
    f6 = np.zeros((dyn.model.body.n_nodes, 6))
    f6[:, :3] = np.einsum("nij,nj->ni", spin._rows, f)
    f6[:, 3:5] = local
    reference = f6.ravel()[spin.model.free]
    assert np.abs(spin.spin_load(state) - reference).max() < 1e-13 * np.abs(reference).max()


@pytest.mark.parametrize("hub", [True, False])
def test_steady_spin_is_the_rotating_disk_and_an_equilibrium_of_the_discrete_motion(hub):
    """The plane-stress rotating annulus (Timoshenko & Goodier): rim displacement converging under refinement
    (the chord error of the straight-sided polygon, ~(pi/n)^2/6), and the initial acceleration of the dynamic
    model at the steady spin is the centripetal one to the solver's tolerance."""
    omega = 20.0
    ref = rotating_annulus_displacement(B, omega, A, B, E, NU, RHO, "hub" if hub else "free")
    errors = []
    for n_radial, n_circ in ((2, 16), (4, 32)):
        dyn = annulus_dynamic(n_radial, n_circ, hub)
        s = steady_spin(dyn, [0.0, 0.0, omega], center=[0.0, 0.0, 0.0])
        outer = dyn.model.body.mesh.node_set("outer")
        u = np.linalg.norm(s.state.x[outer, :2], axis=1) - B
        errors.append(abs(u.mean() / ref - 1))
        assert np.abs(s.state.x[:, 2]).max() == 0.0          # in-plane spin stays flat
        acc = dyn.initial_acceleration(s.state)
        xddot, _ = dyn.nodal_velocities(s.state, acc)
        centripetal = -omega**2 * s.state.x
        centripetal[:, 2] = 0.0
        moving = ~np.all(dyn.model.fixed[:, :3], axis=1)
        assert np.abs(xddot[moving] - centripetal[moving]).max() < 1e-6 * np.abs(centripetal).max()
        assert np.allclose(s.velocity, dyn.rigid_velocity(s.state, [0, 0, omega]))
        if not hub:
            assert len(s.gauge_nodes) == 2 and s.gauge_residual < 1e-6
    assert errors[1] < 0.8 * errors[0] and errors[1] < 3e-3, errors


def test_steady_spin_is_scale_free():
    """The same annulus in millimetres-sized and kilometre-sized units: the same strain state."""
    strains = []
    for scale in (1e-3, 1e3):
        dyn = annulus_dynamic(1, 8, hub=True, scale=scale)
        omega = 20.0 / scale                  # same rim speed, same stretch
        s = steady_spin(dyn, [0.0, 0.0, omega], center=[0.0, 0.0, 0.0])
        outer = dyn.model.body.mesh.node_set("outer")
        strains.append(np.linalg.norm(s.state.x[outer, :2], axis=1).mean() / (B * scale) - 1)
    assert strains[0] == pytest.approx(strains[1], rel=1e-7)


@pytest.mark.parametrize("torque", [False, True])
def test_free_body_under_a_net_axial_load_or_torque_has_no_steady_spin(torque):
    mesh = generators.annulus(A, B, 1, 8)
    if torque:              # a couple about the axis: tangential forces at (b, 0) and (-b, 0)
        east = int(np.argmin(np.linalg.norm(mesh.nodes - [B, 0, 0], axis=1)))
        west = int(np.argmin(np.linalg.norm(mesh.nodes - [-B, 0, 0], axis=1)))
        loads = [NodalLoad([east], force=[0.0, 1e-3, 0.0]), NodalLoad([west], force=[0.0, -1e-3, 0.0])]
    else:
        loads = [NodalLoad(mesh.node_set("outer"), force=[0.0, 0.0, 1e-3])]
    dyn = annulus_dynamic(1, 8, hub=False, loads=loads)
    with pytest.raises(ValueError, match="no steady spin about this axis"):
        steady_spin(dyn, [0.0, 0.0, 20.0], center=[0.0, 0.0, 0.0])


@pytest.mark.parametrize("scale", [1e-3, 1.0])
def test_slow_free_spin_at_tiny_strain_is_found(scale):
    """A free annulus at a rim speed of 2 cm/s (strain 4e-10): the gauge check measures the loads' axial
    resultants, not the solve's round-off (the gauge DoFs' residual was 6e-5 of the load here)."""
    dyn = annulus_dynamic(1, 8, hub=False, scale=scale)
    s = steady_spin(dyn, [0.0, 0.0, 0.02 / scale], center=[0.0, 0.0, 0.0])
    assert s.gauge_residual < 1e-12
    outer = dyn.model.body.mesh.node_set("outer")
    strain = np.linalg.norm(s.state.x[outer, :2], axis=1).mean() / (B * scale) - 1
    ref = rotating_annulus_displacement(B, 0.02, A, B, E, NU, RHO, "free") / B
    assert strain == pytest.approx(ref, rel=0.05)


@pytest.mark.parametrize("kwargs, match", [(dict(omega=[0, 0, 0]), "zero"), (dict(omega=[0, 0, np.nan]), "finite"),
                                           (dict(omega=[0, 0, 1], center=[0, 0]), "centre"),
                                           (dict(omega=[0, 0, 1], n_steps=0), "n_steps")])
def test_bad_spin_input_is_refused_with_the_value(kwargs, match):
    dyn = annulus_dynamic(1, 6)
    with pytest.raises(ValueError, match=match):
        steady_spin(dyn, **kwargs)


def test_fix_direction_refuses_a_zero_direction_and_normalises_huge_ones():
    with pytest.raises(ValueError, match="direction"):
        FixDirection([0], [0.0, 0.0, 0.0])
    assert np.allclose(FixDirection([0], [1e300, 1e300, 0.0]).direction, [2**-0.5, 2**-0.5, 0.0])


# -- dynamic runs that start on the steady spin -------------------------------------------------------------
from pathlib import Path  # noqa: E402

from flexbody.scenes import load_toml_scene, run_scene  # noqa: E402
from flexbody.scenes.sources import SceneError  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spinning_membrane_steady.toml"


def test_a_run_started_on_the_steady_spin_stays_on_it():
    """The example: hub at a constant 20 rad/s from t = 0. The rim stretch is the rotating-disk one from the
    first instant and does not breathe (a start from the unstretched state would oscillate about it with the
    full stretch as amplitude), on one factorization."""
    summary = run_scene(load_toml_scene(EXAMPLE, {"end_time": 0.03}))
    assert summary.result.converged
    u = np.asarray(summary.history["u_r_outer"])
    ref = rotating_annulus_displacement(1.0, 20.0, 0.5, 1.0, E, NU, RHO, "hub")
    assert abs(u[0] / ref - 1) < 6e-3                       # the mesh's chord error (2 x 32)
    assert np.ptp(u) < 1e-3 * ref
    assert summary.result.stats.factorizations <= 2
    assert summary.max_rel_error < 6e-3


def test_a_steady_spin_start_needs_the_hub_at_that_rate(tmp_path):
    text = EXAMPLE.read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('set = "inner"\nangular_velocity = [0.0, 0.0, 20.0]',
                                'set = "inner"\nangular_velocity = [0.0, 0.0, 20.0]\nramp_time = 0.05'))
    with pytest.raises(SceneError, match="ramp_time"):
        load_toml_scene(bad)
    bad.write_text(text.replace("[analysis.initial]\nstate", "[analysis.initial]\nvelocity = [1.0, 0.0, 0.0]\nstate"))
    with pytest.raises(SceneError, match="velocity"):
        load_toml_scene(bad)


SAIL = Path(__file__).resolve().parents[1] / "examples" / "solar_sail_10m.toml"


def test_the_10m_sail_under_a_rim_pulse_runs_at_default_settings():
    """The sail of the spinning-membranes issue (h/L = 1e-5, 2 rpm, 2 mN on the rim in a sin^2 pulse), started on
    its steady spin: the default (modified) iteration used to fail at step 6; a step that fails on kept matrices
    is now retried with Newton's method."""
    summary = run_scene(load_toml_scene(SAIL))
    assert summary.result.converged, summary.result.message
    w = np.asarray(summary.history["w_corner"])
    assert w[-1] > 0 and np.all(np.isfinite(w))          # pushed out of plane along the pulse


def test_rho_inf_defaults_to_the_steady_spin_value_only_with_a_driven_hub(tmp_path):
    """Without rho_inf a steady-spin start on a driven hub integrates at STEADY_SPIN_RHO_INF (the kicked thin
    annulus of 16 x 128 cells fails at 0.9); a free body and a start from rest keep 0.9; a given value wins."""
    from flexbody.scenes.analysis import DEFAULT_RHO_INF
    from flexbody.spinning import STEADY_SPIN_RHO_INF
    assert STEADY_SPIN_RHO_INF < DEFAULT_RHO_INF
    hub = load_toml_scene(EXAMPLE).analysis
    assert hub.rho_inf is None and hub.rho_inf_used == STEADY_SPIN_RHO_INF
    assert hub.alpha_settings().rho_inf == STEADY_SPIN_RHO_INF
    text = EXAMPLE.read_text()
    text = text[:text.index("[reference]")]                 # its CSV lives beside the example
    given = tmp_path / "given.toml"
    given.write_text(text.replace('type = "dynamic"', 'type = "dynamic"\nrho_inf = 0.8'))
    assert load_toml_scene(given).analysis.alpha_settings().rho_inf == 0.8
    free = tmp_path / "free.toml"
    start = text.index("[analysis.hub]")
    free.write_text(text[:start] + text[text.index("[[output]]"):])   # the same membrane without its hub
    assert load_toml_scene(free).analysis.rho_inf_used == DEFAULT_RHO_INF
    still = tmp_path / "still.toml"
    still.write_text(text.replace('state = "steady_spin"', 'state = "reference"'))
    assert load_toml_scene(still).analysis.rho_inf_used == DEFAULT_RHO_INF
