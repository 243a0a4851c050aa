"""Quadratic six-node triangle: shape functions and the quadrature rule.

Reference triangle: r, s >= 0, r + s <= 1, t = 1 - r - s. Node order: corners 1=(0,0), 2=(1,0),
3=(0,1), then midside nodes 4=(1,2), 5=(2,3), 6=(3,1) (0-based in code: 0..5).
"""

from __future__ import annotations

import numpy as np


def shape_functions(r: float, s: float) -> np.ndarray:
    """Values N_I(r, s) of the six quadratic shape functions, shape (6,)."""
    t = 1.0 - r - s
    return np.array([t * (2 * t - 1), r * (2 * r - 1), s * (2 * s - 1), 4 * r * t, 4 * r * s, 4 * s * t])


def shape_derivatives(r: float, s: float) -> np.ndarray:
    """Derivatives dN_I/dr (row 0) and dN_I/ds (row 1), shape (2, 6)."""
    t = 1.0 - r - s
    dr = [1 - 4 * t, 4 * r - 1, 0.0, 4 * (t - r), 4 * s, -4 * s]
    ds = [1 - 4 * t, 0.0, 4 * s - 1, -4 * r, 4 * r, 4 * (t - s)]
    return np.array([dr, ds])


def bubble_function(r: float, s: float) -> float:
    """The cubic bubble N_b = 27 r s t (1 at the centroid, 0 on the edges) of the MITC7 rotations."""
    return 27.0 * r * s * (1.0 - r - s)


def bubble_derivatives(r: float, s: float) -> np.ndarray:
    """dN_b/dr, dN_b/ds, shape (2,)."""
    t = 1.0 - r - s
    return 27.0 * np.array([s * (t - r), r * (t - s)])


def gauss_triangle_7() -> tuple[np.ndarray, np.ndarray]:
    """The 7-point rule of degree 5 on the reference triangle (weights sum to 1/2).

    Returns
    -------
    points : (7, 2) array of (r, s)
    weights : (7,) array
    """
    sq = np.sqrt(15.0)
    a1, b1 = (6 - sq) / 21, (9 + 2 * sq) / 21
    a2, b2 = (6 + sq) / 21, (9 - 2 * sq) / 21
    w1, w2 = (155 - sq) / 2400, (155 + sq) / 2400
    pts = [(1 / 3, 1 / 3), (a1, a1), (b1, a1), (a1, b1), (a2, a2), (b2, a2), (a2, b2)]
    wts = [9 / 80, w1, w1, w1, w2, w2, w2]
    return np.array(pts), np.array(wts)
