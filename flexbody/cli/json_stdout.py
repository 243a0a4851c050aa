"""``--json -``: a command's JSON alone on standard output, what it prints on standard error."""

from __future__ import annotations

from contextlib import contextmanager, redirect_stdout
import os
import sys
import tempfile


class RenamedStream:
    """A text stream that writes to ``stream`` with ``old`` shown as ``new`` (the temporary JSON file of
    ``--json -`` named as standard output in the lines that report it written)."""

    def __init__(self, stream, old: str, new: str) -> None:
        self._stream, self._old, self._new = stream, old, new

    def write(self, text: str) -> int:
        self._stream.write(text.replace(self._old, self._new))
        return len(text)

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextmanager
def stdout_to_stderr(temporary: str):
    """While a command runs for ``--json -``: what it prints goes to standard error, through Python's
    ``sys.stdout`` and through file descriptor 1 (a library may print from C); ``temporary`` is shown as
    "standard output". Descriptor 1 is restored on the way out, whatever happens."""
    sys.stdout.flush()
    try:
        saved = os.dup(1)
        os.dup2(2, 1)
    except OSError:                              # no descriptor 1 or 2: Python's stream only
        saved = None
    try:
        with redirect_stdout(RenamedStream(sys.stderr, temporary, "standard output")):
            yield
    finally:
        sys.stderr.flush()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


def with_json_to_stdout(args, command) -> int:
    """``command(args)`` with ``--json -``: the command writes its JSON to a temporary file while its printed
    text goes to standard error (:func:`stdout_to_stderr`); then that JSON alone goes to standard output
    (nothing if the command stopped before writing it). ``flexbody run`` writes its own
    (:func:`flexbody.cli.run.cmd_run`)."""
    real = sys.stdout
    fd, temporary = tempfile.mkstemp(prefix="flexbody-", suffix=".json")
    os.close(fd)
    args.json = temporary
    try:
        with stdout_to_stderr(temporary):
            code = command(args)
        with open(temporary, encoding="utf-8") as fh:
            text = fh.read()
        if text.strip():
            real.write(text.rstrip("\n") + "\n")
            real.flush()
        return code
    finally:
        args.json = "-"
        os.unlink(temporary)
