"""Where numba caches flexbody's compiled kernels: a per-user directory, never the installed package.

numba's default (``cache=True`` without ``NUMBA_CACHE_DIR``) writes next to the source, into
``flexbody/**/__pycache__``. In an installed package those files outlive ``pip uninstall``, and the leftover
folder then shadows a later (editable) install as a namespace package. So flexbody chooses the cache
directory itself, before any of its kernels is decorated (numba picks a function's cache location when
``@njit(cache=True)`` runs), in this order, the first writable one winning:

1. ``NUMBA_CACHE_DIR``, if the user set it;
2. ``$XDG_CACHE_HOME/flexbody/numba`` (an absolute ``XDG_CACHE_HOME`` only, as the XDG spec says);
3. ``~/.cache/flexbody/numba``;
4. ``<temporary directory>/flexbody-numba-<uid>`` (private to the user, for read-only or missing homes).

Inside it, the kernels go to a subdirectory named for a digest of their sources, ``kernels-<digest>``
(``KERNEL_DIR``). numba's own cache check looks only at the file that defines a kernel: a kernel that takes a
constant (a series, a tying map, shape functions at the points) or an inlined function from another module
would be loaded stale after an edit there. The digest covers every source file the kernel modules
(``KERNEL_MODULES``) import from flexbody, directly or not (:func:`kernel_sources`, read from the import
statements without importing anything), so an edit in any of them starts from an empty directory: no cache
has to be cleared by hand. Directories of earlier sources stay (other checkouts may still use them); delete
``CACHE_DIR`` to reclaim the space. The digest reads the 37 files as text (27 of them took 24 ms, measured on
the loaded machine).

``KERNEL_DIR`` is written to ``NUMBA_CACHE_DIR`` (so that numba's configuration reload keeps it, and child
processes inherit it: a ``NUMBA_CACHE_DIR`` that already names this digest's directory is taken as it is)
and, if numba is already imported, to ``numba.core.config.CACHE_DIR``. With no writable directory at all the
kernels run uncached (compiled in every process) instead of failing. ``CACHE_DIR`` holds the chosen directory
(None: uncached), ``KERNEL_DIR`` the digest's directory in it, ``CACHE`` the ``cache=`` flag for ``numba.njit``.

Importing this module and :mod:`flexbody._numba` (which adds a jit option to numba, see there) are the only
places flexbody sets process-wide numba state; ``flexbody/__init__.py`` imports this module first. A user's own ``cache=True`` functions decorated after ``import flexbody`` are cached there
too (numba has one cache location per process).
"""

from __future__ import annotations

import hashlib
import os
import re
import stat
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path

ENV = "NUMBA_CACHE_DIR"
PACKAGE = Path(__file__).resolve().parent

#: the modules that define numba kernels: the digest covers them and everything they import from flexbody
#: (tests/test_kernel_cache.py checks that no other module of the package uses numba's jit)
KERNEL_MODULES = ("flexbody._numba", "flexbody.lie.kernels", "flexbody.scatter", "flexbody.frames",
                  "flexbody.matrix_transfer",
                  *(f"flexbody.shell.kernels.{stage}" for stage in ("primitives", "points", "material", "geometric",
                                                                    "expansion", "congruence", "loops")),
                  "flexbody.shell.kernels.mitc7.loops")


def module_file(name: str, root: Path = PACKAGE) -> Path | None:
    """The source file of module ``name`` ("flexbody.x.y") under the package directory ``root`` (None: none)."""
    parts = name.split(".")
    if parts[0] != "flexbody":
        return None
    base = root.joinpath(*parts[1:])
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


_IMPORT = re.compile(r"^[ \t]*(?:from[ \t]+(\.*[\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n#]*)|import[ \t]+([^\n#]*))",
                     re.MULTILINE)


def _imported_modules(path: Path, name: str) -> set[str]:
    """The flexbody modules that the source ``path`` (module ``name``) imports anywhere in its text (import
    statements at the start of a line, read as text: fast, and over-inclusive at worst)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for source, names, plain in _IMPORT.findall(path.read_text(encoding="utf-8")):
        if plain:
            found.update(item.split()[0] for item in plain.split(",") if item.strip())
            continue
        level = len(source) - len(source.lstrip("."))
        if level:                                # relative import
            parts = package.split(".")
            source = ".".join(parts[:len(parts) - level + 1] + ([source[level:]] if source[level:] else []))
        found.add(source)
        for item in names.strip("()").split(","):
            if item.split():
                found.add(f"{source}.{item.split()[0]}")       # "from package import module"
    return {m for m in found if m == "flexbody" or m.startswith("flexbody.")}


def kernel_sources(root: Path = PACKAGE, modules: tuple[str, ...] = KERNEL_MODULES) -> list[Path]:
    """The source files of ``modules`` and of every flexbody module they import, transitively (sorted)."""
    seen: dict[str, Path] = {}
    todo = list(modules)
    while todo:
        name = todo.pop()
        path = module_file(name, root)
        if name in seen or path is None:
            continue
        seen[name] = path
        todo.extend(_imported_modules(path, name))
    return sorted(set(seen.values()))


def sources_digest(root: Path = PACKAGE, modules: tuple[str, ...] = KERNEL_MODULES) -> str:
    """16 hex digits of the SHA-256 of :func:`kernel_sources` (their paths relative to ``root`` and bytes)."""
    h = hashlib.sha256()
    for path in kernel_sources(root, modules):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


KERNEL_SUBDIR = f"kernels-{sources_digest()}"


def candidate_dirs(environ: Mapping[str, str]) -> list[tuple[Path, bool]]:
    """The cache directories to try, in order of preference (module docstring), each with whether it must be
    private to the user (the one in the shared temporary folder)."""
    found = []
    if environ.get(ENV):
        path = Path(environ[ENV]).expanduser()
        found.append((path.parent if path.name == KERNEL_SUBDIR else path, False))   # inherited: see apply
    xdg = environ.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        found.append((Path(xdg) / "flexbody" / "numba", False))
    try:
        found.append((Path.home() / ".cache" / "flexbody" / "numba", False))
    except (RuntimeError, KeyError):          # no home directory known
        pass
    try:
        user = os.getuid() if hasattr(os, "getuid") else os.getlogin()
        found.append((Path(tempfile.gettempdir()) / f"flexbody-numba-{user}", True))
    except OSError:                           # no usable temporary directory (or login name)
        pass
    return found


def is_private(path: Path) -> bool:
    """True if ``path`` is the user's own and nobody else may write to it (POSIX; always True elsewhere).

    numba loads cache files as code: a directory in a shared temporary folder must not be someone else's.
    """
    if not hasattr(os, "getuid"):
        return True
    st = path.stat()
    return st.st_uid == os.getuid() and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def usable(path: Path, private: bool = False) -> bool:
    """Create ``path`` if needed and check that a file can be written in it (numba's own test) and, if
    ``private``, that it is the user's own (:func:`is_private`)."""
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
        return not private or is_private(path)
    except (OSError, ValueError):
        return False


def choose(candidates: list[tuple[Path, bool]]) -> Path | None:
    """The first usable directory of ``candidates`` (None: none is)."""
    return next((path for path, private in candidates if usable(path, private)), None)


def apply(path: Path | None) -> Path | None:
    """Point numba's cache at the digest's directory in ``path`` and return it (None: leave numba's setting
    alone, flexbody then runs uncached). The directory is made private (mode 0700) like ``path``."""
    if path is None:
        return None
    kernels = path / KERNEL_SUBDIR
    if not usable(kernels):
        return None
    os.environ[ENV] = str(kernels)
    config = sys.modules.get("numba.core.config")
    if config is not None:                    # numba imported before flexbody: it read the environment already
        config.CACHE_DIR = str(kernels)
    return kernels


CACHE_DIR: Path | None = choose(candidate_dirs(os.environ))
KERNEL_DIR: Path | None = apply(CACHE_DIR)
CACHE: bool = KERNEL_DIR is not None
