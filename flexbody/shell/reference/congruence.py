"""The terms that come from the nodal local frames: the element's rows and columns are the local nodal
motions, not the relative coordinates of the interpolation (readable numpy twin of
:mod:`flexbody.shell.kernels.congruence`).

Virtual and incremental nodal motions are local (paper Eqs. 4-5),

    delta x_I = R_I delta u_I,      delta R_I = R_I hat(delta theta_I),

ordered per node as [u (3), theta (3)]: 36 components h per element. The interpolation works with the
relative rotation vectors d_I = log(R_0^T R_I) (paper Eq. 30), whose variations are (paper Eq. 31)

    delta d_I = T^-1(d_I) delta theta_I - T^-1(-d_I) delta theta_0.

This module holds that map, the rows of the nodal translations (R^T R_I blocks), and the two parts of the
second variation that exist only because the motions are local: the derivative of R_I in
delta x_I = R_I delta u_I (the hat(R_I^T M_I) block of paper Eq. 35) and the derivative of the map of
paper Eq. 31 itself (the D T^-1 terms).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from flexbody.lie import so3

if TYPE_CHECKING:
    from flexbody.shell.reference.points import PointKinematics


def relative_rotation_jacobians(d_nodes: np.ndarray, ndof: int) -> np.ndarray:
    """d(d_I)/dh, shape (6, 3, ndof): the variations of the relative rotations (paper Eq. 31).

    Parameters
    ----------
    d_nodes : (6, 3) relative rotation vectors d_I = log(R_0^T R_I) (paper Eq. 30), d_0 = 0
    ndof : number of columns (36, or 38 with the MITC7 bubble, whose columns stay zero here)

    Returns
    -------
    JdI : (6, 3, ndof), JdI[I] delta h = T^-1(d_I) delta theta_I - T^-1(-d_I) delta theta_0; JdI[0] = 0.
    """
    JdI = np.zeros((6, 3, ndof))
    for i in range(1, 6):
        JdI[i][:, 6 * i + 3:6 * i + 6] = so3.tangent_inv(d_nodes[i])
        JdI[i][:, 3:6] = -so3.tangent_inv(-d_nodes[i])
    return JdI


def add_translation_rows(G: np.ndarray, k: PointKinematics, a: int) -> None:
    """Add the nodal translations' part of delta f_au, R^T sum_I N_I,a R_I delta u_I (paper Eq. 32), to the
    rows 3a..3a+2 of the Jacobian G of the strain measures (in place)."""
    rows = slice(3 * a, 3 * a + 3)
    for i in range(6):
        G[rows, 6 * i:6 * i + 3] += k.dN[a, i] * (k.R.T @ k.frames[i])


def add_translation_frame_terms(H: np.ndarray, k: PointKinematics, a: int, a_u: np.ndarray) -> None:
    """Add the second variation of a_u . R^T sum_I N_I,a R_I delta u_I to H (in place; paper Eqs. 33, 35).

    Two terms: the increment of R^T (rows u_I, all columns) and of R_I in delta x_I = R_I delta u_I, the
    block hat(R_I^T R a_u) in (u_I, theta_I) that paper Eq. 35 calls M*.
    """
    for i in range(6):
        ui = slice(6 * i, 6 * i + 3)
        H[ui] -= k.dN[a, i] * (k.frames[i].T @ k.R @ so3.hat(a_u) @ k.Jth)
        H[ui, 6 * i + 3:6 * i + 6] += k.dN[a, i] * so3.hat(k.frames[i].T @ k.R @ a_u)


def add_relative_rotation_terms(H: np.ndarray, k: PointKinematics, g_d: np.ndarray, g_da: np.ndarray) -> None:
    """Add the increment of the map of paper Eq. 31 to H (in place):

        Delta delta d_I = DT^-1(d_I)[Delta d_I] delta theta_I + DT^-1(-d_I)[Delta d_I] delta theta_0,

    contracted with the weights of delta d_I, N_I g_d + N_I,a g_da (g_d (3,) the weight of delta d at the
    point, g_da (2, 3) those of delta d_,a).
    """
    for i in range(1, 6):
        e = k.N[i] * g_d + k.dN[:, i] @ g_da
        H[6 * i + 3:6 * i + 6] -= so3.d_tangent_inv(-k.d_nodes[i], e) @ k.JdI[i]
        H[3:6] -= so3.d_tangent_inv(k.d_nodes[i], e) @ k.JdI[i]
