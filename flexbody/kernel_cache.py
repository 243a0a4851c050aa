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

The choice is written to ``NUMBA_CACHE_DIR`` (so that numba's configuration reload keeps it) and, if numba
is already imported, to ``numba.core.config.CACHE_DIR``. With no writable directory at all the kernels run
uncached (compiled in every process) instead of failing. ``CACHE_DIR`` holds the outcome (None: uncached),
``CACHE`` the ``cache=`` flag for ``numba.njit``.

Importing this module is the only place flexbody sets process-wide numba state; ``flexbody/__init__.py``
imports it first. A user's own ``cache=True`` functions decorated after ``import flexbody`` are cached there
too (numba has one cache location per process).
"""

from __future__ import annotations

import os
import stat
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path

ENV = "NUMBA_CACHE_DIR"


def candidate_dirs(environ: Mapping[str, str]) -> list[tuple[Path, bool]]:
    """The cache directories to try, in order of preference (module docstring), each with whether it must be
    private to the user (the one in the shared temporary folder)."""
    found = []
    if environ.get(ENV):
        found.append((Path(environ[ENV]).expanduser(), False))
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


def apply(path: Path | None) -> None:
    """Point numba's cache at ``path`` (None: leave numba's setting alone, flexbody then runs uncached)."""
    if path is None:
        return
    os.environ[ENV] = str(path)
    config = sys.modules.get("numba.core.config")
    if config is not None:                    # numba imported before flexbody: it read the environment already
        config.CACHE_DIR = str(path)


CACHE_DIR: Path | None = choose(candidate_dirs(os.environ))
apply(CACHE_DIR)
CACHE: bool = CACHE_DIR is not None
