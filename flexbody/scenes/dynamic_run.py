"""Running a dynamic scene: generalized-alpha time integration with outputs, energies and momenta per step.

Imported only when a scene with a :class:`flexbody.scenes.scene.DynamicAnalysis` runs (it builds the mass:
:class:`flexbody.dynamics.DynamicModel`). The summary (:class:`DynamicRunSummary`) carries what a static run
reports (steps, Newton iterations, tangent updates, factorizations, wall time, outputs, errors against the
reference) and, for a dynamic run, the energy and momentum balance:

* energy: kinetic T, strain W and gravity V_g energy at the start and the end, and the largest drift of
  the total, max_t |E(t) - E(0)| / max_t (T + W + |V_g|);
* momenta (about the origin): linear p and angular L at the start and the end and their largest drifts,
  max_t |p(t) - p(0)| / max(|p(0)|, sqrt(2 M max_t T)) and max_t |L(t) - L(0)| / max_t |L(t)|.
  The momenta are conserved only by an isolated body (``momentum.isolated``: no constraints, loads,
  gravity or prescribed motion), the energy T + W + V_g by a conservative one (``energy.conservative``:
  no loads and no prescribed motion; fixed supports and gravity are allowed); otherwise the drifts
  measure the exchange with the surroundings.

The errors against a reference are taken at the reference's times (linear interpolation between the
recorded steps): |value - reference| / max|reference of that quantity|.
"""

from __future__ import annotations

from dataclasses import dataclass
import time
from typing import Callable

import numpy as np

from flexbody.scenes.scene import DynamicAnalysis, Reference, Scene, kernel_threads

ENERGY_KEYS = ("kinetic", "strain", "gravity", "total")


def rigid_field(positions: np.ndarray, angular_velocity, center=None,
                velocity=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Nodal velocities (n, 3) and angular velocities (n, 3) of the rigid motion v0 + omega x (x - c).

    Parameters
    ----------
    positions : nodal positions x (n, 3)
    angular_velocity : omega (3,), global components
    center : c (3,), default the origin
    velocity : v0 (3,), the velocity of the point c
    """
    x = np.asarray(positions, dtype=float)
    w = np.asarray(angular_velocity, dtype=float)
    c = np.zeros(3) if center is None else np.asarray(center, dtype=float)
    xdot = np.asarray(velocity, dtype=float) + np.cross(w, x - c)
    return xdot, np.tile(w, (len(x), 1))


def spin_up_angle(rate: float, ramp: float) -> Callable[[float], float]:
    """The angle of a smooth spin-up: omega(t) = rate (1 - cos(pi t / ramp)) / 2 for t < ramp, then rate.

    The angular acceleration is continuous and vanishes at both ends of the ramp (ramp = 0: rate from t = 0).
    """
    def angle(t: float) -> float:
        if 0 < ramp and t < ramp:
            return rate * (t / 2 - ramp / (2 * np.pi) * np.sin(np.pi * t / ramp))
        return rate * (ramp / 2 + t - ramp)
    return angle


def hub_spin_up(angular_velocity, ramp: float, center=(0.0, 0.0, 0.0)) -> Callable:
    """t -> (Q(t), d(t)) of a hub spun up about the axis through ``center`` to ``angular_velocity`` in ``ramp``.

    Q(t) = exp(angle(t) n) with n the axis of ``angular_velocity`` and angle from :func:`spin_up_angle`;
    d(t) = c - Q(t) c, so that the points of the axis stay put. For
    :class:`flexbody.dynamics.PrescribedMotion`.
    """
    from flexbody.lie import so3
    w = np.asarray(angular_velocity, dtype=float)
    c = np.asarray(center, dtype=float)
    rate = float(np.linalg.norm(w))
    axis = w / rate if rate > 0 else np.array([0.0, 0.0, 1.0])
    angle = spin_up_angle(rate, ramp)

    def motion(t: float):
        Q = so3.exp(angle(t) * axis)
        return Q, c - Q @ c
    return motion


def nodal_fields(dyn, state, velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodal velocities (n, 3) and global angular velocities (n, 3) of a free-DoF velocity.

    The inverse of :meth:`flexbody.dynamics.DynamicModel.velocity_from_nodal` (drilling components are zero).
    """
    xdot, w_local = dyn.nodal_velocities(state, velocity)
    return xdot, np.einsum("nij,nj->ni", state.frames, w_local)


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
    """The state and free-DoF velocity at t = 0.

    ``analysis.initial_state`` None: the reference configuration; a state: that one; a
    :class:`flexbody.spinning.SteadySpinStart`: the steady spin (:func:`flexbody.spinning.steady_spin`) with its
    rigid velocity, to which the analysis' nodal initial velocities are added (a kick on the steady spin).
    """
    from flexbody.spinning import SteadySpinStart, steady_spin
    start = analysis.initial_state
    if isinstance(start, SteadySpinStart):
        spin = steady_spin(dyn, start.angular_velocity, start.center)
        state = dyn.prescribe(spin.state, 0.0)
        return state, spin.velocity + initial_velocity(dyn, state, analysis)
    state = dyn.prescribe(dyn.model.initial_state() if start is None else start, 0.0)
    return state, initial_velocity(dyn, state, analysis)


def compare_in_time(history: dict[str, list[float]], reference: Reference) -> list[dict]:
    """Relative errors at every reference time inside the recorded interval (linear interpolation).

    The relative error is |value - reference| / max|reference| of that quantity over the table.
    """
    t = np.asarray(history["time"], dtype=float)
    errors = []
    if t.size == 0:
        return errors
    for name, ref_vals in reference.values.items():
        if name not in history:
            continue
        vals = np.asarray(history[name], dtype=float)
        scale = float(np.abs(ref_vals).max()) or 1.0
        for tr, rv in zip(reference.times, ref_vals):
            if tr < t[0] - 1e-12 or tr > t[-1] + 1e-12 * max(1.0, abs(t[-1])):
                continue
            v = float(np.interp(tr, t, vals))
            errors.append({"quantity": name, "time": float(tr), "value": v, "reference": float(rv),
                           "rel_error": abs(v - float(rv)) / scale})
    return errors


@dataclass
class DynamicRunSummary:
    """The outcome of a dynamic scene run.

    Attributes
    ----------
    history : ``time`` and every tracked output at t = 0 and every recorded step
    energies : ``time``, kinetic, strain, gravity and total energy, ``linear_momentum`` and
        ``angular_momentum`` (lists of 3-vectors) at the same instants
    isolated : the body is free, unloaded, without gravity and prescribed motion (its momenta are then
        conserved by the equations of motion)
    conservative : no loads and no prescribed motion (T + W + V_g is then conserved)
    """

    scene: str
    dofs: int
    elements: int
    result: object                          # integrators.generalized_alpha.DynamicResult
    analysis: DynamicAnalysis
    history: dict[str, list[float]]
    energies: dict[str, list]
    errors: list[dict]
    wall_time_s: float
    total_mass: float
    isolated: bool
    conservative: bool

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

    @property
    def steps(self) -> int:
        """Time steps taken (the last recorded one; all of them for a completed run)."""
        return self.result.records[-1].step if self.result.records else 0

    def energy_summary(self) -> dict:
        """Initial and final energies, and the largest drift of the total (module docstring)."""
        e = {k: np.asarray(self.energies[k], dtype=float) for k in ENERGY_KEYS}
        out: dict = {"conservative": self.conservative}
        out.update({k: {"initial": float(e[k][0]) + 0.0, "final": float(e[k][-1]) + 0.0} for k in ENERGY_KEYS})
        scale = float(np.max(e["kinetic"] + e["strain"] + np.abs(e["gravity"])))
        drift = np.abs(e["total"] - e["total"][0])
        out["total"]["max_drift"] = float(drift.max())
        out["total"]["max_rel_drift"] = float(drift.max() / scale) if scale > 0 else float("nan")
        out["strain"]["max"] = float(e["strain"].max())
        return out

    def momentum_summary(self) -> dict:
        """Initial and final linear and angular momenta (about the origin) and their largest drifts."""
        p = np.asarray(self.energies["linear_momentum"], dtype=float)
        L = np.asarray(self.energies["angular_momentum"], dtype=float)
        kinetic = np.asarray(self.energies["kinetic"], dtype=float)
        p_scale = max(float(np.linalg.norm(p[0])), float(np.sqrt(2.0 * self.total_mass * kinetic.max())))
        L_scale = float(np.linalg.norm(L, axis=1).max())
        out = {"isolated": self.isolated}
        for name, arr, scale in (("linear", p, p_scale), ("angular", L, L_scale)):
            drift = float(np.linalg.norm(arr - arr[0], axis=1).max())
            out[name] = {"initial": arr[0].tolist(), "final": arr[-1].tolist(), "max_drift": drift,
                         "max_rel_drift": drift / scale if scale > 0 else float("nan")}
        return out

    def as_dict(self) -> dict:
        st = self.result.stats
        a = self.analysis
        return {
            "scene": self.scene, "kind": "dynamic", "dofs": self.dofs, "elements": self.elements,
            "steps": self.steps, "newton_iterations": st.iterations, "tangent_updates": st.tangent_updates,
            "factorizations": st.factorizations, "wall_time_s": self.wall_time_s,
            "converged": self.result.converged, "message": self.result.message, "time": float(self.result.time),
            "end_time": a.end_time, "time_step": a.end_time / a.n_steps, "rho_inf": a.rho_inf, "policy": a.policy,
            "outputs": {k: v[-1] for k, v in self.history.items() if k != "time" and v},
            "errors": self.errors, "max_rel_error": self.max_rel_error,
            "energy": self.energy_summary(), "momentum": self.momentum_summary(),
            "energy_history": {k: list(map(float, self.energies[k])) for k in ("time", *ENERGY_KEYS)},
        }


def _is_conservative(scene: Scene) -> bool:
    """No loads (their potential is not in T + W + V_g) and no prescribed motion (it does work)."""
    return not (scene.model.loads or scene.analysis.prescribed)


def _is_isolated(scene: Scene) -> bool:
    """Conservative, free (no constraints) and without gravity: the momenta are conserved."""
    model, a = scene.model, scene.analysis
    constrained = bool(np.any(model.fixed[:, :5]) or np.any(model.has_basis))
    return _is_conservative(scene) and not (constrained or np.any(np.asarray(a.gravity, float) != 0))


def _output_value(out, model, dyn, state, velocity: np.ndarray) -> float:
    if getattr(out, "uses_velocity", False):
        return out.motion_value(dyn, state, velocity)
    return out.value(model, state)


def run_dynamic(scene: Scene, on_step: Callable | None = None, progress: Callable | None = None) -> DynamicRunSummary:
    """Integrate a dynamic scene; record outputs, energies and momenta; compare with the reference.

    ``on_step(record, state, history)`` is called for the initial state (record step 0, time 0) and for
    every recorded step; ``progress(record)`` for every recorded step.
    """
    from flexbody.dynamics import DynamicModel
    from integrators.generalized_alpha import DynamicStepRecord, generalized_alpha

    model, a = scene.model, scene.analysis
    dyn = DynamicModel(model, gravity=a.gravity, load_factor=a.load_factor, prescribed=list(a.prescribed))
    state, v0 = initial_conditions(dyn, a)
    history: dict[str, list[float]] = {"time": [], **{o.name: [] for o in scene.outputs}}
    energies: dict[str, list] = {k: [] for k in ("time", *ENERGY_KEYS, "linear_momentum", "angular_momentum")}

    def record(rec, q, v, initial: bool = False) -> None:
        history["time"].append(rec.time)
        for out in scene.outputs:
            history[out.name].append(_output_value(out, model, dyn, q, v))
        energies["time"].append(rec.time)
        for key, value in (("kinetic", rec.kinetic_energy), ("strain", rec.strain_energy),
                           ("gravity", rec.potential_energy), ("total", rec.total_energy)):
            energies[key].append(float(value))
        energies["linear_momentum"].append(np.asarray(rec.linear_momentum, float).tolist())
        energies["angular_momentum"].append(np.asarray(rec.angular_momentum, float).tolist())
        if on_step is not None:
            on_step(rec, q, history)
        if progress is not None and not initial:
            progress(rec)

    with kernel_threads(a.threads, model.body.mesh.n_elements):
        model.warm_up()  # numba compilation is not run time
        t0 = time.perf_counter()
        p, L = dyn.momenta(state, v0)
        first = DynamicStepRecord(0, 0.0, 0, [], [], 0, 1, dyn.kinetic_energy(v0), dyn.strain_energy(state),
                                  dyn.gravity_potential(state), p, L, 0.0)
        record(first, state, v0, initial=True)
        result = generalized_alpha(dyn, a.end_time, a.time_step, state=state, velocity=v0,
                                   settings=a.alpha_settings(), on_step=record, record_every=a.output_every)
        wall = time.perf_counter() - t0
    errors = compare_in_time(history, scene.reference) if scene.reference else []
    return DynamicRunSummary(scene.name, model.n_dof, model.body.mesh.n_elements, result, a, history, energies,
                             errors, wall, dyn.inertia.total_mass, _is_isolated(scene), _is_conservative(scene))
