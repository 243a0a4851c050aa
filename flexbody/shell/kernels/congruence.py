"""The element quantities in z to the nodal local frames (stage ``congruence``).

K_h = P^T K_z P + (D P^T[.]) f_z with z = P h, h = [u_I, theta_I] (paper Eq. 31): the force
(:func:`_force_to_local`), the tangent (:func:`_finish_tangent`: the mirror of the accumulation pattern, the
derivative of P that gives hat(f_u,I) in the (u_I, theta_I) block and the D T^-1 terms of Delta(delta d_I),
contracted with f_z at dd_I), and the terms of a section that couples local and nonlocal assumed-strain rows
(:func:`_has_cross_coupling`, :func:`_cross_terms`; rare).
"""

from __future__ import annotations

from flexbody._numba import fast as jit, uint as _u
from flexbody.lie import kernels as lk
from flexbody.shell.geometry import GAUSS_OFFSET, N_GAUSS
from flexbody.shell.kernels.expansion import _expand_vec
from flexbody.shell.kernels.layout import NZ, _ZR
from flexbody.shell.kernels.points import _GT_times, _add_strain_gradient_row, _load_point


@jit
def _force_to_local(e, fz, fr, Ti, f):
    """f[e] = P^T fz: f_u,I = R_I^T fz[x_I], f_th,I = T_I^T fz[d_I], f_th,0 = fz[th_0] - sum_I T_I fz[d_I]."""
    for i in range(6):
        for c in range(3):
            f[e, 6 * i + c] = fr[i, 0, c] * fz[0, i] + fr[i, 1, c] * fz[0, 8 + i] + fr[i, 2, c] * fz[0, 16 + i]
    for c in range(3):
        f[e, 3 + c] = fz[0, _ZR + 8 * c]
    for i in range(1, 6):
        e0 = fz[0, _ZR + i]
        e1 = fz[0, _ZR + 8 + i]
        e2 = fz[0, _ZR + 16 + i]
        for c in range(3):
            f[e, 6 * i + 3 + c] = Ti[i, 0, c] * e0 + Ti[i, 1, c] * e1 + Ti[i, 2, c] * e2
            f[e, 3 + c] -= Ti[i, c, 0] * e0 + Ti[i, c, 1] * e1 + Ti[i, c, 2] * e2


@jit
def _has_cross_coupling(Ch, loc_rows, n_loc, nl_rows, n_nl):
    """Does the section couple local and nonlocal rows at some Gauss point (not for a block-diagonal one)?"""
    for gg in range(N_GAUSS):
        for li in range(n_loc[gg]):
            for lj in range(n_nl[gg]):
                if Ch[gg, loc_rows[gg, li], nl_rows[gg, lj]] != 0.0:
                    return True
    return False


@jit
def _cross_terms(loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v, nl_rows, n_nl, m_ptr, m_i, m_k, m_v,
                 Ch, Sp, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, F, Q, T, R, X0, X1, d, da, co, s,
                 Dl, Bl, Bn, Y, Yt, W, Kz):
    """Kz += W + W^T, W = sum_g Pi_g^T Bl_g^T Ch_g[loc, nl] Bn_g, Bn_g = M_g S (a coupling section; rare).

    The array W receives W^T; the symmetric sum is the same."""
    for r in range(NZ):
        for c in range(NZ):
            W[r, c] = 0.0
    for gg in range(N_GAUSS):
        nl = n_loc[gg]
        nn = n_nl[gg]
        if nl == 0 or nn == 0:
            continue
        p = GAUSS_OFFSET + gg
        _load_point(p, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, F, Q, T, R, X0, X1, d, da, co, s)
        for li in range(nl):
            for c in range(12):
                Dl[li, c] = 0.0
        for q in range(loc_ptr[gg], loc_ptr[gg + 1]):
            _add_strain_gradient_row(F, loc_j[q], loc_v[q], Dl, loc_i[q])
        for li in range(nl):
            _GT_times(Dl, li, F, Q, T, R, X0, X1, Bl, li)
        for li in range(nn):
            for c in range(NZ):
                Bn[li, c] = 0.0
        for q in range(m_ptr[gg], m_ptr[gg + 1]):
            for c in range(NZ):
                Bn[m_i[q], c] += m_v[q] * Sp[m_k[q], c]
        # Y (18 x NZ) = Bl^T Ch[loc, nl] Bn
        for r in range(18):
            for c in range(NZ):
                Y[r, c] = 0.0
        for li in range(nl):
            for lj in range(nn):
                w = Ch[gg, loc_rows[gg, li], nl_rows[gg, lj]]
                if w != 0.0:
                    for r in range(18):
                        b = w * Bl[li, r]
                        for c in range(NZ):
                            Y[r, c] += b * Bn[lj, c]
        # W^T += (Pi_g^T Y)^T, row by row through Yt = Y^T
        for c in range(NZ):
            for r in range(18):
                Yt[c, r] = Y[r, c]
            _expand_vec(Yt, c, p, W, c)
    for r in range(NZ):
        c0 = 8 * (r // 8) if r < _ZR else _ZR
        for c in range(c0, NZ):
            Kz[r, c] += W[r, c] + W[c, r]


@jit
def _finish_tangent(e, Kz, Kiso, fr, Ti, f, fz, dn, ninv, K1, T0, K, Dp, Dm):
    """K[e] = P^T Kz P + (D P^T[.]) fz (Kz on the accumulation pattern: mirror the symmetric part first).

    f[e] and fz are the element force (local, and in z) whose stresses the geometric terms carry.

    Kiso (6 x 6) is the scalar translation-translation part accumulated separately (times I_3).
    """
    for c in range(3):
        for i in range(6):
            for j in range(6):
                Kz[8 * c + i, 8 * c + j] += Kiso[i, j]
    for c in range(2):
        for i in range(6):
            r = 8 * c + i
            for k in range(8 * (c + 1), _ZR):
                Kz[k, r] = Kz[r, k]
    for r in range(_ZR):
        for k in range(_ZR, NZ):
            Kz[k, r] = Kz[r, k]
    # K1 = Kz P  (z rows, h columns; padding rows are zero and skipped)
    for rc in range(6):
        for ri in range(6):
            r = 8 * rc + ri
            for i in range(6):
                k0 = Kz[r, i]
                k1 = Kz[r, 8 + i]
                k2 = Kz[r, 16 + i]
                for c in range(3):
                    K1[r, 6 * i + c] = k0 * fr[i, 0, c] + k1 * fr[i, 1, c] + k2 * fr[i, 2, c]
            t0 = Kz[r, _ZR]
            t1 = Kz[r, _ZR + 8]
            t2 = Kz[r, _ZR + 16]
            for i in range(1, 6):
                k0 = Kz[r, _ZR + i]
                k1 = Kz[r, _ZR + 8 + i]
                k2 = Kz[r, _ZR + 16 + i]
                for c in range(3):
                    K1[r, 6 * i + 3 + c] = k0 * Ti[i, 0, c] + k1 * Ti[i, 1, c] + k2 * Ti[i, 2, c]
                # - Kz[r, d_i] T_i^T
                t0 -= k0 * Ti[i, 0, 0] + k1 * Ti[i, 0, 1] + k2 * Ti[i, 0, 2]
                t1 -= k0 * Ti[i, 1, 0] + k1 * Ti[i, 1, 1] + k2 * Ti[i, 1, 2]
                t2 -= k0 * Ti[i, 2, 0] + k1 * Ti[i, 2, 1] + k2 * Ti[i, 2, 2]
            K1[r, 3] = t0
            K1[r, 4] = t1
            K1[r, 5] = t2
    # K[e] = P^T K1 (per node: three output rows from three source rows in one loop; theta_0 rows via T0)
    n36 = _u(K.shape[2])
    for i in range(6):
        r00 = fr[i, 0, 0]
        r01 = fr[i, 0, 1]
        r02 = fr[i, 0, 2]
        r10 = fr[i, 1, 0]
        r11 = fr[i, 1, 1]
        r12 = fr[i, 1, 2]
        r20 = fr[i, 2, 0]
        r21 = fr[i, 2, 1]
        r22 = fr[i, 2, 2]
        o = 6 * i
        for k in range(_u(0), n36):
            a = K1[i, k]
            b = K1[8 + i, k]
            t = K1[16 + i, k]
            K[e, o, k] = r00 * a + r10 * b + r20 * t
            K[e, o + 1, k] = r01 * a + r11 * b + r21 * t
            K[e, o + 2, k] = r02 * a + r12 * b + r22 * t
    for k in range(_u(0), n36):
        T0[0, k] = K1[_ZR, k]
        T0[1, k] = K1[_ZR + 8, k]
        T0[2, k] = K1[_ZR + 16, k]
    for i in range(1, 6):
        t00 = Ti[i, 0, 0]
        t01 = Ti[i, 0, 1]
        t02 = Ti[i, 0, 2]
        t10 = Ti[i, 1, 0]
        t11 = Ti[i, 1, 1]
        t12 = Ti[i, 1, 2]
        t20 = Ti[i, 2, 0]
        t21 = Ti[i, 2, 1]
        t22 = Ti[i, 2, 2]
        o = 6 * i + 3
        for k in range(_u(0), n36):
            a = K1[_ZR + i, k]
            b = K1[_ZR + 8 + i, k]
            t = K1[_ZR + 16 + i, k]
            K[e, o, k] = t00 * a + t10 * b + t20 * t       # T_i^T
            K[e, o + 1, k] = t01 * a + t11 * b + t21 * t
            K[e, o + 2, k] = t02 * a + t12 * b + t22 * t
        for k in range(_u(0), n36):
            a = K1[_ZR + i, k]
            b = K1[_ZR + 8 + i, k]
            t = K1[_ZR + 16 + i, k]
            T0[0, k] -= t00 * a + t01 * b + t02 * t         # - T_i
            T0[1, k] -= t10 * a + t11 * b + t12 * t
            T0[2, k] -= t20 * a + t21 * b + t22 * t
    for r in range(3):
        for k in range(_u(0), n36):
            K[e, 3 + r, k] = T0[r, k]
    # node terms: hat(f_u,I) in (u_I, theta_I) and the D T^-1 terms of Delta(delta d_I)
    for i in range(6):
        u0 = f[e, 6 * i]
        u1 = f[e, 6 * i + 1]
        u2 = f[e, 6 * i + 2]
        r = 6 * i
        c = 6 * i + 3
        K[e, r, c + 1] -= u2
        K[e, r, c + 2] += u1
        K[e, r + 1, c] += u2
        K[e, r + 1, c + 2] -= u0
        K[e, r + 2, c] -= u1
        K[e, r + 2, c + 1] += u0
    for i in range(1, 6):
        e0 = fz[0, _ZR + i]
        e1 = fz[0, _ZR + 8 + i]
        e2 = fz[0, _ZR + 16 + i]
        lk.d_tangent_inv_co_into((dn[i, 0], dn[i, 1], dn[i, 2]), (e0, e1, e2), ninv[i, 0], ninv[i, 1], Dp)
        # D T^-1(-d)[.] e = -hat(e) - D T^-1(d)[.] e
        for r in range(3):
            for c in range(3):
                Dm[r, c] = -Dp[r, c]
        Dm[0, 1] += e2
        Dm[0, 2] -= e1
        Dm[1, 0] -= e2
        Dm[1, 2] += e0
        Dm[2, 0] += e1
        Dm[2, 1] -= e0
        t = 6 * i + 3
        for r in range(3):
            for c in range(3):
                mT = Dm[r, 0] * Ti[i, 0, c] + Dm[r, 1] * Ti[i, 1, c] + Dm[r, 2] * Ti[i, 2, c]    # Dm T_i
                mTt = Dm[r, 0] * Ti[i, c, 0] + Dm[r, 1] * Ti[i, c, 1] + Dm[r, 2] * Ti[i, c, 2]   # Dm T_i^T
                pT = Dp[r, 0] * Ti[i, 0, c] + Dp[r, 1] * Ti[i, 1, c] + Dp[r, 2] * Ti[i, 2, c]
                pTt = Dp[r, 0] * Ti[i, c, 0] + Dp[r, 1] * Ti[i, c, 1] + Dp[r, 2] * Ti[i, c, 2]
                K[e, t + r, t + c] -= mT
                K[e, t + r, 3 + c] += mTt
                K[e, 3 + r, t + c] -= pT
                K[e, 3 + r, 3 + c] += pTt
