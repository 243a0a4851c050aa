"""Shared element fixtures: flat and curved reference elements and random deformed states."""

import numpy as np
import pytest

from flexbody.frames import frames_from_directors
from flexbody.lie import so3
from flexbody.shell.geometry import element_geometry
from flexbody.shell.material import ShellMaterial

PARAM = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]], float)


def flat_element(distort: float = 0.1, seed: int = 0):
    rng = np.random.default_rng(seed)
    uv = PARAM @ np.array([[1.0, 0.2], [0.1, 0.9]]) + distort * rng.uniform(-0.5, 0.5, (6, 2)) * (np.arange(6) >= 3)[:, None]
    X = np.column_stack([uv, np.zeros(6)])
    n = np.tile([0.0, 0.0, 1.0], (6, 1))
    return X, frames_from_directors(n, np.array([1.0, 0, 0]))


def curved_element(radius: float = 2.0):
    """A patch of a cylinder of the given radius (axis y), nodes and directors exact."""
    uv = PARAM * 0.8 + np.array([0.1, 0.2])
    X = np.array([[radius * np.sin(u / radius * 2), v, radius * np.cos(u / radius * 2)] for u, v in uv])
    n = np.array([[np.sin(u / radius * 2), 0, np.cos(u / radius * 2)] for u, v in uv])
    return X, frames_from_directors(n, np.array([0.0, 1.0, 0.0]))


def deformed(X, frames, rng, amplitude=0.05, rot=0.3, rigid=True):
    """A random large-rotation deformed state: rigid motion plus random nodal perturbations."""
    Rg = so3.exp(rng.normal(size=3) * 1.5) if rigid else np.eye(3)
    x = (X + amplitude * rng.normal(size=X.shape)) @ Rg.T + rng.normal(size=3)
    fr = np.array([Rg @ frames[i] @ so3.exp(rot * rng.normal(size=3)) for i in range(6)])
    return x, fr


@pytest.fixture(params=["flat", "curved"])
def element(request):
    X, frames = flat_element() if request.param == "flat" else curved_element()
    material = ShellMaterial(young=1.0e3, poisson=0.3, thickness=0.1)
    return X, frames, element_geometry(X, frames), material.section()
