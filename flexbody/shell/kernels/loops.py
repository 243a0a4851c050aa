"""The element loops of the six-node shell kernel and its batch entry points (stage ``loops``).

Computes, for a batch of elements, exactly what :func:`flexbody.shell.reference.loops.internal_force_tangent`
computes (the same strains and the same terms of the second variation), arranged so that nothing is a dense
(8 x 136) or (12 x 36) product at a point:

1. **Relative coordinates.** Per element the 36 local nodal motions h = [u_I, theta_I] are mapped to
   z = [dx_I, dtheta_0, dd_1..dd_5], dx_I = R_I du_I (global translations) and the variations of the relative
   rotation vectors dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0 (paper Eq. 31): z = P h. In z every point
   quantity is a *scalar* (shape function) combination of a few 3x3 blocks (layout:
   :mod:`flexbody.shell.kernels.layout`).
2. **Point slots.** At an evaluation point the strain measures depend on z only through 18 numbers
   xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi z (Pi holds N_I, dN_I). The Jacobian G (12 x 18), the B
   rows and the contracted second variation (18 x 18) are formed in xi from closed-form 3x3 blocks
   (:mod:`~flexbody.shell.kernels.points`, :mod:`~flexbody.shell.kernels.geometric`) and expanded once per
   point into z in two sparse stages (:mod:`~flexbody.shell.kernels.expansion`).
3. **Node terms** (:mod:`~flexbody.shell.kernels.congruence`). K_h = P^T K_z P + (D P^T[.]) f_z.

The assumed-strain map is compressed once in Python (:class:`flexbody.shell.maps.CompressedMaps`); the
material terms are in :mod:`~flexbody.shell.kernels.material`.

The mixed Newton iteration (docs/theory.md) needs two more things, both here: the tangent whose geometric
terms carry given Gauss-point stresses (``stress=`` of :func:`internal_force_tangent_batch`: the point
weights Ps and the node terms are those of the given stresses, the force stays that of the strains), and the
strains linearized along a nodal motion, B dh (:func:`linearized_strains_batch`, from the point kinematics).

Performance notes: the small helpers are inlined at numba-IR level so that the per-point functions contain no
calls; the kernels are compiled without reference counting and with noalias array arguments (see
flexbody._numba), so that point data are read through views of the per-point arrays at no cost; the element
loop runs inside one function per chunk of elements (flexbody.chunks: one chunk on one thread, a few per
thread otherwise), whose workspaces are allocated once per chunk, and prefetches the next element's data.
Nothing is allocated per element or point. The section stiffness must be symmetric.

The residual-only path (``want_tangent`` False) computes f_aw and X_a only at the points whose bending strains
the assumed strains read (:func:`~flexbody.shell.kernels.points._kinematics_points`: the Gauss points of MITC6,
not the tying points), and the sparse map is read with unsigned indices, its pull-back scattered by rows
(:mod:`~flexbody.shell.kernels.material`). Measured on the 4 x 32 hub annulus (256 elements,
``benchmarks/residual_kernel.py``, 2026-12-03): about 3.7 us per element. The element data stream in behind the
prefetch hints: after a cache-evicting 4 MB read a call costs about 3 % more, all of it the call's fixed working
set (code, maps, workspaces: a one-element call before it recovers the 3 %, warming the element arrays does not);
after a 4 MB write about 15 % more at the median (the write-backs drain during the call), whatever is warmed.
"""

from __future__ import annotations

import numpy as np

from flexbody import _numba
from flexbody.chunks import n_chunks as _n_chunks
from flexbody.chunks import Workspaces, run_chunks
from flexbody.kernel_arrays import kernel_input as _as
from flexbody.shell.geometry import N_GAUSS
from flexbody.shell.kernels.congruence import _cross_terms, _finish_tangent, _force_to_local, _has_cross_coupling
from flexbody.shell.kernels.geometric import _points_tangent
from flexbody.shell.kernels.layout import NDOF, NZ, N_EVAL
from flexbody.shell.kernels.material import (_gauss_strains, _given_stress_weights, _nonlocal_material,
                                             _relaxed_stress_weights, _section_cov, _stress_weights)
from flexbody.shell.kernels.points import (_force_points, _interpolate_points, _kinematics_points, _load_element,
                                           _node_setup, _point_coefficients, _strain_increments_points,
                                           _strains_points)
from flexbody.shell.kernels.primitives import _prefetch_element
from flexbody.shell.maps import CompressedMaps, SectionStiffness, checked_section, compress_maps


_AHEAD = 2   # elements prefetched ahead (a few microseconds each)


@_numba.entry
def _chunk(e0, e1, x_el, fr_el, e_ref, to_cart, weights, C, cblk,
           used, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v,
           pt_gauss, loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
           par_p, par_ptr, par_j, par_v, pl_ptr, pl_k, pl_v, w2, has_w, n_rf,
           nl_rows, n_nl, m_ptr, m_i, m_k, m_v, m_dense,
           want_tangent, use_stress, stress, f, fg, K,
           x, fr, dn, Ti, ninv, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, Ps,
           F, Q, T, R, X0, X1, d, da, co, s, g, G2, phi, fz,
           cov, st, Ch, CT, v16, core, Y, Yt, Kz, Kiso, K1, T0, Dl, Bl, CBl, Sp, Wp, Cp, Yp,
           t0, t1, t2, t3, t4, t5, Ct):
    """Internal forces f[e] (and tangents K[e]) of the elements e0 <= e < e1.

    With a scratch Ct (8, 8) the membrane follows the tension-field law (:func:`_relaxed_stress_weights`: its
    stresses and point tangents C_t(eps_g) in Ps and Ch); with Ct None the linear section C. Ct None is typed
    ``none``: numba prunes the branch ``Ct is not None`` before typing, so the specialisation without the law
    neither types nor lowers it (a run-time bool compiled the law into every scene's first run).

    With use_stress the geometric terms of the tangent carry the given stress resultants stress[e] instead
    of those of the strains (the mixed Newton iteration), and fg[e] receives the force of these stresses;
    f[e] is always the force of the strains.

    The arguments are flat on purpose: grouped into named tuples (inputs, section, maps, outputs, workspace)
    they keep their noalias attributes and give the same bits, but numba's dispatcher types a tuple's
    arrays one by one in Python, about 10 us more per call (measured: 48 instead of 37 us for a 4-element
    residual), a third of a small batch's residual.
    """
    for e in range(e0, e1):
        if e + _AHEAD < e1:
            _prefetch_element(e + _AHEAD, x_el, fr_el, e_ref, to_cart, weights, want_tangent, K)
        _load_element(e, x_el, fr_el, x, fr)
        _node_setup(fr, dn, Ti, ninv, t0)
        _interpolate_points(used, dn, Pd, Pda)
        _point_coefficients(used, Pd, Pco)
        _kinematics_points(used, at_ptr, want_tangent, x, fr, Pd, Pda, Pco, PQ, PT, PR, PF, PX)
        _strains_points(e, used, e_ref, PF, Pe)
        if Ct is not None:
            _relaxed_stress_weights(e, used, to_cart, weights, C, want_tangent, a_ptr, a_p, a_j, a_v, Pe, cov, st,
                                    v16, Ct, CT, Ch, Ps)
        else:
            if want_tangent:
                _section_cov(e, to_cart, weights, C, cblk, CT, Ch)
            _stress_weights(e, used, to_cart, weights, C, Ch, want_tangent, a_ptr, a_p, a_j, a_v, Pe, cov, st, v16,
                            Ps)
        _force_points(used, PF, PQ, PT, PR, PX, Ps, g, G2, phi, fz)
        _force_to_local(e, fz, fr, Ti, f)
        fv = f
        if use_stress:
            _given_stress_weights(e, used, to_cart, weights, stress, a_ptr, a_p, a_j, a_v, st, Ps)
            _force_points(used, PF, PQ, PT, PR, PX, Ps, g, G2, phi, fz)
            _force_to_local(e, fz, fr, Ti, fg)
            fv = fg
        if not want_tangent:
            continue
        _points_tangent(used, pt_gauss, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, Ch,
                        loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v,
                        g, core, Y, Kz, Kiso, Dl, Bl, CBl, t0, t1, t2, t3, t4, t5)
        if has_w.shape[0] > 0:
            _nonlocal_material(x, par_p, par_ptr, par_j, par_v, pl_ptr, pl_k, pl_v, w2, has_w, n_rf,
                               nl_rows, n_nl, m_ptr, m_i, m_k, m_v, m_dense,
                               PF, PQ, PT, PR, PX, Ch, G2, phi, Sp, Wp, Cp, Yp, Kz)
            if _has_cross_coupling(Ch, loc_rows, n_loc, nl_rows, n_nl):
                _cross_terms(loc_rows, n_loc, loc_ptr, loc_i, loc_j, loc_v, nl_rows, n_nl, m_ptr, m_i, m_k, m_v,
                             Ch, Sp, PF, PQ, PT, PR, PX, Pd, Pda, Pco, Ps, F, Q, T, R, X0, X1, d, da, co, s,
                             Dl, Bl, Wp, Y, Yt, K1, Kz)
        _finish_tangent(e, Kz, Kiso, fr, Ti, fv, fz, dn, ninv, K1, T0, K, t0, t1)


def _workspaces(npar: int, n_rf: int) -> tuple:
    """The scratch arrays of one :func:`_chunk` call, in the order of its trailing arguments (x ... Ct; the
    call passes None for Ct without the tension-field law), reused for every element of the chunk. ``npar``:
    nonlocal parameters (rows of the rank update), ``n_rf`` of them rotation-free."""
    npar = max(npar, 1)
    n_rows = max(4 * ((npar + 3) // 4), n_rf + 4 * ((npar - n_rf + 3) // 4))
    e = np.empty
    return (e((6, 3)), e((6, 3, 3)), e((6, 3)), e((6, 3, 3)), e((6, 2)),                  # x fr dn Ti ninv
            e((N_EVAL, 3)), e((N_EVAL, 2, 3)), e((N_EVAL, 9)), e((N_EVAL, 3, 3)),           # Pd Pda Pco PQ
            e((N_EVAL, 3, 3)), e((N_EVAL, 3, 3)), e((N_EVAL, 4, 3)), e((N_EVAL, 2, 3, 3)),  # PT PR PF PX
            e((N_EVAL, 8)), e((N_EVAL, 8)),                                                 # Pe Ps
            e((4, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)),               # F Q T R X0 X1
            e(3), e((2, 3)), e(9), e(8), e(12), e((1, 12)), e((1, 18)), e((1, NZ)),         # d da co s g G2 phi fz
            e((N_GAUSS, 8)), e((N_GAUSS, 8)), e((N_GAUSS, 8, 8)), e((8, 8)), e(16),         # cov st Ch CT v16
            e((18, 18)), e((18, NZ)), e((NZ, 18)), e((NZ, NZ)), e((6, 8)), e((NZ, NZ)),     # core Y Yt Kz Kiso K1
            e((3, NDOF)), e((8, 12)), e((8, 18)), e((8, 18)),                               # T0 Dl Bl CBl
            e((n_rows, NZ)), e((max(n_rows, 8), NZ)), e((npar, npar)), e((8, npar)),        # Sp Wp Cp Yp
            e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)), e((3, 3)),               # t0 .. t5
            e((8, 8)))                                                                      # Ct


@_numba.entry
def _chunk_strains(e0, e1, x_el, fr_el, e_ref, to_cart, used, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, out,
                   with_increment, dh, deps, x, fr, dn, Ti, ninv, Pd, Pda, Pco, PQ, PT, PR, PF, PX, Pe, dX, dD, cov,
                   t0):
    """Gauss-point strains out[e] and, with_increment, their linearization deps[e] = B dh[e]."""
    for e in range(e0, e1):
        _load_element(e, x_el, fr_el, x, fr)
        _node_setup(fr, dn, Ti, ninv, t0)
        _interpolate_points(used, dn, Pd, Pda)
        _point_coefficients(used, Pd, Pco)
        _kinematics_points(used, at_ptr, with_increment, x, fr, Pd, Pda, Pco, PQ, PT, PR, PF, PX)
        _strains_points(e, used, e_ref, PF, Pe)
        _gauss_strains(e, to_cart, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, Pe, cov, out)
        if with_increment:
            _strain_increments_points(e, used, fr, Ti, dh, PF, PQ, PT, PR, PX, dX, dD, Pe)
            _gauss_strains(e, to_cart, a_ptr, a_p, a_j, a_v, at_ptr, at_g, at_i, at_v, Pe, cov, deps)


def _strain_workspaces() -> tuple:
    """The scratch arrays of one :func:`_chunk_strains` call, in the order of its trailing arguments."""
    e = np.empty
    return (e((6, 3)), e((6, 3, 3)), e((6, 3)), e((6, 3, 3)), e((6, 2)),                  # x fr dn Ti ninv
            e((N_EVAL, 3)), e((N_EVAL, 2, 3)), e((N_EVAL, 9)), e((N_EVAL, 3, 3)),           # Pd Pda Pco PQ
            e((N_EVAL, 3, 3)), e((N_EVAL, 3, 3)), e((N_EVAL, 4, 3)), e((N_EVAL, 2, 3, 3)),  # PT PR PF PX
            e((N_EVAL, 8)), e((10, 3)), e((6, 3)), e((N_GAUSS, 8)), e((3, 3)))              # Pe dX dD cov t0


def _element_arrays(x_el, frames_el, e_ref, to_cart, **more):
    """The kernels' per-element inputs as contiguous float64 arrays, their shapes and common length checked.

    more : name=(array, shape_tail) for further per-element arrays (weights, dh_el, b0, ...), in that order.
    """
    arrays = [_as(x_el, (6, 3), "x_el"), _as(frames_el, (6, 3, 3), "frames_el"), _as(e_ref, (N_EVAL, 8), "e_ref"),
              _as(to_cart, (N_GAUSS, 8, 8), "to_cart")] + [_as(a, tail, name) for name, (a, tail) in more.items()]
    if any(len(a) != len(arrays[0]) for a in arrays):
        raise ValueError("all element arrays must have the same number of elements")
    return arrays


def internal_force_tangent_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray,
                                 to_cart: np.ndarray, weights: np.ndarray, section: np.ndarray | SectionStiffness,
                                 A: np.ndarray | CompressedMaps, want_tangent: bool = True,
                                 stress: np.ndarray | None = None, workspaces: Workspaces | None = None,
                                 wrinkling: bool = False):
    """Internal forces (m, 36) and tangents (m, 36, 36) of m elements, per node [u, theta], local frames.

    Same result as :func:`flexbody.shell.reference.loops.internal_force_tangent` element by element.

    Parameters
    ----------
    x_el : (m, 6, 3) nodal positions;  frames_el : (m, 6, 3, 3) nodal frames
    e_ref : (m, 17, 8), to_cart : (m, 7, 8, 8), weights : (m, 7)  reference data (geometry.element_geometry)
    section : (8, 8) symmetric section stiffness, or its :class:`flexbody.shell.maps.SectionStiffness` (checked
        once by its owner: :func:`flexbody.shell.maps.checked_section`; an array is checked at every call)
    A : (7, 8, 17, 8) assumed-strain map (``ElementVariant.maps``), or its :class:`CompressedMaps`
        (``ElementVariant.compressed_maps``, built once; an array is compressed at every call)
    want_tangent : False takes the residual-only path (no tangent, no second variation); K is then None.
    stress : optional (m, 7, 8) Cartesian stress resultants at the Gauss points for the geometric terms of
        the tangent (the mixed Newton iteration, :func:`flexbody.shell.reference.loops.force_tangent`);
        the force is always that of the strains. With a stress the result is (f, K, f_stress), f_stress
        (m, 36) the force of the given stresses (K None without want_tangent).
    workspaces : the kernels' per-thread scratch arrays, reused across calls (``ElementVariant.workspaces``);
        None: made for this call
    wrinkling : the tension-field membrane law (``ShellMaterial.wrinkling``,
        :func:`flexbody.shell.reference.material.relaxed_section`; the section's membrane block isotropic and
        not coupled to the others) instead of the linear section
    """
    x_el, frames_el, e_ref, to_cart, weights = _element_arrays(x_el, frames_el, e_ref, to_cart,
                                                               weights=(weights, (N_GAUSS,)))
    m = x_el.shape[0]
    C, cblk = checked_section(section)
    use_stress = stress is not None
    stress = _as(stress, (N_GAUSS, 8), "stress") if use_stress else np.zeros((1, N_GAUSS, 8))
    if use_stress and len(stress) != m:
        raise ValueError(f"stress must have one row per element ({m}), got {len(stress)}")
    maps = compress_maps(A)
    f = np.empty((m, NDOF))
    fs = np.empty((m, NDOF)) if use_stress else np.empty((1, NDOF))
    K = np.empty((m, NDOF, NDOF)) if want_tangent else np.empty((1, NDOF, NDOF))
    if m:
        args = (x_el, frames_el, e_ref, to_cart, weights, C, cblk, *maps.kernel_args(),
                bool(want_tangent), use_stress, stress, f, fs, K)
        key, npar, n_rf = ("mitc6", maps.npar, maps.n_rf), maps.npar, maps.n_rf
        ws = workspaces if workspaces is not None else Workspaces()
        law = bool(wrinkling)

        def chunk(e0: int, e1: int) -> None:
            scratch = ws.get(key, lambda: _workspaces(npar, n_rf))
            _chunk(e0, e1, *args, *scratch[:-1], scratch[-1] if law else None)

        run_chunks(chunk, m, _n_chunks(m))
    if use_stress:
        return f, (K if want_tangent else None), fs
    return f, (K if want_tangent else None)


def element_strains_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                          A: np.ndarray | CompressedMaps, workspaces: Workspaces | None = None) -> np.ndarray:
    """Cartesian strains [membrane | bending | shear] at the 7 Gauss points of m elements, (m, 7, 8).

    Same result as :func:`flexbody.shell.reference.loops.element_strains` element by element (``workspaces``:
    as in :func:`internal_force_tangent_batch`).
    """
    x_el, frames_el, e_ref, to_cart = _element_arrays(x_el, frames_el, e_ref, to_cart)
    m = x_el.shape[0]
    maps = compress_maps(A)
    out = np.empty((m, N_GAUSS, 8))
    if m:
        ws = workspaces if workspaces is not None else Workspaces()
        args = (x_el, frames_el, e_ref, to_cart, *maps.nonzeros(), out, False, np.zeros((1, NDOF)),
                np.zeros((1, N_GAUSS, 8)))
        run_chunks(lambda e0, e1: _chunk_strains(e0, e1, *args, *ws.get(("strains",), _strain_workspaces)), m,
                   _n_chunks(m))
    return out


def linearized_strains_batch(x_el: np.ndarray, frames_el: np.ndarray, e_ref: np.ndarray, to_cart: np.ndarray,
                             A: np.ndarray | CompressedMaps, dh_el: np.ndarray,
                             workspaces: Workspaces | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Cartesian Gauss-point strains eps (m, 7, 8) of m elements and their linearization B dh along the local
    nodal motions dh_el (m, 36), per node [du, dtheta] (the strain increment of the mixed Newton iteration).

    Same result as :func:`flexbody.shell.reference.loops.linearized_strains` element by element (``workspaces``:
    as in :func:`internal_force_tangent_batch`).
    """
    x_el, frames_el, e_ref, to_cart, dh_el = _element_arrays(x_el, frames_el, e_ref, to_cart,
                                                             dh_el=(dh_el, (NDOF,)))
    m = x_el.shape[0]
    maps = compress_maps(A)
    eps = np.empty((m, N_GAUSS, 8))
    deps = np.empty((m, N_GAUSS, 8))
    if m:
        ws = workspaces if workspaces is not None else Workspaces()
        args = (x_el, frames_el, e_ref, to_cart, *maps.nonzeros(), eps, True, dh_el, deps)
        run_chunks(lambda e0, e1: _chunk_strains(e0, e1, *args, *ws.get(("strains",), _strain_workspaces)), m,
                   _n_chunks(m))
    return eps, deps
