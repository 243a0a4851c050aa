"""Rayleigh damping: the force and its velocity derivative, a free vibration's logarithmic decrement, the energy
balance T + W + D = E0, and a spinning free plate (the stiffness part does not damp rigid motion, the mass part
does)."""

import numpy as np
import pytest
import scipy.linalg

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel, RayleighDamping
from flexbody.energy import integrate_motion
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import MITC7
from flexbody.spinning import steady_spin
from integrators.generalized_alpha import AlphaSettings, generalized_alpha


pytestmark = pytest.mark.usefixtures("one_numba_thread")


def spinning_annulus(damping: RayleighDamping | None, omega: float = 20.0):
    """A free annulus (a/b = 0.2, 1 x 8 cells) on its steady spin about z: a pre-stressed, deformed state."""
    mesh = generators.annulus(0.2, 1.0, 1, 8)
    body = ShellBody(mesh, ShellMaterial(1e9, 0.3, 1e-3, density=1000.0))
    dyn = DynamicModel(Model(body, []), damping=damping)
    spin = steady_spin(dyn, [0.0, 0.0, omega], np.zeros(3))
    return dyn, spin


def material_tangent(dyn: DynamicModel, state) -> np.ndarray:
    """B^T C B in the dynamic layout: the tangent whose geometric terms carry zero stresses (no loads)."""
    return dyn.material_stiffness(state).toarray()


def test_damping_force_derivative_and_rigid_velocities():
    """df_d/dv = a0 M + a1 B^T C B (central differences); f_d of a rigid velocity is zero at the deformed,
    pre-stressed steady spin, while K_t v_rigid (the geometric stiffness of the spin's stresses) is not."""
    a0, a1 = 0.7, 2e-4
    dyn, spin = spinning_annulus(RayleighDamping(a0, a1))
    rng = np.random.default_rng(5)
    state = dyn.update(spin.state, 1e-3 * rng.normal(size=dyn.n_dof))     # off the spin, out of plane too
    v = rng.normal(size=dyn.n_dof)
    eps = 1e-3
    fd = np.column_stack([(dyn.damping_force(state, v + eps * e) - dyn.damping_force(state, v - eps * e)) / (2 * eps)
                          for e in np.eye(dyn.n_dof)])
    expected = a0 * dyn.mass_matrix().toarray() + a1 * material_tangent(dyn, state)
    assert np.abs(fd - expected).max() < 1e-8 * np.abs(expected).max()
    # the force-only path of the kernel gives the forces of the mixed iteration's given stresses
    body = dyn.model.body
    sigma = rng.normal(size=(body.mesh.n_elements, 7, 8))
    f_mixed = body.mixed_element_forces(state, sigma)[2]
    assert np.abs(body.stress_forces(state, sigma) - f_mixed).max() < 1e-12 * np.abs(f_mixed).max()
    # the iteration matrix's C is that derivative
    assert np.abs(dyn.damping_matrix(state).toarray() - fd).max() < 1e-8 * np.abs(expected).max()
    z = np.zeros(dyn.n_dof)

    # rigid velocities at the steady spin: the spin itself, a tumble about a tilted axis, a translation
    q = spin.state
    K = dyn.residual_and_tangent(q, z, z, 0.0)[1]
    scale = np.abs(dyn.material_damping_force(q, rng.normal(size=dyn.n_dof))).max()   # of a unit velocity
    spin_forces = np.abs(dyn.internal_minus_external(q, 0.0)).max()      # the stresses' nodal forces
    for omega in ([0.0, 0.0, 20.0], [3.0, -2.0, 0.0], [1.0, 2.0, 3.0]):
        v_rigid = dyn.rigid_velocity(q, omega, v0=[0.1, 0.2, 0.3])
        v_scale = np.linalg.norm(v_rigid) / np.sqrt(dyn.n_dof)
        assert np.abs(dyn.material_damping_force(q, v_rigid)).max() < 1e-9 * scale * v_scale
        # the full tangent would damp it: K_t v_rigid = G(sigma) v_rigid ~ |omega| times the stresses' forces
        # (measured 0.8 to 20 times that), and a1 K_t v would be a torque against the spin
        assert np.abs(K @ v_rigid).max() > 0.5 * spin_forces * np.linalg.norm(omega)
    # the a1 part of the damping force of the spin's own velocity is zero, the a0 part is a0 M v
    f = dyn.damping_force(q, spin.velocity)
    assert np.allclose(f, a0 * (dyn.mass_matrix() @ spin.velocity), rtol=0, atol=1e-9 * np.abs(f).max())


def test_from_ratio_and_bad_parameters():
    d = RayleighDamping.from_ratio(0.05, (2.0, 10.0))
    w1, w2 = 2 * np.pi * 2.0, 2 * np.pi * 10.0
    assert d.ratio(w1) == pytest.approx(0.05) and d.ratio(w2) == pytest.approx(0.05)
    assert d.ratio(np.sqrt(w1 * w2)) < 0.05
    single = RayleighDamping.from_ratio(0.02, (3.0, 3.0))
    assert single.ratio(2 * np.pi * 3.0) == pytest.approx(0.02)
    for bad, word in ((lambda: RayleighDamping(-1.0), "alpha_mass"), (lambda: RayleighDamping(0.0, np.nan), "beta_stiffness"),
                      (lambda: RayleighDamping.from_ratio(-0.1, (1, 2)), "ratio"),
                      (lambda: RayleighDamping.from_ratio(0.1, (2, 1)), "frequencies_hz"),
                      (lambda: RayleighDamping.from_ratio(0.1, (0, 1)), "frequencies_hz"),
                      (lambda: RayleighDamping.from_ratio(0.1, 5.0), "frequencies_hz")):
        with pytest.raises(ValueError, match=word) as err:
            bad()
        assert "\n" not in str(err.value)


# -- a cantilever strip's free vibration -------------------------------------------------------------------
def cantilever(damping: RayleighDamping | None):
    mesh = generators.strip(1.0, 0.1, 4, 1)
    body = ShellBody(mesh, ShellMaterial(1e7, 0.3, 0.01, density=1000.0))
    return DynamicModel(Model(body, [Fix(mesh.node_set("clamped"), "all")]), damping=damping)


def first_mode(dyn: DynamicModel) -> tuple[float, np.ndarray]:
    """omega_1 and its mode shape of the linearized discrete model (K phi = omega^2 M phi at the reference)."""
    z = np.zeros(dyn.n_dof)
    K = dyn.residual_and_tangent(dyn.model.initial_state(), z, z, 0.0)[1].toarray()
    w2, phi = scipy.linalg.eigh(0.5 * (K + K.T), dyn.mass_matrix().toarray())
    return float(np.sqrt(w2[0])), phi[:, 0]


def free_vibration(damping: RayleighDamping | None, periods: float = 6.0, per_period: int = 60):
    """The first mode started by a velocity in its shape (amplitude ~1e-4 of the length: linear), rho_inf = 1
    (no numerical damping), ``per_period`` steps per period. Returns omega_1, the tip deflection history and the run."""
    dyn = cantilever(damping)
    omega, phi = first_mode(dyn)
    q0 = dyn.model.initial_state()
    xdot, _ = dyn.nodal_velocities(q0, phi)
    v0 = phi * (1e-4 * omega / np.abs(xdot[:, 2]).max())
    tip = dyn.model.body.mesh.node_set("tip")
    hist = []
    T = 2 * np.pi / omega
    run = integrate_motion(dyn, periods * T, T / per_period, state=q0, velocity=v0,
                           settings=AlphaSettings(rho_inf=1.0, rtol=1e-10, atol=1e-12),
                           on_step=lambda rec, q, v: hist.append((rec.time, q.x[tip, 2].mean())))
    assert run.result.converged, run.result.message
    return omega, np.array(hist), run


def peaks(hist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the maxima of a sampled signal (parabola through the three samples around each)."""
    t, y = hist[:, 0], hist[:, 1]
    i = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    d = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    h = t[1] - t[0]
    return t[i] + d * h, y1 - 0.25 * (y0 - y2) * d


@pytest.mark.parametrize("part", ["mass", "stiffness", "both"])
def test_logarithmic_decrement_matches_the_ratio(part):
    """zeta = 0.03 on the first mode: from a0 alone, a1 alone, or both (ratio at f1 and 4 f1). The measured
    delta = ln(y_k / y_k+1) = 2 pi zeta / sqrt(1 - zeta^2) over 5 periods gives zeta within 2 % (measured
    0.02992 in all three cases)."""
    zeta = 0.03
    omega = first_mode(cantilever(None))[0]
    f1 = omega / (2 * np.pi)
    damping = {"mass": RayleighDamping(2 * zeta * omega, 0.0), "stiffness": RayleighDamping(0.0, 2 * zeta / omega),
               "both": RayleighDamping.from_ratio(zeta, (f1, 4 * f1))}[part]
    assert damping.ratio(omega) == pytest.approx(zeta)
    _, hist, _ = free_vibration(damping)
    tp, yp = peaks(hist)
    assert len(yp) >= 5
    slope = np.polyfit(tp, np.log(yp), 1)[0]                 # -zeta omega
    measured = -slope / omega
    assert measured == pytest.approx(zeta, rel=0.02), measured
    # and the undamped run keeps its amplitude (the decrement is the damping's, not the scheme's)
    if part == "both":
        _, hist0, _ = free_vibration(None)
        tp0, yp0 = peaks(hist0)
        assert abs(np.polyfit(tp0, np.log(yp0), 1)[0]) / omega < 1e-3 * zeta          # measured 3.5e-8


def test_energy_balance_with_dissipated_work():
    """T + W + D = E0 to the integrator's accuracy while T + W alone loses most of E0. With rho_inf = 1 the
    per-step work of the mean damping force on the step's displacement is the scheme's own energy loss on a
    linear system: measured 1.4e-7, 1.8e-8 of E0 at T/30, T/60 (the trapezoid of the power v . f_d: 1.0e-2,
    2.5e-3)."""
    omega = first_mode(cantilever(None))[0]
    f1 = omega / (2 * np.pi)
    for per_period in (30, 60):
        _, _, run = free_vibration(RayleighDamping.from_ratio(0.05, (f1, 4 * f1)), 4.0, per_period)
        recs = [run.initial, *run.records]
        E0 = recs[0].total_energy
        mech = np.array([r.total_energy for r in recs])
        balance = np.array([r.energy_balance for r in recs])
        assert mech[-1] < 0.3 * E0                            # exp(-2 zeta omega t): 0.08 after 4 periods
        assert run.dissipated_energy == recs[-1].dissipated_energy
        assert np.abs(balance - E0).max() < 1e-6 * E0


@pytest.mark.parametrize("a1", [1.0, 10.0])
def test_a_heavily_damped_cantilever_sagging_under_gravity_converges(a1):
    """A 1 m strip (E = 1e7, h = 0.01) flopping under gravity: its geometric stiffness exceeds its bending
    stiffness, so the iteration matrix's C must be a0 M + a1 K_m (with a1 K_t: no convergence at step 15
    for a1 = 1 s, 257 factorizations in 30 steps for a1 = 10 s; with K_m: 41 and 49)."""
    dyn = DynamicModel(cantilever(None).model, gravity=(0.0, 0.0, -9.81), damping=RayleighDamping(0.0, a1))
    out = generalized_alpha(dyn, 0.3, 0.01)
    assert out.converged, out.message
    assert out.stats.factorizations < 100


def test_dissipated_work_of_an_overdamped_body_stays_bounded():
    """Stiffly overdamped modes alternate their velocity's sign from step to step (rho_inf = 1): the
    dissipated work must stay the energy lost. The cantilever sagging under a small gravity with a1 = 1 s
    (its first mode's ratio 0.5, the others far above 1): the balance holds to 3.4e-6 of |V_g|; the trapezoid of
    the power v . f_d gave 2.8e-4."""
    dyn = DynamicModel(cantilever(None).model, gravity=(0.0, 0.0, -0.1), damping=RayleighDamping(0.0, 1.0))
    run = integrate_motion(dyn, 0.3, 0.01, settings=AlphaSettings(rho_inf=1.0))
    assert run.result.converged, run.result.message
    recs = [run.initial, *run.records]
    scale = max(abs(r.potential_energy) for r in recs)
    balance = np.array([r.energy_balance for r in recs])
    assert scale > 0 and np.abs(balance - balance[0]).max() < 2e-5 * scale


# -- a spinning free plate ---------------------------------------------------------------------------------
def kicked_spin(damping: RayleighDamping | None, revolutions: float = 0.5, steps: int = 60):
    """The annulus on its steady spin at 20 rad/s, kicked out of plane (v_z = 0.5 (x^2 - y^2)), director rates
    from :meth:`DynamicModel.consistent_director_rates`; rho_inf = 1 (the scheme's own angular-momentum error
    is then 7e-7 here, 7e-6 at rho_inf = 0.9). Returns the model, the run and the kick's kinetic energy."""
    dyn, spin = spinning_annulus(damping)
    q = spin.state
    kick = np.zeros_like(q.x)
    kick[:, 2] = 0.5 * (q.x[:, 0] ** 2 - q.x[:, 1] ** 2)
    v_kick = dyn.consistent_director_rates(q, dyn.velocity_from_nodal(q, kick, np.zeros_like(kick)))
    v0 = spin.velocity + v_kick
    t_end = revolutions * 2 * np.pi / 20.0
    # the iteration to its tolerances (no local-error test): the conservation of L is a property of the converged
    # step, which the tests below check to 1e-6; with the default test L holds to the iteration error (2.7e-6)
    run = integrate_motion(dyn, t_end, t_end / steps, state=q, velocity=v0,
                           settings=AlphaSettings(rho_inf=1.0, local_error_fraction=0.0))
    assert run.result.converged, run.result.message
    return dyn, run, dyn.kinetic_energy(v_kick)


def test_consistent_director_rates():
    """They remove the damping moments of a translational kick and keep a rigid velocity."""
    dyn, spin = spinning_annulus(RayleighDamping(0.0, 1e-3))
    q = spin.state
    kick = np.zeros_like(q.x)
    kick[:, 2] = 0.5 * (q.x[:, 0] ** 2 - q.x[:, 1] ** 2)
    v = dyn.velocity_from_nodal(q, kick, np.zeros_like(kick))
    rot = ~dyn.is_translation
    before = np.abs(dyn.damping_force(q, v)[rot]).max()
    after = np.abs(dyn.damping_force(q, dyn.consistent_director_rates(q, v))[rot]).max()
    assert after < 1e-10 * before
    v_rigid = dyn.rigid_velocity(q, [1.0, 2.0, 3.0])
    assert np.allclose(dyn.consistent_director_rates(q, v_rigid), v_rigid, rtol=0, atol=1e-9 * np.abs(v_rigid).max())


def test_spinning_plate_keeps_its_angular_momentum_under_stiffness_damping():
    """a1 > 0 damps the kicked vibration but not the spin: the angular momentum is conserved (drift < 1e-6)
    and the energy balance holds; a0 > 0 damps the rigid spin itself (L decays like exp(-a0 t))."""
    dyn, run, kick_energy = kicked_spin(RayleighDamping(0.0, 1e-3))
    recs = [run.initial, *run.records]
    L = np.array([r.angular_momentum for r in recs])
    assert np.linalg.norm(L - L[0], axis=1).max() < 1e-6 * np.linalg.norm(L[0])
    assert run.dissipated_energy > 0.01 * kick_energy            # it damped the vibration (measured 3.8 %)
    balance = np.array([r.energy_balance for r in recs])
    assert np.abs(balance - balance[0]).max() < 2e-6 * balance[0]

    a0 = 0.5
    dyn, run, _ = kicked_spin(RayleighDamping(a0, 0.0))
    L0, L1 = run.initial.angular_momentum, run.records[-1].angular_momentum
    assert L1[2] / L0[2] == pytest.approx(np.exp(-a0 * run.result.time), rel=1e-3)


# -- scenes: TOML [analysis.damping], the energy balance of a run, bad input ----------------------------------
CANTILEVER = """
name = "damped_cantilever"
[mesh]
generator = "strip"
length = 1.0
width = 0.1
nx = 4
ny = 1
[material]
young = 1e7
poisson = 0.3
thickness = 0.01
density = 1000.0
[[bc]]
type = "fix"
set = "clamped"
[analysis]
type = "dynamic"
dt = 0.01
end_time = 1.0
gravity = [0.0, 0.0, -9.81]
[analysis.damping]
ratio = 0.1
frequencies_hz = [1.0, 20.0]
[[output]]
name = "w_tip"
near = [1.0, 0.05, 0.0]
component = "z"
"""


def write_scene(tmp_path, text: str):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def test_a_damped_toml_run_keeps_its_energy_balance_and_is_trusted(tmp_path, capsys):
    """A cantilever dropped under gravity with 10 % damping: T + W + V_g falls by D, the balance T + W + V_g + D
    holds, and the run is not flagged as an energy drift (exit code 0; before: exit 3)."""
    import json

    from flexbody.cli import main
    from flexbody.scenes import load_toml_scene, run_scene
    path = write_scene(tmp_path, CANTILEVER)
    scene = load_toml_scene(path)
    assert scene.analysis.damping == RayleighDamping.from_ratio(0.1, (1.0, 20.0))
    s = run_scene(scene)
    e = s.energy_summary()
    assert e["dissipated"]["final"] > 0.1 * abs(e["gravity"]["final"])
    assert e["total"]["max_rel_drift"] < 2e-3 and s.warnings == []
    out = tmp_path / "run.json"
    assert main(["run", str(path), "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())
    assert d["warnings"] == [] and d["energy"]["conservative"]
    assert d["energy_history"]["dissipated"][-1] == pytest.approx(e["dissipated"]["final"])
    direct = write_scene(tmp_path, CANTILEVER.replace("ratio = 0.1\nfrequencies_hz = [1.0, 20.0]",
                                                      "alpha_mass = 0.5\nbeta_stiffness = 1e-3"))
    assert load_toml_scene(direct).analysis.damping == RayleighDamping(0.5, 1e-3)


@pytest.mark.parametrize("edit, message", [
    ("ratio = -0.1\nfrequencies_hz = [1.0, 20.0]", "analysis.damping.ratio must be >= 0, got -0.1"),
    ("ratio = 0.1\nfrequencies_hz = [20.0, 1.0]", "analysis.damping.frequencies_hz must be one frequency or two"),
    ("ratio = 0.1\nfrequencies_hz = [0.0, 1.0]", "analysis.damping.frequencies_hz must be one frequency or two"),
    ("ratio = 0.1", "missing key analysis.damping.frequencies_hz"),
    ("alpha_mass = -1.0", "analysis.damping.alpha_mass must be >= 0, got -1.0"),
    ("beta_stiffness = \"big\"", "analysis.damping.beta_stiffness must be a finite number, got 'big'"),
    ("alpha_mass = 1.0\nratio = 0.1", "analysis.damping.ratio cannot be combined with analysis.damping.alpha_mass"),
    ("zeta = 0.1", "unknown key 'analysis.damping.zeta'"),
    ("", "[analysis.damping] needs alpha_mass and/or beta_stiffness, or ratio with frequencies_hz"),
])
def test_bad_damping_toml_is_one_line(tmp_path, edit, message):
    from flexbody.scenes import load_toml_scene
    from flexbody.scenes.sources import SceneError
    text = CANTILEVER.replace("ratio = 0.1\nfrequencies_hz = [1.0, 20.0]", edit)
    with pytest.raises(SceneError) as exc:
        load_toml_scene(write_scene(tmp_path, text))
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_bad_damping_in_the_python_api():
    from flexbody.scenes.scene import DynamicAnalysis
    with pytest.raises(ValueError, match="damping must be a RayleighDamping or None, got float"):
        DynamicAnalysis(0.01, 0.1, damping=0.05)
    mesh = generators.strip(1.0, 0.1, 2, 1)
    body = ShellBody(mesh, ShellMaterial(1e7, 0.3, 0.01, density=1000.0), element=MITC7())
    with pytest.raises(ValueError, match="beta_stiffness > 0.*mitc7"):
        DynamicModel(Model(body, []), damping=RayleighDamping(0.0, 1e-3))
    DynamicModel(Model(body, []), damping=RayleighDamping(0.1, 0.0))      # mass-proportional: any element
