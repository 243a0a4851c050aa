"""Stress resultants and support reactions (flexbody.results)."""

import dataclasses
import math

import numpy as np
import pytest

from flexbody import results
from flexbody.scenes.builtin import cantilever_end_moment, cantilever_end_shear
from flexbody.scenes.scene import run_scene

pytestmark = pytest.mark.usefixtures("one_numba_thread")


def _run(scene, levels, **newton):
    a = dataclasses.replace(scene.analysis, load_factors=tuple(levels),
                            newton=dataclasses.replace(scene.analysis.newton, **newton))
    scene.analysis = a
    summary = run_scene(scene)
    assert summary.result.converged
    return summary.result


def test_nodal_average_reproduces_a_quadratic_field():
    """The least-squares quadratic through the 7 Gauss points is exact for a quadratic field, and the
    average over the elements of a node of a continuous field is the field itself."""
    from flexbody.mesh.generators import strip
    from flexbody.shell.geometry import GAUSS_POINTS
    from flexbody.shell.shape import shape_functions
    mesh = strip(3.0, 1.0, 3, 2)
    f = lambda p: 1.0 + 2 * p[..., 0] - p[..., 1] + 0.5 * p[..., 0] ** 2 + p[..., 0] * p[..., 1]
    Ng = np.array([shape_functions(r, s) for r, s in GAUSS_POINTS])            # (7, 6)
    gauss_xyz = np.einsum("gi,mij->mgj", Ng, mesh.nodes[mesh.elements])
    nodal = results.nodal_average(f(gauss_xyz), mesh.elements, mesh.n_nodes)
    np.testing.assert_allclose(nodal, f(mesh.nodes), rtol=0, atol=1e-12)


def test_end_moment_gives_a_uniform_bending_moment_and_the_fibre_stresses():
    """Strip under an end moment M (10 % of the full-circle moment): M11 = -M / b everywhere (the moment
    turns about -y), N and Q ~ 0, the top fibre (director side) in compression at 6 M / (b h^2), the
    element energies sum to the body's strain energy and the principal direction of the bending stress
    follows the strip."""
    scene = cantilever_end_moment(nx=8, steps=4)
    res = _run(scene, (0.05, 0.1))
    body = scene.model.body
    r = results.stress_resultants(body, res.state)
    m = 0.1 * 2 * math.pi * 1.2e6 * 0.01 ** 3 / 12 / 12            # b = 1
    np.testing.assert_allclose(r.nodal[:, 3], -m, rtol=2e-3)
    _, M, _ = results.to_tensors(r.gauss, results.gauss_bases(body.mesh))     # global tensors
    np.testing.assert_allclose(M[..., 0, 0], -m, rtol=2e-3)
    np.testing.assert_allclose(r.element[:, 3], -m, rtol=2e-3)
    assert np.abs(r.nodal[:, 4:6]).max() < 1e-3 * m                 # nu = 0: no M22, and no twist
    h = 0.01
    sigma_b = 6 * m / h**2
    assert np.abs(r.nodal[:, :3]).max() / h < 2e-3 * sigma_b        # membrane stress: negligible
    np.testing.assert_allclose(r.von_mises_top, sigma_b, rtol=5e-3)
    np.testing.assert_allclose(r.von_mises_bottom, sigma_b, rtol=5e-3)
    top = r.nodal[:, 0] / h + 6 / h**2 * r.nodal[:, 3]             # sigma_11 at z = +h/2
    assert np.all(top < 0)
    assert r.strain_energy == pytest.approx(body.strain_energy(res.state), rel=1e-12)
    assert r.element_energy.shape == (body.mesh.n_elements,) and np.all(r.element_energy > 0)
    np.testing.assert_allclose(np.linalg.norm(r.principal_direction, axis=1), 1.0, rtol=1e-12)


@pytest.mark.parametrize("about", [(0.0, 0.0, 0.0), (3.0, -2.0, 5.0)])
def test_reactions_balance_the_applied_loads(about):
    """End shear at a converged static state: the clamp's reactions balance the applied force and its
    moment about a point to 1e-8 relative (moment relative to |F| times the lever)."""
    scene = cantilever_end_shear(nx=6, steps=4)
    res = _run(scene, (0.25, 0.5), rtol=1e-10)
    rea = results.reactions(scene.model, res.state, res.load_factor)
    F = rea.total_load_force
    assert np.linalg.norm(F) > 0
    assert np.linalg.norm(rea.total_force + F) <= 1e-8 * np.linalg.norm(F)
    M = rea.total_load_moment(about)
    scale = np.linalg.norm(F) * 10.0
    assert np.linalg.norm(rea.total_moment(about) + M) <= 1e-8 * scale
    # the reactions sit on the clamped nodes only, and the applied force is the end shear P = lam P_max
    clamped = scene.model.body.mesh.node_set("clamped")
    assert set(rea.supported) == set(clamped)
    assert np.all(rea.force[np.setdiff1d(np.arange(len(rea.force)), clamped)] == 0)
    np.testing.assert_allclose(F, [0, 0, 0.5 * 4.0], rtol=1e-12, atol=1e-12)
