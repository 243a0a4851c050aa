"""Lie-group generalized-alpha time integration (Bruls, Cardona & Arnold 2012).

Reference: O. Bruls, A. Cardona, M. Arnold, "Lie group generalized-alpha time integration of constrained
flexible multibody systems", Mechanism and Machine Theory 48 (2012) 121-137 -- "BCA" below. (The
paper itself was not at hand while writing this module: the formulas below are cited by content, not by
equation number.)

Equations of motion M vdot + g(q, v, t) = 0 on a Lie group, velocities v in the Lie algebra (here
R^3 x SO(3) per node, see :mod:`flexbody.dynamics`). One step (BCA, the integration formulas)::

    q_{n+1} = q_n o exp(h dq_n),   dq_n = v_n + h (1/2 - beta) a_n + h beta a_{n+1}
    v_{n+1} = v_n + h (1 - gamma) a_n + h gamma a_{n+1}
    (1 - alpha_m) a_{n+1} + alpha_m a_n = (1 - alpha_f) vdot_{n+1} + alpha_f vdot_n

with a the pseudo-acceleration (a_0 = vdot_0). The unknown is the increment x = h dq_n; a Newton correction
Dx gives D vdot = beta' Dx, D v = gamma' Dx with (BCA, linearisation of the step)

    beta' = (1 - alpha_m) / (h^2 beta (1 - alpha_f)),   gamma' = gamma / (h beta)

and the iteration matrix is S = M beta' + C_t gamma' + K_t T(h dq) (BCA, iteration matrix). Here M is constant,
the only velocity-dependent force is the optional damping (no gyroscopic forces in the R^3 x SO(3)
coordinates of the shell, see :mod:`flexbody.shell.inertia`): C_t = ``dyn.damping_matrix(q)`` (Rayleigh:
a0 M + a1 K_m, the velocity derivative of the damping force; its derivative in q is left out), and T(h dq)
is approximated by the identity, both in the iteration matrix only; the residual r(q, v, vdot, t) is exact (q_{n+1} is always
recomputed as q_n o exp(x), v_{n+1} from the integration formulas). The approximations change the
convergence rate of the iterations, not their fixed point.

Observers: the integrator computes no energies, momenta nor dissipated work. Every accepted step (and the start)
is given to the run's observers (:class:`integrators.protocols.StepObserver`) as an
:class:`integrators.protocols.AcceptedStep`: time, step size, state, v, vdot, a, the Newton work and the step
counts, and whether it is an output step (every ``record_every``-th); the model's observers evaluate what they
need from it (for the shell: :class:`flexbody.energy.EnergyAccount`).

Convergence and tangent reuse: a weighted RMS norm of the correction,
||Dx||_w = sqrt(mean((Dx_i / (atol s_i + rtol |x_i|))^2)) with s_i the DoF scale (model size for
translations, 1 rad for rotations). With the contraction estimate theta_k = ||Dx_k|| / ||Dx_{k-1}|| the
iteration stops when eta_k ||Dx_k||_w <= 1, eta_k = theta_k / (1 - theta_k) (the error estimate of a
contracting iteration; Hairer & Wanner, Solving ODE II, IV.8). The contraction is always measured in the
step itself (at least two corrections): an estimate carried over from the previous step, as in RADAU5,
accepted unconverged iterates here when the previous step ended on a fresh matrix and this one starts on
an older one (measured: 17x larger angular-velocity error in the tumbling-plate test). The iteration
matrix and its factorization are kept across iterations and steps ("modified" policy) and refreshed when
theta_k > ``refresh_ratio`` or the iteration diverges; a step that fails with an old matrix is retried
once with a fresh one, and a step that fails under the "modified" policy once more with a fresh matrix at
every iteration (Newton's method).

Contraction floor (``contraction_floor``, default 0.1; 0: off). The ratio theta_k of two corrections measures the
contraction of the components that dominate them. With a kept matrix the predictor's error is mostly in stiff
components that the matrix resolves almost exactly (measured on the kicked hub annulus of docs/dynamics.md:
corrections 1e7, 1e5, 1e4, ... or, from a closer predictor, 1e6, 1e3 tolerance units), while the rest contracts
at 0.3-0.4 per iteration; the first ratio (1e-3) then accepts an iterate whose remaining error is hundreds of
tolerance units, and the converged answer depends on the predictor. With a floor theta_e = max(theta_k, floor)
the estimate assumes no better contraction than the floor for what is left. The default 0.1 accepts an iterate
whose correction is at most 9 tolerance units. Measured: once the kept matrix followed each node's patch
(``dyn.transfer``), it resolved the stiff part so well that the first ratio fell to 1e-2 and below, and without
a floor the swinging strip's energy drift grew from 2.9e-6 to 1.4e-5 at 2.0 iterations per step; with 0.1 it is
2.8e-6 at 2.47 iterations per step, with 0.3 (the refresh ratio: a kept matrix may contract that slowly before it
is refreshed) the same drift at 2.5; the kicked hub annulus takes 2.08 instead of 2.05 iterations per step
(docs/dynamics.md, "The kept matrix follows the surface"; earlier, before that transfer, 0.3 cost 1.6x the
iterations of no floor, "Spinning membranes at real scale").

Transient ratios of a kept matrix. A kept matrix is refreshed when theta_k > ``refresh_ratio``, unless the
geometric mean sqrt(theta_k theta_{k-1}) of its last two ratios (both measured with that matrix) is not: a
one-iteration transient, not slow convergence (the RADAU5 code of Hairer & Wanner estimates the contraction so from
its third correction on, THETA = SQRT(THQ*THQOLD)). The next error estimate then takes max(theta_{k+1}, theta_k):
what the transient left is not assumed to contract faster than it did. Measured on the kicked hub annulus of
docs/dynamics.md at h/R 1e-6 (4 x 32 cells, the turning frame), at the steps that refreshed: corrections like
1e5, 5e2, 4e2 (ratios 0.005, 0.7), the third concentrated on director rotations. The kept, transferred matrix M_B
was not stalling: at four such steps the spectral radius of its error map I - M_B^-1 S (S the fresh matrix) was
0.04-0.28, and the next kept correction would have been 26-121 times smaller than the third (within 2x of a
fresh Newton correction: 7.5 against 4.2, 12.4 against 7.6). The map is far from normal in the weighted norm: translation errors, which it resolves
well, feed the director rotations that follow them (block norm ~1e3, rotation on rotation 0.02-0.25, its
eigenvalues in +- pairs), so the ratios alternate (0.015, 0.67, 0.016, 0.41, 0.03, ...) around sqrt(0.016 x 0.67)
~ 0.1. Refreshing at such a ratio paid a factorization for a next correction at most 2x smaller. Runs, 100 steps per revolution,
unchanged -> now: the hub annulus at h/R 1e-6 over 20 revolutions 66 -> 1 factorizations, 2.27 -> 2.23 iterations
per step, Jacobi drift 6.4e-8 -> 8.5e-8 (tightly converged: 1.2e-7), rim frequency 18.561972 -> 18.561976
(tight 18.561979), the largest position difference from the tight run 1.4e-5 -> 7.6e-6 m; at h/R 1e-3 over 4
revolutions 6 -> 1 factorizations, 2.08 -> 2.10 iterations per step; the free annuli a/b 0.1 and 0.5 over 2
revolutions 7 -> 5 and 2 -> 1 factorizations for 2.87 -> 2.97 and 2.96 -> 3.03 iterations per step, energy drift
1.1e-8 -> 6.7e-9 and 5.0e-9 -> 2.7e-8 (the kept matrix older; tight: 7.9e-10 and 5.9e-10; the states no farther
from the tight ones: 2.9e-6 -> 4.3e-6 and 1.0e-6 -> 2.4e-7 m); the 10 m sail (one revolution, adaptive, its
step count varies 384-519 with refresh_ratio 0.25-0.35 alone) 0.173 -> 0.148 factorizations and 2.47 -> 2.64
iterations per step (means over refresh_ratio 0.25, 0.3, 0.35).

Iteration error against the local error (``local_error_fraction`` kappa, default 0.3; 0: off). The tolerances
above ask the same of every step; but an iteration error far below the step's own discretization error buys
nothing (Hairer & Wanner, Solving ODE II, IV.8: the Newton tolerance of an implicit integrator is a fraction of
its local error tolerance). So an iterate is also accepted when eta_k ||Dx_k|| <= 1 in the weighted norm whose
weights are atol s_i + rtol |x_i| + kappa |e_i|, e = h^2 (beta - gamma/2 + 1/12)(a_{k} - a_n) the step's local
error estimate at the iterate ("Adaptive time steps" below), component by component, |e_i| capped at
``error_tolerance`` s_i (a step whose local error is wild, a run falling apart, does not loosen its own
iteration); there eta_k takes theta_k >= ``refresh_ratio`` (the contraction a kept matrix may have; the first
ratio measures the resolved stiff part of the predictor's error, see "Contraction floor"). The iteration error
then stays a small fraction of the discretization error: measured on a cantilever at h = T/40
(tests/integrators/test_generalized_alpha.py) 0.26 % and 0.06 % of the difference between h and h/2, at 63 and 98
instead of 100 and 137 iterations; on the kicked hub annulus of docs/dynamics.md 1.9 % over two revolutions, at
2.33 instead of 2.83 iterations and 0.13 instead of 0.25 factorizations per step. A converged step no longer satisfies the tolerances exactly: conserved quantities
hold to the iteration error (a run that must meet rtol/atol, or compares iteration schemes, sets 0), and a
restart, which starts on a fresh matrix, follows the uninterrupted run to the iteration error.

The translational DoFs are components in fixed directions, so a tumbling body's stiffness turns with it,
and the parallel-transported frames drift about their directors relative to the body: K -> P K P^T.
With ``rotate_matrix`` an old factorization is applied through P from the configuration where it was made
(``dyn.transfer``: for the shell, node by node the rotation of the node's patch, a Kabsch fit, and the
frames' drilling drift; exact for rigid motion of a free body, tests/shell/test_inertia.py), which keeps it
useful over arbitrarily large rotations, the tumbling plate of the tests runs 600 steps on one
factorization, and as a thin membrane swings, the surface turning differently from place to place (the
kicked hub annulus: 0.12 -> 0.01 factorizations per step).

Adaptive time steps (``AlphaSettings.adaptive``). Local error estimate: with the second-order condition
gamma = 1/2 + alpha_f - alpha_m the pseudo-acceleration approximates vdot at a shifted time,
a_n = vdot(t_n + (alpha_m - alpha_f) h) + O(h^2) (Arnold & Bruls 2007, "Convergence of the generalized-alpha
scheme for constrained mechanical systems", Multibody Syst. Dyn. 18), so a_{n+1} - a_n = h q''' + O(h^2), and
the Taylor expansion of the position update leaves the local error

    x_{n+1} - x(t_{n+1}) = h^3 (beta - gamma/2 + 1/12) q''' + O(h^4) ~ h^2 (beta - gamma/2 + 1/12)(a_{n+1} - a_n)

in the Lie algebra (x = h dq_n, the increment of the step: the estimate is a vector of increments on the
group). For a Newmark scheme (gamma = 1/2) it is the classical h^2 (beta - 1/6)(a_{n+1} - a_n) (Zienkiewicz &
Xie 1991, "A simple error estimator and adaptive time stepping procedure for dynamic analysis", Earthquake
Eng. Struct. Dyn. 20; for Newmark-type schemes also in Geradin & Cardona, "Flexible Multibody Dynamics",
2001); the extra (1/2 - gamma)/2 is the generalized-alpha's shift of a (at rho_inf = 0 the Newmark constant
would overestimate the error 2.5 times; the estimate over the true local error of a linear oscillator tends
to 1, tests/integrators/test_adaptive_steps.py). (Cited by content, as above.) Its size is the weighted RMS
norm sqrt(mean((e_i / (tol s_i))^2)) with s_i the DoF scales of the convergence test (model size, 1 rad):
scale-free, and independent of where the body is. A step is accepted when it is <= 1; the next step is
h * safety * err^(-1/3) (an I controller for a local error of order 3), at most 2 h, and not more than h
right after a rejection; a rejected step is retried with at most h/2 (at least h/10), and a step whose
Newton iteration fails (after the retries of ``GeneralizedAlpha.step``) with h/2. The step doubles only when
the controller would allow ``GROWTH_MARGIN`` (1.25) times more, i.e. err <= (safety / 2.5)^3: a doubled step
has about 8 times the error, and without the margin it lands exactly on err = safety^3, where the next step
is halved again. Each such round trip costs a factorization on each rung (its kept matrix went stale in the
meantime): on the 10 m sail under its rim pulse (one revolution, tolerance 1e-5) the margin took the rung
changes from 79 to 11 and the factorizations from 172 to 119, with 470 steps instead of 486 (the kept matrix
then carried by the body's rotation only). The same idea as keeping h for a small change to save the LU
decomposition (Hairer & Wanner, "Solving Ordinary Differential Equations II", IV.8).

Step sizes lie on the dyadic ladder H / 2^j (H the given step, j of either sign); a step h_j starts only at a
multiple of h_j after t_start and ends at or before the next output time (``record_every`` H): the steps land
exactly on the output times and on t_end, and every rung keeps its own integrator with its iteration matrix
and factorization (S depends on h through beta' and gamma'; a matrix made for one h is never used for
another), so that changing the step size does not refactorize by itself. A change of step size moves the
pseudo-acceleration to the new shift, a_n += (alpha_m - alpha_f)(h/h_prev - 1)(a_n - a_{n-1}): the local
error is the same either way to leading order, but the estimate of the first step after the change is exact
only with it (tests/integrators/test_adaptive_steps.py).
"""

from __future__ import annotations

import dataclasses

from dataclasses import dataclass
import time
from typing import Callable, Sequence

import numpy as np
import scipy.sparse as sp

from integrators.linear import LinearSolver, SingularMatrixError
from integrators.newton import NewtonStats
from integrators.protocols import (AcceptedStep, Capabilities, DynamicProblem, StepObserver, capabilities,
                                   require)


#: adaptive steps: a step doubles only when the error estimate would allow GROWTH_MARGIN x 2 h (module docstring)
GROWTH_MARGIN = 1.25


@dataclass(frozen=True)
class AlphaParameters:
    """alpha_m, alpha_f, beta, gamma of the generalized-alpha method."""

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float

    @classmethod
    def from_rho_inf(cls, rho_inf: float) -> "AlphaParameters":
        """Chung-Hulbert optimal parameters for spectral radius rho_inf in [0, 1] at h omega -> infinity.

        alpha_m = (2 rho - 1)/(rho + 1), alpha_f = rho/(rho + 1), gamma = 1/2 + alpha_f - alpha_m,
        beta = (gamma + 1/2)^2 / 4 (Chung & Hulbert 1993, as used by BCA; second order, unconditionally stable).
        """
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf!r}")
        am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        af = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 + af - am
        return cls(am, af, 0.25 * (gamma + 0.5) ** 2, gamma)

    def beta_prime(self, h: float) -> float:
        return (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))

    def gamma_prime(self, h: float) -> float:
        return self.gamma / (h * self.beta)

    @property
    def error_constant(self) -> float:
        """c in the local position error c h^3 q''' of a step: beta - gamma/2 + 1/12 (module docstring, "Adaptive
        time steps"); 1/12 for the trapezoidal rule, beta - 1/6 for every Newmark scheme (gamma = 1/2)."""
        return self.beta - 0.5 * self.gamma + 1.0 / 12.0


@dataclass
class AlphaSettings:
    """Settings of the generalized-alpha integrator: rho_inf, the Newton tolerances and iteration-matrix
    policy, cut-backs of failing steps, and the error-controlled (adaptive) time steps (each field is
    described where it is declared; the module docstring gives the method)."""

    rho_inf: float = 0.9
    rtol: float = 1e-8            # weighted RMS norm: relative part (of the step increment)
    atol: float = 1e-10           # the floor, times the DoF scale (model size, 1 rad): scale-free too
    max_iterations: int = 20
    policy: str = "modified"      # "modified" (reuse the iteration matrix) or "full" (refresh every iteration)
    refresh_ratio: float = 0.3    # refresh the iteration matrix when the contraction exceeds this ("Transient ratios")
    # the error estimate eta ||Dx|| takes theta_k >= this (module docstring, "Contraction floor"; 0: off)
    contraction_floor: float = 0.1
    rotate_matrix: bool = True    # carry an old matrix along the motion (dyn.transfer, see above)
    # an iterate is also accepted when its error is below this fraction of the step's local error estimate,
    # component by component (module docstring, "Iteration error against the local error"; 0: the tolerances only)
    local_error_fraction: float = 0.3
    divergence_factor: float = 1e6  # a step fails when a correction exceeds this multiple of the first one
    max_cutbacks: int = 0         # a failed step is retried as two half steps, down to h / 2^max_cutbacks
    # error-controlled time steps (module docstring, "Adaptive time steps"); the fixed step when False
    adaptive: bool = False
    error_tolerance: float = 1e-5  # local position error per step, weighted RMS, as a fraction of the DoF scale
    min_step: float | None = None  # the run fails below it (default: the first step / 2^20)
    max_step: float | None = None  # default: the output interval (the step times ``record_every``)
    safety: float = 0.8           # the step chosen is at most safety * the step the estimate asks for

    def __post_init__(self) -> None:
        if self.policy not in ("full", "modified"):
            raise ValueError(f"policy must be 'full' or 'modified', got {self.policy!r}")
        if not 0 < self.rtol < 1:
            raise ValueError(f"rtol must lie in (0, 1) (a fraction of the step increment), got {self.rtol!r}")
        if not 0 < self.atol < 1:
            raise ValueError(f"atol must lie in (0, 1) (a fraction of the model size), got {self.atol!r}")
        if isinstance(self.local_error_fraction, bool) or not (isinstance(self.local_error_fraction, (int, float))
                                                                and 0.0 <= self.local_error_fraction <= 1.0):
            raise ValueError(f"local_error_fraction must lie in [0, 1], got {self.local_error_fraction!r}")
        if not 0.0 <= self.contraction_floor < 1.0:
            raise ValueError(f"contraction_floor must lie in [0, 1), got {self.contraction_floor!r}")
        if not self.max_iterations >= 1:
            raise ValueError(f"max_iterations must be >= 1, got {self.max_iterations!r}")
        if self.max_cutbacks < 0:
            raise ValueError(f"max_cutbacks must be >= 0, got {self.max_cutbacks!r}")
        if not isinstance(self.adaptive, bool):
            raise ValueError(f"adaptive must be true or false, got {self.adaptive!r}")
        if not 0 < self.error_tolerance < 1:
            raise ValueError(f"error_tolerance must lie in (0, 1) (a fraction of the model size), got "
                             f"{self.error_tolerance!r}")
        for name in ("min_step", "max_step"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not np.isfinite(value) or not value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.min_step is not None and self.max_step is not None and self.min_step > self.max_step:
            raise ValueError(f"min_step must not exceed max_step, got {self.min_step!r} > {self.max_step!r}")
        if not 0 < self.safety <= 1:
            raise ValueError(f"safety must lie in (0, 1], got {self.safety!r}")


@dataclass(frozen=True)
class DynamicResult:
    """The end of a run: the last converged step's values, the Newton statistics and the step counts (what the
    run went through step by step is for the observers, :class:`integrators.protocols.StepObserver`)."""

    state: object
    velocity: np.ndarray
    acceleration: np.ndarray          # vdot
    pseudo_acceleration: np.ndarray   # a
    time: float
    stats: NewtonStats
    converged: bool = True
    message: str = "completed"
    wall_time: float = 0.0
    steps: int = 0                    # accepted steps (sub-steps after cut-backs counted)
    rejected_error: int = 0           # steps rejected by the error estimate (adaptive)
    rejected_newton: int = 0          # steps whose Newton iteration failed (retried smaller)
    min_step: float = float("nan")    # the smallest and largest accepted step
    max_step: float = float("nan")
    adaptive: bool = False


@dataclass
class _Step:
    """Working variables of one step."""

    state: object
    x: np.ndarray         # h dq_n
    v: np.ndarray
    vdot: np.ndarray
    a: np.ndarray


@dataclass(frozen=True)
class StepSolution:
    """A converged step of :meth:`GeneralizedAlpha.step`: the end values on the free DoFs and the Newton work."""

    state: object
    v: np.ndarray                     # v_{n+1} (n,)
    vdot: np.ndarray                  # vdot_{n+1} (n,)
    a: np.ndarray                     # a_{n+1} (n,), the pseudo-acceleration
    iterations: int
    residuals: list[float]            # ||r|| at each iterate
    corrections: list[float]          # weighted RMS norm of each correction
    refreshes: int                    # iteration-matrix refreshes


@dataclass(frozen=True)
class _Attempt:
    """One try at a step (:meth:`GeneralizedAlpha._attempt`): its solution, or None and why it failed; and
    whether a fresh iteration matrix was used (a failure with only old ones is retried with a fresh one)."""

    solution: StepSolution | None
    message: str
    any_fresh: bool


@dataclass(frozen=True)
class StepTaken(StepSolution):
    """A step of h taken by :meth:`_Stepper.advance`: a :class:`StepSolution` with the sub-steps behind it.

    After cut-backs (two steps of h/2, recursively) the sub-steps' work is summed (:meth:`then`): the histories
    concatenated, ``substeps`` the sub-steps taken, ``failures`` the failed tries, ``h`` the last sub-step's size.
    """

    substeps: int = 1
    failures: int = 0
    h: float = 0.0                    # the size of the last sub-step (s)

    def then(self, second: "StepTaken") -> "StepTaken":
        """The two halves of a failed step: this one, then ``second`` from its end (the failed try counted)."""
        return StepTaken(second.state, second.v, second.vdot, second.a, iterations=self.iterations + second.iterations,
                         residuals=self.residuals + second.residuals, corrections=self.corrections + second.corrections,
                         refreshes=self.refreshes + second.refreshes, substeps=self.substeps + second.substeps,
                         failures=self.failures + second.failures + 1, h=second.h)


def weighted_rms(dx: np.ndarray, x: np.ndarray, scale, settings: AlphaSettings, extra=0.0) -> float:
    """sqrt(mean((dx_i / (atol s_i + rtol |x_i| + extra_i))^2))."""
    if not dx.size:
        return 0.0
    w = np.abs(x)                 # in place: the same operations in the same order, without temporaries
    w *= settings.rtol
    w += settings.atol * scale
    w += extra
    q = np.divide(dx, w, out=w)
    q *= q
    return float(np.sqrt(np.mean(q)))


def _predict(q_n, v_n, vdot_n, a_n, h: float, p: AlphaParameters, update: Callable) -> _Step:
    """Predictor with vdot_{n+1} = vdot_n (the integration formulas evaluated at that acceleration)."""
    vdot = vdot_n.copy()
    a = (p.alpha_f * vdot_n - p.alpha_m * a_n + (1.0 - p.alpha_f) * vdot) / (1.0 - p.alpha_m)
    x = h * v_n + h * h * ((0.5 - p.beta) * a_n + p.beta * a)
    v = v_n + h * ((1.0 - p.gamma) * a_n + p.gamma * a)
    return _Step(update(q_n, x), x, v, vdot, a)


def _configuration(dyn, caps: Capabilities, q_n, x: np.ndarray, t: float):
    """q_{n+1} = q_n o exp(x) on the free DoFs, the prescribed nodes at their place at t_{n+1}."""
    q = dyn.update(q_n, x)
    return caps.prescribed.prescribe(q, t) if caps.prescribed is not None else q


class GeneralizedAlpha:
    """The integrator with its iteration matrix, factorization and counters (reused across steps).

    ``dyn`` is a :class:`integrators.protocols.DynamicProblem` (``residual(q, v, vdot, t)``,
    ``residual_and_tangent(q, v, vdot, t)``, ``update(q, dq)``, ``dof_scale``, ``n_dof``,
    ``initial_acceleration``) with a mass (``mass_matrix()``, sparse n x n, or a diagonal ``mass`` (n,)); opt-in: damping
    (:class:`~integrators.protocols.Damped`), prescribed motion (:class:`~integrators.protocols.Prescribed`) and
    the transfer of the factorization along the motion (:class:`~integrators.protocols.TransferAlongMotion`);
    see :class:`flexbody.dynamics.DynamicModel`.
    """

    def __init__(self, dyn, h: float, settings: AlphaSettings | None = None,
                 stats: NewtonStats | None = None) -> None:
        if not (np.isfinite(h) and h > 0):
            raise ValueError(f"time step must be positive and finite, got {h!r}")
        self.dyn, self.h = dyn, float(h)
        self.settings = settings or AlphaSettings()
        self.params = AlphaParameters.from_rho_inf(self.settings.rho_inf)
        self.solver = LinearSolver()
        self.stats = NewtonStats() if stats is None else stats
        self.caps = capabilities(dyn)
        self._transfer = None     # (factorized configuration, P): the map P of the step, made once per step

    def _refresh(self, step: _Step, t: float):
        """New tangent at the iterate, S = M beta' + C_t gamma' + K_t (T ~ I), factorized; returns the residual."""
        r, K = self.dyn.residual_and_tangent(step.state, step.v, step.vdot, t)
        self.stats.tangent_updates += 1
        self.stats.residual_evaluations += 1
        S = K + _mass_matrix(self.dyn, self.caps) * self.params.beta_prime(self.h)
        C = self.caps.damped.damping_matrix(step.state) if self.caps.damped is not None else None
        if C is not None:
            S = S + self.params.gamma_prime(self.h) * C
        self.solver.factorize(S.tocsc())
        self.stats.factorizations += 1
        self._factorized_at = step.state
        return r

    def _solve(self, state, r: np.ndarray) -> np.ndarray:
        """-S^-1 r with the stored factorization, carried along the body's rigid rotation since it was made.

        With P the map of DoF components from the factorized configuration to the current one
        (``dyn.transfer``: the rigid rotation on translations, the frames' drilling drift on rotations),
        S_now ~ P S_old P^T, so S_now^-1 ~ P S_old^-1 P^T. P is made at the step's first solve (after a refresh,
        at the refresh's configuration) and kept for the step's later iterations: they move the body by the
        Newton corrections only, and P enters the iteration matrix, not the residual (half of a solve's cost
        was the Kabsch fit of ``dyn.transfer`` at every iteration).
        """
        dyn = self.caps.transfer
        if not (self.settings.rotate_matrix and dyn is not None):
            return -self.solver.solve(r)
        if self._transfer is None or self._transfer[0] is not self._factorized_at:
            self._transfer = (self._factorized_at, dyn.transfer(self._factorized_at, state))
        P = self._transfer[1]
        return -dyn.apply_transfer(self.solver.solve(dyn.apply_transfer(r, P, transpose=True)), P)

    def step(self, q_n, v_n, vdot_n, a_n, t_n: float) -> StepSolution:
        """One step from t_n; raises ``_StepFailure`` if it does not converge."""
        out = self._attempt(q_n, v_n, vdot_n, a_n, t_n, fresh=self.settings.policy == "full" or not self.solver.ready)
        if out.solution is None and not out.any_fresh:   # failed with an old matrix: retry with a fresh one
            out = self._attempt(q_n, v_n, vdot_n, a_n, t_n, fresh=True)
        if out.solution is None and self.settings.policy == "modified":
            # failed with matrices kept across iterations: retry with a fresh one at every iteration (Newton). A slack
            # membrane that tautens within a step changes its stiffness faster than the kept matrices follow
            # (a 10 m sail under a rim pulse: 20 iterations short of convergence at step 6, 4 with Newton)
            out = self._attempt(q_n, v_n, vdot_n, a_n, t_n, fresh=True, newton=True)
        if out.solution is None:
            self.solver = LinearSolver()  # the failed attempt's matrix belongs to a wild iterate: never reuse it
            raise _StepFailure(out.message)
        return out.solution

    def _attempt(self, q_n, v_n, vdot_n, a_n, t_n: float, fresh: bool, newton: bool = False) -> _Attempt:
        """One try at the step: from the predictor, with a fresh matrix first if ``fresh``, and a fresh one at every
        iteration if ``newton`` (or under the "full" policy)."""
        h, p, s, dyn, caps = self.h, self.params, self.settings, self.dyn, self.caps
        scale = dyn.dof_scale
        t = t_n + h
        bp, gp = p.beta_prime(h), p.gamma_prime(h)
        step = _predict(q_n, v_n, vdot_n, a_n, h, p, lambda q, x: _configuration(dyn, caps, q, x, t))

        def failed(message: str) -> _Attempt:
            return _Attempt(None, message, any_fresh)

        def converged(k: int) -> _Attempt:
            return _Attempt(StepSolution(step.state, step.v, step.vdot, step.a, k + 1, residuals, corrections,
                                         refreshes), "", any_fresh)

        self._transfer = None                     # a new P for this step (``_solve``)
        residuals, corrections, refreshes = [], [], 0
        any_fresh, need, prev = fresh, fresh, None
        eta = eta_le = np.inf                     # no contraction estimate before the second correction
        kept = []                                 # the ratios measured with the current matrix alone
        for k in range(s.max_iterations):
            used_fresh = need
            try:
                if need:
                    r = self._refresh(step, t)
                    refreshes += 1
                    any_fresh, need, kept = True, False, []
                else:
                    r = dyn.residual(step.state, step.v, step.vdot, t)
                    self.stats.residual_evaluations += 1
                dx = self._solve(step.state, r)
            except (FloatingPointError, SingularMatrixError) as exc:
                return failed(str(exc))
            residuals.append(float(np.linalg.norm(r)))
            before = dataclasses.replace(step)
            # Newton correction of x = h dq_n, of the velocity and of the accelerations (beta', gamma')
            step.x = step.x + dx
            step.v = step.v + gp * dx
            step.vdot = step.vdot + bp * dx
            step.a = step.a + (1.0 - p.alpha_f) / (1.0 - p.alpha_m) * bp * dx
            try:
                step.state = _configuration(dyn, caps, q_n, step.x, t)   # exact: q_{n+1} = q_n o exp(h dq_n)
            except FloatingPointError as exc:
                return failed(str(exc))
            self.stats.iterations += 1
            err = weighted_rms(dx, step.x, scale, s)
            if s.local_error_fraction > 0.0:
                le = np.minimum(np.abs(local_error_estimate(step.a, a_n, h, p)), s.error_tolerance * scale)
                err_le = weighted_rms(dx, step.x, scale, s, s.local_error_fraction * le)
            else:
                err_le = err
            corrections.append(err)
            if not np.isfinite(err):
                return failed("non-finite correction")
            if err == 0.0:
                return converged(k)
            if prev is not None:
                theta = err / prev
                if theta >= 1.0 and not used_fresh:      # an old matrix made it worse: undo, refresh, redo
                    step = before
                    corrections.pop()
                    need = True
                    continue
                if theta >= 1.0:                         # not contracting: Newton steps with fresh matrices
                    if err > s.divergence_factor * corrections[0]:
                        return failed(f"diverging corrections {[f'{c:.2e}' for c in corrections]}")
                    need, prev = True, err
                    continue
                if not used_fresh:
                    kept.append(theta)
                theta_acc, need = _contraction(theta, kept, s.refresh_ratio)
                theta_e = max(theta_acc, s.contraction_floor)
                eta = theta_e / (1.0 - theta_e)
                theta_le = max(theta_acc, s.refresh_ratio)
                eta_le = theta_le / (1.0 - theta_le)
            need = need or newton or s.policy == "full"
            if eta * err <= 1.0 or (s.local_error_fraction > 0.0 and eta_le * err_le <= 1.0):
                return converged(k)
            prev = err
        return failed(f"no convergence in {s.max_iterations} iterations (corrections "
                      f"{[f'{c:.2e}' for c in corrections]})")


def _contraction(theta: float, kept: list[float], refresh_ratio: float) -> tuple[float, bool]:
    """The contraction estimate of the error test and whether to refresh the matrix (module docstring, "Transient
    ratios of a kept matrix").

    ``theta`` is the last ratio of two corrections, ``kept`` the ratios measured with the current matrix alone
    (``theta`` last, if it is one of them). Refresh when theta exceeds ``refresh_ratio``, unless the geometric mean
    of the matrix's last two ratios does not (a one-iteration transient); the error test takes the larger of those
    two ratios when the earlier one exceeded ``refresh_ratio``, else theta.
    """
    if len(kept) < 2:
        return theta, theta > refresh_ratio
    earlier, last = kept[-2], kept[-1]
    refresh = theta > refresh_ratio and np.sqrt(earlier * last) > refresh_ratio
    return (max(theta, earlier) if earlier > refresh_ratio else theta), refresh


def _mass_matrix(dyn, caps: Capabilities) -> sp.spmatrix:
    """The constant mass matrix M: ``dyn.mass_matrix()`` (sparse: lumped or consistent,
    :class:`~integrators.protocols.MassMatrix`), or diag(``dyn.mass``) (:class:`~integrators.protocols.LumpedMass`)."""
    return caps.mass_matrix.mass_matrix() if caps.mass_matrix is not None else sp.diags(dyn.mass)


class _StepFailure(RuntimeError):
    pass


class _Observers:
    """The run's observers, given every accepted step (:class:`~integrators.protocols.AcceptedStep`) in order."""

    def __init__(self, observers: Sequence[StepObserver], t0: float) -> None:
        self.observers, self.t0 = tuple(observers), t0

    def __call__(self, **fields) -> None:
        if not self.observers:
            return
        step = AcceptedStep(**fields, wall_time=time.perf_counter() - self.t0)
        for observer in self.observers:
            observer(step)


class _Stepper:
    """Steps of h, or after a failure two steps of h/2 (recursively, ``max_cutbacks`` levels).

    One integrator (iteration matrix, factorization) per step size, all counting into one NewtonStats.
    The pseudo-acceleration a is carried across a change of step size unchanged, which keeps the scheme
    consistent but can cost the second order locally (at the few steps where h changes).
    """

    def __init__(self, dyn, h: float, settings: AlphaSettings) -> None:
        self.dyn, self.h, self.settings = dyn, h, settings
        self.stats = NewtonStats()
        self._levels: dict[int, GeneralizedAlpha] = {}

    def _integrator(self, level: int) -> GeneralizedAlpha:
        if level not in self._levels:
            self._levels[level] = GeneralizedAlpha(self.dyn, self.h / 2**level, self.settings, self.stats)
        return self._levels[level]

    def advance(self, q, v, vdot, a, t: float, level: int = 0) -> StepTaken:
        """A step of h / 2^level from t, cut back into two halves (recursively) when it fails."""
        try:
            st = self._integrator(level).step(q, v, vdot, a, t)
            return StepTaken(st.state, st.v, st.vdot, st.a, iterations=st.iterations, residuals=st.residuals,
                             corrections=st.corrections, refreshes=st.refreshes, h=self.h / 2**level)
        except _StepFailure:
            if level >= self.settings.max_cutbacks:
                raise
        half = self.h / 2 ** (level + 1)
        first = self.advance(q, v, vdot, a, t, level + 1)
        return first.then(self.advance(first.state, first.v, first.vdot, first.a, t + half, level + 1))


# -- error-controlled time steps ------------------------------------------------------------------------------
def shifted_pseudo_acceleration(a_n: np.ndarray, a_prev: np.ndarray | None, h_prev: float, h: float,
                                p: AlphaParameters) -> np.ndarray:
    """The pseudo-acceleration a_n for a step of h after steps of h_prev (module docstring, "Adaptive time steps").

    a_n approximates vdot at t_n + (alpha_m - alpha_f) h_prev; moved to t_n + (alpha_m - alpha_f) h with the
    rate (a_n - a_{n-1}) / h_prev of the last step. Unchanged at the first step (a_prev None) or for h = h_prev.
    """
    if a_prev is None or h == h_prev:
        return a_n
    return a_n + (p.alpha_m - p.alpha_f) * (h / h_prev - 1.0) * (a_n - a_prev)


def local_error_estimate(a_new: np.ndarray, a_n: np.ndarray, h: float, p: AlphaParameters) -> np.ndarray:
    """The local position error of a step in the Lie algebra, h^2 (beta - gamma/2 + 1/12) (a_{n+1} - a_n)."""
    return (h * h * p.error_constant) * (a_new - a_n)


def error_norm(e: np.ndarray, scale, settings: AlphaSettings) -> float:
    """sqrt(mean((e_i / (tol s_i))^2)) with s_i the DoF scale (model size, 1 rad): <= 1 accepts the step."""
    return float(np.sqrt(np.mean((e / (settings.error_tolerance * scale)) ** 2))) if e.size else 0.0


def next_step(h: float, err: float, safety: float, grow: bool = True) -> float:
    """The step wanted after an accepted step h whose error norm is err <= 1 (module docstring, "Adaptive time
    steps"): h * safety * err^(-1/3) if that is below h; 2 h if it is at least ``GROWTH_MARGIN`` x 2 h (and growing
    is allowed: not right after a rejection); else h."""
    factor = safety * err ** (-1.0 / 3.0) if err > 0 else np.inf
    if grow and factor >= 2.0 * GROWTH_MARGIN:
        return 2.0 * h
    return h * min(1.0, factor)


class _AdaptiveStepper:
    """Steps on the dyadic ladder h_j = H / 2^j (H the base step, j of either sign), each taken from a time that is
    a multiple of h_j after t_start and ending at or before the next output time, so that the steps land
    exactly on the output times and on t_end. One integrator (iteration matrix, factorization) per rung, as
    the cut-backs of :class:`_Stepper` keep them: a change of step size never refactorizes by itself.

    Times are counted in ticks of the finest rung, H / 2^j_max (integers: no round-off in the landing).
    """

    def __init__(self, dyn, base: float, n_base: int, record_every: int, settings: AlphaSettings) -> None:
        self.dyn, self.base, self.settings = dyn, base, settings
        self.params = AlphaParameters.from_rho_inf(settings.rho_inf)
        self.stats = NewtonStats()
        self._levels: dict[int, GeneralizedAlpha] = {}
        h_min = settings.min_step if settings.min_step is not None else base / 2**20
        h_max = record_every * base if settings.max_step is None else min(settings.max_step, record_every * base)
        self.j_max = max(0, int(np.floor(np.log2(base / h_min) + 1e-9)))
        self.j_min = int(np.ceil(np.log2(base / h_max) - 1e-9))
        if self.j_min > self.j_max:
            raise ValueError(f"max_step {h_max!r} is below min_step {h_min!r}")
        self.end = n_base * 2**self.j_max                     # t_end in ticks
        self.out = record_every * 2**self.j_max               # the output interval in ticks

    def integrator(self, j: int) -> GeneralizedAlpha:
        if j not in self._levels:
            self._levels[j] = GeneralizedAlpha(self.dyn, self.h(j), self.settings, self.stats)
        return self._levels[j]

    def h(self, j: int) -> float:
        return self.base / 2.0**j

    def ticks(self, j: int) -> int:
        return 2 ** (self.j_max - j)

    def next_output(self, pos: int) -> int:
        return min((pos // self.out + 1) * self.out, self.end)

    def rung(self, pos: int, wanted: float) -> int:
        """The longest step h_j <= wanted allowed at ``pos``: aligned, not past the next output time; j_max + 1
        if even the finest rung is too long for ``wanted``."""
        j = max(self.j_min, int(np.ceil(np.log2(self.base / wanted) - 1e-12)))
        stop = self.next_output(pos)
        while j <= self.j_max and (pos % self.ticks(j) or pos + self.ticks(j) > stop):
            j += 1
        return j


def _adaptive_run(stepper: _AdaptiveStepper, t_start: float, t_end: float, q, v, vdot, a, observe: _Observers,
                  t0: float, first_step: int = 0) -> DynamicResult:
    """The loop of :func:`generalized_alpha` with error-controlled steps (module docstring); ``first_step``: the
    step count at t_start (a restart)."""
    s, p, scale = stepper.settings, stepper.params, stepper.dyn.dof_scale
    pos, accepted, rej_err, rej_newton = 0, 0, 0, 0     # totals
    since = [0, 0, 0]                                    # accepted, rejected (error, Newton) since the last record
    wanted, grow = stepper.h(max(stepper.j_min, 0)), True
    a_prev, h_prev, h_taken = None, 0.0, []
    t = t_start

    def result(converged: bool, message: str) -> DynamicResult:
        return DynamicResult(q, v, vdot, a, t, stepper.stats, converged, message, time.perf_counter() - t0,
                             steps=accepted, rejected_error=rej_err, rejected_newton=rej_newton,
                             min_step=min(h_taken, default=float("nan")), max_step=max(h_taken, default=float("nan")),
                             adaptive=True)

    while pos < stepper.end:
        j = stepper.rung(pos, wanted)
        if j > stepper.j_max:
            return result(False, f"step {accepted + 1} from t = {t:.6g} failed: the step size needed is below "
                                 f"min_step {stepper.h(stepper.j_max):.3g} s ({rej_err} steps rejected by the "
                                 f"error estimate, {rej_newton} by Newton failures)")
        h = stepper.h(j)
        a_n = shifted_pseudo_acceleration(a, a_prev, h_prev, h, p)
        try:
            st = stepper.integrator(j).step(q, v, vdot, a_n, t)
        except _StepFailure as exc:
            rej_newton, since[2] = rej_newton + 1, since[2] + 1
            if j >= stepper.j_max:
                return result(False, f"step {accepted + 1} from t = {t:.6g} failed at the smallest step "
                                     f"{h:.3g} s: {exc}")
            wanted, grow = 0.5 * h, False
            continue
        err = error_norm(local_error_estimate(st.a, a_n, h, p), scale, s)
        factor = s.safety * err ** (-1.0 / 3.0) if err > 0 else np.inf
        if not np.isfinite(err) or err > 1.0:
            rej_err, since[1] = rej_err + 1, since[1] + 1
            wanted, grow = h * min(0.5, max(0.1, factor if np.isfinite(err) else 0.1)), False
            continue
        # accepted: q_{n+1}, v_{n+1}, vdot_{n+1}, a_{n+1}
        v_old = v
        q, v, vdot, a_prev, a = st.state, st.v, st.vdot, a_n, st.a
        h_prev = h
        h_taken.append(h)
        pos += stepper.ticks(j)
        t = t_end if pos == stepper.end else t_start + pos / 2**stepper.j_max * stepper.base
        accepted += 1
        since[0] += 1
        wanted = next_step(h, err, s.safety, grow)
        grow = True
        output = pos % stepper.out == 0 or pos == stepper.end
        counts = since
        if output:
            since = [0, 0, 0]
        observe(index=first_step + accepted, time=t, step_size=h, state=q, previous_velocity=v_old, velocity=v,
                acceleration=vdot, pseudo_acceleration=a, iterations=st.iterations, residuals=tuple(st.residuals),
                corrections=tuple(st.corrections), refreshes=st.refreshes, substeps=counts[0],
                rejected_error=counts[1], rejected_newton=counts[2], h=h, error_estimate=err, output=output)
    return result(True, "completed")


def generalized_alpha(dyn: DynamicProblem, t_end: float, h: float, *, state=None, velocity: np.ndarray | None = None,
                      settings: AlphaSettings | None = None, t_start: float = 0.0,
                      observers: Sequence[StepObserver] = (), record_every: int = 1,
                      acceleration: np.ndarray | None = None, pseudo_acceleration: np.ndarray | None = None,
                      first_step: int = 0) -> DynamicResult:
    """Integrate from t_start to t_end with a fixed step (h, rounded down so that whole steps end at t_end) or,
    with ``settings.adaptive``, error-controlled steps.

    Parameters
    ----------
    dyn : the dynamic problem (:class:`integrators.protocols.DynamicProblem`, e.g.
        :class:`flexbody.dynamics.DynamicModel`); a model lacking a required member is refused with a one-line
        ``TypeError`` naming it
    h : the time step; adaptive: the base step H, the first step and the output interval's unit (rounded
        down as the fixed step is)
    state, velocity : initial configuration (default: the reference ``dyn.model.initial_state()``,
        :class:`~integrators.protocols.WrapsStaticProblem`) and free-DoF velocity (default: 0)
    observers : :class:`~integrators.protocols.StepObserver` s, each called with the start
        (:class:`~integrators.protocols.AcceptedStep` with ``initial``) and then with every accepted step, in
        order; what they raise (a ``KeyboardInterrupt`` too) ends the run there
    record_every : mark every k-th step as an output step (``AcceptedStep.output``; the last step is one too);
        adaptive: an output step at every multiple of k H after t_start (the same times as the fixed step's),
        on which the steps land; no step is longer than k H (nor than ``settings.max_step``)
    acceleration, pseudo_acceleration, first_step : a continuation (restart) of a run at its step
        ``first_step``: vdot and a there (default: consistent, a = vdot), the step numbers and the
        record_every grid counted on from it

    The initial acceleration is consistent (vdot_0 = -M^-1 g(q_0, t_0) from ``dyn.initial_acceleration``, a
    sparse solve for a consistent mass; a_0 = vdot_0), which the second
    order of the method requires (BCA; Arnold & Bruls 2007). Fixed step: a step that does not converge is
    retried as two half steps, down to ``settings.max_cutbacks`` levels (default 0); its accepted step then
    sums the sub-steps' iterations and histories (``substeps`` > 1, ``rejected_newton`` the failed tries since
    the previous output step). Adaptive: steps H / 2^j chosen by the local error estimate (module docstring);
    an accepted step counts the steps since the previous output step (``substeps`` accepted,
    ``rejected_error``, ``rejected_newton``). If a step still fails, the run ends with a message and the last
    converged state, never with garbage.
    """
    if not (np.isfinite(t_end) and t_end > t_start):
        raise ValueError(f"t_end must be finite and > t_start, got {t_end!r}")
    if isinstance(record_every, bool) or not isinstance(record_every, (int, np.integer)) or record_every < 1:
        raise ValueError(f"record_every must be an integer >= 1, got {record_every!r}")
    settings = settings or AlphaSettings()
    n_steps = max(1, int(np.ceil((t_end - t_start) / h - 1e-9)))
    h = (t_end - t_start) / n_steps
    require(dyn, DynamicProblem, "the dynamic problem")
    caps = capabilities(dyn)
    if state is None and caps.static_model is None:
        raise ValueError(f"the dynamic problem {type(dyn).__name__} has no static model to start from: give state")
    q = caps.static_model.initial_state() if state is None else state
    if caps.prescribed is not None:
        q = caps.prescribed.prescribe(q, t_start)
    v = np.zeros(dyn.n_dof) if velocity is None else np.asarray(velocity, float).copy()
    vdot = dyn.initial_acceleration(q, t_start, v) if acceleration is None else np.asarray(acceleration, float).copy()
    a = vdot.copy() if pseudo_acceleration is None else np.asarray(pseudo_acceleration, float).copy()
    t0 = time.perf_counter()
    observe = _Observers(observers, t0)
    observe(index=first_step, time=t_start, step_size=0.0, state=q, previous_velocity=v, velocity=v,
            acceleration=vdot, pseudo_acceleration=a, initial=True)
    if settings.adaptive:
        stepper = _AdaptiveStepper(dyn, h, n_steps, int(record_every), settings)
        return _adaptive_run(stepper, t_start, t_end, q, v, vdot, a, observe, t0, first_step)
    stepper = _Stepper(dyn, h, settings)
    substeps, failures, failed_since = 0, 0, 0
    t = t_start

    def result(converged: bool, message: str) -> DynamicResult:
        return DynamicResult(q, v, vdot, a, t, stepper.stats, converged, message, time.perf_counter() - t0,
                             steps=substeps, rejected_newton=failures,
                             min_step=h / 2 ** max(stepper._levels, default=0), max_step=h, adaptive=False)

    for n in range(n_steps):
        try:
            v_old = v
            step = stepper.advance(q, v, vdot, a, t)
        except _StepFailure as exc:
            return result(False, f"step {n + 1} from t = {t:.6g} failed: {exc}")
        q, v, vdot, a = step.state, step.v, step.vdot, step.a
        t = t_start + (n + 1) * h
        substeps, failures = substeps + step.substeps, failures + step.failures
        failed_since += step.failures
        output = (first_step + n + 1) % record_every == 0 or n + 1 == n_steps
        failed = failed_since
        if output:
            failed_since = 0
        observe(index=first_step + n + 1, time=t, step_size=h, state=q, previous_velocity=v_old, velocity=v,
                acceleration=vdot, pseudo_acceleration=a, iterations=step.iterations,
                residuals=tuple(step.residuals), corrections=tuple(step.corrections), refreshes=step.refreshes,
                substeps=step.substeps, rejected_newton=failed, h=step.h, output=output)
    return result(True, "completed")
