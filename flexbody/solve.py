"""Static and dynamic solves of a model, as a user calls them from Python: :func:`solve_static` and
:func:`solve_dynamic`, returning the converged states with the solver's records and statistics.

They are thin layers over the integrators (:func:`integrators.static.load_control`,
:func:`integrators.static.arc_length`, :func:`integrators.generalized_alpha.generalized_alpha`): the same
algorithms, settings and results as ``flexbody run``, without a scene (no tracked outputs, no reference, no
files). A run that stops early (a step that does not converge even after its cut-backs) does not raise: the
solution says so (``converged`` False, ``message`` naming the step and why) and keeps every state converged
until then.
"""

from __future__ import annotations

from dataclasses import dataclass
import time
from typing import Callable, Sequence

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellState
from integrators.newton import NewtonSettings, NewtonStats

__all__ = ["StaticSolution", "DynamicSolution", "solve_static", "solve_dynamic"]


def _kernel_threads(n_elements: int):
    """One numba thread for small meshes (as ``flexbody run`` does: thread start-up costs more than it gains)."""
    from flexbody.scenes.kernel_setup import kernel_threads
    return kernel_threads(None, n_elements)


def _compile(model: Model) -> float:
    """Compile (or load from numba's cache) the kernels of a solve; the seconds it took."""
    t0 = time.perf_counter()
    model.warm_up()
    return time.perf_counter() - t0


class _Outcome:
    """What a static and a dynamic solution both read off the integrator's result (``self.result``)."""

    result: object

    @property
    def state(self) -> ShellState:
        """The last converged state (the initial state if no step converged)."""
        return self.result.state

    @property
    def converged(self) -> bool:
        """True if the solve reached its end (the last load level, or ``end_time``)."""
        return bool(self.result.converged)

    @property
    def message(self) -> str:
        """"completed", or where and why the solve stopped."""
        return str(self.result.message)

    @property
    def stats(self) -> NewtonStats:
        """Newton iterations, iteration-matrix updates and factorizations of the whole solve."""
        return self.result.stats

    @property
    def wall_time_s(self) -> float:
        """Seconds of the solve (after compilation)."""
        return float(self.result.wall_time)


@dataclass
class StaticSolution(_Outcome):
    """The equilibrium path of a static solve.

    Attributes
    ----------
    model : Model
        The model solved.
    load_factors : np.ndarray
        The load factor of every converged step (k,).
    states : list[ShellState]
        The converged state of every step (k; the start is ``initial``); empty if ``keep_states`` was False
        (then :attr:`state` still holds the last one).
    result : integrators.static.StaticResult
        The integrator's result: step records (iterations, residual histories, stability), statistics,
        the failure report of a run that stopped early.
    initial : ShellState
        The state the path started from.
    compile_time_s : float
        Seconds spent compiling the kernels or loading them from numba's cache (not in ``wall_time_s``).
    """

    model: Model
    load_factors: np.ndarray
    states: list[ShellState]
    result: object
    initial: ShellState
    compile_time_s: float = 0.0

    @property
    def load_factor(self) -> float:
        """The load factor of the last converged state."""
        return float(self.result.load_factor)

    def displacements(self, state: ShellState | None = None) -> np.ndarray:
        """Nodal displacements x - X (n, 3) of ``state`` (default: the last converged one).

        Examples
        --------
        ``solution.displacements()[node, 2]`` is the z-displacement of a node.
        """
        state = self.state if state is None else state
        return state.x - self.model.body.mesh.nodes


@dataclass
class DynamicSolution(_Outcome):
    """The motion computed by a dynamic solve.

    Attributes
    ----------
    dynamic_model : flexbody.dynamics.DynamicModel
        The equations of motion solved (the model with its mass, gravity, damping, ...).
    times : np.ndarray
        The time of every recorded state (k,), the initial one first.
    states : list[ShellState]
        The recorded states (every ``output_every``-th step, and the initial one); empty if ``keep_states``
        was False.
    velocities : list[np.ndarray]
        The free-DoF velocities v of the recorded states (:meth:`nodal_velocities` turns them into nodal
        ones); empty if ``keep_states`` was False.
    records : list[flexbody.energy.DynamicStepRecord]
        The step records of the recorded states, the initial one first: iterations, energies (kinetic,
        strain, gravity, dissipated), linear and angular momentum.
    result : integrators.generalized_alpha.DynamicResult
        The integrator's result (last state, velocity, accelerations, statistics, step sizes).
    compile_time_s : float
        Seconds spent compiling the kernels or loading them from numba's cache.
    """

    dynamic_model: object
    times: np.ndarray
    states: list[ShellState]
    velocities: list[np.ndarray]
    records: list
    result: object
    compile_time_s: float = 0.0

    @property
    def model(self) -> Model:
        """The static model (body, constraints, loads) in motion."""
        return self.dynamic_model.model

    @property
    def time(self) -> float:
        """The time reached (``end_time`` if the run completed)."""
        return float(self.result.time)

    def energies(self) -> dict[str, np.ndarray]:
        """The energies at the recorded times: "kinetic", "strain", "gravity" (potential), "dissipated" (the
        work of the damping forces) and "total" (kinetic + strain + gravity), each (k,)."""
        out = {key: np.array([getattr(r, attr) for r in self.records]) for key, attr in
               (("kinetic", "kinetic_energy"), ("strain", "strain_energy"), ("gravity", "potential_energy"),
                ("dissipated", "dissipated_energy"))}
        out["total"] = out["kinetic"] + out["strain"] + out["gravity"]
        return out

    def nodal_velocities(self, k: int = -1) -> tuple[np.ndarray, np.ndarray]:
        """The nodal velocities (n, 3) and global angular velocities (n, 3) of recorded state ``k``."""
        state, v = self.states[k], self.velocities[k]
        xdot, w_local = self.dynamic_model.nodal_velocities(state, v)
        return xdot, np.einsum("nij,nj->ni", state.frames, w_local)

    def displacements(self, state: ShellState | None = None) -> np.ndarray:
        """Nodal displacements x - X (n, 3) of ``state`` (default: the last converged one)."""
        state = self.state if state is None else state
        return state.x - self.model.body.mesh.nodes


def _check_model(model: object) -> Model:
    if not isinstance(model, Model):
        raise TypeError(f"model must be a flexbody Model (fb.Model(body, constraints, loads)), "
                        f"got {type(model).__name__}")
    return model


def solve_static(model: Model, load_factors: Sequence[float] | np.ndarray | None = None, *, steps: int = 10,
                 method: str = "load_control", settings: NewtonSettings | None = None,
                 arc_increment: float = 0.05, max_load_factor: float = 1.0, check_stability: bool = True,
                 keep_states: bool = True, on_step: Callable | None = None, **options) -> StaticSolution:
    """Follow the static equilibrium path r(q, lambda) = f_int(q) - lambda f_ext(q) = 0 of a model.

    Parameters
    ----------
    model : Model
        The body with its constraints and loads (every load scaled by the load factor lambda).
    load_factors : sequence of float, optional
        Load control: the increasing load levels to reach exactly (default: ``steps`` equal steps to
        ``max_load_factor``). Between them the step adapts (grows after easy steps, is cut back on failure).
    steps : int
        The number of equal load steps when ``load_factors`` is not given.
    method : str
        "load_control" (:func:`integrators.static.load_control`) or "arc_length" (Crisfield's arc length,
        :func:`integrators.static.arc_length`, which follows limit points and snap-backs up to
        ``max_load_factor``).
    settings : NewtonSettings, optional
        Newton tolerances and tangent policy (default ``NewtonSettings()``).
    arc_increment : float
        Arc length: the load increment of the first step.
    max_load_factor : float
        The last load level (load control without ``load_factors``; arc length: where the path ends).
    check_stability : bool
        Count the negative eigenvalues of the tangent at every converged step and mark the limit and
        bifurcation points passed (``solution.result.critical_points``); costs one symmetric factorization
        per step.
    keep_states : bool
        Keep every converged state in ``solution.states`` (False: only the last one).
    on_step : callable, optional
        Called as ``on_step(record, state)`` after every converged step.
    **options
        Further keywords of the integrator (e.g. ``min_step``, ``predictor`` for load control;
        ``max_steps``, ``max_load_increment``, ``desired_iterations`` for arc length).

    Returns
    -------
    StaticSolution
        The converged states and load factors with the integrator's records and statistics; check
        ``converged`` (a run that stops early keeps what converged and says where and why in ``message``).

    Raises
    ------
    ValueError
        Bad arguments (named in the message), or a model whose supports leave a rigid-body motion free.
    """
    from integrators.static import arc_length, load_control
    model = _check_model(model)
    if method not in ("load_control", "arc_length"):
        raise ValueError(f"method must be 'load_control' or 'arc_length', got {method!r}")
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"steps must be an integer >= 1, got {steps!r}")
    if isinstance(max_load_factor, bool) or not isinstance(max_load_factor, (int, float, np.number)) \
            or not (np.isfinite(max_load_factor) and max_load_factor > 0):
        raise ValueError(f"max_load_factor must be a finite number > 0, got {max_load_factor!r}")
    if method == "arc_length" and load_factors is not None:
        raise ValueError("arc length chooses its own load factors: give max_load_factor, not load_factors")
    initial = model.initial_state()
    factors: list[float] = []
    states: list[ShellState] = []

    def record(rec, state) -> None:
        factors.append(float(rec.load_factor))
        if keep_states:
            states.append(state.copy())
        if on_step is not None:
            on_step(rec, state)

    compile_time = _compile(model)
    with _kernel_threads(model.body.mesh.n_elements):
        if method == "load_control":
            levels = (np.linspace(0.0, float(max_load_factor), steps + 1)[1:] if load_factors is None
                      else np.asarray(load_factors, dtype=float))
            result = load_control(model, levels, settings=settings, on_step=record,
                                  check_stability=check_stability, **options)
        else:
            result = arc_length(model, lam_max=float(max_load_factor), initial_increment=arc_increment,
                                settings=settings, on_step=record, check_stability=check_stability, **options)
    return StaticSolution(model, np.array(factors), states, result, initial, compile_time)


def solve_dynamic(model: Model, end_time: float, time_step: float, *, gravity: Sequence[float] = (0.0, 0.0, 0.0),
                  load_factor: Callable[[float], float | np.ndarray] | None = None, damping: object | None = None,
                  mass: str = "lumped", point_masses: Sequence = (), prescribed: Sequence = (),
                  state: ShellState | None = None, velocity: np.ndarray | None = None,
                  angular_velocity: np.ndarray | None = None, rho_inf: float = 0.9,
                  settings: object | None = None, output_every: int = 1, keep_states: bool = True,
                  on_step: Callable | None = None) -> DynamicSolution:
    """Integrate the motion of a model in time with the Lie-group generalized-alpha method.

    The equations of motion are M vdot + f_d + f_int(q) - lambda(t) f_ext(q) - f_g = 0
    (:class:`flexbody.dynamics.DynamicModel`); the material needs a density.

    Parameters
    ----------
    model : Model
        The body with its constraints and loads.
    end_time : float
        Integrate from t = 0 to ``end_time``.
    time_step : float
        The time step h (rounded down so that whole steps end at ``end_time``); with
        ``settings.adaptive`` the first step and the unit of the output times.
    gravity : sequence of 3 float
        The body acceleration g.
    load_factor : callable, optional
        lambda(t) scaling the model's loads (default 1 at all times, i.e. the loads applied suddenly), e.g.
        :class:`flexbody.time_functions.Ramp`.
    damping : flexbody.dynamics.RayleighDamping, optional
        Rayleigh damping (default: undamped).
    mass : str
        "lumped" (default) or "consistent".
    point_masses : sequence of flexbody.shell.inertia.PointMass
        Tip masses added to the shell's inertia.
    prescribed : sequence of flexbody.dynamics.PrescribedMotion
        Rigid motions in time of clamped nodes (e.g. a driven hub).
    state : ShellState, optional
        The configuration at t = 0 (default: the reference configuration).
    velocity, angular_velocity : np.ndarray, optional
        Nodal translational velocities and global angular velocities at t = 0, (n, 3) each (default 0;
        the components about the directors are not DoFs and are dropped).
    rho_inf : float
        Spectral radius at infinite frequency in [0, 1] (1: no numerical damping). A kicked thin membrane
        started on its steady spin (:func:`flexbody.spinning.steady_spin`) with a driven hub wants
        :data:`flexbody.spinning.STEADY_SPIN_RHO_INF` (0.5), which scenes take by default for such a start
        (:func:`flexbody.scenes.analysis.default_rho_inf`); this function cannot tell the start apart.
    settings : integrators.generalized_alpha.AlphaSettings, optional
        Tolerances, iteration matrix policy, cut-backs, adaptive steps (``rho_inf`` above overrides theirs).
    output_every : int
        Record every k-th step (energies and momenta are evaluated for recorded steps only).
    keep_states : bool
        Keep the recorded states and velocities (False: only the last state, in ``solution.state``).
    on_step : callable, optional
        Called as ``on_step(record, state, v)`` after every recorded step.

    Returns
    -------
    DynamicSolution
        The recorded times, states, velocities, step records (energies, momenta) and the integrator's result;
        check ``converged``.
    """
    from dataclasses import replace

    from flexbody.dynamics import DynamicModel
    from flexbody.energy import integrate_motion
    from integrators.generalized_alpha import AlphaSettings
    model = _check_model(model)
    for name, value in (("end_time", end_time), ("time_step", time_step)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not (np.isfinite(value)
                                                                                            and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    if time_step > end_time:
        raise ValueError(f"time_step must not exceed end_time, got {time_step!r} > {end_time!r}")
    if isinstance(rho_inf, bool) or not isinstance(rho_inf, (int, float, np.number)) or not 0 <= rho_inf <= 1:
        raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf!r}")
    dyn = DynamicModel(model, gravity=gravity, load_factor=load_factor, prescribed=list(prescribed),
                       point_masses=list(point_masses), damping=damping, mass=mass)
    settings = replace(settings if settings is not None else AlphaSettings(), rho_inf=float(rho_inf))
    q0 = dyn.prescribe(model.initial_state() if state is None else state, 0.0)
    n = model.body.n_nodes
    nodal = []
    for name, value in (("velocity", velocity), ("angular_velocity", angular_velocity)):
        arr = np.zeros((n, 3)) if value is None else np.asarray(value, dtype=float)
        if arr.shape != (n, 3) or not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} must be a finite array of shape ({n}, 3), got shape {arr.shape}")
        nodal.append(arr)
    v0 = dyn.velocity_from_nodal(q0, *nodal)
    records: list = []
    times: list[float] = []
    states: list[ShellState] = []
    velocities: list[np.ndarray] = []

    def record(rec, q, v) -> None:
        records.append(rec)
        times.append(float(rec.time))
        if keep_states:
            states.append(q.copy())
            velocities.append(np.array(v, dtype=float))
        if on_step is not None:
            on_step(rec, q, v)

    compile_time = _compile(model)
    with _kernel_threads(model.body.mesh.n_elements):
        motion = integrate_motion(dyn, float(end_time), float(time_step), state=q0, velocity=v0, settings=settings,
                                  on_step=record, record_every=output_every)
    records.insert(0, motion.initial)        # the state at t = 0 first
    times.insert(0, float(motion.initial.time))
    if keep_states:
        states.insert(0, q0.copy())
        velocities.insert(0, v0.copy())
    return DynamicSolution(dyn, np.array(times), states, velocities, records, motion.result, compile_time)
