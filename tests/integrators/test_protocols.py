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
from integrators.protocols import (ConjugateMatrix, Damped, DynamicProblem, LumpedMass, MassMatrix,
                                   MixedIteration, Prescribed, StaticProblem, StressedState, SupportCheck,
                                   TransferAlongMotion, WrapsStaticProblem, members, missing, require)
from integrators.static import arc_length, load_control
from tests.integrators.test_generalized_alpha import Oscillator
from tests.integrators.test_scale_free import Duffing
from tests.integrators.toy import CubicSpring, HardeningSpring


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


@pytest.mark.parametrize("hidden", ["momenta", "n_dof", "mass"])
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
    """A model with half a capability (damping_force without damping_matrix) is taken as undamped."""

    class HalfDamped(Oscillator):
        def damping_force(self, q, v):
            raise AssertionError("never called")

    dyn, half = Oscillator([1.0]), HalfDamped([1.0])
    assert not isinstance(half, Damped)
    a = generalized_alpha(dyn, 1.0, 0.1, state=np.ones(1))
    b = generalized_alpha(half, 1.0, 0.1, state=np.ones(1))
    assert np.array_equal(a.state, b.state) and a.stats.iterations == b.stats.iterations


def test_the_halves_of_a_cut_step_sum_their_work():
    """StepTaken.then: the end values of the second half, the histories in order, the failed try counted."""
    one, two = np.ones(1), 2 * np.ones(1)
    first = StepTaken("q1", one, one, one, 3, [1.0, 0.1], [5.0], 1, 1, 0, 0.5)
    second = StepTaken("q2", two, two, two, 2, [0.2], [4.0, 0.5], 0, 2, 1, 0.25)
    both = first.then(second)
    assert (both.state, both.v[0], both.vdot[0], both.a[0], both.h) == ("q2", 2.0, 2.0, 2.0, 0.25)
    assert (both.iterations, both.refreshes, both.substeps, both.failures) == (5, 1, 3, 2)
    assert both.residuals == [1.0, 0.1, 0.2] and both.corrections == [5.0, 4.0, 0.5]
