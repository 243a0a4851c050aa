"""The geometric stage of the MITC7 element: the contracted second variation of the strain measures at an
evaluation point, in its 18 slots xi (K_xi, 18 x 18), and restricted to the bubble's column (2 x 2).

K_xi = G^T Hf(s) G (the strain Hessian Hf(s) written out from its sparsity) plus the terms of
kinematics.second_variation: the variations of R^T (through dtheta_0 and dd), of T(d) and of T(d) d_,a.
"""

from __future__ import annotations

from flexbody import _numba
from flexbody.lie import kernels as lk

fast = _numba.fast
#: the point stiffness is inlined at numba-IR level into the element evaluations (as it was written there)
inline = _numba.inline


@fast
def cross_into(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@fast
def hessian_col(s, G, c, H):
    """H[:, c] = Hf(s) G[:, c], Hf (kinematics.strain_hessian) written out (rows 8 and 11 are zero)."""
    s0, s1, s2, s3, s4, s5 = s[0], s[1], s[2], s[3], s[4], s[5]
    h2, h5 = 0.5 * s2, 0.5 * s5
    r0, r1, r2 = G[0, c], G[1, c], G[2, c]
    q0, q1, q2 = G[3, c], G[4, c], G[5, c]
    w0, w1 = G[6, c], G[7, c]
    v0, v1 = G[9, c], G[10, c]
    # hat(e3) v = (-v1, v0, 0)
    H[0, c] = s0 * r0 + h2 * q0 + s3 * w1 + h5 * v1
    H[1, c] = s0 * r1 + h2 * q1 - s3 * w0 - h5 * v0
    H[2, c] = s0 * r2 + h2 * q2
    H[3, c] = s1 * q0 + h2 * r0 + s4 * v1 + h5 * w1
    H[4, c] = s1 * q1 + h2 * r1 - s4 * v0 - h5 * w0
    H[5, c] = s1 * q2 + h2 * r2
    H[6, c] = -s3 * r1 - h5 * q1
    H[7, c] = s3 * r0 + h5 * q0
    H[8, c] = 0.0
    H[9, c] = -s4 * q1 - h5 * r1
    H[10, c] = s4 * q0 + h5 * r0
    H[11, c] = 0.0




@inline
def point_stiffness_into(s, g, F, Q, T, R, d, da, co, Gx, Hx, au, bw, X, v3, w3, W, t33, csum, M, Z, Kx):
    """Kx (18, 18) = K_xi of a point: G^T Hf(s) G + the second variation, for the pulled-back stress weights
    s (8,), g = D^T s (12,), the point's F, Q, T, R, d, d_,a, SO(3) coefficients co and Jacobian Gx (12, 18).
    Hx, au, bw, X, v3, w3, W, t33, csum, M, Z: scratch."""
    for c in range(18):
        hessian_col(s, Gx, c, Hx)
    for r in range(18):                          # G^T Hf G (symmetric; rows 8, 11 of Hf G vanish)
        for c in range(r, 18):
            acc = 0.0
            for k in range(8):
                acc += Gx[k, r] * Hx[k, c]
            acc += Gx[9, r] * Hx[9, c] + Gx[10, r] * Hx[10, c]
            Kx[r, c] = acc
            Kx[c, r] = acc
    for k in range(3):
        au[0, k] = g[k]
        au[1, k] = g[3 + k]
        bw[0, k] = g[6 + k]
        bw[1, k] = g[9 + k]
    # W^T (sum_a hat(a_u) G_u,a), W = [0, 0, Q^T, T, 0, 0] (the rotation of R: w = W xi)
    for c in range(18):
        for k in range(3):
            v3[k] = Gx[k, c]
            w3[k] = Gx[3 + k, c]
        X[0, c] = (au[0, 1] * v3[2] - au[0, 2] * v3[1]) + (au[1, 1] * w3[2] - au[1, 2] * w3[1])
        X[1, c] = (au[0, 2] * v3[0] - au[0, 0] * v3[2]) + (au[1, 2] * w3[0] - au[1, 0] * w3[2])
        X[2, c] = (au[0, 0] * v3[1] - au[0, 1] * v3[0]) + (au[1, 0] * w3[1] - au[1, 1] * w3[0])
    for l in range(3):
        for c in range(18):
            Kx[6 + l, c] += Q[l, 0] * X[0, c] + Q[l, 1] * X[1, c] + Q[l, 2] * X[2, c]
            Kx[9 + l, c] += T[0, l] * X[0, c] + T[1, l] * X[1, c] + T[2, l] * X[2, c]
    # rows dx_,a: - R hat(a_a) W (Delta of R^T)
    for k in range(3):
        for l in range(3):
            W[k, l] = Q[l, k]
            W[k, 3 + l] = T[k, l]
    for a in range(2):
        for k in range(3):                       # t33 = R hat(a_a)
            r0, r1, r2 = R[k, 0], R[k, 1], R[k, 2]
            t33[k, 0] = r1 * au[a, 2] - r2 * au[a, 1]
            t33[k, 1] = r2 * au[a, 0] - r0 * au[a, 2]
            t33[k, 2] = r0 * au[a, 1] - r1 * au[a, 0]
        for k in range(3):
            for c in range(6):
                Kx[3 * a + k, 6 + c] -= t33[k, 0] * W[0, c] + t33[k, 1] * W[1, c] + t33[k, 2] * W[2, c]
    # c = sum_a a_u x f_u;  M = -D T(-d)[.] c + sum_a D^2 T(d)[.,.](b_w, d_,a)  (rows and cols dd)
    cross_into(au[0], F[0], v3)
    cross_into(au[1], F[1], w3)
    for k in range(3):
        csum[k] = v3[k] + w3[k]
    negd = (-d[0], -d[1], -d[2])
    lk.d_tangent_co_into(negd, csum, co, M)
    for k in range(3):
        for l in range(3):
            M[k, l] = -M[k, l]
    for a in range(2):
        lk.d2_tangent_co_into(d, bw[a], da[a], co, t33)
        for k in range(3):
            for l in range(3):
                M[k, l] += t33[k, l]
    for k in range(3):
        for l in range(3):
            Kx[9 + k, 9 + l] += M[k, l]
    # Jd^T Z^T Jda + Jda^T Z Jd,  Z = -D T(-d)[.] b_w
    for a in range(2):
        lk.d_tangent_co_into(negd, bw[a], co, Z)
        for k in range(3):
            for l in range(3):
                Kx[12 + 3 * a + k, 9 + l] -= Z[k, l]
                Kx[9 + l, 12 + 3 * a + k] -= Z[k, l]
    # - Q hat(c) T in the dtheta_0 rows, dd cols
    for k in range(3):
        t33[k, 0] = Q[k, 1] * csum[2] - Q[k, 2] * csum[1]
        t33[k, 1] = Q[k, 2] * csum[0] - Q[k, 0] * csum[2]
        t33[k, 2] = Q[k, 0] * csum[1] - Q[k, 1] * csum[0]
    for k in range(3):
        for l in range(3):
            Kx[6 + k, 9 + l] -= t33[k, 0] * T[0, l] + t33[k, 1] * T[1, l] + t33[k, 2] * T[2, l]


@inline
def bubble_point_stiffness_into(s, g, F, T, d, da, co, nb, nbr, nbs, G, HfG, au, bw, X, v3, w3, csum, M, Z, t33):
    """t33[:2, :2] = Pi_b^T K_xi Pi_b, the bubble's 2 x 2 block of a point's K_xi: N_b, dN_b,r, dN_b,s = nb,
    nbr, nbs, G (12, 2) = G_xi Pi_b, the other arguments as in :func:`point_stiffness_into`."""
    hessian_col(s, G, 0, HfG)
    hessian_col(s, G, 1, HfG)
    for q in range(2):
        for q2 in range(2):
            acc = 0.0
            for k in range(12):
                acc += G[k, q] * HfG[k, q2]
            t33[q, q2] = acc
    for k in range(3):
        au[0, k] = g[k]
        au[1, k] = g[3 + k]
        bw[0, k] = g[6 + k]
        bw[1, k] = g[9 + k]
    # rows dd (N_b T^T): T^T (sum_a hat(a_u) G_u,a)
    for q in range(2):
        for k in range(3):
            v3[k] = G[k, q]
            w3[k] = G[3 + k, q]
        X[0, q] = (au[0, 1] * v3[2] - au[0, 2] * v3[1]) + (au[1, 1] * w3[2] - au[1, 2] * w3[1])
        X[1, q] = (au[0, 2] * v3[0] - au[0, 0] * v3[2]) + (au[1, 2] * w3[0] - au[1, 0] * w3[2])
        X[2, q] = (au[0, 0] * v3[1] - au[0, 1] * v3[0]) + (au[1, 0] * w3[1] - au[1, 1] * w3[0])
    for q in range(2):
        for q2 in range(2):
            t33[q, q2] += nb * (T[0, q] * X[0, q2] + T[1, q] * X[1, q2] + T[2, q] * X[2, q2])
    cross_into(au[0], F[0], v3)
    cross_into(au[1], F[1], w3)
    for k in range(3):
        csum[k] = v3[k] + w3[k]
    negd = (-d[0], -d[1], -d[2])
    lk.d_tangent_co_into(negd, csum, co, M)
    for k in range(2):
        for l in range(2):
            M[k, l] = -M[k, l]
    for a in range(2):
        lk.d2_tangent_co_into(d, bw[a], da[a], co, Z)
        for k in range(2):
            for l in range(2):
                M[k, l] += Z[k, l]
    nn = nb * nb
    for k in range(2):
        for l in range(2):
            t33[k, l] += nn * M[k, l]
    for a in range(2):
        lk.d_tangent_co_into(negd, bw[a], co, Z)
        wa = nb * (nbr if a == 0 else nbs)
        for k in range(2):
            for l in range(2):
                t33[k, l] -= wa * (Z[k, l] + Z[l, k])
