"""Continuing an arc-length path from a converged step (:class:`integrators.static.ArcLengthState`): the
continuation follows the uninterrupted path step for step, through the thin arch's limit point."""

import dataclasses

import numpy as np
import pytest

from integrators.static import ArcLengthState, arc_length
from tests.integrators.test_thin_arc_length import thin_half_arch

pytestmark = pytest.mark.usefixtures("one_numba_thread")


@pytest.fixture(scope="module")
def arch_path():
    model = thin_half_arch()
    path = []
    result = arc_length(model, lam_max=4.0, on_step=lambda rec, q: path.append((rec, q)))
    assert result.converged, result.message
    return model, path


def _continue(model, rec, state, continuation=None):
    """The path continued from a step as a restart file gives it: the state without the mixed iteration's
    stresses, the continuation of the step."""
    sub = []
    arc_length(model, lam_max=4.0, state=dataclasses.replace(state, stress=None),
               continuation=continuation or rec.continuation, on_step=lambda r, q: sub.append((r, q)))
    return sub


@pytest.mark.parametrize("where", [-2, 0, 3], ids=["before", "at", "past"])
def test_continuation_follows_the_uninterrupted_path_through_the_limit_point(arch_path, where):
    """From two steps before, at, and three steps past the first limit point: the same number of steps, the
    same Newton iterations, the same load factors and positions to 1e-7 of their ranges. The continuation's
    first predictor is solved on a fresh tangent where the uninterrupted run reused the factorization of its
    last iterate; both corrections converge on the same intersection of the path with the arc, to the
    corrector's tolerance (rtol 1e-8 of the forces). Measured: 2e-10 of the load-factor range, 2e-10 of the
    displacement range."""
    model, path = arch_path
    lams = np.array([rec.load_factor for rec, _ in path])
    k = int(np.argmax(lams[:len(lams) // 2])) + where
    sub = _continue(model, *path[k])
    rest = path[k + 1:]
    assert len(sub) == len(rest)
    assert [r.iterations for r, _ in sub] == [r.iterations for r, _ in rest]
    lam_range = np.ptp(lams)
    size = np.ptp(path[-1][1].x - path[0][1].x)
    for (r, q), (r0, q0) in zip(sub, rest):
        assert abs(r.load_factor - r0.load_factor) <= 1e-7 * lam_range
        assert np.abs(q.x - q0.x).max() <= 1e-7 * size
    # the limit points are found where the uninterrupted run found them
    turned = [k + 1 + r.step for r, _ in sub if r.critical is not None]
    assert turned == [r.step for r, _ in rest if r.critical is not None]


def test_the_continuation_is_what_keeps_the_direction(arch_path):
    """Control: at the limit point, the same state with the direction of its last step reversed goes back
    down the path it came up (the load factor falls where the uninterrupted one went on): the saved
    direction is what sets the predictor's sign."""
    model, path = arch_path
    lams = np.array([rec.load_factor for rec, _ in path])
    k = int(np.argmax(lams[:len(lams) // 2])) - 2          # still climbing to the limit point
    c = path[k][0].continuation
    back = _continue(model, path[k][0], path[k][1],
                     ArcLengthState(c.load_factor, c.arc_length, c.first_arc_length, -c.direction, -c.load_sign))
    assert back[0][0].load_factor < lams[k] < path[k + 1][0].load_factor


def test_bad_continuations_are_refused():
    with pytest.raises(ValueError, match="arc lengths > 0"):
        ArcLengthState(0.5, -1.0, 1.0, np.ones(3), 1.0)
    with pytest.raises(ValueError, match="non-finite"):
        ArcLengthState(0.5, 1.0, 1.0, np.array([np.nan, 0, 0]), 1.0)
    model = thin_half_arch()
    with pytest.raises(ValueError, match="needs the converged state"):
        arc_length(model, continuation=ArcLengthState(0.5, 1.0, 1.0, np.ones(3), 1.0))
    with pytest.raises(ValueError, match="components"):
        arc_length(model, state=model.initial_state(), continuation=ArcLengthState(0.5, 1.0, 1.0, np.ones(3), 1.0))
