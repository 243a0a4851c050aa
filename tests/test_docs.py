"""The user docs stay true: every command README.md and docs/*.md show parses (its scene, options and keys
exist), the quick ones run and print the sample outputs shown (times masked), the benchmark and example
scripts shown exist with their options, the Python blocks run and print their outputs, and no user doc
names internal issue numbers or commit hashes."""

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


# ----------------------------------------------------------------------------------------------------------
# Every command shown in the user docs
# ----------------------------------------------------------------------------------------------------------
#
# The commands are read from README.md and docs/*.md: inline code that starts with `flexbody ` or
# `python benchmarks/` / `python examples/` (optionally after VAR=value assignments), and the lines of
# indented and fenced blocks that do (a `$ ` prompt allowed; `\` continues a line; `# ...` is a comment;
# `a && b` shows b; `a | b` shows a). A command with a placeholder (an upper-case word such as SCENE or
# FILE, `[...]`, `...`) is a synopsis: its subcommand and every option it names must exist. Every other
# `flexbody` command must parse with the real parser, name a scene that exists (built-in, or a file of
# the repository), and name only `--set`/`--grid` keys the scene documents (checked from the scene's key
# list or its TOML file, without building a mesh). A `python benchmarks/...` or `python examples/...`
# script must exist and its `--help` must list every option the doc shows.
#
# Every runnable `flexbody` command is either in QUICK_RUNS (it runs in the suite, with the exit code
# given) or in SLOW (with the reason it only parses). A command followed (in the same fenced block, after a
# `$ ` prompt) by its printed output must be quick, and prints exactly that after `normalise`: the times
# ("0.41 s") are masked, and so are the counts of the Newton line (iterations, tangent updates,
# factorizations), which differ at round-off level between freshly compiled and cache-loaded numba kernels
# (docs/sweeps.md explains why); every other character of every line is compared.

import subprocess
import sys

SCRIPT = re.compile(r"^(?:[A-Z_]+=\S+ )*python (?:-m \S+ )?((?:benchmarks|examples)/\S+\.py)\b")
PLACEHOLDER = re.compile(r"\[|\.\.\.|\b[A-Z][A-Z0-9_]*[A-Z0-9]\b(?!=)|\b[A-Z]\b|\|")
#: every runnable `flexbody` command the docs show that runs in the suite (a few seconds at most with warm
#: kernels; about 15 s together), with its exit code; it runs in a fresh directory (examples/ linked in)
QUICK_RUNS: dict[str, int] = {
    "flexbody run": 0,
    "flexbody list": 0,
    "flexbody --version": 0,
    "flexbody show hemisphere": 0,
    "flexbody run cantilever_end_shear": 0,
    "flexbody run cantilever_end_shear --json -": 0,
    "flexbody run cantilever_end_shear --set thickness=1e-5": 0,
    "flexbody run examples/cantilever_end_shear.toml": 0,
    "flexbody run examples/cantilever_end_shear.toml --quiet": 0,
    "flexbody run examples/cantilever_end_shear.toml --set nx=8": 0,
    "flexbody run spinning_plate": 0,
    "flexbody run spinning_plate --set dt=1 --set end_time=1": 3,       # the doc shows it not to be trusted
    "flexbody run spinning_membrane --h5 sail.h5 --rerun sail.rrd": 0,
    "flexbody run pullout_cylinder --h5 pull.h5": 0,
    "flexbody run pullout_cylinder --h5 more.h5 --restart pull.h5:15": 0,   # after the run before (in order)
    "flexbody modes examples/kicked_spinning_annulus.toml --count 8 --json modes.json --plot modes.png": 0,
    "flexbody modes examples/kicked_spinning_annulus.toml --sweep omega=0,5,10,20 --json campbell.json "
    "--plot campbell.png": 0,
    "flexbody modes examples/clamped_plate.toml --load-factor end --set material.density=1000": 0,
    "flexbody modes examples/compressed_plate_scene.py --buckling --count 3": 0,
}
#: every other runnable `flexbody` command the docs show: too slow (or needing a cluster or exudyn) for the
#: suite, so only parsed and checked as above; the reason
SLOW: dict[str, str] = {
    "flexbody run slit_annular_plate --set n_radial=16 --set n_circ=48": "a refined benchmark mesh (minutes)",
    "flexbody run slit_annular_plate --h5 slit.h5 --rerun slit.rrd": "about a minute",
    "flexbody run examples/cantilever_end_shear.toml --set nx=32 --set ny=2 --h5 shear.h5 --rerun shear.rrd":
        "a refined mesh with outputs (tens of seconds)",
    "flexbody bench --out bench": "every built-in scene on a mesh sequence (minutes)",
    "flexbody bench --out docs/bench": "every built-in scene on a mesh sequence (minutes)",
    "flexbody bench tumbling_plate": "three time steps of a dynamic scene",
    "flexbody bench spinning_plate spinning_membrane spinning_sail swinging_strip tumbling_plate":
        "five dynamic scenes at three time steps (minutes)",
    "flexbody bench examples/cantilever_end_shear.toml --refine nx=4,8,16,32 --out shear_bench":
        "a mesh sequence up to nx=32",
    "flexbody bench plate.py --refine n=4,8,16": "a scene file the doc writes, on a mesh sequence",
    "flexbody compare cantilever_end_shear --with exudyn": "needs exudyn and solves the problem twice",
    "flexbody sweep spinning_plate --grid omega=5,10,15,20 --grid thickness=0.01,0.015,0.02,0.025 "
    "--set end_time=0.5 --workers 2 --out plate_sweep": "16 dynamic runs on a local Dask cluster",
    "flexbody sweep examples/clamped_plate_scene.py --grid n=2,4,8 --grid pressure=20,50 --h5 --out plate":
        "six static runs on a local Dask cluster",
}


@dataclass
class ShownCommand:
    path: Path
    line: int
    text: str
    output: str | None = None      # the printed output shown after a `$ ` prompt

    @property
    def where(self) -> str:
        return f"{self.path.name}:{self.line}"


def _shown(text: str) -> str | None:
    """The command of one shown line (`$ ` prompt, `&&` chains, pipes and comments removed), or None."""
    text = text.strip()
    if text.startswith("$ "):
        text = text[2:]
    text = text.split(" && ")[-1]
    if "[" not in text:                                  # in a synopsis `[A | B]` is a choice, not a pipe
        text = text.split(" | ")[0]
    text = re.sub(r"\s+#\s.*$", "", text).strip()
    text = " ".join(text.split())
    bare = re.sub(r"^(?:[A-Z_]+=\S+ )*", "", text)
    if bare.startswith("flexbody ") or SCRIPT.match(text):
        return text
    return None


def shown_commands(path: Path) -> list[ShownCommand]:
    """The commands a Markdown file shows, with their printed outputs."""
    lines = path.read_text().splitlines()
    found: list[ShownCommand] = []
    prose: list[tuple[int, str]] = []
    i = 0
    while i < len(lines):
        stripped = lines[i].strip()
        if stripped.startswith("```"):
            end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == "```")
            if stripped[3:].strip() in ("", "sh", "bash", "console", "shell"):
                j = i + 1
                while j < end:
                    first, text = j, lines[j]
                    while text.rstrip().endswith("\\") and j + 1 < end:
                        j += 1
                        text = text.rstrip()[:-1] + " " + lines[j].strip()
                    command = _shown(text)
                    if command:
                        found.append(ShownCommand(path, first + 1, command))
                        if text.strip().startswith("$ "):
                            out = []
                            while j + 1 < end and not lines[j + 1].strip().startswith("$ "):
                                j += 1
                                out.append(lines[j])
                            found[-1].output = "\n".join(out) + "\n" if out else None
                    j += 1
            i = end + 1
            continue
        if lines[i].startswith("    ") and (not prose or not prose[-1][1].strip() or
                                            prose[-1][1].startswith("    ")):
            text, first = lines[i], i
            while text.rstrip().endswith("\\") and i + 1 < len(lines):
                i += 1
                text = text.rstrip()[:-1] + " " + lines[i].strip()
            command = _shown(text)
            if command:
                found.append(ShownCommand(path, first + 1, command))
            elif text.strip().startswith("[") and found and found[-1].line == first:   # a synopsis wraps
                found[-1].text += " " + " ".join(re.sub(r"\s+#\s.*$", "", text).split())
            prose.append((first, "    "))
            i += 1
            continue
        prose.append((i, lines[i]))
        i += 1
    # inline code of the prose (it may wrap over lines)
    text = "\n".join(line for _, line in prose)
    starts = [0]
    for _, line in prose:
        starts.append(starts[-1] + len(line) + 1)
    for match in re.finditer(r"`([^`]+)`", text):
        command = _shown(" ".join(match.group(1).split()))
        if command:
            index = next(k for k in range(len(prose)) if starts[k + 1] > match.start())
            found.append(ShownCommand(path, prose[index][0] + 1, command))
    return found


def all_shown_commands() -> list[ShownCommand]:
    return [c for path in DOC_FILES for c in shown_commands(path)]


def _options(parser) -> set[str]:
    return {s for action in parser._actions for s in action.option_strings}


def _subparsers(parser) -> dict:
    import argparse
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


#: scene files a doc's commands use that the doc itself shows how to write (not files of the repository)
WRITTEN_BY_THE_DOC = {"plate.py": "scenes.md writes it in its Python scene example",
                      "plate.toml": "scenes.md's error messages name it"}


def _scene_exists(name: str) -> bool:
    from flexbody.scenes.registry import SCENES
    return name in SCENES or (ROOT / name).is_file() or name in WRITTEN_BY_THE_DOC


def _keys_of(option: str, words: list[str]) -> list[str]:
    return [words[k + 1].split("=")[0] for k, w in enumerate(words[:-1]) if w == option]


def _words(text: str) -> list[str]:
    return shlex.split(re.sub(r"^(?:[A-Z_]+=\S+ )*", "", text))[1:]


def is_concrete(text: str) -> bool:
    """A `flexbody` command a user can paste and run: no placeholder, not a bare command name or a command
    with option names only, as prose uses them ("`flexbody run --rerun`")."""
    words = _words(text)
    options_only = len(words) > 1 and all(w.startswith("--") and "=" not in w for w in words[1:])
    bare = len(words) == 1 and words[0] not in ("run", "list", "--version")
    return not (PLACEHOLDER.search(text) or options_only or bare)


def check_flexbody_command(command: ShownCommand) -> None:
    from flexbody.cli.scene_input import open_source
    from flexbody.cli.sweep import check_sweep_keys
    words = _words(command.text)
    parser = build_parser()
    sub = _subparsers(parser)
    if not is_concrete(command.text):
        # a synopsis, or a bare command name in prose: the command and the options it names exist
        assert not words or words[0] in sub or words[0].startswith("-"), f"{command.where}: {command.text}"
        known = _options(sub[words[0]]) if words and words[0] in sub else _options(parser)
        for word in words:
            for option in word.lstrip("[").split("=")[0].rstrip("]").split("/"):
                if option.startswith("--"):
                    assert option in known, f"{command.where}: {command.text}: no option {option}"
        keys = [k for k in _keys_of("--set", words) + _keys_of("--grid", words) if not PLACEHOLDER.search(k)]
        if len(words) > 1 and keys and _scene_exists(words[1]) and words[1] not in WRITTEN_BY_THE_DOC:
            check_sweep_keys(open_source(str(ROOT / words[1]) if (ROOT / words[1]).is_file() else words[1]), keys)
        return                                           # e.g. a real scene with a placeholder address
    try:
        args = parser.parse_args(words)
    except SystemExit as exc:
        assert words == ["--version"] and exc.code == 0, f"{command.where}: does not parse: {command.text}"
        return
    scenes = getattr(args, "scenes", None) or ([args.scene] if getattr(args, "scene", None) else [])
    for scene in scenes:
        assert _scene_exists(scene), f"{command.where}: no scene {scene!r}: {command.text}"
        keys = _keys_of("--set", words) + _keys_of("--grid", words)
        if keys and scene not in WRITTEN_BY_THE_DOC:
            if not (ROOT / scene).is_file():
                check_sweep_keys(open_source(scene), keys)
            else:
                check_sweep_keys(open_source(str(ROOT / scene)), keys)


def check_script_command(command: ShownCommand, helps: dict) -> None:
    """The script exists; if the doc shows options, its `--help` (of the subcommand, if the script has
    subcommands and the doc names one) lists each."""
    script = SCRIPT.match(command.text).group(1)
    assert (ROOT / script).is_file(), f"{command.where}: no script {script}"
    words = command.text.split(script, 1)[1].split()
    options = [o for w in words for o in w.lstrip("[").split("=")[0].rstrip("]").split("/") if o.startswith("--")]
    if not options:
        return
    key = (script,)
    if script not in helps:
        helps[script] = _help(script)
    sub = re.search(r"\{([\w,-]+)\}", helps[script].split("\n\n")[0])
    if sub and words and words[0] in sub.group(1).split(","):
        key = (script, words[0])
        if key not in helps:
            helps[key] = _help(script, words[0])
    text = helps[key if len(key) == 2 else script]
    for option in options:
        assert re.search(re.escape(option) + r"(?![\w-])", text), f"{command.where}: {script} has no option {option}"


def _help(script: str, *sub: str) -> str:
    done = subprocess.run([sys.executable, str(ROOT / script), *sub, "--help"], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 0, f"{script} {' '.join(sub)} --help failed: {done.stderr[-500:]}"
    return done.stdout


def test_the_command_reader_finds_blocks_prose_and_outputs(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text("Run `flexbody run cantilever_end_shear\n--json -` or\n\n    flexbody list   # the scenes\n\n"
                   "```\n$ flexbody sweep x --grid a=1,2 \\\n  --zip\nline 1\nline 2\n```\n\n"
                   "`python benchmarks/stress.py --quick`, `flexbody.cli`\n")
    got = [(c.line, c.text, c.output) for c in shown_commands(doc)]
    assert got == [(4, "flexbody list", None),
                   (7, "flexbody sweep x --grid a=1,2 --zip", "line 1\nline 2\n"),
                   (1, "flexbody run cantilever_end_shear --json -", None),
                   (13, "python benchmarks/stress.py --quick", None)]


def test_every_command_of_the_docs_parses():
    commands = all_shown_commands()
    assert {c.path.name for c in commands} >= {"README.md", "getting_started.md", "scenes.md", "sweeps.md",
                                              "modal.md", "performance.md"}
    assert len(commands) >= 80
    failures = []
    for command in commands:
        if SCRIPT.match(command.text):
            continue
        try:
            check_flexbody_command(command)
        except (AssertionError, Exception) as exc:
            failures.append(f"{command.where}: {command.text}: {exc}")
    assert not failures, "\n".join(failures)


def test_every_script_shown_in_the_docs_exists_with_its_options():
    helps: dict = {}
    failures = []
    for command in all_shown_commands():
        if SCRIPT.match(command.text):
            try:
                check_script_command(command, helps)
            except AssertionError as exc:
                failures.append(str(exc))
    assert len(helps) >= 8 and not failures, "\n".join(failures)


def test_a_wrong_option_or_scene_or_key_in_a_doc_is_caught():
    bad = [ShownCommand(ROOT, 1, "flexbody run cantilever_end_shear --colour red"),
           ShownCommand(ROOT, 1, "flexbody run no_such_scene"),
           ShownCommand(ROOT, 1, "flexbody run spinning_plate --set no_such_key=1"),
           ShownCommand(ROOT, 1, "flexbody run examples/cantilever_end_shear.toml --set colour=1"),
           ShownCommand(ROOT, 1, "flexbody sweep SCENE --no-such-option"),
           ShownCommand(ROOT, 1, "flexbody sweep spinning_sail --grid colour=1,2 --scheduler tcp://HOST:1")]
    for command in bad:
        with pytest.raises((AssertionError, Exception)):
            check_flexbody_command(command)
    with pytest.raises(AssertionError):
        check_script_command(ShownCommand(ROOT, 1, "python benchmarks/stress.py --no-such-option"), {})


def normalise(lines: list[str]) -> list[str]:
    """Mask what differs between runs: times ("0.41 s") and the Newton counts (round-off between freshly
    compiled and cache-loaded kernels)."""
    out = []
    for line in lines:
        line = re.sub(r"\d+(?:\.\d+)? s\b", "<t> s", line.rstrip())
        if line.startswith("Newton "):
            line = re.sub(r"\d+", "<n>", line)
        out.append(line)
    return out


def test_every_runnable_command_is_run_or_listed_as_slow():
    concrete = {c.text for c in all_shown_commands() if not SCRIPT.match(c.text) and is_concrete(c.text)}
    assert concrete == set(QUICK_RUNS) | set(SLOW), \
        f"not run, not listed: {concrete - set(QUICK_RUNS) - set(SLOW)}; " \
        f"listed, not in the docs: {(set(QUICK_RUNS) | set(SLOW)) - concrete}"
    assert not set(QUICK_RUNS) & set(SLOW)
    assert "flexbody sweep SCENE --grid ..." not in concrete and "flexbody run --rerun" not in concrete


def test_the_shown_outputs_belong_to_quick_commands():
    assert all(c.text in QUICK_RUNS for c in all_shown_commands() if c.output)
    assert sum(1 for c in all_shown_commands() if c.output) >= 1


def _run_shown(command: str, tmp_path: Path, monkeypatch) -> int:
    monkeypatch.chdir(tmp_path)
    if not (tmp_path / "examples").exists():
        (tmp_path / "examples").symlink_to(ROOT / "examples")
    try:
        return main(shlex.split(command)[1:])
    except SystemExit as exc:                            # --version exits through argparse
        return exc.code


@pytest.fixture(scope="module")
def run_directory(tmp_path_factory):
    return tmp_path_factory.mktemp("shown_commands")     # one for all: a restart reads the run before it


@pytest.mark.parametrize("command", list(QUICK_RUNS))
def test_the_quick_commands_of_the_docs_run(command, run_directory, capsys, monkeypatch):
    if "--rerun" in command:
        pytest.importorskip("rerun")
    if "--plot" in command:
        pytest.importorskip("matplotlib")
    if "--restart pull.h5" in command and not (run_directory / "pull.h5").exists():    # run alone (-k)
        assert _run_shown("flexbody run pullout_cylinder --h5 pull.h5", run_directory, monkeypatch) == 0
        capsys.readouterr()
    assert _run_shown(command, run_directory, monkeypatch) == QUICK_RUNS[command]
    printed = capsys.readouterr().out.strip().splitlines()
    assert printed
    shown = [c for c in all_shown_commands() if c.text == command and c.output]
    for sample in shown:                                 # the printed output the doc shows, times masked
        assert normalise(printed) == normalise(sample.output.strip().splitlines()), \
            f"{sample.where}: printed\n" + "\n".join(printed)
