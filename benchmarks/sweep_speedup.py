"""A 16-run dynamic sweep on a local Dask cluster against the same runs in series, in one run, and the overhead
per task of the sweep as it was first built ("before") and as it is now ("after"), measured on the same cluster.

    python benchmarks/sweep_speedup.py [--workers 2] [--end-time 0.5] [--rounds 1]

The sweep: the spinning plate (``spinning_plate``: free 1 x 1 m plate, 4 x 4 mesh, dt = 2 ms) over
omega = 5, 10, 15, 20 rad/s and thickness = 10, 15, 20, 25 mm, to ``--end-time`` (16 runs). The series is
:func:`flexbody.sweep.run_serial` in this process (kernels loaded before the clock starts), half of the runs
before the cluster's and half after (so that a load of the machine that changes in time affects both alike);
the cluster is :func:`flexbody.cluster.connect` (N worker processes, one numba thread each) and
:func:`flexbody.cluster.run_distributed` (each worker loads the kernels once, in its warm-up plugin).

The sweep runs ``--rounds`` times in each of two ways, alternated (before, after, after, before, ...) so
that a load that changes in time affects both alike, each on a local cluster of its own:

- "after": :func:`flexbody.cluster.connect` and :func:`flexbody.cluster.run_distributed` as they are: the
  scene source opened once per worker, small rows sent back, the longest runs first, the quieter Dask
  settings of ``flexbody.cluster.WORKER_CONFIG`` (one run at a time per worker thread, no work stealing,
  fewer periodic callbacks in the workers and the scheduler);
- "before": the sweep as first built: every task opens its scene source and sends back its full summary and
  history, the tasks in sweep order, Dask's defaults but for the profiler (worker-saturation 1.1: two runs
  queued per one-thread worker; work stealing; a 20 ms tick, ...).

Printed (Markdown): the time of the series and of each sweep (from the submission of the first task to the
last result), the speed-up, that the numbers agree (bit for bit), and the overhead per task, split with
Dask's task stream into
- in the task: the task's own time (``total_time_s``: building the scene, solving, making the row, freeing
  the run's memory) against the same run in series (the slow-down of a run on a busy machine: the capacity,
  not Dask's);
- around the task: the time the worker's thread spent on it outside ``run_task`` (finding the worker and its
  plugin, setting the numba threads);
- between tasks: a worker idle while another task waits for it (scheduling, the transfer of task and row);
- the tail: workers idle at the end while the last runs finish;
and an empty task's time (200 no-op tasks). The overhead per task in the sweep is
(elapsed x workers - the tasks' own time) / tasks = around + between + ends + tail. Less sensitive to the load
of a shared machine: Dask's CPU time per task outside the runs (the worker processes' CPU time less the tasks'
threads', plus this process's: the scheduler and the client), which a 2-core machine takes from the runs. The
machine may be shared: the
load average before and after is printed, and its capacity for parallel work then (a busy loop in one process
against the same loop in N processes at once: N on an idle machine), the speed-up the load allowed.
"""

from __future__ import annotations

import argparse
from contextlib import contextmanager
from dataclasses import replace
import os
import time

from flexbody.sweep import grid_points, make_tasks, run_serial, run_task


def _noop(x):
    return x


def _run_as_first_built(task):
    """A task as the sweep first ran it: the scene source opened in the task, the full summary and history in
    the row (for the "before" sweep)."""
    from distributed import get_worker
    import numba
    from flexbody.cluster import PLUGIN_NAME
    worker = get_worker()
    threads = getattr(worker.plugins.get(PLUGIN_NAME), "threads", 1)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    row = run_task(replace(task, details=True))
    row.worker = worker.address
    return row


_BUSY = "import time; t = time.perf_counter(); sum(range(4 * 10**7)); print(time.perf_counter() - t)"


def machine_capacity(workers: int) -> float:
    """The speed-up the machine allows now: the time of a busy loop in one process over its time in
    ``workers`` processes at once (2.0 on an idle 2-core machine; less when other jobs share it)."""
    import subprocess
    import sys

    def times(n: int) -> list[float]:
        procs = [subprocess.Popen([sys.executable, "-c", _BUSY], stdout=subprocess.PIPE, text=True)
                 for _ in range(n)]
        return [float(p.communicate()[0]) for p in procs]

    one = times(1)[0]
    return workers * one / max(times(workers))


def sweep_before(client, tasks):
    """The sweep as first built (module docstring): the tasks in sweep order; returns its rows."""
    from distributed import as_completed
    token = time.time_ns()
    futures = [client.submit(_run_as_first_built, t, key=f"before-{t.index}-{token}", pure=False) for t in tasks]
    return [f.result() for f in as_completed(futures)]


def sweep_after(client, tasks):
    from flexbody.cluster import run_distributed
    return run_distributed(client, tasks)


@contextmanager
def cluster_as_first_built(workers: int):
    """The local cluster as :func:`flexbody.cluster.connect` first made it: Dask's defaults but the profiler."""
    import logging
    import dask
    from distributed import Client, LocalCluster
    with dask.config.set({"distributed.worker.profile.enabled": False}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               host="127.0.0.1", silence_logs=logging.CRITICAL,
                               env={"NUMBA_NUM_THREADS": str(max(1, (os.cpu_count() or 1) // workers))})
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def _process_cpu(dask_worker=None) -> float:
    return time.process_time()


def timed_sweep(client, run, tasks, workers: int) -> dict:
    """Run one sweep (``run(client, tasks)``) under Dask's task stream; its elapsed time and overhead split."""
    from distributed import get_task_stream
    cpu0, here0 = client.run(_process_cpu), time.process_time()
    with get_task_stream(client) as stream:
        t0 = time.perf_counter()
        rows = {r.index: r for r in run(client, tasks)}
        elapsed = time.perf_counter() - t0
    here, cpu1 = time.process_time() - here0, client.run(_process_cpu)
    workers_cpu = sum(cpu1[w] - cpu0[w] for w in cpu0)
    spans: dict[str, list[tuple[float, float]]] = {}
    for rec in stream.data:
        if not str(rec["key"]).startswith(("flexbody-run", "before")):
            continue
        compute = [s for s in rec["startstops"] if s["action"] == "compute"]
        if compute:
            spans.setdefault(rec["worker"], []).append((compute[0]["start"], compute[0]["stop"]))
    begin = min(a for s in spans.values() for a, _ in s)          # the first task's start, on any worker
    end = max(b for s in spans.values() for _, b in s)            # the last task's stop
    own = sum(r.total_time_s for r in rows.values())
    computed = sum(b - a for s in spans.values() for a, b in s)
    between = sum((max(b for _, b in s) - min(a for a, _ in s)) - sum(b - a for a, b in s) for s in spans.values())
    tail = sum(end - max(b for _, b in s) for s in spans.values())
    head = sum(min(a for a, _ in s) - begin for s in spans.values())
    n = len(tasks)
    return dict(rows=rows, elapsed=elapsed, own=own, overhead=(elapsed * workers - own) / n,
                around=(computed - own) / n, between=between / n, tail=tail / n,
                ends=(elapsed * workers - computed - between - tail) / n,      # head + submission + last result
                cpu=sum(r.cpu_time_s for r in rows.values()),
                dask_cpu=(workers_cpu - sum(r.cpu_time_s for r in rows.values()) + here) / n,
                dask_cpu_rate=(workers_cpu - sum(r.cpu_time_s for r in rows.values()) + here) / elapsed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--end-time", type=float, default=0.5)
    parser.add_argument("--rounds", type=int, default=1, help="sweeps of each kind on the cluster (alternated)")
    args = parser.parse_args()
    from collections import Counter
    from flexbody.cluster import PLUGIN_NAME, KernelWarmUp, _host, connect

    grid = {"omega": [5.0, 10.0, 15.0, 20.0], "thickness": [0.01, 0.015, 0.02, 0.025]}
    tasks = make_tasks("spinning_plate", grid_points(grid), {"end_time": args.end_time})
    load_before = os.getloadavg()
    capacity = [machine_capacity(args.workers)]
    run_task(tasks[0])                                     # load the kernels in this process first

    t0 = time.perf_counter()
    serial = {r.index: r for r in run_serial(tasks[::2])}      # half of the series before the cluster ...
    t_serial = time.perf_counter() - t0

    measured: dict[str, list[dict]] = {"before": [], "after": []}
    kinds = []
    for r in range(args.rounds):
        kinds += ["before", "after"] if r % 2 == 0 else ["after", "before"]
    starts, warm, noop = {}, {}, {}
    for kind in kinds:
        t0 = time.perf_counter()
        with (connect(workers=args.workers) if kind == "after" else cluster_as_first_built(args.workers)) as client:
            starts.setdefault(kind, []).append(time.perf_counter() - t0)
            hosts = dict(Counter(_host(a) for a in client.nthreads()))
            client.register_plugin(KernelWarmUp(tasks[0].scene, tasks[0].parameters, hosts), name=PLUGIN_NAME)
            warm.setdefault(kind, []).extend(client.run(lambda dask_worker: dask_worker.plugins[PLUGIN_NAME].warm_up_s)
                                             .values())
            client.gather(client.map(run_task, tasks[:args.workers], pure=False))   # first calls on the workers
            run = sweep_before if kind == "before" else sweep_after
            measured[kind].append(timed_sweep(client, run, tasks, args.workers))
            t0 = time.perf_counter()
            client.gather(client.map(_noop, range(200), pure=False))
            noop.setdefault(kind, []).append((time.perf_counter() - t0) / 200)
    t0 = time.perf_counter()
    serial.update({r.index: r for r in run_serial(tasks[1::2])})   # ... and half after (a load that changes)
    t_serial += time.perf_counter() - t0
    load_after = os.getloadavg()
    capacity.append(machine_capacity(args.workers))

    same = all(m["rows"][i].outputs == serial[i].outputs and m["rows"][i].newton_iterations ==
               serial[i].newton_iterations for ms in measured.values() for m in ms for i in serial)
    statuses = {r.status for ms in measured.values() for m in ms for r in m["rows"].values()} | \
        {r.status for r in serial.values()}
    own_serial = sum(r.total_time_s for r in serial.values())
    cpu_serial = sum(r.cpu_time_s for r in serial.values())
    mean = lambda kind, key: sum(m[key] for m in measured[kind]) / len(measured[kind])
    print(f"16-run dynamic sweep (spinning_plate, omega x thickness, end_time {args.end_time} s, "
          f"{serial[0].steps} steps each) on {args.workers} workers; {os.cpu_count()} cores; load average before "
          f"{load_before[0]:.2f} / {load_before[1]:.2f} (1 / 5 min), after {load_after[0]:.2f} / {load_after[1]:.2f}; "
          f"{args.rounds} sweep(s) of each kind, alternated")
    print()
    print("| | before | after |")
    print("|---|---:|---:|")
    print(f"| 16 runs in series, in process [s] | {t_serial:.2f} | {t_serial:.2f} |")
    print(f"| 16 runs on {args.workers} workers [s] | {mean('before', 'elapsed'):.2f} | {mean('after', 'elapsed'):.2f} |")
    print(f"| speed-up | {t_serial / mean('before', 'elapsed'):.2f} | {t_serial / mean('after', 'elapsed'):.2f} |")
    print(f"| **overhead per task** [ms] | **{mean('before', 'overhead') * 1e3:.0f}** | "
          f"**{mean('after', 'overhead') * 1e3:.0f}** |")
    print(f"| - around the task (in the worker's thread, outside the run) [ms] | {mean('before', 'around') * 1e3:.1f} | "
          f"{mean('after', 'around') * 1e3:.1f} |")
    print(f"| - between tasks (scheduling, transfer) [ms] | {mean('before', 'between') * 1e3:.1f} | "
          f"{mean('after', 'between') * 1e3:.1f} |")
    print(f"| - at the start and the end (submission, first dispatch, last result) [ms] | "
          f"{mean('before', 'ends') * 1e3:.1f} | {mean('after', 'ends') * 1e3:.1f} |")
    print(f"| - the tail (workers idle at the end) [ms] | {mean('before', 'tail') * 1e3:.0f} | "
          f"{mean('after', 'tail') * 1e3:.0f} |")
    print(f"| **Dask's CPU time per task outside the runs** (workers' other threads, scheduler, client) [ms] | "
          f"**{mean('before', 'dask_cpu') * 1e3:.0f}** | **{mean('after', 'dask_cpu') * 1e3:.0f}** |")
    print(f"| the same per second of the sweep (a share of one core) [ms/s] | {mean('before', 'dask_cpu_rate') * 1e3:.0f} | "
          f"{mean('after', 'dask_cpu_rate') * 1e3:.0f} |")
    print(f"| CPU time of the 16 runs' own threads [s] (in series: {cpu_serial:.2f}) | {mean('before', 'cpu'):.2f} | "
          f"{mean('after', 'cpu'):.2f} |")
    print(f"| an empty task [ms] | {sum(noop['before']) / len(noop['before']) * 1e3:.1f} | "
          f"{sum(noop['after']) / len(noop['after']) * 1e3:.1f} |")
    print(f"| starting the local cluster [s] | {sum(starts['before']) / len(starts['before']):.2f} | "
          f"{sum(starts['after']) / len(starts['after']):.2f} |")
    print(f"| the workers' warm-up (kernels loaded once per worker) [s] | {', '.join(f'{v:.2f}' for v in warm['before'])} | "
          f"{', '.join(f'{v:.2f}' for v in warm['after'])} |")
    print(f"| tasks' own time on the workers / in series | {mean('before', 'own') / own_serial:.3f} | "
          f"{mean('after', 'own') / own_serial:.3f} |")
    print(f"| mean task (own time) on the workers [s] | {mean('before', 'own') / 16:.3f} | "
          f"{mean('after', 'own') / 16:.3f} |")
    print()
    print(f"same numbers (every sweep against the series, bit for bit): {same}; statuses: {sorted(statuses)}")
    print(f"the machine's capacity for {args.workers} processes (a busy loop in 1 process against {args.workers} at "
          f"once): {capacity[0]:.2f}x before, {capacity[1]:.2f}x after: the speed-up its load allowed")


if __name__ == "__main__":
    main()
