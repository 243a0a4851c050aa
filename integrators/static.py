"""Static equilibrium paths: load control with adaptive steps and cut-back, and arc-length (Crisfield).

The model is a :class:`integrators.protocols.StaticProblem`: ``residual(q, lam)``, ``residual_and_tangent(q,
lam)``, ``external_force(q)``, ``update(q, dq)``, ``initial_state()``, ``conjugate(q, dq)`` and ``dof_scale``;
the residual is r = f_int(q) - lam f_ext(q). Opt-in capabilities, used when present: the mixed iteration
(:class:`~integrators.protocols.MixedIteration`), a check of the supports
(:class:`~integrators.protocols.SupportCheck`) and the conjugate map of the stability analysis
(:class:`~integrators.protocols.ConjugateMatrix`); a model that lacks a required member is refused before
the first step with a one-line ``TypeError`` naming it. A run never returns
garbage: a step that fails is cut back down to ``min_step``, then the run stops with a report and the last
converged state.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
import time
from typing import Callable

import numpy as np

from integrators.linear import LinearSolver, SingularMatrixError, inertia
from integrators.newton import NewtonSettings, NewtonStats, newton_solve, work_norm
from integrators.protocols import StaticProblem, StressedState, capabilities, require


@dataclass
class StepRecord:
    """One converged step.

    ``negative_eigenvalues``: the number of negative eigenvalues of the (symmetrized) tangent on the free
    DoFs at the converged state, 0 for a stable equilibrium (None if not counted, see :func:`stability`);
    ``critical``: the limit or bifurcation point the path passed between the previous converged state and
    this one, if any (:class:`CriticalPoint`).
    """

    step: int
    load_factor: float
    iterations: int
    residuals: list[float]
    wall_time: float
    negative_eigenvalues: int | None = None
    critical: "CriticalPoint | None" = None
    load_compliance: float = float("nan")   # f . K^-1 f at the converged state (see :func:`stability`)
    continuation: "ArcLengthState | None" = None   # arc length: what continues the path from this step


@dataclass
class ArcLengthState:
    """What :func:`arc_length` carries from one converged step to the next, besides the state: enough to
    continue the path from a saved step (a restart) as the uninterrupted run would.

    ``load_factor``: lam of the converged step; ``arc_length``: the arc length Delta l of the next step
    (after the step-length control); ``first_arc_length``: the first step's arc length, which the ratios
    ``min_increment_ratio`` and ``max_increment_ratio`` refer to; ``direction``: the last step's increment
    Delta q / scale, of unit length (the predictor follows it: its sign at a limit point); ``load_sign``: the
    sign of the last step's load change (the predictor's sign when the tangent is orthogonal to
    ``direction``). Lengths in units of the model size and radians (``model.dof_scale``).
    """

    load_factor: float
    arc_length: float
    first_arc_length: float
    direction: np.ndarray
    load_sign: float

    def __post_init__(self) -> None:
        self.direction = np.asarray(self.direction, dtype=float)
        values = (self.load_factor, self.arc_length, self.first_arc_length, self.load_sign)
        if not (all(np.isfinite(values)) and np.all(np.isfinite(self.direction))):
            raise ValueError("arc-length continuation: non-finite load factor, arc length or direction")
        if not (self.arc_length > 0 and self.first_arc_length > 0 and self.load_sign in (-1.0, 1.0)):
            raise ValueError(f"arc-length continuation needs arc lengths > 0 and a load sign of +-1, got "
                             f"{self.arc_length!r}, {self.first_arc_length!r} and {self.load_sign!r}")


@dataclass
class CriticalPoint:
    """A critical point passed between two converged steps: the number of negative eigenvalues of the
    tangent changed from ``negative_before`` to ``negative_after``.

    ``kind``: "limit point" if the load compliance f . K^-1 f changed sign with it (the buckling mode has a
    component along the load: the load factor turns, det K changes sign with the load), "bifurcation" if it
    kept its sign (the mode is orthogonal to the load: the path goes on through it and another branch
    crosses it).
    """

    kind: str
    step: int                       # the first converged step past the point
    load_factor_before: float
    load_factor_after: float
    negative_before: int
    negative_after: int

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)

    def __str__(self) -> str:
        return (f"{self.kind} between load factors {self.load_factor_before:.6g} and {self.load_factor_after:.6g} "
                f"(step {self.step}; negative eigenvalues {self.negative_before} -> {self.negative_after})")


@dataclass
class FailureReport:
    """Why and where a run stopped: the step that failed, from which converged load factor to which
    trial, the residual history of its last attempt, and the cut-backs spent on it."""

    step: int                          # number of the step that failed (1 = the first)
    load_factor: float                 # the last converged load factor (the state kept)
    trial_load_factor: float           # the load factor of the last attempt
    residuals: list[float]             # residual norms of the last attempt
    reason: str
    attempts: int                      # attempts at this step (1 + its cut-backs, + 1 for a failed
                                       # secant-predicted start)
    non_finite: bool = False
    limit_point: float | None = None   # load control: the load factor of the limit point that stopped it


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
    failure: FailureReport | None = None

    @property
    def critical_points(self) -> list[CriticalPoint]:
        """The limit and bifurcation points passed on the path (from the step records)."""
        return critical_points(self.records)

    @property
    def negative_eigenvalues(self) -> int | None:
        """The number of negative eigenvalues of the tangent at the last converged state (0: stable; None:
        not counted or no step)."""
        return self.records[-1].negative_eigenvalues if self.records else None


MAX_EXTRAPOLATION = 2.0   # the secant predictor extrapolates at most twice the previous step


def _step_load(model, state, lam: float) -> tuple[np.ndarray, float]:
    """The external load lam f_ext(q) of a step and its norm: with the internal forces, the force scale of
    the convergence tests (:func:`integrators.newton.newton_solve`; never an absolute number)."""
    load = lam * model.external_force(state)
    return load, work_norm(load, model.dof_scale)


def _check_support(model: StaticProblem) -> None:
    """Before the first step: the model must be a :class:`StaticProblem` (a one-line ``TypeError`` names
    what it lacks), and a static run needs every rigid-body motion restrained (else the stiffness is
    singular): models that can tell (:class:`SupportCheck`) are asked."""
    require(model, StaticProblem, "the static problem")
    check = capabilities(model).support_check
    if check is not None:
        check.check_static_support()


def _history(residuals) -> list[str]:
    return [f"{v:.2e}" for v in residuals]


def _failure_message(f: FailureReport) -> str:
    hint = "" if f.limit_point is None else (
        f"limit point at load factor {f.limit_point:.6g}: load control cannot pass it (the tangent turns "
        "singular along the load); use arc length (analysis method \"arc_length\"). ")
    return hint + (f"step {f.step} to load factor {f.trial_load_factor:.6g} failed ({f.reason}) after {f.attempts} "
            f"attempt(s); residual history of the last attempt {_history(f.residuals)}; stopped at the last "
            f"converged load factor {f.load_factor:.6g} (state kept)")


def _mixed(model, settings: NewtonSettings) -> bool:
    """Whether the run uses the mixed Newton iteration: asked for, under the "full" policy, and the model
    supports it (MITC6 bodies). A MITC7 body, a model without stresses and the "modified" policy run the
    displacement iteration: on a factorization kept from older iterates the mixed iteration converges worse
    than the displacement one (refresh ratio 0.5: hemisphere 104 factorizations against 77, end moment 1102
    against 139; docs/performance.md), on fresh ones far better (hemisphere 47)."""
    if not (settings.mixed and settings.policy == "full"):
        return False
    mixed = capabilities(model).mixed_iteration
    return mixed is not None and bool(mixed.supports_mixed_iteration)


def _with_stresses(model, state, settings: NewtonSettings):
    """The start of a step: under the mixed iteration, the state with the stresses of its strains."""
    return model.with_stresses(state) if _mixed(model, settings) else state


ARC_LENGTH_OPTIONS = ("max_steps", "min_increment_ratio", "max_increment_ratio", "desired_iterations")


def check_arc_length_options(**options) -> dict:
    """Check the step-length controls of :func:`arc_length` (``ARC_LENGTH_OPTIONS``; a scene's
    ``[analysis]`` keys of the same names) and return them; a ValueError names the first bad one."""
    for name, value in options.items():
        integer = name in ("max_steps", "desired_iterations")
        if name not in ARC_LENGTH_OPTIONS:
            raise ValueError(f"unknown arc-length option {name!r}; options: {', '.join(ARC_LENGTH_OPTIONS)}")
        if integer and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1):
            raise ValueError(f"arc-length {name} must be an integer >= 1, got {value!r}")
        if not integer and (isinstance(value, bool) or not isinstance(value, (int, float))
                            or not np.isfinite(value)):
            raise ValueError(f"arc-length {name} must be a finite number, got {value!r}")
        if name == "min_increment_ratio" and not 0 < value < 1:
            raise ValueError(f"arc-length min_increment_ratio must lie in (0, 1), got {value!r}")
        if name == "max_increment_ratio" and not value >= 1:
            raise ValueError(f"arc-length max_increment_ratio must be >= 1, got {value!r}")
    return options


def _scaled_size(model, dq: np.ndarray) -> float:
    """max |dq_i / scale_i|: a correction in units of the model size (translations) and radians."""
    return float(np.max(np.abs(dq / model.dof_scale)))


def _scaled_norm(model, dq: np.ndarray) -> float:
    """||dq / scale||: the length of an increment in units of the model size (translations) and radians."""
    return float(np.linalg.norm(dq / model.dof_scale))


def _arc_tolerance(settings: NewtonSettings, r: np.ndarray, f: np.ndarray, trial_lam: float, lam: float,
                   scale) -> float:
    """The arc-length corrector's force tolerance, relative to the model's own forces (never an absolute
    number): the external load of the step (at its start and at the iterate) and the iterate's internal
    forces f_int = r + lam f, in the norm weighted by the DoF scale (:func:`integrators.newton.work_norm`)."""
    load = max(abs(trial_lam), abs(lam)) * work_norm(f, scale)
    return settings.rtol * max(load, work_norm(r + trial_lam * f, scale))


def _arc_correction(solver: LinearSolver, r: np.ndarray, f: np.ndarray, Dq: np.ndarray, dl: float,
                    scale) -> tuple[np.ndarray, float]:
    """Crisfield's corrector on the factorization held: dq = a + x b with K a = -r, K b = f, and x the
    root of ||(Dq + dq) / scale||^2 = dl^2 that keeps the step closest to its direction (the closest point
    if the constraint has no root); returns (dq, x). The arc is measured in units of the model size
    (translations) and radians (``scale``, the DoF scale): the same path in any units."""
    a = solver.solve(-r)
    b = solver.solve(f)
    u, bs, Ds = (Dq + a) / scale, b / scale, Dq / scale
    c2, c1, c0 = bs @ bs, 2 * u @ bs, u @ u - dl * dl
    disc = c1 * c1 - 4 * c2 * c0
    if disc < 0:  # no intersection: take the closest point
        x = -c1 / (2 * c2)
    else:
        roots = [(-c1 + s * np.sqrt(disc)) / (2 * c2) for s in (1.0, -1.0)]
        x = max(roots, key=lambda z: (Ds @ (u + z * bs)))
    return a + x * b, float(x)


def _at_round_off_floor(model, solver: LinearSolver, r: np.ndarray, f: np.ndarray, Dq: np.ndarray, dl: float,
                        settings: NewtonSettings) -> bool:
    """Whether the corrector's next correction, on the factorization held (computed within lazy_tangent of
    the iterate), is below ``increment_tol``: the residual is then at its round-off floor, which on a thin
    shell can lie above the force tolerance (the arc-length twin of Newton's test)."""
    try:
        dq, _ = _arc_correction(solver, r, f, Dq, dl, model.dof_scale)
    except (SingularMatrixError, FloatingPointError):
        return False
    return _scaled_size(model, dq) <= settings.increment_tol


def _load_compliance(model, state, lam: float) -> float:
    """c = f . K^-1 f at an equilibrium (f paired with the increment by virtual work, ``model.conjugate``):
    the compliance of the load path, dW/dlam per unit load. It grows without bound at a limit point,
    where the tangent turns singular along the load, and changes sign beyond it (at a bifurcation, where the
    buckling mode is orthogonal to the load, it stays bounded)."""
    if isinstance(state, StressedState) and state.stress is not None:
        state = dataclasses.replace(state, stress=None)   # the tangent itself, not a mixed iteration matrix
    _, K = model.residual_and_tangent(state, lam)
    solver = LinearSolver()
    solver.factorize(K)
    f = model.external_force(state)
    v = solver.solve(f)
    return float(model.conjugate(state, v) @ f)


def stability_matrix(model, state, lam: float):
    """The symmetric tangent A and the load g in the same coordinates, at a converged state.

    The model's tangent K = dr/dq pairs force rows with increment columns that are not always the virtual
    work conjugates of the rows (a shell's rows are global force components, its columns local nodal
    increments); ``model.conjugate_matrix(state)`` (optional) is the map T with w = T dq the increment
    paired with the rows, so that T^T K is the second variation of the energy, symmetric at an equilibrium
    under conservative loads. Its small skew part (moment residuals of unconstrained drilling components,
    follower loads) is dropped: A = sym(T^T K), g = T^T f. The stresses of a mixed iteration are dropped
    first (the tangent of the state itself).
    """
    if isinstance(state, StressedState) and state.stress is not None:
        state = dataclasses.replace(state, stress=None)
    _, K = model.residual_and_tangent(state, lam)
    f = model.external_force(state)
    conjugate = capabilities(model).conjugate_matrix
    if conjugate is not None:
        T = conjugate.conjugate_matrix(state)
        K, f = T.T @ K, T.T @ f
    return (0.5 * (K + K.T)).tocsc(), f


def stability(model, state, lam: float) -> tuple[int | None, float]:
    """The number of negative eigenvalues of the tangent at a converged state, by Sylvester's law on the
    symmetric LDL^T factorization of :func:`stability_matrix` (:func:`integrators.linear.inertia`), and the
    load compliance g . A^-1 g on the same factorization (it changes sign at a limit point, not at a
    bifurcation). (None, nan) if the state or the tangent is not finite or a pivot is exactly zero."""
    try:
        A, g = stability_matrix(model, state, lam)
        factors = inertia(A)
        return factors.negative, float(g @ factors.solve(g))
    except (FloatingPointError, SingularMatrixError):
        return None, float("nan")


def critical_points(records: list[StepRecord]) -> list[CriticalPoint]:
    """The critical points marked on a run's step records (``StepRecord.critical``)."""
    return [rec.critical for rec in records if rec.critical is not None]


class _StabilityTracker:
    """Counts the negative eigenvalues at every converged state (:func:`stability`) and marks the critical
    points between consecutive states: where the count changes, a limit point if the load compliance
    changed sign with it, else a bifurcation (:class:`CriticalPoint`)."""

    def __init__(self, model, state, lam: float, enabled: bool):
        self.model, self.enabled = model, enabled
        self.lam, (self.count, self.compliance) = lam, (stability(model, state, lam) if enabled
                                                        else (None, float("nan")))

    def record(self, step: int, state, lam: float, iterations: int, residuals, wall_time: float) -> StepRecord:
        if not self.enabled:
            return StepRecord(step, lam, iterations, residuals, wall_time)
        count, compliance = stability(self.model, state, lam)
        critical = None
        if count is not None and self.count is not None and count != self.count:
            turned = np.sign(compliance) != np.sign(self.compliance)
            critical = CriticalPoint("limit point" if turned else "bifurcation", step, self.lam, lam,
                                     self.count, count)
        self.lam, self.count, self.compliance = lam, count, compliance
        return StepRecord(step, lam, iterations, residuals, wall_time, count, critical, compliance)


def _limit_point(model, previous, last, trial: float) -> float | None:
    """The load factor of a limit point that stops load control in the step from ``last`` to ``trial``, or
    None if the failure has another cause.

    ``previous`` and ``last`` are the last two converged (state, load factor). Near a limit point lam_L the
    path is lam_L - lam ~ s^2 along its arc length s, so the compliance c = f . K^-1 f grows like
    (lam_L - lam)^(-1/2): 1 / c^2 falls linearly to 0 at lam_L. Extrapolated from the two points, a limit
    point is reported if it lies before the failed trial (one more step's length of slack for the
    extrapolation).
    """
    (q0, lam0), (q1, lam1) = previous, last
    try:
        c0, c1 = _load_compliance(model, q0, lam0), _load_compliance(model, q1, lam1)
    except (FloatingPointError, SingularMatrixError):
        return None
    if not (c1 > c0 > 0 and lam1 > lam0):
        return None
    g0, g1 = 1.0 / c0**2, 1.0 / c1**2
    lam_limit = lam1 + (lam1 - lam0) * g1 / (g0 - g1)
    return lam_limit if lam_limit <= trial + (trial - lam1) else None


def load_control(model: StaticProblem, load_factors=None, *, n_steps: int = 10, settings: NewtonSettings | None = None,
                 min_step: float = 1e-4, max_step: float | None = None, adaptive: bool = True,
                 on_step: Callable | None = None, state=None, predictor: str = "tangent",
                 grow_iterations: int | None = None, load_factor: float = 0.0,
                 check_stability: bool = True) -> StaticResult:
    """Follow the path by prescribing the load factor.

    Parameters
    ----------
    load_factors : increasing load levels to reach exactly (default: n_steps equal steps to 1)
    adaptive : between the prescribed levels, grow the step (by 1.5) after easy convergence and halve it
        after a failure, down to ``min_step`` (fraction of the total load). Easy: at most
        ``grow_iterations`` Newton iterations on a fresh tangent (under the "modified" policy: iterations);
        None: half of ``settings.max_iterations``, at least 4. A thin shell takes 5-12 iterations per step
        almost whatever its size, so that growing only after <= 4 iterations (the rule until 2026-12) kept
        the slit plate at its first step, 0.025, where its levels are 0.05 apart.
    on_step : called as on_step(record, state) after each converged step (outputs hang off here)
    state, load_factor : the start: a converged state and its load factor (a restart; default the
        initial state at 0); ``load_factors`` then lists the levels beyond it
    predictor : "tangent" (default): each step starts from the last converged state, so that the first
        Newton correction is the tangent predictor; "secant": it starts from that state moved on by the
        previous step's increment (the sum of its Newton corrections, scaled by the ratio of the load
        steps, at most ``MAX_EXTRAPOLATION``); if Newton fails from there, the step is retried from the
        converged state before any cut-back. On the thin-shell benchmarks the secant start costs more
        iterations, not fewer (docs/performance.md), which is why it is not the default.

    Under the "full" policy a step starts on the factorization left by the previous step when that was
    computed within ``settings.lazy_tangent`` of the converged state (the last iterates of a converged
    step): the first correction is then the tangent predictor to a relative O(lazy_tangent), for a
    tangent that does not depend on the load factor (dead forces), and a modified-Newton step otherwise.

    A run that stops at a limit point says so (``FailureReport.limit_point``, :func:`_limit_point`): "limit
    point at load factor X: ...; use arc length".

    check_stability : count the negative eigenvalues of the tangent at every converged state and mark the
        limit and bifurcation points passed (``StepRecord.negative_eigenvalues``, ``StepRecord.critical``,
        ``StaticResult.critical_points``; :func:`stability`): one more tangent and symmetric factorization
        per step (docs/stability.md)
    """
    settings = settings or NewtonSettings()
    targets = np.linspace(0, 1, n_steps + 1)[1:] if load_factors is None else np.asarray(load_factors, float)
    if targets.ndim != 1 or targets.size == 0 or not np.all(np.isfinite(targets)) or np.any(np.diff(targets) <= 0) \
            or targets[0] < 0:
        raise ValueError(f"load factors must be finite, non-negative and increasing, got {targets!r}")
    if not (np.isfinite(min_step) and min_step > 0):
        raise ValueError(f"min_step must be positive, got {min_step!r}")
    if predictor not in ("tangent", "secant"):
        raise ValueError(f"predictor must be 'tangent' or 'secant', got {predictor!r}")
    if grow_iterations is None:
        grow_iterations = max(4, settings.max_iterations // 2)
    elif isinstance(grow_iterations, bool) or not isinstance(grow_iterations, int) or grow_iterations < 0:
        raise ValueError(f"grow_iterations must be an integer >= 0 or None, got {grow_iterations!r}")
    _check_support(model)
    state = model.initial_state() if state is None else state
    solver, stats = LinearSolver(), NewtonStats(iteration="mixed" if _mixed(model, settings) else "displacement")
    records: list[StepRecord] = []
    lam, t0, cutbacks = float(load_factor), time.perf_counter(), 0
    if lam != 0.0 and not targets[0] > lam:
        raise ValueError(f"load factors must lie beyond the start {lam!r}, got {targets[0]!r}")
    tracker = _StabilityTracker(model, state, lam, check_stability)
    first_step = targets[0] - lam
    step = first_step
    max_step = max_step or (targets[-1] - 0.0)
    attempts = 0
    held_lag = float("inf")            # distance of the state from the factorization held (scaled increments)
    prev_increment, prev_dlam, use_predictor = None, 0.0, predictor == "secant"
    previous = None                    # the converged (state, load factor) before the last one
    for target in targets:
        while lam < target - 1e-14:
            # land exactly on the prescribed level (no sliver step, no level missed by round-off)
            trial = target if lam + step >= target - 1e-12 * max(1.0, abs(target)) else lam + step
            attempts += 1
            early = ""
            try:
                load, reference = _step_load(model, state, trial)
            except FloatingPointError as exc:
                load, reference, early = None, np.nan, str(exc)
            start, shift = _with_stresses(model, state, settings), None
            if np.isfinite(reference) and use_predictor and prev_increment is not None:
                shift = min((trial - lam) / prev_dlam, MAX_EXTRAPOLATION) * prev_increment
                try:
                    start = model.update(start, shift)
                except FloatingPointError:
                    start, shift = _with_stresses(model, state, settings), None
            if not np.isfinite(reference):
                out = None
            else:
                # modified Newton keeps the factorization of an earlier step until convergence slows, full
                # Newton the one from the last iterates of the previous step; a retry after a failure
                # starts from a fresh tangent
                reuse = attempts == 1 and shift is None and (settings.policy == "modified"
                                                             or held_lag <= settings.lazy_tangent)
                new_state, out = newton_solve(
                    start, lambda q: model.residual(q, trial), lambda q: model.residual_and_tangent(q, trial),
                    model.update, reference, settings, solver, stats, fresh_tangent=not reuse,
                    dof_scale=model.dof_scale, conjugate=model.conjugate, held_lag=held_lag, load=load,
                    min_iterations=1)
            held_lag = float("inf")
            if out is None or not out.converged:
                if shift is not None:
                    # the predicted start failed: retry the same load from the last converged state
                    use_predictor = False
                    continue
                if out is None:
                    reason = early or "non-finite external load (the reference force is not finite)"
                    residuals, non_finite, at_start = [], True, True
                else:
                    reason, residuals, non_finite = out.reason, out.residuals, out.non_finite
                    at_start = out.non_finite and out.iterations == 0
                cutbacks += 1
                step = (trial - lam) / 2
                # non-finite values in the last converged state or the loads: no cut-back can help
                if step < min_step or not adaptive or at_start:
                    if at_start:
                        reason += "; non-finite at the start of the step, from the last converged state: stopped at once"
                    limit = None
                    if not at_start and previous is not None:
                        limit = _limit_point(model, previous, (state, lam), trial)
                    failure = FailureReport(len(records) + 1, lam, trial, list(residuals), reason, attempts,
                                            non_finite, limit)
                    return StaticResult(state, lam, records, stats, False, _failure_message(failure),
                                        time.perf_counter() - t0, cutbacks, failure)
                continue
            attempts, held_lag = 0, out.factorization_lag
            if predictor == "secant":
                increment = out.increment
                if shift is not None:
                    increment = shift if increment is None else shift + increment
                prev_increment, prev_dlam, use_predictor = increment, trial - lam, True
            previous = (state, lam)
            state, lam = new_state, trial
            rec = tracker.record(len(records) + 1, state, lam, out.iterations, out.residuals,
                                 time.perf_counter() - t0)
            records.append(rec)
            if on_step is not None:
                on_step(rec, state)
            # the effort of the step: its Newton iterations (under the "full" policy those on a fresh
            # tangent: the chord steps near convergence cost a residual and a solve each)
            effort = out.iterations if settings.policy == "modified" else out.factorizations
            if adaptive and effort <= grow_iterations:
                step = min(step * 1.5, max_step)
    return StaticResult(state, lam, records, stats, True, "completed", time.perf_counter() - t0, cutbacks)


def arc_length(model: StaticProblem, *, lam_max: float = 1.0, initial_increment: float = 0.05, max_steps: int = 500,
               settings: NewtonSettings | None = None, min_increment_ratio: float = 1e-3,
               max_increment_ratio: float = 25.0, desired_iterations: int = 5,
               max_load_increment: float | None = None,
               on_step: Callable | None = None, state=None, check_stability: bool = True,
               continuation: ArcLengthState | None = None) -> StaticResult:
    """Crisfield's cylindrical arc-length method: ||Delta q / scale|| = Delta l in each step.

    The first step's arc length follows from a load increment ``initial_increment``. Each iteration solves
    K dq_r = -r and K dq_f = f_ext and picks the load correction from the quadratic constraint, taking the
    root closest to the previous direction (this follows snap-through and snap-back). The step length adapts
    to ``desired_iterations``, between ``min_increment_ratio`` (below it the run stops with a report) and
    ``max_increment_ratio`` times the first arc; ``max_load_increment`` caps the load-factor change of a step
    (a dense record of the path). The run ends when lam reaches ``lam_max`` (the last step is then solved
    under load control at exactly lam_max) or after ``max_steps`` steps (``ARC_LENGTH_OPTIONS``, all
    settable from a scene file).

    The arc is measured in units of the model size (translations) and radians (``model.dof_scale``), and the
    corrector stops on the tests of :func:`integrators.newton.newton_solve`: the force residual relative to
    the model's own forces, or a correction below ``settings.increment_tol`` -- the round-off floor, which
    on a thin shell lies above the force tolerance (tested on the factorization held before a new tangent
    is made, as in Newton).

    The predictor solves on the factorization left by the last iterates of the previous step when that was
    computed within ``settings.lazy_tangent`` of the converged state (else on a fresh tangent there), and an
    iterate within ``lazy_tangent`` of the last factorization is tested on its residual alone before a
    tangent is assembled. The converged point of a step is the intersection of the path with the arc, so a
    slightly different predictor moves it along the path only through the step-length control
    (``max_load_increment``): on the pulled cylinder the outputs at the reference levels changed by 7e-6 of
    their range against a fresh tangent for every predictor.

    ``check_stability`` as in :func:`load_control`: at a limit point the count of negative eigenvalues
    changes where the load factor turns.

    ``continuation`` (with ``state``, the converged state of that step) continues a path from a converged
    step (a restart): its load factor, next arc length, first arc length and the direction of its last step
    (:class:`ArcLengthState`, recorded with every step as ``StepRecord.continuation``); ``max_steps`` then
    counts the steps from there. The predictor of the first step is solved on a fresh tangent at the
    state, where the uninterrupted run may use the factorization of the last iterate: the converged point
    is again the intersection of the path with the arc, equal to the Newton tolerance.
    """
    settings = settings or NewtonSettings()
    if not (np.isfinite(lam_max) and lam_max > 0 and np.isfinite(initial_increment) and initial_increment > 0):
        raise ValueError(f"arc-length needs lam_max > 0 and initial_increment > 0, got {lam_max!r} and "
                         f"{initial_increment!r}")
    if max_load_increment is not None and not (np.isfinite(max_load_increment) and max_load_increment > 0):
        raise ValueError(f"arc-length max_load_increment must be > 0, got {max_load_increment!r}")
    check_arc_length_options(max_steps=max_steps, min_increment_ratio=min_increment_ratio,
                             max_increment_ratio=max_increment_ratio, desired_iterations=desired_iterations)
    _check_support(model)
    if continuation is not None and state is None:
        raise ValueError("an arc-length continuation needs the converged state of its step")
    state = model.initial_state() if state is None else state
    solver, stats = LinearSolver(), NewtonStats(iteration="mixed" if _mixed(model, settings) else "displacement")
    records: list[StepRecord] = []
    t0, lam, cutbacks, attempts = time.perf_counter(), 0.0, 0, 0
    if continuation is not None:
        lam = float(continuation.load_factor)
    tracker = _StabilityTracker(model, state, lam, check_stability)

    def stop(trial_lam, residuals, reason, non_finite=False):
        failure = FailureReport(len(records) + 1, lam, float(trial_lam), list(residuals), reason, attempts,
                                non_finite)
        return StaticResult(state, lam, records, stats, False, _failure_message(failure),
                            time.perf_counter() - t0, cutbacks, failure)

    if continuation is not None:
        if continuation.direction.shape != (len(model.dof_scale),):
            raise ValueError(f"arc-length continuation: its direction has {continuation.direction.size} "
                             f"components, the model {len(model.dof_scale)} DoFs")
        held_lag = float("inf")        # no factorization held: the first predictor on a fresh tangent
        dl, dl0 = float(continuation.arc_length), float(continuation.first_arc_length)
        prev_dir, prev_dlam_sign = continuation.direction.copy(), float(continuation.load_sign)
    else:
        try:
            r, K = model.residual_and_tangent(state, 0.0)
            stats.tangent_updates += 1
            stats.residual_evaluations += 1
            solver.factorize(K)
            stats.factorizations += 1
            held_lag = 0.0             # distance of the state from the factorization held (scaled increments)
            f0 = model.external_force(state)
            dq_f = solver.solve(f0)
        except FloatingPointError as exc:
            return stop(0.0, [], f"non-finite values in the initial state or loads: {exc}", True)
        if not np.any(f0):
            raise ValueError("arc-length needs a nonzero external load (the external force vector is zero)")
        dl = initial_increment * _scaled_norm(model, dq_f)    # arc lengths in units of the model size and radians
        dl0 = dl
        prev_dir = dq_f / model.dof_scale / _scaled_norm(model, dq_f)
        prev_dlam_sign = 1.0

    for _ in range(max_steps):
        attempts += 1
        # predictor along the tangent, in the direction of the previous step; the factorization left by the
        # last iterates of the previous step serves if it was computed within lazy_tangent of its end
        try:
            if not held_lag <= settings.lazy_tangent:
                r, K = model.residual_and_tangent(state, lam)
                stats.tangent_updates += 1
                stats.residual_evaluations += 1
                solver.factorize(K)
                stats.factorizations += 1
            dq_f = solver.solve(model.external_force(state))
        except FloatingPointError as exc:
            return stop(lam, [], f"non-finite values at the last converged state: {exc}; stopped at once", True)
        except SingularMatrixError as exc:
            return stop(lam, [], f"predictor: {exc}")
        sign = np.sign(dq_f / model.dof_scale @ prev_dir) or prev_dlam_sign
        dlam = sign * dl / _scaled_norm(model, dq_f)
        if max_load_increment is not None and abs(dlam) > max_load_increment:
            dl *= max_load_increment / abs(dlam)
            dlam = sign * max_load_increment
        Dq = dlam * dq_f
        trial = model.update(_with_stresses(model, state, settings), Dq)
        trial_lam = lam + dlam
        held_lag = float("inf")
        ok, residuals, it, reason, non_finite, lazy = False, [], 0, "", False, False
        for it in range(1, settings.max_iterations + 1):
            try:
                # near convergence (the last correction below lazy_tangent) the residual alone first
                if lazy:
                    r, K = model.residual(trial, trial_lam), None
                else:
                    r, K = model.residual_and_tangent(trial, trial_lam)
                    stats.tangent_updates += 1
                stats.residual_evaluations += 1
                f = model.external_force(trial)
            except FloatingPointError as exc:
                reason, non_finite = f"non-finite values at iteration {it}: {exc}", True
                break
            norm = work_norm(r, model.dof_scale)
            residuals.append(norm)
            if not np.isfinite(norm):
                reason, non_finite = f"non-finite residual at iteration {it}", True
                break
            if norm <= _arc_tolerance(settings, r, f, trial_lam, lam, model.dof_scale) and it > 1:
                ok = True
                break
            if K is None and _at_round_off_floor(model, solver, r, f, Dq, dl, settings):
                ok = True
                residuals.append(float("nan"))   # its correction, on the factorization held, is round-off
                break
            try:
                if K is None:
                    r, K = model.residual_and_tangent(trial, trial_lam)
                    stats.tangent_updates += 1
                    stats.residual_evaluations += 1
                solver.factorize(K)
                stats.factorizations += 1
                held_lag = 0.0
                dq, x = _arc_correction(solver, r, f, Dq, dl, model.dof_scale)
            except (SingularMatrixError, FloatingPointError) as exc:
                reason = str(exc)
                held_lag = float("inf")
                break
            trial = model.update(trial, dq)
            Dq = Dq + dq
            trial_lam += x
            stats.iterations += 1
            size = _scaled_size(model, dq)
            held_lag += size
            if size <= settings.increment_tol and it > 1:
                ok = True                                  # the round-off floor reached (as in Newton)
                residuals.append(float("nan"))
                break
            lazy = size <= settings.lazy_tangent
        else:
            reason = f"no convergence in {settings.max_iterations} iterations"
        if not ok:
            held_lag = float("inf")
            cutbacks += 1
            dl /= 2
            if dl < min_increment_ratio * dl0:
                return stop(trial_lam, residuals, f"{reason}; arc length cut back below "
                            f"{min_increment_ratio:g} of the first", non_finite)
            continue
        if trial_lam >= lam_max:
            # finish exactly at lam_max under load control from the last converged state
            load, reference = _step_load(model, trial, lam_max)
            state_end, out = newton_solve(
                trial, lambda q: model.residual(q, lam_max), lambda q: model.residual_and_tangent(q, lam_max),
                model.update, reference, settings, solver, stats,
                fresh_tangent=not held_lag <= settings.lazy_tangent, dof_scale=model.dof_scale,
                conjugate=model.conjugate, held_lag=held_lag, load=load,
                min_iterations=int(trial_lam != lam_max))
            if out.converged:
                rec = tracker.record(len(records) + 1, state_end, lam_max, out.iterations, out.residuals,
                                     time.perf_counter() - t0)
                rec.continuation = ArcLengthState(lam_max, dl, dl0, prev_dir.copy(), prev_dlam_sign)
                records.append(rec)
                if on_step is not None:
                    on_step(rec, state_end)
                return StaticResult(state_end, lam_max, records, stats, True, "completed",
                                    time.perf_counter() - t0, cutbacks)
            dl /= 2
            cutbacks += 1
            held_lag = float("inf")
            if dl < min_increment_ratio * dl0:
                return stop(lam_max, out.residuals, f"final step to lam_max: {out.reason}", out.non_finite)
            continue
        attempts = 0
        prev_dir = Dq / model.dof_scale / _scaled_norm(model, Dq)
        prev_dlam_sign = np.sign(trial_lam - lam) or prev_dlam_sign
        state, lam = trial, trial_lam
        rec = tracker.record(len(records) + 1, state, lam, it, residuals, time.perf_counter() - t0)
        dl *= float(np.clip(np.sqrt(desired_iterations / max(it, 1)), 0.5, 2.0))
        dl = min(dl, max_increment_ratio * dl0)
        rec.continuation = ArcLengthState(lam, dl, dl0, prev_dir.copy(), prev_dlam_sign)
        records.append(rec)
        if on_step is not None:
            on_step(rec, state)
    return StaticResult(state, lam, records, stats, False,
                        f"arc-length reached max_steps={max_steps} at load factor {lam:.6g}",
                        time.perf_counter() - t0, cutbacks)
