"""Fewer tangents and factorizations for the same equilibria: the lazy tangent near convergence (round-off
floor, chord steps, the factorization carried into the next step), the opt-in secant predictor with its
fallback, step growth between distant prescribed levels, and the arc-length predictor on the factorization
of the converged step."""

import math

import numpy as np
import pytest
import scipy.sparse as sp

from flexbody.scenes import builtin
from integrators.linear import LinearSolver
from integrators.newton import NewtonSettings, NewtonStats, newton_solve
from integrators.static import arc_length, load_control
from tests.integrators.test_divergence import arch
from tests.integrators.toy import CubicSpring, HardeningSpring

CLASSICAL = NewtonSettings(lazy_tangent=0.0)     # a tangent and a factorization at every iteration


def _run(model, levels, settings=None, **kwargs):
    states = []
    result = load_control(model, levels, settings=settings, on_step=lambda rec, q: states.append((rec.load_factor, q)),
                          **kwargs)
    assert result.converged, result.message
    return result, states


def _max_displacement_difference(model, a, b):
    """max |x_a - x_b| over the levels both runs reached, relative to the largest displacement."""
    b_at = {round(lam, 12): q for lam, q in b}
    common = [(q, b_at[round(lam, 12)]) for lam, q in a if round(lam, 12) in b_at]
    assert common
    u_max = max(np.abs(q.x - model.body.mesh.nodes).max() for q, _ in common)
    return max(np.abs(qa.x - qb.x).max() for qa, qb in common) / u_max, len(common)


def test_thin_plate_same_equilibria_with_fewer_tangents_and_factorizations():
    """The slit annular plate on a coarse mesh (thin: the first correction of every step throws the
    membrane residual up by 5 orders): the lazy tangent saves a third of the factorizations and lands on
    the classical equilibria to the round-off floor."""
    scene = builtin.slit_annular_plate(n_radial=2, n_circ=8)
    levels = scene.analysis.load_factors
    classical, states_c = _run(scene.model, levels, CLASSICAL)
    lazy, states_l = _run(scene.model, levels, NewtonSettings())
    assert [r.load_factor for r in lazy.records] == [r.load_factor for r in classical.records]
    diff, n = _max_displacement_difference(scene.model, states_c, states_l)
    assert n == len(levels) and diff < 1e-6
    c, s = classical.stats, lazy.stats
    # every run reports its iterations, tangent updates and factorizations
    assert min(s.iterations, s.tangent_updates, s.factorizations, s.residual_evaluations) > 0
    assert c.factorizations == c.iterations                  # classical Newton: one per iteration
    assert s.factorizations <= 0.75 * c.factorizations
    assert s.tangent_updates <= 0.75 * c.tangent_updates
    assert s.factorizations < s.iterations                   # chord steps and the carried factorization


class ScriptedResidual:
    """One DoF, tangent 1, whose residual norms follow a script (one entry per evaluation, the last one
    repeated): the iterations of a thin shell reaching its round-off floor, where the residual no longer
    contracts."""

    def __init__(self, script):
        self.script, self.calls, self.tangents = list(script), 0, 0

    def residual(self, q):
        value = self.script[min(self.calls, len(self.script) - 1)]
        self.calls += 1
        return np.array([value])

    def residual_and_tangent(self, q):
        self.tangents += 1
        return self.residual(q), sp.csc_matrix([[1.0]])


def _scripted(script, lazy):
    model, stats = ScriptedResidual(script), NewtonStats()
    settings = NewtonSettings(rtol=1e-16, increment_tol=1e-11, lazy_tangent=lazy)
    state, out = newton_solve(np.zeros(1), model.residual, model.residual_and_tangent, lambda q, dq: q + dq,
                              1.0, settings, LinearSolver(), stats)
    return state, out, stats


def test_round_off_floor_is_detected_on_the_factorization_held():
    """1 -> 1e-6 (quadratic), then 2e-11 (a chord step: its correction is above increment_tol), then the floor
    8e-12, no longer contracting: classical Newton assembles and factorizes once more to find the correction
    below increment_tol; the lazy test finds it on the factorization held."""
    script = [1.0, 1e-6, 2e-11, 8e-12]
    _, out_c, classical = _scripted(script, 0.0)
    state, out, lazy = _scripted(script, 1e-4)
    assert out_c.converged and out.converged
    assert classical.factorizations == classical.tangent_updates == 4
    assert lazy.factorizations == lazy.tangent_updates == 2
    assert out.residuals[-2:] == [8e-12, out.residuals[-1]] and np.isnan(out.residuals[-1])
    # the round-off correction from the floor is not applied: the state is the one evaluated last
    assert state[0] == pytest.approx(-(1.0 + 1e-6 + 2e-11), abs=1e-15)
    assert out.factorization_lag == pytest.approx(1e-6 + 2e-11)


def test_a_floor_above_increment_tol_still_gets_a_fresh_tangent():
    """A stalled residual whose correction on the held factorization is above increment_tol is not taken for
    converged: a fresh tangent decides (here the script stalls for good: no convergence)."""
    _, out, stats = _scripted([1.0, 1e-6, 3e-11], 1e-4)
    assert not out.converged and "no convergence" in out.reason
    assert stats.factorizations > 2


def test_a_step_starts_on_the_factorization_of_the_previous_step():
    """Full Newton: the next step's first correction uses the factorization of the last iterates of the
    previous one (a dead load: the same tangent), so each step after the first saves one."""
    model = CubicSpring(load=0.01)
    levels = np.linspace(0.1, 1.0, 10)
    classical = load_control(model, levels, settings=NewtonSettings(rtol=1e-12, lazy_tangent=0.0), adaptive=False)
    lazy = load_control(model, levels, settings=NewtonSettings(rtol=1e-12), adaptive=False)
    assert classical.converged and lazy.converged
    assert lazy.stats.factorizations <= classical.stats.factorizations - (len(levels) - 1)
    assert abs(lazy.state[0] - classical.state[0]) < 1e-12
    assert abs(model.f_int(lazy.state[0]) - 0.01) < 1e-12


def test_secant_predictor_lands_on_the_same_equilibria():
    scene = builtin.cantilever_end_shear(nx=4)
    levels = scene.analysis.load_factors
    tangent, states_t = _run(scene.model, levels)
    secant, states_s = _run(scene.model, levels, predictor="secant")
    diff, n = _max_displacement_difference(scene.model, states_t, states_s)
    assert n == len(levels) and diff < 1e-6
    assert secant.cutbacks == 0


def test_a_failed_predicted_start_is_retried_from_the_converged_state():
    """A stiffening spring: the secant extrapolation (twice the last step) overshoots into a region where
    the model fails; the step is retried from the converged state, without a cut-back."""
    model = HardeningSpring(load=1.0, fail_above=1.12)
    result = load_control(model, [0.5, 1.0, 2.0], predictor="secant")
    assert result.converged, result.message
    assert model.failures >= 1                                # the predicted start of the last step failed
    assert result.cutbacks == 0 and [r.load_factor for r in result.records] == [0.5, 1.0, 2.0]
    assert abs(model.f_int(result.state[0]) - 2.0) < 1e-8 * 2.0    # w = 1, to the force tolerance
    plain = HardeningSpring(load=1.0, fail_above=1.12)
    assert load_control(plain, [0.5, 1.0, 2.0]).converged and plain.failures == 0


def test_failed_predicted_and_plain_starts_still_stop_with_a_report():
    """When the retry from the converged state fails too, the usual cut-backs follow, and the run stops with
    the last converged state and a report."""
    model = HardeningSpring(load=1.0, fail_above=0.9)
    result = load_control(model, [0.5, 1.0, 2.0], predictor="secant", min_step=0.05)
    assert not result.converged
    assert result.failure.load_factor == result.load_factor and result.state[0] <= 0.9
    assert abs(model.f_int(result.state[0]) - result.load_factor) < 1e-10
    assert "non-finite" in result.message and "stopped at the last converged load factor" in result.message


def test_steps_grow_between_distant_levels_and_hit_every_level():
    """A strip under end shear takes 5-11 displacement-Newton iterations per step whatever its size: growing
    only after <= 4 of them (the old rule) crawls at the first step's size; every prescribed level is still
    reached. (The mixed iteration takes 3-4, and both rules grow its steps.)"""
    scene = builtin.cantilever_end_shear(nx=4)
    levels = [0.05, 0.5, 1.0]
    displacement = NewtonSettings(mixed=False)
    old, states_o = _run(scene.model, levels, displacement, grow_iterations=4)
    new, states_n = _run(scene.model, levels, displacement)
    assert len(new.records) < len(old.records)
    assert new.stats.factorizations < old.stats.factorizations
    reached = {round(r.load_factor, 12) for r in new.records}
    assert all(round(lam, 12) in reached for lam in levels)
    diff, n = _max_displacement_difference(scene.model, states_o, states_n)
    assert n >= len(levels) and diff < 1e-6


def test_arc_length_predictor_on_the_converged_factorization():
    """Arc length over the limit point of a shallow arch: the predictor reuses the factorization of the
    converged step's last iterate (and the converged iterate assembles no tangent): a third fewer
    factorizations, the same points of the path."""
    runs = {}
    for lazy in (0.0, 1e-4):
        model, path = arch(), []
        result = arc_length(model, lam_max=100.0, initial_increment=0.5, max_steps=14,
                            settings=NewtonSettings(lazy_tangent=lazy),
                            on_step=lambda rec, q: path.append((rec.load_factor, q)))
        runs[lazy] = result, path, model
    (c, path_c, model), (s, path_s, _) = runs[0.0], runs[1e-4]
    assert len(path_c) == len(path_s) == 14
    lam_c, lam_s = np.array([p[0] for p in path_c]), np.array([p[0] for p in path_s])
    np.testing.assert_allclose(lam_s, lam_c, rtol=1e-6)
    assert max(np.abs(qa.x - qb.x).max() for (_, qa), (_, qb) in zip(path_c, path_s)) < 1e-6
    assert max(lam_s) > 2.6 and lam_s[-1] < max(lam_s)        # through the limit point
    assert s.stats.factorizations <= 0.8 * c.stats.factorizations
    assert s.stats.tangent_updates <= 0.7 * c.stats.tangent_updates
    for lam, q in path_s:
        r = model.residual(q, lam)
        assert np.linalg.norm(r) <= 1e-7 * abs(lam) * np.linalg.norm(model.external_force(q))


def test_a_residual_whose_norm_overflows_is_reported_not_raised():
    """Finite entries, overflowing norm: a non-finite residual, reported as such."""
    big = lambda q: np.array([1e200, 1e200]) + q
    with np.errstate(over="ignore"):
        state, out = newton_solve(np.zeros(2), big, lambda q: (big(q), None), lambda q, dq: q + dq, 1.0,
                                  NewtonSettings(), LinearSolver(), NewtonStats())
    assert not out.converged and out.non_finite and "overflows" in out.reason
    assert math.isfinite(state[0])


def test_benchmark_script_classical_variant_is_the_old_solver():
    """benchmarks/fewer_iterations.py: its "classical" variant is the solver before the lazy tangent and the
    mixed iteration (on the end-shear strip it took 117 iterations, 135 tangents, 117 factorizations,
    docs/benchmarks.md until 2026-12), and the defaults land on the same outputs with fewer tangents and
    factorizations."""
    import importlib.util
    import sys
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("flexbody_fewer_iterations",
                                                  Path(__file__).parents[2] / "benchmarks" / "fewer_iterations.py")
    bench = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = bench
    spec.loader.exec_module(bench)
    classical = bench.run("cantilever_end_shear", "classical")
    default = bench.run("cantilever_end_shear", "default")
    # one tangent and factorization per iteration (and a tangent at each force-converged iterate)
    assert classical["factorizations"] == classical["iterations"] < classical["tangents"]
    assert abs(classical["iterations"] - 117) <= 5 and abs(classical["tangents"] - 135) <= 5
    assert default["factorizations"] < 0.7 * classical["factorizations"]
    assert default["tangents"] < 0.6 * classical["tangents"]
    assert bench.output_change(classical, default) < 1e-7
    assert default["error"] == pytest.approx(classical["error"], rel=1e-6)


@pytest.mark.parametrize("bad", [-1, 2.5, "4", True])
def test_bad_grow_iterations_is_refused_with_its_value(bad):
    with pytest.raises(ValueError, match="grow_iterations"):
        load_control(CubicSpring(), [0.1], grow_iterations=bad)
