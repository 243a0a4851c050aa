"""Post-processing of a state: stress resultants, fibre stresses, strain energy per element, reactions.

Stress resultants (paper Eq. 14) per unit length of the reference surface, at the 7 Gauss points of each
element: membrane forces N = [N11, N22, N12], bending moments M = [M11, M22, M12], transverse shear forces
Q = [Q1, Q2], i.e. ``sigma = C eps`` with the element's Cartesian strains (MITC6 assumed strains where they
apply). Their components refer to the reference surface's Gauss-point basis (t1, t2): t1 = G_r / |G_r|,
n = G_r x G_s / |G_r x G_s|, t2 = n x t1 (:mod:`flexbody.shell.geometry`): they are material (Lagrangian)
resultants, work conjugate to the Green-Lagrange type strains of the element.

To nodes: the Gauss values are turned into global tensors (N = N_ab t_a (x) t_b, Q = Q_a t_a), extrapolated
to the six nodes of each element by the least-squares quadratic through the 7 Gauss points (exact for a
quadratic field), averaged over the elements that share a node, and projected onto the node's reference
frame axes (a1, a2) = the first two columns of ``body.frames0``: nodal components in a basis that is the
same for every element at the node.

Derived fields: principal membrane forces N1 >= N2 and the direction of N1 (reference: c a1 + s a2; current
configuration: R_I (c e1 + s e2), the nodal frame carries the material direction along); the plane-stress
fibre stresses at z = +-h/2 (z along the director, "top" = +director side) sigma = N/h + z 12 M / h^3 and
their von Mises equivalent sqrt(s11^2 + s22^2 - s11 s22 + 3 s12^2) (the transverse shear stress vanishes at
the faces); the strain energy of each element 1/2 sum_g w_g eps_g . C eps_g.

Reactions: the forces and moments the supports exert on the body, R = f_int - f_ext (- m g in dynamics) on
the constrained components of each node, in global components (moments of the in-plane rotations and, at a
supported node, about its director). At equilibrium the residual of the free components is zero, so the
reactions and the applied loads balance: sum R + sum F = 0 and sum (x x R + M_R) + sum (x x F + M) = 0.
The element's internal forces have small components about the directors (the drilling rotation is not a
DoF: every node is held about its director); at the unsupported nodes these moments (``drilling``) close
the moment balance: without them it is off by 2.3e-3 of |F| L on the end-shear strip at half load, 1e-6 of the
applied moment on the end-moment strip (measured, docs/output_formats.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flexbody.shell.geometry import EVAL_DN, GAUSS_OFFSET, GAUSS_POINTS, N_GAUSS
from flexbody.shell.reference.material import section_stresses
from flexbody.shell.shape import shape_derivatives, shape_functions

if TYPE_CHECKING:
    from flexbody.assembly import Model
    from flexbody.body import ShellBody, ShellState

#: names of the 8 resultant components, in the order of the section law
COMPONENTS = ("N11", "N22", "N12", "M11", "M22", "M12", "Q1", "Q2")

#: least-squares map from the 7 Gauss values to the 6 nodal values of a quadratic field (6, 7)
_GAUSS_TO_NODES = np.linalg.pinv(np.array([shape_functions(r, s) for r, s in GAUSS_POINTS]))


def _bases(G: np.ndarray) -> np.ndarray:
    """Orthonormal (t1, t2, n) (..., 3, 3) (rows) of tangent pairs G (..., 2, 3): t1 = G_r/|G_r|, t2 = n x t1."""
    t1 = G[..., 0, :] / np.linalg.norm(G[..., 0, :], axis=-1, keepdims=True)
    n = np.cross(G[..., 0, :], G[..., 1, :])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.stack([t1, np.cross(n, t1), n], axis=-2)


def gauss_bases(mesh) -> np.ndarray:
    """The reference Gauss-point bases (m, 7, 3, 3), rows t1, t2, n (:mod:`flexbody.shell.geometry`)."""
    X = np.asarray(mesh.nodes, dtype=float)[mesh.elements]                     # (m, 6, 3)
    G = np.einsum("gai,mij->mgaj", EVAL_DN[GAUSS_OFFSET:], X)                 # (m, 7, 2, 3)
    return _bases(G)


def centroid_bases(mesh) -> np.ndarray:
    """The reference bases at the element centroids (m, 3, 3), rows t1, t2, n."""
    X = np.asarray(mesh.nodes, dtype=float)[mesh.elements]
    return _bases(np.einsum("ai,mij->maj", shape_derivatives(1 / 3, 1 / 3), X))


def element_axes(body) -> np.ndarray:
    """Per element, the axes (m, 2, 3) of its element-mean components: the mean of its nodes' reference frame
    axis a1 projected onto the tangent plane at the centroid, and n x a1 -- on a flat mesh the nodal axes
    themselves, so that neighbouring elements share a basis."""
    n = centroid_bases(body.mesh)[:, 2, :]
    a1 = body.frames0[body.mesh.elements][:, :, :, 0].mean(axis=1)
    a1 = a1 - np.einsum("mi,mi->m", a1, n)[:, None] * n
    a1 /= np.linalg.norm(a1, axis=1, keepdims=True)
    return np.stack([a1, np.cross(n, a1)], axis=1)


def gauss_strains(body, state) -> np.ndarray:
    """The Cartesian strains (m, 7, 8) [membrane e11, e22, 2 e12 | bending | shear] at the Gauss points
    (:meth:`flexbody.body.ShellBody.strains`)."""
    return body.strains(state)


def to_tensors(sigma: np.ndarray, bases: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Resultant components (..., 8) in bases (..., 3, 3) -> global N (..., 3, 3), M (..., 3, 3), Q (..., 3)."""
    t = bases[..., :2, :]                                                      # (..., 2, 3)

    def tensor(c):
        c2 = np.stack([np.stack([c[..., 0], c[..., 2]], -1), np.stack([c[..., 2], c[..., 1]], -1)], -2)
        return np.einsum("...ai,...ab,...bj->...ij", t, c2, t)
    return tensor(sigma[..., 0:3]), tensor(sigma[..., 3:6]), np.einsum("...a,...ai->...i", sigma[..., 6:8], t)


def from_tensors(N: np.ndarray, M: np.ndarray, Q: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Global N, M (..., 3, 3), Q (..., 3) -> components (..., 8) on the axes (..., 2, 3) (a1, a2 as rows)."""
    def comps(T):
        return np.stack([np.einsum("...i,...ij,...j->...", axes[..., a, :], T, axes[..., b, :])
                         for a, b in ((0, 0), (1, 1), (0, 1))], -1)
    return np.concatenate([comps(N), comps(M), np.einsum("...ai,...i->...a", axes, Q)], -1)


def nodal_average(values: np.ndarray, elements: np.ndarray, n_nodes: int) -> np.ndarray:
    """Gauss-point values (m, 7, ...) -> nodal values (n, ...): the least-squares quadratic of each element
    at its nodes, averaged over the elements sharing a node."""
    per_node = np.einsum("ig,mg...->mi...", _GAUSS_TO_NODES, values)           # (m, 6, ...)
    total = np.zeros((n_nodes,) + values.shape[2:])
    np.add.at(total, elements, per_node)
    count = np.bincount(elements.ravel(), minlength=n_nodes).astype(float)
    return total / np.maximum(count, 1.0).reshape((-1,) + (1,) * (values.ndim - 2))


def principal(n: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Principal values N1 >= N2 and the angle phi of N1 from axis 1, of [N11, N22, N12] (..., 3)."""
    mean = 0.5 * (n[..., 0] + n[..., 1])
    radius = np.hypot(0.5 * (n[..., 0] - n[..., 1]), n[..., 2])
    return mean + radius, mean - radius, 0.5 * np.arctan2(2.0 * n[..., 2], n[..., 0] - n[..., 1])


def fibre_von_mises(sigma: np.ndarray, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """von Mises stress at the top (z = +h/2, the director's side) and bottom fibre of resultants (..., 8)."""
    out = []
    for z in (0.5 * thickness, -0.5 * thickness):
        s = sigma[..., 0:3] / thickness + 12.0 * z / thickness**3 * sigma[..., 3:6]
        out.append(np.sqrt(np.maximum(s[..., 0]**2 + s[..., 1]**2 - s[..., 0] * s[..., 1] + 3 * s[..., 2]**2, 0)))
    return out[0], out[1]


@dataclass
class Resultants:
    """Stress resultants of one state (module docstring). ``m`` elements, ``n`` nodes.

    Attributes
    ----------
    gauss : (m, 7, 8) N11, N22, N12, M11, M22, M12, Q1, Q2 at the Gauss points, in the Gauss bases
    strains : (m, 7, 8) the strains they come from (membrane e11, e22, 2 e12 | bending | shear)
    weights : (m, 7) Gauss weights times the area element (sum: the reference area)
    nodal : (n, 8) averaged to the nodes, in the nodes' reference frame axes a1, a2
    element : (m, 8) element means (area-weighted), on the element axes (:func:`element_axes`)
    element_energy : (m,) strain energy of each element
    principal_membrane : (n, 2) principal membrane forces N1 >= N2 at the nodes
    principal_direction : (n, 3) unit direction of N1 at the nodes, current configuration
    principal_direction_reference : (n, 3) the same in the reference configuration
    von_mises_top, von_mises_bottom : (n,) equivalent fibre stresses at z = +h/2 and -h/2, nodes
    gauss_von_mises_top, gauss_von_mises_bottom : (m, 7) the same at the Gauss points
    """

    gauss: np.ndarray
    strains: np.ndarray
    weights: np.ndarray
    nodal: np.ndarray
    element: np.ndarray
    element_energy: np.ndarray
    principal_membrane: np.ndarray
    principal_direction: np.ndarray
    principal_direction_reference: np.ndarray
    von_mises_top: np.ndarray
    von_mises_bottom: np.ndarray
    gauss_von_mises_top: np.ndarray
    gauss_von_mises_bottom: np.ndarray

    @property
    def strain_energy(self) -> float:
        return float(self.element_energy.sum())


def stress_resultants(body: "ShellBody", state: "ShellState") -> Resultants:
    """The stress resultants of ``state`` (:class:`Resultants`) of a :class:`flexbody.body.ShellBody`."""
    eps = gauss_strains(body, state)
    sigma = section_stresses(eps, body.material.section(), body.material.wrinkling)
    weights = body.reference.weights
    mesh = body.mesh
    bases = gauss_bases(mesh)
    N, M, Q = to_tensors(sigma, bases)
    flat = np.concatenate([N.reshape(N.shape[:2] + (9,)), M.reshape(M.shape[:2] + (9,)), Q], axis=-1)
    nodal_flat = nodal_average(flat, mesh.elements, mesh.n_nodes)
    axes = np.transpose(body.frames0[:, :, :2], (0, 2, 1))                   # (n, 2, 3) rows a1, a2
    nodal = from_tensors(nodal_flat[:, :9].reshape(-1, 3, 3), nodal_flat[:, 9:18].reshape(-1, 3, 3),
                         nodal_flat[:, 18:], axes)
    area = weights.sum(axis=1)[:, None]
    mean = np.einsum("mg,mgk->mk", weights, flat) / area
    element = from_tensors(mean[:, :9].reshape(-1, 3, 3), mean[:, 9:18].reshape(-1, 3, 3), mean[:, 18:],
                           element_axes(body))
    n1, n2, phi = principal(nodal[:, :3])
    local_dir = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=-1)
    h = body.material.thickness
    top, bottom = fibre_von_mises(nodal, h)
    g_top, g_bottom = fibre_von_mises(sigma, h)
    return Resultants(
        gauss=sigma, strains=eps, weights=weights, nodal=nodal, element=element,
        element_energy=0.5 * np.einsum("mg,mgk,mgk->m", weights, eps, sigma),
        principal_membrane=np.column_stack([n1, n2]),
        principal_direction=np.einsum("nij,nj->ni", state.frames, local_dir),
        principal_direction_reference=np.einsum("nij,nj->ni", body.frames0, local_dir),
        von_mises_top=top, von_mises_bottom=bottom, gauss_von_mises_top=g_top, gauss_von_mises_bottom=g_bottom)


# ----------------------------------------------------------------------------------------------------------
# Reactions
# ----------------------------------------------------------------------------------------------------------

@dataclass
class Reactions:
    """Support reactions of one state: ``force`` (n, 3), ``moment`` (n, 3) in global components (zero at
    unsupported nodes), and the applied nodal loads ``load_force``, ``load_moment`` (n, 3) they balance
    (external loads at the load factor, pressure as its consistent nodal forces, gravity in dynamics)."""

    force: np.ndarray
    moment: np.ndarray
    load_force: np.ndarray
    load_moment: np.ndarray
    positions: np.ndarray      # (n, 3) the nodal positions of the state (for moments about a point)
    supported: np.ndarray      # (k,) the nodes with a constrained component
    drilling: np.ndarray       # (n, 3) the moments about the directors at the unsupported nodes (below)

    @property
    def total_force(self) -> np.ndarray:
        return self.force.sum(axis=0)

    def total_moment(self, about=(0.0, 0.0, 0.0), drilling: bool = True) -> np.ndarray:
        """sum (x_I - p) x R_I + M_I of the reactions about the point ``about``; with ``drilling`` plus the
        moments about the directors of the unsupported nodes (:attr:`drilling`)."""
        extra = self.drilling.sum(axis=0) if drilling else 0.0
        return _moment(self.positions, self.force, self.moment, about) + extra

    @property
    def total_load_force(self) -> np.ndarray:
        return self.load_force.sum(axis=0)

    def total_load_moment(self, about=(0.0, 0.0, 0.0)) -> np.ndarray:
        return _moment(self.positions, self.load_force, self.load_moment, about)


def _moment(x: np.ndarray, force: np.ndarray, moment: np.ndarray, about) -> np.ndarray:
    return np.cross(x - np.asarray(about, dtype=float), force).sum(axis=0) + moment.sum(axis=0)


def support_projectors(model) -> tuple[np.ndarray, np.ndarray]:
    """Per node, the projections (n, 3, 3) onto the constrained translation directions (global) and the
    masks (n, 3) of the constrained local rotation components (drilling: at supported nodes)."""
    n = model.body.n_nodes
    P = np.zeros((n, 3, 3))
    full = model.fixed[:, :3].all(axis=1)
    P[full] = np.eye(3)
    for i in np.flatnonzero(model.has_basis & ~full):
        E = model.basis[i][:, model.fixed[i, :3]]
        P[i] = E @ E.T
    mask = model.fixed[:, 3:6].astype(float)
    mask[:, 2] = model.fixed[:, :5].any(axis=1)
    return P, mask


def reactions(model: "Model", state: "ShellState", lam: float | np.ndarray = 1.0,
              gravity_force: np.ndarray | None = None) -> Reactions:
    """The support reactions of ``state`` at load factor ``lam`` (a number or one factor per load group).

    ``gravity_force`` : nodal gravity forces m_I g (n, 3) of a dynamic model (they load the supports too).
    In dynamics the reactions are those of the elastic, applied and gravity forces; the inertia and damping
    forces of the constrained nodes (zero for fixed supports) are not included.
    """
    r6, fext = model.nodal_out_of_balance(state, lam)                       # local (n, 6) each
    R = state.frames
    f_glob = np.einsum("nij,nj->ni", R, r6[:, :3])
    load_f = np.einsum("nij,nj->ni", R, fext[:, :3])
    load_m = np.einsum("nij,nj->ni", R, fext[:, 3:])
    if gravity_force is not None:
        f_glob = f_glob - gravity_force
        load_f = load_f + gravity_force
    P, mask = support_projectors(model)
    force = np.einsum("nij,nj->ni", P, f_glob)
    moment = np.einsum("nij,nj->ni", R, mask * r6[:, 3:])
    supported = model.fixed[:, :5].any(axis=1)
    drill = np.where(supported, 0.0, r6[:, 5])[:, None] * R[:, :, 2]
    return Reactions(force, moment, load_f, load_m, np.asarray(state.x, dtype=float).copy(),
                     np.flatnonzero(supported), drill)
