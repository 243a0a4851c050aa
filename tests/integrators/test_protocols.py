"""The models satisfy the integrator contracts of integrators/protocols.py, and a model that lacks a required
member is refused before the first step with one line naming it."""

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel, RayleighDamping
from flexbody.shell.material import ShellMaterial
from flexbody.mesh import generators
from flexbody.spinning import SpinningModel
from integrators.generalized_alpha import StepTaken, generalized_alpha
from integrators.protocols import (AcceptedStep, ConjugateMatrix, Damped, DynamicProblem, LumpedMass, MassMatrix,
                                   MixedIteration, Prescribed, StaticProblem, StepObserver, StressedState,
                                   SupportCheck, TransferAlongMotion, WrapsStaticProblem, capabilities, members,
                                   missing, require)
from integrators.static import arc_length, load_control
from tests.integrators.test_scale_free import Duffing
from tests.integrators.toy import CubicSpring, HardeningSpring, Oscillator


def strip_model() -> Model:
    mesh = generators.strip(1.0, 0.5, 2, 1)
    body = ShellBody(mesh, ShellMaterial(1e9, 0.3, 0.01, density=1000.0))
    return Model(body, [Fix(mesh.node_set("clamped"), "all")])


def test_the_shell_model_is_a_static_problem_with_its_capabilities():
    model = strip_model()
    assert isinstance(model, StaticProblem)
    for capability in (MixedIteration, SupportCheck, ConjugateMatrix):
        assert isinstance(model, capability), capability.__name__
    assert isinstance(model.initial_state(), StressedState)


def test_the_dynamic_model_is_a_dynamic_problem_with_its_capabilities():
    dyn = DynamicModel(strip_model(), damping=RayleighDamping(0.1, 0.0))
    assert isinstance(dyn, DynamicProblem) and isinstance(dyn, MassMatrix)
    for capability in (Damped, Prescribed, TransferAlongMotion, WrapsStaticProblem):
        assert isinstance(dyn, capability), capability.__name__
    assert isinstance(dyn.model, StaticProblem)
    require(dyn, DynamicProblem, "the dynamic problem")      # no error
    assert not isinstance(dyn, StaticProblem)                  # its residual takes (q, v, vdot, t)


def test_the_spinning_model_is_a_static_problem_with_its_capabilities():
    spin = SpinningModel(DynamicModel(strip_model()), np.array([0.0, 0.0, 3.0]), np.zeros(3))
    assert isinstance(spin, StaticProblem)
    for capability in (MixedIteration, SupportCheck, ConjugateMatrix):
        assert isinstance(spin, capability), capability.__name__


def test_the_analytic_test_models_satisfy_the_contracts():
    for model in (CubicSpring(), HardeningSpring()):
        assert isinstance(model, StaticProblem)
        assert not isinstance(model, (MixedIteration, SupportCheck, ConjugateMatrix))
        assert not isinstance(model.initial_state(), StressedState)
    for dyn in (Oscillator([1.0, 2.0]), Duffing(1.0)):
        assert isinstance(dyn, DynamicProblem) and isinstance(dyn, LumpedMass)
        assert not isinstance(dyn, (MassMatrix, Damped, Prescribed, TransferAlongMotion, WrapsStaticProblem))
        require(dyn, DynamicProblem, "the dynamic problem")


def test_members_lists_methods_and_attributes():
    assert members(StaticProblem) == ["dof_scale", "initial_state", "update", "residual", "residual_and_tangent",
                                      "external_force", "conjugate"]
    assert members(MixedIteration) == ["supports_mixed_iteration", "with_stresses"]
    assert missing(CubicSpring(), StaticProblem) == []


class _Without:
    """A model that hides one member of the model it wraps."""

    def __init__(self, model, hidden: str):
        self._model, self._hidden = model, hidden

    def __getattr__(self, name):
        if name == self._hidden:
            raise AttributeError(name)
        return getattr(self._model, name)


@pytest.mark.parametrize("hidden", ["conjugate", "dof_scale", "residual_and_tangent"])
@pytest.mark.parametrize("solve", [load_control, arc_length])
def test_a_static_model_without_a_required_member_is_refused_naming_it(hidden, solve):
    model = _Without(CubicSpring(load=0.1), hidden)
    assert not isinstance(model, StaticProblem)
    with pytest.raises(TypeError) as info:
        solve(model)
    message = str(info.value)
    assert "\n" not in message
    assert message == (f"the static problem _Without lacks {hidden} "
                       f"(the contract integrators.protocols.StaticProblem)")


@pytest.mark.parametrize("hidden", ["initial_acceleration", "n_dof", "mass"])
def test_a_dynamic_model_without_a_required_member_is_refused_naming_it(hidden):
    dyn = _Without(Oscillator([1.0]), hidden)
    with pytest.raises(TypeError) as info:
        generalized_alpha(dyn, 1.0, 0.1, state=np.ones(1))
    message = str(info.value)
    assert "\n" not in message and "the dynamic problem _Without lacks " in message
    assert (hidden if hidden != "mass" else "mass_matrix (or mass)") in message


def test_a_dynamic_problem_without_a_static_model_needs_a_start():
    with pytest.raises(ValueError, match="give state"):
        generalized_alpha(Oscillator([1.0]), 1.0, 0.1)


def test_a_capability_is_used_only_when_complete():
    """A model with half a capability (prescribe under another name) does without it."""

    class HalfPrescribed(Oscillator):
        def prescribe_nodes(self, q, t):
            raise AssertionError("never called")

    dyn, half = Oscillator([1.0]), HalfPrescribed([1.0])
    assert not isinstance(half, Prescribed) and capabilities(half).prescribed is None
    a = generalized_alpha(dyn, 1.0, 0.1, state=np.ones(1))
    b = generalized_alpha(half, 1.0, 0.1, state=np.ones(1))
    assert np.array_equal(a.state, b.state) and a.stats.iterations == b.stats.iterations


def test_the_halves_of_a_cut_step_sum_their_work():
    """StepTaken.then: the end values of the second half, the histories in order, the failed try counted."""
    one, two = np.ones(1), 2 * np.ones(1)
    first = StepTaken("q1", one, one, one, iterations=3, residuals=[1.0, 0.1], corrections=[5.0], refreshes=1,
                      substeps=1, failures=0, h=0.5)
    second = StepTaken("q2", two, two, two, iterations=2, residuals=[0.2], corrections=[4.0, 0.5], refreshes=0,
                       substeps=2, failures=1, h=0.25)
    both = first.then(second)
    assert (both.state, both.v[0], both.vdot[0], both.a[0], both.h) == ("q2", 2.0, 2.0, 2.0, 0.25)
    assert (both.iterations, both.refreshes, both.substeps, both.failures) == (5, 1, 3, 2)
    assert both.residuals == [1.0, 0.1, 0.2] and both.corrections == [5.0, 4.0, 0.5]


def test_the_dynamic_contract_has_no_energies_nor_momenta():
    """What the integrator records is observed from outside (flexbody.energy): the contract asks for none."""
    assert members(DynamicProblem) == ["n_dof", "dof_scale", "update", "residual", "residual_and_tangent",
                                       "initial_acceleration"]
    assert members(Damped) == ["damping_matrix"]


def test_capabilities_are_resolved_in_one_place():
    dyn = DynamicModel(strip_model(), damping=RayleighDamping(0.1, 0.0))
    caps = capabilities(dyn)
    assert caps.damped is caps.prescribed is caps.transfer is caps.mass_matrix is dyn
    assert caps.static_model is dyn.model and caps.mixed_iteration is None
    model_caps = capabilities(dyn.model)
    assert model_caps.mixed_iteration is model_caps.support_check is model_caps.conjugate_matrix is dyn.model
    assert capabilities(Oscillator([1.0])) == type(caps)()                 # none at all


def test_observers_get_the_start_and_every_step_in_order():
    seen = []
    out = generalized_alpha(Oscillator([1.0]), 1.0, 0.25, state=np.ones(1), record_every=3, observers=[seen.append])
    assert isinstance(seen.append, StepObserver) and all(isinstance(s, AcceptedStep) for s in seen)
    assert [(s.index, s.initial, s.output) for s in seen] == [(0, True, False), (1, False, False),
                                                              (2, False, False), (3, False, True), (4, False, True)]
    assert seen[0].step_size == 0.0 and seen[0].iterations == 0 and np.array_equal(seen[0].state, np.ones(1))
    assert all(s.step_size == 0.25 and s.iterations >= 1 for s in seen[1:])
    assert all(np.array_equal(b.previous_velocity, a.velocity) for a, b in zip(seen, seen[1:]))
    assert np.array_equal(seen[-1].state, out.state) and seen[-1].time == out.time == 1.0
