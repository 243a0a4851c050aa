"""Running a scene: the static path (load control or arc length) here, the time integration in
:mod:`flexbody.scenes.dynamic_run` (imported only when a dynamic scene runs: a static run never assembles a
mass matrix); both track the outputs per step, time set-up, compilation and solve apart, and compare with the
scene's reference (:mod:`flexbody.scenes.compare`).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Callable

import numpy as np

from flexbody.scenes.analysis import DynamicAnalysis, RestartPoint
from flexbody.scenes.compare import compare_with_reference, level_tolerance
from flexbody.scenes.kernel_setup import CompileNotice, kernel_threads, warm_up_kernels
from flexbody.scenes.summary import RunSummary
from integrators.static import arc_length, load_control

if TYPE_CHECKING:
    from flexbody.scenes.scene import Scene


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
        load-control path from its load factor to the levels beyond it (steps numbered on from the saved
        one); the history starts at the saved step (dynamic) or after it (static)

    Returns
    -------
    :class:`flexbody.scenes.summary.RunSummary` for a static scene,
    :class:`flexbody.scenes.summary.DynamicRunSummary` for a dynamic one.
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
        if restart is not None:
            if a.method != "load_control":
                raise ValueError("a restart continues a load-control path only (this scene uses arc length)")
            levels = [lf for lf in a.load_factors if lf > restart.where + level_tolerance(np.asarray(a.load_factors))]
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
