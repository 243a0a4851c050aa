"""Assembly of a shell body with its constraints and loads into the system the integrators solve.

Data flow: mesh -> ShellBody -> Model (this module) -> integrators. Everything is assembled per node as
[u (3), theta (3)] in the nodal local frames (6 per node). Then

1. nodes whose translations are constrained in fixed directions get the basis change
   delta u_I = R_I^T E_I delta v_I (rows and columns), plus the term -E_I^T R_I hat(r_u,I) that the turning
   frame adds to the rotation columns of those rows;
2. the drilling component (theta_3) and the constrained components are dropped.

The result is the residual r(q, lambda) = f_int(q) - lambda f_ext(q) on the free DoFs and its tangent on
the group (columns: the derivative along R_I exp(eps e_k) and along the translation directions).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from flexbody.body import ShellBody, ShellState, update_state
from flexbody.constraints import Fix, FixDirection, Symmetry, basis_with_first
from flexbody.frames import align_frame
from flexbody.lie.so3 import hat_many
from flexbody.loads import FollowerPressure, NodalLoad, pressure_contribution
from flexbody.scatter import scatter_blocks

_COMPONENT = {"x": 0, "y": 1, "z": 2}


def _sorted_unique(keys: np.ndarray) -> np.ndarray:
    """np.unique of integer keys by a sort (numpy's hash-based unique is several times slower on the millions
    of (row, column) keys of a model's pattern)."""
    keys = np.sort(keys)
    return keys[np.concatenate([[True], keys[1:] != keys[:-1]])] if keys.size else keys


class ModelError(ValueError):
    """A model that cannot be solved as given (bad constraint, every DoF fixed, loads on constrained DoFs only, ...)."""


def _listed(indices: np.ndarray, at_most: int = 5) -> str:
    """'3, 4, 5' or '3, 4, 5, 6, 7, ... (12 in all)'."""
    shown = ", ".join(str(int(i)) for i in indices[:at_most])
    return shown if len(indices) <= at_most else f"{shown}, ... ({len(indices)} in all)"


@dataclass
class Counters:
    """What the solution cost: element evaluations and assemblies."""

    residuals: int = 0
    tangents: int = 0


@dataclass
class Model:
    """A shell body with constraints and loads.

    Parameters
    ----------
    body : the shell body
    constraints : Fix and Symmetry conditions
    loads : NodalLoad and FollowerPressure loads (all scaled by the load factor)
    load_groups : the group k = 0 .. G-1 of each load (None: all in group 0). The load factor ``lam`` of
        :meth:`residual` and :meth:`residual_and_tangent` is then a number (every group scaled by it) or the
        G factors lambda_k of the groups: r = f_int - sum_k lambda_k f_ext,k, the tangent exact for each
        (dead, follower and pressure loads alike; each group's load and tangent blocks are linear in lambda_k).
    """

    body: ShellBody
    constraints: list = field(default_factory=list)
    loads: list = field(default_factory=list)
    counters: Counters = field(default_factory=Counters)
    load_groups: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        n = self.body.n_nodes
        self.fixed = np.zeros((n, 6), dtype=bool)
        self.fixed[:, 5] = True  # no drilling DoF
        self.basis = np.tile(np.eye(3), (n, 1, 1))
        self.has_basis = np.zeros(n, dtype=bool)
        self._apply_constraints()
        self.free = np.flatnonzero(~self.fixed.ravel())
        if self.free.size == 0:
            raise ModelError(f"the constraints fix every DoF of the body's {n} nodes: nothing is left to compute "
                             "(check the node selections of the supports)")
        self._collect_loads()
        conn = self.body.mesh.elements
        self._dof6 = (6 * conn[:, :, None] + np.arange(6)).reshape(len(conn), 36)
        self._dof6_flat = self._dof6.ravel()
        size = float(np.ptp(self.body.mesh.nodes, axis=0).max()) or 1.0
        scale6 = np.tile([size, size, size, 1.0, 1.0, 1.0], n)
        self.dof_scale = scale6[self.free]  # translations in units of the model size, rotations in rad
        self._build_pattern()

    # -- setup -------------------------------------------------------------------------------------------
    def _build_pattern(self) -> None:
        """CSR pattern of the free-DoF matrix and, for every element and nodal entry, its data slot."""
        n, m = self.body.n_nodes, self.body.mesh.n_elements
        n_free = self.free.size
        index = -np.ones(6 * n, dtype=np.int64)
        index[self.free] = np.arange(n_free)
        fe = index[self._dof6]                                        # (m, 36)
        er, ec = np.repeat(fe, 36, axis=1).ravel(), np.tile(fe, (1, 36)).ravel()
        fn = index[(6 * np.arange(n)[:, None] + np.arange(6))]        # (n, 6)
        nr, nc = np.repeat(fn, 6, axis=1).ravel(), np.tile(fn, (1, 6)).ravel()
        rows, cols = np.concatenate([er, nr]), np.concatenate([ec, nc])
        valid = (rows >= 0) & (cols >= 0)
        keys = _sorted_unique(rows[valid] * n_free + cols[valid])
        self._indices = (keys % n_free).astype(np.int32)
        self._indptr = np.searchsorted(keys // n_free, np.arange(n_free + 1)).astype(np.int32)
        slot = lambda r, c: np.where((r >= 0) & (c >= 0), np.searchsorted(keys, r * n_free + c), -1)
        self._slot_elem = slot(er, ec).reshape(m, 36, 36)
        self._slot_node = slot(nr, nc).reshape(n, 6, 6)

    def _check_nodes(self, nodes: np.ndarray, what: str) -> None:
        n = self.body.n_nodes
        if nodes.size == 0:
            raise ModelError(f"{what} acts on no nodes")
        if nodes.min() < 0 or nodes.max() >= n:
            bad = nodes[(nodes < 0) | (nodes >= n)][0]
            raise ModelError(f"{what} names node {bad}, but the mesh has nodes 0..{n - 1}")

    def _apply_constraints(self) -> None:
        frames = self.body.frames0.copy()
        changed = False
        for c in self.constraints:
            if isinstance(c, Symmetry):
                self._check_nodes(c.nodes, "symmetry condition")
                for i in c.nodes:
                    frames[i], k = align_frame(frames[i], c.normal, int(i))
                    changed = True
                    self._fix_direction(int(i), c.normal)
                    self.fixed[i, 3 + (1 - k)] = True
            elif isinstance(c, Fix):
                self._check_nodes(c.nodes, "fixed condition")
                comps = c.expanded()
                trans = sorted(_COMPONENT[a] for a in comps if a in _COMPONENT)
                for i in c.nodes:
                    if len(trans) == 3:
                        self.fixed[i, :3] = True
                    for a in trans if len(trans) < 3 else ():
                        self._fix_direction(int(i), np.eye(3)[a])
                    self.fixed[i, 3] |= "r1" in comps
                    self.fixed[i, 4] |= "r2" in comps
            elif isinstance(c, FixDirection):
                self._check_nodes(c.nodes, "direction condition")
                for i in c.nodes:
                    self._fix_direction(int(i), c.direction)
            else:
                raise ModelError(f"unknown constraint type {type(c).__name__}")
        if changed:
            self.body.set_reference_frames(np.arange(self.body.n_nodes), frames)

    def _fix_direction(self, i: int, direction: np.ndarray) -> None:
        """Fix the translation of node i along a direction, with a fixed translation basis."""
        if self.fixed[i, :3].all():
            return
        if not self.has_basis[i]:
            self.basis[i] = np.eye(3) if np.isclose(np.abs(direction).max(), 1.0) else basis_with_first(direction)
            self.has_basis[i] = True
        cos = self.basis[i].T @ direction
        k = int(np.argmax(np.abs(cos)))
        if abs(abs(cos[k]) - 1.0) > 1e-10:
            raise ModelError(f"node {i}: constraint direction {direction.tolist()} contradicts an earlier "
                             f"constraint direction on the same node (not orthogonal to it)")
        self.fixed[i, k] = True

    def _check_load_groups(self) -> np.ndarray:
        """The group of each load (n_loads,), checked: integers 0 .. G-1, one per load."""
        if self.load_groups is None:
            return np.zeros(len(self.loads), dtype=int)
        groups = list(self.load_groups)
        if len(groups) != len(self.loads) or not all(isinstance(g, (int, np.integer)) and not isinstance(g, bool)
                                                     and g >= 0 for g in groups):
            raise ModelError(f"load_groups must give one group index >= 0 per load ({len(self.loads)} loads), "
                             f"got {self.load_groups!r}")
        return np.asarray(groups, dtype=int)

    def _collect_loads(self) -> None:
        n = self.body.n_nodes
        groups = self._check_load_groups()
        self.n_load_groups = int(groups.max()) + 1 if groups.size else 1
        self._group_dead = np.zeros((self.n_load_groups, n, 6))      # global force, moment per group
        self._group_follower = np.zeros((self.n_load_groups, n, 6))  # local force, moment per group
        self.pressures: list[FollowerPressure] = []
        self._pressure_groups: list[int] = []
        for load, group in zip(self.loads, groups):
            if isinstance(load, NodalLoad):
                self._check_nodes(load.nodes, "load")
                target = self._group_follower[group] if load.follower else self._group_dead[group]
                np.add.at(target, load.nodes, np.concatenate([load.force, load.moment]))
            elif isinstance(load, FollowerPressure):
                try:
                    p = float(load.pressure)
                except (TypeError, ValueError):
                    raise ModelError(f"pressure must be a number, got {load.pressure!r}") from None
                if not np.isfinite(p):
                    raise ModelError(f"pressure must be finite, got {load.pressure!r}")
                if load.elements is not None:
                    elems = np.atleast_1d(np.asarray(load.elements))
                    m = self.body.mesh.n_elements
                    if elems.size == 0 or not np.issubdtype(elems.dtype, np.integer) or elems.min() < 0 \
                            or elems.max() >= m:
                        raise ModelError(f"pressure elements must be indices in 0..{m - 1}, got {load.elements!r}")
                self.pressures.append(load)
                self._pressure_groups.append(int(group))
            else:
                raise ModelError(f"unknown load type {type(load).__name__}")
        self.dead = self._group_dead.sum(axis=0)           # all groups at factor 1
        self.follower = self._group_follower.sum(axis=0)
        self._check_loads_on_constrained()

    def group_factors(self, lam) -> np.ndarray:
        """The factors (G,) of the load groups: ``lam`` for every group, or ``lam`` itself if it has G entries."""
        factors = np.asarray(lam, dtype=float)
        if factors.ndim == 0:
            factors = np.full(self.n_load_groups, float(factors))
        if factors.shape != (self.n_load_groups,):
            raise ValueError(f"the load factor must be a number or {self.n_load_groups} factors (one per load "
                             f"group), got shape {factors.shape}")
        if not np.all(np.isfinite(factors)):
            raise FloatingPointError(f"non-finite load factor {factors.tolist()!r}")
        return factors

    def _check_loads_on_constrained(self) -> None:
        """Refuse nodal loads that act on constrained DoFs only: the supports would carry all of them.

        A load's part on constrained DoFs (a distributed load over a supported edge, a force along a
        fixed direction) goes to the reactions: the residual keeps the free DoFs only. Only when no part of
        the nodal loads reaches a free DoF (and there is no pressure) is the load surely a mistake.
        """
        loaded = np.any(self._group_dead != 0, axis=(0, 2)) | np.any(self._group_follower != 0, axis=(0, 2))
        if self.pressures or not loaded.any():
            return
        state = self.initial_state()         # each load group on its own (groups may cancel at factor 1)
        f = np.array([self.external_force(state, factors) for factors in np.eye(self.n_load_groups)])
        scale = max(np.abs(self._group_dead).max(), np.abs(self._group_follower).max())
        if np.abs(f).max() <= 1e-12 * scale:
            nodes = np.flatnonzero(loaded)
            raise ModelError(f"every load acts on constrained DoFs only (node{'s' if nodes.size > 1 else ''} "
                             f"{_listed(nodes)}): the supports carry all of it and nothing moves (a moment "
                             "about a director does no work either); load free nodes or free the constraint")

    # -- sizes -------------------------------------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        """The number of free DoFs (five per node less the constrained components)."""
        return int(self.free.size)

    def initial_state(self) -> ShellState:
        """The body's reference configuration."""
        return self.body.initial_state()

    def warm_up(self) -> None:
        """Compile (or load from cache) every numba kernel a solve uses, on a single element and node."""
        from flexbody.lie.kernels import update_frames_into
        self.body.warm_up()
        blocks = np.zeros((1, 36, 36))
        maps = np.tile(np.eye(3), (1, 6, 1, 1))
        scatter_blocks(blocks, maps, maps, -np.ones((1, 36, 36), dtype=np.int64), 1.0, np.zeros(1))
        frames = np.ascontiguousarray(self.body.frames0[:1])
        update_frames_into(frames, np.zeros((1, 2)), frames.copy())

    # -- evaluation --------------------------------------------------------------------------------------
    def _external_local(self, state: ShellState, lam=1.0):
        """The external load sum_k lambda_k f_ext,k: local force (n, 6), its nodal tangent blocks (n, 6, 6)
        and pressure element blocks (``lam`` as in :meth:`group_factors`)."""
        factors = self.group_factors(lam)
        if self.n_load_groups == 1:          # one group: no sum over groups
            dead, follower = factors[0] * self.dead, factors[0] * self.follower
        else:
            dead = np.tensordot(factors, self._group_dead, axes=1)
            follower = np.tensordot(factors, self._group_follower, axes=1)
        R = state.frames
        f = follower.copy()
        f[:, :3] += np.einsum("nji,nj->ni", R, dead[:, :3])
        f[:, 3:] += np.einsum("nji,nj->ni", R, dead[:, 3:])
        blocks = np.zeros((len(R), 6, 6))   # d f_ext / d h (local), nodal
        Fl = np.einsum("nji,nj->ni", R, dead[:, :3])
        Ml = np.einsum("nji,nj->ni", R, dead[:, 3:])
        blocks[:, :3, 3:] = hat_many(Fl)
        blocks[:, 3:, 3:] = hat_many(Ml)
        press = []
        for p, group in zip(self.pressures, self._pressure_groups):
            F, dF, elems = pressure_contribution(self.body.mesh, self.body.relative_positions(state),
                                                 factors[group] * p.pressure,
                                                 p.elements)
            Fl = np.einsum("nji,nj->ni", R, F)
            f[:, :3] += Fl
            blocks[:, :3, 3:] += hat_many(Fl)
            conn = self.body.mesh.elements[elems]
            Rc = R[conn]                                        # (k, 6, 3, 3)
            local = np.swapaxes(Rc, -1, -2)[:, :, None] @ dF @ Rc[:, None]  # R_I^T dF_IJ R_J (matmul: fast)
            press.append((elems, conn, local))
        return f, blocks, press

    def _row_maps(self, state: ShellState) -> np.ndarray:
        """S_I (n, 3, 3): translational equations are the force components S_I r_u,I.

        S_I = R_I (global force components) or E_I^T R_I for nodes with a fixed translation basis.
        The increments stay local (delta x_I = R_I delta u_I) except on basis nodes (delta x_I = E_I delta v_I).
        Writing the force balance in fixed directions keeps the term hat(r_u) -- the derivative of a local
        force component under a turning frame, large far from equilibrium -- out of the iteration matrix:
        Newton then takes the steps of a global-frame Newton, and still solves the same equations.
        Without basis nodes this is the state's own frames array (read it, never write it).
        """
        idx = np.flatnonzero(self.has_basis)
        if idx.size == 0:
            return state.frames
        S = state.frames.copy()
        S[idx] = np.einsum("nji,njk->nik", self.basis[idx], state.frames[idx])
        return S

    def residual(self, state: ShellState, lam: float | np.ndarray) -> np.ndarray:
        """r(q, lambda) on the free DoFs (``lam``: a number, or one factor per load group)."""
        r6 = self._residual6(state, lam, want_tangent=False)[0]
        return self._rotate_rows(state, r6).ravel()[self.free]

    def _residual6(self, state: ShellState, lam: float | np.ndarray, want_tangent: bool):
        """Nodal residuals r6 (n, 6), element tangents, external load blocks, pressure blocks, and the
        nodal residuals whose translation part turns with the frames in the iteration matrix: r6 itself,
        or in the mixed iteration (``state.stress`` set) those of the iterated stresses."""
        self._check_finite(state)
        self.group_factors(lam)                       # checked before the element loop
        fs = None
        if want_tangent and state.stress is not None:
            fe, Ke, fs = self.body.mixed_element_forces(state, state.stress)
        else:
            fe, Ke = self.body.element_forces(state, want_tangent)
        self.counters.residuals += 1
        if not (np.isfinite(fe).all() and (not want_tangent or np.isfinite(Ke).all())):
            bad = np.flatnonzero(~np.all(np.isfinite(fe), axis=1))
            if bad.size == 0 and want_tangent:
                bad = np.flatnonzero(~np.all(np.isfinite(Ke.reshape(len(Ke), -1)), axis=1))
            raise FloatingPointError(f"element {bad[0]} gives non-finite internal forces or tangent "
                                     f"({bad.size} element(s)); nodes {self.body.mesh.elements[bad[0]].tolist()}")
        n = self.body.n_nodes
        r6 = self._sum_element_vectors(fe)
        if not want_tangent and self._unloaded():   # no loads: f_ext = 0, and no load blocks are asked for
            return r6, None, None, [], r6
        fext, ext_blocks, press = self._external_local(state, lam)     # scaled by the load factors
        if not np.isfinite(fext).all():
            bad = np.flatnonzero(~np.all(np.isfinite(fext), axis=1))
            raise FloatingPointError(f"non-finite external load at node {bad[0]}: {fext[bad[0]].tolist()}")
        r6 = r6 - fext
        turning = r6
        if fs is not None:
            turning = self._sum_element_vectors(fs) - fext
        return r6, Ke, ext_blocks, press, turning

    def _unloaded(self) -> bool:
        """No nodal load and no pressure: f_ext = 0 at every state and load factor (read from the load arrays
        at each call: they are plain arrays a caller may change)."""
        if self.pressures:
            return False
        if self.n_load_groups == 1:
            return not (self.dead.any() or self.follower.any())
        return not (self._group_dead.any() or self._group_follower.any())

    def _sum_element_vectors(self, fe: np.ndarray) -> np.ndarray:
        """The nodal sums (n, 6) of element vectors (m, 36) in the nodal local frames. A bincount adds the entries
        in the order np.add.at does (each node's sum, term by term, in element order): the same bits, 5-10x
        faster."""
        n = self.body.n_nodes
        return np.bincount(self._dof6_flat, weights=fe.ravel(), minlength=6 * n).reshape(n, 6)

    def nodal_out_of_balance(self, state: ShellState, lam: float | np.ndarray = 1.0):
        """f_int - f_ext (n, 6) and f_ext (n, 6) per node [force, moment] in the nodal local frames, all DoFs
        (constrained ones included: there f_int - f_ext is the support reaction, :mod:`flexbody.results`)."""
        r6 = self._residual6(state, lam, want_tangent=False)[0]
        fext = self._external_local(state, lam)[0]
        return r6, fext

    def _rotate_rows(self, state: ShellState, r6: np.ndarray) -> np.ndarray:
        out = r6.copy()
        out[:, :3] = np.einsum("nij,nj->ni", self._row_maps(state), r6[:, :3])
        return out

    def residual_and_tangent(self, state: ShellState, lam: float | np.ndarray, global_columns: bool = False):
        """r (free,) and the tangent K = dr/dq (free x free, CSC) at the state (``lam`` as in :meth:`residual`).

        ``global_columns``: the translation columns of the nodes without a fixed basis along the global
        directions (delta x_I = delta v_I, so delta u_I = R_I^T delta v_I) instead of the local increments: the
        tangent K D with D the block R_I^T on those columns (the layout of :class:`flexbody.dynamics.DynamicModel`),
        made in the scatter at no extra cost."""
        r6, Ke, ext_blocks, press, turning = self._residual6(state, lam, want_tangent=True)
        self.counters.tangents += 1
        n = self.body.n_nodes
        conn = self.body.mesh.elements
        S = self._row_maps(state)                                   # rows: S_I r_u,I
        # columns: delta u_I = C_I delta v_I
        C = np.transpose(state.frames, (0, 2, 1)).copy() if global_columns else np.tile(np.eye(3), (n, 1, 1))
        idx = np.flatnonzero(self.has_basis)
        C[idx] = np.transpose(S[idx], (0, 2, 1))
        data = np.zeros(self._indices.size)
        scatter_blocks(Ke, np.take(S, conn, axis=0), np.take(C, conn, axis=0), self._slot_elem, 1.0, data)
        nodal = -ext_blocks
        nodal[:, :3, 3:] -= hat_many(turning[:, :3])                # the turning frame: -hat(r_u,I)
        scatter_blocks(nodal, S[:, None], C[:, None], self._slot_node, 1.0, data)
        for elems, conn_p, local in press:
            blocks = np.zeros((len(elems), 6, 6, 6, 6))
            blocks[:, :, :3, :, :3] = local.transpose(0, 1, 3, 2, 4)
            scatter_blocks(blocks.reshape(len(elems), 36, 36), S[conn_p], C[conn_p], self._slot_elem[elems],
                           -1.0, data)
        K = sp.csr_matrix((data, self._indices, self._indptr), shape=(self.n_dof, self.n_dof))
        r = self._rotate_rows(state, r6).ravel()[self.free]
        return r, K.tocsc()

    def external_force(self, state: ShellState, lam: float | np.ndarray = 1.0) -> np.ndarray:
        """f_ext(q) on the free DoFs (the residual is f_int - lambda f_ext); with the load groups' factors
        ``lam``: sum_k lambda_k f_ext,k."""
        fext = self._external_local(state, lam)[0]
        bad = np.flatnonzero(~np.all(np.isfinite(fext), axis=1))
        if bad.size:
            raise FloatingPointError(f"non-finite external load at node {bad[0]}: {fext[bad[0]].tolist()}")
        return self._rotate_rows(state, fext).ravel()[self.free]

    def conjugate(self, state: ShellState, dq: np.ndarray) -> np.ndarray:
        """The increment in the components that pair with the residual by virtual work: w . r = dW."""
        n = self.body.n_nodes
        d6 = np.zeros(6 * n)
        d6[self.free] = dq
        d6 = d6.reshape(n, 6)
        idx = np.flatnonzero(~self.has_basis)
        d6[idx, :3] = np.einsum("nij,nj->ni", state.frames[idx], d6[idx, :3])
        return d6.ravel()[self.free]

    def conjugate_matrix(self, state: ShellState) -> sp.csc_matrix:
        """T (free x free, CSC) with :meth:`conjugate` (state, dq) = T dq: R_I on the translations of nodes
        without a fixed basis, 1 elsewhere. T^T K is the energy's second variation (symmetric at an
        equilibrium under conservative loads), T^T f_ext the load in the same coordinates: what the
        stability count and the linear buckling analysis work with."""
        index = -np.ones((self.body.n_nodes, 6), dtype=np.int64)
        index.ravel()[self.free] = np.arange(self.n_dof)
        nodes = np.flatnonzero(~self.has_basis & np.all(index[:, :3] >= 0, axis=1))
        rows = np.repeat(index[nodes, :3][:, :, None], 3, axis=2)
        cols = np.repeat(index[nodes, None, :3], 3, axis=1)
        other = np.setdiff1d(np.arange(self.n_dof), index[nodes, :3].ravel())
        data = np.concatenate([state.frames[nodes].ravel(), np.ones(other.size)])
        return sp.csc_matrix((data, (np.concatenate([rows.ravel(), other]), np.concatenate([cols.ravel(), other]))),
                             shape=(self.n_dof, self.n_dof))

    def update(self, state: ShellState, dq: np.ndarray) -> ShellState:
        """q <- q o exp(dq): the 5-DoF nodal update.

        In the mixed Newton iteration (``state.stress`` set) the Gauss-point stresses move on with the
        linearized strains of the old state, sigma <- C (eps(q) + B(q) dq) (:meth:`ShellBody.stresses`).
        """
        n = self.body.n_nodes
        d6 = np.zeros(6 * n)
        d6[self.free] = dq
        d6 = d6.reshape(n, 6)
        du = d6[:, :3].copy()
        idx = np.flatnonzero(self.has_basis)
        du[idx] = np.einsum("nij,nj->ni", self.basis[idx], d6[idx, :3])
        new = update_state(state, du, d6[:, 3:5], self.has_basis)
        if state.stress is not None:
            new.stress = self.body.stresses(state, self.element_motions(state, dq))
        return new

    def element_motions(self, state: ShellState, dq: np.ndarray) -> np.ndarray:
        """The local nodal motion [du, dtheta] (drilling 0) of each element (m, 36) for an increment (or a
        velocity) dq on the free DoFs: du_I = R_I^T E_I dv_I on basis nodes, du_I itself elsewhere."""
        n = self.body.n_nodes
        d6 = np.zeros(6 * n)
        d6[self.free] = dq
        d6 = d6.reshape(n, 6)
        idx = np.flatnonzero(self.has_basis)
        d6[idx, :3] = np.einsum("nji,njk,nk->ni", state.frames[idx], self.basis[idx], d6[idx, :3])
        d6[:, 5] = 0.0
        return d6[self.body.mesh.elements].reshape(-1, 36)

    def assemble_element_forces(self, state: ShellState, fe: np.ndarray) -> np.ndarray:
        """Element force vectors (m, 36) in the nodal local frames -> their equations on the free DoFs (the
        rows of :meth:`residual`)."""
        return self._rotate_rows(state, self._sum_element_vectors(fe)).ravel()[self.free]

    @property
    def supports_mixed_iteration(self) -> bool:
        """Whether the static solvers can run the mixed Newton iteration on this model (MITC6 bodies)."""
        return self.body.supports_mixed_iteration

    def with_stresses(self, state: ShellState) -> ShellState:
        """The state with the Gauss-point stresses of its strains: the start of a mixed Newton iteration."""
        new = state.copy()
        new.stress = self.body.stresses(state)
        return new

    @staticmethod
    def _check_finite(state: ShellState) -> None:
        if not (np.all(np.isfinite(state.x)) and np.all(np.isfinite(state.frames))):
            bad = np.flatnonzero(~(np.all(np.isfinite(state.x), axis=1)
                                   & np.all(np.isfinite(state.frames.reshape(len(state.x), -1)), axis=1)))
            raise FloatingPointError(f"non-finite nodal positions or frames in the state (node {bad[0]}, "
                                     f"{bad.size} node(s))")

    # -- support ------------------------------------------------------------------------------------------
    def unrestrained_rigid_modes(self, nodes: np.ndarray | None = None) -> list[str]:
        """The rigid-body motions the constraints leave free, described in words (empty: fully supported).

        ``nodes``: the nodes of one piece of the mesh (its rigid motions); None: the whole body.

        A rigid motion is a translation t and a rotation w about the model centre c: delta x_I = t + w x
        (x_I - c), and the in-plane nodal rotations are the components of w along t1_I, t2_I. It is free
        when every constrained component of every node vanishes for it; the free motions are the null space
        of the constrained components as linear functions of (t, w). Without drilling DoFs a rotation of the
        body about a nodal director is not a nodal rotation DoF, so it is restrained only by translations.
        """
        nodes = np.arange(self.body.n_nodes) if nodes is None else np.asarray(nodes)
        x = self.body.mesh.nodes
        frames = self.body.frames0
        c = x[nodes].mean(axis=0)
        size = float(np.ptp(x[nodes], axis=0).max()) or 1.0
        rows = []
        for i in nodes[self.fixed[nodes, :5].any(axis=1)]:
            p = (x[i] - c) / size
            trans = np.hstack([np.eye(3), -hat_many(p[None])[0]])      # delta x / size per unit (t, w)
            if self.fixed[i, :3].all():
                rows.append(trans)
            elif self.fixed[i, :3].any():
                E = self.basis[i] if self.has_basis[i] else frames[i]
                rows.append(E[:, self.fixed[i, :3]].T @ trans)
            for k in (0, 1):
                if self.fixed[i, 3 + k]:
                    rows.append(np.hstack([np.zeros(3), frames[i][:, k]])[None])
        A = np.vstack(rows) if rows else np.zeros((0, 6))
        if A.shape[0]:
            _, sv, vt = np.linalg.svd(A, full_matrices=True)
            rank = int(np.sum(sv > 1e-8 * sv.max()))
        else:
            vt, rank = np.eye(6), 0
        free = 6 - rank
        if free == 0:
            return []
        modes = [f"translation along {a}" for k, a in enumerate("xyz")
                 if A.shape[0] == 0 or np.linalg.norm(A[:, k]) <= 1e-8 * np.abs(A).max()]
        rotations = free - len(modes)
        if rotations:
            _, sw, wt = np.linalg.svd(vt[rank:, 3:])           # the rotation parts of the free motions
            axes = [(np.round(a * np.sign(a[np.argmax(np.abs(a) > 1e-3)]), 3) + 0.0).tolist()
                    for a in wt[:rotations]]
            modes.append(f"{rotations} rotation(s) (axes along {axes})")
        return modes

    def check_static_support(self) -> None:
        """Raise ModelError if the constraints leave a rigid-body motion free: the stiffness is then singular
        and no static equilibrium can be computed.

        A mesh of several separate pieces is checked piece by piece: each must be supported on its own.
        """
        count, labels = self.body.mesh.connected_components()
        for piece in range(count):
            nodes = np.flatnonzero(labels == piece)
            modes = self.unrestrained_rigid_modes(nodes if count > 1 else None)
            if not modes:
                continue
            if count == 1:
                what = "no constraints" if not self.constraints else "constraints that leave it free to move"
                body = f"the body has {what}"
            else:
                held = self.fixed[nodes, :5].any()
                body = (f"the mesh has {count} separate pieces, and piece {piece + 1} ({nodes.size} nodes, e.g. node "
                        f"{nodes[0]}) has {'constraints that leave it free to move' if held else 'no supports'}")
            raise ModelError(f"{body}: rigid-body motions are not restrained ({'; '.join(modes)}), so the static "
                             "stiffness is singular; add supports (Fix / Symmetry) that stop every rigid-body "
                             "motion")
