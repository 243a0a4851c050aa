"""Output files that stay sound: one writer per file, and no write that the disk cannot hold.

Locking. A writer opens the file without truncating it, takes an exclusive ``flock`` (refused at once if any other
process holds a lock on it: another run writing it, or an HDF5 tool reading it), then keeps a shared lock
for the rest of the run. The shared lock lets HDF5 readers (which take a shared lock themselves) open the
file while it is written, and makes a second writer's exclusive lock fail. The lock goes with the process:
a killed run leaves no stale lock behind. Where ``fcntl`` is missing (Windows) nothing is locked.

Free space. Before a step is written, :func:`check_free_space` makes sure the file system keeps
:data:`DISK_MARGIN` bytes free beyond the step's own size; otherwise it raises :class:`DiskFullError`
and nothing of the step is written. A library (HDF5, rerun) that meets a full disk in the middle of a
write can leave a file that no longer opens, so the writers stop before that point.
"""

from __future__ import annotations

import os
import shutil

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None


#: bytes kept free on the output's file system beyond the size of the step being written (room for the
#: libraries' metadata and for closing the file cleanly)
DISK_MARGIN = 64 * 1024


class DiskFullError(OSError):
    """The output's file system cannot take the next step; the message names the file and the steps written."""


def check_free_space(path: str, nbytes: int, what: str, steps_written: int) -> None:
    """Raise :class:`DiskFullError` unless ``nbytes`` plus :data:`DISK_MARGIN` are free where ``path`` lives."""
    try:
        free = shutil.disk_usage(os.path.dirname(os.path.abspath(path))).free
    except OSError:
        return  # unknown: let the write itself report
    if free < nbytes + DISK_MARGIN:
        raise DiskFullError(f"disk full after {steps_written} steps: {what} {path!r} has "
                            f"{free} bytes left for a step of {nbytes} bytes (+{DISK_MARGIN} kept free)")


class OutputLockedError(OSError):
    """The output file is being written (or read) by another process; the message is one line."""


def lock_holders(path: str) -> list[int]:
    """Process ids holding a lock on ``path`` (from ``/proc/locks``, Linux; [] where unknown)."""
    try:
        st = os.stat(path)
        with open("/proc/locks") as fh:
            lines = fh.read().splitlines()
    except OSError:
        return []
    inode = f"{os.major(st.st_dev):02x}:{os.minor(st.st_dev):02x}:{st.st_ino}"
    pids = []
    for line in lines:
        fields = line.split()
        if "->" in fields:        # a process waiting for the lock, not holding it
            continue
        if len(fields) >= 6 and fields[5] == inode and fields[4].isdigit() and int(fields[4]) != os.getpid():
            pids.append(int(fields[4]))
    return sorted(set(pids))


def lock_output(path: str, what: str) -> int | None:
    """Open ``path`` (created if missing, not truncated) and lock it for this process' writer.

    Returns the descriptor that holds the lock (pass it to :func:`release`), or None where locks are not
    supported. Raises :class:`OutputLockedError` naming the file and, if known, the process holding it.
    """
    if fcntl is None:
        return None
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        raise OSError(f"cannot open {what} {path!r}: {exc.strerror or exc}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)  # let readers in, keep other writers out
    except BlockingIOError:
        pids = lock_holders(path)
        os.close(fd)
        holder = f"process {', '.join(map(str, pids))}" if pids else "another process"
        raise OutputLockedError(f"{what} {path!r} is in use by {holder} (another run writing it, or a "
                                "reader); refusing to overwrite it") from None
    except BaseException:
        os.close(fd)
        raise
    return fd


def release(fd: int | None) -> None:
    """Give up the lock of :func:`lock_output` (closing its descriptor)."""
    if fd is not None:
        os.close(fd)
