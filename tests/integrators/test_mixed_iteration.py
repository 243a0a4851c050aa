"""The mixed Newton iteration (NewtonSettings.mixed): the same equilibria as the displacement iteration,
in fewer iterations on thin shells; where it does not apply (MITC7, models without stresses) the run says
so and uses the displacement iteration."""

import dataclasses

import numpy as np
import pytest

from flexbody.scenes import builtin
from integrators.linear import LinearSolver
from integrators.newton import NewtonSettings, NewtonStats, newton_solve, work_norm
from integrators.static import arc_length, load_control
from tests.integrators.test_fewer_iterations import _max_displacement_difference, _run
from tests.integrators.toy import CubicSpring

DISPLACEMENT = NewtonSettings(mixed=False)
MIXED = NewtonSettings(mixed=True)


def test_thin_plate_same_equilibria_in_fewer_iterations():
    """Same equilibria on the slit plate's coarsest mesh, to the path dependence of the 5-DoF frames.

    The nodal frames carry a drilling angle that no update sets (R <- R exp(th1 e1 + th2 e2)) but that
    non-commuting updates accumulate along the path, and the relative-rotation interpolation depends on it
    weakly: two iteration histories end on two equilibria (each a fixed point of Newton to round-off) that
    differ by 1e-4 rad in drilling and 3e-6 of the deflection on this 2x2x8 mesh.
    """
    scene = builtin.slit_annular_plate(n_radial=2, n_circ=8)
    model = scene.model
    levels = scene.analysis.load_factors
    plain, states_d = _run(model, levels, DISPLACEMENT)
    mixed, states_m = _run(model, levels, MIXED)
    assert plain.stats.iteration == "displacement" and mixed.stats.iteration == "mixed"
    diff, n = _max_displacement_difference(model, states_d, states_m)
    assert n == len(levels) and diff < 1e-5
    for state in (plain.state, mixed.state):       # both are equilibria: Newton from them does not move
        state = dataclasses.replace(state, stress=None)
        lam = levels[-1]
        ref = work_norm(lam * model.external_force(state), model.dof_scale)
        end, out = newton_solve(state, lambda q: model.residual(q, lam), lambda q: model.residual_and_tangent(q, lam),
                                model.update, ref, dataclasses.replace(DISPLACEMENT, lazy_tangent=0.0), LinearSolver(),
                                NewtonStats(), dof_scale=model.dof_scale)
        assert out.converged and np.abs(end.x - state.x).max() < 1e-10 * np.abs(state.x - model.body.mesh.nodes).max()
    assert mixed.stats.factorizations <= 0.6 * plain.stats.factorizations
    assert mixed.stats.iterations <= 0.7 * plain.stats.iterations


def test_one_step_of_the_rolling_strip():
    """The first step of the end moment (h/L = 1/120): the displacement iteration needs 13 iterations,
    its residual jumping 2e5-fold after the predictor and recovering slowly; the mixed one converges
    quadratically after the jump."""
    model = builtin.cantilever_end_moment().model
    lam = 0.05
    counts = {}
    for settings in (dataclasses.replace(DISPLACEMENT, lazy_tangent=0.0), dataclasses.replace(MIXED, lazy_tangent=0.0)):
        start = model.initial_state()
        if settings.mixed:
            start = model.with_stresses(start)
        ref = work_norm(lam * model.external_force(start), model.dof_scale)
        state, out = newton_solve(start, lambda q: model.residual(q, lam), lambda q: model.residual_and_tangent(q, lam),
                                  model.update, ref, settings, LinearSolver(), NewtonStats(), dof_scale=model.dof_scale)
        assert out.converged, out.reason
        counts[settings.mixed] = out.iterations
        if settings.mixed:
            r = [v for v in out.residuals if np.isfinite(v)]
            assert r[-1] < 1e-6 * r[-2] or r[-1] <= 1e-8 * ref     # the last step is quadratic
    assert counts[True] <= 6 < 10 <= counts[False]


def test_arc_length_reaches_the_same_end_state():
    scene = builtin.pullout_cylinder(n_circ=8, n_axial=6)
    a = scene.analysis
    runs = [arc_length(scene.model, lam_max=1.0, initial_increment=a.arc_increment,
                       max_load_increment=a.max_load_increment, settings=dataclasses.replace(a.newton, mixed=m))
            for m in (False, True)]
    assert all(r.converged for r in runs) and runs[1].stats.iteration == "mixed"
    u = np.abs(runs[0].state.x - scene.model.body.mesh.nodes).max()
    assert np.abs(runs[1].state.x - runs[0].state.x).max() < 1e-6 * u
    assert runs[1].stats.factorizations < runs[0].stats.factorizations


def test_where_the_mixed_iteration_does_not_apply():
    scene = builtin.cantilever_end_shear(nx=4, tying="mitc7")
    result = load_control(scene.model, scene.analysis.load_factors[:2], settings=MIXED)
    assert result.converged and result.stats.iteration == "displacement"
    with pytest.raises(ValueError, match="mitc7"):
        scene.model.body.mixed_element_forces(scene.model.initial_state(), np.zeros((1, 7, 8)))
    modified = load_control(builtin.cantilever_end_shear(nx=4).model, [0.5], settings=dataclasses.replace(
        MIXED, policy="modified"))                                           # an old matrix: displacement
    assert modified.converged and modified.stats.iteration == "displacement"
    toy = load_control(CubicSpring(load=0.01), [0.5, 1.0], settings=MIXED)   # no stresses at all
    assert toy.converged and toy.stats.iteration == "displacement"
    with pytest.raises(ValueError, match="mixed"):
        NewtonSettings(mixed="yes")
