"""TOML scene files: a shell model described in a text file, run with ``flexbody run FILE.toml``.

The format is documented in ``docs/scenes.md`` (its key tables are generated from the table specs);
``examples/clamped_plate.toml`` is a worked example. In short: ``name``, ``description``, a ``[mesh]`` (a generator
and its parameters, or a mesh file), a ``[material]``, an optional ``[element]``, ``[[bc]]`` and ``[[load]]`` on
node selections, ``[[point_mass]]`` (dynamic), an ``[analysis]`` (static: load control or arc length, with
``[analysis.newton]``; or ``type = "dynamic"`` with ``[analysis.initial]``, ``[analysis.hub]``,
``[analysis.integrator]``, ``[analysis.damping]``), at least one ``[[output]]`` and an optional ``[reference]``.

Every error is a :class:`SceneError` whose one-line message names the file, the key and the bad value.
``--set KEY=VALUE`` overrides a value by its dotted key (``mesh.nx``, ``load.0.value``) or by its last part
when that is unambiguous (``nx``, ``thickness``, ``steps``).

The module builds the scene's parts from the tables. :mod:`flexbody.scenes.toml_spec` holds every table's keys,
types, ranges, defaults and docs; :func:`flexbody.scenes.toml_values.read_table` reads a table by its spec;
:mod:`flexbody.scenes.toml_selections` selects nodes; :mod:`flexbody.scenes.toml_document` reads the file and
applies ``--set``.
"""

from __future__ import annotations

import inspect
import math
from pathlib import Path
from typing import Any, Callable

import numpy as np

from flexbody.scenes.analysis import DynamicAnalysis, StaticAnalysis
from flexbody.scenes.reference import Reference
from flexbody.scenes.scene import Scene
from flexbody.scenes import toml_spec as spec
from flexbody.scenes.toml_document import apply_overrides, flatten, generator_function, read_toml, resolve_key
from flexbody.scenes.toml_spec import (COMPONENTS, DENSITY_PARAMETERS, GENERATOR_NAMES, MAX_STEPS,
                                       RADIAN_PARAMETERS, SELECTORS)
from flexbody.scenes.toml_selections import hub_nodes, pressure_elements, select_nodes, set_names
from flexbody.scenes.toml_values import REQUIRED, SceneError, Table, call_checked, finish, read_table, read_value
from flexbody.scenes.tracked import AngularVelocity, Output, RadialDisplacement
from flexbody.shell.variants import variant_from_key

__all__ = ["scene_from_document", "load_toml_scene", "density_parameters",
           # kept under this import path (they live in toml_document and toml_values)
           "SceneError", "MAX_STEPS", "read_toml", "flatten", "resolve_key", "apply_overrides"]


# ----------------------------------------------------------------------------------------------------------
# Sections
# ----------------------------------------------------------------------------------------------------------


def _build_mesh(t: Table, folder: Path):
    """The mesh of ``[mesh]``: a generator and its parameters, or a mesh file."""
    if t.has("generator") == t.has("file"):
        raise SceneError(f"{t.where}: [mesh] needs exactly one of 'generator' (one of "
                         f"{', '.join(GENERATOR_NAMES)}) or 'file'")
    if t.has("file"):
        from flexbody.mesh.io import read_mesh
        path = Path(read_value(spec.MESH["file"], t))
        t.done(["file"])
        return call_checked(t.where, "mesh.file", read_mesh, path if path.is_absolute() else folder / path)
    name = read_value(spec.MESH["generator"], t)
    func = generator_function(name)
    signature = inspect.signature(func).parameters
    kwargs = {}
    for pname, param in signature.items():
        deg = f"{pname}_deg"
        if pname in RADIAN_PARAMETERS and t.has(deg):
            if t.has(pname):
                raise SceneError(f"{t.where}: give mesh.{pname} (radians) or mesh.{deg} (degrees), not both")
            kwargs[pname] = math.radians(t.number(deg))
        elif t.has(pname):
            kwargs[pname] = t.raw(pname)
        elif param.default is inspect.Parameter.empty:
            raise SceneError(f"{t.where}: missing key mesh.{pname} (generator {name!r} needs "
                             f"{', '.join(p for p, q in signature.items() if q.default is inspect.Parameter.empty)})")
    known = ["generator", *signature, *(f"{p}_deg" for p in signature if p in RADIAN_PARAMETERS)]
    t.done(known)
    return call_checked(t.where, f"mesh (generator {name!r})", func, **kwargs)


def _build_bcs(tables: list[Table], mesh) -> list:
    from flexbody.constraints import Fix, Symmetry
    out = []
    for t in tables:
        kind = read_value(spec.BC["type"], t)
        nodes = select_nodes(t, mesh)
        v = read_table(spec.BC, t, kind, done=False)
        if kind == "fix":
            comps = v["components"]
            if not (isinstance(comps, str) or (isinstance(comps, list) and comps
                                               and all(isinstance(c, str) for c in comps))):
                raise t.error("components", f"must be a component name or a list of them, got {comps!r}")
            out.append(call_checked(t.where, t.key("components"), Fix, nodes, comps))
        else:
            normal = v["normal"]
            if normal is None and t.has("plane"):
                normal = np.array(t.data["plane"]["normal"], dtype=float)
            elif normal is None:
                raise SceneError(f"{t.where}: missing key {t.key('normal')} (the symmetry plane's normal)")
            out.append(call_checked(t.where, t.key("normal"), Symmetry, nodes, normal))
        finish(spec.BC, t, kind)
    return out


def _build_load(t: Table, mesh) -> list:
    """The loads of one ``[[load]]`` table (an edge load is one load per edge set)."""
    kind = read_value(spec.LOAD["type"], t)
    nodes = select_nodes(t, mesh) if kind == "nodal" else None
    loads = _make_load(t, mesh, kind, nodes, read_table(spec.LOAD, t, kind, done=False))
    finish(spec.LOAD, t, kind)
    return loads


def _make_load(t: Table, mesh, kind: str, nodes: np.ndarray | None, v: dict[str, Any]) -> list:
    """The loads of a ``[[load]]`` of type ``kind`` from its values ``v``."""
    from flexbody.loads import NodalLoad, edge_force, edge_moment, pressure, surface_force
    if kind == "nodal":
        return [call_checked(t.where, t.path, NodalLoad, nodes, v["force"], v["moment"], v["follower"])]
    if kind in ("edge_force", "edge_moment"):
        names = set_names(t, "an edge set name or a list of them")
        build = edge_force if kind == "edge_force" else edge_moment
        return list(call_checked(t.where, t.key("set"), build, mesh, names, v["density"]))
    if kind == "surface_force":
        return list(surface_force(mesh, v["density"]))
    return [pressure(mesh, v["value"], pressure_elements(t, mesh))]


def _given(values: dict[str, Any]) -> dict[str, Any]:
    """The values of the keys given (an absent key without a default reads as None)."""
    return {k: v for k, v in values.items() if v is not None}


def _build_newton(t: Table | None):
    from integrators.newton import NewtonSettings
    if t is None:
        return NewtonSettings()
    return call_checked(t.where, "analysis.newton", NewtonSettings, **_given(read_table(spec.newton_spec(), t)))


def _analysis_type(doc: dict, where: str) -> str:
    """"static" or "dynamic": the ``type`` of ``[analysis]`` (a SceneError for anything else)."""
    analysis = doc.get("analysis", {})
    if not isinstance(analysis, dict):
        return "static"          # reported as "analysis must be a table" when the analysis is built
    return read_value(spec.ANALYSIS["type"], Table(analysis, "analysis", where))


def _build_integrator(t: Table | None):
    """The :class:`integrators.generalized_alpha.AlphaSettings` of ``[analysis.integrator]``."""
    from integrators.generalized_alpha import AlphaSettings
    if t is None:
        return None
    return call_checked(t.where, "analysis.integrator", AlphaSettings, **_given(read_table(spec.integrator_spec(), t)))


def _build_damping(t: Table):
    """The :class:`flexbody.dynamics.RayleighDamping` of ``[analysis.damping]``: ``alpha_mass`` (1/s) and
    ``beta_stiffness`` (s), or ``ratio`` with ``frequencies_hz = [f1, f2]`` (the ratio at both)."""
    from flexbody.dynamics import RayleighDamping
    t.reject_unknown(spec.DAMPING.names())
    direct = [k for k in ("alpha_mass", "beta_stiffness") if t.has(k)]
    by_ratio = [k for k in ("ratio", "frequencies_hz") if t.has(k)]
    if direct and by_ratio:
        raise t.error(by_ratio[0], f"cannot be combined with {t.key(direct[0])}: give alpha_mass/beta_stiffness "
                                   "or ratio with frequencies_hz")
    if not (direct or by_ratio):
        raise SceneError(f"{t.where}: [{t.path}] needs alpha_mass and/or beta_stiffness, or ratio with "
                         "frequencies_hz")
    if direct:
        return call_checked(t.where, t.path, RayleighDamping, **_given(read_table(spec.DAMPING, t)))
    ratio = read_value(spec.DAMPING["ratio"], t, REQUIRED)
    freqs = read_value(spec.DAMPING["frequencies_hz"], t, REQUIRED)
    if len(freqs) == 1:
        freqs = freqs * 2
    if len(freqs) != 2 or not 0 < freqs[0] <= freqs[1]:
        raise t.error("frequencies_hz", f"must be one frequency or two 0 < f1 <= f2 (Hz), got {t.raw('frequencies_hz')!r}")
    return call_checked(t.where, t.path, RayleighDamping.from_ratio, ratio, tuple(freqs))


def _centre_of_mass(body, point_masses=(), mass: str = "lumped") -> np.ndarray:
    """The mass centre of the discrete body with its mass matrix (``mass``: "lumped" or "consistent")."""
    from flexbody.shell.inertia import shell_mass
    return shell_mass(body, mass, point_masses).centre(body.mesh.nodes)


def _velocity_fields(tables: list[Table], positions: np.ndarray) -> np.ndarray:
    """The sum (n, 3) of the ``[[analysis.initial.velocity_field]]`` fields (zero without any)."""
    from flexbody.scenes.motions import modal_velocity_field
    total = np.zeros_like(positions)
    for ft in tables:
        v = read_table(spec.VELOCITY_FIELD, ft)
        radial, modes = v["radial"], v["modes"]
        if not isinstance(radial, str):
            ok = (isinstance(radial, list) and len(radial) == 2 and all(isinstance(x, list) for x in radial))
            if not ok:
                raise ft.error("radial", f"must be one of 'uniform', 'linear', 'quadratic' or a table "
                                         f"[[r...], [f...]], got {radial!r}")
        if not (isinstance(modes, list) and modes
                and all(isinstance(m, int) and not isinstance(m, bool) and m >= 0 for m in modes)):
            raise ft.error("modes", f"must be a non-empty list of integers >= 0 (cos n theta), got {modes!r}")
        total += call_checked(ft.where, ft.path, modal_velocity_field, positions, **v)
    return total


def _build_time_function(t: Table) -> Callable[[float], float]:
    """The ``time_function`` of a ``[[load]]``: {type = "ramp", time}, {type = "pulse", start, duration,
    shape} or {type = "table", time = [...], value = [...]} (:mod:`flexbody.time_functions`)."""
    from flexbody.time_functions import Pulse, Ramp, Table as TableFunction
    tf = t.table("time_function")
    v = read_table(spec.TIME_FUNCTION, tf)
    if v["type"] == "ramp":
        return Ramp(v["time"])
    if v["type"] == "pulse":
        return Pulse(v["start"], v["duration"], v["shape"])
    times, values = v["time"], v["value"]
    if len(values) != len(times):
        raise tf.error("value", f"must have one value per time ({len(times)}), got {len(values)}")
    if any(b <= a for a, b in zip(times, times[1:])):
        raise tf.error("time", f"must be increasing, got {times}")
    return TableFunction(np.array(times), np.array(values))


def _build_timed_loads(tables: list[Table], mesh, dynamic: bool) -> tuple[list, tuple[int, ...] | None, list]:
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
        built = _build_load(t, mesh)
        loads += built
        groups += [len(functions) if function is not None else 0] * len(built)
    return loads, (tuple(groups) if functions else None), functions


def _build_point_masses(tables: list[Table], mesh, dynamic: bool) -> tuple:
    """The :class:`flexbody.shell.inertia.PointMass` of the ``[[point_mass]]`` tables."""
    from flexbody.shell.inertia import PointMass
    out = []
    for t in tables:
        if not dynamic:
            raise SceneError(f"{t.where}: [[point_mass]] needs a dynamic analysis ([analysis] type = \"dynamic\")")
        nodes = select_nodes(t, mesh)
        if isinstance(t.data.get("rotary"), list):
            raise t.error("rotary", "must be one number: the moment of inertia about every axis normal to the "
                                    "director (a 5-DoF node's in-plane axes are not material axes, so two "
                                    f"different moments cannot be represented), got {t.data['rotary']!r}")
        v = read_table(spec.POINT_MASS, t)
        out.append(PointMass(nodes, v["mass"], v["rotary"]))
    return tuple(out)


def _initial_state(it: Table, body, point_masses: tuple, mass: str) -> dict[str, Any]:
    """The ``DynamicAnalysis`` keywords of ``[analysis.initial]``: a rigid initial velocity field (plus the
    velocity fields), or the steady spin (plus the fields: a kick)."""
    from flexbody.scenes.motions import rigid_field
    v = read_table(spec.INITIAL, it, done=False)
    omega, velocity = v["angular_velocity"], v["velocity"]
    center = v["center"] if v["center"] is not None else _centre_of_mass(body, point_masses, mass)
    kick = _velocity_fields(v["velocity_field"], body.mesh.nodes)
    finish(spec.INITIAL, it)
    if v["state"] != "steady_spin":
        xdot, w = rigid_field(body.mesh.nodes, omega, center, velocity)
        return {"initial_velocity": xdot + kick, "initial_angular_velocity": w}
    if np.any(velocity):
        raise it.error("velocity", "must be zero with state = \"steady_spin\" (a relative equilibrium "
                                   f"spins about a fixed axis), got {velocity}")
    if not np.any(omega):
        raise it.error("angular_velocity", "must be nonzero with state = \"steady_spin\"")
    from flexbody.spinning import SteadySpinStart
    out: dict[str, Any] = {"initial_state": SteadySpinStart(tuple(omega), tuple(center))}
    if np.any(kick):
        out["initial_velocity"] = kick         # the kick on top of the spin
    return out


def _hub_motion(ht: Table, nodes: np.ndarray, spin) -> tuple:
    """The prescribed motion of ``[analysis.hub]`` (its nodes were selected by :func:`hub_nodes`); ``spin``:
    the steady-spin start, if any, which the hub must match from t = 0."""
    from flexbody.dynamics import PrescribedMotion
    from flexbody.scenes.motions import hub_spin_up
    ht.used.update(SELECTORS)                   # already read by hub_nodes
    v = read_table(spec.HUB, ht)
    omega, hub_ramp = v["angular_velocity"], v["ramp_time"]
    if spin is not None and (hub_ramp > 0 or not np.allclose(omega, spin.angular_velocity, rtol=1e-12, atol=0)):
        raise ht.error("angular_velocity" if hub_ramp == 0 else "ramp_time",
                       "a steady-spin start needs the hub at the constant rate of analysis.initial from t = 0 "
                       f"(ramp_time = 0, angular_velocity = {list(spin.angular_velocity)}), got "
                       f"{omega.tolist()} with ramp_time = {hub_ramp}")
    return (PrescribedMotion(nodes, hub_spin_up(omega, hub_ramp, v["center"])),)


def _build_dynamic_analysis(t: Table, body, hub: np.ndarray | None, load_functions: list = (),
                            point_masses: tuple = ()) -> DynamicAnalysis:
    """``[analysis] type = "dynamic"`` with its ``initial``, ``hub``, ``integrator`` and ``damping`` tables.

    ``load_functions``: the time functions of load groups 1, 2, ... (group 0 follows ``load_ramp_time``).
    """
    from flexbody.time_functions import GroupFactors, Ramp, constant
    v = read_table(spec.DYNAMIC, t, done=False)
    ramp = v["load_ramp_time"]
    load_factor = Ramp(ramp) if ramp > 0 else None
    if load_functions:
        load_factor = GroupFactors((load_factor or constant, *load_functions))
    settings = _build_integrator(v["integrator"])
    kwargs: dict[str, Any] = {"point_masses": tuple(point_masses), "adaptive": v["adaptive"], "mass": v["mass"],
                              "frame": v["frame"]}
    if v["damping"] is not None:
        kwargs["damping"] = _build_damping(v["damping"])
    if v["initial"] is not None:
        kwargs.update(_initial_state(v["initial"], body, point_masses, v["mass"]))
    if v["hub"] is not None:
        kwargs["prescribed"] = _hub_motion(v["hub"], hub, kwargs.get("initial_state"))
    finish(spec.DYNAMIC, t)
    return call_checked(t.where, "analysis", DynamicAnalysis, v["dt"], v["end_time"], v["rho_inf"], v["policy"],
                        v["output_every"], tuple(v["gravity"]), load_factor, settings=settings, **kwargs)


def _build_analysis(t: Table) -> StaticAnalysis:
    from integrators.static import check_arc_length_options
    v = read_table(spec.ANALYSIS, t, done=False)
    method, lam_max = v["method"], v["max_load_factor"]
    newton = _build_newton(v["newton"])
    if method == "load_control":
        if t.has("load_factors") and t.has("steps"):
            raise SceneError(f"{t.where}: give analysis.steps or analysis.load_factors, not both")
        if t.has("load_factors") and t.has("max_load_factor"):
            raise SceneError(f"{t.where}: give analysis.max_load_factor or analysis.load_factors, not both "
                             "(the last load factor is the largest)")
        lf = v["load_factors"]
        if lf is not None and any(b <= a for a, b in zip([0.0] + lf, lf)):
            raise t.error("load_factors", f"must be positive and increasing, got {lf}")
        if lf is None:
            lf = list(np.linspace(0.0, lam_max, v["steps"] + 1)[1:])
        finish(spec.ANALYSIS, t, method)
        return StaticAnalysis("load_control", tuple(lf), newton=newton, stability=v["stability"])
    options = _given({k: v[k] for k in spec.ARC_LENGTH_KEYS})
    call_checked(t.where, "analysis", check_arc_length_options, **options)
    finish(spec.ANALYSIS, t, method)
    return StaticAnalysis("arc_length", (lam_max,), v["arc_increment"], v["max_load_increment"], newton, options,
                          v["stability"])


def _build_output(t: Table, mesh, kind: str, dynamic: bool):
    """The tracked quantity of one ``[[output]]`` table of type ``kind`` (its name already checked)."""
    if kind == "radial":
        nodes = select_nodes(t, mesh)
        v = read_table(spec.OUTPUT, t, kind, done=False)
        axis = t.direction("axis", v["axis"])
        return RadialDisplacement(v["name"], tuple(int(i) for i in nodes), tuple(v["center"]), tuple(axis),
                                  v["scale"])
    if kind == "angular_velocity":
        if not dynamic:
            raise t.error("type", "'angular_velocity' needs a dynamic analysis ([analysis] type = \"dynamic\")")
        v = read_table(spec.OUTPUT, t, kind, done=False)
        return AngularVelocity(v["name"], "xyz".index(v["component"]))
    node = int(select_nodes(t, mesh, single=True)[0])
    if t.has("component") == t.has("direction"):
        raise SceneError(f"{t.where}: [{t.path}] needs exactly one of 'component' (x, y or z) or 'direction'")
    v = read_table(spec.OUTPUT, t, kind, done=False)
    if v["component"] is not None:
        direction = COMPONENTS[v["component"]]
    else:
        direction = tuple(float(x) for x in t.direction("direction", v["direction"]))
    return Output(v["name"], node, direction, v["scale"])


def _build_outputs(tables: list[Table], mesh, dynamic: bool = False) -> list:
    out, names = [], set()
    for t in tables:
        name = read_value(spec.OUTPUT["name"], t)
        if "/" in name or name in names:
            raise t.error("name", f"must be unique and without '/', got {name!r}")
        names.add(name)
        kind = read_value(spec.OUTPUT["type"], t)
        out.append(_build_output(t, mesh, kind, dynamic))
        finish(spec.OUTPUT, t, kind)
    return out


def _build_reference(t: Table, folder: Path, outputs: list, dynamic: bool = False) -> Reference:
    from flexbody.scenes.reference import read_csv_file
    path = Path(read_value(spec.REFERENCE["file"], t))
    path = path if path.is_absolute() else folder / path
    try:
        cols, comments = read_csv_file(path)
    except (OSError, ValueError) as exc:
        raise SceneError(f"{t.where}: reference.file: {exc}") from None
    header = list(cols)
    abscissa = "time" if dynamic else "load_factor"
    lf_col = read_value(spec.REFERENCE[abscissa], t, header[0])
    if lf_col not in cols:
        raise t.error(abscissa, f"names no column of {str(path)!r}, got {lf_col!r}; columns: {', '.join(header)}")
    names = [o.name for o in outputs]
    mapping = read_value(spec.REFERENCE["columns"], t)
    if mapping is not None:
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
    source = read_value(spec.REFERENCE["source"], t, comments[0] if comments else str(path))
    finish(spec.REFERENCE, t, "dynamic" if dynamic else "static")
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
    top = Table(doc, "", where)
    top.reject_unknown(spec.SECTIONS)
    name = read_value(spec.TOP["name"], top, path.stem)
    description = read_value(spec.TOP["description"], top, f"scene file {path.name}")
    mesh = _build_mesh(read_value(spec.TOP["mesh"], top), folder)
    mt = read_value(spec.TOP["material"], top)
    m = read_table(spec.MATERIAL, mt, done=False)
    material = call_checked(where, "material", ShellMaterial, m["young"], m["poisson"], m["thickness"],
                            m["density"], m["shear_correction"], m["wrinkling"])
    finish(spec.MATERIAL, mt)
    et = read_value(spec.TOP["element"], top)
    e = read_table(spec.ELEMENT, et, done=False)
    tying = e["tying"]
    if not isinstance(tying, bool):
        tying = et.string("tying", True, choices=spec.ELEMENT["tying"].choices)
    finish(spec.ELEMENT, et)
    body = call_checked(where, "element", ShellBody, mesh, material, element=variant_from_key(tying),
                        kernel=e["kernel"])
    constraints = _build_bcs(read_value(spec.TOP["bc"], top), mesh)
    dynamic = _analysis_type(doc, where) == "dynamic"
    loads, load_groups, load_functions = _build_timed_loads(read_value(spec.TOP["load"], top), mesh, dynamic)
    point_masses = _build_point_masses(read_value(spec.TOP["point_mass"], top), mesh, dynamic)
    if dynamic and not material.density > 0:
        raise SceneError(f"{where}: material.density must be > 0 for a dynamic analysis, got {material.density!r}")
    if not loads and not dynamic:
        raise SceneError(f"{where}: a static scene needs at least one [[load]]")
    hub = hub_nodes(doc.get("analysis"), mesh, where) if dynamic else None
    if hub is not None:
        from flexbody.constraints import Fix
        constraints.append(Fix(hub, "all"))          # the hub nodes are clamped to the hub
    model = call_checked(where, "bc/load", Model, body, constraints, loads, load_groups=load_groups)
    at = read_value(spec.TOP["analysis"], top)
    analysis = (_build_dynamic_analysis(at, body, hub, load_functions, point_masses) if dynamic
                else _build_analysis(at))
    outputs = _build_outputs(read_value(spec.TOP["output"], top), mesh, dynamic)
    if not outputs:
        raise SceneError(f"{where}: a scene needs at least one [[output]]")
    rt = read_value(spec.TOP["reference"], top)
    reference = _build_reference(rt, folder, outputs, dynamic) if rt is not None else None
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
    defaults = inspect.signature(generator_function(generator)).parameters
    out = {}
    for name in DENSITY_PARAMETERS[generator]:
        value = mesh.get(name, defaults[name].default)
        if isinstance(value, int) and not isinstance(value, bool):
            out[f"mesh.{name}"] = value
    return out
