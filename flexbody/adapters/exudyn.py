"""exudyn reference models of the built-in scenes, and the side-by-side comparison.

exudyn has no triangular or shear-deformable shell. The matching models used here are

- the strips (``cantilever_end_moment``, ``cantilever_end_shear``): ``ObjectBeamGeometricallyExact``
  (SE(3) beam, Euler-parameter nodes, the default), ``ObjectBeamGeometricallyExact2D`` and
  ``ObjectANCFThinPlate`` (four-node Kirchhoff plate, ``exudyn.shells.ShellMesh``);
- ``slit_annular_plate``, ``pullout_cylinder`` and ``hemisphere``: ``ObjectANCFThinPlate`` on a mapped
  rectangle (``ShellMesh(surfaceMap=...)``), symmetry planes as coordinate constraints on the nodal
  position and slope coordinates;
- the dynamic ``spinning_plate``: a free ``ObjectANCFThinPlate`` mesh started in the scene's rigid spin
  (position and slope rates of the rigid field), exudyn's ``GeneralizedAlpha`` with the scene's spectral
  radius, time step and end time (``build_dynamic_model``, ``solve_dynamic``); angular momentum from the
  nodal coordinates and the consistent mass matrix, strain energy integrated from exudyn's elastic forces
  (exudyn has no energy output for the plate); optionally an RK4 (``RK44``) reference run of the same model.

The physics is read from the flexbody scene itself: material (E, nu, h), geometry (from the mesh nodes),
total loads (from the scene's nodal loads) and the load factors of the analysis; tracked outputs are the
scene's outputs, evaluated at the exudyn node nearest to the flexbody output node (the mean over nodes
at equal distance, e.g. the two tip corners of a one-element-wide plate strip).

Options of the exudyn model ride along in the scene parameters with the prefix ``exudyn_`` (and are removed
before the flexbody scene is built): ``exudyn_model`` ("beam3d", "beam2d" or "plate" for the strips,
"plate" otherwise), ``exudyn_nx``, ``exudyn_ny`` (element counts), ``exudyn_steps`` (uniform load steps,
used where the flexbody scene runs arc-length), ``exudyn_rtol`` (exudyn's relative Newton tolerance);
for dynamic scenes ``exudyn_energy_every`` (strain energy at every k-th recorded step), ``exudyn_reference``
("rk4": add the RK4 run), ``exudyn_reference_dt`` (1e-4) and ``exudyn_reference_end_time``.

``ShellODE2`` puts our shell into an exudyn system as an ``ObjectGenericODE2`` (force and Jacobian user
functions; with the lumped mass also for exudyn's implicit integrators), so that exudyn constraints and
bodies can act with it; ``solve_scene_in_exudyn`` runs a static scene that way, and
``hub_driven_membrane_in_exudyn`` runs ``spinning_membrane`` with its hub an exudyn rigid body on a driven
revolute joint (the inner nodes tied to it by constraints) next to the flexbody-alone run.

Facts about exudyn that shape this module: its static solver raises ``exu.SolverError`` on failure; its
Newton tolerance is relative to a residual that it re-bases after the first iteration
(``adaptInitialResidual``), so beams need a tight tolerance (1e-10; 1e-8 left a 6e-3 error in the tip
displacement of the strip after a 0.1 M_max step); the ANCF plate needs ``useReducedOrderIntegration=1``
(speed, membrane locking); the hemisphere was reported to stall near a relative tolerance of 1e-6 (here
the 20 x 20 model converged at 1e-6 as well) and runs at 1e-5.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import contextlib
import json
import math
import sys
import time

import numpy as np
import scipy.sparse as sparse

import exudyn as exu
import exudyn.beams as beams
import exudyn.itemInterface as eii
import exudyn.shells as shells

from flexbody.body import ShellState, update_state
from flexbody.lie.so3 import tangent
from flexbody.loads import NodalLoad
from flexbody.scenes import build
from flexbody.scenes.scene import DynamicAnalysis, Scene, compare_with_reference, run_scene

#: exudyn models available for each built-in scene; the first is the default
MODELS: dict[str, tuple[str, ...]] = {
    "cantilever_end_moment": ("beam3d", "beam2d", "plate"),
    "cantilever_end_shear": ("beam3d", "beam2d", "plate"),
    "slit_annular_plate": ("plate",),
    "pullout_cylinder": ("plate",),
    "hemisphere": ("plate",),
    "spinning_plate": ("plate",),
}

#: exudyn relative Newton tolerance per model kind and scene (see the module docstring)
_RTOL = {"beam3d": 1e-10, "beam2d": 1e-10, "plate": 1e-8}
_RTOL_SCENE = {"slit_annular_plate": 1e-6, "pullout_cylinder": 1e-6, "hemisphere": 1e-5}

_OPTION_PREFIX = "exudyn_"
_DYNAMIC_OPTIONS = ("energy_every", "reference", "reference_dt", "reference_end_time")
_OPTIONS = ("model", "nx", "ny", "steps", "rtol") + _DYNAMIC_OPTIONS


@contextlib.contextmanager
def _quiet_console():
    """exudyn's console output off for the duration (restored afterwards, whatever happens)."""
    previous = exu.config.printToConsole
    exu.config.printToConsole = False
    try:
        yield
    finally:
        exu.config.printToConsole = previous


def _run_solver(solve) -> tuple[bool, str, float, float]:
    """Run ``solve()`` quietly; an ``exu.SolverError`` becomes ``converged = False`` with its first line.

    Returns (converged, message, wall time, CPU time).
    """
    converged, message = True, "completed"
    t0, c0 = time.perf_counter(), time.process_time()
    with _quiet_console():
        try:
            solve()
        except exu.SolverError as exc:
            converged, message = False, f"exudyn SolverError: {str(exc).splitlines()[0]}"
    return converged, message, time.perf_counter() - t0, time.process_time() - c0


# ----------------------------------------------------------------------------------------------------------
# data
# ----------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class TrackedOutput:
    """A scene output in exudyn: the mean displacement of ``nodes`` along ``direction`` (exudyn frame)."""

    name: str
    nodes: tuple[int, ...]
    direction: tuple[float, float, float]
    scale: float = 1.0


@dataclass
class ExudynModel:
    """An assembled exudyn system that mirrors one flexbody scene.

    Attributes
    ----------
    scene : scene name
    kind : "beam3d", "beam2d" or "plate"
    description : element type and mesh, for reports
    mbs : the exudyn MainSystem (kept alive together with ``system_container``)
    outputs : tracked outputs, named as in the flexbody scene
    load_factors : load factors at which the static solver stops (the loads follow them piecewise linearly)
    rtol : relative Newton tolerance of exudyn's static solver
    elements : number of finite elements
    build_time_s : wall time of building and assembling the system
    sensors : exudyn sensor number of each exudyn node an output reads
    """

    scene: str
    kind: str
    description: str
    system_container: object
    mbs: object
    outputs: list[TrackedOutput]
    load_factors: np.ndarray
    rtol: float
    elements: int
    build_time_s: float = 0.0
    sensors: dict[int, int] = field(default_factory=dict)

    @property
    def coordinates(self) -> int:
        return int(self.mbs.systemData.ODE2Size())

    @property
    def constraints(self) -> int:
        return int(self.mbs.systemData.AEsize())

    @property
    def dofs(self) -> int:
        """Coordinates minus algebraic constraints (the free DoFs, comparable to flexbody's n_dof)."""
        return self.coordinates - self.constraints


@dataclass
class ExudynRun:
    """Result of a static exudyn run: the history of the tracked outputs per converged load step."""

    model: ExudynModel
    history: dict[str, list[float]]
    converged: bool
    message: str
    newton_iterations: int
    wall_time_s: float
    cpu_time_s: float
    errors: list[dict] = field(default_factory=list)

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

    def as_dict(self) -> dict:
        m = self.model
        lam = self.history["load_factor"]
        return {
            "model": m.description, "kind": m.kind, "dofs": m.dofs, "coordinates": m.coordinates,
            "constraints": m.constraints, "elements": m.elements, "steps": len(lam),
            "newton_iterations": self.newton_iterations, "newton_rtol": m.rtol,
            "converged": self.converged, "message": self.message,
            "load_factor": lam[-1] if lam else 0.0,
            "build_time_s": m.build_time_s, "wall_time_s": self.wall_time_s, "cpu_time_s": self.cpu_time_s,
            "outputs": {k: v[-1] for k, v in self.history.items() if k != "load_factor" and v},
            "errors": self.errors, "max_rel_error": self.max_rel_error, "history": self.history,
        }


# ----------------------------------------------------------------------------------------------------------
# reading the physics from the flexbody scene
# ----------------------------------------------------------------------------------------------------------

def split_options(params: dict | None) -> tuple[dict, dict]:
    """Split parameters into (flexbody scene parameters, exudyn options without the ``exudyn_`` prefix)."""
    scene_params, options = {}, {}
    for key, value in (params or {}).items():
        if key.startswith(_OPTION_PREFIX):
            name = key[len(_OPTION_PREFIX):]
            if name not in _OPTIONS:
                raise KeyError(f"unknown exudyn option {key!r}; options: "
                               + ", ".join(_OPTION_PREFIX + o for o in _OPTIONS))
            options[name] = value
        else:
            scene_params[key] = value
    return scene_params, options


def _total_load(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Sum of all dead nodal forces and moments of the scene (at load factor 1)."""
    force, moment = np.zeros(3), np.zeros(3)
    for load in scene.model.loads:
        if not isinstance(load, NodalLoad) or load.follower:
            raise ValueError(f"scene {scene.name!r}: only dead nodal loads have an exudyn counterpart")
        force += len(load.nodes) * np.asarray(load.force, float)
        moment += len(load.nodes) * np.asarray(load.moment, float)
    return force, moment


def _point_loads(scene: Scene) -> list[tuple[np.ndarray, np.ndarray]]:
    """(reference position, force) of every loaded node of a scene with point forces only."""
    nodes = scene.model.body.mesh.nodes
    out = []
    for load in scene.model.loads:
        if not isinstance(load, NodalLoad) or load.follower:
            raise ValueError(f"scene {scene.name!r}: only dead nodal loads have an exudyn counterpart")
        if np.any(np.asarray(load.moment) != 0):
            raise ValueError(f"scene {scene.name!r}: point moments are not mapped to the ANCF plate")
        out += [(nodes[i], np.asarray(load.force, float)) for i in load.nodes]
    return out


def _load_factors(scene: Scene, steps: int | None) -> np.ndarray:
    """The flexbody load factors (load control), or uniform steps plus the reference table (arc-length)."""
    a = scene.analysis
    if a.method == "load_control" and steps is None:
        lf = np.asarray(a.load_factors, float)
    else:
        n = int(steps) if steps is not None else 40
        if n < 1:
            raise ValueError(f"exudyn_steps must be >= 1, got {steps!r}")
        lf = np.linspace(0, max(a.load_factors), n + 1)[1:]
        if scene.reference is not None:
            ref = np.asarray(scene.reference.load_factors, float)
            lf = np.union1d(lf, ref[(ref > 0) & (ref <= lf[-1])])
    lf = np.unique(np.round(lf, 12))
    return lf[lf > 0]


def _material(scene: Scene) -> tuple[float, float, float, float, float]:
    m = scene.model.body.material
    return m.young, m.poisson, m.thickness, (m.density or 1.0), m.shear_correction


# ----------------------------------------------------------------------------------------------------------
# exudyn building blocks
# ----------------------------------------------------------------------------------------------------------

def _new_system():
    sc = exu.SystemContainer()
    return sc, sc.AddSystem()


def _nearest(positions: np.ndarray, point: np.ndarray, size: float) -> np.ndarray:
    """Indices of the positions nearest to ``point`` (all those within 1e-9 size of the minimum)."""
    d = np.linalg.norm(positions - point, axis=1)
    return np.flatnonzero(d <= d.min() + 1e-9 * size)


def _outputs_at(scene: Scene, node_numbers: list[int], positions: np.ndarray,
                rotation: np.ndarray | None = None) -> list[TrackedOutput]:
    """Map each scene output to the exudyn node(s) nearest to its flexbody node.

    positions : reference positions of the exudyn nodes in flexbody coordinates
    rotation : maps flexbody vectors to exudyn vectors (the planar beam lives in the exudyn x-y plane)
    """
    mesh = scene.model.body.mesh
    size = float(np.ptp(mesh.nodes, axis=0).max())
    rot = np.eye(3) if rotation is None else rotation
    outs = []
    for out in scene.outputs:
        idx = _nearest(positions, mesh.nodes[out.node], size)
        direction = rot @ np.asarray(out.direction, float)
        outs.append(TrackedOutput(out.name, tuple(int(node_numbers[i]) for i in idx),
                                  tuple(float(c) for c in direction), out.scale))
    return outs


def _constrain_to_ground(mbs, node: int, coordinates) -> None:
    """Fix the listed coordinates of a node at their reference values (CoordinateConstraint to ground)."""
    shells.AddNodeConstraints(mbs, node, dofs=sorted(set(int(c) for c in coordinates)))


def _point_force(mbs, node: int, force) -> None:
    marker = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node))
    mbs.AddLoad(eii.Force(markerNumber=marker, loadVector=[float(f) for f in force]))


def _follow_load_factors(mbs, load_factors: np.ndarray) -> None:
    """Let every load follow the load factors: pseudo-time k/N of the static solver -> load_factors[k-1].

    The static solver then runs with ``useLoadFactor = False`` and N = len(load_factors) steps, so that it
    stops exactly at the flexbody load factors (also at non-uniform ones such as the reference table's).
    """
    t_grid = np.linspace(0.0, 1.0, len(load_factors) + 1)
    lam = np.concatenate([[0.0], load_factors])

    def scaled(mbs_, t, load):
        return (float(np.interp(t, t_grid, lam)) * np.asarray(load)).tolist()

    for i in range(mbs.systemData.NumberOfLoads()):
        mbs.SetLoadParameter(i, "loadVectorUserFunction", scaled)


# ----------------------------------------------------------------------------------------------------------
# strips: geometrically exact beams and the ANCF plate
# ----------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Strip:
    length: float
    width: float
    young: float
    poisson: float
    thickness: float
    density: float
    shear_correction: float
    force: np.ndarray
    moment: np.ndarray

    @property
    def bending_stiffness(self) -> float:
        """D b = E b h^3 / (12 (1 - nu^2)): the strip bends as a plate strip (equal to E I for nu = 0)."""
        return self.young * self.width * self.thickness**3 / (12 * (1 - self.poisson**2))

    @property
    def axial_stiffness(self) -> float:
        return self.young * self.width * self.thickness / (1 - self.poisson**2)

    @property
    def shear_stiffness(self) -> float:
        g = self.young / (2 * (1 + self.poisson))
        return self.shear_correction * g * self.width * self.thickness


def _strip(scene: Scene) -> _Strip:
    x = scene.model.body.mesh.nodes
    if np.ptp(x[:, 2]) > 0 or x[:, 0].min() != 0 or x[:, 1].min() != 0:
        raise ValueError(f"scene {scene.name!r} is not a flat strip [0, L] x [0, b] in z = 0")
    force, moment = _total_load(scene)
    E, nu, h, rho, k = _material(scene)
    return _Strip(float(x[:, 0].max()), float(x[:, 1].max()), E, nu, h, rho, k, force, moment)


# a rotation taking the strip's bending plane x-z to exudyn's 2D plane x-y: e_x -> e_x, e_y -> -e_z, e_z -> e_y
_XZ_TO_XY = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])


def beam2d_strip(scene: Scene, n_elements: int) -> tuple:
    """The strip as ``ObjectBeamGeometricallyExact2D`` elements (x-z plane mapped to exudyn's x-y plane)."""
    s = _strip(scene)
    sc, mbs = _new_system()
    area = s.width * s.thickness
    template = eii.ObjectBeamGeometricallyExact2D(
        nodeNumbers=[0, 0], massPerLength=s.density * area, crossSectionInertia=s.density * area * s.thickness**2 / 12,
        bendingStiffness=s.bending_stiffness, axialStiffness=s.axial_stiffness, shearStiffness=s.shear_stiffness)
    beam = beams.GenerateBeamElementsAlongLine(mbs, [0.0, 0.0, 0.0], [s.length, 0.0, 0.0], n_elements, template,
                                               groundConstraintsStart=[1, 1, 1])
    tip = beam["nodes"][-1]
    marker = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=tip))
    f, m = _XZ_TO_XY @ s.force, _XZ_TO_XY @ s.moment
    if abs(f[2]) > 0 or abs(m[0]) + abs(m[1]) > 0:
        raise ValueError(f"scene {scene.name!r}: the load leaves the bending plane; use exudyn_model=beam3d")
    if np.any(f != 0):
        mbs.AddLoad(eii.Force(markerNumber=marker, loadVector=f.tolist()))
    if np.any(m != 0):
        mbs.AddLoad(eii.Torque(markerNumber=marker, loadVector=m.tolist()))
    nodes = list(beam["nodes"])
    positions = np.array([[p[0], s.width / 2, 0.0] for p in beam["nodePositions"]])
    outputs = _outputs_at(scene, nodes, positions, _XZ_TO_XY)
    return sc, mbs, outputs, f"ObjectBeamGeometricallyExact2D, {n_elements} elements", n_elements


def beam3d_strip(scene: Scene, n_elements: int) -> tuple:
    """The strip as ``ObjectBeamGeometricallyExact`` (SE(3) beam) elements on Euler-parameter nodes.

    Section axes: x along the strip, y across the width, z through the thickness; the centre line is
    y = b/2. Torsion: G b h^3 / 3 (thin rectangle).
    """
    s = _strip(scene)
    sc, mbs = _new_system()
    g = s.young / (2 * (1 + s.poisson))
    b, h = s.width, s.thickness
    section = exu.BeamSection()
    section.stiffnessMatrix = np.diag([s.axial_stiffness, s.shear_stiffness, s.shear_stiffness, g * b * h**3 / 3,
                                       s.bending_stiffness, s.young * h * b**3 / 12])
    section.massPerLength = s.density * b * h
    section.inertia = s.density * np.diag([b * h * (b**2 + h**2) / 12, b * h**3 / 12, h * b**3 / 12])
    xs = np.linspace(0.0, s.length, n_elements + 1)
    ep0 = [1.0, 0.0, 0.0, 0.0]
    nodes = [mbs.AddNode(eii.NodeRigidBodyEP(referenceCoordinates=[x, b / 2, 0.0] + ep0)) for x in xs]
    for n0, n1 in zip(nodes[:-1], nodes[1:]):
        mbs.AddObject(eii.ObjectBeamGeometricallyExact(nodeNumbers=[n0, n1], length=s.length / n_elements,
                                                       sectionData=section))
    ground = mbs.AddObject(eii.ObjectGround(referencePosition=[0.0, b / 2, 0.0]))
    mbs.AddObject(eii.GenericJoint(markerNumbers=[mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground)),
                                                  mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=nodes[0]))]))
    marker = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=nodes[-1]))
    if np.any(s.force != 0):
        mbs.AddLoad(eii.Force(markerNumber=marker, loadVector=s.force.tolist()))
    if np.any(s.moment != 0):
        mbs.AddLoad(eii.Torque(markerNumber=marker, loadVector=s.moment.tolist()))
    positions = np.column_stack([xs, np.full_like(xs, b / 2), np.zeros_like(xs)])
    outputs = _outputs_at(scene, nodes, positions)
    description = f"ObjectBeamGeometricallyExact (SE(3), Euler parameters), {n_elements} elements"
    return sc, mbs, outputs, description, n_elements


def _plate_mesh(mbs, scene: Scene, vertices, nx: int, ny: int, surface_map=None):
    E, nu, h, rho, _ = _material(scene)
    mesh = shells.ShellMesh(vertices=vertices, numberOfElementsX=nx, numberOfElementsY=ny, youngsModulus=E,
                            poissonsRatio=nu, density=rho, thickness=h, surfaceMap=surface_map)
    mesh.CreateANCFThinPlateElements(mbs, useReducedOrderIntegration=1)
    return mesh


def _plate_outputs(scene: Scene, mesh) -> list[TrackedOutput]:
    return _outputs_at(scene, mesh.nodeNumbers, np.array(mesh.nodeReferencePositions))


def plate_strip(scene: Scene, nx: int, ny: int) -> tuple:
    """The strip as ANCF thin plates (nx x ny), clamped at x = 0 (all nine nodal coordinates).

    The tip moment is applied as nodal torques (trapezoidal rule, ``shells.ApplyEdgeLoad``), the tip force
    as a consistent line load (``distributed=True``).
    """
    s = _strip(scene)
    sc, mbs = _new_system()
    L, b = s.length, s.width
    mesh = _plate_mesh(mbs, scene, [[0, 0, 0], [L, 0, 0], [L, b, 0], [0, b, 0]], nx, ny)
    for node in mesh.boundaryNodeNumbers["left"]:
        _constrain_to_ground(mbs, node, range(9))
    if np.any(s.force != 0):
        shells.ApplyEdgeLoad(mbs, mesh, "right", loadVector=s.force.tolist(), distributed=True)
    if np.any(s.moment != 0):
        shells.ApplyEdgeLoad(mbs, mesh, "right", torqueVector=s.moment.tolist())
    return sc, mbs, _plate_outputs(scene, mesh), f"ObjectANCFThinPlate, {nx} x {ny} elements", nx * ny


# ----------------------------------------------------------------------------------------------------------
# curved and annular plates: the ANCF plate on mapped rectangles
# ----------------------------------------------------------------------------------------------------------

# NodePointSlope12 coordinates: 0-2 position, 3-5 slope x (first parametric direction), 6-8 slope y
_SLOPE = {"x": 3, "y": 6}


def symmetry_coordinates(axis: int, along: str) -> list[int]:
    """ANCF node coordinates fixed by a symmetry plane with normal along the global ``axis`` (0, 1, 2).

    ``along`` is the parametric direction ("x" or "y") whose slope lies in the plane (the edge direction);
    the other slope crosses the plane. Mirror symmetry r(-s) = M r(s) gives: position . n = 0, the in-plane
    slope has no normal component, the crossing slope is parallel to n.
    """
    cross = "y" if along == "x" else "x"
    others = [k for k in range(3) if k != axis]
    return [axis, _SLOPE[along] + axis] + [_SLOPE[cross] + k for k in others]


def _apply_symmetry(mbs, mesh, planes: list[tuple[str, int]]) -> None:
    """Symmetry planes on mesh sides: [(side, normal axis)], the coordinates of shared corners merged."""
    along = {"left": "y", "right": "y", "bottom": "x", "top": "x"}
    fixed: dict[int, set[int]] = {}
    for side, axis in planes:
        for node in mesh.boundaryNodeNumbers[side]:
            fixed.setdefault(node, set()).update(symmetry_coordinates(axis, along[side]))
    for node, coords in fixed.items():
        _constrain_to_ground(mbs, node, coords)


def _apply_point_loads(mbs, scene: Scene, mesh) -> None:
    positions = np.array(mesh.nodeReferencePositions)
    size = float(np.ptp(positions, axis=0).max())
    for x, force in _point_loads(scene):
        idx = _nearest(positions, x, size)
        if np.linalg.norm(positions[idx[0]] - x) > 1e-6 * size:
            raise ValueError(f"scene {scene.name!r}: no ANCF node at the load point {x}; choose another mesh")
        _point_force(mbs, mesh.nodeNumbers[idx[0]], force)


def _sym():
    return exu.symbolic


def slit_annular_plate_model(scene: Scene, nx: int, ny: int) -> tuple:
    """Slit annulus as ANCF plates on (r, theta) in [Ri, Ro] x [0, 2 pi]: nx radial x ny circumferential.

    Lip theta = 0 clamped (all nine nodal coordinates); the scene's total line force on the lip
    theta = 2 pi as a consistent line load.
    """
    x = scene.model.body.mesh.nodes
    r = np.linalg.norm(x[:, :2], axis=1)
    ri, ro = float(r.min()), float(r.max())
    force, _ = _total_load(scene)
    sc, mbs = _new_system()
    sym = _sym()

    def annulus(rr, t):
        return [rr * sym.cos(t), rr * sym.sin(t), 0.0]

    mesh = _plate_mesh(mbs, scene, [[ri, 0, 0], [ro, 0, 0], [ro, 2 * math.pi, 0], [ri, 2 * math.pi, 0]], nx, ny,
                       annulus)
    for node in mesh.boundaryNodeNumbers["bottom"]:
        _constrain_to_ground(mbs, node, range(9))
    shells.ApplyEdgeLoad(mbs, mesh, "top", loadVector=force.tolist(), distributed=True)
    # the lips coincide: pick the output nodes on the loaded lip explicitly
    lip = mesh.boundaryNodeNumbers["top"]
    lip_positions = np.array([mesh.nodeReferencePositions[mesh.nodeNumbers.index(n)] for n in lip])
    outputs = _outputs_at(scene, lip, lip_positions)
    return sc, mbs, outputs, f"ObjectANCFThinPlate, {nx} x {ny} elements (radial x circumferential)", nx * ny


def pullout_cylinder_model(scene: Scene, nx: int, ny: int) -> tuple:
    """Octant of the pulled cylinder as ANCF plates on (angle, z) in [0, pi/2] x [0, L/2].

    Symmetry planes y = 0 (angle 0), x = 0 (angle pi/2) and z = 0 (mid-length); free edge z = L/2.
    """
    x = scene.model.body.mesh.nodes
    radius = float(np.linalg.norm(x[:, :2], axis=1).max())
    half_length = float(x[:, 2].max())
    sc, mbs = _new_system()
    sym = _sym()

    def cylinder(a, z):
        return [radius * sym.cos(a), radius * sym.sin(a), z]

    mesh = _plate_mesh(mbs, scene, [[0, 0, 0], [math.pi / 2, 0, 0], [math.pi / 2, half_length, 0],
                                    [0, half_length, 0]], nx, ny, cylinder)
    _apply_symmetry(mbs, mesh, [("left", 1), ("right", 0), ("bottom", 2)])
    _apply_point_loads(mbs, scene, mesh)
    return (sc, mbs, _plate_outputs(scene, mesh),
            f"ObjectANCFThinPlate, {nx} x {ny} elements (circumferential x axial)", nx * ny)


def hemisphere_model(scene: Scene, nx: int, ny: int) -> tuple:
    """Quarter hemisphere with a polar hole as ANCF plates on (azimuth, polar angle).

    Symmetry planes y = 0 and x = 0; the z translation fixed at the hole node on y = 0 (as in the scene).
    """
    x = scene.model.body.mesh.nodes
    radius = float(np.linalg.norm(x, axis=1).max())
    hole = math.acos(min(1.0, float(x[:, 2].max()) / radius))
    equator = math.acos(max(-1.0, float(x[:, 2].min()) / radius))
    sc, mbs = _new_system()
    sym = _sym()

    def sphere(a, p):
        return [radius * sym.sin(p) * sym.cos(a), radius * sym.sin(p) * sym.sin(a), radius * sym.cos(p)]

    mesh = _plate_mesh(mbs, scene, [[0, hole, 0], [math.pi / 2, hole, 0], [math.pi / 2, equator, 0],
                                    [0, equator, 0]], nx, ny, sphere)
    _apply_symmetry(mbs, mesh, [("left", 1), ("right", 0)])
    _constrain_to_ground(mbs, mesh.boundaryNodeNumbers["bottom"][0], [2])
    _apply_point_loads(mbs, scene, mesh)
    return (sc, mbs, _plate_outputs(scene, mesh),
            f"ObjectANCFThinPlate, {nx} x {ny} elements (azimuthal x meridional)", nx * ny)


# ----------------------------------------------------------------------------------------------------------
# building and running
# ----------------------------------------------------------------------------------------------------------

def _default_mesh(scene: Scene, kind: str) -> tuple[int, int]:
    """Element counts: beams get one element per flexbody node spacing (2 nx), plates one quad per cell."""
    p = scene.parameters
    if scene.name in ("cantilever_end_moment", "cantilever_end_shear"):
        return (2 * p["nx"], 1) if kind.startswith("beam") else (p["nx"], p["ny"])
    keys = {"slit_annular_plate": ("n_radial", "n_circ"), "pullout_cylinder": ("n_circ", "n_axial"),
            "hemisphere": ("n_circ", "n_meridian"), "spinning_plate": ("nx", "ny")}[scene.name]
    return p[keys[0]], p[keys[1]]


def model_kind(scene_name: str, options: dict) -> str:
    """The exudyn model kind for a scene and options; raises KeyError/ValueError for unsupported ones."""
    if scene_name not in MODELS:
        raise KeyError(f"no exudyn model for scene {scene_name!r}; exudyn models exist for: {', '.join(MODELS)}")
    kind = options.get("model", MODELS[scene_name][0])
    if kind not in MODELS[scene_name]:
        raise ValueError(f"exudyn_model for {scene_name!r} must be one of {MODELS[scene_name]}, got {kind!r}")
    return kind


def build_model(scene: Scene, options: dict | None = None) -> ExudynModel:
    """Build and assemble the exudyn reference model of a flexbody scene.

    Parameters
    ----------
    scene : a built-in flexbody scene (``flexbody.scenes.build``)
    options : exudyn options without the prefix: model, nx, ny, steps, rtol (see the module docstring)
    """
    options = dict(options or {})
    kind = model_kind(scene.name, options)
    if isinstance(scene.analysis, DynamicAnalysis):
        raise ValueError(f"scene {scene.name!r} is dynamic: use build_dynamic_model")
    nx0, ny0 = _default_mesh(scene, kind)
    nx, ny = int(options.get("nx", nx0)), int(options.get("ny", ny0))
    if nx < 1 or ny < 1:
        raise ValueError(f"exudyn_nx and exudyn_ny must be >= 1, got {nx} and {ny}")
    rtol = float(options.get("rtol", _RTOL_SCENE.get(scene.name, _RTOL[kind])))
    load_factors = _load_factors(scene, options.get("steps"))
    t0 = time.perf_counter()
    if kind == "beam2d":
        parts = beam2d_strip(scene, nx)
    elif kind == "beam3d":
        parts = beam3d_strip(scene, nx)
    elif scene.name.startswith("cantilever"):
        parts = plate_strip(scene, nx, ny)
    else:
        builder = {"slit_annular_plate": slit_annular_plate_model, "pullout_cylinder": pullout_cylinder_model,
                   "hemisphere": hemisphere_model}[scene.name]
        parts = builder(scene, nx, ny)
    sc, mbs, outputs, description, elements = parts
    _follow_load_factors(mbs, load_factors)
    sensors = _add_sensors(mbs, outputs)
    mbs.Assemble()
    return ExudynModel(scene.name, kind, description, sc, mbs, outputs, load_factors, rtol, elements,
                       time.perf_counter() - t0, sensors)


def _settings(model: ExudynModel):
    s = exu.SimulationSettings()
    st = s.staticSolver
    st.numberOfLoadSteps = len(model.load_factors)
    st.useLoadFactor = False          # the loads follow model.load_factors through their user functions
    st.adaptiveStep = True
    st.verboseMode = 0
    st.newton.relativeTolerance = model.rtol
    s.solution.file.write = False
    s.solution.sensors.writePeriod = 1e-12  # every converged load step
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    return s


def _add_sensors(mbs, outputs: list[TrackedOutput]) -> dict[int, int]:
    nodes = sorted({n for out in outputs for n in out.nodes})
    kind = exu.OutputVariableType.Displacement
    return {n: mbs.AddSensor(eii.SensorNode(nodeNumber=n, storeInternal=True, outputVariableType=kind))
            for n in nodes}


def _history(model: ExudynModel) -> dict[str, list[float]]:
    data = {n: np.asarray(model.mbs.GetSensorStoredData(s), float).reshape(-1, 4)
            for n, s in model.sensors.items()}
    t = next(iter(data.values()))[:, 0]
    keep = t > 1e-14                                 # drop the initial (unloaded) record
    t_grid = np.linspace(0.0, 1.0, len(model.load_factors) + 1)
    lam = np.interp(t[keep], t_grid, np.concatenate([[0.0], model.load_factors]))
    history = {"load_factor": [float(v) for v in lam]}
    for out in model.outputs:
        u = np.mean([data[n][keep, 1:4] for n in out.nodes], axis=0)
        history[out.name] = [float(v) for v in out.scale * (u @ np.asarray(out.direction))]
    return history


def solve(model: ExudynModel, reference=None) -> ExudynRun:
    """Run exudyn's static solver through the model's load factors; track the outputs per converged step.

    A failing solver (``exu.SolverError``) gives ``converged = False`` and the history up to the last
    converged step. ``reference`` (a flexbody ``Reference``) adds the errors against it.
    """
    settings = _settings(model)
    converged, message, wall, cpu = _run_solver(
        lambda: model.mbs.SolveStatic(settings, storeSolver=True, showHints=False))
    solver = model.mbs.sys.get("staticSolver")
    iterations = int(solver.it.newtonStepsCount) if solver is not None else 0
    history = _history(model)
    if converged and (not history["load_factor"] or abs(history["load_factor"][-1] - model.load_factors[-1]) > 1e-9):
        converged, message = False, "exudyn stopped before the last load factor"
    errors = compare_with_reference(history, reference) if reference is not None else []
    return ExudynRun(model, history, converged, message, iterations, wall, cpu, errors)


def run_reference(scene_name: str, params: dict | None = None) -> ExudynRun:
    """Build the flexbody scene (for its physics) and run its exudyn reference model."""
    scene_params, options = split_options(params)
    scene = build(scene_name, **scene_params)
    return solve(build_model(scene, options), scene.reference)


# ----------------------------------------------------------------------------------------------------------
# dynamics: the spinning plate with the ANCF plate
# ----------------------------------------------------------------------------------------------------------

#: dynamic scenes with an exudyn model (``compare`` runs them through ``_compare_dynamic``)
DYNAMIC_SCENES = ("spinning_plate",)


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
    sc, mbs = _new_system()
    mesh = _plate_mesh(mbs, scene, [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]], nx, ny)
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
        idx = sorted({int(i) for n in out.nodes for i in _nearest(positions, x[n], size)})
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
    nx0, ny0 = _default_mesh(scene, kind)
    nx, ny = int(options.get("nx", nx0)), int(options.get("ny", ny0))
    if nx < 1 or ny < 1:
        raise ValueError(f"exudyn_nx and exudyn_ny must be >= 1, got {nx} and {ny}")
    t_end = float(a.end_time if end_time is None else end_time)
    h = t_end / a.n_steps if time_step is None else float(time_step)
    if not (h > 0 and t_end > 0):
        raise ValueError(f"time step and end time must be positive, got {h!r} and {t_end!r}")
    h = t_end / max(1, int(math.ceil(t_end / h - 1e-9)))
    t0 = time.perf_counter()
    sc, mbs, raw_outputs, description, elements, v0, w, element_numbers = spinning_plate_model(scene, nx, ny)
    model = ExudynDynamicModel(scene.name, kind, description, sc, mbs, [], np.zeros(0), np.zeros((0, 0)),
                               np.zeros((0, 0)), w, v0, h, t_end, float(a.rho_inf), elements,
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
    with _quiet_console():
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
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = int(round(model.end_time / model.time_step))
    ti.endTime = model.end_time
    ti.verboseMode = 0
    if integrator == "generalized_alpha":
        ti.generalizedAlpha.spectralRadius = model.rho_inf
    else:
        ti.explicit.computeEndOfStepAccelerations = False
    s.solution.file.write = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
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
    with _quiet_console():
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

    Returns the run dict (``_compare_dynamic`` documents the keys). A failing solver
    (``exu.SolverError``) gives converged = False and the records up to the failure.
    """
    if integrator not in ("generalized_alpha", "rk4"):
        raise ValueError(f"integrator must be 'generalized_alpha' or 'rk4', got {integrator!r}")
    mbs = model.mbs
    model.records.clear()
    settings = _dynamic_settings(model, integrator)
    solver_type = exu.DynamicSolverType.GeneralizedAlpha if integrator == "generalized_alpha" else \
        exu.DynamicSolverType.RK44
    converged, message, wall, cpu = _run_solver(
        lambda: mbs.SolveDynamic(settings, solverType=solver_type, storeSolver=True, showHints=False))
    sd = mbs.systemData
    t_reached = float(sd.GetTime())
    if converged:
        if abs(t_reached - model.end_time) > 1e-9 * max(1.0, model.end_time):
            converged, message = False, f"exudyn stopped at t = {t_reached:.6g}"
        elif not model.records or model.end_time > model.records[-1][0] + 0.5 * model.time_step:
            model.records.append((model.end_time, np.array(sd.GetODE2Coordinates()),
                                  np.array(sd.GetODE2Coordinates_t())))
    solver = mbs.sys.get("dynamicSolver")
    iterations = int(solver.it.newtonStepsCount) if solver is not None else 0
    jacobians = int(solver.it.newtonJacobiCount) if solver is not None else 0
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
        "energy": _energy_summary(t_strain, strain, total, e_scale),
    }


def _energy_summary(t, strain, total, scale) -> dict:
    t, strain, total = np.asarray(t, float), np.asarray(strain, float), np.asarray(total, float)
    later = t > 0
    drift = float(np.abs(total - total[0]).max()) if total.size else float("nan")
    return {"strain": {"max": float(strain.max()) if strain.size else float("nan"),
                       "min": float(strain[later].min()) if later.any() else float("nan"),
                       "mean": float(strain[later].mean()) if later.any() else float("nan"),
                       "final": float(strain[-1]) if strain.size else float("nan")},
            "total": {"initial": float(total[0]) if total.size else float("nan"), "max_drift": drift,
                      "max_rel_drift": drift / scale if scale and scale > 0 else float("nan")}}


def _flexbody_dynamic_dict(scene: Scene, summary, build_time: float, cpu_time: float) -> dict:
    d = summary.as_dict()
    eh = d["energy_history"]
    e = d["energy"]
    scale = float(np.max(np.asarray(eh["kinetic"]) + np.asarray(eh["strain"]) + np.abs(eh["gravity"])))
    energy = _energy_summary(eh["time"], eh["strain"], eh["total"], scale)
    energy["total"]["max_rel_drift"] = e["total"]["max_rel_drift"]
    L = np.asarray(summary.energies["angular_momentum"], float)
    angular = dict(d["momentum"]["angular"], history=L.tolist())
    return {
        "model": f"flexbody six-node SE(3) shell ({scene.model.body.element_name}), "
                 f"{summary.elements} triangles, Lie-group generalized-alpha ({d['policy']})",
        "dofs": d["dofs"], "elements": d["elements"], "steps": d["steps"], "time_step": d["time_step"],
        "end_time": d["end_time"], "rho_inf": d["rho_inf"], "newton_iterations": d["newton_iterations"],
        "tangent_updates": d["tangent_updates"], "factorizations": d["factorizations"],
        "converged": d["converged"], "message": d["message"], "time": d["time"], "build_time_s": build_time,
        "wall_time_s": d["wall_time_s"], "cpu_time_s": cpu_time, "outputs": d["outputs"],
        "history": {k: [float(x) for x in v] for k, v in summary.history.items()},
        "energy_history": {k: eh[k] for k in ("time", "kinetic", "strain", "total")},
        "momentum": {"angular": angular}, "energy": energy,
    }


def _history_difference(a: dict, b: dict, name: str, t_max: float | None = None) -> tuple[float, float]:
    """(max |b - a|, that / max |value| of both) over a's times inside both histories (b interpolated)."""
    ta, tb = np.asarray(a["time"], float), np.asarray(b["time"], float)
    if ta.size == 0 or tb.size == 0:
        return float("nan"), float("nan")
    hi = min(ta[-1], tb[-1]) if t_max is None else min(ta[-1], tb[-1], t_max)
    keep = ta <= hi + 1e-12
    va = np.asarray(a[name], float)[keep]
    vb = np.interp(ta[keep], tb, np.asarray(b[name], float))
    diff = float(np.abs(vb - va).max())
    scale = max(float(np.abs(va).max()), float(np.abs(vb).max())) or 1.0
    return diff, diff / scale


def _samples(runs: dict[str, dict], t_end: float, n: int = 11) -> dict:
    """The strain (potential) energy of each run at n equidistant times (linear interpolation)."""
    times = np.linspace(0.0, t_end, n)
    out = {"time": times.tolist()}
    for key, run in runs.items():
        if run is None:
            continue
        eh = run["energy_history"]
        t = np.asarray(eh["time"], float)
        vals = np.interp(times, t, eh["strain"]) if t.size else np.full(n, np.nan)
        out[key] = [float(v) if tt <= t[-1] + 1e-12 else None for v, tt in zip(vals, times)] if t.size else \
            [None] * n
    return out


def _compare_dynamic(scene_name: str, scene_params: dict, options: dict) -> dict:
    """``compare`` for a dynamic scene (see ``compare``)."""
    for key in ("steps", "rtol"):
        if key in options:
            raise ValueError(f"exudyn option {_OPTION_PREFIX + key} is for static scenes only")
    reference = options.get("reference")
    if reference is not None and str(reference).lower() not in ("0", "false", "no", "1", "true", "rk4", "yes"):
        raise ValueError(f"exudyn_reference must be rk4 (or 1/true, 0/false), got {reference!r}")
    use_reference = reference is not None and str(reference).lower() not in ("0", "false", "no")
    t0 = time.perf_counter()
    scene = build(scene_name, **scene_params)
    fb_build = time.perf_counter() - t0
    model = build_dynamic_model(scene, options)
    scene.model.warm_up()                          # numba compilation is neither wall nor CPU time of the run
    c0 = time.process_time()
    summary = run_scene(scene)
    fb = _flexbody_dynamic_dict(scene, summary, fb_build, time.process_time() - c0)
    ex = solve_dynamic(model, energy_every=int(options.get("energy_every", 1)))
    ref = None
    if use_reference:
        ref_model = build_dynamic_model(scene, options, time_step=float(options.get("reference_dt", 1e-4)),
                                        end_time=float(options.get("reference_end_time", model.end_time)))
        ref_model.record_every = max(1, int(round(model.time_step / ref_model.time_step)))
        ref = solve_dynamic(ref_model, "rk4", energy_every=int(options.get("energy_every", 1)))
    rows = []
    for out in scene.outputs:
        diff, rel = _history_difference(fb["history"], ex["history"], out.name)
        row = {"name": out.name, "flexbody": fb["outputs"].get(out.name), "exudyn": ex["outputs"].get(out.name),
               "max_history_difference": diff, "rel_history_difference": rel}
        a, b = row["flexbody"], row["exudyn"]
        row["difference"] = None if a is None or b is None else b - a
        if ref is not None and ref["history"]["time"]:
            t_ref = ref["history"]["time"][-1]
            row["flexbody_vs_rk4"] = _history_difference(ref["history"], fb["history"], out.name, t_ref)[1]
            row["exudyn_vs_rk4"] = _history_difference(ref["history"], ex["history"], out.name, t_ref)[1]
        rows.append(row)
    ratio = ex["wall_time_s"] / fb["wall_time_s"] if fb["wall_time_s"] > 0 else None
    cpu_ratio = ex["cpu_time_s"] / fb["cpu_time_s"] if fb["cpu_time_s"] > 0 else None
    ok = bool(fb["converged"] and ex["converged"] and (ref is None or ref["converged"]))
    return {
        "scene": scene_name, "kind": "dynamic", "parameters": dict(scene.parameters), "exudyn_options": options,
        "flexbody": fb, "exudyn": ex, "reference": ref, "outputs": rows,
        "strain_energy_samples": _samples({"flexbody": fb, "exudyn": ex, "reference": ref}, model.end_time),
        "reference_source": "exudyn RK44 on the same ANCF model" if ref is not None else None,
        "wall_time_ratio": ratio, "cpu_time_ratio": cpu_ratio, "ok": ok,
    }


def dynamic_table_lines(result: dict) -> list[str]:
    """The printed table of a dynamic comparison."""
    runs = [("flexbody", result["flexbody"]), ("exudyn", result["exudyn"])]
    if result.get("reference") is not None:
        runs.append(("exudyn RK4", result["reference"]))
    lines = [f"scene            {result['scene']} (dynamic)",
             f"parameters       {result['parameters']}" + (f"  exudyn {result['exudyn_options']}"
                                                            if result["exudyn_options"] else "")]
    lines += [f"{label:17}{run['model']}" for label, run in runs]
    lines.append("")
    w = 14
    lines.append(f"{'':28}" + "".join(f"{label:>{w}}" for label, _ in runs))

    def row(label, get, spec):
        vals = []
        for _, run in runs:
            try:
                vals.append(_fmt(get(run), spec))
            except (KeyError, TypeError, IndexError):
                vals.append("-")
        lines.append(f"{label:28}" + "".join(f"{v:>{w}}" for v in vals))

    row("DoFs (coordinates)", lambda r: r["dofs"], "d")
    row("time step", lambda r: r["time_step"], ".3g")
    row("steps", lambda r: r["steps"], "d")
    row("end time", lambda r: r["time"], ".4g")
    row("Newton iterations", lambda r: r["newton_iterations"], "d")
    row("build time [s]", lambda r: r["build_time_s"], ".3f")
    row("solve time [s]", lambda r: r["wall_time_s"], ".3f")
    row("solve CPU time [s]", lambda r: r["cpu_time_s"], ".3f")
    row("L_z(0)", lambda r: r["momentum"]["angular"]["initial"][2], ".6g")
    row("L_z(end)", lambda r: r["momentum"]["angular"]["final"][2], ".6g")
    row("angular momentum drift", lambda r: r["momentum"]["angular"]["max_rel_drift"], ".2e")
    row("strain energy max", lambda r: r["energy"]["strain"]["max"], ".5g")
    row("strain energy min (t > 0)", lambda r: r["energy"]["strain"]["min"], ".5g")
    row("strain energy mean (t > 0)", lambda r: r["energy"]["strain"]["mean"], ".5g")
    row("total energy drift", lambda r: r["energy"]["total"]["max_rel_drift"], ".2e")
    row("converged", lambda r: str(r["converged"]), "")
    lines.append("")
    samples = result["strain_energy_samples"]
    lines.append("strain (potential) energy history")
    keys = [k for k in ("flexbody", "exudyn", "reference") if k in samples]
    lines.append(f"{'t':>8}" + "".join(f"{k if k != 'reference' else 'exudyn RK4':>{w}}" for k in keys))
    for i, t in enumerate(samples["time"]):
        lines.append(f"{t:8.3f}" + "".join(f"{_fmt(samples[k][i]):>{w}}" for k in keys))
    lines.append("")
    head = f"{'output':14}{'flexbody':>12}{'exudyn':>12}{'difference':>12}{'max hist. diff':>16}{'rel.':>10}"
    has_ref = result.get("reference") is not None
    if has_ref:
        head += f"{'fb vs RK4':>11}{'ex vs RK4':>11}"
    lines.append(head)
    for r in result["outputs"]:
        line = (f"{r['name']:14}{_fmt(r['flexbody']):>12}{_fmt(r['exudyn']):>12}{_fmt(r['difference'], '.3e'):>12}"
                f"{_fmt(r['max_history_difference'], '.3e'):>16}{_fmt(r['rel_history_difference'], '.2e'):>10}")
        if has_ref:
            line += f"{_fmt(r.get('flexbody_vs_rk4'), '.2e'):>11}{_fmt(r.get('exudyn_vs_rk4'), '.2e'):>11}"
        lines.append(line)
    lines.append("(max hist. diff: over the recorded times, exudyn interpolated; rel.: / max |value| of both)")
    for label, run in runs:
        if not run["converged"]:
            lines.append(f"{label}: {run['message']}")
    return lines


# ----------------------------------------------------------------------------------------------------------
# comparison
# ----------------------------------------------------------------------------------------------------------

def _flexbody_dict(scene: Scene, summary, build_time: float, cpu_time: float) -> dict:
    d = summary.as_dict()
    return {
        "model": f"flexbody six-node SE(3) shell ({scene.model.body.element_name}), "
                 f"{summary.elements} triangles",
        "dofs": d["dofs"], "elements": d["elements"], "steps": d["steps"],
        "newton_iterations": d["newton_iterations"], "converged": d["converged"], "message": d["message"],
        "load_factor": d["load_factor"], "build_time_s": build_time, "wall_time_s": d["wall_time_s"],
        "cpu_time_s": cpu_time,
        "outputs": d["outputs"], "errors": d["errors"], "max_rel_error": d["max_rel_error"],
        "history": {k: [float(x) for x in v] for k, v in summary.history.items()},
    }


def _max_error(errors: list[dict], name: str) -> float | None:
    vals = [e["rel_error"] for e in errors if e["quantity"] == name]
    return max(vals) if vals else None


def _output_rows(scene: Scene, fb: dict, ex: dict) -> list[dict]:
    """One row per output; rel_difference is |difference| / the largest |value| either code reached."""
    rows = []
    for out in scene.outputs:
        a, b = fb["outputs"].get(out.name), ex["outputs"].get(out.name)
        ref = None
        if scene.reference is not None and out.name in scene.reference.values:
            ref = float(np.asarray(scene.reference.values[out.name])[-1])
        diff = None if a is None or b is None else b - a
        scale = max([abs(v) for v in fb["history"][out.name] + ex["history"][out.name]], default=0.0) or 1.0
        rows.append({"name": out.name, "flexbody": a, "exudyn": b, "difference": diff,
                     "rel_difference": None if diff is None else abs(diff) / scale, "reference": ref,
                     "flexbody_ref_error": _max_error(fb["errors"], out.name),
                     "exudyn_ref_error": _max_error(ex["errors"], out.name)})
    return rows


def compare(scene_name: str, params: dict | None = None) -> dict:
    """Run a built-in scene in flexbody and its exudyn reference model; report both side by side.

    Parameters
    ----------
    scene_name : a scene of ``MODELS``
    params : flexbody scene parameters, plus exudyn options prefixed ``exudyn_`` (module docstring)

    Returns
    -------
    dict with keys
        "scene", "parameters" (flexbody), "exudyn_options";
        "flexbody" and "exudyn": model, dofs, elements, steps, newton_iterations, converged, message,
        load_factor (last reached), build_time_s, wall_time_s, cpu_time_s (process CPU time of the solve,
        robust on a loaded machine), outputs (final values), errors (per
        tabulated load level, ``compare_with_reference``), max_rel_error, history (load_factor and every
        output per converged step); exudyn adds kind, coordinates, constraints, newton_rtol;
        "outputs": one row per tracked output: name, flexbody, exudyn, difference (exudyn - flexbody),
        rel_difference (|difference| / the largest |value| of that output in either history), reference
        (final tabulated value or None), flexbody_ref_error and exudyn_ref_error (max relative error
        over the table, or None);
        "reference_source", "wall_time_ratio" and "cpu_time_ratio" (exudyn / flexbody, solve only),
        "ok" (both converged).

    A dynamic scene (``DYNAMIC_SCENES``: ``spinning_plate``) returns instead the keys
        "scene", "kind" ("dynamic"), "parameters", "exudyn_options";
        "flexbody" and "exudyn" (and "reference", the optional RK4 run of the same exudyn model with
        ``exudyn_reference=rk4``, ``exudyn_reference_dt`` (1e-4), ``exudyn_reference_end_time``, else
        None): model, dofs, elements, steps, time_step, end_time, rho_inf, newton_iterations, converged,
        message, time (reached), build_time_s, wall_time_s, cpu_time_s, outputs (final), history (time and
        every output per recorded step), energy_history (time, kinetic, strain, total),
        momentum["angular"] (initial, final, max_drift, max_rel_drift = max_t |L(t) - L(0)| / max_t |L|,
        history; about the origin), energy (strain max / min / mean over t > 0, final; total initial,
        max_drift, max_rel_drift); flexbody adds tangent_updates and factorizations, exudyn
        jacobians, energy_eval_time_s (the strain-energy post-processing, not in the solve time);
        "outputs": per output name, flexbody, exudyn, difference (final), max_history_difference and
        rel_history_difference (over the recorded times, / max |value| of both), with a reference also
        flexbody_vs_rk4 and exudyn_vs_rk4 (relative history differences over the reference window);
        "strain_energy_samples": time and the strain energy of each run at 11 equidistant times;
        "reference_source", "wall_time_ratio", "cpu_time_ratio", "ok".
    The exudyn option ``exudyn_energy_every`` evaluates exudyn's strain energy at every k-th recorded step.
    """
    scene_params, options = split_options(params)
    model_kind(scene_name, options)                # fail before the (possibly long) flexbody build
    if scene_name in DYNAMIC_SCENES:
        return _compare_dynamic(scene_name, scene_params, options)
    dynamic_only = sorted(set(options) & set(_DYNAMIC_OPTIONS))
    if dynamic_only:
        raise ValueError(f"exudyn options {', '.join(_OPTION_PREFIX + o for o in dynamic_only)} are for dynamic "
                         f"scenes ({', '.join(DYNAMIC_SCENES)}) only")
    t0 = time.perf_counter()
    scene = build(scene_name, **scene_params)
    fb_build = time.perf_counter() - t0
    model = build_model(scene, options)            # before the flexbody run: reads the unloaded scene
    c0 = time.process_time()
    summary = run_scene(scene)
    fb = _flexbody_dict(scene, summary, fb_build, time.process_time() - c0)
    ex = solve(model, scene.reference).as_dict()
    ratio = ex["wall_time_s"] / fb["wall_time_s"] if fb["wall_time_s"] > 0 else None
    cpu_ratio = ex["cpu_time_s"] / fb["cpu_time_s"] if fb["cpu_time_s"] > 0 else None
    return {
        "scene": scene_name, "parameters": dict(scene.parameters), "exudyn_options": options,
        "flexbody": fb, "exudyn": ex, "outputs": _output_rows(scene, fb, ex),
        "reference_source": scene.reference.source if scene.reference is not None else None,
        "wall_time_ratio": ratio, "cpu_time_ratio": cpu_ratio, "ok": bool(fb["converged"] and ex["converged"]),
    }


def _fmt(value, spec: str = ".5g") -> str:
    if value is None:
        return "-"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan"
    return format(value, spec)


def table_lines(result: dict) -> list[str]:
    """The printed comparison table (the same content as the JSON file)."""
    if result.get("kind") == "dynamic":
        return dynamic_table_lines(result)
    fb, ex = result["flexbody"], result["exudyn"]
    lines = [f"scene            {result['scene']}",
             f"parameters       {result['parameters']}" + (f"  exudyn {result['exudyn_options']}"
                                                            if result["exudyn_options"] else ""),
             f"flexbody         {fb['model']}",
             f"exudyn           {ex['model']}",
             ""]
    w = 14
    lines.append(f"{'':22}{'flexbody':>{w}}{'exudyn':>{w}}")
    for label, key, spec in [("DoFs", "dofs", "d"), ("load steps", "steps", "d"),
                             ("Newton iterations", "newton_iterations", "d"), ("build time [s]", "build_time_s", ".3f"),
                             ("solve time [s]", "wall_time_s", ".3f"), ("solve CPU time [s]", "cpu_time_s", ".3f"),
                             ("last load factor", "load_factor", ".4g"),
                             ("max ref. error", "max_rel_error", ".2e")]:
        lines.append(f"{label:22}{_fmt(fb[key], spec):>{w}}{_fmt(ex[key], spec):>{w}}")
    lines.append(f"{'converged':22}{str(fb['converged']):>{w}}{str(ex['converged']):>{w}}")
    lines.append("")
    lines.append(f"{'output':16}{'flexbody':>12}{'exudyn':>12}{'difference':>12}{'rel.diff':>10}"
                 f"{'reference':>11}{'err flexbody':>14}{'err exudyn':>12}")
    for r in result["outputs"]:
        lines.append(f"{r['name']:16}{_fmt(r['flexbody']):>12}{_fmt(r['exudyn']):>12}{_fmt(r['difference'], '.3e'):>12}"
                     f"{_fmt(r['rel_difference'], '.2e'):>10}{_fmt(r['reference']):>11}"
                     f"{_fmt(r['flexbody_ref_error'], '.2e'):>14}{_fmt(r['exudyn_ref_error'], '.2e'):>12}")
    if result["reference_source"]:
        lines.append(f"reference: {result['reference_source']} (errors: max over the table, relative to max |ref|)")
    if not fb["converged"]:
        lines.append(f"flexbody: {fb['message']}")
    if not ex["converged"]:
        lines.append(f"exudyn: {ex['message']}")
    return lines


def _json_ready(value):
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def compare_cli(scene_name: str, params: dict, json_path: str | None, quiet: bool) -> int:
    """``flexbody compare SCENE --with exudyn``: print the table, write the JSON; 0 on success, 2 on failure.

    Failure: an unknown scene or option, a model that cannot be built, an unwritable JSON file, or a run
    that did not converge (the table and JSON are still written then). The failure is one line on stderr.
    """
    try:
        result = compare(scene_name, params)
    except (KeyError, ValueError, TypeError, exu.SolverError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"flexbody compare: error: {msg}", file=sys.stderr)
        return 2
    if not quiet:
        print("\n".join(table_lines(result)))
    if json_path:
        try:
            with open(json_path, "w", encoding="utf-8") as fh:
                json.dump(_json_ready(result), fh, indent=2)
        except OSError as exc:
            print(f"flexbody compare: error: cannot write {json_path!r}: {exc.strerror or exc}", file=sys.stderr)
            return 2
        if not quiet:
            print(f"written          {json_path}")
    if not result["ok"]:
        failed = [f"{k}: {result[k]['message']}" for k in ("flexbody", "exudyn", "reference")
                  if result.get(k) is not None and not result[k]["converged"]]
        print(f"flexbody compare: error: run did not converge ({'; '.join(failed)})", file=sys.stderr)
        return 2
    return 0


# ----------------------------------------------------------------------------------------------------------
# our shell inside an exudyn system
# ----------------------------------------------------------------------------------------------------------

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
    t_grid = np.linspace(0.0, 1.0, len(lf) + 1)
    lam = np.concatenate([[0.0], lf])
    sc, mbs = _new_system()
    shell = ShellODE2(mbs, scene.model, lambda t: float(np.interp(t, t_grid, lam)))
    if constraints is not None:
        constraints(mbs, shell)
    mbs.SetPreStepUserFunction(shell.commit)
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.staticSolver.numberOfLoadSteps = len(lf)
    s.staticSolver.verboseMode = 0
    s.staticSolver.newton.relativeTolerance = rtol
    s.solution.file.write = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    converged, message, wall, _ = _run_solver(lambda: mbs.SolveStatic(s, storeSolver=True, showHints=False))
    q = np.asarray(mbs.systemData.GetODE2Coordinates())[mbs.systemData.GetObjectLTGODE2(shell.object)]
    state = shell.state(q)
    solver = mbs.sys.get("staticSolver")
    return {"converged": converged, "message": message,
            "outputs": {o.name: o.value(scene.model, state) for o in scene.outputs},
            "newton_iterations": int(solver.it.newtonStepsCount) if solver is not None else 0,
            "wall_time_s": wall, "calls": dict(shell.calls), "dofs": scene.model.n_dof,
            "load_factor": float(np.interp(mbs.systemData.GetTime(), t_grid, lam))}


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

    _sc, mbs = _new_system()                       # the container keeps the system alive
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
    s = exu.SimulationSettings()
    steps = round(a.end_time / a.time_step)
    s.timeIntegration.numberOfSteps = steps
    s.timeIntegration.endTime = a.end_time
    s.timeIntegration.generalizedAlpha.spectralRadius = a.rho_inf
    s.timeIntegration.verboseMode = 0
    s.timeIntegration.newton.relativeTolerance = rtol
    s.timeIntegration.adaptiveStep = adaptive_step
    s.solution.file.write = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    converged, message, wall, _ = _run_solver(
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
