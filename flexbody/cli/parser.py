"""The ``flexbody`` command's argument parser: its subcommands, each bound to the function that runs it."""

from __future__ import annotations

import argparse

from flexbody.cli.bench import cmd_bench
from flexbody.cli.compare import cmd_compare
from flexbody.cli.listing import cmd_list
from flexbody.cli.modes import cmd_modes
from flexbody.cli.run import cmd_run
from flexbody.cli.show import cmd_show
from flexbody.cli.sweep import cmd_sweep

DEFAULT_SCENE = "cantilever_end_moment"

#: the help of a SCENE argument
SCENE_HELP = "built-in scene or .toml/.py scene file"


def _scene(parser) -> None:
    """The SCENE argument of the commands that take one."""
    parser.add_argument("scene", help=SCENE_HELP)


def _sets(parser, help: str = "override a scene parameter (repeatable)") -> None:
    """--set KEY=VALUE (repeatable)."""
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help=help)


def _quiet(parser) -> None:
    """--quiet."""
    parser.add_argument("--quiet", action="store_true", help="no progress output")


def _cluster_arguments(parser, default: str) -> None:
    """--workers / --scheduler of ``sweep`` and ``bench``."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--workers", type=int, metavar="N", help=f"a local Dask cluster of N worker processes, "
                       f"0: in this process ({default})")
    group.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask cluster: its scheduler's "
                       "address (tcp://host:8786) or scheduler file (.json)")


def _add_run_parser(sub) -> None:
    """The ``run`` subcommand's arguments."""
    run = sub.add_parser("run", help="run a scene and report error against run time")
    run.add_argument("scene", nargs="?", default=DEFAULT_SCENE, help=f"{SCENE_HELP} (default {DEFAULT_SCENE})")
    _sets(run)
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
    _quiet(run)
    run.set_defaults(func=cmd_run)


def _add_bench_parser(sub) -> None:
    """The ``bench`` subcommand's arguments."""
    bench = sub.add_parser("bench", help="run scenes on a sequence of meshes; write report.md and plots")
    bench.add_argument("scenes", nargs="*", help="scenes (default: the built-in scenes, the static ones on their "
                       "bench meshes, the dynamic ones on time steps dt, dt/2, dt/4)")
    bench.add_argument("--refine", action="append", metavar="KEY=V1,V2,...",
                       help="the mesh sequence, e.g. --refine nx=4,8,16 (repeat for more keys, equal lengths)")
    _sets(bench, "override a parameter in every run")
    bench.add_argument("--out", default="bench", metavar="DIR", help="report directory (default ./bench)")
    _quiet(bench)
    _cluster_arguments(bench, "default: serial, in this process")
    bench.set_defaults(func=cmd_bench)


def _add_sweep_parser(sub) -> None:
    """The ``sweep`` subcommand's arguments."""
    sweep = sub.add_parser("sweep", help="run a scene over a grid of parameters on a Dask cluster; one table")
    _scene(sweep)
    sweep.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                       help="a swept parameter and its values (repeat for more; all combinations)")
    sweep.add_argument("--zip", action="store_true", help="pair the --grid lists (equal lengths) instead of "
                       "taking all combinations")
    _sets(sweep, "a fixed parameter of every run")
    sweep.add_argument("--out", default="sweep", metavar="DIR", help="results directory (default ./sweep)")
    sweep.add_argument("--json", metavar="FILE", help="also write the table as JSON to FILE ('-': to standard "
                       "output, the printed lines then go to standard error)")
    sweep.add_argument("--h5", action="store_true", help="write each run's HDF5 file to DIR/runs/")
    _quiet(sweep)
    _cluster_arguments(sweep, "default: a local cluster, one worker per core")
    sweep.set_defaults(func=cmd_sweep)


def _add_compare_parser(sub) -> None:
    """The ``compare`` subcommand's arguments."""
    compare = sub.add_parser("compare", help="compare a scene with another code")
    compare.add_argument("scene", help="built-in scene or scene file")
    compare.add_argument("--with", dest="other", choices=["exudyn"], default="exudyn",
                         help="the code to compare with (exudyn)")
    _sets(compare, "override a scene parameter")
    compare.add_argument("--json", metavar="FILE", help="write the comparison as JSON ('-': to standard output, "
                         "the table then goes to standard error)")
    _quiet(compare)
    compare.set_defaults(func=cmd_compare)


def _add_modes_parser(sub) -> None:
    """The ``modes`` subcommand's arguments (one function per analysis kind: see
    :func:`flexbody.cli.modes.cmd_modes`)."""
    modes = sub.add_parser("modes", help="natural frequencies and mode shapes about an equilibrium or a steady spin")
    _scene(modes)
    _sets(modes)
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
    _quiet(modes)
    modes.set_defaults(func=cmd_modes)


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``flexbody``: each subcommand's ``func`` is the function that runs it."""
    parser = argparse.ArgumentParser(prog="flexbody", description="List, run, bench and compare shell scenes.",
                                     epilog="Scene files: docs/scenes.md. Output formats: docs/output_formats.md.")
    from flexbody import __version__
    parser.add_argument("--version", action="version", version=f"flexbody {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the built-in scenes").set_defaults(func=cmd_list)
    show = sub.add_parser("show", help="what a scene models: its parameters (defaults, units) and reference")
    _scene(show)
    show.set_defaults(func=cmd_show)
    _add_run_parser(sub)
    _add_bench_parser(sub)
    _add_sweep_parser(sub)
    _add_compare_parser(sub)
    _add_modes_parser(sub)
    return parser
