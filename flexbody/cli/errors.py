"""The errors of the ``flexbody`` command: bad input, and one line for an error inside an analysis."""

from __future__ import annotations


class CliError(Exception):
    """Bad command-line input or a bad scene: printed as one line, exit code 1 (:func:`flexbody.cli.main`)."""


def run_failure(exc: BaseException) -> str:
    """A one-line description of an error raised inside an analysis."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
