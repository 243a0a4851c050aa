"""Membrane tying schemes of MITC6 (flexbody/shell/mitc6.py; measurements in docs/locking.md).

"mean" (default): e_rr, e_ss, e_qq linear, tied at the two Gauss stations of their edge and in the element
mean. "point": the third condition is a point value inside the element. Both reproduce linear strain fields
exactly (consistency, patch tests); only "mean" keeps the thin curved shell free of membrane locking.
"""

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from flexbody.scenes import build
from flexbody.shell import mitc6
from flexbody.shell.reference.material import assumed_strain_maps
from flexbody.shell.geometry import EVAL_POINTS, GAUSS_POINTS, GAUSS_WEIGHTS, MEMBRANE_MAPS
from flexbody.shell.variants import MITC6

QQ = np.array([0.5, 0.5, -1.0])


def sampled(fields):
    """Samples [e_rr, e_ss, e_rs] (N_EVAL, 3) of three scalar functions of (r, s)."""
    return np.array([[f(r, s) for f in fields] for r, s in EVAL_POINTS])


@pytest.mark.parametrize("scheme", mitc6.MEMBRANE_SCHEMES)
def test_linear_membrane_fields_are_reproduced(scheme):
    rng = np.random.default_rng(1)
    c = rng.normal(size=(3, 3))
    fields = [lambda r, s, k=k: c[k, 0] + c[k, 1] * r + c[k, 2] * s for k in range(3)]
    e = sampled(fields)
    for g, (r, s) in enumerate(GAUSS_POINTS):
        assumed = np.einsum("ikj,kj->i", MEMBRANE_MAPS[scheme][g], e)
        np.testing.assert_allclose(assumed, [f(r, s) for f in fields], atol=1e-13)


def test_mean_scheme_ties_edge_stations_and_element_mean():
    """For quadratic samples: the edge values are kept, and the field's mean is the mean of the samples."""
    rng = np.random.default_rng(2)
    c = rng.normal(size=(3, 6))
    fields = [lambda r, s, k=k: c[k] @ [1, r, s, r * r, r * s, s * s] for k in range(3)]
    e = sampled(fields)
    M = lambda r, s: mitc6.membrane_map(r, s, "mean")
    assumed = lambda r, s: np.einsum("ikj,kj->i", M(r, s), e)
    qq = lambda v: QQ @ v
    for k, comp in ((0, 0), (1, 0), (3, 1), (4, 1)):
        assert abs(assumed(*mitc6.TYING_POINTS[k])[comp] - e[k, comp]) < 1e-12
    for k in (6, 7):
        assert abs(qq(assumed(*mitc6.TYING_POINTS[k])) - qq(e[k])) < 1e-12
    # the mean of a linear field is its centroid value; the mean of the samples is exact for quadratics
    exact_mean = np.array([sum(w * f(r, s) for (r, s), w in zip(GAUSS_POINTS, GAUSS_WEIGHTS)) / 0.5
                           for f in fields])
    a_c = assumed(1 / 3, 1 / 3)
    np.testing.assert_allclose([a_c[0], a_c[1], qq(a_c)], [exact_mean[0], exact_mean[1], qq(exact_mean)],
                               atol=1e-12)


def test_membrane_argument():
    np.testing.assert_array_equal(assumed_strain_maps(), assumed_strain_maps(mitc6.DEFAULT_SCHEME))
    np.testing.assert_array_equal(MITC6().maps, assumed_strain_maps("mean"))
    np.testing.assert_array_equal(MITC6(membrane="point").maps, assumed_strain_maps("point"))
    assert np.abs(MITC6().maps - MITC6(membrane="point").maps).max() > 0.1
    with pytest.raises(ValueError, match="membrane must be one of"):
        assumed_strain_maps("mitc6z")
    with pytest.raises(ValueError, match="MITC6 membrane must be one of 'mean', 'point', got 'mitc6z'"):
        MITC6(membrane="mitc6z")


def hemisphere_linear(hr: float, tying, n: int = 10) -> float:
    """Linear radial displacement of the pulled point x (h/h0)^3 (bending-dominated: constant as h -> 0)."""
    scene = build("hemisphere", thickness=10.0 * hr, n_meridian=n, n_circ=n, tying=tying)
    model = scene.model
    state = model.initial_state()
    r, K = model.residual_and_tangent(state, 1.0)
    state = model.update(state, spla.spsolve(K.tocsc(), -r))
    return scene.outputs[0].value(model, state) * (hr / 4e-3) ** 3


def test_thin_hemisphere_does_not_lock_with_the_mean_scheme():
    """Measured (2x10x10): u(h/R = 1e-4) / u(4e-3) = 0.950 ("mean"), 0.175 ("point")."""
    ratio = {t: hemisphere_linear(1e-4, t) / hemisphere_linear(4e-3, t) for t in ("mean", "point")}
    assert ratio["mean"] > 0.9, ratio
    assert ratio["point"] < 0.3, ratio   # the locking the mean scheme removes


@pytest.mark.parametrize("scheme", mitc6.MEMBRANE_SCHEMES)
def test_both_schemes_tangent_energy_and_zero_modes(element, scheme):
    """Tangent vs finite differences, force = energy gradient and six zero-energy modes, for each scheme."""
    from tests.shell.test_element_reference import reduced, tangent_error
    from tests.shell.conftest import deformed
    X, frames, geom, C = element
    x, fr = deformed(X, frames, np.random.default_rng(5))
    variant = MITC6(membrane=scheme)
    assert tangent_error(x, fr, geom, C, variant) < 1e-7
    K = reduced(variant.element_force_tangent(X, frames, geom, C)[1])
    eig = np.sort(np.abs(np.linalg.eigvalsh(0.5 * (K + K.T)))) / np.abs(K).max()
    assert eig[5] < 1e-7 and eig[6] > 1e-6, eig[:8]


@pytest.mark.parametrize("scheme", mitc6.MEMBRANE_SCHEMES)
def test_numba_kernel_matches_reference_for_each_scheme(scheme):
    import math
    from flexbody.body import ShellBody
    from flexbody.mesh import generators
    from flexbody.shell.material import ShellMaterial
    from tests.shell.test_element import deformed_state
    mesh = generators.cylinder(1.5, 1.0, 2, 1, angle=math.pi / 2)
    material = ShellMaterial(2.0e5, 0.3, 0.02)
    fast = ShellBody(mesh, material, element=MITC6(membrane=scheme), kernel="numba")
    slow = ShellBody(mesh, material, element=MITC6(membrane=scheme), kernel="reference")
    state = deformed_state(fast, np.random.default_rng(4))
    f1, K1 = fast.element_forces(state)
    f0, K0 = slow.element_forces(state)
    assert np.abs(f1 - f0).max() <= 1e-12 * np.abs(f0).max()
    assert np.abs(K1 - K0).max() <= 1e-12 * np.abs(K0).max()
