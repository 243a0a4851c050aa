"""The ``flexbody`` command: list, run, bench and compare scenes.

    flexbody list
    flexbody run [SCENE] [--set KEY=VALUE ...] [--json FILE] [--h5 FILE.h5] [--rerun FILE.rrd] [--quiet]
                 [--xdmf FILE.xdmf] [--stresses] [--restart FILE.h5[:STEP]]
    flexbody bench [SCENE ...] [--refine KEY=V1,V2,...] [--set KEY=VALUE ...] [--out DIR] [--quiet]
    flexbody compare SCENE --with exudyn [--set KEY=VALUE ...] [--json FILE] [--quiet]
    flexbody sweep SCENE --grid KEY=V1,V2,... [--grid ...] [--zip] [--workers N | --scheduler ADDRESS]
        [--set KEY=VALUE ...] [--out DIR] [--json FILE] [--h5]         (docs/sweeps.md)
    flexbody modes SCENE [--set K=V ...] [--count N] [--omega W | --load-factor L|end] [--sweep KEY=V1,...]
                   [--json FILE] [--plot FILE.png] [--rerun FILE.rrd] [--h5 FILE.h5]
    flexbody modes SCENE --buckling [--set K=V ...] [--count N] [--json FILE]

SCENE is a built-in scene name (``flexbody list``) or a path to a ``.toml`` or ``.py`` scene file
(docs/scenes.md). Bad input ends with one line on stderr naming the offending key or value (exit code 1);
a run that stops before its last load step writes its outputs and exits with 2 (also when the --h5 file
cannot take another step, e.g. a full disk); an error inside the analysis exits with 1. Ctrl-C (SIGINT)
and SIGTERM (what ``timeout`` and batch schedulers send) stop a run cleanly: the step being written is
finished, the files are closed readable, and the exit code is 128 + the signal number (130, 143).
a dynamic run that completes but is not to be trusted (a conserved energy or momentum drifted, or the
body turned too far in a time step: docs/robustness.md) prints a WARNING line, lists it under ``warnings``
in the JSON and exits with 3.
"""

from __future__ import annotations

import argparse
import ast
from contextlib import contextmanager, redirect_stdout
import json
import math
import os
import signal
import sys
import time

DEFAULT_SCENE = "cantilever_end_moment"

#: how many time steps a bench of a dynamic scene runs: dt, dt/2, dt/4 (dt: the scene's, or --set dt=...)
BENCH_TIME_STEPS = 3


def _default_bench_scenes() -> list[str]:
    from flexbody.scenes.registry import bench_scenes
    return list(bench_scenes())


def _bench_meshes(source) -> list[dict]:
    """A built-in scene's default mesh sequence of ``flexbody bench`` (flexbody.scenes.registry), else []."""
    from flexbody.scenes.registry import SCENES
    entry = SCENES.get(source.name) if source.kind == "builtin" else None
    return [dict(mesh) for mesh in entry.bench_meshes] if entry is not None else []


class CliError(Exception):
    """Bad command-line input or a bad scene: printed as one line, exit code 2."""


# ----------------------------------------------------------------------------------------------------------
# Arguments
# ----------------------------------------------------------------------------------------------------------

def _parse_value(text: str):
    """A ``--set`` value: a Python/TOML-style literal (numbers, lists, true/false), else the text itself."""
    lowered = text.lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _parse_sets(items: list[str]) -> dict:
    out = {}
    for item in items:
        if "=" not in item:
            raise CliError(f"--set expects KEY=VALUE, got {item!r}")
        key, value = item.split("=", 1)
        if not key.strip():
            raise CliError(f"--set expects KEY=VALUE, got {item!r}")
        out[key.strip()] = _parse_value(value.strip())
    return out


def _parse_refine(items: list[str]) -> list[dict]:
    """``--refine nx=4,8,16 --refine ny=1,2,4`` -> [{nx: 4, ny: 1}, {nx: 8, ny: 2}, {nx: 16, ny: 4}]."""
    columns: dict[str, list] = {}
    for item in items:
        if "=" not in item:
            raise CliError(f"--refine expects KEY=V1,V2,..., got {item!r}")
        key, values = item.split("=", 1)
        columns[key.strip()] = [_parse_value(v.strip()) for v in values.split(",") if v.strip()]
        if not columns[key.strip()]:
            raise CliError(f"--refine {key.strip()} has no values")
    lengths = {len(v) for v in columns.values()}
    if len(lengths) > 1:
        raise CliError(f"--refine lists must have the same length, got "
                       f"{', '.join(f'{k}: {len(v)}' for k, v in columns.items())}")
    n = lengths.pop() if lengths else 0
    return [{k: v[i] for k, v in columns.items()} for i in range(n)]


def _check_outputs(paths: dict[str, str | None], inputs: dict[str, str] | None = None) -> None:
    """One line if an output cannot be written, two name one file, or one names an ``inputs`` file."""
    from flexbody.outputs.recording import OutputPathError, check_distinct, check_not_inputs, check_output_path
    try:
        for option, path in paths.items():
            if path is not None:
                check_output_path(path, option, regular=option != "--json")
        check_distinct(paths)
        check_not_inputs(paths, inputs or {})
    except OutputPathError as exc:
        raise CliError(str(exc)) from None


def _input_files(source, scene=None) -> dict[str, str]:
    """The files a scene reads: its scene file, and a TOML scene's mesh and reference files."""
    if source.kind == "builtin":
        return {}
    files = {"scene file": source.name}
    if scene is not None and source.kind == "toml":
        folder = os.path.dirname(os.path.abspath(source.name))
        for key, what in (("mesh.file", "mesh file"), ("reference.file", "reference file")):
            value = scene.parameters.get(key)
            if isinstance(value, str):
                files[what] = os.path.join(folder, value)
    return files


def _open(name: str):
    from flexbody.scenes.sources import SceneError, open_scene
    try:
        return open_scene(name)
    except SceneError as exc:
        raise CliError(str(exc)) from None


def _build(source, params: dict):
    """The scene of ``source`` with ``params``; a bad scene, or a static one whose supports leave a rigid
    motion free (checked now, before the kernels compile), is a CliError; a mesh of several separate pieces
    is a note on stderr (each piece moves on its own)."""
    import numpy as np

    from flexbody.assembly import ModelError
    from flexbody.scenes.sources import SceneError
    try:
        scene = source.build(params)
        if scene.kind == "static":
            scene.model.check_static_support()
    except (SceneError, ModelError) as exc:
        raise CliError(str(exc)) from None
    count, labels = scene.model.body.mesh.connected_components()
    if count > 1:
        sizes = np.bincount(labels)
        print(f"note: the mesh of {scene.name} has {count} separate pieces (nodes per piece: "
              f"{', '.join(map(str, sizes[:10]))}{', ...' if count > 10 else ''})", file=sys.stderr)
    return scene


def _write_json(path: str, data) -> None:
    try:
        with open(path, "w") as fh:
            json.dump(_strict_json(data), fh, indent=2)
    except OSError as exc:
        raise CliError(f"cannot write --json file {path!r}: {exc.strerror or exc}") from None


def _write_json_stdout(data) -> None:
    """``--json -``: the JSON document alone on standard output."""
    json.dump(_strict_json(data), sys.stdout, indent=2)
    sys.stdout.write("\n")
    sys.stdout.flush()


class _RenamedStream:
    """A text stream that writes to ``stream`` with ``old`` shown as ``new`` (the temporary JSON file of
    ``--json -`` named as standard output in the lines that report it written)."""

    def __init__(self, stream, old: str, new: str) -> None:
        self._stream, self._old, self._new = stream, old, new

    def write(self, text: str) -> int:
        self._stream.write(text.replace(self._old, self._new))
        return len(text)

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextmanager
def _stdout_to_stderr(temporary: str):
    """While a command runs for ``--json -``: what it prints goes to standard error, through Python's
    ``sys.stdout`` and through file descriptor 1 (a library may print from C); ``temporary`` is shown as
    "standard output". Descriptor 1 is restored on the way out, whatever happens."""
    sys.stdout.flush()
    try:
        saved = os.dup(1)
        os.dup2(2, 1)
    except OSError:                              # no descriptor 1 or 2: Python's stream only
        saved = None
    try:
        with redirect_stdout(_RenamedStream(sys.stderr, temporary, "standard output")):
            yield
    finally:
        sys.stderr.flush()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


def _with_json_to_stdout(args, command) -> int:
    """``command(args)`` with ``--json -``: the command writes its JSON to a temporary file while its printed
    text goes to standard error (:func:`_stdout_to_stderr`); then that JSON alone goes to standard output
    (nothing if the command stopped before writing it). ``flexbody run`` writes its own (:func:`cmd_run`)."""
    import tempfile
    real = sys.stdout
    fd, temporary = tempfile.mkstemp(prefix="flexbody-", suffix=".json")
    os.close(fd)
    args.json = temporary
    try:
        with _stdout_to_stderr(temporary):
            code = command(args)
        with open(temporary, encoding="utf-8") as fh:
            text = fh.read()
        if text.strip():
            real.write(text.rstrip("\n") + "\n")
            real.flush()
        return code
    finally:
        args.json = "-"
        os.unlink(temporary)


def _strict_json(value):
    """NaN/inf as null so that every JSON reader accepts the file."""
    if isinstance(value, dict):
        return {k: _strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict_json(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


class _Progress:
    """Progress on stderr: the kernels' compilation notices (:meth:`notify`) and a line per step (call); the
    steps' clock starts when the kernels are ready. With a ``goal`` (the last load factor of a load-controlled
    path, or the end time of a dynamic run) each line shows how far the run is, in per cent of the goal, and
    the time left at the rate so far (cut-backs and adaptive steps change the number of steps, not the goal).
    ``steps``: print the step lines (``_progress_printer`` asks for them only when stderr is a terminal; the
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


def _progress_goal(scene) -> float | None:
    """Where a run ends, if known in advance: the last load factor of load control, the end time of a
    dynamic run (None for arc length, whose load factor may turn back)."""
    a = scene.analysis
    if scene.kind == "static":
        return float(max(a.load_factors)) if a.method == "load_control" else None
    end = getattr(a, "end_time", None)
    return float(end) if end else None


def _stderr_is_terminal() -> bool:
    """Whether standard error is a terminal (not a file, a pipe or a CI log)."""
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):       # replaced by an object without it, or closed
        return False


def _progress_printer(quiet: bool, prefix: str = "", goal: float | None = None) -> _Progress | None:
    """The progress printer on stderr (None with --quiet): its step lines only when stderr is a terminal
    (a line per step in a redirected log or a pipe is noise), the compilation notices always."""
    return None if quiet else _Progress(prefix, goal, steps=_stderr_is_terminal())


def _run_scene(scene, on_step=None, quiet: bool = False, prefix: str = "", started: float | None = None,
               restart=None):
    """``run_scene`` with the progress and compilation notices on stderr (none with ``quiet``)."""
    from flexbody.scenes.runner import run_scene
    progress = _progress_printer(quiet, prefix, _progress_goal(scene))
    notify = None if progress is None else progress.notify
    extra = {} if restart is None else {"restart": restart}
    return run_scene(scene, on_step=on_step, progress=progress, notify=notify, started=started, **extra)


# ----------------------------------------------------------------------------------------------------------
# list
# ----------------------------------------------------------------------------------------------------------

def cmd_list(args) -> int:
    """``flexbody list``: one line per built-in scene."""
    from flexbody.scenes.registry import SCENES
    for name, entry in SCENES.items():
        print(f"{name:24s} {entry.summary}")
    return 0


# ----------------------------------------------------------------------------------------------------------
# show
# ----------------------------------------------------------------------------------------------------------

#: Units of the scenes' parameters by their (last) key. The scenes use consistent units (the spinning and
#: dynamic scenes SI: m, kg, s); mesh and step counts and switches have none.
PARAMETER_UNITS = {"thickness": "length", "radius": "length", "inner_radius": "length",
                   "outer_radius": "length", "length": "length", "width": "length", "young": "force/length^2",
                   "pressure": "force/length^2", "density": "mass/length^3", "dt": "s", "end_time": "s",
                   "ramp_time": "s", "omega": "rad/s", "angular_velocity": "rad/s", "steps": "load steps"}


def _parameter_unit(key: str) -> str:
    name = key.split(".")[-1]
    if name in PARAMETER_UNITS:
        return PARAMETER_UNITS[name]
    return "elements" if name == "n" or name.startswith("n_") else ""


def show_lines(source, scene) -> list[str]:
    """The text of ``flexbody show``: the scene, its parameters with defaults and units, its reference."""
    import inspect
    from flexbody.scenes.registry import builtin_scene
    model = scene.model
    lines = [f"scene            {scene.name} ({source.kind})", f"models           {scene.description}"]
    if source.kind == "builtin":
        doc = builtin_scene(source.name).summary
        if doc and doc != scene.description:
            lines.append(f"                 {doc}")
    lines.append(f"mesh             {model.body.mesh.n_nodes} nodes, {model.body.mesh.n_elements} elements "
                 f"({model.body.element_name}), {model.n_dof} DoFs")
    a = scene.analysis
    if scene.kind == "static":
        lines.append(f"analysis         static, {a.method}, {len(a.load_factors)} load steps to load factor "
                     f"{a.load_factors[-1]:g}" if getattr(a, "load_factors", None) else
                     f"analysis         static, {a.method}")
    else:
        lines.append(f"analysis         dynamic, time step {a.time_step:g} s to {a.end_time:g} s"
                     if hasattr(a, "end_time") else "analysis         dynamic")
    defaults = {}
    if source.kind in ("builtin", "python"):
        func = builtin_scene(source.name).builder if source.kind == "builtin" else None
        if func is not None:
            defaults = {k: p.default for k, p in inspect.signature(func).parameters.items()
                        if p.default is not inspect.Parameter.empty}
    params = {**defaults, **{k: v for k, v in scene.parameters.items() if k not in defaults}}
    if params:
        lines.append("parameters       (set with --set KEY=VALUE; default, unit)")
        for k, v in params.items():
            unit = _parameter_unit(k)
            lines.append(f"  {k:20s} {v!r:>14s}  {unit}".rstrip())
    outs = ", ".join(o.name for o in scene.outputs)
    if outs:
        lines.append(f"outputs          {outs}")
    if scene.reference is not None:
        lines.append(f"reference        {scene.reference.source or 'given'}")
    else:
        lines.append("reference        none")
    return lines


def cmd_show(args) -> int:
    """``flexbody show SCENE``: what the scene models, its parameters and reference (builds, does not run)."""
    source = _open(args.scene)
    scene = _build(source, {})
    for line in show_lines(source, scene):
        print(line)
    return 0


# ----------------------------------------------------------------------------------------------------------
# run
# ----------------------------------------------------------------------------------------------------------

def _balance_lines(d: dict) -> list[str]:
    """The energy and momentum lines of a dynamic run's summary."""
    e, m = d["energy"], d["momentum"]
    lines = [f"energy           kinetic {e['kinetic']['initial']:.5g} -> {e['kinetic']['final']:.5g}, strain "
             f"{e['strain']['initial']:.5g} -> {e['strain']['final']:.5g} (max {e['strain']['max']:.5g}), "
             f"gravity {e['gravity']['initial']:.5g} -> {e['gravity']['final']:.5g}"
             + (f", dissipated {e['dissipated']['final']:.5g}" if e.get("dissipated", {}).get("final") else ""),
             f"energy drift     {e['total']['max_rel_drift']:.3e} (max |E - E0| / max(T + W + |Vg|), E = T + W + Vg + D"
             f"{'' if e['conservative'] else '; not conserved: loads or prescribed motion do work'})",
             f"momentum drift   linear {m['linear']['max_rel_drift']:.3e}, angular {m['angular']['max_rel_drift']:.3e}"
             f" ({'isolated body: both conserved' if m['isolated'] else 'not isolated: exchanged with supports, loads or gravity'})"]
    return lines


def summary_lines(summary) -> list[str]:
    """The printed run summary (the same content as the --json file)."""
    d = summary.as_dict()
    dynamic = d.get("kind") == "dynamic"
    if dynamic:
        reached = (f"time reached {d['time']:.4g} s of {d['end_time']:.4g} s, dt {d['time_step']:.4g} s, "
                   f"rho_inf {d['rho_inf']:g}{' (default)' if d.get('rho_inf_default') else ''}, {d['policy']} iteration matrix, {d.get('mass', 'lumped')} mass")
        ts = d.get("time_steps", {})
        if ts.get("adaptive"):
            reached += (f"; adaptive: {ts['accepted']} accepted, rejected {ts['rejected_error']} (error) + "
                        f"{ts['rejected_newton']} (Newton), dt {ts['min']:.3g} to {ts['max']:.3g} s")
    else:
        reached = f"load factor reached {d['load_factor']:.4g}"
    lines = [
        f"scene            {d['scene']}" + (" (dynamic)" if dynamic else ""),
        f"DoFs / elements  {d['dofs']} / {d['elements']}",
        f"steps            {d['steps']}  ({reached})",
        f"Newton           {d['newton_iterations']} iterations, {d['tangent_updates']} tangent updates, "
        f"{d['factorizations']} factorizations" + (f" ({d['newton_iteration']} iteration)"
                                                   if "newton_iteration" in d else "")
        + (f"; per step {d['iterations_per_step']:.2f} iterations, {d['factorizations_per_step']:.3f} "
           "factorizations" if dynamic else ""),
        f"wall time        set-up {d['setup_time_s']:.2f} s, compilation {d['compile_time_s']:.2f} s "
        f"(or loading from the cache), solve {d['solve_time_s']:.2f} s",
    ]
    for k, v in d["outputs"].items():
        lines.append(f"output           {k} = {v:.6g}")
    if dynamic:
        lines += _balance_lines(d)
    if d["errors"]:
        worst = max(d["errors"], key=lambda e: e["rel_error"])
        at = f"time {worst['time']:.4g} s" if dynamic else f"load factor {worst['load_factor']:.3g}"
        if worst.get("measure") == "path":
            versus = (f"nearest point of the reference path {worst['reference']:.5g} at load factor "
                      f"{worst['reference_load_factor']:.3g}; distance in the normalised (value, load) plane")
        else:
            versus = f"vs reference {worst['reference']:.5g}" + (
                ", interpolated between recorded steps" if worst.get("measure") == "interpolated" else "")
        lines.append(f"max rel. error   {d['max_rel_error']:.3e}  ({worst['quantity']} at {at}: "
                     f"{worst['value']:.5g} {versus})")
    if d.get("stability"):
        lines += stability_lines(d["stability"])
    if not d["converged"]:
        lines.append(f"NOT CONVERGED    {d['message']}")
    if d.get("warnings"):
        lines.append(f"WARNING          not to be trusted: {'; '.join(d['warnings'])} (docs/robustness.md)")
    return lines


def stability_lines(st: dict) -> list[str]:
    """The stability lines of a static run's summary (``RunSummary.as_dict()["stability"]``): the count of
    negative eigenvalues of the tangent at the last step, and every limit or bifurcation point passed."""
    n = st.get("final_negative_eigenvalues")
    if n is None:
        return []
    lines = [f"stability        {'stable' if n == 0 else 'UNSTABLE'} final equilibrium: {n} negative eigenvalue(s) "
             "of the tangent" + ("" if n == 0 else " (a perturbation leaves it; see the critical points)")]
    for c in st["critical_points"]:
        lines.append(f"critical point   {c['kind']} between load factors {c['load_factor_before']:.6g} and "
                     f"{c['load_factor_after']:.6g} (step {c['step']}; negative eigenvalues "
                     f"{c['negative_before']} -> {c['negative_after']})")
    return lines


def _run_failure(exc: BaseException) -> str:
    """A one-line description of an error raised inside an analysis."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class Stopped(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived: the run stops (exit code 128 + ``signum``)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class _StopSignals:
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


def cmd_run(args) -> int:
    """``flexbody run``: check the output paths, build the scene, run it with the requested files written
    step by step, print the summary. Returns 0, 2 (not converged, or stopped because the --h5 file cannot
    take a step), 3 (completed, but not to be trusted: ``summary.warnings``), 1 (an error inside the
    analysis) or 128 + the signal number (SIGINT, SIGTERM)."""
    t0 = time.perf_counter()
    params = _parse_sets(args.set or [])
    json_to_stdout = args.json == "-"
    outputs = {"--json": None if json_to_stdout else args.json, "--h5": args.h5, "--rerun": args.rerun}
    xdmf = getattr(args, "xdmf", None)
    if xdmf:
        from flexbody.outputs.xdmf import heavy_data_path
        outputs.update({"--xdmf": xdmf, "--xdmf (its arrays)": heavy_data_path(xdmf)})
    restart_spec = getattr(args, "restart", None)
    if getattr(args, "stresses", False) and not args.h5:
        raise CliError("--stresses writes the stresses to the --h5 file: give --h5 FILE.h5 too")
    source = _open(args.scene)
    restart_input = {}
    if restart_spec:
        from flexbody.outputs.restart import parse_restart
        restart_input = {"--restart file": parse_restart(restart_spec)[0]}
    _check_outputs(outputs, {**_input_files(source), **restart_input})
    import importlib.util
    if args.rerun and importlib.util.find_spec("rerun") is None:  # looked up, not imported
        raise CliError("--rerun needs the rerun SDK: pip install 'flexbody[rerun]' (or rerun-sdk)")
    if xdmf and importlib.util.find_spec("meshio") is None:
        raise CliError("--xdmf needs meshio: pip install 'flexbody[mesh]' (or meshio)")
    scene = _build(source, params)
    _check_outputs(outputs, {**_input_files(source, scene), **restart_input})
    restart = None
    if restart_spec:
        from flexbody.outputs.restart import RestartError, read_restart
        try:
            restart = read_restart(restart_spec, scene)
        except RestartError as exc:
            raise CliError(str(exc)) from None
    from flexbody.outputs.recording import OutputStopped, RunRecorder
    try:
        recorder = RunRecorder(scene, h5=args.h5, rerun=args.rerun, directors=args.directors,
                               warn=lambda message: print(f"flexbody: warning: {message}", file=sys.stderr),
                               xdmf=xdmf, stresses=getattr(args, "stresses", False),
                               rerun_color=getattr(args, "rerun_color", "deformation"))
    except (OSError, ImportError, ValueError) as exc:
        raise CliError(str(exc).splitlines()[0]) from None
    failure = None
    signals = _StopSignals()

    def on_step(rec, state, history) -> None:
        with signals.deferred():
            recorder.on_step(rec, state, history)

    with recorder, signals.installed():
        try:
            summary = _run_scene(scene, on_step, args.quiet, started=t0, restart=restart)
        except Stopped as exc:
            failure, code = f"stopped by {signal.Signals(exc.signum).name}", 128 + exc.signum
        except KeyboardInterrupt:
            failure, code = "interrupted", 130
        except OutputStopped as exc:
            failure, code = f"the run stopped: {exc}", 2
        except (ValueError, ArithmeticError, RuntimeError, OSError) as exc:
            failure, code = f"the analysis failed: {_run_failure(exc)}", 1
    if failure is not None:
        where = (f"; {recorder.steps_written} step(s) written to {', '.join(recorder.paths)}"
                 if recorder.paths else "")
        print(f"flexbody: {failure}{where}", file=sys.stderr)
        return code
    human = sys.stderr if json_to_stdout else sys.stdout   # --json -: standard output is the JSON alone
    for line in summary_lines(summary):
        print(line, file=human)
    print(f"total time       {time.perf_counter() - t0:.2f} s (including setup and compilation)", file=human)
    for path in recorder.paths:
        print(f"written          {path}", file=human)
    if json_to_stdout:
        _write_json_stdout(summary.as_dict())
    elif args.json:
        _write_json(args.json, summary.as_dict())
        print(f"written          {args.json}")
    if not summary.result.converged:
        return 2
    return 3 if summary.warnings else 0


# ----------------------------------------------------------------------------------------------------------
# bench
# ----------------------------------------------------------------------------------------------------------

def _mesh_sequence(source, refine: list[dict], scene=None) -> list[dict]:
    """The runs of a bench for one scene: --refine; else the built-in table; else, for a dynamic scene
    (``scene``, built with the common overrides) whose time step is the key ``dt``, the time steps dt, dt/2,
    dt/4; else the scene's density parameters at 1x and 2x; else the scene as it is."""
    if refine:
        return refine
    if _bench_meshes(source):
        return _bench_meshes(source)
    if scene is not None and scene.kind == "dynamic" and (source.keys is None or "dt" in source.keys):
        dt = scene.analysis.time_step
        return [dict(dt=dt / 2**k) for k in range(BENCH_TIME_STEPS)]
    if source.kind == "toml" and source.density:
        return [dict(source.density), {k: 2 * v for k, v in source.density.items()}]
    return [{}]


def _bench_one(source, params: dict, label: str, quiet: bool):
    from flexbody.outputs.report import BenchRun
    from flexbody.scenes.sources import SceneError
    try:
        scene = source.build(params)
    except SceneError as exc:
        return BenchRun(source.name, label, params, failure=str(exc))
    try:
        summary = _run_scene(scene, quiet=quiet, prefix=f"  [{label}]")  # compiles outside the timed solve
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        return BenchRun(scene.name, label, params, failure=f"the analysis failed: {_run_failure(exc)}")
    reference = None
    if scene.reference is not None:
        reference = {k: (list(map(float, scene.reference.load_factors)), list(map(float, v)))
                     for k, v in scene.reference.values.items()}
    return BenchRun(scene.name, label, params, summary.as_dict(), {k: list(v) for k, v in summary.history.items()},
                    reference, reference_source=scene.reference.source if scene.reference else "")


def _bench_plan(source, common: dict, refine: list[dict]) -> list[dict]:
    """The runs of one scene (:func:`_mesh_sequence`), its first run's scene built to report a bad key now."""
    needs_scene = not refine and not _bench_meshes(source)
    scene = _build(source, common) if needs_scene else None
    meshes = _mesh_sequence(source, refine, scene)
    _build(source, {**common, **meshes[0]})
    return meshes


def _prepare_out_dir(path: str) -> None:
    import os
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        raise CliError(f"cannot create --out directory {path!r}: {exc.strerror or exc}") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise CliError(f"cannot write to --out directory {path!r}")


def cmd_bench(args) -> int:
    """``flexbody bench``: every scene on its mesh sequence, then DIR/report.md, plots and bench.json.
    Returns 0, or 2 if a run failed or did not converge (the report is written either way)."""
    from flexbody.outputs.report import mesh_label, write_report
    common = _parse_sets(args.set or [])
    refine = _parse_refine(args.refine or [])
    names = args.scenes or _default_bench_scenes()
    sources = [_open(name) for name in names]
    plans = [_bench_plan(source, common, refine) for source in sources]  # a bad scene or key stops it now
    _prepare_out_dir(args.out)
    if args.workers is not None or args.scheduler:
        _check_workers(args)
        return _bench_on_cluster(args, sources, plans, common)
    runs, failed = [], 0
    for source, meshes in zip(sources, plans):
        if meshes == [{}]:
            print(f"note: {source.name} runs at one mesh; give --refine KEY=V1,V2,... for a sequence",
                  file=sys.stderr)
        density = list(meshes[0]) or list(source.density)
        for mesh in meshes:
            params = {**common, **mesh}
            label = mesh_label({**source.density, **params}, density)
            if not args.quiet:
                print(f"bench {source.name} [{label}]", file=sys.stderr, flush=True)
            run = _bench_one(source, params, label, args.quiet)
            runs.append(run)
            failed += not run.converged
            error = (f"max rel. error {run.max_rel_error:.2e}" if math.isfinite(run.max_rel_error)
                     else "no reference")
            status = run.failure or (f"{run.dofs} DoFs, {run.wall_time:.2f} s, {error}"
                                     + ("" if run.converged else ", NOT CONVERGED"))
            print(f"{source.name:24s} {label:28s} {status}", flush=True)
    path = write_report(runs, args.out, " ".join(["flexbody", "bench", *args.argv]))
    print(f"written          {path}")
    return 0 if failed == 0 else 2


def _bench_on_cluster(args, sources, plans, common: dict) -> int:
    """``flexbody bench --workers N | --scheduler ADDRESS``: the same runs as the serial bench, as the tasks
    of a sweep (:mod:`flexbody.sweep`, :mod:`flexbody.cluster`); the same report and exit code."""
    from flexbody.outputs.report import BenchRun, mesh_label, write_report
    from dataclasses import replace

    from flexbody.sweep import make_tasks
    tasks, labels = [], []
    for source, meshes in zip(sources, plans):
        density = list(meshes[0]) or list(source.density)
        for mesh in meshes:
            task = replace(make_tasks(source.name, [mesh], common, details=True)[0],  # the report's
                           index=len(tasks))                                # histories; one numbering
            tasks.append(task)
            labels.append((source.name, mesh_label({**source.density, **task.parameters}, density)))

    def status(row) -> None:
        scene, label = labels[row.index]
        error = (f"max rel. error {row.max_rel_error:.2e}" if math.isfinite(row.max_rel_error) else "no reference")
        text = (f"failed: {row.message}" if not row.summary else
                f"{row.dofs} DoFs, {row.wall_time_s:.2f} s, {error}" + ("" if row.converged else ", NOT CONVERGED"))
        print(f"{scene:24s} {label:28s} {text}", flush=True)

    rows, interrupted = _sweep_rows(tasks, args, status, warm_up=None)
    runs = []
    for row in sorted(rows, key=lambda r: r.index):
        scene, label = labels[row.index]
        if row.summary:
            runs.append(BenchRun(row.summary.get("scene", scene), label, tasks[row.index].parameters, row.summary,
                                 row.history, row.reference, reference_source=row.reference_source))
        else:
            runs.append(BenchRun(scene, label, tasks[row.index].parameters, failure=f"{row.status}: {row.message}"))
    path = write_report(runs, args.out, " ".join(["flexbody", "bench", *args.argv]))
    print(f"written          {path}")
    if interrupted is not None:
        return interrupted
    return 0 if all(r.converged for r in runs) else 2


# ----------------------------------------------------------------------------------------------------------
# sweep
# ----------------------------------------------------------------------------------------------------------

def _parse_grid(items: list[str]) -> dict[str, list]:
    """``--grid nx=2,4 --grid thickness=0.01,0.02`` -> {nx: [2, 4], thickness: [0.01, 0.02]}."""
    grids: dict[str, list] = {}
    for item in items:
        key, sep, values = item.partition("=")
        if not sep or not key.strip():
            raise CliError(f"--grid expects KEY=V1,V2,..., got {item!r}")
        if key.strip() in grids:
            raise CliError(f"--grid {key.strip()} is given twice")
        grids[key.strip()] = [_parse_value(v.strip()) for v in values.split(",") if v.strip()]
        if not grids[key.strip()]:
            raise CliError(f"--grid {key.strip()} has no values")
    return grids


def _sweep_rows(tasks, args, on_row=None, warm_up=None):
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

    signals = _StopSignals()
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


def _check_workers(args) -> None:
    if args.workers is not None and args.scheduler:
        raise CliError("give --workers N or --scheduler ADDRESS, not both")
    if args.workers is not None and args.workers < 0:
        raise CliError(f"--workers must be >= 0 (0: in this process, no cluster), got {args.workers}")


def _check_sweep_keys(source, keys: list[str]) -> None:
    """An unknown key would fail every run of a sweep: one line now (the values are checked by each run)."""
    if source.keys is not None:
        unknown = [k for k in keys if k not in source.keys]
        if unknown:
            raise CliError(f"unknown parameter(s) {unknown} for scene {source.name!r}; "
                           f"documented keys: {', '.join(source.keys)}")
    elif source.kind == "toml":
        from flexbody.scenes.toml_scene import SceneError, read_toml, resolve_key
        try:
            doc = read_toml(source.name)
            for key in keys:
                resolve_key(doc, key, source.name)
        except SceneError as exc:
            raise CliError(str(exc)) from None


def cmd_sweep(args) -> int:
    """``flexbody sweep``: run a scene over a grid of parameters as independent tasks (a local Dask cluster,
    an existing one, or in this process with ``--workers 0``); write DIR/sweep.csv, DIR/sweep.json, the plots
    DIR/vs_<parameter>.png and with --h5 DIR/runs/run_<index>.h5. Returns 0 if every run converged and can be
    trusted, 2 if some failed, did not converge or were lost, 3 if all completed but some are not to be
    trusted, 130 / 143 if stopped by Ctrl-C / SIGTERM (the finished results written). ``--json -``: the table's
    JSON alone on standard output, the printed lines on standard error."""
    if args.json == "-":
        return _with_json_to_stdout(args, cmd_sweep)
    from flexbody.sweep import grid_points, make_tasks, plot_sweep, summary_line, write_table, exit_code
    _check_workers(args)
    fixed = _parse_sets(args.set or [])
    grids = _parse_grid(args.grid or [])
    try:
        points = grid_points(grids, paired=args.zip)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    source = _open(args.scene)
    _check_sweep_keys(source, [*fixed, *grids])
    _check_outputs({"--json": args.json}, _input_files(source))
    _prepare_out_dir(args.out)
    h5_dir = os.path.join(args.out, "runs") if args.h5 else None
    if h5_dir:
        _prepare_out_dir(h5_dir)
    tasks = make_tasks(args.scene, points, fixed, h5_dir)
    rows, interrupted = _sweep_rows(tasks, args)
    meta = {"command": " ".join(["flexbody", "sweep", *args.argv]), "scene": args.scene, "grid": grids,
            "paired": bool(args.zip), "fixed": fixed,
            "cluster": args.scheduler or ("in process" if args.workers == 0 else
                                          f"local, {args.workers or os.cpu_count()} workers")}
    try:
        paths = write_table(rows, args.out, meta, args.json) + plot_sweep(rows, args.out)
    except OSError as exc:
        raise CliError(f"cannot write the sweep results to {args.out!r}: {exc.strerror or exc}") from None
    for path in paths:
        print(f"written          {path}")
    code = exit_code(rows)
    print(("sweep            " if code == 0 else "SWEEP NOT TRUSTED ") + summary_line(rows))
    return interrupted if interrupted is not None else code


# ----------------------------------------------------------------------------------------------------------
# compare
# ----------------------------------------------------------------------------------------------------------

def cmd_compare(args) -> int:
    """``flexbody compare SCENE --with exudyn``: hand over to ``flexbody.adapters.exudyn.compare_cli``
    (``--json -``: the comparison's JSON alone on standard output, the table on standard error)."""
    if args.json == "-":
        return _with_json_to_stdout(args, cmd_compare)
    params = _parse_sets(args.set or [])
    _check_outputs({"--json": args.json})
    try:
        from flexbody.adapters.exudyn import compare_cli
    except ImportError as exc:
        print(f"flexbody: compare --with exudyn is not available: {str(exc).splitlines()[0]} "
              "(needs flexbody.adapters.exudyn.compare_cli and pip install 'flexbody[exudyn]')", file=sys.stderr)
        return 2
    return int(compare_cli(args.scene, params, args.json, args.quiet))


# ----------------------------------------------------------------------------------------------------------
# buckling (wired as ``flexbody modes SCENE --buckling``)
# ----------------------------------------------------------------------------------------------------------

def cmd_buckling(args) -> int:
    """Linear buckling of a static scene's load pattern: ``args.scene``, ``args.set`` (KEY=VALUE list),
    ``args.count`` (modes, default 6) and ``args.json`` (file or None). Prints a table of the critical load
    factors (the loads of the scene at load factor 1 times the factor); returns 0, or 2 if the load pattern
    has no positive critical factor (nothing buckles under it)."""
    from flexbody.buckling import linear_buckling
    from flexbody.scenes.kernel_setup import warm_up_kernels
    t0 = time.perf_counter()
    count = 6 if getattr(args, "count", None) is None else args.count
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise CliError(f"--count must be an integer >= 1, got {count!r}")
    json_path = getattr(args, "json", None)
    source = _open(args.scene)
    _check_outputs({"--json": json_path}, _input_files(source))
    scene = _build(source, _parse_sets(getattr(args, "set", None) or []))
    if scene.kind != "static":
        raise CliError(f"linear buckling needs a static scene (its load pattern); {scene.name} is dynamic")
    warm_up_kernels(scene.model)
    try:
        result = linear_buckling(scene.model, count)
    except ValueError as exc:
        raise CliError(str(exc).splitlines()[0]) from None
    print(f"scene            {scene.name} (linear buckling about the unloaded state)")
    print(f"DoFs             {result.dofs}")
    print(f"wall time        {result.wall_time_s:.2f} s (total {time.perf_counter() - t0:.2f} s)")
    print(" mode   critical load factor")
    for i, lam in enumerate(result.load_factors, 1):
        print(f"{i:5d}   {lam:.6g}")
    if not len(result.load_factors):
        print("no positive critical load factor: the load pattern does not buckle the structure")
    if json_path:
        _write_json(json_path, result.as_dict(scene.name))
        print(f"written          {json_path}")
    return 0 if len(result.load_factors) else 2
# modes
# ----------------------------------------------------------------------------------------------------------

#: frames per period of a mode shape in the rerun recording
MODE_FRAMES = 24


def _scene_spin(scene):
    """(omega (3,), center (3,)) of a spinning dynamic scene, or (None, None).

    A steady-spin start gives both; a driven hub (prescribed motion) turns at its rate at the end of the run,
    measured by a one-sided difference of Q(t), about the axis through the centroid of its nodes."""
    import numpy as np

    from flexbody.spinning import SteadySpinStart
    if scene.kind != "dynamic":
        return None, None
    a = scene.analysis
    if isinstance(a.initial_state, SteadySpinStart):
        s = a.initial_state
        center = None if s.center is None else np.asarray(s.center, float)
        return np.asarray(s.angular_velocity, float), center
    for p in a.prescribed:
        t = a.end_time
        delta = 1e-6 * max(t, 1e-3)
        Q0, Q1 = (np.asarray(p.motion(t - k * delta)[0], float) for k in (1, 0))
        W = (Q1 - Q0) / delta @ Q1.T
        rate = np.array([W[2, 1], W[0, 2], W[1, 0]])
        if np.linalg.norm(rate) > 0:
            return rate, scene.model.body.mesh.nodes[p.nodes].mean(axis=0)
    return None, None


def _parse_load_factor(text):
    if text is None or text == "end":
        return text
    try:
        value = float(text)
    except ValueError:
        raise CliError(f"--load-factor must be a number or 'end', got {text!r}") from None
    if not math.isfinite(value):
        raise CliError(f"--load-factor must be finite, got {text!r}")
    return value


def modal_problem_of_scene(scene, omega: float | None = None, load_factor=None, quiet: bool = True):
    """The :class:`flexbody.modal.ModalProblem` of a scene.

    Static scenes: about the reference state (``load_factor`` None or 0), the equilibrium at a load factor
    (a load-controlled path through the scene's load levels below it), or the end of the scene's path
    ("end"). Dynamic scenes: about the steady spin of a spinning scene (its rate, or ``omega`` rad/s about its
    axis; ``omega`` = 0: at rest), else about the reference state (without the loads and gravity; ``omega``
    > 0 spins it about the z-axis through its mass centre)."""
    import numpy as np

    from flexbody import modal
    from flexbody.dynamics import DynamicModel
    if scene.kind == "static":
        if omega is not None:
            raise CliError("--omega needs a dynamic scene (a static scene has no mass at rest to spin)")
        model = scene.model
        if not model.body.material.density > 0:
            raise CliError(f"a modal analysis needs the mass: the material density of {scene.name} is "
                           f"{model.body.material.density!r}; set it (--set density=VALUE, material.density)")
        dyn = DynamicModel(model)
        if load_factor in (None, 0.0):
            return modal.modal_problem_at_rest(dyn)
        if load_factor == "end":
            summary = _run_scene(scene, quiet=quiet)
            result = summary.result
        else:
            from integrators.static import load_control
            levels = [f for f in scene.analysis.load_factors if 0 < f < load_factor] + [load_factor]
            result = load_control(model, levels, settings=scene.analysis.newton)
        if not result.converged:
            raise CliError(f"the static path did not reach the load factor: {result.message}")
        return modal.modal_problem_at_rest(dyn, result.state, result.load_factor)
    if load_factor not in (None, 0.0):
        raise CliError("--load-factor needs a static scene")
    a = scene.analysis
    dyn = DynamicModel(scene.model, point_masses=list(a.point_masses), mass=a.mass)
    spin, center = _scene_spin(scene)
    if omega is not None:
        axis = np.array([0.0, 0.0, 1.0]) if spin is None else spin / np.linalg.norm(spin)
        spin = omega * axis
    if spin is None or not np.any(spin):
        return modal.modal_problem_at_rest(dyn)
    try:
        return modal.modal_problem_in_spin(dyn, spin, center)
    except ValueError as exc:
        raise CliError(str(exc).splitlines()[0]) from None


def modes_record(scene_name: str, problem, modes, reports) -> dict:
    """The JSON record of one modal analysis."""
    return {"scene": scene_name, "frame": problem.frame, "omega": problem.spin_rate,
            "omega_vector": [float(v) for v in problem.omega], "dofs": int(problem.K.shape[0]),
            "frequencies_rad_s": [float(w) for w in modes.frequencies],
            "frequencies_hz": [float(w) / (2 * math.pi) for w in modes.frequencies],
            "stiffness_asymmetry": problem.asymmetry, "modes": [r.as_dict() for r in reports]}


def modes_lines(record: dict) -> list[str]:
    """The printed table of a modal analysis."""
    head = f"{record['scene']}: {len(record['modes'])} modes, {record['dofs']} DoFs, {record['frame']} frame"
    if record["omega"]:
        head += f", spin {record['omega']:.6g} rad/s"
    lines = [head, f"{'mode':>4s} {'omega rad/s':>14s} {'f Hz':>12s} {'diam':>5s} {'circ':>5s}"
             + (f" {'fwd rad/s':>12s} {'bwd rad/s':>12s}" if record["omega"] else "")]
    for k, m in enumerate(record["modes"], 1):
        nd = "-" if m["nodal_diameters"] is None else str(m["nodal_diameters"])
        nc = "-" if m["nodal_circles"] is None else str(m["nodal_circles"])
        line = f"{k:4d} {m['frequency_rad_s']:14.6g} {m['frequency_hz']:12.6g} {nd:>5s} {nc:>5s}"
        if record["omega"] and "inertial_forward_rad_s" in m:
            line += f" {m['inertial_forward_rad_s']:12.6g} {m['inertial_backward_rad_s']:12.6g}"
        lines.append(line)
    return lines


def _mode_animation_amplitude(problem) -> float:
    import numpy as np
    x = problem.dynamic.model.body.mesh.nodes
    return 0.1 * float(np.ptp(x, axis=0).max() or 1.0)


def write_modes_rerun(path: str, scene_name: str, modes) -> None:
    """Animated mode shapes in a rerun recording: mode k over one period on the ``time`` timeline from k to
    k + 1 (``MODE_FRAMES`` frames), amplitude a tenth of the body size; ``outputs/frequency_hz`` per mode."""
    import numpy as np

    from flexbody.outputs.rerun_log import RerunLogger
    p = modes.problem
    mesh = p.dynamic.model.body.mesh
    amp = _mode_animation_amplitude(p)
    step = 0
    with RerunLogger(path, mesh, scene_name, kind="dynamic", color_range=(0.0, amp)) as log:
        for k, w in enumerate(modes.frequencies):
            for j in range(MODE_FRAMES):
                phase = 2 * np.pi * j / MODE_FRAMES
                shown = p.state.copy()
                shown.x = p.state.x + amp * modes.nodal_displacements(k, phase)
                log.log_step(step, k + j / MODE_FRAMES, shown, {"mode": k + 1, "frequency_hz": w / (2 * np.pi)})
                step += 1


def write_modes_hdf5(path: str, scene_name: str, record: dict, modes) -> None:
    """The modes in an HDF5 file (docs/output_formats.md, format ``flexbody-modes``): the mesh as in
    ``flexbody-hdf5``, the equilibrium state, and per mode its frequency and complex nodal translations."""
    import h5py
    import numpy as np

    from flexbody.outputs.hdf5 import quaternions_from_matrices
    p = modes.problem
    mesh = p.dynamic.model.body.mesh
    shapes = np.stack([modes.nodal_displacements(k) + 1j * modes.nodal_displacements(k, -np.pi / 2)
                       for k in range(len(modes.frequencies))])
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "flexbody-modes"
        f.attrs["format_version"] = 1
        f.attrs["scene"] = scene_name
        f.attrs["frame"] = record["frame"]
        f.attrs["omega"] = np.asarray(record["omega_vector"])
        g = f.create_group("mesh")
        g.create_dataset("nodes", data=mesh.nodes)
        g.create_dataset("elements", data=mesh.elements.astype(np.int64))
        g.create_dataset("directors", data=mesh.directors)
        e = f.create_group("equilibrium")
        e.create_dataset("x", data=p.state.x)
        e.create_dataset("frames", data=quaternions_from_matrices(p.state.frames))
        m = f.create_group("modes")
        m.create_dataset("frequency_rad_s", data=np.asarray(record["frequencies_rad_s"]))
        m.create_dataset("shape_real", data=shapes.real)
        m.create_dataset("shape_imag", data=shapes.imag)
        for key in ("nodal_diameters", "nodal_circles"):
            m.create_dataset(key, data=np.array([-1 if r[key] is None else r[key] for r in record["modes"]]))


def _pyplot():
    from flexbody.outputs.report import _pyplot as pyplot
    plt = pyplot()
    if plt is None:
        raise CliError("--plot needs matplotlib: pip install 'flexbody[dev]' (or matplotlib)")
    return plt


def plot_mode_shapes(path: str, record: dict, modes, at_most: int = 6) -> None:
    """The first ``at_most`` mode shapes: the displacement normal to the body's mean plane (or its magnitude,
    for a body that is not flat) on the mesh projected on that plane."""
    import numpy as np
    plt = _pyplot()
    p = modes.problem
    x = p.state.x
    c = x.mean(axis=0)
    _, _, vt = np.linalg.svd(x - c, full_matrices=False)
    e1, e2, normal = vt
    flat = np.ptp((x - c) @ normal) <= 1e-6 * np.ptp(x, axis=0).max()
    tri = p.dynamic.model.body.mesh.elements[:, :3]
    k = min(at_most, len(modes.frequencies))
    cols = min(k, 3)
    fig, axes = plt.subplots((k + cols - 1) // cols, cols, figsize=(4 * cols, 3.6 * ((k + cols - 1) // cols)),
                             squeeze=False)
    for i, ax in enumerate(axes.ravel()):
        if i >= k:
            ax.axis("off")
            continue
        u = modes.nodal_displacements(i)
        value = u @ normal if flat else np.linalg.norm(u, axis=1)
        top = float(np.abs(value).max()) or 1.0
        ax.tripcolor((x - c) @ e1, (x - c) @ e2, tri, value, shading="gouraud", cmap="RdBu_r", vmin=-top, vmax=top)
        ax.set_aspect("equal")
        ax.set_title(f"mode {i + 1}: {record['frequencies_hz'][i]:.4g} Hz")
        ax.set_xticks([]), ax.set_yticks([])
    fig.suptitle(f"{record['scene']} ({record['frame']} frame)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_campbell(path: str, sweep: dict) -> None:
    """Frequencies (Hz) against the swept value; for a spin-rate sweep also the lines n Omega (n = 1..4)."""
    import numpy as np
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    values = np.asarray(sweep["values"], float)
    count = min(len(f) for f in sweep["frequencies_rad_s"])
    F = np.array([f[:count] for f in sweep["frequencies_rad_s"]]) / (2 * np.pi)
    for j in range(count):
        ax.plot(values, F[:, j], "o-", ms=3, lw=1)
    if sweep["parameter"] == "omega":
        for n in range(1, 5):
            ax.plot(values, n * values / (2 * np.pi), "k:", lw=0.8)
            ax.annotate(f"{n}$\\Omega$", (values[-1], n * values[-1] / (2 * np.pi)), fontsize=8)
        ax.set_xlabel("spin rate $\\Omega$ (rad/s)")
    else:
        ax.set_xlabel(sweep["parameter"])
    ax.set_ylabel(f"frequency (Hz, {sweep['frame']} frame)")
    ax.set_title(f"Campbell diagram: {sweep['scene']}")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _parse_sweep(text: str) -> tuple[str, list]:
    if "=" not in text:
        raise CliError(f"--sweep expects KEY=V1,V2,..., got {text!r}")
    key, values = text.split("=", 1)
    key = key.strip()
    parsed = [_parse_value(v.strip()) for v in values.split(",") if v.strip()]
    if not key or not parsed:
        raise CliError(f"--sweep expects KEY=V1,V2,..., got {text!r}")
    if key == "omega":
        for v in parsed:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise CliError(f"--sweep omega values must be finite numbers >= 0 (rad/s), got {v!r}")
    return key, parsed


def _modes_once(source, params: dict, args, omega, quiet: bool):
    scene = _build(source, params)
    from flexbody import modal
    try:
        problem = modal_problem_of_scene(scene, omega, _parse_load_factor(args.load_factor), quiet)
        modes = modal.solve_modes(problem, args.count, args.shift)
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        raise CliError(f"the modal analysis failed: {_run_failure(exc)}") from None
    reports = modal.describe_modes(modes)
    return scene, modes_record(scene.name, problem, modes, reports), modes


def cmd_modes(args) -> int:
    """``flexbody modes``: natural frequencies and mode shapes about an equilibrium (one analysis), or a
    Campbell diagram (``--sweep``), or with ``--buckling`` the linear buckling of a static scene's load pattern
    (:func:`cmd_buckling`). Exit code 0, or 1 (bad input / an analysis that fails). ``--json -``: the JSON
    alone on standard output, the printed table on standard error."""
    if args.json == "-":
        return _with_json_to_stdout(args, cmd_modes)
    if getattr(args, "buckling", False):
        others = [name for name, value in (("--omega", args.omega), ("--load-factor", args.load_factor),
                                           ("--sweep", args.sweep), ("--shift", args.shift), ("--plot", args.plot),
                                           ("--rerun", args.rerun), ("--h5", args.h5)) if value is not None]
        if others:
            raise CliError(f"--buckling takes --set, --count and --json only, not {others[0]}")
        return cmd_buckling(args)
    t0 = time.perf_counter()
    params = _parse_sets(args.set or [])
    if isinstance(args.count, bool) or args.count < 1:
        raise CliError(f"--count must be an integer >= 1, got {args.count!r}")
    if args.omega is not None and not (math.isfinite(args.omega) and args.omega >= 0):
        raise CliError(f"--omega must be a finite number >= 0 (rad/s), got {args.omega!r}")
    if args.shift is not None and not (math.isfinite(args.shift) and args.shift > 0):
        raise CliError(f"--shift must be a finite number > 0 ((rad/s)^2), got {args.shift!r}")
    outputs = {"--json": args.json, "--h5": args.h5, "--rerun": args.rerun, "--plot": args.plot}
    source = _open(args.scene)
    _check_outputs(outputs, _input_files(source))
    if args.sweep and (args.rerun or args.h5):
        raise CliError("--rerun and --h5 write the modes of one analysis, not of a --sweep")
    if args.rerun:
        import importlib.util
        if importlib.util.find_spec("rerun") is None:
            raise CliError("--rerun needs the rerun SDK: pip install 'flexbody[rerun]' (or rerun-sdk)")
    if args.sweep:
        key, values = _parse_sweep(args.sweep)
        runs = []
        for v in values:
            point = dict(params) if key == "omega" else {**params, key: v}
            omega = float(v) if key == "omega" else args.omega
            _, record, _ = _modes_once(source, point, args, omega, args.quiet)
            runs.append(record)
            if not args.quiet:
                print(f"  {key} = {v}: " + ", ".join(f"{w:.5g}" for w in record["frequencies_rad_s"]) + " rad/s",
                      file=sys.stderr, flush=True)
        sweep = {"scene": runs[0]["scene"], "parameter": key, "values": values, "frame": runs[-1]["frame"],
                 "frequencies_rad_s": [r["frequencies_rad_s"] for r in runs], "runs": runs}
        print(f"Campbell diagram of {sweep['scene']}: frequencies (rad/s) against {key}")
        for v, r in zip(values, runs):
            print(f"{key} = {v!s:>10s}  " + " ".join(f"{w:10.5g}" for w in r["frequencies_rad_s"]))
        if args.json:
            _write_json(args.json, sweep)
            print(f"written          {args.json}")
        if args.plot:
            plot_campbell(args.plot, sweep)
            print(f"written          {args.plot}")
        print(f"total time       {time.perf_counter() - t0:.2f} s")
        return 0
    scene, record, modes = _modes_once(source, params, args, args.omega, args.quiet)
    for line in modes_lines(record):
        print(line)
    if args.json:
        _write_json(args.json, record)
        print(f"written          {args.json}")
    if args.rerun:
        write_modes_rerun(args.rerun, scene.name, modes)
        print(f"written          {args.rerun}")
    if args.h5:
        write_modes_hdf5(args.h5, scene.name, record, modes)
        print(f"written          {args.h5}")
    if args.plot:
        plot_mode_shapes(args.plot, record, modes)
        print(f"written          {args.plot}")
    print(f"total time       {time.perf_counter() - t0:.2f} s")
    return 0


def add_modes_parser(sub) -> None:
    """The ``modes`` subcommand's arguments (one function per analysis kind: see :func:`cmd_modes`)."""
    modes = sub.add_parser("modes", help="natural frequencies and mode shapes about an equilibrium or a steady spin")
    modes.add_argument("scene", help="built-in scene or .toml/.py scene file")
    modes.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter (repeatable)")
    modes.add_argument("--count", type=int, default=10, metavar="N", help="number of modes (default 10)")
    modes.add_argument("--omega", type=float, metavar="RAD_S",
                       help="spin rate about the scene's spin axis (dynamic scenes; 0: at rest)")
    modes.add_argument("--load-factor", metavar="L|end",
                       help="static scenes: the equilibrium at load factor L, or at the end of the path "
                            "(default: the unloaded reference state)")
    modes.add_argument("--sweep", metavar="KEY=V1,V2,...",
                       help="Campbell diagram: the frequencies against a --set parameter, or omega (the spin rate)")
    modes.add_argument("--shift", type=float, metavar="S",
                       help="the eigen-solver's shift in (rad/s)^2 (default: from the model)")
    modes.add_argument("--json", metavar="FILE", help="write the frequencies and modes (or the sweep) as JSON "
                       "('-': to standard output, the printed table then goes to standard error)")
    modes.add_argument("--plot", metavar="FILE.png", help="plot the mode shapes (or the Campbell diagram)")
    modes.add_argument("--rerun", metavar="FILE.rrd", help="animated mode shapes in a rerun recording")
    modes.add_argument("--h5", metavar="FILE.h5", help="the mode shapes in an HDF5 file")
    modes.add_argument("--buckling", action="store_true",
                       help="linear buckling of a static scene's load pattern: the critical load factors and modes")
    modes.add_argument("--quiet", action="store_true", help="no progress output")
    modes.set_defaults(func=cmd_modes)


# ----------------------------------------------------------------------------------------------------------
# main
# ----------------------------------------------------------------------------------------------------------

def _cluster_arguments(parser, default: str) -> None:
    """--workers / --scheduler of ``sweep`` and ``bench``."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--workers", type=int, metavar="N", help=f"a local Dask cluster of N worker processes, "
                       f"0: in this process ({default})")
    group.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask cluster: its scheduler's "
                       "address (tcp://host:8786) or scheduler file (.json)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="flexbody", description="List, run, bench and compare shell scenes.",
                                     epilog="Scene files: docs/scenes.md. Output formats: docs/output_formats.md.")
    from flexbody import __version__
    parser.add_argument("--version", action="version", version=f"flexbody {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the built-in scenes").set_defaults(func=cmd_list)
    show = sub.add_parser("show", help="what a scene models: its parameters (defaults, units) and reference")
    show.add_argument("scene", help="built-in scene or .toml/.py scene file")
    show.set_defaults(func=cmd_show)

    run = sub.add_parser("run", help="run a scene and report error against run time")
    run.add_argument("scene", nargs="?", default=DEFAULT_SCENE,
                     help=f"built-in scene or .toml/.py scene file (default {DEFAULT_SCENE})")
    run.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter (repeatable)")
    run.add_argument("--json", metavar="FILE", help="write the run summary as JSON ('-': to standard output, "
                     "the printed summary then goes to standard error)")
    run.add_argument("--h5", metavar="FILE.h5", help="write the mesh and every step to an HDF5 file")
    run.add_argument("--rerun", metavar="FILE.rrd", help="write a rerun recording (needs rerun-sdk)")
    run.add_argument("--directors", action="store_true", help="with --rerun: also log the directors")
    run.add_argument("--rerun-color", choices=["deformation", "displacement", "stress"], default="deformation",
                     help="with --rerun: colour by the displacement without the rigid motion (default), by |x - X0| "
                     "or by the von Mises fibre stress")
    run.add_argument("--xdmf", metavar="FILE.xdmf", help="write an XDMF time series for ParaView (arrays in "
                     "FILE.xdmf.h5; needs meshio)")
    run.add_argument("--stresses", action="store_true", help="with --h5: also write the stress resultants and "
                     "reactions of every step")
    run.add_argument("--restart", metavar="FILE.h5[:STEP]", help="continue from a step (default the last) "
                     "saved in the --h5 file of an earlier run of this scene")
    run.add_argument("--quiet", action="store_true", help="no progress output")
    run.set_defaults(func=cmd_run)

    bench = sub.add_parser("bench", help="run scenes on a sequence of meshes; write report.md and plots")
    bench.add_argument("scenes", nargs="*", help="scenes (default: the built-in scenes, the static ones on their "
                       "bench meshes, the dynamic ones on time steps dt, dt/2, dt/4)")
    bench.add_argument("--refine", action="append", metavar="KEY=V1,V2,...",
                       help="the mesh sequence, e.g. --refine nx=4,8,16 (repeat for more keys, equal lengths)")
    bench.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a parameter in every run")
    bench.add_argument("--out", default="bench", metavar="DIR", help="report directory (default ./bench)")
    bench.add_argument("--quiet", action="store_true", help="no progress output")
    _cluster_arguments(bench, "default: serial, in this process")
    bench.set_defaults(func=cmd_bench)

    sweep = sub.add_parser("sweep", help="run a scene over a grid of parameters on a Dask cluster; one table")
    sweep.add_argument("scene", help="built-in scene or .toml/.py scene file")
    sweep.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                       help="a swept parameter and its values (repeat for more; all combinations)")
    sweep.add_argument("--zip", action="store_true", help="pair the --grid lists (equal lengths) instead of "
                       "taking all combinations")
    sweep.add_argument("--set", action="append", metavar="KEY=VALUE", help="a fixed parameter of every run")
    sweep.add_argument("--out", default="sweep", metavar="DIR", help="results directory (default ./sweep)")
    sweep.add_argument("--json", metavar="FILE", help="also write the table as JSON to FILE ('-': to standard "
                       "output, the printed lines then go to standard error)")
    sweep.add_argument("--h5", action="store_true", help="write each run's HDF5 file to DIR/runs/")
    sweep.add_argument("--quiet", action="store_true", help="no progress output")
    _cluster_arguments(sweep, "default: a local cluster, one worker per core")
    sweep.set_defaults(func=cmd_sweep)

    compare = sub.add_parser("compare", help="compare a scene with another code")
    compare.add_argument("scene", help="built-in scene or scene file")
    compare.add_argument("--with", dest="other", choices=["exudyn"], default="exudyn",
                         help="the code to compare with (exudyn)")
    compare.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    compare.add_argument("--json", metavar="FILE", help="write the comparison as JSON ('-': to standard output, "
                         "the table then goes to standard error)")
    compare.add_argument("--quiet", action="store_true", help="no progress output")
    compare.set_defaults(func=cmd_compare)
    add_modes_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    args.argv = argv[1:]
    try:
        return args.func(args)
    except CliError as exc:
        raise SystemExit(f"flexbody: {exc}") from None


if __name__ == "__main__":
    sys.exit(main())
