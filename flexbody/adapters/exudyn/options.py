"""Which exudyn model each built-in scene has, and the ``exudyn_`` options that ride along in its parameters.

Imports no exudyn: the option checks run before any model is built.
"""

from __future__ import annotations

from flexbody.scenes.registry import SCENES, exudyn_scenes
from flexbody.scenes.scene import Scene

#: exudyn models available for each built-in scene, the default first (from the scene registry)
MODELS: dict[str, tuple[str, ...]] = {name: entry.exudyn_models for name, entry in SCENES.items()
                                      if entry.exudyn_models}

#: dynamic scenes with an exudyn model (``compare`` runs them as dynamic comparisons)
DYNAMIC_SCENES = exudyn_scenes("dynamic")

#: the prefix of exudyn options among the scene parameters
OPTION_PREFIX = "exudyn_"
#: options of the dynamic scenes only
DYNAMIC_OPTIONS = ("energy_every", "reference", "reference_dt", "reference_end_time")
#: options of the static scenes only
STATIC_OPTIONS = ("steps", "rtol")
#: every option, without the prefix
OPTIONS = ("model", "nx", "ny") + STATIC_OPTIONS + DYNAMIC_OPTIONS


def split_options(params: dict | None) -> tuple[dict, dict]:
    """Split parameters into (flexbody scene parameters, exudyn options without the ``exudyn_`` prefix)."""
    scene_params, options = {}, {}
    for key, value in (params or {}).items():
        if key.startswith(OPTION_PREFIX):
            name = key[len(OPTION_PREFIX):]
            if name not in OPTIONS:
                raise KeyError(f"unknown exudyn option {key!r}; options: "
                               + ", ".join(OPTION_PREFIX + o for o in OPTIONS))
            options[name] = value
        else:
            scene_params[key] = value
    return scene_params, options


def model_kind(scene_name: str, options: dict) -> str:
    """The exudyn model kind for a scene and options; raises KeyError/ValueError for unsupported ones."""
    if scene_name not in MODELS:
        raise KeyError(f"no exudyn model for scene {scene_name!r}; exudyn models exist for: {', '.join(MODELS)}")
    kind = options.get("model", MODELS[scene_name][0])
    if kind not in MODELS[scene_name]:
        raise ValueError(f"exudyn_model for {scene_name!r} must be one of {MODELS[scene_name]}, got {kind!r}")
    return kind


def _default_mesh(scene: Scene, kind: str) -> tuple[int, int]:
    """Element counts from the scene's two mesh parameters (the registry's ``exudyn_mesh``): plates one quad
    per cell, beams one element per flexbody node spacing (2 nx)."""
    nx, ny = (scene.parameters[key] for key in SCENES[scene.name].exudyn_mesh)
    return (2 * nx, 1) if kind.startswith("beam") else (nx, ny)


def element_counts(scene: Scene, kind: str, options: dict) -> tuple[int, int]:
    """(nx, ny) of the exudyn model: ``exudyn_nx``, ``exudyn_ny`` or the scene's mesh (``_default_mesh``)."""
    nx0, ny0 = _default_mesh(scene, kind)
    nx, ny = int(options.get("nx", nx0)), int(options.get("ny", ny0))
    if nx < 1 or ny < 1:
        raise ValueError(f"exudyn_nx and exudyn_ny must be >= 1, got {nx} and {ny}")
    return nx, ny
