"""``flexbody run``: one scene, with its output files written step by step, and its summary."""

from __future__ import annotations

import importlib.util
import signal
import sys
import time

from flexbody.cli.errors import CliError, run_failure
from flexbody.cli.outputs import check_outputs, print_written, require_rerun, write_json, write_json_stdout
from flexbody.cli.progress import run_with_progress
from flexbody.cli.scene_input import build_scene, input_files, open_source
from flexbody.cli.stop_signals import StopSignals, Stopped
from flexbody.cli.summary import summary_lines
from flexbody.cli.values import parse_sets


def cmd_run(args) -> int:
    """``flexbody run``: check the output paths, build the scene, run it with the requested files written
    step by step, print the summary. Returns 0, 2 (not converged, or stopped because the --h5 file cannot
    take a step), 3 (completed, but not to be trusted: ``summary.warnings``), 1 (an error inside the
    analysis) or 128 + the signal number (SIGINT, SIGTERM)."""
    t0 = time.perf_counter()
    params = parse_sets(args.set or [])
    json_to_stdout = args.json == "-"
    outputs = {"--json": None if json_to_stdout else args.json, "--h5": args.h5, "--rerun": args.rerun}
    xdmf = getattr(args, "xdmf", None)
    if xdmf:
        from flexbody.outputs.xdmf import heavy_data_path
        outputs.update({"--xdmf": xdmf, "--xdmf (its arrays)": heavy_data_path(xdmf)})
    restart_spec = getattr(args, "restart", None)
    if getattr(args, "stresses", False) and not args.h5:
        raise CliError("--stresses writes the stresses to the --h5 file: give --h5 FILE.h5 too")
    source = open_source(args.scene)
    restart_input = {}
    if restart_spec:
        from flexbody.outputs.restart import parse_restart
        restart_input = {"--restart file": parse_restart(restart_spec)[0]}
    check_outputs(outputs, {**input_files(source), **restart_input})
    if args.rerun:
        require_rerun()
    if xdmf and importlib.util.find_spec("meshio") is None:
        raise CliError("--xdmf needs meshio: pip install 'flexbody[mesh]' (or meshio)")
    scene = build_scene(source, params)
    check_outputs(outputs, {**input_files(source, scene), **restart_input})
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
    signals = StopSignals()

    def on_step(rec, state, history) -> None:
        with signals.deferred():
            recorder.on_step(rec, state, history)

    with recorder, signals.installed():
        try:
            summary = run_with_progress(scene, on_step, args.quiet, started=t0, restart=restart)
        except Stopped as exc:
            failure, code = f"stopped by {signal.Signals(exc.signum).name}", 128 + exc.signum
        except KeyboardInterrupt:
            failure, code = "interrupted", 130
        except OutputStopped as exc:
            failure, code = f"the run stopped: {exc}", 2
        except (ValueError, ArithmeticError, RuntimeError, OSError) as exc:
            failure, code = f"the analysis failed: {run_failure(exc)}", 1
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
        print_written(path, file=human)
    if json_to_stdout:
        write_json_stdout(summary.as_dict())
    elif args.json:
        write_json(args.json, summary.as_dict())
        print_written(args.json)
    if not summary.result.converged:
        return 2
    return 3 if summary.warnings else 0
