"""A user scene file: a cylinder (radius R, length L, thickness h) in uniform axial compression.

    flexbody modes examples/compressed_cylinder_scene.py --buckling --set n_circ=48 --set n_axial=24

Both ends are held radially and circumferentially (x, y fixed; the bottom also axially) and the top carries
a dead axial line load ``line_load`` (force per unit length of the circumference). With nu = 0 the
pre-buckling state is a uniform membrane compression (no Poisson bulge at the held ends). The classical
critical stress (Timoshenko & Gere, Theory of Elastic Stability, 11.4) is
sigma_cr = E h / (R sqrt(3 (1 - nu^2))), i.e. the factor E h^2 / (R sqrt(3 (1 - nu^2))) / line_load
(:func:`classical_factor`); it is reached by many modes at once (the axisymmetric one and Koiter's circle
of checkerboard modes). ``sectors`` > 1 models one sector of 2 pi / sectors between symmetry planes: the
modes symmetric about them, the axisymmetric one included.
"""

import math

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import FixDirection, Symmetry
from flexbody.loads import NodalLoad, nodal_vectors_from_edges
from flexbody.mesh import generators
from flexbody.scenes import Output, Scene, StaticAnalysis
from flexbody.shell.material import ShellMaterial


def classical_factor(radius=1.0, thickness=0.02, young=1.0e6, poisson=0.0, line_load=1.0) -> float:
    """sigma_cr h / line_load with sigma_cr = E h / (R sqrt(3 (1 - nu^2)))."""
    return young * thickness**2 / (radius * math.sqrt(3 * (1 - poisson**2))) / line_load


def build(n_circ: int = 48, n_axial: int = 24, radius: float = 1.0, length: float = 2.0, thickness: float = 0.02,
          young: float = 1.0e6, poisson: float = 0.0, line_load: float = 1.0, sectors: int = 1,
          steps: int = 10) -> Scene:
    angle = 2 * math.pi / sectors
    mesh = generators.cylinder(radius, length, n_circ, n_axial, angle=angle)
    body = ShellBody(mesh, ShellMaterial(young, poisson, thickness))
    ns = mesh.node_sets
    constraints, on_planes = [], np.array([], dtype=int)
    if sectors > 1:
        constraints += [Symmetry(ns["start"], (0.0, 1.0, 0.0)),
                        Symmetry(ns["end"], (-math.sin(angle), math.cos(angle), 0.0))]
        on_planes = np.concatenate([ns["start"], ns["end"]])
    for end, axial in (("bottom", True), ("top", False)):
        for i in ns[end]:                       # radial and circumferential (the planes hold the latter there)
            a = math.atan2(mesh.nodes[i, 1], mesh.nodes[i, 0])
            constraints.append(FixDirection([i], (math.cos(a), math.sin(a), 0.0)))
            if i not in on_planes:
                constraints.append(FixDirection([i], (-math.sin(a), math.cos(a), 0.0)))
            if axial:
                constraints.append(FixDirection([i], (0.0, 0.0, 1.0)))
    F = nodal_vectors_from_edges(mesh.nodes, mesh.edge_sets["top"], np.array([0.0, 0.0, -line_load]), mesh.n_nodes)
    loads = [NodalLoad([i], force=F[i]) for i in np.flatnonzero(np.any(F != 0, axis=1))]
    model = Model(body, constraints, loads)
    mid = mesh.nearest_node([radius, 0.0, length / 2])
    return Scene("compressed_cylinder", "cylinder in axial compression", model,
                 StaticAnalysis("load_control", tuple(np.linspace(0, 1, steps + 1)[1:])),
                 [Output("u_radial_mid", mid, (1.0, 0.0, 0.0))],
                 parameters=dict(n_circ=n_circ, n_axial=n_axial, radius=radius, length=length,
                                 thickness=thickness, young=young, poisson=poisson, line_load=line_load,
                                 sectors=sectors, steps=steps))
