"""Modal analysis (flexbody/modal.py): the gyroscopic matrix against finite differences, the eigen-solvers against
dense solutions, a simply supported plate against the exact (Leissa) frequencies, spinning membranes against an
independent 1-D radial eigenproblem, the rigid modes of a free spinning body, and the ``flexbody modes`` command."""

import json

import numpy as np
import pytest
import scipy.linalg

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel
from flexbody.lie import so3
from flexbody.mesh import generators
from flexbody.modal import (default_shift, describe_modes, gyroscopic_matrix, modal_problem_at_rest, modal_problem_in_spin,
                            quadratic_modes, solve_modes)
from flexbody.shell.material import ShellMaterial
from flexbody.spinning import gauge_supports
from tests.membrane_reference import lamb_southwell, radial_membrane_frequencies
from tests.test_assembly import random_state

pytestmark = pytest.mark.usefixtures("one_numba_thread")

A, B, E, NU, RHO, OMEGA = 0.2, 1.0, 1e9, 0.3, 1000.0, 20.0


def annulus(n_radial, n_circ, hub="translations", thickness=1e-4, scale=1.0, mass="lumped"):
    mesh = generators.annulus(A * scale, B * scale, n_radial, n_circ)
    cons = [Fix(mesh.node_set("inner"), hub)] if hub else []
    return DynamicModel(Model(ShellBody(mesh, ShellMaterial(E, NU, thickness * scale, density=RHO)), cons),
                        mass=mass)


def test_gyroscopic_matrix_against_finite_differences_of_the_kinetic_energy():
    """G = dp/dq - (dp/dq)^T with p = dT/dqdot of the co-rotating kinetic energy
    T = sum m/2 |Omega x x + xdot|^2 + j/2 |Omega x t + tdot|^2, by central differences in the coordinates of
    the group update (x + E dv, R exp(theta_1 e1 + theta_2 e2)); a deformed state, a tilted spin axis, and the
    gauge supports of a free body (nodes with a fixed translation basis)."""
    rng = np.random.default_rng(5)
    dyn0 = annulus(1, 6, hub=None, thickness=0.05)
    omega = np.array([3.0, -2.0, 20.0])
    dyn = DynamicModel(Model(dyn0.model.body, gauge_supports(dyn0, omega, np.zeros(3))))
    assert dyn.model.has_basis.sum() == 2
    state = random_state(dyn.model, rng, scale=0.05)
    G = gyroscopic_matrix(dyn, state, omega).toarray()
    assert np.abs(G + G.T).max() <= 1e-14 * np.abs(G).max()
    m, j = dyn.inertia.mass, dyn.inertia.rotary
    h = 1e-5
    index = -np.ones(6 * dyn.model.body.n_nodes, dtype=int)
    index[dyn.model.free] = np.arange(dyn.n_dof)
    checked = 0
    for node in range(dyn.model.body.n_nodes):
        E_ = dyn.model.basis[node]
        free_t = np.flatnonzero(~dyn.model.fixed[node, :3])
        Et = E_[:, free_t]

        def p_trans(v):          # dT/dvdot at vdot = 0
            return m[node] * Et.T @ np.cross(omega, state.x[node] + Et @ v)

        def director(theta):
            return (state.frames[node] @ so3.exp(np.array([theta[0], theta[1], 0.0])))[:, 2]

        def p_rot(theta):
            dt = np.column_stack([(director(theta + h * e) - director(theta - h * e)) / (2 * h) for e in np.eye(2)])
            return j[node] * dt.T @ np.cross(omega, director(theta))

        for p, size, first in ((p_trans, free_t.size, 0), (p_rot, 2, 3)):
            D = np.column_stack([(p(1e-3 * e) - p(-1e-3 * e)) / 2e-3 for e in np.eye(size)])
            Gfd = D - D.T
            dofs = index[6 * node + (free_t if first == 0 else np.array([3, 4]))]
            block = G[np.ix_(dofs, dofs)]
            assert np.abs(block - Gfd).max() <= 1e-6 * max(np.abs(Gfd).max(), 1e-300) + 1e-12 * np.abs(G).max()
            # no coupling between the nodes or between translations and rotations
            others = np.setdiff1d(np.arange(dyn.n_dof), dofs)
            assert not np.any(G[np.ix_(dofs, others)])
            checked += 1
    assert checked == 2 * dyn.model.body.n_nodes


def test_gyroscopic_matrix_of_the_consistent_mass_against_finite_differences():
    """Consistent mass: the translational momenta p = T^T (S x I)(Omega x x + xdot) couple the nodes; G on the
    translations is dp/dq - (dp/dq)^T by central differences of x + T v (gauge supports, tilted axis)."""
    rng = np.random.default_rng(7)
    dyn0 = annulus(1, 6, hub=None, thickness=0.05, mass="consistent")
    omega = np.array([3.0, -2.0, 20.0])
    dyn = DynamicModel(Model(dyn0.model.body, gauge_supports(dyn0, omega, np.zeros(3))), mass="consistent")
    state = random_state(dyn.model, rng, scale=0.05)
    G = gyroscopic_matrix(dyn, state, omega).toarray()
    T = dyn.translation_directions().toarray()
    S3 = np.kron(dyn.body_mass.scalar.toarray(), np.eye(3))
    tr = np.flatnonzero(np.abs(T).sum(axis=0) > 0)
    x0 = state.x.ravel()

    def p(v):
        x = (x0 + T @ v).reshape(-1, 3)
        return T.T @ S3 @ np.cross(omega, x).ravel()

    D = np.column_stack([(p(1e-3 * e) - p(-1e-3 * e)) / 2e-3 for e in np.eye(dyn.n_dof)[tr]])[tr]
    Gfd = D - D.T
    assert np.abs(G[np.ix_(tr, tr)] - Gfd).max() <= 1e-9 * np.abs(Gfd).max()
    lumped = DynamicModel(Model(dyn0.model.body, gauge_supports(dyn0, omega, np.zeros(3))))
    assert np.abs(gyroscopic_matrix(lumped, state, omega).toarray()[np.ix_(tr, tr)] - Gfd).max() \
        > 1e-2 * np.abs(Gfd).max()       # the lumped masses in it would be wrong


def test_quadratic_solver_against_a_dense_solution():
    """The sparse shift-invert solution of (-omega^2 M + i omega G + K) phi = 0 against scipy.linalg.eig of the
    first-order form, on a small hub annulus in spin (every mode, residual of each returned vector)."""
    dyn = annulus(1, 8, hub="all", thickness=2e-3)
    p = modal_problem_in_spin(dyn, [0.0, 0.0, OMEGA], [0.0, 0.0, 0.0])
    K, G, M = p.K.toarray(), p.G.toarray(), p.M.toarray()
    n = K.shape[0]
    Afull = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -G]])
    Bfull = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), M]])
    lam = scipy.linalg.eig(Afull, Bfull, right=False)
    dense = np.sort(lam.imag[lam.imag > 0])[:8]
    freq, vec = quadratic_modes(p.K, p.G, p.M, 8, OMEGA ** 2)
    assert np.allclose(freq, dense, rtol=1e-8)
    for w, phi in zip(freq, vec.T):
        r = (-w * w * M + 1j * w * G + K) @ phi
        assert np.abs(r).max() <= 1e-8 * np.abs(K).max() * np.abs(phi).max()


def test_simply_supported_plate_converges_to_the_exact_frequencies():
    """Square plate a x a, w = 0 on the edges, h / a = 1e-3: omega a^2 sqrt(rho h / D) -> pi^2 (m^2 + n^2)
    (Leissa, Vibration of Plates, NASA SP-160, 1969, eq. 4.21: the Navier solution, exact for Kirchhoff plates)."""
    a, h = 1.0, 1e-3
    D = E * h ** 3 / (12 * (1 - NU ** 2))
    exact = np.sort([np.pi ** 2 * (m * m + n * n) for m in range(1, 4) for n in range(1, 4)])[:6]
    errors = []
    for ne in (4, 8):
        mesh = generators.strip(a, a, ne, ne)
        edges = np.unique(np.concatenate([mesh.node_set(s) for s in ("clamped", "tip", "bottom", "top")]))
        x = mesh.nodes
        c0 = np.flatnonzero(np.linalg.norm(x[:, :2], axis=1) < 1e-12)
        c1 = np.flatnonzero(np.linalg.norm(x[:, :2] - [a, 0.0], axis=1) < 1e-12)
        model = Model(ShellBody(mesh, ShellMaterial(E, NU, h, density=RHO)),
                      [Fix(edges, "z"), Fix(c0, ("x", "y")), Fix(c1, "y")])
        modes = solve_modes(modal_problem_at_rest(DynamicModel(model)), 6)
        errors.append(np.abs(modes.frequencies * a * a * np.sqrt(RHO * h / D) / exact - 1))
    assert np.all(errors[1] < errors[0])
    assert errors[1].max() < 0.02 and errors[1][0] < 0.006     # measured: 0.019, 0.0053 (docs/modal.md)


def test_spinning_annulus_transverse_modes_converge_to_the_membrane_reference():
    """The annulus a = 0.2, b = 1 pinned to a hub at 20 rad/s, h = 1e-4 (membrane limit): the transverse
    frequencies (n = 0..3 nodal diameters, no nodal circle) against the 1-D radial eigenproblem with the
    rotating-disk pre-stress, closer on the finer mesh; nodal diameters recognised."""
    ref = {n: radial_membrane_frequencies(n, 1, OMEGA, A, B, E, NU, RHO, "hub", 400)[0] for n in range(4)}
    errs = []
    for n_radial, n_circ in ((2, 16), (4, 32)):
        p = modal_problem_in_spin(annulus(n_radial, n_circ), [0.0, 0.0, OMEGA], [0.0, 0.0, 0.0])
        modes = solve_modes(p, 7)
        reports = describe_modes(modes)
        by_n = {}
        for r in reports:
            if r.nodal_circles == 0:
                by_n.setdefault(r.nodal_diameters, r.frequency_rad_s)
        errs.append(np.array([abs(by_n[n] / ref[n] - 1) for n in range(4)]))
        assert [r.nodal_diameters for r in reports] == [0, 1, 1, 2, 2, 3, 3]
    assert np.all(errs[1] < errs[0] + 1e-4)
    assert errs[1].max() < 0.005                      # measured 0.0044 (n = 3); docs/modal.md


def test_spin_shift_does_not_grow_with_slenderness():
    """At h/R = 1e-6 the rest floor of the shift (1e-12 max K_ii/M_ii, ~1/h^2 through the directors' rotary
    inertia) lies far above the spin's modes; in spin the shift is Omega^2 and the modes are found: the 2 x 16
    hub annulus against the membrane reference as at h = 1e-4 (worst 4.5 %, docs/modal.md)."""
    ref = {n: radial_membrane_frequencies(n, 1, OMEGA, A, B, E, NU, RHO, "hub", 400)[0] for n in range(4)}
    p = modal_problem_in_spin(annulus(2, 16, thickness=1e-6), [0.0, 0.0, OMEGA], [0.0, 0.0, 0.0])
    assert default_shift(p) == OMEGA ** 2
    dm = p.M.diagonal()
    assert 1e-12 * np.max(np.abs(p.K.diagonal()) / np.where(dm > 0, dm, np.inf)) > 100 * OMEGA ** 2
    reports = describe_modes(solve_modes(p, 7))
    by_n = {}
    for r in reports:
        if r.nodal_circles == 0:
            by_n.setdefault(r.nodal_diameters, r.frequency_rad_s)
    assert max(abs(by_n[n] / ref[n] - 1) for n in range(4)) < 0.05


def test_free_spinning_annulus_rigid_modes():
    """A free spinning body, seen from the co-rotating frame: the axial translation and the rotation about the
    axis at omega = 0, the in-plane translations and the tilts (n = 1) at omega = Omega (at rest in the
    inertial frame, Lamb & Southwell's n = 1, s = 0 root)."""
    dyn = annulus(2, 16, hub=None, thickness=1e-4)
    modes = solve_modes(modal_problem_in_spin(dyn, [0.0, 0.0, OMEGA], [0.0, 0.0, 0.0]), 8)
    w = modes.frequencies
    # both are double roots with one eigenvector each (a rigid drift grows linearly in time): computed to
    # about sqrt(machine epsilon), measured 3e-6 relative
    assert np.allclose(w[:2], 0.0, atol=2e-5 * OMEGA)
    assert np.allclose(w[2:6], OMEGA, rtol=2e-5)
    assert w[6] > 1.2 * OMEGA
    assert lamb_southwell(1, 0, NU) == pytest.approx(1.0)


def test_spin_frequencies_are_scale_free():
    """The hub annulus in millimetre and kilometre units at the same rim speed (Omega b fixed): the same
    omega / Omega."""
    out = []
    for scale in (1e-3, 1e3):
        p = modal_problem_in_spin(annulus(2, 16, thickness=1e-3, scale=scale), [0.0, 0.0, OMEGA / scale],
                                  [0.0, 0.0, 0.0])
        out.append(solve_modes(p, 6).frequencies * scale / OMEGA)
    assert np.allclose(out[0], out[1], rtol=1e-7)


def test_lamb_southwell_reproduced_by_the_radial_eigenproblem():
    """The closed form (docs/modal.md) and the 1-D finite elements on the full disk agree."""
    for n in range(4):
        fe = radial_membrane_frequencies(n, 3, OMEGA, 0.0, 1.0, E, NU, RHO, "disk", 200) / OMEGA
        exact = [lamb_southwell(n, s, NU) for s in range(3)]
        assert np.allclose(fe[1 if n == 0 else 0:], exact[1 if n == 0 else 0:], rtol=1e-6)


def test_modes_command_writes_the_json_and_refuses_bad_input(tmp_path, capsys):
    from flexbody.cli import main
    out, h5 = tmp_path / "modes.json", tmp_path / "modes.h5"
    assert main(["modes", "examples/kicked_spinning_annulus.toml", "--set", "n_radial=2", "--set", "n_circ=16",
                 "--count", "5", "--json", str(out), "--h5", str(h5), "--quiet"]) == 0
    data = json.loads(out.read_text())
    import h5py
    with h5py.File(h5, "r") as f:
        assert f.attrs["format"] == "flexbody-modes"
        assert np.allclose(f["modes/frequency_rad_s"][()], data["frequencies_rad_s"])
        assert f["modes/shape_real"].shape == (5, len(f["mesh/nodes"]), 3)
    assert data["frame"] == "co-rotating" and data["omega"] == pytest.approx(OMEGA)
    assert data["frequencies_rad_s"] == sorted(data["frequencies_rad_s"])
    assert [m["nodal_diameters"] for m in data["modes"]] == [0, 1, 1, 2, 2]
    assert set(data["modes"][0]) >= {"frequency_rad_s", "nodal_diameters", "nodal_circles"}
    for argv, match in ((["--count", "0"], "--count"), (["--omega", "-1"], "--omega"),
                        (["--sweep", "omega=1,x"], "omega"), (["--load-factor", "2"], "static scene")):
        with pytest.raises(SystemExit) as exc:
            main(["modes", "examples/kicked_spinning_annulus.toml", "--quiet", *argv])
        assert match in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(SystemExit, match="density"):
        main(["modes", "examples/clamped_plate.toml", "--quiet"])


def test_free_plate_has_six_rigid_modes_near_zero_and_its_elastic_modes():
    """A free plate at rest: the shift keeps K + s M regular; six rigid modes at omega ~ 0, then the elastic
    ones. Held by six corner supports (statically determinate: they stop the rigid motions only), its lowest
    frequency interlaces (Rayleigh: six constraints): free omega_1 <= held omega_1 <= free omega_7."""
    mesh = generators.strip(1.0, 1.0, 4, 4)
    body = ShellBody(mesh, ShellMaterial(E, NU, 1e-3, density=RHO))
    w = solve_modes(modal_problem_at_rest(DynamicModel(Model(body, []))), 8).frequencies
    assert np.all(np.abs(w[:6]) < 1e-3 * w[6])
    x = mesh.nodes
    c = [int(np.argmin(np.linalg.norm(x - p, axis=1))) for p in ([0, 0, 0], [1, 0, 0], [0, 1, 0])]
    held = Model(body, [Fix([c[0]], ("x", "y", "z")), Fix([c[1]], ("y", "z")), Fix([c[2]], "z")])
    w_held = solve_modes(modal_problem_at_rest(DynamicModel(held)), 2).frequencies
    assert w[0] <= w_held[0] <= w[6] * (1 + 1e-9)


def test_plate_spinning_about_its_long_axis_wobbles_at_eulers_frequency():
    """A gyroscopic case with a spin axis in the plate's plane: a stiff free 2 x 1 plate spinning about its long
    axis (the least moment of inertia: stable). Its rigid wobble, seen in the turning frame, has Euler's
    frequency omega^2 = Omega^2 (I3 - I1)(I2 - I1) / (I3 I2) (the linearized Euler equations, e.g. Goldstein,
    Classical Mechanics, 5.6), with I1 = m W^2/12 + J, I2 = m L^2/12 + J, I3 = m (L^2 + W^2)/12 and the
    director inertia J = rho h^3/12 L W; the elastic modes lie far above (measured: 7.6e-8 relative)."""
    L, W, h, rho, Om = 2.0, 1.0, 0.02, 1000.0, 2.0
    mesh = generators.strip(L, W, 4, 2)
    dyn = DynamicModel(Model(ShellBody(mesh, ShellMaterial(1e11, NU, h, density=rho)), []), mass="consistent")
    m, J = rho * h * L * W, rho * h**3 / 12 * L * W
    I1, I2, I3 = m * W**2 / 12 + J, m * L**2 / 12 + J, m * (L**2 + W**2) / 12
    euler = Om * np.sqrt((I3 - I1) * (I2 - I1) / (I3 * I2))
    problem = modal_problem_in_spin(dyn, [Om, 0.0, 0.0], [L / 2, W / 2, 0.0])
    w = solve_modes(problem, 7).frequencies
    assert np.allclose(w[:2], 0.0, atol=1e-3 * Om)                 # along and about the axis
    assert w[2] == pytest.approx(euler, rel=1e-6)
    assert np.allclose(w[3:6], Om, rtol=1e-3)                      # the two transverse translations, the tilt
    assert w[6] > 50 * Om
