"""Running a scene, static or dynamic: one :func:`run_scene` for both kinds.

The run of each kind (:class:`StaticRun` here; :class:`flexbody.scenes.dynamic_run.DynamicRun`, imported only
when a dynamic scene runs: a static run never assembles a mass matrix) is set up before the clock starts,
tracks the outputs at every converged or recorded step, solves, and makes its summary; the runner around it
times set-up, compilation and solve apart, sets the kernels' threads and compares with the scene's
reference (:func:`flexbody.scenes.compare.compare`).
"""

from __future__ import annotations

import inspect
import time
from typing import TYPE_CHECKING, Callable, Protocol

import numpy as np

from flexbody.scenes.analysis import DynamicAnalysis, RestartPoint
from flexbody.scenes.compare import compare, level_tolerance
from flexbody.scenes.kernel_setup import CompileNotice, kernel_threads, warm_up_kernels
from flexbody.scenes.summary import RunSummary, StaticRunSummary
from integrators.static import arc_length, load_control

if TYPE_CHECKING:
    from flexbody.scenes.scene import Scene

_ARC_MAX_STEPS = inspect.signature(arc_length).parameters["max_steps"].default


class SceneRun(Protocol):
    """One kind of run, as :func:`run_scene` drives it."""

    #: numba threads of the element kernels during the run (None: by the mesh size, :func:`kernel_threads`)
    threads: int | None
    #: the abscissa (``load_factor`` or ``time``) and every tracked output, per recorded step
    history: dict[str, list[float]]

    def solve(self, t0: float):
        """Solve (``t0``: when the solve's clock started) and return the solver's result."""

    def summary(self, result, errors: list[dict], wall: float, setup: float, compile_time: float) -> RunSummary:
        """The run's summary."""


class StaticRun:
    """A static scene's run: load control to the listed load factors, or arc length.

    ``on_step(record, state, history)`` and ``progress(record)`` are called after every converged step;
    ``restart`` continues a load-control path from its load factor to the levels beyond it, an arc-length path
    from its continuation through the remaining ``max_steps`` (steps numbered on from the saved one; the
    history starts after it).
    """

    threads = None

    def __init__(self, scene: Scene, on_step: Callable | None = None, progress: Callable | None = None,
                 restart: RestartPoint | None = None) -> None:
        a = scene.analysis
        if a.method not in ("load_control", "arc_length"):
            raise ValueError(f"analysis method must be 'load_control' or 'arc_length', got {a.method!r}")
        self.scene, self.analysis, self.restart = scene, a, restart
        self.on_step, self.progress = on_step, progress
        self.history: dict[str, list[float]] = {"load_factor": [], **{o.name: [] for o in scene.outputs}}

    def record(self, rec, state) -> None:
        if self.restart is not None:
            rec.step += self.restart.step
            if getattr(rec, "critical", None) is not None:
                rec.critical.step += self.restart.step
        self.history["load_factor"].append(rec.load_factor)
        for out in self.scene.outputs:
            self.history[out.name].append(out.value(self.scene.model, state))
        if self.on_step is not None:
            self.on_step(rec, state, self.history)
        if self.progress is not None:
            self.progress(rec)

    def solve(self, t0: float):
        model, a, restart = self.scene.model, self.analysis, self.restart
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
            return arc_length(model, lam_max=max(a.load_factors), initial_increment=a.arc_increment,
                              max_load_increment=a.max_load_increment, settings=a.newton, on_step=self.record,
                              check_stability=a.stability, state=restart.state,
                              continuation=restart.continuation, max_steps=max_steps, **options)
        if restart is not None:
            levels = [lf for lf in a.load_factors if lf > restart.where + level_tolerance(np.asarray(a.load_factors))]
            if not levels:
                raise ValueError(f"restart at load factor {restart.where:g}: no load level of the scene lies beyond it")
            return load_control(model, levels, settings=a.newton, on_step=self.record, state=restart.state,
                                load_factor=restart.where, check_stability=a.stability)
        if a.method == "load_control":
            return load_control(model, a.load_factors, settings=a.newton, on_step=self.record,
                                check_stability=a.stability)
        return arc_length(model, lam_max=max(a.load_factors), initial_increment=a.arc_increment,
                          max_load_increment=a.max_load_increment, settings=a.newton, on_step=self.record,
                          check_stability=a.stability, **a.arc_options)

    def summary(self, result, errors: list[dict], wall: float, setup: float, compile_time: float) -> StaticRunSummary:
        model = self.scene.model
        return StaticRunSummary(self.scene.name, model.n_dof, model.body.mesh.n_elements, result, self.history,
                                errors, wall, setup, compile_time)


def run_scene(scene: Scene, on_step: Callable | None = None, progress: Callable | None = None,
              notify: Callable[[CompileNotice], None] | None = None, started: float | None = None,
              restart: RestartPoint | None = None) -> RunSummary:
    """Run a scene; track the outputs at every converged (static) or recorded (dynamic) step; compare
    with the reference.

    Meshes below ``DynamicAnalysis.SINGLE_THREAD_ELEMENTS`` elements run the element kernel on one numba
    thread unless a dynamic analysis sets ``threads`` (thread start-up costs more than it gains there, see
    :func:`kernel_threads`).

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
        continuation (the remaining ``max_steps``; steps numbered on from the saved one); the history starts at the saved step (dynamic) or after it (static)

    Returns
    -------
    :class:`flexbody.scenes.summary.StaticRunSummary` for a static scene,
    :class:`flexbody.scenes.summary.DynamicRunSummary` for a dynamic one.
    """
    started = time.perf_counter() if started is None else started
    run: SceneRun
    if isinstance(scene.analysis, DynamicAnalysis):
        from flexbody.scenes.dynamic_run import DynamicRun
        run = DynamicRun(scene, on_step, progress, restart)
    else:
        run = StaticRun(scene, on_step, progress, restart)
    model = scene.model
    with kernel_threads(run.threads, model.body.mesh.n_elements):
        setup = time.perf_counter() - started
        compile_time = warm_up_kernels(model, notify)  # numba compilation is not run time
        t0 = time.perf_counter()
        result = run.solve(t0)
        wall = time.perf_counter() - t0
    errors = compare(run.history, scene.reference) if scene.reference else []
    return run.summary(result, errors, wall, setup, compile_time)
