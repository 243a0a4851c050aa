"""What the commands of ``flexbody`` share: output files and their JSON, ``--json -``, the stop signals, the
progress lines, the bench's status line, the units of ``flexbody show``, the package's entry points."""

from __future__ import annotations

import io
import json
import math
import signal
import subprocess
import sys
from types import SimpleNamespace

import pytest

from flexbody.cli.bench import run_status
from flexbody.cli.errors import CliError, run_failure
from flexbody.cli.json_stdout import RenamedStream
from flexbody.cli.outputs import prepare_out_dir, print_written, strict_json, write_json
from flexbody.cli.progress import Progress, progress_goal
from flexbody.cli.show import parameter_unit
from flexbody.cli.stop_signals import StopSignals, Stopped


def test_strict_json_writes_non_finite_numbers_as_null(tmp_path):
    data = {"a": math.nan, "b": [1.0, math.inf, (2, -math.inf)], "c": {"d": "text", "e": 3}}
    assert strict_json(data) == {"a": None, "b": [1.0, None, [2, None]], "c": {"d": "text", "e": 3}}
    path = tmp_path / "out.json"
    write_json(str(path), data)
    assert json.loads(path.read_text()) == strict_json(data)
    with pytest.raises(CliError, match="cannot write --json file"):
        write_json(str(tmp_path / "missing" / "out.json"), data)


def test_the_written_line_is_aligned_with_the_summary(capsys):
    print_written("a.h5")
    print_written("b.json", file=sys.stderr)
    out, err = capsys.readouterr()
    assert out == "written          a.h5\n" and err == "written          b.json\n"


def test_the_out_directory_is_made_and_a_file_in_its_place_is_refused(tmp_path):
    prepare_out_dir(str(tmp_path / "a" / "b"))
    assert (tmp_path / "a" / "b").is_dir()
    (tmp_path / "file").write_text("")
    with pytest.raises(CliError, match="cannot create --out directory"):
        prepare_out_dir(str(tmp_path / "file"))


def test_the_temporary_json_file_is_named_standard_output():
    stream = io.StringIO()
    renamed = RenamedStream(stream, "/tmp/flexbody-x.json", "standard output")
    assert renamed.write("written          /tmp/flexbody-x.json\n") == len("written          /tmp/flexbody-x.json\n")
    assert stream.getvalue() == "written          standard output\n"
    assert renamed.getvalue() == stream.getvalue()       # everything else is the stream's


def test_a_signal_inside_deferred_stops_after_the_block():
    signals = StopSignals()
    finished = []
    with pytest.raises(Stopped) as stopped:
        with signals.deferred():
            signals.handle(signal.SIGTERM, None)
            finished.append(True)
    assert finished == [True] and stopped.value.signum == signal.SIGTERM
    with pytest.raises(Stopped):
        StopSignals().handle(signal.SIGINT, None)


def test_run_failure_is_one_line():
    assert run_failure(ValueError("first\nsecond")) == "ValueError: first"
    assert run_failure(ArithmeticError()) == "ArithmeticError"


def test_the_bench_status_of_a_run():
    assert run_status(60, 1.234, 0.0125, True) == "60 DoFs, 1.23 s, max rel. error 1.25e-02"
    assert run_status(60, 1.0, math.nan, False) == "60 DoFs, 1.00 s, no reference, NOT CONVERGED"


@pytest.mark.parametrize("key, unit", [("thickness", "length"), ("material.young", "force/length^2"),
                                       ("dt", "s"), ("nx", ""), ("n_radial", "elements"), ("n", "elements"),
                                       ("kernel", "")])
def test_parameter_units_by_their_last_key(key, unit):
    assert parameter_unit(key) == unit


def test_progress_goal_and_lines(capsys):
    static = SimpleNamespace(kind="static", analysis=SimpleNamespace(method="load_control", load_factors=[0.5, 2.0]))
    arc = SimpleNamespace(kind="static", analysis=SimpleNamespace(method="arc_length", load_factors=[1.0]))
    dynamic = SimpleNamespace(kind="dynamic", analysis=SimpleNamespace(end_time=0.25))
    assert (progress_goal(static), progress_goal(arc), progress_goal(dynamic)) == (2.0, None, 0.25)
    Progress(prefix="  [x]", goal=2.0)(SimpleNamespace(step=3, load_factor=1.0, iterations=4))
    Progress(steps=False)(SimpleNamespace(step=3, load_factor=1.0, iterations=4))
    line = capsys.readouterr().err
    assert line.startswith("  [x]  step    3  load factor   1.0000  iterations  4   50.0 %  left ~")
    assert line.count("\n") == 1


def test_python_m_flexbody_cli_is_the_command():
    done = subprocess.run([sys.executable, "-m", "flexbody.cli", "list"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0 and done.stdout.startswith("cantilever_end_moment")
    from flexbody.cli import main
    from flexbody.scenes.registry import SCENES
    assert len(done.stdout.splitlines()) == len(SCENES)
    assert main.__module__ == "flexbody.cli"


def test_bad_input_ends_with_one_line_and_exit_code_1():
    done = subprocess.run([sys.executable, "-m", "flexbody.cli", "run", "--set", "nx"], capture_output=True,
                          text=True, timeout=120)
    assert (done.returncode, done.stdout, done.stderr) == (1, "", "flexbody: --set expects KEY=VALUE, got 'nx'\n")
