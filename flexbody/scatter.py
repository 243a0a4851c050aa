"""Scatter of element (or nodal) tangent blocks into the data array of a precomputed sparse pattern.

Each block couples k nodes with 6 components per node, [u (3), theta (3)]. On the way into the global
matrix its translation rows are multiplied by the node's 3x3 row map S_a and its translation columns by
the node's column map C_b (the basis changes of :mod:`flexbody.assembly`):

    out[slot[e, 6a + i, 6b + j]] += (S_a K_e C_b)[i, j]      (slot < 0: a dropped DoF)

One pass per block, no temporaries: this replaces two dense einsum transforms and a masked bincount.
"""

from __future__ import annotations

import numpy as np

from flexbody import _numba
from flexbody.kernel_arrays import kernel_input, kernel_output


def scatter_blocks(K: np.ndarray, S: np.ndarray, C: np.ndarray, slots: np.ndarray, scale: float,
                   out: np.ndarray) -> None:
    """out[slots] += scale * (S K C) per block.

    K : (m, 6k, 6k) blocks, node-major; S, C : (m, k, 3, 3) row and column maps of the block's nodes;
    slots : (m, 6k, 6k) int64 indices into ``out`` (-1 where the entry is not assembled); out : a writeable
    float64 vector. The shapes are checked before the kernel runs (:mod:`flexbody.kernel_arrays`), a slot
    beyond ``out`` stops the kernel with an IndexError.
    """
    size = np.shape(K)[1] if np.ndim(K) == 3 else 0
    if size == 0 or size % 6 or np.shape(K)[2] != size:
        raise ValueError(f"K must have shape (m, 6k, 6k), got {np.shape(K)}")
    K = kernel_input(K, (size, size), "K")
    m, k = len(K), size // 6
    S = kernel_input(S, (k, 3, 3), "S", rows=m)
    C = kernel_input(C, (k, 3, 3), "C", rows=m)
    slots = kernel_input(slots, (size, size), "slots", rows=m, dtype=np.int64)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)):
        raise ValueError(f"scale must be a number, got {scale!r}")
    _scatter_blocks(K, S, C, slots, float(scale), kernel_output(out, (None,), "out"))


@_numba.released
def _scatter_blocks(K: np.ndarray, S: np.ndarray, C: np.ndarray, slots: np.ndarray, scale: float,
                    out: np.ndarray) -> None:
    m, nk, n_out = K.shape[0], S.shape[1], out.shape[0]
    T = np.empty((6, 6))
    for e in range(m):
        for a in range(nk):
            for b in range(nk):
                for i in range(6):
                    for j in range(6):
                        T[i, j] = K[e, 6 * a + i, 6 * b + j]
                # rows: translations by S_a
                for j in range(6):
                    t0, t1, t2 = T[0, j], T[1, j], T[2, j]
                    for i in range(3):
                        T[i, j] = S[e, a, i, 0] * t0 + S[e, a, i, 1] * t1 + S[e, a, i, 2] * t2
                # columns: translations by C_b
                for i in range(6):
                    t0, t1, t2 = T[i, 0], T[i, 1], T[i, 2]
                    for j in range(3):
                        T[i, j] = t0 * C[e, b, 0, j] + t1 * C[e, b, 1, j] + t2 * C[e, b, 2, j]
                for i in range(6):
                    for j in range(6):
                        s = slots[e, 6 * a + i, 6 * b + j]
                        if s >= 0:
                            if s >= n_out:
                                raise IndexError("scatter_blocks: a slot lies beyond the output array")
                            out[s] += scale * T[i, j]
