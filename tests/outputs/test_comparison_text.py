"""The printed tables of ``flexbody compare`` from a comparison dict (no exudyn needed)."""

from __future__ import annotations

import math

from flexbody.outputs.comparison_text import table_lines


def _run(dofs: int, converged: bool = True, message: str = "completed") -> dict:
    return {"model": f"model with {dofs} DoFs", "dofs": dofs, "steps": 4, "newton_iterations": 20,
            "build_time_s": 0.25, "wall_time_s": 0.5, "cpu_time_s": 0.125, "load_factor": 1.0,
            "max_rel_error": 8.3e-3, "converged": converged, "message": message}


def static_result() -> dict:
    return {"scene": "cantilever_end_shear", "parameters": {"nx": 4}, "exudyn_options": {"model": "beam2d"},
            "flexbody": _run(120), "exudyn": _run(24, False, "exudyn SolverError: no convergence"),
            "outputs": [{"name": "W_tip", "flexbody": 6.6423, "exudyn": None, "difference": None,
                         "rel_difference": math.nan, "reference": 6.698, "flexbody_ref_error": 8.31e-3,
                         "exudyn_ref_error": None}],
            "reference_source": "the S4R table", "ok": False}


def test_static_table_lines():
    lines = table_lines(static_result())
    assert lines[:4] == ["scene            cantilever_end_shear",
                         "parameters       {'nx': 4}  exudyn {'model': 'beam2d'}",
                         "flexbody         model with 120 DoFs",
                         "exudyn           model with 24 DoFs"]
    assert "DoFs                             120            24" in lines
    assert "solve CPU time [s]             0.125         0.125" in lines
    assert "converged                       True         False" in lines
    # None prints "-", NaN prints "nan"
    assert "W_tip                 6.6423           -           -       nan      6.698      8.31e-03           -" in lines
    assert lines[-2:] == ["reference: the S4R table (errors: max over the table, relative to max |ref|)",
                          "exudyn: exudyn SolverError: no convergence"]


def test_dynamic_table_marks_missing_values():
    run = {"model": "m", "dofs": 10, "time_step": 2e-3, "steps": 5, "time": 0.01, "newton_iterations": 7,
           "build_time_s": 0.1, "wall_time_s": 0.2, "cpu_time_s": 0.3,
           "momentum": {"angular": {"initial": [0.0, 0.0, 16.5], "final": [0.0, 0.0, 16.5], "max_rel_drift": 1e-4}},
           "energy": {"strain": {"max": 2.5, "min": 0.1, "mean": 1.0}, "total": {"max_rel_drift": 3e-4}},
           "converged": True, "message": "completed"}
    result = {"scene": "spinning_plate", "kind": "dynamic", "parameters": {}, "exudyn_options": {},
              "flexbody": run, "exudyn": dict(run, momentum={}), "reference": None, "outputs": [],
              "strain_energy_samples": {"time": [0.0], "flexbody": [0.0], "exudyn": [None]}}
    lines = table_lines(result)
    assert lines[:2] == ["scene            spinning_plate (dynamic)", "parameters       {}"]
    assert "L_z(0)                                16.5             -" in lines
    assert "   0.000             0             -" in lines
