"""Small inlined helpers of the element kernels: 3x3 products, accumulation of 3x3 blocks into the slot
matrix, and the prefetch hints of the element loop.

Inlined at numba-IR level (``flexbody._numba.inline``), so that the per-point functions contain no calls.
"""

from __future__ import annotations

from flexbody._numba import fast as jit, inline as inl, prefetch as _prefetch
from flexbody.shell.geometry import N_GAUSS
from flexbody.shell.kernels.layout import NDOF, N_EVAL


@inl
def _mm(A, B, out):
    """out = A B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@inl
def _mmT(A, B, out):
    """out = A B^T."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[j, 0] + A[i, 1] * B[j, 1] + A[i, 2] * B[j, 2]


@inl
def _mTm(A, B, out):
    """out = A^T B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[0, i] * B[0, j] + A[1, i] * B[1, j] + A[2, i] * B[2, j]


@inl
def _Rhat(R, v0, v1, v2, out):
    """out = R hat(v)."""
    for i in range(3):
        r0 = R[i, 0]
        r1 = R[i, 1]
        r2 = R[i, 2]
        out[i, 0] = r1 * v2 - r2 * v1
        out[i, 1] = r2 * v0 - r0 * v2
        out[i, 2] = r0 * v1 - r1 * v0


@inl
def _add_blk(core, s, t, M, alpha):
    """core[block s, block t] += alpha M."""
    for i in range(3):
        for j in range(3):
            core[3 * s + i, 3 * t + j] += alpha * M[i, j]


@inl
def _add_blk_both(core, s, t, M, alpha):
    """core[block s, block t] += alpha M and core[block t, block s] += alpha M^T."""
    for i in range(3):
        for j in range(3):
            v = alpha * M[i, j]
            core[3 * s + i, 3 * t + j] += v
            core[3 * t + j, 3 * s + i] += v


@inl
def _prefetch_block(a, start, n, write):
    """Prefetch the elements start .. start + n - 1 of a (flat): one hint per cache line, and the last one."""
    for q in range(start, start + n, 8):
        _prefetch(a, q, write)
    _prefetch(a, start + n - 1, write)


@jit
def _prefetch_element(e, x_el, fr_el, e_ref, to_cart, weights, want_tangent, K):
    """Prefetch the inputs (and the tangent, to be written) of element e, ahead of its evaluation.

    The element data are read (written) once, in bursts of a few kB per element that the hardware prefetchers
    miss: without the hints the reads of to_cart alone stall for about 1 us per element.
    """
    _prefetch_block(x_el, 18 * e, 18, False)
    _prefetch_block(fr_el, 54 * e, 54, False)
    _prefetch_block(e_ref, 8 * N_EVAL * e, 8 * N_EVAL, False)
    _prefetch_block(to_cart, 64 * N_GAUSS * e, 64 * N_GAUSS, False)
    _prefetch_block(weights, N_GAUSS * e, N_GAUSS, False)
    if want_tangent:
        _prefetch_block(K, NDOF * NDOF * e, NDOF * NDOF, True)
