"""A user scene file: a simply supported rectangular plate in uniaxial compression (linear buckling).

    flexbody modes examples/compressed_plate_scene.py --buckling --set nx=16 --set ny=8

The plate [0, length] x [0, width] (thickness h, E, nu) is simply supported on its four edges (w = 0 and
the rotation along each edge fixed: "hard" support), held against in-plane rigid motion by u = 0 on x = 0
and v = 0 at the corner (0, 0), and compressed by a dead line load ``line_load`` (force per unit length) on
x = length: a uniform membrane force N_x = -line_load, free to expand sideways. The classical critical load
(Timoshenko & Gere, Theory of Elastic Stability, 9.2) is N_cr = k pi^2 D / width^2 with
D = E h^3 / (12 (1 - nu^2)) and k = min_m (m width / length + length / (m width))^2, m the half-waves
along x (k = 4 when length / width is an integer): the critical load factor is N_cr / line_load.
:func:`classical_factor` gives it.
"""

import math

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.loads import NodalLoad, nodal_vectors_from_edges
from flexbody.mesh import generators
from flexbody.scenes import Output, Scene, StaticAnalysis
from flexbody.shell.material import ShellMaterial


def classical_factor(length=2.0, width=1.0, thickness=0.01, young=1.0e6, poisson=0.3, line_load=1.0):
    """(N_cr / line_load, m): the classical critical load factor and its number of half-waves along x."""
    D = young * thickness**3 / (12 * (1 - poisson**2))
    k, m = min(((m * width / length + length / (m * width)) ** 2, m) for m in range(1, 50))
    return k * math.pi**2 * D / width**2 / line_load, m


def build(nx: int = 8, ny: int = 4, length: float = 2.0, width: float = 1.0, thickness: float = 0.01,
          young: float = 1.0e6, poisson: float = 0.3, line_load: float = 1.0, steps: int = 10) -> Scene:
    mesh = generators.strip(length, width, nx, ny)
    body = ShellBody(mesh, ShellMaterial(young, poisson, thickness))
    ns = mesh.node_sets
    edges = np.unique(np.concatenate([ns[k] for k in ("clamped", "tip", "bottom", "top")]))
    corner = int(np.argmin(np.linalg.norm(mesh.nodes, axis=1)))
    constraints = [Fix(edges, ("z",)), Fix(ns["clamped"], ("x",)), Fix([corner], ("y",)),
                   Fix(np.concatenate([ns["clamped"], ns["tip"]]), ("r1",)),      # frames: t1 = x, t2 = y
                   Fix(np.concatenate([ns["bottom"], ns["top"]]), ("r2",))]
    F = nodal_vectors_from_edges(mesh.nodes, mesh.edge_sets["tip"], np.array([-line_load, 0.0, 0.0]),
                                 mesh.n_nodes)
    loads = [NodalLoad([i], force=F[i]) for i in np.flatnonzero(np.any(F != 0, axis=1))]
    model = Model(body, constraints, loads)
    centre = mesh.nearest_node([length / 2, width / 2, 0.0])
    return Scene("compressed_plate", "simply supported plate in uniaxial compression", model,
                 StaticAnalysis("load_control", tuple(np.linspace(0, 1, steps + 1)[1:])),
                 [Output("w_centre", centre, (0.0, 0.0, 1.0))],
                 parameters=dict(nx=nx, ny=ny, length=length, width=width, thickness=thickness, young=young,
                                 poisson=poisson, line_load=line_load, steps=steps))
