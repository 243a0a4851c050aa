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


# ----------------------------------------------------------------------------------------------------------
# The Python blocks of the docs run
# ----------------------------------------------------------------------------------------------------------
#
# Every ```python block of README.md and docs/*.md runs: the blocks of one file in order, in one namespace,
# in a fresh directory (so that a block may read the files an earlier one wrote). A block followed by an
# ```output block (with only prose between) must print exactly that. A block that cannot run in the suite is
# marked on the line before its fence with <!-- not-run: reason -->; it must still compile and its imports
# from flexbody must resolve.

import ast
import contextlib
from dataclasses import dataclass
import importlib
import io

DOC_FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
NOT_RUN = re.compile(r"^<!--\s*not-run:\s*(\S.*?)\s*-->$")
#: the most blocks the docs may leave unrun (keep it small: a snippet that does not run goes stale)
MAX_NOT_RUN = 3


@dataclass
class PythonBlock:
    path: Path
    line: int                      # 1-based line of the opening fence
    code: str
    not_run: str | None = None     # the reason, for a block marked not-run
    output: str | None = None      # what it must print, from the ```output block after it

    @property
    def where(self) -> str:
        return f"{self.path.name}:{self.line}"


def python_blocks(path: Path) -> list[PythonBlock]:
    """The ```python blocks of a Markdown file with their markers and expected outputs."""
    lines = path.read_text().splitlines()
    blocks: list[PythonBlock] = []
    i = 0
    while i < len(lines):
        fence = lines[i].strip()
        if not fence.startswith("```") or fence == "```":
            i += 1
            continue
        info = fence[3:].strip()
        end = next((j for j in range(i + 1, len(lines)) if lines[j].strip() == "```"), None)
        assert end is not None, f"{path.name}:{i + 1}: unclosed code fence"
        body = "\n".join(lines[i + 1:end]) + "\n"
        if info == "python":
            previous = next((lines[j].strip() for j in range(i - 1, -1, -1) if lines[j].strip()), "")
            marker = NOT_RUN.match(previous)
            blocks.append(PythonBlock(path, i + 1, body, marker.group(1) if marker else None))
        elif info == "output":
            between = [ln for ln in lines[blocks[-1].line:i] if ln.strip().startswith("```")] if blocks else []
            assert blocks and len(between) == 1, f"{path.name}:{i + 1}: an output block follows no python block"
            blocks[-1].output = body
        i = end + 1
    return blocks


def all_blocks() -> list[PythonBlock]:
    return [b for path in DOC_FILES for b in python_blocks(path)]


def test_python_blocks_are_found_and_few_are_left_unrun():
    blocks = all_blocks()
    assert {b.path.name for b in blocks} >= {"README.md", "output_formats.md"}
    assert any(b.output for b in blocks if b.path.name == "README.md")
    unrun = [b.where for b in blocks if b.not_run]
    assert len(unrun) <= MAX_NOT_RUN, f"too many blocks marked not-run: {unrun}"
    for path in DOC_FILES:                 # a marker must sit right before a python fence
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if "not-run" in line:
                assert NOT_RUN.match(line.strip()), f"{path.name}:{number}: malformed marker {line.strip()!r}"
        marked = path.read_text().count("<!-- not-run:")
        assert marked == sum(1 for b in python_blocks(path) if b.not_run), f"{path.name}: a not-run marker " \
                                                                           "is not right before a python block"


def test_the_block_parser_reads_markers_and_outputs(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text("text\n\n```python\nprint(1)\n```\n\nprints\n\n```output\n1\n```\n\n"
                   "<!-- not-run: needs a cluster -->\n```python\nimport dask\n```\n\n```toml\na = 1\n```\n")
    first, second = python_blocks(doc)
    assert (first.line, first.code, first.not_run, first.output) == (3, "print(1)\n", None, "1\n")
    assert (second.line, second.not_run, second.output) == (14, "needs a cluster", None)


def test_unrun_blocks_compile_and_import_what_exists():
    for block in all_blocks():
        if not block.not_run:
            continue
        tree = compile(block.code, block.where, "exec", ast.PyCF_ONLY_AST)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module.split(".")[0] in ("flexbody", "integrators"):
                module = importlib.import_module(node.module)
                for alias in node.names:
                    assert hasattr(module, alias.name), f"{block.where}: {node.module} has no {alias.name}"


def run_blocks(path: Path, tmp_path: Path, monkeypatch) -> None:
    """Run the python blocks of one file in order in one namespace; check the printed outputs."""
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__doc_block__"}
    for block in python_blocks(path):
        if block.not_run:
            continue
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            try:
                exec(compile(block.code, str(block.where), "exec"), namespace)
            except Exception as exc:
                raise AssertionError(f"{block.where}: the block raised {type(exc).__name__}: {exc}") from exc
        if block.output is not None:
            got = [ln.rstrip() for ln in printed.getvalue().strip().splitlines()]
            assert got == [ln.rstrip() for ln in block.output.strip().splitlines()], \
                f"{block.where}: printed\n{printed.getvalue()}"


@pytest.mark.parametrize("name", sorted({b.path.name for b in all_blocks() if not b.not_run}))
def test_the_python_blocks_of_the_docs_run(name, tmp_path, monkeypatch):
    path = next(p for p in DOC_FILES if p.name == name)
    if name == "output_formats.md":
        pytest.importorskip("rerun")         # the blocks write and read a recording (the rerun extra)
        pytest.importorskip("meshio")
    run_blocks(path, tmp_path, monkeypatch)
