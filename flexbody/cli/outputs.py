"""The files a command writes: its output paths checked before it runs, its ``--out`` directory, its JSON
file, and the line that reports a file written."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import sys

from flexbody.cli.errors import CliError

#: the start of the line that reports a written file, aligned with the summary's columns
WRITTEN = "written          "


def check_outputs(paths: dict[str, str | None], inputs: dict[str, str] | None = None) -> None:
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


def require_rerun() -> None:
    """A CliError if the rerun SDK, which ``--rerun`` needs, is not installed (looked up, not imported)."""
    if importlib.util.find_spec("rerun") is None:
        raise CliError("--rerun needs the rerun SDK: pip install 'flexbody[rerun]' (or rerun-sdk)")


def prepare_out_dir(path: str) -> None:
    """Create the ``--out`` directory ``path`` if needed; a CliError if it cannot be created or written to."""
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        raise CliError(f"cannot create --out directory {path!r}: {exc.strerror or exc}") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise CliError(f"cannot write to --out directory {path!r}")


def strict_json(value):
    """NaN/inf as null so that every JSON reader accepts the file."""
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: str, data) -> None:
    """``data`` as strict JSON (:func:`strict_json`) in the ``--json`` file ``path``."""
    try:
        with open(path, "w") as fh:
            json.dump(strict_json(data), fh, indent=2)
    except OSError as exc:
        raise CliError(f"cannot write --json file {path!r}: {exc.strerror or exc}") from None


def write_json_stdout(data) -> None:
    """``--json -``: the JSON document alone on standard output."""
    json.dump(strict_json(data), sys.stdout, indent=2)
    sys.stdout.write("\n")
    sys.stdout.flush()


def print_written(path: str, file=None) -> None:
    """The line ``written          PATH`` (on standard output, or ``file``)."""
    print(f"{WRITTEN}{path}", file=file)
