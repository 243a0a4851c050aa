"""Allocation-free numba kernels of the SO(3)/SE(3) maps, callable from other ``@njit`` code.

Every kernel writes into a caller-provided output array and allocates nothing; ``coefficients`` returns a
tuple. The formulas are those of :mod:`flexbody.lie.so3` and :mod:`flexbody.lie.se3` (see their docstrings
for the conventions), written out entry by entry with the identities::

    hat(a) hat(b) = b a^T - (a.b) I,        hat(phi)^2 = phi phi^T - p^2 I

Inputs may be arrays or tuples of floats. Unless stated otherwise an output must not alias an input.
These per-vector kernels are building blocks for ``@njit`` code and check nothing (a check in them would
sit in the element kernels' inner loops); the batched :func:`update_frames_into`, the one called from
Python, checks its arrays.

The Taylor coefficients are taken from ``so3.SERIES`` and frozen into the compiled code; numba's cache
keys on this file only, so clear the cache (``flexbody.kernel_cache.CACHE_DIR``) after changing the series in
``so3.py``.
"""

from __future__ import annotations

import math

from flexbody import _numba
from flexbody.kernel_arrays import kernel_input, kernel_output
from flexbody.lie.so3 import SERIES, SERIES_SWITCH

_SWITCH = SERIES_SWITCH
_A1, _A2, _A3, _A4 = SERIES["a1"], SERIES["a2"], SERIES["a3"], SERIES["a4"]
_C2, _C3, _C4 = SERIES["c2"], SERIES["c3"], SERIES["c4"]
_E2, _E3 = SERIES["e2"], SERIES["e3"]

jit = _numba.plain  # numba's defaults (flexbody._numba)


# ----------------------------------------------------------------------------------------------------------
# Small helpers
# ----------------------------------------------------------------------------------------------------------


@jit
def _horner(c, x):
    """sum_k c[k] x^k."""
    s = 0.0
    for k in range(c.shape[0] - 1, -1, -1):
        s = s * x + c[k]
    return s


@jit
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jit
def _norm(v):
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@jit
def _add_hat(v, s, out):
    """out += s hat(v)."""
    out[0, 1] -= s * v[2]
    out[0, 2] += s * v[1]
    out[1, 0] += s * v[2]
    out[1, 2] -= s * v[0]
    out[2, 0] -= s * v[1]
    out[2, 1] += s * v[0]


@jit
def _set_identity(s, out):
    """out = s I (3x3)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = 0.0
        out[i, i] = s


# ----------------------------------------------------------------------------------------------------------
# Coefficients
# ----------------------------------------------------------------------------------------------------------


@jit
def coefficients(p):
    """``(a1, a2, a3, a4, c2, c3, c4, e2, e3)`` at ``p = |phi|`` (order of ``so3.COEFFICIENT_NAMES``)."""
    if p < _SWITCH:
        # Taylor series in p^2
        x = p * p
        return (_horner(_A1, x), _horner(_A2, x), _horner(_A3, x), _horner(_A4, x),
                _horner(_C2, x), _horner(_C3, x), _horner(_C4, x), _horner(_E2, x), _horner(_E3, x))
    s, c = math.sin(p), math.cos(p)
    omc = 2.0 * math.sin(0.5 * p) ** 2  # 1 - cos p without cancellation
    a1 = s / p
    a2 = omc / p**2
    a3 = (p - s) / p**3
    c2 = (p * s - 2.0 * omc) / p**4
    c3 = (3.0 * s - 2.0 * p - p * c) / p**5
    e2 = (p * p * c - 5.0 * p * s + 8.0 * omc) / p**6
    e3 = ((p * p - 15.0) * s + 8.0 * p + 7.0 * p * c) / p**7
    a4 = -c2 / (2.0 * a2)  # (1 - (p/2) cot(p/2)) / p^2
    h = 0.5 * p
    sh = math.sin(h)
    c4 = ((h / sh) ** 2 + h * math.cos(h) / sh - 2.0) / p**4  # a4'(p) / p
    return a1, a2, a3, a4, c2, c3, c4, e2, e3


# ----------------------------------------------------------------------------------------------------------
# SO(3)
# ----------------------------------------------------------------------------------------------------------


@jit
def hat_into(v, out):
    """out = hat(v)."""
    _set_identity(0.0, out)
    _add_hat(v, 1.0, out)


@jit
def _rodrigues(phi):
    """Entries (row major) of exp(phi) = cos p I + a1 W + a2 phi phi^T."""
    p = _norm(phi)
    a1, a2 = coefficients(p)[:2]
    d = 1.0 - a2 * p * p  # cos p, consistent with the coefficients
    x, y, z = phi[0], phi[1], phi[2]
    return (d + a2 * x * x, -a1 * z + a2 * x * y, a1 * y + a2 * x * z,
            a1 * z + a2 * y * x, d + a2 * y * y, -a1 * x + a2 * y * z,
            -a1 * y + a2 * z * x, a1 * x + a2 * z * y, d + a2 * z * z)


@jit
def exp_into(phi, out):
    """out = exp(phi) (3x3)."""
    E = _rodrigues(phi)
    for i in range(3):
        for j in range(3):
            out[i, j] = E[3 * i + j]


@jit
def log_into(R, out):
    """out = log(R), ``|out| <= pi``; quaternion (Shepperd) extraction, robust at pi and to slight drift."""
    t = R[0, 0] + R[1, 1] + R[2, 2]
    # quaternion [w, x, y, z] from its largest component
    if t >= R[0, 0] and t >= R[1, 1] and t >= R[2, 2]:
        f = 2.0 * math.sqrt(max(1.0 + t, 0.0))  # 4 w
        w, x, y, z = 0.25 * f, (R[2, 1] - R[1, 2]) / f, (R[0, 2] - R[2, 0]) / f, (R[1, 0] - R[0, 1]) / f
    elif R[0, 0] >= R[1, 1] and R[0, 0] >= R[2, 2]:
        f = 2.0 * math.sqrt(max(1.0 + 2.0 * R[0, 0] - t, 0.0))  # 4 x
        w, x, y, z = (R[2, 1] - R[1, 2]) / f, 0.25 * f, (R[0, 1] + R[1, 0]) / f, (R[0, 2] + R[2, 0]) / f
    elif R[1, 1] >= R[2, 2]:
        f = 2.0 * math.sqrt(max(1.0 + 2.0 * R[1, 1] - t, 0.0))  # 4 y
        w, x, y, z = (R[0, 2] - R[2, 0]) / f, (R[0, 1] + R[1, 0]) / f, 0.25 * f, (R[1, 2] + R[2, 1]) / f
    else:
        f = 2.0 * math.sqrt(max(1.0 + 2.0 * R[2, 2] - t, 0.0))  # 4 z
        w, x, y, z = (R[1, 0] - R[0, 1]) / f, (R[0, 2] + R[2, 0]) / f, (R[1, 2] + R[2, 1]) / f, 0.25 * f
    if w < 0.0:  # q ~ -q; w >= 0 gives the angle in [0, pi]
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    tq = s / w if w > 0.0 else math.inf
    if tq < 1e-5:
        # angle / s = (2 / w) atan(t) / t
        scale = 2.0 / w * (1.0 - tq * tq / 3.0 + tq**4 / 5.0)
    else:
        scale = 2.0 * math.atan2(s, w) / s
    out[0], out[1], out[2] = scale * x, scale * y, scale * z


@jit
def tangent_into(phi, out):
    """out = T(phi) = (1 - a3 p^2) I - a2 W + a3 phi phi^T."""
    p = _norm(phi)
    a2, a3 = coefficients(p)[1:3]
    _set_identity(1.0 - a3 * p * p, out)
    _add_hat(phi, -a2, out)
    for i in range(3):
        for j in range(3):
            out[i, j] += a3 * phi[i] * phi[j]


@jit
def tangent_inv_into(phi, out):
    """out = T^-1(phi) = (1 - a4 p^2) I + W / 2 + a4 phi phi^T."""
    p = _norm(phi)
    a4 = coefficients(p)[3]
    _set_identity(1.0 - a4 * p * p, out)
    _add_hat(phi, 0.5, out)
    for i in range(3):
        for j in range(3):
            out[i, j] += a4 * phi[i] * phi[j]


@jit
def d_tangent_into(phi, b, out):
    """out = X with (D T(phi)[v]) b = X v.

    X = a2 hat(b) - a3 hat(r) - a3 (b phi^T - (phi.b) I) + (c3 q - c2 r) phi^T,  r = W b, q = W r.
    """
    p = _norm(phi)
    _, a2, a3, _, c2, c3, _, _, _ = coefficients(p)
    r = _cross(phi, b)
    q = _cross(phi, r)
    _set_identity(a3 * _dot(phi, b), out)
    _add_hat(b, a2, out)
    _add_hat(r, -a3, out)
    for i in range(3):
        for j in range(3):
            out[i, j] += (c3 * q[i] - c2 * r[i] - a3 * b[i]) * phi[j]


@jit
def d_tangent_inv_into(phi, b, out):
    """out = X with (D T^-1(phi)[v]) b = X v.

    X = -hat(b)/2 - a4 hat(r) - a4 (b phi^T - (phi.b) I) + c4 q phi^T,  r = W b, q = W r.
    """
    p = _norm(phi)
    _, _, _, a4, _, _, c4, _, _ = coefficients(p)
    r = _cross(phi, b)
    q = _cross(phi, r)
    _set_identity(a4 * _dot(phi, b), out)
    _add_hat(b, -0.5, out)
    _add_hat(r, -a4, out)
    for i in range(3):
        for j in range(3):
            out[i, j] += (c4 * q[i] - a4 * b[i]) * phi[j]


@jit
def d2_tangent_into(phi, a, b, out):
    """out = Y (symmetric) with a^T (D^2 T(phi)[v, w]) b = v^T Y w.

    Y = c2 (m phi^T + phi m^T) - c3 (u phi^T + phi u^T) + a3 (a b^T + b a^T) + (e3 a.q - e2 a.r) phi phi^T
        + (c3 a.q - c2 a.r - 2 a3 a.b) I,   r = W b, q = W r, m = a x b, u = a x r + b x (W a).
    """
    p = _norm(phi)
    _, _, a3, _, c2, c3, _, e2, e3 = coefficients(p)
    r = _cross(phi, b)
    q = _cross(phi, r)
    m = _cross(a, b)
    ur = _cross(a, r)
    ua = _cross(b, _cross(phi, a))
    u = (ur[0] + ua[0], ur[1] + ua[1], ur[2] + ua[2])
    ar, aq = _dot(a, r), _dot(a, q)
    _set_identity(c3 * aq - c2 * ar - 2.0 * a3 * _dot(a, b), out)
    s = e3 * aq - e2 * ar
    for i in range(3):
        for j in range(3):
            out[i, j] += (c2 * (m[i] * phi[j] + phi[i] * m[j]) - c3 * (u[i] * phi[j] + phi[i] * u[j])
                          + a3 * (a[i] * b[j] + b[i] * a[j]) + s * phi[i] * phi[j])


@jit
def update_frame_into(R, th1, th2, out):
    """out = R exp(th1 e1 + th2 e2) (5-DoF nodal update). ``out`` may be ``R`` itself."""
    E = _rodrigues((th1, th2, 0.0))
    for i in range(3):
        r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]  # row of R, read before out is written
        for j in range(3):
            out[i, j] = r0 * E[j] + r1 * E[3 + j] + r2 * E[6 + j]


# ----------------------------------------------------------------------------------------------------------
# SE(3), h = [u, w]
# ----------------------------------------------------------------------------------------------------------


@jit
def _d_tangent_matrix_into(w, u, k0, k1, k2, k3, out):
    """out = k0 U + k1 (w.u) W + k2 (w.u) W^2 + k3 (U W + W U)  (3x3), W = hat(w), U = hat(u).

    D T(w)[u] has (k0, k1, k2, k3) = (-a2, -c2, c3, a3); D T^-1(w)[u] has (1/2, 0, c4, a4).
    """
    wu = _dot(w, u)
    # W^2 = w w^T - p^2 I and U W + W U = w u^T + u w^T - 2 (w.u) I
    _set_identity(-(k2 * _dot(w, w) + 2.0 * k3) * wu, out)
    _add_hat(u, k0, out)
    _add_hat(w, k1 * wu, out)
    for i in range(3):
        for j in range(3):
            out[i, j] += k2 * wu * w[i] * w[j] + k3 * (w[i] * u[j] + u[i] * w[j])


@jit
def se3_exp_into(h, out):
    """out = exp(h) (4x4) = [[exp(w), T(w)^T u], [0, 1]]."""
    u, w = (h[0], h[1], h[2]), (h[3], h[4], h[5])
    p = _norm(w)
    a2, a3 = coefficients(p)[1:3]
    E = _rodrigues(w)
    wu = _cross(w, u)
    wwu = _cross(w, wu)
    for i in range(3):
        for j in range(3):
            out[i, j] = E[3 * i + j]
        out[i, 3] = u[i] + a2 * wu[i] + a3 * wwu[i]  # (I + a2 W + a3 W^2) u
        out[3, i] = 0.0
    out[3, 3] = 1.0


@jit
def se3_log_into(H, out):
    """out = log(H) = [T^-1(-w) x, w], w = log(R)."""
    w = out[3:]
    log_into(H[:3, :3], w)
    p = _norm(w)
    a4 = coefficients(p)[3]
    x = (H[0, 3], H[1, 3], H[2, 3])
    wx = _cross(w, x)
    wwx = _cross(w, wx)
    for i in range(3):
        out[i] = x[i] - 0.5 * wx[i] + a4 * wwx[i]  # (I - W/2 + a4 W^2) x


@jit
def se3_tangent_into(h, out):
    """out = [[T(w), D T(w)[u]], [0, T(w)]] (6x6)."""
    u, w = h[:3], h[3:]
    p = _norm(w)
    _, a2, a3, _, c2, c3, _, _, _ = coefficients(p)
    tangent_into(w, out[:3, :3])
    _d_tangent_matrix_into(w, u, -a2, -c2, c3, a3, out[:3, 3:])
    for i in range(3):
        for j in range(3):
            out[3 + i, 3 + j] = out[i, j]
            out[3 + i, j] = 0.0


@jit
def se3_tangent_inv_into(h, out):
    """out = [[T^-1(w), D T^-1(w)[u]], [0, T^-1(w)]] (6x6)."""
    u, w = h[:3], h[3:]
    p = _norm(w)
    _, _, _, a4, _, _, c4, _, _ = coefficients(p)
    tangent_inv_into(w, out[:3, :3])
    _d_tangent_matrix_into(w, u, 0.5, 0.0, c4, a4, out[:3, 3:])
    for i in range(3):
        for j in range(3):
            out[3 + i, 3 + j] = out[i, j]
            out[3 + i, j] = 0.0


@jit
def _update_frames_into(frames, dtheta, out):
    for i in range(frames.shape[0]):
        update_frame_into(frames[i], dtheta[i, 0], dtheta[i, 1], out[i])


def update_frames_into(frames, dtheta, out) -> None:
    """out[i] = frames[i] exp(dtheta[i, 0] e1 + dtheta[i, 1] e2) for every node (the 5-DoF update, batched).

    A Python entry point (not callable from ``@njit`` code): frames (n, 3, 3), dtheta (n, 2) and the
    writeable float64 output (n, 3, 3) are checked first (:mod:`flexbody.kernel_arrays`); ``out`` may be
    ``frames`` itself.
    """
    frames = kernel_input(frames, (3, 3), "frames")
    n = len(frames)
    _update_frames_into(frames, kernel_input(dtheta, (2,), "dtheta", rows=n), kernel_output(out, (n, 3, 3), "out"))
