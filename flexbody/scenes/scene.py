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
import time
from typing import Callable, ClassVar

import numpy as np

from flexbody.assembly import Model
from integrators.newton import NewtonSettings
from integrators.static import StaticResult, arc_length, load_control


@dataclass(frozen=True)
class Output:
    """A tracked scalar: the displacement of one node along a fixed direction, times ``scale``.

    Example: Output("W_A", node=12, direction=(0, 0, 1)) is the z-displacement of node 12.
    """

    name: str
    node: int
    direction: tuple[float, float, float]
    scale: float = 1.0

    def value(self, model: Model, state) -> float:
        u = state.x[self.node] - model.body.mesh.nodes[self.node]
        return self.scale * float(u @ np.asarray(self.direction, float))


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

    def _radius(self, x: np.ndarray) -> np.ndarray:
        n = np.asarray(self.axis, float)
        n = n / np.abs(n).max()                    # no overflow in the norm of a huge axis vector
        n = n / np.linalg.norm(n)
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
    of :func:`integrators.static.arc_length`."""

    method: str = "load_control"
    load_factors: tuple[float, ...] = tuple(np.linspace(0.05, 1.0, 20))
    arc_increment: float = 0.05
    max_load_increment: float | None = None
    newton: NewtonSettings = field(default_factory=NewtonSettings)
    arc_options: dict = field(default_factory=dict)


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
    load_factor : lambda(t) that scales the Model's loads (None: 1 at all times)
    prescribed : rigid motions in time of clamped nodes (:class:`flexbody.dynamics.PrescribedMotion`)
    initial_state : the configuration at t = 0 (None: the reference configuration)
    initial_velocity : nodal translational velocities at t = 0 (n, 3) (None: zero)
    initial_angular_velocity : nodal angular velocities at t = 0 in global components (n, 3) (None: zero);
        the components about the directors are not DoFs and are dropped
    settings : the integrator's other settings (tolerances, iterations, cut-backs); ``rho_inf`` and
        ``policy`` above override theirs
    threads : numba threads of the element kernels during the run; None: one thread for meshes of fewer
        than ``SINGLE_THREAD_ELEMENTS`` elements (thread start-up dominates there: measured on a shared
        2-core machine, 100 steps of the 64-element membrane take 0.34 s on one thread and 2.1 s on two,
        20 steps of 1152 elements 0.72 s and 1.37 s), numba's default otherwise

    Compared by identity (it holds arrays and functions).
    """

    SINGLE_THREAD_ELEMENTS: ClassVar[int] = 2000

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

    def __post_init__(self) -> None:
        for name in ("time_step", "end_time"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.time_step > self.end_time:
            raise ValueError(f"time_step must not exceed end_time, got {self.time_step!r} > {self.end_time!r}")
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
        return replace(base, rho_inf=float(self.rho_inf), policy=self.policy)


@dataclass
class Scene:
    name: str
    description: str
    model: Model
    analysis: StaticAnalysis | DynamicAnalysis
    outputs: list
    reference: Reference | None = None
    parameters: dict = field(default_factory=dict)

    @property
    def kind(self) -> str:
        """"dynamic" for a :class:`DynamicAnalysis`, else "static"."""
        return "dynamic" if isinstance(self.analysis, DynamicAnalysis) else "static"


@dataclass
class RunSummary:
    scene: str
    dofs: int
    elements: int
    result: StaticResult
    history: dict[str, list[float]]          # load_factor and every output, per converged step
    errors: list[dict]
    wall_time_s: float

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

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
        }


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


def compare_with_reference(history: dict[str, list[float]], reference: Reference) -> list[dict]:
    """Relative errors at every tabulated load factor reached (linear interpolation between steps).

    The relative error is |value - reference| / max|reference| of that quantity over the table, so that
    values near zero at small loads do not blow up the measure.
    """
    lam = np.concatenate([[0.0], history["load_factor"]])
    errors = []
    for name, ref_vals in reference.values.items():
        if name not in history:
            continue
        vals = np.concatenate([[0.0], history[name]])
        scale = float(np.abs(ref_vals).max()) or 1.0
        for lf, rv in zip(reference.load_factors, ref_vals):
            if lf <= 0 or lf > lam.max() + 1e-12:
                continue
            if np.all(np.diff(lam) > 0):
                v = float(np.interp(lf, lam, vals))
            else:  # non-monotonic path (snap-back): first crossing
                k = int(np.argmax(lam >= lf - 1e-12))
                t = (lf - lam[k - 1]) / (lam[k] - lam[k - 1])
                v = float(vals[k - 1] + t * (vals[k] - vals[k - 1]))
            errors.append({"quantity": name, "load_factor": float(lf), "value": v, "reference": float(rv),
                           "rel_error": abs(v - rv) / scale})
    return errors


def run_scene(scene: Scene, on_step: Callable | None = None, progress: Callable | None = None):
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

    Returns
    -------
    RunSummary for a static scene, :class:`flexbody.scenes.dynamic_run.DynamicRunSummary` for a dynamic one.
    """
    if isinstance(scene.analysis, DynamicAnalysis):
        from flexbody.scenes.dynamic_run import run_dynamic
        return run_dynamic(scene, on_step, progress)
    model = scene.model
    history: dict[str, list[float]] = {"load_factor": []}
    for out in scene.outputs:
        history[out.name] = []

    def record(rec, state):
        history["load_factor"].append(rec.load_factor)
        for out in scene.outputs:
            history[out.name].append(out.value(model, state))
        if on_step is not None:
            on_step(rec, state, history)
        if progress is not None:
            progress(rec)

    model.warm_up()  # numba compilation is not run time
    t0 = time.perf_counter()
    a = scene.analysis
    if a.method not in ("load_control", "arc_length"):
        raise ValueError(f"analysis method must be 'load_control' or 'arc_length', got {a.method!r}")
    with kernel_threads(None, model.body.mesh.n_elements):
        if a.method == "load_control":
            result = load_control(model, a.load_factors, settings=a.newton, on_step=record)
        else:
            result = arc_length(model, lam_max=max(a.load_factors), initial_increment=a.arc_increment,
                                max_load_increment=a.max_load_increment, settings=a.newton, on_step=record,
                                **a.arc_options)
    wall = time.perf_counter() - t0
    errors = compare_with_reference(history, scene.reference) if scene.reference else []
    return RunSummary(scene.name, model.n_dof, model.body.mesh.n_elements, result, history, errors, wall)
