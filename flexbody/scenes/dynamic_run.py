"""Running a dynamic scene: generalized-alpha time integration with outputs, energies and momenta per step.

Imported only when a scene with a :class:`flexbody.scenes.analysis.DynamicAnalysis` runs (it builds the mass:
:class:`flexbody.dynamics.DynamicModel`); :func:`flexbody.scenes.runner.run_scene` drives its
:class:`DynamicRun`.
The summary (:class:`flexbody.scenes.summary.DynamicRunSummary`) carries the energy and momentum balance and
the checks of a completed run.

The errors against a reference are taken at the reference's times (linear interpolation between the
recorded steps, marked as such; :func:`flexbody.scenes.compare.compare_in_time`).

The velocity fields and motions that used to live here (``rigid_field``, ``modal_velocity_field``,
``hub_spin_up``, ...) are in :mod:`flexbody.scenes.motions`, the summary and its limits (``MAX_*``) in
:mod:`flexbody.scenes.summary`; both are still importable from here.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from flexbody.scenes.analysis import DynamicAnalysis, RestartPoint
from flexbody.scenes.compare import compare_in_time
from flexbody.scenes.motions import (RADIAL_SHAPES, hub_spin_up, modal_velocity_field, nodal_fields,
                                     polar_coordinates, radial_shape, rigid_field, spin_up_angle)
from flexbody.scenes.summary import (ENERGY_KEYS, MAX_ENERGY_DRIFT, MAX_MOMENTUM_DRIFT,
                                     MAX_ROTATION_PER_STEP, RESOLVED_MOTION, DynamicRunSummary)

if TYPE_CHECKING:
    from flexbody.scenes.scene import Scene

__all__ = ["DynamicRun", "initial_conditions", "initial_velocity", "rotation_rate",
           # kept under this import path (they live in flexbody.scenes.motions and flexbody.scenes.summary)
           "RADIAL_SHAPES", "hub_spin_up", "modal_velocity_field", "nodal_fields", "polar_coordinates", "radial_shape",
           "rigid_field", "spin_up_angle", "compare_in_time", "DynamicRunSummary", "ENERGY_KEYS", "MAX_ENERGY_DRIFT",
           "MAX_MOMENTUM_DRIFT", "MAX_ROTATION_PER_STEP", "RESOLVED_MOTION"]


def _nodal_array(value, n: int, what: str) -> np.ndarray:
    if value is None:
        return np.zeros((n, 3))
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n, 3) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} must be a finite array of shape ({n}, 3), got shape {arr.shape}")
    return arr


def initial_velocity(dyn, state, analysis: DynamicAnalysis) -> np.ndarray:
    """The free-DoF velocity at t = 0 from the analysis' nodal initial velocities."""
    n = state.x.shape[0]
    xdot = _nodal_array(analysis.initial_velocity, n, "initial_velocity")
    omega = _nodal_array(analysis.initial_angular_velocity, n, "initial_angular_velocity")
    return dyn.velocity_from_nodal(state, xdot, omega)


def initial_conditions(dyn, analysis: DynamicAnalysis):
    """The state and free-DoF velocity at t = 0, and the steady spin (:class:`flexbody.spinning.SteadySpin`) it
    starts on (None for another start).

    ``analysis.initial_state`` None: the reference configuration; a state: that one; a
    :class:`flexbody.spinning.SteadySpinStart`: the steady spin (:func:`flexbody.spinning.steady_spin`) with its
    rigid velocity, to which the analysis' nodal initial velocities are added (a kick on the steady spin).
    """
    from flexbody.spinning import SteadySpinStart, steady_spin
    start = analysis.initial_state
    if isinstance(start, SteadySpinStart):
        spin = steady_spin(dyn, start.angular_velocity, start.center)
        state = dyn.prescribe(spin.state, 0.0)
        return state, spin.velocity + initial_velocity(dyn, state, analysis), spin
    state = dyn.prescribe(dyn.model.initial_state() if start is None else start, 0.0)
    return state, initial_velocity(dyn, state, analysis), None


def _is_conservative(scene: Scene) -> bool:
    """No loads (their potential is not in T + W + V_g) and no prescribed motion (it does work)."""
    return not (scene.model.loads or scene.analysis.prescribed)


def _is_isolated(scene: Scene) -> bool:
    """Conservative, free (no constraints) and without gravity: the momenta are conserved."""
    model, a = scene.model, scene.analysis
    constrained = bool(np.any(model.fixed[:, :5]) or np.any(model.has_basis))
    return _is_conservative(scene) and not (constrained or np.any(np.asarray(a.gravity, float) != 0))


def rotation_rate(dyn, state, velocity: np.ndarray) -> float:
    """The fastest rotation in the body (rad/s): the larger of its fitted rigid spin
    (:meth:`flexbody.dynamics.DynamicModel.rigid_angular_velocity`, which sees a spin about the directors,
    a DoF the nodes do not have) and the fastest nodal (director) angular velocity."""
    _, omega = nodal_fields(dyn, state, velocity)
    nodal = float(np.linalg.norm(omega, axis=1).max(initial=0.0))
    try:
        rigid = float(np.linalg.norm(dyn.rigid_angular_velocity(state, velocity)))
    except np.linalg.LinAlgError:          # all nodes on a line: no fit about that line
        rigid = 0.0
    return max(nodal, rigid)


def _output_value(out, model, dyn, state, velocity: np.ndarray) -> float:
    if getattr(out, "uses_velocity", False):
        return out.motion_value(dyn, state, velocity)
    return out.value(model, state)


def _steps_taken(result, a: DynamicAnalysis) -> int:
    """The number of time steps behind ``result.time`` (the fixed steps end on a grid; adaptive: counted)."""
    if result.adaptive:
        return int(result.steps)
    return int(round(result.time / (a.end_time / a.n_steps)))


class DynamicRun:
    """A dynamic scene's run (the dynamic half of :func:`flexbody.scenes.runner.run_scene`): generalized-alpha
    time integration recording the outputs, energies and momenta.

    Made before the clock of the solve starts (it builds the mass, :class:`flexbody.dynamics.DynamicModel`, and
    the initial conditions: set-up time). ``on_step(record, state, history)`` is called for the initial state
    (record step 0, time 0) and for every recorded step; ``progress(record)`` for every recorded step;
    ``restart`` (:class:`flexbody.scenes.analysis.RestartPoint`) continues a saved run from its step (the
    history then starts there). A run that stops early (a step that does not converge) also records its last
    converged state when that is not an output step (``output_every`` > 1): the files, the history and the
    summary then all end at that instant.
    """

    def __init__(self, scene: Scene, on_step: Callable | None = None, progress: Callable | None = None,
                 restart: RestartPoint | None = None) -> None:
        from flexbody.dynamics import DynamicModel

        a = scene.analysis
        self.scene, self.analysis, self.restart = scene, a, restart
        self.on_step, self.progress = on_step, progress
        self.threads = a.threads
        self.dyn = DynamicModel(scene.model, gravity=a.gravity, load_factor=a.load_factor,
                                prescribed=list(a.prescribed), point_masses=list(a.point_masses), damping=a.damping,
                                mass=a.mass)
        self.state, self.v0, spin = initial_conditions(self.dyn, a)
        from flexbody.turning_frame import turning_frame_model
        self.turning = turning_frame_model(self.dyn, a.frame, spin, (0.0, a.end_time / a.n_steps, a.end_time))
        self.history: dict[str, list[float]] = {"time": [], **{o.name: [] for o in scene.outputs}}
        self.energies: dict[str, list] = {k: [] for k in ("time", *ENERGY_KEYS, "linear_momentum",
                                                          "angular_momentum")}
        self.h = a.end_time / a.n_steps
        self.turn = (0.0, 0.0)                   # the largest rotation per step so far, and its time
        self.records: list = []                  # the step records after the start

    def record(self, rec, q, v, initial: bool = False) -> None:
        """Record a step: the nodal velocity fields for the output files, outputs, energies, momenta."""
        dyn, history, energies = self.dyn, self.history, self.energies
        if rec.motion is not None:               # nodal velocities and accelerations, for the output files
            rec.motion["velocity"], rec.motion["angular_velocity"] = nodal_fields(dyn, q, rec.motion["v"])
            rec.motion["acceleration"], rec.motion["angular_acceleration"] = nodal_fields(dyn, q, rec.motion["vdot"])
        history["time"].append(rec.time)
        rate = rotation_rate(dyn, q, v) * (rec.h or self.h)      # the step that led here (adaptive: varies)
        if rate > self.turn[0]:
            self.turn = (rate, float(rec.time))
        for out in self.scene.outputs:
            history[out.name].append(_output_value(out, self.scene.model, dyn, q, v))
        energies["time"].append(rec.time)
        for key, value in (("kinetic", rec.kinetic_energy), ("strain", rec.strain_energy),
                           ("gravity", rec.potential_energy), ("total", rec.total_energy),
                           ("dissipated", rec.dissipated_energy)):
            energies[key].append(float(value))
        energies["linear_momentum"].append(np.asarray(rec.linear_momentum, float).tolist())
        energies["angular_momentum"].append(np.asarray(rec.angular_momentum, float).tolist())
        if self.on_step is not None:
            self.on_step(rec, q, history)
        if self.progress is not None and not initial:
            self.progress(rec)

    def solve(self, t0: float):
        """Integrate from t = 0 (or the restart step) to the end time; ``t0``: when the solve's clock started.
        Returns the :class:`integrators.generalized_alpha.DynamicResult`; the energies and momenta are
        accounted for by an :class:`flexbody.energy.EnergyAccount` observing the integrator."""
        from flexbody.energy import EnergyAccount
        from flexbody.turning_frame import InertialObservers
        from integrators.generalized_alpha import generalized_alpha

        dyn, a, restart, state, v0 = self.dyn, self.analysis, self.restart, self.state, self.v0
        if restart is None:
            account = EnergyAccount(dyn, self._record_step)
            vdot0 = dyn.initial_acceleration(state, 0.0, v0)
            first = account.state_record(0, 0.0, state, v0)
            first.motion = {"v": v0, "vdot": vdot0, "a": vdot0}
            self.record(first, state, v0, initial=True)
            options = dict(t_start=0.0)
            h = a.time_step
        else:                                  # continue a saved run (flexbody.outputs.restart)
            h = self.h
            if not 0 <= restart.step < a.n_steps:
                raise ValueError(f"restart step {restart.step} is not before the last step {a.n_steps}")
            state, v0 = restart.state, restart.v
            account = EnergyAccount(dyn, self._record_step, restart.dissipated_energy)
            first = account.state_record(restart.step, restart.step * h, state, v0)
            first.motion = {"v": v0, "vdot": restart.vdot, "a": restart.a}
            self.record(first, state, v0, initial=True)
            options = dict(t_start=restart.step * h, acceleration=restart.vdot, pseudo_acceleration=restart.a,
                           first_step=restart.step)
        problem, observer = dyn, account
        if self.turning is not None:           # solved in the turning frame, observed in the inertial one
            problem, observer = self.turning, InertialObservers(self.turning, (account,))
            if restart is None:
                v0 = self.turning.relative_velocity(state, v0)
            else:
                state, v0, (vdot, pseudo) = self.turning.turning_motion(state, v0, (restart.vdot, restart.a),
                                                                        options["t_start"])
                options.update(acceleration=vdot, pseudo_acceleration=pseudo)
        try:
            result = generalized_alpha(problem, a.end_time, h, state=state, velocity=v0, settings=a.alpha_settings(),
                                       observers=(observer,), record_every=a.output_every, **options)
        except KeyboardInterrupt:              # Ctrl-C / a stop request: record the last converged step, then stop
            if isinstance(observer, InertialObservers):
                observer.flush()               # the account has not seen the steps since the last output
            account.interrupted()
            raise
        if self.turning is not None:
            q, v, (vdot, pseudo) = self.turning.inertial_motion(result.state, result.velocity,
                                                                (result.acceleration, result.pseudo_acceleration),
                                                                result.time)
            result = replace(result, state=q, velocity=v, acceleration=vdot, pseudo_acceleration=pseudo)
        if result.time > self.history["time"][-1]:  # stopped between two output steps: record where it stopped
            last = account.state_record(_steps_taken(result, a), result.time, result.state, result.velocity,
                                        time.perf_counter() - t0)
            last.motion = {"v": result.velocity, "vdot": result.acceleration, "a": result.pseudo_acceleration}
            self._record_step(last, result.state, result.velocity)
        return result

    def _record_step(self, rec, q, v) -> None:
        """Record a step after the start (an output step, or the last converged one of a stopped run)."""
        self.records.append(rec)
        self.record(rec, q, v)

    def summary(self, result, errors: list[dict], wall: float, setup: float, compile_time: float) -> DynamicRunSummary:
        scene, model = self.scene, self.scene.model
        size = float(np.linalg.norm(np.ptp(model.body.mesh.nodes, axis=0)))
        return DynamicRunSummary(scene.name, model.n_dof, model.body.mesh.n_elements, result, self.history, errors,
                                 wall, setup, compile_time, analysis=self.analysis, energies=self.energies,
                                 records=self.records,
                                 total_mass=self.dyn.inertia.total_mass, isolated=_is_isolated(scene),
                                 conservative=_is_conservative(scene), rotation_per_step=self.turn, size=size,
                                 frame="inertial" if self.turning is None else "turning")
