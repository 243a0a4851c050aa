"""Our shell inside an exudyn system: ``ShellODE2`` wraps a flexbody ``Model`` as one ``ObjectGenericODE2``.

``ShellODE2`` gives exudyn the shell's force and Jacobian as user functions (with a mass matrix also for
exudyn's implicit integrators), so that exudyn constraints and bodies can act with it;
``solve_scene_in_exudyn`` runs a static scene that way, and ``hub_driven_membrane_in_exudyn`` runs
``spinning_membrane`` with its hub an exudyn rigid body on a driven revolute joint (the inner nodes tied to
it by constraints) next to the flexbody-alone run.
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse as sparse

import exudyn as exu
import exudyn.itemInterface as eii

from flexbody.adapters.exudyn.system import (dynamic_settings, new_system, newton_counts, pseudo_time_load_factor,
                                             run_solver, static_settings)
from flexbody.body import ShellState, update_state
from flexbody.lie.so3 import tangent
from flexbody.scenes import build
from flexbody.scenes.scene import Scene, run_scene


class ShellODE2:
    """A flexbody ``Model`` (shell body, its constraints and loads) as one exudyn ``ObjectGenericODE2``.

    The exudyn coordinates q are the Model's free DoFs: per node the translation in fixed directions
    (global x, y, z, or the constraint basis E_I of a symmetry node) and the two in-plane rotations. The
    shell's nodal frames are not functions of coordinates: the drilling-free update of the 5-DoF nodes is
    a non-holonomic rule, so the frames are history (see ``flexbody.dynamics``). The wrapper keeps that
    history itself: it holds the state of the last committed step (x_n, R_n, q_n) and maps
    q -> x = x_n + dx, R = R_n exp(dtheta_1 e_1 + dtheta_2 e_2) with (dx, dtheta) from q - q_n; a pre-step
    user function commits at the start of every load step. The user force is -r (the Model's residual at
    the load factor lambda(t) of exudyn's pseudo-time t), so exudyn's equilibrium is flexbody's. The
    Jacobian is the Model's tangent with the translation columns turned to fixed directions and the
    rotation columns times the in-plane block of the tangent operator T(dtheta). The drilling row of
    T(dtheta) couples to a column the Model does not have and is dropped: the Jacobian is exact at the
    start of a step and off by O(|dtheta|) inside it, so Newton converges to the same solution, a little
    slower than quadratically.

    Dynamics: with ``mass`` (the constant mass on the free DoFs, ``flexbody.dynamics.DynamicModel.mass_matrix()``,
    lumped or consistent; in these coordinates there are no gyroscopic or centrifugal terms) exudyn's implicit
    integrators run the shell; the velocities q_t are taken as the DoF velocities (fixed-direction
    translation rates, local angular velocities w_1, w_2), committed with the frames at every step.
    Without ``mass`` the mass matrix is zero: statics only.

    Parameters
    ----------
    mbs : the exudyn MainSystem to add the node and object to
    model : the flexbody model; its loads are scaled by the load factor ``load_factor(t)``
    load_factor : lambda(t) of exudyn's (pseudo-)time; default lambda = t (static solver: t runs 0 to 1)
    mass : the mass matrix on the free DoFs, (n_dof,) diagonal entries or a sparse (n_dof, n_dof) matrix
        (``DynamicModel.mass_matrix()``, lumped or consistent), or None (statics)
    velocity : (n_dof,) initial velocity (e.g. ``DynamicModel.rigid_velocity``), or None (at rest)
    on_commit : called as ``on_commit(t, state)`` with every committed state and its (pseudo-)time
    """

    def __init__(self, mbs, model, load_factor=None, mass: np.ndarray | None = None,
                 velocity: np.ndarray | None = None, on_commit=None) -> None:
        self.model = model
        self.mbs = mbs
        self.load_factor = load_factor if load_factor is not None else (lambda t: float(t))
        self.on_commit = on_commit
        n = model.n_dof
        v0 = [0.0] * n if velocity is None else [float(v) for v in velocity]
        if len(v0) != n:
            raise ValueError(f"velocity must have {n} entries (the free DoFs), got {len(v0)}")
        self.node = mbs.AddNode(eii.NodeGenericODE2(numberOfODE2Coordinates=n, referenceCoordinates=[0.0] * n,
                                                    initialCoordinates=[0.0] * n, initialCoordinates_t=v0))
        mass_matrix = exu.MatrixContainer()
        if mass is None:
            mass_matrix.SetWithSparseMatrixCSR(n, n, [], useDenseMatrix=False)
        elif sparse.issparse(mass):
            if mass.shape != (n, n) or np.any(mass.diagonal() <= 0):
                raise ValueError(f"mass must be an ({n}, {n}) matrix with a positive diagonal, got shape {mass.shape}")
            mass_matrix.SetWithSparseMatrix(sparse.csr_matrix(mass))
        else:
            mass = np.asarray(mass, float)
            if mass.shape != (n,) or np.any(mass <= 0):
                raise ValueError(f"mass must be {n} positive diagonal entries, got shape {mass.shape}")
            mass_matrix.SetWithSparseMatrix(sparse.diags(mass).tocsr())
        self.object = mbs.AddObject(eii.ObjectGenericODE2(nodeNumbers=[self.node], massMatrix=mass_matrix,
                                                          forceUserFunction=self._force,
                                                          jacobianUserFunction=self._jacobian))
        self.state_n = model.initial_state()
        self.q_n = np.zeros(n)
        self.t_n = 0.0                                   # time of the committed state
        self.calls = {"force": 0, "jacobian": 0, "commit": 0}
        self._n_nodes = model.body.n_nodes
        self._basis_nodes = np.flatnonzero(model.has_basis)
        self._local_nodes = np.flatnonzero(~model.has_basis)

    def coordinate_index(self, node: int, component: int) -> int:
        """Index in q of a free component (0-2 translation, 3-4 in-plane rotation) of a flexbody node."""
        k = np.flatnonzero(self.model.free == 6 * node + component)
        if k.size == 0:
            raise ValueError(f"component {component} of node {node} is not a free DoF of the model")
        return int(k[0])

    def _increments(self, q: np.ndarray) -> np.ndarray:
        d6 = np.zeros(6 * self._n_nodes)
        d6[self.model.free] = q - self.q_n
        return d6.reshape(self._n_nodes, 6)

    def state(self, q) -> ShellState:
        """The shell state of coordinates q (relative to the last committed step)."""
        d6 = self._increments(np.asarray(q, float))
        dx = d6[:, :3].copy()
        b = self._basis_nodes
        dx[b] = np.einsum("nij,nj->ni", self.model.basis[b], d6[b, :3])
        return update_state(self.state_n, dx, d6[:, 3:5], np.arange(self._n_nodes))

    def coordinates(self) -> np.ndarray:
        """The wrapped shell's current coordinates q in the exudyn system."""
        mbs = self.mbs
        return np.asarray(mbs.systemData.GetODE2Coordinates())[mbs.systemData.GetObjectLTGODE2(self.object)]

    def _step_start(self, mbs, t: float) -> float:
        """Start time of the step exudyn is about to take (it passes the end time t to pre-step functions)."""
        for key in ("dynamicSolver", "staticSolver"):
            solver = mbs.sys.get(key)
            if solver is not None and abs(float(solver.it.currentTime) - t) <= 1e-12 * max(1.0, abs(t)):
                return t - float(solver.it.currentStepSize)
        return self.t_n

    def commit(self, mbs, t) -> bool:
        """exudyn pre-step user function: the current coordinates become the new committed state.

        The coordinates are those at the start of the step (after a rejected step exudyn restores them and
        calls this again: the same state is committed again, and reported once). ``on_commit`` receives
        the committed state and its time, the step's start.
        """
        self.calls["commit"] += 1
        t_start = self._step_start(mbs, float(t))
        q = self.coordinates()
        self.state_n = self.state(q)
        self.q_n = q.copy()
        if self.on_commit is not None and (self.calls["commit"] == 1 or abs(t_start - self.t_n) > 1e-12):
            self.on_commit(t_start, self.state_n)
        self.t_n = t_start
        return True

    def _force(self, mbs, t, item, q, q_t):
        self.calls["force"] += 1
        return (-self.model.residual(self.state(q), self.load_factor(t))).tolist()

    def _column_map(self, q: np.ndarray, frames: np.ndarray):
        """d(Model increments)/dq: R^T for translations of non-basis nodes, T(dtheta)[:2, :2] for rotations."""
        d6 = self._increments(q)
        blocks = np.tile(np.eye(6), (self._n_nodes, 1, 1))
        a = self._local_nodes
        blocks[a, :3, :3] = np.transpose(frames[a], (0, 2, 1))
        for i in np.flatnonzero(np.any(d6[:, 3:5] != 0, axis=1)):
            blocks[i, 3:5, 3:5] = tangent(np.array([d6[i, 3], d6[i, 4], 0.0]))[:2, :2]
        free = self.model.free
        return sparse.block_diag(list(blocks), format="csr")[free][:, free]

    def _jacobian(self, mbs, t, item, q, q_t, f_ode2, f_ode2_t):
        self.calls["jacobian"] += 1
        q = np.asarray(q, float)
        state = self.state(q)
        _, K = self.model.residual_and_tangent(state, self.load_factor(t))
        J = (K @ self._column_map(q, state.frames)).tocsr() * float(f_ode2)
        J.eliminate_zeros()
        out = exu.MatrixContainer()
        out.SetWithSparseMatrix(J)
        return out


def solve_scene_in_exudyn(scene: Scene, constraints=None, rtol: float = 1e-10) -> dict:
    """Run a load-controlled flexbody scene with exudyn's static solver, the shell wrapped as ``ShellODE2``.

    Parameters
    ----------
    scene : a flexbody scene with ``load_control`` analysis; exudyn stops at its load factors (N equal
        steps of exudyn's pseudo-time t, mapped piecewise linearly to the N load factors)
    constraints : optional callable ``constraints(mbs, shell)`` adding exudyn items (joints, coordinate
        constraints) that act on the wrapped shell, e.g. a clamp given in exudyn instead of in flexbody
    rtol : exudyn's relative Newton tolerance

    Returns
    -------
    dict with "converged", "message", "outputs" (final value of each scene output), "newton_iterations",
    "wall_time_s", "calls" (user-function calls), "dofs".
    """
    if scene.analysis.method != "load_control":
        raise ValueError("solve_scene_in_exudyn needs a load-controlled scene")
    lf = np.asarray(scene.analysis.load_factors, float)
    lam = pseudo_time_load_factor(lf)
    sc, mbs = new_system()
    shell = ShellODE2(mbs, scene.model, lambda t: float(lam(t)))
    if constraints is not None:
        constraints(mbs, shell)
    mbs.SetPreStepUserFunction(shell.commit)
    mbs.Assemble()
    s = static_settings(len(lf), rtol)
    converged, message, wall, _ = run_solver(lambda: mbs.SolveStatic(s, storeSolver=True, showHints=False))
    state = shell.state(shell.coordinates())
    return {"converged": converged, "message": message,
            "outputs": {o.name: o.value(scene.model, state) for o in scene.outputs},
            "newton_iterations": newton_counts(mbs, "staticSolver")[0],
            "wall_time_s": wall, "calls": dict(shell.calls), "dofs": scene.model.n_dof,
            "load_factor": float(lam(mbs.systemData.GetTime()))}


def hub_driven_membrane_in_exudyn(params: dict | None = None, flexbody_alone: bool = True,
                                  rtol: float = 1e-8, adaptive_step: bool = True) -> dict:
    """``spinning_membrane`` (drive "hub") with the hub as an exudyn rigid body on a driven revolute joint.

    The exudyn system: the membrane as ``ShellODE2`` (a Model without the scene's ``Fix`` of the inner
    edge, with the lumped mass of ``flexbody.dynamics.DynamicModel``), and the hub as an
    ``ObjectRigidBody`` (``NodeRigidBodyRxyz``, mass 1, unit inertia, at the origin) on an exudyn revolute
    joint to ground about z, driven by a ``CoordinateConstraint`` on the hub's rotation coordinate rz with
    an offset user function: the scene's spin-up angle (``spin_up_angle``). The inner (hub) nodes are tied
    to the hub by *constraints*, not penalties:

    - in-plane translations: one ``ObjectConnectorCoordinateVector`` between the hub node and the shell
      node with constraint and Jacobian user functions, x_I + u_I = p + Rz(rz) X_I for every inner node
      (x and y rows; the joint keeps rx = ry = 0, so R_hub = Rz(rz) exactly);
    - z translation and both in-plane rotations of the inner nodes: ``CoordinateConstraint``s to ground.
      The flat membrane turns about its normal, i.e. about every director: the directors stay e_z and
      the drilling-free nodal frames do not change (as flexbody's ``PrescribedMotion`` moves them, by
      parallel transport), so fixing the in-plane rotation increments is the exact clamp here. This
      shortcut is not a general hub clamp (a tilting hub would need the director condition too).

    exudyn's ``GeneralizedAlpha`` (index 3) with the scene's dt, end time and rho_inf, relative Newton
    tolerance ``rtol``. exudyn's Newton does not converge in the first step at dt = 1e-3 (the hub has
    turned by 4e-6 rad; measured at rtol 1e-8 and 1e-10): with ``adaptive_step`` (the default) exudyn
    halves the first steps (at rtol 1e-8: 0.5e-3 up to t = 5e-3), without it the run fails. At rtol 1e-10
    the adaptive steps fall to 1.6e-5 and the run takes 600+ steps. Then flexbody alone
    (``run_scene``, its own generalized-alpha with the ``PrescribedMotion`` hub) unless ``flexbody_alone``
    is False.

    Returns a dict: "converged" (exudyn reached the end time), "exudyn" / "flexbody" (final outputs
    ``u_r_mid``, ``u_r_outer``), "reference" (analytic steady rotating annulus on a hub), "rel_difference"
    (final, exudyn vs flexbody), "rel_history_difference" (max over the common times of the difference,
    relative to the max of flexbody's history), "hub_angle" vs "hub_angle_prescribed",
    "hub_angular_velocity", "tie_residual" (max |constraint| of the tie at the end), wall times, calls.
    """
    from flexbody.assembly import Model
    from flexbody.dynamics import DynamicModel
    from flexbody.scenes.dynamic_run import spin_up_angle

    params = dict(params or {})
    params["drive"] = "hub"
    scene = build("spinning_membrane", **params)
    p = scene.parameters
    a = scene.analysis
    mesh = scene.model.body.mesh
    inner = np.asarray(mesh.node_set("inner"), int)
    free_model = Model(scene.model.body, [], [])
    dyn = DynamicModel(free_model)
    angle = spin_up_angle(float(p["omega"]), float(p["ramp_time"]))
    rate = float(p["omega"])
    ramp = float(p["ramp_time"])

    def angle_t(t):
        return rate * (1 - math.cos(math.pi * t / ramp)) / 2 if t < ramp else rate

    _sc, mbs = new_system()                       # the container keeps the system alive
    history = {"time": []} | {o.name: [] for o in scene.outputs}

    def record(t, state):
        history["time"].append(float(t))
        for o in scene.outputs:
            history[o.name].append(o.value(free_model, state))

    shell = ShellODE2(mbs, free_model, lambda t: 0.0, mass=dyn.mass_matrix(), on_commit=record)

    # the hub: a rigid body on a revolute joint (z) to ground, its rotation coordinate driven
    from exudyn.utilities import RigidBodyInertia
    hub = mbs.CreateRigidBody(referencePosition=[0.0, 0.0, 0.0], nodeType=exu.NodeType.RotationRxyz,
                              inertia=RigidBodyInertia(mass=1.0, inertiaTensor=np.eye(3)), returnDict=True)
    hub_body, hub_node = hub["bodyNumber"], hub["nodeNumber"]
    ground = mbs.CreateGround()
    mbs.CreateRevoluteJoint(itemNumbers=[ground, hub_body], position=[0.0, 0.0, 0.0], axis=[0.0, 0.0, 1.0])
    ground_node = mbs.AddNode(eii.NodePointGround())
    ground_marker = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    rz_marker = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=hub_node, coordinate=5))
    mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[ground_marker, rz_marker],
                                           offsetUserFunction=lambda mbs_, t, item, off: angle(float(t)),
                                           offsetUserFunction_t=lambda mbs_, t, item, off: angle_t(float(t))))

    # the clamp: z translation and in-plane rotations fixed, in-plane translations on the hub
    for node in inner:
        for c in (2, 3, 4):
            m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=shell.node,
                                                       coordinate=shell.coordinate_index(int(node), c)))
            mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[ground_marker, m]))
    n = free_model.n_dof
    X = mesh.nodes[inner, :2]
    ix = 6 + np.array([shell.coordinate_index(int(i), 0) for i in inner])
    iy = 6 + np.array([shell.coordinate_index(int(i), 1) for i in inner])
    k = len(inner)
    calls = {"constraint": 0, "constraint_jacobian": 0}

    def tie(mbs_, t, item, q, q_t, velocity_level):
        calls["constraint"] += 1
        q = np.asarray(q)
        if velocity_level:
            v = np.asarray(q_t)
            c, s = math.cos(q[5]), math.sin(q[5])
            w = v[5]
            gx = v[ix] - (-s * X[:, 0] - c * X[:, 1]) * w - v[0]
            gy = v[iy] - (c * X[:, 0] - s * X[:, 1]) * w - v[1]
            return np.concatenate([gx, gy]).tolist()
        c, s = math.cos(q[5]), math.sin(q[5])
        gx = X[:, 0] + q[ix] - (c * X[:, 0] - s * X[:, 1]) - q[0]
        gy = X[:, 1] + q[iy] - (s * X[:, 0] + c * X[:, 1]) - q[1]
        return np.concatenate([gx, gy]).tolist()

    def tie_jacobian(mbs_, t, item, q, q_t, velocity_level):
        calls["constraint_jacobian"] += 1
        q = np.asarray(q)
        c, s = math.cos(q[5]), math.sin(q[5])
        J = np.zeros((2 * k, 6 + n))
        rows = np.arange(k)
        J[rows, 0] = -1.0
        J[rows, 5] = s * X[:, 0] + c * X[:, 1]
        J[rows, ix] = 1.0
        J[k + rows, 1] = -1.0
        J[k + rows, 5] = -(c * X[:, 0] - s * X[:, 1])
        J[k + rows, iy] = 1.0
        return J

    hub_coords = mbs.AddMarker(eii.MarkerNodeCoordinates(nodeNumber=hub_node))
    shell_coords = mbs.AddMarker(eii.MarkerNodeCoordinates(nodeNumber=shell.node))
    mbs.AddObject(eii.ObjectConnectorCoordinateVector(markerNumbers=[hub_coords, shell_coords],
                                                      scalingMarker0=np.zeros((2 * k, 6)),
                                                      constraintUserFunction=tie,
                                                      jacobianUserFunction=tie_jacobian))
    mbs.SetPreStepUserFunction(shell.commit)
    mbs.Assemble()
    steps = round(a.end_time / a.time_step)
    s = dynamic_settings(a.end_time, steps, a.rho_inf_used)
    s.timeIntegration.newton.relativeTolerance = rtol
    s.timeIntegration.adaptiveStep = adaptive_step
    converged, message, wall, _ = run_solver(
        lambda: mbs.SolveDynamic(s, solverType=exu.DynamicSolverType.GeneralizedAlpha))
    t_end = float(mbs.systemData.GetTime())
    converged = converged and abs(t_end - a.end_time) <= 1e-9 * a.end_time
    if not history["time"] or abs(history["time"][-1] - t_end) > 1e-12:
        record(t_end, shell.state(shell.coordinates()))
    hub_q = mbs.GetNodeOutput(hub_node, exu.OutputVariableType.Coordinates)
    hub_w = mbs.GetNodeOutput(hub_node, exu.OutputVariableType.AngularVelocity)
    state = shell.state(shell.coordinates())
    gap = float(np.max(np.abs(np.asarray(tie(mbs, t_end, 0, np.concatenate([hub_q, shell.coordinates()]),
                                                np.zeros(6 + n), False)))))
    result = {"converged": converged, "message": message, "time": t_end, "steps": steps,
              "dofs": n, "hub_nodes": k, "wall_time_s": wall, "calls": dict(shell.calls) | calls,
              "hub_angle": float(hub_q[5]), "hub_angle_prescribed": float(angle(t_end)),
              "hub_angular_velocity": float(hub_w[2]), "tie_residual": gap,
              "exudyn": {o.name: o.value(free_model, state) for o in scene.outputs},
              "exudyn_history": history,
              "reference": {name: float(v[-1]) for name, v in scene.reference.values.items()},
              "parameters": dict(p)}
    if flexbody_alone:
        t0 = time.perf_counter()
        run = run_scene(scene)
        result["flexbody_wall_time_s"] = time.perf_counter() - t0
        result["flexbody"] = {o.name: float(run.history[o.name][-1]) for o in scene.outputs}
        result["flexbody_time"] = float(run.history["time"][-1])
        result["rel_difference"] = {name: abs(result["exudyn"][name] - v) / abs(v)
                                    for name, v in result["flexbody"].items()}
        # histories at the common times: max |u_exudyn - u_flexbody| / max |u_flexbody|
        ours = {round(t, 9): i for i, t in enumerate(run.history["time"])}
        common = [(i, ours[round(t, 9)]) for i, t in enumerate(history["time"]) if round(t, 9) in ours]
        result["common_times"] = len(common)
        result["rel_history_difference"] = {
            o.name: max(abs(history[o.name][i] - run.history[o.name][j]) for i, j in common)
            / max(abs(v) for v in run.history[o.name]) for o in scene.outputs}
    return result
