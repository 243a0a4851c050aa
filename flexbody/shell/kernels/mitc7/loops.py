"""The loop of the MITC7 kernels over a chunk of elements and its Python entry point,
:func:`condensed_force_tangent_batch` (the condensed force, tangent and bubble amplitudes of a batch).

Per element: the nodal relative rotations (:func:`flexbody.shell.kernels.mitc7.points.node_setup`), Newton
on the bubble (:func:`flexbody.shell.kernels.mitc7.condensation.solve_bubble`, which evaluates only the
bubble's force and 2 x 2 block), then the augmented force and, if wanted, tangent at the final b, by the same
code in both cases (:func:`flexbody.shell.kernels.mitc7.augmented.evaluate_z`), and the static condensation
(:func:`flexbody.shell.kernels.mitc7.condensation.condense_into`). An element whose bubble does not converge
gets a NaN force (and tangent) and its warm start as b (:mod:`flexbody.shell.kernels.mitc7.condensation`).
"""

from __future__ import annotations

import numpy as np

from flexbody import _numba
from flexbody.chunks import n_chunks, run_chunks
from flexbody.shell.bubble_newton import BUBBLE_MAX_ITERATIONS, BUBBLE_TOL
from flexbody.shell.kernels.loops import _element_arrays
from flexbody.shell.geometry import N_GAUSS
from flexbody.shell.kernels.mitc7.augmented import evaluate_z, workspace, zspace
from flexbody.shell.kernels.mitc7.condensation import condense_into, solve_bubble
from flexbody.shell.kernels.mitc7.maps import MapNonzeros, as_map_nonzeros
from flexbody.shell.kernels.mitc7.points import (EDN_TABLE, EDNB_TABLE, EN_TABLE, ENB_TABLE, NAUG, NDOF,
                                                 node_setup)


# ``released`` (numba's defaults, without the GIL), not ``entry`` as the MITC6 loops: the chunk allocates its
# workspaces and calls the bubble's Newton, compiled with numba's defaults.
@_numba.released
def _chunk(e0, e1, x_el, fr_el, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
           EN, EDN, ENB, EDNB, b0, want_tangent, c_sym, tol, max_iter, f, K, b_out):
    """Elements e0..e1-1 of the batch (see :func:`condensed_force_tangent_batch`)."""
    ws = workspace()
    zs = zspace()
    x = np.empty((6, 3))
    fr = np.empty((6, 3, 3))
    dn = np.empty((6, 3))
    Ti = np.zeros((6, 3, 3))
    Tm = np.zeros((6, 3, 3))
    t33 = np.empty((3, 3))
    b = np.empty(2)
    fa = np.empty(NAUG)
    Ka = np.empty((NAUG, NAUG))
    Y = np.empty((2, NDOF))
    for e in range(e0, e1):
        for i in range(6):
            for k in range(3):
                x[i, k] = x_el[e, i, k]
                for l in range(3):
                    fr[i, k, l] = fr_el[e, i, k, l]
        node_setup(fr, dn, Ti, Tm, t33)
        converged = solve_bubble(e, b0, b, x, fr, dn, e_ref, to_cart, weights, C, a_ptr, a_i, a_p, a_j, a_v, used,
                                 EN, EDN, ENB, EDNB, tol, max_iter, zs, ws, fa, Ka)
        if not converged:
            for c in range(NDOF):
                f[e, c] = np.nan
            if want_tangent:
                for r in range(NDOF):
                    for c in range(NDOF):
                        K[e, r, c] = np.nan
            b_out[e, 0] = b0[e, 0]
            b_out[e, 1] = b0[e, 1]
            continue
        b_out[e, 0] = b[0]
        b_out[e, 1] = b[1]
        # the force (and tangent) at the final b; the force by the same code in both cases
        evaluate_z(e, b, want_tangent, x, fr, dn, Ti, Tm, e_ref, to_cart, weights, C, c_sym,
                   a_ptr, a_i, a_p, a_j, a_v, used, EN, EDN, ENB, EDNB, zs, ws, fa, Ka)
        if want_tangent:
            condense_into(Ka, Y, K, e)
        for c in range(NDOF):
            f[e, c] = fa[c]


def _n_chunks(m: int) -> int:
    """Chunks: a lower threshold for threads than the MITC6 loops' (an MITC7 element costs about four MITC6
    elements)."""
    return n_chunks(m, min_parallel=16)


def condensed_force_tangent_batch(x_el: np.ndarray, fr_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                                  weights: np.ndarray, C: np.ndarray, A: np.ndarray | MapNonzeros,
                                  b0: np.ndarray | None,
                                  want_tangent: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Condensed MITC7 force (m, 36), tangent (m, 36, 36) and bubble amplitudes (m, 2) of m elements.

    Element by element the result of :func:`flexbody.shell.reference.bubble.condensed_force_tangent` (force and
    tangent, per node [u, theta] in the nodal local frames) and :func:`flexbody.shell.reference.bubble.condensed_bubble`
    (b), to 1e-12 relative.

    Parameters
    ----------
    x_el : (m, 6, 3) nodal positions
    fr_el : (m, 6, 3, 3) nodal frames R_I
    e_ref : (m, 17, 8) reference covariant strains (:func:`flexbody.shell.geometry.element_geometry`)
    to_cart : (m, 7, 8, 8) covariant-to-Cartesian maps at the Gauss points
    weights : (m, 7) Gauss weights times area elements
    C : (8, 8) section stiffness
    A : (7, 8, 17, 8) assumed-strain map, ``MITC7().maps``, or its :class:`MapNonzeros`
        (``MITC7().compressed_maps``: no re-hashing)
    b0 : (m, 2) warm start of the bubble's Newton (e.g. the b returned by the last call), or None (zeros)
    want_tangent : False skips the tangent (only the bubble block K_bb is formed, for the Newton on b)

    Returns
    -------
    f : (m, 36) internal forces; NaN for an element whose bubble did not converge
        (:mod:`flexbody.shell.kernels.mitc7.condensation`)
    K : (m, 36, 36) condensed tangents (NaN where f is), or an empty (0, 36, 36) array if not want_tangent
    b : (m, 2) converged bubble amplitudes (b0 where the bubble did not converge)
    """
    b0 = np.zeros((len(x_el), 2)) if b0 is None else b0
    x_el, fr_el, e_ref, to_cart, weights, b0 = _element_arrays(x_el, fr_el, e_ref, to_cart,
                                                               weights=(weights, (N_GAUSS,)), b0=(b0, (2,)))
    m = x_el.shape[0]
    C = np.ascontiguousarray(C, dtype=np.float64)
    if C.shape != (8, 8):
        raise ValueError(f"C must be (8, 8), got {C.shape}")
    ptr, ai, ap, aj, av, used = as_map_nonzeros(A)
    f = np.empty((m, NDOF))
    K = np.empty((m, NDOF, NDOF)) if want_tangent else np.empty((0, NDOF, NDOF))
    b = np.empty((m, 2))
    if m:
        args = (x_el, fr_el, e_ref, to_cart, weights, C, ptr, ai, ap, aj, av, used,
                EN_TABLE, EDN_TABLE, ENB_TABLE, EDNB_TABLE, b0, bool(want_tangent), bool(np.array_equal(C, C.T)),
                float(BUBBLE_TOL), int(BUBBLE_MAX_ITERATIONS), f, K, b)
        run_chunks(lambda e0, e1: _chunk(e0, e1, *args), m, _n_chunks(m))
    return f, K, b
