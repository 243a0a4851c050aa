"""The ``flexbody`` command: list, run, bench and compare scenes.

    flexbody list
    flexbody run [SCENE] [--set KEY=VALUE ...] [--json FILE] [--h5 FILE.h5] [--rerun FILE.rrd] [--quiet]
                 [--xdmf FILE.xdmf] [--stresses] [--restart FILE.h5[:STEP]]
    flexbody bench [SCENE ...] [--refine KEY=V1,V2,...] [--set KEY=VALUE ...] [--out DIR] [--quiet]
    flexbody compare SCENE --with exudyn [--set KEY=VALUE ...] [--json FILE] [--quiet]

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
from contextlib import contextmanager
import json
import math
import os
import signal
import sys
import time

DEFAULT_SCENE = "cantilever_end_moment"

#: the default mesh sequences of ``flexbody bench`` for the built-in scenes (kept small: all five take
#: about two minutes)
BENCH_MESHES: dict[str, list[dict]] = {
    "cantilever_end_moment": [dict(nx=4), dict(nx=8), dict(nx=16)],
    "cantilever_end_shear": [dict(nx=4), dict(nx=8), dict(nx=16)],
    "slit_annular_plate": [dict(n_radial=3, n_circ=9), dict(n_radial=5, n_circ=15)],
    "pullout_cylinder": [dict(n_circ=6, n_axial=4), dict(n_circ=8, n_axial=6), dict(n_circ=12, n_axial=8)],
    "hemisphere": [dict(n_meridian=8, n_circ=8), dict(n_meridian=12, n_circ=12)],
}


#: how many time steps a bench of a dynamic scene runs: dt, dt/2, dt/4 (dt: the scene's, or --set dt=...)
BENCH_TIME_STEPS = 3


def _default_bench_scenes() -> list[str]:
    from flexbody.scenes.builtin import DYNAMIC
    return list(BENCH_MESHES) + list(DYNAMIC)


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
    steps' clock starts when the kernels are ready."""

    def __init__(self, prefix: str = "", total: int | None = None) -> None:
        self.prefix = prefix
        self.total = total          # the number of steps, if known: the lines then show k/N and the time left
        self.t0 = time.perf_counter()

    def notify(self, notice) -> None:
        """Show a :class:`flexbody.scenes.scene.CompileNotice`; restart the clock once the kernels are ready."""
        print(f"{self.prefix}  {notice}", file=sys.stderr, flush=True)
        if notice.done:
            self.t0 = time.perf_counter()

    def __call__(self, rec) -> None:
        if hasattr(rec, "time"):   # a dynamic step record
            where = f"time {rec.time:10.5g} s  iterations {rec.iterations:2d}  energy {rec.total_energy:11.5g}"
        else:
            where = f"load factor {rec.load_factor:8.4f}  iterations {rec.iterations:2d}"
        elapsed = time.perf_counter() - self.t0
        if self.total:
            left = elapsed / max(rec.step, 1) * max(self.total - rec.step, 0)
            print(f"{self.prefix}  step {rec.step:4d}/{self.total}  {where}  left ~{left:7.1f} s  "
                  f"elapsed {elapsed:7.2f} s", file=sys.stderr, flush=True)
        else:
            print(f"{self.prefix}  step {rec.step:4d}  {where}  {elapsed:7.2f} s", file=sys.stderr, flush=True)


def _step_count(scene) -> int | None:
    """The number of steps of a run, where it is known in advance (load control; a dynamic run)."""
    a = scene.analysis
    if scene.kind == "static":
        return len(a.load_factors) if a.method == "load_control" else None
    steps = getattr(a, "end_time", 0.0) / getattr(a, "time_step", 0.0) if getattr(a, "time_step", 0.0) else 0
    return int(math.floor(steps + 1e-9)) or None


def _progress_printer(quiet: bool, prefix: str = "", total: int | None = None) -> _Progress | None:
    """The progress printer on stderr (None with --quiet)."""
    return None if quiet else _Progress(prefix, total)


def _run_scene(scene, on_step=None, quiet: bool = False, prefix: str = "", started: float | None = None,
               restart=None):
    """``run_scene`` with the progress and compilation notices on stderr (none with ``quiet``)."""
    from flexbody.scenes.scene import run_scene
    progress = _progress_printer(quiet, prefix, _step_count(scene))
    notify = None if progress is None else progress.notify
    extra = {} if restart is None else {"restart": restart}
    return run_scene(scene, on_step=on_step, progress=progress, notify=notify, started=started, **extra)


# ----------------------------------------------------------------------------------------------------------
# list
# ----------------------------------------------------------------------------------------------------------

def cmd_list(args) -> int:
    """``flexbody list``: one line per built-in scene."""
    from flexbody.scenes.builtin import BUILTIN
    for name, builder in BUILTIN.items():
        doc = (builder.__doc__ or "").strip().splitlines()[0]
        print(f"{name:24s} {doc}")
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
    from flexbody.scenes.builtin import BUILTIN
    model = scene.model
    lines = [f"scene            {scene.name} ({source.kind})", f"models           {scene.description}"]
    if source.kind == "builtin":
        doc = (BUILTIN[source.name].__doc__ or "").strip().splitlines()[0]
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
        func = BUILTIN[source.name] if source.kind == "builtin" else None
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
                   f"rho_inf {d['rho_inf']:g}, {d['policy']} iteration matrix")
    else:
        reached = f"load factor reached {d['load_factor']:.4g}"
    lines = [
        f"scene            {d['scene']}" + (" (dynamic)" if dynamic else ""),
        f"DoFs / elements  {d['dofs']} / {d['elements']}",
        f"steps            {d['steps']}  ({reached})",
        f"Newton           {d['newton_iterations']} iterations, {d['tangent_updates']} tangent updates, "
        f"{d['factorizations']} factorizations" + (f" ({d['newton_iteration']} iteration)"
                                                   if "newton_iteration" in d else ""),
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
        if scene.kind == "static" and scene.analysis.method != "load_control":
            raise CliError("--restart continues a load-control path only; this scene uses arc length")
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
    if source.kind == "builtin" and source.name in BENCH_MESHES:
        return BENCH_MESHES[source.name]
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
    needs_scene = not refine and not (source.kind == "builtin" and source.name in BENCH_MESHES)
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


# ----------------------------------------------------------------------------------------------------------
# compare
# ----------------------------------------------------------------------------------------------------------

def cmd_compare(args) -> int:
    """``flexbody compare SCENE --with exudyn``: hand over to ``flexbody.adapters.exudyn.compare_cli``."""
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
    from flexbody.scenes.scene import warm_up_kernels
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


# ----------------------------------------------------------------------------------------------------------
# main
# ----------------------------------------------------------------------------------------------------------

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
    bench.add_argument("scenes", nargs="*", help=f"scenes (default: {', '.join(BENCH_MESHES)} and the dynamic "
                       "scenes, on time steps dt, dt/2, dt/4)")
    bench.add_argument("--refine", action="append", metavar="KEY=V1,V2,...",
                       help="the mesh sequence, e.g. --refine nx=4,8,16 (repeat for more keys, equal lengths)")
    bench.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a parameter in every run")
    bench.add_argument("--out", default="bench", metavar="DIR", help="report directory (default ./bench)")
    bench.add_argument("--quiet", action="store_true", help="no progress output")
    bench.set_defaults(func=cmd_bench)

    compare = sub.add_parser("compare", help="compare a scene with another code")
    compare.add_argument("scene", help="built-in scene or scene file")
    compare.add_argument("--with", dest="other", choices=["exudyn"], default="exudyn",
                         help="the code to compare with (exudyn)")
    compare.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    compare.add_argument("--json", metavar="FILE", help="write the comparison as JSON")
    compare.add_argument("--quiet", action="store_true", help="no progress output")
    compare.set_defaults(func=cmd_compare)
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
