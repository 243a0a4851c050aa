"""The map P that carries a kept iteration matrix from the configuration where it was factorized to the current
one (:meth:`flexbody.dynamics.DynamicModel.transfer`): S_now ~ P S_old P^T, so S_now^-1 ~ P S_old^-1 P^T.

Node by node, P is the rotation G_I of the node's patch (:func:`flexbody.frames.patch_rotations`) on the
translations in fixed directions, and the drilling drift D_I^T on the two local rotations: with the frames
R_I,ref at the factorization and R_I now, D_I = R_I,ref^T G_I^T R_I, the turn of the frame about its director
beyond the turn of its patch, projected on a plane rotation (:func:`drilling_drifts`). Under a rigid rotation Q
every G_I is Q and D_I the frames' drilling rotation: P is then exact (docs/dynamics.md, "The kept matrix
follows the surface").

Both are applied at every solve of a time step, so they are compiled (:func:`drilling_drifts`,
:func:`apply_node_rotations`), next to the numpy references they are tested against
(:func:`drilling_drifts_reference`, :func:`apply_node_rotations_reference`).
"""

from __future__ import annotations

import math

import numpy as np

from flexbody import _numba
from flexbody.kernel_arrays import kernel_input, kernel_output


#: hypot(c, s) (1 for an untilted frame) below which the in-plane block of D has no drilling angle
FLAT_BLOCK = 1e-12


def drilling_drifts_reference(frames_ref: np.ndarray, G: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """The blocks D_I^T (k, 2, 2) of the in-plane part of D_I = R_I,ref^T G_I^T R_I, each projected on a plane
    rotation (the drilling part; its O(eps^2) in-plane stretch is dropped): c = (D_11 + D_22)/2,
    s = (D_21 - D_12)/2, normalized; D^T = [[c, s], [-s, c]]. A frame turned over against its patch (a half
    turn about an in-plane axis: c = s = 0, no drilling angle) gets the identity (:data:`FLAT_BLOCK`).
    The numpy reference of :func:`drilling_drifts`."""
    D = np.swapaxes(frames_ref, 1, 2) @ np.swapaxes(G, 1, 2) @ frames
    c = 0.5 * (D[:, 0, 0] + D[:, 1, 1])
    s = 0.5 * (D[:, 1, 0] - D[:, 0, 1])
    norm = np.hypot(c, s)
    defined = norm > FLAT_BLOCK
    safe = np.where(defined, norm, 1.0)
    c, s = np.where(defined, c / safe, 1.0), np.where(defined, s / safe, 0.0)
    return np.stack([np.stack([c, s], axis=1), np.stack([-s, c], axis=1)], axis=1)


def drilling_drifts(frames_ref: np.ndarray, G: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """:func:`drilling_drifts_reference`, compiled (equal to round-off: the products are associated otherwise)."""
    frames_ref = kernel_input(frames_ref, (3, 3), "frames_ref")
    k = len(frames_ref)
    out = np.empty((k, 2, 2))
    _drilling_drifts_into(frames_ref, kernel_input(G, (3, 3), "G", rows=k),
                          kernel_input(frames, (3, 3), "frames", rows=k), kernel_output(out, (k, 2, 2), "out"))
    return out


@_numba.plain
def _in_plane_entry(frames_ref, G, frames, n, a, b):
    """D_ab = sum_ij R_ref[i, a] G[j, i] R[j, b] of node n."""
    acc = 0.0
    for i in range(3):
        gr = 0.0
        for j in range(3):
            gr += G[n, j, i] * frames[n, j, b]
        acc += frames_ref[n, i, a] * gr
    return acc


@_numba.plain
def _drilling_drifts_into(frames_ref, G, frames, out):
    for n in range(frames_ref.shape[0]):
        c = 0.5 * (_in_plane_entry(frames_ref, G, frames, n, 0, 0) + _in_plane_entry(frames_ref, G, frames, n, 1, 1))
        s = 0.5 * (_in_plane_entry(frames_ref, G, frames, n, 1, 0) - _in_plane_entry(frames_ref, G, frames, n, 0, 1))
        norm = math.hypot(c, s)
        if norm > FLAT_BLOCK:
            c, s = c / norm, s / norm
        else:
            c, s = 1.0, 0.0
        out[n, 0, 0], out[n, 0, 1], out[n, 1, 0], out[n, 1, 1] = c, s, -s, c


def apply_node_rotations_reference(vec: np.ndarray, col_index: np.ndarray, G: np.ndarray, rot_index: np.ndarray,
                                   DT: np.ndarray, transpose: bool = False) -> np.ndarray:
    """P vec (P^T vec with ``transpose``): vec[col_index[k]] turned by G[k] (k, 3, 3), vec[rot_index[k]] by DT[k]
    (k, 2, 2), every other entry kept. The numpy reference of :func:`apply_node_rotations`."""
    out = np.array(vec, dtype=float, copy=True)
    if transpose:
        G, DT = np.transpose(G, (0, 2, 1)), np.transpose(DT, (0, 2, 1))
    out[col_index] = np.einsum("nij,nj->ni", G, vec[col_index])
    out[rot_index] = np.einsum("nij,nj->ni", DT, vec[rot_index])
    return out


def apply_node_rotations(vec: np.ndarray, col_index: np.ndarray, G: np.ndarray, rot_index: np.ndarray,
                         DT: np.ndarray, transpose: bool = False) -> np.ndarray:
    """:func:`apply_node_rotations_reference`, compiled. The index arrays are checked (shape, range); that no
    entry appears twice is the caller's to keep (the DoF indices of distinct nodes)."""
    vec = np.ascontiguousarray(vec, dtype=float)
    if vec.ndim != 1:
        raise ValueError(f"vec must be a vector, got shape {vec.shape}")
    col_index = _dof_index(col_index, 3, "col_index", len(vec))
    rot_index = _dof_index(rot_index, 2, "rot_index", len(vec))
    out = vec.copy()
    _apply_node_rotations_into(vec, col_index, kernel_input(G, (3, 3), "G", rows=len(col_index)), rot_index,
                               kernel_input(DT, (2, 2), "DT", rows=len(rot_index)), bool(transpose), out)
    return out


def _dof_index(index: np.ndarray, width: int, name: str, n: int) -> np.ndarray:
    """``index`` as a contiguous int64 array (k, width) of entries in [0, n), or a ValueError naming it."""
    index = kernel_input(index, (width,), name, dtype=np.int64)
    if index.size and not (index.min() >= 0 and index.max() < n):
        raise ValueError(f"{name} must hold DoF indices in [0, {n}), got {index.min()} .. {index.max()}")
    return index


@_numba.plain
def _apply_node_rotations_into(vec, col_index, G, rot_index, DT, transpose, out):
    for blocks, index, size in ((G, col_index, 3), (DT, rot_index, 2)):
        for n in range(index.shape[0]):
            for i in range(size):
                acc = 0.0
                for j in range(size):
                    acc += (blocks[n, j, i] if transpose else blocks[n, i, j]) * vec[index[n, j]]
                out[index[n, i]] = acc
