"""Where a scene comes from: a built-in name, a user's Python file (``build(**parameters) -> Scene``) or a
user's TOML file (:mod:`flexbody.scenes.toml_scene`). All three build with ``--set`` style overrides and
report a bad scene as one :class:`SceneError` line."""

from __future__ import annotations

from dataclasses import dataclass
import functools
import importlib.util
import inspect
import os
from pathlib import Path
from typing import Any, Callable

from flexbody.scenes import registry
from flexbody.scenes.scene import Scene
from flexbody.scenes.toml_scene import MAX_STEPS, SceneError, density_parameters, load_toml_scene

__all__ = ["SceneError", "SceneSource", "load_scene", "open_scene", "scene_kind"]


@dataclass
class SceneSource:
    """A scene that can be built with parameter overrides.

    Attributes
    ----------
    name : what the user gave (a built-in name or a file path)
    kind : "builtin", "python" or "toml"
    builder : builds the scene from a dict of overrides
    keys : the documented parameter keys (None: any key, as for a ``build(**kwargs)`` file)
    density : the mesh-density parameters and their default values (used by ``flexbody bench``)
    """

    name: str
    kind: str
    builder: Callable[[dict], Scene]
    keys: list[str] | None
    density: dict[str, Any]

    def build(self, overrides: dict[str, Any] | None = None) -> Scene:
        """The scene with ``overrides`` applied; raises :class:`SceneError` (one line) on bad input."""
        overrides = dict(overrides or {})
        if self.keys is not None:
            unknown = [k for k in overrides if k not in self.keys]
            if unknown:
                raise SceneError(f"unknown parameter(s) {unknown} for scene {self.name!r}; "
                                 f"documented keys: {', '.join(self.keys)}")
        if self.kind != "toml" and "steps" in overrides:   # a TOML file checks its analysis.steps itself
            steps = overrides["steps"]
            if isinstance(steps, bool) or not isinstance(steps, int) or not 1 <= steps <= MAX_STEPS:
                raise SceneError(f"scene {self.name!r}: steps must be an integer in 1..{MAX_STEPS}, got {steps!r}")
        try:
            return self.builder(overrides)
        except SceneError:
            raise
        except (ValueError, TypeError, KeyError) as exc:
            msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
            text = str(msg).splitlines()[0] if msg else repr(exc)      # (a `!r` here quoted every message)
            raise SceneError(f"cannot build scene {self.name!r}: {text}") from None


def scene_kind(name: str) -> str:
    """"builtin", "python" or "toml" for a scene argument (by suffix for files)."""
    if name in registry.SCENES:
        return "builtin"
    suffix = Path(name).suffix.lower()
    if suffix == ".py":
        return "python"
    if suffix == ".toml":
        return "toml"
    raise SceneError(f"unknown scene {name!r}; built-in scenes: {', '.join(registry.SCENES)} "
                     "(or give a path to a .toml or .py scene file)")


def _function_source(name: str, kind: str, func: Callable, density_keys: tuple[str, ...] | None = None) -> SceneSource:
    """A builder function's source; its density parameters are ``density_keys`` (a built-in scene's, from the
    registry) or, for a user's ``build``, the integer keywords named ``n...`` (except ``n_sides``)."""
    params = inspect.signature(func).parameters
    any_key = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    keys = None if any_key else [k for k, p in params.items()
                                 if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    if density_keys is None:
        density_keys = tuple(k for k, p in params.items() if k.startswith("n") and isinstance(p.default, int)
                             and not isinstance(p.default, bool) and k != "n_sides")
    density = {k: params[k].default for k in density_keys}
    return SceneSource(name, kind, lambda overrides: func(**overrides), keys, density)


def _python_builder(path: str) -> Callable:
    if not os.path.isfile(path):
        raise SceneError(f"scene file {path!r} does not exist")
    spec = importlib.util.spec_from_file_location("flexbody_user_scene", path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # a user's file: report, do not trace back into flexbody
        raise SceneError(f"cannot load scene file {path!r}: {type(exc).__name__}: {exc}") from None
    if not callable(getattr(module, "build", None)):
        raise SceneError(f"scene file {path!r} must define a function build(**parameters) -> Scene")
    return _checked_build(path, module.build)


def _checked_build(path: str, build: Callable) -> Callable:
    """A user's ``build`` whose exceptions and wrong return values become one SceneError line."""

    @functools.wraps(build)
    def checked(**parameters) -> Scene:
        try:
            scene = build(**parameters)
        except SceneError:
            raise
        except Exception as exc:  # a user's code: report, do not trace back into it
            text = str(exc).splitlines()[0] if str(exc) else ""
            raise SceneError(f"cannot build scene {path!r}: build() raised {type(exc).__name__}"
                             + (f": {text}" if text else "")) from None
        if not isinstance(scene, Scene):
            shown = repr(scene)
            shown = shown if len(shown) <= 60 else shown[:57] + "..."
            raise SceneError(f"cannot build scene {path!r}: build() returned {shown}, expected a Scene")
        return scene

    return checked


def open_scene(name: str) -> SceneSource:
    """The :class:`SceneSource` of a built-in scene name or a ``.py`` / ``.toml`` scene file."""
    kind = scene_kind(name)
    if kind == "builtin":
        entry = registry.builtin_scene(name)
        return _function_source(name, kind, entry.builder, entry.density)
    if kind == "python":
        return _function_source(name, kind, _python_builder(name))
    density = density_parameters(name)  # also reports a missing or malformed file now
    return SceneSource(name, kind, lambda overrides: load_toml_scene(name, overrides), None, density)


def load_scene(scene: str | os.PathLike, **overrides: Any) -> Scene:
    """Build a scene: a built-in one by name, or a ``.toml`` or ``.py`` scene file, with parameter overrides.

    Parameters
    ----------
    scene : str or os.PathLike
        A built-in scene name (``flexbody list`` lists them, e.g. "cantilever_end_moment", "hemisphere",
        "spinning_plate") or the path of a scene file (docs/scenes.md).
    **overrides
        Parameters to change, as ``flexbody run SCENE --set KEY=VALUE`` changes them (e.g. ``nx=8``,
        ``thickness=0.02``; dotted keys of a TOML file as ``**{"mesh.nx": 8}``).

    Returns
    -------
    Scene
        The model, its analysis, the tracked outputs and the reference; run it with
        :func:`flexbody.scenes.scene.run_scene`.

    Raises
    ------
    SceneError
        An unknown scene or parameter, or a bad value: one line naming it.

    Examples
    --------
    >>> import flexbody as fb
    >>> scene = fb.load_scene("cantilever_end_shear", nx=4, steps=2)
    >>> scene.kind, scene.model.n_dof
    ('static', 120)
    """
    name = os.fspath(scene) if isinstance(scene, (str, os.PathLike)) else scene
    if not isinstance(name, str):
        raise SceneError(f"scene must be a built-in scene name or a scene file path, got {scene!r}")
    return open_scene(name).build(overrides)
