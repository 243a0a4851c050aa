"""Every module of ``flexbody.scenes`` imports on its own in a fresh interpreter (first, before any other
flexbody module): an import cycle between them, or a module that works only after another was imported,
fails here; and importing the scene data, the building helpers or the static runner never loads the
dynamics."""

from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys

import pytest

REPO = Path(__file__).resolve().parents[2]
MODULES = sorted("flexbody.scenes" if p.stem == "__init__" else f"flexbody.scenes.{p.stem}"
                 for p in (REPO / "flexbody" / "scenes").glob("*.py"))
DYNAMICS = ("flexbody.dynamics", "flexbody.shell.inertia", "integrators.generalized_alpha")


def _run(code: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)


def test_the_module_list_is_complete():
    assert {"flexbody.scenes.scene", "flexbody.scenes.runner", "flexbody.scenes.dynamic_run",
            "flexbody.scenes.toml_scene", "flexbody.scenes.builtin"} <= set(MODULES)


@pytest.mark.parametrize("module", MODULES)
def test_a_scenes_module_imports_alone(module):
    """Imported first and alone, it works, and it loads none of the dynamics (mass, inertia, integrator)."""
    out = _run(f"import sys, importlib; importlib.import_module({module!r}); "
               f"print(','.join(m for m in {DYNAMICS!r} if m in sys.modules))")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "", f"importing {module} loaded {out.stdout.strip()}"
