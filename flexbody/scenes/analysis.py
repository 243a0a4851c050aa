"""What a scene computes: a static path (:class:`StaticAnalysis`: load control or arc length) or a motion in
time (:class:`DynamicAnalysis`: Lie-group generalized-alpha, :mod:`integrators.generalized_alpha`), and the
saved step a run may continue from (:class:`RestartPoint`).

Plain data: nothing here imports the dynamics at module level (a static run never assembles a mass matrix).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, ClassVar

import numpy as np

from integrators.newton import NewtonSettings


@dataclass(frozen=True)
class StaticAnalysis:
    """method: "load_control" (steps to the listed load factors) or "arc_length"; ``arc_options``: the
    arc-length step-length controls (``integrators.static.ARC_LENGTH_OPTIONS``: ``max_steps``,
    ``min_increment_ratio``, ``max_increment_ratio``, ``desired_iterations``) that differ from the defaults
    of :func:`integrators.static.arc_length`. ``stability``: count the negative eigenvalues of the tangent
    at every converged step and report limit and bifurcation points (one symmetric factorization per step;
    docs/stability.md)."""

    method: str = "load_control"
    load_factors: tuple[float, ...] = tuple(np.linspace(0.05, 1.0, 20))
    arc_increment: float = 0.05
    max_load_increment: float | None = None
    newton: NewtonSettings = field(default_factory=NewtonSettings)
    arc_options: dict = field(default_factory=dict)
    stability: bool = True


#: rho_inf where a run does not give one
DEFAULT_RHO_INF = 0.9


def default_rho_inf(initial_state: object | None, prescribed: tuple) -> float:
    """The spectral radius rho_inf of a dynamic run that does not give one.

    0.9 (little numerical damping), except for a start on the steady spin with a driven hub (prescribed
    motion): :data:`flexbody.spinning.STEADY_SPIN_RHO_INF`, whose stronger damping of the unresolved
    high-frequency director (transverse-shear) oscillations a kick on a spinning thin membrane excites keeps
    the modified Newton iteration contracting (docs/dynamics.md, "Spinning membranes"). A free body keeps 0.9:
    its energy and momenta are the conserved quantities one checks, and 0.5 dissipates energy visibly.
    """
    from flexbody.spinning import STEADY_SPIN_RHO_INF, SteadySpinStart
    if isinstance(initial_state, SteadySpinStart) and prescribed:
        return STEADY_SPIN_RHO_INF
    return DEFAULT_RHO_INF


@dataclass(frozen=True, eq=False)
class DynamicAnalysis:
    """Time integration from t = 0 to ``end_time`` with the Lie-group generalized-alpha method.

    Parameters
    ----------
    time_step : h (rounded down so that whole steps end at ``end_time``)
    end_time : the end of the run
    rho_inf : spectral radius at infinite frequency in [0, 1] (1: no numerical damping); None: the default of
        the start (:func:`default_rho_inf`: 0.5 for a steady-spin start with a driven hub, else 0.9); the
        value used is :attr:`rho_inf_used`
    policy : iteration matrix "modified" (kept across iterations and steps, refreshed when the contraction
        is poor) or "full" (refreshed every iteration)
    output_every : record the outputs, energies and momenta (and write the files) every k-th step
    gravity : body acceleration g (3,)
    load_factor : lambda(t) that scales the Model's loads (None: 1 at all times), or for a Model with load
        groups (``Model.load_groups``) the factors (G,) of its groups, e.g.
        :class:`flexbody.time_functions.GroupFactors`
    prescribed : rigid motions in time of clamped nodes (:class:`flexbody.dynamics.PrescribedMotion`)
    initial_state : the configuration at t = 0 (None: the reference configuration), or
        :class:`flexbody.spinning.SteadySpinStart`: the steady spin (relative equilibrium) at a constant
        angular velocity with its rigid velocity field, to which ``initial_velocity`` and
        ``initial_angular_velocity`` are then added (a kick); a driven hub must turn at that rate from t = 0
    initial_velocity : nodal translational velocities at t = 0 (n, 3) (None: zero)
    initial_angular_velocity : nodal angular velocities at t = 0 in global components (n, 3) (None: zero);
        the components about the directors are not DoFs and are dropped
    settings : the integrator's other settings (tolerances, iterations, cut-backs); ``rho_inf`` and
        ``policy`` above override theirs
    damping : Rayleigh damping (:class:`flexbody.dynamics.RayleighDamping`: ``alpha_mass`` a0,
        ``beta_stiffness`` a1, or ``RayleighDamping.from_ratio(zeta, (f1, f2))``); None: undamped
    threads : numba threads of the element kernels during the run; None: one thread for meshes of fewer
        than ``SINGLE_THREAD_ELEMENTS`` elements (thread start-up dominates there: measured on a shared
        2-core machine, 100 steps of the 64-element membrane take 0.34 s on one thread and 2.1 s on two,
        20 steps of 1152 elements 0.72 s and 1.37 s), numba's default otherwise
    point_masses : tip masses and rotary inertias at nodes (:class:`flexbody.shell.inertia.PointMass`),
        added to the shell's inertia
    adaptive : error-controlled time steps (True), the fixed step (False), or None: the ``settings``' choice
        (fixed by default). Adaptive: ``time_step`` is the first step and the unit of the output times (every
        ``output_every``-th multiple of it, where the steps land), no step is longer than the output interval,
        and the tolerance and step limits are ``settings.error_tolerance``, ``min_step``, ``max_step``
        (docs/dynamics.md, "Adaptive time steps")
    mass : the mass matrix, "lumped" (HRZ, diagonal; default) or "consistent" (translations
        int rho h N_I N_J dA, director inertia lumped): ``flexbody.dynamics.DynamicModel(mass=...)``
    frame : where the equations of motion are solved: "inertial", "turning" (the frame turning with the
        steady spin of ``initial_state``, :mod:`flexbody.turning_frame`; outputs stay inertial), or None: the
        turning frame for a steady-spin start whose loads and prescribed motions allow it, else the inertial
        one (:func:`flexbody.turning_frame.turning_frame_model`)

    Compared by identity (it holds arrays and functions).
    """

    SINGLE_THREAD_ELEMENTS: ClassVar[int] = 2000
    #: the most time steps a run may ask for (1e12 steps hung in the list of output times)
    MAX_TIME_STEPS: ClassVar[int] = 10_000_000

    time_step: float
    end_time: float
    rho_inf: float | None = None
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
    point_masses: tuple = ()
    damping: object | None = None
    adaptive: bool | None = None
    mass: str = "lumped"
    frame: str | None = None

    def __post_init__(self) -> None:
        for name in ("time_step", "end_time"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.time_step > self.end_time:
            raise ValueError(f"time_step must not exceed end_time, got {self.time_step!r} > {self.end_time!r}")
        if self.end_time / self.time_step > self.MAX_TIME_STEPS:
            raise ValueError(f"end_time / time_step asks for {self.end_time / self.time_step:.3g} time steps, at most "
                             f"{self.MAX_TIME_STEPS} (time_step {self.time_step!r}, end_time {self.end_time!r})")
        if self.rho_inf is not None and (isinstance(self.rho_inf, bool) or not isinstance(self.rho_inf, (int, float))
                                         or not 0 <= self.rho_inf <= 1):
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
        if self.adaptive is not None and not isinstance(self.adaptive, bool):
            raise ValueError(f"adaptive must be True, False or None, got {self.adaptive!r}")
        from flexbody.dynamics import RayleighDamping
        if self.damping is not None and not isinstance(self.damping, RayleighDamping):
            raise ValueError(f"damping must be a RayleighDamping or None, got {type(self.damping).__name__}")
        from flexbody.shell.inertia import check_mass_kind
        check_mass_kind(self.mass)
        if self.frame not in (None, "inertial", "turning"):
            raise ValueError(f"frame must be 'inertial' or 'turning' (or None: the default), got {self.frame!r}")

    @property
    def rho_inf_used(self) -> float:
        """The spectral radius the run uses: ``rho_inf``, or without one the default of its start."""
        if self.rho_inf is not None:
            return float(self.rho_inf)
        return default_rho_inf(self.initial_state, self.prescribed)

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
        out = replace(base, rho_inf=self.rho_inf_used, policy=self.policy)
        return out if self.adaptive is None else replace(out, adaptive=self.adaptive)

    @property
    def is_adaptive(self) -> bool:
        """Error-controlled time steps (``adaptive``, else the settings')."""
        return bool(self.alpha_settings().adaptive)


@dataclass
class RestartPoint:
    """A saved step to continue a run from (:func:`flexbody.outputs.restart.read_restart`): its step number,
    load factor (static) or time (dynamic), the state, and for a dynamic run the free-DoF velocity v,
    acceleration vdot and generalized-alpha pseudo-acceleration a, and the work dissipated until then; for an
    arc-length path the :class:`integrators.static.ArcLengthState` of the step (``continuation``)."""

    step: int
    where: float
    state: object
    v: np.ndarray | None = None
    vdot: np.ndarray | None = None
    a: np.ndarray | None = None
    dissipated_energy: float = 0.0
    continuation: object | None = None
