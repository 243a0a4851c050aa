"""Strains and stress resultants at the Gauss points of the six-node shell kernel (stage ``material``).

The assumed (MITC) covariant strains at the Gauss points from the evaluation points (:func:`_gauss_strains`,
through the compressed map of :class:`flexbody.shell.maps.CompressedMaps`), the stress weights of the points
(:func:`_stress_weights`: C applied at the Gauss points, pulled back to the evaluation points;
:func:`_given_stress_weights` for given stress resultants), the section stiffness congruent to the covariant
strains at the Gauss points (:func:`_section_cov`, :func:`_block_cov`) and the material stiffness of the
nonlocal assumed-strain rows (:func:`_nonlocal_material`): one symmetric rank-npar update S^T (sum_g M_g^T C_g
M_g) S per element, the rows S_k of the rotation-free (membrane) parameters W_k x.

With the tension-field membrane law (``ShellMaterial.wrinkling``), :func:`_relaxed_stress_weights` takes the
place of both :func:`_stress_weights` and :func:`_section_cov`: per Gauss point the Cartesian strains
eps_g = T_g cov_g, the law (:func:`_tension_field`, the twin of
:func:`flexbody.shell.reference.material.tension_field_membrane`) for the stresses sigma_g and the point tangent
C_t(eps_g), then st_g = w_g T_g^T sigma_g and Ch_g = w_g T_g^T C_t T_g.
"""

from __future__ import annotations

import math

from flexbody._numba import fast as jit, inline as inl, uint as _u
from flexbody.shell.geometry import N_GAUSS
from flexbody.shell.kernels.expansion import _expand_vec_scaled, _rank_update_block
from flexbody.shell.kernels.layout import _KR, _ZR
from flexbody.shell.kernels.points import _GT_times, _add_strain_gradient_row


@inl
def _assumed_cov(a_ptr, a_p, a_j, a_v, Pe, cov):
    """cov[g, i] = sum_pj A[g, i, p, j] Pe[p, j] (A by rows: a_ptr over g * 8 + i).

    The stored indices are read as unsigned (:data:`flexbody._numba.uint`): numba then drops the wraparound
    test of a negative index at every nonzero (this gather and :func:`_pull_back` took twice as long).
    """
    for gg in range(N_GAUSS):
        for i in range(8):
            r = 8 * gg + i
            acc = 0.0
            for q in range(_u(a_ptr[r]), _u(a_ptr[r + 1])):
                acc += a_v[q] * Pe[_u(a_p[q]), _u(a_j[q])]
            cov[gg, i] = acc


@inl
def _cartesian_strains(e, gg, to_cart, cov, eps):
    """eps[r] = (T_g cov_g)[r], r < 8: the Cartesian strains of Gauss point gg (eps: 8 or more entries)."""
    for r in range(8):
        acc = 0.0
        for c in range(8):
            acc += to_cart[e, gg, r, c] * cov[gg, c]
        eps[r] = acc


@inl
def _covariant_stress(e, gg, to_cart, w, v16, st):
    """st[gg, c] = w (T_g^T sigma_g)[c] of the Cartesian stresses sigma_g in v16[8:16]."""
    for c in range(8):
        acc = 0.0
        for r in range(8):
            acc += to_cart[e, gg, r, c] * v16[8 + r]
        st[gg, c] = w * acc


@jit
def _gauss_strains(e, to_cart, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, Pe, cov, out):
    """Assumed covariant strains at the Gauss points and their Cartesian components out[e] (7, 8)."""
    _assumed_cov(a_ptr, a_p, a_j, a_v, Pe, cov)
    for gg in range(N_GAUSS):
        _cartesian_strains(e, gg, to_cart, cov, out[e, gg])


@jit
def _stress_weights(e, used, to_cart, weights, C, Ch, use_ch, a_ptr, a_p, a_j, a_v, Pe, cov, st, v16, Ps):
    """Covariant stress weights Ps[p] = sum_g w_g (T_g A_g)^T C T_g A_g e at the used points.

    With use_ch the covariant sections Ch_g = w_g T_g^T C T_g (already formed for the tangent) are used.
    """
    _assumed_cov(a_ptr, a_p, a_j, a_v, Pe, cov)
    for gg in range(N_GAUSS):
        if use_ch:
            for r in range(8):
                acc = 0.0
                for c in range(8):
                    acc += Ch[gg, r, c] * cov[gg, c]
                st[gg, r] = acc
            continue
        w = weights[e, gg]
        _cartesian_strains(e, gg, to_cart, cov, v16)
        for r in range(8):
            acc = 0.0
            for c in range(8):
                acc += C[r, c] * v16[c]
            v16[8 + r] = w * acc
        _covariant_stress(e, gg, to_cart, 1.0, v16, st)
    _pull_back(used, a_ptr, a_p, a_j, a_v, st, Ps)


@inl
def _pull_back(used, a_ptr, a_p, a_j, a_v, st, Ps):
    """Ps[p, j] = sum_g,i A[g, i, p, j] st[g, i] at the used points, scattered from the rows of A (a_ptr over
    g * 8 + i; unsigned indices as in :func:`_assumed_cov`).

    Each Ps[p, j] receives its terms in the order of the rows (g, i), the order of a gather down the columns of A:
    the same sums, bit for bit, without the gather's chains of dependent additions (a third faster).
    """
    for k in range(used.shape[0]):
        p = _u(used[k])
        for j in range(8):
            Ps[p, j] = 0.0
    for gg in range(N_GAUSS):
        for i in range(8):
            r = 8 * gg + i
            s = st[gg, i]
            for q in range(_u(a_ptr[r]), _u(a_ptr[r + 1])):
                Ps[_u(a_p[q]), _u(a_j[q])] += a_v[q] * s


@jit
def _given_stress_weights(e, used, to_cart, weights, stress, a_ptr, a_p, a_j, a_v, st, Ps):
    """Ps[p] = sum_g w_g (T_g A_g)^T stress[e, g] at the used points: the covariant weights of given
    Cartesian stress resultants (the independent stresses of the mixed Newton iteration)."""
    for gg in range(N_GAUSS):
        w = weights[e, gg]
        for c in range(8):
            acc = 0.0
            for r in range(8):
                acc += to_cart[e, gg, r, c] * stress[e, gg, r]
            st[gg, c] = w * acc
    _pull_back(used, a_ptr, a_p, a_j, a_v, st, Ps)


@inl
def _block_cov(e, gg, to_cart, C, cblk, a, b, w, Ch):
    """Ch_g[block a, block b] = w T_a^T C_ab T_b (zero without coupling) for a block diagonal T_g."""
    a0 = 3 * a
    b0 = 3 * b
    na = 3 if a < 2 else 2
    nb = 3 if b < 2 else 2
    if cblk[a, b] == 0:
        for i in range(na):
            for j in range(nb):
                Ch[gg, a0 + i, b0 + j] = 0.0
        return
    for i in range(na):
        for j in range(nb):
            acc = 0.0
            for k in range(na):
                ct = 0.0
                for m in range(nb):
                    ct += C[a0 + k, b0 + m] * to_cart[e, gg, b0 + m, b0 + j]
                acc += to_cart[e, gg, a0 + k, a0 + i] * ct
            Ch[gg, a0 + i, b0 + j] = w * acc


@jit
def _section_cov(e, to_cart, weights, C, cblk, CT, Ch):
    """Covariant section per Gauss point: Ch_g = w_g T_g^T C T_g.

    T_g (to_cart) maps each strain block (membrane, bending, shear) to itself on reference elements (block
    diagonal): then only the blocks of C that are nonzero (cblk) are transformed. Otherwise the dense product.
    """
    n8 = _u(CT.shape[1])
    for gg in range(N_GAUSS):
        w = weights[e, gg]
        off = 0.0
        for r in range(3):
            for c in range(3, 8):
                off += abs(to_cart[e, gg, r, c]) + abs(to_cart[e, gg, c, r])
        for r in range(3, 6):
            for c in range(6, 8):
                off += abs(to_cart[e, gg, r, c]) + abs(to_cart[e, gg, c, r])
        if off == 0.0:
            for a in range(3):
                _block_cov(e, gg, to_cart, C, cblk, a, 0, w, Ch)
                _block_cov(e, gg, to_cart, C, cblk, a, 1, w, Ch)
                _block_cov(e, gg, to_cart, C, cblk, a, 2, w, Ch)
            continue
        for r in range(8):
            for c in range(_u(0), n8):
                CT[r, c] = 0.0
            for k in range(8):
                ck = C[r, k]
                if ck != 0.0:
                    for c in range(_u(0), n8):
                        CT[r, c] += ck * to_cart[e, gg, k, c]
        for r in range(8):
            for c in range(_u(0), n8):
                Ch[gg, r, c] = 0.0
            for k in range(8):
                tk = to_cart[e, gg, k, r]
                if tk != 0.0:
                    tk *= w
                    for c in range(_u(0), n8):
                        Ch[gg, r, c] += tk * CT[k, c]


@jit
def _nonlocal_material(x, par_p, par_ptr, par_j, par_v, pl_ptr, pl_k, pl_v, w2, has_w, n_rf,
                       nl_rows, n_nl, m_ptr, m_i, m_k, m_v, m_dense,
                       PF, PQ, PT, PR, PX, Ch, G2, phi, Sp, Wp, Cp, Yp, Kz):
    """Kz += S^T C_par S: parameters S (z rows) and C_par = sum_g M_g^T Ch_g[nl, nl] M_g (pattern of Kz).

    The first n_rf parameters are rotation-free (membrane combinations): S_k = W_k x (translations only, W_k
    constant 6 x 6 from the shape functions). The others get the rotation-free part W_k x plus combinations
    of point rows Pi_p^T G_p^T D_p^T v (the point parameters par_*, pl_* their weights in S).
    """
    npar = has_w.shape[0]
    nz = _u(Kz.shape[1])
    n_rows = Sp.shape[0]
    for a in range(n_rows):
        for c in range(_u(0), nz):
            Sp[a, c] = 0.0
            Wp[a, c] = 0.0
    for k in range(npar):
        if has_w[k]:
            for c in range(3):
                x0 = x[0, c]
                x1 = x[1, c]
                x2 = x[2, c]
                x3 = x[3, c]
                x4 = x[4, c]
                x5 = x[5, c]
                for i in range(6):
                    Sp[k, 8 * c + i] = (w2[k, i, 0] * x0 + w2[k, i, 1] * x1 + w2[k, i, 2] * x2
                                        + w2[k, i, 3] * x3 + w2[k, i, 4] * x4 + w2[k, i, 5] * x5)
    for kp in range(par_p.shape[0]):
        p = par_p[kp]
        F = PF[p]
        for c in range(12):
            G2[0, c] = 0.0
        for q in range(par_ptr[kp], par_ptr[kp + 1]):
            _add_strain_gradient_row(F, par_j[q], par_v[q], G2, 0)
        _GT_times(G2, 0, F, PQ[p], PT[p], PR[p], PX[p, 0], PX[p, 1], phi, 0)
        for q in range(pl_ptr[kp], pl_ptr[kp + 1]):
            _expand_vec_scaled(phi, 0, pl_v[q], p, Sp, pl_k[q])
    for a in range(npar):
        for b in range(npar):
            Cp[a, b] = 0.0
    for gg in range(N_GAUSS):
        nn = n_nl[gg]
        if nn == 0:
            continue
        # Yp = Ch_g[nl, nl] M_g (rows of M_g dense in m_dense) ; Cp += M_g^T Yp
        for li in range(nn):
            for b in range(_u(0), _u(npar)):
                Yp[li, b] = 0.0
            for lj in range(nn):
                w = Ch[gg, nl_rows[gg, li], nl_rows[gg, lj]]
                if w != 0.0:
                    for b in range(_u(0), _u(npar)):
                        Yp[li, b] += w * m_dense[gg, lj, b]
        for q in range(m_ptr[gg], m_ptr[gg + 1]):
            v = m_v[q]
            a = m_k[q]
            li = m_i[q]
            for b in range(_u(0), _u(npar)):
                Cp[a, b] += v * Yp[li, b]
    # Wp = Cp Sp (rotation columns only from the parameters with rotations)
    for a in range(npar):
        for b in range(0, npar - 3, 4):
            w0 = Cp[a, b]
            w1 = Cp[a, b + 1]
            w2_ = Cp[a, b + 2]
            w3 = Cp[a, b + 3]
            for c in range(_u(0), _u(_ZR)):
                Wp[a, c] += w0 * Sp[b, c] + w1 * Sp[b + 1, c] + w2_ * Sp[b + 2, c] + w3 * Sp[b + 3, c]
        for b in range(4 * (npar // 4), npar):
            w0 = Cp[a, b]
            for c in range(_u(0), _u(_ZR)):
                Wp[a, c] += w0 * Sp[b, c]
        for b in range(n_rf, npar - 3, 4):
            w0 = Cp[a, b]
            w1 = Cp[a, b + 1]
            w2_ = Cp[a, b + 2]
            w3 = Cp[a, b + 3]
            for c in range(_u(_ZR), nz):
                Wp[a, c] += w0 * Sp[b, c] + w1 * Sp[b + 1, c] + w2_ * Sp[b + 2, c] + w3 * Sp[b + 3, c]
        for b in range(max(n_rf, n_rf + 4 * ((npar - n_rf) // 4)), npar):
            w0 = Cp[a, b]
            for c in range(_u(_ZR), nz):
                Wp[a, c] += w0 * Sp[b, c]
    # Kz += Sp^T Wp on the pattern of _expand_core (groups of four rows, zero padded): translation rows from
    # their own block on (the lower blocks are mirrored), rotation rows from the rotating parameters only
    for a in range(0, npar, 4):
        for c in range(3):
            _rank_update_block(Kz, 8 * c, _u(8 * c), Sp, Wp, a)
    for a in range(n_rf, npar, 4):
        for c in range(3):
            _rank_update_block(Kz, _ZR + 8 * c, _u(_KR), Sp, Wp, a)


@inl
def _tension_field(e11, e22, g12, C, Ct, sig):
    """The tension-field membrane law at one point (:func:`flexbody.shell.reference.material.tension_field_membrane`):
    the membrane forces sig[0:3] and the tangent Ct[0:3, 0:3] of the strains [e11, e22, g12 = 2 e12], for the
    isotropic membrane block C[0:3, 0:3] (taut: C eps and C; slack: zero; wrinkled: uniaxial tension)."""
    c11 = C[0, 0]
    c12 = C[0, 1]
    Eh = c11 - c12 * c12 / c11
    nu = c12 / c11
    mean = 0.5 * (e11 + e22)
    radius = math.hypot(0.5 * (e11 - e22), 0.5 * g12)
    e1 = mean + radius
    e2 = mean - radius
    if e2 + nu * e1 > 0.0:                           # taut: the linear law
        for r in range(3):
            sig[r] = C[r, 0] * e11 + C[r, 1] * e22 + C[r, 2] * g12
            for c in range(3):
                Ct[r, c] = C[r, c]
        return
    if e1 <= 0.0:                                    # slack
        for r in range(3):
            sig[r] = 0.0
            for c in range(3):
                Ct[r, c] = 0.0
        return
    t = 0.5 * math.atan2(g12, e11 - e22)             # wrinkled: e1 - e2 >= (1 + nu) e1 > 0
    n1 = math.cos(t)
    n2 = math.sin(t)
    m1 = -n2
    m2 = n1
    p0 = n1 * n1
    p1 = n2 * n2
    p2 = n1 * n2
    q0 = 2.0 * n1 * m1
    q1 = 2.0 * n2 * m2
    q2 = n1 * m2 + n2 * m1
    a = Eh * e1
    b = a / (2.0 * (e1 - e2))
    sig[0] = a * p0
    sig[1] = a * p1
    sig[2] = a * p2
    Ct[0, 0] = Eh * p0 * p0 + b * q0 * q0
    Ct[0, 1] = Eh * p0 * p1 + b * q0 * q1
    Ct[0, 2] = Eh * p0 * p2 + b * q0 * q2
    Ct[1, 1] = Eh * p1 * p1 + b * q1 * q1
    Ct[1, 2] = Eh * p1 * p2 + b * q1 * q2
    Ct[2, 2] = Eh * p2 * p2 + b * q2 * q2
    Ct[1, 0] = Ct[0, 1]
    Ct[2, 0] = Ct[0, 2]
    Ct[2, 1] = Ct[1, 2]


@jit
def _relaxed_stress_weights(e, used, to_cart, weights, C, want_tangent, a_ptr, a_p, a_j, a_v, Pe, cov, st, v16,
                            Ct, CT, Ch, Ps):
    """The tension-field membrane's covariant stress weights Ps (as :func:`_stress_weights`) and, with
    want_tangent, its covariant point tangents Ch_g = w_g T_g^T C_t(eps_g) T_g (as :func:`_section_cov`).

    Per Gauss point: eps_g = T_g cov_g (v16[:8]), the law on the membrane block, C eps_g on the others
    (bending and transverse shear stay linear; the section has no membrane coupling), st_g = w_g T_g^T sigma_g.
    """
    _assumed_cov(a_ptr, a_p, a_j, a_v, Pe, cov)
    for gg in range(N_GAUSS):
        w = weights[e, gg]
        _cartesian_strains(e, gg, to_cart, cov, v16)
        for r in range(8):
            for c in range(8):
                Ct[r, c] = C[r, c]
        _tension_field(v16[0], v16[1], v16[2], C, Ct, v16[8:11])
        for r in range(3, 8):
            acc = 0.0
            for c in range(8):
                acc += C[r, c] * v16[c]
            v16[8 + r] = acc
        _covariant_stress(e, gg, to_cart, w, v16, st)
        if not want_tangent:
            continue
        for r in range(8):
            for c in range(8):
                acc = 0.0
                for k in range(8):
                    acc += Ct[r, k] * to_cart[e, gg, k, c]
                CT[r, c] = acc
        for r in range(8):
            for c in range(8):
                acc = 0.0
                for k in range(8):
                    acc += to_cart[e, gg, k, r] * CT[k, c]
                Ch[gg, r, c] = w * acc
    _pull_back(used, a_ptr, a_p, a_j, a_v, st, Ps)
