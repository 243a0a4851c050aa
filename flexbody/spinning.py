"""Steady spin: the relative equilibrium of a shell body turning at a constant angular velocity.

A body that turns rigidly at a constant angular velocity Omega about an axis through ``c`` while its shape
stays fixed in the turning frame is a *relative equilibrium*: every node moves on a circle,
xddot_I = Omega x (Omega x r_I) with r_I = x_I - c, and its frames turn with it. Put into the equations of
motion of :class:`flexbody.dynamics.DynamicModel`, M vdot + f_int - lambda f_ext - f_g = 0, this is a static
problem in the turning frame::

    r_spin(q) = f_int(q) - lambda f_ext(q) - f_g - f_c(q) = 0

with the centrifugal load f_c of the model's own mass matrix (``DynamicModel.mass``, lumped or consistent),

* on the translations: f_c,I = -sum_J S_IJ Omega x (Omega x r_J) = sum_J S_IJ (|Omega|^2 1 - Omega Omega^T) r_J
  with S the translational scalar mass (S = diag(m_I) lumped; the sum runs over the free nodes and the driven
  hub nodes, whose accelerations the dynamic model adds as M_fp a_p(t); a node clamped without a prescribed
  motion stays at rest and adds nothing),
* on the two director rotations: the moment j_I (t_I . Omega) (Omega x t_I), the inertia moment that
  makes the director of inertia j_I diag(1, 1, 0) follow the spin (zero for a director along the axis),
  in the nodal local frame m = j w_3 (w_2, -w_1) with w = R_I^T Omega (it is j wdot of the dynamic model
  along the spinning, parallel-transported frame).

Because the load is the one of the model's mass matrix, the state found here, started with the rigid
velocity field v = Omega x r (``DynamicModel.rigid_velocity``), is an exact solution of the *discrete*
equations of motion: the dynamic run then stays on it (up to the time integrator's error, which for a
uniform rotation is the phase error of the rigid motion only). The tangent of f_c on the group (columns
along x_I + R_I du_I and R_I exp(theta)) is

* translations: d f_c,I / d u_J = S_IJ (|Omega|^2 1 - Omega Omega^T) R_J (a negative stiffness: the spin
  softens the radial direction), and
* rotations: d m / d theta_k = (dm / dw) (w x e_k), because w -> exp(-hat(theta)) w = w + hat(w) theta.

A driven hub is held (clamped) in the turning frame. A free body has two neutral rigid motions in the
turning frame that nothing resists: the translation along the axis and the rotation about it. They are
gauged by fixing the axial translation of the node nearest the centre and the circumferential translation of
the node farthest from the axis (:class:`flexbody.constraints.FixDirection`); those gauge supports carry no
load in a relative equilibrium, and :func:`steady_spin` checks that they carry none (else there is no steady
spin about that axis, e.g. a free body under a net axial load). The other rigid motions are restrained by
the centrifugal stiffness itself (the translations normal to the axis, with a negative stiffness; the tilts).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from flexbody.assembly import Model
from flexbody.body import ShellState
from flexbody.constraints import FixDirection
from flexbody.dynamics import DynamicModel


def finite_vector(value, what: str) -> np.ndarray:
    """``value`` as a finite 3-vector, or a ValueError naming ``what`` and the value."""
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be a finite 3-vector, got {value!r}")
    return v


def centrifugal_matrix(omega: np.ndarray) -> np.ndarray:
    """A = |Omega|^2 I - Omega Omega^T (3, 3, symmetric): -Omega x (Omega x r) = A r."""
    return float(omega @ omega) * np.eye(3) - np.outer(omega, omega)


def centrifugal_forces(mass: np.ndarray, x: np.ndarray, omega: np.ndarray, center: np.ndarray) -> np.ndarray:
    """Nodal centrifugal forces f_I = -m_I Omega x (Omega x (x_I - c)) = m_I A (x_I - c) (:func:`centrifugal_matrix`),
    (n, 3)."""
    return mass[:, None] * ((x - center) @ centrifugal_matrix(omega))


def director_spin_moments(rotary: np.ndarray, frames: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Local moments (n, 2) on the director rotations: j_I w_3 (w_2, -w_1), w = R_I^T Omega.

    In global components this is j_I (t_I . Omega) (Omega x t_I) (the inertia moment of the spinning director).
    """
    w0, w1, w2 = (frames[:, :, i].dot(omega) for i in range(3))      # w_i = sum_j Omega_j R_ji
    out = np.empty((len(frames), 2))
    out[:, 0], out[:, 1] = w1, -w0
    return (rotary * w2)[:, None] * out


def director_spin_moment_tangent(rotary: np.ndarray, frames: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """d m / d theta_k (n, 2, 2) of :func:`director_spin_moments` along R_I exp(theta_k e_k), k = 1, 2."""
    w = np.einsum("nji,j->ni", frames, omega)
    dm_dw = np.zeros((len(w), 2, 3))                  # m1 = j w3 w2, m2 = -j w3 w1
    dm_dw[:, 0, 1], dm_dw[:, 0, 2] = w[:, 2], w[:, 1]
    dm_dw[:, 1, 0], dm_dw[:, 1, 2] = -w[:, 2], -w[:, 0]
    dm_dw *= rotary[:, None, None]
    dw = np.cross(w[:, None, :], np.eye(3)[None, :2, :])   # (n, 2, 3): w x e_k for k = 1, 2
    return np.einsum("nij,nkj->nik", dm_dw, dw)


@dataclass
class SpinningModel:
    """The static equations of a relative equilibrium (steady spin) of a dynamic model.

    Parameters
    ----------
    dynamic : the body in motion (its mass, gravity and loads); the loads at ``load_factor_time``
    omega : the angular velocity (3,) [rad/s]
    center : a point of the spin axis (3,)
    load_factor_time : the time t at which the dynamic model's load factor lambda(t) is taken

    The continuation parameter ``lam`` of the static solvers scales the whole load: the centrifugal load,
    gravity and the model's loads (lam = 1: the spin at ``omega``). The residual rows and the increments are
    those of ``dynamic.model`` (a :class:`flexbody.assembly.Model`), so its group update, its mixed Newton
    iteration and its DoF scales serve unchanged.
    """

    dynamic: DynamicModel
    omega: np.ndarray
    center: np.ndarray
    load_factor_time: float = 0.0
    _index: np.ndarray = field(init=False, repr=False)
    _rows: np.ndarray = field(init=False, repr=False)       # _row_maps(), constant
    _turning: np.ndarray = field(init=False, repr=False)    # _moving() as 0/1 masses, constant
    _centrifugal: sp.csr_matrix = field(init=False, repr=False)   # (x - c).ravel() -> the translational rows of f_c
    _rotations: tuple = field(init=False, repr=False)       # (nodes, component, free DoF) of the director rotations

    def __post_init__(self) -> None:
        self.omega = finite_vector(self.omega, "the spin angular velocity")
        self.center = finite_vector(self.center, "the spin centre")
        m = self.model
        index = -np.ones(6 * m.body.n_nodes, dtype=np.int64)
        index[m.free] = np.arange(m.n_dof)
        self._index = index.reshape(-1, 6)
        self._rows = self._row_maps()
        self._turning = self._moving().astype(float)
        self._centrifugal = self._centrifugal_operator()
        nodes, comp = np.nonzero(self._index[:, 3:5] >= 0)
        self._rotations = (nodes, comp, self._index[nodes, 3 + comp])

    # -- the static-model contract of the integrators ------------------------------------------------------
    @property
    def model(self) -> Model:
        return self.dynamic.model

    @property
    def n_dof(self) -> int:
        return self.model.n_dof

    @property
    def dof_scale(self) -> np.ndarray:
        return self.model.dof_scale

    @property
    def supports_mixed_iteration(self) -> bool:
        return self.model.supports_mixed_iteration

    def initial_state(self) -> ShellState:
        return self.model.initial_state()

    def update(self, state: ShellState, dq: np.ndarray) -> ShellState:
        return self.model.update(state, dq)

    def conjugate(self, state: ShellState, dq: np.ndarray) -> np.ndarray:
        return self.model.conjugate(state, dq)

    def with_stresses(self, state: ShellState) -> ShellState:
        return self.model.with_stresses(state)

    def conjugate_matrix(self, state: ShellState) -> sp.csc_matrix:
        return self.model.conjugate_matrix(state)

    def check_static_support(self) -> None:
        """Nothing to check beyond the gauge: the centrifugal stiffness restrains the other rigid motions."""

    # -- loads ---------------------------------------------------------------------------------------------
    def _row_maps(self) -> np.ndarray:
        """E_I^T (rows of nodes with a fixed translation basis) or 1: the translational rows' directions."""
        m = self.model
        S = np.tile(np.eye(3), (m.body.n_nodes, 1, 1))
        S[m.has_basis] = np.transpose(m.basis[m.has_basis], (0, 2, 1))
        return S

    def _moving(self) -> np.ndarray:
        """The nodes that turn with the spin (n,) bool: all but those clamped in translation and not driven (those
        stay at rest in the dynamic model, so their acceleration is zero: it matters for a consistent mass)."""
        m = self.model
        moving = ~np.all(m.fixed[:, :3], axis=1)
        for p in self.dynamic.prescribed:
            moving[p.nodes] = True
        return moving

    def _centrifugal_operator(self) -> sp.csr_matrix:
        """The constant map (n_dof, 3n) of the positions relative to the centre, (x - c).ravel(), to the
        translational rows of f_c: S_I^T of sum_J S_IJ m_J (|Omega|^2 I - Omega Omega^T)(x_J - c) (S the
        translational scalar mass, m_J 1 on the turning nodes, :func:`centrifugal_forces`; S_I^T the row map,
        E_I^T on the nodes with a translation basis), zero rows on the rotations."""
        m, n = self.model, self.model.body.n_nodes
        A = centrifugal_matrix(self.omega)
        mass = self.dynamic.body_mass.scalar @ sp.diags(self._turning)
        rows = sp.bsr_matrix((self._rows, np.arange(n), np.arange(n + 1)), shape=(3 * n, 3 * n))
        nodes, comp = np.nonzero(self._index[:, :3] >= 0)
        pick = sp.csr_matrix((np.ones(nodes.size), (self._index[nodes, comp], 3 * nodes + comp)),
                             shape=(m.n_dof, 3 * n))
        return (pick @ rows @ sp.kron(mass, A)).tocsr()

    def spin_load(self, state: ShellState) -> np.ndarray:
        """f_c on the free DoFs (the model's row layout): centrifugal forces (:meth:`_centrifugal_operator`) and
        director moments (:func:`director_spin_moments`)."""
        f = self._centrifugal @ (state.x - self.center).ravel()
        nodes, comp, dof = self._rotations
        f[dof] = director_spin_moments(self.dynamic.body_mass.rotary, state.frames, self.omega)[nodes, comp]
        return f

    def spin_load_tangent(self, state: ShellState) -> sp.csc_matrix:
        """d f_c / d q (free x free) along the model's increments (columns as :meth:`Model.update`)."""
        m, bm = self.model, self.dynamic.body_mass
        A = centrifugal_matrix(self.omega)
        cols = state.frames.copy()                       # delta x_J = R_J du_J, or E_J dv_J on basis nodes
        cols[m.has_basis] = m.basis[m.has_basis]
        S = bm.scalar.tocoo()                            # blocks S_IJ E_I^T A R_J, one per entry (I, J) of S
        I, J = S.row, S.col
        trans = S.data[:, None, None] * np.einsum("nij,jk,nkl->nil", self._rows[I], A, cols[J])
        rot = director_spin_moment_tangent(bm.rotary, state.frames, self.omega)
        nodes = np.arange(m.body.n_nodes)
        rows, colidx, vals = [], [], []
        for block, first, I, J in ((trans, 0, I, J), (rot, 3, nodes, nodes)):
            k = block.shape[1]
            r = np.repeat(self._index[I, first:first + k][:, :, None], k, axis=2)
            c = np.repeat(self._index[J, first:first + k][:, None, :], k, axis=1)
            keep = (r >= 0) & (c >= 0)
            rows.append(r[keep]), colidx.append(c[keep]), vals.append(block[keep])
        return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(colidx))),
                             shape=(m.n_dof, m.n_dof))

    def _model_factor(self) -> float | np.ndarray:
        return self.dynamic.lam(self.load_factor_time)

    def external_force(self, state: ShellState) -> np.ndarray:
        """The whole load at lam = 1: the model's loads at lambda(t), gravity and the spin load."""
        return (self.model.external_force(state, self._model_factor()) + self.dynamic.gravity_force
                + self.spin_load(state))

    def residual(self, state: ShellState, lam: float) -> np.ndarray:
        """r_spin = f_int - lam (lambda(t) f_ext + f_g + f_c)."""
        return (self.model.residual(state, lam * self._model_factor())
                - lam * (self.dynamic.gravity_force + self.spin_load(state)))

    def residual_and_tangent(self, state: ShellState, lam: float):
        r, K = self.model.residual_and_tangent(state, lam * self._model_factor())
        r = r - lam * (self.dynamic.gravity_force + self.spin_load(state))
        return r, (K - lam * self.spin_load_tangent(state)).tocsc()


# --------------------------------------------------------------------------------------------------------
# The solve
# --------------------------------------------------------------------------------------------------------
@dataclass
class SteadySpin:
    """A relative equilibrium: the state in the turning frame, its rigid velocity and how it was found.

    ``velocity`` is in the layout of the dynamic model that was passed to :func:`steady_spin`, so that
    ``(state, velocity)`` start its generalized-alpha run on the steady spin. ``gauge_residual`` is the largest
    force the gauge supports of a free body carry, relative to the load (0 for a held body).
    """

    state: ShellState
    velocity: np.ndarray
    omega: np.ndarray
    center: np.ndarray
    result: object                 # the static solver's result (steps, iterations, factorizations)
    gauge_nodes: tuple[int, ...] = ()
    gauge_residual: float = 0.0


def gauge_supports(dynamic: DynamicModel, omega: np.ndarray, center: np.ndarray) -> list[FixDirection]:
    """The two supports that fix the neutral rigid motions of a free body in the turning frame.

    The axial translation of the node nearest the centre and the circumferential translation (along
    Omega x r) of the node farthest from the axis.
    """
    x = dynamic.model.body.mesh.nodes
    axis = omega / np.linalg.norm(omega)
    r = x - center
    radial = r - np.outer(r @ axis, axis)
    dist = np.linalg.norm(radial, axis=1)
    near = int(np.argmin(np.linalg.norm(r, axis=1)))
    far = int(np.argmax(dist))
    if dist[far] <= 1e-9 * max(float(np.ptp(x, axis=0).max()), 1e-300):
        raise ValueError("every node lies on the spin axis: the spin of this body is not defined")
    tangential = np.cross(axis, radial[far] / dist[far])
    return [FixDirection([near], axis), FixDirection([far], tangential)]


def axial_load_resultant(spin: "SpinningModel", state, omega: np.ndarray, center: np.ndarray) -> float:
    """The net force along the spin axis and the net moment about it of a free body's loads at ``state``
    (the model's loads and the spin's centrifugal ones), relative to sum |f_I| and sum |f_I| max|r_I|: what
    the gauge supports would have to carry. A steady spin of a free body needs both to vanish; the measure is
    free of the solve's round-off (unlike the gauge DoFs' residual, whose floor grows as the strain shrinks)."""
    dyn = spin.dynamic
    f = spin.external_force(state)
    axis = omega / np.linalg.norm(omega)
    n = dyn.model.body.n_nodes
    forces = (dyn.translation_directions() @ f).reshape(n, 3)
    rot = ~dyn.is_translation
    moments = np.zeros((n, 3))           # m_1 t1 + m_2 t2 of the rotation rows (local axes of the frames)
    np.add.at(moments, dyn.node[rot], f[rot][:, None] * state.frames[dyn.node[rot], :, dyn.comp[rot] - 3])
    r = state.x - center
    size = float(np.abs(forces).sum()) or 1.0
    length = float(np.linalg.norm(r, axis=1).max()) or 1.0
    axial_force = abs(float(forces.sum(axis=0) @ axis)) / size
    axial_moment = abs(float((np.cross(r, forces).sum(axis=0) + moments.sum(axis=0)) @ axis)) / (size * length)
    return max(axial_force, axial_moment)


def steady_spin(dynamic: DynamicModel, omega, center=None, *, time: float = 0.0, n_steps: int = 4,
                settings=None) -> SteadySpin:
    """The steady spin of a body at angular velocity ``omega`` (3,) about an axis through ``center``.

    Parameters
    ----------
    dynamic : the body in motion. A body with constraints is held by them in the turning frame (a hub driven
        at the constant rate ``omega``, clamped with ``Fix(hub, "all")``); a body without any is free, and its
        neutral rigid motions are gauged (see the module docstring).
    omega : angular velocity [rad/s], nonzero
    center : a point of the axis (default: the mass centre of the discrete body)
    time : the time at which the model's load factor is taken
    n_steps : load steps of the continuation from rest to the full spin (adaptive)
    settings : Newton settings of the static solver (default ``NewtonSettings()``)

    Returns
    -------
    SteadySpin : the deformed state and its rigid velocity Omega x (x - c) in the layout of ``dynamic``.

    Raises
    ------
    ValueError : bad input, no convergence (with the static solver's message), or a free body whose loads do
        not allow a steady spin about this axis (the gauge supports would carry a load).
    """
    from integrators.newton import NewtonSettings
    from integrators.static import load_control

    omega = finite_vector(omega, "the spin angular velocity")
    if not np.any(omega):
        raise ValueError("the spin angular velocity is zero: a steady spin needs omega != 0")
    if center is None:
        center = dynamic.rigid_inertia_tensor(dynamic.model.initial_state())[0]
    center = finite_vector(center, "the spin centre")
    if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) or not 1 <= n_steps <= 10_000:
        raise ValueError(f"n_steps must be an integer in 1..10000, got {n_steps!r}")
    check_constant_rate(dynamic, omega, center, time)
    model = dynamic.model
    gauge: list[FixDirection] = []
    solve_dynamic = dynamic
    if not model.constraints:
        gauge = gauge_supports(dynamic, omega, center)
        gauged = Model(model.body, list(gauge), model.loads, load_groups=model.load_groups)
        solve_dynamic = replace(dynamic, model=gauged)        # the same mass, point masses, loads, ...
    spin = SpinningModel(solve_dynamic, omega, center, time)
    result = load_control(spin, n_steps=n_steps, settings=settings or NewtonSettings())
    if not result.converged:
        raise ValueError(f"no steady spin found at omega = {omega.tolist()} rad/s: {result.message}")
    state = result.state
    state.stress = None
    gauge_residual = 0.0
    if gauge:
        gauge_residual = axial_load_resultant(SpinningModel(dynamic, omega, center, time), state, omega, center)
        if gauge_residual > 1e-6:
            raise ValueError(f"no steady spin about this axis: the free body's loads leave a net force or moment "
                             f"along the axis or about it ({gauge_residual:.3g} of the load at the gauge supports)")
    velocity = dynamic.rigid_velocity(state, omega, center=center)
    return SteadySpin(state, velocity, omega, center, result, tuple(int(g.nodes[0]) for g in gauge),
                      gauge_residual)


# --------------------------------------------------------------------------------------------------------
# A dynamic run that starts on the steady spin
# --------------------------------------------------------------------------------------------------------
#: rho_inf by default of a run that starts on the steady spin with a driven hub
#: (:func:`flexbody.scenes.analysis.default_rho_inf`). A kick on a spinning thin membrane excites director
#: (transverse-shear) oscillations far above any resolved frequency; at rho_inf = 0.9 they decay by 0.9 a step
#: and dominate the predictor's error: on the 4 x 32 hub annulus (h/R 1e-3, 100 steps a revolution) the first
#: Newton correction is ~300 x larger than at 0.5, and the 16 x 128 mesh at h/R 1e-6 fails within the first
#: revolution at 0.9 and completes at 0.5. The transverse frequencies of the membrane (omega h ~ 0.06) move by
#: less than 5e-4 relative between the two (docs/dynamics.md, "Spinning membranes").
STEADY_SPIN_RHO_INF = 0.5

@dataclass(frozen=True)
class SteadySpinStart:
    """The initial condition "the steady spin at ``angular_velocity`` about the axis through ``center``".

    For :class:`flexbody.scenes.scene.DynamicAnalysis` (``initial_state``): the run starts from the relative
    equilibrium of :func:`steady_spin` with its rigid velocity; a driven hub must turn at that constant rate from
    t = 0. ``center`` None: the mass centre of the discrete body.
    """

    angular_velocity: tuple[float, float, float]
    center: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        w = finite_vector(self.angular_velocity, "the steady-spin angular velocity")
        if not np.any(w):
            raise ValueError("the steady-spin angular velocity is zero: a steady spin needs omega != 0")
        object.__setattr__(self, "angular_velocity", tuple(float(v) for v in w))
        if self.center is not None:
            object.__setattr__(self, "center", tuple(float(v) for v in finite_vector(self.center,
                                                                                     "the steady-spin centre")))


def check_constant_rate(dynamic: DynamicModel, omega: np.ndarray, center: np.ndarray, time: float = 0.0) -> None:
    """Raise ValueError unless every prescribed motion of ``dynamic`` turns rigidly at ``omega`` about the axis
    through ``center`` at ``time`` (its rate measured by a one-sided difference of Q(t) over 1e-6 of a turn)."""
    delta = 1e-6 * 2 * np.pi / float(np.linalg.norm(omega))
    size = float(np.ptp(dynamic.model.body.mesh.nodes, axis=0).max()) + float(np.linalg.norm(center))
    for p in dynamic.prescribed:
        # one-sided second-order differences: a motion need not be defined before the start
        (Q0, d0), (Q1, d1), (Q2, d2) = (tuple(np.asarray(v, float) for v in p.motion(time + k * delta))
                                        for k in range(3))
        Wdot = (-3 * Q0 + 4 * Q1 - Q2) / (2 * delta) @ Q0.T        # hat(omega) = Qdot Q^T
        rate = np.array([Wdot[2, 1], Wdot[0, 2], Wdot[1, 0]])
        ddot = (-3 * d0 + 4 * d1 - d2) / (2 * delta)
        expected_ddot = -np.cross(omega, center)           # d = c - Q c: the axis through c stays put
        scale = float(np.linalg.norm(omega))
        if np.abs(rate - omega).max() > 1e-5 * scale or \
                np.abs(ddot - expected_ddot).max() > 1e-5 * scale * size:
            raise ValueError(f"a steady-spin start needs the driven hub turning at the constant rate "
                             f"{np.asarray(omega).tolist()} rad/s about the spin axis from t = {time:g}; it turns at "
                             f"{np.round(rate, 9).tolist()} (a hub spin-up needs ramp_time = 0 here)")
