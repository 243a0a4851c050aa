"""The readable element: internal force, consistent tangent, strains and energy of the six-node SE(3) shell
(readable numpy twin of :mod:`flexbody.shell.kernels.loops`, to be read next to the paper).

Internal virtual work (paper Eqs. 14, 18):   delta W = sum_g w_g (B_g delta h)^T C eps_g
Tangent (paper Eqs. 22-24):                  K = sum_g w_g B_g^T C B_g  +  sum_p [G^T Hf(s_p) G + H(D^T s_p)]_p

where eps_g are the Cartesian strains at Gauss point g, assembled from covariant strains at the evaluation
points (MITC6 tying for membrane and transverse shear, direct for bending; :mod:`.material`), and s_p are the
stress resultants pulled back to the covariant strains at evaluation point p (:mod:`.geometric`). The stages:
:mod:`.points` (strain measures), :mod:`.expansion` (B), :mod:`.material` (assumed strains, stresses),
:mod:`.geometric` (second variation), :mod:`.congruence` (the local nodal motions). The fast kernels
(:mod:`flexbody.shell.kernels`) must agree with these functions (tests/shell/test_element.py).
"""

from __future__ import annotations

import numpy as np

from flexbody.shell.geometry import EVAL_DN, EVAL_DNB, EVAL_N, EVAL_NB, N_GAUSS, ElementGeometry
from flexbody.shell.reference.expansion import covariant_B, gauss_B, gauss_force, linearized_gauss_strains
from flexbody.shell.reference.geometric import point_geometric_stiffness
from flexbody.shell.reference.material import (cartesian_strains, gauss_strain_map, gauss_strain_maps,
                                               mapped_strains, material_stiffness, pulled_back_stress,
                                               relaxed_section, section_stresses, stress_resultants)
from flexbody.shell.reference.points import (PointKinematics, covariant_strains,
                                             evaluation_point_kinematics)


def _bubble_at_points(bubble: np.ndarray | None) -> tuple | None:
    """The MITC7 rotation bubble b (2,) with its shape function at the evaluation points, or None."""
    return None if bubble is None else (EVAL_NB, EVAL_DNB, bubble)


def point_strains(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, bubble: np.ndarray | None = None
                  ) -> tuple[list[PointKinematics], np.ndarray, np.ndarray]:
    """Kinematics, covariant strains e (17, 8) (reference values subtracted, paper Eq. 8) and covariant B
    (17, 8, ndof) at the evaluation points (paper Eqs. 9, 12, 19-21)."""
    kin = evaluation_point_kinematics(x, frames, EVAL_N, EVAL_DN, _bubble_at_points(bubble))
    e = [covariant_strains(k.F) for k in kin]
    B = [covariant_B(k) for k in kin]
    return kin, np.array(e) - geom.e_ref, np.array(B)


def element_strains(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, A: np.ndarray,
                    bubble: np.ndarray | None = None) -> np.ndarray:
    """Cartesian strains [membrane eps11, eps22, 2eps12 | bending | shear] at the 7 Gauss points, (7, 8).

    A : the assumed-strain map (:func:`flexbody.shell.reference.material.assumed_strain_maps`,
        ``ElementVariant.maps``)
    bubble : the rotation bubble b (2,) of MITC7 (:func:`flexbody.shell.reference.bubble.condensed_bubble`),
        or None
    """
    kin = evaluation_point_kinematics(x, frames, EVAL_N, EVAL_DN, _bubble_at_points(bubble))
    e = np.array([covariant_strains(k.F) for k in kin]) - geom.e_ref
    return cartesian_strains(geom.to_cart, A, e)


def internal_force_tangent(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                           A: np.ndarray, wrinkling: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Internal force (36,) and tangent (36, 36) in the nodal local frames, per node [u, theta], of an element
    without a bubble (the MITC6 variants; MITC7's is
    :func:`flexbody.shell.reference.bubble.condensed_force_tangent`; ``ElementVariant.element_force_tangent``
    takes either).

    Parameters
    ----------
    x : (6, 3) nodal positions; frames : (6, 3, 3) nodal frames R_I
    geom : reference data from :func:`flexbody.shell.geometry.element_geometry`
    section : (8, 8) Cartesian section stiffness (``ShellMaterial.section()``)
    A : the assumed-strain map (:func:`flexbody.shell.reference.material.assumed_strain_maps`)
    wrinkling : the tension-field membrane law (:func:`flexbody.shell.reference.material.relaxed_section`)
        instead of the linear one
    """
    return force_tangent(x, frames, geom, section, A, wrinkling=wrinkling)


def linearized_strains(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, dh: np.ndarray,
                       A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cartesian strains eps_g (7, 8) at the Gauss points and their linearization B_g dh along the local
    nodal motion dh (36,), per node [du, dtheta]: the strains of the mixed Newton iteration,
    eps_g + B_g dh, for the assumed-strain map A of an element without a bubble (the MITC6 variants; not
    MITC7, whose bubble is condensed). dh (36, k): B_g dh is (7, 8, k)."""
    _, e, B = point_strains(x, frames, geom, None)
    maps = gauss_strain_maps(geom.to_cart, A)
    return mapped_strains(maps, e), linearized_gauss_strains(maps, B, dh)


def force_tangent(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                  A: np.ndarray, bubble: np.ndarray | None = None,
                  stress: np.ndarray | None = None, wrinkling: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Force and tangent for the assumed-strain map A (paper Eqs. 18, 22-24).

    A : (7, 8, 17, 8) (:func:`flexbody.shell.reference.material.assumed_strain_maps`, ``ElementVariant.maps``)
    bubble : None, or the rotation bubble's amplitudes b (2,) (:mod:`flexbody.shell.reference.bubble`); the
        force and tangent then have 38 components, the last two for b.
    stress : None, or Cartesian stress resultants (7, 8) at the Gauss points that the geometric terms of
        the tangent carry instead of section @ eps_g: the iteration matrix of the mixed Newton iteration
        (stresses at the Gauss points iterated as unknowns of their own, condensed point by point:
        K = sum_g w_g B_g^T C B_g + G(stress); Magisano, Leonetti & Garcea 2017). The force is always the
        one of the strains; with a stress the result is (force, K, f_stress), f_stress = sum_g w_g B_g^T
        stress_g the force of the given stresses.
    wrinkling : the tension-field membrane law at each Gauss point
        (:func:`flexbody.shell.reference.material.relaxed_section`): its stresses and its point tangent C_t(eps_g)
        take the place of C eps_g and C (the material stiffness w_g B_g^T C_t B_g). The law is not linear, so
        the mixed iteration's stresses (``stress``) do not belong with it; the body does not offer them.
    """
    kin, e, B = point_strains(x, frames, geom, bubble)
    ndof = B.shape[2]
    f_stress = np.zeros(ndof)

    force = np.zeros(ndof)
    K = np.zeros((ndof, ndof))
    s_points = np.zeros_like(e)                                 # covariant stress weights per point
    for g in range(N_GAUSS):
        to_cart = gauss_strain_map(geom.to_cart[g], A[g])       # (8, 17*8): point strains -> Cartesian
        eps = to_cart @ e.ravel()
        B_g = gauss_B(to_cart, B)
        if wrinkling:
            sigma, C_g = relaxed_section(eps, section)          # tension-field membrane, point tangent
        else:
            sigma, C_g = stress_resultants(section, eps), section   # [N, M, Q] stress resultants
        w = geom.weights[g]
        force += gauss_force(B_g, sigma, w)
        K += material_stiffness(B_g, C_g, w)                    # material stiffness (paper Eq. 23)
        carried = sigma if stress is None else stress[g]
        s_points += pulled_back_stress(to_cart, carried, w, e.shape)
        f_stress += gauss_force(B_g, carried, w)
    for k, s in zip(kin, s_points):                             # geometric stiffness (paper Eq. 24)
        if not np.any(s):
            continue
        K += point_geometric_stiffness(k, s)
    return (force, K) if stress is None else (force, K, f_stress)


def strain_energy(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                  A: np.ndarray, bubble: np.ndarray | None = None, wrinkling: bool = False) -> float:
    """Elastic energy of the element, 1/2 sum_g w_g eps_g^T C eps_g (MITC7: pass the condensed bubble).

    With ``wrinkling`` the relaxed energy 1/2 sum_g w_g eps_g^T sigma(eps_g) of the tension-field membrane (its
    stresses are homogeneous of degree one in the strains, so this is the energy whose gradient they are)."""
    eps = element_strains(x, frames, geom, A, bubble)
    if wrinkling:
        return 0.5 * float(np.einsum("g,gi,gi->", geom.weights, eps, section_stresses(eps, section, True)))
    return 0.5 * float(np.einsum("g,gi,ij,gj->", geom.weights, eps, section, eps))
