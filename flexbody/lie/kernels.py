"""Allocation-free numba kernels of the SO(3)/SE(3) maps, callable from other ``@njit`` code.

Every kernel writes into a caller-provided output array and allocates nothing; ``coefficients`` returns a
tuple. The formulas are those of :mod:`flexbody.lie.so3` and :mod:`flexbody.lie.se3` (see their docstrings
for the conventions), written out entry by entry with the identities::

    hat(a) hat(b) = b a^T - (a.b) I,        hat(phi)^2 = phi phi^T - p^2 I

Inputs may be arrays or tuples of floats. Unless stated otherwise an output must not alias an input.
These per-vector kernels are building blocks for ``@njit`` code and check nothing (a check in them would
sit in the element kernels' inner loops); the batched :func:`update_frames_into`, the one called from
Python, checks its arrays.

The ``*_co_into`` maps take their coefficients (``coefficients``, or ``point_coefficients_into`` and
``inverse_coefficients``, which evaluate the series fused) instead of computing them: the element kernels
(:mod:`flexbody.shell.kernels`, :mod:`flexbody.shell.kernels.mitc7`) compute them once per point and inline
these maps; this module is the only numba code of the SO(3) coefficients and derivative formulas.

Twins: the helpers that the element kernels (:data:`flexbody._numba.fast`) call and the plain code
(:func:`update_frames_into`, the MITC7 node setup) calls too are compiled twice from one source
(:func:`flexbody._numba.twin`): ``coefficients``, ``log_into``, ``d_tangent_inv_into`` and the helpers they
call under numba's defaults for plain callers, and as ``<name>_fast`` under the fast policy for the element
kernels (``point_coefficients_into`` and ``inverse_coefficients``, inlined into the element kernels, call
``coefficients_fast``). One dispatcher is thus compiled under one set of flags only, whichever kernel is
compiled first and whatever is cached (a callee compiled for a caller takes the flags it leaves unset from
that caller: :mod:`flexbody._numba`); the fast twins give the element kernels FMA contraction and no
reference counting in these helpers too.

The Taylor coefficients are taken from ``so3.SERIES`` and frozen into the compiled code; the cache directory
is named for a digest of all kernel sources (:mod:`flexbody.kernel_cache`), so an edit of ``so3.py``
recompiles them.
"""

from __future__ import annotations

import math

import numpy as np

from flexbody import _numba
from flexbody.kernel_arrays import kernel_input, kernel_output
from flexbody.lie.so3 import SERIES, SERIES_SWITCH

_SWITCH = SERIES_SWITCH
_A1, _A2, _A3, _A4 = SERIES["a1"], SERIES["a2"], SERIES["a3"], SERIES["a4"]
_C2, _C3, _C4 = SERIES["c2"], SERIES["c3"], SERIES["c4"]
_E2, _E3 = SERIES["e2"], SERIES["e3"]
_NSER = len(_A1)   # a1, a2, a3, c2, c3, e2, e3: one length (fused Horner loop)
_NINV = len(_A4)   # a4, c4: one length
assert all(len(SERIES[k]) == _NSER for k in ("a2", "a3", "c2", "c3", "e2", "e3")) and len(_C4) == _NINV

jit = _numba.plain  # numba's defaults (flexbody._numba)
inline = _numba.inline  # inlined into the callers (numba IR), which compile it with their own flags


def _fast_twin(dispatcher, **callees):
    """The twin of a helper for the fast element kernels: ``<name>_fast`` (:func:`flexbody._numba.twin`)."""
    return _numba.twin(_numba.fast, dispatcher, f"{dispatcher.__name__}_fast", **callees)


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


_horner_fast = _fast_twin(_horner)


@jit
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jit
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jit
def _norm(v):
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


_norm_fast = _fast_twin(_norm)


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


coefficients_fast = _fast_twin(coefficients, _horner=_horner_fast)


@jit
def exp_coefficients(p):
    """``(a1, a2)`` at ``p = |phi|``: what exp(phi) needs of :func:`coefficients`, by the same formulas (the same
    bits), without the seven others (a third of the cost of a nodal update)."""
    if p < _SWITCH:
        x = p * p
        return _horner(_A1, x), _horner(_A2, x)
    s = math.sin(p)
    omc = 2.0 * math.sin(0.5 * p) ** 2  # 1 - cos p without cancellation
    return s / p, omc / p**2


@inline
def point_coefficients_into(p, co):
    """co[:9] = :func:`coefficients` at ``p``, except a4 and c4 (co[3], co[6]), which are 0 below the series
    switch (the maps of an evaluation point need only the other seven; their series are evaluated fused)."""
    if p < _SWITCH:
        x = p * p
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        c2 = 0.0
        c3 = 0.0
        e2 = 0.0
        e3 = 0.0
        for j in range(_NSER - 1, -1, -1):
            a1 = a1 * x + _A1[j]
            a2 = a2 * x + _A2[j]
            a3 = a3 * x + _A3[j]
            c2 = c2 * x + _C2[j]
            c3 = c3 * x + _C3[j]
            e2 = e2 * x + _E2[j]
            e3 = e3 * x + _E3[j]
        co[0] = a1
        co[1] = a2
        co[2] = a3
        co[3] = 0.0
        co[4] = c2
        co[5] = c3
        co[6] = 0.0
        co[7] = e2
        co[8] = e3
    else:
        cf = coefficients_fast(p)
        for j in range(9):
            co[j] = cf[j]


@inline
def inverse_coefficients(p):
    """``(a4, c4)`` at ``p``: the coefficients of T^-1 and of its derivative (series fused below the switch)."""
    if p < _SWITCH:
        x = p * p
        a4 = 0.0
        c4 = 0.0
        for j in range(_NINV - 1, -1, -1):
            a4 = a4 * x + _A4[j]
            c4 = c4 * x + _C4[j]
        return a4, c4
    cf = coefficients_fast(p)
    return cf[3], cf[6]


# ----------------------------------------------------------------------------------------------------------
# SO(3)
# ----------------------------------------------------------------------------------------------------------


@jit
def hat_into(v, out):
    """out = hat(v)."""
    _set_identity(0.0, out)
    _add_hat(v, 1.0, out)


# The maps with their coefficients passed in (``co`` = :func:`coefficients` of |phi|, or
# :func:`point_coefficients_into`; the same for -phi): the element kernels compute the coefficients of a point
# once and inline these (``phi``, ``a``, ``b`` may be arrays or tuples). They are the only place of the formulas
# in numba code; the maps below compute the coefficients and call them.


@inline
def rodrigues_co(phi, co):
    """Entries (row major) of exp(phi) = cos p I + a1 W + a2 phi phi^T, cos p = 1 - a2 p^2."""
    a1 = co[0]
    a2 = co[1]
    x = phi[0]
    y = phi[1]
    z = phi[2]
    d = 1.0 - a2 * (x * x + y * y + z * z)
    return (d + a2 * x * x, -a1 * z + a2 * x * y, a1 * y + a2 * x * z,
            a1 * z + a2 * y * x, d + a2 * y * y, -a1 * x + a2 * y * z,
            -a1 * y + a2 * z * x, a1 * x + a2 * z * y, d + a2 * z * z)


@inline
def exp_co_into(phi, co, out):
    """out = exp(phi) (3x3)."""
    E = rodrigues_co(phi, co)
    out[0, 0] = E[0]
    out[0, 1] = E[1]
    out[0, 2] = E[2]
    out[1, 0] = E[3]
    out[1, 1] = E[4]
    out[1, 2] = E[5]
    out[2, 0] = E[6]
    out[2, 1] = E[7]
    out[2, 2] = E[8]


@inline
def tangent_co_into(phi, co, out):
    """out = T(phi) = (1 - a3 p^2) I - a2 W + a3 phi phi^T."""
    a2 = co[1]
    a3 = co[2]
    x = phi[0]
    y = phi[1]
    z = phi[2]
    d = 1.0 - a3 * (x * x + y * y + z * z)
    out[0, 0] = d + a3 * x * x
    out[0, 1] = a2 * z + a3 * x * y
    out[0, 2] = -a2 * y + a3 * x * z
    out[1, 0] = -a2 * z + a3 * y * x
    out[1, 1] = d + a3 * y * y
    out[1, 2] = a2 * x + a3 * y * z
    out[2, 0] = a2 * y + a3 * z * x
    out[2, 1] = -a2 * x + a3 * z * y
    out[2, 2] = d + a3 * z * z


@inline
def tangent_inv_co_into(phi, a4, out):
    """out = T^-1(phi) = (1 - a4 p^2) I + W / 2 + a4 phi phi^T."""
    x = phi[0]
    y = phi[1]
    z = phi[2]
    d = 1.0 - a4 * (x * x + y * y + z * z)
    out[0, 0] = d + a4 * x * x
    out[0, 1] = -0.5 * z + a4 * x * y
    out[0, 2] = 0.5 * y + a4 * x * z
    out[1, 0] = 0.5 * z + a4 * y * x
    out[1, 1] = d + a4 * y * y
    out[1, 2] = -0.5 * x + a4 * y * z
    out[2, 0] = -0.5 * y + a4 * z * x
    out[2, 1] = 0.5 * x + a4 * z * y
    out[2, 2] = d + a4 * z * z


@inline
def d_tangent_co_into(phi, b, co, out):
    """out = X with (D T(phi)[v]) b = X v.

    X = a2 hat(b) - a3 hat(r) - a3 (b phi^T - (phi.b) I) + (c3 q - c2 r) phi^T,  r = W b, q = W r.
    """
    a2 = co[1]
    a3 = co[2]
    c2 = co[4]
    c3 = co[5]
    p0 = phi[0]
    p1 = phi[1]
    p2 = phi[2]
    b0 = b[0]
    b1 = b[1]
    b2 = b[2]
    r0 = p1 * b2 - p2 * b1
    r1 = p2 * b0 - p0 * b2
    r2 = p0 * b1 - p1 * b0
    q0 = p1 * r2 - p2 * r1
    q1 = p2 * r0 - p0 * r2
    q2 = p0 * r1 - p1 * r0
    # X = a3 (phi.b) I + hat(a2 b - a3 r) + (c3 q - c2 r - a3 b) phi^T
    h0 = a2 * b0 - a3 * r0
    h1 = a2 * b1 - a3 * r1
    h2 = a2 * b2 - a3 * r2
    w0 = c3 * q0 - c2 * r0 - a3 * b0
    w1 = c3 * q1 - c2 * r1 - a3 * b1
    w2 = c3 * q2 - c2 * r2 - a3 * b2
    dg = a3 * (p0 * b0 + p1 * b1 + p2 * b2)
    out[0, 0] = dg + w0 * p0
    out[0, 1] = -h2 + w0 * p1
    out[0, 2] = h1 + w0 * p2
    out[1, 0] = h2 + w1 * p0
    out[1, 1] = dg + w1 * p1
    out[1, 2] = -h0 + w1 * p2
    out[2, 0] = -h1 + w2 * p0
    out[2, 1] = h0 + w2 * p1
    out[2, 2] = dg + w2 * p2


@inline
def d_tangent_inv_co_into(phi, b, a4, c4, out):
    """out = X with (D T^-1(phi)[v]) b = X v.

    X = -hat(b)/2 - a4 hat(r) - a4 (b phi^T - (phi.b) I) + c4 q phi^T,  r = W b, q = W r.
    """
    p0 = phi[0]
    p1 = phi[1]
    p2 = phi[2]
    b0 = b[0]
    b1 = b[1]
    b2 = b[2]
    r0 = p1 * b2 - p2 * b1
    r1 = p2 * b0 - p0 * b2
    r2 = p0 * b1 - p1 * b0
    q0 = p1 * r2 - p2 * r1
    q1 = p2 * r0 - p0 * r2
    q2 = p0 * r1 - p1 * r0
    # X = a4 (phi.b) I + hat(-b/2 - a4 r) + (c4 q - a4 b) phi^T
    h0 = -0.5 * b0 - a4 * r0
    h1 = -0.5 * b1 - a4 * r1
    h2 = -0.5 * b2 - a4 * r2
    w0 = c4 * q0 - a4 * b0
    w1 = c4 * q1 - a4 * b1
    w2 = c4 * q2 - a4 * b2
    dg = a4 * (p0 * b0 + p1 * b1 + p2 * b2)
    out[0, 0] = dg + w0 * p0
    out[0, 1] = -h2 + w0 * p1
    out[0, 2] = h1 + w0 * p2
    out[1, 0] = h2 + w1 * p0
    out[1, 1] = dg + w1 * p1
    out[1, 2] = -h0 + w1 * p2
    out[2, 0] = -h1 + w2 * p0
    out[2, 1] = h0 + w2 * p1
    out[2, 2] = dg + w2 * p2


@inline
def d2_tangent_co_into(phi, a, b, co, out):
    """out = Y (symmetric) with a^T (D^2 T(phi)[v, w]) b = v^T Y w.

    Y = c2 (m phi^T + phi m^T) - c3 (u phi^T + phi u^T) + a3 (a b^T + b a^T) + (e3 a.q - e2 a.r) phi phi^T
        + (c3 a.q - c2 a.r - 2 a3 a.b) I,   r = W b, q = W r, m = a x b, u = a x r + b x (W a).
    """
    a3 = co[2]
    c2 = co[4]
    c3 = co[5]
    e2 = co[7]
    e3 = co[8]
    p0 = phi[0]
    p1 = phi[1]
    p2 = phi[2]
    a0 = a[0]
    a1 = a[1]
    a2_ = a[2]
    b0 = b[0]
    b1 = b[1]
    b2 = b[2]
    r0 = p1 * b2 - p2 * b1
    r1 = p2 * b0 - p0 * b2
    r2 = p0 * b1 - p1 * b0
    q0 = p1 * r2 - p2 * r1
    q1 = p2 * r0 - p0 * r2
    q2 = p0 * r1 - p1 * r0
    m0 = a1 * b2 - a2_ * b1
    m1 = a2_ * b0 - a0 * b2
    m2 = a0 * b1 - a1 * b0
    # u = a x r + b x (phi x a)
    pa0 = p1 * a2_ - p2 * a1
    pa1 = p2 * a0 - p0 * a2_
    pa2 = p0 * a1 - p1 * a0
    u0 = (a1 * r2 - a2_ * r1) + (b1 * pa2 - b2 * pa1)
    u1 = (a2_ * r0 - a0 * r2) + (b2 * pa0 - b0 * pa2)
    u2 = (a0 * r1 - a1 * r0) + (b0 * pa1 - b1 * pa0)
    ar = a0 * r0 + a1 * r1 + a2_ * r2
    aq = a0 * q0 + a1 * q1 + a2_ * q2
    ab = a0 * b0 + a1 * b1 + a2_ * b2
    dg = c3 * aq - c2 * ar - 2.0 * a3 * ab
    sc = e3 * aq - e2 * ar
    # row i: c2 (m_i phi_j + phi_i m_j) - c3 (u_i phi_j + phi_i u_j) + a3 (a_i b_j + b_i a_j) + sc phi_i phi_j
    out[0, 0] = dg + 2.0 * (c2 * m0 * p0 - c3 * u0 * p0 + a3 * a0 * b0) + sc * p0 * p0
    out[1, 1] = dg + 2.0 * (c2 * m1 * p1 - c3 * u1 * p1 + a3 * a1 * b1) + sc * p1 * p1
    out[2, 2] = dg + 2.0 * (c2 * m2 * p2 - c3 * u2 * p2 + a3 * a2_ * b2) + sc * p2 * p2
    y01 = c2 * (m0 * p1 + p0 * m1) - c3 * (u0 * p1 + p0 * u1) + a3 * (a0 * b1 + b0 * a1) + sc * p0 * p1
    y02 = c2 * (m0 * p2 + p0 * m2) - c3 * (u0 * p2 + p0 * u2) + a3 * (a0 * b2 + b0 * a2_) + sc * p0 * p2
    y12 = c2 * (m1 * p2 + p1 * m2) - c3 * (u1 * p2 + p1 * u2) + a3 * (a1 * b2 + b1 * a2_) + sc * p1 * p2
    out[0, 1] = y01
    out[1, 0] = y01
    out[0, 2] = y02
    out[2, 0] = y02
    out[1, 2] = y12
    out[2, 1] = y12


@jit
def _rodrigues(phi):
    """Entries (row major) of exp(phi)."""
    return rodrigues_co(phi, exp_coefficients(_norm(phi)))


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


log_into_fast = _fast_twin(log_into)


@jit
def tangent_into(phi, out):
    """out = T(phi) = (1 - a3 p^2) I - a2 W + a3 phi phi^T."""
    tangent_co_into(phi, coefficients(_norm(phi)), out)


@jit
def tangent_inv_into(phi, out):
    """out = T^-1(phi) = (1 - a4 p^2) I + W / 2 + a4 phi phi^T."""
    tangent_inv_co_into(phi, coefficients(_norm(phi))[3], out)


@jit
def d_tangent_into(phi, b, out):
    """out = X with (D T(phi)[v]) b = X v (:func:`d_tangent_co_into`)."""
    d_tangent_co_into(phi, b, coefficients(_norm(phi)), out)


@jit
def d_tangent_inv_into(phi, b, out):
    """out = X with (D T^-1(phi)[v]) b = X v (:func:`d_tangent_inv_co_into`)."""
    cf = coefficients(_norm(phi))
    d_tangent_inv_co_into(phi, b, cf[3], cf[6], out)


d_tangent_inv_into_fast = _fast_twin(d_tangent_inv_into, coefficients=coefficients_fast, _norm=_norm_fast)


@jit
def d2_tangent_into(phi, a, b, out):
    """out = Y (symmetric) with a^T (D^2 T(phi)[v, w]) b = v^T Y w (:func:`d2_tangent_co_into`)."""
    d2_tangent_co_into(phi, a, b, coefficients(_norm(phi)), out)


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
def _adjugate4(A):
    """(det A, adj A row major as 16 numbers) of a 4 x 4 matrix A, from the six 2 x 2 minors of its first two rows
    and the six of its last two (Laplace's expansion by complementary minors: D. Eberly, "The Laplace Expansion
    Theorem: Computing the Determinants and Inverses of Matrices", Geometric Tools, 2008)."""
    s0 = A[0, 0] * A[1, 1] - A[1, 0] * A[0, 1]
    s1 = A[0, 0] * A[1, 2] - A[1, 0] * A[0, 2]
    s2 = A[0, 0] * A[1, 3] - A[1, 0] * A[0, 3]
    s3 = A[0, 1] * A[1, 2] - A[1, 1] * A[0, 2]
    s4 = A[0, 1] * A[1, 3] - A[1, 1] * A[0, 3]
    s5 = A[0, 2] * A[1, 3] - A[1, 2] * A[0, 3]
    c5 = A[2, 2] * A[3, 3] - A[3, 2] * A[2, 3]
    c4 = A[2, 1] * A[3, 3] - A[3, 1] * A[2, 3]
    c3 = A[2, 1] * A[3, 2] - A[3, 1] * A[2, 2]
    c2 = A[2, 0] * A[3, 3] - A[3, 0] * A[2, 3]
    c1 = A[2, 0] * A[3, 2] - A[3, 0] * A[2, 2]
    c0 = A[2, 0] * A[3, 1] - A[3, 0] * A[2, 1]
    det = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
    return det, (A[1, 1] * c5 - A[1, 2] * c4 + A[1, 3] * c3, -A[0, 1] * c5 + A[0, 2] * c4 - A[0, 3] * c3,
                 A[3, 1] * s5 - A[3, 2] * s4 + A[3, 3] * s3, -A[2, 1] * s5 + A[2, 2] * s4 - A[2, 3] * s3,
                 -A[1, 0] * c5 + A[1, 2] * c2 - A[1, 3] * c1, A[0, 0] * c5 - A[0, 2] * c2 + A[0, 3] * c1,
                 -A[3, 0] * s5 + A[3, 2] * s2 - A[3, 3] * s1, A[2, 0] * s5 - A[2, 2] * s2 + A[2, 3] * s1,
                 A[1, 0] * c4 - A[1, 1] * c2 + A[1, 3] * c0, -A[0, 0] * c4 + A[0, 1] * c2 - A[0, 3] * c0,
                 A[3, 0] * s4 - A[3, 1] * s2 + A[3, 3] * s0, -A[2, 0] * s4 + A[2, 1] * s2 - A[2, 3] * s0,
                 -A[1, 0] * c3 + A[1, 1] * c1 - A[1, 2] * c0, A[0, 0] * c3 - A[0, 1] * c1 + A[0, 2] * c0,
                 -A[3, 0] * s3 + A[3, 1] * s1 - A[3, 2] * s0, A[2, 0] * s3 - A[2, 1] * s1 + A[2, 2] * s0)


@jit
def nearest_rotation_into(H, N, out):
    """out = the rotation G maximizing tr(G^T H) (H = sum_k b_k a_k^T: the best map of the a_k onto the b_k), by
    Horn's quaternion: G = R(q), q the unit eigenvector of the largest eigenvalue of the symmetric traceless
    4 x 4 matrix N(H) (Horn 1987, "Closed-form solution of absolute orientation using unit quaternions",
    J. Opt. Soc. Am. A 4). The eigenvalue by Newton's method on the characteristic polynomial
    l^4 - tr(N^2)/2 l^2 - tr(N^3)/3 l + det N from above (Theobald 2005, "Rapid calculation of RMSDs using a
    quaternion-based characteristic polynomial", Acta Cryst. A 61; the start is the Frobenius bound
    sqrt(tr(N^2)) >= l_max), the eigenvector as the largest column of adj(N - l I). N is scratch (4, 4). The
    identity when H spans no plane (the second singular value below about 1e-12 of the largest,
    :func:`_plane_spanned`): the same result as :func:`flexbody.lie.so3.nearest_rotations` (tested). Returns
    False, with the identity written, if H is not finite or the eigenvector is not determined."""
    finite = True
    for i in range(3):
        for j in range(3):
            finite = finite and math.isfinite(H[i, j])
    if not finite or not _plane_spanned(H):
        _set_identity(1.0, out)
        return finite
    # N, the symmetric matrix of the quaternion form q^T N q = tr(R(q)^T H) (Horn's, for H^T)
    sxx, sxy, sxz = H[0, 0], H[1, 0], H[2, 0]
    syx, syy, syz = H[0, 1], H[1, 1], H[2, 1]
    szx, szy, szz = H[0, 2], H[1, 2], H[2, 2]
    N[0, 0], N[0, 1], N[0, 2], N[0, 3] = sxx + syy + szz, syz - szy, szx - sxz, sxy - syx
    N[1, 1], N[1, 2], N[1, 3] = sxx - syy - szz, sxy + syx, szx + sxz
    N[2, 2], N[2, 3] = -sxx + syy - szz, syz + szy
    N[3, 3] = -sxx - syy + szz
    for i in range(4):
        for j in range(i):
            N[i, j] = N[j, i]
    n2 = 0.0
    for i in range(4):
        for j in range(4):
            n2 += N[i, j] * N[i, j]
    n3 = 0.0
    for i in range(4):
        for j in range(4):
            nij = 0.0
            for k in range(4):
                nij += N[i, k] * N[k, j]
            n3 += nij * N[j, i]
    c2, c1, c0 = -0.5 * n2, -n3 / 3.0, _adjugate4(N)[0]
    lam = math.sqrt(n2)
    for _ in range(100):
        p = ((lam * lam + c2) * lam + c1) * lam + c0
        dp = (4.0 * lam * lam + 2.0 * c2) * lam + c1
        if dp <= 0.0:
            break
        step = p / dp
        lam -= step
        if step <= 1e-15 * lam:                      # converged (or below the root by round-off)
            break
    for i in range(4):
        N[i, i] -= lam
    adj = _adjugate4(N)[1]
    best, col = 0.0, 0
    for c in range(4):                               # the column of adj(N - l I) of largest norm
        size = adj[c] * adj[c] + adj[4 + c] * adj[4 + c] + adj[8 + c] * adj[8 + c] + adj[12 + c] * adj[12 + c]
        if size > best:
            best, col = size, c
    q0, q1, q2, q3 = adj[col], adj[4 + col], adj[8 + col], adj[12 + col]
    size = math.sqrt(best)
    if not (size > 1e-300 and math.isfinite(size)):
        _set_identity(1.0, out)
        return False
    w, x, y, z = q0 / size, q1 / size, q2 / size, q3 / size
    out[0, 0], out[0, 1], out[0, 2] = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)
    out[1, 0], out[1, 1], out[1, 2] = 2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)
    out[2, 0], out[2, 1], out[2, 2] = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)
    return True


@jit
def _plane_spanned(H):
    """Whether H has a second singular value above 1e-12 of its largest: the largest cross product of two of
    its columns against the square of its largest column (|h_i x h_j| = s1 s2 ... for the pair that spans)."""
    big, cross = 0.0, 0.0
    for i in range(3):
        big = max(big, H[0, i] * H[0, i] + H[1, i] * H[1, i] + H[2, i] * H[2, i])
        a, b = H[:, i], H[:, (i + 1) % 3]
        cx, cy, cz = a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]
        cross = max(cross, cx * cx + cy * cy + cz * cz)
    return cross > 1e-24 * big * big


@jit
def _nearest_rotations_into(H, N, out):
    failed = 0
    for i in range(H.shape[0]):
        if not nearest_rotation_into(H[i], N, out[i]):
            failed += 1
    return failed


def nearest_rotations_into(H, out) -> int:
    """out[i] = :func:`nearest_rotation_into` of H[i] for every i (H (n, 3, 3), out (n, 3, 3) writeable float64,
    checked first); returns the number of matrices whose eigenvector was not determined (given the identity)."""
    H = kernel_input(H, (3, 3), "H")
    return _nearest_rotations_into(H, np.empty((4, 4)), kernel_output(out, (len(H), 3, 3), "out"))


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
