"""numba kernels: agreement with the numpy reference (near 0, across the series switch, near and at pi) and
freedom from heap allocation when called from other njit code."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from flexbody.lie import kernels, se3, so3

TOL = 1e-13
S = so3.SERIES_SWITCH


def sample_angles(rng: np.random.Generator, n: int) -> np.ndarray:
    """Angles near 0, around the series switch, near and at pi, and uniform in (0, 2 pi - 0.5)."""
    return np.concatenate([
        10.0 ** rng.uniform(-12, -1, n), S + rng.uniform(-1e-6, 1e-6, n), math.pi - 10.0 ** rng.uniform(-12, -3, n),
        rng.uniform(0.0, 2 * math.pi - 0.5, n), [0.0, S, np.nextafter(S, 0.0), math.pi]])


def random_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    angles = sample_angles(rng, n)
    axes = rng.normal(size=(len(angles), 3))
    return angles[:, None] * axes / np.linalg.norm(axes, axis=1)[:, None]


def rel_err(x: np.ndarray, ref: np.ndarray) -> float:
    """Max error relative to the largest entry of the reference (and to 1)."""
    return float(np.abs(np.asarray(x) - ref).max() / max(1.0, np.abs(ref).max()))


def test_coefficients_agree_with_reference():
    rng = np.random.default_rng(0)
    worst = 0.0
    for p in sample_angles(rng, 200):
        k, r = kernels.coefficients(p), so3.coefficients(p)
        worst = max(worst, max(abs(x - y) / abs(y) for x, y in zip(k, r)))
    assert worst < TOL


def test_adjugate_of_a_4x4_matrix():
    """adj A = det(A) A^-1 and det A, of the kernel that gives Horn's quaternion its eigenvector (random, symmetric
    and singular matrices: the adjugate of a rank-3 matrix is the outer product of its null vectors)."""
    rng = np.random.default_rng(9)
    for _ in range(50):
        A = rng.normal(size=(4, 4))
        for M in (A, A + A.T):
            det, adj = kernels._adjugate4(M)
            assert abs(det - np.linalg.det(M)) < 1e-12 * max(1.0, abs(det))
            assert np.allclose(np.reshape(adj, (4, 4)), np.linalg.det(M) * np.linalg.inv(M), rtol=0, atol=1e-11)
    S = rng.normal(size=(4, 3))
    singular = S @ np.diag([1.0, 2.0, 3.0]) @ S.T                              # symmetric, rank 3
    adj = np.reshape(kernels._adjugate4(singular)[1], (4, 4))
    null = np.linalg.svd(singular)[2][-1]
    assert np.allclose(adj, (null @ adj @ null) * np.outer(null, null), rtol=0, atol=1e-10)
    assert abs(null @ adj @ null) > 1e-3


def test_exp_coefficients_are_the_first_two_coefficients_bit_for_bit():
    """exp(phi) takes (a1, a2) alone: the same bits as :func:`coefficients` near 0, near the series switch, near
    pi and at random."""
    rng = np.random.default_rng(8)
    for p in [0.0, *sample_angles(rng, 200)]:
        assert kernels.exp_coefficients(p) == kernels.coefficients(p)[:2], p


def test_so3_kernels_agree_with_reference():
    rng = np.random.default_rng(1)
    out, vec = np.empty((3, 3)), np.empty(3)
    worst: dict[str, float] = {}

    def record(name, x, ref):
        worst[name] = max(worst.get(name, 0.0), rel_err(x, ref))

    for phi in random_vectors(rng, 100):
        a, b = rng.normal(size=(2, 3))
        kernels.hat_into(phi, out)
        record("hat", out, so3.hat(phi))
        kernels.exp_into(phi, out)
        record("exp", out, so3.exp(phi))
        R = so3.exp(phi)
        kernels.log_into(R, vec)
        record("log", vec, so3.log(R))
        assert np.abs(so3.exp(vec) - R).max() < 1e-14
        kernels.tangent_into(phi, out)
        record("tangent", out, so3.tangent(phi))
        kernels.tangent_inv_into(phi, out)
        record("tangent_inv", out, so3.tangent_inv(phi))
        kernels.d_tangent_into(phi, b, out)
        record("d_tangent", out, so3.d_tangent(phi, b))
        kernels.d_tangent_inv_into(phi, b, out)
        record("d_tangent_inv", out, so3.d_tangent_inv(phi, b))
        kernels.d2_tangent_into(phi, a, b, out)
        record("d2_tangent", out, so3.d2_tangent(phi, a, b))
        kernels.update_frame_into(R, phi[0], phi[1], out)
        record("update_frame", out, so3.update_frame(R, phi[:2]))
    assert max(worst.values()) < TOL, worst


def test_log_kernel_at_half_turns_and_with_drift():
    rng = np.random.default_rng(2)
    vec = np.empty(3)
    for _ in range(100):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        R = 2.0 * np.outer(n, n) - np.eye(3)
        kernels.log_into(R, vec)
        assert abs(np.linalg.norm(vec) - math.pi) < 1e-14 and np.abs(so3.exp(vec) - R).max() < 1e-14
        Rp = R + 1e-9 * rng.normal(size=(3, 3))
        kernels.log_into(Rp, vec)
        assert np.abs(so3.exp(vec) - R).max() < 1e-8
        assert np.abs(vec - so3.log(Rp)).max() < TOL


def test_update_frame_in_place_and_tuple_inputs():
    rng = np.random.default_rng(3)
    R = so3.exp(rng.normal(size=3))
    expected = so3.update_frame(R, np.array([0.4, -0.7]))
    Rw = R.copy()
    kernels.update_frame_into(Rw, 0.4, -0.7, Rw)  # out may alias R
    assert np.abs(Rw - expected).max() < 1e-15
    out = np.empty((3, 3))
    kernels.exp_into((0.1, 0.2, 0.3), out)
    assert np.abs(out - so3.exp(np.array([0.1, 0.2, 0.3]))).max() < 1e-15


def test_se3_kernels_agree_with_reference():
    rng = np.random.default_rng(4)
    out4, out6, vec6 = np.empty((4, 4)), np.empty((6, 6)), np.empty(6)
    worst: dict[str, float] = {}

    def record(name, x, ref):
        worst[name] = max(worst.get(name, 0.0), rel_err(x, ref))

    for w in random_vectors(rng, 50):
        h = np.concatenate([rng.normal(size=3), w])
        kernels.se3_exp_into(h, out4)
        record("exp", out4, se3.exp(h))
        H = se3.exp(h)
        kernels.se3_log_into(H, vec6)
        record("log", vec6, se3.log(H))
        kernels.se3_tangent_into(h, out6)
        record("tangent", out6, se3.tangent(h))
        kernels.se3_tangent_inv_into(h, out6)
        record("tangent_inv", out6, se3.tangent_inv(h))
    assert max(worst.values()) < TOL, worst


# ---------------------------------------------------------------------------------------------------------
# No heap allocation: count NRT allocations of a njit caller running the kernels many times.
# ---------------------------------------------------------------------------------------------------------


@numba.njit
def _run_all(n, phi, a, b, R, h, H, o3, v3, o4, o6, v6):
    for _ in range(n):
        kernels.exp_into(phi, o3)
        kernels.log_into(R, v3)
        kernels.tangent_into(phi, o3)
        kernels.tangent_inv_into(phi, o3)
        kernels.d_tangent_into(phi, b, o3)
        kernels.d_tangent_inv_into(phi, b, o3)
        kernels.d2_tangent_into(phi, a, b, o3)
        kernels.update_frame_into(R, 0.1, 0.2, o3)
        kernels.hat_into(phi, o3)
        kernels.coefficients(0.3)
        kernels.se3_exp_into(h, o4)
        kernels.se3_log_into(H, v6)
        kernels.se3_tangent_into(h, o6)
        kernels.se3_tangent_inv_into(h, o6)


@numba.njit
def _allocates(n, o3):
    for _ in range(n):
        tmp = np.empty(3)
        o3[0, 0] = tmp.shape[0]


def _allocations(fun, *args) -> int:
    from numba.core.runtime import rtsys
    before = rtsys.get_allocation_stats().alloc
    fun(*args)
    return rtsys.get_allocation_stats().alloc - before


@pytest.fixture
def nrt_stats():
    nrt = pytest.importorskip("numba.core.runtime._nrt_python")
    if not hasattr(nrt, "memsys_enable_stats"):
        pytest.skip("this numba cannot count allocations")
    was_enabled = nrt.memsys_stats_enabled()
    nrt.memsys_enable_stats()
    yield
    if not was_enabled:
        nrt.memsys_disable_stats()


def test_kernels_do_not_allocate(nrt_stats):
    rng = np.random.default_rng(5)
    for angle in [0.3, 3.0]:  # both branches of the coefficients
        phi = angle * np.array([0.6, 0.0, 0.8])
        h = np.concatenate([rng.normal(size=3), phi])
        args = (phi, rng.normal(size=3), rng.normal(size=3), so3.exp(phi), h, se3.exp(h),
                np.empty((3, 3)), np.empty(3), np.empty((4, 4)), np.empty((6, 6)), np.empty(6))
        _run_all(1, *args)  # compile
        # only the unboxing of the arguments allocates, once per call, whatever the number of iterations
        assert _allocations(_run_all, 1, *args) == _allocations(_run_all, 200, *args)
    # the count is able to fail: a loop that allocates is seen
    _allocates(1, np.empty((3, 3)))
    assert _allocations(_allocates, 200, np.empty((3, 3))) - _allocations(_allocates, 1, np.empty((3, 3))) >= 199


def test_batched_frame_update_matches_the_reference():
    from flexbody.lie.kernels import update_frames_into

    rng = np.random.default_rng(11)
    frames = np.array([so3.exp(v) for v in rng.normal(size=(7, 3))])
    dtheta = rng.normal(size=(7, 2)) * np.array([[1.0], [1e-9], [3.0], [0.0], [1.0], [2.9], [1e-4]])
    out = np.empty_like(frames)
    update_frames_into(frames, dtheta, out)
    for F, th, G in zip(frames, dtheta, out):
        np.testing.assert_allclose(G, F @ so3.exp(np.array([th[0], th[1], 0.0])), rtol=0, atol=1e-14)


def test_nearest_rotations_agree_with_the_kabsch_reference():
    """Horn's quaternion with the characteristic-polynomial eigenvalue against the SVD (so3.nearest_rotations):
    at random matrices, at exact rotations of near 0, the series switch, near and at pi (where G must be the
    rotation itself) for planar point sets (rank 2) and solid ones, with noise, and the identity when no plane
    is spanned (rank 0 and 1)."""
    rng = np.random.default_rng(11)
    H = rng.normal(size=(300, 3, 3))
    out = np.empty_like(H)
    assert kernels.nearest_rotations_into(H, out) == 0
    assert np.abs(out - so3.nearest_rotations(H)).max() < 1e-12
    phi = random_vectors(rng, 40)
    Q = so3.exp_many(phi)
    for planar in (True, False):
        a = rng.normal(size=(len(phi), 6, 3))
        if planar:
            a[:, :, 2] = 0.0
        b = np.einsum("nij,nkj->nki", Q, a)
        for noise in (0.0, 1e-3):
            H = np.einsum("nki,nkj->nij", b + noise * rng.normal(size=b.shape), a)
            out = np.empty_like(H)
            assert kernels.nearest_rotations_into(H, out) == 0
            reference = so3.nearest_rotations(H)
            assert np.abs(out - reference).max() < 1e-12, np.abs(out - reference).max()
            if noise == 0.0:
                assert np.abs(out - Q).max() < 1e-12
    degenerate = np.zeros((3, 3, 3))
    degenerate[1] = np.outer([1.0, 2.0, 0.0], [0.0, 1.0, 1.0])          # rank 1
    degenerate[2, 0, 0], degenerate[2, 1, 1] = 1.0, 1e-14                # rank 2 only to round-off
    out = np.empty_like(degenerate)
    kernels.nearest_rotations_into(degenerate, out)
    assert np.array_equal(out, np.broadcast_to(np.eye(3), (3, 3, 3)))
    assert np.array_equal(so3.nearest_rotations(degenerate), out)
    bad = np.array([np.eye(3), np.full((3, 3), np.nan), np.diag([1.0, np.inf, 1.0])])   # not finite: identity
    out = np.empty_like(bad)
    assert kernels.nearest_rotations_into(bad, out) == 2
    assert np.array_equal(out, np.broadcast_to(np.eye(3), (3, 3, 3)))
    with pytest.raises(ValueError, match="H"):
        kernels.nearest_rotations_into(np.eye(3), np.empty((1, 3, 3)))
