"""Divergence on a real shell: a shallow arch loaded far beyond its limit point.

A step that fails is cut back down to the minimum; then the run stops with a report (which step, which load
factor, the residual history) and keeps the last converged state, which is an equilibrium.
"""

import math

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.loads import NodalLoad
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from integrators.newton import NewtonSettings
from integrators.static import arc_length, load_control

LIMIT = 2.69   # limit load factor of this arch (arc-length path, 8 x 1 cells)


def arch():
    """Shallow cylindrical arch (R = 10, 0.5 rad, rise 0.31, h = 0.05), pinned ends, crown line load."""
    R, half = 10.0, 0.25
    mesh = generators.cylinder(R, 0.5, 8, 1, angle=2 * half)
    body = ShellBody(mesh, ShellMaterial(1e6, 0.0, 0.05))
    crown = np.flatnonzero(np.abs(np.arctan2(mesh.nodes[:, 1], mesh.nodes[:, 0]) - half) < 1e-9)
    down = -np.array([math.cos(half), math.sin(half), 0.0])
    cons = [Fix(mesh.node_set("start"), "translations"), Fix(mesh.node_set("end"), "translations"),
            Fix(mesh.node_set("bottom"), ("z",))]
    return Model(body, cons, [NodalLoad(crown, force=down / len(crown))])


def _is_equilibrium(model, state, lam):
    r = model.residual(state, lam)
    return np.linalg.norm(r) <= 1e-7 * abs(lam) * np.linalg.norm(model.external_force(state))


def test_load_control_beyond_the_limit_point_stops_with_a_report_and_keeps_the_state():
    model = arch()
    result = load_control(model, [5.0], settings=NewtonSettings(max_iterations=8), min_step=0.01)
    assert not result.converged
    f = result.failure
    assert f is not None and f.step == len(result.records) + 1
    assert result.cutbacks >= 5                                # 5 -> 2.5 -> ... cut back down to min_step
    # it got as close to the limit point as min_step allows, never past it
    assert LIMIT - 0.1 < result.load_factor < LIMIT
    assert f.load_factor == result.load_factor == result.records[-1].load_factor
    assert result.load_factor < f.trial_load_factor < result.load_factor + 2 * 0.01 + 1e-12
    assert len(f.residuals) == 9 and "no convergence in 8 iterations" in f.reason
    assert (f"step {f.step} to load factor {f.trial_load_factor:.6g} failed" in result.message
            and "residual history" in result.message
            and f"stopped at the last converged load factor {result.load_factor:.6g}" in result.message)
    assert _is_equilibrium(model, result.state, result.load_factor)


def test_arc_length_passes_the_limit_point_that_load_control_cannot():
    model = arch()
    lams = []
    result = arc_length(model, lam_max=100.0, initial_increment=0.5, max_steps=14,
                        on_step=lambda rec, q: lams.append(rec.load_factor))
    assert max(lams) == pytest.approx(LIMIT, abs=0.02)
    assert lams[-1] < max(lams) - 0.3                           # beyond the limit, on the descending branch
    assert _is_equilibrium(model, result.state, result.load_factor)


class BlowsUpAbove:
    """The arch model, but any evaluation above a load factor raises as a non-finite element would."""

    def __init__(self, model, lam_bad):
        self.model, self.lam_bad = model, lam_bad

    def __getattr__(self, name):
        return getattr(self.model, name)

    def residual_and_tangent(self, q, lam):
        if lam > self.lam_bad:
            raise FloatingPointError("element 3 gives non-finite internal forces (forced by the test)")
        return self.model.residual_and_tangent(q, lam)

    def residual(self, q, lam):
        if lam > self.lam_bad:
            raise FloatingPointError("element 3 gives non-finite internal forces (forced by the test)")
        return self.model.residual(q, lam)


def test_arc_length_stops_with_a_report_when_every_cut_back_fails():
    model = BlowsUpAbove(arch(), 1.5)
    result = arc_length(model, lam_max=100.0, initial_increment=0.5, max_steps=60)
    assert not result.converged
    f = result.failure
    assert f.step == len(result.records) + 1 and f.attempts >= 1 and f.non_finite
    assert result.cutbacks > 5                              # the arc length was cut back, step after step
    assert 1.45 < result.load_factor <= 1.5 and f.load_factor == result.load_factor
    assert "element 3 gives non-finite" in f.reason and "cut back below" in f.reason
    assert f"stopped at the last converged load factor {result.load_factor:.6g}" in result.message
    assert _is_equilibrium(model.model, result.state, result.load_factor)


def test_arc_length_with_too_few_iterations_keeps_the_start():
    model = arch()
    result = arc_length(model, lam_max=5.0, initial_increment=0.5, settings=NewtonSettings(max_iterations=1))
    assert not result.converged and result.records == [] and result.load_factor == 0.0
    assert result.failure.step == 1 and result.failure.attempts == result.cutbacks
    assert "no convergence in 1 iterations" in result.message
    np.testing.assert_array_equal(result.state.x, model.body.mesh.nodes)
