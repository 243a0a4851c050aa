"""The evaluation points of the MITC7 element: the nodal relative rotations and, at each evaluation point the
assumed-strain map uses, the kinematics (d, d_,a, Q, T, R, F), the covariant strains and the pulled-back
stress weights.

The element's 38 augmented motions and the shape-function tables of the 17 evaluation points (N_I, dN_I of the
six nodes, N_b, dN_b of the bubble) are defined here for all the stages of :mod:`flexbody.shell.kernels.mitc7`.
"""

from __future__ import annotations

import numpy as np

from flexbody import _numba
from flexbody.lie import kernels as lk
from flexbody.shell.geometry import EVAL_DNB, EVAL_NB
from flexbody.shell.geometry import EVAL_DN, EVAL_N, N_GAUSS

#: the element's nodal motions (6 nodes x [u, theta])
NDOF = 36
#: the augmented motions: the nodal ones and the two bubble amplitudes b
NAUG = NDOF + 2
#: the evaluation points of the strains
N_EVAL = EVAL_N.shape[0]

EN_TABLE = np.ascontiguousarray(EVAL_N, dtype=np.float64)       # (17, 6)
EDN_TABLE = np.ascontiguousarray(EVAL_DN, dtype=np.float64)     # (17, 2, 6)
ENB_TABLE = np.ascontiguousarray(EVAL_NB, dtype=np.float64)     # (17,)
EDNB_TABLE = np.ascontiguousarray(EVAL_DNB, dtype=np.float64)   # (17, 2)

# The jit policy of flexbody._numba: the per-point kernel allocates nothing (``fast``); the node setup, which
# allocates nothing either, is compiled with numba's defaults (``plain``) as it always was.
plain = _numba.plain
fast = _numba.fast


@plain
def node_setup(fr, dn, Ti, Tm, t33):
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



@fast
def kinematics_and_stresses(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
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
        lk.point_coefficients_into(lk._norm_fast(d), co)
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
