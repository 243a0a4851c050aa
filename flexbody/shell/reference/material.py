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


# -- tension-field membrane (wrinkling) ---------------------------------------------------------------------


def principal_membrane_strains(eps_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Principal strains e1 >= e2 of membrane strains [e11, e22, 2 e12] (..., 3) and their unit directions
    n (of e1) and m (of e2), (..., 2) each: n = (cos t, sin t), m = (-sin t, cos t), 2 t = atan2(2 e12,
    e11 - e22). Equal principal strains give t = 0 (atan2(0, 0)), never NaN."""
    e11, e22, g12 = eps_m[..., 0], eps_m[..., 1], eps_m[..., 2]
    mean = 0.5 * (e11 + e22)
    radius = np.hypot(0.5 * (e11 - e22), 0.5 * g12)
    t = 0.5 * np.arctan2(g12, e11 - e22)
    c, s = np.cos(t), np.sin(t)
    return mean + radius, mean - radius, np.stack([c, s], axis=-1), np.stack([-s, c], axis=-1)


def tension_field_membrane(eps_m: np.ndarray, C_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Membrane forces N (..., 3) and tangent dN/deps (..., 3, 3) of the tension-field (relaxed) membrane law
    for membrane strains [e11, e22, 2 e12] (..., 3) and an isotropic plane-stress membrane stiffness C_m
    (3, 3) = Eh / (1 - nu^2) [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]].

    A film carries no compression: where the linear law would give a compressive principal force it wrinkles.
    The energy is the relaxed (quasiconvex) envelope of the plane-stress energy (Pipkin's relaxed energy),
    with the state chosen by the mixed stress-strain criterion (Roddeman et al.; Kang and Im), for principal
    strains e1 >= e2 along n, m (:func:`principal_membrane_strains`) and Eh = C11 - C12^2 / C11, nu = C12 / C11:

    * taut, e2 + nu e1 > 0 (both principal forces of the linear law positive): N = C_m eps, tangent C_m;
    * slack, e1 <= 0: N = 0, tangent 0;
    * wrinkled otherwise: uniaxial tension along n, N = Eh e1 p with p = [n1^2, n2^2, n1 n2], the gradient of
      W = Eh e1^2 / 2. Its Hessian is the tangent Eh p p^T + Eh e1 / (2 (e1 - e2)) q q^T,
      q = [2 n1 m1, 2 n2 m2, n1 m2 + n2 m1]: de1/deps = p, and dp/deps = q q^T / (2 (e1 - e2)) from the
      rotation of n, dn = m (m . dE n) / (e1 - e2) with m . dE n = q . deps / 2. There e1 - e2 >= (1 + nu) e1
      > 0, and the tangent is symmetric positive semidefinite.

    N is continuous across both regime boundaries (at e2 = -nu e1 the linear law is uniaxial, at e1 = 0 zero);
    the tangent is not. Both are homogeneous in eps (degree 1 and 0): C_t eps = N in every regime.
    """
    eps_m = np.asarray(eps_m, dtype=float)
    c11, c12 = C_m[0, 0], C_m[0, 1]
    Eh, nu = c11 - c12 * c12 / c11, c12 / c11
    e1, e2, n, m = principal_membrane_strains(eps_m)
    p = np.stack([n[..., 0] ** 2, n[..., 1] ** 2, n[..., 0] * n[..., 1]], axis=-1)
    q = np.stack([2 * n[..., 0] * m[..., 0], 2 * n[..., 1] * m[..., 1],
                  n[..., 0] * m[..., 1] + n[..., 1] * m[..., 0]], axis=-1)
    taut = e2 + nu * e1 > 0
    wrinkled = ~taut & (e1 > 0)
    gap = np.where(wrinkled, e1 - e2, 1.0)                       # > 0 where it is used
    N = np.where(taut[..., None], eps_m @ C_m.T, np.where(wrinkled, Eh * e1, 0.0)[..., None] * p)
    C_w = (Eh * p[..., :, None] * p[..., None, :]
           + (Eh * e1 / (2 * gap))[..., None, None] * q[..., :, None] * q[..., None, :])
    C_t = np.where(taut[..., None, None], C_m, np.where(wrinkled[..., None, None], C_w, 0.0))
    return N, C_t


def membrane_regimes(eps_m: np.ndarray, C_m: np.ndarray) -> np.ndarray:
    """The regime of the tension-field law at membrane strains (..., 3): 0 slack, 1 wrinkled, 2 taut
    (:func:`tension_field_membrane`)."""
    nu = C_m[0, 1] / C_m[0, 0]
    e1, e2, _, _ = principal_membrane_strains(np.asarray(eps_m, dtype=float))
    return np.where(e2 + nu * e1 > 0, 2, np.where(e1 > 0, 1, 0))


def relaxed_section(eps: np.ndarray, section: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stress resultants (..., 8) and point tangent (..., 8, 8) of Cartesian strains (..., 8) with the
    tension-field membrane law (:func:`tension_field_membrane`) and linear bending and transverse shear.

    section : (8, 8) with an isotropic membrane block and no coupling between the membrane and the other
        blocks (``ShellMaterial.section()``)
    """
    eps = np.asarray(eps, dtype=float)
    N, C_m = tension_field_membrane(eps[..., MEMBRANE], section[MEMBRANE, MEMBRANE])
    sigma = eps @ section.T
    sigma[..., MEMBRANE] = N
    C_t = np.broadcast_to(section, eps.shape[:-1] + (8, 8)).copy()
    C_t[..., MEMBRANE, MEMBRANE] = C_m
    return sigma, C_t


def section_stresses(eps: np.ndarray, section: np.ndarray, wrinkling: bool = False) -> np.ndarray:
    """Stress resultants (..., 8) of Cartesian strains (..., 8): the linear law eps @ C^T (paper Eq. 14), or
    with ``wrinkling`` the tension-field membrane (:func:`relaxed_section`)."""
    if not wrinkling:
        return eps @ section.T
    return relaxed_section(eps, section)[0]


def section_increments(eps: np.ndarray, deps: np.ndarray, section: np.ndarray, wrinkling: bool = False
                       ) -> np.ndarray:
    """The stress increments (..., 8) of strain increments deps (..., 8) linearized at the strains eps: C deps,
    or with ``wrinkling`` C_t(eps) deps (the tangent of :func:`relaxed_section`)."""
    if not wrinkling:
        return deps @ section.T
    return np.einsum("...ij,...j->...i", relaxed_section(eps, section)[1], deps)
