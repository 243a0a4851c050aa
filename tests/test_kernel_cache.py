"""numba's cache of flexbody's kernels goes to a per-user directory, never into the package (issue #14).

Each test runs a fresh interpreter that compiles the smallest cached kernel (``scatter_blocks``, a few
seconds) under a controlled environment, and checks where its index file (``*.nbi``) lands.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import flexbody
from flexbody import kernel_cache

PACKAGE = Path(flexbody.__file__).resolve().parent
ROOT = PACKAGE.parent

SCATTER_ONCE = """
import numpy as np
from flexbody import kernel_cache
from flexbody.scatter import scatter_blocks
maps = np.tile(np.eye(3), (1, 6, 1, 1))
scatter_blocks(np.zeros((1, 36, 36)), maps, maps, -np.ones((1, 36, 36), dtype=np.int64), 1.0, np.zeros(1))
print(kernel_cache.CACHE_DIR)
"""


def _package_cache_files() -> dict[str, int]:
    """numba cache files (index and data) under the package, with their modification times."""
    return {str(p): p.stat().st_mtime_ns for p in PACKAGE.rglob("*.nb[ic]")}


def _run(tmp_path: Path, code: str, **env: str | None) -> str:
    """Run ``code`` in a fresh interpreter with HOME, XDG_CACHE_HOME and TMPDIR in ``tmp_path`` (overridden
    by ``env``; None unsets) and NUMBA_CACHE_DIR unset unless given; return its stdout's last line."""
    environ = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    environ.update(HOME=str(tmp_path / "home"), XDG_CACHE_HOME=str(tmp_path / "xdg"), TMPDIR=str(tmp_path / "tmp"),
                   PYTHONPATH=os.pathsep.join([str(ROOT), environ.get("PYTHONPATH", "")]))
    environ.update(env)
    environ = {k: v for k, v in environ.items() if v is not None}
    (tmp_path / "tmp").mkdir(exist_ok=True)
    before = _package_cache_files()
    out = subprocess.run([sys.executable, "-c", code], env=environ, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert _package_cache_files() == before, "numba wrote its cache into the flexbody package"
    return out.stdout.strip().splitlines()[-1]


def _index_files(directory: Path) -> list[Path]:
    """The kernel's index files in the sources' digest directory of ``directory`` (kernel_cache.KERNEL_DIR)."""
    return list((directory / kernel_cache.KERNEL_SUBDIR).rglob("scatter.*scatter_blocks-*.nbi"))


def test_cache_goes_to_the_user_cache_directory(tmp_path):
    used = _run(tmp_path, SCATTER_ONCE)
    assert Path(used) == tmp_path / "xdg" / "flexbody" / "numba"
    assert _index_files(Path(used))


def test_cache_without_xdg_goes_under_home(tmp_path):
    used = _run(tmp_path, SCATTER_ONCE, XDG_CACHE_HOME=None)
    assert Path(used) == tmp_path / "home" / ".cache" / "flexbody" / "numba"
    assert _index_files(Path(used))


def test_cache_location_set_when_numba_was_imported_first(tmp_path):
    used = _run(tmp_path, "import numba\n" + SCATTER_ONCE)
    assert Path(used) == tmp_path / "xdg" / "flexbody" / "numba" and _index_files(Path(used))


def test_numba_cache_dir_is_honoured(tmp_path):
    mine = tmp_path / "my numba cache"
    used = _run(tmp_path, SCATTER_ONCE, NUMBA_CACHE_DIR=str(mine))
    assert Path(used) == mine and _index_files(mine)
    assert not (tmp_path / "xdg").exists()


def test_unwritable_cache_locations_fall_back_to_a_private_temporary_directory(tmp_path):
    blocker = tmp_path / "a file"          # no directory can be made under a file (even by root)
    blocker.write_text("")
    used = _run(tmp_path, SCATTER_ONCE, NUMBA_CACHE_DIR=str(blocker / "numba"), HOME=str(blocker),
                XDG_CACHE_HOME=str(blocker / "cache"))
    assert Path(used).parent == tmp_path / "tmp" and Path(used).name.startswith("flexbody-numba-")
    assert _index_files(Path(used))
    assert Path(used).stat().st_mode & 0o077 == 0


def test_no_writable_location_runs_uncached(tmp_path):
    blocker = tmp_path / "a file"
    blocker.write_text("")
    no_temp = ("import tempfile\n"
               "def _none():\n    raise FileNotFoundError('no usable temporary directory')\n"
               "tempfile.gettempdir = _none\n")
    used = _run(tmp_path, no_temp + SCATTER_ONCE + "print(kernel_cache.CACHE)",
                NUMBA_CACHE_DIR=str(blocker / "numba"), HOME=str(blocker), XDG_CACHE_HOME=str(blocker / "cache"))
    assert used == "False"
    assert not list(tmp_path.rglob("*.nbi"))


def test_a_temporary_directory_of_someone_else_is_not_used(tmp_path):
    from flexbody import kernel_cache
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o777)
    shared.chmod(0o777)                    # writable by everybody: somebody could plant compiled code there
    assert not kernel_cache.usable(shared, private=True)
    assert kernel_cache.usable(shared, private=False)
    assert kernel_cache.choose([(shared, True), (tmp_path / "mine", True)]) == tmp_path / "mine"


# ------------------------------------------------------------------------------------------------------------
# Stale caches: the digest of the kernels' sources names the directory numba uses
# ------------------------------------------------------------------------------------------------------------

_USES_JIT = re.compile(r"numba\.njit|\bnjit\(|numba\.jit\(|numba\.extending|from flexbody import _numba")


def test_every_module_that_compiles_kernels_is_in_the_digest():
    sources = set(kernel_cache.kernel_sources())
    users = {p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts and _USES_JIT.search(p.read_text())}
    assert users, "the scan finds no kernel module"
    assert users <= sources, f"kernel modules outside kernel_cache.KERNEL_MODULES: {sorted(users - sources)}"
    # constants the kernels freeze come from modules that define no kernel
    for name in ("lie/so3.py", "shell/geometry.py", "shell/mitc6.py", "shell/bubble_newton.py"):
        assert PACKAGE / name in sources


def test_an_edit_of_any_kernel_source_changes_the_digest_and_nothing_else_does(tmp_path):
    copy = tmp_path / "flexbody"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    digest = kernel_cache.sources_digest(copy)
    assert digest == kernel_cache.sources_digest() and kernel_cache.KERNEL_SUBDIR == f"kernels-{digest}"
    for name in ("lie/so3.py", "shell/geometry.py", "shell/kernels/layout.py", "shell/kernels/expansion.py",
                 "_numba.py"):
        original = (copy / name).read_bytes()
        (copy / name).write_bytes(original.replace(b"\n", b"\n\n", 1))
        assert kernel_cache.sources_digest(copy) != digest, name
        (copy / name).write_bytes(original)
    for name in ("cli/run.py", "body.py", "outputs/__init__.py"):
        (copy / name).write_text((copy / name).read_text() + "\n# an edit\n")
    assert kernel_cache.sources_digest(copy) == digest


def test_numba_and_child_processes_use_the_digest_directory():
    import numba.core.config
    assert kernel_cache.KERNEL_DIR == kernel_cache.CACHE_DIR / kernel_cache.KERNEL_SUBDIR
    assert numba.core.config.CACHE_DIR == os.environ["NUMBA_CACHE_DIR"] == str(kernel_cache.KERNEL_DIR)
    # a child process inherits NUMBA_CACHE_DIR = KERNEL_DIR and takes it as it is (no nested digest directory)
    inherited = kernel_cache.candidate_dirs({"NUMBA_CACHE_DIR": str(kernel_cache.KERNEL_DIR)})[0][0]
    assert inherited == kernel_cache.CACHE_DIR
