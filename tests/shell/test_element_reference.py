"""The readable element: tangent against finite differences on the group, objectivity, zero-energy modes."""

import numpy as np
import pytest

from flexbody.lie import so3
from flexbody.shell.reference.bubble import condensed_bubble
from flexbody.shell.reference.loops import force_tangent
from flexbody.shell.variants import MITC6, MITC7, NoTying
from tests.shell.conftest import deformed

ALL = [MITC6(), NoTying(), MITC7()]
WITH_ENERGY = [MITC6(), MITC7()]
WITHOUT_BUBBLE = [MITC6(), NoTying()]

EPS = 1e-6


def perturb(x, frames, node, k, eps):
    """Group perturbation of one nodal DoF: x_I + R_I eps e_k (k < 3) or R_I exp(eps e_(k-3))."""
    x, frames = x.copy(), frames.copy()
    e = np.zeros(3)
    e[k % 3] = eps
    if k < 3:
        x[node] += frames[node] @ e
    else:
        frames[node] = frames[node] @ so3.exp(e)
    return x, frames


def fd_tangent(fun, x, frames):
    K = np.zeros((36, 36))
    for node in range(6):
        for k in range(6):
            fp = fun(*perturb(x, frames, node, k, EPS))
            fm = fun(*perturb(x, frames, node, k, -EPS))
            K[:, 6 * node + k] = (fp - fm) / (2 * EPS)
    return K


def tangent_error(x, frames, geom, C, variant):
    K = variant.element_force_tangent(x, frames, geom, C)[1]
    Kfd = fd_tangent(lambda xx, ff: variant.element_force_tangent(xx, ff, geom, C)[0], x, frames)
    return np.abs(K - Kfd).max() / np.abs(K).max()


@pytest.mark.parametrize("variant", ALL, ids=repr)
@pytest.mark.parametrize("seed", [0, 1])
def test_tangent_matches_group_finite_differences(element, variant, seed):
    X, frames, geom, C = element
    x, fr = deformed(X, frames, np.random.default_rng(seed))
    assert tangent_error(x, fr, geom, C, variant) < 1e-7


def test_tangent_check_detects_a_wrong_geometric_term(element, monkeypatch):
    """The finite-difference check must be able to fail: drop one term of the second variation."""
    X, frames, geom, C = element
    x, fr = deformed(X, frames, np.random.default_rng(3))
    from flexbody.shell.reference import geometric
    original = geometric.so3.d2_tangent
    monkeypatch.setattr(geometric.so3, "d2_tangent", lambda d, a, b: 1.1 * original(d, a, b))
    assert tangent_error(x, fr, geom, C, MITC6()) > 1e-6


@pytest.mark.parametrize("variant", WITH_ENERGY, ids=repr)
def test_force_is_the_gradient_of_the_energy(element, variant):
    X, frames, geom, C = element
    x, fr = deformed(X, frames, np.random.default_rng(5))
    f = variant.element_force_tangent(x, fr, geom, C)[0]
    g = np.zeros(36)
    for node in range(6):
        for k in range(6):
            ep = variant.element_strain_energy(*perturb(x, fr, node, k, EPS), geom, C)
            em = variant.element_strain_energy(*perturb(x, fr, node, k, -EPS), geom, C)
            g[6 * node + k] = (ep - em) / (2 * EPS)
    assert np.abs(f - g).max() < 1e-7 * np.abs(f).max()


def _bubble(x, fr, geom, C, variant):
    """The condensed rotation bubble of the MITC7 element, None for the others."""
    return condensed_bubble(x, fr, geom, C) if variant.condenses_bubble else None


@pytest.mark.parametrize("variant", WITH_ENERGY, ids=repr)
def test_reference_state_is_stress_free(element, variant):
    X, frames, geom, C = element
    f, _ = variant.element_force_tangent(X, frames, geom, C)
    assert np.abs(variant.element_strains(X, frames, geom, _bubble(X, frames, geom, C, variant))).max() < 1e-13
    assert np.abs(f).max() < 1e-10 * np.abs(C).max()


@pytest.mark.parametrize("variant", WITH_ENERGY, ids=repr)
@pytest.mark.parametrize("angle", [0.3, 2.0, np.pi - 1e-9, np.pi])
def test_objectivity_under_superposed_rigid_motion(element, angle, variant):
    """Strains, local forces and the local tangent do not change under a rigid motion (any angle)."""
    X, frames, geom, C = element
    rng = np.random.default_rng(11)
    x, fr = deformed(X, frames, rng, rigid=False)
    axis = rng.normal(size=3)
    Q = so3.exp(angle * axis / np.linalg.norm(axis))
    x2 = x @ Q.T + np.array([3.0, -1.0, 2.0])
    fr2 = np.einsum("ij,njk->nik", Q, fr)
    f1, K1 = variant.element_force_tangent(x, fr, geom, C)
    f2, K2 = variant.element_force_tangent(x2, fr2, geom, C)
    np.testing.assert_allclose(variant.element_strains(x2, fr2, geom, _bubble(x2, fr2, geom, C, variant)),
                               variant.element_strains(x, fr, geom, _bubble(x, fr, geom, C, variant)), atol=1e-12)
    scale = np.abs(f1).max()
    assert np.abs(f2 - f1).max() < 1e-11 * scale
    assert np.abs(K2 - K1).max() < 1e-11 * np.abs(K1).max()
    # in global components the nodal forces rotate with the body
    g1 = np.einsum("nij,nj->ni", fr, f1.reshape(6, 6)[:, :3])
    g2 = np.einsum("nij,nj->ni", fr2, f2.reshape(6, 6)[:, :3])
    assert np.abs(g2 - g1 @ Q.T).max() < 1e-11 * scale


def reduced(K):
    keep = [6 * i + k for i in range(6) for k in range(5)]
    return K[np.ix_(keep, keep)]


@pytest.mark.parametrize("variant", ALL, ids=repr)
def test_free_element_has_exactly_six_zero_energy_modes(element, variant):
    """Six rigid-body modes and no spurious ones, in the solved 5-DoF space.

    Flat: six exact zeros. Curved: the rigid rotations need drilling increments at the nodes that the
    5-DoF element does not have, so two of the six are near-zero (~1e-9 relative) rather than exact; the
    seventh eigenvalue is a true deformation mode four orders above them.
    """
    X, frames, geom, C = element
    K = reduced(variant.element_force_tangent(X, frames, geom, C)[1])
    eig = np.sort(np.abs(np.linalg.eigvalsh(0.5 * (K + K.T)))) / np.abs(K).max()
    assert eig[5] < 1e-7, eig[:8]
    assert eig[6] > 1e-6, eig[:8]
    assert eig[5] < 1e-3 * eig[6], eig[:8]


def _perturb_along(x, frames, dh, eps):
    """The element state moved on by eps dh on the group: x_I + R_I eps du_I, R_I exp(eps dtheta_I)."""
    h = eps * dh.reshape(6, 6)
    return (x + np.einsum("nij,nj->ni", frames, h[:, :3]),
            np.array([R @ so3.exp(t) for R, t in zip(frames, h[:, 3:])]))


@pytest.mark.parametrize("variant", WITHOUT_BUBBLE, ids=repr)
def test_linearized_strains_are_the_directional_derivative(element, variant):
    """B_g dh against a central difference of the Gauss-point strains along dh on the group."""
    X, frames, geom, C = element
    rng = np.random.default_rng(21)
    x, fr = deformed(X, frames, rng)
    dh = rng.normal(size=36)
    eps, deps = variant.element_linearized_strains(x, fr, geom, dh)
    np.testing.assert_allclose(eps, variant.element_strains(x, fr, geom), atol=1e-14)
    fd = (variant.element_strains(*_perturb_along(x, fr, dh, EPS), geom)
          - variant.element_strains(*_perturb_along(x, fr, dh, -EPS), geom)) / (2 * EPS)
    assert np.abs(deps - fd).max() < 1e-7 * np.abs(deps).max()


@pytest.mark.parametrize("variant", WITHOUT_BUBBLE, ids=repr)
def test_mixed_iteration_matrix(element, variant):
    """With given Gauss-point stresses s the tangent is  sum_g w_g B_g^T C B_g  plus the derivative of the
    virtual work of the fixed stresses, d/dh sum_g w_g B_g^T s_g (by central group differences)."""
    X, frames, geom, C = element
    rng = np.random.default_rng(22)
    x, fr = deformed(X, frames, rng)
    A = variant.maps
    s = rng.normal(size=(7, 8)) * np.abs(C).max() * 0.05
    f, K, f_s = force_tangent(x, fr, geom, C, A, stress=s)
    f0, K0 = force_tangent(x, fr, geom, C, A)
    np.testing.assert_array_equal(f, f0)                         # the force is the strains' own

    def fixed_stress_work(xx, ff):
        # sum_g w_g B_g^T s_g: the force of the stresses s, whatever the strains
        B_fixed = variant.element_linearized_strains(xx, ff, geom, np.eye(36))[1]
        return np.einsum("g,gin,gi->n", geom.weights, B_fixed, s)

    Kfd = fd_tangent(fixed_stress_work, x, fr)
    B = variant.element_linearized_strains(x, fr, geom, np.eye(36))[1]          # (7, 8, 36)
    K_material = np.einsum("g,gin,ij,gjm->nm", geom.weights, B, C, B)
    assert np.abs(K - (K_material + Kfd)).max() < 1e-7 * np.abs(K).max()
    np.testing.assert_allclose(f_s, fixed_stress_work(x, fr), rtol=0, atol=1e-12 * np.abs(f_s).max())
    # and the stresses of the strains give back the ordinary tangent
    sigma = variant.element_linearized_strains(x, fr, geom, np.zeros(36))[0] @ C.T
    assert np.abs(force_tangent(x, fr, geom, C, A, stress=sigma)[1] - K0).max() < 1e-12 * np.abs(K0).max()
