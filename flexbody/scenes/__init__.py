"""Scenes: a model, its analysis, tracked outputs and reference data, runnable by name or from a scene file
(TOML or Python, docs/scenes.md)."""

from flexbody.scenes.scene import Output, Reference, Scene, StaticAnalysis, run_scene
from flexbody.scenes.builtin import BUILTIN, build
from flexbody.scenes.sources import SceneError, open_scene
from flexbody.scenes.toml_scene import load_toml_scene

__all__ = ["Output", "Reference", "Scene", "StaticAnalysis", "run_scene", "BUILTIN", "build", "SceneError",
           "open_scene", "load_toml_scene"]
