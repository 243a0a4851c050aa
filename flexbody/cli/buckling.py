"""Linear buckling of a static scene's load pattern (``flexbody modes SCENE --buckling``)."""

from __future__ import annotations

import time

from flexbody.cli.errors import CliError
from flexbody.cli.outputs import check_outputs, print_written, write_json
from flexbody.cli.scene_input import build_scene, input_files, open_source
from flexbody.cli.values import parse_sets


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
    source = open_source(args.scene)
    check_outputs({"--json": json_path}, input_files(source))
    scene = build_scene(source, parse_sets(getattr(args, "set", None) or []))
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
        write_json(json_path, result.as_dict(scene.name))
        print_written(json_path)
    return 0 if len(result.load_factors) else 2
# modes
# ----------------------------------------------------------------------------------------------------------
