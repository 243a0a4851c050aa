"""Around a run: compiling (or loading from numba's cache) the element kernels before the clock starts, and
the numba thread count of the element kernels during the run."""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
import time
from typing import Callable

from flexbody.assembly import Model
from flexbody.scenes.analysis import DynamicAnalysis


@dataclass(frozen=True)
class CompileNotice:
    """What :func:`warm_up_kernels` tells its caller, as it happens.

    ``stage``: "compiling" (numba started compiling: nothing usable in its cache, the first run), then
    "compiled" or "loaded" (every kernel came from numba's cache) when the kernels are ready, after
    ``seconds``. ``str()`` gives the sentence to show a user.
    """

    stage: str
    seconds: float = 0.0

    @property
    def done(self) -> bool:
        return self.stage != "compiling"

    def __str__(self) -> str:
        if self.stage == "compiling":
            return "compiling the element kernels (first run only, a few minutes) ..."
        if self.stage == "compiled":
            return f"compiled the element kernels in {self.seconds:.1f} s (cached for later runs)"
        return f"loaded the compiled element kernels in {self.seconds:.2f} s (from the cache: no compilation)"


def warm_up_kernels(model: Model, notify: Callable[[CompileNotice], None] | None = None) -> float:
    """Compile, or load from numba's cache, the kernels of a run (:meth:`Model.warm_up`); return the seconds.

    ``notify`` gets a "compiling" :class:`CompileNotice` when numba starts compiling (a cache miss), and
    a "compiled" or "loaded" one when the kernels are ready.
    """
    from numba.core import event

    class Watch(event.Listener):
        compilations = 0

        def on_start(self, ev) -> None:
            self.compilations += 1
            if self.compilations == 1 and notify is not None:
                notify(CompileNotice("compiling"))

        def on_end(self, ev) -> None:
            pass

    watch = Watch()
    t0 = time.perf_counter()
    with event.install_listener("numba:compile", watch):
        model.warm_up()
    seconds = time.perf_counter() - t0
    if notify is not None:
        notify(CompileNotice("compiled" if watch.compilations else "loaded", seconds))
    return seconds


@contextmanager
def kernel_threads(threads: int | None, n_elements: int):
    """Run the block with ``threads`` numba threads (None: automatic: one thread below
    ``DynamicAnalysis.SINGLE_THREAD_ELEMENTS`` elements, see ``DynamicAnalysis.threads``; static runs too)."""
    import numba
    wanted = threads
    if wanted is None and n_elements < DynamicAnalysis.SINGLE_THREAD_ELEMENTS:
        wanted = 1
    before = numba.get_num_threads()
    if wanted is not None:
        numba.set_num_threads(min(wanted, numba.config.NUMBA_NUM_THREADS))
    try:
        yield
    finally:
        numba.set_num_threads(before)
