"""The exudyn model of the dynamic ``spinning_plate``, its runs, and an RK4 reference run of the same model.

A free ``ObjectANCFThinPlate`` mesh started in the scene's rigid spin (position and slope rates of the rigid
field), run with exudyn's ``GeneralizedAlpha`` at the scene's spectral radius, time step and end time
(``build_dynamic_model``, ``solve_dynamic``), or with the explicit ``RK44`` at a small step as a reference.
Angular momentum from the nodal coordinates and the consistent mass matrix; strain energy from exudyn's
element outputs, checked against the work of its elastic forces (``strain_energies``).

Options (``build_dynamic_model``): nx, ny (element counts, default one ANCF quad per flexbody cell).
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
import time

import numpy as np

import exudyn as exu

from flexbody.adapters.exudyn.options import element_counts, model_kind
from flexbody.adapters.exudyn.system import (dynamic_settings, nearest, new_system, newton_counts, plate_mesh,
                                             quiet_console, run_solver)
from flexbody.scenes.scene import Scene


@dataclass(frozen=True)
class RadialOutput:
    """A ``RadialDisplacement`` of the flexbody scene in exudyn: the mean over ANCF nodes of
    |P (x - c)| - |P (X - c)| (P: projection normal to ``axis``), times ``scale``.

    indices : (k, 3) ODE2 indices of the position coordinates of the k nodes
    positions : (k, 3) their reference positions
    """

    name: str
    indices: np.ndarray
    positions: np.ndarray
    center: np.ndarray
    axis: np.ndarray
    scale: float = 1.0

    def value(self, u: np.ndarray) -> float:
        n = self.axis / np.linalg.norm(self.axis)

        def radius(x):
            r = x - self.center
            return np.linalg.norm(r - np.outer(r @ n, n), axis=1)

        x = self.positions + u[self.indices]
        return self.scale * float(np.mean(radius(x) - radius(self.positions)))


@dataclass
class ExudynDynamicModel:
    """An assembled exudyn system that mirrors a dynamic flexbody scene (free ANCF plate, rigid spin).

    Attributes
    ----------
    reference : ODE2 reference coordinates (positions and unit slopes of the NodePointSlope12 nodes)
    mass : the (constant) ODE2 mass matrix, dense; the ANCF plate's is ``scalar_mass`` (x) I_3
    scalar_mass : the mass matrix of the scalar shape functions (one row per nodal 3-vector)
    angular_velocity, velocity : the initial rigid field v = velocity + angular_velocity x X
    time_step, end_time, rho_inf : of the flexbody analysis (exudyn's generalized-alpha takes the same)
    records : (t, u, u_t) per recorded step, filled by the pre-step user function during a solve
    """

    scene: str
    kind: str
    description: str
    system_container: object
    mbs: object
    outputs: list[RadialOutput]
    reference: np.ndarray
    mass: np.ndarray
    scalar_mass: np.ndarray
    angular_velocity: np.ndarray
    velocity: np.ndarray
    time_step: float
    end_time: float
    rho_inf: float
    elements: int
    build_time_s: float = 0.0
    record_every: int = 1
    records: list = field(default_factory=list)
    element_numbers: list = field(default_factory=list)

    @property
    def coordinates(self) -> int:
        return int(self.mbs.systemData.ODE2Size())

    def angular_momentum(self, u: np.ndarray, u_t: np.ndarray) -> np.ndarray:
        """L = int rho r x v dV about the origin: sum_AB M_AB q_A x q_B' (q_A: nodal 3-vectors, absolute)."""
        q = (self.reference + u).reshape(-1, 3)
        return np.cross(q, self.scalar_mass @ np.asarray(u_t).reshape(-1, 3)).sum(axis=0)

    def kinetic_energy(self, u_t: np.ndarray) -> float:
        return 0.5 * float(u_t @ self.mass @ u_t)


def _rigid_field(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(v0, omega) of the scene's initial velocity field v = v0 + omega x X (raises if it is not rigid)."""
    a = scene.analysis
    X = scene.model.body.mesh.nodes
    if a.initial_state is not None or a.prescribed or a.load_factor is not None or scene.model.loads \
            or a.point_masses:
        raise ValueError(f"scene {scene.name!r}: only free, unloaded bodies without point masses and with a rigid "
                         "initial velocity field have an exudyn counterpart")
    v = np.zeros_like(X) if a.initial_velocity is None else np.asarray(a.initial_velocity, float)
    w_nodes = np.zeros_like(X) if a.initial_angular_velocity is None else np.asarray(a.initial_angular_velocity, float)
    w = w_nodes.mean(axis=0)
    v0 = (v - np.cross(w, X)).mean(axis=0)
    scale = max(float(np.abs(v).max()), 1e-300)
    if (np.abs(w_nodes - w).max() > 1e-9 * max(float(np.abs(w).max()), 1e-300)
            or np.abs(v0 + np.cross(w, X) - v).max() > 1e-9 * scale):
        raise ValueError(f"scene {scene.name!r}: the initial velocity is not a rigid field v0 + omega x X")
    return v0, w


def spinning_plate_model(scene: Scene, nx: int, ny: int) -> tuple:
    """The free flat plate as ANCF thin plates (nx x ny), started with the scene's rigid velocity field.

    ANCF interpolates rigid motions exactly, so the rigid field is set exactly on the nodal coordinates:
    position rates v0 + omega x X, slope rates omega x (slope). Returns (sc, mbs, outputs, description,
    elements, v0, omega).
    """
    x = scene.model.body.mesh.nodes
    if np.ptp(x[:, 2]) > 0:
        raise ValueError(f"scene {scene.name!r} is not a flat plate in a plane z = const")
    (x0, y0, z0), (x1, y1, _) = x.min(axis=0), x.max(axis=0)
    v0, w = _rigid_field(scene)
    sc, mbs = new_system()
    mesh = plate_mesh(mbs, scene, [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]], nx, ny)
    for node in mesh.nodeNumbers:
        ref = np.asarray(mbs.GetNodeParameter(node, "referenceCoordinates"), float)
        rates = np.concatenate([v0 + np.cross(w, ref[:3]), np.cross(w, ref[3:6]), np.cross(w, ref[6:9])])
        mbs.SetNodeParameter(node, "initialVelocities", rates.tolist())
    positions = np.array(mesh.nodeReferencePositions, float)
    size = float(np.ptp(x, axis=0).max())
    outputs = []
    for out in scene.outputs:
        if not hasattr(out, "center") or not hasattr(out, "nodes"):
            raise ValueError(f"scene {scene.name!r}: output {out.name!r} has no exudyn counterpart "
                             "(radial displacements only)")
        idx = sorted({int(i) for n in out.nodes for i in nearest(positions, x[n], size)})
        outputs.append((out, [mesh.nodeNumbers[i] for i in idx], positions[idx]))
    return (sc, mbs, outputs, f"ObjectANCFThinPlate, {nx} x {ny} elements, free", nx * ny, v0, w,
            list(mesh.elementNumbers))


def _record_step(model: ExudynDynamicModel):
    """Pre-step user function: store (t, u, u_t) at the start of every ``record_every``-th step."""
    h = model.time_step

    def pre(mbs, t):
        start = float(t) - h                         # exudyn passes the step's end time
        k = int(round(start / h))
        if k % model.record_every == 0 and (not model.records or start > model.records[-1][0] + 0.5 * h):
            sd = mbs.systemData
            model.records.append((start, np.array(sd.GetODE2Coordinates()), np.array(sd.GetODE2Coordinates_t())))
        return True
    return pre


def build_dynamic_model(scene: Scene, options: dict | None = None, time_step: float | None = None,
                        end_time: float | None = None) -> ExudynDynamicModel:
    """Build and assemble the exudyn model of a dynamic scene (``spinning_plate``: free ANCF plate).

    time_step, end_time : default the flexbody analysis' (an RK4 reference run passes its own)
    options : nx, ny (default one ANCF quad per flexbody cell)
    """
    options = dict(options or {})
    kind = model_kind(scene.name, options)
    a = scene.analysis
    nx, ny = element_counts(scene, kind, options)
    t_end = float(a.end_time if end_time is None else end_time)
    h = t_end / a.n_steps if time_step is None else float(time_step)
    if not (h > 0 and t_end > 0):
        raise ValueError(f"time step and end time must be positive, got {h!r} and {t_end!r}")
    h = t_end / max(1, int(math.ceil(t_end / h - 1e-9)))
    t0 = time.perf_counter()
    sc, mbs, raw_outputs, description, elements, v0, w, element_numbers = spinning_plate_model(scene, nx, ny)
    model = ExudynDynamicModel(scene.name, kind, description, sc, mbs, [], np.zeros(0), np.zeros((0, 0)),
                               np.zeros((0, 0)), w, v0, h, t_end, a.rho_inf_used, elements,
                               record_every=max(1, int(a.output_every)), element_numbers=element_numbers)
    mbs.SetPreStepUserFunction(_record_step(model))
    mbs.Assemble()
    sd = mbs.systemData
    model.reference = np.asarray(sd.GetODE2Coordinates(configuration=exu.ConfigurationType.Reference), float)
    for out, nodes, positions in raw_outputs:
        indices = np.array([list(sd.GetNodeLTGODE2(n))[:3] for n in nodes], dtype=int)
        model.outputs.append(RadialOutput(out.name, indices, positions, np.asarray(out.center, float),
                                          np.asarray(out.axis, float), float(out.scale)))
    solver = exu.MainSolverStatic()
    with quiet_console():
        s = _dynamic_settings(model, "generalized_alpha")
        solver.InitializeSolver(mbs, s)
        solver.ComputeMassMatrix(mbs)
        model.mass = np.array(solver.GetSystemMassMatrix(), float)
        solver.FinalizeSolver(mbs, s)
    model.scalar_mass = model.mass[0::3, 0::3].copy()
    if np.abs(model.mass - np.kron(model.scalar_mass, np.eye(3))).max() > 1e-12 * np.abs(model.mass).max():
        raise ValueError("the ANCF mass matrix is not (scalar mass) x I_3; the angular momentum formula needs it")
    model.build_time_s = time.perf_counter() - t0
    return model


def _dynamic_settings(model: ExudynDynamicModel, integrator: str):
    """exudyn's time integration settings of the model: generalized-alpha at the scene's spectral radius, or
    the explicit RK4 without end-of-step accelerations."""
    implicit = integrator == "generalized_alpha"
    s = dynamic_settings(model.end_time, int(round(model.end_time / model.time_step)),
                         model.rho_inf if implicit else None)
    if not implicit:
        s.timeIntegration.explicit.computeEndOfStepAccelerations = False
    return s


def strain_energies(model: ExudynDynamicModel, displacements: list[np.ndarray], method: str = "exudyn",
                    points: int = 4) -> np.ndarray:
    """Strain energy of each displacement u (ODE2 coordinates). Overwrites the system's current
    coordinates (call it after the run).

    method "exudyn": the sum of exudyn's ``PotentialEnergy`` body output of every ANCF plate element
    (``GetObjectOutputBody``; the element's strain energy, the local position is not used).
    method "forces": an independent check, W(u) = int_0^1 f_int(s u) . u ds, integrated from exudyn's
    elastic forces (the ODE2 right-hand side, -f_int, of the free unloaded system) along the straight path
    from the reference configuration with ``points`` Gauss-Legendre points in s: exact for any path
    (f_int is conservative) up to the quadrature; the membrane forces are cubic polynomials in u (Green
    strains), which 4 points integrate exactly.
    """
    mbs = model.mbs
    if method == "exudyn":
        kind = exu.OutputVariableType.PotentialEnergy
        out = []
        for u in displacements:
            mbs.systemData.SetODE2Coordinates(np.asarray(u, float).tolist())
            out.append(sum(float(np.ravel(mbs.GetObjectOutputBody(e, kind, [0.0, 0.0, 0.0]))[0])
                           for e in model.element_numbers))
        return np.array(out)
    if method != "forces":
        raise ValueError(f"method must be 'exudyn' or 'forces', got {method!r}")
    s_pts, s_w = np.polynomial.legendre.leggauss(points)
    s_pts, s_w = (s_pts + 1) / 2, s_w / 2
    solver = exu.MainSolverStatic()
    settings = _dynamic_settings(model, "generalized_alpha")
    with quiet_console():
        solver.InitializeSolver(mbs, settings)
        out = []
        for u in displacements:
            energy = 0.0
            for s, wt in zip(s_pts, s_w):
                mbs.systemData.SetODE2Coordinates((s * u).tolist())
                solver.ComputeODE2RHS(mbs)
                energy -= wt * float(np.asarray(solver.GetSystemResidual()) @ u)
            out.append(energy)
        solver.FinalizeSolver(mbs, settings)
    return np.array(out)


def solve_dynamic(model: ExudynDynamicModel, integrator: str = "generalized_alpha", energy_every: int = 1) -> dict:
    """Run exudyn's time integration of the model; record outputs, energies and the angular momentum.

    integrator : "generalized_alpha" (implicit, ``DynamicSolverType.GeneralizedAlpha`` with the scene's
        spectral radius) or "rk4" (explicit ``RK44``, for a reference at a small step)
    energy_every : evaluate the strain energy at every k-th recorded state (it costs ``points`` force
        evaluations each; the kinetic energy and momentum are taken at every recorded state)

    Returns the run dict (``compare`` documents the keys). A failing solver
    (``exu.SolverError``) gives converged = False and the records up to the failure.
    """
    if integrator not in ("generalized_alpha", "rk4"):
        raise ValueError(f"integrator must be 'generalized_alpha' or 'rk4', got {integrator!r}")
    mbs = model.mbs
    model.records.clear()
    settings = _dynamic_settings(model, integrator)
    solver_type = exu.DynamicSolverType.GeneralizedAlpha if integrator == "generalized_alpha" else \
        exu.DynamicSolverType.RK44
    converged, message, wall, cpu = run_solver(
        lambda: mbs.SolveDynamic(settings, solverType=solver_type, storeSolver=True, showHints=False))
    sd = mbs.systemData
    t_reached = float(sd.GetTime())
    if converged:
        if abs(t_reached - model.end_time) > 1e-9 * max(1.0, model.end_time):
            converged, message = False, f"exudyn stopped at t = {t_reached:.6g}"
        elif not model.records or model.end_time > model.records[-1][0] + 0.5 * model.time_step:
            model.records.append((model.end_time, np.array(sd.GetODE2Coordinates()),
                                  np.array(sd.GetODE2Coordinates_t())))
    iterations, jacobians = newton_counts(mbs, "dynamicSolver")
    times = [r[0] for r in model.records]
    history = {"time": times}
    for out in model.outputs:
        history[out.name] = [out.value(r[1]) for r in model.records]
    L = np.array([model.angular_momentum(r[1], r[2]) for r in model.records]).reshape(-1, 3)
    kinetic = np.array([model.kinetic_energy(r[2]) for r in model.records])
    every = max(1, int(energy_every))
    picked = [k for k in range(len(model.records)) if k % every == 0 or k == len(model.records) - 1]
    e0 = time.perf_counter()
    strain = strain_energies(model, [model.records[k][1] for k in picked]) if picked else np.zeros(0)
    energy_time = time.perf_counter() - e0
    t_strain = np.array([times[k] for k in picked])
    total = kinetic[picked] + strain
    L_scale = float(np.linalg.norm(L, axis=1).max()) if len(L) else float("nan")
    L_drift = float(np.linalg.norm(L - L[0], axis=1).max()) if len(L) else float("nan")
    e_scale = float(np.max(kinetic[picked] + strain)) if picked else float("nan")
    name = "GeneralizedAlpha" if integrator == "generalized_alpha" else "RK44"
    return {
        "model": model.description + f", exudyn {name}", "kind": model.kind, "integrator": integrator,
        "dofs": model.coordinates, "coordinates": model.coordinates, "elements": model.elements,
        "steps": int(round(t_reached / model.time_step)), "time_step": model.time_step,
        "end_time": model.end_time, "rho_inf": model.rho_inf if integrator == "generalized_alpha" else None,
        "newton_iterations": iterations, "jacobians": jacobians, "converged": converged, "message": message,
        "time": t_reached, "build_time_s": model.build_time_s, "wall_time_s": wall, "cpu_time_s": cpu,
        "energy_eval_time_s": energy_time,
        "outputs": {k: v[-1] for k, v in history.items() if k != "time" and v},
        "history": history,
        "energy_history": {"time": t_strain.tolist(), "kinetic": kinetic[picked].tolist(),
                           "strain": strain.tolist(), "total": total.tolist()},
        "kinetic_history": {"time": times, "kinetic": kinetic.tolist()},
        "momentum": {"angular": {"initial": L[0].tolist() if len(L) else None,
                                 "final": L[-1].tolist() if len(L) else None, "max_drift": L_drift,
                                 "max_rel_drift": L_drift / L_scale if L_scale > 0 else float("nan"),
                                 "history": L.tolist()}},
        "energy": energy_summary(t_strain, strain, total, e_scale),
    }


def energy_summary(t, strain, total, scale) -> dict:
    t, strain, total = np.asarray(t, float), np.asarray(strain, float), np.asarray(total, float)
    later = t > 0
    drift = float(np.abs(total - total[0]).max()) if total.size else float("nan")
    return {"strain": {"max": float(strain.max()) if strain.size else float("nan"),
                       "min": float(strain[later].min()) if later.any() else float("nan"),
                       "mean": float(strain[later].mean()) if later.any() else float("nan"),
                       "final": float(strain[-1]) if strain.size else float("nan")},
            "total": {"initial": float(total[0]) if total.size else float("nan"), "max_drift": drift,
                      "max_rel_drift": drift / scale if scale and scale > 0 else float("nan")}}

