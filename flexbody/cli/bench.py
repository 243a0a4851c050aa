"""``flexbody bench``: scenes on a sequence of meshes (or time steps), then a report with plots."""

from __future__ import annotations

import math
import sys

from flexbody.cli.cluster import check_workers, run_tasks
from flexbody.cli.errors import run_failure
from flexbody.cli.outputs import prepare_out_dir, print_written
from flexbody.cli.progress import run_with_progress
from flexbody.cli.scene_input import build_scene, open_source
from flexbody.cli.values import parse_refine, parse_sets

#: how many time steps a bench of a dynamic scene runs: dt, dt/2, dt/4 (dt: the scene's, or --set dt=...)
BENCH_TIME_STEPS = 3


def default_bench_scenes() -> list[str]:
    """The scenes of ``flexbody bench`` without scene names (:func:`flexbody.scenes.registry.bench_scenes`)."""
    from flexbody.scenes.registry import bench_scenes
    return list(bench_scenes())


def _bench_meshes(source) -> list[dict]:
    """A built-in scene's default mesh sequence of ``flexbody bench`` (flexbody.scenes.registry), else []."""
    from flexbody.scenes.registry import SCENES
    entry = SCENES.get(source.name) if source.kind == "builtin" else None
    return [dict(mesh) for mesh in entry.bench_meshes] if entry is not None else []


def run_status(dofs: int, wall_time: float, max_rel_error: float, converged: bool) -> str:
    """A finished bench run in a few words: its DoFs, wall time, error against the reference and whether it
    converged."""
    error = f"max rel. error {max_rel_error:.2e}" if math.isfinite(max_rel_error) else "no reference"
    return f"{dofs} DoFs, {wall_time:.2f} s, {error}" + ("" if converged else ", NOT CONVERGED")


def print_status(scene: str, label: str, status: str) -> None:
    """The line of one bench run: scene, mesh label, status."""
    print(f"{scene:24s} {label:28s} {status}", flush=True)


def mesh_sequence(source, refine: list[dict], scene=None) -> list[dict]:
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
    """One run of a bench as a :class:`flexbody.outputs.report.BenchRun` (a failure is a run too)."""
    from flexbody.outputs.report import BenchRun
    from flexbody.scenes.sources import SceneError
    try:
        scene = source.build(params)
    except SceneError as exc:
        return BenchRun(source.name, label, params, failure=str(exc))
    try:
        summary = run_with_progress(scene, quiet=quiet, prefix=f"  [{label}]")  # compiles outside the timed solve
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        return BenchRun(scene.name, label, params, failure=f"the analysis failed: {run_failure(exc)}")
    reference = None
    if scene.reference is not None:
        reference = {k: (list(map(float, scene.reference.load_factors)), list(map(float, v)))
                     for k, v in scene.reference.values.items()}
    return BenchRun(scene.name, label, params, summary.as_dict(), {k: list(v) for k, v in summary.history.items()},
                    reference, reference_source=scene.reference.source if scene.reference else "")


def bench_plan(source, common: dict, refine: list[dict]) -> list[dict]:
    """The runs of one scene (:func:`_mesh_sequence`), its first run's scene built to report a bad key now."""
    needs_scene = not refine and not _bench_meshes(source)
    scene = build_scene(source, common) if needs_scene else None
    meshes = mesh_sequence(source, refine, scene)
    build_scene(source, {**common, **meshes[0]})
    return meshes


def cmd_bench(args) -> int:
    """``flexbody bench``: every scene on its mesh sequence, then DIR/report.md, plots and bench.json.
    Returns 0, or 2 if a run failed or did not converge (the report is written either way)."""
    from flexbody.outputs.report import mesh_label, write_report
    common = parse_sets(args.set or [])
    refine = parse_refine(args.refine or [])
    names = args.scenes or default_bench_scenes()
    sources = [open_source(name) for name in names]
    plans = [bench_plan(source, common, refine) for source in sources]  # a bad scene or key stops it now
    prepare_out_dir(args.out)
    if args.workers is not None or args.scheduler:
        check_workers(args)
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
            status = run.failure or run_status(run.dofs, run.wall_time, run.max_rel_error, run.converged)
            print_status(source.name, label, status)
    print_written(write_report(runs, args.out, " ".join(["flexbody", "bench", *args.argv])))
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
        print_status(scene, label, f"failed: {row.message}" if not row.summary else
                     run_status(row.dofs, row.wall_time_s, row.max_rel_error, row.converged))

    rows, interrupted = run_tasks(tasks, args, status, warm_up=None)
    runs = []
    for row in sorted(rows, key=lambda r: r.index):
        scene, label = labels[row.index]
        if row.summary:
            runs.append(BenchRun(row.summary.get("scene", scene), label, tasks[row.index].parameters, row.summary,
                                 row.history, row.reference, reference_source=row.reference_source))
        else:
            runs.append(BenchRun(scene, label, tasks[row.index].parameters, failure=f"{row.status}: {row.message}"))
    print_written(write_report(runs, args.out, " ".join(["flexbody", "bench", *args.argv])))
    if interrupted is not None:
        return interrupted
    return 0 if all(r.converged for r in runs) else 2
