"""The ``flexbody`` command: list and run scenes.

    flexbody list
    flexbody run [SCENE] [--set KEY=VALUE ...] [--json FILE] [--quiet]
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
import time

DEFAULT_SCENE = "cantilever_end_moment"


def _parse_value(text: str):
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _parse_sets(items: list[str]) -> dict:
    out = {}
    for item in items:
        if "=" not in item:
            raise SystemExit(f"flexbody: --set expects KEY=VALUE, got {item!r}")
        key, value = item.split("=", 1)
        out[key.strip()] = _parse_value(value.strip())
    return out


def _scene_builder(name: str):
    """A built-in scene builder, or ``build`` from a user's Python scene file."""
    import importlib.util
    import os

    from flexbody.scenes.builtin import BUILTIN
    if name in BUILTIN:
        return BUILTIN[name]
    if name.endswith(".py"):
        if not os.path.isfile(name):
            raise SystemExit(f"flexbody: scene file {name!r} does not exist")
        spec = importlib.util.spec_from_file_location("flexbody_user_scene", name)
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:  # a user's file: report, do not trace back into flexbody
            raise SystemExit(f"flexbody: cannot load scene file {name!r}: {type(exc).__name__}: {exc}") from None
        if not callable(getattr(module, "build", None)):
            raise SystemExit(f"flexbody: scene file {name!r} must define a function build(**parameters) -> Scene")
        return module.build
    raise SystemExit(f"flexbody: unknown scene {name!r}; built-in scenes: {', '.join(BUILTIN)} "
                     "(or give a path to a .py scene file)")


def _build(name: str, params: dict):
    import inspect

    builder = _scene_builder(name)
    allowed = [p for p in inspect.signature(builder).parameters]
    unknown = [k for k in params if k not in allowed]
    if unknown:
        raise SystemExit(f"flexbody: unknown parameter(s) {unknown} for scene {name!r}; "
                         f"documented keys: {', '.join(allowed)}")
    try:
        return builder(**params)
    except (ValueError, TypeError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise SystemExit(f"flexbody: cannot build scene {name!r}: {msg}") from None


def cmd_list(args) -> int:
    from flexbody.scenes.builtin import BUILTIN
    for name, builder in BUILTIN.items():
        doc = (builder.__doc__ or "").strip().splitlines()[0]
        print(f"{name:24s} {doc}")
    return 0


def summary_lines(summary) -> list[str]:
    d = summary.as_dict()
    lines = [
        f"scene            {d['scene']}",
        f"DoFs / elements  {d['dofs']} / {d['elements']}",
        f"steps            {d['steps']}  (load factor reached {d['load_factor']:.4g})",
        f"Newton           {d['newton_iterations']} iterations, {d['tangent_updates']} tangent updates, "
        f"{d['factorizations']} factorizations",
        f"wall time        {d['wall_time_s']:.2f} s",
    ]
    for k, v in d["outputs"].items():
        lines.append(f"output           {k} = {v:.6g}")
    if d["errors"]:
        worst = max(d["errors"], key=lambda e: e["rel_error"])
        lines.append(f"max rel. error   {d['max_rel_error']:.3e}  ({worst['quantity']} at load factor "
                     f"{worst['load_factor']:.3g}: {worst['value']:.5g} vs reference {worst['reference']:.5g})")
    if not d["converged"]:
        lines.append(f"NOT CONVERGED    {d['message']}")
    return lines


def cmd_run(args) -> int:
    from flexbody.scenes.scene import run_scene
    t0 = time.perf_counter()
    scene = _build(args.scene, _parse_sets(args.set or []))
    progress = None
    if not args.quiet:
        def progress(rec):
            print(f"  step {rec.step:4d}  load factor {rec.load_factor:8.4f}  iterations {rec.iterations:2d}",
                  file=sys.stderr, flush=True)
    summary = run_scene(scene, progress=progress)
    for line in summary_lines(summary):
        print(line)
    print(f"total time       {time.perf_counter() - t0:.2f} s (including setup and compilation)")
    if args.json:
        try:
            with open(args.json, "w") as fh:
                json.dump(summary.as_dict(), fh, indent=2)
        except OSError as exc:
            raise SystemExit(f"flexbody: cannot write --json file {args.json!r}: {exc}") from None
    return 0 if summary.result.converged else 2


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="flexbody", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the built-in scenes").set_defaults(func=cmd_list)
    run = sub.add_parser("run", help="run a scene and report error against run time")
    run.add_argument("scene", nargs="?", default=DEFAULT_SCENE, help=f"built-in scene (default {DEFAULT_SCENE})")
    run.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    run.add_argument("--json", metavar="FILE", help="write the run summary as JSON")
    run.add_argument("--quiet", action="store_true", help="no progress output")
    run.set_defaults(func=cmd_run)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
