"""The assembled system: tangent against group finite differences with constraints and loads."""

import math

import numpy as np
import pytest

from flexbody.assembly import Model, ModelError
from flexbody.body import ShellBody
from flexbody.constraints import Fix, Symmetry
from flexbody.loads import FollowerPressure, NodalLoad
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial


def fd_check(model, state, lam, eps=1e-6):
    r, K = model.residual_and_tangent(state, lam)
    K = K.toarray()
    Kfd = np.zeros_like(K)
    for j in range(model.n_dof):
        e = np.zeros(model.n_dof)
        e[j] = eps
        Kfd[:, j] = (model.residual(model.update(state, e), lam) - model.residual(model.update(state, -e), lam)) / (2 * eps)
    return np.abs(K - Kfd).max() / np.abs(K).max()


def random_state(model, rng, scale=0.05):
    state = model.initial_state()
    for _ in range(3):
        state = model.update(state, scale * rng.normal(size=model.n_dof))
    return state


def cylinder_model(kernel="reference"):
    R = 2.0
    mesh = generators.cylinder(R, 1.5, 2, 2, angle=math.pi / 2)
    body = ShellBody(mesh, ShellMaterial(1e4, 0.3, 0.05), kernel=kernel)
    x = mesh.nodes
    cons = [Symmetry(np.flatnonzero(np.abs(x[:, 1]) < 1e-9), (0, 1.0, 0)),
            Symmetry(np.flatnonzero(np.abs(x[:, 2]) < 1e-9), (0, 0, 1.0)),
            Fix([mesh.nearest_node([0, R, 1.5])], ("x",))]
    a = mesh.nearest_node([R, 0, 0.75])
    loads = [NodalLoad([a], force=[3.0, 0, 1.0]),
             NodalLoad([mesh.nearest_node([0, R, 0.75])], moment=[0.5, 0.2, 0.1]),
             NodalLoad([mesh.nearest_node([R * math.cos(0.7), R * math.sin(0.7), 1.5])], force=[0.3, 0.2, 0.1],
                       moment=[0.1, 0.4, 0], follower=True),
             FollowerPressure(2.0)]
    return Model(body, cons, loads)


def test_model_tangent_with_symmetry_basis_and_loads():
    model = cylinder_model()
    state = random_state(model, np.random.default_rng(0))
    assert fd_check(model, state, 0.7) < 1e-6


def test_nodal_sums_of_element_vectors_are_those_of_add_at():
    """The residual's nodal sums (a bincount) are np.add.at's, bit for bit: the same terms in the same order."""
    model = cylinder_model(kernel="numba")
    fe = np.random.default_rng(4).normal(size=(model.body.mesh.n_elements, 36)) * 10.0 ** np.arange(-6, 6, 1 / 3)
    expected = np.zeros(6 * model.body.n_nodes)
    np.add.at(expected, model._dof6, fe)
    assert np.array_equal(model._sum_element_vectors(fe).ravel(), expected)


def test_an_unloaded_model_has_no_external_force():
    """Without loads the residual skips the external load; loads written into the arrays later are seen."""
    mesh = generators.strip(1.0, 1.0, 2, 2)
    model = Model(ShellBody(mesh, ShellMaterial(1e4, 0.3, 0.05)), [Fix(mesh.node_sets["clamped"], "all")])
    state = random_state(model, np.random.default_rng(5))
    assert model._unloaded()
    r = model.residual(state, 1.0)
    assert np.allclose(r, model.residual_and_tangent(state, 1.0)[0], rtol=0.0, atol=1e-12 * np.abs(r).max())
    model.dead[mesh.nearest_node([1.0, 1.0, 0.0]), 2] = 2.0
    assert not model._unloaded()
    assert np.abs(model.residual(state, 1.0) - r).max() > 1.0


def test_symmetry_frames_keep_their_plane():
    """On a symmetry plane the nodal frame keeps one in-plane axis along the plane normal."""
    model = cylinder_model()
    state = random_state(model, np.random.default_rng(1))
    x = model.body.mesh.nodes
    for i in np.flatnonzero(np.abs(x[:, 1]) < 1e-9):
        assert np.isclose(np.abs(state.frames[i][:, :2].T @ [0, 1.0, 0]).max(), 1.0, atol=1e-12)
        assert abs(state.x[i, 1]) < 1e-12


def test_load_on_constrained_dof_is_rejected():
    mesh = generators.strip(2.0, 1.0, 2, 1)
    body = ShellBody(mesh, ShellMaterial(1e4, 0.3, 0.05), kernel="reference")
    clamped = mesh.node_set("clamped")
    with pytest.raises(ModelError, match=f"node {clamped[0]}"):
        Model(body, [Fix(clamped, "all")], [NodalLoad([clamped[0]], force=[0, 0, 1.0])])


def test_unknown_node_is_rejected():
    mesh = generators.strip(2.0, 1.0, 2, 1)
    body = ShellBody(mesh, ShellMaterial(1e4, 0.3, 0.05), kernel="reference")
    with pytest.raises(ModelError, match="node 999"):
        Model(body, [Fix([999], "all")])


def test_warm_up_compiles_without_changing_anything():
    mesh = generators.strip(2.0, 1.0, 2, 1)
    body = ShellBody(mesh, ShellMaterial(1e4, 0.3, 0.05))
    model = Model(body, [Fix(mesh.node_set("clamped"), "all")], [NodalLoad(mesh.node_set("tip"), force=[0, 0, 1.0])])
    state = model.initial_state()
    r0 = model.residual(state, 0.5)
    model.warm_up()
    np.testing.assert_array_equal(model.residual(state, 0.5), r0)
    np.testing.assert_array_equal(model.initial_state().frames, state.frames)


def _fixed_stress_rows(model, state, lam):
    """The equations of the mixed iteration at fixed stresses: rows of f_int(stress) - lam f_ext."""
    turning = model._residual6(state, lam, want_tangent=True)[4]
    return model._rotate_rows(state, turning).ravel()[model.free]


def test_mixed_iteration_matrix_of_the_model():
    """K(q, s) - K(q, s_q) is the derivative of the fixed-stress equations S(q) (f(q; s) - lam f_ext) minus
    that at s_q = the state's own stresses (the material part cancels): the element geometric terms and
    the turning frame -hat(r_u) both carry the iterated stresses."""
    model = cylinder_model(kernel="numba")
    rng = np.random.default_rng(5)
    state = random_state(model, rng)
    lam, eps = 0.7, 1e-6
    own = model.with_stresses(state)
    other = own.copy()
    other.stress = own.stress + rng.normal(size=own.stress.shape) * 0.3 * np.abs(own.stress).max()

    def derivative(s):
        D = np.zeros((model.n_dof, model.n_dof))
        for j in range(model.n_dof):
            e = np.zeros(model.n_dof)
            e[j] = eps
            plus, minus = model.update(s, e), model.update(s, -e)
            plus.stress = minus.stress = s.stress          # the stresses held fixed
            D[:, j] = (_fixed_stress_rows(model, plus, lam) - _fixed_stress_rows(model, minus, lam)) / (2 * eps)
        return D

    K_other = model.residual_and_tangent(other, lam)[1].toarray()
    K_own = model.residual_and_tangent(own, lam)[1].toarray()
    np.testing.assert_allclose(K_own, model.residual_and_tangent(state, lam)[1].toarray(), rtol=0,
                               atol=1e-10 * np.abs(K_own).max())
    difference = derivative(other) - derivative(own)
    assert np.abs(difference).max() > 1e-3 * np.abs(K_own).max()   # the stresses matter
    assert np.abs((K_other - K_own) - difference).max() < 1e-6 * np.abs(K_own).max()
    # and the residual is the strains' own whatever the stresses
    r = model.residual(state, lam)
    np.testing.assert_allclose(model.residual_and_tangent(other, lam)[0], r, rtol=0, atol=1e-12 * np.abs(r).max())


def test_mixed_update_moves_the_stresses_on_linearly():
    """update() carries sigma <- C (eps(q) + B(q) dq): second-order close to the stresses of the new state."""
    model = cylinder_model(kernel="numba")
    rng = np.random.default_rng(6)
    state = model.with_stresses(random_state(model, rng))
    dq = rng.normal(size=model.n_dof)
    gaps = []
    for t in (1e-2, 5e-3):
        new = model.update(state, t * dq)
        gaps.append(np.abs(new.stress - model.with_stresses(new).stress).max())
    assert 3.0 < gaps[0] / gaps[1] < 5.0          # O(t^2)
