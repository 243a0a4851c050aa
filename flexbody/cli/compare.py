"""``flexbody compare SCENE --with exudyn``: the comparison with another code (the comparison and its table:
:mod:`flexbody.adapters.exudyn.compare`, :mod:`flexbody.outputs.comparison_text`)."""

from __future__ import annotations

import sys

from flexbody.cli.json_stdout import with_json_to_stdout
from flexbody.cli.outputs import check_outputs
from flexbody.cli.values import parse_sets


def cmd_compare(args) -> int:
    """``flexbody compare SCENE --with exudyn``: hand over to ``flexbody.adapters.exudyn.compare_cli``
    (``--json -``: the comparison's JSON alone on standard output, the table on standard error)."""
    if args.json == "-":
        return with_json_to_stdout(args, cmd_compare)
    params = parse_sets(args.set or [])
    check_outputs({"--json": args.json})
    try:
        from flexbody.adapters.exudyn import compare_cli
    except ImportError as exc:
        print(f"flexbody: compare --with exudyn is not available: {str(exc).splitlines()[0]} "
              "(needs flexbody.adapters.exudyn.compare_cli and pip install 'flexbody[exudyn]')", file=sys.stderr)
        return 2
    return int(compare_cli(args.scene, params, args.json, args.quiet))
