"""Kinematics at the evaluation points of the six-node shell kernel (stage ``points``).

Per element: the nodal data (:func:`_load_element`), the relative rotation vectors d_I of the nodes and their
inverse tangent maps (:func:`_node_setup`), the interpolated d, d_,a at the used points
(:func:`_interpolate_points`) and the SO(3) coefficients of each point computed once
(:func:`_point_coefficients`; :mod:`flexbody.lie.kernels`: closed forms above the series switch, the Taylor
series fused below). Then the point kinematics Q, T(d), R, F = [f_ru, f_su, f_rw, f_sw], X_a
(:func:`_kinematics_points`), the covariant strains (:func:`_strains_points`) and their linearization along a
nodal motion (:func:`_strain_increments_points`), the strain gradient D = de/dF applied to stress weights
(:func:`_strain_gradient_T`, :func:`_add_strain_gradient_row`), the point Jacobian in the slots xi
(:func:`_GT_times`) and the force of the points (:func:`_force_points`).
"""

from __future__ import annotations

import math

from flexbody._numba import fast as jit, inline as inl, uint as _u
from flexbody.lie import kernels as lk
from flexbody.shell.kernels.expansion import _expand_vec
from flexbody.shell.kernels.layout import NZ, _EDN, _EN


@jit
def _point_coefficients(used, Pd, Pco):
    """Pco[p] = (a1, a2, a3, a4, c2, c3, c4, e2, e3) at |d_p| for the used points (a4, c4 unused)."""
    for k in range(used.shape[0]):
        p = _u(used[k])
        n = math.sqrt(Pd[p, 0] * Pd[p, 0] + Pd[p, 1] * Pd[p, 1] + Pd[p, 2] * Pd[p, 2])
        lk.point_coefficients_into(n, Pco[p])


@jit
def _node_setup(fr, dn, Ti, ninv, M):
    """d_I = log(R_0^T R_I), Ti[I] = T^-1(d_I) (so T^-1(-d_I) = Ti[I]^T), ninv[I] = (a4, c4) of |d_I|."""
    for c in range(3):
        dn[0, c] = 0.0
        for k in range(3):
            Ti[0, c, k] = 1.0 if c == k else 0.0
    ninv[0, 0] = 0.0
    ninv[0, 1] = 0.0
    for i in range(1, 6):
        for r in range(3):
            for c in range(3):
                M[r, c] = fr[0, 0, r] * fr[i, 0, c] + fr[0, 1, r] * fr[i, 1, c] + fr[0, 2, r] * fr[i, 2, c]
        lk.log_into_fast(M, dn[i])
        d0 = dn[i, 0]
        d1 = dn[i, 1]
        d2 = dn[i, 2]
        pp = d0 * d0 + d1 * d1 + d2 * d2
        a4, c4 = lk.inverse_coefficients(math.sqrt(pp))
        ninv[i, 0] = a4
        ninv[i, 1] = c4
        lk.tangent_inv_co_into((d0, d1, d2), a4, Ti[i])


@jit
def _load_element(e, x_el, fr_el, x, fr):
    for i in range(6):
        for r in range(3):
            x[i, r] = x_el[e, i, r]
            for c in range(3):
                fr[i, r, c] = fr_el[e, i, r, c]


@jit
def _interpolate_points(used, dn, Pd, Pda):
    """d = sum N_I d_I and d_,a at the used points."""
    for k in range(used.shape[0]):
        p = _u(used[k])
        for c in range(3):
            s = 0.0
            s0 = 0.0
            s1 = 0.0
            for i in range(1, 6):
                s += _EN[p, i] * dn[i, c]
                s0 += _EDN[p, 0, i] * dn[i, c]
                s1 += _EDN[p, 1, i] * dn[i, c]
            Pd[p, c] = s
            Pda[p, 0, c] = s0
            Pda[p, 1, c] = s1


@inl
def _frame_kinematics(p, x, fr, Pd, Pco, PQ, PT, PR, PF):
    """Q = exp(d), T(d), R = R_0 Q and f_au = R^T x_,a (rows 0, 1 of F) at point p."""
    d0 = Pd[p, 0]
    d1 = Pd[p, 1]
    d2 = Pd[p, 2]
    co = Pco[p]
    Q = PQ[p]
    T = PT[p]
    R = PR[p]
    lk.exp_co_into((d0, d1, d2), co, Q)
    lk.tangent_co_into((d0, d1, d2), co, T)
    for r in range(3):
        for c in range(3):
            R[r, c] = fr[0, r, 0] * Q[0, c] + fr[0, r, 1] * Q[1, c] + fr[0, r, 2] * Q[2, c]
    for a in range(2):
        xa0 = 0.0
        xa1 = 0.0
        xa2 = 0.0
        for i in range(6):
            w = _EDN[p, a, i]
            xa0 += w * x[i, 0]
            xa1 += w * x[i, 1]
            xa2 += w * x[i, 2]
        for c in range(3):
            PF[p, a, c] = R[0, c] * xa0 + R[1, c] * xa1 + R[2, c] * xa2


@inl
def _bending_kinematics(p, Pd, Pda, Pco, PT, PF, PX):
    """f_aw = T d_,a (rows 2, 3 of F) and X_a = DT(d)[.] d_,a at point p."""
    T = PT[p]
    for a in range(2):
        for c in range(3):
            PF[p, 2 + a, c] = T[c, 0] * Pda[p, a, 0] + T[c, 1] * Pda[p, a, 1] + T[c, 2] * Pda[p, a, 2]
    d = (Pd[p, 0], Pd[p, 1], Pd[p, 2])
    lk.d_tangent_co_into(d, (Pda[p, 0, 0], Pda[p, 0, 1], Pda[p, 0, 2]), Pco[p], PX[p, 0])
    lk.d_tangent_co_into(d, (Pda[p, 1, 0], Pda[p, 1, 1], Pda[p, 1, 2]), Pco[p], PX[p, 1])


@jit
def _kinematics_points(used, at_ptr, all_points, x, fr, Pd, Pda, Pco, PQ, PT, PR, PF, PX):
    """Q = exp(d), T(d), R = R_0 Q, F = [f_ru, f_su, f_rw, f_sw], X_a = DT(d)[.] d_,a at the used points.

    With all_points False, f_aw and X_a only at the points whose bending strains some assumed strain reads
    (columns 8 p + 3 .. 8 p + 5 of A, by at_ptr: the Gauss points of MITC6), zero elsewhere: enough for the
    force and the assumed strains, which read them only through these bending strains and their weights (the
    other points' bending weights Ps[p, 3:6] are zero). The tangent and the strain increments take all points.
    (A run-time flag: one compiled version serves every caller; a literal would compile a second one.)
    """
    for k in range(used.shape[0]):
        p = _u(used[k])
        _frame_kinematics(p, x, fr, Pd, Pco, PQ, PT, PR, PF)
        if all_points or at_ptr[8 * p + 6] > at_ptr[8 * p + 3]:
            _bending_kinematics(p, Pd, Pda, Pco, PT, PF, PX)
            continue
        for a in range(2):
            for c in range(3):
                PF[p, 2 + a, c] = 0.0
                for j in range(3):
                    PX[p, a, c, j] = 0.0


@jit
def _strains_points(e, used, e_ref, PF, Pe):
    """Pe[p] = covariant_strains(F_p) - e_ref[e, p] (kinematics.covariant_strains)."""
    for k in range(used.shape[0]):
        p = _u(used[k])
        F = PF[p]
        # a . hat(e3) b = a1 b0 - a0 b1
        Pe[p, 0] = 0.5 * (F[0, 0] * F[0, 0] + F[0, 1] * F[0, 1] + F[0, 2] * F[0, 2]) - e_ref[e, p, 0]
        Pe[p, 1] = 0.5 * (F[1, 0] * F[1, 0] + F[1, 1] * F[1, 1] + F[1, 2] * F[1, 2]) - e_ref[e, p, 1]
        Pe[p, 2] = 0.5 * (F[0, 0] * F[1, 0] + F[0, 1] * F[1, 1] + F[0, 2] * F[1, 2]) - e_ref[e, p, 2]
        Pe[p, 3] = -(F[0, 1] * F[2, 0] - F[0, 0] * F[2, 1]) - e_ref[e, p, 3]
        Pe[p, 4] = -(F[1, 1] * F[3, 0] - F[1, 0] * F[3, 1]) - e_ref[e, p, 4]
        Pe[p, 5] = -0.5 * ((F[0, 1] * F[3, 0] - F[0, 0] * F[3, 1])
                           + (F[1, 1] * F[2, 0] - F[1, 0] * F[2, 1])) - e_ref[e, p, 5]
        Pe[p, 6] = F[0, 2] - e_ref[e, p, 6]
        Pe[p, 7] = F[1, 2] - e_ref[e, p, 7]


@jit
def _strain_increments_points(e, used, fr, Ti, dh, PF, PQ, PT, PR, PX, dX, dD, dPe):
    """dPe[p] = D(F_p) G_p dh[e]: the covariant strains at the used points linearized along the local nodal
    motion dh[e] = [du_I, dtheta_I] (kinematics.measures_jacobian, strain_gradient):
        delta f_au = f_au x omega + R^T sum dN_I R_I du_I,  omega = T(d) delta d + Q^T dtheta_0,
        delta f_aw = DT(d)[delta d] d_,a + T(d) delta d_,a,  delta d_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0.
    """
    for i in range(6):
        for c in range(3):
            dX[i, c] = fr[i, c, 0] * dh[e, 6 * i] + fr[i, c, 1] * dh[e, 6 * i + 1] + fr[i, c, 2] * dh[e, 6 * i + 2]
            dD[i, c] = 0.0
    for i in range(1, 6):
        for c in range(3):
            acc = 0.0
            for k in range(3):
                acc += Ti[i, c, k] * dh[e, 6 * i + 3 + k] - Ti[i, k, c] * dh[e, 3 + k]
            dD[i, c] = acc
    for k in range(used.shape[0]):
        p = _u(used[k])
        F = PF[p]
        Q = PQ[p]
        T = PT[p]
        R = PR[p]
        dd0 = 0.0
        dd1 = 0.0
        dd2 = 0.0
        for i in range(1, 6):
            dd0 += _EN[p, i] * dD[i, 0]
            dd1 += _EN[p, i] * dD[i, 1]
            dd2 += _EN[p, i] * dD[i, 2]
        om0 = T[0, 0] * dd0 + T[0, 1] * dd1 + T[0, 2] * dd2 + Q[0, 0] * dh[e, 3] + Q[1, 0] * dh[e, 4] + Q[2, 0] * dh[e, 5]
        om1 = T[1, 0] * dd0 + T[1, 1] * dd1 + T[1, 2] * dd2 + Q[0, 1] * dh[e, 3] + Q[1, 1] * dh[e, 4] + Q[2, 1] * dh[e, 5]
        om2 = T[2, 0] * dd0 + T[2, 1] * dd1 + T[2, 2] * dd2 + Q[0, 2] * dh[e, 3] + Q[1, 2] * dh[e, 4] + Q[2, 2] * dh[e, 5]
        for a in range(2):
            x0 = 0.0
            x1 = 0.0
            x2 = 0.0
            w0 = 0.0
            w1 = 0.0
            w2 = 0.0
            for i in range(6):
                wd = _EDN[p, a, i]
                x0 += wd * dX[i, 0]
                x1 += wd * dX[i, 1]
                x2 += wd * dX[i, 2]
                w0 += wd * dD[i, 0]
                w1 += wd * dD[i, 1]
                w2 += wd * dD[i, 2]
            fu0 = F[a, 0]
            fu1 = F[a, 1]
            fu2 = F[a, 2]
            # delta f_au (row a of dF), delta f_aw (row 2 + a), stored in the workspace dX rows 6 + a, 8 + a
            dX[6 + a, 0] = fu1 * om2 - fu2 * om1 + R[0, 0] * x0 + R[1, 0] * x1 + R[2, 0] * x2
            dX[6 + a, 1] = fu2 * om0 - fu0 * om2 + R[0, 1] * x0 + R[1, 1] * x1 + R[2, 1] * x2
            dX[6 + a, 2] = fu0 * om1 - fu1 * om0 + R[0, 2] * x0 + R[1, 2] * x1 + R[2, 2] * x2
            X = PX[p, a]
            for c in range(3):
                dX[8 + a, c] = (X[c, 0] * dd0 + X[c, 1] * dd1 + X[c, 2] * dd2
                                + T[c, 0] * w0 + T[c, 1] * w1 + T[c, 2] * w2)
        r = dX[6]
        sv = dX[7]
        rw = dX[8]
        sw = dX[9]
        # linearized covariant_strains (kinematics.covariant_strains): a . hat(e3) b = a1 b0 - a0 b1
        dPe[p, 0] = F[0, 0] * r[0] + F[0, 1] * r[1] + F[0, 2] * r[2]
        dPe[p, 1] = F[1, 0] * sv[0] + F[1, 1] * sv[1] + F[1, 2] * sv[2]
        dPe[p, 2] = 0.5 * (r[0] * F[1, 0] + r[1] * F[1, 1] + r[2] * F[1, 2]
                           + F[0, 0] * sv[0] + F[0, 1] * sv[1] + F[0, 2] * sv[2])
        dPe[p, 3] = -(r[1] * F[2, 0] + F[0, 1] * rw[0] - r[0] * F[2, 1] - F[0, 0] * rw[1])
        dPe[p, 4] = -(sv[1] * F[3, 0] + F[1, 1] * sw[0] - sv[0] * F[3, 1] - F[1, 0] * sw[1])
        dPe[p, 5] = -0.5 * ((r[1] * F[3, 0] + F[0, 1] * sw[0] - r[0] * F[3, 1] - F[0, 0] * sw[1])
                            + (sv[1] * F[2, 0] + F[1, 1] * rw[0] - sv[0] * F[2, 1] - F[1, 0] * rw[1]))
        dPe[p, 6] = r[2]
        dPe[p, 7] = sv[2]


@inl
def _strain_gradient_T(F, s, g):
    """g = D^T s (12): the weights [a_r, a_s, b_r, b_s] of the strain measures (kinematics.strain_gradient)."""
    h2 = 0.5 * s[2]
    h5 = 0.5 * s[5]
    # hat(e3) v = (-v1, v0, 0)
    for c in range(3):
        g[c] = s[0] * F[0, c] + h2 * F[1, c]
        g[3 + c] = s[1] * F[1, c] + h2 * F[0, c]
    # -s3 E f_rw - s5/2 E f_sw on a_r ; -s4 E f_sw - s5/2 E f_rw on a_s
    g[0] += s[3] * F[2, 1] + h5 * F[3, 1]
    g[1] -= s[3] * F[2, 0] + h5 * F[3, 0]
    g[3] += s[4] * F[3, 1] + h5 * F[2, 1]
    g[4] -= s[4] * F[3, 0] + h5 * F[2, 0]
    g[2] += s[6]
    g[5] += s[7]
    # b_r = s3 E f_ru + s5/2 E f_su ; b_s = s4 E f_su + s5/2 E f_ru
    g[6] = -(s[3] * F[0, 1] + h5 * F[1, 1])
    g[7] = s[3] * F[0, 0] + h5 * F[1, 0]
    g[8] = 0.0
    g[9] = -(s[4] * F[1, 1] + h5 * F[0, 1])
    g[10] = s[4] * F[1, 0] + h5 * F[0, 0]
    g[11] = 0.0


@inl
def _add_strain_gradient_row(F, k, v, G2, row):
    """G2[row] (12) += v * (row k of D), D = de/dF (8 x 12)."""
    if k == 0:
        for c in range(3):
            G2[row, c] += v * F[0, c]
    elif k == 1:
        for c in range(3):
            G2[row, 3 + c] += v * F[1, c]
    elif k == 2:
        for c in range(3):
            G2[row, c] += 0.5 * v * F[1, c]
            G2[row, 3 + c] += 0.5 * v * F[0, c]
    elif k == 3:
        G2[row, 0] += v * F[2, 1]
        G2[row, 1] -= v * F[2, 0]
        G2[row, 6] -= v * F[0, 1]
        G2[row, 7] += v * F[0, 0]
    elif k == 4:
        G2[row, 3] += v * F[3, 1]
        G2[row, 4] -= v * F[3, 0]
        G2[row, 9] -= v * F[1, 1]
        G2[row, 10] += v * F[1, 0]
    elif k == 5:
        h = 0.5 * v
        G2[row, 0] += h * F[3, 1]
        G2[row, 1] -= h * F[3, 0]
        G2[row, 3] += h * F[2, 1]
        G2[row, 4] -= h * F[2, 0]
        G2[row, 6] -= h * F[1, 1]
        G2[row, 7] += h * F[1, 0]
        G2[row, 9] -= h * F[0, 1]
        G2[row, 10] += h * F[0, 0]
    elif k == 6:
        G2[row, 2] += v
    else:
        G2[row, 5] += v


@inl
def _GT_times(G2, grow, F, Q, T, R, X0, X1, out, orow):
    """out[orow] (18) = G_xi^T g, g = G2[grow] = [a_r, a_s, b_r, b_s] (12) weights of the strain measures.

    G_xi rows f_au: [U_a: R^T, V0: hat(f_au) Q^T, V: hat(f_au) T]; rows f_aw: [V: X_a, W_a: T].
    """
    g0 = G2[grow, 0]
    g1 = G2[grow, 1]
    g2 = G2[grow, 2]
    g3 = G2[grow, 3]
    g4 = G2[grow, 4]
    g5 = G2[grow, 5]
    g6 = G2[grow, 6]
    g7 = G2[grow, 7]
    g8 = G2[grow, 8]
    g9 = G2[grow, 9]
    g10 = G2[grow, 10]
    g11 = G2[grow, 11]
    # c = a_r x f_ru + a_s x f_su
    c0 = (g1 * F[0, 2] - g2 * F[0, 1]) + (g4 * F[1, 2] - g5 * F[1, 1])
    c1 = (g2 * F[0, 0] - g0 * F[0, 2]) + (g5 * F[1, 0] - g3 * F[1, 2])
    c2 = (g0 * F[0, 1] - g1 * F[0, 0]) + (g3 * F[1, 1] - g4 * F[1, 0])
    for r in range(3):
        out[orow, r] = R[r, 0] * g0 + R[r, 1] * g1 + R[r, 2] * g2
        out[orow, 3 + r] = R[r, 0] * g3 + R[r, 1] * g4 + R[r, 2] * g5
        out[orow, 6 + r] = Q[r, 0] * c0 + Q[r, 1] * c1 + Q[r, 2] * c2
        out[orow, 9 + r] = (T[0, r] * c0 + T[1, r] * c1 + T[2, r] * c2
                            + X0[0, r] * g6 + X0[1, r] * g7 + X0[2, r] * g8
                            + X1[0, r] * g9 + X1[1, r] * g10 + X1[2, r] * g11)
        out[orow, 12 + r] = T[0, r] * g6 + T[1, r] * g7 + T[2, r] * g8
        out[orow, 15 + r] = T[0, r] * g9 + T[1, r] * g10 + T[2, r] * g11


@inl
def _load_point(p, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, F, Q, T, R, X0, X1, d, da, co, s):
    """Copy the data of point p into whole small arrays."""
    for c in range(3):
        d[c] = Pd[p, c]
        da[0, c] = Pda[p, 0, c]
        da[1, c] = Pda[p, 1, c]
        for k in range(3):
            Q[c, k] = PQ[p, c, k]
            T[c, k] = PT[p, c, k]
            R[c, k] = PR[p, c, k]
            X0[c, k] = PX[p, 0, c, k]
            X1[c, k] = PX[p, 1, c, k]
    for k in range(4):
        for c in range(3):
            F[k, c] = PF[p, k, c]
    for k in range(9):
        co[k] = Pco[p, k]
    for k in range(8):
        s[k] = Ps[p, k]


@jit
def _force_points(used, PF, PQ, PT, PR, PX, Ps, g, G2, phi, fz):
    """fz (z, row 0) = sum_p Pi_p^T G_xi^T D^T s_p."""
    for r in range(NZ):
        fz[0, r] = 0.0
    for k in range(used.shape[0]):
        p = _u(used[k])
        F = PF[p]
        _strain_gradient_T(F, Ps[p], g)
        for c in range(12):
            G2[0, c] = g[c]
        _GT_times(G2, 0, F, PQ[p], PT[p], PR[p], PX[p, 0], PX[p, 1], phi, 0)
        _expand_vec(phi, 0, p, fz, 0)
