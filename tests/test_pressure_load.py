"""The vectorised follower pressure against its element-by-element reference and against finite differences."""

import numpy as np

from flexbody.loads import pressure_contribution, pressure_contribution_reference
from flexbody.mesh import generators


def _deformed_cylinder(seed: int = 3):
    mesh = generators.cylinder(0.7, 1.3, 6, 3, angle=np.pi)
    rng = np.random.default_rng(seed)
    x = mesh.nodes + 0.05 * rng.standard_normal(mesh.nodes.shape)
    return mesh, x


def test_vectorised_pressure_equals_the_reference():
    mesh, x = _deformed_cylinder()
    for elements in (None, np.array([4, 1, 7])):
        F, dF, elems = pressure_contribution(mesh, x, -2.5, elements)
        F0, dF0, elems0 = pressure_contribution_reference(mesh, x, -2.5, elements)
        np.testing.assert_array_equal(elems, elems0)
        assert np.abs(F - F0).max() <= 1e-13 * np.abs(F0).max()
        assert np.abs(dF - dF0).max() <= 1e-13 * np.abs(dF0).max()


def test_pressure_tangent_against_central_differences():
    mesh, x = _deformed_cylinder(seed=5)
    elements = np.array([2, 5])
    _, dF, elems = pressure_contribution(mesh, x, 1.7, elements)
    h = 1e-6
    for k, e in enumerate(elems):
        conn = mesh.elements[e]
        for j in range(6):
            for b in range(3):
                xp, xm = x.copy(), x.copy()
                xp[conn[j], b] += h
                xm[conn[j], b] -= h
                Fp = pressure_contribution(mesh, xp, 1.7, [e])[0][conn]
                Fm = pressure_contribution(mesh, xm, 1.7, [e])[0][conn]
                fd = (Fp - Fm) / (2 * h)                       # (6, 3): dF_I,a / dx_J,b
                assert np.abs(fd - dF[k, :, j, :, b]).max() <= 1e-7 * np.abs(dF[k]).max()


def test_reference_geometry_of_all_elements_equals_the_element_by_element_one():
    from flexbody.frames import frames_from_directors
    from flexbody.lie import so3
    from flexbody.shell.geometry import element_geometry, element_geometry_batch
    mesh = generators.spherical_cap(1.0, 18.0, 3, 5)
    rng = np.random.default_rng(2)
    frames = frames_from_directors(mesh.directors)
    frames = np.array([R @ so3.exp(0.3 * rng.standard_normal(3)) for R in frames])   # rotated node frames
    frames[mesh.elements[0, 1]] = frames[mesh.elements[0, 0]] @ so3.exp([0.0, 0.0, 3.0])  # near pi
    X, Fr = mesh.nodes[mesh.elements], frames[mesh.elements]
    e_ref, to_cart, weights = element_geometry_batch(X, Fr)
    for k in range(len(X)):
        g = element_geometry(X[k], Fr[k])
        assert np.abs(g.e_ref - e_ref[k]).max() <= 1e-12 * np.abs(g.e_ref).max()
        assert np.abs(g.to_cart - to_cart[k]).max() <= 1e-12 * np.abs(g.to_cart).max()
        assert np.abs(g.weights - weights[k]).max() <= 1e-14 * g.weights.max()
