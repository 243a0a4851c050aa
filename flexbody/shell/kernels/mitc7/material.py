"""The material stage of the MITC7 element: the strain gradient D = de/dF (its transpose applied to the stress
weights, and the B rows of one column) and the material stiffness sum_g B_g^T (w tc^T C tc) B_g in relative
coordinates z."""

from __future__ import annotations

from flexbody import _numba
from flexbody.shell.geometry import N_GAUSS
from flexbody.shell.kernels.mitc7.points import NAUG

fast = _numba.fast


@fast
def gradient_T_s(F, s, g):
    """g = D^T s (12,), D = de/dF (kinematics.strain_gradient), written out."""
    fru, fsu, frw, fsw = F[0], F[1], F[2], F[3]
    s0, s1, s2, s3, s4, s5, s6, s7 = s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7]
    h2, h5 = 0.5 * s2, 0.5 * s5
    g[0] = s0 * fru[0] + h2 * fsu[0] + s3 * frw[1] + h5 * fsw[1]
    g[1] = s0 * fru[1] + h2 * fsu[1] - s3 * frw[0] - h5 * fsw[0]
    g[2] = s0 * fru[2] + h2 * fsu[2] + s6
    g[3] = s1 * fsu[0] + h2 * fru[0] + s4 * fsw[1] + h5 * frw[1]
    g[4] = s1 * fsu[1] + h2 * fru[1] - s4 * fsw[0] - h5 * frw[0]
    g[5] = s1 * fsu[2] + h2 * fru[2] + s7
    g[6] = -s3 * fru[1] - h5 * fsu[1]
    g[7] = s3 * fru[0] + h5 * fsu[0]
    g[8] = 0.0
    g[9] = -s4 * fsu[1] - h5 * fru[1]
    g[10] = s4 * fsu[0] + h5 * fru[0]
    g[11] = 0.0


@fast
def gradient_col(F, G, c, B):
    """B[:, c] = D G[:, c] (the 8 strain rows of column c)."""
    fru, fsu, frw, fsw = F[0], F[1], F[2], F[3]
    r0, r1, r2 = G[0, c], G[1, c], G[2, c]
    q0, q1, q2 = G[3, c], G[4, c], G[5, c]
    w0, w1 = G[6, c], G[7, c]
    v0, v1 = G[9, c], G[10, c]
    B[0, c] = fru[0] * r0 + fru[1] * r1 + fru[2] * r2
    B[1, c] = fsu[0] * q0 + fsu[1] * q1 + fsu[2] * q2
    B[2, c] = 0.5 * ((fsu[0] * r0 + fsu[1] * r1 + fsu[2] * r2) + (fru[0] * q0 + fru[1] * q1 + fru[2] * q2))
    B[3, c] = frw[1] * r0 - frw[0] * r1 - fru[1] * w0 + fru[0] * w1
    B[4, c] = fsw[1] * q0 - fsw[0] * q1 - fsu[1] * v0 + fsu[0] * v1
    B[5, c] = 0.5 * ((fsw[1] * r0 - fsw[0] * r1 - fru[1] * v0 + fru[0] * v1)
                     + (frw[1] * q0 - frw[0] * q1 - fsu[1] * w0 + fsu[0] * w1))
    B[6, c] = r2
    B[7, c] = q2



@fast
def material_z(e, to_cart, weights, C, c_sym, a_ptr, a_i, a_p, a_j, a_v, PBz, Cg, Bg, Bc, CB, Sz, Kz):
    """Kz += sum_g B_g^T (w tc^T C tc) B_g, B_g the assumed covariant strain rows (8, 38) in z."""
    for gg in range(N_GAUSS):
        tc = to_cart[e, gg]
        w = weights[e, gg]
        for i in range(8):
            for j in range(8):
                acc = 0.0
                for k in range(8):
                    acc += C[i, k] * tc[k, j]
                Bg[i, j] = acc                       # C tc (8 x 8, in the first 8 columns of Bg)
        for i in range(8):
            for j in range(8):
                acc = 0.0
                for k in range(8):
                    acc += tc[k, i] * Bg[k, j]
                Cg[i, j] = w * acc
        for i in range(8):
            for c in range(NAUG):
                Bc[i, c] = 0.0
        for q in range(a_ptr[gg], a_ptr[gg + 1]):
            i, pp, j, v = a_i[q], a_p[q], a_j[q], a_v[q]
            for c in range(NAUG):
                Bc[i, c] += v * PBz[pp, j, c]
        for i in range(8):
            for c in range(NAUG):
                CB[i, c] = 0.0
            for j in range(8):
                cij = Cg[i, j]
                if cij != 0.0:                       # (block-diagonal sections: most are zero)
                    for c in range(NAUG):
                        CB[i, c] += cij * Bc[j, c]
        if c_sym:
            for i in range(8):
                for r in range(NAUG):
                    bir = Bc[i, r]
                    for c in range(r, NAUG):
                        Sz[r, c] += bir * CB[i, c]
        else:
            for i in range(8):
                for r in range(NAUG):
                    bir = Bc[i, r]
                    for c in range(NAUG):
                        Kz[r, c] += bir * CB[i, c]
    if c_sym:
        for r in range(NAUG):
            Kz[r, r] += Sz[r, r]
            for c in range(r + 1, NAUG):
                Kz[r, c] += Sz[r, c]
                Kz[c, r] += Sz[r, c]
