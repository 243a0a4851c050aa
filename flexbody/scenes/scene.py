"""The scene: a model, its analysis (static or dynamic), the tracked outputs and an optional reference.

A scene is data; it is built by the built-in builders (:mod:`flexbody.scenes.builtin`), a TOML file
(:mod:`flexbody.scenes.toml_scene`) or a user's Python file, and run by :func:`flexbody.scenes.runner.run_scene`.
The pieces live in their own modules: tracked outputs (:mod:`flexbody.scenes.tracked`), analyses
(:mod:`flexbody.scenes.analysis`), the reference (:mod:`flexbody.scenes.reference`), the run
(:mod:`flexbody.scenes.runner`), its summary (:mod:`flexbody.scenes.summary`) and the comparison with the
reference (:mod:`flexbody.scenes.compare`). This module also gives their names under the import path
``flexbody.scenes.scene`` that scene files, benchmarks and the docs use (none of them imports this module,
so there is no cycle).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from flexbody.assembly import Model
from flexbody.scenes.analysis import DynamicAnalysis, RestartPoint, StaticAnalysis
from flexbody.scenes.compare import compare, compare_with_reference, nearest_on_polyline
from flexbody.scenes.kernel_setup import CompileNotice, kernel_threads, warm_up_kernels
from flexbody.scenes.reference import Reference
from flexbody.scenes.runner import run_scene
from flexbody.scenes.summary import DynamicRunSummary, RunSummary, StaticRunSummary, stability_summary, timings
from flexbody.scenes.tracked import AngularVelocity, Output, RadialDisplacement, check_outputs

__all__ = ["Scene", "Output", "RadialDisplacement", "AngularVelocity", "Reference", "StaticAnalysis",
           "DynamicAnalysis", "RestartPoint", "RunSummary", "StaticRunSummary", "DynamicRunSummary", "run_scene",
           "compare", "compare_with_reference",
           "nearest_on_polyline", "CompileNotice", "warm_up_kernels", "kernel_threads", "stability_summary",
           "timings"]


@dataclass
class Scene:
    """A named model with its analysis, tracked outputs (:mod:`flexbody.scenes.tracked`), optional reference
    and the parameters it was built with (``parameters``: what ``--set`` may change for a built-in scene).
    Output node indices are checked against the mesh here."""

    name: str
    description: str
    model: Model
    analysis: StaticAnalysis | DynamicAnalysis
    outputs: list
    reference: Reference | None = None
    parameters: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_outputs(self.outputs, self.model.body.n_nodes)

    @property
    def kind(self) -> str:
        """"dynamic" for a :class:`DynamicAnalysis`, else "static"."""
        return "dynamic" if isinstance(self.analysis, DynamicAnalysis) else "static"
