"""The bench report: the table's rows, the plots, strict JSON, and a report without matplotlib."""

import json
import math

import pytest

from flexbody.outputs import report
from flexbody.outputs.report import BenchRun, markdown_table, mesh_label, plot_error_vs_time, write_report


def run(label, dofs, wall, error, converged=True, scene="s"):
    summary = {"dofs": dofs, "steps": 2, "wall_time_s": wall, "max_rel_error": error, "newton_iterations": 9,
               "tangent_updates": 10, "factorizations": 8, "converged": converged,
               "message": "completed" if converged else "step to load factor 0.75 failed | diverging"}
    history = {"load_factor": [0.5, 1.0], "W": [0.1, 0.25]}
    return BenchRun(scene, label, {"nx": dofs // 10}, summary, history, {"W": ([0.5, 1.0], [0.11, 0.24])})


def test_mesh_label_uses_the_density_keys():
    assert mesh_label({"mesh.nx": 4, "mesh.ny": 2, "steps": 3}, ["mesh.nx", "mesh.ny"]) == "nx=4, ny=2"
    assert mesh_label({}, []) == "default"


def test_table_rows_for_converged_failed_and_unbuilt_runs():
    rows = [run("nx=2", 20, 0.1234, 1.5e-2), run("nx=4", 40, 0.5, 3e-3, converged=False),
            BenchRun("s", "nx=8", {"nx": 8}, failure="cannot build scene 's': nx too big")]
    lines = markdown_table(rows).splitlines()
    assert lines[0].startswith("| mesh | DoFs | steps | wall time [s] | max rel. error | Newton iterations |")
    assert lines[2] == "| nx=2 | 20 | 2 | 0.123 | 1.50e-02 | 9 | 10 | 8 | yes |"
    assert lines[3].endswith("| no: step to load factor 0.75 failed / diverging |")  # '|' kept out of the cell
    assert lines[4] == "| nx=8 | - | - | - | - | - | - | - | failed: cannot build scene 's': nx too big |"


def test_no_error_plot_without_a_reference(tmp_path):
    pytest.importorskip("matplotlib")
    rows = [run("nx=2", 20, 0.1, math.nan)]
    assert not plot_error_vs_time(rows, str(tmp_path / "e.png")) and not (tmp_path / "e.png").exists()
    assert plot_error_vs_time([run("nx=2", 20, 0.1, 1e-2)], str(tmp_path / "e.png"))
    assert (tmp_path / "e.png").read_bytes()[:4] == b"\x89PNG"


def test_report_without_matplotlib_keeps_the_tables(tmp_path, monkeypatch):
    monkeypatch.setattr(report, "_pyplot", lambda: None)
    rows = [run("nx=2", 20, 0.1, 1e-2), run("nx=4", 40, 0.2, math.nan, scene="t")]
    path = write_report(rows, str(tmp_path / "out"), "flexbody bench s t")
    text = open(path).read()
    assert "Plots skipped: matplotlib is not installed" in text and "## s" in text and "## t" in text
    assert "`flexbody bench s t`" in text
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["bench.json", "report.md"]
    data = json.loads((tmp_path / "out" / "bench.json").read_text())  # strict JSON: NaN became null
    assert data[1]["summary"]["max_rel_error"] is None and data[0]["history"]["W"] == [0.1, 0.25]
