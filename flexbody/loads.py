"""External loads, scaled by the load factor lambda: r(q, lambda) = f_int(q) - lambda f_ext(q).

Every load returns its contribution to the nodal *local-frame* external force (n, 6) = [force, moment]
components in R_I, and, where it depends on the configuration, its tangent. Dead loads are fixed in
space, follower loads turn with the nodes (a follower nodal load is constant in the local frame) or with the
surface (follower pressure).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexbody.lie import so3
from flexbody.shell.shape import gauss_triangle_7, shape_derivatives, shape_functions


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


def nodal_vectors_from_area(mesh, density: np.ndarray) -> np.ndarray:
    """Consistent nodal vectors of a dead area density (per unit reference area)."""
    out = np.zeros((mesh.n_nodes, 3))
    pts, wts = gauss_triangle_7()
    for conn in mesh.elements:
        X = mesh.nodes[conn]
        for (r, s), w in zip(pts, wts):
            dX = shape_derivatives(r, s) @ X
            area = np.linalg.norm(np.cross(dX[0], dX[1]))
            out[conn] += np.outer(shape_functions(r, s), density) * w * area
    return out


@dataclass(frozen=True)
class FollowerPressure:
    """Pressure p on the current surface, acting along the director side normal (x_,r x x_,s)."""

    pressure: float
    elements: np.ndarray | None = None  # None: all elements


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
