"""The contracts between the integrators and the models they solve, as ``typing.Protocol`` classes.

The integrators import nothing from the models' package: a model is any object with the members below.
Two problem protocols are required, one per kind of solve:

- :class:`StaticProblem`: what :func:`integrators.static.load_control` and :func:`integrators.static.arc_length`
  call (the residual r(q, lam) = f_int(q) - lam f_ext(q), its tangent, the group update, ...);
- :class:`DynamicProblem`: what :func:`integrators.generalized_alpha.generalized_alpha` calls (the residual
  r(q, v, vdot, t) of M vdot + g(q, v, t) = 0, its tangent, the consistent start), with the mass as
  :class:`MassMatrix` or :class:`LumpedMass`.

and small opt-in capabilities: :class:`MixedIteration`, :class:`SupportCheck`, :class:`ConjugateMatrix` (static);
:class:`Damped`, :class:`Prescribed`, :class:`TransferAlongMotion`, :class:`WrapsStaticProblem` (dynamic);
and the state protocol :class:`StressedState`. A capability is absent when one of its members is missing; the
integrator then does without it (documented on each). :func:`capabilities` is the one place where a problem's
capabilities are checked (``isinstance``), once per run.

What a run produces besides its end state is observed from outside: the dynamic integrator gives every
accepted step to its :class:`StepObserver` s as an :class:`AcceptedStep` (energies, momenta and the work of
damping forces are the model's business, e.g. :class:`flexbody.energy.EnergyAccount`).

Conventions: n is the number of free DoFs; ``State`` is whatever the model uses for a configuration (the
integrators only pass it back to the model); a DoF vector is a float array (n,); a tangent is a scipy sparse
matrix (n, n). Increments dq live in the Lie algebra of the configuration group (translations in model length
units, rotations in rad); forces are paired with them by virtual work (:meth:`StaticProblem.conjugate`).

:func:`require` is the run-time check of the entry points: it raises a one-line ``TypeError`` naming the
members a model lacks.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp

State = Any
"""A configuration of the model (opaque to the integrators)."""


@runtime_checkable
class StaticProblem(Protocol):
    """A static equilibrium problem r(q, lam) = f_int(q) - lam f_ext(q) = 0 on a configuration group."""

    dof_scale: np.ndarray | float
    """(n,) or scalar: the size of a unit increment of each DoF (the model size for translations, 1 for
    rotations in rad); every norm of the integrators is weighted by it, which makes them scale-free."""

    def initial_state(self) -> State:
        """The reference configuration q_0 (the start of a path)."""
        ...

    def update(self, state: State, dq: np.ndarray) -> State:
        """q o exp(dq): the configuration moved by the increment dq (n,); a new state, ``state`` unchanged."""
        ...

    def residual(self, state: State, lam: float) -> np.ndarray:
        """r(q, lam) = f_int(q) - lam f_ext(q), (n,), in force units (moments for rotation DoFs)."""
        ...

    def residual_and_tangent(self, state: State, lam: float) -> tuple[np.ndarray, sp.spmatrix]:
        """(r (n,), K (n, n) sparse): the residual and its tangent K = dr/dq along ``update``'s increments."""
        ...

    def external_force(self, state: State) -> np.ndarray:
        """f_ext(q) (n,): the load at unit load factor (state-dependent for follower loads)."""
        ...

    def conjugate(self, state: State, dq: np.ndarray) -> np.ndarray:
        """w (n,): the increment dq expressed in the coordinates whose virtual work with a residual is w . r
        (the line search and the load compliance f . K^-1 f pair forces with it); dq itself for a model whose
        rows and columns are conjugate."""
        ...


@runtime_checkable
class MixedIteration(Protocol):
    """Opt-in: the mixed Newton iteration (stresses carried as unknowns of the iteration, MITC6 bodies).

    Used under ``NewtonSettings(mixed=True, policy="full")`` when ``supports_mixed_iteration`` is true; else
    the displacement iteration runs."""

    supports_mixed_iteration: bool
    """Whether this model's body can run the mixed iteration."""

    def with_stresses(self, state: State) -> State:
        """The state with the stresses of its own strains attached (the start of a mixed step)."""
        ...


@runtime_checkable
class StressedState(Protocol):
    """A state that may carry the stresses of a mixed iteration (``stress`` None when it does not).

    The stability analysis drops them (``dataclasses.replace(state, stress=None)``: the state must be a
    dataclass) to factorize the tangent of the configuration itself."""

    stress: Any


@runtime_checkable
class SupportCheck(Protocol):
    """Opt-in: a model that can tell whether its rigid-body motions are restrained."""

    def check_static_support(self) -> None:
        """Raise a ``ValueError`` (one line, naming the free motion) if the static stiffness is singular for
        lack of supports; called once before the first step of a static run."""
        ...


@runtime_checkable
class ConjugateMatrix(Protocol):
    """Opt-in: the map to virtual-work conjugate increments as a matrix (the stability analysis).

    Without it, the tangent's rows and columns are taken as conjugate (T = I)."""

    def conjugate_matrix(self, state: State) -> sp.spmatrix:
        """T (n, n) sparse with w = T dq (:meth:`StaticProblem.conjugate`): T^T K is the second variation of
        the energy, symmetric at an equilibrium under conservative loads."""
        ...


@runtime_checkable
class DynamicProblem(Protocol):
    """Equations of motion M vdot + g(q, v, t) = 0 on a Lie group, velocities v in its Lie algebra.

    Also needs a mass: :class:`MassMatrix` or :class:`LumpedMass` (``require`` checks for one of them)."""

    n_dof: int
    """n, the number of free DoFs (the length of v, vdot and of the residual)."""

    dof_scale: np.ndarray | float
    """(n,) or scalar: as :attr:`StaticProblem.dof_scale` (convergence test and local error estimate)."""

    def update(self, state: State, dq: np.ndarray) -> State:
        """q o exp(dq) on the free DoFs (n,); a new state."""
        ...

    def residual(self, state: State, v: np.ndarray, vdot: np.ndarray, t: float) -> np.ndarray:
        """r = M vdot + g(q, v, t), (n,), in force units, at time t (s)."""
        ...

    def residual_and_tangent(self, state: State, v: np.ndarray, vdot: np.ndarray,
                             t: float) -> tuple[np.ndarray, sp.spmatrix]:
        """(r (n,), K_t (n, n) sparse): the residual and the stiffness part dg/dq of its tangent (the
        integrator adds M beta' and the damping C_t gamma')."""
        ...

    def initial_acceleration(self, state: State, t: float = 0.0, v: np.ndarray | None = None) -> np.ndarray:
        """vdot_0 = -M^-1 g(q_0, v_0, t_0), (n,): the consistent start of the second-order scheme."""
        ...


@runtime_checkable
class MassMatrix(Protocol):
    """The constant mass of a :class:`DynamicProblem` as a sparse matrix (lumped or consistent)."""

    def mass_matrix(self) -> sp.spmatrix:
        """M (n, n) sparse, constant."""
        ...


@runtime_checkable
class LumpedMass(Protocol):
    """The constant mass of a :class:`DynamicProblem` as a diagonal (used when there is no ``mass_matrix``)."""

    mass: np.ndarray
    """(n,): the diagonal of M."""


@runtime_checkable
class Damped(Protocol):
    """Opt-in: velocity-dependent damping forces in g, whose velocity derivative enters the iteration matrix
    (without it: none). The work they dissipate is the model's to account for (a :class:`StepObserver`)."""

    def damping_matrix(self, state: State) -> sp.spmatrix | None:
        """C_t (n, n) sparse, the velocity derivative of f_d (in the iteration matrix only), or None."""
        ...


@runtime_checkable
class Prescribed(Protocol):
    """Opt-in: nodes whose motion is prescribed in time (kept in place for every iterate)."""

    def prescribe(self, state: State, t: float) -> State:
        """The state with the prescribed nodes at their places at time t (s)."""
        ...


@runtime_checkable
class TransferAlongMotion(Protocol):
    """Opt-in: carry an old factorization of the iteration matrix along the body's rigid motion
    (``AlphaSettings.rotate_matrix``); without it, the factorization is used as it is."""

    def transfer(self, state_ref: State, state: State) -> Any:
        """P: the map of DoF components from the configuration ``state_ref`` (where the matrix was factorized)
        to ``state`` (opaque to the integrator, passed back to ``apply_transfer``)."""
        ...

    def apply_transfer(self, x: np.ndarray, P: Any, transpose: bool = False) -> np.ndarray:
        """P x, or P^T x with ``transpose``, (n,)."""
        ...


@runtime_checkable
class WrapsStaticProblem(Protocol):
    """Opt-in: a dynamic problem built on a static model, whose reference configuration is the default start."""

    model: StaticProblem


@dataclass(frozen=True)
class Capabilities:
    """The opt-in capabilities of a problem, resolved once (:func:`capabilities`): each is the problem itself
    when it has the capability, else None (the integrator then does without it, as documented on each)."""

    mixed_iteration: MixedIteration | None = None
    support_check: SupportCheck | None = None
    conjugate_matrix: ConjugateMatrix | None = None
    mass_matrix: MassMatrix | None = None
    damped: Damped | None = None
    prescribed: Prescribed | None = None
    transfer: TransferAlongMotion | None = None
    static_model: StaticProblem | None = None


def capabilities(problem: object) -> Capabilities:
    """The opt-in capabilities of ``problem`` (static or dynamic): the one place where the integrators check
    them, with ``isinstance`` on the ``runtime_checkable`` protocols above."""
    def having(protocol: type):
        return problem if isinstance(problem, protocol) else None

    return Capabilities(mixed_iteration=having(MixedIteration), support_check=having(SupportCheck),
                        conjugate_matrix=having(ConjugateMatrix), mass_matrix=having(MassMatrix),
                        damped=having(Damped), prescribed=having(Prescribed), transfer=having(TransferAlongMotion),
                        static_model=problem.model if isinstance(problem, WrapsStaticProblem) else None)


@dataclass(frozen=True)
class AcceptedStep:
    """A time step accepted by :func:`integrators.generalized_alpha.generalized_alpha`, as the integrator has it,
    given to every :class:`StepObserver` (the start of the run too, as ``initial``).

    Vectors are on the free DoFs (n,); the arrays are the integrator's own: an observer must not change them.
    Counts (``substeps``, ``rejected_*``) are those of the output record this step would make: with fixed steps
    the sub-steps of this step after cut-backs, and the failed tries since the previous output step; with
    adaptive steps the accepted steps and the rejections since the previous output step (this one included).
    """

    index: int                        # the step number from the run's start (a restart's ``first_step`` counted)
    time: float                       # t_{n+1} (s)
    step_size: float                  # t_{n+1} - t_n as taken (sub-steps included); 0 for the initial state
    state: State                      # q_{n+1}
    previous_velocity: np.ndarray     # v_n, at the start of the step
    velocity: np.ndarray              # v_{n+1}
    acceleration: np.ndarray          # vdot_{n+1}
    pseudo_acceleration: np.ndarray   # a_{n+1}
    iterations: int = 0               # Newton iterations (of the last accepted step; its sub-steps summed)
    residuals: tuple[float, ...] = ()     # ||r|| at each iterate
    corrections: tuple[float, ...] = ()   # the weighted RMS norm of each correction
    refreshes: int = 0                # iteration-matrix refreshes (each a factorization)
    substeps: int = 1
    rejected_error: int = 0           # steps rejected by the error estimate (adaptive)
    rejected_newton: int = 0          # tries whose Newton iteration failed
    h: float = 0.0                    # the size of the last (sub-)step taken (s); 0 for the initial state
    error_estimate: float = float("nan")  # the weighted local error estimate of the step (adaptive; <= 1)
    output: bool = False              # an output step (every ``record_every``-th, and the last)
    initial: bool = False             # the start of the run (no step taken)
    wall_time: float = 0.0            # seconds since the integrator started


@runtime_checkable
class StepObserver(Protocol):
    """Called with every :class:`AcceptedStep` of a run, the initial state first, in order. What the integrator
    does not need (energies, momenta, dissipated work, output files) is computed by observers. An exception
    raised by an observer (a ``KeyboardInterrupt`` too) ends the run there."""

    def __call__(self, step: AcceptedStep) -> None:
        ...


def members(protocol: type) -> list[str]:
    """The public member names a protocol asks for (methods and annotated attributes, its bases included)."""
    names: list[str] = []
    for base in reversed(protocol.__mro__):
        if base in (object, Protocol) or base.__name__ == "Generic":
            continue
        for name in (*base.__dict__.get("__annotations__", {}), *base.__dict__):
            if not name.startswith("_") and name not in names:
                names.append(name)
    return names


def missing(obj: object, protocol: type) -> list[str]:
    """The members of ``protocol`` that ``obj`` lacks (empty: ``isinstance(obj, protocol)``)."""
    return [name for name in members(protocol) if not hasattr(obj, name)]


def require(obj: object, protocol: type, role: str) -> None:
    """Raise a one-line ``TypeError`` naming the members of ``protocol`` that ``obj`` (the ``role``, e.g.
    "the static problem") lacks. For a :class:`DynamicProblem`, a mass (:class:`MassMatrix` or
    :class:`LumpedMass`) is required too."""
    lacking = missing(obj, protocol)
    if protocol is DynamicProblem and not isinstance(obj, (MassMatrix, LumpedMass)):
        lacking.append("mass_matrix (or mass)")
    if lacking:
        raise TypeError(f"{role} {type(obj).__name__} lacks {', '.join(lacking)} "
                        f"(the contract integrators.protocols.{protocol.__name__})")
