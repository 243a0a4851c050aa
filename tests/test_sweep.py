"""Parameter sweeps on a local Dask cluster of 2 worker processes (flexbody.sweep, flexbody.cluster, the
``flexbody sweep`` command): the same numbers as the runs made one by one, a bad value or a lost worker
reported in the table while the other runs finish, dask never imported by a plain run."""

import csv
import json
import math
import os
import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("distributed")

from flexbody.cli import main
from flexbody.sweep import exit_code, grid_points, make_tasks, run_task, summary_line, write_table

pytestmark = pytest.mark.usefixtures("one_numba_thread")

SCENE = "cantilever_end_moment"
FIXED = {"steps": 3}          # a short path: 3 load steps of the strip rolled by an end moment


@pytest.fixture(scope="module")
def client():
    """One local cluster of 2 worker processes for the module (start-up costs seconds). A task whose worker
    dies is not retried on another worker (``allowed-failures`` 0), so the lost-worker test kills one."""
    import dask
    from flexbody.cluster import connect
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with connect(workers=2) as c:
            yield c


def _by_index(rows):
    return {r.index: r for r in rows}


def test_grid_points_product_and_pairs():
    assert grid_points({"a": [1, 2], "b": [3, 4, 5]}) == [
        {"a": 1, "b": 3}, {"a": 1, "b": 4}, {"a": 1, "b": 5}, {"a": 2, "b": 3}, {"a": 2, "b": 4}, {"a": 2, "b": 5}]
    assert grid_points({"a": [1, 2], "b": [3, 4]}, paired=True) == [{"a": 1, "b": 3}, {"a": 2, "b": 4}]
    with pytest.raises(ValueError, match="one length"):
        grid_points({"a": [1, 2], "b": [3]}, paired=True)
    with pytest.raises(ValueError, match="at most"):
        grid_points({k: list(range(100)) for k in "abc"})


def test_sweep_on_cluster_equals_runs_one_by_one(client, tmp_path):
    """A 2 x 2 sweep over mesh and thickness on 2 worker processes gives exactly the numbers of the same
    runs made one by one in a fresh process (``--workers 0``: in series); the table (CSV, JSON) holds them.
    (The reference is a fresh process, not this one: after the rest of the test suite, this process once gave
    48 Newton iterations where a fresh one gives 51, with the same answer to the last digit: see the note in
    docs/sweeps.md.)"""
    from flexbody.cluster import run_distributed
    tasks = make_tasks(SCENE, grid_points({"nx": [2, 4], "thickness": [0.01, 0.02]}), FIXED)
    rows = _by_index(run_distributed(client, tasks))
    assert sorted(rows) == [0, 1, 2, 3]
    serial = subprocess.run([sys.executable, "-m", "flexbody.cli", "sweep", SCENE, "--grid", "nx=2,4", "--grid",
                             "thickness=0.01,0.02", *[f"--set={k}={v}" for k, v in FIXED.items()],
                             "--workers", "0", "--out", str(tmp_path / "alone")], capture_output=True, text=True)
    assert serial.returncode == 0, serial.stderr
    alone_rows = {r["index"]: r for r in json.loads((tmp_path / "alone" / "sweep.json").read_text())["runs"]}
    outputs = set()
    for task in tasks:
        alone, swept = alone_rows[task.index], rows[task.index]
        assert swept.status == alone["status"] == "ok"
        assert swept.parameters == task.swept
        assert swept.worker.startswith("tcp://")
        for key in ("newton_iterations", "tangent_updates", "factorizations", "steps", "dofs"):
            assert getattr(swept, key) == alone[key], key
        assert swept.outputs == alone["outputs"]       # bit for bit: the same kernels on one thread
        assert swept.max_rel_error == alone["max_rel_error"]
        outputs.add(round(swept.outputs["W_tip"], 9))
    assert len(outputs) == 4                           # the parameters did reach the runs
    assert exit_code(rows.values()) == 0
    plugins = client.run(lambda dask_worker: (dask_worker.plugins["flexbody-kernels"].threads,
                                              dask_worker.plugins["flexbody-kernels"].failure))
    threads = max(1, (os.cpu_count() or 1) // 2)       # 2 workers share this host's cores (1 on 2 cores)
    assert list(plugins.values()) == [(threads, None)] * 2     # both warmed up, without error
    write_table(list(rows.values()), str(tmp_path))
    with open(tmp_path / "sweep.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [int(r["index"]) for r in table] == [0, 1, 2, 3]
    for r in table:
        assert float(r["W_tip"]) == rows[int(r["index"])].outputs["W_tip"]
        assert (int(r["nx"]), float(r["thickness"])) == (rows[int(r["index"])].parameters["nx"],
                                                         rows[int(r["index"])].parameters["thickness"])
    data = json.loads((tmp_path / "sweep.json").read_text())
    assert data["exit_code"] == 0 and data["summary"] == "4 of 4 runs converged and trusted"


def test_bad_value_is_reported_and_the_others_finish(client, tmp_path):
    """One negative thickness among three: its row says "failed" and names the value; the others are
    "ok"; the CLI (on the same cluster, --scheduler) writes the table and exits 2 with a summary line."""
    from flexbody.cluster import run_distributed
    tasks = make_tasks(SCENE, grid_points({"thickness": [0.01, -0.01, 0.02]}), {**FIXED, "nx": 2})
    rows = _by_index(run_distributed(client, tasks))
    assert [rows[i].status for i in range(3)] == ["ok", "failed", "ok"]
    assert "thickness" in rows[1].message and "-0.01" in rows[1].message
    assert math.isnan(rows[1].max_rel_error) and rows[1].outputs == {}
    assert exit_code(rows.values()) == 2
    assert summary_line(list(rows.values())) == "2 of 3 runs converged and trusted; 1 failed"

    out = tmp_path / "out"
    code = main(["sweep", SCENE, "--grid", "thickness=0.01,-0.01,0.02", "--set", "nx=2", "--set", "steps=3",
                 "--scheduler", client.scheduler.address, "--out", str(out), "--quiet", "--h5"])
    assert code == 2
    with open(out / "sweep.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [r["status"] for r in table] == ["ok", "failed", "ok"]
    assert [float(r["W_tip"] or "nan") == rows[i].outputs.get("W_tip", -1) for i, r in enumerate(table)] == \
        [True, False, True]
    assert sorted(os.listdir(out / "runs")) == ["run_0000.h5", "run_0002.h5"]
    assert (out / "vs_thickness.png").stat().st_size > 0


def test_lost_worker_is_reported_and_the_others_finish(client, tmp_path):
    """A run whose worker process dies (a scene file that exits the process) is a "lost" row; the other runs
    finish on the remaining worker."""
    scene = tmp_path / "dies.py"
    scene.write_text(textwrap.dedent(f"""
        import os
        from flexbody.scenes.builtin import cantilever_end_moment

        def build(die: int = 0, nx: int = 2, steps: int = 5):
            if die:
                os._exit(3)
            return cantilever_end_moment(nx=nx, steps=steps)
    """))
    from flexbody.cluster import run_distributed
    tasks = make_tasks(str(scene), grid_points({"die": [0, 1, 0]}))
    rows = _by_index(run_distributed(client, tasks))
    assert [rows[i].status for i in range(3)] == ["ok", "lost", "ok"]
    assert "KilledWorker" in rows[1].message
    client.wait_for_workers(2, timeout=60)             # the nanny restarts it for the next test


def test_bench_through_the_cluster_matches_the_serial_bench(client, tmp_path):
    """``flexbody bench --scheduler`` writes the report of the same runs as the serial bench."""
    args = [SCENE, "--refine", "nx=2,3", "--set", "steps=3", "--quiet"]
    assert main(["bench", *args, "--out", str(tmp_path / "serial")]) == 0
    assert main(["bench", *args, "--out", str(tmp_path / "dask"), "--scheduler", client.scheduler.address]) == 0
    serial, dask = (json.loads((tmp_path / d / "bench.json").read_text()) for d in ("serial", "dask"))
    assert [r["mesh"] for r in dask] == [r["mesh"] for r in serial] == ["nx=2", "nx=3"]
    for a, b in zip(serial, dask):
        assert a["summary"]["outputs"] == b["summary"]["outputs"]
        assert a["summary"]["factorizations"] == b["summary"]["factorizations"]
        assert a["history"] == b["history"]


def test_sweep_command_checks_its_input(tmp_path, capsys):
    """Bad grids and options stop with one line before anything runs."""
    cases = [(["--grid", "nx"], "--grid expects KEY=V1,V2"),
             (["--grid", "nx="], "--grid nx has no values"),
             (["--grid", "nx=2,4", "--grid", "ny=1", "--zip"], "one length"),
             (["--grid", "bogus=1,2"], "unknown parameter(s) ['bogus']"),
             (["--grid", "nx=2", "--workers", "-1"], "--workers must be >= 0")]
    for extra, message in cases:
        with pytest.raises(SystemExit) as exc:
            main(["sweep", SCENE, *extra, "--out", str(tmp_path)])
        assert message in str(exc.value)
    toml = os.path.join(os.path.dirname(__file__), "..", "examples", "cantilever_end_shear.toml")
    with pytest.raises(SystemExit) as exc:
        main(["sweep", toml, "--grid", "nx=2,4", "--grid", "bogus=1", "--out", str(tmp_path)])
    assert "unknown parameter 'bogus'" in str(exc.value)
    with pytest.raises(SystemExit):
        main(["sweep", SCENE, "--grid", "nx=2", "--workers", "2", "--scheduler", "tcp://localhost:1"])
    assert "not allowed with argument" in capsys.readouterr().err


def test_in_process_sweep_and_a_plain_run_never_import_dask(tmp_path):
    """``flexbody run`` and ``flexbody sweep --workers 0`` do not import dask (a subprocess's sys.modules)."""
    code = textwrap.dedent(f"""
        import sys
        from flexbody.cli import main
        assert main(["run", "{SCENE}", "--set", "nx=2", "--set", "steps=2", "--quiet"]) == 0
        assert main(["sweep", "{SCENE}", "--grid", "nx=2,3", "--set", "steps=2", "--workers", "0",
                     "--out", {str(tmp_path)!r}, "--quiet"]) == 0
        loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("dask", "distributed"))
        print("LOADED", loaded)
        sys.modules["distributed"] = None           # as without the cluster extra: one line, exit code 1
        try:
            main(["sweep", "{SCENE}", "--grid", "nx=2,3", "--workers", "2", "--out", {str(tmp_path)!r}])
        except SystemExit as exc:
            print("WITHOUT DASK", exc.code)
        sys.exit(1 if loaded else 0)
    """)
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "LOADED []" in done.stdout
    assert "WITHOUT DASK flexbody: running on a Dask cluster needs dask.distributed" in done.stdout
    assert "pip install 'flexbody[cluster]'" in done.stdout
    assert json.loads((tmp_path / "sweep.json").read_text())["counts"] == {"ok": 2}


def test_interrupt_keeps_the_finished_rows(client):
    """Ctrl-C while the rows come in (here raised by the progress hook after the first row) cancels the rest:
    SweepInterrupted carries the finished row and the others "cancelled", on the cluster and in series."""
    from flexbody.cluster import run_distributed
    from flexbody.sweep import SweepInterrupted, run_serial
    tasks = make_tasks(SCENE, grid_points({"nx": [2, 3, 4, 5, 6, 7]}), {"steps": 2})

    def interrupt(row):
        raise KeyboardInterrupt

    for run in (lambda: run_distributed(client, tasks, interrupt), lambda: run_serial(tasks, interrupt)):
        with pytest.raises(SweepInterrupted) as exc:
            run()
        rows = exc.value.rows
        assert sorted(r.index for r in rows) == list(range(6))
        assert [r.status for r in rows].count("ok") == 1
        assert [r.status for r in rows].count("cancelled") == 5
        assert exit_code(rows) == 2


def test_exit_code_and_summary_line_of_each_status():
    """0 only if every run is "ok"; 3 if all completed but some are not to be trusted; 2 otherwise."""
    from flexbody.sweep import SweepRow
    rows = lambda *statuses: [SweepRow(i, {}, s) for i, s in enumerate(statuses)]
    assert exit_code(rows("ok", "ok")) == 0
    assert exit_code(rows("ok", "untrusted")) == 3
    for bad in ("not converged", "failed", "lost", "cancelled"):
        assert exit_code(rows("ok", "untrusted", bad)) == 2
    assert summary_line(rows("ok", "lost", "untrusted", "lost")) == \
        "1 of 4 runs converged and trusted; 1 untrusted, 2 lost"


def test_untrusted_dynamic_run_gives_exit_code_3(client, tmp_path):
    """A dynamic run that completes but turns 0.5 rad per step (dt = 0.05 s at 10 rad/s) and drifts is
    "untrusted", with its reasons in the table; the sweep exits with 3."""
    out = tmp_path / "out"
    code = main(["sweep", "spinning_plate", "--grid", "dt=0.01,0.05", "--set", "nx=2", "--set", "ny=2",
                 "--set", "end_time=0.1", "--scheduler", client.scheduler.address, "--out", str(out), "--quiet"])
    assert code == 3
    with open(out / "sweep.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [(r["status"], r["converged"], r["trusted"]) for r in table] == [("ok", "True", "True"),
                                                                          ("untrusted", "True", "False")]
    assert "turns by 0.5 rad in a time step" in table[1]["message"]


def test_rows_are_small_unless_details_are_asked_for():
    """A task's row carries the run's full summary and history only with ``details`` (as the bench asks);
    the table's numbers are the same either way."""
    import pickle
    from dataclasses import replace
    task = make_tasks(SCENE, [{"nx": 2}], FIXED)[0]
    small, full = run_task(task), run_task(replace(task, details=True))
    assert small.summary == {} and small.history == {} and small.reference is None
    assert full.summary["outputs"] == small.outputs and len(full.history["W_tip"]) == 3 and full.reference
    assert small.as_dict() | {"total_time_s": 0, "cpu_time_s": 0, "wall_time_s": 0} == \
        full.as_dict() | {"total_time_s": 0, "cpu_time_s": 0, "wall_time_s": 0}
    assert len(pickle.dumps(small)) < len(pickle.dumps(full)) / 3
    assert make_tasks(SCENE, [{}], details=True)[0].details and not make_tasks(SCENE, [{}])[0].details


def test_source_cache_opens_a_scene_once_and_a_changed_file_again(tmp_path):
    """The scene source is opened once per cache (a Python scene file executed once, not per run), and
    again when the file changes; a scene that cannot be opened is reported by every run."""
    from flexbody.sweep import SourceCache
    scene = tmp_path / "counted.py"
    scene.write_text("from flexbody.scenes.builtin import cantilever_end_moment\n"
                     "def build(nx: int = 2, steps: int = 2):\n    return cantilever_end_moment(nx=nx, steps=steps)\n")
    cache = SourceCache()
    first = cache.get(str(scene))
    assert cache.get(str(scene)) is first and cache.opened == 1
    scene.write_text(scene.read_text() + "\n# edited\n")
    os.utime(scene, ns=(os.stat(scene).st_atime_ns, os.stat(scene).st_mtime_ns + 10**9))
    assert cache.get(str(scene)) is not first and cache.opened == 2
    rows = [run_task(t, cache) for t in make_tasks(str(scene), grid_points({"nx": [2, 3]}))]
    assert [r.status for r in rows] == ["ok", "ok"] and cache.opened == 2
    missing = make_tasks(str(tmp_path / "missing.py"), [{}])[0]
    assert run_task(missing, cache).status == "failed" and run_task(missing, cache).status == "failed"


def test_longest_runs_first():
    """The estimate orders the runs of one scene by mesh density times steps; ties keep the sweep order."""
    from flexbody.cluster import longest_first
    from flexbody.sweep import SourceCache, estimated_cost
    cache = SourceCache()
    tasks = make_tasks(SCENE, grid_points({"nx": [2, 8, 4], "steps": [3, 6]}))
    assert [estimated_cost(t, cache) for t in tasks] == [6, 12, 24, 48, 12, 24]
    assert [t.index for t in longest_first(tasks)] == [3, 2, 5, 1, 4, 0]
    dynamic = make_tasks("spinning_plate", grid_points({"dt": [0.004, 0.001, 0.002], "omega": [5, 10]}),
                         {"end_time": 0.2})
    assert [t.index for t in longest_first(dynamic)] == [2, 3, 4, 5, 0, 1]
    assert estimated_cost(make_tasks("no_such_scene", [{}])[0], cache) == 0.0


def test_second_sweep_reuses_the_workers_warm_up_and_sources(client):
    """A second sweep of the same scene on the same workers does not repeat the warm-up, and each worker
    opened the scene's source once for all its runs."""
    from flexbody.cluster import PLUGIN_NAME, run_distributed
    tasks = make_tasks(SCENE, grid_points({"nx": [2, 3, 2, 3]}), {"steps": 2})
    first = _by_index(run_distributed(client, tasks))
    plugins = client.run(lambda dask_worker: id(dask_worker.plugins[PLUGIN_NAME]))
    second = _by_index(run_distributed(client, tasks))
    assert client.run(lambda dask_worker: id(dask_worker.plugins[PLUGIN_NAME])) == plugins
    assert client.run(lambda dask_worker: dask_worker.plugins[PLUGIN_NAME].sources.opened) == \
        {address: 1 for address in plugins}
    assert all(first[i].outputs == second[i].outputs and first[i].status == "ok" for i in first)


def test_local_cluster_runs_with_the_quiet_settings(client):
    """The local cluster's scheduler gives each worker thread one run at a time and steals nothing; its
    workers run without the profiler and with the slow health check and monitors (flexbody.cluster.WORKER_CONFIG),
    also a worker that its nanny restarted (after the lost-worker test: it once came back with Dask's defaults)."""
    from flexbody.cluster import WORKER_CONFIG
    scheduler = client.run_on_scheduler(lambda dask_scheduler: (dask_scheduler.WORKER_SATURATION,
                                                                "stealing" in dask_scheduler.extensions))
    assert scheduler == (1.0, False)

    def settings():
        import dask
        return {key: dask.config.get(key) for key in WORKER_CONFIG}

    assert list(client.run(settings).values()) == [WORKER_CONFIG] * 2
