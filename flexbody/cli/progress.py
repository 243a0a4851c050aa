"""Progress on stderr while a scene runs: the kernels' compilation notices, and a line per step when
stderr is a terminal."""

from __future__ import annotations

import sys
import time


class Progress:
    """Progress on stderr: the kernels' compilation notices (:meth:`notify`) and a line per step (call); the
    steps' clock starts when the kernels are ready. With a ``goal`` (the last load factor of a load-controlled
    path, or the end time of a dynamic run) each line shows how far the run is, in per cent of the goal, and
    the time left at the rate so far (cut-backs and adaptive steps change the number of steps, not the goal).
    ``steps``: print the step lines (:func:`progress_printer` asks for them only when stderr is a terminal; the
    compilation notices are printed either way, they explain a first run's wait in a log too)."""

    def __init__(self, prefix: str = "", goal: float | None = None, steps: bool = True) -> None:
        self.prefix = prefix
        self.goal = goal
        self.steps = steps
        self.t0 = time.perf_counter()

    def notify(self, notice) -> None:
        """Show a :class:`flexbody.scenes.scene.CompileNotice`; restart the clock once the kernels are ready."""
        print(f"{self.prefix}  {notice}", file=sys.stderr, flush=True)
        if notice.done:
            self.t0 = time.perf_counter()

    def __call__(self, rec) -> None:
        if not self.steps:
            return
        if hasattr(rec, "time"):   # a dynamic step record
            where = f"time {rec.time:10.5g} s  iterations {rec.iterations:2d}  energy {rec.total_energy:11.5g}"
            position = rec.time
        else:
            where = f"load factor {rec.load_factor:8.4f}  iterations {rec.iterations:2d}"
            position = rec.load_factor
        elapsed = time.perf_counter() - self.t0
        if self.goal:
            done = min(max(position / self.goal, 0.0), 1.0)
            left = f"{elapsed * (1.0 - done) / done:7.1f} s" if done > 0 else "      ? s"
            print(f"{self.prefix}  step {rec.step:4d}  {where}  {100 * done:5.1f} %  left ~{left}  "
                  f"elapsed {elapsed:7.2f} s", file=sys.stderr, flush=True)
        else:
            print(f"{self.prefix}  step {rec.step:4d}  {where}  {elapsed:7.2f} s", file=sys.stderr, flush=True)


def progress_goal(scene) -> float | None:
    """Where a run ends, if known in advance: the last load factor of load control, the end time of a
    dynamic run (None for arc length, whose load factor may turn back)."""
    a = scene.analysis
    if scene.kind == "static":
        return float(max(a.load_factors)) if a.method == "load_control" else None
    end = getattr(a, "end_time", None)
    return float(end) if end else None


def stderr_is_terminal() -> bool:
    """Whether standard error is a terminal (not a file, a pipe or a CI log)."""
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):       # replaced by an object without it, or closed
        return False


def progress_printer(quiet: bool, prefix: str = "", goal: float | None = None) -> Progress | None:
    """The progress printer on stderr (None with --quiet): its step lines only when stderr is a terminal
    (a line per step in a redirected log or a pipe is noise), the compilation notices always."""
    return None if quiet else Progress(prefix, goal, steps=stderr_is_terminal())


def run_with_progress(scene, on_step=None, quiet: bool = False, prefix: str = "", started: float | None = None,
                      restart=None):
    """``run_scene`` with the progress and compilation notices on stderr (none with ``quiet``)."""
    from flexbody.scenes.runner import run_scene
    progress = progress_printer(quiet, prefix, progress_goal(scene))
    notify = None if progress is None else progress.notify
    extra = {} if restart is None else {"restart": restart}
    return run_scene(scene, on_step=on_step, progress=progress, notify=notify, started=started, **extra)
