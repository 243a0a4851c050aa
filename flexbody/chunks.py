"""Running an element loop over chunks of elements, on as many threads as numba is set to use.

The element kernels (:mod:`flexbody.shell.kernels`, :mod:`flexbody.shell.kernels.mitc7`) are compiled
functions of a range of elements ``[e0, e1)`` that release the GIL (:data:`flexbody._numba.entry`). One thread
(``numba.get_num_threads() == 1``, every run below ``DynamicAnalysis.SINGLE_THREAD_ELEMENTS`` elements) or a
small batch runs them in one call; otherwise the batch is cut into a few chunks per thread, run on a pool of
Python threads. This replaces numba's ``parallel=True`` loops: the same kernel serves both cases, and no
parfor is compiled (on a first run that compilation cost about 20 s of CPU for the element kernels, and one
thread never needed it).

Thread count: ``numba.get_num_threads()`` of the calling thread, so that
:func:`flexbody.scenes.scene.kernel_threads` and ``numba.set_num_threads`` keep their meaning.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numba

#: batches smaller than this run as one chunk (thread hand-off costs more than it gains)
MIN_PARALLEL = 128


def n_chunks(m: int, min_parallel: int = MIN_PARALLEL) -> int:
    """Chunks for a batch of ``m`` elements: one on one thread or below ``min_parallel`` elements, else a few
    per thread."""
    threads = numba.get_num_threads()
    if threads <= 1 or m < min_parallel:
        return 1
    return max(1, min(m, 4 * threads))


class Workspaces:
    """Per-thread scratch arrays of the element kernels, owned by whoever calls them repeatedly (an element
    variant keeps one: :attr:`flexbody.shell.variants.MITC6.workspaces`).

    ``get(key, make)`` returns the calling thread's arrays for ``key``, made by ``make()`` on first use and
    then reused: a kernel call's workspaces cost about 30 us to allocate, as much as a small batch's
    evaluation. The kernels overwrite their workspaces before reading them, so the reuse changes no result;
    one thread runs one chunk at a time, so no two running chunks share a workspace. A pickled copy starts
    empty (the arrays are scratch, and a thread-local store does not travel).
    """

    #: keys kept per thread before the store is cleared (a body uses one or two)
    MAX_KEYS = 16

    def __init__(self) -> None:
        self._local = threading.local()

    def get(self, key: tuple, make: Callable[[], tuple]) -> tuple:
        store = getattr(self._local, "store", None)
        if store is None:
            store = self._local.store = {}
        found = store.get(key)
        if found is None:
            if len(store) >= self.MAX_KEYS:
                store.clear()
            found = store[key] = make()
        return found

    def __reduce__(self):
        return (Workspaces, ())


@functools.lru_cache(maxsize=4)
def _pool(threads: int) -> ThreadPoolExecutor:
    """A pool of ``threads`` worker threads, made on first use and kept for the process (daemon-like: idle
    workers cost nothing and exit with the interpreter)."""
    return ThreadPoolExecutor(max_workers=threads, thread_name_prefix="flexbody-kernel")


def run_chunks(run: Callable[[int, int], None], m: int, chunks: int) -> None:
    """Call ``run(e0, e1)`` on ``chunks`` consecutive ranges covering ``range(m)``: in this thread for one
    chunk, else on ``numba.get_num_threads()`` worker threads (``run`` must release the GIL to gain anything,
    and make its own workspaces). Exceptions of a chunk are raised here."""
    if chunks <= 1:
        run(0, m)
        return
    bounds = [(c * m) // chunks for c in range(chunks + 1)]
    pool = _pool(numba.get_num_threads())
    for future in [pool.submit(run, bounds[c], bounds[c + 1]) for c in range(chunks)]:
        future.result()
