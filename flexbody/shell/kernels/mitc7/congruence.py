"""The congruence stage of the MITC7 element: the force and tangent in relative coordinates z to the nodal
motions h, f_h = P^T f_z and K_h = P^T K_z P plus the nodal terms of the derivative of P (paper Eq. 31:
dx_I = R_I du_I, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0; the bubble amplitudes are not mapped)."""

from __future__ import annotations

from flexbody import _numba
from flexbody.lie import kernels as lk
from flexbody.shell.kernels.mitc7.points import NAUG, NDOF

fast = _numba.fast
#: the force and nodal terms are inlined at numba-IR level into evaluate_z (as they were written there)
inline = _numba.inline


@fast
def congruence(Kz, KP, fr, Ti, Tm, Ka):
    """Ka = P^T Kz P: dx_I = R_I du_I, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0."""
    for r in range(NAUG):                            # KP = K_z P (rows z, cols h)
        for i in range(6):
            for l in range(3):
                KP[r, 6 * i + l] = (Kz[r, 3 * i] * fr[i, 0, l] + Kz[r, 3 * i + 1] * fr[i, 1, l]
                                    + Kz[r, 3 * i + 2] * fr[i, 2, l])
        for l in range(3):
            acc = Kz[r, 18 + l]
            for i in range(1, 6):
                z0 = 18 + 3 * i
                acc -= Kz[r, z0] * Tm[i, 0, l] + Kz[r, z0 + 1] * Tm[i, 1, l] + Kz[r, z0 + 2] * Tm[i, 2, l]
            KP[r, 3 + l] = acc
        for i in range(1, 6):
            z0 = 18 + 3 * i
            for l in range(3):
                KP[r, 6 * i + 3 + l] = (Kz[r, z0] * Ti[i, 0, l] + Kz[r, z0 + 1] * Ti[i, 1, l]
                                        + Kz[r, z0 + 2] * Ti[i, 2, l])
        KP[r, NDOF] = Kz[r, NDOF]
        KP[r, NDOF + 1] = Kz[r, NDOF + 1]
    for i in range(6):                               # Ka = P^T KP
        for l in range(3):
            for c in range(NAUG):
                Ka[6 * i + l, c] = (fr[i, 0, l] * KP[3 * i, c] + fr[i, 1, l] * KP[3 * i + 1, c]
                                    + fr[i, 2, l] * KP[3 * i + 2, c])
    for l in range(3):
        for c in range(NAUG):
            Ka[3 + l, c] = KP[18 + l, c]
    for i in range(1, 6):
        z0 = 18 + 3 * i
        for l in range(3):
            tm0, tm1, tm2 = Tm[i, 0, l], Tm[i, 1, l], Tm[i, 2, l]
            ti0, ti1, ti2 = Ti[i, 0, l], Ti[i, 1, l], Ti[i, 2, l]
            for c in range(NAUG):
                k0, k1, k2 = KP[z0, c], KP[z0 + 1, c], KP[z0 + 2, c]
                Ka[3 + l, c] -= tm0 * k0 + tm1 * k1 + tm2 * k2
                Ka[6 * i + 3 + l, c] = ti0 * k0 + ti1 * k1 + ti2 * k2
    for c in range(NAUG):
        Ka[NDOF, c] = KP[NDOF, c]
        Ka[NDOF + 1, c] = KP[NDOF + 1, c]


@inline
def force_to_nodes_into(fz, fr, Ti, Tm, fa):
    """fa = P^T fz: f_u = R_I^T f_x, f_theta_I = T^-1(d_I)^T f_dd, f_theta_0 = f_t0 - sum T^-1(-d_I)^T f_dd."""
    for i in range(6):
        for l in range(3):
            fa[6 * i + l] = fr[i, 0, l] * fz[3 * i] + fr[i, 1, l] * fz[3 * i + 1] + fr[i, 2, l] * fz[3 * i + 2]
    for l in range(3):
        acc = fz[18 + l]
        for i in range(1, 6):
            z0 = 18 + 3 * i
            acc -= Tm[i, 0, l] * fz[z0] + Tm[i, 1, l] * fz[z0 + 1] + Tm[i, 2, l] * fz[z0 + 2]
        fa[3 + l] = acc
    for i in range(1, 6):
        z0 = 18 + 3 * i
        for l in range(3):
            fa[6 * i + 3 + l] = Ti[i, 0, l] * fz[z0] + Ti[i, 1, l] * fz[z0 + 1] + Ti[i, 2, l] * fz[z0 + 2]
    fa[NDOF] = fz[NDOF]
    fa[NDOF + 1] = fz[NDOF + 1]


@inline
def nodal_terms_into(fa, fz, dn, Ti, Tm, E, M, Ka):
    """Ka += the nodal terms: hat(f_u,I) in (u_I, theta_I) (Delta R_I), and the D T^-1 terms of Delta delta d_I
    contracted with the z-force at dd_I. E (6, 3), M (3, 3): scratch."""
    for i in range(6):
        w0, w1, w2 = fa[6 * i], fa[6 * i + 1], fa[6 * i + 2]
        c0 = 6 * i + 3
        Ka[6 * i, c0 + 1] -= w2
        Ka[6 * i, c0 + 2] += w1
        Ka[6 * i + 1, c0] += w2
        Ka[6 * i + 1, c0 + 2] -= w0
        Ka[6 * i + 2, c0] -= w1
        Ka[6 * i + 2, c0 + 1] += w0
    for i in range(1, 6):
        z0 = 18 + 3 * i
        for k in range(3):
            E[i, k] = fz[z0 + k]
        for sign in range(2):
            if sign == 0:                            # rows theta_I: - D T^-1(-d_I)[.] E_I JdI
                lk.d_tangent_inv_into_fast((-dn[i, 0], -dn[i, 1], -dn[i, 2]), E[i], M)
                r0 = 6 * i + 3
            else:                                    # rows theta_0: - D T^-1(d_I)[.] E_I JdI
                lk.d_tangent_inv_into_fast(dn[i], E[i], M)
                r0 = 3
            for k in range(3):
                for l in range(3):
                    acc_i = 0.0
                    acc_0 = 0.0
                    for m in range(3):
                        acc_i += M[k, m] * Ti[i, m, l]
                        acc_0 += M[k, m] * Tm[i, m, l]
                    Ka[r0 + k, 6 * i + 3 + l] -= acc_i
                    Ka[r0 + k, 3 + l] += acc_0
