"""A 16-run dynamic sweep on a local Dask cluster against the same runs in series, in one run.

    python benchmarks/sweep_speedup.py [--workers 2] [--end-time 0.5]

The sweep: the spinning plate (``spinning_plate``: free 1 x 1 m plate, 4 x 4 mesh, dt = 2 ms) over
omega = 5, 10, 15, 20 rad/s and thickness = 10, 15, 20, 25 mm, to ``--end-time`` (16 runs). The series is
:func:`flexbody.sweep.run_serial` in this process (kernels loaded before the clock starts), half of the runs
before the cluster's and half after (so that a load of the machine that changes in time affects both alike); the cluster is
:func:`flexbody.cluster.connect` (N worker processes, one numba thread each) and
:func:`flexbody.cluster.run_distributed` (each worker loads the kernels once, in its warm-up plugin).

Printed (Markdown): the time of the series, of the sweep on the cluster (from the submission of the first
task to the last result, the workers' warm-up included) and of the cluster's start, the speed-up, that the
numbers agree, and the overhead per task in two ways:
- in the sweep: (elapsed x workers - the workers' warm-up - the tasks' own times) / tasks: the scheduling,
  the transfer of the task and its row, and the workers idle at the end;
- of an empty task: the time per task of 200 no-op tasks (submission to result) on the same cluster.
The machine may be shared: its load average before and after is printed, and its capacity for parallel
work then (a busy loop in one process against the same loop in N processes at once: N on an idle machine),
the speed-up the load allowed.
"""

from __future__ import annotations

import argparse
import os
import time

from flexbody.sweep import grid_points, make_tasks, run_serial, run_task


def _noop(x):
    return x


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--end-time", type=float, default=0.5)
    args = parser.parse_args()
    from flexbody.cluster import connect, run_distributed

    grid = {"omega": [5.0, 10.0, 15.0, 20.0], "thickness": [0.01, 0.015, 0.02, 0.025]}
    tasks = make_tasks("spinning_plate", grid_points(grid), {"end_time": args.end_time})
    load_before = os.getloadavg()
    capacity = [machine_capacity(args.workers)]
    run_task(tasks[0])                                     # load the kernels in this process first

    t0 = time.perf_counter()
    serial = {r.index: r for r in run_serial(tasks[::2])}      # half of the series before the cluster ...
    t_serial = time.perf_counter() - t0

    t0 = time.perf_counter()
    with connect(workers=args.workers) as client:
        t_start = time.perf_counter() - t0
        t0 = time.perf_counter()
        rows = {r.index: r for r in run_distributed(client, tasks)}
        t_sweep = time.perf_counter() - t0
        warm = client.run(lambda dask_worker: dask_worker.plugins["flexbody-kernels"].warm_up_s)
        t0 = time.perf_counter()
        client.gather(client.map(_noop, range(200), pure=False))
        t_noop = (time.perf_counter() - t0) / 200
    t0 = time.perf_counter()
    serial.update({r.index: r for r in run_serial(tasks[1::2])})   # ... and half after (a load that changes)
    t_serial += time.perf_counter() - t0
    load_after = os.getloadavg()
    capacity.append(machine_capacity(args.workers))

    same = all(rows[i].outputs == serial[i].outputs and rows[i].newton_iterations == serial[i].newton_iterations
               for i in serial)
    statuses = {r.status for r in rows.values()} | {r.status for r in serial.values()}
    busy = sum(r.total_time_s for r in rows.values())
    cpu_serial = sum(r.cpu_time_s for r in serial.values())
    cpu_sweep = sum(r.cpu_time_s for r in rows.values())
    overhead = (t_sweep * args.workers - sum(warm.values()) - busy) / len(tasks)
    print(f"16-run dynamic sweep (spinning_plate, omega x thickness, end_time {args.end_time} s, "
          f"{tasks and serial[0].steps} steps each); {os.cpu_count()} cores; load average before "
          f"{load_before[0]:.2f} / {load_before[1]:.2f} (1 / 5 min), after {load_after[0]:.2f} / {load_after[1]:.2f}")
    print()
    print("| | wall time [s] |")
    print("|---|---:|")
    print(f"| 16 runs in series, in process | {t_serial:.2f} |")
    print(f"| 16 runs on {args.workers} workers (warm-up included) | {t_sweep:.2f} |")
    print(f"| starting the local cluster | {t_start:.2f} |")
    print(f"| workers' warm-up (kernels loaded once per worker) | "
          f"{', '.join(f'{v:.2f}' for v in warm.values())} |")
    print()
    print(f"speed-up {t_serial / t_sweep:.2f}x (sweep alone), {t_serial / (t_sweep + t_start):.2f}x "
          f"(cluster start included); same numbers: {same}; statuses: {sorted(statuses)}")
    print(f"the machine's capacity for {args.workers} processes (a busy loop in 1 process against {args.workers} at "
          f"once): {capacity[0]:.2f}x before, {capacity[1]:.2f}x after: the speed-up its load allowed")
    print(f"CPU time of the 16 runs: {cpu_serial:.2f} s in series, {cpu_sweep:.2f} s on the workers; the runs got "
          f"{cpu_serial / t_serial:.2f} cores in series and {cpu_sweep / t_sweep:.2f} cores on the cluster "
          f"(CPU time / elapsed)")
    print(f"overhead per task: {overhead * 1e3:.0f} ms in the sweep ((elapsed x workers - warm-up - task time) / tasks; "
          f"mean task {busy / len(tasks):.2f} s), {t_noop * 1e3:.1f} ms per empty task")


if __name__ == "__main__":
    main()
