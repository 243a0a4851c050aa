"""The equations of motion in a frame turning with a steady spin (flexbody.turning_frame): tangent and Coriolis
matrix on the group, the maps between the frames, the steady spin at rest, agreement with the inertial run,
and what the frame refuses."""

import math
import textwrap
import tomllib

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel, PrescribedMotion
from flexbody.loads import NodalLoad
from flexbody.mesh import generators
from flexbody.scenes import run_scene
from flexbody.scenes.sources import SceneError
from flexbody.scenes.toml_scene import scene_from_document
from flexbody.shell.material import ShellMaterial
from flexbody.spinning import steady_spin
from flexbody.turning_frame import TurningFrame, TurningFrameModel, turning_frame_model

OMEGA = np.array([0.0, 0.0, 20.0])


def hub_motion(omega, center=np.zeros(3)):
    frame = TurningFrame(omega, center)
    return lambda t: (frame.rotation(t), center - frame.rotation(t) @ center)


def spinning_annulus(hub=True, omega=OMEGA, n_radial=1, n_circ=8, thickness=0.02, loads=(), gravity=(0, 0, 0)):
    mesh = generators.annulus(0.2, 1.0, n_radial, n_circ)
    body = ShellBody(mesh, ShellMaterial(1e7, 0.3, thickness, density=1000.0))
    cons = [Fix(mesh.node_set("inner"), "all")] if hub else []
    prescribed = [PrescribedMotion(mesh.node_set("inner"), hub_motion(omega))] if hub else []
    return DynamicModel(Model(body, cons, list(loads)), gravity=gravity, prescribed=prescribed)


def deformed(problem, state, rng, scale=0.02):
    for _ in range(2):
        state = problem.update(state, scale * rng.normal(size=problem.n_dof))
    return state


@pytest.mark.parametrize("axis", [(0.0, 0.0, 20.0), (3.0, -2.0, 20.0)])
def test_tangent_and_coriolis_matrix_against_finite_differences(axis):
    """dr/dq along the group increments and dr/dv, at a deformed state with a random relative velocity (a tilted
    axis too: director spin moments, a full centrifugal block and Coriolis forces on the directors)."""
    rng = np.random.default_rng(7)
    omega = np.array(axis)
    dyn = spinning_annulus(hub=False, omega=omega, thickness=0.05)
    tm = TurningFrameModel(dyn, TurningFrame(omega, [0.05, -0.02, 0.0]))
    state = deformed(tm, dyn.model.initial_state(), rng)
    v, vdot = rng.normal(size=tm.n_dof), rng.normal(size=tm.n_dof)
    r, K = tm.residual_and_tangent(state, v, vdot, 0.1)
    assert np.allclose(r, tm.residual(state, v, vdot, 0.1), rtol=0, atol=1e-12 * np.abs(r).max())
    K = K.toarray()
    eps = 1e-6
    Kfd = np.column_stack([(tm.residual(tm.update(state, eps * e), v, vdot, 0.1)
                            - tm.residual(tm.update(state, -eps * e), v, vdot, 0.1)) / (2 * eps)
                           for e in np.eye(tm.n_dof)])
    assert np.abs(K - Kfd).max() < 1e-6 * np.abs(K).max()
    # the residual is linear in v: its derivative is the damping matrix (Coriolis), exactly, and skew
    C = tm.damping_matrix(state).toarray()
    Cfd = np.column_stack([tm.residual(state, v + e, vdot, 0.1) - tm.residual(state, v, vdot, 0.1)
                           for e in np.eye(tm.n_dof)])
    assert np.abs(C - Cfd).max() < 1e-9 * np.abs(C).max()
    assert np.abs(C + C.T).max() < 1e-12 * np.abs(C).max()
    rot = ~dyn.is_translation
    assert np.abs(C[np.ix_(rot, rot)]).max() > 0                 # the directors' Coriolis terms are there


def test_coriolis_of_the_translations_is_twice_the_mass_times_omega():
    dyn = spinning_annulus(hub=True, n_circ=8)
    tm = TurningFrameModel(dyn, TurningFrame(OMEGA, np.zeros(3)))
    state = dyn.model.initial_state()
    v = np.zeros(tm.n_dof)
    tr = np.flatnonzero(dyn.is_translation & (dyn.comp == 0))
    v[tr[3]] = 1.0                                               # a node moving along x at 1 m/s
    f = tm.coriolis_force(state, v)
    node = dyn.node[tr[3]]
    iy = np.flatnonzero((dyn.node == node) & (dyn.comp == 1))[0]
    m = dyn.mass_matrix().diagonal()[tr[3]]
    assert f[iy] == pytest.approx(2.0 * m * 20.0, rel=1e-12)     # 2 m Omega x v: along +y


def test_the_maps_between_the_frames_invert_each_other():
    rng = np.random.default_rng(2)
    omega = np.array([1.0, 2.0, 20.0])
    dyn = spinning_annulus(hub=False, omega=omega)
    tm = TurningFrameModel(dyn, TurningFrame(omega, [0.1, 0.0, 0.3]))
    state = deformed(tm, dyn.model.initial_state(), rng, 0.1)
    v, acc = rng.normal(size=tm.n_dof), rng.normal(size=tm.n_dof)
    for t in (0.0, 0.37, 2.9):
        q_in, v_in, (a_in,) = tm.inertial_motion(state, v, (acc,), t)
        back, v_back, (a_back,) = tm.turning_motion(q_in, v_in, (a_in,), t)
        assert np.abs(back.x - state.x).max() < 1e-12 * np.abs(state.x).max()
        assert np.abs(back.frames - state.frames).max() < 1e-12
        assert np.abs(v_back - v).max() < 1e-10 * np.abs(v).max()
        assert np.abs(a_back - acc).max() < 1e-10 * np.abs(acc).max()
    # at t = 0 the frames coincide: the inertial velocity is the relative one plus the rigid one
    q0, v0, _ = tm.inertial_motion(state, v, (), 0.0)
    assert np.allclose(tm.relative_velocity(q0, v0), v, rtol=0, atol=1e-10)
    rot = TurningFrame(omega, np.zeros(3)).rotation(0.3)
    assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-15) and np.allclose(rot @ omega, omega)
    # at rest in the frame, every node's inertial acceleration is the centripetal Omega x (Omega x (x - c))
    q1, _, (a1,) = tm.inertial_motion(state, np.zeros(tm.n_dof), (np.zeros(tm.n_dof),), 0.0)
    xddot = dyn.nodal_velocities(q1, a1)[0]
    centripetal = np.cross(omega, np.cross(omega, q1.x - tm.frame.center))
    moving = np.flatnonzero(np.abs(centripetal).max(axis=1) > 0)
    assert np.abs(xddot[moving] - centripetal[moving]).max() < 1e-12 * np.abs(centripetal).max()


ANNULUS = """
name = "annulus"
[mesh]
generator = "annulus"
inner_radius = 0.2
outer_radius = 1.0
n_radial = 2
n_circ = 16
[material]
young = 1e9
poisson = 0.3
thickness = 1e-3
density = 1000.0
[analysis]
type = "dynamic"
dt = {dt}
end_time = {end}
{extra}
[analysis.initial]
state = "steady_spin"
angular_velocity = [0.0, 0.0, 20.0]
center = [0.0, 0.0, 0.0]
[[analysis.initial.velocity_field]]
direction = [0.0, 0.0, 1.0]
amplitude = {kick}
radial = "linear"
modes = [0, 1, 2]
[analysis.hub]
radius = 0.2
angular_velocity = [0.0, 0.0, 20.0]
[[output]]
name = "w_rim"
near = [1.0, 0.0, 0.0]
component = "z"
[[output]]
name = "x_rim"
near = [1.0, 0.0, 0.0]
component = "x"
[[output]]
name = "y_rim"
near = [1.0, 0.0, 0.0]
component = "y"
"""

PERIOD = 2 * math.pi / 20.0


def annulus_scene(dt, end, extra="", kick=0.05):
    text = ANNULUS.format(dt=dt, end=end, extra=extra, kick=kick)
    return scene_from_document(tomllib.loads(textwrap.dedent(text)), "test_turning_frame")


def test_a_steady_spin_is_at_rest_in_the_turning_frame():
    """Without a kick the run stays on the steady spin to round-off (in the inertial frame the generalized-alpha
    carries the phase error of the rigid turn): the rim node is where the turn puts it, the energy is constant."""
    summary = run_scene(annulus_scene(PERIOD / 50, PERIOD / 5, kick=0.0))
    assert summary.frame == "turning" and summary.as_dict()["frame_default"]
    # the rim node at (1, 0, 0): its place (1 + u_x, u_y) turns rigidly
    z = 1.0 + np.asarray(summary.history["x_rim"]) + 1j * np.asarray(summary.history["y_rim"])
    t = np.asarray(summary.history["time"])
    assert np.abs(z - z[0] * np.exp(20j * t)).max() < 1e-10 * abs(z[0])
    E = np.asarray(summary.energies["kinetic"]) + np.asarray(summary.energies["strain"])
    assert np.ptp(E) < 1e-12 * E.max()
    assert summary.result.stats.factorizations == 1


def test_the_turning_and_inertial_runs_converge_to_the_same_motion():
    """A kicked annulus for a fifth of a revolution in both frames at dt and dt/2: the rim deflections differ by
    the time integrator's error (second order), not by a model difference."""
    diffs = []
    for n in (50, 100):
        w = {}
        for frame in ("turning", "inertial"):
            s = run_scene(annulus_scene(PERIOD / n, PERIOD / 5, f'frame = "{frame}"'))
            assert s.result.converged and s.frame == frame
            w[frame] = np.asarray(s.history["w_rim"])
        scale = np.abs(w["inertial"]).max()
        assert scale > 1e-4
        diffs.append(np.abs(w["turning"] - w["inertial"]).max() / scale)
    assert diffs[1] < 0.4 * diffs[0]
    assert diffs[1] < 5e-3


def test_the_frame_is_chosen_and_refused_with_the_reason(tmp_path):
    # a start from rest keeps the inertial frame; asking for the turning one there is refused
    still = annulus_scene(PERIOD / 50, PERIOD / 50, kick=0.0)
    dyn = spinning_annulus()
    assert turning_frame_model(dyn, None, None, (0.0,)) is None
    with pytest.raises(ValueError, match="steady spin"):
        turning_frame_model(dyn, "turning", None, (0.0,))
    with pytest.raises(ValueError, match="frame must be"):
        turning_frame_model(dyn, "rotating", None, (0.0,))
    assert run_scene(still).frame == "turning"
    # gravity across the spin axis would turn in that frame: the default falls back, an explicit choice fails
    across = annulus_scene(PERIOD / 50, PERIOD / 50, "gravity = [0.0, -9.81, 0.0]", kick=0.0)
    assert run_scene(across).frame == "inertial"
    with pytest.raises(ValueError, match="gravity"):
        run_scene(annulus_scene(PERIOD / 50, PERIOD / 50, 'gravity = [0.0, -9.81, 0.0]\nframe = "turning"', 0.0))
    # a dead load across the axis too; one along it is fine
    spin = steady_spin(dyn, OMEGA, np.zeros(3))
    rim = dyn.model.body.mesh.nearest_node([1.0, 0.0, 0.0])
    across_load = spinning_annulus(loads=[NodalLoad([rim], force=[1.0, 0.0, 0.0])])
    with pytest.raises(ValueError, match="dead nodal force"):
        turning_frame_model(across_load, "turning", spin, (0.0,))
    along = spinning_annulus(loads=[NodalLoad([rim], force=[0.0, 0.0, 1.0]),
                                    NodalLoad([rim], [1.0, 0, 0], follower=True)])
    assert turning_frame_model(along, "turning", spin, (0.0,)) is not None
    # a hub at another rate cannot be held in the frame
    other = spinning_annulus(omega=np.array([0.0, 0.0, 19.0]))
    with pytest.raises(ValueError, match="prescribed motion 0 does not turn with the frame"):
        TurningFrameModel(other, TurningFrame(OMEGA, np.zeros(3)), times=(0.0, 0.1))
    with pytest.raises(ValueError, match="angular velocity is zero"):
        TurningFrame(np.zeros(3), np.zeros(3))
    # mass-proportional damping brakes the spin itself: the default is the inertial frame, "turning" is refused;
    # stiffness-proportional damping acts on strain rates only and keeps the turning frame
    damped = '[analysis.damping]\nalpha_mass = 0.5'
    assert run_scene(annulus_scene(PERIOD / 50, PERIOD / 50, damped, kick=0.0)).frame == "inertial"
    with pytest.raises(ValueError, match="mass-proportional damping"):
        run_scene(annulus_scene(PERIOD / 50, PERIOD / 50, 'frame = "turning"\n' + damped, kick=0.0))
    stiff = '[analysis.damping]\nbeta_stiffness = 1e-5'
    assert run_scene(annulus_scene(PERIOD / 50, PERIOD / 50, stiff, kick=0.0)).frame == "turning"
    # the TOML key names its values
    with pytest.raises(SceneError, match="frame.*'rotating'"):
        annulus_scene(PERIOD / 50, PERIOD / 50, 'frame = "rotating"')


def test_gauge_free_body_runs_in_the_turning_frame_and_conserves_energy():
    """A free annulus (no hub) kicked on its steady spin: the turning frame conserves the energy and angular
    momentum the inertial run drifts on (the inertial run's phase error of the rigid turn)."""
    text = ANNULUS.format(dt=PERIOD / 50, end=PERIOD / 2, extra="", kick=0.05)
    text = text[:text.index("[analysis.hub]")] + text[text.index("[[output]]"):]
    drift = {}
    for frame in ("turning", "inertial"):
        doc = tomllib.loads(textwrap.dedent(text).replace('type = "dynamic"', f'type = "dynamic"\nframe = "{frame}"'))
        s = run_scene(scene_from_document(doc, "free"))
        assert s.result.converged
        e = s.energies
        E = np.asarray(e["kinetic"]) + np.asarray(e["strain"])
        drift[frame] = np.ptp(E) / E.max()
    assert drift["turning"] < 1e-6
    assert drift["turning"] < 0.1 * drift["inertial"]


class _Stop:
    """An observer that wants every step and raises KeyboardInterrupt (Ctrl-C) when it sees step ``at``."""

    def __init__(self, at: int):
        self.at, self.seen = at, []

    def __call__(self, step):
        self.seen.append(step)
        if step.index == self.at:
            raise KeyboardInterrupt


@pytest.mark.parametrize("damped", [False, True])
def test_steps_between_outputs_are_mapped_only_for_observers_that_want_them(damped):
    """An undamped body's energy account sees the start, the output steps and, after a stop, the last accepted
    step; an observer without ``every_step`` and a damped body's account see every step. Each sees the same
    inertial motion of a step."""
    from flexbody.dynamics import RayleighDamping
    from flexbody.energy import EnergyAccount
    from flexbody.turning_frame import InertialObservers
    from integrators.generalized_alpha import generalized_alpha

    dyn = spinning_annulus(n_circ=8)
    if damped:
        dyn = DynamicModel(dyn.model, prescribed=dyn.prescribed, damping=RayleighDamping(0.0, 1e-4))
    spin = steady_spin(dyn, OMEGA, np.zeros(3))
    tm = turning_frame_model(dyn, "turning", spin, (0.0,))
    seen, handed = [], []

    class Account(EnergyAccount):
        def __call__(self, step):
            seen.append(step)
            super().__call__(step)

    account = Account(dyn, lambda rec, q, v: handed.append((rec, v)))
    assert account.every_step is damped
    stop = _Stop(at=7)
    observers = InertialObservers(tm, (account, stop))
    v0 = tm.relative_velocity(spin.state, spin.velocity + 0.01 * np.random.default_rng(3).normal(size=dyn.n_dof))
    with pytest.raises(KeyboardInterrupt):
        generalized_alpha(tm, 12 * PERIOD / 50, PERIOD / 50, state=spin.state, velocity=v0, observers=(observers,),
                          record_every=5)
    assert [s.index for s in stop.seen] == list(range(8))
    expected = list(range(8)) if damped else [0, 5]
    assert [s.index for s in seen] == expected
    observers.flush()                          # what the scene run does on a stop, before account.interrupted()
    account.interrupted()
    assert [s.index for s in seen] == (list(range(8)) if damped else [0, 5, 7])
    assert [rec.step for rec, _ in handed] == [5, 7]
    for a in seen:                             # the same inertial motion as handed to the every-step observer
        b = stop.seen[a.index]
        assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.velocity, b.velocity)
        assert np.array_equal(a.acceleration, b.acceleration)
    assert np.array_equal(handed[-1][1], stop.seen[7].velocity)
    observers.flush()                          # nothing left to hand over
    assert len(seen) == (8 if damped else 3)
