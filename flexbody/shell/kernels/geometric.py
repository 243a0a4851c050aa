"""The tangent at the evaluation points of the six-node shell kernel (stage ``geometric``).

:func:`_geometric_core`: the contracted second variation of the strain measures at a point, in the 18 slot
coordinates xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] (closed-form 3x3 blocks; the rotation-rotation
block is the only non-symmetric one). :func:`_points_tangent`: per point G^T Hf G + H plus the local material
rows, expanded into z (:mod:`flexbody.shell.kernels.expansion`).
"""

from __future__ import annotations

from flexbody._numba import fast as jit, inline as inl, uint as _u
from flexbody.lie import kernels as lk
from flexbody.shell.kernels.expansion import _expand_core, _expand_core_rot
from flexbody.shell.kernels.layout import NZ, _PI8, _V, _V0, _W0, _W1
from flexbody.shell.kernels.points import _GT_times, _add_strain_gradient_row, _strain_gradient_T
from flexbody.shell.kernels.primitives import _Rhat, _add_blk, _add_blk_both, _mTm, _mm, _mmT


@inl
def _geometric_core(s, g, F, Q, T, R, X0, X1, d, da, co, core, ns, with_uu, t0, t1, t2, t3, t4, t5):
    """core (slots) = G_xi^T Hf(s) G_xi + second variation contracted with g = D^T s (less the node terms).

    Closed forms of kinematics.strain_hessian / second_variation in the slots, with
    m_a = sum_b A_ab f_bu (A = [[s0, s2/2], [s2/2, s1]]), n_a = m_a - a_a, c = sum_a a_a x f_au and
    Omega = sum_a (f_au a_a^T - m_a f_au^T + (f_au . n_a) I):
      [U_a, U_b] = A_ab I, [U_a, V0] = R hat(n_a) Q^T, [U_a, V] = R hat(n_a) T (and transposes),
      [V0, V0] = Q Omega Q^T, [V, V0] = T^T Omega Q^T, [V0, V] = Q (Omega - hat c) T,
      [V, V] = T^T Omega T - DT(-d)[.] c, plus the bending-weight terms (ns = 6).
    """
    nr = 3 * ns
    for i in range(nr):
        for j in range(nr):
            core[i, j] = 0.0
    A01 = 0.5 * s[2]
    # t5 rows: m_0, m_1 ; n_a into t4 rows 0, 1
    dot = 0.0
    for c in range(3):
        m0 = s[0] * F[0, c] + A01 * F[1, c]
        m1 = A01 * F[0, c] + s[1] * F[1, c]
        t5[0, c] = m0
        t5[1, c] = m1
        t4[0, c] = m0 - g[c]
        t4[1, c] = m1 - g[3 + c]
        dot += F[0, c] * t4[0, c] + F[1, c] * t4[1, c]
    Om = t0
    for i in range(3):
        for j in range(3):
            Om[i, j] = F[0, i] * g[j] + F[1, i] * g[3 + j] - t5[0, i] * F[0, j] - t5[1, i] * F[1, j]
        Om[i, i] += dot
    cc0 = (g[1] * F[0, 2] - g[2] * F[0, 1]) + (g[4] * F[1, 2] - g[5] * F[1, 1])
    cc1 = (g[2] * F[0, 0] - g[0] * F[0, 2]) + (g[5] * F[1, 0] - g[3] * F[1, 2])
    cc2 = (g[0] * F[0, 1] - g[1] * F[0, 0]) + (g[3] * F[1, 1] - g[4] * F[1, 0])
    # U-U: A_ab I (left out with with_uu False: then accumulated as scalars, see _points_tangent)
    if with_uu:
        for c in range(3):
            core[c, c] += s[0]
            core[3 + c, 3 + c] += s[1]
            core[c, 3 + c] += A01
            core[3 + c, c] += A01
    # U_a - V0 / V: R hat(n_a) Q^T, R hat(n_a) T and their transposes
    for a in range(2):
        _Rhat(R, t4[a, 0], t4[a, 1], t4[a, 2], t1)
        _mmT(t1, Q, t2)
        _add_blk_both(core, a, _V0, t2, 1.0)
        _mm(t1, T, t2)
        _add_blk_both(core, a, _V, t2, 1.0)
    # V0 / V blocks
    _mmT(Om, Q, t1)                 # Omega Q^T
    _mm(Q, t1, t2)
    _add_blk(core, _V0, _V0, t2, 1.0)
    _mTm(T, t1, t2)
    _add_blk(core, _V, _V0, t2, 1.0)
    _mTm(T, Om, t1)
    _mm(t1, T, t2)
    _add_blk(core, _V, _V, t2, 1.0)
    # [V0, V] = Q (Omega - hat(c)) T
    Om[0, 1] += cc2
    Om[0, 2] -= cc1
    Om[1, 0] -= cc2
    Om[1, 2] += cc0
    Om[2, 0] += cc1
    Om[2, 1] -= cc0
    _mm(Q, Om, t1)
    _mm(t1, T, t2)
    _add_blk(core, _V0, _V, t2, 1.0)
    # [V, V] -= D T(-d)[.] c
    lk.d_tangent_co_into((-d[0], -d[1], -d[2]), (cc0, cc1, cc2), co, t2)
    _add_blk(core, _V, _V, t2, -1.0)
    if ns < 6:
        return
    # ---- terms of the bending weights: Hf couplings f_u - f_w and the b-terms of the second variation
    b3 = s[3]
    b4 = s[4]
    b5 = 0.5 * s[5]
    # beta_ab couples f_au with f_bw: [[s3, s5/2], [s5/2, s4]];  h_b = sum_a beta_ab f_au  (rows of t5)
    for c in range(3):
        t5[0, c] = b3 * F[0, c] + b5 * F[1, c]
        t5[1, c] = b5 * F[0, c] + b4 * F[1, c]
    # RE = R hat(e3): columns (R[:,1], -R[:,0], 0);  RET = R E T
    for r in range(3):
        for c in range(3):
            t1[r, c] = R[r, 1] * T[0, c] - R[r, 0] * T[1, c]
    for a in range(2):
        ba0 = b3 if a == 0 else b5
        ba1 = b5 if a == 0 else b4
        # Z[U_a, V] = -R E (sum_b beta_ab X_b)
        for r in range(3):
            for c in range(3):
                t3[r, c] = ba0 * X0[r, c] + ba1 * X1[r, c]
        for r in range(3):
            for c in range(3):
                t2[r, c] = R[r, 1] * t3[0, c] - R[r, 0] * t3[1, c]
        _add_blk_both(core, a, _V, t2, -1.0)
        # Z[U_a, W_b] = -beta_ab R E T
        _add_blk_both(core, a, _W0, t1, -ba0)
        _add_blk_both(core, a, _W1, t1, -ba1)
    # HX = sum_b hat(h_b) E X_b, with hat(h) E = e3 h^T - h_2 I
    for r in range(3):
        for c in range(3):
            t3[r, c] = -(t5[0, 2] * X0[r, c] + t5[1, 2] * X1[r, c])
    for c in range(3):
        t3[2, c] += (t5[0, 0] * X0[0, c] + t5[0, 1] * X0[1, c] + t5[0, 2] * X0[2, c]
                     + t5[1, 0] * X1[0, c] + t5[1, 1] * X1[1, c] + t5[1, 2] * X1[2, c])
    _mm(Q, t3, t2)
    _add_blk_both(core, _V0, _V, t2, 1.0)
    _mTm(T, t3, t2)
    _add_blk_both(core, _V, _V, t2, 1.0)
    # Z[V0, W_b] = Q hat(h_b) E T, Z[V, W_b] = T^T hat(h_b) E T
    for b in range(2):
        for r in range(3):
            for c in range(3):
                t3[r, c] = -t5[b, 2] * T[r, c]
        for c in range(3):
            t3[2, c] += t5[b, 0] * T[0, c] + t5[b, 1] * T[1, c] + t5[b, 2] * T[2, c]
        _mm(Q, t3, t2)
        _add_blk_both(core, _V0, _W0 + b, t2, 1.0)
        _mTm(T, t3, t2)
        _add_blk_both(core, _V, _W0 + b, t2, 1.0)
    # second variation: D^2 T(d)[., .] contracted with b_a, d_,a ; Z_a = -D T(-d)[.] b_a at (V, W_a)
    for a in range(2):
        o = 6 + 3 * a
        lk.d2_tangent_co_into((d[0], d[1], d[2]), (g[o], g[o + 1], g[o + 2]), (da[a, 0], da[a, 1], da[a, 2]), co, t2)
        _add_blk(core, _V, _V, t2, 1.0)
        lk.d_tangent_co_into((-d[0], -d[1], -d[2]), (g[o], g[o + 1], g[o + 2]), co, t2)
        _add_blk_both(core, _W0 + a, _V, t2, -1.0)


@jit
def _points_tangent(used, pt_gauss, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, Ch,
                    loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
                    g, core, Y, Kz, Kiso, Dl, Bl, CBl, t0, t1, t2, t3, t4, t5):
    """Kz = sum over points of Pi^T [G^T Hf G + H (+ local material rows)] Pi (pattern of _expand_core).

    At points without local material rows the translation-translation block of the core is A_ab I_3
    (A = [[s0, s2/2], [s2/2, s1]]): it is accumulated as the scalar 6 x 6 matrix Kiso (added in
    _finish_tangent), and only the rotation columns are expanded; without shear and bending weights the rest
    of the core vanishes identically (the membrane strains are rotation-free) and the point costs nothing more.
    """
    for r in range(NZ):
        for c in range(NZ):
            Kz[r, c] = 0.0
    n8 = _u(Kiso.shape[1])
    for i in range(6):
        for j in range(_u(0), n8):
            Kiso[i, j] = 0.0
    for k in range(used.shape[0]):
        p = used[k]
        F = PF[p]
        Q = PQ[p]
        T = PT[p]
        R = PR[p]
        X0 = PX[p, 0]
        X1 = PX[p, 1]
        d = Pd[p]
        da = Pda[p]
        co = Pco[p]
        s = Ps[p]
        gg = pt_gauss[p]
        bend = s[3] != 0.0 or s[4] != 0.0 or s[5] != 0.0
        if gg < 0:
            h2 = 0.5 * s[2]
            for i in range(6):
                a0 = _PI8[p, 0, i]
                a1 = _PI8[p, 1, i]
                u = s[0] * a0 + h2 * a1
                v = s[1] * a1 + h2 * a0
                for j in range(_u(0), n8):
                    Kiso[i, j] += u * _PI8[p, 0, j] + v * _PI8[p, 1, j]
            if not bend and s[6] == 0.0 and s[7] == 0.0:
                continue
        _strain_gradient_T(F, s, g)
        ns = 6 if (bend or gg >= 0) else 4
        _geometric_core(s, g, F, Q, T, R, X0, X1, d, da, co, core, ns, gg >= 0, t0, t1, t2, t3, t4, t5)
        if gg < 0:
            _expand_core_rot(core, ns, p, Y, Kz)
            continue
        if gg >= 0:
            nl = n_loc[gg]
            for li in range(nl):
                for c in range(12):
                    Dl[li, c] = 0.0
            for q in range(loc_ptr[gg], loc_ptr[gg + 1]):
                _add_strain_gradient_row(F, loc_j[q], loc_v[q], Dl, loc_i[q])
            for li in range(nl):
                _GT_times(Dl, li, F, Q, T, R, X0, X1, Bl, li)
            n18 = _u(Bl.shape[1])
            for li in range(nl):
                for c in range(_u(0), n18):
                    CBl[li, c] = 0.0
                for lj in range(nl):
                    w = Ch[gg, loc_rows[gg, li], loc_rows[gg, lj]]
                    for c in range(_u(0), n18):
                        CBl[li, c] += w * Bl[lj, c]
            # core += Bl^T CBl, row by row with four (three, one) B rows per loop
            for r in range(18):
                a = 0
                while a + 4 <= nl:
                    b0 = Bl[a, r]
                    b1 = Bl[a + 1, r]
                    b2 = Bl[a + 2, r]
                    b3 = Bl[a + 3, r]
                    for c in range(_u(0), n18):
                        core[r, c] += b0 * CBl[a, c] + b1 * CBl[a + 1, c] + b2 * CBl[a + 2, c] + b3 * CBl[a + 3, c]
                    a += 4
                if a + 3 <= nl:
                    b0 = Bl[a, r]
                    b1 = Bl[a + 1, r]
                    b2 = Bl[a + 2, r]
                    for c in range(_u(0), n18):
                        core[r, c] += b0 * CBl[a, c] + b1 * CBl[a + 1, c] + b2 * CBl[a + 2, c]
                    a += 3
                while a < nl:
                    b0 = Bl[a, r]
                    for c in range(_u(0), n18):
                        core[r, c] += b0 * CBl[a, c]
                    a += 1
        _expand_core(core, ns, p, Y, Kz)
