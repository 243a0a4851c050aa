"""Assumed strains, Cartesian strains and stress resultants at the Gauss points (readable numpy twin of
:mod:`flexbody.shell.kernels.material`; paper Eqs. 14, 18, 23, 27-28).

The covariant strains e_p (8,) at the evaluation points p (the tying points, then the Gauss points:
``flexbody.shell.geometry.EVAL_POINTS``) give the Cartesian strains [membrane eps11, eps22, 2eps12 |
bending | shear] at Gauss point g through the assumed-strain map A (7, 8, 17, 8) and the covariant-to-Cartesian
map of the reference geometry (``ElementGeometry.to_cart``):

    eps_g = to_cart_g sum_p A[g, :, p, :] e_p,        sigma_g = C eps_g   (paper Eq. 14)

The same maps, transposed, pull a Gauss point's stress resultants back to covariant weights at the
evaluation points (the weights s_p of the geometric stiffness, paper Eq. 24).
"""

from __future__ import annotations

import numpy as np

from flexbody.shell.geometry import GAUSS_OFFSET, MEMBRANE_MAPS, MITC7_SHEAR_MAPS, N_GAUSS, SHEAR_MAPS
from flexbody.shell.mitc6 import DEFAULT_SCHEME, MEMBRANE_SCHEMES, N_TYING

MEMBRANE, BENDING, SHEAR = slice(0, 3), slice(3, 6), slice(6, 8)

#: Transverse shear tying schemes: MITC6a's edge stations (MITC6) and MITC7's canonical degrees of freedom.
SHEAR_SCHEMES = ("mitc6", "mitc7")


def assumed_strain_maps(membrane: str | None = DEFAULT_SCHEME, shear: str | None = "mitc6") -> np.ndarray:
    """A (7, 8, 17, 8): covariant strains at Gauss point g = sum A[g, :, p, :] e[p] over evaluation points
    (paper Eqs. 27-28).

    membrane : a membrane tying scheme of ``mitc6.MEMBRANE_SCHEMES`` ("mean", "point"), or None (the strains
        of the Gauss point itself, displacement-based)
    shear : "mitc6" (MITC6a), "mitc7" (the canonical tying of MITC7, :mod:`flexbody.shell.reference.bubble`)
        or None (displacement-based). Bending is always displacement-based.

    The element variants of :mod:`flexbody.shell.variants` hold theirs (``ElementVariant.maps``).
    """
    if membrane is not None and membrane not in MEMBRANE_SCHEMES:
        raise ValueError(f"membrane must be one of {MEMBRANE_SCHEMES} or None, got {membrane!r}")
    if shear is not None and shear not in SHEAR_SCHEMES:
        raise ValueError(f"shear must be one of {SHEAR_SCHEMES} or None, got {shear!r}")
    n_eval = N_TYING + N_GAUSS
    A = np.zeros((N_GAUSS, 8, n_eval, 8))
    for g in range(N_GAUSS):
        gp = GAUSS_OFFSET + g
        A[g, BENDING, gp, BENDING] = np.eye(3)
        if membrane is None:
            A[g, MEMBRANE, gp, MEMBRANE] = np.eye(3)
        else:
            A[g, MEMBRANE, :, MEMBRANE] = MEMBRANE_MAPS[membrane][g]
        if shear is None:
            A[g, SHEAR, gp, SHEAR] = np.eye(2)
        elif shear == "mitc7":
            A[g, SHEAR, :, SHEAR] = MITC7_SHEAR_MAPS[g]
        else:
            A[g, SHEAR, :N_TYING, SHEAR] = SHEAR_MAPS[g]
    return A


def cartesian_strains(to_cart: np.ndarray, A: np.ndarray, e: np.ndarray) -> np.ndarray:
    """eps_g (7, 8) = to_cart_g A_g e: the Cartesian strains at the Gauss points from the covariant strains
    e (17, 8) at the evaluation points (reference values subtracted)."""
    cov = np.einsum("gipj,pj->gi", A, e)
    return np.einsum("gij,gj->gi", to_cart, cov)


def gauss_strain_maps(to_cart: np.ndarray, A: np.ndarray) -> np.ndarray:
    """to_cart_g A_g for all Gauss points, (7, 8, 17, 8): point strains -> Cartesian strains."""
    return np.einsum("gij,gjpk->gipk", to_cart, A)


def gauss_strain_map(to_cart_g: np.ndarray, A_g: np.ndarray) -> np.ndarray:
    """to_cart_g A_g of one Gauss point as a matrix (8, 17*8) acting on the flattened point strains."""
    return to_cart_g @ A_g.reshape(8, -1)


def stress_resultants(section: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """[N, M, Q] = C eps (8,): membrane forces, bending moments, transverse shear forces (paper Eq. 14)."""
    return section @ eps


def material_stiffness(B_g: np.ndarray, section: np.ndarray, w: float) -> np.ndarray:
    """w B_g^T C B_g (ndof, ndof): the material stiffness of one Gauss point of weight w (paper Eq. 23)."""
    return w * B_g.T @ section @ B_g


def pulled_back_stress(to_cart_map: np.ndarray, sigma: np.ndarray, w: float, shape: tuple) -> np.ndarray:
    """w (to_cart_g A_g)^T sigma_g, reshaped to the point strains' shape (17, 8): the covariant stress weights
    that one Gauss point's resultants sigma_g put on the evaluation points (paper Eq. 24)."""
    return w * (to_cart_map.T @ sigma).reshape(shape)


def mapped_strains(gauss_maps: np.ndarray, e: np.ndarray) -> np.ndarray:
    """eps_g (7, 8) from the combined maps to_cart_g A_g (7, 8, 17, 8) (:func:`gauss_strain_maps`) and the
    point strains e (17, 8): :func:`cartesian_strains` with the two maps multiplied first."""
    return np.einsum("gipk,pk->gi", gauss_maps, e)
