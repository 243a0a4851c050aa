"""Point operators expanded to element rows: the B matrices and the element vectors of a Gauss point
(readable numpy twin of :mod:`flexbody.shell.kernels.expansion`; paper Eqs. 17-21).

At an evaluation point the covariant strains vary as delta e = D G delta h, with G = dF/dh the Jacobian of
the strain measures (:func:`flexbody.shell.reference.points.measures_jacobian`) and D = de/dF
(:func:`flexbody.shell.reference.points.strain_gradient`): the covariant B of that point, (8, ndof). A Gauss
point's Cartesian B_g combines the B of the evaluation points through the assumed-strain map
(:mod:`flexbody.shell.reference.material`):

    B_g = to_cart_g A_g [B_p]_p,          delta W = sum_g w_g (B_g delta h)^T sigma_g   (paper Eq. 18)
"""

from __future__ import annotations

import numpy as np

from flexbody.shell.reference.points import PointKinematics, measures_jacobian, strain_gradient


def covariant_B(k: PointKinematics) -> np.ndarray:
    """B_p = D G (8, ndof): the covariant strains' rows of one evaluation point (paper Eqs. 19-21)."""
    return strain_gradient(k.F) @ measures_jacobian(k)


def gauss_B(gauss_map: np.ndarray, B: np.ndarray) -> np.ndarray:
    """B_g (8, ndof) = (to_cart_g A_g) [B_p]_p from the points' B (17, 8, ndof) and the Gauss point's strain
    map (8, 17*8) (:func:`flexbody.shell.reference.material.gauss_strain_map`)."""
    return gauss_map @ B.reshape(-1, B.shape[-1])


def gauss_force(B_g: np.ndarray, sigma: np.ndarray, w: float) -> np.ndarray:
    """w B_g^T sigma_g (ndof,): the internal force of one Gauss point of weight w (paper Eq. 18)."""
    return w * B_g.T @ sigma


def linearized_gauss_strains(gauss_maps: np.ndarray, B: np.ndarray, dh: np.ndarray) -> np.ndarray:
    """B_g dh for all Gauss points: (7, 8) for dh (ndof,), (7, 8, k) for dh (ndof, k); gauss_maps
    (7, 8, 17, 8) from :func:`flexbody.shell.reference.material.gauss_strain_maps`."""
    return np.einsum("gipk,pkn,n...->gi...", gauss_maps, B, dh)
