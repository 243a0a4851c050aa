"""SE(3) reference: exp against expm of the 4x4 algebra matrix, log round trip, the right tangent operator
against finite differences on the group, and the adjoints."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from flexbody.lie import se3, so3

FD_EPS = 1e-5
FD_TOL = 1e-9


def fd_error_tangent(h: np.ndarray, eps: float = FD_EPS) -> float:
    """max |T_SE3(h) - T_fd|, T_fd[:, j] = (log(exp(h)^-1 exp(h + eps e_j)) - (same, -eps)) / (2 eps)."""
    Hi = se3.inverse(se3.exp(h))
    cols = [(se3.log(Hi @ se3.exp(h + eps * e)) - se3.log(Hi @ se3.exp(h - eps * e))) / (2 * eps)
            for e in np.eye(6)]
    return float(np.abs(se3.tangent(h) - np.column_stack(cols)).max())


def random_h(rng: np.random.Generator, angle: float) -> np.ndarray:
    w = rng.normal(size=3)
    return np.concatenate([rng.normal(size=3), angle * w / np.linalg.norm(w)])


ANGLES = [0.0, 1e-9, 1e-6, 0.2, so3.SERIES_SWITCH - 1e-9, so3.SERIES_SWITCH + 1e-9, 1.0, 3.0, math.pi - 1e-6]

axes = (st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)
        .filter(lambda v: np.linalg.norm(v) > 0.1).map(lambda v: v / np.linalg.norm(v)))
translations = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).map(np.array)
angles_below_pi = st.one_of(st.floats(0.0, math.pi - 1e-6), st.floats(1e-12, 1e-6),
                            st.floats(math.pi - 1e-6, math.pi - 1e-12))


def test_hat6_vee6_and_ad_is_the_commutator():
    rng = np.random.default_rng(0)
    h1, h2 = rng.normal(size=(2, 6))
    assert np.array_equal(se3.vee6(se3.hat6(h1)), h1)
    X1, X2 = se3.hat6(h1), se3.hat6(h2)
    assert np.abs(se3.hat6(se3.ad(h1) @ h2) - (X1 @ X2 - X2 @ X1)).max() < 1e-14


@settings(max_examples=200, deadline=None, database=None)
@given(axes, angles_below_pi, translations)
def test_exp_against_expm_and_log_round_trip(axis, angle, u):
    h = np.concatenate([u, angle * axis])
    H = se3.exp(h)
    assert np.abs(H - scipy.linalg.expm(se3.hat6(h))).max() < 1e-13
    assert np.linalg.norm(se3.log(H) - h) < 1e-14 * (1.0 + np.linalg.norm(u))
    assert np.abs(se3.exp(se3.log(H)) - H).max() < 1e-14 * (1.0 + np.linalg.norm(u))


def test_log_at_a_half_turn():
    rng = np.random.default_rng(1)
    for _ in range(20):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        H = se3.make(2.0 * np.outer(n, n) - np.eye(3), rng.normal(size=3))
        h = se3.log(H)
        assert abs(np.linalg.norm(h[3:]) - math.pi) < 1e-14
        assert np.abs(se3.exp(h) - H).max() < 1e-14


@pytest.mark.parametrize("angle", ANGLES)
def test_tangent_against_finite_differences(angle):
    rng = np.random.default_rng(2)
    for _ in range(5):
        assert fd_error_tangent(random_h(rng, angle)) < FD_TOL


def test_tangent_check_detects_a_wrong_off_diagonal_block(monkeypatch):
    """A test must be able to fail: a 1e-6 relative error in c3 (only in the T_uw block) is caught."""
    h = random_h(np.random.default_rng(3), 2.0)
    assert fd_error_tangent(h) < FD_TOL
    original = so3.c3
    monkeypatch.setattr(so3, "c3", lambda p: original(p) * (1.0 + 1e-6))
    assert fd_error_tangent(h) > FD_TOL


@settings(max_examples=100, deadline=None, database=None)
@given(axes, st.floats(0.0, 2 * math.pi - 0.5), translations)
def test_tangent_inverse(axis, angle, u):
    h = np.concatenate([u, angle * axis])
    T, Ti = se3.tangent(h), se3.tangent_inv(h)
    assert np.abs(Ti @ T - np.eye(6)).max() < 1e-14 * max(1.0, np.abs(Ti).max(), np.abs(T).max())
    # block structure, and the SO(3) blocks
    assert np.array_equal(T[3:, :3], np.zeros((3, 3))) and np.array_equal(T[:3, :3], T[3:, 3:])
    assert np.array_equal(T[:3, :3], so3.tangent(h[3:]))
    # the left Jacobian is T(-h), and Ad(exp(h)) T(h) = T(-h)
    assert np.abs(se3.Ad(se3.exp(h)) @ T - se3.tangent(-h)).max() < 1e-13 * max(1.0, np.abs(T).max())


@settings(max_examples=100, deadline=None, database=None)
@given(axes, st.floats(0.0, math.pi), translations)
def test_Ad_of_exp_is_expm_of_ad(axis, angle, u):
    h = np.concatenate([u, angle * axis])
    assert np.abs(se3.Ad(se3.exp(h)) - scipy.linalg.expm(se3.ad(h))).max() < 1e-13 * (1.0 + np.linalg.norm(u))


def test_Ad_conjugation_and_group_helpers():
    rng = np.random.default_rng(4)
    H1, H2 = se3.exp(rng.normal(size=6)), se3.exp(rng.normal(size=6))
    h = rng.normal(size=6)
    assert np.abs(se3.hat6(se3.Ad(H1) @ h) - H1 @ se3.hat6(h) @ se3.inverse(H1)).max() < 1e-14
    assert np.abs(se3.Ad(se3.compose(H1, H2)) - se3.Ad(H1) @ se3.Ad(H2)).max() < 1e-14
    assert np.abs(se3.compose(H1, se3.inverse(H1)) - np.eye(4)).max() < 1e-15
    y = rng.normal(size=3)
    assert np.allclose(se3.act(H1, y), (H1 @ np.append(y, 1.0))[:3], rtol=0, atol=1e-15)
    H = se3.make(se3.rotation(H1), se3.translation(H1))
    assert np.array_equal(H, H1)
