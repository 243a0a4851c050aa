"""The ``flexbody`` command: list, run, bench and compare scenes.

    flexbody list
    flexbody run [SCENE] [--set KEY=VALUE ...] [--json FILE] [--h5 FILE.h5] [--rerun FILE.rrd] [--quiet]
    flexbody bench [SCENE ...] [--refine KEY=V1,V2,...] [--set KEY=VALUE ...] [--out DIR] [--quiet]
    flexbody compare SCENE --with exudyn [--set KEY=VALUE ...] [--json FILE] [--quiet]
    flexbody modes SCENE [--set K=V ...] [--count N] [--omega W | --load-factor L|end] [--sweep KEY=V1,...]
                   [--json FILE] [--plot FILE.png] [--rerun FILE.rrd] [--h5 FILE.h5]

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

    def __init__(self, prefix: str = "") -> None:
        self.prefix = prefix
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
        print(f"{self.prefix}  step {rec.step:4d}  {where}  {time.perf_counter() - self.t0:7.2f} s",
              file=sys.stderr, flush=True)


def _progress_printer(quiet: bool, prefix: str = "") -> _Progress | None:
    """The progress printer on stderr (None with --quiet)."""
    return None if quiet else _Progress(prefix)


def _run_scene(scene, on_step=None, quiet: bool = False, prefix: str = "", started: float | None = None):
    """``run_scene`` with the progress and compilation notices on stderr (none with ``quiet``)."""
    from flexbody.scenes.scene import run_scene
    progress = _progress_printer(quiet, prefix)
    notify = None if progress is None else progress.notify
    return run_scene(scene, on_step=on_step, progress=progress, notify=notify, started=started)


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
    if not d["converged"]:
        lines.append(f"NOT CONVERGED    {d['message']}")
    if d.get("warnings"):
        lines.append(f"WARNING          not to be trusted: {'; '.join(d['warnings'])} (docs/robustness.md)")
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
    outputs = {"--json": args.json, "--h5": args.h5, "--rerun": args.rerun}
    source = _open(args.scene)
    _check_outputs(outputs, _input_files(source))
    if args.rerun:
        import importlib.util
        if importlib.util.find_spec("rerun") is None:  # looked up, not imported
            raise CliError("--rerun needs the rerun SDK: pip install 'flexbody[rerun]' (or rerun-sdk)")
    scene = _build(source, params)
    _check_outputs(outputs, _input_files(source, scene))
    from flexbody.outputs.recording import OutputStopped, RunRecorder
    try:
        recorder = RunRecorder(scene, h5=args.h5, rerun=args.rerun, directors=args.directors,
                               warn=lambda message: print(f"flexbody: warning: {message}", file=sys.stderr))
    except (OSError, ImportError, ValueError) as exc:
        raise CliError(str(exc).splitlines()[0]) from None
    failure = None
    signals = _StopSignals()

    def on_step(rec, state, history) -> None:
        with signals.deferred():
            recorder.on_step(rec, state, history)

    with recorder, signals.installed():
        try:
            summary = _run_scene(scene, on_step, args.quiet, started=t0)
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
    for line in summary_lines(summary):
        print(line)
    print(f"total time       {time.perf_counter() - t0:.2f} s (including setup and compilation)")
    for path in recorder.paths:
        print(f"written          {path}")
    if args.json:
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
    dyn = DynamicModel(scene.model, point_masses=list(a.point_masses))
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
    Campbell diagram (``--sweep``). Exit code 0, or 1 (bad input / an analysis that fails)."""
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
    modes.add_argument("--json", metavar="FILE", help="write the frequencies and modes (or the sweep) as JSON")
    modes.add_argument("--plot", metavar="FILE.png", help="plot the mode shapes (or the Campbell diagram)")
    modes.add_argument("--rerun", metavar="FILE.rrd", help="animated mode shapes in a rerun recording")
    modes.add_argument("--h5", metavar="FILE.h5", help="the mode shapes in an HDF5 file")
    modes.add_argument("--quiet", action="store_true", help="no progress output")
    modes.set_defaults(func=cmd_modes)


# ----------------------------------------------------------------------------------------------------------
# main
# ----------------------------------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="flexbody", description="List, run, bench and compare shell scenes.",
                                     epilog="Scene files: docs/scenes.md. Output formats: docs/output_formats.md.")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the built-in scenes").set_defaults(func=cmd_list)

    run = sub.add_parser("run", help="run a scene and report error against run time")
    run.add_argument("scene", nargs="?", default=DEFAULT_SCENE,
                     help=f"built-in scene or .toml/.py scene file (default {DEFAULT_SCENE})")
    run.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter (repeatable)")
    run.add_argument("--json", metavar="FILE", help="write the run summary as JSON")
    run.add_argument("--h5", metavar="FILE.h5", help="write the mesh and every step to an HDF5 file")
    run.add_argument("--rerun", metavar="FILE.rrd", help="write a rerun recording (needs rerun-sdk)")
    run.add_argument("--directors", action="store_true", help="with --rerun: also log the directors")
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
