"""Ensembles of scenes: a parameter sweep as independent runs, each run one task, and the table of results.

A sweep is a list of :class:`SweepTask` (a scene and its parameter overrides), made from grids of values
(:func:`grid_points`: the cartesian product, or the paired lists). :func:`run_task` runs one of them and
returns its :class:`SweepRow` (parameters, converged, trusted, error against the reference, wall time,
iterations, factorizations, the tracked outputs); it never raises for a run that fails (a bad parameter
value, a diverging analysis): the row says what happened. The rows are written as one table
(:func:`write_table`: JSON and CSV) with plots of the tracked outputs and the errors against each swept
parameter (:func:`plot_sweep`, matplotlib imported only there).

Where the tasks run is not decided here: :func:`run_serial` runs them one after another in this process;
:mod:`flexbody.cluster` sends them to a Dask cluster (the only module that imports dask, and only when a
sweep runs on a cluster: nothing here imports it).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field, fields
import itertools
import json
import math
import os
import time
from typing import Callable

#: the most runs one sweep may ask for (a typo in a grid should not queue a million scenes)
MAX_RUNS = 100_000

#: the statuses of a row; only "ok" is an answer to be trusted
STATUSES = ("ok", "untrusted", "not converged", "failed", "lost", "cancelled")


@dataclass(frozen=True)
class SweepTask:
    """One run of a sweep.

    Attributes
    ----------
    index : its place in the sweep (0-based)
    scene : a built-in scene name, or the absolute path of a ``.toml`` / ``.py`` scene file (the path must be
        readable where the task runs: a shared file system on a cluster)
    parameters : the overrides the scene is built with (swept and fixed ones)
    swept : the swept parameters alone (the table's parameter columns)
    h5 : the HDF5 results file of this run, or None
    details : return the run's full summary, tracked-output history and reference in the row (what
        ``flexbody bench`` reports); without it the row holds what the table has, which is what a task on a
        cluster sends back (a few hundred bytes instead of the histories of every step)
    """

    index: int
    scene: str
    parameters: dict
    swept: dict
    h5: str | None = None
    details: bool = False


@dataclass
class SweepRow:
    """The result of one run (a row of the table).

    ``status``: "ok" (converged, and a dynamic run passed its energy/momentum/rotation checks), "untrusted"
    (completed but failed those checks: ``warnings``), "not converged" (the analysis stopped early:
    ``message`` says where and why), "failed" (the scene could not be built, a bad parameter value, or the
    analysis raised), "lost" (the task never returned: its worker died), "cancelled" (stopped by Ctrl-C
    before it finished). ``summary``, ``history`` and ``reference`` hold the run's full summary
    (``RunSummary.as_dict()``), tracked-output history and reference when its task asked for them
    (``SweepTask.details``, as ``flexbody bench`` does), else they are empty; they are not written to the table.
    """

    index: int
    parameters: dict
    status: str
    message: str = ""
    max_rel_error: float = math.nan
    wall_time_s: float = math.nan            # the solve (set-up and compilation excluded)
    total_time_s: float = math.nan           # the whole task: building the scene, loading kernels, solving,
                                             # making the row, freeing the run's memory
    cpu_time_s: float = math.nan             # the CPU time of the thread that ran the task (numba's other
                                             # threads not counted): below total_time_s on a shared machine
    steps: int = 0
    newton_iterations: int = 0
    tangent_updates: int = 0
    factorizations: int = 0
    dofs: int = 0
    outputs: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    worker: str = ""
    h5: str | None = None
    summary: dict = field(default_factory=dict, repr=False)
    history: dict = field(default_factory=dict, repr=False)
    reference: dict | None = field(default=None, repr=False)
    reference_source: str = ""

    @property
    def converged(self) -> bool:
        return self.status in ("ok", "untrusted")

    @property
    def trusted(self) -> bool:
        return self.status == "ok"

    def as_dict(self) -> dict:
        """The row as the table has it (without the full summary and history)."""
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("summary", "history", "reference")}
        d.update(parameters=dict(self.parameters), outputs=dict(self.outputs), warnings=list(self.warnings))
        d.update(converged=self.converged, trusted=self.trusted)
        return d


# ----------------------------------------------------------------------------------------------------------
# The tasks
# ----------------------------------------------------------------------------------------------------------

def grid_points(grids: dict[str, list], paired: bool = False) -> list[dict]:
    """The parameter sets of a sweep: the cartesian product of the value lists (the last key varies fastest),
    or with ``paired`` the i-th values of every list together (the lists must have one length).

    >>> grid_points({"nx": [2, 4], "thickness": [0.1, 0.2]})
    [{'nx': 2, 'thickness': 0.1}, {'nx': 2, 'thickness': 0.2}, {'nx': 4, 'thickness': 0.1}, {'nx': 4, 'thickness': 0.2}]
    """
    if not grids:
        raise ValueError("a sweep needs at least one --grid KEY=V1,V2,...")
    for key, values in grids.items():
        if not values:
            raise ValueError(f"--grid {key} has no values")
    keys = list(grids)
    if paired:
        lengths = {len(v) for v in grids.values()}
        if len(lengths) > 1:
            raise ValueError("--zip needs lists of one length, got "
                             + ", ".join(f"{k}: {len(v)}" for k, v in grids.items()))
        rows = zip(*grids.values())
    else:
        count = math.prod(len(v) for v in grids.values())
        if count > MAX_RUNS:
            raise ValueError(f"the grid asks for {count} runs, at most {MAX_RUNS}")
        rows = itertools.product(*grids.values())
    return [dict(zip(keys, row)) for row in rows]


def make_tasks(scene: str, points: list[dict], fixed: dict | None = None, h5_dir: str | None = None,
               details: bool = False) -> list[SweepTask]:
    """The tasks of a sweep of ``scene`` over ``points`` (each with the ``fixed`` overrides under it); with
    ``h5_dir`` each run writes ``h5_dir/run_<index>.h5``; with ``details`` the rows carry each run's full
    summary and history (:class:`SweepTask`). A scene file is named by its absolute path."""
    if os.path.splitext(scene)[1].lower() in (".toml", ".py"):
        scene = os.path.abspath(scene)
    width = max(4, len(str(len(points) - 1)))
    tasks = []
    for i, point in enumerate(points):
        h5 = os.path.abspath(os.path.join(h5_dir, f"run_{i:0{width}d}.h5")) if h5_dir else None
        tasks.append(SweepTask(i, scene, {**(fixed or {}), **point}, dict(point), h5, details))
    return tasks


#: the parameters whose value is a run's number of time or load steps, and its time step
_STEP_KEYS = ("steps", "analysis.steps")
_TIME_KEYS = (("end_time", "dt"), ("analysis.end_time", "analysis.dt"))


def estimated_cost(task: SweepTask, sources: SourceCache) -> float:
    """A relative estimate of a run's time, to start the longest runs of a sweep first: the product of its
    mesh-density parameters (the scene's ``density`` keys: the elements, up to a constant) and of its steps
    (``steps``, or ``end_time / dt``), as far as the task sets them. A value the task does not set is the
    scene's default in every run of the sweep, a common factor left out. Runs that differ only in other
    values (a thickness, a spin rate) have one estimate; 0 for a scene that cannot be opened (its runs fail
    at once). Not a time: only the order of the estimates of one scene's runs means something."""
    from flexbody.scenes.sources import SceneError
    try:
        density = sources.get(task.scene).density
    except (SceneError, OSError):
        return 0.0
    p = task.parameters

    def number(key) -> float | None:
        value = p.get(key)
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0
        return float(value) if ok else None

    cost = 1.0
    for key in density:
        for name in (key, key.rpartition(".")[2]):       # a TOML scene's "mesh.nx" is also set as "nx"
            if number(name) is not None:
                cost *= number(name)
                break
    steps = next((number(k) for k in _STEP_KEYS if number(k) is not None), None)
    if steps is None:
        for end, dt in _TIME_KEYS:
            if number(end) is not None or number(dt) is not None:
                steps = (number(end) or 1.0) / (number(dt) or 1.0)
                break
    return cost * (steps or 1.0)


def _failure_text(exc: BaseException) -> str:
    """One line for an exception: its type and the first line of its message."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def failed_row(task: SweepTask, status: str, message: str, **extra) -> SweepRow:
    """The row of a run that gave no answer (``status`` "failed", "lost" or "cancelled")."""
    return SweepRow(task.index, dict(task.swept), status, message, h5=None, **extra)


def row_from_summary(task: SweepTask, summary, total_time: float, scene=None) -> SweepRow:
    """The row of a run that finished (converged or not) from its ``RunSummary`` / ``DynamicRunSummary``;
    with ``task.details`` also its full summary, history and reference."""
    d = summary.as_dict()
    if not d["converged"]:
        status = "not converged"
    else:
        status = "untrusted" if d.get("warnings") else "ok"
    reference = None
    if task.details and scene is not None and scene.reference is not None:
        reference = {k: (list(map(float, scene.reference.load_factors)), list(map(float, v)))
                     for k, v in scene.reference.values.items()}
    error = d.get("max_rel_error")
    return SweepRow(task.index, dict(task.swept), status, "" if d["converged"] else str(d["message"]),
                    max_rel_error=math.nan if error is None else float(error), wall_time_s=float(d["wall_time_s"]),
                    total_time_s=total_time, steps=int(d["steps"]), newton_iterations=int(d["newton_iterations"]),
                    tangent_updates=int(d["tangent_updates"]), factorizations=int(d["factorizations"]),
                    dofs=int(d["dofs"]), outputs={k: float(v) for k, v in d["outputs"].items()},
                    warnings=list(d.get("warnings", [])), h5=task.h5, summary=d if task.details else {},
                    history={k: list(map(float, v)) for k, v in summary.history.items()} if task.details else {},
                    reference=reference,
                    reference_source=scene.reference.source if scene is not None and scene.reference else "")


def run_task(task: SweepTask, sources: SourceCache | None = None) -> SweepRow:
    """Build and run one scene of a sweep (with its HDF5 file if ``task.h5``); the row says how it went.

    ``sources``: the scene sources opened so far by this sweep in this process (:class:`SourceCache`: a scene
    file is read, and a Python one executed, once per process rather than once per run); None: open it now.

    A scene that cannot be built (an unknown key, a bad value), a static model that is not supported, or an
    analysis that raises gives a "failed" row; a run that stops early gives a "not converged" row with its
    message. Nothing here imports dask.
    """
    t0, c0 = time.perf_counter(), time.thread_time()
    row = _run(task, t0, sources if sources is not None else SourceCache())
    row.total_time_s = time.perf_counter() - t0      # after the row is made and the run's scene and states freed
    row.cpu_time_s = time.thread_time() - c0
    return row


class SourceCache:
    """The scene sources (:class:`flexbody.scenes.sources.SceneSource`) a sweep has opened in one process,
    by scene name and, for a scene file, its modification time and size (a file edited during the sweep is
    read again). Building a scene from its source is what every run does; opening the source (reading a
    TOML file, executing a Python scene file, looking up a built-in) is done once per process: one cache per
    :func:`run_serial` call, one per Dask worker (:mod:`flexbody.cluster`). A source that cannot be opened is
    not kept (each run reports it)."""

    def __init__(self) -> None:
        self._sources: dict[tuple, object] = {}
        self.opened = 0              # how many sources were opened (not found in the cache)

    @staticmethod
    def _key(scene: str) -> tuple:
        try:
            st = os.stat(scene)
        except OSError:
            return (scene, None)
        return (scene, st.st_mtime_ns, st.st_size)

    def get(self, scene: str):
        """The source of ``scene`` (a built-in name or a scene file), opened now if it is not cached."""
        from flexbody.scenes.sources import open_scene
        key = self._key(scene)
        source = self._sources.get(key)
        if source is None:
            source = open_scene(scene)
            self.opened += 1
            self._sources = {k: v for k, v in self._sources.items() if k[0] != scene}   # an older version
            self._sources[key] = source
        return source


def _run(task: SweepTask, t0: float, sources: SourceCache) -> SweepRow:
    from flexbody.assembly import ModelError
    from flexbody.outputs.recording import OutputStopped, RunRecorder
    from flexbody.scenes.runner import run_scene
    from flexbody.scenes.sources import SceneError
    try:
        scene = sources.get(task.scene).build(task.parameters)
        if scene.kind == "static":
            scene.model.check_static_support()
    except (SceneError, ModelError) as exc:
        return failed_row(task, "failed", str(exc), total_time_s=time.perf_counter() - t0)
    try:
        with RunRecorder(scene, h5=task.h5) as recorder:
            summary = run_scene(scene, on_step=recorder.on_step if task.h5 else None, started=t0)
    except (ValueError, ArithmeticError, RuntimeError, OSError, OutputStopped) as exc:
        return failed_row(task, "failed", f"the analysis failed: {_failure_text(exc)}",
                          total_time_s=time.perf_counter() - t0)
    return row_from_summary(task, summary, time.perf_counter() - t0, scene)


def run_serial(tasks: list[SweepTask], on_row: Callable[[SweepRow], None] | None = None) -> list[SweepRow]:
    """Run the tasks one after another in this process (no dask); Ctrl-C stops the sweep and marks the runs
    not finished "cancelled" (the finished rows are kept)."""
    rows: list[SweepRow] = []
    sources = SourceCache()
    try:
        for task in tasks:
            row = run_task(task, sources)
            rows.append(row)
            if on_row is not None:
                on_row(row)
    except KeyboardInterrupt:
        done = {r.index for r in rows}
        rows += [failed_row(t, "cancelled", "stopped before it finished") for t in tasks if t.index not in done]
        raise SweepInterrupted(rows) from None
    return rows


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM) stopped a sweep; ``rows`` holds every row, the unfinished ones "cancelled"."""

    def __init__(self, rows: list[SweepRow]):
        super().__init__("sweep interrupted")
        self.rows = rows


# ----------------------------------------------------------------------------------------------------------
# The table
# ----------------------------------------------------------------------------------------------------------

def counts(rows: list[SweepRow]) -> dict[str, int]:
    """How many rows have each status (only the statuses that occur)."""
    out = {s: sum(r.status == s for r in rows) for s in STATUSES}
    return {s: n for s, n in out.items() if n}


def summary_line(rows: list[SweepRow]) -> str:
    """One line: how many runs converged and can be trusted, and what happened to the others."""
    c = counts(rows)
    ok = c.pop("ok", 0)
    rest = ", ".join(f"{n} {s}" for s, n in c.items())
    return f"{ok} of {len(rows)} runs converged and trusted" + (f"; {rest}" if rest else "")


def exit_code(rows: list[SweepRow]) -> int:
    """0 if every run converged and can be trusted; 2 if any run failed, did not converge, was lost or
    cancelled; 3 if all completed but some are not to be trusted (a dynamic run's checks)."""
    if all(r.trusted for r in rows):
        return 0
    return 3 if all(r.converged for r in rows) else 2


def _columns(rows: list[SweepRow]) -> tuple[list[str], list[str]]:
    params = list(dict.fromkeys(k for r in rows for k in r.parameters))
    outputs = list(dict.fromkeys(k for r in rows for k in r.outputs))
    return params, outputs


def _finite(value):
    return None if isinstance(value, float) and not math.isfinite(value) else value


def write_table(rows: list[SweepRow], out_dir: str, meta: dict | None = None,
                json_path: str | None = None) -> list[str]:
    """Write ``out_dir/sweep.csv`` and ``out_dir/sweep.json`` (and the JSON to ``json_path`` too, if given);
    return the paths. Rows in sweep order; NaN as an empty CSV cell and as JSON null."""
    rows = sorted(rows, key=lambda r: r.index)
    params, outputs = _columns(rows)
    os.makedirs(out_dir, exist_ok=True)
    csv_path = os.path.join(out_dir, "sweep.csv")
    fixed = ["status", "converged", "trusted", "max_rel_error", "wall_time_s", "total_time_s", "cpu_time_s", "steps",
             "newton_iterations", "tangent_updates", "factorizations", "dofs"]
    with open(csv_path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["index", *params, *fixed, *outputs, "message", "worker", "h5"])
        for r in rows:
            d = r.as_dict()
            cells = [r.index, *(r.parameters.get(k, "") for k in params), *(d[k] for k in fixed),
                     *(r.outputs.get(k, math.nan) for k in outputs),
                     "; ".join([r.message, *r.warnings]).strip("; "), r.worker, r.h5 or ""]
            writer.writerow(["" if isinstance(c, float) and not math.isfinite(c) else c for c in cells])
    data = {**(meta or {}), "summary": summary_line(rows), "counts": counts(rows), "exit_code": exit_code(rows),
            "parameters": params, "outputs": outputs, "runs": [_clean(r.as_dict()) for r in rows]}
    paths = [csv_path]
    for path in [os.path.join(out_dir, "sweep.json")] + ([json_path] if json_path else []):
        with open(path, "w") as fh:
            json.dump(data, fh, indent=1)
        paths.append(path)
    return paths


def _clean(value):
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return _finite(value)


def plot_sweep(rows: list[SweepRow], out_dir: str) -> list[str]:
    """For each swept parameter, ``out_dir/vs_<parameter>.png``: each tracked output and the error against the
    reference (log scale) against that parameter, one line per combination of the other swept parameters,
    converged runs only. Returns the paths written (none without matplotlib, or without a converged run)."""
    from flexbody.outputs.report import _pyplot, _safe
    plt = _pyplot()
    good = sorted((r for r in rows if r.converged), key=lambda r: r.index)
    if plt is None or not good:
        return []
    params, outputs = _columns(good)
    quantities = outputs + (["max_rel_error"] if any(math.isfinite(r.max_rel_error) for r in good) else [])
    paths = []
    for p in params:
        others = [k for k in params if k != p]
        numeric = all(isinstance(r.parameters.get(p), (int, float)) and not isinstance(r.parameters.get(p), bool)
                      for r in good)
        ticks = list(dict.fromkeys(r.parameters.get(p) for r in sorted(good, key=lambda r: r.index)))
        fig, axes = plt.subplots(1, len(quantities), figsize=(4.2 * len(quantities), 3.4), squeeze=False)
        groups: dict[tuple, list[SweepRow]] = {}
        for r in good:
            groups.setdefault(tuple(r.parameters.get(k) for k in others), []).append(r)
        for ax, q in zip(axes[0], quantities):
            for key, rs in groups.items():
                rs = sorted(rs, key=lambda r: r.parameters[p] if numeric else ticks.index(r.parameters[p]))
                x = [r.parameters[p] if numeric else ticks.index(r.parameters[p]) for r in rs]
                y = [r.max_rel_error if q == "max_rel_error" else r.outputs.get(q, math.nan) for r in rs]
                label = ", ".join(f"{k}={v}" for k, v in zip(others, key)) or None
                ax.plot(x, y, "o-", label=label)
            if not numeric:
                ax.set_xticks(range(len(ticks)), [str(t) for t in ticks])
            if q == "max_rel_error":
                ax.set_yscale("log")
                ax.set_ylabel("max rel. error vs reference")
            else:
                ax.set_ylabel(q)
            ax.set_xlabel(p)
            ax.grid(True, alpha=0.3)
            if len(groups) > 1 and len(groups) <= 8:
                ax.legend(fontsize=7)
        path = os.path.join(out_dir, f"vs_{_safe(p)}.png")
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
