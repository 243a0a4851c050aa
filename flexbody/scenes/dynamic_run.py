"""Running a dynamic scene: generalized-alpha time integration with outputs, energies and momenta per step.

Imported only when a scene with a :class:`flexbody.scenes.scene.DynamicAnalysis` runs (it builds the mass:
:class:`flexbody.dynamics.DynamicModel`). The summary (:class:`DynamicRunSummary`) carries what a static run
reports (steps, Newton iterations, tangent updates, factorizations, wall time, outputs, errors against the
reference) and, for a dynamic run, the energy and momentum balance:

* energy: kinetic T, strain W and gravity V_g energy at the start and the end, the work D dissipated by
  damping (:class:`flexbody.dynamics.RayleighDamping`), and the largest drift of the balance E = T + W +
  V_g + D, max_t |E(t) - E(0)| / max_t (T + W + |V_g|) (``total`` is T + W + V_g; a damped body's
  ``total`` decreases by D, its balance does not);
* momenta (about the origin): linear p and angular L at the start and the end and their largest drifts,
  max_t |p(t) - p(0)| / max(|p(0)|, sqrt(2 M max_t T)) and max_t |L(t) - L(0)| / max_t |L(t)|.
  The momenta are conserved only by an isolated body (``momentum.isolated``: no constraints, loads,
  gravity or prescribed motion), the energy T + W + V_g by a conservative one (``energy.conservative``:
  no loads and no prescribed motion; fixed supports and gravity are allowed); otherwise the drifts
  measure the exchange with the surroundings.

The errors against a reference are taken at the reference's times (linear interpolation between the
recorded steps, marked as such): |value - reference| / max|reference of that quantity|.

A completed run is checked for answers not to be trusted (:attr:`DynamicRunSummary.warnings`: the drift of
a conserved energy or momentum, the rotation per step; limits ``MAX_*`` below, docs/robustness.md), which
``flexbody run`` reports with exit code 3.
"""

from __future__ import annotations

from dataclasses import dataclass
import time
from typing import Callable

import numpy as np

from flexbody.scenes.scene import (CompileNotice, DynamicAnalysis, Reference, Scene, kernel_threads, timings,
                                   warm_up_kernels)

ENERGY_KEYS = ("kinetic", "strain", "gravity", "total", "dissipated")

#: Accuracy limits of a completed dynamic run (docs/robustness.md, "Dynamic runs not to be trusted"): a run
#: beyond one of them warns and ``flexbody run`` exits with 3. The rotation per step |omega| h (rad) of the
#: body's fitted rigid spin or of a node's director: the phase error of a spin, 0.31 (|omega| h)^2 of the
#: angle turned (measured on ``spinning_plate``), reaches 1 % there:
MAX_ROTATION_PER_STEP = 0.18
#: the largest relative energy drift of a conservative body (``energy.total.max_rel_drift``; the built-in
#: scenes reach 1.5e-3 at their default time steps):
MAX_ENERGY_DRIFT = 0.02
#: the largest relative drift of either momentum of an isolated body (``momentum.*.max_rel_drift``; the
#: built-in scenes reach 7e-4):
MAX_MOMENTUM_DRIFT = 0.01
#: a drift is checked only for a motion faster than this many times the round-off velocity eps L / h (L the
#: body's size): a body at rest has energies of 1e-28 J and drifts of 100 % of that
RESOLVED_MOTION = 1e3


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


RADIAL_SHAPES = ("uniform", "linear", "quadratic")


def _shown(value) -> str:
    """A value for an error message (arrays as lists)."""
    return repr(value.tolist() if isinstance(value, np.ndarray) else value)


def polar_coordinates(positions: np.ndarray, center=(0.0, 0.0, 0.0),
                      axis=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """Distance r from the axis through ``center`` and angle theta about it, of points (n, 3).

    theta is measured from the projection of global x on the plane normal to the axis (of global y when the
    axis is along x), positive about the axis: for the axis z, the usual polar angle.
    """
    n = np.asarray(axis, dtype=float)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.abs(n).max() > 0:
        raise ValueError(f"axis must be a finite nonzero 3-vector, got {_shown(axis)}")
    n = n / np.abs(n).max()
    n = n / np.linalg.norm(n)
    ref = np.eye(3)[0] if abs(n[0]) < 0.9 else np.eye(3)[1]
    e1 = ref - (ref @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    rel = np.asarray(positions, dtype=float) - np.asarray(center, dtype=float)
    a, b = rel @ e1, rel @ e2
    return np.hypot(a, b), np.arctan2(b, a)


def radial_shape(r: np.ndarray, shape, inner: float, outer: float) -> np.ndarray:
    """f(r) of a velocity field: with s = (r - a) / (b - a) held in [0, 1], "uniform" 1, "linear" s,
    "quadratic" s^2, or a table (r_k, f_k) interpolated linearly in r and held at its ends."""
    if isinstance(shape, str):
        if shape not in RADIAL_SHAPES:
            raise ValueError(f"radial must be one of {', '.join(map(repr, RADIAL_SHAPES))} or a table "
                             f"[[r...], [f...]], got {shape!r}")
        if not (np.isfinite(inner) and np.isfinite(outer) and outer > inner):
            raise ValueError(f"outer_radius must exceed inner_radius, got {inner!r} and {outer!r}")
        s = np.clip((r - inner) / (outer - inner), 0.0, 1.0)
        return np.ones_like(r) if shape == "uniform" else s if shape == "linear" else s * s
    try:
        rk, fk = (np.asarray(v, dtype=float) for v in shape)
    except (TypeError, ValueError):
        raise ValueError(f"radial table must be two lists [r...], [f...], got {shape!r}") from None
    if rk.ndim != 1 or rk.size < 1 or rk.shape != fk.shape or not np.all(np.isfinite(rk)) \
            or not np.all(np.isfinite(fk)) or np.any(np.diff(rk) <= 0):
        raise ValueError(f"radial table must be two lists of equal length, finite, the radii increasing, "
                         f"got {shape!r}")
    return np.interp(r, rk, fk)


def modal_velocity_field(positions: np.ndarray, direction, amplitude: float, radial="linear",
                         modes=(0,), phase: float = 0.0, inner_radius: float | None = None,
                         outer_radius: float | None = None, center=(0.0, 0.0, 0.0),
                         axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Nodal velocities (n, 3) v_I = amplitude f(r_I) sum_n cos(n (theta_I - phase)) d along ``direction`` d.

    A kick out of plane (d the axis) or in any direction, with circumferential modes n (cos n theta,
    n = 0 the axisymmetric one) and a radial shape f (:func:`radial_shape`) between ``inner_radius`` a and
    ``outer_radius`` b (default: the smallest and largest distance of the nodes from the axis). For the kick
    v_z = 0.05 (r - a)/(b - a) sum_{n=0..3} cos n theta of an annulus:
    ``modal_velocity_field(x, [0, 0, 1], 0.05, "linear", modes=[0, 1, 2, 3])``. Add it to the
    ``initial_velocity`` of a :class:`flexbody.scenes.scene.DynamicAnalysis` (for a steady-spin start it is
    the kick on top of the spin). r and theta are those of :func:`polar_coordinates`; ``direction`` is
    normalised; ``phase`` is in radians.
    """
    x = np.asarray(positions, dtype=float)
    d = np.asarray(direction, dtype=float)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.abs(d).max() > 0:
        raise ValueError(f"direction must be a finite nonzero 3-vector, got {_shown(direction)}")
    d = d / np.abs(d).max()
    d = d / np.linalg.norm(d)
    if isinstance(amplitude, bool) or not np.isfinite(amplitude):
        raise ValueError(f"amplitude must be a finite number, got {amplitude!r}")
    if isinstance(phase, bool) or not np.isfinite(phase):
        raise ValueError(f"phase must be a finite number, got {phase!r}")
    modes = list(modes)
    if not modes or not all(isinstance(m, (int, np.integer)) and not isinstance(m, bool) and m >= 0 for m in modes):
        raise ValueError(f"modes must be a non-empty list of integers >= 0, got {modes!r}")
    r, theta = polar_coordinates(x, center, axis)
    a = float(r.min()) if inner_radius is None else float(inner_radius)
    b = float(r.max()) if outer_radius is None else float(outer_radius)
    pattern = sum(np.cos(m * (theta - phase)) for m in modes)
    return (amplitude * radial_shape(r, radial, a, b) * pattern)[:, None] * d


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
    """Relative errors at every reference time inside the recorded interval.

    The relative error is |value - reference| / max|reference| of that quantity over the table. A reference
    time that is a recorded instant is compared there (``measure`` "recorded"); any other (a reference
    between the recorded steps of ``output_every`` > 1) with the recorded values interpolated linearly
    (``measure`` "interpolated": it adds the interpolation's error to the run's).
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
            recorded = float(np.min(np.abs(t - tr))) <= 1e-9 * max(1.0, abs(t[-1]))
            errors.append({"quantity": name, "time": float(tr), "value": v, "reference": float(rv),
                           "rel_error": abs(v - float(rv)) / scale,
                           "measure": "recorded" if recorded else "interpolated"})
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
    rotation_per_step : the largest rotation per time step |omega| h over the recorded instants
        (:func:`rotation_rate`) and its time
    size : the diagonal of the body's bounding box in the reference configuration
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
    setup_time_s: float = 0.0               # building the scene (if the caller timed it), the mass, ...
    compile_time_s: float = 0.0             # compiling the kernels, or loading them from numba's cache
    rotation_per_step: tuple[float, float] = (0.0, 0.0)
    size: float = 0.0

    @property
    def largest_step(self) -> float:
        """The longest time step taken (the fixed step, or the adaptive run's longest accepted one)."""
        fixed = self.analysis.end_time / self.analysis.n_steps
        taken = getattr(self.result, "max_step", float("nan"))
        return float(taken) if getattr(self.result, "adaptive", False) and np.isfinite(taken) else fixed

    def step_summary(self) -> dict:
        """Accepted and rejected steps (by the error estimate, by Newton failures) and the step sizes taken."""
        r = self.result
        return {"adaptive": bool(getattr(r, "adaptive", False)), "accepted": int(getattr(r, "steps", self.steps)),
                "rejected_error": int(getattr(r, "rejected_error", 0)),
                "rejected_newton": int(getattr(r, "rejected_newton", 0)),
                "min": float(getattr(r, "min_step", float("nan"))), "max": float(getattr(r, "max_step", float("nan"))),
                "error_tolerance": self.analysis.alpha_settings().error_tolerance}

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

    @property
    def steps(self) -> int:
        """Time steps taken (the last recorded one; all of them for a completed run)."""
        return self.result.records[-1].step if self.result.records else 0

    def energy_summary(self) -> dict:
        """Initial and final energies, and the largest drift of the balance T + W + V_g + D (module docstring;
        reported as ``total.max_drift``, ``total.max_rel_drift``)."""
        e = {k: np.asarray(self.energies[k], dtype=float) for k in ENERGY_KEYS}
        out: dict = {"conservative": self.conservative}
        out.update({k: {"initial": float(e[k][0]) + 0.0, "final": float(e[k][-1]) + 0.0} for k in ENERGY_KEYS})
        scale = float(np.max(e["kinetic"] + e["strain"] + np.abs(e["gravity"])))
        balance = e["total"] + e["dissipated"]                  # T + W + V_g + D
        drift = np.abs(balance - balance[0])
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

    @property
    def warnings(self) -> list[str]:
        """Why a completed run is not to be trusted (empty if it is): a conserved quantity drifted beyond
        ``MAX_ENERGY_DRIFT`` or ``MAX_MOMENTUM_DRIFT`` of its scale, or the body turned by more than
        ``MAX_ROTATION_PER_STEP`` in a time step."""
        out = []
        h = self.largest_step
        resolved = RESOLVED_MOTION * np.finfo(float).eps * self.size / h    # a velocity
        e = {k: np.asarray(self.energies[k], dtype=float) for k in ENERGY_KEYS}
        energy_velocity = np.sqrt(2.0 * np.max(e["kinetic"] + e["strain"] + np.abs(e["gravity"])) / self.total_mass)
        drift = self.energy_summary()["total"]["max_rel_drift"]
        if self.conservative and energy_velocity > resolved and drift > MAX_ENERGY_DRIFT:
            out.append(f"the energy of this conservative body drifted by {drift:.3g} of its scale "
                       f"(limit {MAX_ENERGY_DRIFT:g})")
        momenta = self.momentum_summary()
        for name in ("linear", "angular"):
            drift = momenta[name]["max_rel_drift"]
            if self.isolated and energy_velocity > resolved and drift > MAX_MOMENTUM_DRIFT:
                out.append(f"the {name} momentum of this isolated body drifted by {drift:.3g} of its scale "
                           f"(limit {MAX_MOMENTUM_DRIFT:g})")
        turn, at = self.rotation_per_step
        if turn > MAX_ROTATION_PER_STEP:
            out.append(f"the body turns by {turn:.3g} rad in a time step at t = {at:.4g} s (accuracy limit "
                       f"{MAX_ROTATION_PER_STEP:g} rad): take dt <= {h * MAX_ROTATION_PER_STEP / turn:.3g} s")
        return out

    def as_dict(self) -> dict:
        st = self.result.stats
        a = self.analysis
        return {
            "scene": self.scene, "kind": "dynamic", "dofs": self.dofs, "elements": self.elements,
            "steps": self.steps, "newton_iterations": st.iterations, "tangent_updates": st.tangent_updates,
            "factorizations": st.factorizations, "wall_time_s": self.wall_time_s,
            "iterations_per_step": st.iterations / max(self.steps, 1),
            "factorizations_per_step": st.factorizations / max(self.steps, 1),
            "converged": self.result.converged, "message": self.result.message, "time": float(self.result.time),
            "end_time": a.end_time, "time_step": a.end_time / a.n_steps, "rho_inf": a.rho_inf, "policy": a.policy,
            "time_steps": self.step_summary(),
            "mass": a.mass,
            "outputs": {k: v[-1] for k, v in self.history.items() if k != "time" and v},
            "errors": self.errors, "max_rel_error": self.max_rel_error,
            "energy": self.energy_summary(), "momentum": self.momentum_summary(),
            "energy_history": {k: list(map(float, self.energies[k])) for k in ("time", *ENERGY_KEYS)},
            **timings(self),
            "rotation_per_step": {"max": self.rotation_per_step[0], "time": self.rotation_per_step[1],
                                  "limit": MAX_ROTATION_PER_STEP},
            "warnings": self.warnings,
        }


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


def _state_record(dyn, step: int, t: float, state, velocity: np.ndarray, wall_time: float,
                  dissipated: float = 0.0):
    """A step record of a state without solver statistics (the initial state; the last converged state of a
    run that stopped between two output steps): 0 iterations, energies and momenta evaluated here."""
    from integrators.generalized_alpha import DynamicStepRecord
    p, L = dyn.momenta(state, velocity)
    return DynamicStepRecord(step, t, 0, [], [], 0, 1, dyn.kinetic_energy(velocity), dyn.strain_energy(state),
                             dyn.gravity_potential(state), p, L, wall_time, dissipated)


def _steps_taken(result, a: DynamicAnalysis) -> int:
    """The number of time steps behind ``result.time`` (the fixed steps end on a grid; adaptive: counted)."""
    if getattr(result, "adaptive", False):
        return int(result.steps)
    return int(round(result.time / (a.end_time / a.n_steps)))


def run_dynamic(scene: Scene, on_step: Callable | None = None, progress: Callable | None = None,
                notify: Callable[[CompileNotice], None] | None = None,
                started: float | None = None, restart=None) -> DynamicRunSummary:
    """Integrate a dynamic scene; record outputs, energies and momenta; compare with the reference.

    ``on_step(record, state, history)`` is called for the initial state (record step 0, time 0) and for
    every recorded step; ``progress(record)`` for every recorded step; ``notify`` and ``started`` as in
    :func:`flexbody.scenes.scene.run_scene`; ``restart`` (:class:`flexbody.scenes.scene.RestartPoint`)
    continues a saved run from its step (the history then starts there). A run that stops early (a step that does not converge) also
    records its last converged state when that is not an output step (``output_every`` > 1): the files, the
    history and the summary then all end at that instant.
    """
    started = time.perf_counter() if started is None else started
    from flexbody.dynamics import DynamicModel
    from integrators.generalized_alpha import generalized_alpha

    model, a = scene.model, scene.analysis
    dyn = DynamicModel(model, gravity=a.gravity, load_factor=a.load_factor, prescribed=list(a.prescribed),
                       point_masses=list(a.point_masses), damping=a.damping, mass=a.mass)
    state, v0 = initial_conditions(dyn, a)
    history: dict[str, list[float]] = {"time": [], **{o.name: [] for o in scene.outputs}}
    energies: dict[str, list] = {k: [] for k in ("time", *ENERGY_KEYS, "linear_momentum", "angular_momentum")}
    h = a.end_time / a.n_steps
    turn = [0.0, 0.0]                        # the largest rotation per step so far, and its time

    def record(rec, q, v, initial: bool = False) -> None:
        if rec.motion is not None:               # nodal velocities and accelerations, for the output files
            rec.motion["velocity"], rec.motion["angular_velocity"] = nodal_fields(dyn, q, rec.motion["v"])
            rec.motion["acceleration"], rec.motion["angular_acceleration"] = nodal_fields(dyn, q, rec.motion["vdot"])
        history["time"].append(rec.time)
        rate = rotation_rate(dyn, q, v) * (rec.h or h)      # the step that led here (adaptive: varies)
        if rate > turn[0]:
            turn[:] = [rate, float(rec.time)]
        for out in scene.outputs:
            history[out.name].append(_output_value(out, model, dyn, q, v))
        energies["time"].append(rec.time)
        for key, value in (("kinetic", rec.kinetic_energy), ("strain", rec.strain_energy),
                           ("gravity", rec.potential_energy), ("total", rec.total_energy),
                           ("dissipated", rec.dissipated_energy)):
            energies[key].append(float(value))
        energies["linear_momentum"].append(np.asarray(rec.linear_momentum, float).tolist())
        energies["angular_momentum"].append(np.asarray(rec.angular_momentum, float).tolist())
        if on_step is not None:
            on_step(rec, q, history)
        if progress is not None and not initial:
            progress(rec)

    with kernel_threads(a.threads, model.body.mesh.n_elements):
        setup = time.perf_counter() - started
        compile_time = warm_up_kernels(model, notify)  # numba compilation is not run time
        t0 = time.perf_counter()
        if restart is None:
            vdot0 = dyn.initial_acceleration(state, 0.0, v0)
            first = _state_record(dyn, 0, 0.0, state, v0, 0.0)
            first.motion = {"v": v0, "vdot": vdot0, "a": vdot0}
            record(first, state, v0, initial=True)
            result = generalized_alpha(dyn, a.end_time, a.time_step, state=state, velocity=v0,
                                       settings=a.alpha_settings(), on_step=record, record_every=a.output_every)
        else:                                  # continue a saved run (flexbody.outputs.restart)
            h = a.end_time / a.n_steps
            if not 0 <= restart.step < a.n_steps:
                raise ValueError(f"restart step {restart.step} is not before the last step {a.n_steps}")
            state, v0 = restart.state, restart.v
            first = _state_record(dyn, restart.step, restart.step * h, state, v0, 0.0, restart.dissipated_energy)
            first.motion = {"v": v0, "vdot": restart.vdot, "a": restart.a}
            record(first, state, v0, initial=True)
            result = generalized_alpha(dyn, a.end_time, h, state=state, velocity=v0, settings=a.alpha_settings(),
                                       on_step=record, record_every=a.output_every, t_start=restart.step * h,
                                       acceleration=restart.vdot, pseudo_acceleration=restart.a,
                                       first_step=restart.step, dissipated_energy=restart.dissipated_energy)
        if result.time > history["time"][-1]:  # stopped between two output steps: record where it stopped
            last = _state_record(dyn, _steps_taken(result, a), result.time, result.state, result.velocity,
                                 time.perf_counter() - t0, result.dissipated_energy)
            last.motion = {"v": result.velocity, "vdot": result.acceleration, "a": result.pseudo_acceleration}
            result.records.append(last)
            record(last, result.state, result.velocity)
        wall = time.perf_counter() - t0
    errors = compare_in_time(history, scene.reference) if scene.reference else []
    return DynamicRunSummary(scene.name, model.n_dof, model.body.mesh.n_elements, result, a, history, energies,
                             errors, wall, dyn.inertia.total_mass, _is_isolated(scene), _is_conservative(scene),
                             setup, compile_time, tuple(turn), float(np.linalg.norm(np.ptp(model.body.mesh.nodes, axis=0))))
