"""Ctrl-C during a dynamic run: the interrupt goes on, and the observers have seen every converged step up to
the last one, once (a flexbody.energy.EnergyAccount hands that one over: tests/test_energy.py)."""

import numpy as np
import pytest

from integrators.generalized_alpha import AlphaSettings, generalized_alpha
from tests.integrators.toy import Oscillator


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
def test_an_interrupt_leaves_the_observers_at_the_last_converged_step(adaptive):
    settings = AlphaSettings(rho_inf=0.8, rtol=1e-10, atol=1e-12, adaptive=adaptive)
    complete = []
    generalized_alpha(Oscillator([1.0, 3.0]), 2.0, 0.05, state=np.ones(2), settings=settings,
                      observers=[complete.append])
    seen = []
    dyn = InterruptedOscillator([1.0, 3.0], stop_at=40)
    with pytest.raises(KeyboardInterrupt):
        generalized_alpha(dyn, 2.0, 0.05, state=np.ones(2), settings=settings, record_every=1000,
                          observers=[seen.append])
    assert seen[0].initial and [s.index for s in seen] == list(range(len(seen)))   # every step, in order, once
    last = seen[-1]
    assert last.index > 1 and not last.output and last.iterations >= 1
    if adaptive:    # the steps of the two runs differ (their output intervals differ)
        assert 0 < last.time < 2.0 and np.all(np.isfinite(last.state)) and np.all(np.isfinite(last.velocity))
        return
    ref = complete[last.index]
    assert last.time == ref.time and np.array_equal(last.state, ref.state)
    assert np.array_equal(last.velocity, ref.velocity) and np.array_equal(last.previous_velocity, ref.previous_velocity)


def test_an_interrupt_in_an_observer_ends_the_run_there():
    calls = []

    def observer(step):
        calls.append(step.index)
        if step.index == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        generalized_alpha(Oscillator([1.0]), 1.0, 0.1, state=np.ones(1), observers=[observer])
    assert calls == [0, 1, 2, 3]
