"""The numba MITC7 kernels (flexbody.shell.kernels.mitc7) against their numpy twin (flexbody.shell.reference:
loops + bubble), to 1e-12."""

import numpy as np
import pytest

from flexbody.shell.reference.bubble import condensed_bubble, condensed_force_tangent
from flexbody.shell.kernels.mitc7.loops import condensed_force_tangent_batch
from flexbody.shell.variants import MITC7
from tests.shell.conftest import deformed

TOL = 1e-12
#: Deformed states per reference element: (seed, nodal amplitude, nodal rotation), all under a random
#: large rigid rotation (conftest.deformed).
STATES = [(0, 0.05, 0.3), (1, 0.05, 0.3), (2, 0.1, 0.6)]
A7 = MITC7().maps
_REFERENCE = {}


def rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def batch_of(element):
    """The STATES of one element as a batch, and the numpy reference (f, K, b) of each (computed once)."""
    X, frames, geom, C = element
    states = [deformed(X, frames, np.random.default_rng(seed), amplitude=amp, rot=rot) for seed, amp, rot in STATES]
    x = np.array([s[0] for s in states])
    fr = np.array([s[1] for s in states])
    key = (X.tobytes(), frames.tobytes())
    if key not in _REFERENCE:
        ref = []
        for xe, fe in states:
            f, K = condensed_force_tangent(xe, fe, geom, C)
            ref.append((f, K, condensed_bubble(xe, fe, geom, C)))
        _REFERENCE[key] = ref
    m = len(states)
    geo = (np.repeat(geom.e_ref[None], m, 0), np.repeat(geom.to_cart[None], m, 0), np.repeat(geom.weights[None], m, 0))
    return x, fr, geo, C, _REFERENCE[key]


def run(x, fr, geo, C, b0, want_tangent=True):
    return condensed_force_tangent_batch(x, fr, *geo, C, A7, b0, want_tangent)


def test_agrees_with_the_numpy_reference(element):
    x, fr, geo, C, ref = batch_of(element)
    f, K, b = run(x, fr, geo, C, None)
    assert f.shape == (len(x), 36) and K.shape == (len(x), 36, 36) and b.shape == (len(x), 2)
    for e, (f_ref, K_ref, b_ref) in enumerate(ref):
        assert np.abs(b_ref).max() > 1e-3                      # the bubble is really active
        assert rel(f[e], f_ref) < TOL
        assert rel(K[e], K_ref) < TOL
        assert np.abs(b[e] - b_ref).max() < TOL * (1.0 + np.abs(b_ref).max())


def test_force_only_agrees(element):
    x, fr, geo, C, ref = batch_of(element)
    f, K, b = run(x, fr, geo, C, np.zeros((len(x), 2)), want_tangent=False)
    assert K.size == 0
    f_t, _, b_t = run(x, fr, geo, C, np.zeros((len(x), 2)))
    assert np.array_equal(f, f_t) and np.array_equal(b, b_t)    # the same code path for the force
    for e, (f_ref, _, b_ref) in enumerate(ref):
        assert rel(f[e], f_ref) < TOL
        assert np.abs(b[e] - b_ref).max() < TOL * (1.0 + np.abs(b_ref).max())


@pytest.mark.parametrize("start", ["converged", "perturbed", "far"])
def test_warm_start_does_not_change_the_result(element, start):
    x, fr, geo, C, _ = batch_of(element)
    f0, K0, b0 = run(x, fr, geo, C, None)
    rng = np.random.default_rng(7)
    start_b = {"converged": b0, "perturbed": b0 + 1e-4 * rng.normal(size=b0.shape),
               "far": b0 + 0.1 * rng.normal(size=b0.shape)}[start]
    f, K, b = run(x, fr, geo, C, start_b)
    for e in range(len(x)):
        assert rel(f[e], f0[e]) < TOL
        assert rel(K[e], K0[e]) < TOL
        assert np.abs(b[e] - b0[e]).max() < TOL * (1.0 + np.abs(b0[e]).max())


def test_parallel_batch_equals_elementwise(element):
    """A batch large enough to be split into parallel chunks gives each element's own result."""
    x, fr, geo, C, _ = batch_of(element)
    f1, K1, b1 = run(x, fr, geo, C, None)
    idx = np.arange(40) % len(x)
    f, K, b = run(x[idx], fr[idx], tuple(a[idx] for a in geo), C, None)
    assert np.array_equal(f, f1[idx]) and np.array_equal(K, K1[idx]) and np.array_equal(b, b1[idx])


def test_a_non_finite_start_is_retried_from_zero(element):
    """A NaN warm start gives a non-finite correction; the element is solved again from b = 0, as a cold
    start, and the other elements are unaffected."""
    x, fr, geo, C, _ = batch_of(element)
    f1, K1, b1 = run(x, fr, geo, C, None)
    start = np.zeros((len(x), 2))
    start[1] = np.nan
    f, K, b = run(x, fr, geo, C, start)
    assert np.array_equal(f, f1) and np.array_equal(K, K1) and np.array_equal(b, b1)


def test_unconverged_bubble_gives_nan_force_and_keeps_the_start(element, monkeypatch):
    """Newton on b out of iterations (here: one evaluation allowed, from a start away from b*): NaN force
    and tangent, the start value returned as b."""
    from flexbody.shell.kernels.mitc7 import loops
    x, fr, geo, C, _ = batch_of(element)
    _, _, b1 = run(x, fr, geo, C, None)
    monkeypatch.setattr(loops, "BUBBLE_MAX_ITERATIONS", 1)
    start = b1.copy()
    start[0] += 0.1
    f, K, b = run(x, fr, geo, C, start)
    assert np.all(np.isnan(f[0])) and np.all(np.isnan(K[0])) and np.array_equal(b[0], start[0])
    assert np.all(np.isfinite(f[1:])) and np.all(np.isfinite(K[1:]))  # converged b: one evaluation suffices


def test_non_symmetric_section_agrees(element):
    """The material stiffness is formed as an upper triangle only for a symmetric section; a non-symmetric
    one takes the general path, still equal to the reference."""
    X, frames, geom, C = element
    A = np.random.default_rng(5).normal(size=C.shape) * (C != 0)
    C2 = C + 0.01 * (A - A.T) * np.abs(C)
    assert not np.array_equal(C2, C2.T)
    xe, fe = deformed(X, frames, np.random.default_rng(1), amplitude=0.05, rot=0.3)
    f_ref, K_ref = condensed_force_tangent(xe, fe, geom, C2)
    f, K, _ = condensed_force_tangent_batch(xe[None], fe[None], geom.e_ref[None], geom.to_cart[None],
                                            geom.weights[None], C2, A7, None)
    assert rel(f[0], f_ref) < TOL
    assert rel(K[0], K_ref) < TOL
