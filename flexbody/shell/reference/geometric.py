"""The geometric stiffness at one point: the second variation of the strains contracted with the stress
resultants (readable numpy twin of :mod:`flexbody.shell.kernels.geometric`; paper Eqs. 22, 24, 33-34).

With the strain measures F (:mod:`flexbody.shell.reference.points`), their Jacobian G = dF/dh and the
gradient D = de/dF of the covariant strains, a point carrying covariant stress weights s contributes

    K_geo,p = G^T Hf(s) G + H(D^T s),

Hf(s) = sum_k s_k d^2 e_k / dF^2 (constant: the strains are quadratic in F) and H(g) the second variation
of the strain measures contracted with g. The paper's Eqs. 33-34 list these terms with several typos; they
are derived here term by term from the first variation (paper Eq. 32),

    delta theta(point) = exp(d)^T delta theta_0 + T(d) delta d
    delta f_au = hat(f_au) delta theta + R^T sum_I N_I,a R_I delta u_I
    delta f_aw = Xi(d, d_,a) delta d + T(d) delta d_,a,    Xi(d, b) v = DT(d)[v] b,

using b^T DT(d)[w] v = -v^T Xi(-d, b) w (from T(d)^T = T(-d)). The terms due to the local nodal motions
themselves are in :mod:`flexbody.shell.reference.congruence`.
"""

from __future__ import annotations

import numpy as np

from flexbody.lie import so3
from flexbody.shell.reference.congruence import add_relative_rotation_terms, add_translation_frame_terms
from flexbody.shell.reference.points import HAT_E3, PointKinematics, measures_jacobian, strain_gradient


def strain_hessian(s: np.ndarray) -> np.ndarray:
    """Hf(s) = sum_k s_k d^2 e_k / dF^2, shape (12, 12), of the covariant strains of paper Eq. 12."""
    Hf = np.zeros((12, 12))
    I3 = np.eye(3)
    ru, su, rw, sw = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
    Hf[ru, ru] += s[0] * I3
    Hf[su, su] += s[1] * I3
    Hf[ru, su] += 0.5 * s[2] * I3
    Hf[su, ru] += 0.5 * s[2] * I3
    Hf[ru, rw] += -s[3] * HAT_E3
    Hf[rw, ru] += s[3] * HAT_E3
    Hf[su, sw] += -s[4] * HAT_E3
    Hf[sw, su] += s[4] * HAT_E3
    Hf[ru, sw] += -0.5 * s[5] * HAT_E3
    Hf[sw, ru] += 0.5 * s[5] * HAT_E3
    Hf[su, rw] += -0.5 * s[5] * HAT_E3
    Hf[rw, su] += 0.5 * s[5] * HAT_E3
    return Hf


def add_stretch_terms(H: np.ndarray, k: PointKinematics, G_a: np.ndarray, a_u: np.ndarray,
                      f_u: np.ndarray) -> np.ndarray:
    """Add the increment of hat(f_au) delta theta, weighted by a_u, to H (in place; paper Eq. 33):

        delta theta^T hat(a_u) Delta f_au  +  (a_u x f_au) . Delta delta theta,

    the second through Delta(exp(d)^T) delta theta_0 and Delta(T(d)) delta d. G_a (3, ndof): the rows of
    f_au in G. Returns c = a_u x f_au, whose T(d) Delta delta d part the caller adds to the weight of
    delta d.
    """
    H += k.Jth.T @ so3.hat(a_u) @ G_a
    c = np.cross(a_u, f_u)
    H[3:6] -= k.Q @ so3.hat(c) @ k.T @ k.Jd               # Delta(exp(d)^T) delta theta_0
    H += k.Jd.T @ (-so3.d_tangent(-k.d, c)) @ k.Jd         # Delta(T(d)) delta d
    return c


def add_curvature_terms(H: np.ndarray, k: PointKinematics, a: int, b_w: np.ndarray) -> None:
    """Add the increment of Xi_T(d, d_,a) delta d + T(d) delta d_,a, weighted by b_w, to H (in place; paper
    Eq. 34): the second derivative of T along (delta d, Delta d) and the mixed terms in (d, d_,a)."""
    H += k.Jd.T @ so3.d2_tangent(k.d, b_w, k.d_a[a]) @ k.Jd
    Z = -so3.d_tangent(-k.d, b_w)                         # b^T DT(d)[w] v = v^T Z w
    H += k.Jd.T @ Z.T @ k.Jda[a] + k.Jda[a].T @ Z @ k.Jd


def second_variation(k: PointKinematics, g: np.ndarray) -> np.ndarray:
    """H with  Delta(delta F) . g = delta h^T H Delta h  for fixed local virtual motions (paper Eqs. 33-34).

    g = [a_r, a_s, b_r, b_s] (12,) weights the four strain measures. Rows of H are the virtual motion,
    columns the increment; H is not symmetric away from equilibrium (the tangent lives on the group).
    """
    H = np.zeros((k.Jd.shape[1], k.Jd.shape[1]))
    G = measures_jacobian(k)
    g_d = np.zeros(3)          # weight of Delta(delta d)
    g_da = np.zeros((2, 3))    # weight of Delta(delta d_,a)
    for a in range(2):
        a_u, b_w = g[3 * a:3 * a + 3], g[6 + 3 * a:9 + 3 * a]
        c = add_stretch_terms(H, k, G[3 * a:3 * a + 3], a_u, k.F[a])
        g_d += k.T.T @ c                                       # T(d) Delta delta d
        add_translation_frame_terms(H, k, a, a_u)
        add_curvature_terms(H, k, a, b_w)
        g_d += so3.d_tangent(k.d, k.d_a[a]).T @ b_w
        g_da[a] += k.T.T @ b_w
    add_relative_rotation_terms(H, k, g_d, g_da)
    return H


def point_geometric_stiffness(k: PointKinematics, s: np.ndarray) -> np.ndarray:
    """K_geo,p = G^T Hf(s) G + H(D^T s) (ndof, ndof) of one evaluation point with covariant stress weights
    s (8,) (paper Eq. 24)."""
    D = strain_gradient(k.F)
    G = measures_jacobian(k)
    return G.T @ strain_hessian(s) @ G + second_variation(k, D.T @ s)
