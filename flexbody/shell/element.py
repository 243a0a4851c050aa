"""The fast element: numba kernels for the internal force and tangent of the six-node SE(3) shell.

Computes, for a batch of elements, exactly what :func:`flexbody.shell.element_reference.internal_force_tangent`
computes (same terms of the second variation, same strains), but arranged so that nothing is a dense
(8 x 136) or (12 x 36) product at a point. Three changes of bookkeeping make it cheap:

1. **Relative coordinates.** Per element, the 36 local nodal motions h = [u_I, theta_I] are mapped to
   z = [dx_I, dtheta_0, dd_1..dd_5] with dx_I = R_I du_I (global translation) and the variations of the
   relative rotation vectors dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0 (paper Eq. 31): z = P h.
   In z every point quantity is a *scalar* (shape function) combination of a few 3x3 blocks.
2. **Point slots.** At an evaluation point the strain measures depend on z only through the 18 numbers
   xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi z, where Pi holds N_I and dN_I (times I_3). The
   Jacobian G, the B rows and the contracted second variation are formed in xi (12 x 18 and 18 x 18 with
   3x3 blocks written out in closed form) and expanded once per point into z (two sparse stages).
3. **Node terms.** K_h = P^T K_z P + (D P^T[.]) f_z: the derivative of P adds hat(f_u,I) in the (u_I, theta_I)
   block and the D T^-1 terms of Delta(delta d_I) (contracted with f_z at dd_I, which equals the reference's
   sum over points of N_I g_d + dN_I . g_da).

The MITC6 assumed-strain map A (7, 8, 17, 8) is compressed in Python: rows of a Gauss point that only use
that Gauss point ("local": bending; everything with tying off) enter the point's 18 x 18 slot matrix; the
other rows ("nonlocal": membrane and shear with tying on) are sums of sampled rows at the tying points and
are assembled as rank-5 updates per Gauss point. Evaluation points no row refers to are skipped.

Workspaces are allocated once per parallel chunk (a few per thread), never per element or point.
The section stiffness must be symmetric (it is for :class:`~flexbody.shell.material.ShellMaterial`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from flexbody.lie import kernels as lk
from flexbody.shell.geometry import EVAL_DN, EVAL_N, GAUSS_OFFSET, N_GAUSS
from flexbody.shell.mitc6 import N_TYING

N_EVAL = N_TYING + N_GAUSS
NDOF = 36

jit = numba.njit(cache=True)

_EVAL_N = np.ascontiguousarray(EVAL_N, dtype=np.float64)     # (17, 6)
_EVAL_DN = np.ascontiguousarray(EVAL_DN, dtype=np.float64)   # (17, 2, 6)

# slots of the point coordinates xi (3 components each)
_U0, _U1, _V0, _V, _W0, _W1 = 0, 1, 2, 3, 4, 5


# ----------------------------------------------------------------------------------------------------------
# 3x3 helpers (allocation free)
# ----------------------------------------------------------------------------------------------------------


@jit
def _mm(A, B, out):
    """out = A B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@jit
def _mmT(A, B, out):
    """out = A B^T."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[j, 0] + A[i, 1] * B[j, 1] + A[i, 2] * B[j, 2]


@jit
def _mTm(A, B, out):
    """out = A^T B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[0, i] * B[0, j] + A[1, i] * B[1, j] + A[2, i] * B[2, j]


@jit
def _hat(v0, v1, v2, out):
    out[0, 0] = 0.0
    out[0, 1] = -v2
    out[0, 2] = v1
    out[1, 0] = v2
    out[1, 1] = 0.0
    out[1, 2] = -v0
    out[2, 0] = -v1
    out[2, 1] = v0
    out[2, 2] = 0.0


@jit
def _add_blk(core, s, t, M, alpha):
    """core[block s, block t] += alpha M."""
    for i in range(3):
        for j in range(3):
            core[3 * s + i, 3 * t + j] += alpha * M[i, j]


@jit
def _add_blkT(core, s, t, M, alpha):
    """core[block s, block t] += alpha M^T."""
    for i in range(3):
        for j in range(3):
            core[3 * s + i, 3 * t + j] += alpha * M[j, i]


# ----------------------------------------------------------------------------------------------------------
# Tangent-operator derivatives with precomputed coefficients (formulas of flexbody.lie.kernels; the
# coefficients of |phi| are computed once per point instead of once per call)
# co = (a1, a2, a3, a4, c2, c3, c4, e2, e3)
# ----------------------------------------------------------------------------------------------------------


@jit
def _dtan_into(p0, p1, p2, b, co, out):
    """out = X with (D T(phi)[v]) b = X v at phi = (p0, p1, p2) (kernels.d_tangent_into)."""
    a2, a3, c2, c3 = co[1], co[2], co[4], co[5]
    r0 = p1 * b[2] - p2 * b[1]
    r1 = p2 * b[0] - p0 * b[2]
    r2 = p0 * b[1] - p1 * b[0]
    q0 = p1 * r2 - p2 * r1
    q1 = p2 * r0 - p0 * r2
    q2 = p0 * r1 - p1 * r0
    pb = p0 * b[0] + p1 * b[1] + p2 * b[2]
    # X = a3 (phi.b) I + hat(a2 b - a3 r) + (c3 q - c2 r - a3 b) phi^T
    h0 = a2 * b[0] - a3 * r0
    h1 = a2 * b[1] - a3 * r1
    h2 = a2 * b[2] - a3 * r2
    w0 = c3 * q0 - c2 * r0 - a3 * b[0]
    w1 = c3 * q1 - c2 * r1 - a3 * b[1]
    w2 = c3 * q2 - c2 * r2 - a3 * b[2]
    dg = a3 * pb
    out[0, 0] = dg + w0 * p0
    out[0, 1] = -h2 + w0 * p1
    out[0, 2] = h1 + w0 * p2
    out[1, 0] = h2 + w1 * p0
    out[1, 1] = dg + w1 * p1
    out[1, 2] = -h0 + w1 * p2
    out[2, 0] = -h1 + w2 * p0
    out[2, 1] = h0 + w2 * p1
    out[2, 2] = dg + w2 * p2


@jit
def _dtan_inv_into(p0, p1, p2, b0, b1, b2, a4, c4, out):
    """out = X with (D T^-1(phi)[v]) b = X v (kernels.d_tangent_inv_into)."""
    r0 = p1 * b2 - p2 * b1
    r1 = p2 * b0 - p0 * b2
    r2 = p0 * b1 - p1 * b0
    q0 = p1 * r2 - p2 * r1
    q1 = p2 * r0 - p0 * r2
    q2 = p0 * r1 - p1 * r0
    pb = p0 * b0 + p1 * b1 + p2 * b2
    # X = a4 (phi.b) I + hat(-b/2 - a4 r) + (c4 q - a4 b) phi^T
    h0 = -0.5 * b0 - a4 * r0
    h1 = -0.5 * b1 - a4 * r1
    h2 = -0.5 * b2 - a4 * r2
    w0 = c4 * q0 - a4 * b0
    w1 = c4 * q1 - a4 * b1
    w2 = c4 * q2 - a4 * b2
    dg = a4 * pb
    out[0, 0] = dg + w0 * p0
    out[0, 1] = -h2 + w0 * p1
    out[0, 2] = h1 + w0 * p2
    out[1, 0] = h2 + w1 * p0
    out[1, 1] = dg + w1 * p1
    out[1, 2] = -h0 + w1 * p2
    out[2, 0] = -h1 + w2 * p0
    out[2, 1] = h0 + w2 * p1
    out[2, 2] = dg + w2 * p2


@jit
def _d2tan_add(phi, a, b, co, core, s, t):
    """core[block s, block t] += Y, a^T (D^2 T(phi)[v, w]) b = v^T Y w (kernels.d2_tangent_into)."""
    a3, c2, c3, e2, e3 = co[2], co[4], co[5], co[7], co[8]
    p0, p1, p2 = phi[0], phi[1], phi[2]
    r0 = p1 * b[2] - p2 * b[1]
    r1 = p2 * b[0] - p0 * b[2]
    r2 = p0 * b[1] - p1 * b[0]
    q0 = p1 * r2 - p2 * r1
    q1 = p2 * r0 - p0 * r2
    q2 = p0 * r1 - p1 * r0
    m0 = a[1] * b[2] - a[2] * b[1]
    m1 = a[2] * b[0] - a[0] * b[2]
    m2 = a[0] * b[1] - a[1] * b[0]
    # u = a x r + b x (phi x a)
    pa0 = p1 * a[2] - p2 * a[1]
    pa1 = p2 * a[0] - p0 * a[2]
    pa2 = p0 * a[1] - p1 * a[0]
    u0 = (a[1] * r2 - a[2] * r1) + (b[1] * pa2 - b[2] * pa1)
    u1 = (a[2] * r0 - a[0] * r2) + (b[2] * pa0 - b[0] * pa2)
    u2 = (a[0] * r1 - a[1] * r0) + (b[0] * pa1 - b[1] * pa0)
    ar = a[0] * r0 + a[1] * r1 + a[2] * r2
    aq = a[0] * q0 + a[1] * q1 + a[2] * q2
    ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    dg = c3 * aq - c2 * ar - 2.0 * a3 * ab
    sc = e3 * aq - e2 * ar
    pv = (p0, p1, p2)
    mv = (m0, m1, m2)
    uv = (u0, u1, u2)
    for i in range(3):
        for j in range(3):
            y = (c2 * (mv[i] * pv[j] + pv[i] * mv[j]) - c3 * (uv[i] * pv[j] + pv[i] * uv[j])
                 + a3 * (a[i] * b[j] + b[i] * a[j]) + sc * pv[i] * pv[j])
            if i == j:
                y += dg
            core[3 * s + i, 3 * t + j] += y


# ----------------------------------------------------------------------------------------------------------
# Element setup: nodal relative rotations
# ----------------------------------------------------------------------------------------------------------


@jit
def _node_setup(fr, dn, Ti, nco):
    """d_I = log(R_0^T R_I), Ti[I] = T^-1(d_I) (T^-1(-d_I) = Ti[I]^T), coefficients of |d_I|."""
    R0 = fr[0]
    for c in range(3):
        dn[0, c] = 0.0
        for k in range(3):
            Ti[0, c, k] = 1.0 if c == k else 0.0
    for i in range(1, 6):
        Ri = fr[i]
        M = Ti[i]  # scratch for R_0^T R_i
        for r in range(3):
            for c in range(3):
                M[r, c] = R0[0, r] * Ri[0, c] + R0[1, r] * Ri[1, c] + R0[2, r] * Ri[2, c]
        lk.log_into(M, dn[i])
        d0, d1, d2 = dn[i, 0], dn[i, 1], dn[i, 2]
        pp = d0 * d0 + d1 * d1 + d2 * d2
        co = lk.coefficients(math.sqrt(pp))
        for k in range(9):
            nco[i, k] = co[k]
        a4 = co[3]
        # T^-1 = (1 - a4 p^2) I + hat(d)/2 + a4 d d^T
        dv = (d0, d1, d2)
        for r in range(3):
            for c in range(3):
                M[r, c] = a4 * dv[r] * dv[c]
            M[r, r] += 1.0 - a4 * pp
        M[0, 1] -= 0.5 * d2
        M[0, 2] += 0.5 * d1
        M[1, 0] += 0.5 * d2
        M[1, 2] -= 0.5 * d0
        M[2, 0] -= 0.5 * d1
        M[2, 1] += 0.5 * d0


# ----------------------------------------------------------------------------------------------------------
# Point kinematics
# ----------------------------------------------------------------------------------------------------------


@jit
def _point_kinematics(x, fr, dn, N, dN, d, da, co, Q, T, R, F, X, with_x):
    """d, d_,a, coefficients, Q = exp(d), T(d), R = R_0 Q, F = [f_ru, f_su, f_rw, f_sw], X_a = DT(d)[.] d_,a."""
    for c in range(3):
        s = 0.0
        s0 = 0.0
        s1 = 0.0
        for i in range(1, 6):
            s += N[i] * dn[i, c]
            s0 += dN[0, i] * dn[i, c]
            s1 += dN[1, i] * dn[i, c]
        d[c] = s
        da[0, c] = s0
        da[1, c] = s1
    d0, d1, d2 = d[0], d[1], d[2]
    pp = d0 * d0 + d1 * d1 + d2 * d2
    cf = lk.coefficients(math.sqrt(pp))
    for k in range(9):
        co[k] = cf[k]
    a1, a2, a3 = cf[0], cf[1], cf[2]
    dv = (d0, d1, d2)
    # Q = cos I + a1 hat(d) + a2 d d^T, cos = 1 - a2 p^2;  T = (1 - a3 p^2) I - a2 hat(d) + a3 d d^T
    cq = 1.0 - a2 * pp
    ct = 1.0 - a3 * pp
    for r in range(3):
        for c in range(3):
            Q[r, c] = a2 * dv[r] * dv[c]
            T[r, c] = a3 * dv[r] * dv[c]
        Q[r, r] += cq
        T[r, r] += ct
    Q[0, 1] -= a1 * d2
    Q[0, 2] += a1 * d1
    Q[1, 0] += a1 * d2
    Q[1, 2] -= a1 * d0
    Q[2, 0] -= a1 * d1
    Q[2, 1] += a1 * d0
    T[0, 1] += a2 * d2
    T[0, 2] -= a2 * d1
    T[1, 0] -= a2 * d2
    T[1, 2] += a2 * d0
    T[2, 0] += a2 * d1
    T[2, 1] -= a2 * d0
    _mm(fr[0], Q, R)
    # f_au = R^T x_,a ;  f_aw = T d_,a
    for a in range(2):
        xa0 = 0.0
        xa1 = 0.0
        xa2 = 0.0
        for i in range(6):
            w = dN[a, i]
            xa0 += w * x[i, 0]
            xa1 += w * x[i, 1]
            xa2 += w * x[i, 2]
        for c in range(3):
            F[a, c] = R[0, c] * xa0 + R[1, c] * xa1 + R[2, c] * xa2
            F[2 + a, c] = T[c, 0] * da[a, 0] + T[c, 1] * da[a, 1] + T[c, 2] * da[a, 2]
    if with_x:
        _dtan_into(d0, d1, d2, da[0], co, X[0])
        _dtan_into(d0, d1, d2, da[1], co, X[1])


@jit
def _covariant_strains(F, e_ref, out):
    """out = covariant_strains(F) - e_ref (kinematics.covariant_strains)."""
    f0 = F[0]
    f1 = F[1]
    w0 = F[2]
    w1 = F[3]
    out[0] = 0.5 * (f0[0] * f0[0] + f0[1] * f0[1] + f0[2] * f0[2]) - e_ref[0]
    out[1] = 0.5 * (f1[0] * f1[0] + f1[1] * f1[1] + f1[2] * f1[2]) - e_ref[1]
    out[2] = 0.5 * (f0[0] * f1[0] + f0[1] * f1[1] + f0[2] * f1[2]) - e_ref[2]
    # a . hat(e3) b = a1 b0 - a0 b1
    out[3] = -(f0[1] * w0[0] - f0[0] * w0[1]) - e_ref[3]
    out[4] = -(f1[1] * w1[0] - f1[0] * w1[1]) - e_ref[4]
    out[5] = -0.5 * ((f0[1] * w1[0] - f0[0] * w1[1]) + (f1[1] * w0[0] - f1[0] * w0[1])) - e_ref[5]
    out[6] = f0[2] - e_ref[6]
    out[7] = f1[2] - e_ref[7]


@jit
def _strain_gradient_T(F, s, g):
    """g = D^T s (12): the weights [a_r, a_s, b_r, b_s] of the strain measures (kinematics.strain_gradient)."""
    f0 = F[0]
    f1 = F[1]
    w0 = F[2]
    w1 = F[3]
    h2 = 0.5 * s[2]
    h5 = 0.5 * s[5]
    # hat(e3) v = (-v1, v0, 0)
    for c in range(3):
        g[c] = s[0] * f0[c] + h2 * f1[c]
        g[3 + c] = s[1] * f1[c] + h2 * f0[c]
    # -s3 E w0 - s5/2 E w1 on a_r ; -s4 E w1 - s5/2 E w0 on a_s
    g[0] += s[3] * w0[1] + h5 * w1[1]
    g[1] -= s[3] * w0[0] + h5 * w1[0]
    g[3] += s[4] * w1[1] + h5 * w0[1]
    g[4] -= s[4] * w1[0] + h5 * w0[0]
    g[2] += s[6]
    g[5] += s[7]
    # b_r = s3 E f0 + s5/2 E f1 ; b_s = s4 E f1 + s5/2 E f0
    g[6] = -(s[3] * f0[1] + h5 * f1[1])
    g[7] = s[3] * f0[0] + h5 * f1[0]
    g[8] = 0.0
    g[9] = -(s[4] * f1[1] + h5 * f0[1])
    g[10] = s[4] * f1[0] + h5 * f0[0]
    g[11] = 0.0


@jit
def _strain_gradient_row(F, k, g):
    """g = row k of D (12)."""
    for c in range(12):
        g[c] = 0.0
    f0 = F[0]
    f1 = F[1]
    w0 = F[2]
    w1 = F[3]
    if k == 0:
        for c in range(3):
            g[c] = f0[c]
    elif k == 1:
        for c in range(3):
            g[3 + c] = f1[c]
    elif k == 2:
        for c in range(3):
            g[c] = 0.5 * f1[c]
            g[3 + c] = 0.5 * f0[c]
    elif k == 3:
        g[0] = w0[1]
        g[1] = -w0[0]
        g[6] = -f0[1]
        g[7] = f0[0]
    elif k == 4:
        g[3] = w1[1]
        g[4] = -w1[0]
        g[9] = -f1[1]
        g[10] = f1[0]
    elif k == 5:
        g[0] = 0.5 * w1[1]
        g[1] = -0.5 * w1[0]
        g[3] = 0.5 * w0[1]
        g[4] = -0.5 * w0[0]
        g[6] = -0.5 * f1[1]
        g[7] = 0.5 * f1[0]
        g[9] = -0.5 * f0[1]
        g[10] = 0.5 * f0[0]
    elif k == 6:
        g[2] = 1.0
    else:
        g[5] = 1.0


@jit
def _GT_times(g, F, Q, T, R, X, out):
    """out (18) = G_xi^T g: the slot components of the variation weighted by g = [a_r, a_s, b_r, b_s].

    G_xi rows f_au: [U_a: R^T, V0: hat(f_au) Q^T, V: hat(f_au) T]; rows f_aw: [V: X_a, W_a: T].
    """
    # c = a_r x f_ru + a_s x f_su
    c0 = (g[1] * F[0, 2] - g[2] * F[0, 1]) + (g[4] * F[1, 2] - g[5] * F[1, 1])
    c1 = (g[2] * F[0, 0] - g[0] * F[0, 2]) + (g[5] * F[1, 0] - g[3] * F[1, 2])
    c2 = (g[0] * F[0, 1] - g[1] * F[0, 0]) + (g[3] * F[1, 1] - g[4] * F[1, 0])
    for r in range(3):
        out[r] = R[r, 0] * g[0] + R[r, 1] * g[1] + R[r, 2] * g[2]
        out[3 + r] = R[r, 0] * g[3] + R[r, 1] * g[4] + R[r, 2] * g[5]
        out[6 + r] = Q[r, 0] * c0 + Q[r, 1] * c1 + Q[r, 2] * c2
        out[9 + r] = (T[0, r] * c0 + T[1, r] * c1 + T[2, r] * c2
                      + X[0, 0, r] * g[6] + X[0, 1, r] * g[7] + X[0, 2, r] * g[8]
                      + X[1, 0, r] * g[9] + X[1, 1, r] * g[10] + X[1, 2, r] * g[11])
        out[12 + r] = T[0, r] * g[6] + T[1, r] * g[7] + T[2, r] * g[8]
        out[15 + r] = T[0, r] * g[9] + T[1, r] * g[10] + T[2, r] * g[11]


# ----------------------------------------------------------------------------------------------------------
# Slot expansion xi -> z (Pi) and the change of variables z -> h (P)
# ----------------------------------------------------------------------------------------------------------


@jit
def _expand_vec(v, N, dN, out):
    """out (36) += Pi^T v (v in slots, 18)."""
    for i in range(6):
        a0 = dN[0, i]
        a1 = dN[1, i]
        for c in range(3):
            out[6 * i + c] += a0 * v[c] + a1 * v[3 + c]
    for c in range(3):
        out[3 + c] += v[6 + c]
    for i in range(1, 6):
        n = N[i]
        a0 = dN[0, i]
        a1 = dN[1, i]
        for c in range(3):
            out[6 * i + 3 + c] += n * v[9 + c] + a0 * v[12 + c] + a1 * v[15 + c]


@jit
def _expand_core(core, ns, N, dN, Y, Kz):
    """Kz (36 x 36) += Pi^T core Pi for the first ns slots of the 18 x 18 core."""
    nr = 3 * ns
    # stage 1: Y = core Pi (nr x 36)
    for r in range(nr):
        for i in range(6):
            a0 = dN[0, i]
            a1 = dN[1, i]
            for c in range(3):
                Y[r, 6 * i + c] = a0 * core[r, c] + a1 * core[r, 3 + c]
        for c in range(3):
            Y[r, 3 + c] = core[r, 6 + c]
        if ns == 6:
            for i in range(1, 6):
                n = N[i]
                a0 = dN[0, i]
                a1 = dN[1, i]
                for c in range(3):
                    Y[r, 6 * i + 3 + c] = n * core[r, 9 + c] + a0 * core[r, 12 + c] + a1 * core[r, 15 + c]
        else:
            for i in range(1, 6):
                n = N[i]
                for c in range(3):
                    Y[r, 6 * i + 3 + c] = n * core[r, 9 + c]
    # stage 2: Kz += Pi^T Y
    for i in range(6):
        a0 = dN[0, i]
        a1 = dN[1, i]
        for c in range(3):
            row = 6 * i + c
            for k in range(NDOF):
                Kz[row, k] += a0 * Y[c, k] + a1 * Y[3 + c, k]
    for c in range(3):
        for k in range(NDOF):
            Kz[3 + c, k] += Y[6 + c, k]
    for i in range(1, 6):
        n = N[i]
        a0 = dN[0, i]
        a1 = dN[1, i]
        for c in range(3):
            row = 6 * i + 3 + c
            if ns == 6:
                for k in range(NDOF):
                    Kz[row, k] += n * Y[9 + c, k] + a0 * Y[12 + c, k] + a1 * Y[15 + c, k]
            else:
                for k in range(NDOF):
                    Kz[row, k] += n * Y[9 + c, k]


@jit
def _force_to_local(fz, fr, Ti, f):
    """f = P^T fz: f_u,I = R_I^T fz[x_I], f_theta,I = T_I^T fz[d_I], f_theta,0 = fz[theta_0] - sum T_I fz[d_I]."""
    for i in range(6):
        R = fr[i]
        for c in range(3):
            f[6 * i + c] = R[0, c] * fz[6 * i] + R[1, c] * fz[6 * i + 1] + R[2, c] * fz[6 * i + 2]
    for c in range(3):
        f[3 + c] = fz[3 + c]
    for i in range(1, 6):
        Tm = Ti[i]
        e0 = fz[6 * i + 3]
        e1 = fz[6 * i + 4]
        e2 = fz[6 * i + 5]
        for c in range(3):
            f[6 * i + 3 + c] = Tm[0, c] * e0 + Tm[1, c] * e1 + Tm[2, c] * e2
            f[3 + c] -= Tm[c, 0] * e0 + Tm[c, 1] * e1 + Tm[c, 2] * e2


@jit
def _tangent_to_local(Kz, fr, Ti, K1, K):
    """K = P^T Kz P."""
    # K1 = Kz P
    for r in range(NDOF):
        for i in range(6):
            R = fr[i]
            k0 = Kz[r, 6 * i]
            k1 = Kz[r, 6 * i + 1]
            k2 = Kz[r, 6 * i + 2]
            for c in range(3):
                K1[r, 6 * i + c] = k0 * R[0, c] + k1 * R[1, c] + k2 * R[2, c]
        t0 = Kz[r, 3]
        t1 = Kz[r, 4]
        t2 = Kz[r, 5]
        for i in range(1, 6):
            Tm = Ti[i]
            k0 = Kz[r, 6 * i + 3]
            k1 = Kz[r, 6 * i + 4]
            k2 = Kz[r, 6 * i + 5]
            for c in range(3):
                K1[r, 6 * i + 3 + c] = k0 * Tm[0, c] + k1 * Tm[1, c] + k2 * Tm[2, c]
            # - Kz[r, d_i] T_i^T
            t0 -= k0 * Tm[0, 0] + k1 * Tm[0, 1] + k2 * Tm[0, 2]
            t1 -= k0 * Tm[1, 0] + k1 * Tm[1, 1] + k2 * Tm[1, 2]
            t2 -= k0 * Tm[2, 0] + k1 * Tm[2, 1] + k2 * Tm[2, 2]
        K1[r, 3] = t0
        K1[r, 4] = t1
        K1[r, 5] = t2
    # K = P^T K1
    for i in range(6):
        R = fr[i]
        for c in range(3):
            w0 = R[0, c]
            w1 = R[1, c]
            w2 = R[2, c]
            for k in range(NDOF):
                K[6 * i + c, k] = w0 * K1[6 * i, k] + w1 * K1[6 * i + 1, k] + w2 * K1[6 * i + 2, k]
    for c in range(3):
        for k in range(NDOF):
            K[3 + c, k] = K1[3 + c, k]
    for i in range(1, 6):
        Tm = Ti[i]
        for c in range(3):
            w0 = Tm[0, c]
            w1 = Tm[1, c]
            w2 = Tm[2, c]
            v0 = Tm[c, 0]
            v1 = Tm[c, 1]
            v2 = Tm[c, 2]
            for k in range(NDOF):
                a = K1[6 * i + 3, k]
                b = K1[6 * i + 4, k]
                e = K1[6 * i + 5, k]
                K[6 * i + 3 + c, k] = w0 * a + w1 * b + w2 * e
                K[3 + c, k] -= v0 * a + v1 * b + v2 * e


@jit
def _node_terms(f, fz, dn, Ti, nco, K, tm):
    """K += (D P^T[.]) fz: hat(f_u,I) in (u_I, theta_I) and the D T^-1 terms of Delta(delta d_I)."""
    for i in range(6):
        u0 = f[6 * i]
        u1 = f[6 * i + 1]
        u2 = f[6 * i + 2]
        r = 6 * i
        c = 6 * i + 3
        K[r, c + 1] -= u2
        K[r, c + 2] += u1
        K[r + 1, c] += u2
        K[r + 1, c + 2] -= u0
        K[r + 2, c] -= u1
        K[r + 2, c + 1] += u0
    Dp = tm[0]
    Dm = tm[1]
    M = tm[2]
    for i in range(1, 6):
        e0 = fz[6 * i + 3]
        e1 = fz[6 * i + 4]
        e2 = fz[6 * i + 5]
        a4 = nco[i, 3]
        c4 = nco[i, 6]
        _dtan_inv_into(dn[i, 0], dn[i, 1], dn[i, 2], e0, e1, e2, a4, c4, Dp)
        # D T^-1(-d)[.] e = -hat(e) - D T^-1(d)[.] e
        _hat(-e0, -e1, -e2, Dm)
        for r in range(3):
            for c in range(3):
                Dm[r, c] -= Dp[r, c]
        Tm = Ti[i]
        t = 6 * i + 3
        _mm(Dm, Tm, M)       # theta_i, theta_i: -Dm T_i
        for r in range(3):
            for c in range(3):
                K[t + r, t + c] -= M[r, c]
        _mmT(Dm, Tm, M)      # theta_i, theta_0: +Dm T_i^T
        for r in range(3):
            for c in range(3):
                K[t + r, 3 + c] += M[r, c]
        _mm(Dp, Tm, M)       # theta_0, theta_i: -Dp T_i
        for r in range(3):
            for c in range(3):
                K[3 + r, t + c] -= M[r, c]
        _mmT(Dp, Tm, M)      # theta_0, theta_0: +Dp T_i^T
        for r in range(3):
            for c in range(3):
                K[3 + r, 3 + c] += M[r, c]


# ----------------------------------------------------------------------------------------------------------
# The contracted second variation and G^T Hf G at a point, in slots
# ----------------------------------------------------------------------------------------------------------


@jit
def _geometric_core(s, g, F, Q, T, R, X, d, da, co, core, ns, tm):
    """core (slots) = G_xi^T Hf(s) G_xi + second variation contracted with g = D^T s (minus node terms).

    Closed forms of kinematics.strain_hessian / second_variation in the slots, with
    m_a = sum_b A_ab f_bu (A = [[s0, s2/2], [s2/2, s1]]), n_a = m_a - a_a, c = sum_a a_a x f_au and
    Omega = sum_a (f_au a_a^T - m_a f_au^T + (f_au . n_a) I).
    """
    nr = 3 * ns
    for i in range(nr):
        for j in range(nr):
            core[i, j] = 0.0
    f0 = F[0]
    f1 = F[1]
    A01 = 0.5 * s[2]
    Om = tm[0]
    nvec = tm[7]  # rows 0, 1: n_a ; row 2: c
    dot = 0.0
    for c in range(3):
        m0 = s[0] * f0[c] + A01 * f1[c]
        m1 = A01 * f0[c] + s[1] * f1[c]
        nvec[0, c] = m0 - g[c]
        nvec[1, c] = m1 - g[3 + c]
        dot += f0[c] * nvec[0, c] + f1[c] * nvec[1, c]
    for i in range(3):
        m0i = s[0] * f0[i] + A01 * f1[i]
        m1i = A01 * f0[i] + s[1] * f1[i]
        for j in range(3):
            Om[i, j] = f0[i] * g[j] + f1[i] * g[3 + j] - m0i * f0[j] - m1i * f1[j]
        Om[i, i] += dot
    cc0 = (g[1] * f0[2] - g[2] * f0[1]) + (g[4] * f1[2] - g[5] * f1[1])
    cc1 = (g[2] * f0[0] - g[0] * f0[2]) + (g[5] * f1[0] - g[3] * f1[2])
    cc2 = (g[0] * f0[1] - g[1] * f0[0]) + (g[3] * f1[1] - g[4] * f1[0])
    # U-U: A_ab I
    for c in range(3):
        core[c, c] += s[0]
        core[3 + c, 3 + c] += s[1]
        core[c, 3 + c] += A01
        core[3 + c, c] += A01
    # U_a - V0 / V: R hat(n_a) Q^T, R hat(n_a) T and their transposes
    H = tm[1]
    RH = tm[2]
    M = tm[3]
    for a in range(2):
        _hat(nvec[a, 0], nvec[a, 1], nvec[a, 2], H)
        _mm(R, H, RH)
        _mmT(RH, Q, M)
        _add_blk(core, a, _V0, M, 1.0)
        _add_blkT(core, _V0, a, M, 1.0)
        _mm(RH, T, M)
        _add_blk(core, a, _V, M, 1.0)
        _add_blkT(core, _V, a, M, 1.0)
    # V0 / V blocks
    OQ = tm[1]
    _mmT(Om, Q, OQ)                 # Omega Q^T
    _mm(Q, OQ, M)
    _add_blk(core, _V0, _V0, M, 1.0)
    _mTm(T, OQ, M)
    _add_blk(core, _V, _V0, M, 1.0)
    TO = tm[2]
    _mTm(T, Om, TO)
    _mm(TO, T, M)
    _add_blk(core, _V, _V, M, 1.0)
    # [V0, V] = Q (Omega - hat(c)) T
    Om[0, 1] += cc2
    Om[0, 2] -= cc1
    Om[1, 0] -= cc2
    Om[1, 2] += cc0
    Om[2, 0] += cc1
    Om[2, 1] -= cc0
    _mm(Q, Om, TO)
    _mm(TO, T, M)
    _add_blk(core, _V0, _V, M, 1.0)
    # [V, V] -= D T(-d)[.] c
    nvec[2, 0] = cc0
    nvec[2, 1] = cc1
    nvec[2, 2] = cc2
    _dtan_into(-d[0], -d[1], -d[2], nvec[2], co, M)
    _add_blk(core, _V, _V, M, -1.0)
    if ns < 6:
        return
    # ---- terms of the bending weights: Hf couplings f_u - f_w and the b-terms of the second variation
    b3 = s[3]
    b4 = s[4]
    b5 = 0.5 * s[5]
    # beta_ab couples f_au with f_bw: [[s3, s5/2], [s5/2, s4]]; h_b = sum_a beta_ab f_au
    hv = tm[6]
    for c in range(3):
        hv[0, c] = b3 * f0[c] + b5 * f1[c]
        hv[1, c] = b5 * f0[c] + b4 * f1[c]
    # RE = R hat(e3): columns (R[:,1], -R[:,0], 0)
    RE = tm[1]
    for r in range(3):
        RE[r, 0] = R[r, 1]
        RE[r, 1] = -R[r, 0]
        RE[r, 2] = 0.0
    RET = tm[2]
    _mm(RE, T, RET)
    S = tm[4]
    for a in range(2):
        ba0 = b3 if a == 0 else b5
        ba1 = b5 if a == 0 else b4
        # Z[U_a, V] = -R E (sum_b beta_ab X_b)
        for r in range(3):
            for c in range(3):
                S[r, c] = ba0 * X[0, r, c] + ba1 * X[1, r, c]
        _mm(RE, S, M)
        _add_blk(core, a, _V, M, -1.0)
        _add_blkT(core, _V, a, M, -1.0)
        # Z[U_a, W_b] = -beta_ab R E T
        _add_blk(core, a, _W0, RET, -ba0)
        _add_blkT(core, _W0, a, RET, -ba0)
        _add_blk(core, a, _W1, RET, -ba1)
        _add_blkT(core, _W1, a, RET, -ba1)
    # HX = sum_b hat(h_b) E X_b,  hat(h) E = e3 h^T - h_2 I
    HX = tm[4]
    for r in range(3):
        for c in range(3):
            HX[r, c] = -(hv[0, 2] * X[0, r, c] + hv[1, 2] * X[1, r, c])
    for c in range(3):
        HX[2, c] += (hv[0, 0] * X[0, 0, c] + hv[0, 1] * X[0, 1, c] + hv[0, 2] * X[0, 2, c]
                     + hv[1, 0] * X[1, 0, c] + hv[1, 1] * X[1, 1, c] + hv[1, 2] * X[1, 2, c])
    _mm(Q, HX, M)
    _add_blk(core, _V0, _V, M, 1.0)
    _add_blkT(core, _V, _V0, M, 1.0)
    _mTm(T, HX, M)
    _add_blk(core, _V, _V, M, 1.0)
    _add_blkT(core, _V, _V, M, 1.0)
    # Z[V0, W_b] = Q hat(h_b) E T, Z[V, W_b] = T^T hat(h_b) E T
    HT = tm[5]
    for b in range(2):
        for r in range(3):
            for c in range(3):
                HT[r, c] = -hv[b, 2] * T[r, c]
        for c in range(3):
            HT[2, c] += hv[b, 0] * T[0, c] + hv[b, 1] * T[1, c] + hv[b, 2] * T[2, c]
        _mm(Q, HT, M)
        _add_blk(core, _V0, _W0 + b, M, 1.0)
        _add_blkT(core, _W0 + b, _V0, M, 1.0)
        _mTm(T, HT, M)
        _add_blk(core, _V, _W0 + b, M, 1.0)
        _add_blkT(core, _W0 + b, _V, M, 1.0)
    # second variation: D^2 T(d)[., .] contracted with b_a, d_,a ; Z_a = -D T(-d)[.] b_a
    for a in range(2):
        ba = g[6 + 3 * a:9 + 3 * a]
        _d2tan_add(d, ba, da[a], co, core, _V, _V)
        _dtan_into(-d[0], -d[1], -d[2], ba, co, M)
        _add_blkT(core, _V, _W0 + a, M, -1.0)
        _add_blk(core, _W0 + a, _V, M, -1.0)


# ----------------------------------------------------------------------------------------------------------
# One element
# ----------------------------------------------------------------------------------------------------------


@jit
def _element(x, fr, e_ref, to_cart, wts, C, used, nz_g, nz_i, nz_p, nz_j, nz_v,
             need_b, pt_gauss, loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
             nl_rows, n_nl, nl_ptr, nl_i, nl_k, nl_v, smp_p, smp_j,
             want_tangent, f_out, K_out,
             dn, Ti, nco, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, Ps, Pg, PB,
             cov, st, Ch, phi, fz, g12, core, Y, Kz, K1, S, Bl, CBl, Bn, CBn, tm):
    """Internal force (and tangent) of one element into f_out (36,) and K_out (36, 36)."""
    n_used = used.shape[0]
    _node_setup(fr, dn, Ti, nco)
    for k in range(n_used):
        p = used[k]
        _point_kinematics(x, fr, dn, _EVAL_N[p], _EVAL_DN[p], Pd[p], Pda[p], Pco[p], PQ[p], PT[p], PR[p],
                          PF[p], PX[p], True)
        _covariant_strains(PF[p], e_ref[p], Pe[p])
    # assumed covariant strains -> Cartesian strains -> stress resultants -> covariant stress weights s_p
    for gg in range(N_GAUSS):
        for i in range(8):
            cov[gg, i] = 0.0
    for q in range(nz_g.shape[0]):
        cov[nz_g[q], nz_i[q]] += nz_v[q] * Pe[nz_p[q], nz_j[q]]
    for gg in range(N_GAUSS):
        Tg = to_cart[gg]
        w = wts[gg]
        for r in range(8):  # eps in g12[0:8], sigma in g12[8:12] + phi[0:4] (scratch)
            acc = 0.0
            for c in range(8):
                acc += Tg[r, c] * cov[gg, c]
            phi[r] = acc
        for r in range(8):
            acc = 0.0
            for c in range(8):
                acc += C[r, c] * phi[c]
            phi[8 + r] = w * acc
        for c in range(8):
            acc = 0.0
            for r in range(8):
                acc += Tg[r, c] * phi[8 + r]
            st[gg, c] = acc
    for k in range(n_used):
        p = used[k]
        for j in range(8):
            Ps[p, j] = 0.0
    for q in range(nz_g.shape[0]):
        Ps[nz_p[q], nz_j[q]] += nz_v[q] * st[nz_g[q], nz_i[q]]
    # force: fz = sum_p Pi_p^T G_xi^T D^T s_p
    for r in range(NDOF):
        fz[r] = 0.0
    for k in range(n_used):
        p = used[k]
        _strain_gradient_T(PF[p], Ps[p], Pg[p])
        _GT_times(Pg[p], PF[p], PQ[p], PT[p], PR[p], PX[p], phi)
        _expand_vec(phi, _EVAL_N[p], _EVAL_DN[p], fz)
    _force_to_local(fz, fr, Ti, f_out)
    if not want_tangent:
        return
    # ---- tangent, in z
    # covariant section per Gauss point: Ch_g = w_g T_g^T C T_g
    for gg in range(N_GAUSS):
        Tg = to_cart[gg]
        w = wts[gg]
        Cg = Ch[gg]
        for r in range(8):
            for c in range(8):
                acc = 0.0
                for k2 in range(8):
                    t = Tg[k2, c]
                    if t != 0.0:
                        acc += C[r, k2] * t
                K1[r, c] = acc  # C T_g (scratch)
        for r in range(8):
            for c in range(8):
                acc = 0.0
                for k2 in range(8):
                    t = Tg[k2, r]
                    if t != 0.0:
                        acc += t * K1[k2, c]
                Cg[r, c] = w * acc
    # B rows in slots where needed
    for k in range(n_used):
        p = used[k]
        for j in range(8):
            if need_b[p, j]:
                _strain_gradient_row(PF[p], j, g12)
                _GT_times(g12, PF[p], PQ[p], PT[p], PR[p], PX[p], PB[p, j])
    for r in range(NDOF):
        for c in range(NDOF):
            Kz[r, c] = 0.0
    # points: geometric terms (+ local material rows at Gauss points), expanded into z
    for k in range(n_used):
        p = used[k]
        s = Ps[p]
        gg = pt_gauss[p]
        bend = s[3] != 0.0 or s[4] != 0.0 or s[5] != 0.0
        ns = 6 if (bend or gg >= 0) else 4
        _geometric_core(s, Pg[p], PF[p], PQ[p], PT[p], PR[p], PX[p], Pd[p], Pda[p], Pco[p], core, ns, tm)
        if gg >= 0:
            nl = n_loc[gg]
            for li in range(nl):
                for c in range(18):
                    Bl[li, c] = 0.0
            for q in range(loc_ptr[gg], loc_ptr[gg + 1]):
                v = loc_v[q]
                src = PB[p, loc_j[q]]
                dst = Bl[loc_i[q]]
                for c in range(18):
                    dst[c] += v * src[c]
            Cg = Ch[gg]
            for li in range(nl):
                for c in range(18):
                    acc = 0.0
                    for lj in range(nl):
                        acc += Cg[loc_rows[gg, li], loc_rows[gg, lj]] * Bl[lj, c]
                    CBl[li, c] = acc
            for li in range(nl):
                for r in range(18):
                    b = Bl[li, r]
                    if b != 0.0:
                        for c in range(18):
                            core[r, c] += b * CBl[li, c]
        _expand_core(core, ns, _EVAL_N[p], _EVAL_DN[p], Y, Kz)
    # nonlocal material rows (assumed membrane / shear from the tying points)
    n_smp = smp_p.shape[0]
    if n_smp > 0:
        for k in range(n_smp):
            for c in range(NDOF):
                S[k, c] = 0.0
            p = smp_p[k]
            _expand_vec(PB[p, smp_j[k]], _EVAL_N[p], _EVAL_DN[p], S[k])
        for r in range(NDOF):
            for c in range(NDOF):
                K1[r, c] = 0.0  # symmetric material part, upper triangle
        for gg in range(N_GAUSS):
            nn = n_nl[gg]
            if nn == 0:
                continue
            for li in range(nn):
                for c in range(NDOF):
                    Bn[li, c] = 0.0
            for q in range(nl_ptr[gg], nl_ptr[gg + 1]):
                v = nl_v[q]
                src = S[nl_k[q]]
                dst = Bn[nl_i[q]]
                for c in range(NDOF):
                    dst[c] += v * src[c]
            Cg = Ch[gg]
            for li in range(nn):
                for c in range(NDOF):
                    acc = 0.0
                    for lj in range(nn):
                        acc += Cg[nl_rows[gg, li], nl_rows[gg, lj]] * Bn[lj, c]
                    CBn[li, c] = acc
            for li in range(nn):
                for r in range(NDOF):
                    b = Bn[li, r]
                    if b != 0.0:
                        for c in range(r, NDOF):
                            K1[r, c] += b * CBn[li, c]
            # coupling of local and nonlocal rows through the section (zero for a block-diagonal section)
            nl_ = n_loc[gg]
            cross = False
            for li in range(nl_):
                for lj in range(nn):
                    if Ch[gg, loc_rows[gg, li], nl_rows[gg, lj]] != 0.0:
                        cross = True
            if cross:
                _cross_terms(gg, nl_, nn, loc_rows, nl_rows, loc_ptr, loc_i, loc_j, loc_v, Ch, PB, Bn,
                             Bl, CBn, Y, Kz)
        for r in range(NDOF):
            for c in range(r + 1, NDOF):
                v = K1[r, c]
                Kz[r, c] += v
                Kz[c, r] += v
            Kz[r, r] += K1[r, r]
    _tangent_to_local(Kz, fr, Ti, K1, K_out)
    _node_terms(f_out, fz, dn, Ti, nco, K_out, tm)


@jit
def _cross_terms(gg, nl_, nn, loc_rows, nl_rows, loc_ptr, loc_i, loc_j, loc_v, Ch, PB, Bn, Bl, CBn, Y, Kz):
    """Kz += W + W^T, W = Pi_g^T Bl^T Ch[loc, nl] Bn (a section coupling local and nonlocal rows; rare)."""
    p = GAUSS_OFFSET + gg
    for li in range(nl_):
        for c in range(18):
            Bl[li, c] = 0.0
    for q in range(loc_ptr[gg], loc_ptr[gg + 1]):
        v = loc_v[q]
        for c in range(18):
            Bl[loc_i[q], c] += v * PB[p, loc_j[q], c]
    for li in range(nl_):
        for c in range(NDOF):
            acc = 0.0
            for lj in range(nn):
                acc += Ch[gg, loc_rows[gg, li], nl_rows[gg, lj]] * Bn[lj, c]
            CBn[li, c] = acc
    # Y (18 x 36) = Bl^T CBn ; W = Pi^T Y, row by row
    for r in range(18):
        for c in range(NDOF):
            acc = 0.0
            for li in range(nl_):
                acc += Bl[li, r] * CBn[li, c]
            Y[r, c] = acc
    N = _EVAL_N[p]
    dN = _EVAL_DN[p]
    for i in range(6):
        for c in range(3):
            for k in range(NDOF):
                w = dN[0, i] * Y[c, k] + dN[1, i] * Y[3 + c, k]
                Kz[6 * i + c, k] += w
                Kz[k, 6 * i + c] += w
            if i == 0:
                for k in range(NDOF):
                    w = Y[6 + c, k]
                    Kz[3 + c, k] += w
                    Kz[k, 3 + c] += w
            else:
                for k in range(NDOF):
                    w = N[i] * Y[9 + c, k] + dN[0, i] * Y[12 + c, k] + dN[1, i] * Y[15 + c, k]
                    Kz[6 * i + 3 + c, k] += w
                    Kz[k, 6 * i + 3 + c] += w


# ----------------------------------------------------------------------------------------------------------
# Strains only
# ----------------------------------------------------------------------------------------------------------


@jit
def _element_strains(x, fr, e_ref, to_cart, used, nz_g, nz_i, nz_p, nz_j, nz_v, out,
                     dn, Ti, nco, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, cov):
    _node_setup(fr, dn, Ti, nco)
    for k in range(used.shape[0]):
        p = used[k]
        _point_kinematics(x, fr, dn, _EVAL_N[p], _EVAL_DN[p], Pd[p], Pda[p], Pco[p], PQ[p], PT[p], PR[p],
                          PF[p], PX[p], False)
        _covariant_strains(PF[p], e_ref[p], Pe[p])
    for gg in range(N_GAUSS):
        for i in range(8):
            cov[gg, i] = 0.0
    for q in range(nz_g.shape[0]):
        cov[nz_g[q], nz_i[q]] += nz_v[q] * Pe[nz_p[q], nz_j[q]]
    for gg in range(N_GAUSS):
        for r in range(8):
            acc = 0.0
            for c in range(8):
                acc += to_cart[gg, r, c] * cov[gg, c]
            out[gg, r] = acc


# ----------------------------------------------------------------------------------------------------------
# Batches
# ----------------------------------------------------------------------------------------------------------


@numba.njit(cache=True, parallel=True)
def _batch(x_el, fr_el, e_ref, to_cart, weights, C, used, nz_g, nz_i, nz_p, nz_j, nz_v,
           need_b, pt_gauss, loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
           nl_rows, n_nl, nl_ptr, nl_i, nl_k, nl_v, smp_p, smp_j,
           want_tangent, n_chunks, f, K):
    m = x_el.shape[0]
    n_smp = max(smp_p.shape[0], 1)
    for ch in prange(n_chunks):
        # per-chunk workspaces (a few chunks per thread), reused for every element of the chunk
        dn = np.empty((6, 3))
        Ti = np.empty((6, 3, 3))
        nco = np.empty((6, 9))
        Pd = np.empty((N_EVAL, 3))
        Pda = np.empty((N_EVAL, 2, 3))
        Pco = np.empty((N_EVAL, 9))
        PQ = np.empty((N_EVAL, 3, 3))
        PT = np.empty((N_EVAL, 3, 3))
        PR = np.empty((N_EVAL, 3, 3))
        PF = np.empty((N_EVAL, 4, 3))
        PX = np.empty((N_EVAL, 2, 3, 3))
        Pe = np.empty((N_EVAL, 8))
        Ps = np.empty((N_EVAL, 8))
        Pg = np.empty((N_EVAL, 12))
        PB = np.empty((N_EVAL, 8, 18))
        cov = np.empty((N_GAUSS, 8))
        st = np.empty((N_GAUSS, 8))
        Ch = np.empty((N_GAUSS, 8, 8))
        phi = np.empty(18)
        fz = np.empty(NDOF)
        g12 = np.empty(12)
        core = np.empty((18, 18))
        Y = np.empty((18, NDOF))
        Kz = np.empty((NDOF, NDOF))
        K1 = np.empty((NDOF, NDOF))
        S = np.empty((n_smp, NDOF))
        Bl = np.empty((8, 18))
        CBl = np.empty((8, 18))
        Bn = np.empty((8, NDOF))
        CBn = np.empty((8, NDOF))
        tm = np.empty((8, 3, 3))
        e0 = (ch * m) // n_chunks
        e1 = ((ch + 1) * m) // n_chunks
        for e in range(e0, e1):
            Ke = K[e] if want_tangent else K[0]
            _element(x_el[e], fr_el[e], e_ref[e], to_cart[e], weights[e], C, used, nz_g, nz_i, nz_p, nz_j, nz_v,
                     need_b, pt_gauss, loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
                     nl_rows, n_nl, nl_ptr, nl_i, nl_k, nl_v, smp_p, smp_j,
                     want_tangent, f[e], Ke,
                     dn, Ti, nco, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, Ps, Pg, PB,
                     cov, st, Ch, phi, fz, g12, core, Y, Kz, K1, S, Bl, CBl, Bn, CBn, tm)


@numba.njit(cache=True, parallel=True)
def _batch_strains(x_el, fr_el, e_ref, to_cart, used, nz_g, nz_i, nz_p, nz_j, nz_v, n_chunks, out):
    m = x_el.shape[0]
    for ch in prange(n_chunks):
        dn = np.empty((6, 3))
        Ti = np.empty((6, 3, 3))
        nco = np.empty((6, 9))
        Pd = np.empty((N_EVAL, 3))
        Pda = np.empty((N_EVAL, 2, 3))
        Pco = np.empty((N_EVAL, 9))
        PQ = np.empty((N_EVAL, 3, 3))
        PT = np.empty((N_EVAL, 3, 3))
        PR = np.empty((N_EVAL, 3, 3))
        PF = np.empty((N_EVAL, 4, 3))
        PX = np.empty((N_EVAL, 2, 3, 3))
        Pe = np.empty((N_EVAL, 8))
        cov = np.empty((N_GAUSS, 8))
        e0 = (ch * m) // n_chunks
        e1 = ((ch + 1) * m) // n_chunks
        for e in range(e0, e1):
            _element_strains(x_el[e], fr_el[e], e_ref[e], to_cart[e], used, nz_g, nz_i, nz_p, nz_j, nz_v, out[e],
                             dn, Ti, nco, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, cov)


# ----------------------------------------------------------------------------------------------------------
# Python side: compressed assumed-strain maps
# ----------------------------------------------------------------------------------------------------------


class CompressedMaps:
    """Sparse form of A (7, 8, 17, 8) for the kernels (see the module docstring)."""

    def __init__(self, A: np.ndarray) -> None:
        A = np.asarray(A, dtype=np.float64)
        if A.shape != (N_GAUSS, 8, N_EVAL, 8):
            raise ValueError(f"A must have shape {(N_GAUSS, 8, N_EVAL, 8)}, got {A.shape}")
        g, i, p, j = np.nonzero(A)
        v = A[g, i, p, j]
        self.nz_g, self.nz_i, self.nz_p, self.nz_j = (a.astype(np.int64) for a in (g, i, p, j))
        self.nz_v = v.astype(np.float64)
        self.used = np.unique(p).astype(np.int64)
        own = GAUSS_OFFSET + np.arange(N_GAUSS)
        # a row of Gauss point g is local when all its entries refer to g's own evaluation point
        has = np.zeros((N_GAUSS, 8), bool)
        other = np.zeros((N_GAUSS, 8), bool)
        has[g, i] = True
        other[g[p != own[g]], i[p != own[g]]] = True
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
        # nonlocal entries refer to sampled rows (p, j)
        is_nl = ~is_loc
        pairs = sorted({(int(pp), int(jj)) for pp, jj in zip(p[is_nl], j[is_nl])})
        sample_index = {pair: k for k, pair in enumerate(pairs)}
        self.smp_p = np.array([pp for pp, _ in pairs], np.int64)
        self.smp_j = np.array([jj for _, jj in pairs], np.int64)
        order = np.argsort(g[is_nl], kind="stable")
        gn, in_, pn, jn, vn = g[is_nl][order], i[is_nl][order], p[is_nl][order], j[is_nl][order], v[is_nl][order]
        self.nl_i = nl_index[gn, in_].astype(np.int64)
        self.nl_k = np.array([sample_index[(int(a), int(b))] for a, b in zip(pn, jn)], np.int64)
        self.nl_v = vn
        self.nl_ptr = np.searchsorted(gn, np.arange(N_GAUSS + 1)).astype(np.int64)
        self.need_b = np.zeros((N_EVAL, 8), bool)
        self.need_b[self.smp_p, self.smp_j] = True
        for gg in range(N_GAUSS):
            self.need_b[own[gg], self.loc_j[self.loc_ptr[gg]:self.loc_ptr[gg + 1]]] = True
        self.pt_gauss = -np.ones(N_EVAL, np.int64)
        for gg in range(N_GAUSS):
            if self.n_loc[gg] > 0:
                self.pt_gauss[own[gg]] = gg

    def nonzeros(self):
        return self.used, self.nz_g, self.nz_i, self.nz_p, self.nz_j, self.nz_v

    def kernel_args(self):
        return (self.used, self.nz_g, self.nz_i, self.nz_p, self.nz_j, self.nz_v,
                self.need_b, self.pt_gauss, self.loc_rows, self.n_loc, self.loc_ptr, self.loc_i, self.loc_j,
                self.loc_v, self.nl_rows, self.n_nl, self.nl_ptr, self.nl_i, self.nl_k, self.nl_v,
                self.smp_p, self.smp_j)


_MAP_CACHE: dict[bytes, CompressedMaps] = {}


def compress_maps(A: np.ndarray) -> CompressedMaps:
    """Compressed form of an assumed-strain map (cached on its contents)."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    key = A.tobytes()
    maps = _MAP_CACHE.get(key)
    if maps is None:
        if len(_MAP_CACHE) > 8:
            _MAP_CACHE.clear()
        maps = _MAP_CACHE[key] = CompressedMaps(A)
    return maps


def _n_chunks(m: int) -> int:
    return max(1, min(m, 4 * numba.get_num_threads()))


def _as(a, shape_tail, name):
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.shape[1:] != shape_tail:
        raise ValueError(f"{name} must have shape (m, {', '.join(map(str, shape_tail))}), got {a.shape}")
    return a


def internal_force_tangent_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray,
                                 to_cart: np.ndarray, weights: np.ndarray, section: np.ndarray,
                                 A: np.ndarray, want_tangent: bool = True):
    """Internal forces (m, 36) and tangents (m, 36, 36) of m elements, per node [u, theta], local frames.

    Parameters
    ----------
    x_el : (m, 6, 3) nodal positions;  frames_el : (m, 6, 3, 3) nodal frames
    e_ref : (m, 17, 8), to_cart : (m, 7, 8, 8), weights : (m, 7)  reference data (geometry.element_geometry)
    section : (8, 8) symmetric section stiffness
    A : (7, 8, 17, 8) assumed-strain map (element_reference.assumed_strain_maps(tying))
    want_tangent : False gives the residual-only path (no tangent, no second variation); K is then None.
    """
    x_el = _as(x_el, (6, 3), "x_el")
    m = x_el.shape[0]
    frames_el = _as(frames_el, (6, 3, 3), "frames_el")
    e_ref = _as(e_ref, (N_EVAL, 8), "e_ref")
    to_cart = _as(to_cart, (N_GAUSS, 8, 8), "to_cart")
    weights = _as(weights, (N_GAUSS,), "weights")
    if not (len(frames_el) == len(e_ref) == len(to_cart) == len(weights) == m):
        raise ValueError("all element arrays must have the same number of elements")
    C = np.ascontiguousarray(section, dtype=np.float64)
    if C.shape != (8, 8):
        raise ValueError(f"section must be (8, 8), got {C.shape}")
    if not np.allclose(C, C.T, rtol=1e-12, atol=1e-12 * np.abs(C).max()):
        raise ValueError("section stiffness must be symmetric")
    maps = compress_maps(A)
    f = np.zeros((m, NDOF))
    K = np.zeros((m, NDOF, NDOF)) if want_tangent else np.zeros((1, NDOF, NDOF))
    if m == 0:
        return f, (K if want_tangent else None)
    _batch(x_el, frames_el, e_ref, to_cart, weights, C, *maps.kernel_args(),
           bool(want_tangent), _n_chunks(m), f, K)
    return f, (K if want_tangent else None)


def element_strains_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                          A: np.ndarray) -> np.ndarray:
    """Cartesian strains [membrane | bending | shear] at the 7 Gauss points of m elements, (m, 7, 8)."""
    x_el = _as(x_el, (6, 3), "x_el")
    m = x_el.shape[0]
    frames_el = _as(frames_el, (6, 3, 3), "frames_el")
    e_ref = _as(e_ref, (N_EVAL, 8), "e_ref")
    to_cart = _as(to_cart, (N_GAUSS, 8, 8), "to_cart")
    maps = compress_maps(A)
    out = np.zeros((m, N_GAUSS, 8))
    if m:
        _batch_strains(x_el, frames_el, e_ref, to_cart, *maps.nonzeros(), _n_chunks(m), out)
    return out
