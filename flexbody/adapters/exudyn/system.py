"""exudyn plumbing shared by the reference models and the wrapped shell: new systems, solver settings, quiet
solver runs with their Newton counts, the static solver's pseudo-time as load factors, ANCF plate meshes.

Facts about exudyn behind these helpers: its solvers raise ``exu.SolverError`` on failure and print to the
console unless told not to; its static solver runs a pseudo-time t from 0 to 1 in equal load steps.
"""

from __future__ import annotations

from collections.abc import Callable
import contextlib
import time

import numpy as np

import exudyn as exu
import exudyn.shells as shells

from flexbody.scenes.scene import Scene


@contextlib.contextmanager
def quiet_console():
    """exudyn's console output off for the duration (restored afterwards, whatever happens)."""
    previous = exu.config.printToConsole
    exu.config.printToConsole = False
    try:
        yield
    finally:
        exu.config.printToConsole = previous


def run_solver(solve: Callable[[], object]) -> tuple[bool, str, float, float]:
    """Run ``solve()`` quietly; an ``exu.SolverError`` becomes ``converged = False`` with its first line.

    Returns (converged, message, wall time, CPU time).
    """
    converged, message = True, "completed"
    t0, c0 = time.perf_counter(), time.process_time()
    with quiet_console():
        try:
            solve()
        except exu.SolverError as exc:
            converged, message = False, f"exudyn SolverError: {str(exc).splitlines()[0]}"
    return converged, message, time.perf_counter() - t0, time.process_time() - c0


def newton_counts(mbs, solver_key: str) -> tuple[int, int]:
    """(Newton iterations, Jacobian computations) of the last stored solver ("staticSolver" or
    "dynamicSolver"; solved with ``storeSolver=True``), zeros if there is none."""
    solver = mbs.sys.get(solver_key)
    if solver is None:
        return 0, 0
    return int(solver.it.newtonStepsCount), int(solver.it.newtonJacobiCount)


def new_system():
    """(SystemContainer, MainSystem): keep the container alive as long as the system is used."""
    sc = exu.SystemContainer()
    return sc, sc.AddSystem()


def simulation_settings():
    """exudyn settings of every run here: no solution file, exudyn's sparse LU (EigenSparse)."""
    s = exu.SimulationSettings()
    s.solution.file.write = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    return s


def static_settings(load_steps: int, rtol: float):
    """Settings of exudyn's static solver: ``load_steps`` equal steps of pseudo-time, silent, relative
    Newton tolerance ``rtol``."""
    s = simulation_settings()
    s.staticSolver.numberOfLoadSteps = load_steps
    s.staticSolver.verboseMode = 0
    s.staticSolver.newton.relativeTolerance = rtol
    return s


def dynamic_settings(end_time: float, steps: int, spectral_radius: float | None = None):
    """Settings of exudyn's time integration: ``steps`` steps to ``end_time``, silent; the generalized-alpha
    spectral radius if given."""
    s = simulation_settings()
    ti = s.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = end_time
    ti.verboseMode = 0
    if spectral_radius is not None:
        ti.generalizedAlpha.spectralRadius = spectral_radius
    return s


def pseudo_time_load_factor(load_factors: np.ndarray) -> Callable:
    """lambda(t): the static solver's pseudo-time t in [0, 1] (N equal steps) mapped piecewise linearly to the
    N load factors, k/N -> load_factors[k-1] (and 0 -> 0); takes scalars and arrays."""
    t_grid = np.linspace(0.0, 1.0, len(load_factors) + 1)
    lam = np.concatenate([[0.0], np.asarray(load_factors, float)])
    return lambda t: np.interp(t, t_grid, lam)


def nearest(positions: np.ndarray, point: np.ndarray, size: float) -> np.ndarray:
    """Indices of the positions nearest to ``point`` (all those within 1e-9 size of the minimum)."""
    d = np.linalg.norm(positions - point, axis=1)
    return np.flatnonzero(d <= d.min() + 1e-9 * size)


def material(scene: Scene) -> tuple[float, float, float, float, float]:
    """(E, nu, h, rho, shear correction) of the scene's shell; rho 1 where the scene has no density."""
    m = scene.model.body.material
    if m.wrinkling:
        raise ValueError(f"scene {scene.name!r}: exudyn's reference elements have no tension-field (wrinkling) "
                         "membrane law (material wrinkling = true)")
    return m.young, m.poisson, m.thickness, (m.density or 1.0), m.shear_correction


def plate_mesh(mbs, scene: Scene, vertices, nx: int, ny: int, surface_map=None):
    """``ObjectANCFThinPlate`` elements (reduced integration) on a (mapped) quadrilateral, the scene's material."""
    E, nu, h, rho, _ = material(scene)
    mesh = shells.ShellMesh(vertices=vertices, numberOfElementsX=nx, numberOfElementsY=ny, youngsModulus=E,
                            poissonsRatio=nu, density=rho, thickness=h, surfaceMap=surface_map)
    mesh.CreateANCFThinPlateElements(mbs, useReducedOrderIntegration=1)
    return mesh
