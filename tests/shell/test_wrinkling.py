"""The tension-field (wrinkling) membrane law: the law itself, kernel/reference parity, the element tangent
against finite differences, analytic membrane patches, scale-freedom and the input checks."""

import math

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody, ShellState
from flexbody.mesh import generators
from flexbody.results import gauss_bases, stress_resultants, to_tensors
from flexbody.shell.material import ShellMaterial
from flexbody.shell.reference.material import (membrane_regimes, principal_membrane_strains, relaxed_section,
                                               tension_field_membrane)
from flexbody.shell.variants import MITC6, MITC7, NoTying
from tests.shell.conftest import deformed
from tests.shell.test_element import deformed_state
from tests.shell.test_element_reference import fd_tangent

E, NU, H = 7.0e3, 0.3, 0.1
MATERIAL = ShellMaterial(E, NU, H)
C_M = MATERIAL.membrane()
EH = E * H
SLACK, WRINKLED, TAUT = 0, 1, 2


def voigt(e1: float, e2: float, angle: float) -> np.ndarray:
    """Membrane strains [e11, e22, 2 e12] with principal strains e1, e2, e1 along (cos angle, sin angle)."""
    c, s = math.cos(angle), math.sin(angle)
    R = np.array([[c, -s], [s, c]])
    T = R @ np.diag([e1, e2]) @ R.T
    return np.array([T[0, 0], T[1, 1], 2 * T[0, 1]])


def force_tensor(N: np.ndarray) -> np.ndarray:
    return np.array([[N[0], N[2]], [N[2], N[1]]])


def strain_tensor(eps: np.ndarray) -> np.ndarray:
    return np.array([[eps[0], eps[2] / 2], [eps[2] / 2, eps[1]]])


def random_state(rng, regime: int) -> np.ndarray:
    """Random membrane strains in the given regime, away from its boundaries."""
    angle = rng.uniform(0, math.pi)
    while True:
        e1, e2 = np.sort(rng.normal(size=2) * 1e-3)[::-1]
        eps = voigt(e1, e2, angle)
        if membrane_regimes(eps, C_M) == regime and abs(e2 + NU * e1) > 1e-2 * abs(e1) and abs(e1) > 1e-5:
            return eps


# -- the law ------------------------------------------------------------------------------------------------


def test_taut_is_linear():
    rng = np.random.default_rng(0)
    for _ in range(20):
        eps = random_state(rng, TAUT)
        N, Ct = tension_field_membrane(eps, C_M)
        np.testing.assert_allclose(N, C_M @ eps, rtol=1e-14, atol=0)
        np.testing.assert_array_equal(Ct, C_M)


def test_wrinkled_is_uniaxial_tension_along_the_major_strain():
    rng = np.random.default_rng(1)
    for _ in range(20):
        eps = random_state(rng, WRINKLED)
        N, _ = tension_field_membrane(eps, C_M)
        e1, e2, n, m = principal_membrane_strains(eps)
        assert e1 > 0 and e2 + NU * e1 <= 0
        T = force_tensor(N)
        assert abs(m @ T @ m) <= 1e-14 * EH * e1
        assert abs(n @ T @ m) <= 1e-14 * EH * e1
        assert abs(n @ T @ n - EH * e1) <= 1e-14 * EH * e1
        # the linear law would compress along m
        assert m @ force_tensor(C_M @ eps) @ m < 0


def test_slack_carries_nothing():
    rng = np.random.default_rng(2)
    for _ in range(20):
        N, Ct = tension_field_membrane(random_state(rng, SLACK), C_M)
        assert not N.any() and not Ct.any()


@pytest.mark.parametrize("boundary", ["taut/wrinkled", "wrinkled/slack"])
def test_stress_is_continuous_across_the_regime_boundaries(boundary):
    rng = np.random.default_rng(3)
    delta = 1e-9
    for _ in range(10):
        angle = rng.uniform(0, math.pi)
        scale = rng.uniform(0.5, 2.0) * 1e-3
        if boundary == "taut/wrinkled":             # e2 = -nu e1
            sides = [voigt(scale, -NU * scale * (1 + s), angle) for s in (-delta, delta)]
        else:                                        # e1 = 0, e2 < 0
            sides = [voigt(s * scale, -scale, angle) for s in (delta, -delta)]
        regimes = [int(membrane_regimes(eps, C_M)) for eps in sides]
        assert regimes == ([TAUT, WRINKLED] if boundary == "taut/wrinkled" else [WRINKLED, SLACK])
        (Na, _), (Nb, _) = (tension_field_membrane(eps, C_M) for eps in sides)
        assert np.abs(Na - Nb).max() <= 10 * delta * EH * scale


@pytest.mark.parametrize("regime", [SLACK, WRINKLED, TAUT])
def test_tangent_is_the_derivative_of_the_stress(regime):
    rng = np.random.default_rng(4 + regime)
    for _ in range(10):
        eps = random_state(rng, regime)
        N, Ct = tension_field_membrane(eps, C_M)
        h = 1e-6 * np.abs(eps).max()
        fd = np.column_stack([(tension_field_membrane(eps + h * d, C_M)[0]
                               - tension_field_membrane(eps - h * d, C_M)[0]) / (2 * h) for d in np.eye(3)])
        assert np.abs(Ct - fd).max() <= 1e-6 * np.abs(C_M).max()
        np.testing.assert_allclose(Ct, Ct.T, rtol=0, atol=1e-12 * np.abs(C_M).max())
        assert np.linalg.eigvalsh(Ct).min() >= -1e-12 * np.abs(C_M).max()
        np.testing.assert_allclose(Ct @ eps, N, rtol=1e-12, atol=1e-14 * EH * np.abs(eps).max())


def test_tangent_check_can_fail():
    """Dropping the rotation term of the wrinkled tangent is seen by the finite differences."""
    eps = random_state(np.random.default_rng(8), WRINKLED)
    e1, e2, n, m = principal_membrane_strains(eps)
    p = np.array([n[0] ** 2, n[1] ** 2, n[0] * n[1]])
    h = 1e-6 * np.abs(eps).max()
    fd = np.column_stack([(tension_field_membrane(eps + h * d, C_M)[0]
                           - tension_field_membrane(eps - h * d, C_M)[0]) / (2 * h) for d in np.eye(3)])
    assert np.abs(EH * np.outer(p, p) - fd).max() > 1e-3 * np.abs(C_M).max()


@pytest.mark.parametrize("regime", [SLACK, WRINKLED, TAUT])
def test_law_is_invariant_under_rotation_of_the_frame(regime):
    rng = np.random.default_rng(10 + regime)
    for _ in range(10):
        eps = random_state(rng, regime)
        phi = rng.uniform(0, 2 * math.pi)
        R = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
        T = R @ strain_tensor(eps) @ R.T
        rotated = np.array([T[0, 0], T[1, 1], 2 * T[0, 1]])
        N, _ = tension_field_membrane(eps, C_M)
        Nr, _ = tension_field_membrane(rotated, C_M)
        np.testing.assert_allclose(force_tensor(Nr), R @ force_tensor(N) @ R.T, rtol=0,
                                   atol=1e-13 * EH * np.abs(eps).max())


@pytest.mark.parametrize("eps", [np.zeros(3), np.array([1e-3, 1e-3, 0.0]), np.array([-1e-3, -1e-3, 0.0])],
                         ids=["zero", "equibiaxial tension", "equibiaxial compression"])
def test_equal_principal_strains_give_no_nan(eps):
    N, Ct = tension_field_membrane(eps, C_M)
    assert np.all(np.isfinite(N)) and np.all(np.isfinite(Ct))
    expected = (C_M @ eps, C_M) if eps[0] > 0 else (np.zeros(3), np.zeros((3, 3)))
    np.testing.assert_array_equal(N, expected[0])
    np.testing.assert_array_equal(Ct, expected[1])


def test_section_law_keeps_bending_and_shear_linear():
    rng = np.random.default_rng(12)
    C = MATERIAL.section()
    eps = np.concatenate([random_state(rng, WRINKLED), rng.normal(size=5)])
    sigma, Ct = relaxed_section(eps, C)
    np.testing.assert_array_equal(sigma[3:], (C @ eps)[3:])
    np.testing.assert_array_equal(Ct[3:, 3:], C[3:, 3:])
    assert not Ct[:3, 3:].any() and not Ct[3:, :3].any()
    np.testing.assert_array_equal(sigma[:3], tension_field_membrane(eps[:3], C[:3, :3])[0])


# -- the element ------------------------------------------------------------------------------------------


def regimes_of(body: ShellBody, state: ShellState) -> np.ndarray:
    """How many Gauss points are slack, wrinkled, taut."""
    regimes = membrane_regimes(body.strains(state)[..., :3], body.material.membrane())
    return np.bincount(regimes.ravel(), minlength=3)


@pytest.mark.parametrize("geometry", ["flat", "curved"])
@pytest.mark.parametrize("variant", [MITC6(), NoTying(), MITC6(membrane="point")], ids=repr)
def test_numba_kernel_matches_reference(geometry, variant):
    mesh = (generators.strip(1.0, 0.6, 3, 2, diagonal="alternate") if geometry == "flat"
            else generators.cylinder(1.5, 1.0, 3, 2, angle=math.pi / 2))
    material = ShellMaterial(2.0e5, 0.3, 0.02, wrinkling=True)
    fast = ShellBody(mesh, material, element=variant, kernel="numba")
    slow = ShellBody(mesh, material, element=variant, kernel="reference")
    linear = ShellBody(mesh, ShellMaterial(2.0e5, 0.3, 0.02), element=variant, kernel="numba")
    rng = np.random.default_rng(5)
    for _ in range(2):
        state = deformed_state(fast, rng, amplitude=0.03)
        counts = regimes_of(slow, state)
        assert np.all(counts > 0), counts
        f1, K1 = fast.element_forces(state)
        f0, K0 = slow.element_forces(state)
        scale_f, scale_K = np.abs(f0).max(), np.abs(K0).max()
        assert np.abs(f1 - f0).max() <= 1e-12 * scale_f
        assert np.abs(K1 - K0).max() <= 1e-12 * scale_K
        f2, _ = fast.element_forces(state, want_tangent=False)
        assert np.abs(f2 - f1).max() <= 1e-12 * scale_f
        f3, K3 = linear.element_forces(state)                  # the law changes the result
        assert np.abs(f3 - f1).max() > 1e-3 * scale_f and np.abs(K3 - K1).max() > 1e-3 * scale_K
        assert abs(fast.strain_energy(state, "numba") - slow.strain_energy(state)) <= 1e-12 * slow.strain_energy(state)


def element_loop_calls_the_law(scratch_type) -> bool:
    """Whether the element loop still calls the law after numba's pruning of the branches on its arguments'
    types (the pass that runs before typing), its wrinkling scratch Ct (the last argument) of scratch_type."""
    from numba import types
    from numba.core import ir
    from numba.core.analysis import dead_branch_prune
    from numba.core.compiler import run_frontend
    from flexbody.shell.kernels import loops, material

    func_ir = run_frontend(loops._chunk.py_func)
    dead_branch_prune(func_ir, (types.float64[:, ::1],) * (func_ir.arg_count - 1) + (scratch_type,))
    return any(isinstance(stmt, ir.Assign) and isinstance(stmt.value, (ir.Global, ir.FreeVar))
               and stmt.value.value is material._relaxed_stress_weights
               for block in func_ir.blocks.values() for stmt in block.body)


def test_the_element_loop_without_the_law_does_not_compile_it():
    """Without wrinkling the law's branch is gone before typing, so a scene without it never compiles it
    (its first run's compilation); with the scratch array it stays."""
    from numba import types

    assert element_loop_calls_the_law(types.float64[:, ::1])
    assert not element_loop_calls_the_law(types.none)


def element_tangent_error(x, fr, geom, C, variant) -> float:
    K = variant.element_force_tangent(x, fr, geom, C, wrinkling=True)[1]
    Kfd = fd_tangent(lambda xx, ff: variant.element_force_tangent(xx, ff, geom, C, wrinkling=True)[0], x, fr)
    return np.abs(K - Kfd).max() / np.abs(K).max()


@pytest.mark.parametrize("variant", [MITC6(), NoTying()], ids=repr)
def test_element_tangent_matches_group_finite_differences(element, variant):
    X, frames, geom, C = element
    seen = np.zeros(3, dtype=int)
    for seed in (0, 1, 2):
        x, fr = deformed(X, frames, np.random.default_rng(seed), amplitude=0.03)
        eps = variant.element_strains(x, fr, geom)
        seen += np.bincount(membrane_regimes(eps[:, :3], C[:3, :3]), minlength=3)
        assert element_tangent_error(x, fr, geom, C, variant) < 1e-7
    assert np.all(seen > 0), seen


def test_element_tangent_check_can_fail(element, monkeypatch):
    """With the linear material stiffness in place of the law's tangent the check fails."""
    X, frames, geom, C = element
    x, fr = deformed(X, frames, np.random.default_rng(0), amplitude=0.03)
    from flexbody.shell.reference import loops
    original = loops.relaxed_section
    monkeypatch.setattr(loops, "relaxed_section", lambda eps, section: (original(eps, section)[0], section))
    assert element_tangent_error(x, fr, geom, C, MITC6()) > 1e-6


def test_force_is_the_gradient_of_the_relaxed_energy(element):
    X, frames, geom, C = element
    x, fr = deformed(X, frames, np.random.default_rng(1), amplitude=0.03)
    variant = MITC6()
    f = variant.element_force_tangent(x, fr, geom, C, wrinkling=True)[0]
    energy = lambda xx, ff: np.array([variant.element_strain_energy(xx, ff, geom, C, wrinkling=True)])  # noqa: E731
    fd = fd_tangent(energy, x, fr)[0]
    assert np.abs(f - fd).max() <= 1e-7 * np.abs(f).max()


# -- membrane patches ---------------------------------------------------------------------------------------


def patch_forces(u, young=2.0e5, nu=0.3, h=1e-4, size=1.0, wrinkling=True, variant=MITC6()):
    """Gauss-point membrane forces (global tensors, (m, 7, 3, 3)) of a flat square patch whose nodes all
    follow the displacement field u(x) (n, 3) -> (n, 3), and the body."""
    mesh = generators.strip(size, size, 2, 2, diagonal="alternate")
    body = ShellBody(mesh, ShellMaterial(young, nu, h, wrinkling=wrinkling), element=variant)
    s = body.initial_state()
    state = ShellState(s.x + u(s.x), s.frames)
    N = to_tensors(body.stresses(state), gauss_bases(mesh))[0]
    return N, body, state


def shear(gamma):
    return lambda x: np.column_stack([gamma * x[:, 1], 0 * x[:, 0], 0 * x[:, 0]])


@pytest.mark.parametrize("variant", [MITC6(), NoTying()], ids=repr)
def test_simple_shear_patch(variant):
    gamma, young, nu, h = 1e-7, 2.0e5, 0.3, 1e-4
    Eh, G = young * h, young / (2 * (1 + nu))
    linear, _, _ = patch_forces(shear(gamma), young, nu, h, wrinkling=False, variant=variant)
    relaxed, body, state = patch_forces(shear(gamma), young, nu, h, variant=variant)
    ref = G * h * gamma
    assert np.abs(linear[..., 0, 1] / ref - 1).max() < 1e-6
    assert np.abs(linear[..., 0, 0]).max() < 1e-6 * ref and np.abs(linear[..., 1, 1]).max() < 1e-6 * ref
    quarter = Eh * gamma / 4
    for i, j in ((0, 0), (1, 1), (0, 1)):
        assert np.abs(relaxed[..., i, j] / quarter - 1).max() < 1e-6
    assert np.abs(relaxed[..., 2, :]).max() < 1e-6 * quarter
    assert np.all(regimes_of(body, state) == [0, 7 * body.mesh.n_elements, 0])
    # the results' Gauss values and energies use the law too
    results = stress_resultants(body, state)
    np.testing.assert_array_equal(results.gauss, body.stresses(state))
    area = body.reference.weights.sum()
    assert abs(results.strain_energy / (area * Eh * gamma**2 / 8) - 1) < 1e-6      # W = Eh e1^2 / 2, e1 = g / 2
    # the readable element's strains differ from the kernel's by round-off, 1e-16 absolute on strains of 1e-7
    assert abs(body.strain_energy(state) / results.strain_energy - 1) < 1e-8
    assert abs(body.strain_energy(state, "numba") / results.strain_energy - 1) < 1e-12


def test_uniaxial_compression_patch_carries_nothing():
    """Uniaxial strain -gamma along x: e1 = 0 (slack up to the strains' round-off, 1e-16 absolute)."""
    gamma, young, h = 1e-6, 2.0e5, 1e-4
    u = lambda x: np.column_stack([-gamma * x[:, 0], 0 * x[:, 0], 0 * x[:, 0]])  # noqa: E731
    relaxed, _, _ = patch_forces(u, young, h=h)
    linear, _, _ = patch_forces(u, young, h=h, wrinkling=False)
    assert np.abs(linear).max() > 0.5 * young * h * gamma
    assert np.abs(relaxed).max() <= 1e-8 * young * h * gamma


def test_equibiaxial_tension_patch_is_linear():
    gamma, young, nu, h = 1e-7, 2.0e5, 0.3, 1e-4
    u = lambda x: np.column_stack([gamma * x[:, 0], gamma * x[:, 1], 0 * x[:, 0]])  # noqa: E731
    relaxed, body, state = patch_forces(u, young, nu, h)
    linear, _, _ = patch_forces(u, young, nu, h, wrinkling=False)
    np.testing.assert_allclose(relaxed, linear, rtol=0, atol=1e-12 * np.abs(linear).max())
    ref = young * h * gamma / (1 - nu)
    assert np.abs(relaxed[..., 0, 0] / ref - 1).max() < 1e-6 and np.abs(relaxed[..., 1, 1] / ref - 1).max() < 1e-6
    assert np.all(regimes_of(body, state) == [0, 0, 7 * body.mesh.n_elements])


@pytest.mark.parametrize("length, force, time", [(1.0, 1.0, 1.0), (1e-3, 1.0, 1.0), (1e6, 1e-6, 1.0)],
                         ids=["SI", "kilometres", "micrometres, micronewtons"])
def test_shear_patch_is_scale_free(length, force, time):
    """The shear patch of a 10 m, 10 um thick film of E = 5 GPa in metres, kilometres and micro-units."""
    gamma = 1e-7
    size, h = 10.0 * length, 1e-5 * length
    young = 5e9 * force / length**2
    relaxed, body, state = patch_forces(shear(gamma), young, 0.34, h, size)
    normalised = relaxed[..., :2, :2] / (young * h * gamma)
    np.testing.assert_allclose(normalised, np.full_like(normalised, 0.25), rtol=1e-6)
    f = body.element_forces(state, want_tangent=False)[0]
    assert np.all(np.isfinite(f))


# -- the body, the solvers, the inputs ----------------------------------------------------------------------


def test_mixed_iteration_is_unavailable_with_wrinkling():
    mesh = generators.strip(1.0, 1.0, 2, 2)
    body = ShellBody(mesh, ShellMaterial(2.0e5, 0.3, 0.01, wrinkling=True))
    assert not body.supports_mixed_iteration
    assert ShellBody(mesh, ShellMaterial(2.0e5, 0.3, 0.01)).supports_mixed_iteration
    assert not Model(body, []).supports_mixed_iteration          # what the static solver asks
    from integrators.protocols import capabilities
    assert not capabilities(Model(body, [])).mixed_iteration.supports_mixed_iteration
    state = body.initial_state()
    with pytest.raises(ValueError, match="linear section law"):
        body.mixed_element_forces(state, np.zeros((mesh.n_elements, 7, 8)))


def test_stress_rates_use_the_tangent_of_the_law():
    mesh = generators.strip(1.0, 1.0, 2, 2)
    body = ShellBody(mesh, ShellMaterial(2.0e5, 0.3, 0.01, wrinkling=True))
    s = body.initial_state()
    state = ShellState(s.x + shear(1e-4)(s.x), s.frames)
    hdot = np.random.default_rng(6).normal(size=(mesh.n_elements, 36))
    eps, deps = body._linearized_strains(state, hdot)
    Ct = relaxed_section(eps, body.material.section())[1]
    np.testing.assert_allclose(body.stress_rates(state, hdot), np.einsum("egij,egj->egi", Ct, deps), rtol=1e-14,
                               atol=0)
    np.testing.assert_array_equal(body.stresses(state, hdot),
                                  relaxed_section(eps, body.material.section())[0] + body.stress_rates(state, hdot))


@pytest.mark.parametrize("value", ["yes", 1, 0.0, None])
def test_wrinkling_must_be_a_bool(value):
    with pytest.raises(ValueError) as info:
        ShellMaterial(1.0, 0.3, 0.1, wrinkling=value)
    message = str(info.value)
    assert "\n" not in message and "wrinkling" in message and repr(value) in message


def test_mitc7_with_wrinkling_fails_at_construction():
    mesh = generators.strip(1.0, 1.0, 2, 2)
    with pytest.raises(ValueError) as info:
        ShellBody(mesh, ShellMaterial(1.0, 0.3, 0.1, wrinkling=True), element=MITC7())
    message = str(info.value)
    assert "\n" not in message and "wrinkling" in message and "MITC7" in message
    ShellBody(mesh, ShellMaterial(1.0, 0.3, 0.1), element=MITC7())     # without it: fine


SCENE = """
name = "wrinkling_patch"
[mesh]
generator = "strip"
length = 1.0
width = 1.0
nx = 2
ny = 2
[material]
young = 1.0e6
poisson = 0.3
thickness = 0.001
{extra}
[element]
tying = {tying}
[[bc]]
type = "fix"
set = ["clamped"]
[[load]]
type = "edge_force"
set = "tip"
density = [1.0, 0.0, 0.0]
[[output]]
name = "u_tip"
near = [1.0, 0.5, 0.0]
component = "x"
"""


def test_toml_key(tmp_path):
    from flexbody.cli.values import parse_sets
    from flexbody.scenes import load_toml_scene
    from flexbody.scenes.toml_values import SceneError

    def scene(extra="", tying="true", sets=()):
        path = tmp_path / "scene.toml"
        path.write_text(SCENE.format(extra=extra, tying=tying))
        return load_toml_scene(path, parse_sets(list(sets)))

    assert scene("wrinkling = true").model.body.material.wrinkling is True
    assert scene("wrinkling = false").model.body.material.wrinkling is False
    assert scene().model.body.material.wrinkling is False
    assert scene(sets=["wrinkling=true"]).model.body.material.wrinkling is True
    with pytest.raises(SceneError) as info:
        scene("wrinkling = true", tying='"mitc7"')
    assert "\n" not in str(info.value) and "wrinkling" in str(info.value)
    with pytest.raises(SceneError) as info:
        scene('wrinkling = "yes"')
    assert "\n" not in str(info.value) and "wrinkling" in str(info.value)


# -- whole solves and what the law refuses ------------------------------------------------------------------
def test_the_sail_runs_with_the_tension_field_and_carries_no_compression():
    """The 10 m sail (h/L = 1e-5, 2 rpm, rim pulse) started on its steady spin with the relaxed law: the steady
    spin (a static solve, load control from rest) and the dynamic steps converge, and no Gauss point carries a
    compressive principal membrane force (the linear law leaves most of them compressed after the pulse)."""
    from pathlib import Path
    from flexbody.scenes import load_toml_scene, run_scene
    sail = Path(__file__).resolve().parents[2] / "examples" / "solar_sail_10m.toml"
    def principal_forces(wrinkling):
        scene = load_toml_scene(sail, {"wrinkling": wrinkling, "end_time": 6.0})
        summary = run_scene(scene)
        assert summary.result.converged, summary.result.message
        n = scene.model.body.stresses(summary.result.state)[:, :, :3]
        mean, radius = 0.5 * (n[..., 0] + n[..., 1]), np.hypot(0.5 * (n[..., 0] - n[..., 1]), n[..., 2])
        return mean - radius, mean + radius

    smallest, largest = principal_forces(True)
    assert largest.max() > 0
    assert smallest.min() > -1e-9 * largest.max()
    linear_smallest, linear_largest = principal_forces(False)
    assert np.mean(linear_smallest < 0) > 0.1                             # the linear law: compressed regions


def test_buckling_damping_and_exudyn_refuse_the_tension_field_with_the_reason():
    from flexbody.buckling import geometric_stiffness
    from flexbody.constraints import Fix
    from flexbody.dynamics import DynamicModel, RayleighDamping
    mesh = generators.strip(1.0, 1.0, 2, 2)
    body = ShellBody(mesh, ShellMaterial(1e6, 0.3, 1e-3, density=1.0, wrinkling=True))
    model = Model(body, [Fix(mesh.node_set("clamped"), "all")], [])
    state = model.initial_state()
    with pytest.raises(ValueError, match="wrinkling"):
        geometric_stiffness(model, state, np.zeros((mesh.n_elements, 7, 8)))
    with pytest.raises(ValueError, match="wrinkling"):
        DynamicModel(model, damping=RayleighDamping(beta_stiffness=1e-3))
    DynamicModel(model, damping=RayleighDamping(alpha_mass=0.1))          # mass damping needs no stresses
    pytest.importorskip("exudyn")
    from types import SimpleNamespace
    from flexbody.adapters.exudyn.system import material
    with pytest.raises(ValueError, match="wrinkling"):
        material(SimpleNamespace(name="film", model=model))
