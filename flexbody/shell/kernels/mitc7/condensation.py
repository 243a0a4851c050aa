"""The static condensation of the MITC7 rotation bubble, element by element: Newton on the bubble amplitudes b,
then the condensed tangent::

    r_b(b*) = 0  (Newton on the 2 x 2 block, from the warm start b0),
    f = r_n(b*),     K = K_nn - K_nb K_bb^-1 K_bn.

Convergence of the bubble: the safeguarded Newton step of :func:`flexbody.shell.bubble_newton.bubble_step` (the
same function, compiled), from the warm start b0 and, if that fails, from b = 0, until the correction is
<= ``BUBBLE_TOL (1 + |b|_inf)``; that last correction is applied and the force and tangent are evaluated
at the final b, as in the reference. If it does not converge within ``BUBBLE_MAX_ITERATIONS`` evaluations,
or a correction is not finite, the caller (:mod:`flexbody.shell.kernels.mitc7.loops`) sets the element's
force (and tangent) to NaN, so that its Newton stops cleanly on a non-finite residual, and returns the warm
start b0 as the element's b (not the diverged iterate), so that a retry from the last state is not poisoned.
The reference raises ``FloatingPointError`` in that case.
"""

from __future__ import annotations

import numpy as np

from flexbody import _numba
from flexbody.shell.bubble_newton import bubble_step
from flexbody.shell.kernels.mitc7.augmented import evaluate_bubble
from flexbody.shell.kernels.mitc7.points import NDOF

# The jit policy of flexbody._numba: numba's defaults (``plain``: no fastmath, so that moving these loops out
# of the chunk loop changes no result).
plain = _numba.plain
#: the safeguarded Newton step, shared with the numpy reference
compiled_bubble_step = plain(bubble_step)


@plain
def solve_bubble(e, b0, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                 EN, EDN, ENB, EDNB, tol, max_iter, zs, ws, fa, Ka):
    """Newton on element e's bubble b (2,), in place, from b0[e] and, if that fails, from b = 0 (as
    :func:`flexbody.shell.reference.bubble.condense`). True if it converged (module docstring)."""
    converged = False
    warm = b0[e, 0] != 0.0 or b0[e, 1] != 0.0
    for attempt in range(2 if warm else 1):   # from the warm start, then from b = 0
        b[0] = b0[e, 0] if attempt == 0 else 0.0
        b[1] = b0[e, 1] if attempt == 0 else 0.0
        for _ in range(max_iter):
            evaluate_bubble(e, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                            EN, EDN, ENB, EDNB, zs, ws, fa, Ka)
            db0, db1 = compiled_bubble_step(fa[NDOF], fa[NDOF + 1], Ka[NDOF, NDOF], Ka[NDOF, NDOF + 1],
                                            Ka[NDOF + 1, NDOF], Ka[NDOF + 1, NDOF + 1])
            if not (np.isfinite(db0) and np.isfinite(db1)):
                break
            b[0] += db0
            b[1] += db1
            if max(abs(db0), abs(db1)) <= tol * (1.0 + max(abs(b[0]), abs(b[1]))):
                converged = True
                break
        if converged:
            break
    return converged


@plain
def condense_into(Ka, Y, K, e):
    """K[e] (36, 36) = K_nn - K_nb K_bb^-1 K_bn of the augmented tangent Ka (38, 38); Y (2, 36) scratch."""
    k00, k01, k10, k11 = Ka[NDOF, NDOF], Ka[NDOF, NDOF + 1], Ka[NDOF + 1, NDOF], Ka[NDOF + 1, NDOF + 1]
    det = k00 * k11 - k01 * k10
    for c in range(NDOF):
        u0, u1 = Ka[NDOF, c], Ka[NDOF + 1, c]
        Y[0, c] = (k11 * u0 - k01 * u1) / det
        Y[1, c] = (k00 * u1 - k10 * u0) / det
    for r in range(NDOF):
        kr0, kr1 = Ka[r, NDOF], Ka[r, NDOF + 1]
        for c in range(NDOF):
            K[e, r, c] = Ka[r, c] - kr0 * Y[0, c] - kr1 * Y[1, c]
