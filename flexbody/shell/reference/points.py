"""Strain measures of the SE(3) shell at one point of an element and their first variation (readable numpy
twin of :mod:`flexbody.shell.kernels.points`; paper Eqs. 9, 12, 17, 30-32).

Nodal state: positions x_I and frames R_I, I = 0..5. Virtual and incremental nodal motions are local
(paper Eqs. 4-5; :mod:`flexbody.shell.reference.congruence`),

    delta x_I = R_I delta u_I,      delta R_I = R_I hat(delta theta_I),

ordered per node as [u (3), theta (3)], 36 components per element (the drilling component of theta is
removed later by the body). All derivatives are directional derivatives along these group motions, so the
tangent they build is the one a finite difference with R exp(eps e_i) measures.

Relative-rotation interpolation about the reference node r = 0 (paper Eq. 30):
    d_I = log(R_0^T R_I),   d = sum N_I d_I,   R = R_0 exp(hat d)
Strain measures in the parametric directions a in {r, s} (paper Eq. 9):
    f_au = R^T x_,a,        f_aw = axial(R^T R_,a) = T(d) d_,a
with T the right tangent operator of SO(3) (paper Eq. 10). Covariant strains (paper Eq. 12):
e = [e_rr, e_ss, e_rs | k_rr, k_ss, k_rs | g_r, g_s], membrane and bending as tensor components, transverse
shear as engineering components (g_a = 2 e_a3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexbody.lie import so3
from flexbody.shell.reference.congruence import add_translation_rows, relative_rotation_jacobians

NDOF = 36  # 6 nodes x [u, theta]
E3 = np.array([0.0, 0.0, 1.0])
HAT_E3 = so3.hat(E3)


def relative_rotations(frames: np.ndarray) -> np.ndarray:
    """d_I = log(R_0^T R_I) for the six nodes (paper Eq. 30); d_0 = 0.

    Parameters
    ----------
    frames : (6, 3, 3) nodal frames R_I

    Returns
    -------
    d : (6, 3)
    """
    d = np.zeros((6, 3))
    for i in range(1, 6):
        d[i] = so3.log(frames[0].T @ frames[i])
    return d


@dataclass
class PointKinematics:
    """Everything the variations at one point need. F = [f_ru, f_su, f_rw, f_sw], shape (4, 3)."""

    N: np.ndarray          # (6,) shape functions
    dN: np.ndarray         # (2, 6) derivatives in r, s
    frames: np.ndarray     # (6, 3, 3) nodal frames R_I
    d_nodes: np.ndarray    # (6, 3) relative rotation vectors d_I
    d: np.ndarray          # (3,) interpolated relative rotation
    d_a: np.ndarray        # (2, 3) its derivatives
    Q: np.ndarray          # exp(d)
    T: np.ndarray          # T(d)
    R: np.ndarray          # R_0 exp(d): the interpolated frame
    F: np.ndarray          # (4, 3) strain measures
    Jd: np.ndarray         # (3, 36) d(d)/d(h)
    Jda: np.ndarray        # (2, 3, 36) d(d_,a)/d(h)
    Jth: np.ndarray        # (3, 36) variation of the point rotation: R^T delta R = hat(Jth delta h)
    JdI: np.ndarray        # (6, 3, 36) d(d_I)/d(h)


def point_kinematics(x: np.ndarray, frames: np.ndarray, d_nodes: np.ndarray,
                     N: np.ndarray, dN: np.ndarray, bubble: tuple | None = None) -> PointKinematics:
    """Strain measures f (paper Eq. 9) and the Jacobians of the interpolated quantities (paper Eqs. 30-31).

    Parameters
    ----------
    x : (6, 3) nodal positions; frames : (6, 3, 3) nodal frames R_I
    d_nodes : (6, 3) relative rotations (:func:`relative_rotations`)
    N, dN : (6,) shape functions and (2, 6) their derivatives at the point
    bubble : optional (N_b, dN_b, b) of the rotation bubble (MITC7, :mod:`flexbody.shell.reference.bubble`):
        the interpolated relative rotation gains N_b (b_1, b_2, 0), b an internal element unknown in the
        frame of the reference node; the Jacobians then have 38 columns, the last two for b.

    The variation of the point rotation is delta theta = exp(d)^T delta theta_0 + T(d) delta d (``Jth``).
    """
    d = N @ d_nodes
    d_a = dN @ d_nodes
    ndof = NDOF
    if bubble is not None:
        nb, dnb, b = bubble
        bvec = np.array([b[0], b[1], 0.0])
        d = d + nb * bvec
        d_a = d_a + np.outer(dnb, bvec)
        ndof = NDOF + 2
    Q = so3.exp(d)
    T = so3.tangent(d)
    R = frames[0] @ Q
    x_a = dN @ x
    F = np.array([R.T @ x_a[0], R.T @ x_a[1], T @ d_a[0], T @ d_a[1]])

    JdI = relative_rotation_jacobians(d_nodes, ndof)
    Jd = np.einsum("i,ijk->jk", N, JdI)
    Jda = np.einsum("ai,ijk->ajk", dN, JdI)
    if bubble is not None:                                     # d is linear in b
        Jd[:2, NDOF:] += nb * np.eye(2)
        Jda[:, :2, NDOF:] += dnb[:, None, None] * np.eye(2)
    Jth = T @ Jd
    Jth[:, 3:6] += Q.T
    return PointKinematics(N, dN, frames, d_nodes, d, d_a, Q, T, R, F, Jd, Jda, Jth, JdI)


def measures_jacobian(k: PointKinematics) -> np.ndarray:
    """G = dF/dh, shape (12, ndof), rows [f_ru, f_su, f_rw, f_sw] (paper Eqs. 17, 32):

        delta f_au = hat(f_au) delta theta + R^T sum_I N_I,a R_I delta u_I
        delta f_aw = Xi_T(d, d_,a) delta d + T(d) delta d_,a
    """
    G = np.zeros((12, k.Jd.shape[1]))
    for a in range(2):
        f_u = k.F[a]
        rows = slice(3 * a, 3 * a + 3)
        G[rows] = so3.hat(f_u) @ k.Jth
        add_translation_rows(G, k, a)
        G[6 + 3 * a:9 + 3 * a] = so3.d_tangent(k.d, k.d_a[a]) @ k.Jd + k.T @ k.Jda[a]
    return G


def covariant_strains(F: np.ndarray) -> np.ndarray:
    """Raw covariant strain measures (8,) of F (4, 3) (paper Eq. 12; the caller subtracts the reference
    values, paper Eq. 8)."""
    fru, fsu, frw, fsw = F
    return np.array([
        0.5 * fru @ fru, 0.5 * fsu @ fsu, 0.5 * fru @ fsu,
        -fru @ HAT_E3 @ frw, -fsu @ HAT_E3 @ fsw, -0.5 * (fru @ HAT_E3 @ fsw + fsu @ HAT_E3 @ frw),
        fru[2], fsu[2],
    ])


def covariant_strains_many(F: np.ndarray) -> np.ndarray:
    """:func:`covariant_strains` of many points at once: F (..., 4, 3) -> (..., 8)."""
    fru, fsu, frw, fsw = (F[..., k, :] for k in range(4))
    dot = lambda a, b: np.einsum("...a,...a->...", a, b)
    bend = lambda a, b: dot(a, b @ HAT_E3.T)              # a . (HAT_E3 b)
    return np.stack([0.5 * dot(fru, fru), 0.5 * dot(fsu, fsu), 0.5 * dot(fru, fsu),
                     -bend(fru, frw), -bend(fsu, fsw), -0.5 * (bend(fru, fsw) + bend(fsu, frw)),
                     fru[..., 2], fsu[..., 2]], axis=-1)


def strain_gradient(F: np.ndarray) -> np.ndarray:
    """D = de/dF, shape (8, 12), of the covariant strains of paper Eq. 12 (the rows of paper Eqs. 19-21
    before the Jacobian G)."""
    fru, fsu, frw, fsw = F
    D = np.zeros((8, 12))
    ru, su, rw, sw = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
    D[0, ru] = fru
    D[1, su] = fsu
    D[2, ru], D[2, su] = 0.5 * fsu, 0.5 * fru
    D[3, ru], D[3, rw] = -HAT_E3 @ frw, HAT_E3 @ fru
    D[4, su], D[4, sw] = -HAT_E3 @ fsw, HAT_E3 @ fsu
    D[5, ru], D[5, sw] = -0.5 * HAT_E3 @ fsw, 0.5 * HAT_E3 @ fru
    D[5, su], D[5, rw] = -0.5 * HAT_E3 @ frw, 0.5 * HAT_E3 @ fsu
    D[6, 2] = 1.0
    D[7, 5] = 1.0
    return D


def evaluation_point_kinematics(x: np.ndarray, frames: np.ndarray, eval_n: np.ndarray, eval_dn: np.ndarray,
                                bubble: tuple | None = None) -> list[PointKinematics]:
    """:func:`point_kinematics` at every evaluation point of an element (paper Eqs. 9, 30).

    Parameters
    ----------
    x, frames : nodal positions (6, 3) and frames (6, 3, 3)
    eval_n, eval_dn : (P, 6) shape functions and (P, 2, 6) their derivatives at the P evaluation points
        (``flexbody.shell.geometry.EVAL_N``, ``EVAL_DN``)
    bubble : None, or (eval_nb (P,), eval_dnb (P, 2), b (2,)): the MITC7 rotation bubble at the points
    """
    d_nodes = relative_rotations(frames)
    return [point_kinematics(x, frames, d_nodes, N, dN,
                             None if bubble is None else (bubble[0][p], bubble[1][p], bubble[2]))
            for p, (N, dN) in enumerate(zip(eval_n, eval_dn))]
