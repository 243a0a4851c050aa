"""Static equilibrium paths: load control with adaptive steps and cut-back, and arc-length (Crisfield).

The model supplies ``residual(q, lam)``, ``residual_and_tangent(q, lam)``, ``external_force(q)``,
``update(q, dq)`` and ``initial_state()``; the residual is r = f_int(q) - lam f_ext(q). A run never returns
garbage: a step that fails is cut back down to ``min_step``, then the run stops with a report and the last
converged state.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import time
from typing import Callable

import numpy as np

from integrators.linear import LinearSolver
from integrators.newton import NewtonSettings, NewtonStats, newton_solve


@dataclass
class StepRecord:
    """One converged step."""

    step: int
    load_factor: float
    iterations: int
    residuals: list[float]
    wall_time: float


@dataclass
class StaticResult:
    state: object                      # the last converged state
    load_factor: float
    records: list[StepRecord]
    stats: NewtonStats
    converged: bool = True
    message: str = "completed"
    wall_time: float = 0.0
    cutbacks: int = 0


def _reference_norm(model, state, lam: float) -> float:
    return abs(lam) * float(np.linalg.norm(model.external_force(state))) or 1.0


def load_control(model, load_factors=None, *, n_steps: int = 10, settings: NewtonSettings | None = None,
                 min_step: float = 1e-4, max_step: float | None = None, adaptive: bool = True,
                 on_step: Callable | None = None, state=None) -> StaticResult:
    """Follow the path by prescribing the load factor.

    Parameters
    ----------
    load_factors : increasing load levels to reach exactly (default: n_steps equal steps to 1)
    adaptive : between the prescribed levels, grow the step after easy convergence (<= 4 iterations)
        and halve it after a failure, down to ``min_step`` (fraction of the total load)
    on_step : called as on_step(record, state) after each converged step (outputs hang off here)
    """
    settings = settings or NewtonSettings()
    targets = np.linspace(0, 1, n_steps + 1)[1:] if load_factors is None else np.asarray(load_factors, float)
    if targets.size == 0 or not np.all(np.isfinite(targets)) or np.any(np.diff(targets) <= 0):
        raise ValueError(f"load factors must be finite and increasing, got {targets!r}")
    state = model.initial_state() if state is None else state
    solver, stats = LinearSolver(), NewtonStats()
    records: list[StepRecord] = []
    lam, t0, cutbacks = 0.0, time.perf_counter(), 0
    first_step = targets[0]
    step = first_step
    max_step = max_step or (targets[-1] - 0.0)
    for target in targets:
        while lam < target - 1e-14:
            trial = min(lam + step, target)
            new_state, out = newton_solve(
                state, lambda q: model.residual(q, trial), lambda q: model.residual_and_tangent(q, trial),
                model.update, _reference_norm(model, state, trial), settings, solver, stats,
                dof_scale=model.dof_scale, conjugate=model.conjugate)
            if not out.converged:
                cutbacks += 1
                step = (trial - lam) / 2
                if step < min_step or not adaptive:
                    msg = (f"step to load factor {trial:.6g} failed ({out.reason}); residual history "
                           f"{[f'{v:.2e}' for v in out.residuals]}; stopped at the last converged load "
                           f"factor {lam:.6g}")
                    return StaticResult(state, lam, records, stats, False, msg, time.perf_counter() - t0,
                                        cutbacks)
                continue
            state, lam = new_state, trial
            rec = StepRecord(len(records) + 1, lam, out.iterations, out.residuals, time.perf_counter() - t0)
            records.append(rec)
            if on_step is not None:
                on_step(rec, state)
            if adaptive and out.iterations <= 4:
                step = min(step * 1.5, max_step)
    return StaticResult(state, lam, records, stats, True, "completed", time.perf_counter() - t0, cutbacks)


def arc_length(model, *, lam_max: float = 1.0, initial_increment: float = 0.05, max_steps: int = 500,
               settings: NewtonSettings | None = None, min_increment_ratio: float = 1e-3,
               max_increment_ratio: float = 4.0, desired_iterations: int = 5,
               max_load_increment: float | None = None,
               on_step: Callable | None = None, state=None) -> StaticResult:
    """Crisfield's cylindrical arc-length method: ||Delta q|| = Delta l in each step.

    The first step's arc length follows from a load increment ``initial_increment``. Each iteration solves
    K dq_r = -r and K dq_f = f_ext and picks the load correction from the quadratic constraint, taking the
    root closest to the previous direction (this follows snap-through and snap-back). The step length adapts
    to ``desired_iterations``; ``max_load_increment`` caps the load-factor change of a step (a dense record
    of the path). The run ends when lam reaches ``lam_max``: the last step is then solved under load
    control at exactly lam_max.
    """
    settings = settings or NewtonSettings()
    state = model.initial_state() if state is None else state
    solver, stats = LinearSolver(), NewtonStats()
    records: list[StepRecord] = []
    t0, lam, cutbacks = time.perf_counter(), 0.0, 0

    r, K = model.residual_and_tangent(state, 0.0)
    stats.tangent_updates += 1
    solver.factorize(K)
    stats.factorizations += 1
    dq_f = solver.solve(model.external_force(state))
    dl = initial_increment * float(np.linalg.norm(dq_f))
    dl0 = dl
    prev_dir = dq_f / np.linalg.norm(dq_f)
    prev_dlam_sign = 1.0

    for _ in range(max_steps):
        # predictor along the tangent, in the direction of the previous step
        r, K = model.residual_and_tangent(state, lam)
        stats.tangent_updates += 1
        solver.factorize(K)
        stats.factorizations += 1
        dq_f = solver.solve(model.external_force(state))
        sign = np.sign(dq_f @ prev_dir) or prev_dlam_sign
        dlam = sign * dl / np.linalg.norm(dq_f)
        if max_load_increment is not None and abs(dlam) > max_load_increment:
            dl *= max_load_increment / abs(dlam)
            dlam = sign * max_load_increment
        Dq = dlam * dq_f
        trial = model.update(state, Dq)
        trial_lam = lam + dlam
        ok, residuals, it = False, [], 0
        ref = _reference_norm(model, state, max(abs(trial_lam), 1e-12))
        for it in range(1, settings.max_iterations + 1):
            r, K = model.residual_and_tangent(trial, trial_lam)
            stats.tangent_updates += 1
            norm = float(np.linalg.norm(r))
            residuals.append(norm)
            if not np.isfinite(norm):
                break
            if norm <= max(settings.rtol * ref, settings.atol) and it > 1:
                ok = True
                break
            solver.factorize(K)
            stats.factorizations += 1
            a = solver.solve(-r)
            b = solver.solve(model.external_force(trial))
            # ||Dq + a + x b||^2 = dl^2
            u = Dq + a
            c2, c1, c0 = b @ b, 2 * u @ b, u @ u - dl * dl
            disc = c1 * c1 - 4 * c2 * c0
            if disc < 0:  # no intersection: take the closest point
                x = -c1 / (2 * c2)
            else:
                roots = [(-c1 + s * np.sqrt(disc)) / (2 * c2) for s in (1.0, -1.0)]
                x = max(roots, key=lambda z: (Dq @ (u + z * b)))
            dq = a + x * b
            trial = model.update(trial, dq)
            Dq = Dq + dq
            trial_lam += x
            stats.iterations += 1
        if not ok:
            cutbacks += 1
            dl /= 2
            if dl < min_increment_ratio * dl0:
                msg = (f"arc-length step from load factor {lam:.6g} failed after cut-backs; residual history "
                       f"{[f'{v:.2e}' for v in residuals]}; stopped at the last converged state")
                return StaticResult(state, lam, records, stats, False, msg, time.perf_counter() - t0, cutbacks)
            continue
        if trial_lam >= lam_max:
            # finish exactly at lam_max under load control from the last converged state
            state_end, out = newton_solve(
                trial, lambda q: model.residual(q, lam_max), lambda q: model.residual_and_tangent(q, lam_max),
                model.update, _reference_norm(model, trial, lam_max), settings, solver, stats,
                dof_scale=model.dof_scale, conjugate=model.conjugate)
            if out.converged:
                rec = StepRecord(len(records) + 1, lam_max, out.iterations, out.residuals, time.perf_counter() - t0)
                records.append(rec)
                if on_step is not None:
                    on_step(rec, state_end)
                return StaticResult(state_end, lam_max, records, stats, True, "completed",
                                    time.perf_counter() - t0, cutbacks)
            dl /= 2
            cutbacks += 1
            continue
        prev_dir = Dq / np.linalg.norm(Dq)
        prev_dlam_sign = np.sign(trial_lam - lam) or prev_dlam_sign
        state, lam = trial, trial_lam
        rec = StepRecord(len(records) + 1, lam, it, residuals, time.perf_counter() - t0)
        records.append(rec)
        if on_step is not None:
            on_step(rec, state)
        dl *= float(np.clip(np.sqrt(desired_iterations / max(it, 1)), 0.5, 2.0))
        dl = min(dl, max_increment_ratio * dl0)
    return StaticResult(state, lam, records, stats, False,
                        f"arc-length reached max_steps={max_steps} at load factor {lam:.6g}",
                        time.perf_counter() - t0, cutbacks)
