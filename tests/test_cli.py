"""The flexbody command: list, run with --set/--json, user scene files, one-line errors on bad input."""

import json
import subprocess
import sys

import pytest

from flexbody.cli import main


def test_list_names_every_builtin_scene(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("cantilever_end_moment", "cantilever_end_shear", "slit_annular_plate", "pullout_cylinder",
                 "hemisphere"):
        assert name in out


def test_run_writes_the_json_summary(tmp_path, capsys):
    path = tmp_path / "run.json"
    code = main(["run", "cantilever_end_shear", "--set", "nx=4", "--set", "steps=4", "--json", str(path), "--quiet"])
    assert code == 0
    d = json.loads(path.read_text())
    for key in ("scene", "dofs", "elements", "steps", "newton_iterations", "tangent_updates", "factorizations",
                "wall_time_s", "outputs", "errors", "max_rel_error"):
        assert key in d
    assert d["steps"] == 4 and d["elements"] == 8
    assert {"quantity", "load_factor", "value", "reference", "rel_error"} <= set(d["errors"][0])
    out = capsys.readouterr().out
    assert "tangent updates" in out and "max rel. error" in out


@pytest.mark.parametrize("args, message", [
    (["run", "no_such_scene"], "unknown scene 'no_such_scene'"),
    (["run", "cantilever_end_shear", "--set", "colour=red"], "unknown parameter(s) ['colour']"),
    (["run", "cantilever_end_shear", "--set", "thickness=-1"], "thickness must be > 0, got -1"),
    (["run", "cantilever_end_shear", "--set", "nx"], "--set expects KEY=VALUE"),
    (["run", "missing_file.py"], "scene file 'missing_file.py' does not exist"),
])
def test_bad_input_is_one_clear_line(args, message):
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert message in str(exc.value)
    assert "\n" not in str(exc.value)


def test_user_scene_file_runs(tmp_path):
    scene = tmp_path / "plate.py"
    scene.write_text(open("examples/clamped_plate_scene.py").read())
    code = main(["run", str(scene), "--set", "n=2", "--set", "steps=2", "--quiet"])
    assert code == 0


def test_console_script_is_installed():
    out = subprocess.run([sys.executable, "-m", "flexbody.cli", "list"], capture_output=True, text=True)
    assert out.returncode == 0 and "hemisphere" in out.stdout


# ----------------------------------------------------------------------------------------------------------
# run --h5 / --rerun / --json, progress, failures
# ----------------------------------------------------------------------------------------------------------

import os
from pathlib import Path
import textwrap
import types

import h5py
import numpy as np

from flexbody.outputs.hdf5 import read_hdf5

REPO = Path(__file__).resolve().parents[1]
SMALL = ["--set", "nx=2", "--set", "steps=3"]


def run_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """The command in a fresh interpreter (imports flexbody from this checkout)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-m", "flexbody.cli", *args], capture_output=True, text=True,
                          timeout=180, cwd=cwd, env=env)


def read_rrd(path) -> dict:
    """{entity path: {"static": rows, "steps": rows}} of a recording, also one left by a killed run."""
    import warnings
    from rerun.chunk import RrdReader
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a killed run's file has no footer: rerun warns, then scans it
        store = RrdReader(str(path)).stream().collect()
    out: dict = {}
    for chunk in store.stream():
        entry = out.setdefault(chunk.entity_path, {"static": 0, "steps": 0})
        entry["static" if chunk.is_static else "steps"] += chunk.num_rows
    return out


def test_run_writes_hdf5_rerun_and_json_that_agree(tmp_path, capsys):
    pytest.importorskip("rerun")
    h5, rrd, js = tmp_path / "run.h5", tmp_path / "run.rrd", tmp_path / "run.json"
    code = main(["run", "cantilever_end_shear", *SMALL, "--h5", str(h5), "--rerun", str(rrd), "--json", str(js),
                 "--quiet"])
    assert code == 0
    summary = json.loads(js.read_text())
    d = read_hdf5(h5)
    assert d["scene"] == "cantilever_end_shear" and d["parameters"]["nx"] == 2
    assert len(d["step"]) == summary["steps"] == 3
    np.testing.assert_allclose(d["load_factor"][-1], 1.0)
    for name, value in summary["outputs"].items():
        assert d["tracked"][name][-1] == pytest.approx(value, rel=1e-12)
    assert d["stats"]["iterations"].sum() == summary["newton_iterations"]
    chunks = read_rrd(rrd)
    assert chunks["/body/mesh"] == {"static": 1, "steps": 3}
    assert chunks["/outputs/W_tip"]["steps"] == 3
    assert chunks["/reference/W_tip"]["steps"] == 21  # the reference curve on the load_factor timeline
    out = capsys.readouterr().out
    assert f"written          {h5}" in out and f"written          {rrd}" in out


def test_a_run_without_rerun_never_imports_it(tmp_path):
    code = textwrap.dedent(f"""
        import sys
        from flexbody.cli import main
        assert main(["run", "cantilever_end_shear", "--set", "nx=2", "--set", "steps=2", "--quiet",
                     "--h5", {str(tmp_path / "a.h5")!r}, "--json", {str(tmp_path / "a.json")!r}]) == 0
        assert "rerun" not in sys.modules, sorted(m for m in sys.modules if "rerun" in m)
    """)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=180, env=env)
    assert out.returncode == 0, out.stderr
    assert read_hdf5(tmp_path / "a.h5")["step"].tolist() == [1, 2]


def test_progress_goes_to_stderr_and_quiet_silences_it(capsys, terminal_stderr):
    assert main(["run", "cantilever_end_shear", *SMALL]) == 0
    captured = capsys.readouterr()
    progress = [line for line in captured.err.splitlines() if "load factor" in line]
    assert len(progress) == 3 and "iterations" in progress[0] and "step" not in captured.out.split("\n")[0]
    assert main(["run", "cantilever_end_shear", *SMALL, "--quiet"]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("option, path, message", [
    ("--h5", "no/such/dir/run.h5", "cannot write --h5 file 'no/such/dir/run.h5': directory"),
    ("--rerun", ".", "cannot write --rerun file '.': it is a directory"),
    ("--json", "missing_dir/run.json", "cannot write --json file 'missing_dir/run.json'"),
])
def test_bad_output_path_is_one_line_before_the_run(tmp_path, monkeypatch, option, path, message):
    monkeypatch.chdir(tmp_path)
    import flexbody.scenes.runner as runner_module
    monkeypatch.setattr(runner_module, "run_scene", lambda *a, **k: pytest.fail("the run started"))
    with pytest.raises(SystemExit) as exc:
        main(["run", "cantilever_end_shear", *SMALL, option, path])
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_two_outputs_naming_one_file_is_an_error(tmp_path):
    with pytest.raises(SystemExit) as exc:
        main(["run", "cantilever_end_shear", "--h5", str(tmp_path / "x"), "--json", str(tmp_path / "x")])
    assert "--json and --h5 name the same file" in str(exc.value)


# Scene files that fail in the middle of a run, in three ways. Each tracks the steps it has seen.
FAILING_SCENE = '''
import os
from dataclasses import dataclass
import numpy as np
from flexbody.assembly import Model
from flexbody.scenes.builtin import cantilever_end_shear
from flexbody.scenes.scene import Output

SEEN = []


class BlowsUp(Model):
    """The residual turns non-finite beyond load factor 0.5, as a diverging simulation's does."""
    def residual(self, state, lam):
        r = super().residual(state, lam)
        return r * np.nan if lam > 0.5 else r

    def residual_and_tangent(self, state, lam):
        r, K = super().residual_and_tangent(state, lam)
        return (r * np.nan if lam > 0.5 else r), K


@dataclass(frozen=True)
class FailsAtStep3(Output):
    how: str = "raise"

    def value(self, model, state):
        SEEN.append(1)
        if len(SEEN) == 3:
            if self.how == "kill":
                os._exit(3)  # no cleanup at all, as after a kill -9 or a segfault
            if self.how == "interrupt":
                raise KeyboardInterrupt  # Ctrl-C
            raise FloatingPointError("overflow in a user output")
        return super().value(model, state)


def build(how: str = "diverge", nx: int = 2, steps: int = 4):
    scene = cantilever_end_shear(nx=nx, steps=steps)
    if how == "diverge":
        m = scene.model
        scene.model = BlowsUp(m.body, m.constraints, m.loads)
    else:
        scene.outputs.append(FailsAtStep3("fails", scene.outputs[0].node, (1.0, 0.0, 0.0), how=how))
    return scene
'''


@pytest.fixture
def failing_scene(tmp_path):
    path = tmp_path / "failing.py"
    path.write_text(FAILING_SCENE)
    return path


def test_a_diverging_run_leaves_readable_outputs(tmp_path, failing_scene, capsys):
    pytest.importorskip("rerun")
    h5, rrd, js = tmp_path / "d.h5", tmp_path / "d.rrd", tmp_path / "d.json"
    code = main(["run", str(failing_scene), "--h5", str(h5), "--rerun", str(rrd), "--json", str(js), "--quiet"])
    assert code == 2
    assert "NOT CONVERGED" in capsys.readouterr().out
    summary = json.loads(js.read_text())
    assert summary["converged"] is False and summary["load_factor"] == 0.5 and summary["steps"] == 2
    d = read_hdf5(h5)
    assert d["load_factor"].tolist() == [0.25, 0.5]
    assert np.all(np.isfinite(d["x"]))
    assert read_rrd(rrd)["/body/mesh"] == {"static": 1, "steps": 2}


def test_an_error_inside_the_run_is_one_line_and_keeps_the_outputs(tmp_path, failing_scene, capsys):
    pytest.importorskip("rerun")
    h5, rrd = tmp_path / "e.h5", tmp_path / "e.rrd"
    code = main(["run", str(failing_scene), "--set", "how='raise'", "--h5", str(h5), "--rerun", str(rrd), "--quiet"])
    assert code == 1
    err = capsys.readouterr().err.strip()
    assert err == (f"flexbody: the analysis failed: FloatingPointError: overflow in a user output; "
                   f"2 step(s) written to {h5}, {rrd}")
    assert read_hdf5(h5)["step"].tolist() == [1, 2]
    assert read_rrd(rrd)["/body/mesh"]["steps"] == 2


def test_ctrl_c_closes_the_outputs(tmp_path, failing_scene, capsys):
    h5 = tmp_path / "i.h5"
    assert main(["run", str(failing_scene), "--set", "how=interrupt", "--h5", str(h5), "--quiet"]) == 130
    assert capsys.readouterr().err == f"flexbody: interrupted; 2 step(s) written to {h5}\n"
    with h5py.File(h5, "r") as f:  # closed normally: plain HDF5 readers open it
        assert f["steps/index"][()].tolist() == [1, 2]


def test_rerun_missing_is_reported_before_the_scene_is_built(monkeypatch, tmp_path):
    import importlib.util
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "rerun" else find_spec(name, *a))
    import flexbody.scenes.sources as sources
    monkeypatch.setattr(sources.SceneSource, "build", lambda *a: pytest.fail("the scene was built"))
    with pytest.raises(SystemExit) as exc:
        main(["run", "cantilever_end_shear", "--rerun", str(tmp_path / "r.rrd")])
    assert str(exc.value) == "flexbody: --rerun needs the rerun SDK: pip install 'flexbody[rerun]' (or rerun-sdk)"


def test_a_killed_run_leaves_readable_outputs(tmp_path, failing_scene):
    pytest.importorskip("rerun")
    out = run_cli(["run", str(failing_scene), "--set", "how=kill", "--h5", "k.h5", "--rerun", "k.rrd", "--quiet"],
                  tmp_path)
    assert out.returncode == 3, out.stderr
    assert read_hdf5(tmp_path / "k.h5")["step"].tolist() == [1, 2]
    chunks = read_rrd(tmp_path / "k.rrd")  # flushed every step: both steps are in the file
    assert chunks["/body/mesh"] == {"static": 1, "steps": 2} and chunks["/outputs/W_tip"]["steps"] == 2


# ----------------------------------------------------------------------------------------------------------
# bench
# ----------------------------------------------------------------------------------------------------------

def test_bench_writes_the_report_and_plots(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "report"
    code = main(["bench", "cantilever_end_shear", "--refine", "nx=1,2", "--set", "steps=2", "--out", str(out),
                 "--quiet"])
    assert code == 0
    text = (out / "report.md").read_text()
    rows = [line for line in text.splitlines() if line.startswith("| nx=")]
    assert len(rows) == 2
    cells = [[c.strip() for c in row.strip("|").split("|")] for row in rows]
    assert [c[0] for c in cells] == ["nx=1", "nx=2"]
    assert int(cells[0][1]) < int(cells[1][1])             # DoFs grow with the mesh
    assert all(float(c[4]) > 0 for c in cells)             # max relative error
    assert all(c[8] == "yes" for c in cells)
    for header in ("DoFs", "wall time", "max rel. error", "Newton iterations", "tangent updates", "factorizations"):
        assert header in text
    for png in ("error_vs_time.png", "load_displacement_cantilever_end_shear.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f"]({png})" in text
    data = json.loads((out / "bench.json").read_text())
    assert [r["summary"]["dofs"] for r in data] == [int(cells[0][1]), int(cells[1][1])]
    assert "written" in capsys.readouterr().out


def test_bench_rejects_unknown_keys_before_running(tmp_path):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "cantilever_end_shear", "--refine", "n_radial=1,2", "--out", str(tmp_path)])
    assert "unknown parameter(s) ['n_radial']" in str(exc.value)
    with pytest.raises(SystemExit) as exc:
        main(["bench", "cantilever_end_shear", "--refine", "nx=1,2", "--refine", "ny=1", "--out", str(tmp_path)])
    assert "--refine lists must have the same length" in str(exc.value)
    assert not (tmp_path / "report.md").exists()


def test_bench_of_a_toml_scene_refines_its_generator_counts(tmp_path):
    pytest.importorskip("matplotlib")
    scene = tmp_path / "shear.toml"
    scene.write_text((REPO / "examples" / "cantilever_end_shear.toml").read_text()
                     .replace("nx = 16", "nx = 1").replace("steps = 20", "steps = 2")
                     .replace("cantilever_end_shear_reference.csv",
                              str(REPO / "examples" / "cantilever_end_shear_reference.csv")))
    assert main(["bench", str(scene), "--out", str(tmp_path / "b"), "--quiet"]) == 0
    text = (tmp_path / "b" / "report.md").read_text()
    assert "| nx=1, ny=1 |" in text and "| nx=2, ny=2 |" in text  # the file's density, then twice it


# ----------------------------------------------------------------------------------------------------------
# compare
# ----------------------------------------------------------------------------------------------------------

def test_compare_calls_the_exudyn_adapter(monkeypatch, tmp_path):
    calls = []
    fake = types.ModuleType("flexbody.adapters.exudyn")
    fake.compare_cli = lambda scene_name, params, json_path, quiet: calls.append(
        (scene_name, params, json_path, quiet)) or 7
    monkeypatch.setitem(sys.modules, "flexbody.adapters.exudyn", fake)
    js = str(tmp_path / "c.json")
    assert main(["compare", "hemisphere", "--with", "exudyn", "--set", "n_circ=4", "--json", js, "--quiet"]) == 7
    assert calls == [("hemisphere", {"n_circ": 4}, js, True)]


def test_compare_without_the_adapter_is_one_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "flexbody.adapters.exudyn", None)  # import fails as if it were missing
    assert main(["compare", "hemisphere", "--with", "exudyn"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("flexbody: compare --with exudyn is not available") and err.count("\n") == 1


def test_toml_scene_runs_from_the_command_and_its_json_is_strict(tmp_path, capsys):
    js = tmp_path / "plate.json"
    code = main(["run", str(REPO / "examples" / "clamped_plate.toml"), "--set", "nx=2", "--set", "ny=2",
                 "--set", "steps=2", "--json", str(js), "--quiet"])
    assert code == 0
    text = js.read_text()
    assert "NaN" not in text  # no reference: max_rel_error is null, not the invalid JSON token NaN
    d = json.loads(text)
    assert d["scene"] == "clamped_plate_toml" and d["errors"] == [] and d["max_rel_error"] is None
    assert d["outputs"]["w_centre"] > 0


def test_a_bad_toml_scene_is_one_line_without_traceback(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text((REPO / "examples" / "clamped_plate.toml").read_text().replace('value = 50.0', 'value = "high"'))
    out = run_cli(["run", str(scene)], tmp_path)
    assert out.returncode == 1 and "Traceback" not in out.stderr
    assert out.stderr == f"flexbody: scene file {str(scene)!r}: load.0.value must be a finite number, got 'high'\n"
