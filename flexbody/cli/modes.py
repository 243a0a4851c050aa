"""``flexbody modes``: natural frequencies and mode shapes of a scene, a Campbell diagram (``--sweep``), or
with ``--buckling`` its linear buckling (:mod:`flexbody.cli.buckling`)."""

from __future__ import annotations

import math
import sys
import time

from flexbody.cli.buckling import cmd_buckling
from flexbody.cli.errors import CliError, run_failure
from flexbody.cli.json_stdout import with_json_to_stdout
from flexbody.cli.modal_problem import modal_problem_of_scene
from flexbody.cli.mode_files import write_modes_hdf5, write_modes_rerun
from flexbody.cli.mode_plots import plot_campbell, plot_mode_shapes
from flexbody.cli.outputs import check_outputs, print_written, require_rerun, write_json
from flexbody.cli.scene_input import build_scene, input_files, open_source
from flexbody.cli.values import parse_load_factor, parse_sets, parse_sweep


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



def _modes_once(source, params: dict, args, omega, quiet: bool):
    """One modal analysis of ``source`` with ``params``: (scene, its JSON record, its modes)."""
    scene = build_scene(source, params)
    from flexbody import modal
    try:
        problem = modal_problem_of_scene(scene, omega, parse_load_factor(args.load_factor), quiet)
        modes = modal.solve_modes(problem, args.count, args.shift)
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        raise CliError(f"the modal analysis failed: {run_failure(exc)}") from None
    reports = modal.describe_modes(modes)
    return scene, modes_record(scene.name, problem, modes, reports), modes



def _check_arguments(args) -> None:
    """The numbers of ``flexbody modes`` (without ``--buckling``) in their ranges."""
    if isinstance(args.count, bool) or args.count < 1:
        raise CliError(f"--count must be an integer >= 1, got {args.count!r}")
    if args.omega is not None and not (math.isfinite(args.omega) and args.omega >= 0):
        raise CliError(f"--omega must be a finite number >= 0 (rad/s), got {args.omega!r}")
    if args.shift is not None and not (math.isfinite(args.shift) and args.shift > 0):
        raise CliError(f"--shift must be a finite number > 0 ((rad/s)^2), got {args.shift!r}")


def _buckling(args) -> int:
    """``flexbody modes --buckling``: only --set, --count and --json go with it."""
    others = [name for name, value in (("--omega", args.omega), ("--load-factor", args.load_factor),
                                       ("--sweep", args.sweep), ("--shift", args.shift), ("--plot", args.plot),
                                       ("--rerun", args.rerun), ("--h5", args.h5)) if value is not None]
    if others:
        raise CliError(f"--buckling takes --set, --count and --json only, not {others[0]}")
    return cmd_buckling(args)


def _campbell(source, params: dict, args) -> None:
    """``--sweep KEY=V1,...``: one modal analysis per value, the table of their frequencies, the JSON and
    the plot of the Campbell diagram."""
    key, values = parse_sweep(args.sweep)
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
        write_json(args.json, sweep)
        print_written(args.json)
    if args.plot:
        plot_campbell(args.plot, sweep)
        print_written(args.plot)


def _one_analysis(source, params: dict, args) -> None:
    """One modal analysis: its table, and the files asked for."""
    scene, record, modes = _modes_once(source, params, args, args.omega, args.quiet)
    for line in modes_lines(record):
        print(line)
    if args.json:
        write_json(args.json, record)
        print_written(args.json)
    if args.rerun:
        write_modes_rerun(args.rerun, scene.name, modes)
        print_written(args.rerun)
    if args.h5:
        write_modes_hdf5(args.h5, scene.name, record, modes)
        print_written(args.h5)
    if args.plot:
        plot_mode_shapes(args.plot, record, modes)
        print_written(args.plot)


def cmd_modes(args) -> int:
    """``flexbody modes``: natural frequencies and mode shapes about an equilibrium (one analysis), or a
    Campbell diagram (``--sweep``), or with ``--buckling`` the linear buckling of a static scene's load pattern
    (:func:`flexbody.cli.buckling.cmd_buckling`). Exit code 0, or 1 (bad input / an analysis that fails).
    ``--json -``: the JSON alone on standard output, the printed table on standard error."""
    if args.json == "-":
        return with_json_to_stdout(args, cmd_modes)
    if getattr(args, "buckling", False):
        return _buckling(args)
    t0 = time.perf_counter()
    params = parse_sets(args.set or [])
    _check_arguments(args)
    outputs = {"--json": args.json, "--h5": args.h5, "--rerun": args.rerun, "--plot": args.plot}
    source = open_source(args.scene)
    check_outputs(outputs, input_files(source))
    if args.sweep and (args.rerun or args.h5):
        raise CliError("--rerun and --h5 write the modes of one analysis, not of a --sweep")
    if args.rerun:
        require_rerun()
    if args.sweep:
        _campbell(source, params, args)
    else:
        _one_analysis(source, params, args)
    print(f"total time       {time.perf_counter() - t0:.2f} s")
    return 0
