"""The fast numba element agrees with the readable numpy reference (force and tangent, to round-off)."""

import math

import numpy as np
import pytest

from flexbody.body import ShellBody, ShellState
from flexbody.lie import so3
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import MITC6, NoTying


def deformed_state(body: ShellBody, rng, amplitude=0.05, rot=0.4) -> ShellState:
    """A rigid motion with rotation angle near pi plus random nodal perturbations (large relative rotations)."""
    s = body.initial_state()
    axis = rng.normal(size=3)
    Rg = so3.exp(0.95 * math.pi * axis / np.linalg.norm(axis))
    x = (s.x + amplitude * rng.normal(size=s.x.shape)) @ Rg.T + rng.normal(size=3)
    frames = np.array([Rg @ F @ so3.exp(rot * rng.normal(size=3)) for F in s.frames])
    return ShellState(x, frames)


@pytest.mark.parametrize("geometry", ["flat", "curved"])
@pytest.mark.parametrize("variant", [MITC6(), NoTying()], ids=repr)
def test_numba_kernel_matches_reference(geometry, variant):
    mesh = (generators.strip(1.0, 0.6, 2, 1, diagonal="alternate") if geometry == "flat"
            else generators.cylinder(1.5, 1.0, 2, 1, angle=math.pi / 2))
    material = ShellMaterial(2.0e5, 0.3, 0.02)
    fast = ShellBody(mesh, material, element=variant, kernel="numba")
    slow = ShellBody(mesh, material, element=variant, kernel="reference")
    rng = np.random.default_rng(3)
    for _ in range(2):
        state = deformed_state(fast, rng)
        f1, K1 = fast.element_forces(state)
        f0, K0 = slow.element_forces(state)
        scale_f, scale_K = np.abs(f0).max(), np.abs(K0).max()
        assert np.abs(f1 - f0).max() <= 1e-12 * scale_f
        assert np.abs(K1 - K0).max() <= 1e-12 * scale_K
        f2, K2 = fast.element_forces(state, want_tangent=False)
        assert np.abs(f2 - f1).max() <= 1e-12 * scale_f   # the force-only path


def test_comparison_can_fail():
    """A perturbed state changes the force far beyond the tolerance used above (the check is not vacuous)."""
    mesh = generators.strip(1.0, 0.6, 2, 1)
    body = ShellBody(mesh, ShellMaterial(2.0e5, 0.3, 0.02))
    state = deformed_state(body, np.random.default_rng(4))
    f0, _ = body.element_forces(state)
    state.x[3] += 1e-9
    f1, _ = body.element_forces(state)
    assert np.abs(f1 - f0).max() > 1e-12 * np.abs(f0).max()


@pytest.mark.parametrize("geometry", ["flat", "curved"])
@pytest.mark.parametrize("variant", [MITC6(), NoTying()], ids=repr)
def test_numba_mixed_iteration_matches_reference(geometry, variant):
    """The iteration matrix with given Gauss-point stresses and the linearized stresses C (eps + B dh)."""
    mesh = (generators.strip(1.0, 0.6, 2, 1, diagonal="alternate") if geometry == "flat"
            else generators.cylinder(1.5, 1.0, 2, 1, angle=math.pi / 2))
    material = ShellMaterial(2.0e5, 0.3, 0.02)
    fast = ShellBody(mesh, material, element=variant, kernel="numba")
    slow = ShellBody(mesh, material, element=variant, kernel="reference")
    rng = np.random.default_rng(7)
    state = deformed_state(fast, rng)
    m = mesh.n_elements
    dh = rng.normal(size=(m, 36))
    s1, s0 = fast.stresses(state, dh), slow.stresses(state, dh)
    assert np.abs(s1 - s0).max() <= 1e-12 * np.abs(s0).max()
    own = fast.stresses(state)
    assert np.abs(s1 - own).max() > 1e-3 * np.abs(own).max()         # dh moves the stresses on
    f_own, K_own = fast.element_forces(state)
    f2, K2, fs2 = fast.mixed_element_forces(state, own)
    scale_K = np.abs(K_own).max()
    assert np.abs(K2 - K_own).max() <= 1e-12 * scale_K and np.abs(fs2 - f_own).max() <= 1e-12 * np.abs(f_own).max()
    f1, K1, fs1 = fast.mixed_element_forces(state, s1)
    f0, K0, fs0 = slow.mixed_element_forces(state, s1)
    assert np.abs(f1 - f_own).max() <= 1e-13 * np.abs(f_own).max()   # the force is the strains' own
    assert np.abs(fs1 - fs0).max() <= 1e-12 * np.abs(fs0).max()
    assert np.abs(K1 - K0).max() <= 1e-12 * np.abs(K0).max()
    assert np.abs(K1 - K_own).max() > 1e-6 * scale_K and np.abs(fs1 - f_own).max() > 1e-6 * np.abs(f_own).max()


def test_mixed_iteration_inputs_are_checked():
    mesh = generators.strip(1.0, 0.6, 2, 1)
    for kernel in ("numba", "reference"):
        body = ShellBody(mesh, ShellMaterial(2.0e5, 0.3, 0.02), kernel=kernel)
        state = body.initial_state()
        with pytest.raises(ValueError, match=r"stress must have shape \(4, 7, 8\)"):
            body.mixed_element_forces(state, np.zeros((4, 7)))
        with pytest.raises(ValueError, match=r"dh_el must have shape \(4, 36\)"):
            body.stresses(state, np.zeros((4, 30)))
