"""Helpers shared by the output tests: a fresh interpreter on this checkout, a two-element stand-in mesh."""

import os
from pathlib import Path
import subprocess
import sys
from types import SimpleNamespace

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def run_python(code: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter that imports flexbody from this checkout."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)


def square_mesh():
    """Stand-in for a Tri6Mesh: the unit square as two six-node triangles on a 3 x 3 grid of nodes."""
    jj, ii = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
    nodes = np.stack([0.5 * ii.ravel(), 0.5 * jj.ravel(), np.zeros(9)], axis=1)
    elements = np.array([[0, 2, 8, 1, 5, 4], [0, 8, 6, 4, 7, 3]])
    directors = np.tile([0.0, 0.0, 1.0], (9, 1))
    return SimpleNamespace(nodes=nodes, elements=elements, directors=directors)


def mount_small_disk(path: Path, size: str = "300k") -> None:
    """Mount a tmpfs of ``size`` on ``path`` (a file system to fill); pytest.skip with the reason if mounting is
    not permitted here (it needs root or CAP_SYS_ADMIN)."""
    import shutil
    import pytest
    if shutil.which("mount") is None:
        pytest.skip("no mount command: cannot make a small file system to fill")
    path.mkdir(exist_ok=True)
    out = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                         capture_output=True, text=True)
    if out.returncode != 0:
        pytest.skip(f"mounting a {size} tmpfs is not permitted here: {out.stderr.strip()}")


def unmount(path: Path) -> None:
    subprocess.run(["umount", "-l", str(path)], capture_output=True)
