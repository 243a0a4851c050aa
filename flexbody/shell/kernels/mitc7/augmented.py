"""The augmented MITC7 element at a given bubble b: its force (38,) and tangent (38, 38) in the nodal motions
and the two bubble amplitudes (:func:`evaluate_z`), or only the bubble's force and 2 x 2 block
(:func:`evaluate_bubble`, for the Newton iterations on b), and the scratch arrays of both.

z = P h (38): dx_I = R_I du_I at 3I (I = 0..5), dtheta_0 at 18, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0
at 18 + 3I (I = 1..5), db at 36. At a point the strains depend on z only through the 18 slots
xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi_p z, Pi_p holding scalars (N_I, dN_I, N_b, dN_b). The
Jacobian G (12 x 18), the B rows and the contracted second variation K_xi (18 x 18) are formed in xi and
expanded into z; K_h = P^T K_z P plus the nodal terms of the derivative of P (hat(f_u,I) in (u_I, theta_I),
the D T^-1 terms contracted with f_z at dd_I).
"""

from __future__ import annotations

import numpy as np

from flexbody import _numba
from flexbody.lie import kernels as lk
from flexbody.shell.geometry import N_GAUSS
from flexbody.shell.kernels.mitc7.congruence import congruence, force_to_nodes_into, nodal_terms_into
from flexbody.shell.kernels.mitc7.expansion import expand_cols, expand_rows_add
from flexbody.shell.kernels.mitc7.geometric import bubble_point_stiffness_into, point_stiffness_into
from flexbody.shell.kernels.mitc7.material import gradient_col, gradient_T_s, material_z
from flexbody.shell.kernels.mitc7.points import N_EVAL, NAUG, NDOF, kinematics_and_stresses

# The jit policy of flexbody._numba: the evaluations allocate nothing (``fast``); the workspaces use numba's
# defaults (``plain``).
plain = _numba.plain
fast = _numba.fast


@fast
def evaluate_z(e, b, full, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C, c_sym,
                a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, zs, ws, fa, Ka):
    """Augmented force fa (38,) and, if full, tangent Ka (38, 38) at the bubble b (relative coordinates)."""
    (PF, PQ, PT, PR, Pd, Pda, Pe, Ps, G, HfG, PB, X, Bc, Bg, CB,
     DTa, E, M, Z, t33, v3, w3, au, bw, csum, g, cov, eps, sig, tq) = ws
    (Gx, Kx, Hx, Yx, PBz, Kz, Sz, fz, gx, Cg, KP, W, Pco) = zs
    kinematics_and_stresses(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                             EN, EDN, ENB, EDNB, PF, PQ, PT, PR, Pd, Pda, Pe, Ps, Pco, v3, cov, eps, sig, tq)
    for c in range(NAUG):
        fz[c] = 0.0
    if full:
        for r in range(NAUG):
            for c in range(NAUG):
                Kz[r, c] = 0.0
                Sz[r, c] = 0.0
    for r in range(12):
        for c in range(18):
            Gx[r, c] = 0.0
    for p in range(N_EVAL):
        if not used[p]:
            continue
        Q, T, R, F, d, da, s, co = PQ[p], PT[p], PR[p], PF[p], Pd[p], Pda[p], Ps[p], Pco[p]
        # G_xi (12, 18): f_au = R^T x_,a -> R^T dx_,a + hat(f_au) (Q^T dtheta_0 + T dd);
        #                f_aw = T d_,a  -> X_a dd + T dd_,a,  X_a v = D T(d)[v] d_,a
        for a in range(2):
            fu = F[a]
            for k in range(3):
                for l in range(3):
                    Gx[3 * a + k, 3 * a + l] = R[l, k]
            for l in range(3):
                q0, q1, q2 = Q[l, 0], Q[l, 1], Q[l, 2]        # column l of Q^T
                Gx[3 * a, 6 + l] = fu[1] * q2 - fu[2] * q1
                Gx[3 * a + 1, 6 + l] = fu[2] * q0 - fu[0] * q2
                Gx[3 * a + 2, 6 + l] = fu[0] * q1 - fu[1] * q0
                t0, t1, t2 = T[0, l], T[1, l], T[2, l]
                Gx[3 * a, 9 + l] = fu[1] * t2 - fu[2] * t1
                Gx[3 * a + 1, 9 + l] = fu[2] * t0 - fu[0] * t2
                Gx[3 * a + 2, 9 + l] = fu[0] * t1 - fu[1] * t0
            DT = DTa[a]
            lk.d_tangent_co_into(d, da[a], co, DT)
            for k in range(3):
                for l in range(3):
                    Gx[6 + 3 * a + k, 9 + l] = DT[k, l]
                    Gx[6 + 3 * a + k, 12 + 3 * a + l] = T[k, l]
        # g = D^T s, force slots gx = G_xi^T g, expanded into z
        gradient_T_s(F, s, g)
        for c in range(18):
            acc = 0.0
            for k in range(12):
                acc += Gx[k, c] * g[k]
            gx[c] = acc
        for i in range(6):
            wr = EDN[p, 0, i]
            wsn = EDN[p, 1, i]
            for k in range(3):
                fz[3 * i + k] += wr * gx[k] + wsn * gx[3 + k]
        for k in range(3):
            fz[18 + k] += gx[6 + k]
        for i in range(1, 6):
            wn = EN[p, i]
            wr = EDN[p, 0, i]
            wsn = EDN[p, 1, i]
            for k in range(3):
                fz[18 + 3 * i + k] += wn * gx[9 + k] + wr * gx[12 + k] + wsn * gx[15 + k]
        for q in range(2):
            fz[NDOF + q] += ENB[p] * gx[9 + q] + EDNB[p, 0] * gx[12 + q] + EDNB[p, 1] * gx[15 + q]
        if not full:
            continue
        # covariant B rows in z: (D G_xi) Pi_p
        for c in range(18):
            gradient_col(F, Gx, c, Hx)
        expand_cols(Hx, 8, p, EN, EDN, ENB, EDNB, PBz[p])
        nonzero = False
        for j in range(8):
            if s[j] != 0.0:
                nonzero = True
        if not nonzero:
            continue
        # K_xi = G^T Hf(s) G + the second variation
        point_stiffness_into(s, g, F, Q, T, R, d, da, co, Gx, Hx, au, bw, X, v3, w3, W, t33, csum, M, Z, Kx)
        expand_cols(Kx, 18, p, EN, EDN, ENB, EDNB, Yx)
        expand_rows_add(Yx, p, EN, EDN, ENB, EDNB, Kz)

    # --- force in h: f_u = R_I^T f_x, f_theta_I = T^-1(d_I)^T f_dd, f_theta_0 = f_t0 - sum T^-1(-d_I)^T f_dd
    force_to_nodes_into(fz, fr, Ti, Tm, fa)
    if not full:
        return

    material_z(e, to_cart, weights, C, c_sym, a_ptr, a_i, a_p, a_j, a_v, PBz, Cg, Bg, Bc, CB, Sz, Kz)
    congruence(Kz, KP, fr, Ti, Tm, Ka)

    # --- nodal terms: hat(f_u,I) in (u_I, theta_I) (Delta R_I), and the D T^-1 terms of Delta delta d_I -------
    nodal_terms_into(fa, fz, dn, Ti, Tm, E, M, Ka)


@fast
def evaluate_bubble(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                     EN, EDN, ENB, EDNB, zs, ws, fa, Ka):
    """Only the bubble's force fa[36:] and block Ka[36:, 36:] at b (for its Newton iterations).

    The bubble column of Pi_p: slots dd (N_b), dd_,r (dN_b,r), dd_,s (dN_b,s), components 0 and 1; the same
    terms as evaluate_z restricted to it.
    """
    (PF, PQ, PT, PR, Pd, Pda, Pe, Ps, G, HfG, PB, X, Bc, Bg, CB,
     DTa, E, M, Z, t33, v3, w3, au, bw, csum, g, cov, eps, sig, tq) = ws
    (Gx, Kx, Hx, Yx, PBz, Kz, Sz, fz, gx, Cg, KP, W, Pco) = zs
    kinematics_and_stresses(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                             EN, EDN, ENB, EDNB, PF, PQ, PT, PR, Pd, Pda, Pe, Ps, Pco, v3, cov, eps, sig, tq)
    r0 = 0.0
    r1 = 0.0
    k00 = 0.0
    k01 = 0.0
    k10 = 0.0
    k11 = 0.0
    for p in range(N_EVAL):
        if not used[p]:
            continue
        Q, T, R, F, d, da, s, co = PQ[p], PT[p], PR[p], PF[p], Pd[p], Pda[p], Ps[p], Pco[p]
        nb, nbr, nbs = ENB[p], EDNB[p, 0], EDNB[p, 1]
        # Gb = G_xi Pi_b (12, 2): u rows nb hat(f_au) T[:, q]; w rows nb X_a[:, q] + dN_b,a T[:, q]
        for a in range(2):
            fu = F[a]
            wa = nbr if a == 0 else nbs
            DT = DTa[a]
            lk.d_tangent_co_into(d, da[a], co, DT)
            for q in range(2):
                t0, t1, t2 = T[0, q], T[1, q], T[2, q]
                G[3 * a, q] = nb * (fu[1] * t2 - fu[2] * t1)
                G[3 * a + 1, q] = nb * (fu[2] * t0 - fu[0] * t2)
                G[3 * a + 2, q] = nb * (fu[0] * t1 - fu[1] * t0)
                for k in range(3):
                    G[6 + 3 * a + k, q] = nb * DT[k, q] + wa * T[k, q]
        gradient_T_s(F, s, g)
        acc0 = 0.0
        acc1 = 0.0
        for k in range(12):
            acc0 += G[k, 0] * g[k]
            acc1 += G[k, 1] * g[k]
        r0 += acc0
        r1 += acc1
        Bp = PB[p]                                   # B rows (8, 2) of the bubble
        gradient_col(F, G, 0, Bp)
        gradient_col(F, G, 1, Bp)
        nonzero = False
        for j in range(8):
            if s[j] != 0.0:
                nonzero = True
        if not nonzero:
            continue
        bubble_point_stiffness_into(s, g, F, T, d, da, co, nb, nbr, nbs, G, HfG, au, bw, X, v3, w3, csum, M,
                                    Z, t33)
        k00 += t33[0, 0]
        k01 += t33[0, 1]
        k10 += t33[1, 0]
        k11 += t33[1, 1]
    # material: sum_g Bb_g^T (w tc^T C tc) Bb_g
    for gg in range(N_GAUSS):
        tc = to_cart[e, gg]
        w = weights[e, gg]
        for i in range(8):
            Bc[i, 0] = 0.0
            Bc[i, 1] = 0.0
        for q in range(a_ptr[gg], a_ptr[gg + 1]):
            i, pp, j, v = a_i[q], a_p[q], a_j[q], a_v[q]
            Bc[i, 0] += v * PB[pp, j, 0]
            Bc[i, 1] += v * PB[pp, j, 1]
        for q in range(2):
            for i in range(8):
                acc = 0.0
                for j in range(8):
                    acc += tc[i, j] * Bc[j, q]
                Bg[i, q] = acc
        for q in range(2):
            for i in range(8):
                acc = 0.0
                for j in range(8):
                    acc += C[i, j] * Bg[j, q]
                CB[i, q] = w * acc
        for i in range(8):
            k00 += Bg[i, 0] * CB[i, 0]
            k01 += Bg[i, 0] * CB[i, 1]
            k10 += Bg[i, 1] * CB[i, 0]
            k11 += Bg[i, 1] * CB[i, 1]
    fa[NDOF] = r0
    fa[NDOF + 1] = r1
    Ka[NDOF, NDOF] = k00
    Ka[NDOF, NDOF + 1] = k01
    Ka[NDOF + 1, NDOF] = k10
    Ka[NDOF + 1, NDOF + 1] = k11


@plain
def zspace():
    """Scratch arrays of evaluate_z (the order of the tuple unpacked there)."""
    return (np.zeros((12, 18)), np.zeros((18, 18)), np.zeros((12, 18)), np.zeros((18, NAUG)),   # Gx Kx Hx Yx
            np.zeros((N_EVAL, 8, NAUG)), np.zeros((NAUG, NAUG)), np.zeros((NAUG, NAUG)),      # PBz Kz Sz
            np.zeros(NAUG), np.zeros(18), np.zeros((8, 8)), np.zeros((NAUG, NAUG)), np.zeros((3, 6)),  # fz gx Cg KP W
            np.zeros((N_EVAL, 9)))                                                              # Pco


@plain
def workspace():
    """Per-chunk scratch arrays (the order of the tuple unpacked in evaluate_z and evaluate_bubble)."""
    return (np.zeros((N_EVAL, 4, 3)), np.zeros((N_EVAL, 3, 3)), np.zeros((N_EVAL, 3, 3)),
            np.zeros((N_EVAL, 3, 3)), np.zeros((N_EVAL, 3)), np.zeros((N_EVAL, 2, 3)), np.zeros((N_EVAL, 8)),
            np.zeros((N_EVAL, 8)),                                   # PF PQ PT PR Pd Pda Pe Ps
            np.zeros((12, 2)), np.zeros((12, 2)), np.zeros((N_EVAL, 8, 2)), np.zeros((3, 18)),  # G HfG PB X
            np.zeros((8, NAUG)), np.zeros((8, NAUG)), np.zeros((8, NAUG)),  # Bc Bg CB
            np.zeros((2, 3, 3)), np.zeros((6, 3)), np.zeros((3, 3)), np.zeros((3, 3)),  # DTa E M Z
            np.zeros((3, 3)),                                        # t33
            np.zeros(3), np.zeros(3), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros(3),  # v3 w3 au bw csum
            np.zeros(12),                                            # g
            np.zeros(8), np.zeros(8), np.zeros(8), np.zeros(8))     # cov eps sig tq
