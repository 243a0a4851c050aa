"""The runs of ``flexbody sweep`` and ``flexbody bench --workers/--scheduler`` as tasks: in this process
(``--workers 0``) or on a Dask cluster (:mod:`flexbody.cluster`), with their progress on stderr."""

from __future__ import annotations

import os
import signal
import sys
import time

from flexbody.cli.errors import CliError
from flexbody.cli.stop_signals import StopSignals, Stopped


def check_workers(args) -> None:
    """``--workers N`` (N >= 0) or ``--scheduler ADDRESS``, not both."""
    if args.workers is not None and args.scheduler:
        raise CliError("give --workers N or --scheduler ADDRESS, not both")
    if args.workers is not None and args.workers < 0:
        raise CliError(f"--workers must be >= 0 (0: in this process, no cluster), got {args.workers}")


def run_tasks(tasks, args, on_row=None, warm_up=None):
    """Run sweep tasks (serially with ``--workers 0``, else on a Dask cluster: :mod:`flexbody.cluster`), with
    the progress ``[finished/total]`` on stderr. Returns (rows, None), or (rows, 130 / 143) if Ctrl-C or
    SIGTERM stopped the sweep (the unfinished runs "cancelled")."""
    from flexbody.sweep import SweepInterrupted, failed_row, run_serial
    total, finished = len(tasks), []
    t0 = time.perf_counter()

    def progress(row) -> None:
        finished.append(row)
        if not args.quiet:
            params = ", ".join(f"{k}={v}" for k, v in row.parameters.items()) or "default"
            print(f"[{len(finished)}/{total}] {params}: {row.status}"
                  + (f" ({row.message})" if row.message and not row.converged else "")
                  + f"  {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
        if on_row is not None:
            on_row(row)

    signals = StopSignals()
    try:
        with signals.installed():
            if args.workers == 0:
                return run_serial(tasks, progress), None
            try:
                from flexbody.cluster import connect, run_distributed
            except ImportError as exc:
                raise CliError(f"running on a Dask cluster needs dask.distributed ({exc}): pip install "
                               "'flexbody[cluster]' (or --workers 0 to run in this process)") from None
            if not args.quiet:
                where = f"the Dask scheduler at {args.scheduler}" if args.scheduler else \
                    f"a local cluster of {args.workers or os.cpu_count()} worker processes"
                print(f"running {total} runs on {where}", file=sys.stderr, flush=True)
            try:
                with connect(args.workers, args.scheduler) as client:
                    return run_distributed(client, tasks, progress, warm_up), None
            except ConnectionError as exc:
                raise CliError(str(exc)) from None
    except SweepInterrupted as exc:
        code = 128 + getattr(exc.__context__, "signum", signal.SIGINT)
        print(f"flexbody: sweep stopped after {sum(r.status != 'cancelled' for r in exc.rows)} of {total} runs; "
              "the finished results are kept", file=sys.stderr)
        return exc.rows, code
    except Stopped as exc:   # stopped while the cluster started or stopped: nothing finished is lost
        rows = list(finished)
        done = {r.index for r in rows}
        rows += [failed_row(t, "cancelled", "stopped before it finished") for t in tasks if t.index not in done]
        return rows, 128 + exc.signum
