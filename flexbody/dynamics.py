"""A shell model in motion: mass, inertia forces, gravity, initial conditions, energy and momenta.

``DynamicModel`` wraps a :class:`flexbody.assembly.Model` (it does not change it) and gives the time
integrators (``integrators.generalized_alpha``) the equations of motion on the free DoFs::

    r(q, v, vdot, t) = M vdot + f_d(q, v) + f_int(q) - lambda(t) f_ext(q) - f_g = 0

with f_d the optional Rayleigh damping force (:class:`RayleighDamping`, zero without it).

(with load groups, lambda(t) f_ext is sum_k lambda_k(t) f_ext,k, see ``Model.load_groups``).

Velocity layout: the Lie group is R^3 x SO(3) per node.
* translations: the velocity components in *fixed* directions, the same directions as the Model's
  translational equations: global x, y, z for free nodes, the constraint basis E_I for nodes with a fixed
  translation basis (their constrained components are not DoFs). A translation increment is x <- x + dx.
* rotations: the local angular velocity components w_1, w_2 about the frame axes t1, t2. The drilling
  velocity w_3 is not a DoF: the nodal frame is parallel-transported with the director (w_3 = 0), exactly
  as the static Newton updates it (R <- R exp(theta_1 e1 + theta_2 e2)). The kinetic energy does not
  depend on w_3 (J = j diag(1, 1, 0)). The strain energy of the SE(3) element does depend on the frames'
  drilling angles (through the relative-rotation interpolation). Measured with random +-0.5 rad drilling of
  every frame of the 2 x 2 x 2 quarter-cylinder patch of the tests: the energy of a deformed state goes
  from 72.92 to 73.33, that of the rigidly moved reference from 0 to 0.18; on a flat plate the reference
  stays at 0. So the drilling is a history variable of the formulation, in dynamics as in statics. w_3 = 0 is then a velocity constraint that
  does no work (Lagrange-d'Alembert): the equations of motion are the five per node below, and energy is
  conserved because f_int . v = dW/dt along 5-DoF motions (tests/shell/test_inertia.py).
Both pieces of the mass are constant (lumped, see :mod:`flexbody.shell.inertia`): M = diag(m_I, j_I) and
there are no gyroscopic or centrifugal terms in these coordinates (the centripetal accelerations of a
spinning body are simply the global accelerations of its nodes).

The Model's translational *equations* already are force components in fixed directions; its translational
*columns* are local increments du (x <- x + R du). ``DynamicModel`` maps them: du = R^T dx, which the Model's
update applies exactly (the frame R is the one before the increment), and the tangent columns become
K R^T per free node.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse as sp

from flexbody.assembly import Model
from flexbody.body import ShellState
from flexbody.shell.inertia import NodalInertia, nodal_inertia, with_point_masses


@dataclass(frozen=True)
class RayleighDamping:
    """Rayleigh damping, mass- and stiffness-proportional: f_d(q, v) = a0 M v + a1 B(q)^T C B(q) v.

    Parameters
    ----------
    alpha_mass : a0 (1/s), the mass-proportional part. It damps every velocity, rigid motion included (a
        free body's spin and drift decay as exp(-a0 t)), as in every FE code: use it for supported bodies.
    beta_stiffness : a1 (s), the stiffness-proportional part, on the material (strain-rate) stiffness:
        Kelvin-Voigt stresses a1 C eps_dot of the strain rates eps_dot = B(q) v. A rigid velocity has no
        strain rate, so this part never damps rigid motion (a spinning body keeps its angular momentum). The
        full tangent K_t v would: its geometric part G(sigma) v does not vanish for a rigid rotation of a
        pre-stressed body (tests/test_damping.py).

    A mode of circular frequency omega gets the damping ratio zeta(omega) = a0 / (2 omega) + a1 omega / 2
    (Chopra, Dynamics of Structures, 11.4; Clough & Penzien 12-4); :meth:`from_ratio` matches a ratio at two
    frequencies.
    """

    alpha_mass: float = 0.0
    beta_stiffness: float = 0.0

    def __post_init__(self) -> None:
        for name in ("alpha_mass", "beta_stiffness"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (np.isfinite(value) and value >= 0):
                raise ValueError(f"damping {name} must be a finite number >= 0, got {value!r}")

    @classmethod
    def from_ratio(cls, ratio: float, frequencies_hz: tuple[float, float]) -> "RayleighDamping":
        """The damping with ratio ``ratio`` at the two frequencies f1 <= f2 (Hz), omega_i = 2 pi f_i:
        a0 = 2 zeta omega1 omega2 / (omega1 + omega2), a1 = 2 zeta / (omega1 + omega2) (Chopra 11.4.3).
        Between f1 and f2 the ratio is lower, outside higher; f1 = f2 gives zeta at that frequency."""
        if isinstance(ratio, bool) or not isinstance(ratio, (int, float)) or not (np.isfinite(ratio) and ratio >= 0):
            raise ValueError(f"damping ratio must be a finite number >= 0, got {ratio!r}")
        f = np.asarray(frequencies_hz, dtype=float) if np.ndim(frequencies_hz) == 1 else np.array([np.nan])
        if f.shape != (2,) or not np.all(np.isfinite(f)) or not 0 < f[0] <= f[1]:
            raise ValueError(f"damping frequencies_hz must be two finite frequencies 0 < f1 <= f2, got {frequencies_hz!r}")
        w1, w2 = 2.0 * np.pi * f
        return cls(float(2.0 * ratio * w1 * w2 / (w1 + w2)), float(2.0 * ratio / (w1 + w2)))

    def ratio(self, omega: float) -> float:
        """The damping ratio of a mode of circular frequency omega (rad/s)."""
        return self.alpha_mass / (2.0 * omega) + self.beta_stiffness * omega / 2.0


@dataclass(frozen=True)
class PrescribedMotion:
    """A rigid motion in time of clamped nodes (a driven hub or support): x_I(t) = Q(t) X_I + d(t).

    Parameters
    ----------
    nodes : nodes whose five DoFs are all fixed in the Model (e.g. ``Fix(nodes, "all")``)
    motion : t -> (Q(t) (3, 3), d(t) (3,)) with Q(0) = 1, d(0) = 0 (the reference positions at t = 0)

    The directors follow, t_I(t) = Q(t) N_I; the nodal frames are moved as every other 5-DoF frame is,
    by the in-plane rotation that takes the director to its new place (parallel transport, no drilling):
    the element energy depends on the frames' relative drilling, so a clamp frame turned with Q (drilling
    included) would strain the elements next to it when the hub turns about a director.
    """

    nodes: np.ndarray
    motion: Callable[[float], tuple[np.ndarray, np.ndarray]]

    def __post_init__(self) -> None:
        object.__setattr__(self, "nodes", np.atleast_1d(np.asarray(self.nodes, dtype=int)))


def director_step(frames: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Frames R exp(theta_1 e1 + theta_2 e2) whose directors are the unit vectors ``target`` (k, 3).

    theta = angle * R^T (t x t_target) / |t x t_target| is the in-plane rotation along the great circle
    (its axis is normal to the director, so it has no drilling component).
    """
    from flexbody.lie import kernels
    frames = np.asarray(frames, dtype=float)
    a = frames[:, :, 2]
    b = np.asarray(target, dtype=float)
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis, axis=1), np.einsum("ni,ni->n", a, b)
    still = sin < 1e-15
    if np.any(still & (cos < 0)):
        raise ValueError("a prescribed director reversed in one step")
    angle = np.where(still, 0.0, np.arctan2(sin, cos) / np.where(still, 1.0, sin))
    # the in-plane components R^T axis (e1, e2; the e3 component is zero up to round-off)
    theta = np.einsum("nji,nj->ni", frames[:, :, :2], axis) * angle[:, None]
    out = np.empty_like(frames)
    kernels.update_frames_into(np.ascontiguousarray(frames), np.ascontiguousarray(theta), out)
    return out


@dataclass
class DynamicModel:
    """Equations of motion of a constrained, loaded shell body.

    Parameters
    ----------
    model : the static model (body, constraints, loads); its loads are scaled by ``load_factor(t)``
    gravity : body acceleration g (3,), applied as the dead nodal forces m_I g
    load_factor : lambda(t) for the Model's loads (default: 1 at all times); for a Model with G load groups
        (``Model.load_groups``) it may return the G factors lambda_k(t), one per group:
        r = M vdot + f_int - sum_k lambda_k(t) f_ext,k - f_g
    prescribed : rigid motions in time of clamped nodes (:class:`PrescribedMotion`); their mass does not
        enter the equations, energies and momenta (it sits on fixed DoFs)
    point_masses : tip masses (:class:`flexbody.shell.inertia.PointMass`) added to the shell's lumped nodal
        inertia (``inertia``): they take part in everything the mass does (inertia forces, gravity, energies,
        momenta, the steady spin's centrifugal load)
    damping : Rayleigh damping (:class:`RayleighDamping`), or None (undamped)
    """

    model: Model
    gravity: np.ndarray | tuple = (0.0, 0.0, 0.0)
    load_factor: Callable[[float], float | np.ndarray] | None = None
    prescribed: list = field(default_factory=list)
    point_masses: list = field(default_factory=list)
    damping: RayleighDamping | None = None
    inertia: NodalInertia = field(init=False)

    def __post_init__(self) -> None:
        self.gravity = np.asarray(self.gravity, dtype=float)
        if self.gravity.shape != (3,) or not np.all(np.isfinite(self.gravity)):
            raise ValueError(f"gravity must be a finite 3-vector, got {self.gravity!r}")
        m = self.model
        self.inertia = with_point_masses(nodal_inertia(m.body), self.point_masses)
        free = m.free
        self.node = free // 6                      # node of each free DoF
        self.comp = free % 6                       # 0..2 translation, 3..4 rotation
        self.is_translation = self.comp < 3
        # free DoFs whose translation columns the Model takes as local increments (no fixed basis)
        self.local_columns = self.is_translation & ~m.has_basis[self.node]
        self.mass = np.where(self.is_translation, self.inertia.mass[self.node], self.inertia.rotary[self.node])
        if np.any(self.mass <= 0):
            raise ValueError("the mass matrix has non-positive entries: the material density must be > 0")
        self.dof_scale = m.dof_scale
        self._gravity_force = self._fixed_direction_vectors(self.inertia.mass[:, None] * self.gravity)
        # for the column map: the free DoF index of (node, translation component) of local-column nodes
        nodes = np.unique(self.node[self.local_columns])
        index = -np.ones((m.body.n_nodes, 6), dtype=np.int64)
        index.ravel()[free] = np.arange(free.size)
        self._col_nodes = nodes
        self._col_index = index[nodes, :3]          # (k, 3), all >= 0 (a non-basis node frees all three)
        self._rot_nodes = np.flatnonzero(np.all(index[:, 3:5] >= 0, axis=1))
        self._rot_index = index[self._rot_nodes, 3:5]
        if self.damping is not None and not isinstance(self.damping, RayleighDamping):
            raise ValueError(f"damping must be RayleighDamping or None, got {type(self.damping).__name__}")
        if self.damping is not None and self.damping.beta_stiffness > 0 and not m.body.supports_mixed_iteration:
            raise ValueError("stiffness-proportional damping (beta_stiffness > 0) needs an MITC6 element, "
                             "not tying = 'mitc7'")
        for p in self.prescribed:
            if not isinstance(p, PrescribedMotion):
                raise ValueError(f"prescribed motions must be PrescribedMotion, got {type(p).__name__}")
            bad = p.nodes[~np.all(m.fixed[p.nodes, :5], axis=1)]
            if bad.size:
                raise ValueError(f"prescribed motion on node {bad[0]}, which is not clamped (Fix(..., 'all'))")

    # -- sizes, loads ------------------------------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        return self.model.n_dof

    @property
    def gravity_force(self) -> np.ndarray:
        """The dead nodal forces m_I g on the free DoFs (the rows of the Model)."""
        return self._gravity_force

    def lam(self, t: float) -> float | np.ndarray:
        """lambda(t): a number, or the factors (G,) of the Model's load groups."""
        if self.load_factor is None:
            return 1.0
        value = np.asarray(self.load_factor(t), dtype=float)
        return float(value) if value.ndim == 0 else self.model.group_factors(value)

    def _fixed_direction_vectors(self, vec: np.ndarray) -> np.ndarray:
        """Global nodal vectors (n, 3) -> their components on the free translation DoFs (zero on rotations)."""
        m = self.model
        comp = vec.copy()
        idx = np.flatnonzero(m.has_basis)
        comp[idx] = np.einsum("nji,nj->ni", m.basis[idx], vec[idx])   # E_I^T g
        out = np.zeros(self.n_dof)
        tr = self.is_translation
        out[tr] = comp[self.node[tr], self.comp[tr]]
        return out

    # -- group update --------------------------------------------------------------------------------------
    def model_increment(self, state: ShellState, dq: np.ndarray) -> np.ndarray:
        """The Model's increment for dq in this layout: du_I = R_I^T dx_I on the local-column nodes."""
        out = np.array(dq, dtype=float, copy=True)
        R = state.frames[self._col_nodes]                          # (k, 3, 3)
        out[self._col_index] = np.einsum("nji,nj->ni", R, dq[self._col_index])
        return out

    def update(self, state: ShellState, dq: np.ndarray) -> ShellState:
        """q o exp(dq) on R^3 x SO(3): x_I <- x_I + dx_I, R_I <- R_I exp(dtheta_1 e1 + dtheta_2 e2)."""
        return self.model.update(state, self.model_increment(state, dq))

    def prescribe(self, state: ShellState, t: float) -> ShellState:
        """The state with the prescribed nodes moved to their place at time t (a no-op without any).

        Positions are set; frames are turned from their current orientation by :func:`director_step`.
        """
        if not self.prescribed:
            return state
        new = state.copy()
        X, N = self.model.body.mesh.nodes, self.model.body.frames0[:, :, 2]
        for p in self.prescribed:
            Q, d = p.motion(t)
            Q, d = np.asarray(Q, float), np.asarray(d, float)
            new.x[p.nodes] = X[p.nodes] @ Q.T + d
            new.frames[p.nodes] = director_step(state.frames[p.nodes], N[p.nodes] @ Q.T)
        return new

    def _column_map(self, state: ShellState) -> sp.csc_matrix:
        """D with K_dyn = K_model D: block R_I^T on the translation columns of the local-column nodes."""
        n = self.n_dof
        keep = np.ones(n, dtype=bool)
        keep[self._col_index.ravel()] = False
        diag = np.flatnonzero(keep)
        R = state.frames[self._col_nodes]                          # D[col_k, col_l] = R[l, k]
        rows = np.concatenate([diag, np.repeat(self._col_index, 3, axis=1).ravel()])
        cols = np.concatenate([diag, np.tile(self._col_index, (1, 3)).ravel()])
        vals = np.concatenate([np.ones(diag.size), np.transpose(R, (0, 2, 1)).reshape(-1)])
        return sp.csc_matrix((vals, (rows, cols)), shape=(n, n))

    # -- equations of motion -------------------------------------------------------------------------------
    def internal_minus_external(self, state: ShellState, t: float) -> np.ndarray:
        """g(q, t) = f_int(q) - lambda(t) f_ext(q) - f_g on the free DoFs."""
        return self.model.residual(state, self.lam(t)) - self._gravity_force

    def residual(self, state: ShellState, v: np.ndarray, vdot: np.ndarray, t: float) -> np.ndarray:
        """r = M vdot + f_d(q, v) + f_int - lambda f_ext - f_g (the equations of motion, exact)."""
        return self.mass * vdot + self.damping_force(state, v) + self.internal_minus_external(state, t)

    def residual_and_tangent(self, state: ShellState, v: np.ndarray, vdot: np.ndarray, t: float):
        """r and the stiffness K_t = dr/dq (columns along q o exp(eps e_k) in this layout), CSC.

        K_t is the tangent of f_int - lambda f_ext; the damping force's derivative in q is left out (an
        approximation of the iteration matrix only; its velocity derivative is :meth:`damping_matrix`)."""
        r, K = self.model.residual_and_tangent(state, self.lam(t))
        K = (K @ self._column_map(state)).tocsc()
        return self.mass * vdot + self.damping_force(state, v) + r - self._gravity_force, K

    def initial_acceleration(self, state: ShellState, t: float = 0.0, v: np.ndarray | None = None) -> np.ndarray:
        """vdot_0 = -M^-1 (f_d(q_0, v_0) + g(q_0, t_0)) (no gyroscopic forces in these coordinates)."""
        f = self.internal_minus_external(state, t)
        if v is not None:
            f = f + self.damping_force(state, v)
        return -f / self.mass

    # -- damping -------------------------------------------------------------------------------------------
    def material_damping_force(self, state: ShellState, v: np.ndarray) -> np.ndarray:
        """f_v = B(q)^T C B(q) v on the free DoFs: the forces of the Kelvin-Voigt stresses C eps_dot of the
        strain rates eps_dot = B v, with the element's own kernels (:meth:`ShellBody.stress_rates`, then
        :meth:`ShellBody.stress_forces`). Zero for a rigid velocity."""
        body = self.model.body
        hdot = self.model.element_motions(state, self.model_increment(state, v))
        fe = body.stress_forces(state, body.stress_rates(state, hdot))
        return self.model.assemble_element_forces(state, fe)

    def damping_force(self, state: ShellState, v: np.ndarray) -> np.ndarray:
        """f_d = a0 M v + a1 f_v(q, v) (:class:`RayleighDamping`; zero without damping)."""
        d = self.damping
        out = np.zeros(self.n_dof)
        if d is None:
            return out
        if d.alpha_mass:
            out += d.alpha_mass * self.mass * v
        if d.beta_stiffness:
            out += d.beta_stiffness * self.material_damping_force(state, v)
        return out

    def damping_matrix(self, state: ShellState) -> sp.csc_matrix | None:
        """C = df_d/dv = a0 M + a1 K_m (:meth:`material_stiffness`) for the iteration matrix, or None without
        damping.

        The exact K_m, not the current tangent K_t: a thin body's geometric stiffness G(sigma) can exceed
        its material bending stiffness, and a1 gamma' K_t then misrepresents the damping that dominates S
        (measured: a 1 m cantilever sagging under gravity, a1 = 1 s, failed at step 15 with K_t; with K_m it
        completes, and a1 = 10 s takes 49 factorizations instead of 257). It costs one more tangent per
        refresh of the iteration matrix."""
        d = self.damping
        if d is None or not (d.alpha_mass or d.beta_stiffness):
            return None
        C = sp.diags(d.alpha_mass * self.mass)
        if d.beta_stiffness:
            C = C + d.beta_stiffness * self.material_stiffness(state)
        return C.tocsc()

    def material_stiffness(self, state: ShellState) -> sp.csc_matrix:
        """K_m = B^T C B in this layout (CSC): the tangent whose geometric terms carry zero stresses, without
        loads; the velocity derivative of :meth:`material_damping_force`. MITC6 variants."""
        zero = state.copy()
        zero.stress = np.zeros((self.model.body.mesh.n_elements, 7, 8))
        K = self.model.residual_and_tangent(zero, 0.0)[1]
        return (K @ self._column_map(state)).tocsc()

    def consistent_director_rates(self, state: ShellState, v: np.ndarray) -> np.ndarray:
        """v with its rotation components replaced by the director rates that minimise the strain-rate energy
        v^T K_m v at the given translational velocities (K_m,rr w = -K_m,rt v_t): no transverse-shear rate
        beyond what the translations force. A rigid velocity is kept.

        For a stiffness-damped start from translational velocities alone (a kick v_z without director rates):
        its shear-strain rate puts damping moments a1 kGh gamma_dot on the rotary inertias j ~ rho h^3 / 12,
        an initial acceleration that throws the predictor of the first step (tests/test_damping.py).
        """
        rot = ~self.is_translation
        out = np.array(v, dtype=float, copy=True)
        if not rot.any():
            return out
        from scipy.sparse.linalg import spsolve
        K = self.material_stiffness(state)
        Krr = K[rot][:, rot].tocsc()
        out[rot] = spsolve(Krr, -(K[rot][:, ~rot] @ out[~rot]))
        return out


    # -- reuse of an iteration matrix under large rigid rotations ------------------------------------------
    def body_rotation(self, x_ref: np.ndarray, x: np.ndarray) -> np.ndarray:
        """The rotation Q that best maps the positions x_ref onto x (mass-weighted Kabsch fit about the centroids)."""
        m = self.inertia.mass
        a = x_ref - (m @ x_ref) / m.sum()
        b = x - (m @ x) / m.sum()
        H = np.einsum("n,ni,nj->ij", m, b, a)          # sum m b a^T
        U, _, Vt = np.linalg.svd(H)
        d = np.sign(np.linalg.det(U @ Vt)) or 1.0
        return U @ np.diag([1.0, 1.0, d]) @ Vt

    def transfer(self, state_ref: ShellState, state: ShellState) -> tuple[np.ndarray, np.ndarray]:
        """The map P of DoF components from ``state_ref`` to ``state`` under the body's rigid rotation.

        Under a rigid rotation Q of a free body (x -> Q x, R_I -> Q R_I D_I, D_I a drilling rotation: the
        frames are parallel-transported, so they turn about their directors relative to the body), the
        stiffness in these coordinates transforms as K -> P K P^T with P = Q on the fixed-direction
        translations (nodes without a constraint basis) and P = D_I^T (its in-plane 2 x 2 block) on the local
        rotations; the lumped mass is invariant. An old factorization of M beta' + K then serves through P.
        Exact for rigid motion of a free body, an approximation (used only in the iteration matrix) otherwise.

        Returns Q (3, 3) and the 2 x 2 blocks D_I^T of the nodes with both rotations free (k, 2, 2).
        """
        Q = self.body_rotation(state_ref.x, state.x)
        nodes = self._rot_nodes
        D = np.einsum("nji,jk,nkl->nil", state_ref.frames[nodes], Q.T, state.frames[nodes])  # R_ref^T Q^T R
        D2 = D[:, :2, :2]
        # project each block on a plane rotation (the drilling part; O(eps^2) in-plane leakage is dropped)
        c = 0.5 * (D2[:, 0, 0] + D2[:, 1, 1])
        s_ = 0.5 * (D2[:, 1, 0] - D2[:, 0, 1])
        norm = np.hypot(c, s_)
        c, s_ = c / norm, s_ / norm
        DT = np.stack([np.stack([c, s_], axis=1), np.stack([-s_, c], axis=1)], axis=1)   # D^T
        return Q, DT

    def apply_transfer(self, vec: np.ndarray, transfer: tuple[np.ndarray, np.ndarray],
                       transpose: bool = False) -> np.ndarray:
        """P vec (or P^T vec) for P from :meth:`transfer`."""
        Q, DT = transfer
        out = np.array(vec, dtype=float, copy=True)
        if transpose:
            Q, DT = Q.T, np.transpose(DT, (0, 2, 1))
        out[self._col_index] = vec[self._col_index] @ Q.T
        out[self._rot_index] = np.einsum("nij,nj->ni", DT, vec[self._rot_index])
        return out

    # -- initial conditions --------------------------------------------------------------------------------
    def velocity_from_nodal(self, state: ShellState, xdot: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """The free-DoF velocity of nodal velocities xdot (n, 3) and global angular velocities omega (n, 3).

        The nodal angular velocity is w_I = R_I^T omega_I; its drilling component w_3 (about the director) is
        not a DoF and is dropped (a rotation about the director does not move the director). Constrained
        components are dropped as well.
        """
        xdot = np.asarray(xdot, dtype=float)
        w = np.einsum("nji,nj->ni", state.frames, np.asarray(omega, dtype=float))
        out = self._fixed_direction_vectors(xdot)
        rot = ~self.is_translation
        out[rot] = w[self.node[rot], self.comp[rot] - 3]
        return out

    def rigid_velocity(self, state: ShellState, omega, v0=(0.0, 0.0, 0.0), center=None) -> np.ndarray:
        """The free-DoF velocity of the rigid field xdot = v0 + omega x (x - center), angular velocity omega."""
        omega, v0 = np.asarray(omega, float), np.asarray(v0, float)
        c = np.zeros(3) if center is None else np.asarray(center, float)
        xdot = v0 + np.cross(omega, state.x - c)
        return self.velocity_from_nodal(state, xdot, np.tile(omega, (len(state.x), 1)))

    # -- outputs -------------------------------------------------------------------------------------------
    def nodal_velocities(self, state: ShellState, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Global nodal velocities xdot (n, 3) and local angular velocities (n, 3) (w_3 = 0) from v."""
        m = self.model
        n = m.body.n_nodes
        comp = np.zeros((n, 6))
        comp.ravel()[m.free] = v
        xdot = comp[:, :3].copy()
        idx = np.flatnonzero(m.has_basis)
        xdot[idx] = np.einsum("nij,nj->ni", m.basis[idx], comp[idx, :3])
        w = comp[:, 3:].copy()
        w[:, 2] = 0.0
        return xdot, w

    def kinetic_energy(self, v: np.ndarray) -> float:
        """1/2 v^T M v = 1/2 sum m_I |xdot_I|^2 + 1/2 sum j_I (w_1^2 + w_2^2)."""
        return 0.5 * float(np.sum(self.mass * v * v))

    def strain_energy(self, state: ShellState) -> float:
        """Elastic energy 1/2 sum_g w_g eps^T C eps from the numba strain kernel (same as body.strain_energy)."""
        from flexbody.shell.element import element_strains_batch
        body = self.model.body
        if body.tying == "mitc7":          # the strains need the condensed bubbles
            return body.strain_energy(state)
        conn = body.mesh.elements
        ref = body.reference
        eps = element_strains_batch(state.x[conn], state.frames[conn], ref.e_ref, ref.to_cart, body._maps)
        C = body.material.section()
        return 0.5 * float(np.einsum("eg,egi,ij,egj->", ref.weights, eps, C, eps))

    def gravity_potential(self, state: ShellState) -> float:
        """-sum m_I g . x_I."""
        return -float(self.inertia.mass @ (state.x @ self.gravity))

    def momenta(self, state: ShellState, v: np.ndarray, center=None) -> tuple[np.ndarray, np.ndarray]:
        """Linear momentum p = sum m xdot and angular momentum about ``center`` (default origin).

        L = sum_I (x_I - c) x m_I xdot_I + R_I J_I w_I, with J_I = j_I diag(1, 1, 0).
        """
        xdot, w = self.nodal_velocities(state, v)
        m, j = self.inertia.mass, self.inertia.rotary
        c = np.zeros(3) if center is None else np.asarray(center, float)
        p = m @ xdot
        L = np.cross(state.x - c, m[:, None] * xdot).sum(axis=0)
        L += np.einsum("nij,nj->i", state.frames, j[:, None] * w)
        return p, L

    def rigid_angular_velocity(self, state: ShellState, v: np.ndarray) -> np.ndarray:
        """The least-squares rigid angular velocity of the nodal translational velocities (mass-weighted).

        Minimises sum m_I |xdot_I - xdot_c - omega x (x_I - c)|^2: a kinematic fit, independent of the
        director velocities and of the momenta.
        """
        xdot, _ = self.nodal_velocities(state, v)
        m = self.inertia.mass
        r = state.x - m @ state.x / m.sum()
        rd = xdot - m @ xdot / m.sum()
        A = np.einsum("n,nk,nk->", m, r, r) * np.eye(3) - np.einsum("n,ni,nj->ij", m, r, r)
        return np.linalg.solve(A, np.cross(r, m[:, None] * rd).sum(axis=0))

    def rigid_inertia_tensor(self, state: ShellState) -> tuple[np.ndarray, np.ndarray]:
        """Centre of mass c and inertia tensor about it of the discrete body frozen in ``state``.

        I = sum m_I (|r_I|^2 1 - r_I r_I^T) + sum j_I (1 - t_I t_I^T), r_I = x_I - c, t_I the director.
        """
        m, j = self.inertia.mass, self.inertia.rotary
        c = (m @ state.x) / m.sum()
        r = state.x - c
        I = np.einsum("n,nk,nk->", m, r, r) * np.eye(3) - np.einsum("n,ni,nj->ij", m, r, r)
        t = state.directors
        I += j.sum() * np.eye(3) - np.einsum("n,ni,nj->ij", j, t, t)
        return c, I
