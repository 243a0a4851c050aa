"""exudyn reference models of the built-in static scenes, and their static runs.

exudyn has no triangular or shear-deformable shell. The matching models used here are

- the strips (``cantilever_end_moment``, ``cantilever_end_shear``): ``ObjectBeamGeometricallyExact``
  (SE(3) beam, Euler-parameter nodes, the default), ``ObjectBeamGeometricallyExact2D`` and
  ``ObjectANCFThinPlate`` (four-node Kirchhoff plate, ``exudyn.shells.ShellMesh``);
- ``slit_annular_plate``, ``pullout_cylinder`` and ``hemisphere``: ``ObjectANCFThinPlate`` on a mapped
  rectangle (``ShellMesh(surfaceMap=...)``), symmetry planes as coordinate constraints on the nodal
  position and slope coordinates.

The physics is read from the flexbody scene itself: material (E, nu, h), geometry (from the mesh nodes),
total loads (from the scene's nodal loads) and the load factors of the analysis; tracked outputs are the
scene's outputs, evaluated at the exudyn node nearest to the flexbody output node (the mean over nodes
at equal distance, e.g. the two tip corners of a one-element-wide plate strip).

Options (``build_model``): model ("beam3d", "beam2d" or "plate" for the strips, "plate" otherwise), nx, ny
(element counts), steps (uniform load steps, used where the flexbody scene runs arc-length), rtol (exudyn's
relative Newton tolerance).

Facts about exudyn that shape this module: its Newton tolerance is relative to a residual that it re-bases
after the first iteration (``adaptInitialResidual``), so beams need a tight tolerance (1e-10; 1e-8 left a
6e-3 error in the tip displacement of the strip after a 0.1 M_max step); the ANCF plate needs
``useReducedOrderIntegration=1`` (speed, membrane locking); the hemisphere was reported to stall near a
relative tolerance of 1e-6 (here the 20 x 20 model converged at 1e-6 as well) and runs at 1e-5.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
import time

import numpy as np

import exudyn as exu
import exudyn.beams as beams
import exudyn.itemInterface as eii
import exudyn.shells as shells

from flexbody.adapters.exudyn.options import element_counts, model_kind, split_options
from flexbody.adapters.exudyn.system import (material, nearest, new_system, newton_counts, plate_mesh,
                                             pseudo_time_load_factor, run_solver, static_settings)
from flexbody.loads import NodalLoad
from flexbody.scenes import build
from flexbody.scenes.registry import SCENES
from flexbody.scenes.scene import DynamicAnalysis, Scene, compare_with_reference

#: exudyn relative Newton tolerance per model kind and scene (see the module docstring)
_RTOL = {"beam3d": 1e-10, "beam2d": 1e-10, "plate": 1e-8}


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

def _dead_nodal_loads(scene: Scene) -> list[NodalLoad]:
    """The scene's loads, checked to be dead nodal loads (the only ones with an exudyn counterpart here)."""
    for load in scene.model.loads:
        if not isinstance(load, NodalLoad) or load.follower:
            raise ValueError(f"scene {scene.name!r}: only dead nodal loads have an exudyn counterpart")
    return list(scene.model.loads)


def _total_load(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Sum of all dead nodal forces and moments of the scene (at load factor 1)."""
    force, moment = np.zeros(3), np.zeros(3)
    for load in _dead_nodal_loads(scene):
        force += len(load.nodes) * np.asarray(load.force, float)
        moment += len(load.nodes) * np.asarray(load.moment, float)
    return force, moment


def _point_loads(scene: Scene) -> list[tuple[np.ndarray, np.ndarray]]:
    """(reference position, force) of every loaded node of a scene with point forces only."""
    nodes = scene.model.body.mesh.nodes
    out = []
    for load in _dead_nodal_loads(scene):
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


# ----------------------------------------------------------------------------------------------------------
# exudyn building blocks
# ----------------------------------------------------------------------------------------------------------

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
        idx = nearest(positions, mesh.nodes[out.node], size)
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
    lam = pseudo_time_load_factor(load_factors)

    def scaled(mbs_, t, load):
        return (float(lam(t)) * np.asarray(load)).tolist()

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
    E, nu, h, rho, k = material(scene)
    return _Strip(float(x[:, 0].max()), float(x[:, 1].max()), E, nu, h, rho, k, force, moment)


# a rotation taking the strip's bending plane x-z to exudyn's 2D plane x-y: e_x -> e_x, e_y -> -e_z, e_z -> e_y
_XZ_TO_XY = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])


def beam2d_strip(scene: Scene, n_elements: int) -> tuple:
    """The strip as ``ObjectBeamGeometricallyExact2D`` elements (x-z plane mapped to exudyn's x-y plane)."""
    s = _strip(scene)
    sc, mbs = new_system()
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
    sc, mbs = new_system()
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


def _plate_outputs(scene: Scene, mesh) -> list[TrackedOutput]:
    return _outputs_at(scene, mesh.nodeNumbers, np.array(mesh.nodeReferencePositions))


def plate_strip(scene: Scene, nx: int, ny: int) -> tuple:
    """The strip as ANCF thin plates (nx x ny), clamped at x = 0 (all nine nodal coordinates).

    The tip moment is applied as nodal torques (trapezoidal rule, ``shells.ApplyEdgeLoad``), the tip force
    as a consistent line load (``distributed=True``).
    """
    s = _strip(scene)
    sc, mbs = new_system()
    L, b = s.length, s.width
    mesh = plate_mesh(mbs, scene, [[0, 0, 0], [L, 0, 0], [L, b, 0], [0, b, 0]], nx, ny)
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
        idx = nearest(positions, x, size)
        if np.linalg.norm(positions[idx[0]] - x) > 1e-6 * size:
            raise ValueError(f"scene {scene.name!r}: no ANCF node at the load point {x}; choose another mesh")
        _point_force(mbs, mesh.nodeNumbers[idx[0]], force)


def slit_annular_plate_model(scene: Scene, nx: int, ny: int) -> tuple:
    """Slit annulus as ANCF plates on (r, theta) in [Ri, Ro] x [0, 2 pi]: nx radial x ny circumferential.

    Lip theta = 0 clamped (all nine nodal coordinates); the scene's total line force on the lip
    theta = 2 pi as a consistent line load.
    """
    x = scene.model.body.mesh.nodes
    r = np.linalg.norm(x[:, :2], axis=1)
    ri, ro = float(r.min()), float(r.max())
    force, _ = _total_load(scene)
    sc, mbs = new_system()
    sym = exu.symbolic

    def annulus(rr, t):
        return [rr * sym.cos(t), rr * sym.sin(t), 0.0]

    mesh = plate_mesh(mbs, scene, [[ri, 0, 0], [ro, 0, 0], [ro, 2 * math.pi, 0], [ri, 2 * math.pi, 0]], nx, ny,
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
    sc, mbs = new_system()
    sym = exu.symbolic

    def cylinder(a, z):
        return [radius * sym.cos(a), radius * sym.sin(a), z]

    mesh = plate_mesh(mbs, scene, [[0, 0, 0], [math.pi / 2, 0, 0], [math.pi / 2, half_length, 0],
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
    sc, mbs = new_system()
    sym = exu.symbolic

    def sphere(a, p):
        return [radius * sym.sin(p) * sym.cos(a), radius * sym.sin(p) * sym.sin(a), radius * sym.cos(p)]

    mesh = plate_mesh(mbs, scene, [[0, hole, 0], [math.pi / 2, hole, 0], [math.pi / 2, equator, 0],
                                    [0, equator, 0]], nx, ny, sphere)
    _apply_symmetry(mbs, mesh, [("left", 1), ("right", 0)])
    _constrain_to_ground(mbs, mesh.boundaryNodeNumbers["bottom"][0], [2])
    _apply_point_loads(mbs, scene, mesh)
    return (sc, mbs, _plate_outputs(scene, mesh),
            f"ObjectANCFThinPlate, {nx} x {ny} elements (azimuthal x meridional)", nx * ny)


# ----------------------------------------------------------------------------------------------------------
# building and running
# ----------------------------------------------------------------------------------------------------------

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
    nx, ny = element_counts(scene, kind, options)
    scene_rtol = SCENES[scene.name].exudyn_rtol
    rtol = float(options.get("rtol", _RTOL[kind] if scene_rtol is None else scene_rtol))
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
    """exudyn's static solver settings: one load step per load factor, adaptive, sensors at every step."""
    s = static_settings(len(model.load_factors), model.rtol)
    s.staticSolver.useLoadFactor = False          # the loads follow model.load_factors (user functions)
    s.staticSolver.adaptiveStep = True
    s.solution.sensors.writePeriod = 1e-12        # every converged load step
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
    lam = pseudo_time_load_factor(model.load_factors)(t[keep])
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
    converged, message, wall, cpu = run_solver(
        lambda: model.mbs.SolveStatic(settings, storeSolver=True, showHints=False))
    iterations, _ = newton_counts(model.mbs, "staticSolver")
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

