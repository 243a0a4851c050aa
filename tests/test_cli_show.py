"""flexbody show, --version, --json - (JSON alone on standard output) and the k/N progress lines."""

import json
import os
import pty
import subprocess
import sys
from pathlib import Path

import pytest

from flexbody import __version__
from flexbody.cli import main

SMALL = ["--set", "nx=4", "--set", "ny=1", "--set", "steps=2"]


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"flexbody {__version__}"


def test_show_names_the_parameters_with_defaults_units_and_the_reference(capsys):
    assert main(["show", "hemisphere"]) == 0
    out = capsys.readouterr().out
    assert "Sze 3.4" in out and "1681 nodes, 800 elements" in out
    thickness = next(line for line in out.splitlines() if line.split()[:1] == ["thickness"])
    assert thickness.split()[1:] == ["0.04", "length"]
    assert next(line for line in out.splitlines() if line.startswith("reference")).split()[1] == "Sze"


def test_show_of_a_bad_scene_is_one_line():
    with pytest.raises(SystemExit, match="unknown scene 'nope'"):
        main(["show", "nope"])


def test_json_dash_writes_only_json_to_stdout(capsys):
    assert main(["run", "cantilever_end_shear", *SMALL, "--json", "-"]) == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["scene"] == "cantilever_end_shear" and data["steps"] == 2
    assert "scene            cantilever_end_shear" in captured.err      # the summary went to stderr


def test_progress_shows_how_far_and_the_time_left(capsys, terminal_stderr):
    """Per cent of the last load factor (not k/N: cut-backs add steps) and the time left."""
    assert main(["run", "cantilever_end_shear", *SMALL]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines() if "load factor" in line and "step" in line]
    assert [line.split()[1] for line in lines] == ["1", "2"] and all("left ~" in line for line in lines)
    assert [line.split("%")[0].split()[-1] for line in lines] == ["50.0", "100.0"]


def _step_lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.strip().startswith("step") and "left ~" in line]


def test_progress_is_silent_when_stderr_is_not_a_terminal(capsys):
    """Captured (a file, a pipe, a CI log): no step lines; the summary and the rest are unchanged."""
    assert main(["run", "cantilever_end_shear", *SMALL]) == 0
    captured = capsys.readouterr()
    assert _step_lines(captured.err) == [] and "load factor reached 1" in captured.out


def _run_with_stderr(stderr, *extra) -> subprocess.CompletedProcess:
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(repo), os.environ.get("PYTHONPATH")])),
               NUMBA_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-m", "flexbody.cli", "run", "cantilever_end_shear", *SMALL, *extra],
                          stdout=subprocess.PIPE, stderr=stderr, text=True, timeout=300, env=env)


def _read_all(fd: int) -> str:
    chunks = []
    while True:
        try:
            data = os.read(fd, 65536)
        except OSError:                 # EIO: the terminal's other side is closed
            break
        if not data:
            break
        chunks.append(data)
    return b"".join(chunks).decode(errors="replace")


@pytest.mark.parametrize("quiet", [False, True], ids=["progress", "quiet"])
def test_progress_on_a_pseudo_terminal_and_not_on_a_pipe(quiet):
    """The command itself, its stderr a pseudo-terminal: a step line per step (none with --quiet); the same
    command with stderr a pipe: none."""
    extra = ("--quiet",) if quiet else ()
    master, slave = pty.openpty()
    try:
        out = _run_with_stderr(slave, *extra)
        os.close(slave)
        slave = -1
        on_terminal = _read_all(master)
    finally:
        if slave >= 0:
            os.close(slave)
        os.close(master)
    assert out.returncode == 0, on_terminal
    lines = _step_lines(on_terminal)
    assert [line.split()[1] for line in lines] == ([] if quiet else ["1", "2"])
    piped = _run_with_stderr(subprocess.PIPE, *extra)
    assert piped.returncode == 0 and _step_lines(piped.stderr) == []


def test_progress_of_a_dynamic_run_counts_time(capsys, terminal_stderr):
    assert main(["run", "spinning_plate", "--set", "end_time=0.004", "--quiet"]) in (0, 3)
    assert "left ~" not in capsys.readouterr().err                      # --quiet: no progress
    assert main(["run", "spinning_plate", "--set", "end_time=0.004"]) in (0, 3)
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip().startswith("step")]
    assert lines and lines[-1].split("%")[0].split()[-1] == "100.0"
