"""The scene: model + analysis + tracked outputs + optional reference, and the run that reports error
against run time.

A scene's analysis is static (:class:`StaticAnalysis`: load control or arc length) or dynamic
(:class:`DynamicAnalysis`: Lie-group generalized-alpha time integration, :mod:`integrators.generalized_alpha`).
The dynamic modules (mass, inertia, the integrator) are imported only when a dynamic scene runs: a static
run never assembles a mass matrix.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field, replace
import inspect
import time
from typing import Callable, ClassVar

import numpy as np

from flexbody.assembly import Model
from flexbody.frames import unit_vector
from integrators.newton import NewtonSettings
from integrators.static import StaticResult, arc_length, load_control


@dataclass(frozen=True)
class Output:
    """A tracked scalar: the displacement of one node along a fixed direction, times ``scale``.

    The direction is normalised (any finite nonzero vector, huge components included); a node index is
    checked against the mesh when the :class:`Scene` is made.

    Example: Output("W_A", node=12, direction=(0, 0, 1)) is the z-displacement of node 12.
    """

    name: str
    node: int
    direction: tuple[float, float, float]
    scale: float = 1.0

    def __post_init__(self) -> None:
        if isinstance(self.node, (bool, np.bool_)) or not isinstance(self.node, (int, np.integer)):
            raise ValueError(f"output {self.name!r} node must be a node index, got {self.node!r}")
        object.__setattr__(self, "node", int(self.node))
        unit = unit_vector(self.direction, f"output {self.name!r} direction")
        object.__setattr__(self, "direction", tuple(float(v) for v in unit))
        _check_scale(self)

    def node_indices(self) -> tuple[int, ...]:
        """The nodes this output reads (checked against the mesh when the scene is made)."""
        return (self.node,)

    def value(self, model: Model, state) -> float:
        u = state.x[self.node] - model.body.mesh.nodes[self.node]
        return self.scale * float(u @ np.asarray(self.direction, float))


def _check_scale(output) -> None:
    scale = output.scale
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not np.isfinite(scale):
        raise ValueError(f"output {output.name!r} scale must be a finite number, got {scale!r}")


@dataclass(frozen=True)
class RadialDisplacement:
    """The mean radial displacement of some nodes about an axis through ``center``, times ``scale``.

    u_r = mean_I (|P (x_I - c)| - |P (X_I - c)|) with P the projection normal to ``axis``: invariant under
    rotations about the axis, so it measures the stretch of a spinning body in any of its positions.
    """

    name: str
    nodes: tuple[int, ...]
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    scale: float = 1.0

    def __post_init__(self) -> None:
        nodes = np.atleast_1d(np.asarray(self.nodes))
        if nodes.size == 0 or nodes.ndim != 1 or not np.issubdtype(nodes.dtype, np.integer):
            raise ValueError(f"output {self.name!r} nodes must be a non-empty list of node indices, "
                             f"got {self.nodes!r}")
        object.__setattr__(self, "nodes", tuple(int(i) for i in nodes))
        unit_vector(self.axis, f"output {self.name!r} axis")
        c = np.asarray(self.center, dtype=float)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise ValueError(f"output {self.name!r} center must be a finite 3-vector, got {self.center!r}")
        _check_scale(self)

    def node_indices(self) -> tuple[int, ...]:
        """The nodes this output reads (checked against the mesh when the scene is made)."""
        return self.nodes

    def _radius(self, x: np.ndarray) -> np.ndarray:
        n = unit_vector(self.axis, f"output {self.name!r} axis")
        r = x - np.asarray(self.center, float)
        return np.linalg.norm(r - np.outer(r @ n, n), axis=1)

    def value(self, model: Model, state) -> float:
        idx = np.asarray(self.nodes, dtype=int)
        X = model.body.mesh.nodes[idx]
        return self.scale * float(np.mean(self._radius(state.x[idx]) - self._radius(X)))


@dataclass(frozen=True)
class AngularVelocity:
    """A global component (0, 1, 2 = x, y, z) of the body's rigid angular velocity (dynamic scenes only).

    The mass-weighted least-squares fit of the nodal velocities
    (:meth:`flexbody.dynamics.DynamicModel.rigid_angular_velocity`): a kinematic measure, independent of
    the momenta.
    """

    name: str
    component: int
    uses_velocity = True

    def value(self, model: Model, state) -> float:
        raise ValueError(f"output {self.name!r} (an angular velocity) needs a dynamic analysis")

    def motion_value(self, dyn, state, velocity: np.ndarray) -> float:
        return float(dyn.rigid_angular_velocity(state, velocity)[self.component])


@dataclass(frozen=True)
class Reference:
    """Reference values of some outputs at load factors (static scenes) or at times (dynamic scenes)."""

    load_factors: np.ndarray
    values: dict[str, np.ndarray]
    source: str = ""

    @property
    def times(self) -> np.ndarray:
        """The abscissae of a dynamic scene's reference (the same array as ``load_factors``)."""
        return self.load_factors


@dataclass(frozen=True)
class StaticAnalysis:
    """method: "load_control" (steps to the listed load factors) or "arc_length"; ``arc_options``: the
    arc-length step-length controls (``integrators.static.ARC_LENGTH_OPTIONS``: ``max_steps``,
    ``min_increment_ratio``, ``max_increment_ratio``, ``desired_iterations``) that differ from the defaults
    of :func:`integrators.static.arc_length`. ``stability``: count the negative eigenvalues of the tangent
    at every converged step and report limit and bifurcation points (one symmetric factorization per step;
    docs/stability.md)."""

    method: str = "load_control"
    load_factors: tuple[float, ...] = tuple(np.linspace(0.05, 1.0, 20))
    arc_increment: float = 0.05
    max_load_increment: float | None = None
    newton: NewtonSettings = field(default_factory=NewtonSettings)
    arc_options: dict = field(default_factory=dict)
    stability: bool = True


@dataclass(frozen=True, eq=False)
class DynamicAnalysis:
    """Time integration from t = 0 to ``end_time`` with the Lie-group generalized-alpha method.

    Parameters
    ----------
    time_step : h (rounded down so that whole steps end at ``end_time``)
    end_time : the end of the run
    rho_inf : spectral radius at infinite frequency in [0, 1] (1: no numerical damping)
    policy : iteration matrix "modified" (kept across iterations and steps, refreshed when the contraction
        is poor) or "full" (refreshed every iteration)
    output_every : record the outputs, energies and momenta (and write the files) every k-th step
    gravity : body acceleration g (3,)
    load_factor : lambda(t) that scales the Model's loads (None: 1 at all times), or for a Model with load
        groups (``Model.load_groups``) the factors (G,) of its groups, e.g.
        :class:`flexbody.time_functions.GroupFactors`
    prescribed : rigid motions in time of clamped nodes (:class:`flexbody.dynamics.PrescribedMotion`)
    initial_state : the configuration at t = 0 (None: the reference configuration), or
        :class:`flexbody.spinning.SteadySpinStart`: the steady spin (relative equilibrium) at a constant
        angular velocity with its rigid velocity field, to which ``initial_velocity`` and
        ``initial_angular_velocity`` are then added (a kick); a driven hub must turn at that rate from t = 0
    initial_velocity : nodal translational velocities at t = 0 (n, 3) (None: zero)
    initial_angular_velocity : nodal angular velocities at t = 0 in global components (n, 3) (None: zero);
        the components about the directors are not DoFs and are dropped
    settings : the integrator's other settings (tolerances, iterations, cut-backs); ``rho_inf`` and
        ``policy`` above override theirs
    damping : Rayleigh damping (:class:`flexbody.dynamics.RayleighDamping`: ``alpha_mass`` a0,
        ``beta_stiffness`` a1, or ``RayleighDamping.from_ratio(zeta, (f1, f2))``); None: undamped
    threads : numba threads of the element kernels during the run; None: one thread for meshes of fewer
        than ``SINGLE_THREAD_ELEMENTS`` elements (thread start-up dominates there: measured on a shared
        2-core machine, 100 steps of the 64-element membrane take 0.34 s on one thread and 2.1 s on two,
        20 steps of 1152 elements 0.72 s and 1.37 s), numba's default otherwise
    point_masses : tip masses and rotary inertias at nodes (:class:`flexbody.shell.inertia.PointMass`),
        added to the shell's inertia
    adaptive : error-controlled time steps (True), the fixed step (False), or None: the ``settings``' choice
        (fixed by default). Adaptive: ``time_step`` is the first step and the unit of the output times (every
        ``output_every``-th multiple of it, where the steps land), no step is longer than the output interval,
        and the tolerance and step limits are ``settings.error_tolerance``, ``min_step``, ``max_step``
        (docs/dynamics.md, "Adaptive time steps")
    mass : the mass matrix, "lumped" (HRZ, diagonal; default) or "consistent" (translations
        int rho h N_I N_J dA, director inertia lumped): ``flexbody.dynamics.DynamicModel(mass=...)``

    Compared by identity (it holds arrays and functions).
    """

    SINGLE_THREAD_ELEMENTS: ClassVar[int] = 2000
    #: the most time steps a run may ask for (1e12 steps hung in the list of output times)
    MAX_TIME_STEPS: ClassVar[int] = 10_000_000

    time_step: float
    end_time: float
    rho_inf: float = 0.9
    policy: str = "modified"
    output_every: int = 1
    gravity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    load_factor: Callable[[float], float] | None = None
    prescribed: tuple = ()
    initial_state: object | None = None
    initial_velocity: np.ndarray | None = None
    initial_angular_velocity: np.ndarray | None = None
    settings: object | None = None
    threads: int | None = None
    point_masses: tuple = ()
    damping: object | None = None
    adaptive: bool | None = None
    mass: str = "lumped"

    def __post_init__(self) -> None:
        for name in ("time_step", "end_time"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.time_step > self.end_time:
            raise ValueError(f"time_step must not exceed end_time, got {self.time_step!r} > {self.end_time!r}")
        if self.end_time / self.time_step > self.MAX_TIME_STEPS:
            raise ValueError(f"end_time / time_step asks for {self.end_time / self.time_step:.3g} time steps, at most "
                             f"{self.MAX_TIME_STEPS} (time_step {self.time_step!r}, end_time {self.end_time!r})")
        if isinstance(self.rho_inf, bool) or not isinstance(self.rho_inf, (int, float)) or not 0 <= self.rho_inf <= 1:
            raise ValueError(f"rho_inf must lie in [0, 1], got {self.rho_inf!r}")
        if self.policy not in ("modified", "full"):
            raise ValueError(f"policy must be 'modified' or 'full', got {self.policy!r}")
        if isinstance(self.output_every, bool) or not isinstance(self.output_every, int) or self.output_every < 1:
            raise ValueError(f"output_every must be an integer >= 1, got {self.output_every!r}")
        if self.threads is not None and (isinstance(self.threads, bool) or not isinstance(self.threads, int)
                                         or self.threads < 1):
            raise ValueError(f"threads must be an integer >= 1 or None, got {self.threads!r}")
        g = np.asarray(self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity must be a finite 3-vector, got {self.gravity!r}")
        if self.adaptive is not None and not isinstance(self.adaptive, bool):
            raise ValueError(f"adaptive must be True, False or None, got {self.adaptive!r}")
        from flexbody.dynamics import RayleighDamping
        if self.damping is not None and not isinstance(self.damping, RayleighDamping):
            raise ValueError(f"damping must be a RayleighDamping or None, got {type(self.damping).__name__}")
        from flexbody.shell.inertia import check_mass_kind
        check_mass_kind(self.mass)

    @property
    def n_steps(self) -> int:
        """The number of time steps (as :func:`integrators.generalized_alpha.generalized_alpha` takes them)."""
        return max(1, int(np.ceil(self.end_time / self.time_step - 1e-9)))

    def output_times(self) -> np.ndarray:
        """The times at which the outputs are recorded: 0, every ``output_every``-th step, and the end."""
        n = self.n_steps
        steps = [k for k in range(1, n + 1) if k % self.output_every == 0 or k == n]
        return np.concatenate([[0.0], np.array(steps) * (self.end_time / n)])

    def alpha_settings(self):
        """The :class:`integrators.generalized_alpha.AlphaSettings` of this analysis."""
        from integrators.generalized_alpha import AlphaSettings
        base = self.settings if self.settings is not None else AlphaSettings()
        out = replace(base, rho_inf=float(self.rho_inf), policy=self.policy)
        return out if self.adaptive is None else replace(out, adaptive=self.adaptive)

    @property
    def is_adaptive(self) -> bool:
        """Error-controlled time steps (``adaptive``, else the settings')."""
        return bool(self.alpha_settings().adaptive)


_ARC_MAX_STEPS = inspect.signature(arc_length).parameters["max_steps"].default


@dataclass
class RestartPoint:
    """A saved step to continue a run from (:func:`flexbody.outputs.restart.read_restart`): its step number,
    load factor (static) or time (dynamic), the state, and for a dynamic run the free-DoF velocity v,
    acceleration vdot and generalized-alpha pseudo-acceleration a, and the work dissipated until then; for an
    arc-length path the :class:`integrators.static.ArcLengthState` of the step (``continuation``)."""

    step: int
    where: float
    state: object
    v: np.ndarray | None = None
    vdot: np.ndarray | None = None
    a: np.ndarray | None = None
    dissipated_energy: float = 0.0
    continuation: object | None = None


@dataclass
class Scene:
    name: str
    description: str
    model: Model
    analysis: StaticAnalysis | DynamicAnalysis
    outputs: list
    reference: Reference | None = None
    parameters: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        _check_outputs(self.outputs, self.model.body.n_nodes)

    @property
    def kind(self) -> str:
        """"dynamic" for a :class:`DynamicAnalysis`, else "static"."""
        return "dynamic" if isinstance(self.analysis, DynamicAnalysis) else "static"


def _check_outputs(outputs: list, n_nodes: int) -> None:
    """Every output's nodes exist: a bad index is named when the scene is made, not at the first step."""
    for out in outputs:
        for i in getattr(out, "node_indices", lambda: ())():
            if not 0 <= i < n_nodes:
                raise ValueError(f"output {out.name!r} names node {i}, but the mesh has nodes 0..{n_nodes - 1}")


@dataclass
class RunSummary:
    scene: str
    dofs: int
    elements: int
    result: StaticResult
    history: dict[str, list[float]]          # load_factor and every output, per converged step
    errors: list[dict]
    wall_time_s: float                       # the solve (after set-up and compilation)
    setup_time_s: float = 0.0                # building the scene (if the caller timed it) and the run's set-up
    compile_time_s: float = 0.0              # compiling the kernels, or loading them from numba's cache

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

    @property
    def warnings(self) -> list[str]:
        """Why a completed run is not to be trusted (a dynamic run's checks; none for a static path)."""
        return []

    def as_dict(self) -> dict:
        st = self.result.stats
        return {
            "scene": self.scene, "kind": "static", "dofs": self.dofs, "elements": self.elements,
            "steps": len(self.result.records), "newton_iterations": st.iterations,
            "tangent_updates": st.tangent_updates, "factorizations": st.factorizations,
            "newton_iteration": st.iteration, "wall_time_s": self.wall_time_s, "converged": self.result.converged,
            "message": self.result.message, "load_factor": self.result.load_factor,
            "outputs": {k: v[-1] for k, v in self.history.items() if k != "load_factor" and v},
            "errors": self.errors, "max_rel_error": self.max_rel_error,
            **timings(self),
            "history": {k: [float(x) for x in v] for k, v in self.history.items()}, "warnings": self.warnings,
            "stability": stability_summary(self.result),
        }


def stability_summary(result: StaticResult) -> dict:
    """The stability of a static path (JSON-able): the number of negative eigenvalues of the tangent at
    every converged step (null where not counted), at the last one, and the critical points passed
    (:class:`integrators.static.CriticalPoint`)."""
    return {"negative_eigenvalues": [r.negative_eigenvalues for r in result.records],
            "final_negative_eigenvalues": result.negative_eigenvalues,
            "critical_points": [c.as_dict() for c in result.critical_points]}


def timings(summary) -> dict[str, float]:
    """The set-up, compilation and solve times of a run summary (``solve_time_s`` is its ``wall_time_s``)."""
    return {"setup_time_s": summary.setup_time_s, "compile_time_s": summary.compile_time_s,
            "solve_time_s": summary.wall_time_s}


@dataclass(frozen=True)
class CompileNotice:
    """What :func:`warm_up_kernels` tells its caller, as it happens.

    ``stage``: "compiling" (numba started compiling: nothing usable in its cache, the first run), then
    "compiled" or "loaded" (every kernel came from numba's cache) when the kernels are ready, after
    ``seconds``. ``str()`` gives the sentence to show a user.
    """

    stage: str
    seconds: float = 0.0

    @property
    def done(self) -> bool:
        return self.stage != "compiling"

    def __str__(self) -> str:
        if self.stage == "compiling":
            return "compiling the element kernels (first run only, a few minutes) ..."
        if self.stage == "compiled":
            return f"compiled the element kernels in {self.seconds:.1f} s (cached for later runs)"
        return f"loaded the compiled element kernels in {self.seconds:.2f} s (from the cache: no compilation)"


def warm_up_kernels(model: Model, notify: Callable[[CompileNotice], None] | None = None) -> float:
    """Compile, or load from numba's cache, the kernels of a run (:meth:`Model.warm_up`); return the seconds.

    ``notify`` gets a "compiling" :class:`CompileNotice` when numba starts compiling (a cache miss), and
    a "compiled" or "loaded" one when the kernels are ready.
    """
    from numba.core import event

    class Watch(event.Listener):
        compilations = 0

        def on_start(self, ev) -> None:
            self.compilations += 1
            if self.compilations == 1 and notify is not None:
                notify(CompileNotice("compiling"))

        def on_end(self, ev) -> None:
            pass

    watch = Watch()
    t0 = time.perf_counter()
    with event.install_listener("numba:compile", watch):
        model.warm_up()
    seconds = time.perf_counter() - t0
    if notify is not None:
        notify(CompileNotice("compiled" if watch.compilations else "loaded", seconds))
    return seconds


@contextmanager
def kernel_threads(threads: int | None, n_elements: int):
    """Run the block with ``threads`` numba threads (None: automatic: one thread below
    ``DynamicAnalysis.SINGLE_THREAD_ELEMENTS`` elements, see ``DynamicAnalysis.threads``; static runs too)."""
    import numba
    wanted = threads
    if wanted is None and n_elements < DynamicAnalysis.SINGLE_THREAD_ELEMENTS:
        wanted = 1
    before = numba.get_num_threads()
    if wanted is not None:
        numba.set_num_threads(min(wanted, numba.config.NUMBA_NUM_THREADS))
    try:
        yield
    finally:
        numba.set_num_threads(before)


def _level_tolerance(*levels: np.ndarray) -> float:
    """Two load factors closer than this are the same level (round-off of the step targets)."""
    return 1e-9 * max([1.0, *(float(np.abs(v).max(initial=0.0)) for v in levels)])


def nearest_on_polyline(points: np.ndarray, polyline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distance of each point (m, 2) to a polyline (k, 2), and the nearest point of the polyline (m, 2)."""
    a, d = polyline[:-1], np.diff(polyline, axis=0)               # the segments a + t d, t in [0, 1]
    if len(d) == 0:
        return np.linalg.norm(points - polyline[0], axis=1), np.repeat(polyline[:1], len(points), axis=0)
    length2 = np.einsum("ij,ij->i", d, d)
    t = np.einsum("msj,sj->ms", points[:, None, :] - a[None], d) / np.where(length2 > 0, length2, 1.0)
    foot = a[None] + np.clip(t, 0.0, 1.0)[..., None] * d[None]
    dist = np.linalg.norm(points[:, None, :] - foot, axis=2)
    k = np.argmin(dist, axis=1)
    rows = np.arange(len(points))
    return dist[rows, k], foot[rows, k]


def _steps_on_levels(lam: np.ndarray, ref_lam: np.ndarray, tol: float) -> np.ndarray:
    """For each step, the index of the tabulated level it lies on (within ``tol``), or -1."""
    nearest = np.abs(lam[:, None] - ref_lam[None, :]).argmin(axis=1)
    return np.where(np.abs(ref_lam[nearest] - lam) <= tol, nearest, -1)


def compare_with_reference(history: dict[str, list[float]], reference: Reference) -> list[dict]:
    """Relative errors of the tracked outputs against the reference, at converged steps only.

    Nothing is interpolated between steps, neither the path nor the table (linear interpolation across a
    coarse step of a strongly curved path, the strip rolled twice into a circle in 0.2 M_max steps, reported
    8.3 % for a path within 7e-5 at its steps):

    * ``measure = "load_level"``: the load factor increases along the path and in the table, and some steps
      lie on tabulated levels: at those steps (only), |value - reference| / s_q, with s_q = max |reference|
      of that quantity over the table (so that values near zero at small loads do not blow up the measure);
      ``load_factor`` is the tabulated level;
    * ``measure = "path"``: otherwise (no step on a tabulated level, or a path whose load factor is not
      monotonic: snap-through, snap-back, arc length), at every step within the table's load range, the
      distance of the point (value / s_q, lambda / s_l) to the reference polyline in that normalised plane,
      s_l = max |reference load factor|; ``reference`` and ``reference_load_factor`` are the nearest point
      of the reference path. It does not depend on where the steps fall or on the direction the path takes,
      so it measures a path through a snap, where the value at a load factor is not unique (comparing at
      the first crossing of each load level reported 33 % for a path that lies on its reference). Where the
      path is flat in load (a soft response) it is the load error rather than the displacement error.
    """
    lam = np.asarray(history["load_factor"], dtype=float)
    ref_lam = np.asarray(reference.load_factors, dtype=float)
    if lam.size == 0 or ref_lam.size == 0:
        return []
    tol = _level_tolerance(lam, ref_lam)
    s_lam = float(np.abs(ref_lam).max()) or 1.0
    levels = _steps_on_levels(lam, ref_lam, tol)
    at_levels = bool(np.all(np.diff(lam) > 0) and np.all(np.diff(ref_lam) > 0) and np.any(levels >= 0))
    inside = np.flatnonzero((lam >= ref_lam.min() - tol) & (lam <= ref_lam.max() + tol) & (lam > 0))
    errors = []
    for name, ref_vals in reference.values.items():
        if name not in history:
            continue
        ref_vals = np.asarray(ref_vals, dtype=float)
        s_q = float(np.abs(ref_vals).max()) or 1.0
        vals = np.asarray(history[name], dtype=float)
        if at_levels:
            errors += [{"quantity": name, "value": float(vals[i]), "load_factor": float(ref_lam[k]),
                        "reference": float(ref_vals[k]), "rel_error": float(abs(vals[i] - ref_vals[k]) / s_q),
                        "measure": "load_level"} for i, k in enumerate(levels) if k >= 0 and lam[i] > 0]
            continue
        dist, foot = nearest_on_polyline(np.column_stack([vals[inside] / s_q, lam[inside] / s_lam]),
                                         np.column_stack([ref_vals / s_q, ref_lam / s_lam]))
        errors += [{"quantity": name, "value": float(vals[i]), "load_factor": float(lam[i]),
                    "reference": float(fq * s_q), "reference_load_factor": float(fl * s_lam),
                    "rel_error": float(d), "measure": "path"} for i, d, (fq, fl) in zip(inside, dist, foot)]
    return errors


def run_scene(scene: Scene, on_step: Callable | None = None, progress: Callable | None = None,
              notify: Callable[[CompileNotice], None] | None = None, started: float | None = None,
              restart: RestartPoint | None = None):
    """Run a scene; track the outputs at every converged (static) or recorded (dynamic) step; compare
    with the reference.

    Static runs of meshes below ``DynamicAnalysis.SINGLE_THREAD_ELEMENTS`` elements run the element kernel on
    one numba thread (thread start-up costs more than it gains there, see :func:`kernel_threads`).

    Parameters
    ----------
    scene : the scene
    on_step : called as ``on_step(record, state, history)`` after every step (HDF5 and rerun writers);
        a dynamic run calls it for the initial state (record step 0) too
    progress : called as ``progress(record)`` after every step
    notify : told when the kernels' compilation starts and ends (:func:`warm_up_kernels`)
    started : the ``time.perf_counter()`` reading when the set-up began (e.g. before building the scene);
        default: the call
    restart : continue from a saved step (:class:`RestartPoint`): a dynamic run from its time step, a static
        load-control path from its load factor to the levels beyond it, an arc-length path from its
        continuation (the remaining ``max_steps``; steps numbered on from the saved one); the history starts
        at the saved step (dynamic) or after it (static)

    Returns
    -------
    RunSummary for a static scene, :class:`flexbody.scenes.dynamic_run.DynamicRunSummary` for a dynamic one.
    """
    started = time.perf_counter() if started is None else started
    if isinstance(scene.analysis, DynamicAnalysis):
        from flexbody.scenes.dynamic_run import run_dynamic
        return run_dynamic(scene, on_step, progress, notify, started, restart)
    model = scene.model
    history: dict[str, list[float]] = {"load_factor": []}
    for out in scene.outputs:
        history[out.name] = []

    def record(rec, state):
        if restart is not None:
            rec.step += restart.step
            if getattr(rec, "critical", None) is not None:
                rec.critical.step += restart.step
        history["load_factor"].append(rec.load_factor)
        for out in scene.outputs:
            history[out.name].append(out.value(model, state))
        if on_step is not None:
            on_step(rec, state, history)
        if progress is not None:
            progress(rec)

    setup = time.perf_counter() - started
    compile_time = warm_up_kernels(model, notify)  # numba compilation is not run time
    t0 = time.perf_counter()
    a = scene.analysis
    if a.method not in ("load_control", "arc_length"):
        raise ValueError(f"analysis method must be 'load_control' or 'arc_length', got {a.method!r}")
    with kernel_threads(None, model.body.mesh.n_elements):
        if restart is not None and a.method == "arc_length":
            if restart.continuation is None:
                raise ValueError("an arc-length restart needs the continuation of its step (arc length, direction)")
            if restart.where >= max(a.load_factors):
                raise ValueError(f"restart at load factor {restart.where:g}: the path ended there (the scene "
                                 f"goes to {max(a.load_factors):g})")
            options = dict(a.arc_options)
            max_steps = options.pop("max_steps", _ARC_MAX_STEPS) - restart.step
            if max_steps < 1:
                raise ValueError(f"restart at step {restart.step}: the scene's max_steps "
                                 f"{max_steps + restart.step} are used up")
            result = arc_length(model, lam_max=max(a.load_factors), initial_increment=a.arc_increment,
                                max_load_increment=a.max_load_increment, settings=a.newton, on_step=record,
                                check_stability=a.stability, state=restart.state,
                                continuation=restart.continuation, max_steps=max_steps, **options)
        elif restart is not None:
            levels = [lf for lf in a.load_factors if lf > restart.where + _level_tolerance(np.asarray(a.load_factors))]
            if not levels:
                raise ValueError(f"restart at load factor {restart.where:g}: no load level of the scene lies beyond it")
            result = load_control(model, levels, settings=a.newton, on_step=record, state=restart.state,
                                  load_factor=restart.where, check_stability=a.stability)
        elif a.method == "load_control":
            result = load_control(model, a.load_factors, settings=a.newton, on_step=record,
                                  check_stability=a.stability)
        else:
            result = arc_length(model, lam_max=max(a.load_factors), initial_increment=a.arc_increment,
                                max_load_increment=a.max_load_increment, settings=a.newton, on_step=record,
                                check_stability=a.stability, **a.arc_options)
    wall = time.perf_counter() - t0
    errors = compare_with_reference(history, scene.reference) if scene.reference else []
    return RunSummary(scene.name, model.n_dof, model.body.mesh.n_elements, result, history, errors, wall,
                      setup, compile_time)
