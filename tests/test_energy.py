"""The energy and momentum bookkeeping outside the integrator (flexbody.energy): the records of an EnergyAccount
are the model's energies and momenta of the integrator's accepted steps, the dissipated work follows the steps,
and a Ctrl-C hands the last converged step over once."""

import dataclasses
import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel, RayleighDamping
from flexbody.energy import DynamicStepRecord, EnergyAccount, EnergyRecord, dissipated_work, integrate_motion
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from integrators.generalized_alpha import AlphaSettings, generalized_alpha

pytestmark = pytest.mark.usefixtures("one_numba_thread")


class SaggingStrip(DynamicModel):
    """A damped cantilever strip released under gravity; raises KeyboardInterrupt at the ``stop_at``-th residual
    evaluation (as Ctrl-C would, inside a step) when ``stop_at`` is given."""

    def __init__(self, stop_at: int | None = None):
        mesh = generators.strip(1.0, 0.1, 4, 1)
        body = ShellBody(mesh, ShellMaterial(1e7, 0.3, 0.01, density=1000.0))
        super().__init__(Model(body, [Fix(mesh.node_set("clamped"), "all")]), gravity=(0.0, 0.0, -9.81),
                         damping=RayleighDamping(0.5, 1e-3))
        self.calls, self.stop_at = 0, stop_at

    def residual(self, q, v, vdot, t):
        self.calls += 1
        if self.calls == self.stop_at:
            raise KeyboardInterrupt
        return super().residual(q, v, vdot, t)


# iterations to the tolerances: a restart starts on a fresh matrix, so only a tightly converged run continues the
# uninterrupted one to 1e-12 (with the local-error test it does to the iteration error)
SETTINGS = AlphaSettings(rho_inf=0.8, local_error_fraction=0.0)


def test_the_records_are_the_models_energies_of_the_accepted_steps():
    dyn = SaggingStrip()
    steps = []
    run = integrate_motion(dyn, 0.1, 0.01, settings=SETTINGS, record_every=3, observers=[steps.append])
    assert run.result.converged, run.result.message
    outputs = [s for s in steps if s.output]
    assert [r.step for r in run.records] == [s.index for s in outputs] == [3, 6, 9, 10]
    d = 0.0
    for a, b in zip(steps, steps[1:]):           # the dissipated work, step by step
        d += dissipated_work(b.step_size, a.velocity, b.velocity, dyn.damping_force(a.state, a.velocity),
                             dyn.damping_force(b.state, b.velocity))
        if b.output:
            rec = run.records[outputs.index(b)]
            energy = EnergyRecord.of(dyn, b.state, b.velocity, d)
            assert rec.dissipated_energy == d > 0
            assert (rec.kinetic_energy, rec.strain_energy, rec.potential_energy) == (energy.kinetic, energy.strain,
                                                                                   energy.gravity)
            assert np.array_equal(rec.angular_momentum, energy.angular_momentum)
            assert rec.total_energy == energy.total and rec.energy_balance == energy.balance
            assert rec.iterations == b.iterations and rec.motion["v"] is b.velocity
    assert run.dissipated_energy == d
    assert run.initial.step == 0 and run.initial.motion is None and run.initial.dissipated_energy == 0.0


def test_a_restart_carries_the_dissipated_work_on():
    """The continuation of an interrupted run from its last state gives the uninterrupted run's dissipated work.
    A restart starts on a fresh iteration matrix where the uninterrupted run keeps an older one, so the two
    agree to their iteration errors: converged tightly, to 1e-12 (at the default tolerances without the
    local-error test, measured 2.3e-8 relative; with it, 1e-6)."""
    tight = dataclasses.replace(SETTINGS, rtol=1e-12, atol=1e-14)
    whole = integrate_motion(SaggingStrip(), 0.1, 0.01, settings=tight)
    first = integrate_motion(SaggingStrip(), 0.05, 0.01, settings=tight)
    r = first.result
    rest = integrate_motion(SaggingStrip(), 0.1, 0.01, settings=tight, state=r.state, velocity=r.velocity,
                            acceleration=r.acceleration, pseudo_acceleration=r.pseudo_acceleration, t_start=r.time,
                            first_step=5, dissipated_energy=first.dissipated_energy)
    assert rest.initial.dissipated_energy == first.dissipated_energy and rest.records[0].step == 6
    assert rest.dissipated_energy == pytest.approx(whole.dissipated_energy, rel=1e-12)


def test_an_interrupt_hands_over_the_last_converged_step_once():
    complete = []
    integrate_motion(SaggingStrip(), 0.2, 0.01, settings=SETTINGS,
                     on_step=lambda rec, q, v: complete.append((rec, q.copy(), v.copy())))
    handed = []
    with pytest.raises(KeyboardInterrupt):
        integrate_motion(SaggingStrip(stop_at=30), 0.2, 0.01, settings=SETTINGS, record_every=1000,
                         on_step=lambda rec, q, v: handed.append((rec, q.copy(), v.copy())))
    assert len(handed) == 1                       # only the interrupted step's predecessor, no record before it
    rec, q, v = handed[0]
    assert isinstance(rec, DynamicStepRecord) and rec.step > 1 and rec.iterations == 0
    assert np.array_equal(rec.motion["v"], v)
    ref, q_ref, v_ref = complete[rec.step - 1]
    assert rec.time == ref.time and np.array_equal(q.x, q_ref.x) and np.array_equal(v, v_ref)
    assert rec.dissipated_energy == ref.dissipated_energy and rec.total_energy == ref.total_energy


def test_an_interrupt_in_on_step_is_not_handed_over_twice():
    calls = []

    def on_step(rec, q, v):
        calls.append(rec.step)
        if rec.step == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        integrate_motion(SaggingStrip(), 0.1, 0.01, settings=SETTINGS, on_step=on_step)
    assert calls == [1, 2, 3]


def test_an_account_is_an_observer_of_the_plain_integrator():
    dyn = SaggingStrip()
    account = EnergyAccount(dyn)
    out = generalized_alpha(dyn, 0.05, 0.01, settings=SETTINGS, observers=[account])
    assert out.converged and len(account.records) == 5 and account.last.time == out.time
    assert account.initial.step == 0 and account.records[-1].dissipated_energy == account.dissipated
