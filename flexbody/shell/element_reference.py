"""The readable element: internal force and consistent tangent of the six-node SE(3) shell.

Numpy reference implementation, to be read next to the paper. The fast kernel in ``element.py`` must
agree with it (tests/shell/test_element.py).

Internal virtual work (paper Eq. 14, 18):   delta W = sum_g w_g (B_g delta h)^T C (eps_g)
Tangent (paper Eq. 22-24):                  K = sum_g w_g B_g^T C B_g  +  sum_p [G^T Hf(s_p) G + H(D^T s_p)]_p
where eps_g are the Cartesian strains at Gauss point g, assembled from covariant strains at the evaluation
points (MITC6 tying for membrane and transverse shear, direct for bending), and s_p are the stress resultants
pulled back to the covariant strains at evaluation point p.
"""

from __future__ import annotations

import numpy as np

from flexbody.shell.geometry import (EVAL_DN, EVAL_N, EVAL_POINTS, GAUSS_OFFSET, MEMBRANE_MAPS,
                                     MITC7_SHEAR_MAPS, N_GAUSS, SHEAR_MAPS, ElementGeometry)
from flexbody.shell.kinematics import (covariant_strains, measures_jacobian, point_kinematics,
                                       relative_rotations, second_variation, strain_gradient, strain_hessian)
from flexbody.shell.mitc6 import DEFAULT_SCHEME, MEMBRANE_SCHEMES, N_TYING
from flexbody.shell.shape import bubble_derivatives, bubble_function

MEMBRANE, BENDING, SHEAR = slice(0, 3), slice(3, 6), slice(6, 8)
#: The rotation bubble N_b = 27 r s t and its derivatives at the evaluation points (MITC7).
EVAL_NB = np.array([bubble_function(r, s) for r, s in EVAL_POINTS])
EVAL_DNB = np.array([bubble_derivatives(r, s) for r, s in EVAL_POINTS])


#: Transverse shear tying schemes: MITC6a's edge stations (MITC6) and MITC7's canonical degrees of freedom.
SHEAR_SCHEMES = ("mitc6", "mitc7")


def assumed_strain_maps(membrane: str | None = DEFAULT_SCHEME, shear: str | None = "mitc6") -> np.ndarray:
    """A (7, 8, 17, 8): covariant strains at Gauss point g = sum A[g, :, p, :] e[p] over evaluation points.

    membrane : a membrane tying scheme of ``mitc6.MEMBRANE_SCHEMES`` ("mean", "point"), or None (the strains
        of the Gauss point itself, displacement-based)
    shear : "mitc6" (MITC6a), "mitc7" (the canonical tying of MITC7, :mod:`flexbody.shell.bubble`) or None
        (displacement-based). Bending is always displacement-based.

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


def element_strains(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, A: np.ndarray,
                    bubble: np.ndarray | None = None) -> np.ndarray:
    """Cartesian strains [membrane eps11, eps22, 2eps12 | bending | shear] at the 7 Gauss points, (7, 8).

    A : the assumed-strain map (:func:`assumed_strain_maps`, ``ElementVariant.maps``)
    bubble : the rotation bubble b (2,) of MITC7 (:func:`flexbody.shell.bubble.condensed_bubble`), or None
    """
    d_nodes = relative_rotations(frames)
    e = np.array([covariant_strains(point_kinematics(
        x, frames, d_nodes, N, dN, None if bubble is None else (EVAL_NB[p], EVAL_DNB[p], bubble)).F)
        for p, (N, dN) in enumerate(zip(EVAL_N, EVAL_DN))]) - geom.e_ref
    cov = np.einsum("gipj,pj->gi", A, e)
    return np.einsum("gij,gj->gi", geom.to_cart, cov)


def internal_force_tangent(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                           A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Internal force (36,) and tangent (36, 36) in the nodal local frames, per node [u, theta], of an element
    without a bubble (the MITC6 variants; MITC7's is :func:`flexbody.shell.bubble.condensed_force_tangent`;
    ``ElementVariant.element_force_tangent`` takes either).

    Parameters
    ----------
    x : (6, 3) nodal positions; frames : (6, 3, 3) nodal frames R_I
    geom : reference data from :func:`flexbody.shell.geometry.element_geometry`
    section : (8, 8) Cartesian section stiffness (``ShellMaterial.section()``)
    A : the assumed-strain map (:func:`assumed_strain_maps`, ``ElementVariant.maps``)
    """
    return force_tangent(x, frames, geom, section, A)


def _point_strains(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, bubble: np.ndarray | None):
    """Kinematics, covariant strains e (17, 8) and covariant B (17, 8, ndof) at the evaluation points."""
    d_nodes = relative_rotations(frames)
    kin, e, B = [], [], []
    for p, (N, dN) in enumerate(zip(EVAL_N, EVAL_DN)):
        extra = None if bubble is None else (EVAL_NB[p], EVAL_DNB[p], bubble)
        k = point_kinematics(x, frames, d_nodes, N, dN, extra)
        kin.append(k)
        e.append(covariant_strains(k.F))
        B.append(strain_gradient(k.F) @ measures_jacobian(k))   # covariant B (paper Eq. 19-21)
    return kin, np.array(e) - geom.e_ref, np.array(B)


def linearized_strains(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, dh: np.ndarray,
                       A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cartesian strains eps_g (7, 8) at the Gauss points and their linearization B_g dh along the local
    nodal motion dh (36,), per node [du, dtheta]: the strains of the mixed Newton iteration,
    eps_g + B_g dh, for the assumed-strain map A of an element without a bubble (the MITC6 variants; not
    MITC7, whose bubble is condensed). dh (36, k): B_g dh is (7, 8, k)."""
    _, e, B = _point_strains(x, frames, geom, None)
    to_cart = np.einsum("gij,gjpk->gipk", geom.to_cart, A)
    return np.einsum("gipk,pk->gi", to_cart, e), np.einsum("gipk,pkn,n...->gi...", to_cart, B, dh)


def force_tangent(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                  A: np.ndarray, bubble: np.ndarray | None = None,
                  stress: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Force and tangent for the assumed-strain map A (:func:`assumed_strain_maps`, ``ElementVariant.maps``).

    bubble : None, or the rotation bubble's amplitudes b (2,) (:mod:`flexbody.shell.bubble`); the force and
        tangent then have 38 components, the last two for b.
    stress : None, or Cartesian stress resultants (7, 8) at the Gauss points that the geometric terms of
        the tangent carry instead of section @ eps_g: the iteration matrix of the mixed Newton iteration
        (stresses at the Gauss points iterated as unknowns of their own, condensed point by point:
        K = sum_g w_g B_g^T C B_g + G(stress); Magisano, Leonetti & Garcea 2017). The force is always the
        one of the strains; with a stress the result is (force, K, f_stress), f_stress = sum_g w_g B_g^T
        stress_g the force of the given stresses.
    """
    kin, e, B = _point_strains(x, frames, geom, bubble)
    ndof = B.shape[2]
    f_stress = np.zeros(ndof)

    force = np.zeros(ndof)
    K = np.zeros((ndof, ndof))
    s_points = np.zeros_like(e)                                 # covariant stress weights per point
    for g in range(N_GAUSS):
        to_cart = geom.to_cart[g] @ A[g].reshape(8, -1)          # (8, 17*8): point strains -> Cartesian
        eps = to_cart @ e.ravel()
        B_g = to_cart @ B.reshape(-1, ndof)
        sigma = section @ eps                                   # [N, M, Q] stress resultants
        w = geom.weights[g]
        force += w * B_g.T @ sigma
        K += w * B_g.T @ section @ B_g                          # material stiffness (paper Eq. 23)
        carried = sigma if stress is None else stress[g]
        s_points += w * (to_cart.T @ carried).reshape(e.shape)
        f_stress += w * B_g.T @ carried
    for k, s in zip(kin, s_points):                             # geometric stiffness (paper Eq. 24)
        if not np.any(s):
            continue
        D = strain_gradient(k.F)
        G = measures_jacobian(k)
        K += G.T @ strain_hessian(s) @ G + second_variation(k, D.T @ s)
    return (force, K) if stress is None else (force, K, f_stress)


def strain_energy(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                  A: np.ndarray, bubble: np.ndarray | None = None) -> float:
    """Elastic energy of the element, 1/2 sum_g w_g eps_g^T C eps_g (MITC7: pass the condensed bubble)."""
    eps = element_strains(x, frames, geom, A, bubble)
    return 0.5 * float(np.einsum("g,gi,ij,gj->", geom.weights, eps, section, eps))
