"""The Newton iteration on the MITC7 rotation bubble: its safeguarded step and its stopping rule, shared by
the readable element (:mod:`flexbody.shell.reference.bubble`) and the numba one, which compiles
:func:`bubble_step` itself (scalar arithmetic only)."""

from __future__ import annotations

#: Newton on the bubble stops when its correction is below this (b is an angle).
BUBBLE_TOL = 1e-13
BUBBLE_MAX_ITERATIONS = 25
#: Largest bubble correction per Newton step, in radians (max-norm).
BUBBLE_STEP_CAP = 0.3


def bubble_step(g0: float, g1: float, h00: float, h01: float, h10: float, h11: float) -> tuple[float, float]:
    """The safeguarded Newton correction of the bubble for its force g and its 2 x 2 block H.

    b* minimises the element energy over b. Where H is positive definite (always near a minimum) this is
    the Newton step -H^-1 g. Elsewhere (a far-off trial state under large compression) H is replaced by
    |H| = (H^2 + |det H| I) / sqrt(tr H^2 + 2 |det H|), the matrix with H's eigenvectors and the absolute
    values of its eigenvalues, which gives a descent direction. The step is capped at BUBBLE_STEP_CAP.
    Scalar arithmetic only, so that the numba kernel compiles this same function.
    """
    a, b, c = h00, 0.5 * (h01 + h10), h11
    det = a * c - b * b
    if not (det > 0.0 and a + c > 0.0):
        ad = abs(det)
        scale = (a * a + 2.0 * b * b + c * c + 2.0 * ad) ** 0.5
        floor = 1e-12 * (abs(a) + abs(c) + 2.0 * abs(b))
        a, b, c = ((a * a + b * b + ad) / scale + floor, (a + c) * b / scale,
                   (b * b + c * c + ad) / scale + floor)
        det = a * c - b * b
        h01 = h10 = b
    else:
        a, c = h00, h11
        det = a * c - h01 * h10
    d0 = -(c * g0 - h01 * g1) / det
    d1 = -(a * g1 - h10 * g0) / det
    big = max(abs(d0), abs(d1))
    if big > BUBBLE_STEP_CAP:
        d0, d1 = d0 * BUBBLE_STEP_CAP / big, d1 * BUBBLE_STEP_CAP / big
    return d0, d1
