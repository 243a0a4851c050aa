"""`flexbody run` and its output files under stress (issue 14, "lost or corrupt output"): a full disk, a
second run on the same file, outputs naming inputs or devices, SIGTERM/SIGINT in the middle of a run, and
the last state of a dynamic run with output_every > 1 that stops early."""

import json
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from flexbody.cli import main
from flexbody.outputs.hdf5 import read_hdf5
from tests.test_cli import REPO, read_rrd, run_cli

#: a small dynamic scene that runs long enough to be stopped (2 elements, 1e6 steps)
ENDLESS = ["spinning_plate", "--set", "nx=1", "--set", "ny=1", "--set", "dt=1e-3", "--set", "end_time=1000"]


def start_cli(args: list[str], cwd: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    return subprocess.Popen([sys.executable, "-m", "flexbody.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=cwd, env=env)


def wait_for_steps(proc: subprocess.Popen, path: Path, steps: int, timeout: float = 300.0) -> None:
    """Wait until the HDF5 file being written by ``proc`` holds ``steps`` steps."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert proc.poll() is None, proc.communicate()
        try:
            if len(read_hdf5(path)["step"]) >= steps:
                return
        except (OSError, KeyError, ValueError):
            pass
        time.sleep(0.2)
    proc.kill()
    pytest.fail(f"{path} did not reach {steps} steps")


# ----------------------------------------------------------------------------------------------------------
# a full disk
# ----------------------------------------------------------------------------------------------------------

def test_disk_full_during_h5_stops_the_run_with_one_line(small_disk):
    """Before: a segfault (exit 139/135) and a file read_hdf5 could not open (zero quaternions)."""
    out = run_cli(["run", "cantilever_end_shear", "--set", "nx=16", "--set", "steps=400", "--quiet",
                   "--h5", str(small_disk / "run.h5")], small_disk.parent)
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr
    d = read_hdf5(small_disk / "run.h5")
    n = len(d["step"])
    assert 3 < n < 400 and d["step"].tolist() == list(range(1, n + 1))
    assert lines[0].startswith(f"flexbody: the run stopped: disk full after {n} steps: HDF5 output "
                               f"{str(small_disk / 'run.h5')!r}")
    assert lines[0].endswith(f"; {n} step(s) written to {small_disk / 'run.h5'}")
    assert np.all(np.isfinite(d["x"])) and np.all(np.abs(np.linalg.norm(d["quaternions"], axis=-1) - 1) < 1e-12)


def test_disk_full_during_rerun_drops_the_recording_and_the_run_goes_on(small_disk, tmp_path):
    """Before: a traceback, the run aborted, and an unreadable recording."""
    pytest.importorskip("rerun")
    h5, rrd, js = tmp_path / "run.h5", small_disk / "run.rrd", tmp_path / "run.json"
    out = run_cli(["run", "cantilever_end_shear", "--set", "nx=16", "--set", "steps=400", "--quiet",
                   "--h5", str(h5), "--rerun", str(rrd), "--json", str(js)], tmp_path)
    assert out.returncode == 0, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"flexbody: warning: rerun recording {str(rrd)!r} stopped after ")
    assert "disk full after" in lines[0] and lines[0].endswith("the run goes on")
    n = int(lines[0].split("stopped after ")[1].split()[0])
    assert 3 < n < 400
    assert read_rrd(rrd)["/body/mesh"] == {"static": 1, "steps": n}
    assert len(read_hdf5(h5)["step"]) == json.loads(js.read_text())["steps"] == 400


# ----------------------------------------------------------------------------------------------------------
# one writer per file
# ----------------------------------------------------------------------------------------------------------

def test_a_second_run_on_the_same_h5_is_refused(tmp_path):
    """Before: both runs exited 0 and the file was a mixture of the two."""
    h5 = tmp_path / "shared.h5"
    first = start_cli(["run", *ENDLESS, "--quiet", "--h5", str(h5)], tmp_path)
    try:
        wait_for_steps(first, h5, 3)
        with pytest.raises(SystemExit) as exc:
            main(["run", "cantilever_end_shear", "--set", "nx=2", "--set", "steps=2", "--quiet", "--h5", str(h5)])
        message = str(exc.value)
        assert message.startswith(f"flexbody: HDF5 output {str(h5)!r} is in use by process {first.pid}")
        assert "\n" not in message
        first.send_signal(signal.SIGTERM)
        first.communicate(timeout=60)
    finally:
        first.kill()
    d = read_hdf5(h5)
    assert d["scene"] == "spinning_plate" and d["step"][0] == 0 and len(d["step"]) >= 3


# ----------------------------------------------------------------------------------------------------------
# outputs that name inputs or devices
# ----------------------------------------------------------------------------------------------------------

@pytest.fixture
def toml_scene(tmp_path):
    for name in ("cantilever_end_shear.toml", "cantilever_end_shear_reference.csv"):
        shutil.copy(REPO / "examples" / name, tmp_path / name)
    return tmp_path / "cantilever_end_shear.toml"


@pytest.mark.parametrize("option, target, what", [
    ("--h5", "cantilever_end_shear.toml", "scene file"),
    ("--json", "cantilever_end_shear_reference.csv", "reference file"),
    ("--rerun", "link.toml", "scene file"),                    # a symbolic link to the scene file
    ("--json", "./sub/../cantilever_end_shear.toml", "scene file"),
])
def test_an_output_naming_an_input_is_refused(toml_scene, monkeypatch, option, target, what):
    """Before: the scene or reference file was overwritten silently."""
    folder = toml_scene.parent
    monkeypatch.chdir(folder)
    (folder / "sub").mkdir()
    (folder / "link.toml").symlink_to(toml_scene)
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    with pytest.raises(SystemExit) as exc:
        main(["run", str(toml_scene), "--set", "nx=2", "--set", "steps=2", "--quiet", option, target])
    message = str(exc.value)
    assert message.startswith(f"flexbody: {option} {target!r} is the {what} ") and "\n" not in message
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before


def test_an_output_naming_the_python_scene_file_is_refused(tmp_path):
    scene = tmp_path / "plate.py"
    scene.write_text((REPO / "examples" / "clamped_plate_scene.py").read_text())
    text = scene.read_text()
    with pytest.raises(SystemExit) as exc:
        main(["run", str(scene), "--set", "n=2", "--set", "steps=2", "--quiet", "--h5", str(scene)])
    assert f"--h5 {str(scene)!r} is the scene file" in str(exc.value)
    assert scene.read_text() == text


def test_an_output_naming_the_mesh_file_of_a_toml_scene_is_refused(tmp_path, monkeypatch):
    pytest.importorskip("meshio")
    from flexbody.mesh import generators
    from flexbody.mesh.io import write_mesh
    from tests.scenes.test_toml_scene import PLATE
    monkeypatch.chdir(tmp_path)
    write_mesh(generators.strip(2.0, 1.0, 2, 1), tmp_path / "strip.vtu")
    (tmp_path / "plate.toml").write_text(
        PLATE.replace('generator = "strip"\nlength = 2.0\nwidth = 1.0\nnx = 2\nny = 2', 'file = "strip.vtu"')
        .replace('set = "clamped"', 'plane = { point = [0, 0, 0], normal = [1, 0, 0] }'))
    mesh = (tmp_path / "strip.vtu").read_bytes()
    with pytest.raises(SystemExit) as exc:
        main(["run", "plate.toml", "--quiet", "--h5", "strip.vtu"])
    assert str(exc.value).startswith("flexbody: --h5 'strip.vtu' is the mesh file ")
    assert (tmp_path / "strip.vtu").read_bytes() == mesh


@pytest.mark.parametrize("option", ["--h5", "--rerun"])
def test_an_output_that_is_not_a_regular_file_is_refused(option):
    """Before: --h5 /dev/null ended in a traceback from h5py."""
    with pytest.raises(SystemExit) as exc:
        main(["run", "cantilever_end_shear", "--set", "nx=2", "--set", "steps=2", option, os.devnull])
    assert str(exc.value) == f"flexbody: cannot write {option} file {os.devnull!r}: it is not a regular file"


# ----------------------------------------------------------------------------------------------------------
# SIGTERM and SIGINT in the middle of a run
# ----------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("signum, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_stops_the_run_cleanly_and_both_files_agree(tmp_path, signum, code):
    """Before: SIGTERM killed the run at once (exit -15), possibly inside a step write."""
    pytest.importorskip("rerun")
    h5, rrd = tmp_path / "s.h5", tmp_path / "s.rrd"
    proc = start_cli(["run", *ENDLESS, "--quiet", "--h5", str(h5), "--rerun", str(rrd)], tmp_path)
    try:
        wait_for_steps(proc, h5, 5)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == code, err
    d = read_hdf5(h5)
    n = len(d["step"])
    assert err == (f"flexbody: stopped by {signal.Signals(signum).name}; {n} step(s) written to {h5}, {rrd}\n")
    assert d["step"].tolist() == list(range(n))
    chunks = read_rrd(rrd)
    assert chunks["/body/mesh"]["steps"] == n and chunks["/outputs/u_r_corner"]["steps"] == n


def test_a_signal_between_output_steps_still_writes_the_last_converged_state(tmp_path):
    """output_every beyond the run: only step 0 is on the output grid. Before: a stopped run kept step 0 only."""
    h5 = tmp_path / "every.h5"
    proc = start_cli(["run", *ENDLESS, "--set", "output_every=10000000", "--quiet", "--h5", str(h5)], tmp_path)
    try:
        wait_for_steps(proc, h5, 1)
        time.sleep(3.0)  # some steps, none of them on the output grid
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 143, err
    d = read_hdf5(h5)
    assert len(d["step"]) == 2 and d["step"][0] == 0 and d["step"][1] > 0
    assert d["time"][1] == pytest.approx(1e-3 * d["step"][1], rel=1e-9)
    assert err == f"flexbody: stopped by SIGTERM; 2 step(s) written to {h5}\n"


# ----------------------------------------------------------------------------------------------------------
# a dynamic run with output_every > 1 that stops early
# ----------------------------------------------------------------------------------------------------------

STOPS_LATE = '''
from dataclasses import replace
import numpy as np
from flexbody.assembly import Model
from flexbody.scenes.builtin import spinning_plate


class FailsLate(Model):
    """The residual turns non-finite after t = 0.0105 (the load factor is the time), as a diverging run's."""
    def residual(self, state, lam):
        r = super().residual(state, lam)
        return r * np.nan if lam > 0.0105 else r

    def residual_and_tangent(self, state, lam, **options):
        r, K = super().residual_and_tangent(state, lam, **options)
        return (r * np.nan if lam > 0.0105 else r), K


def build(output_every: int = 3, end_time: float = 0.02):
    scene = spinning_plate(nx=1, ny=1, dt=0.002, end_time=end_time, output_every=output_every)
    m = scene.model
    scene.model = FailsLate(m.body, m.constraints, m.loads)
    scene.analysis = replace(scene.analysis, load_factor=lambda t: t)
    return scene
'''


def test_a_dynamic_run_that_stops_between_output_steps_writes_its_last_state(tmp_path, capsys):
    """Steps 1-5 converge, step 6 fails; output_every = 3. Before: the files ended at step 3 (t = 0.006) while
    the summary said step 3 and time 0.01 with the outputs and energies of t = 0.006."""
    scene = tmp_path / "late.py"
    scene.write_text(STOPS_LATE)
    h5, js = tmp_path / "late.h5", tmp_path / "late.json"
    assert main(["run", str(scene), "--quiet", "--h5", str(h5), "--json", str(js)]) == 2
    d, summary = read_hdf5(h5), json.loads(js.read_text())
    assert d["step"].tolist() == [0, 3, 5]
    np.testing.assert_allclose(d["time"], [0.0, 0.006, 0.01], rtol=1e-12)
    assert summary["steps"] == 5 and summary["time"] == pytest.approx(0.01, rel=1e-12)
    assert summary["converged"] is False and "step 6" in summary["message"]
    for name, value in summary["outputs"].items():
        assert value == pytest.approx(d["tracked"][name][-1], rel=1e-12)
    assert summary["energy"]["total"]["final"] == pytest.approx(d["stats"]["total_energy"][-1], rel=1e-12)
    assert summary["energy_history"]["time"][-1] == pytest.approx(0.01, rel=1e-12)


def test_a_completed_dynamic_run_ends_on_its_last_step_off_the_output_grid(tmp_path):
    """5 steps, output_every = 4: the files hold 0, 4 and the last step 5 (off the output grid)."""
    scene = tmp_path / "late.py"
    scene.write_text(STOPS_LATE)
    h5, js = tmp_path / "done.h5", tmp_path / "done.json"
    assert main(["run", str(scene), "--quiet", "--set", "output_every=4", "--set", "end_time=0.01",
                 "--h5", str(h5), "--json", str(js)]) == 0
    assert read_hdf5(h5)["step"].tolist() == [0, 4, 5]
    assert json.loads(js.read_text())["steps"] == 5
