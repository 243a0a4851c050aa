"""What a run reports: :class:`RunSummary`, as :class:`StaticRunSummary` (a static path) or
:class:`DynamicRunSummary` (a motion in time).

Both carry the steps, Newton iterations, tangent updates, factorizations, wall time, outputs and errors
against the reference; a dynamic run also the energy and momentum balance:

* energy: kinetic T, strain W and gravity V_g energy at the start and the end, the work D dissipated by
  damping (:class:`flexbody.dynamics.RayleighDamping`), and the largest drift of the balance E = T + W +
  V_g + D, max_t |E(t) - E(0)| / max_t (T + W + |V_g|) (``total`` is T + W + V_g; a damped body's
  ``total`` decreases by D, its balance does not);
* momenta (about the origin): linear p and angular L at the start and the end and their largest drifts,
  max_t |p(t) - p(0)| / max(|p(0)|, sqrt(2 M max_t T)) and max_t |L(t) - L(0)| / max_t |L(t)|.
  The momenta are conserved only by an isolated body (``momentum.isolated``: no constraints, loads,
  gravity or prescribed motion), the energy T + W + V_g by a conservative one (``energy.conservative``:
  no loads and no prescribed motion; fixed supports and gravity are allowed); otherwise the drifts
  measure the exchange with the surroundings.

A completed dynamic run is checked for answers not to be trusted (:attr:`DynamicRunSummary.warnings`: the
drift of a conserved energy or momentum, the rotation per step; limits ``MAX_*`` below, docs/robustness.md),
which ``flexbody run`` reports with exit code 3.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from flexbody.scenes.analysis import DynamicAnalysis
from integrators.static import StaticResult

ENERGY_KEYS = ("kinetic", "strain", "gravity", "total", "dissipated")

#: Accuracy limits of a completed dynamic run (docs/robustness.md, "Dynamic runs not to be trusted"): a run
#: beyond one of them warns and ``flexbody run`` exits with 3. The rotation per step |omega| h (rad) of the
#: body's fitted rigid spin or of a node's director: the phase error of a spin, 0.31 (|omega| h)^2 of the
#: angle turned (measured on ``spinning_plate``), reaches 1 % there:
MAX_ROTATION_PER_STEP = 0.18
#: the largest relative energy drift of a conservative body (``energy.total.max_rel_drift``; the built-in
#: scenes reach 1.5e-3 at their default time steps):
MAX_ENERGY_DRIFT = 0.02
#: the largest relative drift of either momentum of an isolated body (``momentum.*.max_rel_drift``; the
#: built-in scenes reach 7e-4):
MAX_MOMENTUM_DRIFT = 0.01
#: a drift is checked only for a motion faster than this many times the round-off velocity eps L / h (L the
#: body's size): a body at rest has energies of 1e-28 J and drifts of 100 % of that
RESOLVED_MOTION = 1e3


@dataclass
class RunSummary(ABC):
    """What every run reports, static or dynamic (:func:`flexbody.scenes.runner.run_scene` returns a
    :class:`StaticRunSummary` or a :class:`DynamicRunSummary`, both of this type).

    Attributes
    ----------
    scene, dofs, elements : the scene's name and size
    result : the solver's result (:class:`integrators.static.StaticResult` or
        :class:`integrators.generalized_alpha.DynamicResult`)
    history : the abscissa (``load_factor`` or ``time``) and every tracked output, per recorded step
    errors : the errors against the scene's reference (:func:`flexbody.scenes.compare.compare`)
    wall_time_s : the solve (after set-up and compilation)
    setup_time_s : building the scene (if the caller timed it) and the run's set-up (a dynamic run's mass)
    compile_time_s : compiling the kernels, or loading them from numba's cache
    """

    kind: ClassVar[str] = ""
    #: the history's abscissa
    abscissa: ClassVar[str] = ""

    scene: str
    dofs: int
    elements: int
    result: object
    history: dict[str, list[float]]
    errors: list[dict]
    wall_time_s: float
    setup_time_s: float = 0.0
    compile_time_s: float = 0.0

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

    @property
    def warnings(self) -> list[str]:
        """Why a completed run is not to be trusted (empty if it is)."""
        return []

    def final_outputs(self) -> dict[str, float]:
        """Every tracked output at the last recorded step."""
        return {k: v[-1] for k, v in self.history.items() if k != self.abscissa and v}

    @abstractmethod
    def as_dict(self) -> dict:
        """The summary as JSON-able data (``flexbody run --json``, the bench report, sweeps)."""


@dataclass
class StaticRunSummary(RunSummary):
    """A static path's summary (``result``: :class:`integrators.static.StaticResult`; ``history``:
    ``load_factor`` and every output per converged step), with the path's stability."""

    kind: ClassVar[str] = "static"
    abscissa: ClassVar[str] = "load_factor"

    def as_dict(self) -> dict:
        st = self.result.stats
        return {
            "scene": self.scene, "kind": "static", "dofs": self.dofs, "elements": self.elements,
            "steps": len(self.result.records), "newton_iterations": st.iterations,
            "tangent_updates": st.tangent_updates, "factorizations": st.factorizations,
            "newton_iteration": st.iteration, "wall_time_s": self.wall_time_s, "converged": self.result.converged,
            "message": self.result.message, "load_factor": self.result.load_factor,
            "outputs": self.final_outputs(),
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


@dataclass(kw_only=True)
class DynamicRunSummary(RunSummary):
    """The outcome of a dynamic scene run (``result``: :class:`integrators.generalized_alpha.DynamicResult`).

    Attributes (besides :class:`RunSummary`'s)
    ------------------------------------------
    history : ``time`` and every tracked output at t = 0 and every recorded step
    energies : ``time``, kinetic, strain, gravity and total energy, ``linear_momentum`` and
        ``angular_momentum`` (lists of 3-vectors) at the same instants
    isolated : the body is free, unloaded, without gravity and prescribed motion (its momenta are then
        conserved by the equations of motion)
    conservative : no loads and no prescribed motion (T + W + V_g is then conserved)
    rotation_per_step : the largest rotation per time step |omega| h over the recorded instants
        (:func:`flexbody.scenes.dynamic_run.rotation_rate`) and its time
    size : the diagonal of the body's bounding box in the reference configuration
    frame : where the run was solved, "inertial" or "turning" (:mod:`flexbody.turning_frame`; the outputs are
        inertial either way)
    records : the step records (:class:`flexbody.energy.DynamicStepRecord`) after the start: every output step,
        and the last converged one of a run that stopped between two
    """

    kind: ClassVar[str] = "dynamic"
    abscissa: ClassVar[str] = "time"

    analysis: DynamicAnalysis
    energies: dict[str, list]
    total_mass: float
    isolated: bool
    conservative: bool
    rotation_per_step: tuple[float, float] = (0.0, 0.0)
    size: float = 0.0
    records: list = field(default_factory=list)
    frame: str = "inertial"

    @property
    def largest_step(self) -> float:
        """The longest time step taken (the fixed step, or the adaptive run's longest accepted one)."""
        fixed = self.analysis.end_time / self.analysis.n_steps
        taken = getattr(self.result, "max_step", float("nan"))
        return float(taken) if getattr(self.result, "adaptive", False) and np.isfinite(taken) else fixed

    def step_summary(self) -> dict:
        """Accepted and rejected steps (by the error estimate, by Newton failures) and the step sizes taken."""
        r = self.result
        return {"adaptive": bool(getattr(r, "adaptive", False)), "accepted": int(getattr(r, "steps", self.steps)),
                "rejected_error": int(getattr(r, "rejected_error", 0)),
                "rejected_newton": int(getattr(r, "rejected_newton", 0)),
                "min": float(getattr(r, "min_step", float("nan"))), "max": float(getattr(r, "max_step", float("nan"))),
                "error_tolerance": self.analysis.alpha_settings().error_tolerance}

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

    @property
    def steps(self) -> int:
        """Time steps taken (the last recorded one; all of them for a completed run)."""
        return self.records[-1].step if self.records else 0

    def energy_summary(self) -> dict:
        """Initial and final energies, and the largest drift of the balance T + W + V_g + D (module docstring;
        reported as ``total.max_drift``, ``total.max_rel_drift``)."""
        e = {k: np.asarray(self.energies[k], dtype=float) for k in ENERGY_KEYS}
        out: dict = {"conservative": self.conservative}
        out.update({k: {"initial": float(e[k][0]) + 0.0, "final": float(e[k][-1]) + 0.0} for k in ENERGY_KEYS})
        scale = float(np.max(e["kinetic"] + e["strain"] + np.abs(e["gravity"])))
        balance = e["total"] + e["dissipated"]                  # T + W + V_g + D
        drift = np.abs(balance - balance[0])
        out["total"]["max_drift"] = float(drift.max())
        out["total"]["max_rel_drift"] = float(drift.max() / scale) if scale > 0 else float("nan")
        out["strain"]["max"] = float(e["strain"].max())
        return out

    def momentum_summary(self) -> dict:
        """Initial and final linear and angular momenta (about the origin) and their largest drifts."""
        p = np.asarray(self.energies["linear_momentum"], dtype=float)
        L = np.asarray(self.energies["angular_momentum"], dtype=float)
        kinetic = np.asarray(self.energies["kinetic"], dtype=float)
        p_scale = max(float(np.linalg.norm(p[0])), float(np.sqrt(2.0 * self.total_mass * kinetic.max())))
        L_scale = float(np.linalg.norm(L, axis=1).max())
        out = {"isolated": self.isolated}
        for name, arr, scale in (("linear", p, p_scale), ("angular", L, L_scale)):
            drift = float(np.linalg.norm(arr - arr[0], axis=1).max())
            out[name] = {"initial": arr[0].tolist(), "final": arr[-1].tolist(), "max_drift": drift,
                         "max_rel_drift": drift / scale if scale > 0 else float("nan")}
        return out

    @property
    def warnings(self) -> list[str]:
        """Why a completed run is not to be trusted (empty if it is): a conserved quantity drifted beyond
        ``MAX_ENERGY_DRIFT`` or ``MAX_MOMENTUM_DRIFT`` of its scale, or the body turned by more than
        ``MAX_ROTATION_PER_STEP`` in a time step."""
        out = []
        h = self.largest_step
        resolved = RESOLVED_MOTION * np.finfo(float).eps * self.size / h    # a velocity
        e = {k: np.asarray(self.energies[k], dtype=float) for k in ENERGY_KEYS}
        energy_velocity = np.sqrt(2.0 * np.max(e["kinetic"] + e["strain"] + np.abs(e["gravity"])) / self.total_mass)
        drift = self.energy_summary()["total"]["max_rel_drift"]
        if self.conservative and energy_velocity > resolved and drift > MAX_ENERGY_DRIFT:
            out.append(f"the energy of this conservative body drifted by {drift:.3g} of its scale "
                       f"(limit {MAX_ENERGY_DRIFT:g})")
        momenta = self.momentum_summary()
        for name in ("linear", "angular"):
            drift = momenta[name]["max_rel_drift"]
            if self.isolated and energy_velocity > resolved and drift > MAX_MOMENTUM_DRIFT:
                out.append(f"the {name} momentum of this isolated body drifted by {drift:.3g} of its scale "
                           f"(limit {MAX_MOMENTUM_DRIFT:g})")
        turn, at = self.rotation_per_step
        if turn > MAX_ROTATION_PER_STEP:
            out.append(f"the body turns by {turn:.3g} rad in a time step at t = {at:.4g} s (accuracy limit "
                       f"{MAX_ROTATION_PER_STEP:g} rad): take dt <= {h * MAX_ROTATION_PER_STEP / turn:.3g} s")
        return out

    def as_dict(self) -> dict:
        st = self.result.stats
        a = self.analysis
        return {
            "scene": self.scene, "kind": "dynamic", "dofs": self.dofs, "elements": self.elements,
            "steps": self.steps, "newton_iterations": st.iterations, "tangent_updates": st.tangent_updates,
            "factorizations": st.factorizations, "wall_time_s": self.wall_time_s,
            "iterations_per_step": st.iterations / max(self.steps, 1),
            "factorizations_per_step": st.factorizations / max(self.steps, 1),
            "converged": self.result.converged, "message": self.result.message, "time": float(self.result.time),
            "end_time": a.end_time, "time_step": a.end_time / a.n_steps, "rho_inf": a.rho_inf_used, "policy": a.policy,
            "rho_inf_default": a.rho_inf is None,
            "time_steps": self.step_summary(),
            "mass": a.mass,
            "frame": self.frame, "frame_default": a.frame is None,
            "outputs": self.final_outputs(),
            "errors": self.errors, "max_rel_error": self.max_rel_error,
            "energy": self.energy_summary(), "momentum": self.momentum_summary(),
            "energy_history": {k: list(map(float, self.energies[k])) for k in ("time", *ENERGY_KEYS)},
            **timings(self),
            "rotation_per_step": {"max": self.rotation_per_step[0], "time": self.rotation_per_step[1],
                                  "limit": MAX_ROTATION_PER_STEP},
            "warnings": self.warnings,
        }
