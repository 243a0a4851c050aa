"""MITC6 tying against locking, through h = 1e-1 ... 1e-4 (linear response).

The end-shear cantilever keeps its normalised tip deflection with tying. It does not lock without tying
either: a quadratic element satisfies the Kirchhoff constraint of 1-D bending exactly. The clamped square
plate under uniform pressure is the problem that does lock: without tying the centre deflection falls
by orders of magnitude as h decreases; with MITC6 it stays at the Kirchhoff value.
"""

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.loads import NodalLoad, nodal_vectors_from_area, nodal_vectors_from_edges
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import MITC6, MITC7, ElementVariant, NoTying

L, B, E = 10.0, 1.0, 1.2e6


def normalised_tip_deflection(h: float, element: ElementVariant, kernel: str = "reference") -> float:
    """Linear tip deflection under an end shear, divided by the Euler-Bernoulli value P L^3 / (3 E I)."""
    mesh = generators.strip(L, B, 16, 1)
    body = ShellBody(mesh, ShellMaterial(E, 0.0, h), element=element, kernel=kernel)
    P = 1.0
    forces = nodal_vectors_from_edges(mesh.nodes, mesh.edge_set("tip"), np.array([0, 0, P / B]), mesh.n_nodes)
    loads = [NodalLoad([i], force=forces[i]) for i in np.flatnonzero(np.any(forces != 0, axis=1))]
    model = Model(body, [Fix(mesh.node_set("clamped"), "all")], loads)
    state = model.initial_state()
    r, K = model.residual_and_tangent(state, 1.0)
    state = model.update(state, spla.spsolve(K, -r))
    tip = mesh.nearest_node([L, B / 2, 0])
    w = state.x[tip, 2] - mesh.nodes[tip, 2]
    return w / (P * L**3 / (3 * E * B * h**3 / 12))


@pytest.mark.parametrize("h", [1e-1, 1e-2, 1e-3, 1e-4])
def test_tying_keeps_the_thin_limit(h):
    # Timoshenko adds a shear term ~ (h/L)^2; the linear solution is exact to a few 1e-4
    assert abs(normalised_tip_deflection(h, MITC6()) - 1.0) < 5e-3


def clamped_plate_deflection(h: float, element: ElementVariant, n: int = 4, kernel: str = "reference") -> float:
    """Centre deflection of a clamped unit square plate (nu = 0.3) under unit pressure / Kirchhoff value."""
    a, E, nu = 1.0, 1.0e6, 0.3
    mesh = generators.strip(a, a, n, n)
    x = mesh.nodes
    edge = np.flatnonzero((np.abs(x[:, 0]) < 1e-9) | (np.abs(x[:, 0] - a) < 1e-9)
                          | (np.abs(x[:, 1]) < 1e-9) | (np.abs(x[:, 1] - a) < 1e-9))
    body = ShellBody(mesh, ShellMaterial(E, nu, h), element=element, kernel=kernel)
    f = nodal_vectors_from_area(mesh, np.array([0, 0, 1.0]))
    f[edge] = 0.0  # reactions carry the load on the clamped edge
    loads = [NodalLoad([i], force=f[i]) for i in np.flatnonzero(np.any(f != 0, axis=1))]
    model = Model(body, [Fix(edge, "all")], loads)
    state = model.initial_state()
    r, K = model.residual_and_tangent(state, 1.0)
    state = model.update(state, spla.spsolve(K, -r))
    c = mesh.nearest_node([a / 2, a / 2, 0])
    D = E * h**3 / (12 * (1 - nu**2))
    return state.x[c, 2] / (0.00126532 * a**4 / D)  # Timoshenko & Woinowsky-Krieger, Table 35


def test_mitc6_plate_keeps_the_thin_limit():
    """Clamped plate: no locking from h/a = 1e-2 to 1e-4, and convergence to Kirchhoff under refinement.

    Measured (numba kernel, 'right' diagonals), centre deflection / Kirchhoff:
    2x4x4: 1.0412, 1.0186, 1.0184; 2x8x8: 1.0288, 1.0097, 1.0091; 2x16x16: 1.0116, 1.0041 (h = 1e-2, 1e-3,
    1e-4). MITC6 converges from above here, with an error about linear in the element size.
    """
    coarse = [clamped_plate_deflection(h, MITC6(), n=4) for h in (1e-2, 1e-3, 1e-4)]
    fine = [clamped_plate_deflection(h, MITC6(), n=8, kernel="numba") for h in (1e-2, 1e-3, 1e-4)]
    assert abs(fine[2] - fine[1]) < 1e-3 and abs(coarse[2] - coarse[1]) < 1e-3, (coarse, fine)  # thin limit
    assert all(abs(v - 1.0) < 0.03 for v in fine), fine                     # 2x8x8 within 3 %
    assert all(abs(f - 1.0) < 0.75 * abs(c - 1.0) for c, f in zip(coarse, fine)), (coarse, fine)  # converging


def test_without_tying_the_plate_locks():
    values = [clamped_plate_deflection(h, NoTying()) for h in (1e-2, 1e-3, 1e-4)]
    assert values[0] < 0.3 and values[1] < 0.01 and values[2] < 1e-4, values


def test_mitc7_plate_converges_at_the_optimal_rate():
    """The rotation bubble with the canonical shear tying (MITC7, flexbody.shell.reference.bubble) on the clamped plate.

    Measured, h/a = 1e-3, centre deflection / Kirchhoff: 2x4x4 0.94446, 2x8x8 0.99496, 2x16x16 0.99962,
    2x32x32 0.99999 (errors / 11, / 13, / 40) against MITC6's 1.0186, 1.0097, 1.0041, 1.0018 (about O(h)).
    """
    coarse, fine = (clamped_plate_deflection(1e-3, MITC7(), n=n) for n in (4, 8))
    assert abs(fine - 1.0) < 6e-3, fine
    assert abs(fine - 1.0) < abs(coarse - 1.0) / 8, (coarse, fine)
    mitc6 = clamped_plate_deflection(1e-3, MITC6(), n=8, kernel="numba")
    assert abs(fine - 1.0) < 0.6 * abs(mitc6 - 1.0), (fine, mitc6)
