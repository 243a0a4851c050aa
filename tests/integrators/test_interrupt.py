"""Ctrl-C during a dynamic run: the last converged step is handed to on_step (with its motion), then the
interrupt goes on; a step already recorded is not handed over twice."""

import numpy as np
import pytest

from integrators.generalized_alpha import AlphaSettings, generalized_alpha
from tests.integrators.test_generalized_alpha import Oscillator


class InterruptedOscillator(Oscillator):
    """Raises KeyboardInterrupt at the ``stop_at``-th residual evaluation (as Ctrl-C would, inside a step)."""

    def __init__(self, omegas, stop_at: int):
        super().__init__(omegas)
        self.calls, self.stop_at = 0, stop_at

    def residual(self, q, v, vdot, t):
        self.calls += 1
        if self.calls == self.stop_at:
            raise KeyboardInterrupt
        return super().residual(q, v, vdot, t)


@pytest.mark.parametrize("adaptive", [False, True])
def test_an_interrupt_hands_over_the_last_converged_step(adaptive):
    settings = AlphaSettings(rho_inf=0.8, rtol=1e-10, atol=1e-12, adaptive=adaptive)
    complete = []
    generalized_alpha(Oscillator([1.0, 3.0]), 2.0, 0.05, state=np.ones(2), settings=settings,
                      on_step=lambda rec, q, v: complete.append((rec.step, rec.time, q.copy(), v.copy())))
    handed = []
    dyn = InterruptedOscillator([1.0, 3.0], stop_at=40)
    with pytest.raises(KeyboardInterrupt):
        generalized_alpha(dyn, 2.0, 0.05, state=np.ones(2), settings=settings, record_every=1000,
                          on_step=lambda rec, q, v: handed.append((rec, q.copy(), v.copy())))
    assert len(handed) == 1                       # only the interrupted step's predecessor, no record before it
    rec, q, v = handed[0]
    assert rec.step > 1 and rec.iterations == 0 and rec.motion is not None
    assert np.array_equal(rec.motion["v"], v)
    if adaptive:    # the steps of the two runs differ (their output intervals differ)
        assert 0 < rec.time < 2.0 and np.all(np.isfinite(q)) and np.all(np.isfinite(v))
        return
    step, t, q_ref, v_ref = complete[rec.step - 1]
    assert rec.time == t and np.array_equal(q, q_ref) and np.array_equal(v, v_ref)


def test_an_interrupt_in_on_step_is_not_handed_over_twice():
    calls = []

    def on_step(rec, q, v):
        calls.append(rec.step)
        if rec.step == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        generalized_alpha(Oscillator([1.0]), 1.0, 0.1, state=np.ones(1), on_step=on_step)
    assert calls == [1, 2, 3]
