"""The scene a command reads: opened by name or path, built with the ``--set`` parameters, and the files it
reads (which no output may overwrite)."""

from __future__ import annotations

import os
import sys

from flexbody.cli.errors import CliError


def open_source(name: str):
    """The :class:`flexbody.scenes.sources.SceneSource` of a built-in scene name or a scene file's path."""
    from flexbody.scenes.sources import SceneError, open_scene
    try:
        return open_scene(name)
    except SceneError as exc:
        raise CliError(str(exc)) from None


def build_scene(source, params: dict):
    """The scene of ``source`` with ``params``; a bad scene, or a static one whose supports leave a rigid
    motion free (checked now, before the kernels compile), is a CliError; a mesh of several separate pieces
    is a note on stderr (each piece moves on its own)."""
    import numpy as np

    from flexbody.assembly import ModelError
    from flexbody.scenes.sources import SceneError
    try:
        scene = source.build(params)
        if scene.kind == "static":
            scene.model.check_static_support()
    except (SceneError, ModelError) as exc:
        raise CliError(str(exc)) from None
    count, labels = scene.model.body.mesh.connected_components()
    if count > 1:
        sizes = np.bincount(labels)
        print(f"note: the mesh of {scene.name} has {count} separate pieces (nodes per piece: "
              f"{', '.join(map(str, sizes[:10]))}{', ...' if count > 10 else ''})", file=sys.stderr)
    return scene


def input_files(source, scene=None) -> dict[str, str]:
    """The files a scene reads: its scene file, and a TOML scene's mesh and reference files."""
    if source.kind == "builtin":
        return {}
    files = {"scene file": source.name}
    if scene is not None and source.kind == "toml":
        folder = os.path.dirname(os.path.abspath(source.name))
        for key, what in (("mesh.file", "mesh file"), ("reference.file", "reference file")):
            value = scene.parameters.get(key)
            if isinstance(value, str):
                files[what] = os.path.join(folder, value)
    return files
