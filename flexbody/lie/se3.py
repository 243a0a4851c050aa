"""SE(3): exponential, logarithm, right tangent operator, adjoints (numpy reference, built on ``so3``).

A group element is the 4x4 matrix ``H = [[R, x], [0, 1]]``. Algebra vectors are ordered translation first,
``h = [h_u, h_w]``, with ``hat6(h) = [[hat(h_w), h_u], [0, 0]]``.

The tangent operator is the right one, consistent with ``so3.tangent``:
``exp(h + dh) = exp(h) @ exp(hat6(tangent(h) @ dh))`` to first order. Both ``tangent`` and its inverse are
power series in ``ad(h)`` (``sum (-1)^k ad^k / (k+1)!`` and its reciprocal), and
``ad(h)^k = [[W^k, sum_j W^j U W^(k-1-j)], [0, W^k]]`` with ``W = hat(h_w)``, ``U = hat(h_u)``, so the
off-diagonal block is the directional derivative of the SO(3) operator along ``h_u``::

    tangent(h)     = [[T(w), D T(w)[u]],    [0, T(w)]]
    tangent_inv(h) = [[T^-1(w), D T^-1(w)[u]], [0, T^-1(w)]]
"""

from __future__ import annotations

import math

import numpy as np

from flexbody.lie import so3


def hat6(h: np.ndarray) -> np.ndarray:
    """4x4 algebra matrix ``[[hat(h_w), h_u], [0, 0]]`` of ``h = [h_u, h_w]``."""
    X = np.zeros((4, 4))
    X[:3, :3] = so3.hat(h[3:])
    X[:3, 3] = h[:3]
    return X


def vee6(X: np.ndarray) -> np.ndarray:
    """Inverse of :func:`hat6`: ``[h_u, h_w]`` from a 4x4 algebra matrix."""
    return np.concatenate([X[:3, 3], so3.vee(X[:3, :3])])


def make(R: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Group element ``[[R, x], [0, 1]]``."""
    H = np.eye(4)
    H[:3, :3] = R
    H[:3, 3] = x
    return H


def rotation(H: np.ndarray) -> np.ndarray:
    """Rotation block of a group element."""
    return H[:3, :3].copy()


def translation(H: np.ndarray) -> np.ndarray:
    """Translation column of a group element."""
    return H[:3, 3].copy()


def inverse(H: np.ndarray) -> np.ndarray:
    """``H^-1 = [[R^T, -R^T x], [0, 1]]``."""
    R, x = H[:3, :3], H[:3, 3]
    return make(R.T, -R.T @ x)


def compose(*Hs: np.ndarray) -> np.ndarray:
    """Product ``H1 @ H2 @ ...`` of group elements."""
    out = np.eye(4)
    for H in Hs:
        out = out @ H
    return out


def act(H: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Action on a point: ``R y + x``."""
    return H[:3, :3] @ y + H[:3, 3]


def _d_tangent_matrix(w: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Directional derivative of the matrix ``T(w)`` along ``u``."""
    p = math.sqrt(w @ w)
    W, U = so3.hat(w), so3.hat(u)
    # D T[u] = -c2 (w.u) W - a2 U + c3 (w.u) W^2 + a3 (U W + W U)
    return ((so3.c3(p) * (w @ u)) * (W @ W) - (so3.c2(p) * (w @ u)) * W
            - so3.a2(p) * U + so3.a3(p) * (U @ W + W @ U))


def _d_tangent_inv_matrix(w: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Directional derivative of the matrix ``T^-1(w)`` along ``u``."""
    p = math.sqrt(w @ w)
    W, U = so3.hat(w), so3.hat(u)
    # D T^-1[u] = U/2 + c4 (w.u) W^2 + a4 (U W + W U)
    return 0.5 * U + (so3.c4(p) * (w @ u)) * (W @ W) + so3.a4(p) * (U @ W + W @ U)


def exp(h: np.ndarray) -> np.ndarray:
    """Group element ``expm(hat6(h)) = [[exp(w), T(w)^T u], [0, 1]]``."""
    h = np.asarray(h, dtype=float)
    u, w = h[:3], h[3:]
    # translation: sum W^k / (k+1)! u = T(-w) u = T(w)^T u
    return make(so3.exp(w), so3.tangent(w).T @ u)


def log(H: np.ndarray) -> np.ndarray:
    """Algebra vector ``h`` with ``exp(h) == H`` and ``|h_w| <= pi``."""
    w = so3.log(H[:3, :3])
    # u = T(w)^-T x = T^-1(-w) x
    return np.concatenate([so3.tangent_inv(-w) @ H[:3, 3], w])


def tangent(h: np.ndarray) -> np.ndarray:
    """Right tangent operator ``[[T(w), D T(w)[u]], [0, T(w)]]`` (6x6)."""
    h = np.asarray(h, dtype=float)
    u, w = h[:3], h[3:]
    T = so3.tangent(w)
    return np.block([[T, _d_tangent_matrix(w, u)], [np.zeros((3, 3)), T]])


def tangent_inv(h: np.ndarray) -> np.ndarray:
    """Inverse right tangent operator ``[[T^-1(w), D T^-1(w)[u]], [0, T^-1(w)]]`` (6x6)."""
    h = np.asarray(h, dtype=float)
    u, w = h[:3], h[3:]
    Ti = so3.tangent_inv(w)
    return np.block([[Ti, _d_tangent_inv_matrix(w, u)], [np.zeros((3, 3)), Ti]])


def ad(h: np.ndarray) -> np.ndarray:
    """Algebra adjoint ``[[hat w, hat u], [0, hat w]]``: ``hat6(ad(h1) h2) = [hat6(h1), hat6(h2)]``."""
    h = np.asarray(h, dtype=float)
    W, U = so3.hat(h[3:]), so3.hat(h[:3])
    return np.block([[W, U], [np.zeros((3, 3)), W]])


def Ad(H: np.ndarray) -> np.ndarray:
    """Group adjoint ``[[R, hat(x) R], [0, R]]``: ``hat6(Ad(H) h) = H hat6(h) H^-1``."""
    R, x = H[:3, :3], H[:3, 3]
    return np.block([[R, so3.hat(x) @ R], [np.zeros((3, 3)), R]])
