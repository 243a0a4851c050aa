"""Dask's own CPU time per second of an idle local cluster of 2 worker processes, setting by setting.

    python benchmarks/dask_idle_cpu.py [--seconds 15]

Starts a local cluster with Dask's defaults (but the profiler, off in every flexbody cluster), then again with
each setting of ``flexbody.cluster.WORKER_CONFIG`` added in turn, and prints the CPU time that the worker and
nanny processes, and this process (scheduler and client), use per second while no task runs: the periodic
callbacks (event-loop health check, system and memory monitors, work stealing) that a sweep's runs share the
cores with. CPU time, not wall time: little affected by other users' load.
"""

from __future__ import annotations

import argparse
import logging
import time

STEPS = [("Dask's defaults (profiler off)", {}),
         ("+ tick every 1 s", {"distributed.admin.tick.interval": "1s"}),
         ("+ system monitor every 5 s, no GIL monitor", {"distributed.admin.system-monitor.interval": "5s",
                                                        "distributed.admin.system-monitor.gil.enabled": False}),
         ("+ memory monitor every 1 s", {"distributed.worker.memory.monitor-interval": "1s"}),
         ("+ no work stealing, saturation 1.0 (= WORKER_CONFIG)", {"distributed.scheduler.work-stealing": False,
                                                                  "distributed.scheduler.worker-saturation": 1.0})]


def _cpu(pids: list[int]) -> float:
    import psutil
    total = 0.0
    for pid in pids:
        try:
            times = psutil.Process(pid).cpu_times()
            total += times.user + times.system
        except psutil.Error:
            pass
    return total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=15.0)
    args = parser.parse_args()
    import dask
    import psutil
    from distributed import Client, LocalCluster
    from flexbody.cluster import WORKER_CONFIG

    config = {"distributed.worker.profile.enabled": False}
    print("| settings | workers and nannies [ms CPU / s] | scheduler and client [ms CPU / s] |")
    print("|---|---:|---:|")
    for name, extra in STEPS:
        config.update(extra)
        with dask.config.set(config):
            cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                   host="127.0.0.1", silence_logs=logging.CRITICAL, config=dict(config))
            client = Client(cluster)
            time.sleep(3)                                        # past the start-up
            pids = [p.pid for p in psutil.Process().children(recursive=True)]
            c0, h0, t0 = _cpu(pids), time.process_time(), time.perf_counter()
            time.sleep(args.seconds)
            c1, h1, t1 = _cpu(pids), time.process_time(), time.perf_counter()
            client.close()
            cluster.close()
        print(f"| {name} | {1e3 * (c1 - c0) / (t1 - t0):.1f} | {1e3 * (h1 - h0) / (t1 - t0):.1f} |", flush=True)
    assert config == {**config, **WORKER_CONFIG}, "the steps should end at flexbody.cluster.WORKER_CONFIG"


if __name__ == "__main__":
    main()
