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
