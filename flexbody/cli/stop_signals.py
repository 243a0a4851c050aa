"""SIGINT and SIGTERM stop a run cleanly: the step being written is written whole before it stops."""

from __future__ import annotations

from contextlib import contextmanager
import signal


class Stopped(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived: the run stops (exit code 128 + ``signum``)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class StopSignals:
    """SIGINT and SIGTERM raise :class:`Stopped`, except inside :meth:`deferred`, which finishes its block first
    (a step being written to the output files is written whole, to every file, before the run stops)."""

    def __init__(self) -> None:
        self.pending: int | None = None
        self._deferring = False

    def handle(self, signum: int, frame) -> None:
        if self._deferring:
            self.pending = signum
        else:
            raise Stopped(signum)

    @contextmanager
    def deferred(self):
        self._deferring = True
        try:
            yield
        finally:
            self._deferring = False
        if self.pending is not None:
            raise Stopped(self.pending)

    @contextmanager
    def installed(self):
        """Install the handlers for the block (in the main thread only; elsewhere signals stay as they are)."""
        previous = {}
        try:
            for signum in (signal.SIGINT, signal.SIGTERM):
                previous[signum] = signal.signal(signum, self.handle)
        except ValueError:  # not the main thread
            pass
        try:
            yield self
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
