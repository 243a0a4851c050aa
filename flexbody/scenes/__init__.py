"""Scenes: a model, its analysis (static or dynamic), tracked outputs and reference data, runnable by name or
from a scene file (TOML or Python, docs/scenes.md)."""

from flexbody.scenes.analysis import DynamicAnalysis, StaticAnalysis
from flexbody.scenes.builtin import BUILTIN, build
from flexbody.scenes.reference import Reference
from flexbody.scenes.runner import run_scene
from flexbody.scenes.scene import Scene
from flexbody.scenes.sources import SceneError, load_scene, open_scene
from flexbody.scenes.toml_scene import load_toml_scene
from flexbody.scenes.tracked import AngularVelocity, Output, RadialDisplacement

__all__ = ["Output", "RadialDisplacement", "AngularVelocity", "Reference", "Scene", "StaticAnalysis",
           "DynamicAnalysis", "run_scene", "BUILTIN", "build", "SceneError",
           "load_scene", "open_scene", "load_toml_scene"]
