"""Equations of motion in a frame turning at a constant angular velocity (spinning bodies).

A body that spins at a constant angular velocity Omega about the axis through ``c`` is described in the frame
that turns with it, y = c + Q(t)^T (x - c) with Q(t) = exp(t hat(Omega)). Nodal frames are R = Q(t)^T R_in.
With v the velocity relative to that frame (translations ydot, local angular velocities w_r of the nodal
frames) the equations of motion of :class:`flexbody.dynamics.DynamicModel` become (Goldstein, Classical
Mechanics, ch. 4.10; Geradin & Cardona, Flexible Multibody Dynamics, 2001, ch. 12, for rotating flexible
bodies)::

    M vdot + G(q) v + f_int(q) - lambda f_ext(q) - f_g - f_c(q) (+ f_d(q, v)) = 0

* f_c: the centrifugal load of the model's own mass (:meth:`flexbody.spinning.SpinningModel.spin_load`, with
  its tangent): -S Omega x (Omega x (y - c)) on the translations, the steady moment of the director inertia on
  the rotations. A steady spin (:func:`flexbody.spinning.steady_spin`) is a static equilibrium here: it stays
  exactly at rest in the turning frame, where the inertial run carries the time integrator's phase error of
  the rigid motion.
* G v: the Coriolis forces, 2 S Omega x ydot on the translations (S the translational scalar mass, lumped or
  consistent), and on the two director rotations of a node of inertia j diag(1, 1, 0) with Omega_l = R^T Omega:
  2 j (t . Omega) (-w_2, w_1). Both are skew: they do no work. (From J wdot + w x J w with w = w_r + Omega_l and
  d/dt Omega_l = -w_r x Omega_l; the drilling row is not a DoF.)
* f_d: stiffness-proportional Rayleigh damping on the relative velocity. It acts on strain rates, which a rigid
  velocity does not change, so it is the inertial one. Mass-proportional damping a0 M v acts on the inertial
  velocity and brakes the spin itself: the steady spin is then no relative equilibrium, and the turning frame
  refuses it (the default is then the inertial frame), so that a run's answer never depends on its frame.

Why: the rigid motion of a node on a circle is not a motion the generalized-alpha predictor or its iteration
treat exactly on R^3 x SO(3). In the inertial frame the predicted membrane lags its clamped hub by a rigid
turn of third order in Omega h (5e-4 rad a step at 50 steps per revolution), a twist the Newton iteration must
take out; in the turning frame the rigid motion is at rest and the step only carries the vibration
(docs/dynamics.md, "Turning frame"). Loads must be ones the turn does not change: follower loads, and dead
loads and gravity along the spin axis. Prescribed motions must be the hub turning with the frame (they are at
rest in it).

Outputs: the states, velocities and accelerations handed to the run's observers are the inertial ones
(:meth:`TurningFrameModel.inertial_motion`, :class:`InertialObservers`), so energies, momenta, files and outputs
mean what they mean in an inertial run.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from flexbody.body import ShellState
from flexbody.dynamics import DynamicModel
from flexbody.lie import so3
from flexbody.spinning import SpinningModel, centrifugal_matrix, finite_vector


@dataclass(frozen=True)
class TurningFrame:
    """A frame turning at the constant angular velocity ``omega`` (3,) [rad/s] about the axis through
    ``center`` (3,), coinciding with the inertial frame at t = 0."""

    omega: np.ndarray
    center: np.ndarray

    def __post_init__(self) -> None:
        w = finite_vector(self.omega, "the turning frame's angular velocity")
        if not np.any(w):
            raise ValueError("the turning frame's angular velocity is zero: use the inertial frame")
        object.__setattr__(self, "omega", w)
        object.__setattr__(self, "center", finite_vector(self.center, "the turning frame's centre"))

    def rotation(self, t: float) -> np.ndarray:
        """Q(t) = exp(t hat(omega)), the frame's orientation at time t."""
        return so3.exp(t * self.omega)


class TurningFrameModel:
    """A :class:`flexbody.dynamics.DynamicModel` written in a :class:`TurningFrame` (module docstring): a
    :class:`integrators.protocols.DynamicProblem` with a mass matrix and damping (the Coriolis forces), whose
    states and velocities are relative to the frame.

    Parameters
    ----------
    dynamic : the body in the inertial frame (mass, loads, gravity, damping, the hub's prescribed motion)
    frame : the turning frame
    times : instants at which the prescribed motions are checked to turn with the frame (any motion that does
        not is refused: in the turning frame prescribed nodes are held)
    """

    def __init__(self, dynamic: DynamicModel, frame: TurningFrame, times=(0.0, 1.0)) -> None:
        self.dynamic, self.frame = dynamic, frame
        self._check_loads()
        self._check_prescribed(times)
        self._check_damping()
        self.spin = SpinningModel(dynamic, frame.omega, frame.center)
        self._translations = self._translation_map()
        S = dynamic.body_mass.scalar
        T = self._translations
        self._coriolis_translations = (2.0 * (T.T @ sp.kron(S, so3.hat(frame.omega)) @ T)).tocsc()
        self._rot = np.flatnonzero(~dynamic.is_translation)
        # the Coriolis forces on the director rotations: the partner of each rotation DoF (w_2 for w_1 and back;
        # n_dof where it is held: a zero appended to v) and the sign of 2 j (t . Omega) (-w_2, w_1)
        comp = dynamic.comp[self._rot]
        index = np.full((dynamic.model.body.n_nodes, 2), dynamic.n_dof, dtype=np.int64)
        index[dynamic.node[self._rot], comp - 3] = self._rot
        self._partner = index[dynamic.node[self._rot], 4 - comp]
        self._rot_sign = np.where(comp == 3, -1.0, 1.0)

    # -- checks --------------------------------------------------------------------------------------------
    def _along_axis(self, vector: np.ndarray) -> bool:
        k = self.frame.omega / np.linalg.norm(self.frame.omega)
        v = np.asarray(vector, float)
        return bool(np.linalg.norm(v - (v @ k) * k) <= 1e-12 * max(np.linalg.norm(v), 1e-300))

    def _check_loads(self) -> None:
        from flexbody.loads import NodalLoad
        if not self._along_axis(self.dynamic.gravity):
            raise ValueError(f"turning frame: gravity {self.dynamic.gravity.tolist()} is not along the spin axis "
                             f"{self.frame.omega.tolist()} (it would turn in that frame): use the inertial frame")
        for load in self.dynamic.model.loads:
            if isinstance(load, NodalLoad) and not load.follower:
                for what in ("force", "moment"):
                    if not self._along_axis(getattr(load, what)):
                        raise ValueError(f"turning frame: a dead nodal {what} {getattr(load, what).tolist()} (nodes "
                                         f"{load.nodes[:3].tolist()}...) is not along the spin axis: it would turn in "
                                         f"that frame; use the inertial frame or a follower load")

    def _check_damping(self) -> None:
        """Mass-proportional damping a0 M v acts on the inertial velocity, the spin included (it brakes a free
        body's spin and loads a driven hub): the steady spin is then no relative equilibrium, and damping the
        velocity relative to the frame instead would make the answer depend on the frame."""
        damping = self.dynamic.damping
        if damping is not None and damping.alpha_mass > 0:
            raise ValueError(f"turning frame: mass-proportional damping (alpha_mass = {damping.alpha_mass:g} 1/s) "
                             "damps the spin too, so the steady spin is no equilibrium in that frame: use the "
                             "inertial frame, or stiffness-proportional damping only")

    def _check_prescribed(self, times) -> None:
        c = self.frame.center
        for k, p in enumerate(self.dynamic.prescribed):
            for t in times:
                Q, d = p.motion(float(t))
                Qf = self.frame.rotation(float(t))
                if (np.abs(np.asarray(Q, float) - Qf).max() > 1e-9
                        or np.abs(np.asarray(d, float) - (c - Qf @ c)).max() > 1e-9 * max(1.0, np.abs(c).max())):
                    raise ValueError(f"turning frame: prescribed motion {k} does not turn with the frame at t = {t:g} "
                                     f"(the frame turns at {self.frame.omega.tolist()} rad/s about {c.tolist()}); "
                                     f"only a hub turning with the frame can be held in it")

    def _translation_map(self) -> sp.csr_matrix:
        """T (3n, n_dof): the global nodal translation of each free translational DoF (unit vectors, or the
        basis vectors of nodes with a fixed basis)."""
        d, m = self.dynamic, self.dynamic.model
        tr = np.flatnonzero(d.is_translation)
        node, comp = d.node[tr], d.comp[tr]
        rows, cols, vals = [], [], []
        for i, I, c in zip(tr, node, comp):
            direction = m.basis[I][:, c] if m.has_basis[I] else np.eye(3)[c]
            for k in range(3):
                if direction[k] != 0.0:
                    rows.append(3 * I + k), cols.append(i), vals.append(direction[k])
        return sp.csr_matrix((vals, (rows, cols)), shape=(3 * m.body.n_nodes, d.n_dof))

    # -- the problem ---------------------------------------------------------------------------------------
    @property
    def model(self):
        return self.dynamic.model

    @property
    def n_dof(self) -> int:
        return self.dynamic.n_dof

    @property
    def dof_scale(self):
        return self.dynamic.dof_scale

    def update(self, state: ShellState, dq: np.ndarray) -> ShellState:
        return self.dynamic.update(state, dq)

    def mass_matrix(self) -> sp.csc_matrix:
        return self.dynamic.mass_matrix()

    def transfer(self, state_ref: ShellState, state: ShellState):
        """The map of an old iteration matrix to ``state``: :meth:`DynamicModel.transfer` in the frame's
        coordinates (the body hardly turns against the frame; what remains is the turn of the surface as the
        membrane swings, which the kept matrix cannot follow without it). An approximation for the frame's
        terms as well: the Coriolis and centrifugal tangents are turned with the nodes."""
        return self.dynamic.transfer(state_ref, state)

    def apply_transfer(self, vec: np.ndarray, transfer, transpose: bool = False) -> np.ndarray:
        return self.dynamic.apply_transfer(vec, transfer, transpose)

    def _director_spin(self, state: ShellState) -> np.ndarray:
        """2 j_I (t_I . Omega) at the rotational DoFs' nodes (the Coriolis coefficient of the directors)."""
        d = self.dynamic
        nodes = d.node[self._rot]
        return 2.0 * d.body_mass.rotary[nodes] * state.frames[:, :, 2].dot(self.frame.omega)[nodes]

    def coriolis_force(self, state: ShellState, v: np.ndarray) -> np.ndarray:
        """G(q) v: 2 S Omega x ydot on the translations, 2 j (t . Omega)(-w_2, w_1) on the director rotations."""
        out = self._coriolis_translations @ v
        out[self._rot] += self._director_spin(state) * self._rot_sign * np.append(v, 0.0)[self._partner]
        return out

    def coriolis_matrix(self, state: ShellState) -> sp.csc_matrix:
        """G(q) = d(G v)/dv (skew)."""
        d = self.dynamic
        rot, comp = self._rot, d.comp[self._rot]
        index = -np.ones((d.model.body.n_nodes, 2), dtype=np.int64)
        index[d.node[rot], comp - 3] = rot
        partner = index[d.node[rot], 4 - comp]
        keep = partner >= 0
        c = self._director_spin(state)
        vals = np.where(comp == 3, -c, c)[keep]
        G_rot = sp.csc_matrix((vals, (rot[keep], partner[keep])), shape=(d.n_dof, d.n_dof))
        return (self._coriolis_translations + G_rot).tocsc()

    def _coriolis_tangent(self, state: ShellState, v: np.ndarray) -> sp.csc_matrix:
        """d(G(q) v)/dq at fixed v: the directors' coefficient 2 j (t . Omega) varies with t; along
        R exp(theta), d(t . Omega) = (Omega_l)_1 theta_2 - (Omega_l)_2 theta_1."""
        d = self.dynamic
        rot, comp = self._rot, d.comp[self._rot]
        n = d.model.body.n_nodes
        index = -np.ones((n, 2), dtype=np.int64)
        index[d.node[rot], comp - 3] = rot
        w = np.zeros((n, 2))
        w[d.node[rot], comp - 3] = v[rot]
        nodes = np.unique(d.node[rot])
        om_l = np.einsum("nji,j->ni", state.frames[nodes], self.frame.omega)
        j2 = 2.0 * d.body_mass.rotary[nodes]
        force = np.stack([-w[nodes, 1], w[nodes, 0]], axis=1) * j2[:, None]     # per unit (t . Omega)
        grad = np.stack([-om_l[:, 1], om_l[:, 0]], axis=1)                       # d(t . Omega)/d theta_k
        rows = np.repeat(index[nodes][:, :, None], 2, axis=2)
        cols = np.repeat(index[nodes][:, None, :], 2, axis=1)
        vals = force[:, :, None] * grad[:, None, :]
        keep = (rows >= 0) & (cols >= 0)
        return sp.csc_matrix((vals[keep], (rows[keep], cols[keep])), shape=(d.n_dof, d.n_dof))

    def _static_part(self, state: ShellState, t: float, tangent: bool):
        """f_int - lambda f_ext - f_g - f_c (and its tangent, global translation columns)."""
        d = self.dynamic
        if tangent:
            r, K = d.model.residual_and_tangent(state, d.lam(t), global_columns=True)
            K = K - self.spin.spin_load_tangent(state) @ d.column_map(state)
        else:
            r, K = d.model.residual(state, d.lam(t)), None
        return r - d.gravity_force - self.spin.spin_load(state), K

    def residual(self, state: ShellState, v: np.ndarray, vdot: np.ndarray, t: float) -> np.ndarray:
        """r = M vdot + G v + f_d + f_int - lambda f_ext - f_g - f_c (the equations of motion, exact)."""
        d = self.dynamic
        return (d.mass_matrix() @ vdot + self.coriolis_force(state, v) + d.damping_force(state, v)
                + self._static_part(state, t, False)[0])

    def residual_and_tangent(self, state: ShellState, v: np.ndarray, vdot: np.ndarray, t: float):
        """r and K_t = dr/dq at fixed v and vdot (columns along the group increments); the damping force's
        configuration derivative is left out, as in :meth:`DynamicModel.residual_and_tangent`."""
        d = self.dynamic
        g, K = self._static_part(state, t, True)
        r = d.mass_matrix() @ vdot + self.coriolis_force(state, v) + d.damping_force(state, v) + g
        return r, (K + self._coriolis_tangent(state, v)).tocsc()

    def damping_matrix(self, state: ShellState) -> sp.csc_matrix:
        """C_t = G(q) + the Rayleigh damping matrix (the velocity derivative of the residual)."""
        G = self.coriolis_matrix(state)
        C = self.dynamic.damping_matrix(state)
        return G if C is None else (G + C).tocsc()

    def initial_acceleration(self, state: ShellState, t: float = 0.0, v: np.ndarray | None = None) -> np.ndarray:
        """vdot_0 = -M^-1 (G v_0 + f_d + f_int - lambda f_ext - f_g - f_c) at t."""
        f = self._static_part(state, t, False)[0]
        if v is not None:
            f = f + self.coriolis_force(state, v) + self.dynamic.damping_force(state, v)
        return -self.dynamic.solve_mass(f)

    # -- between the frames --------------------------------------------------------------------------------
    def relative_velocity(self, state: ShellState, velocity: np.ndarray) -> np.ndarray:
        """The velocity relative to the frame at t = 0 (where the frames coincide) of an inertial one."""
        return velocity - self.dynamic.rigid_velocity(state, self.frame.omega, center=self.frame.center)

    def inertial_state(self, state: ShellState, t: float) -> ShellState:
        """x = c + Q(t) (y - c), R_in = Q(t) R."""
        Q, c = self.frame.rotation(t), self.frame.center
        local = (state.relative_positions() + state.origin - c) @ Q.T + (c - state.origin)
        return ShellState(local + state.origin, np.einsum("ij,njk->nik", Q, state.frames),
                          None if state.stress is None else state.stress.copy(), local, state.origin)

    def inertial_motion(self, state: ShellState, v: np.ndarray, accelerations: tuple, t: float):
        """(state, v, accelerations) in the inertial frame at time t, of the turning frame's ones:
        xdot = Q (ydot + Omega x (y - c)), omega = Q R w_r + Omega; xddot = Q (yddot + 2 Omega x ydot
        + Omega x (Omega x (y - c))), angular acceleration R_in (wdot_r - w_r x Omega_l) (each of
        ``accelerations``: vdot, or the pseudo-acceleration taken as one)."""
        d, om, c = self.dynamic, self.frame.omega, self.frame.center
        Q, W = self.frame.rotation(t), so3.hat(om).T        # Omega x y_I = (y @ W)_I: one product for all nodes
        A = centrifugal_matrix(om)                          # Omega x (Omega x y_I) = -(y @ A)_I (A symmetric)
        inertial = self.inertial_state(state, t)
        r = state.x - c
        ydot, w_r = d.nodal_velocities(state, v)
        om_l = np.einsum("nji,j->ni", state.frames, om)
        xdot = (ydot + r @ W) @ Q.T
        omega = np.einsum("nij,nj->ni", inertial.frames, w_r) + om
        out = []
        for acc in accelerations:
            yddot, wdot_r = d.nodal_velocities(state, acc)
            xddot = (yddot + 2.0 * (ydot @ W) - r @ A) @ Q.T
            alpha = np.einsum("nij,nj->ni", inertial.frames, wdot_r - np.cross(w_r, om_l))
            out.append(d.velocity_from_nodal(inertial, xddot, alpha))
        return inertial, d.velocity_from_nodal(inertial, xdot, omega), out

    def turning_motion(self, state: ShellState, v: np.ndarray, accelerations: tuple, t: float):
        """The inverse of :meth:`inertial_motion`: an inertial (state, v, accelerations) at time t in the frame
        (a restart of a turning-frame run from its inertial files)."""
        d, om, c = self.dynamic, self.frame.omega, self.frame.center
        Q, W = self.frame.rotation(t), so3.hat(om).T        # Omega x y_I = (y @ W)_I, as in inertial_motion
        A = centrifugal_matrix(om)
        local = (state.relative_positions() + state.origin - c) @ Q + (c - state.origin)
        turning = ShellState(local + state.origin, np.einsum("ji,njk->nik", Q, state.frames),
                             None if state.stress is None else state.stress.copy(), local, state.origin)
        r = turning.x - c
        xdot, w = d.nodal_velocities(state, v)
        om_l = np.einsum("nji,j->ni", turning.frames, om)
        w_r = w - om_l
        w_r[:, 2] = 0.0
        ydot = xdot @ Q - r @ W
        out = []
        for acc in accelerations:
            xddot, alpha = d.nodal_velocities(state, acc)
            yddot = xddot @ Q - 2.0 * (ydot @ W) + r @ A
            wdot_r = alpha + np.cross(w_r, om_l)
            out.append(d.velocity_from_nodal(turning, yddot, np.einsum("nij,nj->ni", turning.frames, wdot_r)))
        return turning, d.velocity_from_nodal(turning, ydot, np.einsum("nij,nj->ni", turning.frames, w_r)), out


@dataclass
class InertialObservers:
    """Hands the accepted steps of a turning-frame run to ``observers`` in the inertial frame (state, velocities,
    accelerations; the pseudo-acceleration is mapped as an acceleration).

    Mapping a step costs about as much as a residual evaluation. An observer that needs only the start, the
    output steps and the last step of a stopped run says so with ``every_step = False``
    (:attr:`flexbody.energy.EnergyAccount.every_step`: an undamped body dissipates nothing between outputs);
    the steps between are then mapped only for the observers that want every step (without an attribute: every
    step). :meth:`flush` hands the last accepted step to those that skipped it (a stopped run's last converged
    step), so that each observer sees the run's last accepted step.
    """

    model: TurningFrameModel
    observers: tuple
    _last: tuple = (None, None)      # (the last mapped step's relative velocity, its inertial map)
    _pending: object = None          # the last accepted step not handed to the observers that skip steps

    def __call__(self, step) -> None:
        if step.initial or step.output:
            targets, self._pending = self.observers, None
        else:
            targets = tuple(o for o in self.observers if getattr(o, "every_step", True))
            self._pending = step if len(targets) < len(self.observers) else None
        if targets:
            mapped = self._mapped(step)
            for observer in targets:
                observer(mapped)

    def flush(self) -> None:
        """Hand the last accepted step to the observers that skipped it (nothing if they have seen it)."""
        step, self._pending = self._pending, None
        if step is None:
            return
        mapped = self._mapped(step)
        for observer in self.observers:
            if not getattr(observer, "every_step", True):
                observer(mapped)

    def _mapped(self, step):
        """The accepted step with its motion in the inertial frame at its time."""
        m, t = self.model, step.time
        state, v, (vdot, a) = m.inertial_motion(step.state, step.velocity,
                                                (step.acceleration, step.pseudo_acceleration), t)
        if step.initial:
            v_prev = v
        elif step.previous_velocity is self._last[0]:       # v_n, mapped at its own step (exact)
            v_prev = self._last[1]
        else:                                               # mapped at q_{n+1} (only damping work uses it)
            v_prev = m.inertial_motion(step.state, step.previous_velocity, (), t)[1]
        self._last = (step.velocity, v)
        return replace(step, state=state, velocity=v, acceleration=vdot, pseudo_acceleration=a,
                       previous_velocity=v_prev)


FRAMES = ("inertial", "turning")


def turning_frame_model(dynamic: DynamicModel, requested: str | None, spin, times) -> TurningFrameModel | None:
    """The turning-frame model of a run, or None for the inertial frame.

    ``requested``: "turning", "inertial", or None (the default: the turning frame for a start on the steady spin
    ``spin`` (:class:`flexbody.spinning.SteadySpin`, None for another start) whenever its loads and prescribed
    motions allow it, else the inertial frame). "turning" needs a steady-spin start, whose angular velocity and
    centre the frame takes, and loads and motions the turn does not change (else a ``ValueError``).
    """
    if requested not in (None, *FRAMES):
        raise ValueError(f"frame must be one of {', '.join(map(repr, FRAMES))}, got {requested!r}")
    if requested == "inertial" or (requested is None and spin is None):
        return None
    if spin is None:
        raise ValueError("frame 'turning' needs a start on the steady spin (initial state \"steady_spin\"): "
                         "the frame turns at its angular velocity")
    try:
        return TurningFrameModel(dynamic, TurningFrame(spin.omega, spin.center), times)
    except ValueError:
        if requested == "turning":
            raise
        return None
