"""The geometric stage of the MITC7 element: the strain Hessian Hf(s) applied to one column of the Jacobian G,
and the cross product of the terms of the second variation."""

from __future__ import annotations

from flexbody import _numba

fast = _numba.fast


@fast
def cross_into(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@fast
def hessian_col(s, G, c, H):
    """H[:, c] = Hf(s) G[:, c], Hf (kinematics.strain_hessian) written out (rows 8 and 11 are zero)."""
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


