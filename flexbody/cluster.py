"""Running the tasks of a sweep on a Dask cluster (dask.distributed: ``pip install 'flexbody[cluster]'``).

This is the only flexbody module that imports dask, and it is imported only by ``flexbody sweep`` and by
``flexbody bench --workers/--scheduler``: a scene run never loads it.

- :func:`connect`: a local cluster of N worker processes (one task at a time each), or a client of an
  existing cluster (``--scheduler tcp://host:8786``: a ``dask scheduler`` and ``dask worker`` started by
  hand, or by dask-jobqueue on SLURM/PBS: docs/sweeps.md).
- :class:`KernelWarmUp`: a worker plugin that compiles, or loads from numba's cache, the kernels of the
  sweep's scene once per worker (when the worker starts, or joins later), not per task, and fixes the
  number of numba threads of a worker: the cores of its machine shared among the workers on it (one thread
  each when several workers share a machine, the local cluster on a 2-core machine).
- :func:`run_distributed`: submit every task, collect the rows as they finish (progress through
  ``on_row``); a task whose worker died is a "lost" row, Ctrl-C cancels what is left ("cancelled" rows)
  and raises :class:`flexbody.sweep.SweepInterrupted` with every row.
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

from flexbody.sweep import SweepInterrupted, SweepRow, SweepTask, failed_row, run_task

PLUGIN_NAME = "flexbody-kernels"

#: the Dask settings of the local cluster's workers: no statistical profiler (its thread samples the stack of
#: the running task every 10 ms, which costs a Python-bound run time); on a cluster started by hand the same
#: with DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False in the workers' environment (docs/sweeps.md)
WORKER_CONFIG = {"distributed.worker.profile.enabled": False}


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
    (seconds spent compiling or loading) and ``failure`` (why the warm-up failed: the tasks then compile
    what they need themselves and report their own errors).
    """

    name = PLUGIN_NAME

    def __init__(self, scene: str, parameters: dict, workers_by_host: dict[str, int]):
        self.scene = scene
        self.parameters = dict(parameters)
        self.workers_by_host = dict(workers_by_host)
        self.threads = 1
        self.warm_up_s = 0.0
        self.failure: str | None = None

    async def setup(self, worker) -> None:
        import asyncio
        self.threads = threads_per_worker(os.cpu_count() or 1, self.workers_by_host.get(_host(worker.address), 2))
        await asyncio.to_thread(self._warm_up)   # a first compilation takes minutes: not on the event loop

    def _warm_up(self) -> None:
        from flexbody.scenes.kernel_setup import kernel_threads, warm_up_kernels
        from flexbody.scenes.sources import open_scene
        t0 = time.perf_counter()
        try:
            scene = open_scene(self.scene).build(self.parameters)
            with kernel_threads(self.threads, scene.model.body.mesh.n_elements):
                warm_up_kernels(scene.model)
        except Exception as exc:  # the tasks report what is wrong with the scene
            self.failure = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
        self.warm_up_s = time.perf_counter() - t0


def run_on_worker(task: SweepTask) -> SweepRow:
    """:func:`flexbody.sweep.run_task` on a Dask worker, with the worker's numba threads (:class:`KernelWarmUp`)
    and the worker's address in the row."""
    import numba
    worker = get_worker()
    plugin = worker.plugins.get(PLUGIN_NAME)
    threads = getattr(plugin, "threads", 1)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))   # per thread: set in the task's thread
    row = run_task(task)
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
    worker (one thread when the workers outnumber the cores). Closed (and the local cluster stopped) on exit."""
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
                               env={"NUMBA_NUM_THREADS": str(threads)})
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


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
    default: the first task's). A task whose worker died (Dask retries it on other workers before it gives
    up) is a "lost" row, one that raised outside the errors :func:`run_task` reports a "failed" row.
    Ctrl-C / SIGTERM cancel the tasks not finished and raise :class:`SweepInterrupted` with every row (the
    unfinished ones "cancelled").
    """
    if not tasks:
        return []
    scene, parameters = warm_up or (tasks[0].scene, tasks[0].parameters)
    hosts = Counter(_host(address) for address in client.nthreads())
    client.register_plugin(KernelWarmUp(scene, parameters, dict(hosts)), name=PLUGIN_NAME)
    token = f"{os.getpid()}-{time.time_ns()}"
    futures = {client.submit(run_on_worker, t, key=f"flexbody-run-{t.index}-{token}", pure=False, retries=0): t
               for t in tasks}
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


__all__ = ["KernelWarmUp", "connect", "run_distributed", "run_on_worker", "threads_per_worker"]
