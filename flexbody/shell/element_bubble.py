"""The condensed MITC7 element (rotation bubble) for a batch of elements: numba kernels.

Computes, element by element, exactly what the readable numpy twin computes:
:func:`flexbody.shell.element_reference.force_tangent` with ``bubble=b`` (the 38-component augmented force
and tangent, the last two components for the bubble amplitudes b) and
:func:`flexbody.shell.bubble.condensed_force_tangent` (Newton on b, then static condensation)::

    r_b(b*) = 0  (Newton on the 2 x 2 block, from the warm start b0),
    f = r_n(b*),     K = K_nn - K_nb K_bb^-1 K_bn.

Contract: the force, the condensed tangent and b* agree with the numpy reference to 1e-12 relative
(tests/shell/test_element_bubble.py). Change the two together.

The arithmetic is that of the reference, arranged as in the MITC6 kernel (:mod:`flexbody.shell.element`);
results agree to round-off:

* **Relative coordinates.** The 38 augmented motions h = [u_I, theta_I, b] are mapped to
  z = [dx_I, dtheta_0, dd_1..dd_5, db], dx_I = R_I du_I, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0
  (paper Eq. 31): z = P h. At an evaluation point the strains depend on z only through 18 slots
  xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi_p z, Pi_p holding only the scalars N_I, dN_I (and
  N_b, dN_b for db). The Jacobian G (12 x 18), the B rows and the contracted second variation K_xi (18 x 18:
  G^T Hf G, written out from the sparsity of Hf, plus the terms of kinematics.second_variation) are formed
  in xi and expanded into z in two sparse stages; the material stiffness sum_g B_g^T (w tc^T C tc) B_g is
  formed in z (upper triangle, if C is symmetric). Then K_h = P^T K_z P plus the nodal terms of the
  derivative of P: hat(f_u,I) in (u_I, theta_I) and the D T^-1(+-d_I)[.] terms contracted with the z-force
  at dd_I (which equals the reference's sum over points of N_I g_d + dN_I . g_da).
* The stress weights of the evaluation points are pulled back once (as in the reference); the force is
  sum_p Pi_p^T G_p^T D_p^T s_p (equal to sum_g w_g B_g^T sigma_g), mapped back by P^T.
* **Bubble iterations.** During the bubble's Newton iterations only r_b (2,) and K_bb (2 x 2) are formed
  (_evaluate_bubble: the same terms restricted to the db column of Pi_p); the force (38,) and, if wanted,
  the full tangent are formed once, at the final b, by _evaluate_z (the force by the same code with and
  without the tangent).
* The SO(3) coefficients of a point (lk.coefficients of |d|; the same for -d) are computed once per point
  (the Taylor series below the switch evaluated fused), and the maps D T, D^2 T use them.
* Evaluation points that the assumed-strain map does not use are skipped. The per-element kernels are
  compiled with the flags of the MITC6 kernel (no reference counting, noalias, FMA contraction).

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

from typing import NamedTuple

import numpy as np

from flexbody import _numba
from flexbody.chunks import n_chunks, run_chunks
from flexbody.lie import kernels as lk
from flexbody.shell.bubble_newton import BUBBLE_MAX_ITERATIONS, BUBBLE_TOL, bubble_step
from flexbody.shell.element import _element_arrays
from flexbody.shell.geometry import EVAL_DNB, EVAL_NB
from flexbody.shell.geometry import EVAL_DN, EVAL_N, N_GAUSS

NDOF = 36
NAUG = NDOF + 2
N_EVAL = EVAL_N.shape[0]

# The jit policy of flexbody._numba: the per-element kernels allocate nothing (``fast``: no reference counting,
# noalias array arguments, numpy error model, FMA contraction, as the MITC6 kernel); the workspace allocation
# and the chunk loop use numba's defaults.
jit = _numba.plain
fast = _numba.fast
_bubble_step = jit(bubble_step)       # the safeguarded Newton step, shared with the numpy reference

_EN = np.ascontiguousarray(EVAL_N, dtype=np.float64)       # (17, 6)
_EDN = np.ascontiguousarray(EVAL_DN, dtype=np.float64)     # (17, 2, 6)
_ENB = np.ascontiguousarray(EVAL_NB, dtype=np.float64)     # (17,)
_EDNB = np.ascontiguousarray(EVAL_DNB, dtype=np.float64)   # (17, 2)

# ----------------------------------------------------------------------------------------------------------
# Small helpers
# ----------------------------------------------------------------------------------------------------------


@fast
def _cross_into(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@fast
def _gradient_T_s(F, s, g):
    """g = D^T s (12,), D = de/dF of _strain_gradient_into, written out."""
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
def _gradient_col(F, G, c, B):
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
def _hessian_col(s, G, c, H):
    """H[:, c] = Hf(s) G[:, c], Hf of _strain_hessian_into written out (rows 8 and 11 are zero)."""
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


# The SO(3) coefficients of a point (lk.coefficients of |d|, the same for -d) are computed once
# (lk.point_coefficients_into) and passed to the maps of flexbody.lie.kernels that take them (inlined).

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


# ----------------------------------------------------------------------------------------------------------
# The final evaluation (force and, if wanted, tangent) in relative coordinates
# ----------------------------------------------------------------------------------------------------------
#
# z = P h (38): dx_I = R_I du_I at 3I (I = 0..5), dtheta_0 at 18, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0
# at 18 + 3I (I = 1..5), db at 36. At a point the strains depend on z only through the 18 slots
# xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi_p z, Pi_p holding scalars (N_I, dN_I, N_b, dN_b). The
# Jacobian G (12 x 18), the B rows and the contracted second variation K_xi (18 x 18) are formed in xi and
# expanded into z; K_h = P^T K_z P plus the nodal terms of the derivative of P (hat(f_u,I) in (u_I, theta_I),
# the D T^-1 terms contracted with f_z at dd_I).


@fast
def _expand_cols(Kx, nrow, p, EN, EDN, ENB, EDNB, Y):
    """Y[:nrow] (nrow, 38) = Kx[:nrow] (nrow, 18) Pi_p."""
    nb, nbr, nbs = ENB[p], EDNB[p, 0], EDNB[p, 1]
    for r in range(nrow):
        for i in range(6):
            wr = EDN[p, 0, i]
            ws = EDN[p, 1, i]
            for k in range(3):
                Y[r, 3 * i + k] = wr * Kx[r, k] + ws * Kx[r, 3 + k]
        for k in range(3):
            Y[r, 18 + k] = Kx[r, 6 + k]
        for i in range(1, 6):
            wn = EN[p, i]
            wr = EDN[p, 0, i]
            ws = EDN[p, 1, i]
            for k in range(3):
                Y[r, 18 + 3 * i + k] = wn * Kx[r, 9 + k] + wr * Kx[r, 12 + k] + ws * Kx[r, 15 + k]
        for q in range(2):
            Y[r, NDOF + q] = nb * Kx[r, 9 + q] + nbr * Kx[r, 12 + q] + nbs * Kx[r, 15 + q]


@fast
def _expand_rows_add(Y, p, EN, EDN, ENB, EDNB, Kz):
    """Kz (38, 38) += Pi_p^T Y (Y: 18 x 38)."""
    nb, nbr, nbs = ENB[p], EDNB[p, 0], EDNB[p, 1]
    for i in range(6):
        wr = EDN[p, 0, i]
        ws = EDN[p, 1, i]
        for k in range(3):
            for c in range(NAUG):
                Kz[3 * i + k, c] += wr * Y[k, c] + ws * Y[3 + k, c]
    for k in range(3):
        for c in range(NAUG):
            Kz[18 + k, c] += Y[6 + k, c]
    for i in range(1, 6):
        wn = EN[p, i]
        wr = EDN[p, 0, i]
        ws = EDN[p, 1, i]
        for k in range(3):
            for c in range(NAUG):
                Kz[18 + 3 * i + k, c] += wn * Y[9 + k, c] + wr * Y[12 + k, c] + ws * Y[15 + k, c]
    for q in range(2):
        for c in range(NAUG):
            Kz[NDOF + q, c] += nb * Y[9 + q, c] + nbr * Y[12 + q, c] + nbs * Y[15 + q, c]


@fast
def _kinematics_and_stresses(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                             EN, EDN, ENB, EDNB, PF, PQ, PT, PR, Pd, Pda, Pe, Ps, Pco, v3, cov, eps, sig, tq):
    """Point kinematics (d, d_,a, Q, T, R, F), covariant strains and pulled-back stress weights Ps."""
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
        Q, T, R, F, co = PQ[p], PT[p], PR[p], PF[p], Pco[p]
        lk.point_coefficients_into(lk._norm(d), co)
        lk.exp_co_into(d, co, Q)
        lk.tangent_co_into(d, co, T)
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
        ep[3] = (fru[0] * frw[1] - fru[1] * frw[0]) - e_ref[e, p, 3]
        ep[4] = (fsu[0] * fsw[1] - fsu[1] * fsw[0]) - e_ref[e, p, 4]
        ep[5] = 0.5 * ((fru[0] * fsw[1] - fru[1] * fsw[0]) + (fsu[0] * frw[1] - fsu[1] * frw[0])) - e_ref[e, p, 5]
        ep[6] = fru[2] - e_ref[e, p, 6]
        ep[7] = fsu[2] - e_ref[e, p, 7]
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


@fast
def _material_z(e, to_cart, weights, C, c_sym, a_ptr, a_i, a_p, a_j, a_v, PBz, Cg, Bg, Bc, CB, Sz, Kz):
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



@fast
def _congruence(Kz, KP, fr, Ti, Tm, Ka):
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



@fast
def _evaluate_z(e, b, full, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C, c_sym,
                a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, zs, ws, fa, Ka):
    """Augmented force fa (38,) and, if full, tangent Ka (38, 38) at the bubble b (relative coordinates)."""
    (PF, PQ, PT, PR, Pd, Pda, Pe, Ps, G, HfG, PB, X, Bc, Bg, CB,
     DTa, E, M, Z, t33, v3, w3, au, bw, csum, g, cov, eps, sig, tq) = ws
    (Gx, Kx, Hx, Yx, PBz, Kz, Sz, fz, gx, Cg, KP, W, Pco) = zs
    _kinematics_and_stresses(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
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
        _gradient_T_s(F, s, g)
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
            _gradient_col(F, Gx, c, Hx)
        _expand_cols(Hx, 8, p, EN, EDN, ENB, EDNB, PBz[p])
        nonzero = False
        for j in range(8):
            if s[j] != 0.0:
                nonzero = True
        if not nonzero:
            continue
        # K_xi = G^T Hf(s) G + the second variation
        for c in range(18):
            _hessian_col(s, Gx, c, Hx)
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
        _cross_into(au[0], F[0], v3)
        _cross_into(au[1], F[1], w3)
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
        _expand_cols(Kx, 18, p, EN, EDN, ENB, EDNB, Yx)
        _expand_rows_add(Yx, p, EN, EDN, ENB, EDNB, Kz)

    # --- force in h: f_u = R_I^T f_x, f_theta_I = T^-1(d_I)^T f_dd, f_theta_0 = f_t0 - sum T^-1(-d_I)^T f_dd
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
    if not full:
        return

    _material_z(e, to_cart, weights, C, c_sym, a_ptr, a_i, a_p, a_j, a_v, PBz, Cg, Bg, Bc, CB, Sz, Kz)
    _congruence(Kz, KP, fr, Ti, Tm, Ka)

    # --- nodal terms: hat(f_u,I) in (u_I, theta_I) (Delta R_I), and the D T^-1 terms of Delta delta d_I -------
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
                lk.d_tangent_inv_into((-dn[i, 0], -dn[i, 1], -dn[i, 2]), E[i], M)
                r0 = 6 * i + 3
            else:                                    # rows theta_0: - D T^-1(d_I)[.] E_I JdI
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


@fast
def _evaluate_bubble(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                     EN, EDN, ENB, EDNB, zs, ws, fa, Ka):
    """Only the bubble's force fa[36:] and block Ka[36:, 36:] at b (for its Newton iterations).

    The bubble column of Pi_p: slots dd (N_b), dd_,r (dN_b,r), dd_,s (dN_b,s), components 0 and 1; the same
    terms as _evaluate_z restricted to it.
    """
    (PF, PQ, PT, PR, Pd, Pda, Pe, Ps, G, HfG, PB, X, Bc, Bg, CB,
     DTa, E, M, Z, t33, v3, w3, au, bw, csum, g, cov, eps, sig, tq) = ws
    (Gx, Kx, Hx, Yx, PBz, Kz, Sz, fz, gx, Cg, KP, W, Pco) = zs
    _kinematics_and_stresses(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
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
        _gradient_T_s(F, s, g)
        acc0 = 0.0
        acc1 = 0.0
        for k in range(12):
            acc0 += G[k, 0] * g[k]
            acc1 += G[k, 1] * g[k]
        r0 += acc0
        r1 += acc1
        Bp = PB[p]                                   # B rows (8, 2) of the bubble
        _gradient_col(F, G, 0, Bp)
        _gradient_col(F, G, 1, Bp)
        nonzero = False
        for j in range(8):
            if s[j] != 0.0:
                nonzero = True
        if not nonzero:
            continue
        _hessian_col(s, G, 0, HfG)
        _hessian_col(s, G, 1, HfG)
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
        _cross_into(au[0], F[0], v3)
        _cross_into(au[1], F[1], w3)
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


@jit
def _zspace():
    """Scratch arrays of _evaluate_z (the order of the tuple unpacked there)."""
    return (np.zeros((12, 18)), np.zeros((18, 18)), np.zeros((12, 18)), np.zeros((18, NAUG)),   # Gx Kx Hx Yx
            np.zeros((N_EVAL, 8, NAUG)), np.zeros((NAUG, NAUG)), np.zeros((NAUG, NAUG)),      # PBz Kz Sz
            np.zeros(NAUG), np.zeros(18), np.zeros((8, 8)), np.zeros((NAUG, NAUG)), np.zeros((3, 6)),  # fz gx Cg KP W
            np.zeros((N_EVAL, 9)))                                                              # Pco


# ----------------------------------------------------------------------------------------------------------
# Batch driver
# ----------------------------------------------------------------------------------------------------------


@jit
def _workspace():
    """Per-chunk scratch arrays (the order of the tuple unpacked in _evaluate_z and _evaluate_bubble)."""
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


@_numba.released
def _chunk(e0, e1, x_el, fr_el, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
           EN, EDN, ENB, EDNB, b0, want_tangent, c_sym, tol, max_iter, f, K, b_out):
    ws = _workspace()
    zs = _zspace()
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
                _evaluate_bubble(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                                 EN, EDN, ENB, EDNB, zs, ws, fa, Ka)
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
        # the force (and tangent) at the final b; the force by the same code in both cases
        _evaluate_z(e, b, want_tangent, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C, c_sym,
                    a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, zs, ws, fa, Ka)
        if want_tangent:
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


# ----------------------------------------------------------------------------------------------------------
# Python entry point
# ----------------------------------------------------------------------------------------------------------

class MapNonzeros(NamedTuple):
    """The nonzeros of an assumed-strain map A (7, 8, 17, 8) by Gauss point, and the evaluation points used."""

    ptr: np.ndarray     # (8,) start of each Gauss point's entries
    i: np.ndarray       # row component
    p: np.ndarray       # evaluation point
    j: np.ndarray       # column component
    value: np.ndarray   # A[g, i, p, j]
    used: np.ndarray    # (17,) bool: the evaluation points the map uses


def map_nonzeros(A: np.ndarray) -> MapNonzeros:
    """The kernel's form of an assumed-strain map A (7, 8, 17, 8) (computed; :func:`_map_nonzeros` caches)."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    if A.shape != (N_GAUSS, 8, N_EVAL, 8):
        raise ValueError(f"A must have shape {(N_GAUSS, 8, N_EVAL, 8)}, got {A.shape}")
    g, i, p, j = np.nonzero(A)                   # row-major: sorted by g
    ptr = np.searchsorted(g, np.arange(N_GAUSS + 1)).astype(np.int64)
    used = np.zeros(N_EVAL, dtype=np.bool_)
    used[p] = True
    return MapNonzeros(ptr, i.astype(np.int64), p.astype(np.int64), j.astype(np.int64),
                       np.ascontiguousarray(A[g, i, p, j]), used)


_MAP_CACHE: dict[bytes, MapNonzeros] = {}


def _map_nonzeros(A: np.ndarray | MapNonzeros) -> MapNonzeros:
    """:func:`map_nonzeros`, cached on the contents of A; a MapNonzeros is returned as it is."""
    if isinstance(A, MapNonzeros):
        return A
    A = np.ascontiguousarray(A, dtype=np.float64)
    key = A.tobytes()
    out = _MAP_CACHE.get(key)
    if out is None:
        out = map_nonzeros(A)
        if len(_MAP_CACHE) > 8:
            _MAP_CACHE.clear()
        _MAP_CACHE[key] = out
    return out


def _n_chunks(m: int) -> int:
    """Chunks: a lower threshold for threads than element.py's (an MITC7 element costs about four MITC6
    elements)."""
    return n_chunks(m, min_parallel=16)


def condensed_force_tangent_batch(x_el: np.ndarray, fr_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                                  weights: np.ndarray, C: np.ndarray, A: np.ndarray | MapNonzeros,
                                  b0: np.ndarray | None,
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
    A : (7, 8, 17, 8) assumed-strain map, ``MITC7().maps``, or its :class:`MapNonzeros`
        (``MITC7().compressed_maps``: no re-hashing)
    b0 : (m, 2) warm start of the bubble's Newton (e.g. the b returned by the last call), or None (zeros)
    want_tangent : False skips the tangent (only the bubble block K_bb is formed, for the Newton on b)

    Returns
    -------
    f : (m, 36) internal forces; NaN for an element whose bubble did not converge (see the module docstring)
    K : (m, 36, 36) condensed tangents (NaN where f is), or an empty (0, 36, 36) array if not want_tangent
    b : (m, 2) converged bubble amplitudes (b0 where the bubble did not converge)
    """
    b0 = np.zeros((len(x_el), 2)) if b0 is None else b0
    x_el, fr_el, e_ref, to_cart, weights, b0 = _element_arrays(x_el, fr_el, e_ref, to_cart,
                                                               weights=(weights, (N_GAUSS,)), b0=(b0, (2,)))
    m = x_el.shape[0]
    C = np.ascontiguousarray(C, dtype=np.float64)
    if C.shape != (8, 8):
        raise ValueError(f"C must be (8, 8), got {C.shape}")
    ptr, ai, ap, aj, av, used = _map_nonzeros(A)
    f = np.empty((m, NDOF))
    K = np.empty((m, NDOF, NDOF)) if want_tangent else np.empty((0, NDOF, NDOF))
    b = np.empty((m, 2))
    if m:
        args = (x_el, fr_el, e_ref, to_cart, weights, C, ptr, ai, ap, aj, av, used, _EN, _EDN, _ENB, _EDNB,
                b0, bool(want_tangent), bool(np.array_equal(C, C.T)), float(BUBBLE_TOL), int(BUBBLE_MAX_ITERATIONS),
                f, K, b)
        run_chunks(lambda e0, e1: _chunk(e0, e1, *args), m, _n_chunks(m))
    return f, K, b
