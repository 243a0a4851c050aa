"""The condensed MITC7 element (rotation bubble) for a batch of elements: numba kernels.

Computes, element by element, exactly what the readable numpy twin computes:
:func:`flexbody.shell.element_reference.force_tangent` with ``bubble=b`` (the 38-component augmented force
and tangent, the last two components for the bubble amplitudes b) and
:func:`flexbody.shell.bubble.condensed_force_tangent` (Newton on b, then static condensation)::

    r_b(b*) = 0  (Newton on the 2 x 2 block, from the warm start b0),
    f = r_n(b*),     K = K_nn - K_nb K_bb^-1 K_bn.

Contract: the force, the condensed tangent and b* agree with the numpy reference to 1e-12 relative
(tests/shell/test_element_bubble.py). Change the two together.

The arithmetic is that of the reference, written as plain loops over small arrays; the differences are
only in the order of summation and in where the work is skipped:

* The Jacobians of the interpolated rotation (``Jd``, ``Jda``, ``Jth`` of
  :func:`flexbody.shell.kinematics.point_kinematics`) vanish in the translation columns, so the products
  of the second variation run over the 20 rotation columns (theta_I and b) only.
* The stress weights of the evaluation points are pulled back once (as in the reference); the force is
  sum_p G_p^T D_p^T s_p (equal to sum_g w_g B_g^T sigma_g).
* The nodal terms D T^-1(+-d_I)[.] of the second variation are linear in their weight, so they are summed
  over the points first and applied once per element.
* During the bubble's Newton iterations only the force (38,) and the 2 x 2 block K_bb are formed (the
  same code restricted to the bubble columns); the full 38 x 38 tangent is formed once, at the converged b
  (and only if it is wanted). The force is computed by the same code in both cases.
* Evaluation points that the assumed-strain map does not use are skipped.

Convergence of the bubble: the safeguarded Newton step of :func:`flexbody.shell.bubble.bubble_step` (the
same function, compiled), from the warm start b0 and, if that fails, from b = 0, until the correction is
<= ``BUBBLE_TOL (1 + |b|_inf)``; that last correction is applied and the force and tangent are evaluated
at the final b, as in the reference. If it does not converge within ``BUBBLE_MAX_ITERATIONS`` evaluations,
or a correction is not finite, the element's force (and tangent) are set to NaN, so that the caller's
Newton stops cleanly on a non-finite residual, and its returned b is the warm start b0 (not the diverged
iterate), so that a retry from the last state is not poisoned. The reference raises
``FloatingPointError`` in that case.

SO(3) maps: :mod:`flexbody.lie.kernels` (same conventions as :mod:`flexbody.lie.so3`:
``d_tangent_into(phi, b, X)`` gives ``X v = (D T(phi)[v]) b`` etc.).
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

from flexbody.lie import kernels as lk
from flexbody.shell.bubble import BUBBLE_MAX_ITERATIONS, BUBBLE_TOL, bubble_step
from flexbody.shell.element_reference import EVAL_DNB, EVAL_NB
from flexbody.shell.geometry import EVAL_DN, EVAL_N, N_GAUSS

NDOF = 36
NAUG = NDOF + 2
N_EVAL = EVAL_N.shape[0]

jit = numba.njit(cache=True)
_bubble_step = jit(bubble_step)       # the safeguarded Newton step, shared with the numpy reference

_EN = np.ascontiguousarray(EVAL_N, dtype=np.float64)       # (17, 6)
_EDN = np.ascontiguousarray(EVAL_DN, dtype=np.float64)     # (17, 2, 6)
_ENB = np.ascontiguousarray(EVAL_NB, dtype=np.float64)     # (17,)
_EDNB = np.ascontiguousarray(EVAL_DNB, dtype=np.float64)   # (17, 2)

#: Column sets of the augmented 38 DoFs: all, rotations (theta_I and the bubble), the bubble alone.
_ALL_COLS = np.arange(NAUG, dtype=np.int64)
_ROT_COLS = np.array([6 * i + 3 + k for i in range(6) for k in range(3)] + [NDOF, NDOF + 1], dtype=np.int64)
_BUB_COLS = np.array([NDOF, NDOF + 1], dtype=np.int64)


# ----------------------------------------------------------------------------------------------------------
# Small helpers
# ----------------------------------------------------------------------------------------------------------


@jit
def _cross_into(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@jit
def _strain_gradient_into(F, D):
    """D = de/dF (8, 12) of :func:`flexbody.shell.kinematics.strain_gradient`; hat(e3) v = (-v1, v0, 0)."""
    for i in range(8):
        for j in range(12):
            D[i, j] = 0.0
    fru, fsu, frw, fsw = F[0], F[1], F[2], F[3]
    for k in range(3):
        D[0, k] = fru[k]
        D[1, 3 + k] = fsu[k]
        D[2, k] = 0.5 * fsu[k]
        D[2, 3 + k] = 0.5 * fru[k]
    # D[3, ru] = -hat(e3) frw, D[3, rw] = hat(e3) fru
    D[3, 0], D[3, 1] = frw[1], -frw[0]
    D[3, 6], D[3, 7] = -fru[1], fru[0]
    D[4, 3], D[4, 4] = fsw[1], -fsw[0]
    D[4, 9], D[4, 10] = -fsu[1], fsu[0]
    D[5, 0], D[5, 1] = 0.5 * fsw[1], -0.5 * fsw[0]
    D[5, 9], D[5, 10] = -0.5 * fru[1], 0.5 * fru[0]
    D[5, 3], D[5, 4] = 0.5 * frw[1], -0.5 * frw[0]
    D[5, 6], D[5, 7] = -0.5 * fsu[1], 0.5 * fsu[0]
    D[6, 2] = 1.0
    D[7, 5] = 1.0


@jit
def _add_block(H, r0, c0, s, skew):
    """H[r0:r0+3, c0:c0+3] += s I (skew False) or s hat(e3) (skew True)."""
    if skew:
        H[r0, c0 + 1] -= s
        H[r0 + 1, c0] += s
    else:
        for k in range(3):
            H[r0 + k, c0 + k] += s


@jit
def _strain_hessian_into(s, Hf):
    """sum_k s_k d^2 e_k / dF^2 (12, 12) of :func:`flexbody.shell.kinematics.strain_hessian`."""
    for i in range(12):
        for j in range(12):
            Hf[i, j] = 0.0
    ru, su, rw, sw = 0, 3, 6, 9
    _add_block(Hf, ru, ru, s[0], False)
    _add_block(Hf, su, su, s[1], False)
    _add_block(Hf, ru, su, 0.5 * s[2], False)
    _add_block(Hf, su, ru, 0.5 * s[2], False)
    _add_block(Hf, ru, rw, -s[3], True)
    _add_block(Hf, rw, ru, s[3], True)
    _add_block(Hf, su, sw, -s[4], True)
    _add_block(Hf, sw, su, s[4], True)
    _add_block(Hf, ru, sw, -0.5 * s[5], True)
    _add_block(Hf, sw, ru, 0.5 * s[5], True)
    _add_block(Hf, su, rw, -0.5 * s[5], True)
    _add_block(Hf, rw, su, 0.5 * s[5], True)


# ----------------------------------------------------------------------------------------------------------
# One evaluation of the augmented element at a given bubble b
# ----------------------------------------------------------------------------------------------------------


@jit
def _node_setup(fr, dn, Ti, Tm, t33):
    """d_I = log(R_0^T R_I), T^-1(d_I), T^-1(-d_I) for I = 1..5 (d_0 = 0)."""
    for k in range(3):
        dn[0, k] = 0.0
    for i in range(1, 6):
        for k in range(3):
            for l in range(3):
                acc = 0.0
                for m in range(3):
                    acc += fr[0, m, k] * fr[i, m, l]
                t33[k, l] = acc
        lk.log_into(t33, dn[i])
        lk.tangent_inv_into(dn[i], Ti[i])
        lk.tangent_inv_into((-dn[i, 0], -dn[i, 1], -dn[i, 2]), Tm[i])


@jit
def _evaluate(e, b, full, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C,
              a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, cols, rcols, ws, fa, Ka):
    """Augmented force fa (38,) and tangent Ka at the bubble b of element e.

    full : True fills Ka (38, 38); False only the bubble block Ka[36:, 36:] (then cols = rcols = the two
    bubble columns). fa is computed the same way in both cases.
    """
    (PF, PQ, PT, PR, Pd, Pda, Pe, Ps, Jd, Jda, Jth, G, RtRi, D, Hf, HfG, PB, X, MJ, ZJ, Bc, Bg, CB,
     DTa, E, M, Z, t33, v3, w3, au, bw, csum, g, gd, gda, cov, eps, sig, tq) = ws
    nc = cols.shape[0]
    nr = rcols.shape[0]
    for c in range(NAUG):
        fa[c] = 0.0
    if full:
        for r in range(NAUG):
            for c in range(NAUG):
                Ka[r, c] = 0.0
        for i in range(6):
            for k in range(3):
                E[i, k] = 0.0
    else:
        for r in range(nc):
            for c in range(nc):
                Ka[cols[r], cols[c]] = 0.0

    # --- pass 1: kinematics and covariant strains at the evaluation points -------------------------------
    for p in range(N_EVAL):
        if not used[p]:
            continue
        nb = ENB[p]
        d = Pd[p]
        da = Pda[p]
        for k in range(3):
            bk = b[k] if k < 2 else 0.0
            acc = nb * bk
            acc0 = EDNB[p, 0] * bk
            acc1 = EDNB[p, 1] * bk
            for i in range(6):
                acc += EN[p, i] * dn[i, k]
                acc0 += EDN[p, 0, i] * dn[i, k]
                acc1 += EDN[p, 1, i] * dn[i, k]
            d[k] = acc
            da[0, k] = acc0
            da[1, k] = acc1
        Q, T, R, F = PQ[p], PT[p], PR[p], PF[p]
        lk.exp_into(d, Q)
        lk.tangent_into(d, T)
        for k in range(3):
            for l in range(3):
                acc = 0.0
                for m in range(3):
                    acc += fr[0, k, m] * Q[m, l]
                R[k, l] = acc
        for a in range(2):
            for k in range(3):                       # x_,a
                acc = 0.0
                for i in range(6):
                    acc += EDN[p, a, i] * x[i, k]
                v3[k] = acc
            for k in range(3):
                acc = 0.0
                acc2 = 0.0
                for m in range(3):
                    acc += R[m, k] * v3[m]           # f_au = R^T x_,a
                    acc2 += T[k, m] * da[a, m]       # f_aw = T d_,a
                F[a, k] = acc
                F[2 + a, k] = acc2
        fru, fsu, frw, fsw = F[0], F[1], F[2], F[3]
        ep = Pe[p]
        ep[0] = 0.5 * (fru[0] * fru[0] + fru[1] * fru[1] + fru[2] * fru[2]) - e_ref[e, p, 0]
        ep[1] = 0.5 * (fsu[0] * fsu[0] + fsu[1] * fsu[1] + fsu[2] * fsu[2]) - e_ref[e, p, 1]
        ep[2] = 0.5 * (fru[0] * fsu[0] + fru[1] * fsu[1] + fru[2] * fsu[2]) - e_ref[e, p, 2]
        # -a . hat(e3) b = a0 b1 - a1 b0
        ep[3] = (fru[0] * frw[1] - fru[1] * frw[0]) - e_ref[e, p, 3]
        ep[4] = (fsu[0] * fsw[1] - fsu[1] * fsw[0]) - e_ref[e, p, 4]
        ep[5] = 0.5 * ((fru[0] * fsw[1] - fru[1] * fsw[0]) + (fsu[0] * frw[1] - fsu[1] * frw[0])) - e_ref[e, p, 5]
        ep[6] = fru[2] - e_ref[e, p, 6]
        ep[7] = fsu[2] - e_ref[e, p, 7]

    # --- stresses at the Gauss points, pulled back to covariant weights at the points ---------------------
    for p in range(N_EVAL):
        for j in range(8):
            Ps[p, j] = 0.0
    for gg in range(N_GAUSS):
        tc = to_cart[e, gg]
        w = weights[e, gg]
        for i in range(8):
            cov[i] = 0.0
        for n in range(a_ptr[gg], a_ptr[gg + 1]):
            cov[a_i[n]] += a_v[n] * Pe[a_p[n], a_j[n]]
        for i in range(8):
            acc = 0.0
            for j in range(8):
                acc += tc[i, j] * cov[j]
            eps[i] = acc
        for i in range(8):
            acc = 0.0
            for j in range(8):
                acc += C[i, j] * eps[j]
            sig[i] = acc
        for i in range(8):
            acc = 0.0
            for j in range(8):
                acc += tc[j, i] * sig[j]
            tq[i] = w * acc
        for n in range(a_ptr[gg], a_ptr[gg + 1]):
            Ps[a_p[n], a_j[n]] += a_v[n] * tq[a_i[n]]

    # --- pass 2: Jacobians, force, B rows and geometric stiffness per point -------------------------------
    for p in range(N_EVAL):
        if not used[p]:
            continue
        nb = ENB[p]
        Q, T, R, F, d, da, s = PQ[p], PT[p], PR[p], PF[p], Pd[p], Pda[p], Ps[p]
        # Jd, Jda (3, 38): zero in the translation columns (never written)
        for k in range(3):
            for l in range(3):
                a0 = 0.0
                a1 = 0.0
                a2 = 0.0
                for i in range(1, 6):
                    a0 -= EN[p, i] * Tm[i, k, l]
                    a1 -= EDN[p, 0, i] * Tm[i, k, l]
                    a2 -= EDN[p, 1, i] * Tm[i, k, l]
                    Jd[k, 6 * i + 3 + l] = EN[p, i] * Ti[i, k, l]
                    Jda[0, k, 6 * i + 3 + l] = EDN[p, 0, i] * Ti[i, k, l]
                    Jda[1, k, 6 * i + 3 + l] = EDN[p, 1, i] * Ti[i, k, l]
                Jd[k, 3 + l] = a0
                Jda[0, k, 3 + l] = a1
                Jda[1, k, 3 + l] = a2
        for k in range(3):
            for q in range(2):
                Jd[k, NDOF + q] = nb if k == q else 0.0
                Jda[0, k, NDOF + q] = EDNB[p, 0] if k == q else 0.0
                Jda[1, k, NDOF + q] = EDNB[p, 1] if k == q else 0.0
        # Jth = T Jd + [Q^T at theta_0]
        for n in range(_ROT_COLS.shape[0]):
            c = _ROT_COLS[n]
            for k in range(3):
                Jth[k, c] = T[k, 0] * Jd[0, c] + T[k, 1] * Jd[1, c] + T[k, 2] * Jd[2, c]
        for k in range(3):
            for l in range(3):
                Jth[k, 3 + l] += Q[l, k]
        # R^T R_I
        for i in range(6):
            for k in range(3):
                for l in range(3):
                    RtRi[i, k, l] = R[0, k] * fr[i, 0, l] + R[1, k] * fr[i, 1, l] + R[2, k] * fr[i, 2, l]
        # G = dF/dh (12, 38)
        for a in range(2):
            fu = F[a]
            for n in range(_ROT_COLS.shape[0]):
                c = _ROT_COLS[n]
                G[3 * a, c] = fu[1] * Jth[2, c] - fu[2] * Jth[1, c]
                G[3 * a + 1, c] = fu[2] * Jth[0, c] - fu[0] * Jth[2, c]
                G[3 * a + 2, c] = fu[0] * Jth[1, c] - fu[1] * Jth[0, c]
            for i in range(6):
                dNai = EDN[p, a, i]
                for k in range(3):
                    for l in range(3):
                        G[3 * a + k, 6 * i + l] = dNai * RtRi[i, k, l]
            DT = DTa[a]
            lk.d_tangent_into(d, da[a], DT)
            Jdaa = Jda[a]
            for n in range(_ROT_COLS.shape[0]):
                c = _ROT_COLS[n]
                for k in range(3):
                    G[6 + 3 * a + k, c] = (DT[k, 0] * Jd[0, c] + DT[k, 1] * Jd[1, c] + DT[k, 2] * Jd[2, c]
                                           + T[k, 0] * Jdaa[0, c] + T[k, 1] * Jdaa[1, c] + T[k, 2] * Jdaa[2, c])
        # g = D^T s, force += G^T g
        _strain_gradient_into(F, D)
        for k in range(12):
            acc = 0.0
            for j in range(8):
                acc += D[j, k] * s[j]
            g[k] = acc
        for c in range(NAUG):
            acc = 0.0
            for k in range(12):
                acc += G[k, c] * g[k]
            fa[c] += acc
        # covariant B rows (8, cols)
        Bp = PB[p]
        for n in range(nc):
            c = cols[n]
            for j in range(8):
                acc = 0.0
                for k in range(12):
                    acc += D[j, k] * G[k, c]
                Bp[j, c] = acc

        nonzero = False
        for j in range(8):
            if s[j] != 0.0:
                nonzero = True
        if not nonzero:
            continue
        # G^T Hf(s) G
        _strain_hessian_into(s, Hf)
        for n in range(nc):
            c = cols[n]
            for k in range(12):
                acc = 0.0
                for l in range(12):
                    acc += Hf[k, l] * G[l, c]
                HfG[k, c] = acc
        for n in range(nc):
            r = cols[n]
            for n2 in range(nc):
                c = cols[n2]
                acc = 0.0
                for k in range(12):
                    acc += G[k, r] * HfG[k, c]
                Ka[r, c] += acc
        # second variation (kinematics.second_variation), weights g = [a_r, a_s, b_r, b_s]
        for k in range(3):
            au[0, k] = g[k]
            au[1, k] = g[3 + k]
            bw[0, k] = g[6 + k]
            bw[1, k] = g[9 + k]
        # Jth^T (sum_a hat(a_u) G_u,a)
        for n in range(nc):
            c = cols[n]
            for k in range(3):
                v3[k] = G[k, c]
                w3[k] = G[3 + k, c]
            X[0, c] = (au[0, 1] * v3[2] - au[0, 2] * v3[1]) + (au[1, 1] * w3[2] - au[1, 2] * w3[1])
            X[1, c] = (au[0, 2] * v3[0] - au[0, 0] * v3[2]) + (au[1, 2] * w3[0] - au[1, 0] * w3[2])
            X[2, c] = (au[0, 0] * v3[1] - au[0, 1] * v3[0]) + (au[1, 0] * w3[1] - au[1, 1] * w3[0])
        for n in range(nr):
            r = rcols[n]
            for n2 in range(nc):
                c = cols[n2]
                Ka[r, c] += Jth[0, r] * X[0, c] + Jth[1, r] * X[1, c] + Jth[2, r] * X[2, c]
        # c = sum_a a_u x f_u;  M = -D T(-d)[.] c + sum_a D^2 T(d)[.,.](b_w, d_,a)
        _cross_into(au[0], F[0], v3)
        _cross_into(au[1], F[1], w3)
        for k in range(3):
            csum[k] = v3[k] + w3[k]
        negd = (-d[0], -d[1], -d[2])
        lk.d_tangent_into(negd, csum, M)
        for k in range(3):
            for l in range(3):
                M[k, l] = -M[k, l]
        for a in range(2):
            lk.d2_tangent_into(d, bw[a], da[a], t33)
            for k in range(3):
                for l in range(3):
                    M[k, l] += t33[k, l]
        for n in range(nr):
            c = rcols[n]
            for k in range(3):
                MJ[k, c] = M[k, 0] * Jd[0, c] + M[k, 1] * Jd[1, c] + M[k, 2] * Jd[2, c]
        for n in range(nr):
            r = rcols[n]
            for n2 in range(nr):
                c = rcols[n2]
                Ka[r, c] += Jd[0, r] * MJ[0, c] + Jd[1, r] * MJ[1, c] + Jd[2, r] * MJ[2, c]
        # Jd^T Z^T Jda + Jda^T Z Jd,  Z = -D T(-d)[.] b_w
        for a in range(2):
            lk.d_tangent_into(negd, bw[a], Z)
            for n in range(nr):
                c = rcols[n]
                for k in range(3):
                    ZJ[k, c] = -(Z[k, 0] * Jd[0, c] + Z[k, 1] * Jd[1, c] + Z[k, 2] * Jd[2, c])
            Jdaa = Jda[a]
            for n in range(nr):
                r = rcols[n]
                for n2 in range(nr):
                    c = rcols[n2]
                    wv = Jdaa[0, r] * ZJ[0, c] + Jdaa[1, r] * ZJ[1, c] + Jdaa[2, r] * ZJ[2, c]
                    Ka[r, c] += wv
                    Ka[c, r] += wv
        if not full:
            continue
        # - Q hat(c) T Jd in the theta_0 rows
        for k in range(3):                           # t33 = Q hat(c)
            for l in range(3):
                t33[k, l] = 0.0
        for k in range(3):
            t33[k, 0] = Q[k, 1] * csum[2] - Q[k, 2] * csum[1]
            t33[k, 1] = Q[k, 2] * csum[0] - Q[k, 0] * csum[2]
            t33[k, 2] = Q[k, 0] * csum[1] - Q[k, 1] * csum[0]
        for k in range(3):                           # M = Q hat(c) T
            for l in range(3):
                M[k, l] = t33[k, 0] * T[0, l] + t33[k, 1] * T[1, l] + t33[k, 2] * T[2, l]
        for n in range(nr):
            c = rcols[n]
            for k in range(3):
                Ka[3 + k, c] -= M[k, 0] * Jd[0, c] + M[k, 1] * Jd[1, c] + M[k, 2] * Jd[2, c]
        # weights of Delta delta d and Delta delta d_,a, summed into the nodes
        for k in range(3):
            acc = T[0, k] * csum[0] + T[1, k] * csum[1] + T[2, k] * csum[2]
            for a in range(2):
                acc += DTa[a, 0, k] * bw[a, 0] + DTa[a, 1, k] * bw[a, 1] + DTa[a, 2, k] * bw[a, 2]
                gda[a, k] = T[0, k] * bw[a, 0] + T[1, k] * bw[a, 1] + T[2, k] * bw[a, 2]
            gd[k] = acc
        for i in range(1, 6):
            for k in range(3):
                E[i, k] += EN[p, i] * gd[k] + EDN[p, 0, i] * gda[0, k] + EDN[p, 1, i] * gda[1, k]
        # translation rows: Delta of R^T sum dN_I R_I delta u_I
        for i in range(6):
            for k in range(3):
                v3[k] = EDN[p, 0, i] * au[0, k] + EDN[p, 1, i] * au[1, k]
            # M = RtRi^T hat(v): row k of RtRi^T is column k of RtRi; (hat(v)^T u) = u x v
            for k in range(3):
                u0, u1, u2 = RtRi[i, 0, k], RtRi[i, 1, k], RtRi[i, 2, k]
                M[k, 0] = u1 * v3[2] - u2 * v3[1]
                M[k, 1] = u2 * v3[0] - u0 * v3[2]
                M[k, 2] = u0 * v3[1] - u1 * v3[0]
            for n in range(nr):
                c = rcols[n]
                for k in range(3):
                    Ka[6 * i + k, c] -= M[k, 0] * Jth[0, c] + M[k, 1] * Jth[1, c] + M[k, 2] * Jth[2, c]
            for k in range(3):
                w3[k] = RtRi[i, 0, k] * v3[0] + RtRi[i, 1, k] * v3[1] + RtRi[i, 2, k] * v3[2]
            c0 = 6 * i + 3
            Ka[6 * i, c0 + 1] -= w3[2]
            Ka[6 * i, c0 + 2] += w3[1]
            Ka[6 * i + 1, c0] += w3[2]
            Ka[6 * i + 1, c0 + 2] -= w3[0]
            Ka[6 * i + 2, c0] -= w3[1]
            Ka[6 * i + 2, c0 + 1] += w3[0]

    # --- material stiffness sum_g w_g B_g^T C B_g -----------------------------------------------------------
    for gg in range(N_GAUSS):
        tc = to_cart[e, gg]
        w = weights[e, gg]
        for n in range(nc):
            c = cols[n]
            for i in range(8):
                Bc[i, c] = 0.0
        for q in range(a_ptr[gg], a_ptr[gg + 1]):
            i, pp, j, v = a_i[q], a_p[q], a_j[q], a_v[q]
            for n in range(nc):
                c = cols[n]
                Bc[i, c] += v * PB[pp, j, c]
        for n in range(nc):
            c = cols[n]
            for i in range(8):
                acc = 0.0
                for j in range(8):
                    acc += tc[i, j] * Bc[j, c]
                Bg[i, c] = acc
        for n in range(nc):
            c = cols[n]
            for i in range(8):
                acc = 0.0
                for j in range(8):
                    acc += C[i, j] * Bg[j, c]
                CB[i, c] = w * acc
        for n in range(nc):
            r = cols[n]
            for n2 in range(nc):
                c = cols[n2]
                acc = 0.0
                for i in range(8):
                    acc += Bg[i, r] * CB[i, c]
                Ka[r, c] += acc

    # --- nodal terms: Delta delta d_I = DT^-1(d_I)[.] dtheta_I + DT^-1(-d_I)[.] dtheta_0 (JdI cols) --------
    if full:
        for i in range(1, 6):
            for sign in range(2):
                if sign == 0:                        # rows theta_I: - D T^-1(-d_I)[.] E_I JdI
                    lk.d_tangent_inv_into((-dn[i, 0], -dn[i, 1], -dn[i, 2]), E[i], M)
                    r0 = 6 * i + 3
                else:                                # rows theta_0: - D T^-1(d_I)[.] E_I JdI
                    lk.d_tangent_inv_into(dn[i], E[i], M)
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


# ----------------------------------------------------------------------------------------------------------
# Batch driver
# ----------------------------------------------------------------------------------------------------------


@jit
def _workspace():
    """Per-chunk scratch arrays (the order of the tuple unpacked in _evaluate)."""
    return (np.zeros((N_EVAL, 4, 3)), np.zeros((N_EVAL, 3, 3)), np.zeros((N_EVAL, 3, 3)),
            np.zeros((N_EVAL, 3, 3)), np.zeros((N_EVAL, 3)), np.zeros((N_EVAL, 2, 3)), np.zeros((N_EVAL, 8)),
            np.zeros((N_EVAL, 8)),                                   # PF PQ PT PR Pd Pda Pe Ps
            np.zeros((3, NAUG)), np.zeros((2, 3, NAUG)), np.zeros((3, NAUG)), np.zeros((12, NAUG)),  # Jd Jda Jth G
            np.zeros((6, 3, 3)), np.zeros((8, 12)), np.zeros((12, 12)), np.zeros((12, NAUG)),  # RtRi D Hf HfG
            np.zeros((N_EVAL, 8, NAUG)), np.zeros((3, NAUG)), np.zeros((3, NAUG)), np.zeros((3, NAUG)),  # PB X MJ ZJ
            np.zeros((8, NAUG)), np.zeros((8, NAUG)), np.zeros((8, NAUG)),  # Bc Bg CB
            np.zeros((2, 3, 3)), np.zeros((6, 3)), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3)),  # DTa E M Z t33
            np.zeros(3), np.zeros(3), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros(3),  # v3 w3 au bw csum
            np.zeros(12), np.zeros(3), np.zeros((2, 3)),            # g gd gda
            np.zeros(8), np.zeros(8), np.zeros(8), np.zeros(8))     # cov eps sig tq


@jit
def _chunk(e0, e1, x_el, fr_el, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
           EN, EDN, ENB, EDNB, b0, want_tangent, tol, max_iter, f, K, b_out):
    ws = _workspace()
    x = np.empty((6, 3))
    fr = np.empty((6, 3, 3))
    dn = np.empty((6, 3))
    Ti = np.zeros((6, 3, 3))
    Tm = np.zeros((6, 3, 3))
    t33 = np.empty((3, 3))
    b = np.empty(2)
    fa = np.empty(NAUG)
    Ka = np.empty((NAUG, NAUG))
    Y = np.empty((2, NDOF))
    for e in range(e0, e1):
        for i in range(6):
            for k in range(3):
                x[i, k] = x_el[e, i, k]
                for l in range(3):
                    fr[i, k, l] = fr_el[e, i, k, l]
        _node_setup(fr, dn, Ti, Tm, t33)
        converged = False
        warm = b0[e, 0] != 0.0 or b0[e, 1] != 0.0
        for attempt in range(2 if warm else 1):   # from the warm start, then from b = 0 (as bubble._solve)
            b[0] = b0[e, 0] if attempt == 0 else 0.0
            b[1] = b0[e, 1] if attempt == 0 else 0.0
            for _ in range(max_iter):
                _evaluate(e, b, False, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C,
                          a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, _BUB_COLS, _BUB_COLS, ws, fa, Ka)
                db0, db1 = _bubble_step(fa[NDOF], fa[NDOF + 1], Ka[NDOF, NDOF], Ka[NDOF, NDOF + 1],
                                        Ka[NDOF + 1, NDOF], Ka[NDOF + 1, NDOF + 1])
                if not (np.isfinite(db0) and np.isfinite(db1)):
                    break
                b[0] += db0
                b[1] += db1
                if max(abs(db0), abs(db1)) <= tol * (1.0 + max(abs(b[0]), abs(b[1]))):
                    converged = True
                    break
            if converged:
                break
        if not converged:
            for c in range(NDOF):
                f[e, c] = np.nan
            if want_tangent:
                for r in range(NDOF):
                    for c in range(NDOF):
                        K[e, r, c] = np.nan
            b_out[e, 0] = b0[e, 0]
            b_out[e, 1] = b0[e, 1]
            continue
        b_out[e, 0] = b[0]
        b_out[e, 1] = b[1]
        if not want_tangent:   # the force at the final b (its error is the square of the last correction)
            _evaluate(e, b, False, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C,
                      a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, _BUB_COLS, _BUB_COLS, ws, fa, Ka)
        if want_tangent:
            _evaluate(e, b, True, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C,
                      a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, _ALL_COLS, _ROT_COLS, ws, fa, Ka)
            # K = K_nn - K_nb K_bb^-1 K_bn
            k00, k01, k10, k11 = Ka[NDOF, NDOF], Ka[NDOF, NDOF + 1], Ka[NDOF + 1, NDOF], Ka[NDOF + 1, NDOF + 1]
            det = k00 * k11 - k01 * k10
            for c in range(NDOF):
                u0, u1 = Ka[NDOF, c], Ka[NDOF + 1, c]
                Y[0, c] = (k11 * u0 - k01 * u1) / det
                Y[1, c] = (k00 * u1 - k10 * u0) / det
            for r in range(NDOF):
                kr0, kr1 = Ka[r, NDOF], Ka[r, NDOF + 1]
                for c in range(NDOF):
                    K[e, r, c] = Ka[r, c] - kr0 * Y[0, c] - kr1 * Y[1, c]
        for c in range(NDOF):
            f[e, c] = fa[c]


@numba.njit(cache=True, parallel=True)
def _batch(x_el, fr_el, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
           EN, EDN, ENB, EDNB, b0, want_tangent, tol, max_iter, n_chunks, f, K, b_out):
    m = x_el.shape[0]
    for ch in prange(n_chunks):
        _chunk((ch * m) // n_chunks, ((ch + 1) * m) // n_chunks, x_el, fr_el, e_ref, to_cart, weights, C,
               a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, b0, want_tangent, tol, max_iter, f, K, b_out)


# ----------------------------------------------------------------------------------------------------------
# Python entry point
# ----------------------------------------------------------------------------------------------------------

_MAP_CACHE: dict[bytes, tuple] = {}


def _map_nonzeros(A: np.ndarray) -> tuple:
    """The nonzeros of A (7, 8, 17, 8) by Gauss point: (ptr, i, p, j, value), and the points used."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    if A.shape != (N_GAUSS, 8, N_EVAL, 8):
        raise ValueError(f"A must have shape {(N_GAUSS, 8, N_EVAL, 8)}, got {A.shape}")
    key = A.tobytes()
    out = _MAP_CACHE.get(key)
    if out is None:
        g, i, p, j = np.nonzero(A)                   # row-major: sorted by g
        ptr = np.searchsorted(g, np.arange(N_GAUSS + 1)).astype(np.int64)
        used = np.zeros(N_EVAL, dtype=np.bool_)
        used[p] = True
        out = (ptr, i.astype(np.int64), p.astype(np.int64), j.astype(np.int64),
               np.ascontiguousarray(A[g, i, p, j]), used)
        if len(_MAP_CACHE) > 8:
            _MAP_CACHE.clear()
        _MAP_CACHE[key] = out
    return out


def _as(a, shape_tail, name):
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.shape[1:] != shape_tail:
        raise ValueError(f"{name} must have shape (m, {', '.join(map(str, shape_tail))}), got {a.shape}")
    return a


def _n_chunks(m: int) -> int:
    """Parallel chunks: a few per thread, one for small batches."""
    if m < 16:
        return 1
    return max(1, min(m, 4 * numba.get_num_threads()))


def condensed_force_tangent_batch(x_el: np.ndarray, fr_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                                  weights: np.ndarray, C: np.ndarray, A: np.ndarray, b0: np.ndarray | None,
                                  want_tangent: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Condensed MITC7 force (m, 36), tangent (m, 36, 36) and bubble amplitudes (m, 2) of m elements.

    Element by element the result of :func:`flexbody.shell.bubble.condensed_force_tangent` (force and
    tangent, per node [u, theta] in the nodal local frames) and :func:`flexbody.shell.bubble.condensed_bubble`
    (b), to 1e-12 relative.

    Parameters
    ----------
    x_el : (m, 6, 3) nodal positions
    fr_el : (m, 6, 3, 3) nodal frames R_I
    e_ref : (m, 17, 8) reference covariant strains (:func:`flexbody.shell.geometry.element_geometry`)
    to_cart : (m, 7, 8, 8) covariant-to-Cartesian maps at the Gauss points
    weights : (m, 7) Gauss weights times area elements
    C : (8, 8) section stiffness
    A : (7, 8, 17, 8) assumed-strain map, ``element_reference.assumed_strain_maps("mitc7")``
    b0 : (m, 2) warm start of the bubble's Newton (e.g. the b returned by the last call), or None (zeros)
    want_tangent : False skips the tangent (only the bubble block K_bb is formed, for the Newton on b)

    Returns
    -------
    f : (m, 36) internal forces; NaN for an element whose bubble did not converge (see the module docstring)
    K : (m, 36, 36) condensed tangents (NaN where f is), or an empty (0, 36, 36) array if not want_tangent
    b : (m, 2) converged bubble amplitudes (b0 where the bubble did not converge)
    """
    x_el = _as(x_el, (6, 3), "x_el")
    m = x_el.shape[0]
    fr_el = _as(fr_el, (6, 3, 3), "fr_el")
    e_ref = _as(e_ref, (N_EVAL, 8), "e_ref")
    to_cart = _as(to_cart, (N_GAUSS, 8, 8), "to_cart")
    weights = _as(weights, (N_GAUSS,), "weights")
    b0 = np.zeros((m, 2)) if b0 is None else _as(b0, (2,), "b0")
    if not (len(fr_el) == len(e_ref) == len(to_cart) == len(weights) == len(b0) == m):
        raise ValueError("all element arrays must have the same number of elements")
    C = np.ascontiguousarray(C, dtype=np.float64)
    if C.shape != (8, 8):
        raise ValueError(f"C must be (8, 8), got {C.shape}")
    ptr, ai, ap, aj, av, used = _map_nonzeros(A)
    f = np.empty((m, NDOF))
    K = np.empty((m, NDOF, NDOF)) if want_tangent else np.empty((0, NDOF, NDOF))
    b = np.empty((m, 2))
    if m:
        _batch(x_el, fr_el, e_ref, to_cart, weights, C, ptr, ai, ap, aj, av, used, _EN, _EDN, _ENB, _EDNB,
               b0, bool(want_tangent), float(BUBBLE_TOL), int(BUBBLE_MAX_ITERATIONS), _n_chunks(m), f, K, b)
    return f, K, b
