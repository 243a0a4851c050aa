"""The ``flexbody`` command: list, run, bench and compare scenes.

    flexbody list
    flexbody run [SCENE] [--set KEY=VALUE ...] [--json FILE] [--h5 FILE.h5] [--rerun FILE.rrd] [--quiet]
                 [--xdmf FILE.xdmf] [--stresses] [--restart FILE.h5[:STEP]]
    flexbody bench [SCENE ...] [--refine KEY=V1,V2,...] [--set KEY=VALUE ...] [--out DIR] [--quiet]
    flexbody compare SCENE --with exudyn [--set KEY=VALUE ...] [--json FILE] [--quiet]
    flexbody sweep SCENE --grid KEY=V1,V2,... [--grid ...] [--zip] [--workers N | --scheduler ADDRESS]
        [--set KEY=VALUE ...] [--out DIR] [--json FILE] [--h5]         (docs/sweeps.md)
    flexbody modes SCENE [--set K=V ...] [--count N] [--omega W | --load-factor L|end] [--sweep KEY=V1,...]
                   [--json FILE] [--plot FILE.png] [--rerun FILE.rrd] [--h5 FILE.h5]
    flexbody modes SCENE --buckling [--set K=V ...] [--count N] [--json FILE]

SCENE is a built-in scene name (``flexbody list``) or a path to a ``.toml`` or ``.py`` scene file
(docs/scenes.md). Bad input ends with one line on stderr naming the offending key or value (exit code 1);
a run that stops before its last load step writes its outputs and exits with 2 (also when the --h5 file
cannot take another step, e.g. a full disk); an error inside the analysis exits with 1. Ctrl-C (SIGINT)
and SIGTERM (what ``timeout`` and batch schedulers send) stop a run cleanly: the step being written is
finished, the files are closed readable, and the exit code is 128 + the signal number (130, 143).
a dynamic run that completes but is not to be trusted (a conserved energy or momentum drifted, or the
body turned too far in a time step: docs/robustness.md) prints a WARNING line, lists it under ``warnings``
in the JSON and exits with 3.

One module per command (:mod:`.listing`, :mod:`.show`, :mod:`.run`, :mod:`.bench`, :mod:`.sweep`,
:mod:`.compare`, :mod:`.modes`, :mod:`.buckling`), the argument parser in :mod:`.parser`, and what the
commands share: :mod:`.values` (``--set`` values and lists), :mod:`.scene_input` (opening and building a
scene), :mod:`.outputs` (output paths and JSON files), :mod:`.json_stdout` (``--json -``), :mod:`.progress`,
:mod:`.stop_signals`, :mod:`.cluster` (runs on a Dask cluster) and :mod:`.summary` (the run summary's lines).
"""

from __future__ import annotations

import sys

from flexbody.cli.errors import CliError
from flexbody.cli.parser import build_parser

__all__ = ["CliError", "build_parser", "main"]


def main(argv: list[str] | None = None) -> int:
    """Run the ``flexbody`` command with ``argv`` (default: the process's arguments); returns its exit code.

    Bad input (:class:`CliError`) ends the process with the message as one line on stderr (exit code 1).
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    args.argv = argv[1:]
    try:
        return args.func(args)
    except CliError as exc:
        raise SystemExit(f"flexbody: {exc}") from None
