"""The user docs stay true: the commands of docs/getting_started.md exist (their options parse), the quick ones
run, the sample output of ``flexbody run`` is what it prints (times aside), and no user doc names internal
issue numbers or commit hashes."""

import re
import shlex
from pathlib import Path

import pytest

from flexbody.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
GETTING_STARTED = ROOT / "docs" / "getting_started.md"
#: commands of getting_started.md quick enough to run in the suite (a few seconds each)
QUICK = ("flexbody list", "flexbody show hemisphere", "flexbody --version")


def documented_commands() -> list[str]:
    """Every ``flexbody ...`` command of getting_started.md (inline code and indented blocks)."""
    text = GETTING_STARTED.read_text()
    found = re.findall(r"`(flexbody(?: [^`]*)?)`", text) + re.findall(r"&& (flexbody[^\n]*)", text)
    return sorted({c.strip() for c in found if c.strip() != "flexbody"} | {"flexbody run"})


def test_every_documented_command_parses():
    commands = documented_commands()
    assert "flexbody run" in commands and "flexbody show hemisphere" in commands and len(commands) >= 8
    for command in commands:
        words = [w for w in shlex.split(command.split(" | ")[0])[1:] if w != "[--set"]
        if words == ["--version"] or (len(words) == 1 and words[0] not in ("run", "list")):
            continue                                     # a bare command name in prose ("`flexbody compare`")
        build_parser().parse_args(words)                 # an unknown option or command exits here


@pytest.mark.parametrize("command", QUICK)
def test_quick_documented_commands_run(command, capsys):
    assert command in documented_commands()
    try:
        code = main(shlex.split(command)[1:])
    except SystemExit as exc:                            # --version exits through argparse
        code = exc.code
    assert code == 0 and capsys.readouterr().out.strip()


def test_the_sample_output_of_flexbody_run_is_what_it_prints(capsys):
    text = GETTING_STARTED.read_text()
    sample = text.split("```\nscene            cantilever_end_moment")[1].split("```")[0]
    sample = ("scene            cantilever_end_moment" + sample).strip().splitlines()
    assert main(["run", "--quiet"]) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    timed = ("wall time", "total time")
    assert [line for line in printed if not line.startswith(timed)] == \
        [line for line in sample if not line.startswith(timed)]
    assert [line.split()[0] for line in printed] == [line.split()[0] for line in sample]


def test_no_internal_issue_numbers_or_commit_hashes_in_user_docs():
    internal = re.compile(r"\b[Ii]ssues? #?\d+|#\d+\b|\bcommit [0-9a-f]{7,40}\b|the [a-z-]+ issue\b")
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for number, line in enumerate(path.read_text().splitlines(), 1):
            assert not internal.search(line), f"{path.name}:{number}: {line.strip()}"
