"""Boundary conditions of 5-DoF shell nodes.

Each node solves five components: three translations and the two in-plane rotations theta_1, theta_2
about the frame axes t1, t2 (no drilling). Translations are local to the nodal frame (the SE(3) local frame,
which keeps the tangent invariant) unless a constraint needs components in fixed directions: such a node
gets a fixed translation basis E_I (columns = directions) and solves delta x_I = E_I delta v_I.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flexbody.frames import unit_vector

if TYPE_CHECKING:
    from flexbody.mesh.tri6 import Tri6Mesh

_AXES = {"x": 0, "y": 1, "z": 2}


def node_indices(nodes, what: str) -> np.ndarray:
    """Node indices as a 1-d int array; floats that are not whole numbers (1.5) are an error, not truncated."""
    try:
        arr = np.atleast_1d(np.asarray(nodes))
        if arr.dtype == bool:
            raise TypeError
        values = arr.astype(float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} nodes must be integer node indices, got {nodes!r}") from None
    if arr.ndim != 1:
        arr, values = arr.ravel(), values.ravel()
    if not np.all(np.isfinite(values)) or np.any(values != np.round(values)):
        raise ValueError(f"{what} nodes must be integer node indices, got {nodes!r}")
    return values.astype(np.int64)
_VALID = {"x", "y", "z", "r1", "r2", "all", "translations", "rotations"}


@dataclass(frozen=True)
class Fix:
    """Fix components of the listed nodes.

    components : any of "x", "y", "z" (global translations), "r1", "r2" (rotations about the nodal
    in-plane axes t1, t2), or the shorthands "all" (clamped), "translations", "rotations".
    """

    nodes: np.ndarray
    components: tuple[str, ...] = ("all",)

    def __post_init__(self) -> None:
        object.__setattr__(self, "nodes", node_indices(self.nodes, "Fix"))
        comps = (self.components,) if isinstance(self.components, str) else tuple(self.components)
        bad = [c for c in comps if c not in _VALID]
        if bad:
            raise ValueError(f"unknown constraint component(s) {bad}; use any of {sorted(_VALID)}")
        object.__setattr__(self, "components", comps)

    def expanded(self) -> set[str]:
        """The fixed components with the shorthands spelled out (a subset of x, y, z, r1, r2)."""
        out: set[str] = set()
        for c in self.components:
            if c == "all":
                out |= {"x", "y", "z", "r1", "r2"}
            elif c == "translations":
                out |= {"x", "y", "z"}
            elif c == "rotations":
                out |= {"r1", "r2"}
            else:
                out.add(c)
        return out


@dataclass(frozen=True)
class Symmetry:
    """Symmetry plane with unit normal ``normal`` through the listed nodes.

    The translation along the normal is zero, and so is the rotation about the in-plane axis that lies in
    the plane. The nodal frame is turned about the director (if needed) so that one in-plane axis is the
    plane normal; the rotation about the other in-plane axis is then the fixed one, for any deformation.
    """

    nodes: np.ndarray
    normal: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "nodes", node_indices(self.nodes, "Symmetry"))
        object.__setattr__(self, "normal", unit_vector(self.normal, "symmetry normal"))


@dataclass(frozen=True)
class FixDirection:
    """Fix the translation of the listed nodes along one direction (a roller: free normal to it).

    The nodes get a fixed translation basis whose first vector is ``direction``; the rotations stay free.
    """

    nodes: np.ndarray
    direction: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "nodes", node_indices(self.nodes, "FixDirection"))
        d = np.asarray(self.direction, dtype=float)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.any(d):
            raise ValueError(f"FixDirection direction must be a nonzero finite 3-vector, got {self.direction!r}")
        d = d / np.abs(d).max()                     # no overflow of the norm for huge components
        object.__setattr__(self, "direction", d / np.linalg.norm(d))


def basis_with_first(direction: np.ndarray) -> np.ndarray:
    """An orthonormal basis (columns) whose first vector is ``direction``."""
    d = unit_vector(direction, "direction")
    helper = np.eye(3)[int(np.argmin(np.abs(d)))]
    b = np.cross(d, helper)
    b /= np.linalg.norm(b)
    return np.column_stack([d, b, np.cross(d, b)])


def nodes_of(mesh: "Tri6Mesh", nodes: str | Sequence[str] | Sequence[int] | np.ndarray) -> np.ndarray:
    """The node indices of a selection: a node or edge set name, a list of set names (their union), or node
    indices.

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh whose sets are named.
    nodes : str, list of str, or array_like of int
        The selection.

    Returns
    -------
    np.ndarray
        The sorted, distinct node indices.

    Raises
    ------
    ValueError
        An unknown set name (a :class:`flexbody.mesh.MeshError` listing the sets the mesh has), an empty
        selection or an index outside the mesh.
    """
    if isinstance(nodes, str):
        nodes = [nodes]
    if isinstance(nodes, (list, tuple)) and nodes and all(isinstance(n, str) for n in nodes):
        return np.unique(np.concatenate([mesh.node_set(n) for n in nodes]))
    indices = np.unique(node_indices(nodes, "selected"))
    if indices.size == 0:
        raise ValueError("the node selection is empty")
    if indices[0] < 0 or indices[-1] >= mesh.n_nodes:
        bad = indices[(indices < 0) | (indices >= mesh.n_nodes)][0]
        raise ValueError(f"node {bad} does not exist; the mesh has nodes 0..{mesh.n_nodes - 1}")
    return indices


def clamp(mesh: "Tri6Mesh", nodes: str | Sequence[str] | Sequence[int] | np.ndarray) -> Fix:
    """Clamp nodes: their translations and rotations are fixed (``Fix(nodes, "all")``).

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh.
    nodes : str, list of str, or array_like of int
        Node or edge set name(s), or node indices (:func:`nodes_of`).

    Examples
    --------
    >>> import flexbody as fb
    >>> mesh = fb.strip(10.0, 1.0, 4, 1)
    >>> fb.clamp(mesh, "clamped").nodes.tolist()
    [0, 1, 2]
    """
    return fix(mesh, nodes, "all")


def fix(mesh: "Tri6Mesh", nodes: str | Sequence[str] | Sequence[int] | np.ndarray,
        components: str | Sequence[str] = "all") -> Fix:
    """Fix some components of nodes.

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh.
    nodes : str, list of str, or array_like of int
        Node or edge set name(s), or node indices (:func:`nodes_of`).
    components : str or sequence of str
        Any of "x", "y", "z" (global translations), "r1", "r2" (rotations about the nodal in-plane axes), or
        "all", "translations", "rotations" (see :class:`Fix`).
    """
    return Fix(nodes_of(mesh, nodes), components)
