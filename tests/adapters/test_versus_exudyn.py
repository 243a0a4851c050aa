"""benchmarks/versus_exudyn.py: the time-to-accuracy pairing, and one coarse run of both codes."""

import importlib.util
import sys
from pathlib import Path

import pytest

pytest.importorskip("exudyn")

_spec = importlib.util.spec_from_file_location("flexbody_versus_exudyn",
                                               Path(__file__).parents[2] / "benchmarks" / "versus_exudyn.py")
vs = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = vs
_spec.loader.exec_module(vs)


def _run(mesh, error, cpu, converged=True):
    return dict(mesh=mesh, error=error, cpu_s=cpu, converged=converged)


def test_pairs_each_exudyn_run_with_the_cheapest_flexbody_run_at_least_as_accurate():
    ours = [_run("a", 0.020, 1.0), _run("b", 0.008, 3.0), _run("c", 0.003, 9.0), _run("d", 0.001, 2.0, False)]
    theirs = [_run("X", 0.010, 30.0), _run("Y", 0.002, 60.0), _run("Z", 0.05, 5.0, False)]
    rows = vs.time_to_accuracy(ours, theirs)
    assert [r["exudyn_mesh"] for r in rows] == ["X", "Y"]          # a failed exudyn run is not paired
    assert rows[0]["flexbody_mesh"] == "b" and rows[0]["ratio"] == pytest.approx(10.0)
    # nothing converged at <= 0.2 %: the failed run "d" does not count
    assert rows[1]["flexbody_mesh"] is None and rows[1]["ratio"] is None


def test_quick_ladder_runs_both_codes_on_the_same_problem():
    runs_f = [vs.run_flexbody("pullout_cylinder", p) for p in vs.QUICK["pullout_cylinder"]["flexbody"]]
    runs_x = [vs.run_exudyn("pullout_cylinder", *m) for m in vs.QUICK["pullout_cylinder"]["exudyn"]]
    for r in runs_f + runs_x:
        assert r["converged"]
        assert 0 < r["error"] < 0.1 and r["cpu_s"] > 0 and r["iterations"] > 0
    assert runs_f[0]["factorizations"] >= 1
    assert len(vs.time_to_accuracy(runs_f, runs_x)) == 1


def test_repeated_runs_keep_the_least_cpu_time():
    times = iter([3.0, 1.5, 2.0])
    best = vs.least_cpu(lambda: dict(cpu_s=next(times)), 3)
    assert best["cpu_s"] == 1.5
    assert vs.least_cpu(lambda: dict(cpu_s=7.0), 0)["cpu_s"] == 7.0    # at least one run
