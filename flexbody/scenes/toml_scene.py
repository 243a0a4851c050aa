"""TOML scene files: a shell model described in a text file, run with ``flexbody run FILE.toml``.

The format is documented in ``docs/scenes.md``; ``examples/clamped_plate.toml`` is a worked example.
In short (every table but ``[mesh]``, ``[material]`` and one ``[[output]]`` is optional)::

    name = "clamped_plate"
    [mesh]                 generator = "strip" + its parameters, or file = "plate.msh"
    [material]             young, poisson, thickness, density, shear_correction
    [element]              tying = true, kernel = "numba"
    [[bc]]                 type = "fix" | "symmetry" on a node selection
    [[load]]               type = "nodal" | "edge_force" | "edge_moment" | "surface_force" | "pressure";
                           time_function = {type = "ramp" | "pulse" | "table", ...} (dynamic)
    [[point_mass]]         mass, rotary, a node selection: tip masses (dynamic)
    [analysis]             method = "load_control" | "arc_length", steps, max_load_factor, ...
    [analysis.newton]      any field of integrators.newton.NewtonSettings
      or [analysis]        type = "dynamic", dt, end_time, rho_inf, policy, output_every, gravity, load_ramp_time,
                           adaptive (error-controlled time steps)
    [analysis.initial]     velocity, angular_velocity, center: a rigid initial velocity field (dynamic);
                           state = "steady_spin": start on the steady spin at angular_velocity instead
    [[analysis.initial.velocity_field]]  direction, amplitude, radial, modes, ...: added (a kick)
    [analysis.hub]         a node selection (or radius, or polygon), angular_velocity, ramp_time, center:
                           a hub spun up (dynamic)
    [analysis.integrator]  rtol, atol, max_iterations, refresh_ratio, max_cutbacks, error_tolerance, min_step,
                           max_step, safety, ... (dynamic)
    [analysis.damping]     alpha_mass (1/s) and/or beta_stiffness (s), or ratio + frequencies_hz = [f1, f2]:
                           Rayleigh damping (dynamic)
                           [analysis] mass = "lumped" (default) | "consistent": the mass matrix (dynamic)
    [[output]]             name, a node selection of one node, component or direction, scale; or
                           type = "radial" (mean radial displacement of nodes) | "angular_velocity"
    [reference]            file = "ref.csv", load_factor (or time) = column, columns = {output = column}

A node selection is exactly one of ``set`` (a node or edge set name, or a list of them), ``nodes`` (indices),
``near`` (the node nearest a point), ``plane`` (``{point = [...], normal = [...]}``: the nodes on it) or
``ring`` (``{radius = r, center = [...], axis = [...]}``: the nodes at distance r from the axis).

Every error is a :class:`SceneError` whose one-line message names the file, the key and the bad value.
``--set KEY=VALUE`` overrides a value by its dotted key (``mesh.nx``, ``load.0.value``) or by its last part
when that is unambiguous (``nx``, ``thickness``, ``steps``).
"""

from __future__ import annotations

import copy
import inspect
import math
from pathlib import Path
import tomllib
from typing import Any, Callable

import numpy as np

from flexbody.scenes.scene import (AngularVelocity, DynamicAnalysis, Output, RadialDisplacement, Reference, Scene,
                                   StaticAnalysis)
from flexbody.shell.variants import VARIANT_KEYS, variant_from_key


class SceneError(ValueError):
    """A scene that cannot be built as given; the message is one line naming the key and value."""


_REQUIRED = object()

#: the most load steps a scene may ask for (a path needs far fewer; 1e10 steps exhausted the memory)
MAX_STEPS = 100_000

#: mesh generators by name, and which of their parameters set the mesh density (used by ``flexbody bench``)
GENERATOR_NAMES = ("strip", "slit_annulus", "annulus", "cylinder", "spherical_cap", "regular_polygon")
DENSITY_PARAMETERS = {
    "strip": ("nx", "ny"), "slit_annulus": ("n_radial", "n_circ"), "annulus": ("n_radial", "n_circ"),
    "cylinder": ("n_circ", "n_axial"), "spherical_cap": ("n_meridian", "n_circ"), "regular_polygon": ("n_rings",),
}
#: generator parameters in radians that may be given in degrees with the suffix ``_deg``
_RADIAN_PARAMETERS = ("angle",)
_SECTIONS = ("name", "description", "mesh", "material", "element", "bc", "load", "point_mass", "analysis", "output",
             "reference")
_SELECTORS = ("set", "nodes", "near", "plane", "ring")
_HUB_SHAPES = ("radius", "polygon")             # a hub's nodes may also be given by these
_VELOCITY_FIELD_KEYS = ("direction", "amplitude", "radial", "modes", "phase", "inner_radius", "outer_radius",
                        "center", "axis")
_MATERIAL_KEYS = ("young", "poisson", "thickness", "density", "shear_correction")
_ANALYSIS_KEYS = ("method", "steps", "max_load_factor", "load_factors", "arc_increment", "max_load_increment",
                  "max_steps", "min_increment_ratio", "max_increment_ratio", "desired_iterations", "newton",
                  "stability")
_DYNAMIC_KEYS = ("type", "dt", "end_time", "rho_inf", "policy", "output_every", "gravity", "load_ramp_time",
                 "initial", "hub", "integrator", "damping", "adaptive", "mass")
_DAMPING_KEYS = ("alpha_mass", "beta_stiffness", "ratio", "frequencies_hz")
_OUTPUT_TYPES = ("displacement", "radial", "angular_velocity")
_ELEMENT_KEYS = ("tying", "kernel")
_COMPONENTS = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


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


def _section_keys(doc: dict) -> dict[str, str]:
    """Bare keys that may be set although the document does not write them: key -> dotted key."""
    keys = {k: f"material.{k}" for k in _MATERIAL_KEYS}
    keys.update({k: f"analysis.{k}" for k in _ANALYSIS_KEYS if k != "newton"})
    keys.update({k: f"analysis.{k}" for k in _DYNAMIC_KEYS if k not in ("type", "initial", "hub", "integrator",
                                                                           "damping")})
    keys.update({k: f"element.{k}" for k in _ELEMENT_KEYS})
    generator = doc.get("mesh", {}).get("generator") if isinstance(doc.get("mesh"), dict) else None
    if generator in GENERATOR_NAMES:
        for k in inspect.signature(_generator(generator)).parameters:
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
    known = _section_keys(doc)
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


# ----------------------------------------------------------------------------------------------------------
# Typed access to a table, with one-line errors naming the key
# ----------------------------------------------------------------------------------------------------------

class _Table:
    """A TOML table read key by key; :meth:`done` reports the keys nobody asked for."""

    def __init__(self, data: Any, path: str, where: str):
        if not isinstance(data, dict):
            raise SceneError(f"{where}: {path} must be a table, got {data!r}")
        self.data, self.path, self.where = data, path, where
        self.used: set[str] = set()

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, message: str) -> SceneError:
        return SceneError(f"{self.where}: {self.key(name)} {message}")

    def has(self, name: str) -> bool:
        return name in self.data

    def raw(self, name: str, default: Any = _REQUIRED) -> Any:
        self.used.add(name)
        if name not in self.data:
            if default is _REQUIRED:
                raise SceneError(f"{self.where}: missing key {self.key(name)}")
            return default
        return self.data[name]

    def number(self, name: str, default: Any = _REQUIRED, *, positive: bool = False) -> float:
        value = self.raw(name, default)
        if value is None and default is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(name, f"must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.error(name, f"must be > 0, got {value!r}")
        return float(value)

    def integer(self, name: str, default: Any = _REQUIRED, *, minimum: int = 1, maximum: int | None = None) -> int:
        value = self.raw(name, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(name, f"must be an integer >= {minimum}, got {value!r}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be an integer in {minimum}..{maximum}, got {value!r}")
        return value

    def boolean(self, name: str, default: Any = _REQUIRED) -> bool:
        value = self.raw(name, default)
        if not isinstance(value, bool):
            raise self.error(name, f"must be true or false, got {value!r}")
        return value

    def string(self, name: str, default: Any = _REQUIRED, *, choices: tuple[str, ...] | None = None) -> str:
        value = self.raw(name, default)
        if not isinstance(value, str) or not value:
            raise self.error(name, f"must be a non-empty string, got {value!r}")
        if choices is not None and value not in choices:
            raise self.error(name, f"must be one of {', '.join(map(repr, choices))}, got {value!r}")
        return value

    def vector(self, name: str, default: Any = _REQUIRED) -> np.ndarray:
        value = self.raw(name, default)
        ok = (isinstance(value, list) and len(value) == 3
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
        if not ok:
            raise self.error(name, f"must be a list of three finite numbers, got {value!r}")
        return np.array(value, dtype=float)

    def direction(self, name: str, vector: np.ndarray) -> np.ndarray:
        """The unit vector of the direction ``vector`` read from key ``name`` (a nonzero vector, any size)."""
        from flexbody.frames import unit_vector
        try:
            return unit_vector(vector, "direction")
        except ValueError:
            raise self.error(name, f"must be a nonzero vector, got {vector.tolist()}") from None

    def numbers(self, name: str, default: Any = _REQUIRED) -> list[float]:
        value = self.raw(name, default)
        ok = (isinstance(value, list) and len(value) > 0
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
        if not ok:
            raise self.error(name, f"must be a non-empty list of finite numbers, got {value!r}")
        return [float(v) for v in value]

    def table(self, name: str, default: Any = _REQUIRED) -> "_Table":
        return _Table(self.raw(name, default), self.key(name), self.where)

    def tables(self, name: str) -> list["_Table"]:
        value = self.raw(name, [])
        if isinstance(value, dict):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error(name, f"must be an array of tables ([[{name}]]), got {value!r}")
        return [_Table(v, f"{self.key(name)}.{i}", self.where) for i, v in enumerate(value)]

    def reject_unknown(self, known: tuple[str, ...]) -> None:
        """Report a key that is not in ``known`` before anything is built."""
        unknown = [k for k in self.data if k not in known]
        if unknown:
            where = f"[{self.path}]" if self.path else "the top level"
            raise SceneError(f"{self.where}: unknown key {self.key(unknown[0])!r}; "
                             f"keys allowed in {where}: {', '.join(known)}")

    def done(self, known: tuple[str, ...] | list[str] | None = None) -> None:
        unknown = [k for k in self.data if k not in self.used]
        if unknown:
            allowed = list(dict.fromkeys(known)) if known is not None else sorted(self.used)
            where = f"[{self.path}]" if self.path else "the top level"
            raise SceneError(f"{self.where}: unknown key {self.key(unknown[0])!r}; "
                             f"keys allowed in {where}: {', '.join(allowed)}")


def _wrap(where: str, key: str, func: Callable, *args, **kwargs):
    """Call a flexbody constructor and turn its ValueError into a one-line SceneError naming ``key``."""
    try:
        return func(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if message.lower().startswith(key.lower() + " "):  # "material: material thickness ..." -> once
            raise SceneError(f"{where}: {message}") from None
        raise SceneError(f"{where}: {key}: {message}") from None


# ----------------------------------------------------------------------------------------------------------
# Sections
# ----------------------------------------------------------------------------------------------------------

def _generator(name: str) -> Callable:
    from flexbody.mesh import generators
    return getattr(generators, name)


def _build_mesh(t: _Table, folder: Path):
    """The mesh of ``[mesh]``: a generator and its parameters, or a mesh file."""
    if t.has("generator") == t.has("file"):
        raise SceneError(f"{t.where}: [mesh] needs exactly one of 'generator' (one of "
                         f"{', '.join(GENERATOR_NAMES)}) or 'file'")
    if t.has("file"):
        from flexbody.mesh.io import read_mesh
        path = Path(t.string("file"))
        t.done(["file"])
        return _wrap(t.where, "mesh.file", read_mesh, path if path.is_absolute() else folder / path)
    name = t.string("generator", choices=GENERATOR_NAMES)
    func = _generator(name)
    signature = inspect.signature(func).parameters
    kwargs = {}
    for pname, param in signature.items():
        deg = f"{pname}_deg"
        if pname in _RADIAN_PARAMETERS and t.has(deg):
            if t.has(pname):
                raise SceneError(f"{t.where}: give mesh.{pname} (radians) or mesh.{deg} (degrees), not both")
            kwargs[pname] = math.radians(t.number(deg))
        elif t.has(pname):
            kwargs[pname] = t.raw(pname)
        elif param.default is inspect.Parameter.empty:
            raise SceneError(f"{t.where}: missing key mesh.{pname} (generator {name!r} needs "
                             f"{', '.join(p for p, q in signature.items() if q.default is inspect.Parameter.empty)})")
    known = ["generator", *signature, *(f"{p}_deg" for p in signature if p in _RADIAN_PARAMETERS)]
    t.done(known)
    return _wrap(t.where, f"mesh (generator {name!r})", func, **kwargs)


def _select_nodes(t: _Table, mesh, *, single: bool = False) -> np.ndarray:
    """The nodes of a node selection: exactly one of set, nodes, near, plane."""
    given = [k for k in _SELECTORS if t.has(k)]
    if len(given) != 1:
        raise SceneError(f"{t.where}: [{t.path}] needs exactly one node selection of "
                         f"{', '.join(_SELECTORS)}, got {given or 'none'}")
    kind = given[0]
    if kind == "set":
        names = _set_names(t, "a set name or a list of set names")
        nodes = np.unique(np.concatenate([_wrap(t.where, t.key("set"), mesh.node_set, n) for n in names]))
    elif kind == "nodes":
        value = t.raw("nodes")
        if (not isinstance(value, list) or not value
                or not all(isinstance(i, int) and not isinstance(i, bool) for i in value)):
            raise t.error("nodes", f"must be a non-empty list of node indices, got {value!r}")
        bad = [i for i in value if not 0 <= i < mesh.n_nodes]
        if bad:
            raise t.error("nodes", f"names node {bad[0]}, but the mesh has nodes 0..{mesh.n_nodes - 1}")
        nodes = np.unique(np.array(value, dtype=int))
    elif kind == "near":
        nodes = np.array([_wrap(t.where, t.key("near"), mesh.nearest_node, t.vector("near"))])
    elif kind == "ring":
        ring = t.table("ring")
        radius = ring.number("radius", positive=True)
        center, axis = ring.vector("center", [0.0, 0.0, 0.0]), ring.vector("axis", [0.0, 0.0, 1.0])
        ring.done(["radius", "center", "axis"])
        n = ring.direction("axis", axis)
        r = mesh.nodes - center
        distance = np.linalg.norm(r - np.outer(r @ n, n), axis=1)
        size = float(np.ptp(mesh.nodes, axis=0).max()) or 1.0
        nodes = np.flatnonzero(np.abs(distance - radius) <= 1e-8 * size)
        if nodes.size == 0:
            raise SceneError(f"{t.where}: {t.key('ring')} selects no nodes (no node lies at distance {radius} "
                             f"from the axis through {center.tolist()} along {axis.tolist()})")
    else:
        plane = t.table("plane")
        point, normal = plane.vector("point"), plane.vector("normal")
        plane.done(["point", "normal"])
        size = float(np.ptp(mesh.nodes, axis=0).max()) or 1.0
        distance = (mesh.nodes - point) @ plane.direction("normal", normal)
        nodes = np.flatnonzero(np.abs(distance) <= 1e-8 * size)
        if nodes.size == 0:
            raise SceneError(f"{t.where}: {t.key('plane')} selects no nodes (no node lies on the plane "
                             f"through {point.tolist()} with normal {normal.tolist()})")
    if single and nodes.size != 1:
        raise SceneError(f"{t.where}: {t.key(kind)} must select one node, it selects {nodes.size}")
    return nodes


def _build_bcs(tables: list[_Table], mesh) -> list:
    from flexbody.constraints import Fix, Symmetry
    out = []
    for t in tables:
        kind = t.string("type", choices=("fix", "symmetry"))
        nodes = _select_nodes(t, mesh)
        if kind == "fix":
            comps = t.raw("components", "all")
            if not (isinstance(comps, str) or (isinstance(comps, list) and comps
                                               and all(isinstance(c, str) for c in comps))):
                raise t.error("components", f"must be a component name or a list of them, got {comps!r}")
            out.append(_wrap(t.where, t.key("components"), Fix, nodes, comps))
        else:
            if t.has("normal"):
                normal = t.vector("normal")
            elif t.has("plane"):
                normal = np.array(t.data["plane"]["normal"], dtype=float)
            else:
                raise SceneError(f"{t.where}: missing key {t.key('normal')} (the symmetry plane's normal)")
            out.append(_wrap(t.where, t.key("normal"), Symmetry, nodes, normal))
        t.done(["type", *_SELECTORS, "components" if kind == "fix" else "normal"])
    return out


def _set_names(t: _Table, what: str) -> list[str]:
    """The names of ``set`` (one name or a list of distinct names)."""
    value = t.raw("set")
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise t.error("set", f"must be {what}, got {value!r}")
    twice = [n for k, n in enumerate(names) if n in names[:k]]
    if twice:
        raise t.error("set", f"lists {twice[0]!r} twice, got {value!r}")
    return names


def _edges(t: _Table, mesh) -> np.ndarray:
    """The edges of ``set``: their union, each edge once even where the sets overlap."""
    names = _set_names(t, "an edge set name or a list of them")
    edges = np.vstack([_wrap(t.where, t.key("set"), mesh.edge_set, n) for n in names])
    _, first = np.unique(np.sort(edges[:, [0, 2]], axis=1), axis=0, return_index=True)
    return edges[np.sort(first)]


def _nodal_loads(vectors: np.ndarray, key: str) -> list:
    from flexbody.loads import NodalLoad
    nodes = np.flatnonzero(np.any(vectors != 0, axis=1))
    return [NodalLoad([i], **{key: vectors[i]}) for i in nodes]


def _build_loads(tables: list[_Table], mesh) -> list:
    from flexbody.loads import FollowerPressure, NodalLoad, nodal_vectors_from_area, nodal_vectors_from_edges
    kinds = ("nodal", "edge_force", "edge_moment", "surface_force", "pressure")
    out = []
    for t in tables:
        kind = t.string("type", choices=kinds)
        if kind == "nodal":
            nodes = _select_nodes(t, mesh)
            force, moment = t.vector("force", [0, 0, 0]), t.vector("moment", [0, 0, 0])
            follower = t.boolean("follower", False)
            out.append(_wrap(t.where, t.path, NodalLoad, nodes, force, moment, follower))
            t.done(["type", *_SELECTORS, "force", "moment", "follower"])
        elif kind in ("edge_force", "edge_moment"):
            edges, density = _edges(t, mesh), t.vector("density")
            vectors = nodal_vectors_from_edges(mesh.nodes, edges, density, mesh.n_nodes)
            out += _nodal_loads(vectors, "force" if kind == "edge_force" else "moment")
            t.done(["type", "set", "density"])
        elif kind == "surface_force":
            out += _nodal_loads(nodal_vectors_from_area(mesh, t.vector("density")), "force")
            t.done(["type", "density"])
        else:
            out.append(FollowerPressure(t.number("value"), _pressure_elements(t, mesh)))
            t.done(["type", "value", "set"])
    return out


def _pressure_elements(t: _Table, mesh):
    """The elements of a pressure load: all (no ``set``), or the element set(s) ``set`` names (a mesh file's
    physical surface groups)."""
    if not t.has("set"):
        return None
    names = t.raw("set")
    names = [names] if isinstance(names, str) else names
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise t.error("set", f"must be an element set name or a list of them, got {names!r}")
    known = mesh.element_sets
    for name in names:
        if name not in known:
            raise t.error("set", f"names element set {name!r}; the mesh has element sets: "
                                 f"{', '.join(sorted(known)) or 'none'} (the physical surfaces of a mesh file)")
    return np.unique(np.concatenate([known[n] for n in names]))


def _build_newton(t: _Table | None):
    from dataclasses import fields

    from integrators.newton import NewtonSettings
    if t is None:
        return NewtonSettings()
    kwargs = {}
    names = [f.name for f in fields(NewtonSettings)]
    for f in fields(NewtonSettings):
        if not t.has(f.name):
            continue
        if f.default.__class__ is bool:
            kwargs[f.name] = t.boolean(f.name)
        elif f.default.__class__ is int:
            kwargs[f.name] = t.integer(f.name)
        elif f.default.__class__ is str:
            kwargs[f.name] = t.string(f.name)
        else:
            kwargs[f.name] = t.number(f.name)
    t.done(names)
    return _wrap(t.where, "analysis.newton", NewtonSettings, **kwargs)


def _analysis_type(doc: dict, where: str) -> str:
    """"static" or "dynamic": the ``type`` of ``[analysis]`` (a SceneError for anything else)."""
    analysis = doc.get("analysis", {})
    if not isinstance(analysis, dict):
        return "static"          # reported as "analysis must be a table" when the analysis is built
    return _Table(analysis, "analysis", where).string("type", "static", choices=("static", "dynamic"))


def _build_integrator(t: _Table | None):
    """The :class:`integrators.generalized_alpha.AlphaSettings` of ``[analysis.integrator]``."""
    from dataclasses import fields

    from integrators.generalized_alpha import AlphaSettings
    if t is None:
        return None
    names = [f.name for f in fields(AlphaSettings) if f.name not in ("rho_inf", "policy", "adaptive")]
    kwargs = {}
    for f in fields(AlphaSettings):
        if f.name not in names or not t.has(f.name):
            continue
        if f.default.__class__ is bool:
            kwargs[f.name] = t.boolean(f.name)
        elif f.default.__class__ is int:
            kwargs[f.name] = t.integer(f.name, minimum=0)
        else:
            kwargs[f.name] = t.number(f.name, positive=True)
    t.done(names)
    return _wrap(t.where, "analysis.integrator", AlphaSettings, **kwargs)


def _build_damping(t: _Table):
    """The :class:`flexbody.dynamics.RayleighDamping` of ``[analysis.damping]``: ``alpha_mass`` (1/s) and
    ``beta_stiffness`` (s), or ``ratio`` with ``frequencies_hz = [f1, f2]`` (the ratio at both)."""
    from flexbody.dynamics import RayleighDamping
    t.reject_unknown(_DAMPING_KEYS)
    direct = [k for k in ("alpha_mass", "beta_stiffness") if t.has(k)]
    by_ratio = [k for k in ("ratio", "frequencies_hz") if t.has(k)]
    if direct and by_ratio:
        raise t.error(by_ratio[0], f"cannot be combined with {t.key(direct[0])}: give alpha_mass/beta_stiffness "
                                   "or ratio with frequencies_hz")
    if not (direct or by_ratio):
        raise SceneError(f"{t.where}: [{t.path}] needs alpha_mass and/or beta_stiffness, or ratio with "
                         "frequencies_hz")
    if direct:
        values = {}
        for k in direct:
            values[k] = t.number(k)
            if values[k] < 0:
                raise t.error(k, f"must be >= 0, got {values[k]!r}")
        return _wrap(t.where, t.path, RayleighDamping, **values)
    ratio = t.number("ratio")
    if ratio < 0:
        raise t.error("ratio", f"must be >= 0, got {ratio!r}")
    freqs = t.numbers("frequencies_hz")
    if len(freqs) == 1:
        freqs = freqs * 2
    if len(freqs) != 2 or not 0 < freqs[0] <= freqs[1]:
        raise t.error("frequencies_hz", f"must be one frequency or two 0 < f1 <= f2 (Hz), got {t.raw('frequencies_hz')!r}")
    return _wrap(t.where, t.path, RayleighDamping.from_ratio, ratio, tuple(freqs))


def _centre_of_mass(body, point_masses=(), mass: str = "lumped") -> np.ndarray:
    """The mass centre of the discrete body with its mass matrix (``mass``: "lumped" or "consistent")."""
    from flexbody.shell.inertia import shell_mass
    return shell_mass(body, mass, point_masses).centre(body.mesh.nodes)


def _hub_nodes(doc_analysis: Any, mesh, where: str) -> np.ndarray | None:
    """The nodes of ``[analysis.hub]`` (clamped to the hub), or None: a node selection, or the nodes within
    ``radius`` of the hub's axis, or inside the regular ``polygon`` about it (:func:`_hub_shape_nodes`)."""
    if not isinstance(doc_analysis, dict) or "hub" not in doc_analysis:
        return None
    hub = _Table(doc_analysis["hub"], "analysis.hub", where)
    given = [k for k in (*_SELECTORS, *_HUB_SHAPES) if hub.has(k)]
    if len(given) == 1 and given[0] in _HUB_SHAPES:
        return _hub_shape_nodes(hub, mesh, given[0])
    if len(given) != 1:
        raise SceneError(f"{where}: [analysis.hub] needs exactly one node selection of "
                         f"{', '.join((*_SELECTORS, *_HUB_SHAPES))}, got {given or 'none'}")
    return _select_nodes(hub, mesh)


def _hub_shape_nodes(hub: _Table, mesh, kind: str) -> np.ndarray:
    """The nodes within ``radius`` of the hub's axis, or inside ``polygon = {sides, circumradius, angle}``
    (vertex 0 at ``angle`` radians from the reference direction of the polar angle), both about the axis
    along ``angular_velocity`` (z if it is zero) through ``center``; boundary nodes included."""
    from flexbody.scenes.dynamic_run import polar_coordinates
    omega = hub.vector("angular_velocity")
    axis = omega if np.abs(omega).max() > 0 else np.array([0.0, 0.0, 1.0])
    center = hub.vector("center", [0.0, 0.0, 0.0])
    r, theta = polar_coordinates(mesh.nodes, center, axis)
    tol = 1e-8 * (float(np.ptp(mesh.nodes, axis=0).max()) or 1.0)
    if kind == "radius":
        radius = hub.number("radius", positive=True)
        nodes = np.flatnonzero(r <= radius + tol)
        what = f"within radius {radius}"
    else:
        poly = hub.table("polygon")
        sides = poly.integer("sides", minimum=3)
        circumradius = poly.number("circumradius", positive=True)
        angle = poly.number("angle", 0.0)
        poly.done(["sides", "circumradius", "angle"])
        normals = angle + np.pi / sides + 2 * np.pi * np.arange(sides) / sides     # the sides' normals
        apothem = circumradius * np.cos(np.pi / sides)
        inside = np.all(r[:, None] * np.cos(theta[:, None] - normals[None, :]) <= apothem + tol, axis=1)
        nodes = np.flatnonzero(inside)
        what = f"inside the {sides}-sided polygon of circumradius {circumradius}"
    if nodes.size == 0:
        raise SceneError(f"{hub.where}: {hub.key(kind)} selects no nodes (no node lies {what} about the axis "
                         f"through {center.tolist()} along {axis.tolist()})")
    return nodes


def _velocity_fields(it: _Table, positions: np.ndarray) -> np.ndarray:
    """The sum (n, 3) of the ``[[analysis.initial.velocity_field]]`` fields (zero without any)."""
    from flexbody.scenes.dynamic_run import modal_velocity_field
    total = np.zeros_like(positions)
    for ft in it.tables("velocity_field"):
        radial = ft.raw("radial", "linear")
        if not isinstance(radial, str):
            ok = (isinstance(radial, list) and len(radial) == 2 and all(isinstance(v, list) for v in radial))
            if not ok:
                raise ft.error("radial", f"must be one of 'uniform', 'linear', 'quadratic' or a table "
                                         f"[[r...], [f...]], got {radial!r}")
        modes = ft.raw("modes", [0])
        if not (isinstance(modes, list) and modes
                and all(isinstance(m, int) and not isinstance(m, bool) and m >= 0 for m in modes)):
            raise ft.error("modes", f"must be a non-empty list of integers >= 0 (cos n theta), got {modes!r}")
        kwargs = dict(direction=ft.vector("direction"), amplitude=ft.number("amplitude"), radial=radial,
                      modes=modes, phase=ft.number("phase", 0.0),
                      inner_radius=ft.number("inner_radius", None), outer_radius=ft.number("outer_radius", None),
                      center=ft.vector("center", [0.0, 0.0, 0.0]), axis=ft.vector("axis", [0.0, 0.0, 1.0]))
        ft.done(_VELOCITY_FIELD_KEYS)
        total += _wrap(ft.where, ft.path, modal_velocity_field, positions, **kwargs)
    return total


def _build_time_function(t: _Table) -> Callable[[float], float]:
    """The ``time_function`` of a ``[[load]]``: {type = "ramp", time}, {type = "pulse", start, duration,
    shape} or {type = "table", time = [...], value = [...]} (:mod:`flexbody.time_functions`)."""
    from flexbody.time_functions import Pulse, Ramp, Table
    tf = t.table("time_function")
    kind = tf.string("type", choices=("ramp", "pulse", "table"))
    if kind == "ramp":
        tf.done(["type", "time"])
        return Ramp(tf.number("time", positive=True))
    if kind == "pulse":
        start, duration = tf.number("start", 0.0), tf.number("duration", positive=True)
        if start < 0:
            raise tf.error("start", f"must be >= 0, got {start!r}")
        shape = tf.string("shape", "sin2", choices=Pulse.SHAPES)
        tf.done(["type", "start", "duration", "shape"])
        return Pulse(start, duration, shape)
    times, values = tf.numbers("time"), tf.numbers("value")
    tf.done(["type", "time", "value"])
    if len(values) != len(times):
        raise tf.error("value", f"must have one value per time ({len(times)}), got {len(values)}")
    if any(b <= a for a, b in zip(times, times[1:])):
        raise tf.error("time", f"must be increasing, got {times}")
    return Table(np.array(times), np.array(values))


def _build_timed_loads(tables: list[_Table], mesh, dynamic: bool) -> tuple[list, tuple[int, ...] | None, list]:
    """The loads of the ``[[load]]`` tables, the load group of each and the time function of each group.

    Group 0 holds the loads without a ``time_function`` (they follow ``load_ramp_time``); every table with
    one is a group of its own. Without any time function: (loads, None, []).
    """
    loads, groups, functions = [], [], []
    for t in tables:
        function = None
        if t.has("time_function"):
            if not dynamic:
                raise t.error("time_function", "needs a dynamic analysis ([analysis] type = \"dynamic\"); a "
                                               "static scene's loads follow the load factor")
            function = _build_time_function(t)
            functions.append(function)
        built = _build_loads([t], mesh)
        loads += built
        groups += [len(functions) if function is not None else 0] * len(built)
    return loads, (tuple(groups) if functions else None), functions


def _build_point_masses(tables: list[_Table], mesh, dynamic: bool) -> tuple:
    """The :class:`flexbody.shell.inertia.PointMass` of the ``[[point_mass]]`` tables."""
    from flexbody.shell.inertia import PointMass
    out = []
    for t in tables:
        if not dynamic:
            raise SceneError(f"{t.where}: [[point_mass]] needs a dynamic analysis ([analysis] type = \"dynamic\")")
        nodes = _select_nodes(t, mesh)
        mass = t.number("mass")
        if mass < 0:
            raise t.error("mass", f"must be >= 0, got {mass!r}")
        if isinstance(t.data.get("rotary"), list):
            raise t.error("rotary", "must be one number: the moment of inertia about every axis normal to the "
                                    "director (a 5-DoF node's in-plane axes are not material axes, so two "
                                    f"different moments cannot be represented), got {t.data['rotary']!r}")
        rotary = t.number("rotary", 0.0)
        if rotary < 0:
            raise t.error("rotary", f"must be >= 0, got {rotary!r}")
        t.done(["mass", "rotary", *_SELECTORS])
        out.append(PointMass(nodes, mass, rotary))
    return tuple(out)


def _build_dynamic_analysis(t: _Table, body, hub_nodes: np.ndarray | None, load_functions: list = (),
                            point_masses: tuple = ()) -> DynamicAnalysis:
    """``[analysis] type = "dynamic"`` with its ``initial``, ``hub`` and ``integrator`` tables.

    ``load_functions``: the time functions of load groups 1, 2, ... (group 0 follows ``load_ramp_time``).
    """
    from flexbody.dynamics import PrescribedMotion
    from flexbody.scenes.dynamic_run import hub_spin_up, rigid_field
    from flexbody.time_functions import GroupFactors, Ramp, constant
    t.string("type", choices=("static", "dynamic"))
    dt, end = t.number("dt", positive=True), t.number("end_time", positive=True)
    rho_inf = t.number("rho_inf", 0.9)
    policy = t.string("policy", "modified", choices=("modified", "full"))
    every = t.integer("output_every", 1)
    adaptive = t.boolean("adaptive") if t.has("adaptive") else None
    gravity = t.vector("gravity", [0.0, 0.0, 0.0])
    ramp = t.number("load_ramp_time", 0.0)
    if ramp < 0:
        raise t.error("load_ramp_time", f"must be >= 0, got {ramp!r}")
    load_factor = Ramp(ramp) if ramp > 0 else None
    if load_functions:
        load_factor = GroupFactors((load_factor or constant, *load_functions))
    settings = _build_integrator(t.table("integrator") if t.has("integrator") else None)
    mass = t.string("mass", "lumped", choices=("lumped", "consistent"))
    kwargs: dict[str, Any] = {"point_masses": tuple(point_masses), "adaptive": adaptive, "mass": mass}
    if t.has("damping"):
        kwargs["damping"] = _build_damping(t.table("damping"))
    if t.has("initial"):
        it = t.table("initial")
        start = it.string("state", "reference", choices=("reference", "steady_spin"))
        omega = it.vector("angular_velocity", [0.0, 0.0, 0.0])
        velocity = it.vector("velocity", [0.0, 0.0, 0.0])
        center = it.vector("center") if it.has("center") else _centre_of_mass(body, point_masses, mass)
        kick = _velocity_fields(it, body.mesh.nodes)
        it.done(["state", "velocity", "angular_velocity", "center", "velocity_field"])
        if start == "steady_spin":
            if np.any(velocity):
                raise it.error("velocity", "must be zero with state = \"steady_spin\" (a relative equilibrium "
                                           f"spins about a fixed axis), got {velocity}")
            if not np.any(omega):
                raise it.error("angular_velocity", "must be nonzero with state = \"steady_spin\"")
            from flexbody.spinning import SteadySpinStart
            kwargs["initial_state"] = SteadySpinStart(tuple(omega), tuple(center))
            if np.any(kick):
                kwargs["initial_velocity"] = kick         # the kick on top of the spin
        else:
            xdot, w = rigid_field(body.mesh.nodes, omega, center, velocity)
            kwargs.update(initial_velocity=xdot + kick, initial_angular_velocity=w)
    if t.has("hub"):
        ht = t.table("hub")
        for key in (*_SELECTORS, *_HUB_SHAPES):       # already read by _hub_nodes
            ht.used.add(key)
        omega = ht.vector("angular_velocity")
        hub_ramp = ht.number("ramp_time", 0.0)
        if hub_ramp < 0:
            raise ht.error("ramp_time", f"must be >= 0, got {hub_ramp!r}")
        center = ht.vector("center", [0.0, 0.0, 0.0])
        ht.done([*_SELECTORS, *_HUB_SHAPES, "angular_velocity", "ramp_time", "center"])
        kwargs["prescribed"] = (PrescribedMotion(hub_nodes, hub_spin_up(omega, hub_ramp, center)),)
        spin = kwargs.get("initial_state")
        if spin is not None and (hub_ramp > 0 or not np.allclose(omega, spin.angular_velocity, rtol=1e-12, atol=0)):
            raise ht.error("angular_velocity" if hub_ramp == 0 else "ramp_time",
                           "a steady-spin start needs the hub at the constant rate of analysis.initial from t = 0 "
                           f"(ramp_time = 0, angular_velocity = {list(spin.angular_velocity)}), got "
                           f"{omega.tolist()} with ramp_time = {hub_ramp}")
    t.done(list(_DYNAMIC_KEYS))
    return _wrap(t.where, "analysis", DynamicAnalysis, dt, end, rho_inf, policy, every, tuple(gravity),
                 load_factor, settings=settings, **kwargs)


def _build_analysis(t: _Table) -> StaticAnalysis:
    from integrators.static import ARC_LENGTH_OPTIONS, check_arc_length_options
    if t.has("type"):
        t.string("type", choices=("static", "dynamic"))
    method = t.string("method", "load_control", choices=("load_control", "arc_length"))
    newton = _build_newton(t.table("newton") if t.has("newton") else None)
    lam_max = t.number("max_load_factor", 1.0, positive=True)
    stability = t.boolean("stability", True)
    if method == "load_control":
        if t.has("load_factors") and t.has("steps"):
            raise SceneError(f"{t.where}: give analysis.steps or analysis.load_factors, not both")
        if t.has("load_factors") and t.has("max_load_factor"):
            raise SceneError(f"{t.where}: give analysis.max_load_factor or analysis.load_factors, not both "
                             "(the last load factor is the largest)")
        if t.has("load_factors"):
            lf = t.numbers("load_factors")
            if any(b <= a for a, b in zip([0.0] + lf, lf)):
                raise t.error("load_factors", f"must be positive and increasing, got {lf}")
        else:
            steps = t.integer("steps", 10, maximum=MAX_STEPS)
            lf = list(np.linspace(0.0, lam_max, steps + 1)[1:])
        t.done(["type", "method", "steps", "max_load_factor", "load_factors", "newton", "stability"])
        return StaticAnalysis("load_control", tuple(lf), newton=newton, stability=stability)
    arc = t.number("arc_increment", 0.05, positive=True)
    cap = t.number("max_load_increment", None, positive=True)
    options = {k: t.integer(k) if k in ("max_steps", "desired_iterations") else t.number(k)
               for k in ARC_LENGTH_OPTIONS if t.has(k)}
    _wrap(t.where, "analysis", check_arc_length_options, **options)
    t.done(["type", "method", "max_load_factor", "arc_increment", "max_load_increment", *ARC_LENGTH_OPTIONS,
            "newton", "stability"])
    return StaticAnalysis("arc_length", (lam_max,), arc, cap, newton, options, stability)


def _build_outputs(tables: list[_Table], mesh, dynamic: bool = False) -> list:
    out, names = [], set()
    for t in tables:
        name = t.string("name")
        if "/" in name or name in names:
            raise t.error("name", f"must be unique and without '/', got {name!r}")
        names.add(name)
        kind = t.string("type", "displacement", choices=_OUTPUT_TYPES)
        if kind == "radial":
            nodes = _select_nodes(t, mesh)
            axis = t.direction("axis", t.vector("axis", [0.0, 0.0, 1.0]))
            out.append(RadialDisplacement(name, tuple(int(i) for i in nodes), tuple(t.vector("center", [0, 0, 0])),
                                          tuple(axis), t.number("scale", 1.0)))
            t.done(["name", "type", *_SELECTORS, "center", "axis", "scale"])
            continue
        if kind == "angular_velocity":
            if not dynamic:
                raise t.error("type", "'angular_velocity' needs a dynamic analysis ([analysis] type = \"dynamic\")")
            component = t.string("component", choices=tuple(_COMPONENTS))
            out.append(AngularVelocity(name, "xyz".index(component)))
            t.done(["name", "type", "component"])
            continue
        node = int(_select_nodes(t, mesh, single=True)[0])
        if t.has("component") == t.has("direction"):
            raise SceneError(f"{t.where}: [{t.path}] needs exactly one of 'component' (x, y or z) or 'direction'")
        if t.has("component"):
            direction = _COMPONENTS[t.string("component", choices=tuple(_COMPONENTS))]
        else:
            direction = tuple(float(v) for v in t.direction("direction", t.vector("direction")))
        out.append(Output(name, node, direction, t.number("scale", 1.0)))
        t.done(["name", "type", *_SELECTORS, "component", "direction", "scale"])
    return out


def _build_reference(t: _Table, folder: Path, outputs: list, dynamic: bool = False) -> Reference:
    from flexbody.scenes.reference import read_csv_file
    path = Path(t.string("file"))
    path = path if path.is_absolute() else folder / path
    try:
        cols, comments = read_csv_file(path)
    except (OSError, ValueError) as exc:
        raise SceneError(f"{t.where}: reference.file: {exc}") from None
    header = list(cols)
    abscissa = "time" if dynamic else "load_factor"
    lf_col = t.string(abscissa, header[0])
    if lf_col not in cols:
        raise t.error(abscissa, f"names no column of {str(path)!r}, got {lf_col!r}; columns: {', '.join(header)}")
    names = [o.name for o in outputs]
    if t.has("columns"):
        mapping = t.table("columns")
        columns = {name: mapping.string(name) for name in list(mapping.data)}
        for name, col in columns.items():
            if name not in names:
                raise mapping.error(name, f"names no [[output]]; outputs: {', '.join(names)}")
            if col not in cols:
                raise mapping.error(name, f"names no column of {str(path)!r}, got {col!r}; columns: {', '.join(header)}")
    else:
        columns = {name: name for name in names if name in cols}
        if not columns:
            raise SceneError(f"{t.where}: reference.file {str(path)!r} has no column named like an output "
                             f"({', '.join(names)}); map them with reference.columns = {{output = \"column\"}}")
    source = t.string("source", comments[0] if comments else str(path))
    t.done(["file", abscissa, "columns", "source"])
    return Reference(np.asarray(cols[lf_col]), {n: np.asarray(cols[c]) for n, c in columns.items()}, source)


# ----------------------------------------------------------------------------------------------------------
# The scene
# ----------------------------------------------------------------------------------------------------------

def scene_from_document(doc: dict, path: str | Path) -> Scene:
    """Build a :class:`Scene` from a parsed TOML document; ``path`` names it and anchors relative files."""
    from flexbody.assembly import Model
    from flexbody.body import ShellBody
    from flexbody.shell.material import ShellMaterial

    path = Path(path)
    where, folder = f"scene file {str(path)!r}", path.resolve().parent
    top = _Table(doc, "", where)
    top.reject_unknown(_SECTIONS)
    name = top.string("name", path.stem)
    description = top.string("description", f"scene file {path.name}")
    mesh = _build_mesh(top.table("mesh"), folder)
    mt = top.table("material")
    material = _wrap(where, "material", ShellMaterial, mt.number("young"), mt.number("poisson"),
                     mt.number("thickness"), mt.number("density", 0.0), mt.number("shear_correction", 5.0 / 6.0))
    mt.done(_MATERIAL_KEYS)
    et = top.table("element", {})
    tying = et.raw("tying", True)
    if not isinstance(tying, bool):
        tying = et.string("tying", True, choices=VARIANT_KEYS)
    kernel = et.string("kernel", "numba", choices=("numba", "reference"))
    et.done(_ELEMENT_KEYS)
    body = _wrap(where, "element", ShellBody, mesh, material, element=variant_from_key(tying), kernel=kernel)
    constraints = _build_bcs(top.tables("bc"), mesh)
    dynamic = _analysis_type(doc, where) == "dynamic"
    loads, load_groups, load_functions = _build_timed_loads(top.tables("load"), mesh, dynamic)
    point_masses = _build_point_masses(top.tables("point_mass"), mesh, dynamic)
    if dynamic and not material.density > 0:
        raise SceneError(f"{where}: material.density must be > 0 for a dynamic analysis, got {material.density!r}")
    if not loads and not dynamic:
        raise SceneError(f"{where}: a static scene needs at least one [[load]]")
    hub = _hub_nodes(doc.get("analysis"), mesh, where) if dynamic else None
    if hub is not None:
        from flexbody.constraints import Fix
        constraints.append(Fix(hub, "all"))          # the hub nodes are clamped to the hub
    model = _wrap(where, "bc/load", Model, body, constraints, loads, load_groups=load_groups)
    at = top.table("analysis", {})
    analysis = (_build_dynamic_analysis(at, body, hub, load_functions, point_masses) if dynamic
                else _build_analysis(at))
    outputs = _build_outputs(top.tables("output"), mesh, dynamic)
    if not outputs:
        raise SceneError(f"{where}: a scene needs at least one [[output]]")
    reference = (_build_reference(top.table("reference"), folder, outputs, dynamic) if top.has("reference")
                 else None)
    return Scene(name, description, model, analysis, outputs, reference, flatten(doc))


def load_toml_scene(path: str | Path, overrides: dict[str, Any] | None = None) -> Scene:
    """Read, override (``--set``) and build a TOML scene file."""
    doc = read_toml(path)
    doc = apply_overrides(doc, overrides or {}, f"scene file {str(path)!r}")
    return scene_from_document(doc, path)


def density_parameters(path: str | Path) -> dict[str, int]:
    """The mesh-density parameters (e.g. ``{"mesh.nx": 8, "mesh.ny": 8}``) of a generator scene file."""
    doc = read_toml(path)
    mesh = doc.get("mesh", {}) if isinstance(doc.get("mesh"), dict) else {}
    generator = mesh.get("generator")
    if generator not in DENSITY_PARAMETERS:
        return {}
    defaults = inspect.signature(_generator(generator)).parameters
    out = {}
    for name in DENSITY_PARAMETERS[generator]:
        value = mesh.get(name, defaults[name].default)
        if isinstance(value, int) and not isinstance(value, bool):
            out[f"mesh.{name}"] = value
    return out
