"""The paper's static benchmarks (Sze, Liu & Lo 2004) as built-in scenes.

Each builder takes the mesh density and the physical parameters as keyword arguments, so that a user (or
``--set``) can refine the mesh or change the thickness without touching the package. Registered, with their
bench meshes and exudyn models, in :mod:`flexbody.scenes.registry`.
"""

from __future__ import annotations

import math

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix, Symmetry
from flexbody.loads import NodalLoad, nodal_loads, nodal_vectors_from_edges
from flexbody.mesh import generators
from flexbody.scenes.analysis import StaticAnalysis
from flexbody.scenes.reference import Reference, read_reference_csv
from flexbody.scenes.scene import Scene
from flexbody.scenes.tracked import Output
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import variant_from_key
from integrators.newton import NewtonSettings


def _loads_from_nodal(vectors: np.ndarray, moment: bool = False) -> list[NodalLoad]:
    return nodal_loads(vectors, "moment" if moment else "force")


def cantilever_end_moment(nx: int = 16, ny: int = 1, thickness: float = 0.01, steps: int = 20,
                          tying: bool = True, kernel: str = "numba", planar: bool = True,
                          diagonal: str = "alternate") -> Scene:
    """Strip L=12, b=1, E=1.2e6, nu=0 clamped at x=0, end moment up to M_max = 2 pi EI/L: a full circle.

    planar: keep the motion in the x-z plane (the centre line y = b/2 on a symmetry plane: no lateral
    translation, no twist), which is the benchmark's plane problem. Without it the dead end moment's planar
    path bifurcates near 0.8 M_max into an out-of-plane branch, which the asymmetric triangle mesh picks up
    (a genuine instability of a space-fixed end moment, see docs/benchmarks.md).
    """
    L, b, E = 12.0, 1.0, 1.2e6
    mesh = generators.strip(L, b, nx, ny, diagonal)
    mat = ShellMaterial(E, 0.0, thickness)
    body = ShellBody(mesh, mat, element=variant_from_key(tying), kernel=kernel)
    m_max = 2 * math.pi * E * b * thickness**3 / 12 / L
    moments = nodal_vectors_from_edges(mesh.nodes, mesh.edge_set("tip"), np.array([0.0, -m_max / b, 0.0]),
                                       mesh.n_nodes)
    constraints = [Fix(mesh.node_set("clamped"), "all")]
    if planar:
        centre = np.flatnonzero(np.abs(mesh.nodes[:, 1] - b / 2) < 1e-9 * b)
        constraints.append(Symmetry(np.setdiff1d(centre, mesh.node_set("clamped")), (0.0, 1.0, 0.0)))
    model = Model(body, constraints, _loads_from_nodal(moments, moment=True))
    tip = mesh.nearest_node([L, b / 2, 0.0])
    lf = np.linspace(0, 1, steps + 1)[1:]
    theta = 2 * math.pi * lf
    ref = Reference(lf, {"minus_U_tip": L * (1 - np.sin(theta) / theta), "W_tip": L * (1 - np.cos(theta)) / theta},
                    "exact elastica (nu = 0)")
    return Scene("cantilever_end_moment", "strip under end moment rolls into a full circle (exact elastica)",
                 model, StaticAnalysis("load_control", tuple(lf)),
                 [Output("minus_U_tip", tip, (-1.0, 0, 0)), Output("W_tip", tip, (0, 0, 1.0))], ref,
                 dict(nx=nx, ny=ny, thickness=thickness, steps=steps, tying=tying, planar=planar, diagonal=diagonal))


def cantilever_end_shear(nx: int = 16, ny: int = 1, thickness: float = 0.1, steps: int = 20,
                         tying: bool = True, kernel: str = "numba") -> Scene:
    """Strip L=10, b=1, h=0.1, E=1.2e6, nu=0, clamped, end shear force P_max = 4 (Sze 3.1)."""
    L, b, E = 10.0, 1.0, 1.2e6
    mesh = generators.strip(L, b, nx, ny)
    body = ShellBody(mesh, ShellMaterial(E, 0.0, thickness), element=variant_from_key(tying), kernel=kernel)
    p_max = 4.0 * (thickness / 0.1) ** 3
    forces = nodal_vectors_from_edges(mesh.nodes, mesh.edge_set("tip"), np.array([0, 0, p_max / b]), mesh.n_nodes)
    model = Model(body, [Fix(mesh.node_set("clamped"), "all")], _loads_from_nodal(forces))
    tip = mesh.nearest_node([L, b / 2, 0.0])
    cols, comments = read_reference_csv("ref_cantilever_end_shear.csv")
    ref = Reference(cols["load_factor_P_over_Pmax"], {"minus_U_tip": cols["minus_U_tip"], "W_tip": cols["W_tip"]},
                    comments[0])
    return Scene("cantilever_end_shear", "strip under end shear force (Sze et al. 2004, 3.1)", model,
                 StaticAnalysis("load_control", tuple(np.linspace(0, 1, steps + 1)[1:])),
                 [Output("minus_U_tip", tip, (-1.0, 0, 0)), Output("W_tip", tip, (0, 0, 1.0))], ref,
                 dict(nx=nx, ny=ny, thickness=thickness, steps=steps, tying=tying))


def slit_annular_plate(n_radial: int = 10, n_circ: int = 30, thickness: float = 0.03, steps: int = 20,
                       tying: bool = True, kernel: str = "numba") -> Scene:
    """Slit annular plate Ri=6, Ro=10, E=21e6, nu=0, line force q_max=0.8 on one slit edge (Sze 3.3)."""
    mesh = generators.slit_annulus(6.0, 10.0, n_radial, n_circ)
    body = ShellBody(mesh, ShellMaterial(21e6, 0.0, thickness), element=variant_from_key(tying), kernel=kernel)
    q = 0.8 * (thickness / 0.03) ** 3
    forces = nodal_vectors_from_edges(mesh.nodes, mesh.edge_set("loaded"), np.array([0, 0, q]), mesh.n_nodes)
    model = Model(body, [Fix(mesh.node_set("clamped"), "all")], _loads_from_nodal(forces))
    cols, comments = read_reference_csv("ref_slit_annular_plate.csv")
    ref = Reference(cols["load_factor_P_over_Pmax"], {"W_A": cols["W_A_inner_R6"], "W_B": cols["W_B_outer_R10"]},
                    comments[0])
    outs = [Output("W_A", int(mesh.node_set("A")[0]), (0, 0, 1.0)),
            Output("W_B", int(mesh.node_set("B")[0]), (0, 0, 1.0))]
    lf = sorted(set(np.round(np.linspace(0, 1, steps + 1)[1:], 12)) | set(cols["load_factor_P_over_Pmax"][1:]))
    return Scene("slit_annular_plate", "slit annular plate under a transverse line force (Sze et al. 2004, 3.3)",
                 model, StaticAnalysis("load_control", tuple(lf)), outs, ref,
                 dict(n_radial=n_radial, n_circ=n_circ, thickness=thickness, steps=steps, tying=tying))


def pullout_cylinder(n_circ: int = 12, n_axial: int = 8, thickness: float = 0.094, arc_increment: float = 0.02,
                     tying: bool = True, kernel: str = "numba") -> Scene:
    """Open cylinder pulled by two radial forces at mid-length, octant model (Sze 3.5): snap near 0.5 P_max."""
    R, L = 4.953, 10.35
    mesh = generators.cylinder(R, L / 2, n_circ, n_axial, angle=math.pi / 2)
    body = ShellBody(mesh, ShellMaterial(10.5e6, 0.3125, thickness), element=variant_from_key(tying), kernel=kernel)
    x = mesh.nodes
    on = lambda mask: np.flatnonzero(mask)
    tol = 1e-8 * R
    cons = [Symmetry(on(np.abs(x[:, 1]) < tol), (0, 1.0, 0)),
            Symmetry(on(np.abs(x[:, 0]) < tol), (1.0, 0, 0)),
            Symmetry(on(np.abs(x[:, 2]) < tol), (0, 0, 1.0))]
    a = mesh.nearest_node([R, 0, 0])
    model = Model(body, cons, [NodalLoad([a], force=[40000.0 / 4, 0, 0])])
    cols, comments = read_reference_csv("ref_pullout_cylinder.csv")
    ref = Reference(cols["load_factor_P_over_Pmax"],
                    {"W_A": cols["W_A"], "minus_U_B": cols["minus_U_B"], "minus_U_C": cols["minus_U_C"]}, comments[0])
    outs = [Output("W_A", a, (1.0, 0, 0)), Output("minus_U_B", mesh.nearest_node([0, R, 0]), (0, -1.0, 0)),
            Output("minus_U_C", mesh.nearest_node([0, R, L / 2]), (0, -1.0, 0))]
    return Scene("pullout_cylinder", "open cylinder pulled by two radial forces, octant (Sze et al. 2004, 3.5)",
                 model, StaticAnalysis("arc_length", (1.0,), arc_increment, 0.025, NewtonSettings(rtol=1e-7)), outs, ref,
                 dict(n_circ=n_circ, n_axial=n_axial, thickness=thickness, arc_increment=arc_increment, tying=tying))


def hemisphere(n_meridian: int = 20, n_circ: int = 20, thickness: float = 0.04, steps: int = 20,
               tying: bool = True, kernel: str = "numba") -> Scene:
    """Hemisphere with an 18 deg hole, quarter model, alternating radial forces at the equator (Sze 3.4)."""
    R = 10.0
    mesh = generators.spherical_cap(R, 18.0, n_meridian, n_circ, angle=math.pi / 2)
    body = ShellBody(mesh, ShellMaterial(6.825e7, 0.3, thickness), element=variant_from_key(tying), kernel=kernel)
    x = mesh.nodes
    tol = 1e-8 * R
    pulled = mesh.nearest_node([R, 0, 0])
    pushed = mesh.nearest_node([0, R, 0])
    cons = [Symmetry(np.flatnonzero(np.abs(x[:, 1]) < tol), (0, 1.0, 0)),
            Symmetry(np.flatnonzero(np.abs(x[:, 0]) < tol), (1.0, 0, 0)),
            Fix([mesh.nearest_node([R * math.sin(math.radians(18)), 0, R * math.cos(math.radians(18))])], ("z",))]
    loads = [NodalLoad([pulled], force=[200.0, 0, 0]), NodalLoad([pushed], force=[0, -200.0, 0])]
    model = Model(body, cons, loads)
    cols, comments = read_reference_csv("ref_hemisphere_18deg_hole.csv")
    ref = Reference(cols["load_factor_P_over_Pmax"],
                    {"U_pulled": cols["radial_disp_outward_at_pulled_point"],
                     "minus_U_pushed": cols["radial_disp_inward_at_pushed_point"]}, comments[0])
    outs = [Output("U_pulled", pulled, (1.0, 0, 0)), Output("minus_U_pushed", pushed, (0, -1.0, 0))]
    return Scene("hemisphere", "hemisphere with 18 deg hole under alternating radial forces, quarter (Sze 3.4)",
                 model, StaticAnalysis("load_control", tuple(np.linspace(0, 1, steps + 1)[1:])), outs, ref,
                 dict(n_meridian=n_meridian, n_circ=n_circ, thickness=thickness, steps=steps, tying=tying))
