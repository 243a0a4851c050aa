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

The module reads the tables into the scene's parts; :mod:`flexbody.scenes.toml_values` checks the values,
:mod:`flexbody.scenes.toml_document` reads the file, holds the key vocabulary and applies ``--set``.
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
from flexbody.scenes.toml_document import (COMPONENTS, DAMPING_KEYS, DENSITY_PARAMETERS, DYNAMIC_KEYS, ELEMENT_KEYS,
                                           GENERATOR_NAMES, HUB_SHAPES, MATERIAL_KEYS, OUTPUT_TYPES,
                                           RADIAN_PARAMETERS, SECTIONS, SELECTORS, VELOCITY_FIELD_KEYS,
                                           apply_overrides, flatten, generator_function, read_toml, resolve_key)
from flexbody.scenes.toml_values import MAX_STEPS, SceneError, Table, call_checked
from flexbody.scenes.tracked import AngularVelocity, Output, RadialDisplacement
from flexbody.shell.variants import VARIANT_KEYS, variant_from_key

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
        path = Path(t.string("file"))
        t.done(["file"])
        return call_checked(t.where, "mesh.file", read_mesh, path if path.is_absolute() else folder / path)
    name = t.string("generator", choices=GENERATOR_NAMES)
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


def _select_nodes(t: Table, mesh, *, single: bool = False) -> np.ndarray:
    """The nodes of a node selection: exactly one of set, nodes, near, plane."""
    given = [k for k in SELECTORS if t.has(k)]
    if len(given) != 1:
        raise SceneError(f"{t.where}: [{t.path}] needs exactly one node selection of "
                         f"{', '.join(SELECTORS)}, got {given or 'none'}")
    kind = given[0]
    if kind == "set":
        names = _set_names(t, "a set name or a list of set names")
        nodes = np.unique(np.concatenate([call_checked(t.where, t.key("set"), mesh.node_set, n) for n in names]))
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
        nodes = np.array([call_checked(t.where, t.key("near"), mesh.nearest_node, t.vector("near"))])
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


def _build_bcs(tables: list[Table], mesh) -> list:
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
            out.append(call_checked(t.where, t.key("components"), Fix, nodes, comps))
        else:
            if t.has("normal"):
                normal = t.vector("normal")
            elif t.has("plane"):
                normal = np.array(t.data["plane"]["normal"], dtype=float)
            else:
                raise SceneError(f"{t.where}: missing key {t.key('normal')} (the symmetry plane's normal)")
            out.append(call_checked(t.where, t.key("normal"), Symmetry, nodes, normal))
        t.done(["type", *SELECTORS, "components" if kind == "fix" else "normal"])
    return out


def _set_names(t: Table, what: str) -> list[str]:
    """The names of ``set`` (one name or a list of distinct names)."""
    value = t.raw("set")
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise t.error("set", f"must be {what}, got {value!r}")
    twice = [n for k, n in enumerate(names) if n in names[:k]]
    if twice:
        raise t.error("set", f"lists {twice[0]!r} twice, got {value!r}")
    return names


def _build_loads(tables: list[Table], mesh) -> list:
    from flexbody.loads import NodalLoad, edge_force, edge_moment, pressure, surface_force
    kinds = ("nodal", "edge_force", "edge_moment", "surface_force", "pressure")
    out = []
    for t in tables:
        kind = t.string("type", choices=kinds)
        if kind == "nodal":
            nodes = _select_nodes(t, mesh)
            force, moment = t.vector("force", [0, 0, 0]), t.vector("moment", [0, 0, 0])
            follower = t.boolean("follower", False)
            out.append(call_checked(t.where, t.path, NodalLoad, nodes, force, moment, follower))
            t.done(["type", *SELECTORS, "force", "moment", "follower"])
        elif kind in ("edge_force", "edge_moment"):
            names, density = _set_names(t, "an edge set name or a list of them"), t.vector("density")
            build = edge_force if kind == "edge_force" else edge_moment
            out += call_checked(t.where, t.key("set"), build, mesh, names, density)
            t.done(["type", "set", "density"])
        elif kind == "surface_force":
            out += surface_force(mesh, t.vector("density"))
            t.done(["type", "density"])
        else:
            out.append(pressure(mesh, t.number("value"), _pressure_elements(t, mesh)))
            t.done(["type", "value", "set"])
    return out


def _pressure_elements(t: Table, mesh):
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


def _build_newton(t: Table | None):
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
    return call_checked(t.where, "analysis.newton", NewtonSettings, **kwargs)


def _analysis_type(doc: dict, where: str) -> str:
    """"static" or "dynamic": the ``type`` of ``[analysis]`` (a SceneError for anything else)."""
    analysis = doc.get("analysis", {})
    if not isinstance(analysis, dict):
        return "static"          # reported as "analysis must be a table" when the analysis is built
    return Table(analysis, "analysis", where).string("type", "static", choices=("static", "dynamic"))


def _build_integrator(t: Table | None):
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
    return call_checked(t.where, "analysis.integrator", AlphaSettings, **kwargs)


def _build_damping(t: Table):
    """The :class:`flexbody.dynamics.RayleighDamping` of ``[analysis.damping]``: ``alpha_mass`` (1/s) and
    ``beta_stiffness`` (s), or ``ratio`` with ``frequencies_hz = [f1, f2]`` (the ratio at both)."""
    from flexbody.dynamics import RayleighDamping
    t.reject_unknown(DAMPING_KEYS)
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
        return call_checked(t.where, t.path, RayleighDamping, **values)
    ratio = t.number("ratio")
    if ratio < 0:
        raise t.error("ratio", f"must be >= 0, got {ratio!r}")
    freqs = t.numbers("frequencies_hz")
    if len(freqs) == 1:
        freqs = freqs * 2
    if len(freqs) != 2 or not 0 < freqs[0] <= freqs[1]:
        raise t.error("frequencies_hz", f"must be one frequency or two 0 < f1 <= f2 (Hz), got {t.raw('frequencies_hz')!r}")
    return call_checked(t.where, t.path, RayleighDamping.from_ratio, ratio, tuple(freqs))


def _centre_of_mass(body, point_masses=(), mass: str = "lumped") -> np.ndarray:
    """The mass centre of the discrete body with its mass matrix (``mass``: "lumped" or "consistent")."""
    from flexbody.shell.inertia import shell_mass
    return shell_mass(body, mass, point_masses).centre(body.mesh.nodes)


def _hub_nodes(doc_analysis: Any, mesh, where: str) -> np.ndarray | None:
    """The nodes of ``[analysis.hub]`` (clamped to the hub), or None: a node selection, or the nodes within
    ``radius`` of the hub's axis, or inside the regular ``polygon`` about it (:func:`_hub_shape_nodes`)."""
    if not isinstance(doc_analysis, dict) or "hub" not in doc_analysis:
        return None
    hub = Table(doc_analysis["hub"], "analysis.hub", where)
    given = [k for k in (*SELECTORS, *HUB_SHAPES) if hub.has(k)]
    if len(given) == 1 and given[0] in HUB_SHAPES:
        return _hub_shape_nodes(hub, mesh, given[0])
    if len(given) != 1:
        raise SceneError(f"{where}: [analysis.hub] needs exactly one node selection of "
                         f"{', '.join((*SELECTORS, *HUB_SHAPES))}, got {given or 'none'}")
    return _select_nodes(hub, mesh)


def _hub_shape_nodes(hub: Table, mesh, kind: str) -> np.ndarray:
    """The nodes within ``radius`` of the hub's axis, or inside ``polygon = {sides, circumradius, angle}``
    (vertex 0 at ``angle`` radians from the reference direction of the polar angle), both about the axis
    along ``angular_velocity`` (z if it is zero) through ``center``; boundary nodes included."""
    from flexbody.scenes.motions import polar_coordinates
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


def _velocity_fields(it: Table, positions: np.ndarray) -> np.ndarray:
    """The sum (n, 3) of the ``[[analysis.initial.velocity_field]]`` fields (zero without any)."""
    from flexbody.scenes.motions import modal_velocity_field
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
        ft.done(VELOCITY_FIELD_KEYS)
        total += call_checked(ft.where, ft.path, modal_velocity_field, positions, **kwargs)
    return total


def _build_time_function(t: Table) -> Callable[[float], float]:
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
        built = _build_loads([t], mesh)
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
        t.done(["mass", "rotary", *SELECTORS])
        out.append(PointMass(nodes, mass, rotary))
    return tuple(out)


def _build_dynamic_analysis(t: Table, body, hub_nodes: np.ndarray | None, load_functions: list = (),
                            point_masses: tuple = ()) -> DynamicAnalysis:
    """``[analysis] type = "dynamic"`` with its ``initial``, ``hub`` and ``integrator`` tables.

    ``load_functions``: the time functions of load groups 1, 2, ... (group 0 follows ``load_ramp_time``).
    """
    from flexbody.dynamics import PrescribedMotion
    from flexbody.scenes.motions import hub_spin_up, rigid_field
    from flexbody.time_functions import GroupFactors, Ramp, constant
    t.string("type", choices=("static", "dynamic"))
    dt, end = t.number("dt", positive=True), t.number("end_time", positive=True)
    rho_inf = t.number("rho_inf", None)       # None: the default of the start (scenes.analysis.default_rho_inf)
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
        for key in (*SELECTORS, *HUB_SHAPES):       # already read by _hub_nodes
            ht.used.add(key)
        omega = ht.vector("angular_velocity")
        hub_ramp = ht.number("ramp_time", 0.0)
        if hub_ramp < 0:
            raise ht.error("ramp_time", f"must be >= 0, got {hub_ramp!r}")
        center = ht.vector("center", [0.0, 0.0, 0.0])
        ht.done([*SELECTORS, *HUB_SHAPES, "angular_velocity", "ramp_time", "center"])
        kwargs["prescribed"] = (PrescribedMotion(hub_nodes, hub_spin_up(omega, hub_ramp, center)),)
        spin = kwargs.get("initial_state")
        if spin is not None and (hub_ramp > 0 or not np.allclose(omega, spin.angular_velocity, rtol=1e-12, atol=0)):
            raise ht.error("angular_velocity" if hub_ramp == 0 else "ramp_time",
                           "a steady-spin start needs the hub at the constant rate of analysis.initial from t = 0 "
                           f"(ramp_time = 0, angular_velocity = {list(spin.angular_velocity)}), got "
                           f"{omega.tolist()} with ramp_time = {hub_ramp}")
    t.done(list(DYNAMIC_KEYS))
    return call_checked(t.where, "analysis", DynamicAnalysis, dt, end, rho_inf, policy, every, tuple(gravity),
                 load_factor, settings=settings, **kwargs)


def _build_analysis(t: Table) -> StaticAnalysis:
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
    call_checked(t.where, "analysis", check_arc_length_options, **options)
    t.done(["type", "method", "max_load_factor", "arc_increment", "max_load_increment", *ARC_LENGTH_OPTIONS,
            "newton", "stability"])
    return StaticAnalysis("arc_length", (lam_max,), arc, cap, newton, options, stability)


def _build_outputs(tables: list[Table], mesh, dynamic: bool = False) -> list:
    out, names = [], set()
    for t in tables:
        name = t.string("name")
        if "/" in name or name in names:
            raise t.error("name", f"must be unique and without '/', got {name!r}")
        names.add(name)
        kind = t.string("type", "displacement", choices=OUTPUT_TYPES)
        if kind == "radial":
            nodes = _select_nodes(t, mesh)
            axis = t.direction("axis", t.vector("axis", [0.0, 0.0, 1.0]))
            out.append(RadialDisplacement(name, tuple(int(i) for i in nodes), tuple(t.vector("center", [0, 0, 0])),
                                          tuple(axis), t.number("scale", 1.0)))
            t.done(["name", "type", *SELECTORS, "center", "axis", "scale"])
            continue
        if kind == "angular_velocity":
            if not dynamic:
                raise t.error("type", "'angular_velocity' needs a dynamic analysis ([analysis] type = \"dynamic\")")
            component = t.string("component", choices=tuple(COMPONENTS))
            out.append(AngularVelocity(name, "xyz".index(component)))
            t.done(["name", "type", "component"])
            continue
        node = int(_select_nodes(t, mesh, single=True)[0])
        if t.has("component") == t.has("direction"):
            raise SceneError(f"{t.where}: [{t.path}] needs exactly one of 'component' (x, y or z) or 'direction'")
        if t.has("component"):
            direction = COMPONENTS[t.string("component", choices=tuple(COMPONENTS))]
        else:
            direction = tuple(float(v) for v in t.direction("direction", t.vector("direction")))
        out.append(Output(name, node, direction, t.number("scale", 1.0)))
        t.done(["name", "type", *SELECTORS, "component", "direction", "scale"])
    return out


def _build_reference(t: Table, folder: Path, outputs: list, dynamic: bool = False) -> Reference:
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
    top = Table(doc, "", where)
    top.reject_unknown(SECTIONS)
    name = top.string("name", path.stem)
    description = top.string("description", f"scene file {path.name}")
    mesh = _build_mesh(top.table("mesh"), folder)
    mt = top.table("material")
    material = call_checked(where, "material", ShellMaterial, mt.number("young"), mt.number("poisson"),
                     mt.number("thickness"), mt.number("density", 0.0), mt.number("shear_correction", 5.0 / 6.0))
    mt.done(MATERIAL_KEYS)
    et = top.table("element", {})
    tying = et.raw("tying", True)
    if not isinstance(tying, bool):
        tying = et.string("tying", True, choices=VARIANT_KEYS)
    kernel = et.string("kernel", "numba", choices=("numba", "reference"))
    et.done(ELEMENT_KEYS)
    body = call_checked(where, "element", ShellBody, mesh, material, element=variant_from_key(tying), kernel=kernel)
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
    model = call_checked(where, "bc/load", Model, body, constraints, loads, load_groups=load_groups)
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
    defaults = inspect.signature(generator_function(generator)).parameters
    out = {}
    for name in DENSITY_PARAMETERS[generator]:
        value = mesh.get(name, defaults[name].default)
        if isinstance(value, int) and not isinstance(value, bool):
            out[f"mesh.{name}"] = value
    return out
