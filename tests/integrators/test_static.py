"""Static integrators on analytic models: convergence, cut-back, failure reports, arc-length snap-through."""

import numpy as np
import pytest
import scipy.sparse as sp

from integrators.linear import LinearSolver, SingularMatrixError
from integrators.newton import NewtonSettings, NewtonStats, newton_solve
from integrators.static import arc_length, load_control
from tests.integrators.toy import CubicSpring


def test_newton_converges_quadratically():
    model = CubicSpring(load=0.1)
    state, out = newton_solve(model.initial_state(), lambda q: model.residual(q, 1.0),
                              lambda q: model.residual_and_tangent(q, 1.0), model.update, 0.1,
                              NewtonSettings(rtol=1e-14, increment_tol=0.0), LinearSolver(), NewtonStats())
    assert out.converged
    r = [v for v in out.residuals if np.isfinite(v)]
    # quadratic: r_(k+1) <= C r_k^2 in the last iterations
    assert r[-1] < 1e-14 and r[-2] < 1e-5
    assert r[-1] <= 10 * r[-2] ** 2 + 1e-16
    assert abs(model.f_int(state[0]) - 0.1) < 1e-14


def test_modified_newton_reuses_the_factorization():
    model = CubicSpring(load=0.1)
    stats = NewtonStats()
    state, out = newton_solve(model.initial_state(), lambda q: model.residual(q, 1.0),
                              lambda q: model.residual_and_tangent(q, 1.0), model.update, 0.1,
                              NewtonSettings(policy="modified", refresh_ratio=0.9, rtol=1e-12),
                              LinearSolver(), stats)
    assert out.converged
    assert stats.factorizations < stats.iterations


def test_load_control_cuts_back_and_reaches_the_load():
    model = CubicSpring(load=0.15)
    result = load_control(model, [1.0], settings=NewtonSettings(max_iterations=3))
    assert result.converged and result.load_factor == 1.0
    assert result.cutbacks >= 1
    assert abs(model.f_int(result.state[0]) - 0.15) < 1e-8


def test_failure_keeps_the_last_converged_state_and_says_where():
    model = CubicSpring(load=0.15, fail_above=0.2)
    result = load_control(model, np.linspace(0.1, 1.0, 10), min_step=1e-3)
    assert not result.converged
    assert "load factor" in result.message and "non-finite" in result.message
    assert np.all(np.isfinite(result.state))
    assert result.state[0] <= 0.2
    lam = result.load_factor
    assert abs(model.f_int(result.state[0]) - lam * 0.15) < 1e-8


def test_singular_tangent_is_reported():
    solver = LinearSolver()
    with pytest.raises(SingularMatrixError, match="singular"):
        solver.factorize(sp.csc_matrix(np.zeros((2, 2))))


def test_arc_length_follows_snap_through_to_the_far_branch():
    """The load passes two limit points: lambda must go down and up again, and every step is on the curve."""
    model = CubicSpring(load=0.3)
    path = []
    result = arc_length(model, initial_increment=0.1, settings=NewtonSettings(rtol=1e-12),
                        on_step=lambda rec, q: path.append((rec.load_factor, q[0])))
    assert result.converged, result.message
    lam, w = np.array(path).T
    np.testing.assert_allclose(model.f_int(w), lam * 0.3, atol=1e-9)
    assert np.any(np.diff(lam) < 0), "the path must pass the limit point (load factor decreasing)"
    assert w.max() > 1 + 1 / np.sqrt(3)  # beyond the second limit point
    roots = np.roots([0.5, -1.5, 1.0, -0.3])
    far = roots[np.isreal(roots)].real.max()
    assert abs(result.state[0] - far) < 1e-8


def test_modified_newton_keeps_the_factorization_across_load_steps():
    """A mildly nonlinear spring: the first step's factorization serves the later steps too."""
    model = CubicSpring(load=0.01)
    full = load_control(model, np.linspace(0.1, 1.0, 10), settings=NewtonSettings(rtol=1e-10), adaptive=False)
    modified = load_control(model, np.linspace(0.1, 1.0, 10), adaptive=False,
                            settings=NewtonSettings(rtol=1e-10, policy="modified", refresh_ratio=0.5))
    assert full.converged and modified.converged
    assert full.stats.factorizations >= 10
    assert modified.stats.factorizations < 10 // 2
    assert abs(model.f_int(modified.state[0]) - 0.01) < 1e-12
