"""The scene: model + analysis + tracked outputs + optional reference, and the run that reports error
against run time."""

from __future__ import annotations

from dataclasses import dataclass, field
import time
from typing import Callable

import numpy as np

from flexbody.assembly import Model
from integrators.newton import NewtonSettings
from integrators.static import StaticResult, arc_length, load_control


@dataclass(frozen=True)
class Output:
    """A tracked scalar: the displacement of one node along a fixed direction, times ``scale``.

    Example: Output("W_A", node=12, direction=(0, 0, 1)) is the z-displacement of node 12.
    """

    name: str
    node: int
    direction: tuple[float, float, float]
    scale: float = 1.0

    def value(self, model: Model, state) -> float:
        u = state.x[self.node] - model.body.mesh.nodes[self.node]
        return self.scale * float(u @ np.asarray(self.direction, float))


@dataclass(frozen=True)
class Reference:
    """Reference values of some outputs at load factors (or times)."""

    load_factors: np.ndarray
    values: dict[str, np.ndarray]
    source: str = ""


@dataclass(frozen=True)
class StaticAnalysis:
    """method: "load_control" (steps to the listed load factors) or "arc_length"."""

    method: str = "load_control"
    load_factors: tuple[float, ...] = tuple(np.linspace(0.05, 1.0, 20))
    arc_increment: float = 0.05
    max_load_increment: float | None = None
    newton: NewtonSettings = field(default_factory=NewtonSettings)


@dataclass
class Scene:
    name: str
    description: str
    model: Model
    analysis: StaticAnalysis
    outputs: list[Output]
    reference: Reference | None = None
    parameters: dict = field(default_factory=dict)


@dataclass
class RunSummary:
    scene: str
    dofs: int
    elements: int
    result: StaticResult
    history: dict[str, list[float]]          # load_factor and every output, per converged step
    errors: list[dict]
    wall_time_s: float

    @property
    def max_rel_error(self) -> float:
        return max((e["rel_error"] for e in self.errors), default=float("nan"))

    def as_dict(self) -> dict:
        st = self.result.stats
        return {
            "scene": self.scene, "dofs": self.dofs, "elements": self.elements,
            "steps": len(self.result.records), "newton_iterations": st.iterations,
            "tangent_updates": st.tangent_updates, "factorizations": st.factorizations,
            "wall_time_s": self.wall_time_s, "converged": self.result.converged,
            "message": self.result.message, "load_factor": self.result.load_factor,
            "outputs": {k: v[-1] for k, v in self.history.items() if k != "load_factor" and v},
            "errors": self.errors, "max_rel_error": self.max_rel_error,
        }


def compare_with_reference(history: dict[str, list[float]], reference: Reference) -> list[dict]:
    """Relative errors at every tabulated load factor reached (linear interpolation between steps).

    The relative error is |value - reference| / max|reference| of that quantity over the table, so that
    values near zero at small loads do not blow up the measure.
    """
    lam = np.concatenate([[0.0], history["load_factor"]])
    errors = []
    for name, ref_vals in reference.values.items():
        if name not in history:
            continue
        vals = np.concatenate([[0.0], history[name]])
        scale = float(np.abs(ref_vals).max()) or 1.0
        for lf, rv in zip(reference.load_factors, ref_vals):
            if lf <= 0 or lf > lam.max() + 1e-12:
                continue
            if np.all(np.diff(lam) > 0):
                v = float(np.interp(lf, lam, vals))
            else:  # non-monotonic path (snap-back): first crossing
                k = int(np.argmax(lam >= lf - 1e-12))
                t = (lf - lam[k - 1]) / (lam[k] - lam[k - 1])
                v = float(vals[k - 1] + t * (vals[k] - vals[k - 1]))
            errors.append({"quantity": name, "load_factor": float(lf), "value": v, "reference": float(rv),
                           "rel_error": abs(v - rv) / scale})
    return errors


def run_scene(scene: Scene, on_step: Callable | None = None, progress: Callable | None = None) -> RunSummary:
    """Run a static scene; track outputs at every converged step; compare with the reference."""
    model = scene.model
    history: dict[str, list[float]] = {"load_factor": []}
    for out in scene.outputs:
        history[out.name] = []

    def record(rec, state):
        history["load_factor"].append(rec.load_factor)
        for out in scene.outputs:
            history[out.name].append(out.value(model, state))
        if on_step is not None:
            on_step(rec, state, history)
        if progress is not None:
            progress(rec)

    t0 = time.perf_counter()
    a = scene.analysis
    if a.method == "load_control":
        result = load_control(model, a.load_factors, settings=a.newton, on_step=record)
    elif a.method == "arc_length":
        result = arc_length(model, lam_max=max(a.load_factors), initial_increment=a.arc_increment,
                            max_load_increment=a.max_load_increment, settings=a.newton, on_step=record)
    else:
        raise ValueError(f"analysis method must be 'load_control' or 'arc_length', got {a.method!r}")
    wall = time.perf_counter() - t0
    errors = compare_with_reference(history, scene.reference) if scene.reference else []
    return RunSummary(scene.name, model.n_dof, model.body.mesh.n_elements, result, history, errors, wall)
