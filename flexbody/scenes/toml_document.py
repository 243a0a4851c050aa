"""A scene file as a document: reading it, the key vocabulary of its tables, and the ``--set`` overrides by
dotted key (``mesh.nx``, ``load.0.value``) or by the last part of a key when that is unambiguous."""

from __future__ import annotations

import copy
import inspect
from pathlib import Path
import tomllib
from typing import Any, Callable

from flexbody.scenes.toml_values import SceneError


#: mesh generators by name, and which of their parameters set the mesh density (used by ``flexbody bench``)
GENERATOR_NAMES = ("strip", "slit_annulus", "annulus", "cylinder", "spherical_cap", "regular_polygon")
DENSITY_PARAMETERS = {
    "strip": ("nx", "ny"), "slit_annulus": ("n_radial", "n_circ"), "annulus": ("n_radial", "n_circ"),
    "cylinder": ("n_circ", "n_axial"), "spherical_cap": ("n_meridian", "n_circ"), "regular_polygon": ("n_rings",),
}
#: generator parameters in radians that may be given in degrees with the suffix ``_deg``
RADIAN_PARAMETERS = ("angle",)
SECTIONS = ("name", "description", "mesh", "material", "element", "bc", "load", "point_mass", "analysis", "output",
             "reference")
SELECTORS = ("set", "nodes", "near", "plane", "ring")
HUB_SHAPES = ("radius", "polygon")             # a hub's nodes may also be given by these
VELOCITY_FIELD_KEYS = ("direction", "amplitude", "radial", "modes", "phase", "inner_radius", "outer_radius",
                        "center", "axis")
MATERIAL_KEYS = ("young", "poisson", "thickness", "density", "shear_correction")
ANALYSIS_KEYS = ("method", "steps", "max_load_factor", "load_factors", "arc_increment", "max_load_increment",
                  "max_steps", "min_increment_ratio", "max_increment_ratio", "desired_iterations", "newton",
                  "stability")
DYNAMIC_KEYS = ("type", "dt", "end_time", "rho_inf", "policy", "output_every", "gravity", "load_ramp_time",
                 "initial", "hub", "integrator", "damping", "adaptive", "mass")
DAMPING_KEYS = ("alpha_mass", "beta_stiffness", "ratio", "frequencies_hz")
OUTPUT_TYPES = ("displacement", "radial", "angular_velocity")
ELEMENT_KEYS = ("tying", "kernel")
COMPONENTS = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


# ----------------------------------------------------------------------------------------------------------
# Reading and overriding
# ----------------------------------------------------------------------------------------------------------

def read_toml(path: str | Path) -> dict:
    """The parsed TOML document of a scene file.

    Raises
    ------
    SceneError
        If the file is missing or not valid TOML (the message carries tomllib's line and column).
    """
    path = Path(path)
    if not path.is_file():
        raise SceneError(f"scene file {str(path)!r} does not exist")
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene file {str(path)!r} is not valid TOML: {exc}") from None
    except OSError as exc:
        raise SceneError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}") from None


def flatten(doc: dict, prefix: str = "") -> dict[str, Any]:
    """The leaves of a TOML document by dotted key; arrays of tables are indexed (``load.0.value``)."""
    out: dict[str, Any] = {}
    for key, value in doc.items():
        path = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, path + "."))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for i, item in enumerate(value):
                out.update(flatten(item, f"{path}.{i}."))
        else:
            out[path] = value
    return out


def section_keys(doc: dict) -> dict[str, str]:
    """Bare keys that may be set although the document does not write them: key -> dotted key."""
    keys = {k: f"material.{k}" for k in MATERIAL_KEYS}
    keys.update({k: f"analysis.{k}" for k in ANALYSIS_KEYS if k != "newton"})
    keys.update({k: f"analysis.{k}" for k in DYNAMIC_KEYS if k not in ("type", "initial", "hub", "integrator",
                                                                           "damping")})
    keys.update({k: f"element.{k}" for k in ELEMENT_KEYS})
    generator = doc.get("mesh", {}).get("generator") if isinstance(doc.get("mesh"), dict) else None
    if generator in GENERATOR_NAMES:
        for k in inspect.signature(generator_function(generator)).parameters:
            keys[k] = f"mesh.{k}"
    return keys


def resolve_key(doc: dict, key: str, where: str) -> str:
    """The dotted key that ``--set key=...`` addresses in ``doc`` (see the module docstring)."""
    leaves = flatten(doc)
    if "." in key or key in leaves:
        return key
    matches = [k for k in leaves if k.rsplit(".", 1)[-1] == key]
    if len(matches) == 1:
        return matches[0]
    if len(matches) > 1:
        raise SceneError(f"{where}: --set key {key!r} is ambiguous; use one of {', '.join(matches)}")
    known = section_keys(doc)
    if key in known:
        return known[key]
    raise SceneError(f"{where}: unknown parameter {key!r}; documented keys: {', '.join(sorted(leaves))} "
                     "(or any dotted key of the format, see docs/scenes.md)")


def apply_overrides(doc: dict, overrides: dict[str, Any], where: str) -> dict:
    """A copy of ``doc`` with the ``--set`` overrides applied (keys as in :func:`resolve_key`)."""
    doc = copy.deepcopy(doc)
    for key, value in overrides.items():
        parts = resolve_key(doc, key, where).split(".")
        node: Any = doc
        for depth, part in enumerate(parts[:-1]):
            here = ".".join(parts[:depth + 1])
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise SceneError(f"{where}: --set {key}: {'.'.join(parts[:depth])} has no entry {part!r} "
                                     f"({len(node)} entries, numbered from 0)")
                node = node[int(part)]
            elif isinstance(node, dict):
                node = node.setdefault(part, {})  # a new table; the format check rejects unknown ones
            else:
                raise SceneError(f"{where}: --set {key}: {here!r} is a value, not a table")
        if not isinstance(node, dict):
            raise SceneError(f"{where}: --set {key}: {'.'.join(parts[:-1])!r} is not a table")
        node[parts[-1]] = value
    return doc


def generator_function(name: str) -> Callable:
    """The mesh generator of :mod:`flexbody.mesh.generators` named ``name``."""
    from flexbody.mesh import generators
    return getattr(generators, name)
