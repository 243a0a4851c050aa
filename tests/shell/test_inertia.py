"""Shell inertia: lumped masses, nodal inertia forces and their tangents (finite differences on the group)."""

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix, Symmetry
from flexbody.dynamics import DynamicModel
from flexbody.lie import so3
from flexbody.loads import NodalLoad
from flexbody.mesh import generators
from flexbody.shell import inertia
from flexbody.shell.material import ShellMaterial


pytestmark = pytest.mark.usefixtures("one_numba_thread")


def plate_body(nx=2, ny=1, length=1.0, width=0.5, E=1e6, h=0.01, rho=1000.0):
    mesh = generators.strip(length, width, nx, ny)
    return ShellBody(mesh, ShellMaterial(E, 0.3, h, density=rho))


# -- lumped mass ---------------------------------------------------------------------------------------------
def test_hrz_areas_of_a_straight_element_and_total_mass():
    body = plate_body(3, 2, 1.0, 0.5)
    w = body.reference.weights
    areas = inertia.hrz_nodal_areas(w[:1], body.mesh.elements[:1], body.n_nodes)
    a = w[0].sum()
    elem = areas[body.mesh.elements[0]]
    # HRZ on a straight-sided quadratic triangle: corners 3/57, midsides 16/57 of the area
    assert np.allclose(elem[:3], 3 / 57 * a, rtol=1e-12) and np.allclose(elem[3:], 16 / 57 * a, rtol=1e-12)
    inn = inertia.nodal_inertia(body)
    assert np.all(inn.mass > 0)
    assert inn.total_mass == pytest.approx(1000.0 * 0.01 * 0.5, rel=1e-12)
    assert inn.rotary.sum() == pytest.approx(1000.0 * 0.01**3 / 12 * 0.5, rel=1e-12)


def test_lumped_inertia_tensor_converges_to_the_plate():
    """The discrete inertia tensor of a rectangle a x b tends to m (b^2, a^2, a^2 + b^2)/12 (+ thickness)."""
    a, b, h = 1.0, 0.5, 0.01
    errors = []
    for n in (2, 8):
        body = plate_body(2 * n, n, a, b, h=h)
        dyn = DynamicModel(Model(body))
        _, I = dyn.rigid_inertia_tensor(body.initial_state())
        m = dyn.inertia.total_mass
        exact = m / 12 * np.diag([b * b + h * h, a * a + h * h, a * a + b * b])
        errors.append(np.abs(I - exact).max() / np.abs(exact).max())
    # measured: 3.16e-2 (n = 2) -> 1.97e-3 (n = 8): second order in the mesh size
    assert errors[1] < errors[0] / 12
    assert errors[1] < 2.5e-3


# -- nodal inertia forces and their tangents ----------------------------------------------------------------
def central(f, x, eps=1e-6):
    cols = []
    for k in range(len(x)):
        e = np.zeros(len(x))
        e[k] = eps
        cols.append((f(x + e) - f(x - e)) / (2 * eps))
    return np.column_stack(cols)


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def test_gyroscopic_tangent_against_finite_differences(rng):
    A = rng.normal(size=(3, 3))
    J = A @ A.T + np.eye(3)
    w, wdot = rng.normal(size=3), rng.normal(size=3)
    dJ, G = inertia.rotary_tangents(J, w)
    assert np.allclose(dJ, central(lambda z: inertia.rotary_force(J, w, z), wdot), atol=1e-8)
    assert np.allclose(G, central(lambda z: inertia.rotary_force(J, z, wdot), w), atol=1e-8)
    assert np.abs(G).max() > 0.1   # the gyroscopic matrix is not trivially zero here


def test_local_rows_tangent_on_the_group(rng):
    """f_u = R^T m a: derivative along R exp(eps e_k) by central differences on the group."""
    m, a = 2.5, rng.normal(size=3)
    R = so3.exp(rng.normal(size=3))
    dA, dT = inertia.translational_local_rows_tangents(m, R, a)
    fd = central(lambda th: inertia.translational_force_local_rows(m, R @ so3.exp(th), a), np.zeros(3))
    assert np.allclose(dT, fd, atol=1e-8)
    assert np.allclose(dA, central(lambda z: inertia.translational_force_local_rows(m, R, z), a), atol=1e-8)


def test_se3_local_velocity_force_on_a_trajectory(rng):
    """With v = R^T xdot: R^T m xddot = m (vdot + w x v), on an analytic trajectory (derivatives by FD)."""
    m = 1.7
    A, B = rng.normal(size=3), rng.normal(size=3)
    R = lambda t: so3.exp(A * t + B * t * t)
    x = lambda t: np.array([np.sin(t), t**3, np.cos(2 * t)])
    t, d = 0.4, 1e-4
    xd = lambda s: (x(s + d) - x(s - d)) / (2 * d)
    xdd = (x(t + d) - 2 * x(t) + x(t - d)) / d**2
    v = lambda s: R(s).T @ xd(s)
    vdot = (v(t + d) - v(t - d)) / (2 * d)
    w = so3.vee(R(t).T @ (R(t + d) - R(t - d)) / (2 * d))
    f = inertia.translational_force_se3(m, v(t), w, vdot)
    assert np.allclose(f, m * R(t).T @ xdd, atol=1e-5)
    # and its tangents
    dvd, dv, dw = inertia.translational_se3_tangents(m, v(t), w)
    assert np.allclose(dv, central(lambda z: inertia.translational_force_se3(m, z, w, vdot), v(t)), atol=1e-8)
    assert np.allclose(dw, central(lambda z: inertia.translational_force_se3(m, v(t), z, vdot), w), atol=1e-8)
    assert np.allclose(dvd, m * np.eye(3))


def test_director_inertia_reduces_to_j_wdot_without_drilling():
    """j tddot . R (e_a x e3) = j wdot_a on a frame path with w_3 = 0 (the centripetal part is normal)."""
    j = 0.3
    wfun = lambda t: np.array([np.sin(3 * t) + 0.5, np.cos(2 * t), 0.0])
    dt, n = 1e-5, 60000                      # frame path: R' = R hat(w), midpoint exponential steps
    R = np.eye(3)
    frames = [R]
    for k in range(n):
        R = R @ so3.exp(dt * wfun((k + 0.5) * dt))
        frames.append(R)
    k, s = n // 2, 300                       # evaluate at t = k dt, difference step s dt
    t = k * dt
    d = lambda i: frames[k + i * s][:, 2]   # fourth-order central second difference
    tdd = (-d(2) + 16 * d(1) - 30 * d(0) + 16 * d(-1) - d(-2)) / (12 * (s * dt) ** 2)
    wdot = (wfun(t + 1e-6) - wfun(t - 1e-6)) / 2e-6
    Rk = frames[k]
    for a in (0, 1):
        virtual = Rk @ np.cross(np.eye(3)[a], [0, 0, 1.0])
        assert j * tdd @ virtual == pytest.approx(j * wdot[a], abs=3e-6)
    # the shell node's inertia force: no gyroscopic term for J = j diag(1, 1, 0) and w_3 = 0 ...
    f = inertia.shell_node_force(2.0, j, np.zeros(3), wfun(t)[:2], wdot[:2])
    assert np.allclose(f[3:], j * wdot[:2], atol=1e-14)
    # ... which a drilling velocity would bring back
    w3 = wfun(t) + np.array([0, 0, 0.7])
    assert np.abs(inertia.rotary_force(inertia.director_tensor(j), w3, np.zeros(3))[:2]).max() > 0.05


# -- the dynamic model ----------------------------------------------------------------------------------------
def constrained_dynamic_model():
    mesh = generators.cylinder(2.0, 1.5, 2, 2, angle=np.pi / 2)
    body = ShellBody(mesh, ShellMaterial(1e4, 0.3, 0.05, density=3.0))
    x = mesh.nodes
    cons = [Symmetry(np.flatnonzero(np.abs(x[:, 1]) < 1e-9), (0, 1.0, 0)),
            Fix([mesh.nearest_node([0, 2.0, 1.5])], ("x",))]
    loads = [NodalLoad([mesh.nearest_node([2.0, 0, 0.75])], force=[3.0, 0, 1.0]),
             NodalLoad([mesh.nearest_node([0, 2.0, 0.75])], moment=[0.5, 0.2, 0.1], follower=True)]
    return DynamicModel(Model(body, cons, loads), gravity=(0.0, 0.0, -9.81), load_factor=lambda t: 1 + t)


def test_dynamic_tangent_against_group_finite_differences(rng):
    dyn = constrained_dynamic_model()
    assert np.any(dyn.model.has_basis) and np.any(dyn.local_columns)
    state = dyn.model.initial_state()
    for _ in range(3):
        state = dyn.update(state, 0.05 * rng.normal(size=dyn.n_dof))
    vdot, z = rng.normal(size=dyn.n_dof), np.zeros(dyn.n_dof)
    r, K = dyn.residual_and_tangent(state, z, vdot, 0.3)
    K = K.toarray()
    fd = central(lambda d: dyn.residual(dyn.update(state, d), z, vdot, 0.3), np.zeros(dyn.n_dof))
    assert np.abs(K - fd).max() < 1e-6 * np.abs(K).max()
    assert np.allclose(r, dyn.residual(state, z, vdot, 0.3))


def test_global_columns_are_the_model_tangent_times_the_column_map(rng):
    """The dynamic layout's tangent is made in the scatter (``global_columns``): the Model's tangent with local
    translation columns times the column map D (R_I^T on the local-column nodes), to round-off."""
    dyn = constrained_dynamic_model()
    state = dyn.model.initial_state()
    for _ in range(3):
        state = dyn.update(state, 0.05 * rng.normal(size=dyn.n_dof))
    r_local, K_local = dyn.model.residual_and_tangent(state, 1.3)
    r, K = dyn.model.residual_and_tangent(state, 1.3, global_columns=True)
    assert np.array_equal(r, r_local)
    expected = (K_local @ dyn.column_map(state)).toarray()
    assert np.abs(K.toarray() - expected).max() < 1e-13 * np.abs(expected).max()


def test_translation_increments_are_global_and_exact(rng):
    dyn = constrained_dynamic_model()
    state = dyn.update(dyn.model.initial_state(), 0.1 * rng.normal(size=dyn.n_dof))
    dq = np.zeros(dyn.n_dof)
    i = np.flatnonzero(dyn.local_columns)[:3]
    dq[i] = [0.1, -0.2, 0.3]
    new = dyn.update(state, dq)
    node = dyn.node[i[0]]
    assert np.allclose(new.x[node] - state.x[node], [0.1, -0.2, 0.3], atol=1e-14)
    assert np.allclose(new.frames, state.frames)


def test_mass_gravity_and_rigid_velocity():
    body = plate_body(2, 1)
    dyn = DynamicModel(Model(body), gravity=(0, 0, -9.81))
    state = body.initial_state()
    # gravity on a free body: vdot_0 = g on the translations, 0 on the rotations
    a0 = dyn.initial_acceleration(state)
    tr = dyn.is_translation
    assert np.allclose(a0[tr & (dyn.comp == 2)], -9.81) and np.allclose(a0[~tr], 0.0, atol=1e-9)
    # a rigid spin: momenta and kinetic energy of the discrete rigid body
    c, I = dyn.rigid_inertia_tensor(state)
    omega = np.array([0.3, -1.2, 0.4])
    v = dyn.rigid_velocity(state, omega, v0=[1.0, 0, 0], center=c)
    p, L = dyn.momenta(state, v, center=c)
    assert np.allclose(p, dyn.inertia.total_mass * np.array([1.0, 0, 0]))
    assert np.allclose(L, I @ omega, rtol=1e-12, atol=1e-14)
    ke = dyn.kinetic_energy(v)
    assert ke == pytest.approx(0.5 * dyn.inertia.total_mass + 0.5 * omega @ I @ omega, rel=1e-12)
    assert dyn.strain_energy(state) == pytest.approx(0.0, abs=1e-20)


def test_fast_strain_energy_matches_the_body(rng):
    dyn = constrained_dynamic_model()
    state = dyn.update(dyn.model.initial_state(), 0.05 * rng.normal(size=dyn.n_dof))
    e = dyn.strain_energy(state)
    assert e > 0 and e == pytest.approx(dyn.model.body.strain_energy(state), rel=1e-10)


def test_internal_force_is_the_energy_gradient_along_the_5dof_update(rng):
    """Energy conservation of the dynamics rests on dW = f_int . dq for the 5-DoF update (no drilling):
    central differences of the strain energy along q o exp(eps d) against the residual of a load-free model."""
    mesh = generators.cylinder(2.0, 1.5, 2, 2, angle=np.pi / 2)
    body = ShellBody(mesh, ShellMaterial(1e4, 0.3, 0.05, density=3.0))
    x = mesh.nodes
    dyn = DynamicModel(Model(body, [Symmetry(np.flatnonzero(np.abs(x[:, 1]) < 1e-9), (0, 1.0, 0))]))
    state = dyn.update(dyn.model.initial_state(), 0.05 * rng.normal(size=dyn.n_dof))
    f = dyn.internal_minus_external(state, 0.0)
    for _ in range(3):
        d = rng.normal(size=dyn.n_dof)
        eps = 1e-6
        dW = (dyn.strain_energy(dyn.update(state, eps * d)) - dyn.strain_energy(dyn.update(state, -eps * d))) / (2 * eps)
        assert dW == pytest.approx(f @ d, rel=1e-6)



@pytest.mark.parametrize("increment, limit", [(0.002, 0.75), (0.01, 0.65), (0.03, 0.6)])
def test_transfer_follows_the_tilt_of_the_directors_of_a_bending_plate(increment, limit):
    """A thin clamped plate bent to w = 0.05 x^2 (iteration matrix S1 = K + M / (beta h^2) made there), then bent
    further by ``increment`` x^2: the modified Newton iteration on the old matrix contracts at the spectral
    radius of I - S^-1 S2, S = S1 as it is or carried with P (per node: the rotation of its patch,
    DynamicModel.transfer). The turn of the surface carries a good part of the change (measured radii
    0.060 -> 0.036, 0.332 -> 0.195, 1.248 -> 0.693), which keeps a kept matrix converging on a swinging membrane
    (docs/dynamics.md: 0.120 -> 0.010 fresh matrices per step on the kicked hub annulus)."""
    mesh = generators.strip(1.0, 0.5, 4, 2)
    dyn = DynamicModel(Model(ShellBody(mesh, ShellMaterial(1e9, 0.3, 1e-3, density=1000.0)),
                             [Fix(mesh.node_sets["clamped"], "all")]))

    def bend(q, c):                                   # w = c x^2 with the directors along the normal
        xdot, omega = np.zeros_like(q.x), np.zeros_like(q.x)
        xdot[:, 2], omega[:, 1] = c * q.x[:, 0] ** 2, -2.0 * c * q.x[:, 0]
        return dyn.update(q, dyn.velocity_from_nodal(q, xdot, omega))

    z = np.zeros(dyn.n_dof)
    inertia = dyn.mass_matrix().toarray() / (0.3 * 1e-3 ** 2)
    q1 = bend(dyn.model.initial_state(), 0.05)
    q2 = bend(q1, increment)
    S1 = dyn.residual_and_tangent(q1, z, z, 0.0)[1].toarray() + inertia
    S2 = dyn.residual_and_tangent(q2, z, z, 0.0)[1].toarray() + inertia
    T = dyn.transfer(q1, q2)
    P = np.column_stack([dyn.apply_transfer(e, T) for e in np.eye(dyn.n_dof)])
    assert np.allclose(P.T @ P, np.eye(dyn.n_dof), rtol=0, atol=1e-14)          # orthogonal
    radius = lambda S: np.abs(np.linalg.eigvals(np.eye(dyn.n_dof) - np.linalg.solve(S, S2))).max()
    assert radius(P @ S1 @ P.T) < limit * radius(S1), (radius(P @ S1 @ P.T), radius(S1))

@pytest.mark.parametrize("curved", [False, True])
def test_transfer_carries_residual_and_tangent_along_rigid_motion(rng, curved):
    """r(Q q D) = P r(q) and K(Q q D) = P K(q) P^T for a rigid rotation Q of a deformed free body whose frames
    also turn by a common drilling rotation D (what parallel transport does): the basis of the reuse of an old
    factorization in integrators.generalized_alpha."""
    mesh = generators.cylinder(2.0, 1.5, 2, 2, angle=np.pi / 2) if curved else generators.strip(1.0, 0.5, 2, 1)
    dyn = DynamicModel(Model(ShellBody(mesh, ShellMaterial(1e6, 0.3, 0.01, density=1000.0))))
    q = dyn.update(dyn.model.initial_state(), 0.02 * rng.normal(size=dyn.n_dof))
    Q, D = so3.exp(np.array([0.4, -0.3, 0.8])), so3.exp(np.array([0.0, 0.0, 0.3]))
    q2 = q.copy()
    q2.x = q.x @ Q.T + 0.5
    q2.frames = np.einsum("ij,njk,kl->nil", Q, q.frames, D)
    z = np.zeros(dyn.n_dof)
    r1, K1 = dyn.residual_and_tangent(q, z, z, 0.0)
    r2, K2 = dyn.residual_and_tangent(q2, z, z, 0.0)
    T = dyn.transfer(q, q2)
    P = np.column_stack([dyn.apply_transfer(e, T) for e in np.eye(dyn.n_dof)])
    assert np.allclose(P.T, np.column_stack([dyn.apply_transfer(e, T, transpose=True) for e in np.eye(dyn.n_dof)]))
    assert np.abs(P @ r1 - r2).max() < 1e-12 * np.abs(r1).max()              # measured ~1e-15
    assert np.abs(P @ K1.toarray() @ P.T - K2.toarray()).max() < 1e-12 * np.abs(K1).max()
