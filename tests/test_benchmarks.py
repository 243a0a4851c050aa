"""The paper's nonlinear benchmarks at the paper's meshes, against the reference tables (Sze et al. 2004).

Errors are measured at every tabulated load level; the relative error of a quantity is
|value - reference| / max |reference| over the table (``flexbody.scenes.scene.compare_with_reference``).
"""

import pytest

from flexbody.scenes import build, run_scene


def run(name, **params):
    summary = run_scene(build(name, **params))
    assert summary.result.converged, summary.result.message
    return summary


def test_cantilever_end_shear_within_one_percent_of_sze():
    s = run("cantilever_end_shear")
    assert len(s.errors) == 40
    assert s.max_rel_error < 0.01


@pytest.mark.parametrize("thickness", [0.1, 0.01])
def test_cantilever_end_moment_rolls_into_a_full_circle(thickness):
    """Tip within 1e-3 L of the elastica at every 0.05 M_max, up to the closed circle."""
    s = run("cantilever_end_moment", thickness=thickness)
    L = 12.0
    abs_err = [abs(e["value"] - e["reference"]) for e in s.errors]
    assert len(abs_err) == 40
    assert max(abs_err) < 1e-3 * L
    assert abs(s.history["minus_U_tip"][-1] - L) < 1e-3 * L  # the tip is back at the root


@pytest.mark.slow
def test_slit_annular_plate_within_one_percent_at_the_paper_mesh_with_mitc7():
    """W_A, W_B within 1 % at every tabulated load on the paper's 2 x 10 x 30 mesh with MITC7 (measured
    0.87 %). MITC6 gives 1.15 % there and 0.41 % on 2 x 10 x 60: see docs/benchmarks.md."""
    s = run("slit_annular_plate", tying="mitc7")
    assert s.max_rel_error < 0.01


@pytest.mark.slow
def test_hemisphere_within_one_percent():
    s = run("hemisphere")
    assert s.max_rel_error < 0.01


@pytest.mark.slow
def test_pullout_cylinder_within_two_percent_at_pmax():
    s = run("pullout_cylinder")
    final = [e for e in s.errors if e["load_factor"] == 1.0]
    assert final and max(e["rel_error"] for e in final) < 0.02


@pytest.mark.slow
def test_pullout_cylinder_with_mitc7_within_two_percent_at_pmax():
    """MITC7 through the snap on the paper's 2 x 12 x 8 mesh (measured 1.66 % at worst over the path)."""
    s = run("pullout_cylinder", tying="mitc7")
    final = [e for e in s.errors if e["load_factor"] == 1.0]
    assert final and max(e["rel_error"] for e in final) < 0.02
