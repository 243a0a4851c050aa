"""The first run is not silent: the kernels' compilation is announced on stderr as it happens, and a run
reports its set-up, compilation and solve times separately (issue #14, first contact)."""

from __future__ import annotations

import json
import time
from types import SimpleNamespace

import numba
import pytest

from flexbody.cli import main
from flexbody.cli.progress import Progress
from flexbody.scenes.scene import CompileNotice, warm_up_kernels

STATIC = ["cantilever_end_shear", "--set", "nx=2", "--set", "steps=3"]
DYNAMIC = ["spinning_plate", "--set", "nx=1", "--set", "ny=1", "--set", "end_time=0.004"]


class _FakeModel:
    """A model whose warm-up runs ``work``."""

    def __init__(self, work):
        self.warm_up = work


def test_warm_up_announces_a_compilation_as_it_starts():
    @numba.njit(cache=False)
    def fresh(x):                          # a new function: numba must compile it
        return x + 1.0

    seen = []

    def work():
        assert not seen, "nothing may be announced before numba starts compiling"
        fresh(1.0)
        assert [n.stage for n in seen] == ["compiling"], "announced while compiling, not after"

    seconds = warm_up_kernels(_FakeModel(work), seen.append)
    assert [n.stage for n in seen] == ["compiling", "compiled"]
    assert seen[-1].seconds == seconds > 0 and seen[-1].done and not seen[0].done
    assert "compiling the element kernels (first run only" in str(seen[0])
    assert f"{seconds:.1f} s" in str(seen[-1])


def test_warm_up_of_ready_kernels_says_they_were_loaded():
    seen = []
    warm_up_kernels(_FakeModel(lambda: None), seen.append)
    assert [n.stage for n in seen] == ["loaded"] and "loaded the compiled element kernels" in str(seen[0])
    assert warm_up_kernels(_FakeModel(lambda: None)) >= 0     # notify is optional


def test_progress_clock_starts_when_the_kernels_are_ready(capsys):
    progress = Progress()
    progress.t0 -= 100.0                   # as if compiling had taken 100 s
    progress.notify(CompileNotice("compiling"))
    progress(SimpleNamespace(step=1, load_factor=0.5, iterations=3))
    before = float(capsys.readouterr().err.splitlines()[-1].split()[-2])
    progress.notify(CompileNotice("compiled", 100.0))
    progress(SimpleNamespace(step=1, load_factor=0.5, iterations=3))
    after = float(capsys.readouterr().err.splitlines()[-1].split()[-2])
    assert before >= 100.0 and after < 1.0


@pytest.mark.parametrize("scene", [STATIC, DYNAMIC], ids=["static", "dynamic"])
def test_run_reports_setup_compile_and_solve_times(tmp_path, capsys, terminal_stderr, scene):
    path = tmp_path / "run.json"
    t0 = time.perf_counter()
    assert main(["run", *scene, "--json", str(path)]) == 0
    wall = time.perf_counter() - t0
    d = json.loads(path.read_text())
    parts = [d["setup_time_s"], d["compile_time_s"], d["solve_time_s"]]
    assert all(p > 0 for p in parts) and sum(parts) <= wall
    assert d["solve_time_s"] == d["wall_time_s"]
    captured = capsys.readouterr()
    err = captured.err.splitlines()
    notices = [k for k, line in enumerate(err) if "element kernels" in line]
    steps = [k for k, line in enumerate(err) if line.lstrip().startswith("step")]
    assert notices and steps and max(notices) < min(steps), captured.err
    assert "compiled the element kernels" in err[notices[-1]] or "loaded the compiled" in err[notices[-1]]
    timing = next(line for line in captured.out.splitlines() if line.startswith("wall time"))
    assert "solve" in timing and "set-up" in timing and "compilation" in timing


def test_quiet_silences_the_compilation_notices(capsys):
    assert main(["run", *STATIC, "--quiet"]) == 0
    assert capsys.readouterr().err == ""
