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

from flexbody.shell.geometry import (EVAL_DN, EVAL_N, GAUSS_OFFSET, MEMBRANE_MAPS, N_GAUSS, SHEAR_MAPS,
                                     ElementGeometry)
from flexbody.shell.kinematics import (NDOF, covariant_strains, measures_jacobian, point_kinematics,
                                       relative_rotations, second_variation, strain_gradient, strain_hessian)
from flexbody.shell.mitc6 import DEFAULT_SCHEME, MEMBRANE_SCHEMES, N_TYING

MEMBRANE, BENDING, SHEAR = slice(0, 3), slice(3, 6), slice(6, 8)


def _scheme(tying: bool | str) -> str | None:
    """The membrane scheme of a ``tying`` argument: True -> the default, a scheme name, False -> None."""
    if isinstance(tying, str):
        if tying not in MEMBRANE_SCHEMES:
            raise ValueError(f"tying must be True, False or one of {MEMBRANE_SCHEMES}, got {tying!r}")
        return tying
    return DEFAULT_SCHEME if tying else None


def assumed_strain_maps(tying: bool | str) -> np.ndarray:
    """A (7, 8, 17, 8): covariant strains at Gauss point g = sum A[g, :, p, :] e[p] over evaluation points.

    tying : True (MITC6 with the default membrane scheme), a scheme of ``mitc6.MEMBRANE_SCHEMES``
    ("mean", "point"), or False (plain displacement-based strains).
    """
    scheme = _scheme(tying)
    n_eval = N_TYING + N_GAUSS
    A = np.zeros((N_GAUSS, 8, n_eval, 8))
    for g in range(N_GAUSS):
        gp = GAUSS_OFFSET + g
        A[g, BENDING, gp, BENDING] = np.eye(3)
        if scheme is not None:
            A[g, MEMBRANE, :, MEMBRANE] = MEMBRANE_MAPS[scheme][g]
            A[g, SHEAR, :N_TYING, SHEAR] = SHEAR_MAPS[g]
        else:
            A[g, MEMBRANE, gp, MEMBRANE] = np.eye(3)
            A[g, SHEAR, gp, SHEAR] = np.eye(2)
    return A


_MAPS = {s: assumed_strain_maps(s) for s in (False, *MEMBRANE_SCHEMES)}


def _maps(tying: bool | str) -> np.ndarray:
    scheme = _scheme(tying)
    return _MAPS[False if scheme is None else scheme]


def element_strains(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, tying: bool = True) -> np.ndarray:
    """Cartesian strains [membrane eps11, eps22, 2eps12 | bending | shear] at the 7 Gauss points, (7, 8)."""
    d_nodes = relative_rotations(frames)
    e = np.array([covariant_strains(point_kinematics(x, frames, d_nodes, N, dN).F)
                  for N, dN in zip(EVAL_N, EVAL_DN)]) - geom.e_ref
    cov = np.einsum("gipj,pj->gi", _maps(tying), e)
    return np.einsum("gij,gj->gi", geom.to_cart, cov)


def internal_force_tangent(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                           tying: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Internal force (36,) and tangent (36, 36) in the nodal local frames, per node [u, theta].

    Parameters
    ----------
    x : (6, 3) nodal positions; frames : (6, 3, 3) nodal frames R_I
    geom : reference data from :func:`flexbody.shell.geometry.element_geometry`
    section : (8, 8) Cartesian section stiffness (``ShellMaterial.section()``)
    tying : MITC6 assumed strains on (True, or a membrane scheme name, see :func:`assumed_strain_maps`)
             or plain displacement-based strains (False)
    """
    A = _maps(tying)
    d_nodes = relative_rotations(frames)
    kin, e, B = [], [], []
    for N, dN in zip(EVAL_N, EVAL_DN):
        k = point_kinematics(x, frames, d_nodes, N, dN)
        kin.append(k)
        e.append(covariant_strains(k.F))
        B.append(strain_gradient(k.F) @ measures_jacobian(k))   # covariant B (paper Eq. 19-21)
    e = np.array(e) - geom.e_ref
    B = np.array(B)                                             # (17, 8, 36)

    force = np.zeros(NDOF)
    K = np.zeros((NDOF, NDOF))
    s_points = np.zeros_like(e)                                 # covariant stress weights per point
    for g in range(N_GAUSS):
        to_cart = geom.to_cart[g] @ A[g].reshape(8, -1)          # (8, 17*8): point strains -> Cartesian
        eps = to_cart @ e.ravel()
        B_g = to_cart @ B.reshape(-1, NDOF)
        sigma = section @ eps                                   # [N, M, Q] stress resultants
        w = geom.weights[g]
        force += w * B_g.T @ sigma
        K += w * B_g.T @ section @ B_g                          # material stiffness (paper Eq. 23)
        s_points += w * (to_cart.T @ sigma).reshape(e.shape)
    for k, s in zip(kin, s_points):                             # geometric stiffness (paper Eq. 24)
        if not np.any(s):
            continue
        D = strain_gradient(k.F)
        G = measures_jacobian(k)
        K += G.T @ strain_hessian(s) @ G + second_variation(k, D.T @ s)
    return force, K


def strain_energy(x: np.ndarray, frames: np.ndarray, geom: ElementGeometry, section: np.ndarray,
                  tying: bool = True) -> float:
    """Elastic energy of the element, 1/2 sum_g w_g eps_g^T C eps_g."""
    eps = element_strains(x, frames, geom, tying)
    return 0.5 * float(np.einsum("g,gi,ij,gj->", geom.weights, eps, section, eps))
