"""The rotation bubble of the MITC7 shell, condensed element by element (readable numpy twin of
:mod:`flexbody.shell.kernels.mitc7`).

MITC6 (quadratic positions and rotations, MITC6a shear) converges at only about O(h) in the thin limit:
its shear space, the rotated Raviart-Thomas space of index 1, is tied partly by point values and the
rotations lack the interior freedom that makes the Kirchhoff constraint stable. MITC7 (Brezzi, Bathe &
Fortin 1989, for plates) adds a cubic bubble N_b = 27 r s t to the rotations and ties the shear by the
canonical degrees of freedom of that space: the edge moments (the two Gauss stations of each edge, as in
MITC6a) and the element means of e_rt and e_st (:func:`flexbody.shell.mitc6.shear_map_mitc7`).

On the SE(3) shell the bubble enters the relative rotation of paper Eq. 30:

    d = sum_I N_I log(R_0^T R_I) + N_b (b_1, b_2, 0),

b an element unknown: a rotation about the in-plane axes of the reference node's frame, so rigid motions
leave it unchanged and the element stays invariant. b is not a global unknown: for a given nodal state it
is solved from its own equilibrium r_b(b) = 0 (Newton on the 2 x 2 block,
:func:`flexbody.shell.bubble_newton.bubble_step`), and the element returns

    f = r_n(b*),    K = K_nn - K_nb K_bb^-1 K_bn,

the exact tangent of the condensed force (implicit function theorem). Membrane strains do not depend on
the rotations: the membrane tying is the default "mean" scheme.
"""

from __future__ import annotations

import numpy as np

from flexbody.shell.bubble_newton import BUBBLE_MAX_ITERATIONS, BUBBLE_TOL, bubble_step
from flexbody.shell.geometry import ElementGeometry
from flexbody.shell.mitc6 import DEFAULT_SCHEME
from flexbody.shell.reference.loops import force_tangent
from flexbody.shell.reference.material import assumed_strain_maps
from flexbody.shell.reference.points import NDOF

#: MITC7's assumed-strain map: the default membrane scheme, the canonical shear tying (read-only).
MITC7_MAPS = assumed_strain_maps(DEFAULT_SCHEME, "mitc7")
MITC7_MAPS.flags.writeable = False


def augmented_force_tangent(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                            b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Force (38,) and tangent (38, 38) of the element with the bubble b (2,) as two more unknowns."""
    return force_tangent(x, frames, geom, section, MITC7_MAPS, b)


def condensed_bubble(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                     b0: np.ndarray | None = None) -> np.ndarray:
    """The bubble amplitudes b* (2,) in equilibrium with the nodal state (Newton from b0, default 0)."""
    return _solve(x, frames, geom, section, b0)[0]


def _solve(x, frames, geom, section, b0=None):
    """b*, and the augmented force (38,) and tangent (38, 38) at b*; from b0, and from 0 if that fails."""
    if b0 is not None and np.any(b0):
        try:
            return _newton(x, frames, geom, section, np.array(b0, dtype=float))
        except FloatingPointError:
            pass
    return _newton(x, frames, geom, section, np.zeros(2))


def _newton(x, frames, geom, section, b):
    for _ in range(BUBBLE_MAX_ITERATIONS):
        f, K = augmented_force_tangent(x, frames, geom, section, b)
        db = np.array(bubble_step(f[NDOF], f[NDOF + 1], K[NDOF, NDOF], K[NDOF, NDOF + 1], K[NDOF + 1, NDOF],
                                  K[NDOF + 1, NDOF + 1]))
        if not np.all(np.isfinite(db)):
            break
        b = b + db
        if np.abs(db).max() <= BUBBLE_TOL * (1.0 + np.abs(b).max()):
            f, K = augmented_force_tangent(x, frames, geom, section, b)  # at the final b: r_b's error ~ |db|^2
            return b, f, K
    raise FloatingPointError(f"the rotation bubble did not converge (last correction {np.abs(db).max():.3e})")


def condense(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
             b0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Internal force (36,), condensed tangent (36, 36) and bubble b* (2,) of the MITC7 element.

    b0 : a starting value for the bubble's Newton (for example its value at the last evaluation); the
         result does not depend on it beyond the bubble tolerance.
    """
    b, f, K = _solve(x, frames, geom, section, b0)
    n, i = slice(0, NDOF), slice(NDOF, NDOF + 2)
    K_c = K[n, n] - K[n, i] @ np.linalg.solve(K[i, i], K[i, n])
    return f[n], K_c, b


def condensed_force_tangent(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                            b0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Internal force (36,) and condensed tangent (36, 36) of the MITC7 element (see :func:`condense`)."""
    return condense(x, frames, geom, section, b0)[:2]
