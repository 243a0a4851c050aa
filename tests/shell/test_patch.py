"""Patch tests on a distorted patch of straight-sided six-node triangles (linear analysis at the reference).

The boundary nodes get the exact values of a constant-strain field, the interior nodes are solved for with
the element stiffness assembled at the reference state; they must reproduce the field to round-off.
Membrane: u = B x (constant membrane strain). Bending: w = (a x^2 + 2 b x y + c y^2) / 2 with the rotations
of zero transverse shear (constant curvature). With MITC6 tying, MITC7 (the condensed rotation bubble) and without tying.
"""

import numpy as np
import pytest

from flexbody.body import ShellBody
from flexbody.mesh import Tri6Mesh
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import MITC6, MITC7, ElementVariant, NoTying


def distorted_patch() -> Tri6Mesh:
    """2 x 3 x 3 square patch, interior corner nodes moved off the grid, midside nodes on straight edges."""
    base = generators.strip(1.0, 1.0, 3, 3, diagonal="alternate")
    x = base.nodes.copy()
    rng = np.random.default_rng(7)
    corner = np.zeros(len(x), bool)
    corner[base.elements[:, :3].ravel()] = True
    interior_corners = np.flatnonzero(corner & (x[:, 0] > 1e-9) & (x[:, 0] < 1 - 1e-9)
                                      & (x[:, 1] > 1e-9) & (x[:, 1] < 1 - 1e-9))
    x[interior_corners, :2] += rng.uniform(-0.08, 0.08, (len(interior_corners), 2))
    for a, m, b in [(0, 3, 1), (1, 4, 2), (2, 5, 0)]:
        e = base.elements
        x[e[:, m]] = 0.5 * (x[e[:, a]] + x[e[:, b]])
    return Tri6Mesh(x, base.elements, base.directors)


def global_stiffness(body: ShellBody) -> np.ndarray:
    """Dense stiffness on the 5 DoF per node [u (3), theta_1, theta_2] at the reference state (frames = I)."""
    _, Ke = body.element_forces(body.initial_state())
    n = body.n_nodes
    K = np.zeros((6 * n, 6 * n))
    for conn, k in zip(body.mesh.elements, Ke):
        dofs = (6 * conn[:, None] + np.arange(6)).ravel()
        K[np.ix_(dofs, dofs)] += k
    keep = np.flatnonzero(np.arange(6 * n) % 6 != 5)  # no drilling DoF
    return K[np.ix_(keep, keep)]


def solve_patch(mesh: Tri6Mesh, exact: np.ndarray, element: ElementVariant) -> np.ndarray:
    """Interior values solved with the exact values (n, 5) prescribed on the boundary nodes."""
    body = ShellBody(mesh, ShellMaterial(1.0e4, 0.25, 0.05), element=element)
    assert np.allclose(body.frames0[:, :, :], np.eye(3))
    K = global_stiffness(body)
    boundary = np.unique(mesh.boundary_edges())
    is_b = np.zeros(mesh.n_nodes, bool)
    is_b[boundary] = True
    b = np.repeat(is_b, 5)
    u = exact.ravel().copy()
    i = ~b
    u[i] = np.linalg.solve(K[np.ix_(i, i)], -K[np.ix_(i, b)] @ u[b])
    return u.reshape(-1, 5)


@pytest.mark.parametrize("element", [MITC6(), NoTying(), MITC7()], ids=repr)
def test_membrane_patch(element):
    mesh = distorted_patch()
    B = np.array([[1.0e-3, 4.0e-4], [-2.0e-4, 6.0e-4]])
    exact = np.zeros((mesh.n_nodes, 5))
    exact[:, :2] = mesh.nodes[:, :2] @ B.T
    u = solve_patch(mesh, exact, element)
    assert np.abs(u - exact).max() < 1e-10 * np.abs(exact).max()


@pytest.mark.parametrize("element", [MITC6(), NoTying(), MITC7()], ids=repr)
def test_bending_patch(element):
    mesh = distorted_patch()
    a, b, c = 2.0e-3, -7.0e-4, 1.2e-3
    x, y = mesh.nodes[:, 0], mesh.nodes[:, 1]
    exact = np.zeros((mesh.n_nodes, 5))
    exact[:, 2] = 0.5 * (a * x**2 + 2 * b * x * y + c * y**2)
    w_x, w_y = a * x + b * y, b * x + c * y
    # zero transverse shear: the director turns with the slope, theta x e3 = -grad w
    exact[:, 3], exact[:, 4] = w_y, -w_x
    u = solve_patch(mesh, exact, element)
    assert np.abs(u - exact).max() < 1e-9 * np.abs(exact).max()


def test_patch_test_can_fail():
    """A field the element cannot carry free of load (a cubic deflection) is not reproduced."""
    mesh = distorted_patch()
    x = mesh.nodes[:, 0]
    exact = np.zeros((mesh.n_nodes, 5))
    exact[:, 2] = 1e-3 * x**3
    exact[:, 4] = -3e-3 * x**2
    u = solve_patch(mesh, exact, MITC6())
    assert np.abs(u - exact).max() > 1e-6 * np.abs(exact).max()
