"""SO(3): exponential, logarithm, right tangent operator and its derivatives (numpy reference).

Conventions (fixed throughout flexbody):

* ``hat(v) @ w == np.cross(v, w)``; ``vee`` is its inverse.
* ``tangent`` is the *right* tangent operator (right Jacobian),
  ``exp(phi + dphi) = exp(phi) @ exp(hat(tangent(phi) @ dphi))`` to first order::

      T(phi)    = I - a2 hat(phi) + a3 hat(phi)^2
      T(phi)^-1 = I + hat(phi)/2 + a4 hat(phi)^2

  ``tangent(-phi) == tangent(phi).T`` is the left Jacobian.
* Directional derivatives are returned as 3x3 matrices acting on the direction ``v``:
  ``d_tangent(phi, b) @ v == (D T(phi)[v]) @ b``, ``d_tangent_inv(phi, b) @ v == (D T^-1(phi)[v]) @ b`` and
  ``v @ d2_tangent(phi, a, b) @ w == a @ (D^2 T(phi)[v, w]) @ b``.

Scalar coefficients of ``p = |phi|`` (all even, entire functions except ``a4``, ``c4``, which have poles at
``p = 2 pi k``)::

    a1 = sin p / p                 a2 = (1 - cos p) / p^2         a3 = (p - sin p) / p^3
    a4 = (1 - (p/2) cot(p/2)) / p^2
    c2 = a2'(p) / p    c3 = a3'(p) / p    c4 = a4'(p) / p    e2 = c2'(p) / p    e3 = c3'(p) / p

Below ``SERIES_SWITCH`` every coefficient is its Taylor series in ``p^2``. The closed forms of the derivative
coefficients cancel catastrophically for small ``p`` (``e3`` loses about ``1e4 eps / p^6``: 1e-10 relative at
``p = 0.5``, 1e-12 at ``p = 1``), so the switch is placed high, at ``p = 2.5``, where the worst closed forms
(``e2``, ``e3``) are within ~2e-15 of the exact values. The series carry enough terms (``SERIES_TERMS``) that
their truncation error there is below 1e-17, and they are well conditioned up to and beyond the switch.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

# ----------------------------------------------------------------------------------------------------------
# Scalar coefficients
# ----------------------------------------------------------------------------------------------------------

SERIES_SWITCH = 2.5
"""Below this angle every coefficient is evaluated by its Taylor series in p^2."""

COEFFICIENT_NAMES = ("a1", "a2", "a3", "a4", "c2", "c3", "c4", "e2", "e3")
"""Order of the tuple returned by :func:`coefficients` (and by ``kernels.coefficients``)."""


def _bernoulli(n: int) -> list[Fraction]:
    """Bernoulli numbers B_0..B_n (B_1 = -1/2), exact."""
    B = [Fraction(1)]
    for m in range(1, n + 1):
        # B_m = -1/(m+1) sum_{k<m} C(m+1, k) B_k
        B.append(-sum(math.comb(m + 1, k) * B[k] for k in range(m)) / (m + 1))
    return B


def _d_over_p(c: list[Fraction]) -> list[Fraction]:
    """Series of f'(p)/p from the series of f = sum c_j p^(2j): coefficient 2(j+1) c_(j+1)."""
    return [2 * (j + 1) * c[j + 1] for j in range(len(c) - 1)]


def _series_table(n_entire: int, n_cot: int) -> dict[str, np.ndarray]:
    """Taylor coefficients (ascending powers of p^2) of every coefficient function, from exact rationals."""
    m = n_entire + 2  # two extra terms: each derivative drops one
    a1 = [Fraction((-1) ** k, math.factorial(2 * k + 1)) for k in range(m)]  # sin p / p
    a2 = [Fraction((-1) ** k, math.factorial(2 * k + 2)) for k in range(m)]  # (1 - cos p) / p^2
    a3 = [Fraction((-1) ** k, math.factorial(2 * k + 3)) for k in range(m)]  # (p - sin p) / p^3
    B = _bernoulli(2 * n_cot + 4)
    # (p/2) cot(p/2) = sum_n (-1)^n B_2n p^2n / (2n)!, so a4 = -sum_{n>=1} (-1)^n B_2n p^(2n-2) / (2n)!
    a4 = [-((-1) ** n) * B[2 * n] / math.factorial(2 * n) for n in range(1, n_cot + 2)]
    exact = {"a1": a1, "a2": a2, "a3": a3, "a4": a4,
             "c2": _d_over_p(a2), "c3": _d_over_p(a3), "c4": _d_over_p(a4),
             "e2": _d_over_p(_d_over_p(a2)), "e3": _d_over_p(_d_over_p(a3))}
    return {name: np.array([float(c) for c in exact[name][:(n_cot if name in ("a4", "c4") else n_entire)]])
            for name in COEFFICIENT_NAMES}


SERIES_TERMS = {"entire": 14, "cot": 24}
"""Series lengths: 14 terms for a1, a2, a3, c2, c3, e2, e3; 24 for a4, c4 (radius of convergence 2 pi)."""

SERIES = _series_table(SERIES_TERMS["entire"], SERIES_TERMS["cot"])
"""Taylor coefficients in ascending powers of p^2, one float64 array per coefficient name."""


def series(name: str, p: float) -> float:
    """Evaluate the Taylor series of coefficient ``name`` at ``p`` (Horner in p^2), whatever ``p`` is."""
    x = p * p
    s = 0.0
    for c in SERIES[name][::-1]:
        s = s * x + c
    return s


def a1(p: float) -> float:
    """``sin p / p``."""
    if p < SERIES_SWITCH:
        return series("a1", p)
    return math.sin(p) / p


def a2(p: float) -> float:
    """``(1 - cos p) / p^2``."""
    if p < SERIES_SWITCH:
        return series("a2", p)
    # 1 - cos p = 2 sin^2(p/2) avoids the cancellation
    return 2.0 * math.sin(0.5 * p) ** 2 / p**2


def a3(p: float) -> float:
    """``(p - sin p) / p^3``."""
    if p < SERIES_SWITCH:
        return series("a3", p)
    return (p - math.sin(p)) / p**3


def c2(p: float) -> float:
    """``a2'(p) / p = (p sin p - 2 (1 - cos p)) / p^4``."""
    if p < SERIES_SWITCH:
        return series("c2", p)
    return (p * math.sin(p) - 4.0 * math.sin(0.5 * p) ** 2) / p**4


def c3(p: float) -> float:
    """``a3'(p) / p = (3 sin p - 2 p - p cos p) / p^5``."""
    if p < SERIES_SWITCH:
        return series("c3", p)
    return (3.0 * math.sin(p) - 2.0 * p - p * math.cos(p)) / p**5


def e2(p: float) -> float:
    """``c2'(p) / p = (p^2 cos p - 5 p sin p + 8 (1 - cos p)) / p^6``."""
    if p < SERIES_SWITCH:
        return series("e2", p)
    return (p * p * math.cos(p) - 5.0 * p * math.sin(p) + 16.0 * math.sin(0.5 * p) ** 2) / p**6


def e3(p: float) -> float:
    """``c3'(p) / p = (p^2 sin p - 15 sin p + 8 p + 7 p cos p) / p^7``."""
    if p < SERIES_SWITCH:
        return series("e3", p)
    return ((p * p - 15.0) * math.sin(p) + 8.0 * p + 7.0 * p * math.cos(p)) / p**7


def a4(p: float) -> float:
    """``(1 - (p/2) cot(p/2)) / p^2``; pole at ``p = 2 pi``."""
    if p < SERIES_SWITCH:
        return series("a4", p)
    # (p/2) cot(p/2) = a1 / (2 a2), hence a4 = (2 a2 - a1) / (2 a2 p^2) = -c2 / (2 a2)
    return -c2(p) / (2.0 * a2(p))


def c4(p: float) -> float:
    """``a4'(p) / p``; pole at ``p = 2 pi``."""
    if p < SERIES_SWITCH:
        return series("c4", p)
    # a4 = 1/p^2 - cot(p/2) / (2 p), differentiated: c4 = ((h / sin h)^2 + h cot h - 2) / p^4, h = p/2
    h = 0.5 * p
    return ((h / math.sin(h)) ** 2 + h * math.cos(h) / math.sin(h) - 2.0) / p**4


def coefficients(p: float) -> tuple[float, ...]:
    """All coefficients at ``p``, in the order of :data:`COEFFICIENT_NAMES`."""
    return a1(p), a2(p), a3(p), a4(p), c2(p), c3(p), c4(p), e2(p), e3(p)


# ----------------------------------------------------------------------------------------------------------
# Maps
# ----------------------------------------------------------------------------------------------------------


def hat(v: np.ndarray) -> np.ndarray:
    """Skew matrix of ``v``: ``hat(v) @ w == cross(v, w)``."""
    return np.array([[0.0, -v[2], v[1]],
                     [v[2], 0.0, -v[0]],
                     [-v[1], v[0], 0.0]])


def hat_many(v: np.ndarray) -> np.ndarray:
    """:func:`hat` of each vector of v (..., 3) -> (..., 3, 3)."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def vee(W: np.ndarray) -> np.ndarray:
    """Axial vector of a skew matrix (inverse of :func:`hat`; the skew part is used)."""
    return 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])


def exp(phi: np.ndarray) -> np.ndarray:
    """Rotation matrix ``expm(hat(phi))`` (Rodrigues)."""
    phi = np.asarray(phi, dtype=float)
    p = math.sqrt(phi @ phi)
    W = hat(phi)
    # R = I + a1 W + a2 W^2
    return np.eye(3) + a1(p) * W + a2(p) * (W @ W)


def _quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``[w, x, y, z]`` with ``w >= 0`` of ``R`` (Shepperd's method, any angle).

    The largest of ``4 w^2, 4 x^2, 4 y^2, 4 z^2`` is taken from the diagonal, the other components from the
    off-diagonal sums and differences divided by it, so no small number is divided by a small number.
    A matrix that drifted slightly from orthogonality gives a quaternion that is wrong to the same order.
    """
    t = R[0, 0] + R[1, 1] + R[2, 2]
    k = int(np.argmax([t, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:  # |angle| not near pi: w is the largest
        w = 0.5 * math.sqrt(max(1.0 + t, 0.0))
        q = np.array([4 * w * w, R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (4 * w)
    elif k == 1:
        x = 0.5 * math.sqrt(max(1.0 + 2 * R[0, 0] - t, 0.0))
        q = np.array([R[2, 1] - R[1, 2], 4 * x * x, R[0, 1] + R[1, 0], R[0, 2] + R[2, 0]]) / (4 * x)
    elif k == 2:
        y = 0.5 * math.sqrt(max(1.0 + 2 * R[1, 1] - t, 0.0))
        q = np.array([R[0, 2] - R[2, 0], R[0, 1] + R[1, 0], 4 * y * y, R[1, 2] + R[2, 1]]) / (4 * y)
    else:
        z = 0.5 * math.sqrt(max(1.0 + 2 * R[2, 2] - t, 0.0))
        q = np.array([R[1, 0] - R[0, 1], R[0, 2] + R[2, 0], R[1, 2] + R[2, 1], 4 * z * z]) / (4 * z)
    # q and -q are the same rotation; w >= 0 gives the angle in [0, pi]
    return -q if q[0] < 0 else q


def log(R: np.ndarray) -> np.ndarray:
    """Rotation vector ``phi`` with ``exp(phi) == R`` and ``|phi| <= pi``.

    Accurate at every angle, including at and near ``pi``, via the quaternion of ``R``. The angle
    ``2 atan2(|q_v|, q_w)`` does not depend on the quaternion's norm, so a slightly non-orthogonal ``R``
    gives a rotation vector in error only to the order of the drift.
    """
    q = _quaternion(np.asarray(R, dtype=float))
    s = math.sqrt(q[1:] @ q[1:])
    t = s / q[0] if q[0] > 0.0 else math.inf
    if t < 1e-5:
        # angle / s = (2 / q_w) atan(t) / t, series to t^4 (error < t^6 / 7)
        scale = 2.0 / q[0] * (1.0 - t * t / 3.0 + t**4 / 5.0)
    else:
        scale = 2.0 * math.atan2(s, q[0]) / s
    return scale * q[1:]


def tangent(phi: np.ndarray) -> np.ndarray:
    """Right tangent operator ``T(phi) = I - a2 hat(phi) + a3 hat(phi)^2``."""
    phi = np.asarray(phi, dtype=float)
    p = math.sqrt(phi @ phi)
    W = hat(phi)
    return np.eye(3) - a2(p) * W + a3(p) * (W @ W)


def tangent_inv(phi: np.ndarray) -> np.ndarray:
    """Inverse right tangent operator ``T^-1(phi) = I + hat(phi)/2 + a4 hat(phi)^2`` (singular at 2 pi)."""
    phi = np.asarray(phi, dtype=float)
    p = math.sqrt(phi @ phi)
    W = hat(phi)
    return np.eye(3) + 0.5 * W + a4(p) * (W @ W)


def d_tangent(phi: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Matrix ``X`` with ``(D T(phi)[v]) @ b == X @ v`` for all ``v``.

    With ``dp[v] = phi.v / p``: ``D T[v] b = -c2 (phi.v) W b - a2 hat(v) b + c3 (phi.v) W^2 b
    + a3 (hat(v) W + W hat(v)) b``, and ``hat(v) c = -hat(c) v``.
    """
    phi, b = np.asarray(phi, dtype=float), np.asarray(b, dtype=float)
    p = math.sqrt(phi @ phi)
    W, Wb = hat(phi), np.cross(phi, b)
    # X = a2 hat(b) - a3 (hat(W b) + W hat(b)) + (c3 W^2 b - c2 W b) phi^T
    return (a2(p) * hat(b) - a3(p) * (hat(Wb) + W @ hat(b))
            + np.outer(c3(p) * (W @ Wb) - c2(p) * Wb, phi))


def d_tangent_inv(phi: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Matrix ``X`` with ``(D T^-1(phi)[v]) @ b == X @ v`` for all ``v``."""
    phi, b = np.asarray(phi, dtype=float), np.asarray(b, dtype=float)
    p = math.sqrt(phi @ phi)
    W, Wb = hat(phi), np.cross(phi, b)
    # X = -hat(b)/2 - a4 (hat(W b) + W hat(b)) + c4 W^2 b phi^T
    return -0.5 * hat(b) - a4(p) * (hat(Wb) + W @ hat(b)) + c4(p) * np.outer(W @ Wb, phi)


def d2_tangent(phi: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Symmetric matrix ``Y`` with ``a @ (D^2 T(phi)[v, w]) @ b == v @ Y @ w`` for all ``v, w``.

    Differentiating ``d_tangent(phi, b) @ v`` once more along ``w`` and contracting with ``a`` gives, with
    ``r = W b``, ``q = W^2 b``, ``m = a x b`` and ``u = a x r + b x (W a)``::

        Y = c2 (m phi^T + phi m^T) - c3 (u phi^T + phi u^T) - a3 (2 (a.b) I - a b^T - b a^T)
            + (e3 a.q - e2 a.r) phi phi^T + (c3 a.q - c2 a.r) I
    """
    phi, a, b = (np.asarray(x, dtype=float) for x in (phi, a, b))
    p = math.sqrt(phi @ phi)
    A3, C2, C3, E2, E3 = a3(p), c2(p), c3(p), e2(p), e3(p)
    r = np.cross(phi, b)  # W b
    q = np.cross(phi, r)  # W^2 b
    m = np.cross(a, b)
    u = np.cross(a, r) + np.cross(b, np.cross(phi, a))
    ar, aq = a @ r, a @ q
    return (C2 * (np.outer(m, phi) + np.outer(phi, m))          # from D a2
            - C3 * (np.outer(u, phi) + np.outer(phi, u))        # from D a3 times D(W^2)
            - A3 * (2.0 * (a @ b) * np.eye(3) - np.outer(a, b) - np.outer(b, a))  # a3 D^2(W^2)
            + (E3 * aq - E2 * ar) * np.outer(phi, phi)          # second derivatives of a2, a3
            + (C3 * aq - C2 * ar) * np.eye(3))                  # D(phi.v)[w] = v.w


# ----------------------------------------------------------------------------------------------------------
# Nodal frames
# ----------------------------------------------------------------------------------------------------------


def update_frame(R: np.ndarray, th: np.ndarray) -> np.ndarray:
    """5-DoF nodal update ``R @ exp(th[0] e1 + th[1] e2)`` (no drilling increment)."""
    return R @ exp(np.array([th[0], th[1], 0.0]))


def director(R: np.ndarray) -> np.ndarray:
    """Director of a nodal frame: its third column ``R e3``."""
    return R[:, 2].copy()


def nearest_rotations(H: np.ndarray) -> np.ndarray:
    """The rotations G (..., 3, 3) that maximize tr(G^T H) for H (..., 3, 3): with H = sum_k b_k a_k^T, the one
    that best maps the vectors a_k onto b_k (least squares; Kabsch: H = U S V^T, G = U diag(1, 1, det(U V^T))
    V^T). A rank of H below 2 (no plane spanned) gives the identity. The reference of
    :func:`flexbody.lie.kernels.nearest_rotations_into`."""
    U, S, Vt = np.linalg.svd(np.asarray(H, dtype=float))
    U[..., :, 2] *= np.where(np.linalg.det(U @ Vt) < 0.0, -1.0, 1.0)[..., None]
    G = U @ Vt
    G[~(S[..., 1] > 1e-12 * S[..., 0])] = np.eye(3)
    return G


# ----------------------------------------------------------------------------------------------------------
# The maps for many rotation vectors / matrices at once (numpy, same formulas as the single versions)
# ----------------------------------------------------------------------------------------------------------


def _closed_or_series(name: str, p: np.ndarray, closed) -> np.ndarray:
    """Coefficient ``name`` at every angle of ``p``: its series below SERIES_SWITCH, ``closed(p)`` above."""
    small = p < SERIES_SWITCH
    out = np.polyval(SERIES[name][::-1], p * p)
    if not small.all():
        big = p[~small]
        out[~small] = closed(big)
    return out


def exp_many(phi: np.ndarray) -> np.ndarray:
    """:func:`exp` of each rotation vector of ``phi`` (..., 3) -> (..., 3, 3)."""
    p = np.linalg.norm(phi, axis=-1)
    W = hat_many(phi)
    a1_ = _closed_or_series("a1", p, lambda q: np.sin(q) / q)
    a2_ = _closed_or_series("a2", p, lambda q: 2.0 * np.sin(0.5 * q) ** 2 / q**2)
    return np.eye(3) + a1_[..., None, None] * W + a2_[..., None, None] * (W @ W)


def tangent_many(phi: np.ndarray) -> np.ndarray:
    """:func:`tangent` of each rotation vector of ``phi`` (..., 3) -> (..., 3, 3)."""
    p = np.linalg.norm(phi, axis=-1)
    W = hat_many(phi)
    a2_ = _closed_or_series("a2", p, lambda q: 2.0 * np.sin(0.5 * q) ** 2 / q**2)
    a3_ = _closed_or_series("a3", p, lambda q: (q - np.sin(q)) / q**3)
    return np.eye(3) - a2_[..., None, None] * W + a3_[..., None, None] * (W @ W)


def log_many(R: np.ndarray) -> np.ndarray:
    """:func:`log` of each rotation matrix of ``R`` (..., 3, 3) -> (..., 3) (Shepperd's quaternion)."""
    R = np.asarray(R, dtype=float)
    t = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    k = np.argmax(np.stack([t, R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]], axis=-1), axis=-1)
    d = lambda i, j: R[..., i, j] - R[..., j, i]
    a = lambda i, j: R[..., i, j] + R[..., j, i]
    with np.errstate(divide="ignore", invalid="ignore"):   # the candidates not chosen may divide by 0
        return _log_from_candidates(R, t, k, d, a)


def _log_from_candidates(R, t, k, d, a) -> np.ndarray:
    big = [0.5 * np.sqrt(np.maximum(1.0 + t, 0.0))] + \
        [0.5 * np.sqrt(np.maximum(1.0 + 2 * R[..., i, i] - t, 0.0)) for i in range(3)]
    cand = [np.stack([4 * big[0] ** 2, d(2, 1), d(0, 2), d(1, 0)], axis=-1) / (4 * big[0])[..., None],
            np.stack([d(2, 1), 4 * big[1] ** 2, a(0, 1), a(0, 2)], axis=-1) / (4 * big[1])[..., None],
            np.stack([d(0, 2), a(0, 1), 4 * big[2] ** 2, a(1, 2)], axis=-1) / (4 * big[2])[..., None],
            np.stack([d(1, 0), a(0, 2), a(1, 2), 4 * big[3] ** 2], axis=-1) / (4 * big[3])[..., None]]
    q = np.choose(k[..., None], cand)
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1)
    w = q[..., 0]
    tt = np.where(w > 0.0, s / w, np.inf)
    scale = np.where(tt < 1e-5, 2.0 / w * (1.0 - tt * tt / 3.0 + tt**4 / 5.0), 2.0 * np.arctan2(s, w) / s)
    return scale[..., None] * q[..., 1:]
