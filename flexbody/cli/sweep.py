"""``flexbody sweep``: one scene over a grid of parameters, its runs as independent tasks (docs/sweeps.md)."""

from __future__ import annotations

import os

from flexbody.cli.cluster import check_workers, run_tasks
from flexbody.cli.errors import CliError
from flexbody.cli.json_stdout import with_json_to_stdout
from flexbody.cli.outputs import check_outputs, prepare_out_dir, print_written
from flexbody.cli.scene_input import input_files, open_source
from flexbody.cli.values import parse_grid, parse_sets


def check_sweep_keys(source, keys: list[str]) -> None:
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
        return with_json_to_stdout(args, cmd_sweep)
    from flexbody.sweep import grid_points, make_tasks, plot_sweep, summary_line, write_table, exit_code
    check_workers(args)
    fixed = parse_sets(args.set or [])
    grids = parse_grid(args.grid or [])
    try:
        points = grid_points(grids, paired=args.zip)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    source = open_source(args.scene)
    check_sweep_keys(source, [*fixed, *grids])
    check_outputs({"--json": args.json}, input_files(source))
    prepare_out_dir(args.out)
    h5_dir = os.path.join(args.out, "runs") if args.h5 else None
    if h5_dir:
        prepare_out_dir(h5_dir)
    tasks = make_tasks(args.scene, points, fixed, h5_dir)
    rows, interrupted = run_tasks(tasks, args)
    meta = {"command": " ".join(["flexbody", "sweep", *args.argv]), "scene": args.scene, "grid": grids,
            "paired": bool(args.zip), "fixed": fixed,
            "cluster": args.scheduler or ("in process" if args.workers == 0 else
                                          f"local, {args.workers or os.cpu_count()} workers")}
    try:
        paths = write_table(rows, args.out, meta, args.json) + plot_sweep(rows, args.out)
    except OSError as exc:
        raise CliError(f"cannot write the sweep results to {args.out!r}: {exc.strerror or exc}") from None
    for path in paths:
        print_written(path)
    code = exit_code(rows)
    print(("sweep            " if code == 0 else "SWEEP NOT TRUSTED ") + summary_line(rows))
    return interrupted if interrupted is not None else code
