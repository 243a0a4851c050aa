"""Reference geometry of one element: evaluation points, metric, covariant-to-Cartesian maps, f^0.

The covariant strains of the kinematics are referred to the parametric directions (r, s). The material
law needs them in a local Cartesian basis (t1, t2) of the reference surface at each Gauss point:
t1 = G_r/|G_r|, n = G_r x G_s/|G_r x G_s|, t2 = n x t1, with G_a = X^0_,a. With J_ia = G_i . t_a and
P = J^-1, a tensor strain transforms as eps_ab = P_ai P_bj e_ij and a transverse shear as gamma_a = P_ai g_i.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexbody.lie import so3
from flexbody.shell import mitc6
from flexbody.shell.reference.points import (covariant_strains, covariant_strains_many, point_kinematics,
                                             relative_rotations)
from flexbody.shell.shape import (bubble_derivatives, bubble_function, gauss_triangle_7, shape_derivatives,
                                  shape_functions)

GAUSS_POINTS, GAUSS_WEIGHTS = gauss_triangle_7()
#: Evaluation points of an element: the MITC6 tying points first, then the Gauss points.
EVAL_POINTS = np.vstack([mitc6.TYING_POINTS, GAUSS_POINTS])
N_GAUSS = len(GAUSS_POINTS)
GAUSS_OFFSET = mitc6.N_TYING
EVAL_N = np.array([shape_functions(r, s) for r, s in EVAL_POINTS])
EVAL_DN = np.array([shape_derivatives(r, s) for r, s in EVAL_POINTS])
#: The rotation bubble N_b = 27 r s t of MITC7 and its derivatives at the evaluation points: (17,), (17, 2).
EVAL_NB = np.array([bubble_function(r, s) for r, s in EVAL_POINTS])
EVAL_DNB = np.array([bubble_derivatives(r, s) for r, s in EVAL_POINTS])
assert np.array_equal(EVAL_POINTS[GAUSS_OFFSET:], mitc6._GAUSS_POINTS) and len(EVAL_POINTS) == mitc6.N_EVAL
#: Membrane maps per scheme (mitc6.MEMBRANE_SCHEMES), over all evaluation points: (7, 3, 17, 3) each.
MEMBRANE_MAPS = {scheme: np.array([mitc6.membrane_map(r, s, scheme) for r, s in GAUSS_POINTS])
                 for scheme in mitc6.MEMBRANE_SCHEMES}
SHEAR_MAPS = np.array([mitc6.shear_map(r, s) for r, s in GAUSS_POINTS])        # (7, 2, 10, 2)
MITC7_SHEAR_MAPS = np.array([mitc6.shear_map_mitc7(r, s) for r, s in GAUSS_POINTS])  # (7, 2, 17, 2)


def tensor_to_voigt(P: np.ndarray) -> np.ndarray:
    """L with [eps_11, eps_22, 2 eps_12] = L [e_rr, e_ss, e_rs] for eps_ab = P_ai P_bj e_ij."""
    (p00, p01), (p10, p11) = P
    return np.array([
        [p00 * p00, p01 * p01, 2 * p00 * p01],
        [p10 * p10, p11 * p11, 2 * p10 * p11],
        [2 * p00 * p10, 2 * p01 * p11, 2 * (p00 * p11 + p01 * p10)],
    ])


def local_basis(G: np.ndarray) -> tuple[np.ndarray, float]:
    """Covariant-to-Cartesian 2x2 map P and the area element |G_r x G_s| from G = (G_r, G_s)."""
    normal = np.cross(G[0], G[1])
    area = float(np.linalg.norm(normal))
    n = normal / area
    t1 = G[0] / np.linalg.norm(G[0])
    t2 = np.cross(n, t1)
    J = np.array([[G[0] @ t1, G[0] @ t2], [G[1] @ t1, G[1] @ t2]])
    return np.linalg.inv(J), area


@dataclass(frozen=True)
class ElementGeometry:
    """Reference data of one element (computed once from the reference configuration)."""

    e_ref: np.ndarray      # (17, 8) covariant strain measures of the reference state at EVAL_POINTS
    to_cart: np.ndarray    # (7, 8, 8) covariant -> Cartesian [membrane, bending, shear] at Gauss points
    weights: np.ndarray    # (7,) Gauss weight x area element


def element_geometry(x0: np.ndarray, frames0: np.ndarray) -> ElementGeometry:
    """Reference measures f^0 (paper Eq. 8) and the metric of one element."""
    d0 = relative_rotations(frames0)
    e_ref = np.array([
        covariant_strains(point_kinematics(x0, frames0, d0, N, dN).F) for N, dN in zip(EVAL_N, EVAL_DN)
    ])
    to_cart = np.zeros((N_GAUSS, 8, 8))
    weights = np.zeros(N_GAUSS)
    for g in range(N_GAUSS):
        P, area = local_basis(EVAL_DN[GAUSS_OFFSET + g] @ x0)
        L = tensor_to_voigt(P)
        to_cart[g, :3, :3] = L
        to_cart[g, 3:6, 3:6] = L
        to_cart[g, 6:, 6:] = P
        weights[g] = GAUSS_WEIGHTS[g] * area
    return ElementGeometry(e_ref, to_cart, weights)


def element_geometry_batch(x0_el: np.ndarray, frames0_el: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`element_geometry` of m elements at once (numpy over elements and points; the set-up of a model).

    x0_el (m, 6, 3), frames0_el (m, 6, 3, 3) -> e_ref (m, 17, 8), to_cart (m, 7, 8, 8), weights (m, 7).
    The same formulas as the element-by-element version (paper Eqs. 8, 9, 30), which is the reference.
    """
    m = len(x0_el)
    R0 = frames0_el[:, 0]                                                   # (m, 3, 3)
    d_nodes = np.zeros((m, 6, 3))
    d_nodes[:, 1:] = so3.log_many(np.einsum("mba,mibc->miac", R0, frames0_el[:, 1:]))   # log(R_0^T R_I)
    d = np.einsum("pi,mia->mpa", EVAL_N, d_nodes)                           # (m, 17, 3)
    d_a = np.einsum("pbi,mia->mpba", EVAL_DN, d_nodes)                      # (m, 17, 2, 3)
    x_a = np.einsum("pbi,mia->mpba", EVAL_DN, x0_el)                        # (m, 17, 2, 3)
    R = np.einsum("mab,mpbc->mpac", R0, so3.exp_many(d))                    # R_0 exp(d)
    F = np.concatenate([np.einsum("mpba,mpkb->mpka", R, x_a),               # R^T x_,a
                        np.einsum("mpab,mpkb->mpka", so3.tangent_many(d), d_a)], axis=2)  # T d_,a
    e_ref = covariant_strains_many(F)

    G = x_a[:, GAUSS_OFFSET:]                                               # (m, 7, 2, 3) = (G_r, G_s)
    normal = np.cross(G[..., 0, :], G[..., 1, :])
    area = np.linalg.norm(normal, axis=-1)
    n = normal / area[..., None]
    t1 = G[..., 0, :] / np.linalg.norm(G[..., 0, :], axis=-1)[..., None]
    t2 = np.cross(n, t1)
    J = np.stack([np.einsum("...ka,...a->...k", G, t1), np.einsum("...ka,...a->...k", G, t2)], axis=-1)
    P = np.linalg.inv(J)                                                    # (m, 7, 2, 2)
    p00, p01, p10, p11 = P[..., 0, 0], P[..., 0, 1], P[..., 1, 0], P[..., 1, 1]
    L = np.stack([np.stack([p00 * p00, p01 * p01, 2 * p00 * p01], -1),
                  np.stack([p10 * p10, p11 * p11, 2 * p10 * p11], -1),
                  np.stack([2 * p00 * p10, 2 * p01 * p11, 2 * (p00 * p11 + p01 * p10)], -1)], -2)
    to_cart = np.zeros((m, N_GAUSS, 8, 8))
    to_cart[..., :3, :3] = L
    to_cart[..., 3:6, 3:6] = L
    to_cart[..., 6:, 6:] = P
    return e_ref, to_cart, GAUSS_WEIGHTS * area
