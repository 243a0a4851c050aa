"""Running the tasks of a sweep on a Dask cluster (dask.distributed: ``pip install 'flexbody[cluster]'``).

This is the only flexbody module that imports dask, and it is imported only by ``flexbody sweep`` and by
``flexbody bench --workers/--scheduler``: a scene run never loads it.

- :func:`connect`: a local cluster of N worker processes (one task at a time each), or a client of an
  existing cluster (``--scheduler tcp://host:8786``: a ``dask scheduler`` and ``dask worker`` started by
  hand, or by dask-jobqueue on SLURM/PBS: docs/sweeps.md).
- :class:`KernelWarmUp`: a worker plugin that compiles, or loads from numba's cache, the kernels of the
  sweep's scene once per worker (when the worker starts, or joins later), not per task, fixes the
  number of numba threads of a worker (the cores of its machine shared among the workers on it: one thread
  each when several workers share a machine, the local cluster on a 2-core machine), and keeps the worker's
  scene sources (:class:`flexbody.sweep.SourceCache`: a scene file read once per worker, not per task).
- :func:`run_distributed`: submit every task, the longest first (:func:`flexbody.sweep.estimated_cost`),
  collect the rows as they finish (progress through ``on_row``); a task whose worker died is a "lost" row,
  Ctrl-C cancels what is left ("cancelled" rows) and raises :class:`flexbody.sweep.SweepInterrupted` with
  every row.
"""

from __future__ import annotations

from collections import Counter
from contextlib import contextmanager
import logging
import os
import time
from typing import Callable

from distributed import Client, LocalCluster, as_completed, get_worker
from distributed.diagnostics.plugin import WorkerPlugin

from flexbody.sweep import SourceCache, SweepInterrupted, SweepRow, SweepTask, estimated_cost, failed_row, run_task

PLUGIN_NAME = "flexbody-kernels"

#: the Dask settings of the local cluster (its scheduler runs in this process, its workers are separate
#: processes that share this machine's cores with it). Measured with benchmarks/sweep_speedup.py, Dask's
#: defaults cost a sweep of 16 runs of about 1 s some 1.3 s of CPU time outside the runs (in the workers'
#: other threads and in the scheduler), which on a 2-core machine is taken from the runs; with these
#: settings 0.3 s:
#: - no statistical profiler in the workers (its thread samples the stack of the running task every 10 ms);
#: - the event loops' health check ("tick") every 1 s instead of 20 ms, the system monitor every 5 s instead
#:   of 0.5 s, no GIL-contention monitor, the memory monitor every 1 s instead of 0.1 s: each wakes a
#:   thread that takes the GIL from the running task;
#: - one run at a time per worker thread (worker-saturation 1.0; Dask's default 1.1 gives a one-thread
#:   worker two, the second of which waits there while another worker idles at the end of the sweep), and
#:   so no work stealing (nothing waits on a worker to be stolen).
#: On a cluster started by hand, the same through the workers' and the scheduler's environment
#: (DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False etc.: docs/sweeps.md).
WORKER_CONFIG = {"distributed.worker.profile.enabled": False,
                 "distributed.admin.tick.interval": "1s",
                 "distributed.admin.system-monitor.interval": "5s",
                 "distributed.admin.system-monitor.gil.enabled": False,
                 "distributed.worker.memory.monitor-interval": "1s",
                 "distributed.scheduler.worker-saturation": 1.0,
                 "distributed.scheduler.work-stealing": False}


def _host(address: str) -> str:
    """The host of a worker address such as ``tcp://10.0.0.5:40211``."""
    from distributed.comm import get_address_host
    return get_address_host(address)


def threads_per_worker(cores: int, workers_on_host: int) -> int:
    """The numba threads of each worker: the machine's cores shared among its workers, at least one."""
    return max(1, cores // max(1, workers_on_host))


class KernelWarmUp(WorkerPlugin):
    """Compile or load the kernels of a scene once per worker, and set the worker's numba threads.

    Parameters
    ----------
    scene : the scene to warm up (a built-in name or an absolute scene-file path)
    parameters : its overrides (the sweep's first run: the kernels depend on the element variant, not on
        the values)
    workers_by_host : how many workers each host runs (counted by the client when the sweep starts; a worker
        on a host not counted is taken to share it with others: one thread)

    After :meth:`setup`: ``threads`` (the numba threads each task of this worker runs with), ``warm_up_s``
    (seconds spent compiling or loading), ``failure`` (why the warm-up failed: the tasks then compile
    what they need themselves and report their own errors) and ``sources`` (the worker's
    :class:`flexbody.sweep.SourceCache`, which the tasks of this worker share).
    """

    name = PLUGIN_NAME

    def __init__(self, scene: str, parameters: dict, workers_by_host: dict[str, int]):
        self.scene = scene
        self.parameters = dict(parameters)
        self.workers_by_host = dict(workers_by_host)
        self.threads = 1
        self.warm_up_s = 0.0
        self.failure: str | None = None
        self.sources = SourceCache()
        self.key = plugin_key(scene, parameters, workers_by_host)

    async def setup(self, worker) -> None:
        import asyncio
        self.threads = threads_per_worker(os.cpu_count() or 1, self.workers_by_host.get(_host(worker.address), 2))
        await asyncio.to_thread(self._warm_up)   # a first compilation takes minutes: not on the event loop

    def _warm_up(self) -> None:
        from flexbody.scenes.kernel_setup import kernel_threads, warm_up_kernels
        t0 = time.perf_counter()
        try:
            scene = self.sources.get(self.scene).build(self.parameters)
            with kernel_threads(self.threads, scene.model.body.mesh.n_elements):
                warm_up_kernels(scene.model)
        except Exception as exc:  # the tasks report what is wrong with the scene
            self.failure = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
        self.warm_up_s = time.perf_counter() - t0


def plugin_key(scene: str, parameters: dict, workers_by_host: dict[str, int]) -> str:
    """What a :class:`KernelWarmUp` is for: a second sweep of the same scene on the same workers finds the
    warm-up done (its workers keep their plugin) and does not repeat it."""
    return repr((scene, sorted((k, repr(v)) for k, v in parameters.items()), sorted(workers_by_host.items())))


def _warmed_up(client, key: str) -> bool:
    """Whether every worker of the cluster has a :class:`KernelWarmUp` for ``key``."""
    found = client.run(lambda dask_worker: getattr(dask_worker.plugins.get(PLUGIN_NAME), "key", None))
    return bool(found) and all(v == key for v in found.values())


def run_on_worker(task: SweepTask) -> SweepRow:
    """:func:`flexbody.sweep.run_task` on a Dask worker, with the worker's numba threads and scene sources
    (:class:`KernelWarmUp`) and the worker's address in the row."""
    import numba
    worker = get_worker()
    plugin = worker.plugins.get(PLUGIN_NAME)
    threads = getattr(plugin, "threads", 1)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))   # per thread: set in the task's thread
    row = run_task(task, getattr(plugin, "sources", None))
    row.worker = worker.address
    return row


@contextmanager
def _sigint_ignored():
    """SIGINT ignored for the block (in the main thread): processes started in it inherit the disposition,
    and Python installs no KeyboardInterrupt handler in a process that starts with SIGINT ignored, so Ctrl-C
    reaches only this process, which cancels the sweep and closes the cluster (no worker tracebacks)."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def connect(workers: int | None = None, scheduler: str | None = None, quiet: bool = False):
    """A :class:`distributed.Client`: of the cluster at ``scheduler`` (an address, or the JSON file a
    ``dask scheduler --scheduler-file FILE`` wrote), else of a local cluster of ``workers``
    processes (default: the number of cores), one task at a time each, whose numba pool has the cores per
    worker (one thread when the workers outnumber the cores), with the Dask settings of :data:`WORKER_CONFIG`.
    Closed (and the local cluster stopped) on exit."""
    if scheduler:
        is_file = scheduler.endswith(".json") and os.path.isfile(scheduler)
        try:
            client = (Client(scheduler_file=scheduler, timeout="20s") if is_file
                      else Client(scheduler, timeout="20s"))
        except (OSError, TimeoutError) as exc:
            raise ConnectionError(f"cannot reach the Dask scheduler at {scheduler!r}: {exc}") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    threads = threads_per_worker(os.cpu_count() or 1, n)
    import dask
    with _sigint_ignored(), dask.config.set(WORKER_CONFIG):   # workers immune to Ctrl-C: this process stops them
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               host="127.0.0.1", silence_logs=logging.CRITICAL,
                               env={"NUMBA_NUM_THREADS": str(threads)},
                               config=dict(WORKER_CONFIG))   # also for a worker its nanny restarts later (the
                                                             # nanny's copy of the config set here is shallow)
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def longest_first(tasks: list[SweepTask]) -> list[SweepTask]:
    """The tasks in the order to start them: the largest :func:`flexbody.sweep.estimated_cost` first, ties
    in sweep order."""
    sources = SourceCache()
    costs = {t.index: estimated_cost(t, sources) for t in tasks}
    return sorted(tasks, key=lambda t: -costs[t.index])


def _error_row(task: SweepTask, exc: BaseException) -> SweepRow:
    """The row of a task that raised: "lost" if its worker died or the connection to it broke (Dask's
    KilledWorker, a closed comm, a cancelled future), else "failed" (the run raised outside the errors
    :func:`flexbody.sweep.run_task` reports itself)."""
    from distributed import CancelledError
    from distributed.comm.core import CommClosedError
    from distributed.scheduler import KilledWorker
    text = f"{type(exc).__name__}: {str(exc).splitlines()[0]}" if str(exc) else type(exc).__name__
    if isinstance(exc, (KilledWorker, CommClosedError, CancelledError)):
        return failed_row(task, "lost", f"the task did not return: {text}")
    return failed_row(task, "failed", f"the run raised {text}")


def run_distributed(client, tasks: list[SweepTask], on_row: Callable[[SweepRow], None] | None = None,
                    warm_up: tuple[str, dict] | None = None) -> list[SweepRow]:
    """Run ``tasks`` on the cluster of ``client``; return their rows in the order they finished.

    ``warm_up``: the scene and parameters whose kernels each worker loads once (:class:`KernelWarmUp`;
    default: the first task's). The tasks are submitted longest first (:func:`flexbody.sweep.estimated_cost`,
    ties in sweep order), so that the last runs to finish are short ones and no worker idles long at the end
    while another finishes a long run. A task whose worker died (Dask retries it on other workers before it gives
    up) is a "lost" row, one that raised outside the errors :func:`run_task` reports a "failed" row.
    Ctrl-C / SIGTERM cancel the tasks not finished and raise :class:`SweepInterrupted` with every row (the
    unfinished ones "cancelled").
    """
    if not tasks:
        return []
    scene, parameters = warm_up or (tasks[0].scene, tasks[0].parameters)
    hosts = dict(Counter(_host(address) for address in client.nthreads()))
    if not _warmed_up(client, plugin_key(scene, parameters, hosts)):     # (a second sweep on the same workers)
        client.register_plugin(KernelWarmUp(scene, parameters, hosts), name=PLUGIN_NAME)
    token = f"{os.getpid()}-{time.time_ns()}"
    order = longest_first(tasks)
    futures = {client.submit(run_on_worker, t, key=f"flexbody-run-{t.index}-{token}", pure=False, retries=0,
                             priority=len(order) - rank): t
               for rank, t in enumerate(order)}
    rows: list[SweepRow] = []
    try:
        for future in as_completed(futures):
            task = futures[future]
            if future.status == "finished":
                row = future.result()
            else:
                row = _error_row(task, future.exception())
            rows.append(row)
            if on_row is not None:
                on_row(row)
    except KeyboardInterrupt:
        client.cancel(list(futures))
        done = {r.index for r in rows}
        rows += [failed_row(t, "cancelled", "stopped before it finished") for t in tasks if t.index not in done]
        raise SweepInterrupted(rows) from None
    return rows


__all__ = ["KernelWarmUp", "connect", "longest_first", "run_distributed", "run_on_worker", "threads_per_worker"]
