"""Scenes: a model, its analysis, tracked outputs and reference data, runnable by name."""

from flexbody.scenes.scene import Output, Reference, Scene, StaticAnalysis, run_scene
from flexbody.scenes.builtin import BUILTIN, build

__all__ = ["Output", "Reference", "Scene", "StaticAnalysis", "run_scene", "BUILTIN", "build"]
