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
Both pieces of the mass are constant (see :mod:`flexbody.shell.inertia`): M = diag(m_I, j_I) lumped (HRZ), or
with ``mass="consistent"`` the translational block S x I_3, S_IJ = int rho h N_I N_J dA, next to the lumped
director inertia j_I; there are no gyroscopic or centrifugal terms in these coordinates (the centripetal
accelerations of a spinning body are simply the global accelerations of its nodes). With the consistent mass
the free nodes next to a prescribed (driven) node feel its acceleration: M_fp a_p(t) is part of g(q, t).

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
from flexbody.body import ShellState, moved_state
from flexbody.frames import node_patches, patch_rotations
from flexbody.matrix_transfer import apply_node_rotations, drilling_drifts
from flexbody.shell.inertia import (NodalInertia, ShellMass, check_mass_kind, nodal_inertia, shell_mass,
                                    with_point_masses)


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


def prescribed_acceleration(motion: Callable, X: np.ndarray, t: float) -> np.ndarray:
    """xddot (k, 3) at time t of the points x(t) = Q(t) X + d(t) of a prescribed motion, by finite differences.

    A one-sided second-order difference (the motion need not be defined before the start),
    xddot ~ (2 x(t) - 5 x(t + s) + 4 x(t + 2s) - x(t + 3s)) / s^2, with the step s set from the motion itself so
    that the points move by about 1e-4 of their extent over s (truncation and round-off both ~1e-8 relative:
    scale-free in time and length). A motion at rest over 1e6 time units has zero acceleration.
    """
    X = np.asarray(X, dtype=float)

    def x(time: float) -> np.ndarray:
        Q, d = motion(time)
        return X @ np.asarray(Q, float).T + np.asarray(d, float)

    x0 = x(t)
    size = float(np.ptp(x0, axis=0).max()) or float(np.abs(x0).max()) or 1.0     # the points' extent
    s = 1.0
    for _ in range(40):                       # s <- s (target / moved), clipped: a few iterations
        moved = float(np.abs(x(t + s) - x0).max())
        if moved == 0.0:
            if s >= 1e6:
                return np.zeros_like(x0)
            s *= 1e3
            continue
        ratio = 1e-4 * size / moved
        if 0.5 < ratio < 2.0:
            break
        s *= min(max(ratio, 1e-3), 1e3)
    return (2.0 * x0 - 5.0 * x(t + s) + 4.0 * x(t + 2 * s) - x(t + 3 * s)) / s**2


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
    mass : "lumped" (HRZ, diagonal; the default) or "consistent" (translations int rho h N_I N_J dA, the
        director inertia lumped): :meth:`mass_matrix`. Everything that uses the mass uses this one (inertia
        forces, iteration matrix, gravity, energies, momenta, mass damping, the steady spin's load).
    """

    model: Model
    gravity: np.ndarray | tuple = (0.0, 0.0, 0.0)
    load_factor: Callable[[float], float | np.ndarray] | None = None
    prescribed: list = field(default_factory=list)
    point_masses: list = field(default_factory=list)
    damping: RayleighDamping | None = None
    mass: str = "lumped"
    inertia: NodalInertia = field(init=False)
    body_mass: ShellMass = field(init=False)

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
        check_mass_kind(self.mass)
        self.body_mass = shell_mass(m.body, self.mass, self.point_masses)
        self._M = self._free_mass_matrix()
        if np.any(self._M.diagonal() <= 0):
            raise ValueError("the mass matrix has non-positive entries: the material density must be > 0")
        self._M_solve = None
        self.dof_scale = m.dof_scale
        self._gravity_force = self._fixed_direction_vectors(self.body_mass.nodal[:, None] * self.gravity)
        # for the column map: the free DoF index of (node, translation component) of local-column nodes
        nodes = np.unique(self.node[self.local_columns])
        index = -np.ones((m.body.n_nodes, 6), dtype=np.int64)
        index.ravel()[free] = np.arange(free.size)
        self._col_nodes = nodes
        self._col_index = index[nodes, :3]          # (k, 3), all >= 0 (a non-basis node frees all three)
        self._rot_nodes = np.flatnonzero(np.all(index[:, 3:5] >= 0, axis=1))
        self._rot_index = index[self._rot_nodes, 3:5]
        self._patches = node_patches(m.body.mesh.elements, m.body.n_nodes)
        self._basis_nodes = np.flatnonzero(m.has_basis)
        if self.damping is not None and not isinstance(self.damping, RayleighDamping):
            raise ValueError(f"damping must be RayleighDamping or None, got {type(self.damping).__name__}")
        if self.damping is not None and self.damping.beta_stiffness > 0 and m.body.material.wrinkling:
            raise ValueError("stiffness-proportional damping (beta_stiffness > 0) is not available with the tension-"
                             "field membrane (material wrinkling = true): its damping matrix B^T C B needs the "
                             "geometric terms of given stresses, which that law does not provide")
        if self.damping is not None and self.damping.beta_stiffness > 0 and not m.body.supports_mixed_iteration:
            raise ValueError("stiffness-proportional damping (beta_stiffness > 0) needs the linearized stresses "
                             f"of an MITC6 element, not {m.body.element_name} (tying = {m.body.element.key!r})")
        for p in self.prescribed:
            if not isinstance(p, PrescribedMotion):
                raise ValueError(f"prescribed motions must be PrescribedMotion, got {type(p).__name__}")
            bad = p.nodes[~np.all(m.fixed[p.nodes, :5], axis=1)]
            if bad.size:
                raise ValueError(f"prescribed motion on node {bad[0]}, which is not clamped (Fix(..., 'all'))")
        self._M_fp = self._prescribed_coupling()
        self._prescribed_cache: dict[int, tuple] = {}     # :meth:`_prescribed_place`

    # -- the mass matrix -----------------------------------------------------------------------------------
    def translation_directions(self) -> sp.csr_matrix:
        """T (3n x n_dof): the global nodal translations of the free DoFs, x_dot = T v (see ``_directions``)."""
        return self._directions()

    def _directions(self) -> sp.csr_matrix:
        """T (3n x n_dof): column a is the direction d_a of translation DoF a in the rows of its node (the
        constraint basis column E_I[:, i], or e_i), zero for rotation DoFs. x_dot = T v (translations)."""
        m = self.model
        tr = np.flatnonzero(self.is_translation)
        node, comp = self.node[tr], self.comp[tr]
        d = m.basis[node, :, comp]                                   # (k, 3): E_I[:, i]
        rows = (3 * node[:, None] + np.arange(3)).ravel()
        return sp.csr_matrix((d.ravel(), (rows, np.repeat(tr, 3))), shape=(3 * m.body.n_nodes, self.n_dof))

    def _free_mass_matrix(self) -> sp.csc_matrix:
        """M on the free DoFs: T^T (S x I_3) T on the translations, diag(j_I) on the rotations."""
        rot = np.where(self.is_translation, 0.0, self.body_mass.rotary[self.node])
        if self.mass == "lumped":     # exactly diag(m_I, j_I)
            return sp.diags(np.where(self.is_translation, self.body_mass.scalar.diagonal()[self.node], rot)).tocsc()
        T = self._directions()
        M = T.T @ sp.kron(self.body_mass.scalar, sp.eye(3)) @ T
        return (0.5 * (M + M.T) + sp.diags(rot)).tocsc()          # symmetric to the last bit

    def _prescribed_coupling(self) -> sp.csr_matrix | None:
        """M_fp (n_dof x 3k): the consistent mass between the free DoFs and the translations of the k prescribed
        nodes (None when it is zero: a lumped mass, or no prescribed motion)."""
        if self.mass == "lumped" or not self.prescribed:
            return None
        nodes = np.concatenate([p.nodes for p in self.prescribed])
        cols = (3 * nodes[:, None] + np.arange(3)).ravel()
        Mp = (self._directions().T @ sp.kron(self.body_mass.scalar, sp.eye(3)).tocsc()[:, cols]).tocsr()
        return Mp if Mp.nnz else None

    def _prescribed_inertia(self, t: float) -> np.ndarray | float:
        """M_fp a_p(t): the inertia forces on the free DoFs of the prescribed nodes' accelerations (0 lumped)."""
        if self._M_fp is None:
            return 0.0
        X = self.model.body.mesh.nodes
        a = np.concatenate([prescribed_acceleration(p.motion, X[p.nodes], t) for p in self.prescribed])
        return self._M_fp @ a.ravel()

    def mass_matrix(self) -> sp.csc_matrix:
        """The constant mass matrix M on the free DoFs (CSC), lumped (diagonal) or consistent (``mass``)."""
        return self._M

    def solve_mass(self, f: np.ndarray) -> np.ndarray:
        """M^-1 f (a division lumped, a sparse factorization kept for the model consistent)."""
        if self.mass == "lumped":
            return f / self._M.diagonal()
        if self._M_solve is None:
            from scipy.sparse.linalg import factorized
            self._M_solve = factorized(self._M)
        return self._M_solve(np.asarray(f, dtype=float))

    # -- sizes, loads ------------------------------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        """The number of free DoFs (those of the static model)."""
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
        """q o exp(dq) on R^3 x SO(3): x_I <- x_I + dx_I, R_I <- R_I exp(dtheta_1 e1 + dtheta_2 e2).

        dx_I: the increment's fixed-direction components, E_I dv_I on the nodes with a constraint basis (the
        Model's update of :meth:`model_increment`, without turning the translations into the local frames and
        back). In the mixed Newton iteration (``state.stress`` set) the Model moves the stresses on too."""
        m = self.model
        if state.stress is not None:
            return m.update(state, self.model_increment(state, dq))
        d6 = np.zeros((m.body.n_nodes, 6))
        d6.ravel()[m.free] = dq
        dx = d6[:, :3]
        idx = self._basis_nodes
        if idx.size:
            dx[idx] = np.einsum("nij,nj->ni", m.basis[idx], dx[idx])
        return moved_state(state, dx, d6[:, 3:5])

    def prescribe(self, state: ShellState, t: float) -> ShellState:
        """The state with the prescribed nodes moved to their place at time t (a no-op without any).

        Positions are set; frames are turned from their current orientation by :func:`director_step`.
        """
        if not self.prescribed:
            return state
        new = state.copy()
        for k, p in enumerate(self.prescribed):
            new.x[p.nodes], new.frames[p.nodes] = self._prescribed_place(k, state.frames[p.nodes], t)
        return new

    def _prescribed_place(self, k: int, frames: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Positions and frames at time t of the nodes of prescribed motion k whose frames are now ``frames``.

        Every iterate of a time step asks for the same ones (the free-DoF corrections do not move clamped
        nodes): the last answer is kept, keyed on t and the frames it was made from."""
        cached = self._prescribed_cache.get(k)
        if cached is not None and cached[0] == t and np.array_equal(cached[1], frames):
            return cached[2], cached[3]
        p = self.prescribed[k]
        X, N = self.model.body.mesh.nodes[p.nodes], self.model.body.frames0[p.nodes, :, 2]
        Q, d = p.motion(t)
        Q, d = np.asarray(Q, float), np.asarray(d, float)
        x, moved = X @ Q.T + d, director_step(frames, N @ Q.T)
        self._prescribed_cache[k] = (t, frames.copy(), x, moved)
        return x, moved

    def column_map(self, state: ShellState) -> sp.csc_matrix:
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
        return self.model.residual(state, self.lam(t)) - self._gravity_force + self._prescribed_inertia(t)

    def residual(self, state: ShellState, v: np.ndarray, vdot: np.ndarray, t: float) -> np.ndarray:
        """r = M vdot + f_d(q, v) + f_int - lambda f_ext - f_g (the equations of motion, exact)."""
        return self._M @ vdot + self.damping_force(state, v) + self.internal_minus_external(state, t)

    def residual_and_tangent(self, state: ShellState, v: np.ndarray, vdot: np.ndarray, t: float):
        """r and the stiffness K_t = dr/dq (columns along q o exp(eps e_k) in this layout), CSC.

        K_t is the tangent of f_int - lambda f_ext; the damping force's derivative in q is left out (an
        approximation of the iteration matrix only; its velocity derivative is :meth:`damping_matrix`)."""
        r, K = self.model.residual_and_tangent(state, self.lam(t), global_columns=True)
        return (self._M @ vdot + self.damping_force(state, v) + r - self._gravity_force
                + self._prescribed_inertia(t), K)

    def initial_acceleration(self, state: ShellState, t: float = 0.0, v: np.ndarray | None = None) -> np.ndarray:
        """vdot_0 = -M^-1 (f_d(q_0, v_0) + g(q_0, t_0)) (no gyroscopic forces in these coordinates)."""
        f = self.internal_minus_external(state, t)
        if v is not None:
            f = f + self.damping_force(state, v)
        return -self.solve_mass(f)

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
            out += d.alpha_mass * (self._M @ v)
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
        C = d.alpha_mass * self._M
        if d.beta_stiffness:
            C = C + d.beta_stiffness * self.material_stiffness(state)
        return C.tocsc()

    def material_stiffness(self, state: ShellState) -> sp.csc_matrix:
        """K_m = B^T C B in this layout (CSC): the tangent whose geometric terms carry zero stresses, without
        loads; the velocity derivative of :meth:`material_damping_force`. MITC6 variants."""
        zero = state.copy()
        zero.stress = np.zeros((self.model.body.mesh.n_elements, 7, 8))
        return self.model.residual_and_tangent(zero, 0.0, global_columns=True)[1]

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
        """The map P of DoF components from ``state_ref`` to ``state``: node by node, the rotation of the node's
        patch.

        Under a rigid rotation Q of a free body (x -> Q x, R_I -> Q R_I D_I, D_I a drilling rotation: the
        frames are parallel-transported, so they turn about their directors relative to the body), the
        stiffness in these coordinates transforms as K -> P K P^T with P = Q on the fixed-direction
        translations (nodes without a constraint basis) and P = D_I^T (its in-plane 2 x 2 block) on the local
        rotations, D_I = R_I,ref^T Q^T R_I; the mass is invariant (lumped: diagonal; consistent: S x I_3 commutes
        with Q on every node, and the director part is j_I times the identity). An old factorization of
        M beta' + K then serves through P.

        A deforming body turns each part of its surface differently: node by node, G_I, the rotation of the
        node's patch (the nodes it shares an element with, :func:`flexbody.frames.patch_rotations`), replaces Q
        (G_I = Q under rigid motion, which stays exact). The element tangents in their local frames change only
        with the strains, while the fixed-direction translations turn with the surface: with one Q for all, a
        surface tilted by phi since the factorization mixes phi times the membrane stiffness into the soft
        transverse directions of a thin shell, and the kept matrix stalls. Measured (docs/dynamics.md): the
        kicked 4 x 32 hub annulus, three revolutions in the turning frame, 0.120 fresh matrices per step with one
        Q, 0.017 with the directors' tilts, 0.010 with the patches' rotations; the 10 m sail (one revolution,
        linear law, its buckled film kinked at the mesh scale) 0.253, 0.454 (the directors of a kinked film are
        not the rotation of its elements) and 0.151. Otherwise P is an approximation, used only in the iteration
        matrix (a lumped mass stays invariant, a consistent one to the turn between neighbours).

        Returns G_I (k, 3, 3) of the nodes with free fixed-direction translations and the 2 x 2 blocks D_I^T of
        the nodes with both rotations free (k, 2, 2) (:func:`flexbody.matrix_transfer.drilling_drifts`).
        """
        G = patch_rotations(self._patches, state_ref.x, state.x)
        nodes = self._rot_nodes
        return G[self._col_nodes], drilling_drifts(state_ref.frames[nodes], G[nodes], state.frames[nodes])

    def apply_transfer(self, vec: np.ndarray, transfer: tuple[np.ndarray, np.ndarray],
                       transpose: bool = False) -> np.ndarray:
        """P vec (or P^T vec) for P from :meth:`transfer` (:func:`flexbody.matrix_transfer.apply_node_rotations`)."""
        G, DT = transfer
        return apply_node_rotations(vec, self._col_index, G, self._rot_index, DT, transpose)

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
        """1/2 v^T M v = 1/2 sum_IJ S_IJ xdot_I . xdot_J + 1/2 sum j_I (w_1^2 + w_2^2) (lumped: S = diag(m_I))."""
        return 0.5 * float(v @ (self._M @ v))

    def strain_energy(self, state: ShellState) -> float:
        """Elastic energy 1/2 sum_g w_g eps^T C eps from the numba strain kernel (MITC7: at the condensed
        bubbles; :meth:`flexbody.body.ShellBody.strain_energy`)."""
        return self.model.body.strain_energy(state, strain_kernel="numba")

    def gravity_potential(self, state: ShellState) -> float:
        """-sum s_I g . x_I, s_I the row sums of the translational mass (m_I lumped, int rho h N_I dA consistent)."""
        return -float(self.body_mass.nodal @ (state.x @ self.gravity))

    def momenta(self, state: ShellState, v: np.ndarray, center=None) -> tuple[np.ndarray, np.ndarray]:
        """Linear momentum p = sum m xdot and angular momentum about ``center`` (default origin).

        L = sum_I (x_I - c) x (S xdot)_I + R_I J_I w_I, with J_I = j_I diag(1, 1, 0) and S the translational
        mass (diag(m_I) lumped): p = sum_IJ S_IJ xdot_J, the momenta of the mass matrix the equations use.
        """
        xdot, w = self.nodal_velocities(state, v)
        S, j = self.body_mass.scalar, self.body_mass.rotary
        c = np.zeros(3) if center is None else np.asarray(center, float)
        Sx = S @ xdot
        p = Sx.sum(axis=0)
        L = np.cross(state.x - c, Sx).sum(axis=0)
        L += np.einsum("nij,nj->i", state.frames, j[:, None] * w)
        return p, L

    def rigid_angular_velocity(self, state: ShellState, v: np.ndarray) -> np.ndarray:
        """The least-squares rigid angular velocity of the nodal translational velocities (mass-weighted).

        Minimises the kinetic energy of xdot_I - xdot_c - omega x (x_I - c) in the translational mass S
        (sum m_I |.|^2 lumped): a kinematic fit, independent of the director velocities.
        """
        xdot, _ = self.nodal_velocities(state, v)
        S, s = self.body_mass.scalar, self.body_mass.nodal
        r = state.x - s @ state.x / s.sum()
        rd = xdot - s @ xdot / s.sum()
        Sr = S @ r
        A = np.einsum("nk,nk->", r, Sr) * np.eye(3) - r.T @ Sr
        return np.linalg.solve(A, np.cross(r, S @ rd).sum(axis=0))

    def rigid_inertia_tensor(self, state: ShellState) -> tuple[np.ndarray, np.ndarray]:
        """Centre of mass c and inertia tensor about it of the discrete body frozen in ``state``.

        I = sum_IJ S_IJ (r_I . r_J 1 - r_I r_J^T) + sum j_I (1 - t_I t_I^T), r_I = x_I - c, t_I the director,
        S the translational mass (diag(m_I) lumped), c = sum s_I x_I / sum s_I with s_I its row sums.
        """
        bm = self.body_mass
        c = bm.centre(state.x)
        return c, bm.inertia_tensor(state.x, state.directors, c)
