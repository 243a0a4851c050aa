"""The Newton loop of the static solvers, with the tangent-reuse policy and its counters.

The tangent of the SE(3) local-frame formulation does not change under rigid motion, so a factorized
tangent often stays good over several iterations and steps. Policy:
- "full": a new tangent and factorization every iteration (classical Newton), except near convergence:
  once the iterate lies within ``lazy_tangent`` of the state at which the factorization held was computed,
  the residual is evaluated alone first, convergence tested on it, and the factorization kept (chord
  steps) while the residual contracts by ``refresh_ratio`` (a chord step that does not is undone);
- "modified": keep the factorization while the residual contracts fast enough (ratio < ``refresh_ratio``);
  refresh it otherwise, and always when an iteration diverges.
Both stop on the same tests (force residual, or an increment below ``increment_tol``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from integrators.linear import LinearSolver, SingularMatrixError


@dataclass
class NewtonSettings:
    """Settings of the Newton iteration of the static solvers: the convergence tests, the tangent policy
    ("full" or "modified"), line search, the lazy tangent near convergence and the mixed iteration (each
    field is described where it is declared)."""

    rtol: float = 1e-8            # ||r|| <= rtol * reference force (the model's own: no absolute floor)
    increment_tol: float = 1e-11  # or: max |dq_i / scale_i| <= increment_tol (round-off floor reached)
    max_iterations: int = 25
    policy: str = "full"          # "full" or "modified"
    refresh_ratio: float = 0.25   # modified Newton: refresh when ||r_k+1|| > ratio ||r_k||
    divergence_factor: float = 1e6
    line_search: bool = False     # Crisfield's line search on s(a) = dq . r(q o exp(a dq))
    line_search_ratio: float = 0.5
    line_search_max: int = 6
    # "full" policy: while the iterate lies within lazy_tangent (the scaled corrections, summed, as for
    # increment_tol) of the state of the factorization held, the residual is evaluated alone first and tested
    # (force test; increment test with that factorization), and chord steps are taken on that factorization
    # while the residual contracts by refresh_ratio. 0: classical Newton (a tangent every iteration).
    lazy_tangent: float = 1e-4
    # the mixed Newton iteration (the static solvers, "full" policy; MITC6 elements): the stress resultants at
    # the Gauss points are iterated as unknowns of their own, condensed point by point, so that the geometric
    # stiffness of an iterate carries the linearized stresses C (eps + B dq) instead of those of its
    # strains (Magisano, Leonetti & Garcea 2017). Same equations, same converged states; no spurious
    # membrane stresses of a thin shell's bending predictor in the next tangent.
    mixed: bool = True

    def __post_init__(self) -> None:
        if self.policy not in ("full", "modified"):
            raise ValueError(f"Newton policy must be 'full' or 'modified', got {self.policy!r}")
        if not 0 < self.rtol < 1:
            raise ValueError(f"Newton rtol must lie in (0, 1) (a fraction of the reference force), "
                             f"got {self.rtol!r}")
        if not self.max_iterations >= 1:
            raise ValueError(f"Newton max_iterations must be >= 1, got {self.max_iterations!r}")
        if not isinstance(self.mixed, bool):
            raise ValueError(f"Newton mixed must be true or false, got {self.mixed!r}")
        if not (self.lazy_tangent >= 0):
            raise ValueError(f"Newton lazy_tangent must be >= 0, got {self.lazy_tangent!r}")


@dataclass
class NewtonStats:
    """Counters over a whole run."""

    iterations: int = 0
    tangent_updates: int = 0
    factorizations: int = 0
    residual_evaluations: int = 0
    iteration: str = "displacement"   # or "mixed": the Newton iteration the run used (NewtonSettings.mixed)


@dataclass
class NewtonOutcome:
    converged: bool
    iterations: int
    residuals: list[float] = field(default_factory=list)
    reason: str = ""
    non_finite: bool = False      # stopped on a non-finite residual or state (at ``iterations``)
    # how far the returned state lies from the state at which the solver's factorization was computed (the
    # max-norms of the scaled corrections since, summed): 0 if computed there, inf if unknown
    factorization_lag: float = float("inf")
    increment: object = None      # the sum of the corrections applied (None if none was)
    factorizations: int = 0       # made in this solve


def work_norm(r: np.ndarray, dof_scale=1.0) -> float:
    """||r * dof_scale||: a residual (or force) weighted by the DoF scale -- forces times the model size,
    moments times 1 rad -- so that forces and moments add up in one unit (the virtual work per unit scaled
    DoF). Every force test of the static solvers is in this norm: a model in other units (lengths times s,
    forces times s^2, moments times s^3) has the same relative residuals."""
    return float(np.linalg.norm(r * dof_scale))


def _first_non_finite(r: np.ndarray) -> str:
    bad = np.flatnonzero(~np.isfinite(r))
    return f"first at equation {int(bad[0])}" if bad.size else "its norm overflows"


def newton_solve(state, residual: Callable, residual_and_tangent: Callable, update: Callable,
                 reference_norm: float, settings: NewtonSettings, solver: LinearSolver,
                 stats: NewtonStats, fresh_tangent: bool = True, dof_scale=1.0,
                 conjugate: Callable | None = None, held_lag: float = float("inf"),
                 load: np.ndarray | None = None, min_iterations: int = 0):
    """Solve r(q) = 0 from ``state``; returns (state, outcome). Never returns a non-finite state.

    Converged when ||r|| <= rtol * reference (norms weighted by ``dof_scale``, :func:`work_norm`), or when
    an increment scaled by ``dof_scale`` (a length for translations, 1 for rotations) is below
    ``increment_tol``: the residual has then reached its round-off floor, which for thin shells (membrane
    stiffness >> bending load) can lie above rtol. The reference is the model's own force scale, never an
    absolute number: ``reference_norm`` (the weighted norm of the step's external load) or, with ``load``
    (that external load vector, r = f_int - load), the norm of the iterate's internal forces f_int = r + load
    if larger. So the tests are scale-free: a model in other units (forces, lengths) takes the same
    iterations. A step whose load changed needs at least ``min_iterations`` corrections (1: never
    "converged" without moving).
    ``solver`` may hold a factorization from earlier iterations or steps: it serves the first iteration
    unless ``fresh_tangent`` (the static solvers pass False under the "full" policy only when it was
    computed within ``lazy_tangent`` of the start: the last iterates of the previous step); ``held_lag`` is
    that distance (the scaled corrections since, summed; reported back in ``factorization_lag``).

    Near convergence -- the iterate within ``lazy_tangent`` of the state at which the factorization held was
    computed -- the "full" policy evaluates the residual alone first (as the "modified" policy always does).
    Converged if it passes the force test, or if the correction it gives with the factorization held passes
    the increment test (that correction, below ``increment_tol``, is round-off and is not applied). If it
    has not converged but contracted by ``refresh_ratio``, the next step is a chord step on the same
    factorization; otherwise a tangent is assembled and factorized (a chord step that did not contract is
    undone first: the fresh tangent is taken where classical Newton takes it). The tests are those of
    classical Newton: the increments of the held and of a fresh tangent differ by a relative
    O(lazy_tangent), and a borderline case falls through to the fresh tangent. This saves the tangent and
    factorization that classical Newton spends on the last iterate (the one at the round-off floor, or
    within the force tolerance), and those of the last quadratic steps, which a chord step does as well.

    Line search (Crisfield): s(a) = w . r(q o exp(a dq)) with w = conjugate(q, dq) the increment paired with
    the residual by virtual work (s is the derivative of the energy along the step for conservative
    loads). The full step is kept when |s(1)| <= ratio |s(0)|; otherwise a is found by secant steps on s.
    It works on s rather than on ||r|| because after a bending step the membrane residual of a thin shell
    is huge but nearly orthogonal to the step, which a residual-norm line search would wrongly reject.
    (Measured on the load-control benchmarks it still costs 1.7-26x the iterations of plain Newton,
    docs/performance.md: it is off by default.)
    """
    tol = settings.rtol * reference_norm
    outcome = NewtonOutcome(False, 0)
    need_tangent = fresh_tangent or not solver.ready
    lag = held_lag
    r = None
    chord_base = None        # full policy: (state, lag, increment) a chord step started from, to undo it
    reevaluated = False      # the iterate is one whose residual is already in the history
    for it in range(settings.max_iterations + 1):
        try:
            if need_tangent:
                r, K = residual_and_tangent(state)
                stats.tangent_updates += 1
                stats.residual_evaluations += 1
            elif r is None:
                r = residual(state)
                stats.residual_evaluations += 1
        except FloatingPointError as exc:
            outcome.reason = f"non-finite values at iteration {it}: {exc}"
            outcome.non_finite, outcome.iterations = True, it
            return state, outcome
        norm = work_norm(r, dof_scale)
        if not np.isfinite(norm):
            outcome.reason = f"non-finite residual at iteration {it} ({_first_non_finite(r)})"
            outcome.non_finite, outcome.iterations = True, it
            return state, outcome
        if not reevaluated:
            outcome.residuals.append(norm)
        reevaluated = False
        if load is not None:
            tol = settings.rtol * max(reference_norm, work_norm(r + load, dof_scale))
        if norm <= tol and it >= min_iterations:
            outcome.converged = True
            outcome.iterations = it
            outcome.factorization_lag = lag
            return state, outcome
        if it == settings.max_iterations:
            outcome.reason = f"no convergence in {settings.max_iterations} iterations (|r| = {norm:.3e}, tol {tol:.1e})"
            outcome.iterations = it
            return state, outcome
        # Diverging: still growing, and far above the smallest residual since the first update. The jump of
        # the first update itself is not judged: on a thin shell a bending step leaves a membrane residual
        # ~ (L/h)^2 times the load, which the next iterations remove (a legitimate jump of 1e9 at h/L = 1e-4).
        finite_res = [v for v in outcome.residuals if np.isfinite(v)]
        if len(finite_res) > 2 and norm > finite_res[-2] and \
                norm > settings.divergence_factor * max(min(finite_res[1:-1]), tol):
            outcome.reason = (f"diverging (|r| grew from {min(finite_res[1:-1]):.3e} to {norm:.3e} in "
                              f"{len(finite_res) - 2} iterations)")
            outcome.iterations = it
            return state, outcome
        if need_tangent:
            try:
                solver.factorize(K)
            except SingularMatrixError as exc:
                outcome.reason = str(exc)
                return state, outcome
            stats.factorizations += 1
            outcome.factorizations += 1
            lag = 0.0
        try:
            dq = solver.solve(-r)
        except SingularMatrixError as exc:
            outcome.reason = str(exc)
            return state, outcome
        if settings.line_search:
            searched = _line_search(state, dq, r, residual, update, conjugate, settings, stats)
        else:
            searched = _Searched(update(state, dq), None, 1.0)
        state, r_new, a = searched.state, searched.residual, searched.step
        stats.iterations += 1
        outcome.iterations = it + 1
        outcome.increment = a * dq if outcome.increment is None else outcome.increment + a * dq
        size = float(np.max(np.abs(dq / dof_scale)))
        lag += abs(a) * size
        if size <= settings.increment_tol and len(outcome.residuals) > 1:
            outcome.converged = True
            outcome.residuals.append(float("nan"))  # not evaluated: converged on the increment
            outcome.factorization_lag = lag
            return state, outcome
        # decide on the tangent for the next iteration
        base, chord_base = chord_base, None
        lazy = settings.policy == "modified" or lag <= settings.lazy_tangent or base is not None
        if not lazy:
            need_tangent = True
            continue
        if r_new is None:
            try:
                r_new = residual(state)
            except FloatingPointError:
                r_new = None
            stats.residual_evaluations += 1
        finite = r_new is not None and bool(np.all(np.isfinite(r_new)))
        norm_new = work_norm(r_new, dof_scale) if finite else float("inf")
        # modified Newton, and full Newton on a factorization computed within lazy_tangent: keep it while
        # the residual contracts (a converged residual is reported by the next iteration)
        need_tangent = not (norm_new <= tol or norm_new < settings.refresh_ratio * norm)
        if need_tangent and finite:
            # the round-off floor, tested with the factorization held before a new one is made
            try:
                dq_held = solver.solve(-r_new)
            except SingularMatrixError:
                dq_held = None
            if dq_held is not None and float(np.max(np.abs(dq_held / dof_scale))) <= settings.increment_tol:
                outcome.converged = True
                outcome.residuals += [norm_new, float("nan")]   # |r| at the floor; its correction is round-off
                outcome.factorization_lag = lag
                return state, outcome
        if need_tangent and base is not None:
            # a chord step that did not contract is undone: a fresh tangent at the iterate it started from,
            # as classical Newton would have taken there
            state, lag, outcome.increment = base
            r, reevaluated = None, True
            continue
        if not finite:
            need_tangent, r = True, None   # the next iteration evaluates (and reports) it in full
            continue
        if not need_tangent and settings.policy == "full" and norm_new > tol:
            chord_base = (state, lag, outcome.increment)
        r = None if need_tangent else r_new
    return state, outcome


@dataclass(frozen=True)
class _Searched:
    """The end of a line search: the new state q o exp(a dq), its residual (None if not evaluated or not finite
    enough to use) and the step a."""

    state: object
    residual: np.ndarray | None
    step: float


def _line_search(state, dq, r0, residual, update, conjugate, settings: NewtonSettings,
                 stats: NewtonStats) -> _Searched:
    """Secant line search on s(a) = w . r(q o exp(a dq)); returns the new state, its residual and a."""
    w = dq if conjugate is None else conjugate(state, dq)
    s0 = float(w @ r0)
    trial = update(state, dq)
    try:
        r1 = residual(trial)
    except FloatingPointError:
        r1 = None
    stats.residual_evaluations += 1
    if r1 is None or not np.all(np.isfinite(r1)):
        s1 = np.inf
    else:
        s1 = float(w @ r1)
    if s0 >= 0 or abs(s1) <= settings.line_search_ratio * abs(s0):
        return _Searched(trial, r1, 1.0)
    a_lo, s_lo, a_hi, s_hi = 0.0, s0, 1.0, s1
    best = (abs(s1), 1.0, trial, r1)
    for _ in range(settings.line_search_max):
        if np.isfinite(s_hi) and s_hi != s_lo:
            a = a_hi - s_hi * (a_hi - a_lo) / (s_hi - s_lo)
            a = float(np.clip(a, a_lo + 0.1 * (a_hi - a_lo), a_hi - 0.1 * (a_hi - a_lo)))
        else:
            a = 0.5 * (a_lo + a_hi)
        trial = update(state, a * dq)
        try:
            ra = residual(trial)
        except FloatingPointError:
            ra = None
        stats.residual_evaluations += 1
        sa = float(w @ ra) if ra is not None and np.all(np.isfinite(ra)) else np.inf
        if abs(sa) < best[0]:
            best = (abs(sa), a, trial, ra)
        if abs(sa) <= settings.line_search_ratio * abs(s0):
            return _Searched(trial, ra, a)
        if sa < 0:
            a_lo, s_lo = a, sa
        else:
            a_hi, s_hi = a, sa
    return _Searched(best[2], best[3], best[1])
