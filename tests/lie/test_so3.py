"""SO(3) reference: exp/log round trips, tangent operators and their derivatives against finite differences,
and the accuracy and continuity of the scalar coefficients across the series switch."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from flexbody.lie import so3

S = so3.SERIES_SWITCH
FD_EPS = 1e-5
FD_TOL = 1e-9  # central differences with FD_EPS are good to ~3e-11 here

# ---------------------------------------------------------------------------------------------------------
# Finite-difference checks: each returns the max error, so a test can also show that it is able to fail.
# ---------------------------------------------------------------------------------------------------------


def fd_error_tangent(phi: np.ndarray, eps: float = FD_EPS) -> float:
    """max |T(phi) - T_fd|, T_fd[:, j] = (log(exp(phi)^T exp(phi + eps e_j)) - (same, -eps)) / (2 eps)."""
    R = so3.exp(phi)
    cols = [(so3.log(R.T @ so3.exp(phi + eps * e)) - so3.log(R.T @ so3.exp(phi - eps * e))) / (2 * eps)
            for e in np.eye(3)]
    return float(np.abs(so3.tangent(phi) - np.column_stack(cols)).max())


def fd_error_d_tangent(phi: np.ndarray, b: np.ndarray, eps: float = FD_EPS) -> float:
    """max |d_tangent(phi, b) - X_fd|, X_fd[:, j] = central difference of T(phi) b along e_j."""
    cols = [(so3.tangent(phi + eps * e) - so3.tangent(phi - eps * e)) @ b / (2 * eps) for e in np.eye(3)]
    return float(np.abs(so3.d_tangent(phi, b) - np.column_stack(cols)).max())


def fd_error_d_tangent_inv(phi: np.ndarray, b: np.ndarray, eps: float = FD_EPS) -> float:
    """max |d_tangent_inv(phi, b) - X_fd|, X_fd from central differences of T^-1(phi) b."""
    cols = [(so3.tangent_inv(phi + eps * e) - so3.tangent_inv(phi - eps * e)) @ b / (2 * eps)
            for e in np.eye(3)]
    return float(np.abs(so3.d_tangent_inv(phi, b) - np.column_stack(cols)).max())


def fd_error_d2_tangent(phi: np.ndarray, a: np.ndarray, b: np.ndarray, eps: float = FD_EPS) -> float:
    """max |d2_tangent(phi, a, b) - Y_fd|, Y_fd[:, j] = (central difference of d_tangent(phi, b) along e_j)^T a."""
    cols = [(so3.d_tangent(phi + eps * e, b) - so3.d_tangent(phi - eps * e, b)).T @ a / (2 * eps)
            for e in np.eye(3)]
    return float(np.abs(so3.d2_tangent(phi, a, b) - np.column_stack(cols)).max())


# ---------------------------------------------------------------------------------------------------------
# Inputs
# ---------------------------------------------------------------------------------------------------------


def random_axis(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


axes = (st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)
        .filter(lambda v: np.linalg.norm(v) > 0.1).map(lambda v: v / np.linalg.norm(v)))
vectors = st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3).map(np.array)
angles_below_pi = st.one_of(st.floats(0.0, math.pi - 1e-6), st.floats(1e-12, 1e-6),
                            st.floats(math.pi - 1e-6, math.pi - 1e-12), st.floats(S - 1e-6, S + 1e-6))

SMALL = [1e-12, 1e-9, 1e-6]
NEAR_PI = [math.pi - 1e-6, math.pi - 1e-9, math.pi - 1e-12]
DERIVATIVE_ANGLES = [1e-6, 0.2, S - 1e-9, S + 1e-9, 1.0, 2.0, 3.0, math.pi - 1e-6, 4.0]


# ---------------------------------------------------------------------------------------------------------
# hat, exp, log
# ---------------------------------------------------------------------------------------------------------


def test_hat_vee():
    rng = np.random.default_rng(0)
    v, w = rng.normal(size=(2, 3))
    assert np.allclose(so3.hat(v) @ w, np.cross(v, w), rtol=0, atol=1e-15)
    assert np.array_equal(so3.vee(so3.hat(v)), v)


@settings(max_examples=200, deadline=None, database=None)
@given(axes, angles_below_pi)
def test_log_exp_round_trip(axis, angle):
    phi = angle * axis
    err = np.linalg.norm(so3.log(so3.exp(phi)) - phi)
    # relative near 0, absolute (of order eps * pi) elsewhere
    assert err <= 4e-16 * angle + 2e-15


@settings(max_examples=200, deadline=None, database=None)
@given(axes, st.floats(0.0, 2 * math.pi))
def test_exp_log_round_trip_and_exp_against_expm(axis, angle):
    R = so3.exp(angle * axis)
    assert np.abs(R.T @ R - np.eye(3)).max() < 1e-15 * 4
    # scipy's expm itself is off by up to ~6e-14 for angles between pi and 2 pi
    assert np.abs(R - scipy.linalg.expm(so3.hat(angle * axis))).max() < (1e-14 if angle <= math.pi else 1e-13)
    n, c, s = axis, math.cos(angle), math.sin(angle)
    assert np.abs(R - (c * np.eye(3) + s * so3.hat(n) + (1 - c) * np.outer(n, n))).max() < 2e-15
    phi = so3.log(R)
    assert np.linalg.norm(phi) <= math.pi + 1e-15
    assert np.abs(so3.exp(phi) - R).max() < 1e-14


@pytest.mark.parametrize("angle", SMALL + NEAR_PI + [math.pi])
def test_round_trips_near_zero_and_pi(angle):
    rng = np.random.default_rng(1)
    for _ in range(50):
        phi = angle * random_axis(rng)
        R = so3.exp(phi)
        assert np.abs(so3.exp(so3.log(R)) - R).max() < 1e-14
        if angle < math.pi:
            assert np.linalg.norm(so3.log(R) - phi) <= 4e-16 * angle + 2e-15


def test_log_of_exact_half_turns():
    """R = 2 n n^T - I (a rotation by pi), also about the coordinate axes where R is exactly symmetric."""
    rng = np.random.default_rng(2)
    axes_ = [random_axis(rng) for _ in range(100)] + list(np.eye(3)) + [np.array([1.0, 1.0, 0.0]) / math.sqrt(2)]
    for n in axes_:
        R = 2.0 * np.outer(n, n) - np.eye(3)
        phi = so3.log(R)
        assert abs(np.linalg.norm(phi) - math.pi) < 1e-14
        assert abs(abs(phi @ n) - math.pi) < 1e-14  # +-pi n
        assert np.abs(so3.exp(phi) - R).max() < 1e-14


def test_log_of_slightly_non_orthogonal_matrix():
    rng = np.random.default_rng(3)
    for angle in [0.0, 1e-8, 0.5, 2.0, math.pi - 1e-7, math.pi]:
        for _ in range(20):
            R = so3.exp(angle * random_axis(rng))
            Rp = R + 1e-9 * rng.normal(size=(3, 3))
            phi = so3.log(Rp)
            assert np.linalg.norm(phi) <= math.pi + 1e-8
            assert np.abs(so3.exp(phi) - R).max() < 1e-8


# ---------------------------------------------------------------------------------------------------------
# Tangent operators
# ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("angle", [1e-8, 1e-6, 1e-3, 0.2, 1.0, S - 1e-9, S + 1e-9, 3.0, math.pi - 1e-6])
def test_tangent_against_finite_differences_of_exp(angle):
    rng = np.random.default_rng(4)
    for _ in range(5):
        phi = angle * random_axis(rng)
        assert fd_error_tangent(phi) < FD_TOL


@settings(max_examples=200, deadline=None, database=None)
@given(axes, st.floats(0.0, 2 * math.pi - 0.5))
def test_tangent_inverse_and_transpose(axis, angle):
    phi = angle * axis
    T, Ti = so3.tangent(phi), so3.tangent_inv(phi)
    assert np.abs(Ti @ T - np.eye(3)).max() < 1e-14 * max(1.0, np.abs(Ti).max())
    assert np.abs(so3.tangent(-phi) - T.T).max() < 1e-15


@settings(max_examples=100, deadline=None, database=None)
@given(axes, st.floats(0.0, math.pi - 1e-6))
def test_tangent_against_finite_differences_random(axis, angle):
    assert fd_error_tangent(angle * axis) < FD_TOL


# ---------------------------------------------------------------------------------------------------------
# Derivatives of the tangent operators
# ---------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("angle", DERIVATIVE_ANGLES)
def test_derivatives_against_finite_differences(angle):
    rng = np.random.default_rng(5)
    for _ in range(5):
        phi = angle * random_axis(rng)
        a, b = rng.normal(size=(2, 3))
        assert fd_error_d_tangent(phi, b) < FD_TOL
        assert fd_error_d_tangent_inv(phi, b) < FD_TOL
        assert fd_error_d2_tangent(phi, a, b) < FD_TOL


@settings(max_examples=100, deadline=None, database=None)
@given(axes, st.floats(0.0, math.pi), vectors, vectors)
def test_derivatives_against_finite_differences_random(axis, angle, a, b):
    phi = angle * axis
    assert fd_error_d_tangent(phi, b) < FD_TOL
    assert fd_error_d_tangent_inv(phi, b) < FD_TOL
    assert fd_error_d2_tangent(phi, a, b) < FD_TOL
    Y = so3.d2_tangent(phi, a, b)
    assert np.abs(Y - Y.T).max() < 1e-15


def test_transpose_identity_of_d_tangent():
    """b^T DT(phi)[w] v = -v^T d_tangent(-phi, b) w, from T(phi)^T = T(-phi) (used by the element)."""
    rng = np.random.default_rng(6)
    for angle in [1e-7, 0.7, 3.0]:
        phi = angle * random_axis(rng)
        b, v, w = rng.normal(size=(3, 3))
        lhs = b @ (so3.d_tangent(phi, v) @ w)
        assert abs(lhs + v @ so3.d_tangent(-phi, b) @ w) < 1e-14


@pytest.mark.parametrize(("coefficient", "check", "angle"), [
    ("a2", "tangent", 1.0), ("a3", "tangent", 0.2), ("a3", "tangent", 1.0), ("a3", "tangent", 3.0),
    ("c2", "d_tangent", 2.0), ("c3", "d_tangent", 1.0), ("c3", "d_tangent", 2.0),
    ("c4", "d_tangent_inv", 2.0), ("c4", "d_tangent_inv", 3.0),
    ("e2", "d2_tangent", 2.0), ("e3", "d2_tangent", 2.0), ("e3", "d2_tangent", 3.0),
])
def test_finite_difference_checks_detect_a_wrong_coefficient(monkeypatch, coefficient, check, angle):
    """A test must be able to fail: a 1e-6 relative error in one coefficient is caught by the FD check.

    The coefficient is one the checked function uses but its finite-difference reference does not (the
    derivative coefficients c, e enter only the derivatives), so the error cannot cancel.
    """
    rng = np.random.default_rng(7)
    phi = angle * random_axis(rng)
    a, b = 2.0 * random_axis(rng), 2.0 * random_axis(rng)
    run = {"tangent": lambda: fd_error_tangent(phi),
           "d_tangent": lambda: fd_error_d_tangent(phi, b),
           "d_tangent_inv": lambda: fd_error_d_tangent_inv(phi, b),
           "d2_tangent": lambda: fd_error_d2_tangent(phi, a, b)}[check]
    assert run() < FD_TOL
    original = getattr(so3, coefficient)
    monkeypatch.setattr(so3, coefficient, lambda p: original(p) * (1.0 + 1e-6))
    assert run() > FD_TOL


# ---------------------------------------------------------------------------------------------------------
# Scalar coefficients: series vs closed form
# ---------------------------------------------------------------------------------------------------------


def _exact_coefficients(p: float) -> dict[str, float]:
    """The coefficients from their definitions, at 50 digits (derivatives by mpmath's differentiation)."""
    mp = pytest.importorskip("mpmath")
    with mp.workdps(50):
        x = mp.mpf(p)
        A2 = lambda t: (1 - mp.cos(t)) / t**2  # noqa: E731
        A3 = lambda t: (t - mp.sin(t)) / t**3  # noqa: E731
        A4 = lambda t: (1 - (t / 2) * mp.cot(t / 2)) / t**2  # noqa: E731
        exact = {"a1": mp.sin(x) / x, "a2": A2(x), "a3": A3(x), "a4": A4(x),
                 "c2": mp.diff(A2, x) / x, "c3": mp.diff(A3, x) / x, "c4": mp.diff(A4, x) / x,
                 # (f'(p)/p)'/p = (f''(p) - f'(p)/p) / p^2
                 "e2": (mp.diff(A2, x, 2) - mp.diff(A2, x) / x) / x**2,
                 "e3": (mp.diff(A3, x, 2) - mp.diff(A3, x) / x) / x**2}
        return {k: float(v) for k, v in exact.items()}


def _rel(x: float, y: float) -> float:
    return abs(x - y) / abs(y)


def test_series_switch_continuity():
    """Relative jump of every coefficient across the switch (series just below, closed form at S)."""
    below = np.nextafter(S, 0.0)
    jumps = {name: _rel(getattr(so3, name)(below), getattr(so3, name)(S)) for name in so3.COEFFICIENT_NAMES}
    assert max(jumps.values()) < 1e-14, jumps


@pytest.mark.parametrize("name", so3.COEFFICIENT_NAMES)
def test_coefficients_against_high_precision(name):
    f = getattr(so3, name)
    below = float(np.nextafter(S, 0.0))
    # the series right below the switch, and the closed form right above it
    assert _rel(so3.series(name, below), _exact_coefficients(below)[name]) < 2e-15
    assert _rel(f(S), _exact_coefficients(S)[name]) < 1e-14
    # everywhere in (0, pi] and beyond (a4, c4 have a pole at 2 pi)
    for p in [1e-8, 1e-3, 0.1, 0.3, 0.5, 1.0, 1.5, 2.0, 2.4, 2.6, 3.0, math.pi, 4.0, 5.0]:
        assert _rel(f(p), _exact_coefficients(p)[name]) < 1e-14, p
    assert f(0.0) == so3.SERIES[name][0]


def test_series_are_long_enough():
    """The first omitted term at the switch is negligible: the series with one more term agrees to 1e-17."""
    for name in so3.COEFFICIENT_NAMES:
        c = so3.SERIES[name]
        last = abs(c[-1]) * S ** (2 * (len(c) - 1))
        assert last < 2e-17 * abs(so3.series(name, S)), name


# ---------------------------------------------------------------------------------------------------------
# Nodal frames
# ---------------------------------------------------------------------------------------------------------


def test_update_frame_and_director():
    rng = np.random.default_rng(8)
    R = so3.exp(rng.normal(size=3))
    th = np.array([0.3, -0.2])
    Rn = so3.update_frame(R, th)
    assert np.allclose(Rn, R @ scipy.linalg.expm(so3.hat([th[0], th[1], 0.0])), rtol=0, atol=1e-14)
    assert np.array_equal(so3.director(Rn), Rn[:, 2])
    # no drilling: the relative rotation has no component along the local e3
    assert abs(so3.log(R.T @ Rn)[2]) < 1e-15
