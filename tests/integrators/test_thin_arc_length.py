"""Arc length on thin shells and limit points under load control (issue 14).

Before, the arc-length corrector had no round-off-floor test: on a thin shell the residual stalls at its
floor above the tolerance, each cut-back tightened the tolerance, and the run failed at step 1 blaming
non-convergence. Load control that stopped at a limit point said only "no convergence".
"""

import dataclasses
import math

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix, Symmetry
from flexbody.loads import NodalLoad
from flexbody.mesh import generators
from flexbody.scenes.builtin import cantilever_end_shear
from flexbody.scenes.scene import StaticAnalysis, run_scene
from flexbody.shell.material import ShellMaterial
from integrators.linear import LinearSolver
from integrators.newton import NewtonSettings
from integrators.static import arc_length, load_control

THIN_ARCH_LIMIT = 2.93   # the first limit load factor of the thin half arch below (arc length, 2 x 4 x 1 mesh)


def thin_half_arch(thickness=0.005):
    """Half of a pinned shallow cylindrical arch (R = 10, 0.5 rad, span 4.9, rise 0.31; h / span = 1e-3), a
    symmetry plane at the crown and a crown line load: a symmetric snap-through, the load factor going up
    to a limit point, down (below zero) to a second one, and up again."""
    R, half = 10.0, 0.25
    mesh = generators.cylinder(R, 0.5, 4, 1, angle=half)
    body = ShellBody(mesh, ShellMaterial(1e6, 0.0, thickness))
    crown = mesh.node_set("end")
    down = -np.array([math.cos(half), math.sin(half), 0.0])
    cons = [Symmetry(crown, (-math.sin(half), math.cos(half), 0.0)), Fix(mesh.node_set("start"), "translations"),
            Fix(mesh.node_set("bottom"), ("z",))]
    force = down * (thickness / 0.05) ** 3 / 2 / len(crown)
    return Model(body, cons, [NodalLoad(crown, force=force)])


def _is_equilibrium(model, state, lam):
    """A Newton correction from the state is below 1e-9 of the model size: an equilibrium to round-off (a
    thin shell's residual has a floor, up to 1e-4 of the load here, far above the force tolerance)."""
    r, K = model.residual_and_tangent(dataclasses.replace(state, stress=None), lam)
    solver = LinearSolver()
    solver.factorize(K)
    return float(np.max(np.abs(solver.solve(-r) / model.dof_scale))) <= 1e-9


def test_thin_end_shear_strip_in_arc_length_reaches_the_end_as_load_control_does():
    """h/L = 1e-3: arc length failed at step 1 (residual floor 1.6e-10 above the tolerance); now it ends at
    P_max on the load-control answer, with its error against the reference."""
    scene = cantilever_end_shear(thickness=0.01)
    lc = run_scene(scene)
    arc = run_scene(dataclasses.replace(scene, analysis=StaticAnalysis("arc_length", (1.0,))))
    assert arc.result.converged, arc.result.message
    assert arc.history["load_factor"][-1] == 1.0
    ref = scene.reference.values
    for name in ("W_tip", "minus_U_tip"):
        err_lc = abs(lc.history[name][-1] / ref[name][-1] - 1)
        err_arc = abs(arc.history[name][-1] / ref[name][-1] - 1)
        assert err_arc == pytest.approx(err_lc, abs=2e-5) and err_arc < 2e-3
        assert arc.history[name][-1] == pytest.approx(lc.history[name][-1], rel=2e-5)


def test_thin_roof_snap_through_in_arc_length_at_default_settings():
    """The load factor goes up to the limit point, down below zero to the second one, and up again to the end;
    every converged point is an equilibrium."""
    model = thin_half_arch()
    path = []
    result = arc_length(model, lam_max=4.0, on_step=lambda rec, q: path.append((rec.load_factor, q)))
    assert result.converged, result.message
    lams = np.array([lam for lam, _ in path])
    first = int(np.argmax(lams[:len(lams) // 2]))
    second = first + int(np.argmin(lams[first:]))
    assert lams[first] == pytest.approx(THIN_ARCH_LIMIT, abs=0.02)              # up to the limit point,
    assert lams[second] < -5.0 and np.all(np.diff(lams[first:second + 1]) < 0)  # down below zero,
    assert np.all(np.diff(lams[second:]) > 0) and lams[-1] == 4.0              # and up again to the end
    for lam, q in path[:-1]:
        assert _is_equilibrium(model, q, lam)


def test_load_control_names_the_limit_point_of_the_thin_roof():
    model = thin_half_arch()
    result = load_control(model, [2.0, 4.0], settings=NewtonSettings(max_iterations=12), min_step=5e-3)
    assert not result.converged
    limit = result.failure.limit_point
    assert limit == pytest.approx(THIN_ARCH_LIMIT, abs=0.02)
    assert result.load_factor <= limit
    assert result.message.startswith(f"limit point at load factor {limit:.6g}")
    assert "use arc length" in result.message
    assert _is_equilibrium(model, result.state, result.load_factor)


def test_a_failure_that_is_no_limit_point_gets_no_such_hint():
    """Too few iterations on a stiffening strip: no convergence, and no limit point claimed."""
    scene = cantilever_end_shear(nx=4)
    result = load_control(scene.model, [1.0], settings=NewtonSettings(max_iterations=2), min_step=0.2)
    assert not result.converged and result.failure.limit_point is None
    assert "limit point" not in result.message
