"""Inertia of the shell: lumped nodal mass and director (rotary) inertia, nodal inertia forces and tangents.

Kinetic energy of a Reissner-Mindlin shell with mid-surface position x and director t (|t| = 1)::

    T = 1/2 int_A int_{-h/2}^{h/2} rho |xdot + z tdot|^2 dz dA = 1/2 int_A (rho h |xdot|^2 + rho h^3/12 |tdot|^2) dA

(the cross term vanishes because the reference surface is the mid-surface).

Choice: lumped (HRZ) mass
-------------------------
The quadratic triangle's row-sum lumping gives zero corner masses (a corner shape function integrates to
zero), so the nodal area is the Hinton-Rock-Zienkiewicz (HRZ) lumping: the diagonal of the consistent
matrix int N_I^2 dA, scaled so that the nodal areas add up to the element area (corners 3/57, midsides
16/57 of a straight-sided element). The nodal mass is m_I = rho h A_I and the nodal director inertia
j_I = rho h^3/12 A_I. Why lumped:

* the director inertia is then a nodal term, j_I |tdot_I|^2 / 2, expressed in the nodal local frame with a
  *constant* matrix J_I = j_I diag(1, 1, 0), which is the point of the local-frame formulation; a consistent
  director mass would couple the interpolated relative rotations and depend on the configuration;
* with global translational velocities (see below) the translational mass m_I I is constant as well, so the
  whole mass matrix is a constant diagonal and the iteration matrix needs no mass re-assembly;
* HRZ lumping of six-node triangles converges at the rate of the consistent mass for the lowest modes.

The consistent translational mass S_IJ = int rho h N_I N_J dA (:func:`consistent_scalar_mass`) is the other
choice (``DynamicModel(mass="consistent")``, :func:`shell_mass`): constant as well, with the director inertia
kept lumped (a consistent one couples the nodes through R_I^T R_J). Measured in docs/dynamics.md: HRZ
underestimates the higher membrane modes, the consistent mass overestimates them and converges faster (in-plane
errors fall 10-15x per mesh halving against 2-4x).

Nodal inertia forces
--------------------
Two parametrisations of the nodal velocity are provided (both with a local angular velocity w,
Rdot = R hat(w)):

``R^3 x SO(3)`` (used by :mod:`flexbody.dynamics`): global translational velocity xdot. Force in the
    global rows: f_x = m xdot_dot; rotary part f_w = J wdot + w x (J w). Nothing depends on the configuration
    unless the translational rows are written in the local frame (``inertia_force_local_rows``), where
    f_u = R^T m a and its derivative along R exp(eps e_k) is hat(R^T m a).
``SE(3) local`` velocities v = R^T xdot: xddot = R (vdot + w x v), so f_u = m (vdot + w x v) (a Coriolis
    term appears) with tangents d/dvdot = m I, d/dv = m hat(w), d/dw = -m hat(v).

Shell director and gyroscopic terms: the 5-DoF node has no drilling velocity (w_3 = 0: the nodal frame is
parallel-transported with the director, it is not a DoF), and J = j diag(1, 1, 0), so w x (J w) = j w x w = 0
identically. The director's virtual work j tddot . delta t with delta t = R (delta theta x e3) reduces to
j (wdot_1 delta theta_1 + wdot_2 delta theta_2): tddot = R (wdot x e3 - |w|^2 e3) and the centripetal part
-|w|^2 e3 is normal to every admissible variation (tests/shell/test_inertia.py checks this on a trajectory).
The general formulas with full J and w are kept for other bodies (and are tested against finite differences).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from flexbody.lie import so3
from flexbody.shell.geometry import EVAL_N, GAUSS_OFFSET, N_GAUSS

#: shape functions at the 7 Gauss points, (7, 6)
GAUSS_N = EVAL_N[GAUSS_OFFSET:GAUSS_OFFSET + N_GAUSS]


@dataclass(frozen=True)
class NodalInertia:
    """Lumped nodal inertia: translational mass m_I and director inertia j_I (J_I = j_I diag(1, 1, 0))."""

    mass: np.ndarray      # (n,)
    rotary: np.ndarray    # (n,)

    @property
    def total_mass(self) -> float:
        return float(self.mass.sum())


def hrz_nodal_areas(weights: np.ndarray, conn: np.ndarray, n_nodes: int) -> np.ndarray:
    """HRZ-lumped nodal areas A_I (n,).

    Parameters
    ----------
    weights : (m, 7) Gauss weight x reference area element of each element (``ReferenceGeometry.weights``)
    conn : (m, 6) element connectivity
    n_nodes : number of nodes
    """
    area = weights.sum(axis=1)                               # element areas
    diag = np.einsum("eg,gi->ei", weights, GAUSS_N**2)       # int N_I^2 dA (exact: degree 4 <= 5)
    lumped = diag * (area / diag.sum(axis=1))[:, None]       # scaled to the element area
    out = np.zeros(n_nodes)
    np.add.at(out, conn, lumped)
    return out


def nodal_inertia(body) -> NodalInertia:
    """Lumped inertia of a :class:`flexbody.body.ShellBody` from its material density and thickness."""
    mat = body.material
    areas = hrz_nodal_areas(body.reference.weights, body.mesh.elements, body.n_nodes)
    return NodalInertia(mat.density * mat.thickness * areas, mat.density * mat.thickness**3 / 12.0 * areas)


#: the mass matrices a :class:`flexbody.dynamics.DynamicModel` can use
MASS_KINDS = ("lumped", "consistent")


def check_mass_kind(kind) -> str:
    """``kind`` if it is one of :data:`MASS_KINDS`, else ValueError naming it."""
    if not isinstance(kind, str) or kind not in MASS_KINDS:
        raise ValueError(f"mass must be 'lumped' or 'consistent', got {kind!r}")
    return kind


def consistent_scalar_mass(weights: np.ndarray, conn: np.ndarray, n_nodes: int, rho_h: float) -> sp.csr_matrix:
    """The consistent scalar mass M_IJ = int rho h N_I N_J dA (n, n), assembled over the elements.

    The product of two quadratic shape functions is of degree 4; the 7-point rule is exact to degree 5, so the
    element matrices are exact on straight-sided (flat) elements (on curved ones the area element varies).
    The translational mass is M_IJ I_3 (translations in fixed directions: constant).

    Parameters
    ----------
    weights : (m, 7) Gauss weight x reference area element of each element (``ReferenceGeometry.weights``)
    conn : (m, 6) element connectivity
    n_nodes : number of nodes
    rho_h : mass per unit area rho h
    """
    me = rho_h * np.einsum("eg,gi,gj->eij", weights, GAUSS_N, GAUSS_N)        # (m, 6, 6)
    rows = np.repeat(conn, 6, axis=1).ravel()                                  # conn[e, i] for (i, j)
    cols = np.tile(conn, (1, 6)).ravel()                                       # conn[e, j]
    return sp.csr_matrix((me.ravel(), (rows, cols)), shape=(n_nodes, n_nodes))


@dataclass(frozen=True)
class ShellMass:
    """The mass of a shell body: the translational scalar mass S (M_tt = S x I_3) and the director inertia j.

    ``kind`` "lumped": S = diag(m_I) (HRZ, :func:`nodal_inertia`); "consistent": S_IJ = int rho h N_I N_J dA
    (:func:`consistent_scalar_mass`). The director (rotary) inertia is lumped in both, j_I = rho h^3/12 A_I: a
    consistent director mass couples the nodes through R_I^T R_J and is not constant; it is h^2/12 of the
    translational mass per unit area, so its share of the kinetic energy of a mode of wavelength lambda is
    of order (h/lambda)^2 (docs/dynamics.md measures it). Point masses add M to S_II and J to j_I.
    """

    kind: str
    scalar: sp.csr_matrix   # (n, n)
    rotary: np.ndarray      # (n,)

    @property
    def nodal(self) -> np.ndarray:
        """The row sums of S: int rho h N_I dA (+ point masses) consistent, m_I lumped. Gravity is f_I = s_I g,
        the first moment sum s_I x_I, the linear momentum sum s_I xdot_I (exact for the interpolated field)."""
        return np.asarray(self.scalar.sum(axis=1)).ravel()

    @property
    def total_mass(self) -> float:
        return float(self.scalar.sum())

    def centre(self, x: np.ndarray) -> np.ndarray:
        """The mass centre sum s_I x_I / sum s_I of the positions x (n, 3)."""
        s = self.nodal
        return (s @ x) / s.sum()

    def inertia_tensor(self, x: np.ndarray, directors: np.ndarray, center: np.ndarray) -> np.ndarray:
        """sum_IJ S_IJ (r_I . r_J 1 - r_I r_J^T) + sum j_I (1 - t_I t_I^T), r_I = x_I - center."""
        r = x - center
        Sr = self.scalar @ r
        I = np.einsum("nk,nk->", r, Sr) * np.eye(3) - 0.5 * (r.T @ Sr + Sr.T @ r)
        return I + self.rotary.sum() * np.eye(3) - np.einsum("n,ni,nj->ij", self.rotary, directors, directors)


def shell_mass(body, kind: str = "lumped", point_masses=()) -> ShellMass:
    """The :class:`ShellMass` of a :class:`flexbody.body.ShellBody` with point masses, lumped or consistent."""
    check_mass_kind(kind)
    lumped = with_point_masses(nodal_inertia(body), point_masses)
    if kind == "lumped":
        return ShellMass(kind, sp.diags(lumped.mass).tocsr(), lumped.rotary)
    mat, n = body.material, body.n_nodes
    S = consistent_scalar_mass(body.reference.weights, body.mesh.elements, n, mat.density * mat.thickness)
    points = with_point_masses(NodalInertia(np.zeros(n), np.zeros(n)), point_masses).mass
    return ShellMass(kind, (S + sp.diags(points)).tocsr(), lumped.rotary)


@dataclass(frozen=True)
class PointMass:
    """A rigid mass attached at nodes (a tip mass): each of ``nodes`` carries ``mass`` and ``rotary``.

    Parameters
    ----------
    nodes : the node indices; every one of them gets the whole mass and rotary inertia
    mass : M >= 0, added to the translational mass m_I
    rotary : J >= 0, added to the director inertia j_I: the moment of inertia about every axis normal to the
        director t_I through the node. A 5-DoF node has no rotation about its director (its frame is
        parallel-transported, w_3 = 0), so that moment of inertia does not enter, and the two in-plane axes are
        not material axes: only an inertia that is the same about both (J diag(1, 1, 0)) is objective.
    """

    nodes: np.ndarray
    mass: float
    rotary: float = 0.0

    def __post_init__(self) -> None:
        nodes = np.atleast_1d(np.asarray(self.nodes))
        if nodes.size == 0 or nodes.ndim != 1 or not np.issubdtype(nodes.dtype, np.integer):
            raise ValueError(f"point mass nodes must be a non-empty list of node indices, got {self.nodes!r}")
        object.__setattr__(self, "nodes", nodes.astype(int))
        for name in ("mass", "rotary"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
                    or not (np.isfinite(value) and value >= 0):
                raise ValueError(f"point mass {name} must be a finite number >= 0, got {value!r}")
            object.__setattr__(self, name, float(value))


def with_point_masses(inertia: NodalInertia, point_masses) -> NodalInertia:
    """The nodal inertia with point masses added: m_I += M, j_I += J on their nodes."""
    mass, rotary = inertia.mass.copy(), inertia.rotary.copy()
    n = mass.size
    for p in point_masses:
        if not isinstance(p, PointMass):
            raise ValueError(f"point masses must be PointMass, got {type(p).__name__}")
        bad = p.nodes[(p.nodes < 0) | (p.nodes >= n)]
        if bad.size:
            raise ValueError(f"point mass on node {bad[0]}, but the mesh has nodes 0..{n - 1}")
        np.add.at(mass, p.nodes, p.mass)
        np.add.at(rotary, p.nodes, p.rotary)
    return NodalInertia(mass, rotary)


def director_tensor(j: float) -> np.ndarray:
    """The local rotary inertia J = j diag(1, 1, 0) of a shell node (no drilling inertia)."""
    return np.diag([j, j, 0.0])


# -- rotary part, general J (3 x 3) -------------------------------------------------------------------------
def rotary_force(J: np.ndarray, w: np.ndarray, wdot: np.ndarray) -> np.ndarray:
    """Euler's rotary inertia force J wdot + w x (J w) in the local frame."""
    return J @ wdot + np.cross(w, J @ w)


def rotary_tangents(J: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(d f/d wdot, d f/d w) of :func:`rotary_force`: J and hat(w) J - hat(J w) (gyroscopic matrix)."""
    return J.copy(), so3.hat(w) @ J - so3.hat(J @ w)


# -- translational part -------------------------------------------------------------------------------------
def translational_force_local_rows(m: float, R: np.ndarray, a: np.ndarray) -> np.ndarray:
    """f_u = R^T m a: the inertia force of a global acceleration a in the local rows of frame R."""
    return m * (R.T @ a)


def translational_local_rows_tangents(m: float, R: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(d f_u/d a, d f_u/d theta) of :func:`translational_force_local_rows`; theta along R exp(hat(theta)).

    exp(-hat(theta)) R^T m a = R^T m a - theta x (R^T m a) = R^T m a + hat(R^T m a) theta.
    """
    return m * R.T, so3.hat(m * (R.T @ a))


def translational_force_se3(m: float, v: np.ndarray, w: np.ndarray, vdot: np.ndarray) -> np.ndarray:
    """f_u = m (vdot + w x v) for local translational velocity v = R^T xdot (xddot = R (vdot + w x v))."""
    return m * (vdot + np.cross(w, v))


def translational_se3_tangents(m: float, v: np.ndarray, w: np.ndarray):
    """(d f_u/d vdot, d f_u/d v, d f_u/d w) of :func:`translational_force_se3`: m I, m hat(w), -m hat(v)."""
    return m * np.eye(3), m * so3.hat(w), -m * so3.hat(v)


# -- the 5-DoF shell node -----------------------------------------------------------------------------------
def shell_node_force(m: float, j: float, a: np.ndarray, w: np.ndarray, wdot: np.ndarray) -> np.ndarray:
    """Inertia force of a 5-DoF shell node [global translation (3), in-plane rotations (2)].

    a : global acceleration (3,);  w, wdot : in-plane local angular velocity and acceleration (2,)
    (the drilling component is not a DoF: w_3 = 0). With J = j diag(1, 1, 0) the gyroscopic term
    w x (J w) vanishes, so the force is linear: [m a, j wdot].
    """
    w3 = np.array([w[0], w[1], 0.0])
    f_rot = rotary_force(director_tensor(j), w3, np.array([wdot[0], wdot[1], 0.0]))
    return np.concatenate([m * np.asarray(a, float), f_rot[:2]])
