"""The fast stiff and extreme cases of benchmarks/stress.py (the full table: python benchmarks/stress.py)."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

_spec = importlib.util.spec_from_file_location("flexbody_stress_cases",
                                               Path(__file__).parents[1] / "benchmarks" / "stress.py")
stress = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = stress          # dataclasses look their module up
_spec.loader.exec_module(stress)


def _check(row):
    assert row.passed, f"{row.case}: {row.figure} {row.note}"
    return row


@pytest.mark.parametrize("h_over_l", [1e-3, 1e-5])
def test_thin_strip_does_not_lock_and_newton_converges(h_over_l):
    """End shear at h/L = 1e-3 and 1e-5: the normalised tip response within 1 % of the benchmark."""
    _check(stress.case_thickness(h_over_l))


def test_rotation_past_4_pi_follows_the_exact_elastica():
    row = _check(stress.case_rotation_4pi(nx=24, steps=48))
    assert "rotation 3.99" in row.figure or "rotation 4.00" in row.figure


def test_exp_log_near_pi_and_2_pi():
    _check(stress.case_exp_log())


def test_whole_load_in_one_step_is_reached_by_cut_back():
    row = _check(stress.case_one_step_shear(1e-2))
    assert "0 cut-backs" not in row.figure          # it did need to cut back
    _check(stress.case_one_step_moment())


def test_very_coarse_mesh():
    _check(stress.case_coarse())


def test_skewed_midside_nodes_converge_with_refinement():
    _check(stress.case_skewed(0.05))
    # the strongest allowed skew costs accuracy on a coarse mesh, but the error falls fast with refinement
    errors = []
    for nx in (16, 32):
        model, tip = stress.end_shear_model(stress.skewed_strip(0.2, nx))
        res, err, _ = stress.run_end_shear(model, tip, np.linspace(0, 1, 21)[1:])
        assert res.converged
        errors.append(err)
    assert errors[1] < errors[0] / 4 and errors[1] < 0.015, errors


def test_nearly_incompressible_material():
    _check(stress.case_incompressible(0.4999))
