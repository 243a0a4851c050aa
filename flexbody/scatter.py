"""Scatter of element (or nodal) tangent blocks into the data array of a precomputed sparse pattern.

Each block couples k nodes with 6 components per node, [u (3), theta (3)]. On the way into the global
matrix its translation rows are multiplied by the node's 3x3 row map S_a and its translation columns by
the node's column map C_b (the basis changes of :mod:`flexbody.assembly`):

    out[slot[e, 6a + i, 6b + j]] += (S_a K_e C_b)[i, j]      (slot < 0: a dropped DoF)

One pass per block, no temporaries: this replaces two dense einsum transforms and a masked bincount.
"""

from __future__ import annotations

import numba
import numpy as np

from flexbody.kernel_cache import CACHE


@numba.njit(cache=CACHE, nogil=True)
def scatter_blocks(K: np.ndarray, S: np.ndarray, C: np.ndarray, slots: np.ndarray, scale: float,
                   out: np.ndarray) -> None:
    """out[slots] += scale * (S K C) per block.

    K : (m, 6k, 6k) blocks, node-major; S, C : (m, k, 3, 3) row and column maps of the block's nodes;
    slots : (m, 6k, 6k) int64 indices into ``out`` (-1 where the entry is not assembled).
    """
    m, nk = K.shape[0], S.shape[1]
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
                            out[s] += scale * T[i, j]
