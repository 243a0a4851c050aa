"""The fast element: numba kernels for the internal force and tangent of the six-node SE(3) shell.

Computes, for a batch of elements, exactly what :func:`flexbody.shell.element_reference.internal_force_tangent`
computes (the same strains and the same terms of the second variation), arranged so that nothing is a dense
(8 x 136) or (12 x 36) product at a point:

1. **Relative coordinates.** Per element the 36 local nodal motions h = [u_I, theta_I] are mapped to
   z = [dx_I, dtheta_0, dd_1..dd_5], dx_I = R_I du_I (global translations) and the variations of the relative
   rotation vectors dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0 (paper Eq. 31): z = P h. In z every point
   quantity is a *scalar* (shape function) combination of a few 3x3 blocks. z is stored component-major,
   translations first: dx_I[c] at 8c + I, rotations (dtheta_0, dd_I)[c] at 24 + 8c + I (8 lanes).
2. **Point slots.** At an evaluation point the strain measures depend on z only through 18 numbers
   xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi z (Pi holds N_I, dN_I). The Jacobian G (12 x 18), the B
   rows and the contracted second variation (18 x 18) are formed in xi from closed-form 3x3 blocks and
   expanded once per point into z in two sparse stages. Only the rotation-rotation block of the second
   variation is non-symmetric: the translation rows are accumulated as an upper block triangle, the rotation
   block in full (see _KR).
3. **Node terms.** K_h = P^T K_z P + (D P^T[.]) f_z: the derivative of P gives hat(f_u,I) in the (u_I, theta_I)
   block and the D T^-1 terms of Delta(delta d_I), contracted with f_z at dd_I (which equals the reference's
   sum over points of N_I g_d + dN_I . g_da).

The assumed-strain map A (7, 8, 17, 8) is compressed in Python (:class:`CompressedMaps`): rows of a Gauss point
that only use that Gauss point ("local": bending; all rows with tying off) enter the point's 18 x 18 slot matrix;
the other rows ("nonlocal": membrane and shear with tying on) are factored exactly, A_nl = M E, through a
minimal set of parameters E: the independent sampled combinations at each point (e_rr, e_ss, e_rs at a membrane
tying point, e_qt on the hypotenuse, ...), then reduced to a basis of what the rows use (the element means of
the "mean" membrane tying combine samples of seven points: 9 membrane and 8 shear parameters for MITC6 with
either scheme). Their material stiffness is one symmetric rank-17 update S^T (sum_g M_g^T C_g M_g) S per
element; the rows S_k of the membrane parameters (rotation-free) are W_k x, constant 6 x 6 matrices W_k of
the shape functions times the nodal positions. Evaluation points that no row uses are skipped.

The mixed Newton iteration (docs/theory.md) needs two more things, both here: the tangent whose geometric
terms carry given Gauss-point stresses (``stress=`` of :func:`internal_force_tangent_batch`: the point
weights Ps and the node terms are those of the given stresses, the force stays that of the strains), and the
strains linearized along a nodal motion, B dh (:func:`linearized_strains_batch`, from the point kinematics).

SO(3): :mod:`flexbody.lie.kernels`, the only numba code of these formulas: ``log_into``, the coefficients
of a point computed once (``point_coefficients_into``, ``inverse_coefficients``: closed forms above the series
switch, the Taylor series ``so3.SERIES`` fused below), and the maps that take them (``exp_co_into``,
``tangent_co_into``, ``tangent_inv_co_into``, ``d_tangent_co_into``, ``d_tangent_inv_co_into``,
``d2_tangent_co_into``; a point needs up to eight), inlined.

Performance notes: the small helpers are inlined at numba-IR level so that the per-point functions contain no
calls; the kernels are compiled without reference counting and with noalias array arguments (see flexbody._numba), so
that point data are read through views of the per-point arrays at no cost; the element loop runs inside one
function per chunk of elements (flexbody.chunks: one chunk on one thread, a few per thread otherwise), whose
workspaces are allocated once per chunk, and
prefetches the next element's data. Nothing is allocated per element or point. The section stiffness must be
symmetric.
"""

from __future__ import annotations

import math

import numpy as np

from flexbody import _numba
from flexbody.chunks import n_chunks as _n_chunks, run_chunks, scratch
from flexbody._numba import prefetch as _prefetch
from flexbody.kernel_arrays import kernel_input as _as
from flexbody.lie import kernels as lk
from flexbody.shell.geometry import EVAL_DN, EVAL_N, GAUSS_OFFSET, N_GAUSS
from flexbody.shell.mitc6 import N_TYING

N_EVAL = N_TYING + N_GAUSS
NDOF = 36

# The jit policy of flexbody._numba: the kernels below never allocate (no reference counting, noalias array
# arguments: no two array arguments of a kernel overlap), FMA contraction allowed.
jit = _numba.fast
inl = _numba.inline
_u = _numba.uint  # unsigned inner-loop indices with run-time bounds: lets LLVM vectorize the loops

_EN = np.ascontiguousarray(EVAL_N, dtype=np.float64)     # (17, 6)
_EDN = np.ascontiguousarray(EVAL_DN, dtype=np.float64)   # (17, 2, 6)


# slots of the point coordinates xi (3 components each)
_U0, _U1, _V0, _V, _W0, _W1 = 0, 1, 2, 3, 4, 5

# z is stored component-major and padded to 8 lanes: dx_I[c] at 8c + I, (dtheta_0, dd_I)[c] at 24 + 8c + I
NZ = 48
_ZR = 24
# The tangent in z is accumulated on a pattern: the translation rows of component c from column 8c (the upper
# block triangle of the symmetric part), the rotation rows in the rotation columns from _KR; the rest is
# overwritten by the mirror in _finish_tangent.
_KR = 24


def _slot_weights() -> np.ndarray:
    """Pi per point as 8-lane rows: (17, 6 slots, 8); translation slots U0, U1 act on dx, the others on rotations."""
    w = np.zeros((N_EVAL, 6, 8))
    w[:, _U0, :6] = EVAL_DN[:, 0]
    w[:, _U1, :6] = EVAL_DN[:, 1]
    w[:, _V0, 0] = 1.0
    w[:, _V, 1:6] = EVAL_N[:, 1:]
    w[:, _W0, 1:6] = EVAL_DN[:, 0, 1:]
    w[:, _W1, 1:6] = EVAL_DN[:, 1, 1:]
    return w


_PI8 = _slot_weights()


# ----------------------------------------------------------------------------------------------------------
# 3x3 helpers (inlined)
# ----------------------------------------------------------------------------------------------------------


@inl
def _mm(A, B, out):
    """out = A B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@inl
def _mmT(A, B, out):
    """out = A B^T."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[j, 0] + A[i, 1] * B[j, 1] + A[i, 2] * B[j, 2]


@inl
def _mTm(A, B, out):
    """out = A^T B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[0, i] * B[0, j] + A[1, i] * B[1, j] + A[2, i] * B[2, j]


@inl
def _Rhat(R, v0, v1, v2, out):
    """out = R hat(v)."""
    for i in range(3):
        r0 = R[i, 0]
        r1 = R[i, 1]
        r2 = R[i, 2]
        out[i, 0] = r1 * v2 - r2 * v1
        out[i, 1] = r2 * v0 - r0 * v2
        out[i, 2] = r0 * v1 - r1 * v0


@inl
def _add_blk(core, s, t, M, alpha):
    """core[block s, block t] += alpha M."""
    for i in range(3):
        for j in range(3):
            core[3 * s + i, 3 * t + j] += alpha * M[i, j]


@inl
def _add_blk_both(core, s, t, M, alpha):
    """core[block s, block t] += alpha M and core[block t, block s] += alpha M^T."""
    for i in range(3):
        for j in range(3):
            v = alpha * M[i, j]
            core[3 * s + i, 3 * t + j] += v
            core[3 * t + j, 3 * s + i] += v


# ----------------------------------------------------------------------------------------------------------
# SO(3) at the points and nodes: the coefficients once per point (flexbody.lie.kernels.point_coefficients_into:
# lk.coefficients above the series switch, the same series fused below), then the maps of flexbody.lie.kernels
# that take them (inlined)
# ----------------------------------------------------------------------------------------------------------


@jit
def _point_coefficients(used, Pd, Pco):
    """Pco[p] = (a1, a2, a3, a4, c2, c3, c4, e2, e3) at |d_p| for the used points (a4, c4 unused)."""
    for k in range(used.shape[0]):
        p = used[k]
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
        lk.log_into(M, dn[i])
        d0 = dn[i, 0]
        d1 = dn[i, 1]
        d2 = dn[i, 2]
        pp = d0 * d0 + d1 * d1 + d2 * d2
        a4, c4 = lk.inverse_coefficients(math.sqrt(pp))
        ninv[i, 0] = a4
        ninv[i, 1] = c4
        lk.tangent_inv_co_into((d0, d1, d2), a4, Ti[i])


# ----------------------------------------------------------------------------------------------------------
# Point kinematics (per point data stored by point index)
# ----------------------------------------------------------------------------------------------------------


@inl
def _prefetch_block(a, start, n, write):
    """Prefetch the elements start .. start + n - 1 of a (flat): one hint per cache line, and the last one."""
    for q in range(start, start + n, 8):
        _prefetch(a, q, write)
    _prefetch(a, start + n - 1, write)


_AHEAD = 2   # elements prefetched ahead (a few microseconds each)


@jit
def _prefetch_element(e, x_el, fr_el, e_ref, to_cart, weights, want_tangent, K):
    """Prefetch the inputs (and the tangent, to be written) of element e, ahead of its evaluation.

    The element data are read (written) once, in bursts of a few kB per element that the hardware prefetchers
    miss: without the hints the reads of to_cart alone stall for about 1 us per element.
    """
    _prefetch_block(x_el, 18 * e, 18, False)
    _prefetch_block(fr_el, 54 * e, 54, False)
    _prefetch_block(e_ref, 8 * N_EVAL * e, 8 * N_EVAL, False)
    _prefetch_block(to_cart, 64 * N_GAUSS * e, 64 * N_GAUSS, False)
    _prefetch_block(weights, N_GAUSS * e, N_GAUSS, False)
    if want_tangent:
        _prefetch_block(K, NDOF * NDOF * e, NDOF * NDOF, True)


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
        p = used[k]
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


@jit
def _kinematics_points(used, x, fr, Pd, Pda, Pco, PQ, PT, PR, PF, PX):
    """Q = exp(d), T(d), R = R_0 Q, F = [f_ru, f_su, f_rw, f_sw], X_a = DT(d)[.] d_,a at the used points.

    (X is computed also where only the strains are wanted: one compiled version serves every caller.)
    """
    for k in range(used.shape[0]):
        p = used[k]
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
        # f_au = R^T x_,a ;  f_aw = T d_,a
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
                PF[p, 2 + a, c] = T[c, 0] * Pda[p, a, 0] + T[c, 1] * Pda[p, a, 1] + T[c, 2] * Pda[p, a, 2]
        lk.d_tangent_co_into((d0, d1, d2), (Pda[p, 0, 0], Pda[p, 0, 1], Pda[p, 0, 2]), co, PX[p, 0])
        lk.d_tangent_co_into((d0, d1, d2), (Pda[p, 1, 0], Pda[p, 1, 1], Pda[p, 1, 2]), co, PX[p, 1])


@jit
def _strains_points(e, used, e_ref, PF, Pe):
    """Pe[p] = covariant_strains(F_p) - e_ref[e, p] (kinematics.covariant_strains)."""
    for k in range(used.shape[0]):
        p = used[k]
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


@inl
def _assumed_cov(a_ptr, a_p, a_j, a_v, Pe, cov):
    """cov[g, i] = sum_pj A[g, i, p, j] Pe[p, j] (A by rows: a_ptr over g * 8 + i)."""
    for gg in range(N_GAUSS):
        for i in range(8):
            r = 8 * gg + i
            acc = 0.0
            for q in range(a_ptr[r], a_ptr[r + 1]):
                acc += a_v[q] * Pe[a_p[q], a_j[q]]
            cov[gg, i] = acc


@jit
def _gauss_strains(e, to_cart, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, Pe, cov, out):
    """Assumed covariant strains at the Gauss points and their Cartesian components out[e] (7, 8)."""
    _assumed_cov(a_ptr, a_p, a_j, a_v, Pe, cov)
    for gg in range(N_GAUSS):
        for r in range(8):
            acc = 0.0
            for c in range(8):
                acc += to_cart[e, gg, r, c] * cov[gg, c]
            out[e, gg, r] = acc


@jit
def _stress_weights(e, used, to_cart, weights, C, Ch, use_ch, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v,
                    Pe, cov, st, v16, Ps):
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
        for r in range(8):
            acc = 0.0
            for c in range(8):
                acc += to_cart[e, gg, r, c] * cov[gg, c]
            v16[r] = acc
        for r in range(8):
            acc = 0.0
            for c in range(8):
                acc += C[r, c] * v16[c]
            v16[8 + r] = w * acc
        for c in range(8):
            acc = 0.0
            for r in range(8):
                acc += to_cart[e, gg, r, c] * v16[8 + r]
            st[gg, c] = acc
    _pull_back(used, at_ptr, at_g, at_i, at_v, st, Ps)


@inl
def _pull_back(used, at_ptr, at_g, at_i, at_v, st, Ps):
    """Ps[p, j] = sum_g,i A[g, i, p, j] st[g, i] at the used points (A by columns: at_ptr over p * 8 + j)."""
    for k in range(used.shape[0]):
        p = used[k]
        for j in range(8):
            c = 8 * p + j
            acc = 0.0
            for q in range(at_ptr[c], at_ptr[c + 1]):
                acc += at_v[q] * st[at_g[q], at_i[q]]
            Ps[p, j] = acc


@jit
def _given_stress_weights(e, used, to_cart, weights, stress, at_ptr, at_g, at_i, at_v, st, Ps):
    """Ps[p] = sum_g w_g (T_g A_g)^T stress[e, g] at the used points: the covariant weights of given
    Cartesian stress resultants (the independent stresses of the mixed Newton iteration)."""
    for gg in range(N_GAUSS):
        w = weights[e, gg]
        for c in range(8):
            acc = 0.0
            for r in range(8):
                acc += to_cart[e, gg, r, c] * stress[e, gg, r]
            st[gg, c] = w * acc
    _pull_back(used, at_ptr, at_g, at_i, at_v, st, Ps)


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


# ----------------------------------------------------------------------------------------------------------
# Slot expansion xi -> z (Pi); z component-major: dx_I[c] at 6c + I, rotations[c] at 18 + 6c + I
# ----------------------------------------------------------------------------------------------------------


@inl
def _expand_vec(V, vrow, p, out, orow):
    """out[orow] (z, NZ) += Pi_p^T V[vrow] (18 slot components)."""
    n8 = _u(out.shape[1]) // _u(6)
    for c in range(3):
        u0 = V[vrow, c]
        u1 = V[vrow, 3 + c]
        r0 = V[vrow, 6 + c]
        rv = V[vrow, 9 + c]
        w0 = V[vrow, 12 + c]
        w1 = V[vrow, 15 + c]
        ot = 8 * c
        orot = _ZR + 8 * c
        for i in range(_u(0), n8):
            out[orow, ot + i] += _PI8[p, 0, i] * u0 + _PI8[p, 1, i] * u1
            out[orow, orot + i] += (_PI8[p, 2, i] * r0 + _PI8[p, 3, i] * rv + _PI8[p, 4, i] * w0
                                    + _PI8[p, 5, i] * w1)


@jit
def _force_points(used, PF, PQ, PT, PR, PX, Ps, g, G2, phi, fz):
    """fz (z, row 0) = sum_p Pi_p^T G_xi^T D^T s_p."""
    for r in range(NZ):
        fz[0, r] = 0.0
    for k in range(used.shape[0]):
        p = used[k]
        F = PF[p]
        _strain_gradient_T(F, Ps[p], g)
        for c in range(12):
            G2[0, c] = g[c]
        _GT_times(G2, 0, F, PQ[p], PT[p], PR[p], PX[p, 0], PX[p, 1], phi, 0)
        _expand_vec(phi, 0, p, fz, 0)


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


# ----------------------------------------------------------------------------------------------------------
# Tangent: points, nonlocal material rows, change of variables
# ----------------------------------------------------------------------------------------------------------


_BLOCK0 = np.array([0, 3, 6, 8], np.int64)   # strain blocks: membrane, bending, shear


def _section_blocks(C: np.ndarray) -> np.ndarray:
    """(3, 3) flags: does the section couple strain blocks a and b (membrane, bending, shear)?"""
    return np.array([[np.any(C[_BLOCK0[a]:_BLOCK0[a + 1], _BLOCK0[b]:_BLOCK0[b + 1]] != 0.0) for b in range(3)]
                     for a in range(3)], np.int64)


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


@inl
def _expand_core(core, ns, p, Y, Kz):
    """Kz += Pi^T core Pi (z padded, NZ) on the accumulation pattern (see _KR).

    Loops are blocked (one loop per core row in stage 1, one per component block of six rows in stage 2) so
    that few, long loops vectorize.
    """
    nr = 3 * ns
    nz = _u(Kz.shape[1])     # run-time trip counts (48, 8): see _u
    n8 = nz // _u(6)
    # stage 1: Y = core Pi (nr x NZ); the rotation-slot rows only in the rotation columns (their translation
    # columns would land in the rotation-translation block of Kz, which _finish_tangent mirrors)
    for r in range(6):
        a0 = core[r, 0]
        a1 = core[r, 1]
        a2 = core[r, 2]
        b0 = core[r, 3]
        b1 = core[r, 4]
        b2 = core[r, 5]
        c0 = core[r, 6]
        c1 = core[r, 7]
        c2 = core[r, 8]
        d0 = core[r, 9]
        d1 = core[r, 10]
        d2 = core[r, 11]
        if ns == 6:
            e0 = core[r, 12]
            e1 = core[r, 13]
            e2 = core[r, 14]
            f0 = core[r, 15]
            f1 = core[r, 16]
            f2 = core[r, 17]
        else:
            e0 = e1 = e2 = f0 = f1 = f2 = 0.0
        for i in range(_u(0), n8):
            p0 = _PI8[p, 0, i]
            p1 = _PI8[p, 1, i]
            p2 = _PI8[p, 2, i]
            p3 = _PI8[p, 3, i]
            p4 = _PI8[p, 4, i]
            p5 = _PI8[p, 5, i]
            Y[r, i] = p0 * a0 + p1 * b0
            Y[r, 8 + i] = p0 * a1 + p1 * b1
            Y[r, 16 + i] = p0 * a2 + p1 * b2
            Y[r, 24 + i] = p2 * c0 + p3 * d0 + p4 * e0 + p5 * f0
            Y[r, 32 + i] = p2 * c1 + p3 * d1 + p4 * e1 + p5 * f1
            Y[r, 40 + i] = p2 * c2 + p3 * d2 + p4 * e2 + p5 * f2
    for r in range(6, nr):
        c0 = core[r, 6]
        c1 = core[r, 7]
        c2 = core[r, 8]
        d0 = core[r, 9]
        d1 = core[r, 10]
        d2 = core[r, 11]
        if ns == 6:
            e0 = core[r, 12]
            e1 = core[r, 13]
            e2 = core[r, 14]
            f0 = core[r, 15]
            f1 = core[r, 16]
            f2 = core[r, 17]
        else:
            e0 = e1 = e2 = f0 = f1 = f2 = 0.0
        for i in range(_u(0), n8):
            p2 = _PI8[p, 2, i]
            p3 = _PI8[p, 3, i]
            p4 = _PI8[p, 4, i]
            p5 = _PI8[p, 5, i]
            Y[r, 24 + i] = p2 * c0 + p3 * d0 + p4 * e0 + p5 * f0
            Y[r, 32 + i] = p2 * c1 + p3 * d1 + p4 * e1 + p5 * f1
            Y[r, 40 + i] = p2 * c2 + p3 * d2 + p4 * e2 + p5 * f2
    # stage 2, translation rows of component c (sources U0, U1)
    a00 = _PI8[p, 0, 0]
    a01 = _PI8[p, 0, 1]
    a02 = _PI8[p, 0, 2]
    a03 = _PI8[p, 0, 3]
    a04 = _PI8[p, 0, 4]
    a05 = _PI8[p, 0, 5]
    a10 = _PI8[p, 1, 0]
    a11 = _PI8[p, 1, 1]
    a12 = _PI8[p, 1, 2]
    a13 = _PI8[p, 1, 3]
    a14 = _PI8[p, 1, 4]
    a15 = _PI8[p, 1, 5]
    for c in range(3):
        b = 8 * c
        for k in range(_u(b), nz):
            y0 = Y[c, k]
            y1 = Y[3 + c, k]
            Kz[b, k] += a00 * y0 + a10 * y1
            Kz[b + 1, k] += a01 * y0 + a11 * y1
            Kz[b + 2, k] += a02 * y0 + a12 * y1
            Kz[b + 3, k] += a03 * y0 + a13 * y1
            Kz[b + 4, k] += a04 * y0 + a14 * y1
            Kz[b + 5, k] += a05 * y0 + a15 * y1
    # stage 2, rotation rows of component c (sources V0, V, W0, W1), rotation columns
    n1 = _PI8[p, 3, 1]
    n2 = _PI8[p, 3, 2]
    n3 = _PI8[p, 3, 3]
    n4 = _PI8[p, 3, 4]
    n5 = _PI8[p, 3, 5]
    p1 = _PI8[p, 4, 1]
    p2 = _PI8[p, 4, 2]
    p3 = _PI8[p, 4, 3]
    p4 = _PI8[p, 4, 4]
    p5 = _PI8[p, 4, 5]
    q1 = _PI8[p, 5, 1]
    q2 = _PI8[p, 5, 2]
    q3 = _PI8[p, 5, 3]
    q4 = _PI8[p, 5, 4]
    q5 = _PI8[p, 5, 5]
    for c in range(3):
        b = _ZR + 8 * c
        if ns == 6:
            for k in range(_u(_KR), nz):
                v0 = Y[6 + c, k]
                v = Y[9 + c, k]
                w0 = Y[12 + c, k]
                w1 = Y[15 + c, k]
                Kz[b, k] += v0
                Kz[b + 1, k] += n1 * v + p1 * w0 + q1 * w1
                Kz[b + 2, k] += n2 * v + p2 * w0 + q2 * w1
                Kz[b + 3, k] += n3 * v + p3 * w0 + q3 * w1
                Kz[b + 4, k] += n4 * v + p4 * w0 + q4 * w1
                Kz[b + 5, k] += n5 * v + p5 * w0 + q5 * w1
        else:
            for k in range(_u(_KR), nz):
                v0 = Y[6 + c, k]
                v = Y[9 + c, k]
                Kz[b, k] += v0
                Kz[b + 1, k] += n1 * v
                Kz[b + 2, k] += n2 * v
                Kz[b + 3, k] += n3 * v
                Kz[b + 4, k] += n4 * v
                Kz[b + 5, k] += n5 * v


@inl
def _expand_core_rot(core, ns, p, Y, Kz):
    """Kz += Pi^T core Pi restricted to the rotation columns (core without its translation-translation block)."""
    nr = 3 * ns
    nz = _u(Kz.shape[1])
    n8 = nz // _u(6)
    for r in range(nr):
        c0 = core[r, 6]
        c1 = core[r, 7]
        c2 = core[r, 8]
        d0 = core[r, 9]
        d1 = core[r, 10]
        d2 = core[r, 11]
        if ns == 6:
            e0 = core[r, 12]
            e1 = core[r, 13]
            e2 = core[r, 14]
            f0 = core[r, 15]
            f1 = core[r, 16]
            f2 = core[r, 17]
        else:
            e0 = e1 = e2 = f0 = f1 = f2 = 0.0
        for i in range(_u(0), n8):
            p2 = _PI8[p, 2, i]
            p3 = _PI8[p, 3, i]
            p4 = _PI8[p, 4, i]
            p5 = _PI8[p, 5, i]
            Y[r, 24 + i] = p2 * c0 + p3 * d0 + p4 * e0 + p5 * f0
            Y[r, 32 + i] = p2 * c1 + p3 * d1 + p4 * e1 + p5 * f1
            Y[r, 40 + i] = p2 * c2 + p3 * d2 + p4 * e2 + p5 * f2
    a00 = _PI8[p, 0, 0]
    a01 = _PI8[p, 0, 1]
    a02 = _PI8[p, 0, 2]
    a03 = _PI8[p, 0, 3]
    a04 = _PI8[p, 0, 4]
    a05 = _PI8[p, 0, 5]
    a10 = _PI8[p, 1, 0]
    a11 = _PI8[p, 1, 1]
    a12 = _PI8[p, 1, 2]
    a13 = _PI8[p, 1, 3]
    a14 = _PI8[p, 1, 4]
    a15 = _PI8[p, 1, 5]
    for c in range(3):
        b = 8 * c
        for k in range(_u(_ZR), nz):
            y0 = Y[c, k]
            y1 = Y[3 + c, k]
            Kz[b, k] += a00 * y0 + a10 * y1
            Kz[b + 1, k] += a01 * y0 + a11 * y1
            Kz[b + 2, k] += a02 * y0 + a12 * y1
            Kz[b + 3, k] += a03 * y0 + a13 * y1
            Kz[b + 4, k] += a04 * y0 + a14 * y1
            Kz[b + 5, k] += a05 * y0 + a15 * y1
    n1 = _PI8[p, 3, 1]
    n2 = _PI8[p, 3, 2]
    n3 = _PI8[p, 3, 3]
    n4 = _PI8[p, 3, 4]
    n5 = _PI8[p, 3, 5]
    p1 = _PI8[p, 4, 1]
    p2 = _PI8[p, 4, 2]
    p3 = _PI8[p, 4, 3]
    p4 = _PI8[p, 4, 4]
    p5 = _PI8[p, 4, 5]
    q1 = _PI8[p, 5, 1]
    q2 = _PI8[p, 5, 2]
    q3 = _PI8[p, 5, 3]
    q4 = _PI8[p, 5, 4]
    q5 = _PI8[p, 5, 5]
    for c in range(3):
        b = _ZR + 8 * c
        for k in range(_u(_ZR), nz):
            v0 = Y[6 + c, k]
            v = Y[9 + c, k]
            if ns == 6:
                w0 = Y[12 + c, k]
                w1 = Y[15 + c, k]
            else:
                w0 = 0.0
                w1 = 0.0
            Kz[b, k] += v0
            Kz[b + 1, k] += n1 * v + p1 * w0 + q1 * w1
            Kz[b + 2, k] += n2 * v + p2 * w0 + q2 * w1
            Kz[b + 3, k] += n3 * v + p3 * w0 + q3 * w1
            Kz[b + 4, k] += n4 * v + p4 * w0 + q4 * w1
            Kz[b + 5, k] += n5 * v + p5 * w0 + q5 * w1


@inl
def _rank_update_block(Kz, b, k0, S, W, a):
    """Kz[b:b+6, k0:] += S[a:a+4, b:b+6]^T W[a:a+4, k0:] (six rows, four sources per loop)."""
    s00 = S[a, b]
    s01 = S[a, b + 1]
    s02 = S[a, b + 2]
    s03 = S[a, b + 3]
    s04 = S[a, b + 4]
    s05 = S[a, b + 5]
    s10 = S[a + 1, b]
    s11 = S[a + 1, b + 1]
    s12 = S[a + 1, b + 2]
    s13 = S[a + 1, b + 3]
    s14 = S[a + 1, b + 4]
    s15 = S[a + 1, b + 5]
    s20 = S[a + 2, b]
    s21 = S[a + 2, b + 1]
    s22 = S[a + 2, b + 2]
    s23 = S[a + 2, b + 3]
    s24 = S[a + 2, b + 4]
    s25 = S[a + 2, b + 5]
    s30 = S[a + 3, b]
    s31 = S[a + 3, b + 1]
    s32 = S[a + 3, b + 2]
    s33 = S[a + 3, b + 3]
    s34 = S[a + 3, b + 4]
    s35 = S[a + 3, b + 5]
    for k in range(k0, _u(Kz.shape[1])):
        w0 = W[a, k]
        w1 = W[a + 1, k]
        w2 = W[a + 2, k]
        w3 = W[a + 3, k]
        Kz[b, k] += s00 * w0 + s10 * w1 + s20 * w2 + s30 * w3
        Kz[b + 1, k] += s01 * w0 + s11 * w1 + s21 * w2 + s31 * w3
        Kz[b + 2, k] += s02 * w0 + s12 * w1 + s22 * w2 + s32 * w3
        Kz[b + 3, k] += s03 * w0 + s13 * w1 + s23 * w2 + s33 * w3
        Kz[b + 4, k] += s04 * w0 + s14 * w1 + s24 * w2 + s34 * w3
        Kz[b + 5, k] += s05 * w0 + s15 * w1 + s25 * w2 + s35 * w3


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


@inl
def _expand_vec_scaled(V, vrow, alpha, p, out, orow):
    """out[orow] (z, NZ) += alpha Pi_p^T V[vrow] (18 slot components)."""
    n8 = _u(out.shape[1]) // _u(6)
    for c in range(3):
        u0 = alpha * V[vrow, c]
        u1 = alpha * V[vrow, 3 + c]
        r0 = alpha * V[vrow, 6 + c]
        rv = alpha * V[vrow, 9 + c]
        w0 = alpha * V[vrow, 12 + c]
        w1 = alpha * V[vrow, 15 + c]
        ot = 8 * c
        orot = _ZR + 8 * c
        for i in range(_u(0), n8):
            out[orow, ot + i] += _PI8[p, 0, i] * u0 + _PI8[p, 1, i] * u1
            out[orow, orot + i] += (_PI8[p, 2, i] * r0 + _PI8[p, 3, i] * rv + _PI8[p, 4, i] * w0
                                    + _PI8[p, 5, i] * w1)


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


# ----------------------------------------------------------------------------------------------------------
# Element loops
# ----------------------------------------------------------------------------------------------------------


@_numba.entry
def _chunk(e0, e1, x_el, fr_el, e_ref, to_cart, weights, C, cblk,
           used, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v,
           pt_gauss, loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
           par_p, par_ptr, par_j, par_v, pl_ptr, pl_k, pl_v, w2, has_w, n_rf,
           nl_rows, n_nl, m_ptr, m_i, m_k, m_v, m_dense,
           want_tangent, use_stress, stress, f, fg, K,
           x, fr, dn, Ti, ninv, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, Ps,
           F, Q, T, R, X0, X1, d, da, co, s, g, G2, phi, fz,
           cov, st, Ch, CT, v16, core, Y, Yt, Kz, Kiso, K1, T0, Dl, Bl, CBl, Sp, Wp, Cp, Yp,
           t0, t1, t2, t3, t4, t5):
    """Internal forces f[e] (and tangents K[e]) of the elements e0 <= e < e1.

    With use_stress the geometric terms of the tangent carry the given stress resultants stress[e] instead
    of those of the strains (the mixed Newton iteration), and fg[e] receives the force of these stresses;
    f[e] is always the force of the strains.
    """
    for e in range(e0, e1):
        if e + _AHEAD < e1:
            _prefetch_element(e + _AHEAD, x_el, fr_el, e_ref, to_cart, weights, want_tangent, K)
        _load_element(e, x_el, fr_el, x, fr)
        _node_setup(fr, dn, Ti, ninv, t0)
        _interpolate_points(used, dn, Pd, Pda)
        _point_coefficients(used, Pd, Pco)
        _kinematics_points(used, x, fr, Pd, Pda, Pco, PQ, PT, PR, PF, PX)
        _strains_points(e, used, e_ref, PF, Pe)
        if want_tangent:
            _section_cov(e, to_cart, weights, C, cblk, CT, Ch)
        _stress_weights(e, used, to_cart, weights, C, Ch, want_tangent, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v,
                        Pe, cov, st, v16, Ps)
        _force_points(used, PF, PQ, PT, PR, PX, Ps, g, G2, phi, fz)
        _force_to_local(e, fz, fr, Ti, f)
        fv = f
        if use_stress:
            _given_stress_weights(e, used, to_cart, weights, stress, at_ptr, at_g, at_i, at_v, st, Ps)
            _force_points(used, PF, PQ, PT, PR, PX, Ps, g, G2, phi, fz)
            _force_to_local(e, fz, fr, Ti, fg)
            fv = fg
        if not want_tangent:
            continue
        _points_tangent(used, pt_gauss, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, Ch,
                        loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
                        g, core, Y, Kz, Kiso, Dl, Bl, CBl, t0, t1, t2, t3, t4, t5)
        if has_w.shape[0] > 0:
            _nonlocal_material(x, par_p, par_ptr, par_j, par_v, pl_ptr, pl_k, pl_v, w2, has_w, n_rf,
                               nl_rows, n_nl, m_ptr, m_i, m_k, m_v, m_dense,
                               PF, PQ, PT, PR, PX, Ch, G2, phi, Sp, Wp, Cp, Yp, Kz)
            if _has_cross_coupling(Ch, loc_rows, n_loc, nl_rows, n_nl):
                _cross_terms(loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v, nl_rows, n_nl, m_ptr, m_i, m_k, m_v,
                             Ch, Sp, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, F, Q, T, R, X0, X1, d, da, co, s,
                             Dl, Bl, Wp, Y, Yt, K1, Kz)
        _finish_tangent(e, Kz, Kiso, fr, Ti, fv, fz, dn, ninv, K1, T0, K, t0, t1)


def _workspaces(npar: int, n_rf: int) -> tuple:
    """The scratch arrays of one :func:`_chunk` call, in the order of its trailing arguments (x ... t5),
    reused for every element of the chunk. ``npar``: nonlocal parameters (rows of the rank update), ``n_rf``
    of them rotation-free."""
    npar = max(npar, 1)
    n_rows = max(4 * ((npar + 3) // 4), n_rf + 4 * ((npar - n_rf + 3) // 4))
    e = np.empty
    return (e((6, 3)), e((6, 3, 3)), e((6, 3)), e((6, 3, 3)), e((6, 2)),                  # x fr dn Ti ninv
            e((N_EVAL, 3)), e((N_EVAL, 2, 3)), e((N_EVAL, 9)), e((N_EVAL, 3, 3)),           # Pd Pda Pco PQ
            e((N_EVAL, 3, 3)), e((N_EVAL, 3, 3)), e((N_EVAL, 4, 3)), e((N_EVAL, 2, 3, 3)),  # PT PR PF PX
            e((N_EVAL, 8)), e((N_EVAL, 8)),                                                 # Pe Ps
            e((4, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)),               # F Q T R X0 X1
            e(3), e((2, 3)), e(9), e(8), e(12), e((1, 12)), e((1, 18)), e((1, NZ)),         # d da co s g G2 phi fz
            e((N_GAUSS, 8)), e((N_GAUSS, 8)), e((N_GAUSS, 8, 8)), e((8, 8)), e(16),         # cov st Ch CT v16
            e((18, 18)), e((18, NZ)), e((NZ, 18)), e((NZ, NZ)), e((6, 8)), e((NZ, NZ)),     # core Y Yt Kz Kiso K1
            e((3, NDOF)), e((8, 12)), e((8, 18)), e((8, 18)),                               # T0 Dl Bl CBl
            e((n_rows, NZ)), e((max(n_rows, 8), NZ)), e((npar, npar)), e((8, npar)),        # Sp Wp Cp Yp
            e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)))               # t0 .. t5


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
        p = used[k]
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


@_numba.entry
def _chunk_strains(e0, e1, x_el, fr_el, e_ref, to_cart, used, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, out,
                   with_increment, dh, deps, x, fr, dn, Ti, ninv, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, dX, dD, cov,
                   t0):
    """Gauss-point strains out[e] and, with_increment, their linearization deps[e] = B dh[e]."""
    for e in range(e0, e1):
        _load_element(e, x_el, fr_el, x, fr)
        _node_setup(fr, dn, Ti, ninv, t0)
        _interpolate_points(used, dn, Pd, Pda)
        _point_coefficients(used, Pd, Pco)
        _kinematics_points(used, x, fr, Pd, Pda, Pco, PQ, PT, PR, PF, PX)
        _strains_points(e, used, e_ref, PF, Pe)
        _gauss_strains(e, to_cart, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, Pe, cov, out)
        if with_increment:
            _strain_increments_points(e, used, fr, Ti, dh, PF, PQ, PT, PR, PX, dX, dD, Pe)
            _gauss_strains(e, to_cart, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, Pe, cov, deps)


def _strain_workspaces() -> tuple:
    """The scratch arrays of one :func:`_chunk_strains` call, in the order of its trailing arguments."""
    e = np.empty
    return (e((6, 3)), e((6, 3, 3)), e((6, 3)), e((6, 3, 3)), e((6, 2)),                  # x fr dn Ti ninv
            e((N_EVAL, 3)), e((N_EVAL, 2, 3)), e((N_EVAL, 9)), e((N_EVAL, 3, 3)),           # Pd Pda Pco PQ
            e((N_EVAL, 3, 3)), e((N_EVAL, 3, 3)), e((N_EVAL, 4, 3)), e((N_EVAL, 2, 3, 3)),  # PT PR PF PX
            e((N_EVAL, 8)), e((10, 3)), e((6, 3)), e((N_GAUSS, 8)), e((3, 3)))              # Pe dX dD cov t0


# ----------------------------------------------------------------------------------------------------------
# Python side: compressed assumed-strain maps
# ----------------------------------------------------------------------------------------------------------


def _row_basis(M: np.ndarray, tol: float) -> np.ndarray:
    """Reduced row-echelon basis of the row space of M (sparse rows with unit pivots)."""
    M = M.copy()
    rows, cols = M.shape
    basis, r = [], 0
    for c in range(cols):
        if r == rows:
            break
        piv = r + int(np.argmax(np.abs(M[r:, c])))
        if abs(M[piv, c]) <= tol:
            continue
        M[[r, piv]] = M[[piv, r]]
        M[r] /= M[r, c]
        for k in range(rows):
            if k != r:
                M[k] -= M[k, c] * M[r]
        r += 1
    basis = M[:r]
    basis[np.abs(basis) <= tol] = 0.0
    return basis


class CompressedMaps:
    """Sparse form of an assumed-strain map A (7, 8, 17, 8) for the kernels (see the module docstring).

    * all nonzeros (g, i, p, j, v), by rows (g, i) and by columns (p, j): strains and the pull-back of the
      stress resultants;
    * local rows of each Gauss point (entries referring only to the point itself): in the point's slots;
    * nonlocal rows: A_nl = M E with parameters E = L E1: E1 the row-echelon bases of the sampled components
      used at each point (e.g. e_qq = (e_rr + e_ss)/2 - e_rs at a hypotenuse tying point), L the row-echelon
      basis of the combinations of them that the rows use (fewer when rows share combinations of several
      points, as the element means of the "mean" tying do; L = I otherwise), M the sparse combination per
      Gauss point row. Rotation-free parameters (membrane only) come first and get their rows as W_k x.
      The factorizations are verified to round-off.
    """

    def __init__(self, A: np.ndarray) -> None:
        A = np.asarray(A, dtype=np.float64)
        if A.shape != (N_GAUSS, 8, N_EVAL, 8):
            raise ValueError(f"A must have shape {(N_GAUSS, 8, N_EVAL, 8)}, got {A.shape}")
        if not np.all(np.isfinite(A)):
            raise ValueError("A must be finite")
        g, i, p, j = np.nonzero(A)
        v = A[g, i, p, j]
        # A by rows (g, i) and by columns (p, j), each in the order of the other index (sums as in the reference)
        self.a_ptr = np.searchsorted(8 * g + i, np.arange(8 * N_GAUSS + 1)).astype(np.int64)
        self.a_p, self.a_j, self.a_v = p.astype(np.int64), j.astype(np.int64), v.astype(np.float64)
        by_col = np.argsort(8 * p + j, kind="stable")
        self.at_ptr = np.searchsorted((8 * p + j)[by_col], np.arange(8 * N_EVAL + 1)).astype(np.int64)
        self.at_g, self.at_i = g[by_col].astype(np.int64), i[by_col].astype(np.int64)
        self.at_v = v[by_col].astype(np.float64)
        self.used = np.unique(p).astype(np.int64)
        own = GAUSS_OFFSET + np.arange(N_GAUSS)
        # a row of Gauss point g is local when all its entries refer to g's own evaluation point
        has = np.zeros((N_GAUSS, 8), bool)
        other = np.zeros((N_GAUSS, 8), bool)
        has[g, i] = True
        far = p != own[g]
        other[g[far], i[far]] = True
        local = has & ~other
        nonlocal_ = has & other
        self.loc_rows = np.zeros((N_GAUSS, 8), np.int64)
        self.nl_rows = np.zeros((N_GAUSS, 8), np.int64)
        self.n_loc = local.sum(axis=1).astype(np.int64)
        self.n_nl = nonlocal_.sum(axis=1).astype(np.int64)
        loc_index = -np.ones((N_GAUSS, 8), np.int64)
        nl_index = -np.ones((N_GAUSS, 8), np.int64)
        for gg in range(N_GAUSS):
            rows = np.flatnonzero(local[gg])
            self.loc_rows[gg, :len(rows)] = rows
            loc_index[gg, rows] = np.arange(len(rows))
            rows = np.flatnonzero(nonlocal_[gg])
            self.nl_rows[gg, :len(rows)] = rows
            nl_index[gg, rows] = np.arange(len(rows))
        is_loc = local[g, i]
        order = np.argsort(g[is_loc], kind="stable")
        self.loc_i = loc_index[g, i][is_loc][order]
        self.loc_j = j[is_loc][order].astype(np.int64)
        self.loc_v = v[is_loc][order]
        self.loc_ptr = np.searchsorted(g[is_loc][order], np.arange(N_GAUSS + 1)).astype(np.int64)
        self.pt_gauss = -np.ones(N_EVAL, np.int64)
        for gg in range(N_GAUSS):
            if self.n_loc[gg] > 0:
                self.pt_gauss[own[gg]] = gg
        self._factor_nonlocal(A, nonlocal_, nl_index)

    def _factor_nonlocal(self, A, nonlocal_, nl_index) -> None:
        # dense A_nl: rows (g, nonlocal row), columns (point, component)
        row_of = [(gg, int(r)) for gg in range(N_GAUSS) for r in np.flatnonzero(nonlocal_[gg])]
        A_nl = np.array([A[gg, r].ravel() for gg, r in row_of]).reshape(len(row_of), N_EVAL * 8)
        scale = np.abs(A_nl).max() if A_nl.size else 1.0
        tol = 1e-12 * scale
        # point parameters E1: row-echelon bases of the sampled components used at each point
        E_rows, pt_of = [], []
        for pp in range(N_EVAL):
            sub = A_nl[:, 8 * pp:8 * pp + 8] if A_nl.size else np.zeros((0, 8))
            if not np.any(np.abs(sub) > tol):
                continue
            for row in _row_basis(sub, tol):
                full = np.zeros(N_EVAL * 8)
                full[8 * pp:8 * pp + 8] = row
                E_rows.append(full)
                pt_of.append(pp)
        E1 = np.array(E_rows).reshape(len(E_rows), N_EVAL * 8)
        pt_of = np.array(pt_of, np.int64)
        # rotation-free (membrane) point parameters first
        rf1 = np.array([bool(np.all(np.flatnonzero(row) % 8 < 3)) for row in E1], bool)
        order = np.argsort(~rf1, kind="stable")
        E1, rf1, pt_of = E1[order], rf1[order], pt_of[order]
        if len(E1):
            M1 = np.linalg.lstsq(E1.T, A_nl.T, rcond=None)[0].T      # A_nl = M1 E1
            M1[np.abs(M1) <= 1e-14 * np.abs(M1).max()] = 0.0
            if np.abs(M1 @ E1 - A_nl).max() > 1e-13 * scale:
                raise ValueError("could not factor the nonlocal assumed-strain rows")
            # parameters E = L E1 of minimal number: L the row-echelon basis of the row space of M1
            # (e.g. the element means of the "mean" membrane tying combine sampled strains of several points)
            L = _row_basis(M1, 1e-12 * max(np.abs(M1).max(), 1.0))
            rf = ~np.any(L[:, ~rf1] != 0.0, axis=1)                  # parameters of rotation-free rows only
            order = np.argsort(~rf, kind="stable")
            L, rf = L[order], rf[order]
            E = L @ E1
            M = np.linalg.lstsq(E.T, A_nl.T, rcond=None)[0].T        # A_nl = M E
            M[np.abs(M) <= 1e-14 * np.abs(M).max()] = 0.0
            if len(L) == len(E1) or np.abs(M @ E - A_nl).max() > 1e-13 * scale:
                L, rf, M = np.eye(len(E1)), rf1.copy(), M1           # no reduction (or an ill-conditioned one)
        else:
            L = np.zeros((0, 0))
            rf = np.zeros(0, bool)
            M = np.zeros((len(row_of), 0))
        npar = len(L)
        self.n_rf = int(rf.sum())
        # rotation-free parts: S_k[x_I] = sum_J W_k[I, J] x_J, from the membrane gradients at the points
        # (delta e_rr = x_,r . delta x_,r, delta e_ss = x_,s . delta x_,s,
        #  2 delta e_rs = x_,r . delta x_,s + x_,s . delta x_,r)
        self.w2 = np.zeros((max(npar, 1), 6, 6))
        for k in range(npar):
            for kp in np.flatnonzero(rf1):
                lv = L[k, kp]
                if lv == 0.0:
                    continue
                pp = pt_of[kp]
                dr, ds = EVAL_DN[pp]
                row = E1[kp, 8 * pp:8 * pp + 3]
                self.w2[k] += lv * (row[0] * np.outer(dr, dr) + row[1] * np.outer(ds, ds)
                                    + 0.5 * row[2] * (np.outer(dr, ds) + np.outer(ds, dr)))
        self.has_w = np.any(self.w2[:npar] != 0.0, axis=(1, 2)).astype(np.int64)
        # point parameters with rotations: their sampled components and weights in the parameters
        nr1 = np.flatnonzero(~rf1)
        self.par_p = pt_of[nr1].astype(np.int64)
        ptr, pj, pv = [0], [], []
        lptr, lk, lv = [0], [], []
        for kp in nr1:
            (nzc,) = np.nonzero(E1[kp])
            pj.extend(int(c) % 8 for c in nzc)
            pv.extend(E1[kp, nzc])
            ptr.append(len(pj))
            for k in np.flatnonzero(L[:, kp]):
                lk.append(int(k))
                lv.append(L[k, kp])
            lptr.append(len(lk))
        self.par_ptr = np.array(ptr, np.int64)
        self.par_j = np.array(pj, np.int64)
        self.par_v = np.array(pv, np.float64)
        self.pl_ptr = np.array(lptr, np.int64)
        self.pl_k = np.array(lk, np.int64)
        self.pl_v = np.array(lv, np.float64)
        self.npar = npar
        mg, mi, mk, mv = [], [], [], []
        for r, (gg, row) in enumerate(row_of):
            for k in np.flatnonzero(M[r]):
                mg.append(gg)
                mi.append(nl_index[gg, row])
                mk.append(int(k))
                mv.append(M[r, k])
        mg = np.array(mg, np.int64)
        self.m_ptr = np.searchsorted(mg, np.arange(N_GAUSS + 1)).astype(np.int64)
        self.m_i = np.array(mi, np.int64)
        self.m_k = np.array(mk, np.int64)
        self.m_v = np.array(mv, np.float64)
        self.m_dense = np.zeros((N_GAUSS, 8, max(npar, 1)))        # M_g by nonlocal row, dense in the parameters
        self.m_dense[mg, self.m_i, self.m_k] = self.m_v

    @property
    def n_parameters(self) -> int:
        return self.npar

    def nonzeros(self):
        return self.used, self.a_ptr, self.a_p, self.a_j, self.a_v, self.at_ptr, self.at_g, self.at_i, self.at_v

    def kernel_args(self):
        return (self.used, self.a_ptr, self.a_p, self.a_j, self.a_v, self.at_ptr, self.at_g, self.at_i, self.at_v,
                self.pt_gauss, self.loc_rows, self.n_loc, self.loc_ptr, self.loc_i, self.loc_j, self.loc_v,
                self.par_p, self.par_ptr, self.par_j, self.par_v, self.pl_ptr, self.pl_k, self.pl_v,
                self.w2, self.has_w, self.n_rf, self.nl_rows, self.n_nl, self.m_ptr, self.m_i, self.m_k, self.m_v,
                self.m_dense)


_MAP_CACHE: dict[bytes, CompressedMaps] = {}


def compress_maps(A: np.ndarray | CompressedMaps) -> CompressedMaps:
    """Compressed form of an assumed-strain map (cached on its contents); a compressed map is returned as it
    is (an element variant compresses its map once, :mod:`flexbody.shell.variants`)."""
    if isinstance(A, CompressedMaps):
        return A
    A = np.ascontiguousarray(A, dtype=np.float64)
    key = A.tobytes()
    maps = _MAP_CACHE.get(key)
    if maps is None:
        if len(_MAP_CACHE) > 8:
            _MAP_CACHE.clear()
        maps = _MAP_CACHE[key] = CompressedMaps(A)
    return maps


_SECTION_CACHE: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _checked_section(section: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The section stiffness (8, 8) as a contiguous float64 array, checked (shape, symmetry), and its block
    coupling flags (:func:`_section_blocks`); cached on its contents (a solve passes the same section at every
    evaluation: the checks cost 5 % of a small batch's residual)."""
    C = np.ascontiguousarray(section, dtype=np.float64)
    if C.shape != (8, 8):
        raise ValueError(f"section must be (8, 8), got {C.shape}")
    key = C.tobytes()
    hit = _SECTION_CACHE.get(key)
    if hit is not None:
        return hit
    if not np.allclose(C, C.T, rtol=0.0, atol=1e-13 * np.abs(C).max()):
        raise ValueError("section stiffness must be symmetric")
    if len(_SECTION_CACHE) > 8:
        _SECTION_CACHE.clear()
    C = C.copy()                      # the cached array is the kernel's own: a caller's later edits do not reach it
    hit = _SECTION_CACHE[key] = (C, _section_blocks(C))
    return hit


def _element_arrays(x_el, frames_el, e_ref, to_cart, **more):
    """The kernels' per-element inputs as contiguous float64 arrays, their shapes and common length checked.

    more : name=(array, shape_tail) for further per-element arrays (weights, dh_el, b0, ...), in that order.
    """
    arrays = [_as(x_el, (6, 3), "x_el"), _as(frames_el, (6, 3, 3), "frames_el"), _as(e_ref, (N_EVAL, 8), "e_ref"),
              _as(to_cart, (N_GAUSS, 8, 8), "to_cart")] + [_as(a, tail, name) for name, (a, tail) in more.items()]
    if any(len(a) != len(arrays[0]) for a in arrays):
        raise ValueError("all element arrays must have the same number of elements")
    return arrays


def internal_force_tangent_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray,
                                 to_cart: np.ndarray, weights: np.ndarray, section: np.ndarray,
                                 A: np.ndarray | CompressedMaps, want_tangent: bool = True,
                                 stress: np.ndarray | None = None):
    """Internal forces (m, 36) and tangents (m, 36, 36) of m elements, per node [u, theta], local frames.

    Same result as :func:`flexbody.shell.element_reference.internal_force_tangent` element by element.

    Parameters
    ----------
    x_el : (m, 6, 3) nodal positions;  frames_el : (m, 6, 3, 3) nodal frames
    e_ref : (m, 17, 8), to_cart : (m, 7, 8, 8), weights : (m, 7)  reference data (geometry.element_geometry)
    section : (8, 8) symmetric section stiffness
    A : (7, 8, 17, 8) assumed-strain map (``ElementVariant.maps``), or its :class:`CompressedMaps`
        (``ElementVariant.compressed_maps``: no re-hashing)
    want_tangent : False takes the residual-only path (no tangent, no second variation); K is then None.
    stress : optional (m, 7, 8) Cartesian stress resultants at the Gauss points for the geometric terms of
        the tangent (the mixed Newton iteration, :func:`flexbody.shell.element_reference.force_tangent`);
        the force is always that of the strains. With a stress the result is (f, K, f_stress), f_stress
        (m, 36) the force of the given stresses (K None without want_tangent).
    """
    x_el, frames_el, e_ref, to_cart, weights = _element_arrays(x_el, frames_el, e_ref, to_cart,
                                                               weights=(weights, (N_GAUSS,)))
    m = x_el.shape[0]
    C, cblk = _checked_section(section)
    use_stress = stress is not None
    stress = _as(stress, (N_GAUSS, 8), "stress") if use_stress else np.zeros((1, N_GAUSS, 8))
    if use_stress and len(stress) != m:
        raise ValueError(f"stress must have one row per element ({m}), got {len(stress)}")
    maps = compress_maps(A)
    f = np.empty((m, NDOF))
    fs = np.empty((m, NDOF)) if use_stress else np.empty((1, NDOF))
    K = np.empty((m, NDOF, NDOF)) if want_tangent else np.empty((1, NDOF, NDOF))
    if m:
        args = (x_el, frames_el, e_ref, to_cart, weights, C, cblk, *maps.kernel_args(),
                bool(want_tangent), use_stress, stress, f, fs, K)
        key, npar, n_rf = ("mitc6", maps.npar, maps.n_rf), maps.npar, maps.n_rf
        run_chunks(lambda e0, e1: _chunk(e0, e1, *args, *scratch(key, lambda: _workspaces(npar, n_rf))), m,
                   _n_chunks(m))
    if use_stress:
        return f, (K if want_tangent else None), fs
    return f, (K if want_tangent else None)


def element_strains_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                          A: np.ndarray | CompressedMaps) -> np.ndarray:
    """Cartesian strains [membrane | bending | shear] at the 7 Gauss points of m elements, (m, 7, 8).

    Same result as :func:`flexbody.shell.element_reference.element_strains` element by element.
    """
    x_el, frames_el, e_ref, to_cart = _element_arrays(x_el, frames_el, e_ref, to_cart)
    m = x_el.shape[0]
    maps = compress_maps(A)
    out = np.empty((m, N_GAUSS, 8))
    if m:
        args = (x_el, frames_el, e_ref, to_cart, *maps.nonzeros(), out, False, np.zeros((1, NDOF)),
                np.zeros((1, N_GAUSS, 8)))
        run_chunks(lambda e0, e1: _chunk_strains(e0, e1, *args, *scratch(("strains",), _strain_workspaces)), m,
                   _n_chunks(m))
    return out


def linearized_strains_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                             A: np.ndarray | CompressedMaps, dh_el: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cartesian Gauss-point strains eps (m, 7, 8) of m elements and their linearization B dh along the local
    nodal motions dh_el (m, 36), per node [du, dtheta] (the strain increment of the mixed Newton iteration).

    Same result as :func:`flexbody.shell.element_reference.linearized_strains` element by element.
    """
    x_el, frames_el, e_ref, to_cart, dh_el = _element_arrays(x_el, frames_el, e_ref, to_cart,
                                                             dh_el=(dh_el, (NDOF,)))
    m = x_el.shape[0]
    maps = compress_maps(A)
    eps = np.empty((m, N_GAUSS, 8))
    deps = np.empty((m, N_GAUSS, 8))
    if m:
        args = (x_el, frames_el, e_ref, to_cart, *maps.nonzeros(), eps, True, dh_el, deps)
        run_chunks(lambda e0, e1: _chunk_strains(e0, e1, *args, *scratch(("strains",), _strain_workspaces)), m,
                   _n_chunks(m))
    return eps, deps
