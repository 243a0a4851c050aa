"""Energy and momentum bookkeeping of a shell in motion, observed from outside the time integrator.

The generalized-alpha integrator (:func:`integrators.generalized_alpha.generalized_alpha`) computes no energies:
it gives every accepted step to its observers (:class:`integrators.protocols.StepObserver`) as an
:class:`integrators.protocols.AcceptedStep`. :class:`EnergyAccount` is the observer of a shell model
(:class:`flexbody.dynamics.DynamicModel`): it accumulates the work dissipated by the damping forces at every
step and, at every output step, evaluates the kinetic, strain and gravity energies and the momenta
(:class:`EnergyRecord`) into a :class:`DynamicStepRecord`, the record the outputs, the summary and the
Python API read. :func:`integrate_motion` runs the integrator with an account.

Dissipated work: with damping, D(t) = int_0^t v . f_d dt is carried in the records, so that T + W + V_g + D
is the conserved balance of an otherwise conservative body. Per step, D += h v_m . f_m with the means
v_m = (v_n + v_{n+1}) / 2, f_m = (f_d,n + f_d,n+1) / 2 (``dyn.damping_force(q, v)``): the work of the mean
damping force on the step's displacement h v_m, which for rho_inf = 1 (h dq_n = h v_m) is the scheme's own
energy loss on a linear system (the trapezoidal rule's energy identity). The trapezoid of the power
v . f_d instead overestimates it on overdamped modes, whose velocities alternate in sign.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from integrators.generalized_alpha import DynamicResult, generalized_alpha
from integrators.protocols import AcceptedStep

__all__ = ["EnergyRecord", "DynamicStepRecord", "EnergyAccount", "AccountedMotion", "integrate_motion",
           "dissipated_work"]


@dataclass(frozen=True)
class EnergyRecord:
    """The energies (J) and momenta of a shell's state: kinetic T, strain W, gravity potential V_g, the work D
    dissipated since the start, linear p (kg m/s) and angular L (kg m^2/s, about the origin) momentum."""

    kinetic: float
    strain: float
    gravity: float
    dissipated: float
    linear_momentum: np.ndarray
    angular_momentum: np.ndarray

    @classmethod
    def of(cls, dyn, state, v: np.ndarray, dissipated: float = 0.0) -> "EnergyRecord":
        """The record of ``state`` with free-DoF velocity ``v`` (:class:`flexbody.dynamics.DynamicModel`'s
        ``kinetic_energy``, ``strain_energy``, ``gravity_potential`` and ``momenta``)."""
        p, L = dyn.momenta(state, v)
        return cls(dyn.kinetic_energy(v), dyn.strain_energy(state), dyn.gravity_potential(state), dissipated, p, L)

    @property
    def total(self) -> float:
        """The mechanical energy T + W + V_g (without the dissipated work)."""
        return self.kinetic + self.strain + self.gravity

    @property
    def balance(self) -> float:
        """T + W + V_g + D: conserved by an otherwise conservative body, damped or not."""
        return self.total + self.dissipated


@dataclass
class DynamicStepRecord:
    """One recorded time step: the integrator's work (iterations, histories, step counts) and the energies and
    momenta of its state (:class:`EnergyRecord`)."""

    step: int
    time: float
    iterations: int
    residuals: list[float]            # ||r|| at each iterate
    corrections: list[float]          # weighted RMS norm of each correction
    refreshed: int                    # iteration-matrix refreshes in this step
    substeps: int                     # 1, or the number of sub-steps after cut-backs
    kinetic_energy: float
    strain_energy: float
    potential_energy: float           # gravity
    linear_momentum: np.ndarray
    angular_momentum: np.ndarray
    wall_time: float
    dissipated_energy: float = 0.0    # D(t), the work of the damping forces since the start
    #: the step's end values on the free DoFs {"v", "vdot", "a"} (and the nodal fields the scene runs add)
    motion: dict | None = None
    h: float = 0.0                    # the size of the last step taken (of the last sub-step after cut-backs)
    rejected_error: int = 0           # steps rejected by the error estimate since the previous record
    rejected_newton: int = 0          # steps whose Newton iteration failed since the previous record
    error_estimate: float = float("nan")  # the last step's weighted local error estimate (adaptive; <= 1)

    @classmethod
    def of_state(cls, step: int, t: float, energy: EnergyRecord, wall_time: float) -> "DynamicStepRecord":
        """The record of a state without solver statistics (an initial state, the last converged state of a run
        that stopped between two output steps): 0 iterations."""
        return cls(step, t, 0, [], [], 0, 1, energy.kinetic, energy.strain, energy.gravity, energy.linear_momentum,
                   energy.angular_momentum, wall_time, energy.dissipated)

    @classmethod
    def of_step(cls, step: AcceptedStep, energy: EnergyRecord) -> "DynamicStepRecord":
        """The record of an accepted output step, with its motion {"v", "vdot", "a"}."""
        return cls(step.index, step.time, step.iterations, list(step.residuals), list(step.corrections),
                   step.refreshes, step.substeps, energy.kinetic, energy.strain, energy.gravity,
                   energy.linear_momentum, energy.angular_momentum, step.wall_time, energy.dissipated,
                   motion=_motion(step), h=step.h, rejected_error=step.rejected_error,
                   rejected_newton=step.rejected_newton, error_estimate=step.error_estimate)

    @property
    def total_energy(self) -> float:
        """The mechanical energy T + W + V_g (without the dissipated work)."""
        return self.kinetic_energy + self.strain_energy + self.potential_energy

    @property
    def energy_balance(self) -> float:
        """T + W + V_g + D: conserved by an otherwise conservative body, damped or not."""
        return self.total_energy + self.dissipated_energy


def _motion(step: AcceptedStep) -> dict:
    return {"v": step.velocity, "vdot": step.acceleration, "a": step.pseudo_acceleration}


def dissipated_work(h: float, v_old: np.ndarray, v: np.ndarray, f_old: np.ndarray, f_new: np.ndarray) -> float:
    """The work of the damping forces over a step of h: h v_m . f_m with the step's means v_m = (v_n + v_{n+1})/2,
    f_m = (f_d,n + f_d,n+1)/2 (module docstring)."""
    return 0.25 * h * float((v_old + v) @ (f_old + f_new))


class EnergyAccount:
    """The energy and momentum bookkeeping of a shell run: a :class:`integrators.protocols.StepObserver`.

    Parameters
    ----------
    dyn : the equations of motion (:class:`flexbody.dynamics.DynamicModel`)
    on_record : called as ``on_record(record, state, v)`` with every :class:`DynamicStepRecord` of an output
        step, and by :meth:`interrupted` with the last accepted step's
    dissipated : the work D dissipated before the start (a restart)

    Attributes
    ----------
    initial : the record of the start (no motion), set when the run starts
    records : the records of the output steps, in order
    dissipated : D at the last accepted step
    last : the last :class:`integrators.protocols.AcceptedStep` seen
    """

    def __init__(self, dyn, on_record: Callable | None = None, dissipated: float = 0.0) -> None:
        self.dyn, self.on_record = dyn, on_record
        self.dissipated = float(dissipated)
        self.initial: DynamicStepRecord | None = None
        self.records: list[DynamicStepRecord] = []
        self.last: AcceptedStep | None = None
        self._f_damp: np.ndarray | None = None     # f_d at the last accepted step
        self._handed = -1                          # the index of the last step given to on_record

    @property
    def every_step(self) -> bool:
        """Whether the account needs every accepted step: only to sum the work of a damping force. An undamped
        body's account needs the start, the output steps and the last accepted step of a stopped run
        (:class:`flexbody.turning_frame.InertialObservers` then maps only these to the inertial frame)."""
        return getattr(self.dyn, "damping", True) is not None      # unknown: every step

    def __call__(self, step: AcceptedStep) -> None:
        """Account for an accepted step (the start first): D, and at an output step the record."""
        f_new = self.dyn.damping_force(step.state, step.velocity)
        if step.initial:
            self._f_damp, self.last, self._handed = f_new, step, step.index
            energy = EnergyRecord.of(self.dyn, step.state, step.velocity, self.dissipated)
            self.initial = DynamicStepRecord.of_state(step.index, step.time, energy, step.wall_time)
            return
        self.dissipated += dissipated_work(step.step_size, step.previous_velocity, step.velocity, self._f_damp, f_new)
        self._f_damp, self.last = f_new, step
        if step.output:
            rec = DynamicStepRecord.of_step(step, EnergyRecord.of(self.dyn, step.state, step.velocity, self.dissipated))
            self.records.append(rec)
            self._hand_over(rec, step)

    def state_record(self, step: int, t: float, state, v: np.ndarray, wall_time: float = 0.0) -> DynamicStepRecord:
        """A record of ``state`` without solver statistics, with the work dissipated so far."""
        return DynamicStepRecord.of_state(step, t, EnergyRecord.of(self.dyn, state, v, self.dissipated), wall_time)

    def interrupted(self) -> None:
        """Ctrl-C / a stop request: give ``on_record`` the last accepted step if it was not recorded (0 iterations,
        with its motion)."""
        last = self.last
        if self.on_record is None or last is None or last.index <= self._handed:
            return
        rec = self.state_record(last.index, last.time, last.state, last.velocity, last.wall_time)
        rec.motion = _motion(last)
        self._hand_over(rec, last)

    def _hand_over(self, rec: DynamicStepRecord, step: AcceptedStep) -> None:
        self._handed = step.index
        if self.on_record is not None:
            self.on_record(rec, step.state, step.velocity)


@dataclass(frozen=True)
class AccountedMotion:
    """A run of :func:`integrate_motion`: the integrator's result and the account's records."""

    result: DynamicResult
    initial: DynamicStepRecord
    records: list[DynamicStepRecord]
    dissipated_energy: float          # D at ``result.time``


def integrate_motion(dyn, t_end: float, h: float, *, on_step: Callable | None = None, dissipated_energy: float = 0.0,
                     **options) -> AccountedMotion:
    """:func:`integrators.generalized_alpha.generalized_alpha` with an :class:`EnergyAccount`.

    ``on_step(record, state, v)`` is called with every output step's record; a ``KeyboardInterrupt`` hands the
    last accepted step over to it (if it was not recorded) and is re-raised. ``dissipated_energy``: D at the
    start (a restart); ``options``: those of ``generalized_alpha`` (``observers`` are added to the account).
    """
    account = EnergyAccount(dyn, on_step, dissipated_energy)
    observers = (account, *options.pop("observers", ()))
    try:
        result = generalized_alpha(dyn, t_end, h, observers=observers, **options)
    except KeyboardInterrupt:
        account.interrupted()
        raise
    return AccountedMotion(result, account.initial, account.records, account.dissipated)
