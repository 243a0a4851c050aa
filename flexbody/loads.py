"""External loads, scaled by the load factor lambda: r(q, lambda) = f_int(q) - lambda f_ext(q).

Every load returns its contribution to the nodal *local-frame* external force (n, 6) = [force, moment]
components in R_I, and, where it depends on the configuration, its tangent. Dead loads are fixed in
space, follower loads turn with the nodes (a follower nodal load is constant in the local frame) or with the
surface (follower pressure).

Distributed loads as one-liners (each returns what a :class:`flexbody.assembly.Model` takes, built as the
TOML scene files build them): :func:`edge_force` and :func:`edge_moment` (a line density on edge sets),
:func:`surface_force` (a dead area density) and :func:`pressure` (a follower pressure on all elements or on
element sets).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flexbody.lie import so3
from flexbody.shell.shape import gauss_triangle_7, shape_derivatives, shape_functions

if TYPE_CHECKING:
    from flexbody.mesh.tri6 import Tri6Mesh


def _as_vector(value, name: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3-vector of numbers, got {value!r}") from None
    if v.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got {value!r}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


@dataclass(frozen=True)
class NodalLoad:
    """A force and/or moment at each listed node (not divided among them).

    follower=False: fixed global vectors; follower=True: components in the nodal frame R_I.
    The moment component along the director does no work on a 5-DoF node and is ignored.
    """

    nodes: np.ndarray
    force: np.ndarray | tuple = (0.0, 0.0, 0.0)
    moment: np.ndarray | tuple = (0.0, 0.0, 0.0)
    follower: bool = False

    def __post_init__(self) -> None:
        from flexbody.constraints import node_indices
        object.__setattr__(self, "nodes", node_indices(self.nodes, "NodalLoad"))
        object.__setattr__(self, "force", _as_vector(self.force, "force"))
        object.__setattr__(self, "moment", _as_vector(self.moment, "moment"))


def nodal_vectors_from_edges(nodes: np.ndarray, edges: np.ndarray, density: np.ndarray,
                             n_nodes: int) -> np.ndarray:
    """Consistent nodal vectors of a dead line density (per unit reference length) on quadratic edges.

    edges : (k, 3) node triples (corner, midside, corner); 3-point Gauss rule along each edge.
    """
    out = np.zeros((n_nodes, 3))
    gp = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
    gw = np.array([5 / 9, 8 / 9, 5 / 9])
    for edge in edges:
        X = nodes[edge]
        for xi, w in zip(gp, gw):
            N = np.array([xi * (xi - 1) / 2, 1 - xi * xi, xi * (xi + 1) / 2])
            dN = np.array([xi - 0.5, -2 * xi, xi + 0.5])
            jac = np.linalg.norm(dN @ X)
            out[edge] += np.outer(N, density) * w * jac
    return out


def nodal_vectors_from_area(mesh: "Tri6Mesh", density: np.ndarray, elements: np.ndarray | None = None) -> np.ndarray:
    """Consistent nodal vectors (n, 3) of a dead area density (per unit reference area).

    ``elements``: the loaded elements (default: all).
    """
    out = np.zeros((mesh.n_nodes, 3))
    pts, wts = gauss_triangle_7()
    conns = mesh.elements if elements is None else mesh.elements[np.asarray(elements, dtype=int)]
    for conn in conns:
        X = mesh.nodes[conn]
        for (r, s), w in zip(pts, wts):
            dX = shape_derivatives(r, s) @ X
            area = np.linalg.norm(np.cross(dX[0], dX[1]))
            out[conn] += np.outer(shape_functions(r, s), density) * w * area
    return out


def nodal_loads(vectors: np.ndarray, kind: str = "force") -> list[NodalLoad]:
    """One dead :class:`NodalLoad` per node with a nonzero row of ``vectors`` (n, 3).

    Parameters
    ----------
    vectors : np.ndarray
        Nodal forces or moments (n, 3), e.g. from :func:`nodal_vectors_from_edges`.
    kind : str
        "force" or "moment": what the rows are.

    Returns
    -------
    list[NodalLoad]
        The loads, in node order.
    """
    if kind not in ("force", "moment"):
        raise ValueError(f"kind must be 'force' or 'moment', got {kind!r}")
    vectors = np.asarray(vectors, dtype=float)
    nodes = np.flatnonzero(np.any(vectors != 0, axis=1))
    return [NodalLoad([i], **{kind: vectors[i]}) for i in nodes]


def _set_names(sets: str | Sequence[str], what: str) -> list[str]:
    """One set name or a list of distinct names, checked."""
    names = [sets] if isinstance(sets, str) else sets
    if (not isinstance(names, (list, tuple)) or not names
            or not all(isinstance(n, str) and n for n in names)):
        raise ValueError(f"{what} must be a set name or a list of set names, got {sets!r}")
    twice = [n for k, n in enumerate(names) if n in names[:k]]
    if twice:
        raise ValueError(f"{what} lists {twice[0]!r} twice, got {sets!r}")
    return list(names)


def edges_of(mesh: "Tri6Mesh", sets: str | Sequence[str] | np.ndarray) -> np.ndarray:
    """The (k, 3) edges (corner, midside, corner) of edge sets: their union, each edge once even where the
    sets overlap.

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh whose ``edge_sets`` are named.
    sets : str, list of str or np.ndarray
        An edge set name, a list of names, or the (k, 3) edge triples themselves.

    Raises
    ------
    ValueError
        A name the mesh does not have (a :class:`flexbody.mesh.MeshError` listing the edge sets it has), a
        name listed twice, or edge triples of the wrong shape.
    """
    if isinstance(sets, np.ndarray):
        if sets.ndim != 2 or sets.shape[1] != 3 or sets.shape[0] == 0:
            raise ValueError(f"edges must be a non-empty array of shape (k, 3), got shape {sets.shape}")
        edges = sets.astype(np.int64)
    else:
        edges = np.vstack([mesh.edge_set(n) for n in _set_names(sets, "edge sets")])
    _, first = np.unique(np.sort(edges[:, [0, 2]], axis=1), axis=0, return_index=True)
    return edges[np.sort(first)]


def _edge_loads(mesh: "Tri6Mesh", sets, density, kind: str) -> list[NodalLoad]:
    """Consistent nodal forces or moments (``kind``) of a density per unit reference length on edges."""
    vectors = nodal_vectors_from_edges(mesh.nodes, edges_of(mesh, sets), _as_vector(density, f"edge {kind} density"),
                                       mesh.n_nodes)
    return nodal_loads(vectors, kind)


def edge_force(mesh: "Tri6Mesh", sets: str | Sequence[str] | np.ndarray,
               density: Sequence[float] | np.ndarray) -> list[NodalLoad]:
    """A dead force per unit reference length on edges, as consistent nodal forces.

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh.
    sets : str, list of str or np.ndarray
        The loaded edges: edge set name(s) or (k, 3) edge triples (:func:`edges_of`).
    density : array_like
        The force per unit length (3,), global components.

    Returns
    -------
    list[NodalLoad]
        One load per loaded node (what the TOML ``type = "edge_force"`` builds), scaled by the load factor
        like every load.

    Examples
    --------
    >>> import flexbody as fb
    >>> mesh = fb.strip(10.0, 1.0, 4, 1)
    >>> loads = fb.edge_force(mesh, "tip", [0.0, 0.0, 2.0])
    >>> round(float(sum(load.force[2] for load in loads)), 12)      # density x edge length
    2.0
    """
    return _edge_loads(mesh, sets, density, "force")


def edge_moment(mesh: "Tri6Mesh", sets: str | Sequence[str] | np.ndarray,
                density: Sequence[float] | np.ndarray) -> list[NodalLoad]:
    """A dead moment per unit reference length on edges, as consistent nodal moments.

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh.
    sets : str, list of str or np.ndarray
        The loaded edges: edge set name(s) or (k, 3) edge triples (:func:`edges_of`).
    density : array_like
        The moment per unit length (3,), global components (the part about a director does no work).

    Returns
    -------
    list[NodalLoad]
        One load per loaded node (the TOML ``type = "edge_moment"``).
    """
    return _edge_loads(mesh, sets, density, "moment")


def elements_of(mesh: "Tri6Mesh", sets: str | Sequence[str] | np.ndarray | None) -> np.ndarray | None:
    """The element indices of element sets (their union, sorted), or None for None (all elements).

    ``sets``: an element set name, a list of names, or element indices.
    """
    if sets is None:
        return None
    if isinstance(sets, str) or (isinstance(sets, (list, tuple)) and sets and all(isinstance(n, str) for n in sets)):
        return np.unique(np.concatenate([mesh.element_set(n) for n in _set_names(sets, "element sets")]))
    elems = np.atleast_1d(np.asarray(sets))
    if elems.size == 0 or not np.issubdtype(elems.dtype, np.integer) or elems.min() < 0 \
            or elems.max() >= mesh.n_elements:
        raise ValueError(f"elements must be element set names or indices in 0..{mesh.n_elements - 1}, got {sets!r}")
    return np.unique(elems)


def surface_force(mesh: "Tri6Mesh", density: Sequence[float] | np.ndarray,
                  elements: str | Sequence[str] | np.ndarray | None = None) -> list[NodalLoad]:
    """A dead force per unit reference area, as consistent nodal forces.

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh.
    density : array_like
        The force per unit area (3,), global components (e.g. a self-weight rho h g).
    elements : str, list of str, np.ndarray or None
        The loaded elements: element set name(s) or indices (default: all; :func:`elements_of`).

    Returns
    -------
    list[NodalLoad]
        One load per loaded node (the TOML ``type = "surface_force"``).
    """
    vectors = nodal_vectors_from_area(mesh, _as_vector(density, "surface force density"), elements_of(mesh, elements))
    return nodal_loads(vectors, "force")


@dataclass(frozen=True)
class FollowerPressure:
    """Pressure p on the current surface, acting along the director side normal (x_,r x x_,s)."""

    pressure: float
    elements: np.ndarray | None = None  # None: all elements


def pressure(mesh: "Tri6Mesh", value: float, elements: str | Sequence[str] | np.ndarray | None = None
             ) -> FollowerPressure:
    """A follower pressure on the current surface (positive along the director side normal).

    Parameters
    ----------
    mesh : Tri6Mesh
        The mesh.
    value : float
        The pressure at load factor 1.
    elements : str, list of str, np.ndarray or None
        The loaded elements: element set name(s) (a mesh file's physical surfaces) or indices; default all.

    Returns
    -------
    FollowerPressure
        The load (the TOML ``type = "pressure"``).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
            or not np.isfinite(value):
        raise ValueError(f"pressure must be a finite number, got {value!r}")
    return FollowerPressure(float(value), elements_of(mesh, elements))


def pressure_contribution(mesh, x: np.ndarray, p: float, elements=None):
    """Global nodal forces F (n, 3) of a follower pressure and per-element dF_I/dx_J (m, 6, 6, 3, 3).

    F_I = p int N_I (x_,r x x_,s) dr ds;  dF_I/dx_J = p int N_I (N_J,s hat(x_,r) - N_J,r hat(x_,s)) dr ds.

    All elements and Gauss points at once (numpy); :func:`pressure_contribution_reference` is the same
    integral element by element and point by point, the readable form this one is tested against.
    """
    elems = np.arange(mesh.n_elements) if elements is None else np.asarray(elements, int)
    conn = mesh.elements[elems]                                  # (k, 6)
    X = x[conn]                                                  # (k, 6, 3)
    xr = np.einsum("gi,kia->kga", _PRESSURE_DN[:, 0], X)         # (k, 7, 3) x_,r at the Gauss points
    xs = np.einsum("gi,kia->kga", _PRESSURE_DN[:, 1], X)
    wN = p * _PRESSURE_W[:, None] * _PRESSURE_N                  # (7, 6) p w_g N_I(g)
    Fe = np.einsum("gi,kga->kia", wN, np.cross(xr, xs))          # (k, 6, 3)
    F = np.zeros((mesh.n_nodes, 3))
    for a in range(3):
        F[:, a] = np.bincount(conn.ravel(), Fe[:, :, a].ravel(), minlength=mesh.n_nodes)
    # dF_IJ = sum_g p w_g N_I (N_J,s hat(x_,r) - N_J,r hat(x_,s))
    H = np.einsum("gj,kgab->kgjab", _PRESSURE_DN[:, 1], so3.hat_many(xr)) \
        - np.einsum("gj,kgab->kgjab", _PRESSURE_DN[:, 0], so3.hat_many(xs))   # (k, 7, 6, 3, 3)
    dF = np.einsum("gi,kgjab->kijab", wN, H)
    return F, dF, elems


def pressure_contribution_reference(mesh, x: np.ndarray, p: float, elements=None):
    """:func:`pressure_contribution` element by element and Gauss point by Gauss point (the reference)."""
    elems = np.arange(mesh.n_elements) if elements is None else np.asarray(elements, int)
    pts, wts = gauss_triangle_7()
    F = np.zeros((mesh.n_nodes, 3))
    dF = np.zeros((len(elems), 6, 6, 3, 3))
    for k, e in enumerate(elems):
        conn = mesh.elements[e]
        X = x[conn]
        for (r, s), w in zip(pts, wts):
            N = shape_functions(r, s)
            dN = shape_derivatives(r, s)
            xr, xs = dN @ X
            F[conn] += p * w * np.outer(N, np.cross(xr, xs))
            Hr, Hs = so3.hat(xr), so3.hat(xs)
            dF[k] += p * w * np.einsum("i,jab->ijab", N, dN[1][:, None, None] * Hr - dN[0][:, None, None] * Hs)
    return F, dF, elems


_PRESSURE_POINTS, _PRESSURE_W = gauss_triangle_7()
_PRESSURE_N = np.array([shape_functions(r, s) for r, s in _PRESSURE_POINTS])      # (7, 6)
_PRESSURE_DN = np.array([shape_derivatives(r, s) for r, s in _PRESSURE_POINTS])   # (7, 2, 6)
