"""The node selections of a scene file: exactly one of ``set``, ``nodes``, ``near``, ``plane``, ``ring``
(:data:`flexbody.scenes.toml_spec.SELECTION`), a hub's nodes (a selection, or ``radius`` or ``polygon`` about its
axis), and the element sets of a pressure load."""

from __future__ import annotations

from typing import Any

import numpy as np

from flexbody.scenes import toml_spec as spec
from flexbody.scenes.toml_spec import HUB_SHAPES, SELECTORS
from flexbody.scenes.toml_values import SceneError, Table, call_checked, read_table, read_value

__all__ = ["select_nodes", "set_names", "pressure_elements", "hub_nodes"]


def select_nodes(t: Table, mesh, *, single: bool = False) -> np.ndarray:
    """The nodes of a node selection: exactly one of ``SELECTORS``."""
    given = [k for k in SELECTORS if t.has(k)]
    if len(given) != 1:
        raise SceneError(f"{t.where}: [{t.path}] needs exactly one node selection of "
                         f"{', '.join(SELECTORS)}, got {given or 'none'}")
    kind = given[0]
    size = float(np.ptp(mesh.nodes, axis=0).max()) or 1.0
    if kind == "set":
        names = set_names(t, "a set name or a list of set names")
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
        v = read_table(spec.RING, ring)
        n = ring.direction("axis", v["axis"])
        r = mesh.nodes - v["center"]
        distance = np.linalg.norm(r - np.outer(r @ n, n), axis=1)
        nodes = np.flatnonzero(np.abs(distance - v["radius"]) <= 1e-8 * size)
        if nodes.size == 0:
            raise SceneError(f"{t.where}: {t.key('ring')} selects no nodes (no node lies at distance {v['radius']} "
                             f"from the axis through {v['center'].tolist()} along {v['axis'].tolist()})")
    else:
        plane = t.table("plane")
        v = read_table(spec.PLANE, plane)
        distance = (mesh.nodes - v["point"]) @ plane.direction("normal", v["normal"])
        nodes = np.flatnonzero(np.abs(distance) <= 1e-8 * size)
        if nodes.size == 0:
            raise SceneError(f"{t.where}: {t.key('plane')} selects no nodes (no node lies on the plane "
                             f"through {v['point'].tolist()} with normal {v['normal'].tolist()})")
    if single and nodes.size != 1:
        raise SceneError(f"{t.where}: {t.key(kind)} must select one node, it selects {nodes.size}")
    return nodes


def set_names(t: Table, what: str) -> list[str]:
    """The names of ``set`` (one name or a list of distinct names)."""
    value = t.raw("set")
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise t.error("set", f"must be {what}, got {value!r}")
    twice = [n for k, n in enumerate(names) if n in names[:k]]
    if twice:
        raise t.error("set", f"lists {twice[0]!r} twice, got {value!r}")
    return names


def pressure_elements(t: Table, mesh):
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


def hub_nodes(doc_analysis: Any, mesh, where: str) -> np.ndarray | None:
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
    return select_nodes(hub, mesh)


def _hub_shape_nodes(hub: Table, mesh, kind: str) -> np.ndarray:
    """The nodes within ``radius`` of the hub's axis, or inside ``polygon = {sides, circumradius, angle}``
    (vertex 0 at ``angle`` radians from the reference direction of the polar angle), both about the axis
    along ``angular_velocity`` (z if it is zero) through ``center``; boundary nodes included."""
    from flexbody.scenes.motions import polar_coordinates
    omega = read_value(spec.HUB["angular_velocity"], hub)
    axis = omega if np.abs(omega).max() > 0 else np.array([0.0, 0.0, 1.0])
    center = read_value(spec.HUB["center"], hub)
    r, theta = polar_coordinates(mesh.nodes, center, axis)
    tol = 1e-8 * (float(np.ptp(mesh.nodes, axis=0).max()) or 1.0)
    if kind == "radius":
        radius = read_value(spec.HUB["radius"], hub)
        nodes = np.flatnonzero(r <= radius + tol)
        what = f"within radius {radius}"
    else:
        v = read_table(spec.POLYGON, read_value(spec.HUB["polygon"], hub))
        sides, circumradius = v["sides"], v["circumradius"]
        normals = v["angle"] + np.pi / sides + 2 * np.pi * np.arange(sides) / sides     # the sides' normals
        apothem = circumradius * np.cos(np.pi / sides)
        inside = np.all(r[:, None] * np.cos(theta[:, None] - normals[None, :]) <= apothem + tol, axis=1)
        nodes = np.flatnonzero(inside)
        what = f"inside the {sides}-sided polygon of circumradius {circumradius}"
    if nodes.size == 0:
        raise SceneError(f"{hub.where}: {hub.key(kind)} selects no nodes (no node lies {what} about the axis "
                         f"through {center.tolist()} along {axis.tolist()})")
    return nodes
